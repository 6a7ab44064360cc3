"""FFRBeam: a scene's clamped structure in time, with named inputs and outputs.

The FMU (fmu_src/FFRBeam.py) is a thin shell over this class: the variable names here are the
FMU's.  Inputs are held over each step (zero-order hold) and the step is exact for such input
(flexfmu.ffr_dynamics), so one internal step per communication step of any length.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np

from flexfmu.assembly import BOUNDARY_PRESETS, build_beam_model
from flexfmu.errors import ParameterError, require
from flexfmu.ffr_dynamics import BaseMotion, FFRBeamDynamics, ModalState
from flexfmu.modal import solve_modes
from flexfmu.scene import check_arc_length, load_scene
from flexfmu.vec3 import cross as _cross

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


@dataclass(frozen=True)
class FFRBeamConfig:
    """Parameters, named and defaulted as in the FMU.  load_s = -1 means the last point."""

    scene: str = "spatial_double_L"
    boundary: str = "XFF"
    elements_per_segment: int = 8
    n_modes: int = 6
    damping_ratio: float = 0.01
    load_s: float = -1.0
    sensor_s: float = 0.04


def _check_config(cfg: FFRBeamConfig) -> None:
    require(cfg.boundary in BOUNDARY_PRESETS and cfg.boundary != "free", "boundary",
            f"got {cfg.boundary!r}", "XFF | XFX | FXF | FXF_mid | scene")
    require(isinstance(cfg.elements_per_segment, (int, np.integer)) and 1 <= cfg.elements_per_segment <= 512,
            "elements_per_segment", f"got {cfg.elements_per_segment!r}", "1 .. 512")
    require(cfg.n_modes != -1, "n_modes", "-1 (choose automatically) is not available yet", ">= 1")
    require(isinstance(cfg.n_modes, (int, np.integer)) and cfg.n_modes >= 1, "n_modes",
            f"got {cfg.n_modes!r}", ">= 1")
    require(np.isfinite(cfg.damping_ratio) and 0.0 <= cfg.damping_ratio < 1.0, "damping_ratio",
            f"got {cfg.damping_ratio!r}", "0 <= damping_ratio < 1")


@lru_cache(maxsize=8)
def _build(cfg: FFRBeamConfig) -> tuple[FFRBeamDynamics, np.ndarray]:
    """Model, modes and dynamics for a configuration; cached, since instances of one FMU share them."""
    _check_config(cfg)
    scene = load_scene(cfg.scene)
    load_s = scene.total_length if cfg.load_s == -1.0 else check_arc_length(scene, cfg.load_s, "load_s")
    sensor_s = check_arc_length(scene, cfg.sensor_s, "sensor_s")
    model = build_beam_model(scene, cfg.boundary, int(cfg.elements_per_segment),
                             extra_arc_lengths=(load_s, sensor_s))
    require(model.clamped_nodes.size > 0, "boundary", f"{cfg.boundary!r} clamps nothing in scene {scene.name}",
            "a boundary with at least one clamp")
    require(cfg.n_modes <= model.n_free, "n_modes", f"got {cfg.n_modes}", f"1 .. {model.n_free} (free DOFs)")
    n_solve = min(max(cfg.n_modes, N_REPORTED_FREQUENCIES), model.n_free)
    modes = solve_modes(model.K_free, model.M_free, n_solve)
    reported = np.zeros(N_REPORTED_FREQUENCIES)   # 0 Hz = not available (fewer free DOFs than 6)
    reported[:min(n_solve, N_REPORTED_FREQUENCIES)] = modes.frequencies_hz[:N_REPORTED_FREQUENCIES]
    retained = type(modes)(modes.frequencies_hz[:cfg.n_modes], modes.shapes[:, :cfg.n_modes], modes.method)
    return FFRBeamDynamics(model, retained, cfg.damping_ratio, load_s, sensor_s), reported


class FFRBeamSimulator:
    """State (modal coordinates, time) and the step of one FFRBeam instance."""

    def __init__(self, config: FFRBeamConfig = FFRBeamConfig()):
        self.config = config
        self.dynamics, self.frequencies_hz = _build(config)
        self.state = self.dynamics.initial_state()
        self.inputs = dict.fromkeys(INPUT_NAMES, 0.0)
        self._u = np.zeros(len(INPUT_NAMES))          # the inputs as a vector, INPUT_NAMES order
        self._k = self.dynamics.stiffness
        self._map_cache: dict = {}
        self._x, self._x_state = None, None

    @property
    def time(self) -> float:
        return self.state.t

    @staticmethod
    def check_inputs(inputs: dict) -> None:
        for name, value in inputs.items():
            require(name in INPUT_NAMES, name, "unknown input", ", ".join(INPUT_NAMES))
            require(np.isfinite(value), name, f"input is {value!r}", "a finite number")

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

    def set_input_vector(self, values) -> None:
        """All inputs at once, in INPUT_NAMES order (the FMU's per-step path)."""
        u = np.array(values, dtype=float)
        if u.shape != (len(INPUT_NAMES),) or not np.isfinite(u).all():
            self.check_inputs(dict(zip(INPUT_NAMES, np.resize(u, len(INPUT_NAMES)).tolist())))
            require(u.shape == (len(INPUT_NAMES),), "inputs", f"{u.shape[0] if u.ndim else 0} values",
                    f"{len(INPUT_NAMES)} values")
        self._u = u
        self.inputs = dict(zip(INPUT_NAMES, u.tolist()))

    def _maps(self, h):
        """(Ad, Bu, b0 or None, Cx, Cu, y0) for step h (None: outputs only) and the held base rotation,
        cached: the step and the outputs are then a few matrix-vector products."""
        u = self._u
        rot = tuple(u[9:15].tolist())
        key = (h, rot)
        hit = self._map_cache.get(key)
        if hit is None:
            base = BaseMotion(omega=u[9:12].copy(), alpha=u[12:15].copy())
            Ad, Bu, b0, C, y0 = self.dynamics.fast_maps(h, base)
            n = C.shape[1] - 9
            Cx = np.zeros((len(OUTPUT_NAMES), n))
            Cu = np.zeros((len(OUTPUT_NAMES), 9))
            Cx[:18], Cu[:18] = C[:, :n], C[:, n:]
            y = np.zeros(len(OUTPUT_NAMES))
            y[:18] = y0
            y[18:18 + N_REPORTED_FREQUENCIES] = self.frequencies_hz
            if len(self._map_cache) > 64:
                self._map_cache.clear()
            hit = self._map_cache[key] = (Ad, Bu, b0 if (b0 is not None and b0.any()) else None,
                                          np.ascontiguousarray(Cx), np.ascontiguousarray(Cu), y)
        return hit

    def step(self, step_size: float) -> None:
        """Advance by step_size (s) with the current inputs held (exact zero-order hold, cached maps)."""
        require(np.isfinite(step_size) and step_size > 0, "step_size", f"got {step_size!r}", "> 0 s")
        Ad, Bu, b0, _, _, _ = self._maps(float(step_size))
        st = self.state
        m = st.eta.shape[0]
        x = Ad @ self._stacked()
        u = self._u[:9]
        if u.any():
            x += Bu @ u
        if b0 is not None:
            x += b0
        t = st.t + step_size
        if not float(x @ x) <= _DIVERGENCE_LIMIT ** 2:      # max |x| <= |x|: only then the exact check
            size = float(np.max(np.abs(x)))
            if not np.isfinite(size) or size > _DIVERGENCE_LIMIT:
                raise ParameterError("state", f"diverged at t = {t:.6g} s (modal state norm {size:.3g})",
                                     "inputs within the linear model's range; spin below the first bending frequency")
        self.state = ModalState(x[:m], x[m:], t)
        self._x, self._x_state = x, self.state

    def _stacked(self) -> np.ndarray:
        """[eta; eta_dot] of self.state (kept from the last step unless the state was replaced)."""
        st = self.state
        if self._x_state is not st:
            self._x = np.concatenate((st.eta, st.eta_dot))
            self._x_state = st
        return self._x

    def output_vector(self) -> np.ndarray:
        """All outputs at the current time for the current inputs (body frame, SI), OUTPUT_NAMES order."""
        _, _, _, Cx, Cu, y0 = self._maps(None)
        x = self._stacked()
        eta = self.state.eta
        y = Cx @ x
        y += y0
        u = self._u[:9]
        if u.any():
            y += Cu @ u
            dyn = self.dynamics
            y[15:18] += _cross(dyn.load_disp_map @ eta, u[0:3]) - _cross(dyn.S_bar_hat @ eta, u[6:9])
        y[-1] = 0.5 * float(eta @ (self._k * eta))
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
        values = np.concatenate([u, v, a, dyn.tip_displacement(state), F, M, self.frequencies_hz,
                                 [dyn.elastic_energy(state)]])
        return dict(zip(OUTPUT_NAMES, values.tolist()))

    # ---- state for FMI get/set/serialize: plain JSON-able data
    def get_state(self) -> dict:
        return {"eta": self.state.eta.tolist(), "eta_dot": self.state.eta_dot.tolist(), "t": self.state.t,
                "inputs": dict(self.inputs), "config": asdict(self.config)}

    def set_state(self, data: dict) -> None:
        require(data.get("config") == asdict(self.config), "FMUstate", "was taken with other parameters",
                "a state of this instance's configuration")
        self.state = ModalState(np.array(data["eta"], float), np.array(data["eta_dot"], float), float(data["t"]))
        self.inputs = dict(data["inputs"])
        self._u = np.array([self.inputs[name] for name in INPUT_NAMES], dtype=float)


def _axis_info(prefix: str, unit: str, text: str) -> dict:
    return {f"{prefix}_{a}": (unit, f"{text}, body {a}") for a in AXES}


#: name -> (unit, description) of every FMU variable; the FMU build writes these into modelDescription.xml.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "scene": ("", "built-in scene name (spatial_double_L, inclined_beam, c_section) or path to a scene JSON"),
    "boundary": ("", "clamps: XFF | XFX | FXF (first corner) | FXF_mid (mid segment 2) | scene"),
    "elements_per_segment": ("", "beam elements per polyline segment, 1 .. 512"),
    "n_modes": ("", "retained modes, 1 .. number of free DOFs"),
    "damping_ratio": ("", "modal damping ratio of every retained mode, 0 <= zeta < 1"),
    "load_s": ("m", "arc length of the load point from the first point; -1 = the last point"),
    "sensor_s": ("m", "arc length of the sensor (accelerometer) point"),
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
    "elastic_energy": ("J", "strain energy of the retained modes"),
}
