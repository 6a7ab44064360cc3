"""FFRBeam: a scene's clamped structure in time, with named inputs and outputs.

The FMU (flexfmu.fmi.registry, flexfmu.fmi.plumbing) is a thin shell over this class: the variable names here are the
FMU's.  Inputs are held over each step (zero-order hold) and the step is exact for such input
(flexfmu.ffr.dynamics), so one internal step per communication step of any length.  With
integrator = "rk4" the step is classical RK4 instead, sub-stepped automatically below its stability
limit (n_sub = ceil(h / (0.9 h_limit)) equal sub-steps, composed into one map per communication step); more
than ``max_internal_steps`` sub-steps are refused before stepping (flexfmu.native.step_policy: StepRejected when a
smaller communication step would do).  A state or output that overflows is a NonFiniteError naming the input behind it;
a failed step keeps the state of its start.

Model size (flexfmu.sizing.model_size, docs/model_size.md): elements_per_segment = 0 chooses the mesh from
the convergence of the frequencies below f_max (with n_modes = -1: of every retained mode) to within
tolerance; n_modes = -1 keeps every mode below f_max and more above it until the estimated dynamic
truncation error of the displacement outputs is within tolerance (mode-acceleration estimate, Eq. (E)
of flexfmu.sizing.model_size); static_correction adds the residual flexibility of the omitted modes to the displacement outputs
(and the strain energy), so the quasi-static deflection equals the full model's.  What was chosen and
why, and the RK4 sub-stepping, go to ``messages`` (logged by the FMU).

The parts beside this module: flexfmu.ffr.ffrbeam_config (the variable names, FFRBeamConfig and its checks, the
variable table), flexfmu.ffr.ffrbeam_build (the model a configuration builds, cached) and
flexfmu.ffr.ffrbeam_diagnostics (the input or parameter a failure names).
"""
from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass

import numpy as np

from flexfmu.core.checks import finite_input, shown
from flexfmu.core.stress import evaluate_derived
from flexfmu.errors import FlexfmuError, ParameterError, require
from flexfmu.core.cache import BoundedCache
from flexfmu.core.step_size import StepSizes
from flexfmu.ffr.dynamics import MAP_MEMO_SIZE, RK4_STABILITY_LIMIT, BaseMotion, ModalState
from flexfmu.ffr.gauges import DerivedFill
# The FMU's variables and parameters, the model a configuration builds and the failure diagnostics live in their own
# modules; their public names are re-exported here, where the FMU registry and the rest of flexfmu import them from.
from flexfmu.ffr.ffrbeam_build import TAIL_FRACTION, _build  # noqa: F401
from flexfmu.ffr.ffrbeam_config import (AXES, BASE_INPUTS, ENERGY_OUTPUT, FORCE_INPUTS, GAUGE_ROWS,  # noqa: F401
                                        INPUT_NAMES, INTEGRATORS, N_REPORTED_FREQUENCIES, OUTPUT_NAMES,
                                        RK4_STEP_FRACTION, VARIABLE_INFO, FFRBeamConfig, _check_config)
from flexfmu.ffr.ffrbeam_diagnostics import _DIVERGENCE_LIMIT, FFRBeamDiagnostics
from flexfmu.native import lti_taylor, step_policy
from flexfmu.core.vec3 import cross as _cross
from flexfmu.core.vec3 import skew as _skew

_INF = math.inf             # a module constant: cheaper than math.inf on the per-step path
#: the outputs of fast_maps' rows (18 point and reaction outputs, then six section forces per gauge), OUTPUT_NAMES order
_MAP_ROWS = np.r_[0:18, np.concatenate([np.arange(r, r + 6) for r in GAUGE_ROWS])]
_GAUGE_FORCE_ROWS = _MAP_ROWS[18:]


@dataclass(frozen=True, slots=True)
class _StepMaps:
    """The affine maps of one step size and held base motion (FFRBeamSimulator._maps):

        x+ = Ad x + Bu u[:9] (+ b0),     y = Cx x + Cu u[:9] + y0 (+ the load-dependent cross terms, energy)

    Ad, Bu, b0: None for the output maps only (h = None); b0 also None when zero.  energy: the static
    correction's strain energy as (Q, linear, constant) in u[:9], or None.  substeps: RK4's (n_sub, limit,
    omega_max, h), or None.  wide: the output maps may overflow for a state within the divergence limit
    (outputs then checked on every read)."""

    Ad: np.ndarray | None
    Bu: np.ndarray | None
    b0: np.ndarray | None
    Cx: np.ndarray
    Cu: np.ndarray
    y0: np.ndarray
    energy: tuple | None
    substeps: tuple | None
    wide: bool


class FFRBeamSimulator(FFRBeamDiagnostics):
    """State (modal coordinates, time) and the step of one FFRBeam instance."""

    def __init__(self, config: FFRBeamConfig = FFRBeamConfig()):
        self.config = config
        _check_config(config)                 # before _build's cache: it hashes the config
        built = _build(config)
        self.dynamics, self.frequencies_hz = built.dynamics, built.frequencies_hz
        self.model_choice, self.static_correction = built.choice, built.correction
        #: What the model chose and why (model size, RK4 sub-steps); the FMU logs and clears it.
        self.messages: list[str] = []
        self.messages.extend(built.choice.messages)
        #: the gauges' stresses, computed from their section forces after the linear outputs (flexfmu.ffr.gauges)
        self.derived_outputs = built.derived_outputs
        self._fill_derived = DerivedFill(self.derived_outputs, OUTPUT_NAMES) if self.derived_outputs else None
        gauges = self.dynamics.gauges
        self._gauge_correction = (gauges.correction_rows(self.static_correction.residual)
                                  if gauges.present and self.static_correction is not None else None)
        self.state = self.dynamics.initial_state()
        self.inputs = dict.fromkeys(INPUT_NAMES, 0.0)
        self._u = np.zeros(len(INPUT_NAMES))          # the inputs as a vector, INPUT_NAMES order
        self._k = self.dynamics.stiffness
        self._map_cache = BoundedCache(MAP_MEMO_SIZE)
        self._steps = StepSizes()                      # the step sizes of the map cache's keys
        self._x, self._x_state = None, None
        self._n_sub = None                             # RK4 sub-steps of the last step (logged when it changes)
        # With geometric stiffening K_eff depends on the base acceleration too: the maps are per a0 as well.
        self._held = slice(6, 15) if self.dynamics.geometric_stiffening else slice(9, 15)
        self._held_input_cache = None   # (map key, loads non-zero, u[:9]): derived once per input change
        #: base motion that moves at every step (flexfmu.native.lti_taylor): a step whose held base motion differs
        #: from the step's before it goes by the series of its exponential on the state, not by new maps; False:
        #: always by the maps (one exponential per new base motion: the comparisons of tests and benchmarks)
        self.moving_base_series = True
        self._held_before = None        # map key of the base motion the last step held (None: no step yet)
        self._series_last = False       # the last step went by the series (its outputs then by the polynomials)
        self._moving_base = None        # flexfmu.ffr.moving_base.FFRBeamMovingBase, built when first needed
        self._moving_outputs = None     # (map key, _StepMaps) of the output maps from the polynomials

    @property
    def time(self) -> float:
        return self.state.t

    @staticmethod
    def check_inputs(inputs: dict) -> None:
        for name, value in inputs.items():
            require(name in INPUT_NAMES, name, "unknown input", ", ".join(INPUT_NAMES))
            if not finite_input(value):
                raise ParameterError(name, f"input is {shown(value)}", "a finite number")

    def _vectors(self):
        v = self.inputs
        force = np.array([v["F_x"], v["F_y"], v["F_z"]])
        moment = np.array([v["M_x"], v["M_y"], v["M_z"]])
        base = BaseMotion(a0=np.array([v[f"base_a_{a}"] for a in AXES]),
                          omega=np.array([v[f"base_w_{a}"] for a in AXES]),
                          alpha=np.array([v[f"base_dw_{a}"] for a in AXES]))
        return force, moment, base

    def set_inputs(self, **inputs: float) -> None:
        self.check_inputs(inputs)
        self.inputs.update({k: float(v) for k, v in inputs.items()})
        self._u = np.array([self.inputs[name] for name in INPUT_NAMES])
        self._held_input_cache = None

    def set_input_vector(self, values) -> None:
        """All inputs at once, in INPUT_NAMES order (the FMU's per-step path)."""
        try:
            u = np.array(values, dtype=float)
        except (TypeError, ValueError, OverflowError):      # a string, an int too large for a float: named
            self.check_inputs(dict(zip(INPUT_NAMES, list(values))))
            raise ParameterError("inputs", "not all numbers", f"{len(INPUT_NAMES)} finite numbers") from None
        if u.shape != (len(INPUT_NAMES),) or not np.isfinite(u).all():
            self.check_inputs(dict(zip(INPUT_NAMES, np.resize(u, len(INPUT_NAMES)).tolist())))
            require(u.shape == (len(INPUT_NAMES),), "inputs", f"{u.shape[0] if u.ndim else 0} values",
                    f"{len(INPUT_NAMES)} values")
        self._u = u
        self.inputs = dict(zip(INPUT_NAMES, u.tolist()))
        self._held_input_cache = None

    def _held_input(self):
        """(map key of the held base motion, whether F, M, a0 are non-zero, u[:9]) of the current inputs,
        derived once per input change instead of twice per step."""
        if self._held_input_cache is None:
            u = self._u
            self._held_input_cache = (tuple(u[self._held].tolist()), bool(u[:9].any()), u[:9].copy())
        return self._held_input_cache

    def _maps(self, h):
        """The _StepMaps of step h (None: outputs only) and the held base motion, cached: the step and the
        outputs are then a few matrix-vector products.  A host's last-bit variants of one step size share its
        maps (flexfmu.core.step_size: the error bound)."""
        if h is not None:
            h = self._steps.canonical(h)
        held = self._held_input()[0]
        if h is None and self._series_last and held == self._held_before:
            return self._series_output_maps(held)       # moving base: the polynomials, not a new fast_maps
        key = (h, held)
        hit = self._map_cache.get(key)
        if hit is None:
            hit = self._new_maps(h, key)
        return hit

    def _new_maps(self, h, key):
        u = self._u
        dyn = self.dynamics
        base = BaseMotion(a0=u[6:9].copy() if dyn.geometric_stiffening else np.zeros(3),
                          omega=u[9:12].copy(), alpha=u[12:15].copy())
        sub = None
        try:
            # overflow (a huge base rotation or step) is detected below, by value, whatever numpy's error mode
            with np.errstate(all="ignore"):
                if h is not None and dyn.integrator == "rk4":
                    Ad, Bu, b0, C, y0, sub = self._rk4_maps(h, base)
                else:
                    Ad, Bu, b0, C, y0 = dyn.fast_maps(h, base)
                hit = self._assemble_maps(Ad, Bu, b0, C, y0, base, sub)
        except FlexfmuError:
            raise
        except (np.linalg.LinAlgError, ArithmeticError, ValueError):
            hit = None
        if hit is None:
            raise self._map_failure(h, base)
        self._map_cache[key] = hit
        return hit

    def _assemble_maps(self, Ad, Bu, b0, C, y0, base, sub):
        """The _StepMaps of FFRBeamDynamics.fast_maps' (Ad, Bu, b0, C, y0) with the frequencies and the static
        correction for ``base``; None when they are not finite.  Called under np.errstate(all="ignore")."""
        n = C.shape[1] - 9
        Cx = np.zeros((len(OUTPUT_NAMES), n))
        Cu = np.zeros((len(OUTPUT_NAMES), 9))
        Cx[_MAP_ROWS], Cu[_MAP_ROWS] = C[:, :n], C[:, n:]
        y = np.zeros(len(OUTPUT_NAMES))
        y[_MAP_ROWS] = y0
        y[18:18 + N_REPORTED_FREQUENCIES] = self.frequencies_hz
        energy = None
        if self.static_correction is not None:
            energy = self._add_static_correction(Cu, y, base)
        ok = all(np.all(np.isfinite(a)) for a in (Ad, Bu, b0, Cx, Cu, y) if a is not None) and (
            energy is None or all(np.all(np.isfinite(a)) for a in energy))
        if not ok:
            return None
        # the outputs Cx x + y0 are then finite for any state within the divergence limit: else checked per read
        wide = not (float(np.max(np.abs(Cx), initial=0.0)) * Cx.shape[1] * _DIVERGENCE_LIMIT
                    + float(np.max(np.abs(y)))) < 1e300
        return _StepMaps(Ad, Bu, b0 if (b0 is not None and b0.any()) else None, np.ascontiguousarray(Cx),
                         np.ascontiguousarray(Cu), y, energy, sub, wide)

    # ---- moving base: the series step and the polynomial output maps (flexfmu.native.lti_taylor)
    def _moving_model(self):
        if self._moving_base is None:
            from flexfmu.ffr.moving_base import FFRBeamMovingBase      # on first use: a fixed base never needs it
            self._moving_base = FFRBeamMovingBase(self.dynamics, self._output_values)
        return self._moving_base

    def _output_values(self, dynamics, base) -> np.ndarray:
        """[Cx, Cu, y] of the output maps of ``dynamics`` for ``base`` as one vector (the static correction's
        energy apart: degree 4 in omega): what the moving base's polynomial interpolates."""
        _, _, _, C, y0 = dynamics.fast_maps(None, base)
        with np.errstate(all="ignore"):
            maps = self._assemble_maps(None, None, None, C, y0, base, None)
        return np.concatenate([maps.Cx.ravel(), maps.Cu.ravel(), maps.y0])

    def _series_step(self, h: float, held) -> bool:
        """One exact step by the series when flexfmu.native.lti_taylor's rule takes it (False: take the maps);
        the state is that of the step's start on failure (the maps then name the input, as a step by them would)."""
        u, st = self._u, self.state
        t = st.t + h
        with np.errstate(all="ignore"):
            prepared = self._moving_model().system.prepare(u[self._held], np.array(self._held_before), h, u[:9])
            if prepared is None:
                return False
            A, g, plan = prepared
            x = lti_taylor.taylor_steps(A, g, self._stacked(), h, plan)
            if not (float(x @ x) <= _DIVERGENCE_LIMIT ** 2 and t < _INF):
                size = float(np.max(np.abs(x)))
                if not np.isfinite(size) or size > _DIVERGENCE_LIMIT or not math.isfinite(t):
                    maps = self._maps(h)
                    raise self._divergence(t, size, maps.Ad, maps.Bu, maps.b0)
        m = st.eta.shape[0]
        self.state = ModalState(x[:m], x[m:], t)
        self._x, self._x_state = x, self.state
        self._held_before, self._series_last = held, True
        return True

    def _series_output_maps(self, held) -> _StepMaps:
        """The output maps of the held base motion from the polynomials (one product, no fast_maps), kept for
        that motion only (moving base: it is not seen again)."""
        if self._moving_outputs is not None and self._moving_outputs[0] == held:
            return self._moving_outputs[1]
        mb = self._moving_model()
        p = self._u[self._held]
        ny, nx = len(OUTPUT_NAMES), 2 * mb.m
        with np.errstate(all="ignore"):
            v = mb.outputs(p)
            ok = bool(np.isfinite(v).all())
            energy = None
            if self.static_correction is not None and ok:
                xab = self.static_correction_weights(mb.base(p))
                Q = self.static_correction.energy
                energy = (0.5 * Q[:9, :9], Q[:9, 9:] @ xab, 0.5 * float(xab @ Q[9:, 9:] @ xab))
                ok = all(np.all(np.isfinite(a)) for a in energy)
            if ok:
                Cx, Cu, y = v[:ny * nx].reshape(ny, nx), v[ny * nx:ny * (nx + 9)].reshape(ny, 9), v[ny * (nx + 9):]
                wide = not (float(np.abs(Cx).max(initial=0.0)) * nx * _DIVERGENCE_LIMIT + float(np.abs(y).max())
                            ) < 1e300
        if not ok:
            raise self._map_failure(None, mb.base(p))
        hit = _StepMaps(None, None, None, Cx, Cu, y, energy, None, wide)
        self._moving_outputs = (held, hit)
        return hit

    @staticmethod
    def static_correction_weights(base: BaseMotion) -> np.ndarray:
        """X_ab = ([alpha]x + [omega]x^2)_ab, row-major (9,): the weights of the static correction's rotation load
        patterns for the held base rotation (its load vector is [F, M, a0, X_ab])."""
        W = _skew(base.omega)
        return (_skew(base.alpha) + W @ W).ravel()

    def with_damping(self, damping_ratio: float) -> "FFRBeamSimulator":
        """A copy of this instance (state, inputs) whose dynamics has another modal damping ratio, any finite value
        (flexfmu.native.lti samples the maps' dependence on it); shares the built model, has its own map caches.
        Its ``config`` still names the original damping ratio."""
        other = copy.copy(self)
        other.dynamics = self.dynamics.with_damping(damping_ratio)
        other.messages = []
        other.state = self.state.copy()
        other.inputs = dict(self.inputs)
        other._u = self._u.copy()
        other._map_cache = BoundedCache(MAP_MEMO_SIZE)
        other._steps = StepSizes()
        other._x, other._x_state = None, None
        other._held_input_cache = None
        other._moving_base, other._moving_outputs = None, None      # the polynomials hold the damping
        return other

    def lti_probe(self):
        """This simulator's maps as flexfmu.native.lti's Probe (flexfmu.ffr.lti_probe), for
        ``LtiModel.from_ffrbeam``: the native FMU's linear system is extracted from them."""
        from flexfmu.ffr.lti_probe import ffrbeam_probe      # on use: importing the simulator loads no ctypes code
        return ffrbeam_probe(self, INPUT_NAMES, OUTPUT_NAMES)

    def _add_static_correction(self, Cu: np.ndarray, y: np.ndarray, base: BaseMotion):
        """Residual flexibility (flexfmu.sizing.model_size) in the output maps for the held base rotation:
        sensor_u, tip_u and the gauges' section forces (K_e R f) gain R f as affine terms of the inputs [F, M, a0];
        returns the strain energy's
        1/2 f^T R f as (Q (9, 9), linear (9,), constant) in those inputs."""
        corr = self.static_correction
        xab = self.static_correction_weights(base)               # X_ab, row-major: the rotation patterns' weights
        blocks = [(slice(0, 3), corr.sensor), (slice(9, 12), corr.tip)]
        if self._gauge_correction is not None:
            blocks.append((_GAUGE_FORCE_ROWS, self._gauge_correction))
        for rows, block in blocks:
            Cu[rows] += block[:, :9]
            y[rows] += block[:, 9:] @ xab
        Q = corr.energy
        return (0.5 * Q[:9, :9], Q[:9, 9:] @ xab, 0.5 * float(xab @ Q[9:, 9:] @ xab))

    def _rk4_maps(self, h: float, base: BaseMotion):
        """RK4 with n_sub = ceil(h / (0.9 h_limit)) equal sub-steps, composed into one affine map of the
        communication step: [Ad c; 0 1]^n_sub by repeated squaring (c = [Bu b0]), O(log n_sub) products.
        More than max_internal_steps sub-steps: refused before anything is computed (see _too_many_steps)."""
        dyn = self.dynamics
        limit = dyn.rk4_step_limit(base)
        if math.isfinite(limit):
            ratio = h / (RK4_STEP_FRACTION * limit)           # no guard: counted as it is (flexfmu.native.step_policy)
            if not (n_sub := step_policy.step_count(ratio, 1.0, self.config.max_internal_steps)):
                raise self._too_many_steps(h, limit, ratio)
        else:
            n_sub = 1
        Ad, Bu, b0, C, y0 = dyn.fast_maps(h / n_sub, base)
        if n_sub > 1:
            m2, k = Ad.shape[0], Bu.shape[1]
            step = np.zeros((m2 + k + 1, m2 + k + 1))
            step[:m2, :m2], step[:m2, m2:m2 + k], step[:m2, -1] = Ad, Bu, b0
            step[m2:, m2:] = np.eye(k + 1)
            total = np.linalg.matrix_power(step, n_sub)
            Ad, Bu, b0 = total[:m2, :m2].copy(), total[:m2, m2:m2 + k].copy(), total[:m2, -1].copy()
        omega_max = RK4_STABILITY_LIMIT / limit if math.isfinite(limit) and limit > 0 else 0.0
        return Ad, Bu, b0, C, y0, (n_sub, limit, omega_max, h)

    def _log_substeps(self, sub) -> None:
        n_sub, limit, omega_max, h = sub
        self._n_sub = n_sub
        self.messages.append(
            f"integrator rk4: stable step limit {limit:.4g} s = {RK4_STABILITY_LIMIT:g} / omega_max with omega_max = "
            f"{omega_max:.6g} rad/s ({omega_max / (2 * math.pi):.6g} Hz; highest retained mode, held base motion); "
            + (f"communication step {h:.6g} s -> {n_sub} equal RK4 sub-steps of {h / n_sub:.4g} s "
               f"(<= {RK4_STEP_FRACTION:g} x limit)" if n_sub > 1 else
               f"communication step {h:.6g} s <= {RK4_STEP_FRACTION:g} x limit: 1 RK4 step, no sub-steps"))

    def step(self, step_size: float) -> None:
        """Advance by step_size (s) with the current inputs held (exact zero-order hold, or RK4 sub-steps;
        cached maps)."""
        if not (math.isfinite(step_size) and step_size > 0):     # math: np.isfinite costs ~1 us per call
            require(False, "step_size", f"got {step_size!r}", "> 0 s")
        held = self._held_input()[0]
        if (self._held_before is not None and held != self._held_before and self.moving_base_series
                and self.dynamics.integrator == "exact" and self._series_step(float(step_size), held)):
            return
        maps = self._maps(float(step_size))
        Ad, Bu, b0, sub = maps.Ad, maps.Bu, maps.b0, maps.substeps
        if sub is not None and sub[0] != self._n_sub:
            self._log_substeps(sub)
        st = self.state
        m = st.eta.shape[0]
        t = st.t + step_size
        try:
            x = Ad @ self._stacked()
            _, loaded, u = self._held_input()
            if loaded:
                x += Bu @ u
            if b0 is not None:
                x += b0
            # max |x| <= |x|: only then the exact check
            diverged = not (float(x @ x) <= _DIVERGENCE_LIMIT ** 2 and t < _INF)
        except ArithmeticError:                                      # numpy's error mode set to raise
            x, diverged = None, True
        if diverged:
            with np.errstate(all="ignore"):
                if x is None:
                    x = Ad @ self._stacked() + (Bu @ self._u[:9]) + (b0 if b0 is not None else 0.0)
                size = float(np.max(np.abs(x)))
            if not np.isfinite(size) or size > _DIVERGENCE_LIMIT or not math.isfinite(t):
                raise self._divergence(t, size, Ad, Bu, b0)          # the state is still that of the step's start
        self.state = ModalState(x[:m], x[m:], t)
        self._x, self._x_state = x, self.state
        self._held_before, self._series_last = held, False

    def _stacked(self) -> np.ndarray:
        """[eta; eta_dot] of self.state (kept from the last step unless the state was replaced)."""
        st = self.state
        if self._x_state is not st:
            self._x = np.concatenate((st.eta, st.eta_dot))
            self._x_state = st
        return self._x

    def output_vector(self) -> np.ndarray:
        """All outputs at the current time for the current inputs (body frame, SI), OUTPUT_NAMES order."""
        maps = self._maps(None)
        Cx, Cu, y0, energy = maps.Cx, maps.Cu, maps.y0, maps.energy
        x = self._stacked()
        eta = self.state.eta
        try:
            y = Cx @ x
            y += y0
            _, loaded, u = self._held_input()
            if loaded:
                y += Cu @ u
                dyn = self.dynamics
                y[15:18] += _cross(dyn.load_disp_map @ eta, u[0:3]) - _cross(dyn.S_bar_hat @ eta, u[6:9])
            y[ENERGY_OUTPUT] = 0.5 * float(eta @ (self._k * eta))
            if energy is not None:        # + 1/2 f^T R f of the static correction
                Q, linear, constant = energy
                y[ENERGY_OUTPUT] += float(u @ (Q @ u)) + float(linear @ u) + constant
            if self._fill_derived is not None:      # the gauges' stresses from their section forces
                self._fill_derived(y)
            # finite maps and a state within the divergence limit give finite outputs unless inputs enter
            # (or the maps are wide): then one dot product (~0.3 us), the culprit only on failure
            if (loaded or energy is not None or maps.wide) and not y.dot(y) < _INF and not np.all(np.isfinite(y)):
                raise self._output_failure(y)
        except ArithmeticError:              # numpy's error mode set to raise: again without it, then checked
            with np.errstate(all="ignore"):
                return self.output_vector()
        return y

    def outputs(self) -> dict[str, float]:
        """All outputs at the current time for the current inputs (body frame, SI)."""
        return dict(zip(OUTPUT_NAMES, self.output_vector().tolist()))

    def reference_outputs(self) -> dict[str, float]:
        """:meth:`outputs` through the term-by-term formulas of FFRBeamDynamics (tests)."""
        dyn, state = self.dynamics, self.state
        force, moment, base = self._vectors()
        eta_ddot = dyn.acceleration(state, force, moment, base)
        u, v, a = dyn.sensor_motion(state, eta_ddot, base)
        F, M = dyn.reactions(state, eta_ddot, force, moment, base)
        tip, energy = dyn.tip_displacement(state), dyn.elastic_energy(state)
        q_modal = dyn.Phi @ state.eta
        q_res = np.zeros_like(q_modal)
        if self.static_correction is not None:     # q_residual = R f on all DOFs, f from Eq. (*)'s patterns
            W = _skew(base.omega)
            z = np.concatenate([force, moment, base.a0, (_skew(base.alpha) + W @ W).ravel()])
            q_res = self.static_correction.residual @ z
            u = u + dyn.sensor.displacement_body(q_res)
            tip = tip + dyn.tip.displacement_body(q_res)
            energy += 0.5 * float(q_res @ (dyn.model.K @ q_res))
        sections = dyn.gauges.reference(q_modal + q_res, q_modal, dyn.Phi @ state.eta_dot, dyn.Phi @ eta_ddot,
                                        dyn.Phi @ (dyn.damping * state.eta_dot), base.a0, base.omega,
                                        base.alpha).reshape(-1, 6)
        gauges = np.hstack([sections, np.zeros((len(sections), 2))]).ravel()     # the stresses: derived below
        values = np.concatenate([u, v, a, tip, F, M, self.frequencies_hz, [energy], gauges])
        evaluate_derived(self.derived_outputs, OUTPUT_NAMES, values)
        return dict(zip(OUTPUT_NAMES, values.tolist()))

    # ---- state for FMI get/set/serialize: plain JSON-able data
    def get_state(self) -> dict:
        return {"eta": self.state.eta.tolist(), "eta_dot": self.state.eta_dot.tolist(), "t": self.state.t,
                "inputs": dict(self.inputs), "config": asdict(self.config),
                # what the next step compares its base motion with, and how the last step went (the outputs'
                # maps): a restored state steps and reads as the original did, bit for bit
                "held_before": None if self._held_before is None else list(self._held_before),
                "series_last": self._series_last}

    def set_state(self, data: dict) -> None:
        require(data.get("config") == asdict(self.config), "FMUstate", "was taken with other parameters",
                "a state of this instance's configuration")
        state = ModalState(np.array(data["eta"], float), np.array(data["eta_dot"], float), float(data["t"]))
        x = np.concatenate((state.eta, state.eta_dot))
        require(x.shape == (2 * self.dynamics.m,) and bool(np.all(np.abs(x) <= _DIVERGENCE_LIMIT))
                and math.isfinite(state.t), "FMUstate", "modal state of the wrong size, not finite or beyond the "
                "divergence limit", f"{2 * self.dynamics.m} finite values within +-{_DIVERGENCE_LIMIT:g}")
        self.state = state
        self.inputs = dict(data["inputs"])
        self._u = np.array([self.inputs[name] for name in INPUT_NAMES], dtype=float)
        self._held_input_cache = None
        before = data.get("held_before")           # absent from a state of an older version: as before any step
        self._held_before = None if before is None else tuple(float(v) for v in before)
        self._series_last = bool(data.get("series_last", False)) and self._held_before is not None
        self._moving_outputs = None
