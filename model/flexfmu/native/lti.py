"""A clamped flexible body on a moving base as the parameter-dependent linear system of csrc/lti_kernels.h, with its
coefficients taken from the library's own maps (the probes: one beside each simulator, flexfmu.ffr.lti_probe and
flexfmu.body.lti_probe), and the C kernel through ctypes (flexfmu.native.lti_kernel; the monomials and the exact fit of
a quadratic: flexfmu.native.lti_quadratic; their public names are re-exported here).

    x' = A(p) x + B(p) u + b(p),     y = Cx(p) x + Cu(p) u + y0(p) + sum_k v_k z[i_k] z[j_k] e_{r_k},
    z = [x; u; mono(p)],  mono(p) = [1, p_1 .. p_np, p_i p_j (i <= j)]

Every matrix is a polynomial of degree <= 2 in the held parameters p (the damping ratio, the base's angular velocity
and acceleration, and with geometric stiffening its acceleration too): A(p) = sum_k mono_k(p) A[k].  The
coefficients are not written down a second time here: :meth:`LtiModel.from_ffrbeam` and
:meth:`LtiModel.from_clamped_body` evaluate the library's maps (FFRBeamSimulator's step and output maps,
FFRBeamDynamics.system_matrix and modal_force; ClampedDynamics.system_matrix and modal_force and the clamped
simulator's outputs) at p = 0, p = a_i e_i, b_i e_i and a_i e_i + a_j e_j (a_i = -b_i = BASE_OFFSET for the base
motion; for the damping ratio a = 1/4, b = 1/2, inside its range), which determines a quadratic exactly up to
rounding; the output terms quadratic in (x, u) (the strain energy, the load's moment arm, ...) come from second
differences of the simulator's outputs at unit x and u, differences below their rounding (64 eps of the values
differenced) taken as zero.  Each constructor then checks the result against the library at random (x, u, p) and
refuses a model whose maps are not of this form (ContractError; ``fit_error`` holds the largest relative differences
it measured, ~1e-15 for FFRBeam and the clamped bodies of tests/test_native_lti.py).

The strain energy of FFRBeam's static correction, 1/2 X_ab^T R X_ab with X = [alpha]x + [omega]x^2, is of degree 4
in p: it is carried as terms mono_a mono_b of the quadratic output part (z holds mono(p) for that).

The step is the exact zero-order hold (expm of the augmented matrix, csrc/lti_kernels.c), or for base motion that
moves by little at every step the same exponential's Taylor series on the step's vector (ffx_lti_steps_held; the rule
and its bound: flexfmu.native.lti_taylor); FFRBeam's integrator "rk4" has no native form (ParameterError naming
``integrator``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flexfmu.core.stress import evaluate_derived
from flexfmu.errors import FlexfmuError, ParameterError
# the kernel (status codes, bindings) and the quadratics, re-exported: callers import them from flexfmu.native.lti
from flexfmu.native.lti_kernel import (BAD_ARGUMENT, NONFINITE, OK, SINGULAR, SOURCES,  # noqa: F401
                                       LtiKernel, LtiSimulator, expm, library)
from flexfmu.native.lti_derived import check_derived, derived_arrays, derived_of_arrays
from flexfmu.native.lti_quadratic import (fit_quadratic, monomial_names, monomial_pairs, monomials,  # noqa: F401
                                          n_monomials, sample_points)

AXES = ("x", "y", "z")
BASE_W = tuple(f"base_w_{a}" for a in AXES)
BASE_DW = tuple(f"base_dw_{a}" for a in AXES)
BASE_A = tuple(f"base_a_{a}" for a in AXES)
#: a constructor refuses a model whose coefficients reproduce the library's maps worse than this (relative)
FIT_TOLERANCE = 1e-9
#: sample offsets of the base motion (rad/s, rad/s^2, m/s^2): large enough that the p-dependent part is not lost to
#: the rounding of the modal stiffness (the coefficients err by ~eps |Lambda| / offset^2), a power of 2
BASE_OFFSET = 16.0
_EPS = np.finfo(float).eps


class ContractError(FlexfmuError):
    """The library's maps are not polynomials of degree <= 2 in the held parameters (lti_kernels.h's contract)."""


# ---------------------------------------------------------------------------------------------- the model
@dataclass
class LtiModel:
    """The arrays of ffx_lti_model (shapes there) and what the FMU needs around them: the names of the FMU's
    inputs, of the held parameters p and of the outputs; ``u_from_input`` (nu) the FMU input behind each u_k;
    ``p_from_input`` (np) the FMU input behind each p_k, or -1 for a parameter (named in ``param_names``, value
    ``p_start``).  ``derived``: the outputs computed after the others from them, not linearly (DerivedStress of
    flexfmu.core.stress: von Mises stresses, a section's largest stresses; their rows of the maps are zero, the C
    evaluates them by csrc/derived_stress.c).  ``fit_error``: the largest relative differences from the library
    measured at construction."""

    A: np.ndarray
    B: np.ndarray
    b: np.ndarray
    Cx: np.ndarray
    Cu: np.ndarray
    y0: np.ndarray
    quad_row: np.ndarray
    quad_i: np.ndarray
    quad_j: np.ndarray
    quad_value: np.ndarray
    input_names: tuple
    param_names: tuple
    output_names: tuple
    u_from_input: np.ndarray
    p_from_input: np.ndarray
    p_start: np.ndarray
    kind: str = ""
    derived: tuple = ()
    fit_error: dict = field(default_factory=dict)

    def __post_init__(self):
        f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)        # noqa: E731
        i32 = lambda a: np.ascontiguousarray(a, dtype=np.int32)          # noqa: E731
        for name in ("A", "B", "b", "Cx", "Cu", "y0", "quad_value", "p_start"):
            setattr(self, name, f64(getattr(self, name)))
        for name in ("quad_row", "quad_i", "quad_j", "u_from_input", "p_from_input"):
            setattr(self, name, i32(getattr(self, name)))
        self.input_names, self.param_names = tuple(self.input_names), tuple(self.param_names)
        self.output_names = tuple(self.output_names)
        nm, nx, nu, ny, n_p = self.nmono, self.nx, self.nu, self.ny, self.np
        shapes = {"A": (nm, nx, nx), "B": (nm, nx, nu), "b": (nm, nx), "Cx": (nm, ny, nx), "Cu": (nm, ny, nu),
                  "y0": (nm, ny), "p_start": (n_p,), "u_from_input": (nu,), "p_from_input": (n_p,)}
        for name, shape in shapes.items():
            if getattr(self, name).shape != shape:
                raise ParameterError(name, f"shape {getattr(self, name).shape}", f"{shape}")
        nq = self.quad_value.size
        if any(getattr(self, n).shape != (nq,) for n in ("quad_row", "quad_i", "quad_j")):
            raise ParameterError("quad_row", "quadratic-term arrays of different lengths", f"{nq} each")
        nz = nx + nu + nm
        if nq and (self.quad_row.min() < 0 or self.quad_row.max() >= ny or min(self.quad_i.min(), self.quad_j.min()) < 0
                   or max(self.quad_i.max(), self.quad_j.max()) >= nz):
            raise ParameterError("quad_i", "an index out of range", f"rows < {ny}, z indices < {nz}")
        if len(self.output_names) != ny:
            raise ParameterError("output_names", f"{len(self.output_names)} names", f"{ny}")
        self.derived = check_derived(self.derived, self.output_names)

    # ---- sizes
    @property
    def nx(self) -> int:
        return int(self.A.shape[1])

    @property
    def nu(self) -> int:
        return int(self.B.shape[2])

    @property
    def ny(self) -> int:
        return int(self.y0.shape[1])

    @property
    def np(self) -> int:
        return int(self.p_start.size)

    @property
    def nmono(self) -> int:
        return int(self.A.shape[0])

    @property
    def nquad(self) -> int:
        return int(self.quad_value.size)

    @property
    def u_names(self) -> tuple:
        return tuple(self.input_names[k] for k in self.u_from_input)

    # ---- the arrays of the model file (flexfmu.native's model file is written elsewhere)
    def arrays(self) -> dict:
        """name -> numpy array: the float64 / int32 arrays of ffx_lti_model and of the input map, the sizes
        (nx, nu, ny, np, nmono, nquad) as 0-d int32 arrays, and the derived outputs' arrays (derived_*: flexfmu.native.
        lti_derived; absent when there are none)."""
        out = {name: getattr(self, name) for name in ("A", "B", "b", "Cx", "Cu", "y0", "quad_row", "quad_i", "quad_j",
                                                      "quad_value", "u_from_input", "p_from_input", "p_start")}
        if self.derived:
            out.update({f"derived_{k}": v for k, v in derived_arrays(self.derived, self.output_names).items()})
        out.update({name: np.array(getattr(self, name), dtype=np.int32)
                    for name in ("nx", "nu", "ny", "np", "nmono", "nquad")})
        return out

    def names(self) -> dict:
        return {"input_names": self.input_names, "param_names": self.param_names, "output_names": self.output_names}

    @classmethod
    def from_arrays(cls, arrays: dict, names: dict, kind: str = "") -> "LtiModel":
        """The inverse of :meth:`arrays` and :meth:`names`."""
        keys = ("A", "B", "b", "Cx", "Cu", "y0", "quad_row", "quad_i", "quad_j", "quad_value", "u_from_input",
                "p_from_input", "p_start")
        derived = ()
        if "derived_kind" in arrays:
            derived = derived_of_arrays({k[8:]: v for k, v in arrays.items() if k.startswith("derived_")},
                                        tuple(names["output_names"]))
        model = cls(**{k: np.asarray(arrays[k]) for k in keys}, **{k: tuple(names[k]) for k in
                                                                    ("input_names", "param_names", "output_names")},
                    kind=kind, derived=derived)
        for k in ("nx", "nu", "ny", "np", "nmono", "nquad"):
            if k in arrays and int(arrays[k]) != getattr(model, k):
                raise ParameterError(k, f"{int(arrays[k])}", f"{getattr(model, k)} (the arrays' size)")
        return model

    # ---- numpy evaluation (the reference the C kernel is tested against, and the extraction's check)
    def split_inputs(self, values, params=None) -> tuple[np.ndarray, np.ndarray]:
        """(u, p) of the FMU input vector ``values``; the parameter-fed p from ``params`` {name: value} (default
        p_start)."""
        v = np.asarray(values, dtype=float)
        u = v[self.u_from_input]
        p = self.p_start.copy()
        fed = self.p_from_input >= 0
        p[fed] = v[self.p_from_input[fed]]
        for k, name in enumerate(self.param_names):
            if not fed[k] and params and name in params:
                p[k] = float(params[name])
        return u, p

    def dynamics(self, p):
        """A (nx, nx), B (nx, nu), b (nx) for p."""
        m = monomials(p)
        return (np.tensordot(m, self.A, axes=1), np.tensordot(m, self.B, axes=1), np.tensordot(m, self.b, axes=1))

    def output_maps(self, p):
        """Cx, Cu, y0 for p (the quadratic terms not included)."""
        m = monomials(p)
        return (np.tensordot(m, self.Cx, axes=1), np.tensordot(m, self.Cu, axes=1), np.tensordot(m, self.y0, axes=1))

    def quadratic(self, x, u, p) -> np.ndarray:
        z = np.concatenate([np.asarray(x, float), np.asarray(u, float), monomials(p)])
        y = np.zeros(self.ny)
        np.add.at(y, self.quad_row, self.quad_value * z[self.quad_i] * z[self.quad_j])
        return y

    def outputs(self, x, u, p) -> np.ndarray:
        """y of (x, u, p): the linear and quadratic part, then the derived outputs from it."""
        Cx, Cu, y0 = self.output_maps(p)
        y = Cx @ x + Cu @ u + y0 + self.quadratic(x, u, p)
        evaluate_derived(self.derived, self.output_names, y)
        return y

    def kernel(self) -> "LtiKernel":
        return LtiKernel(self)

    # ---- constructors from the library's simulators
    @classmethod
    def from_simulator(cls, simulator, kind: str | None = None) -> "LtiModel":
        """The model of a simulator that describes its maps: ``simulator.lti_probe()`` returns the :class:`Probe`
        (FFRBeamSimulator: flexfmu.ffr.lti_probe; FlexBodySimulator: flexfmu.body.lti_probe).  This module imports
        no simulator: each probe lives beside its simulator (native sits below ffr and body, docs/architecture.md,
        "Layers").  ``kind``: the probe's model_kind asked for (ParameterError naming ``simulator`` otherwise)."""
        lti_probe = getattr(simulator, "lti_probe", None)
        if lti_probe is None:
            raise ParameterError("simulator", f"a {type(simulator).__name__} has no linear form here",
                                 "an FFRBeamSimulator or a clamped body's FlexBodySimulator")
        probe = lti_probe()
        if kind is not None and probe.model_kind != kind:
            raise ParameterError("simulator", f"a {probe.model_kind} simulator", f"a {kind} simulator")
        if not probe.derived:                 # the simulator's nonlinear outputs (flexfmu.core.stress.DerivedStress)
            probe.derived = tuple(getattr(simulator, "derived_outputs", ()))
        return extract(probe)

    @classmethod
    def from_ffrbeam(cls, simulator) -> "LtiModel":
        """The model of an FFRBeamSimulator (flexfmu.ffr.simulator): x = [eta; eta_dot], u = [F, M, base_a] (body
        frame, at load_s), p = (damping_ratio, base_w, base_dw) and with geometric stiffening also base_a; outputs
        OUTPUT_NAMES (all 25, with the static correction when the simulator has one).  Integrator "exact" only."""
        return cls.from_simulator(simulator, "FFRBeam")

    @classmethod
    def from_clamped_body(cls, simulator) -> "LtiModel":
        """The model of a clamped body's FlexBodySimulator (flexfmu.body.simulator): x = [eta; eta_d], u = the
        interface loads and base_a, p = (damping_ratio, base_w, base_dw); outputs the simulator's output_names."""
        return cls.from_simulator(simulator, "clamped body")


# ---------------------------------------------------------------------------------------------- extraction
@dataclass
class Probe:
    """What the extraction evaluates: the library's maps at p and its outputs at (x, FMU inputs, p).  A simulator
    with a native linear form returns its own from ``lti_probe()`` (flexfmu.ffr.lti_probe, flexfmu.body.lti_probe)."""

    model_kind: str
    input_names: tuple
    param_names: tuple
    output_names: tuple
    u_from_input: np.ndarray
    p_from_input: np.ndarray
    p_start: np.ndarray
    #: p -> (A, B, b) of the library
    dynamics: object
    #: p -> (Cx, Cu, y0) of the library, without the mono-mono terms
    output_maps: object
    #: (x, FMU input vector, p) -> y of the library (p's inputs taken from the vector, the parameters from p)
    outputs: object
    #: sample offsets (a_i, b_i) along each p axis
    offsets: list
    #: per output row None or V (nmono, nmono): a known term mono(p)^T V mono(p) of degree 4 in p, not in y0(p)
    mono_quadratic: object = None
    #: the outputs computed from others, not linearly (flexfmu.core.stress.DerivedStress): left out of the fit,
    #: checked through evaluate_derived (default: the simulator's ``derived_outputs``, LtiModel.from_simulator)
    derived: tuple = ()


def inputs_of(probe: Probe, u, p) -> np.ndarray:
    """The FMU input vector with u and the input-fed p; where both feed one input (base_a with geometric
    stiffening) u's value wins (the callers keep them equal)."""
    v = np.zeros(len(probe.input_names))
    fed = probe.p_from_input >= 0
    v[probe.p_from_input[fed]] = np.asarray(p, float)[fed]
    v[probe.u_from_input] = u
    return v


def p_of(probe: Probe, v, p_params) -> np.ndarray:
    p = np.array(p_params, dtype=float)
    fed = probe.p_from_input >= 0
    p[fed] = v[probe.p_from_input[fed]]
    return p


def extract(probe: Probe, rng_seed: int = 20261121) -> LtiModel:
    n_p = len(probe.param_names)
    nmono = n_monomials(n_p)
    pts = sample_points(probe.offsets)
    dyn = [probe.dynamics(p) for p in pts]
    outs = [probe.output_maps(p) for p in pts]
    A, B, b = (_fit(np.array([d[k] for d in dyn]), probe.offsets) for k in range(3))
    Cx, Cu, y0 = (_fit(np.array([o[k] for o in outs]), probe.offsets) for k in range(3))
    nx, nu, ny = A.shape[1], B.shape[2], y0.shape[1]
    derived = check_derived(probe.derived, probe.output_names)
    linear = np.ones(ny, bool)                        # the rows of the linear part (the derived ones: zero rows)
    linear[[probe.output_names.index(d.output) for d in derived]] = False
    Cx[:, ~linear], Cu[:, ~linear], y0[:, ~linear] = 0.0, 0.0, 0.0

    mono_terms = []                                   # (row, a, b, v) over mono indices
    if probe.mono_quadratic is not None:
        V = probe.mono_quadratic
        for r in range(ny):
            if V[r] is None or not linear[r]:
                continue
            for a in range(nmono):
                for c in range(a, nmono):
                    v = V[r][a, a] if a == c else V[r][a, c] + V[r][c, a]
                    if v != 0.0:
                        mono_terms.append((r, nx + nu + a, nx + nu + c, v))

    def linear_part(x, u, p):
        m = monomials(p)
        y = (np.tensordot(m, Cx, axes=1) @ x + np.tensordot(m, Cu, axes=1) @ u + np.tensordot(m, y0, axes=1))
        if mono_terms:
            z = np.concatenate([x, u, m])
            for r, i, j, v in mono_terms:
                y[r] += v * z[i] * z[j]
        return y

    # terms quadratic in (x, u): second differences of what the library's outputs add to the maps, at the
    # parameters' start values (p's inputs at 0 unless u moves them)
    n = nx + nu
    p_par = probe.p_start

    def residual(w):
        x, u = w[:nx], w[nx:]
        v = inputs_of(probe, u, np.where(probe.p_from_input >= 0, 0.0, p_par))
        p = p_of(probe, v, p_par)
        y = np.where(linear, probe.outputs(x, v, p), 0.0)
        lin = linear_part(x, u, p)
        return y - lin, np.abs(y) + np.abs(lin)

    zero = np.zeros(n)
    r0, s0 = residual(zero)
    plus, minus = {}, {}
    for a in range(n):
        e = np.zeros(n)
        e[a] = 1.0
        plus[a] = residual(e)
        minus[a] = residual(-e)
    quads = []
    for a in range(n):
        for c in range(a, n):
            if a == c:
                d = 0.5 * (plus[a][0] + minus[a][0] - 2.0 * r0)
                scale = plus[a][1] + minus[a][1] + 2.0 * s0
            else:
                e = np.zeros(n)
                e[a] = e[c] = 1.0
                rac, sac = residual(e)
                d = rac - plus[a][0] - plus[c][0] + r0
                scale = sac + plus[a][1] + plus[c][1] + s0
            keep = np.abs(d) > 64.0 * _EPS * scale          # above the rounding of the differences
            for r in np.flatnonzero(keep):
                quads.append((int(r), a, c, float(d[r])))
    quads += mono_terms
    quads.sort(key=lambda q: (q[0], q[1], q[2]))
    q = np.array(quads, dtype=float).reshape(-1, 4)
    model = LtiModel(A=A, B=B, b=b, Cx=Cx, Cu=Cu, y0=y0, quad_row=q[:, 0], quad_i=q[:, 1], quad_j=q[:, 2],
                     quad_value=q[:, 3], input_names=probe.input_names, param_names=probe.param_names,
                     output_names=probe.output_names, u_from_input=probe.u_from_input,
                     p_from_input=probe.p_from_input, p_start=probe.p_start, kind=probe.model_kind,
                     derived=derived)
    model.fit_error = _check(model, probe, np.random.default_rng(rng_seed))
    worst = max(model.fit_error.values())
    if not worst <= FIT_TOLERANCE:
        raise ContractError(f"the {probe.model_kind} maps are not reproduced by polynomials of degree 2 in "
                            f"{', '.join(probe.param_names)} (relative differences {model.fit_error}): "
                            "flexfmu.native.lti's contract does not hold for this model")
    return model


def _fit(values: np.ndarray, offsets) -> np.ndarray:
    """fit_quadratic of ``values`` with the coefficients that are rounding set to zero: a coefficient is a fixed
    combination sum_j w_kj values_j of the samples, so one within 64 eps of sum_j |w_kj| |values_j| (what the rounding
    of the samples and of the combination can make of a zero) is taken as zero, as the quadratic output terms are.
    A monomial the maps do not depend on (base_w * base_dw, ...) then has an all-zero block, which the kernel skips
    (csrc/lti_kernels.c: the 'used' flags): about half of FFRBeam's."""
    coefficients = fit_quadratic(values, offsets)
    n_points = values.shape[0]
    weights = fit_quadratic(np.eye(n_points), offsets)              # (nmono, n_points): the combinations
    scale = np.tensordot(np.abs(weights), np.abs(values), axes=1)
    coefficients[np.abs(coefficients) <= 64.0 * _EPS * scale] = 0.0
    return coefficients


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(float(np.max(np.abs(b), initial=0.0)), 1e-300)
    return float(np.max(np.abs(a - b), initial=0.0)) / scale


def _check(model: LtiModel, probe: Probe, rng) -> dict:
    """Largest relative differences (per matrix, relative to its largest entry; outputs per row) between the model
    and the library at random p (base rotation up to ~ 3 rad/s, 10 rad/s^2, damping in [0, 0.5)) and (x, u).  The
    derived outputs apart ("derived"): each against the library's relative to the larger of it and the derived
    value of its sources' sizes (the formulas are norms of the sources, so that is its size)."""
    err = {"A": 0.0, "B": 0.0, "b": 0.0, "outputs": 0.0}
    derived_rows = [model.output_names.index(d.output) for d in model.derived]
    if derived_rows:
        err["derived"] = 0.0
    for _ in range(3):
        p = np.array([rng.uniform(0.0, 0.5) if name == "damping_ratio" else
                      rng.uniform(-3.0, 3.0) if name.startswith("base_w") else rng.uniform(-10.0, 10.0)
                      for name in probe.param_names])
        for name, mine, lib in zip(("A", "B", "b"), model.dynamics(p), probe.dynamics(p)):
            err[name] = max(err[name], _rel(mine, lib))
        x = rng.standard_normal(model.nx) * 1e-3
        u = rng.standard_normal(model.nu)
        v = inputs_of(probe, u, p)
        p = p_of(probe, v, p)                          # base_a: u's (as the FMU feeds both)
        y_lib = probe.outputs(x, v, p)
        y = model.outputs(x, u, p)
        # per output, relative to that output's size over the parts that make it up
        Cx, Cu, y0 = model.output_maps(p)
        scale = np.abs(Cx) @ np.abs(x) + np.abs(Cu) @ np.abs(u) + np.abs(y0) + np.abs(model.quadratic(x, u, p))
        scale = np.maximum(scale, np.abs(y_lib))
        if derived_rows:
            size = scale.copy()
            evaluate_derived(model.derived, model.output_names, size)
            d = np.abs(y - y_lib)[derived_rows] / np.maximum(np.maximum(size, np.abs(y_lib))[derived_rows], 1e-300)
            err["derived"] = max(err["derived"], float(np.max(d)))
            scale[derived_rows] = 0.0
        ok = scale > 0
        if np.any(ok):
            err["outputs"] = max(err["outputs"], float(np.max(np.abs(y - y_lib)[ok] / scale[ok])))
    return err
