# Over 500 lines on purpose: one FMU's configuration, model set-up, step, outputs and their failure diagnostics,
# which share the cached maps and the held inputs; the model size itself lives in flexfmu.sizing.
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
"""
from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np

from flexfmu.core.blas import limited_for
from flexfmu.ffr.assembly import BOUNDARY_PRESETS, boundary_clamps, build_beam_model
from flexfmu.core.checks import (DEFAULT_MAX_INTERNAL_STEPS, MIN_COMMUNICATION_STEP, check_max_internal_steps, culprit,
                            finite, finite_input, is_int, require_str, shown)
from flexfmu.errors import DivergenceError, FlexfmuError, NonFiniteError, ParameterError, StepRejected, require
from flexfmu.core.cache import BoundedCache
from flexfmu.core.step_size import StepSizes
from flexfmu.ffr.dynamics import MAP_MEMO_SIZE, RK4_STABILITY_LIMIT, BaseMotion, FFRBeamDynamics, ModalState
from flexfmu.linalg.modal import solve_modes
from flexfmu.native import step_policy
from flexfmu.sizing.beam import (ModelChoice, StaticCorrection, TruncationChoice, ffr_load_patterns,
                                 ffr_static_correction, ffr_truncation_errors)
from flexfmu.sizing.common import SAFETY_FACTOR
from flexfmu.ffr.mesh_choice import choose_elements_per_segment
from flexfmu.sizing.mesh import MAX_ELEMENTS_PER_SEGMENT, check_band
from flexfmu.ffr.scene import check_arc_length, load_scene
from flexfmu.core.vec3 import cross as _cross
from flexfmu.core.vec3 import skew as _skew

_INF = math.inf             # a module constant: cheaper than math.inf on the per-step path
AXES = ("x", "y", "z")
FORCE_INPUTS = tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES)
BASE_INPUTS = (tuple(f"base_a_{a}" for a in AXES) + tuple(f"base_w_{a}" for a in AXES)
               + tuple(f"base_dw_{a}" for a in AXES))
INPUT_NAMES = FORCE_INPUTS + BASE_INPUTS
N_REPORTED_FREQUENCIES = 6
OUTPUT_NAMES = (tuple(f"sensor_{k}_{a}" for k in "uva" for a in AXES) + tuple(f"tip_u_{a}" for a in AXES)
                + tuple(f"reaction_F_{a}" for a in AXES) + tuple(f"reaction_M_{a}" for a in AXES)
                + tuple(f"f_{i}" for i in range(1, N_REPORTED_FREQUENCIES + 1)) + ("elastic_energy",))
# The state norm beyond which a run counts as diverged (m-scale modal coordinates of a rod).
_DIVERGENCE_LIMIT = 1e6
_NO_ROTATION = BaseMotion()
INTEGRATORS = ("exact", "rk4")
#: RK4 sub-steps stay at or below this fraction of the stability limit (margin for the damping terms).
RK4_STEP_FRACTION = 0.9
#: n_modes = -1: more modes are computed until the bound on the uncomputed ones is below this part of tolerance.
TAIL_FRACTION = 0.1


@dataclass(frozen=True)
class FFRBeamConfig:
    """Parameters, named and defaulted as in the FMU.  load_s = -1 means the last point.

    elements_per_segment = 0 and n_modes = -1 mean "choose" (from f_max and tolerance);
    static_correction: -1 = on when n_modes = -1 (the modes are chosen), 0 = off, 1 = on."""

    scene: str = "spatial_double_L"
    boundary: str = "XFF"
    elements_per_segment: int = 8
    n_modes: int = 6
    damping_ratio: float = 0.01
    load_s: float = -1.0
    sensor_s: float = 0.04
    f_max: float = 300.0
    tolerance: float = 1e-3
    static_correction: int = -1
    integrator: str = "exact"
    geometric_stiffening: bool = False
    max_internal_steps: int = DEFAULT_MAX_INTERNAL_STEPS


_is_int = is_int


def _check_config(cfg: FFRBeamConfig) -> None:
    require_str(cfg.scene, "scene", "a built-in scene name or a path to a scene JSON")
    require(isinstance(cfg.boundary, str) and cfg.boundary in BOUNDARY_PRESETS and cfg.boundary != "free", "boundary",
            f"got {cfg.boundary!r}", "XFF | XFX | FXF | FXF_mid | scene")
    require(_is_int(cfg.elements_per_segment) and 0 <= cfg.elements_per_segment <= MAX_ELEMENTS_PER_SEGMENT,
            "elements_per_segment", f"got {cfg.elements_per_segment!r}",
            f"0 (choose from f_max and tolerance) or 1 .. {MAX_ELEMENTS_PER_SEGMENT}")
    require(_is_int(cfg.n_modes) and (cfg.n_modes == -1 or cfg.n_modes >= 1), "n_modes",
            f"got {cfg.n_modes!r}", "-1 (choose: every mode below f_max) or 1 .. number of free DOFs")
    require(finite(cfg.damping_ratio) and 0.0 <= cfg.damping_ratio < 1.0, "damping_ratio",
            f"got {cfg.damping_ratio!r}", "0 <= damping_ratio < 1")
    for name in ("load_s", "sensor_s"):           # the range (the rod's length) is checked with the scene
        require(finite(getattr(cfg, name)), name, f"got {getattr(cfg, name)!r}",
                "an arc length in m (load_s: or -1 = the last point)")
    check_band(cfg.f_max, cfg.tolerance)
    require(isinstance(cfg.static_correction, (int, np.integer)) and cfg.static_correction in (-1, 0, 1),
            "static_correction", f"got {cfg.static_correction!r}", "-1 (on when n_modes = -1), 0 (off), 1 (on)")
    require(isinstance(cfg.integrator, str) and cfg.integrator in INTEGRATORS, "integrator", f"got {cfg.integrator!r}",
            " | ".join(INTEGRATORS))
    require(isinstance(cfg.geometric_stiffening, (bool, np.bool_)), "geometric_stiffening",
            f"got {cfg.geometric_stiffening!r}", "true | false")
    check_max_internal_steps(cfg.max_internal_steps)


@dataclass(frozen=True)
class _Built:
    """What a configuration builds: the dynamics, the reported frequencies f_1..f_6 (Hz), the model
    choice (for the log) and the static correction (None when off or nothing is omitted)."""

    dynamics: FFRBeamDynamics
    frequencies_hz: np.ndarray
    choice: ModelChoice
    correction: StaticCorrection | None


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


def _lowest_modes(model, n_wanted: int, f_max: float | None = None):
    """The lowest max(n_wanted, 1) modes, more while the highest solved is below f_max (Hz)."""
    k = min(max(n_wanted, 1), model.n_free)
    modes = solve_modes(model.K_free, model.M_free, k)
    while f_max is not None and k < model.n_free and modes.frequencies_hz[-1] < f_max:
        k = min(2 * k, model.n_free)
        modes = solve_modes(model.K_free, model.M_free, k)
    return modes


def _truncated_modes(model, cfg: FFRBeamConfig, load_s: float, sensor_s: float, mesh_choice):
    """(n_modes, modes computed, TruncationChoice, TruncationEstimate) for n_modes = -1 on ``model``: at least the modes below
    f_max (their converged frequencies when the mesh was chosen), then the fewest whose estimated dynamic
    truncation error of tip_u and sensor_u is within tolerance (Eq. (E) of flexfmu.sizing.model_size), computed
    from the lowest modes in doubling batches (the rest bounded by their static residual)."""
    first = solve_modes(model.K_free, model.M_free, 1)
    with limited_for(model.n_dof):     # a small model's dense set-up: one BLAS thread (flexfmu.core.blas)
        probe = FFRBeamDynamics(model, first, cfg.damping_ratio, load_s, sensor_s)   # load patterns and points
    patterns = ffr_load_patterns(probe)
    points = {"tip_u": probe.tip, "sensor_u": probe.sensor}
    k = min(model.n_free, 16)
    # k doubles up to n_free: at most log2(n_free) + 2 rounds; with every mode computed the basis is complete
    # and keeping all of them has no truncation error (errors[n_free] = 0), so the last round always decides.
    for _ in range(2 + max(1, model.n_free).bit_length()):
        modes = solve_modes(model.K_free, model.M_free, k)
        below = (mesh_choice.n_below_f_max if mesh_choice is not None
                 else int(np.count_nonzero(modes.frequencies_hz < cfg.f_max)))
        if below < k or k == model.n_free:
            estimate = ffr_truncation_errors(model, modes, patterns, points, cfg.f_max, cfg.damping_ratio)
            n_modes = estimate.smallest(cfg.tolerance / SAFETY_FACTOR, at_least=max(1, min(below, k)))
            # decided once the modes beyond those computed (bounded together, errors[k]) are well within it
            settled = estimate.errors[-1] <= TAIL_FRACTION * cfg.tolerance
            if k == model.n_free and n_modes is None:
                n_modes = k
            if n_modes is not None and ((n_modes < k and settled) or k == model.n_free):
                return n_modes, modes, TruncationChoice(
                    n_below_f_max=min(below, k), error=float(estimate.errors[n_modes]), worst=estimate.worst[n_modes],
                    static_residual=float(estimate.static_residual[n_modes]),
                    all_modes=n_modes == model.n_free), estimate
        k = min(2 * k, model.n_free)
    raise AssertionError("unreachable: the last round computes every mode")


@lru_cache(maxsize=8)
def _build(cfg: FFRBeamConfig) -> _Built:
    """Model, modes and dynamics for a configuration; cached, since instances of one FMU share them."""
    _check_config(cfg)
    scene = load_scene(cfg.scene)
    load_s = scene.total_length if cfg.load_s == -1.0 else check_arc_length(scene, cfg.load_s, "load_s")
    sensor_s = check_arc_length(scene, cfg.sensor_s, "sensor_s")
    require(len(boundary_clamps(scene, cfg.boundary)) > 0, "boundary",
            f"{cfg.boundary!r} clamps nothing in scene {scene.name}", "a boundary with at least one clamp")
    mesh_choice, truncation = None, None
    n_el = int(cfg.elements_per_segment)
    extra = (load_s, sensor_s)
    if n_el == 0:
        mesh_choice = choose_elements_per_segment(scene, cfg.boundary, cfg.f_max, cfg.tolerance,
                                                  extra_arc_lengths=extra, min_modes=max(cfg.n_modes, 1),
                                                  min_modes_parameter="n_modes")
        n_el = mesh_choice.elements_per_segment
    model = build_beam_model(scene, cfg.boundary, n_el, extra_arc_lengths=extra)
    if cfg.n_modes == -1:
        # Modes below f_max, then more until the dynamic truncation error (flexfmu.sizing.model_size Eq. (E)) is
        # within tolerance; with the mesh chosen, the mesh is then re-chosen so that every *retained*
        # frequency is resolved to the tolerance (docs/model_size.md: looser allowances for the modes above
        # f_max failed the response test), and the modes again on that mesh (settles in one or two rounds:
        # the mesh only grows).
        for _ in range(4):
            n_modes, modes, truncation, _ = _truncated_modes(model, cfg, load_s, sensor_s, mesh_choice)
            if mesh_choice is None:
                break
            finer = choose_elements_per_segment(scene, cfg.boundary, cfg.f_max, cfg.tolerance,
                                                extra_arc_lengths=extra, min_modes=n_modes,
                                                min_modes_parameter="f_max")     # the retained modes, from f_max
            if finer.elements_per_segment <= n_el:
                if finer.elements_per_segment == n_el:
                    mesh_choice = finer
                break
            mesh_choice, n_el = finer, finer.elements_per_segment
            model = build_beam_model(scene, cfg.boundary, n_el, extra_arc_lengths=extra)
        modes = _lowest_modes(model, max(n_modes + 1, N_REPORTED_FREQUENCIES)) if modes.shapes.shape[1] < min(
            max(n_modes + 1, N_REPORTED_FREQUENCIES), model.n_free) else modes
    else:
        n_modes = int(cfg.n_modes)
        require(n_modes <= model.n_free, "n_modes", f"got {n_modes}", f"1 .. {model.n_free} (free DOFs)")
        # one more than retained only when the choice is logged (the first omitted mode is reported)
        logged = mesh_choice is not None or cfg.static_correction == 1
        modes = _lowest_modes(model, max(n_modes + int(logged), N_REPORTED_FREQUENCIES))
    reported = np.zeros(N_REPORTED_FREQUENCIES)   # 0 Hz = not available (fewer free DOFs than 6)
    shown = modes.frequencies_hz[:N_REPORTED_FREQUENCIES]
    reported[:shown.size] = shown
    retained = type(modes)(modes.frequencies_hz[:n_modes], modes.shapes[:, :n_modes], modes.method)
    corrected = cfg.static_correction == 1 or (cfg.static_correction == -1 and cfg.n_modes == -1)
    with limited_for(model.n_dof):     # the dense invariants of a small model: one BLAS thread (flexfmu.core.blas)
        dynamics = FFRBeamDynamics(model, retained, cfg.damping_ratio, load_s, sensor_s, integrator=cfg.integrator,
                                   geometric_stiffening=bool(cfg.geometric_stiffening))
        correction = ffr_static_correction(dynamics) if corrected and n_modes < model.n_free else None
    choice = ModelChoice(f_max=float(cfg.f_max), tolerance=float(cfg.tolerance), elements_per_segment=n_el,
                         mesh=mesh_choice, n_modes=n_modes, modes_chosen=cfg.n_modes == -1,
                         frequencies_hz=modes.frequencies_hz[:n_modes + 1].copy(), n_free=model.n_free,
                         static_correction=corrected, truncation=truncation)
    return _Built(dynamics, reported, choice, correction)


class FFRBeamSimulator:
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
        key = (h, self._held_input()[0])
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
                n = C.shape[1] - 9
                Cx = np.zeros((len(OUTPUT_NAMES), n))
                Cu = np.zeros((len(OUTPUT_NAMES), 9))
                Cx[:18], Cu[:18] = C[:, :n], C[:, n:]
                y = np.zeros(len(OUTPUT_NAMES))
                y[:18] = y0
                y[18:18 + N_REPORTED_FREQUENCIES] = self.frequencies_hz
                energy = None
                if self.static_correction is not None:
                    energy = self._add_static_correction(Cu, y, base)
                ok = all(np.all(np.isfinite(a)) for a in (Ad, Bu, b0, Cx, Cu, y) if a is not None) and (
                    energy is None or all(np.all(np.isfinite(a)) for a in energy))
                # the outputs Cx x + y0 are then finite for any state within the divergence limit: else checked
                # per read
                wide = not (float(np.max(np.abs(Cx), initial=0.0)) * Cx.shape[1] * _DIVERGENCE_LIMIT
                            + float(np.max(np.abs(y)))) < 1e300
        except FlexfmuError:
            raise
        except (np.linalg.LinAlgError, ArithmeticError, ValueError):
            ok = False
        if not ok:
            raise self._map_failure(h, base)
        hit = self._map_cache[key] = _StepMaps(Ad, Bu, b0 if (b0 is not None and b0.any()) else None,
                                               np.ascontiguousarray(Cx), np.ascontiguousarray(Cu), y, energy, sub,
                                               wide)
        return hit

    def _base_culprit(self) -> str | None:
        """The held base input that most likely overflowed the maps: omega enters squared, alpha and (with
        geometric stiffening) a0 linearly."""
        u = self._u.tolist()                  # Python floats: w * w is inf on overflow, without a warning
        scores = {f"base_w_{a}": abs(u[9 + i]) * abs(u[9 + i]) for i, a in enumerate(AXES)}
        scores.update({f"base_dw_{a}": abs(u[12 + i]) for i, a in enumerate(AXES)})
        if self.dynamics.geometric_stiffening:
            scores.update({f"base_a_{a}": abs(u[6 + i]) for i, a in enumerate(AXES)})
        return culprit(scores)

    def _map_failure(self, h, base: BaseMotion) -> FlexfmuError:
        """The error for maps that are not finite: the held base motion, else the step size (the step's
        transition matrix overflows; a smaller step would do)."""
        name = self._base_culprit()
        if name is not None:
            try:
                with np.errstate(all="ignore"):
                    maps = self.dynamics.fast_maps(h, _NO_ROTATION)
                still = not all(np.all(np.isfinite(a)) for a in maps if a is not None)
            except (np.linalg.LinAlgError, ArithmeticError, ValueError):
                still = True
            if not still or h is None:
                unit = "m/s2" if name.startswith("base_a") else "rad/s2" if name.startswith("base_dw") else "rad/s"
                return NonFiniteError(name, f"{self.inputs[name]:.6g} {unit}: the held base motion's inertial loads "
                                            "(omega^2, alpha, a0 times the rod's mass distribution) overflow the "
                                            "model's maps (not finite); allowed: a base motion within the "
                                            "floating-point range of the model (|omega| well below 1e150 rad/s)")
        if h is None:
            return NonFiniteError(name or "base motion", "the output maps of the held inputs are not finite")
        return StepRejected("step_size", f"a communication step of {h!r} s makes the step's transition matrix "
                                         "overflow (not finite); take a smaller communication step")

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
        return other

    def lti_probe(self):
        """This simulator's maps as flexfmu.native.lti's Probe (flexfmu.ffr.lti_probe), for
        ``LtiModel.from_ffrbeam``: the native FMU's linear system is extracted from them."""
        from flexfmu.ffr.lti_probe import ffrbeam_probe      # on use: importing the simulator loads no ctypes code
        return ffrbeam_probe(self, INPUT_NAMES, OUTPUT_NAMES)

    def _add_static_correction(self, Cu: np.ndarray, y: np.ndarray, base: BaseMotion):
        """Residual flexibility (flexfmu.sizing.model_size) in the output maps for the held base rotation:
        sensor_u and tip_u gain R f as affine terms of the inputs [F, M, a0]; returns the strain energy's
        1/2 f^T R f as (Q (9, 9), linear (9,), constant) in those inputs."""
        corr = self.static_correction
        xab = self.static_correction_weights(base)               # X_ab, row-major: the rotation patterns' weights
        for rows, block in ((slice(0, 3), corr.sensor), (slice(9, 12), corr.tip)):
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

    def _too_many_steps(self, h: float, limit: float, ratio: float) -> FlexfmuError:
        """More RK4 sub-steps than max_internal_steps (flexfmu.native.step_policy, in its RK4 wording): StepRejected
        when a communication step of at least MIN_COMMUNICATION_STEP would be within the cap, else ParameterError
        naming the held base rotation (when without it the limit would allow that) or the integrator (the highest
        retained mode sets the limit)."""
        cap = self.config.max_internal_steps
        return step_policy.refusal(h, ratio, cap, cap * RK4_STEP_FRACTION * limit, lambda: self._rk4_cause(limit),
                                   rk4_limit=limit)

    def _rk4_cause(self, limit: float):
        cap = self.config.max_internal_steps
        name = self._base_culprit()
        if name is not None:
            try:
                free = self.dynamics.rk4_step_limit(_NO_ROTATION)
            except (np.linalg.LinAlgError, ArithmeticError, ValueError):
                free = 0.0
            if cap * RK4_STEP_FRACTION * free >= MIN_COMMUNICATION_STEP:
                return step_policy.Cause(name, "a smaller base rotation, or integrator exact (no step limit)",
                                         f"{self.inputs[name]:.6g}: the held base motion makes ")
        f_top = RK4_STABILITY_LIMIT / limit / (2 * math.pi)
        return step_policy.Cause("integrator", "integrator exact (no step limit), fewer modes, or a larger "
                                 "max_internal_steps", after=f" (highest retained mode {f_top:.6g} Hz)")

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

    def _divergence(self, t: float, size: float, Ad, Bu, b0) -> FlexfmuError:
        """The error of a step whose state left the linear model's range: NonFiniteError when not finite,
        ParameterError ("diverged") when beyond _DIVERGENCE_LIMIT; named after the load input or the held base
        motion when one alone does it in this step, else the state (a dynamic instability)."""
        with np.errstate(all="ignore"):
            scores = {name: float(np.max(np.abs(Bu[:, j] * self._u[j]))) for j, name in enumerate(INPUT_NAMES[:9])}
            base = self._base_culprit()
            if base is not None and b0 is not None:
                scores[base] = float(np.max(np.abs(b0)))
        name = culprit({k: v for k, v in scores.items() if not v <= _DIVERGENCE_LIMIT})
        if not math.isfinite(t):
            return NonFiniteError("step_size", f"the time t + step_size overflows at t = {self.state.t!r} s")
        if not np.isfinite(size):
            cause = name or "state"
            shown = f"{self.inputs[cause]:.6g} makes" if name else "the modal state"
            return NonFiniteError(cause, f"{shown} the modal state overflow (not finite) at t = {t:.6g} s: the state "
                                         "diverged; allowed: inputs within the linear model's range")
        return DivergenceError(name or "state", f"diverged at t = {t:.6g} s (modal state norm {size:.3g})"
                              + (f": {name} = {self.inputs[name]:.6g} alone moves it beyond {_DIVERGENCE_LIMIT:g}"
                                 if name else ""),
                              "inputs within the linear model's range; spin below the first bending frequency")

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
            y[-1] = 0.5 * float(eta @ (self._k * eta))
            if energy is not None:        # + 1/2 f^T R f of the static correction
                Q, linear, constant = energy
                y[-1] += float(u @ (Q @ u)) + float(linear @ u) + constant
            # finite maps and a state within the divergence limit give finite outputs unless inputs enter
            # (or the maps are wide): then one dot product (~0.3 us), the culprit only on failure
            if (loaded or energy is not None or maps.wide) and not y.dot(y) < _INF and not np.all(np.isfinite(y)):
                raise self._output_failure(y)
        except ArithmeticError:              # numpy's error mode set to raise: again without it, then checked
            with np.errstate(all="ignore"):
                return self.output_vector()
        return y

    def _output_failure(self, y) -> NonFiniteError:
        """NonFiniteError naming the input that alone makes an output overflow (the outputs are affine in F, M,
        a0 with the base rotation held, the energy quadratic)."""
        maps = self._maps(None)
        Cx, Cu, energy = maps.Cx, maps.Cu, maps.energy
        eta = self.state.eta
        bad = [OUTPUT_NAMES[i] for i in np.nonzero(~np.isfinite(y))[0]] if y is not None else ["the outputs"]
        scores = {}
        with np.errstate(all="ignore"):
            for j, name in enumerate(INPUT_NAMES[:9]):
                uj = self._u[j]
                part = np.abs(Cu[:, j] * uj)
                if energy is not None:
                    part = np.append(part, abs(energy[0][j, j] * uj * uj) + abs(energy[1][j] * uj))
                scores[name] = float(np.max(part)) if np.all(np.isfinite(part)) else math.inf
            scores["state"] = float(np.max(np.abs(Cx @ np.concatenate((eta, self.state.eta_dot)))))
        name = culprit({k: v for k, v in scores.items() if not v < 1e300}) or culprit(scores) or "state"
        shown = f"{self.inputs[name]:.6g} makes" if name in self.inputs else "the modal state makes"
        return NonFiniteError(name, f"{shown} {', '.join(bad)} overflow (not finite) at t = {self.time:.6g} s; "
                                    "allowed: inputs within the linear model's range")

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
        if self.static_correction is not None:     # q_residual = R f on all DOFs, f from Eq. (*)'s patterns
            W = _skew(base.omega)
            z = np.concatenate([force, moment, base.a0, (_skew(base.alpha) + W @ W).ravel()])
            q_res = self.static_correction.residual @ z
            u = u + dyn.sensor.displacement_body(q_res)
            tip = tip + dyn.tip.displacement_body(q_res)
            energy += 0.5 * float(q_res @ (dyn.model.K @ q_res))
        values = np.concatenate([u, v, a, tip, F, M, self.frequencies_hz, [energy]])
        return dict(zip(OUTPUT_NAMES, values.tolist()))

    # ---- state for FMI get/set/serialize: plain JSON-able data
    def get_state(self) -> dict:
        return {"eta": self.state.eta.tolist(), "eta_dot": self.state.eta_dot.tolist(), "t": self.state.t,
                "inputs": dict(self.inputs), "config": asdict(self.config)}

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


def _axis_info(prefix: str, unit: str, text: str) -> dict:
    return {f"{prefix}_{a}": (unit, f"{text}, body {a}") for a in AXES}


#: name -> (unit, description) of every FMU variable; the FMU build writes these into modelDescription.xml.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "scene": ("", "built-in scene name (spatial_double_L, inclined_beam, c_section) or path to a scene JSON"),
    "boundary": ("", "clamps: XFF | XFX | FXF (first corner) | FXF_mid (mid segment 2) | scene"),
    "elements_per_segment": ("", "beam elements per polyline segment, 1 .. 512; 0 = choose: the fewest whose "
                             "frequencies below f_max are within tolerance of the converged ones"),
    "n_modes": ("", "retained modes, 1 .. number of free DOFs; -1 = choose: every mode below f_max and more above "
                "it until the estimated dynamic truncation error of tip_u and sensor_u is within tolerance"),
    "damping_ratio": ("", "modal damping ratio of every retained mode, 0 <= zeta < 1"),
    "load_s": ("m", "arc length of the load point from the first point; -1 = the last point"),
    "sensor_s": ("m", "arc length of the sensor (accelerometer) point"),
    "f_max": ("Hz", "highest frequency of interest, for n_modes = -1 and elements_per_segment = 0 (> 0)"),
    "tolerance": ("", "relative error allowed, 1e-6 .. 0.1: of the retained frequencies when elements_per_segment = 0, "
                  "of the displacement outputs' modal truncation when n_modes = -1"),
    "static_correction": ("", "residual flexibility of the omitted modes in sensor_u, tip_u and elastic_energy "
                          "(exact quasi-static deflection): -1 = on when n_modes = -1, 0 = off, 1 = on"),
    "integrator": ("", "exact (zero-order-hold matrix exponential, any step) | rk4 (classical RK4, sub-stepped "
                   "automatically below its stability limit 2.8 / omega_max)"),
    "geometric_stiffening": ("", "add the geometric (centrifugal) stiffness of the held base motion's "
                             "inertial load"),
    "max_internal_steps": ("", "integrator rk4: most sub-steps per communication step, 1 .. 1e8 (default 100000), "
                               "counted before stepping: a longer communication step is rejected (fmi2Discard: take a "
                               "smaller one) while a 1e-05 s step would fit, else the input or parameter that needs so "
                               "many is refused (fmi2Error)"),
    **_axis_info("F", "N", "force at load_s"),
    **_axis_info("M", "N.m", "moment at load_s"),
    **_axis_info("base_a", "m/s2", "acceleration of the floating-frame origin (base)"),
    **_axis_info("base_w", "rad/s", "angular velocity of the floating frame (base)"),
    **_axis_info("base_dw", "rad/s2", "angular acceleration of the floating frame (base)"),
    **_axis_info("sensor_u", "m", "elastic displacement of the sensor point"),
    **_axis_info("sensor_v", "m/s", "elastic velocity of the sensor point relative to the frame"),
    **_axis_info("sensor_a", "m/s2", "total acceleration of the sensor point incl. base motion (accelerometer)"),
    **_axis_info("tip_u", "m", "elastic displacement of the last point"),
    **_axis_info("reaction_F", "N", "force the structure exerts on its clamps (sum)"),
    **_axis_info("reaction_M", "N.m", "moment the structure exerts on its clamps, about the frame origin"),
    **{f"f_{i}": ("Hz", f"natural frequency {i} of the clamped structure (0 = not available)")
       for i in range(1, N_REPORTED_FREQUENCIES + 1)},
    "elastic_energy": ("J", "strain energy of the retained modes (plus the static correction's when on)"),
}
