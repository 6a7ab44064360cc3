"""FlexBody's simulator: a reduced body (flexfmu.body.model.FlexBody) with named inputs and outputs, what an exported
FMU wraps through flexfmu.fmi.plumbing (the Simulator protocol there).

Variables of a body with interfaces I (names from input_names / output_names):

    free body      inputs  I.F_x, I.F_y, I.F_z (N), I.M_x, I.M_y, I.M_z (N.m; where the patch carries a moment),
                           global frame, held over a communication step
                   outputs I.pos_*, I.vel_*, I.acc_* (global: the rigid fit of the patch's motion, Eq. (I3));
                           pos_*, vel_* (frame origin), q_w .. q_z (body -> global), omega_1..3, alpha_1..3 (body
                           frame), com_pos_*, com_vel_* (global; the deformed body's centre of mass,
                           flexfmu.body.free), max_elastic_displacement; f_1 .. f_k
    clamped body   inputs  I.F_*, I.M_* (body frame); base_a_* (m/s2), base_w_* (rad/s), base_dw_* (rad/s2): the
                           base's acceleration, angular velocity and angular acceleration, body frame (as FFRBeam)
                   outputs I.pos_* (x_I + u_I), I.vel_* (elastic, relative to the base), I.acc_* (absolute:
                           accelerometer), body frame; reaction_F_*, reaction_M_* (on the base, about the body
                           origin, body frame); f_1 .. f_k

f_1 .. f_k (Hz, constant) are the body's lowest natural frequencies: k = 6, or fewer when the structure has fewer
elastic DOFs (free: without the rigid modes; clamped: of the clamped structure).

Inputs are held over a communication step.  Free body: equal internal steps, counted before stepping (scheme
"consistent": 90 % of the RK4 stability limit; "exponential": by the rotation per step, as ReframeBody); clamped
body: one exact zero-order-hold step of any length (or internal_step sub-steps).  More than max_internal_steps
is refused (StepRejected when a smaller communication step would do); a non-finite input or state is a
NonFiniteError naming the input; a failed step keeps the state of its start.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from flexfmu.body.engines import ClampedEngine, FreeEngine
from flexfmu.core.rotation import rotation_matrix
from flexfmu.core.checks import (DEFAULT_MAX_INTERNAL_STEPS, check_max_internal_steps, finite_input, require_real,
                                 require_str, shown)
from flexfmu.errors import NonFiniteError, ParameterError
from flexfmu.reframe.layout import output_layout
from flexfmu.reframe.schemes import scheme_class, scheme_names

AXES = ("x", "y", "z")
TOLERANCE_RANGE = (1e-8, 1.0)
_BODY_FREE = (tuple(f"pos_{a}" for a in AXES) + tuple(f"vel_{a}" for a in AXES) + ("q_w", "q_x", "q_y", "q_z")
              + tuple(f"omega_{i}" for i in (1, 2, 3)) + tuple(f"alpha_{i}" for i in (1, 2, 3))
              + tuple(f"com_pos_{a}" for a in AXES) + tuple(f"com_vel_{a}" for a in AXES)
              + ("max_elastic_displacement",))
#: the body frame's rotation in global components (what a seakeeping or a clamped component downstream reads):
#: rotation vector, angular velocity and acceleration; computed from q and omega_k, alpha_k (body)
_FRAME_GLOBAL = (tuple(f"rot_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES)
                 + tuple(f"alpha_{a}" for a in AXES))
_BODY_CLAMPED = tuple(f"reaction_F_{a}" for a in AXES) + tuple(f"reaction_M_{a}" for a in AXES)
_BASE = tuple(f"base_a_{a}" for a in AXES) + tuple(f"base_w_{a}" for a in AXES) + tuple(f"base_dw_{a}" for a in AXES)
_INITIAL = ("v0_x", "v0_y", "v0_z", "omega0_1", "omega0_2", "omega0_3")


@dataclass(frozen=True)
class FlexBodyConfig:
    """The FMU's parameters (variable_info describes each)."""

    damping_ratio: float = -1.0         # -1: the body's own (FlexBody.damping_ratio)
    scheme: str = "exponential"          # free bodies
    tolerance: float = 1e-3              # free bodies, scheme exponential, internal_step = 0
    internal_step: float = 0.0
    max_internal_steps: int = DEFAULT_MAX_INTERNAL_STEPS
    v0_x: float = 0.0
    v0_y: float = 0.0
    v0_z: float = 0.0
    omega0_1: float = 0.0
    omega0_2: float = 0.0
    omega0_3: float = 0.0


@dataclass(frozen=True)
class ClampedBodyConfig:
    """The parameters of a clamped body's FMU: those of FlexBodyConfig that act on it."""

    damping_ratio: float = -1.0         # -1: the body's own (FlexBody.damping_ratio)
    internal_step: float = 0.0
    max_internal_steps: int = DEFAULT_MAX_INTERNAL_STEPS


def config_class(body):
    """The parameters of ``body``'s FMU: FlexBodyConfig for a free body, ClampedBodyConfig for a clamped one
    (initial motion, scheme and its tolerance do not apply to a body that moves with its base)."""
    return FlexBodyConfig if body.kind == "free" else ClampedBodyConfig


def _interface_inputs(body) -> tuple:
    out = []
    for i in body.interfaces:
        out += [f"{i.name}.F_{a}" for a in AXES]
        if i.moments:
            out += [f"{i.name}.M_{a}" for a in AXES]
    return tuple(out)


def input_names(body) -> tuple[str, ...]:
    """The body's inputs in the order of set_input_vector (module docstring)."""
    return _interface_inputs(body) + (_BASE if body.kind == "clamped" else ())


def _frequency_names(body) -> tuple:
    return tuple(f"f_{k}" for k in range(1, len(body.natural_frequencies_hz) + 1))


def output_names(body) -> tuple[str, ...]:
    """The body's outputs in the order of output_vector (module docstring)."""
    per = tuple(f"{i.name}.{q}_{a}" for i in body.interfaces for q in ("pos", "vel", "acc") for a in AXES)
    return per + (_BODY_FREE + _FRAME_GLOBAL if body.kind == "free" else _BODY_CLAMPED) + _frequency_names(body)


def deferred_outputs(body) -> tuple[str, ...]:
    """Outputs whose cost grows with the mesh (computed only when read, flexfmu.fmi.plumbing)."""
    return ("max_elastic_displacement",) if body.kind == "free" else ()


def _axes(prefix, unit, text):
    return {f"{prefix}_{a}": (unit, f"{text}, {a}") for a in AXES}


def variable_info(body) -> dict[str, tuple[str, str]]:
    """name -> (unit, description) of every parameter, input and output of the body's FMU."""
    free = body.kind == "free"
    frame = "global" if free else "body frame"
    info = {
        "damping_ratio": ("", f"modal damping ratio of every elastic coordinate, 0 <= zeta < 1; -1 = the body's "
                              f"({body.damping_ratio:g})"),
        "scheme": ("", "exponential (exact in the modes' linear part, no stability limit) | consistent (RK4)"),
        "tolerance": ("", "scheme exponential, internal_step = 0: rotation per internal step <= "
                          "0.5 tolerance^(1/4) rad; 1e-8 <= tolerance < 1"),
        "internal_step": ("s", "longest internal step; 0 = automatic (free: 90% of the RK4 stability limit, or by "
                               "accuracy for scheme exponential; clamped: one exact step per communication step)"),
        "max_internal_steps": ("", "most internal steps per communication step, 1 .. 1e8, counted before stepping: "
                                   "a longer communication step is rejected (fmi2Discard) while a 1e-05 s step "
                                   "would fit"),
        **_axes("v0", "m/s", "initial velocity of the centre of mass, global"),
        **{f"omega0_{k}": ("rad/s", f"initial angular velocity, body frame, {k}") for k in (1, 2, 3)},
    }
    if not free:                        # only the parameters of ClampedBodyConfig
        info = {name: info[name] for name in ("damping_ratio", "internal_step", "max_internal_steps")}
    for i in body.interfaces:
        info.update(_axes(f"{i.name}.F", "N", f"force at interface {i.name}, {frame}"))
        if i.moments:
            info.update(_axes(f"{i.name}.M", "N.m", f"moment at interface {i.name}, {frame}"))
        info.update(_axes(f"{i.name}.pos", "m", f"position of interface {i.name} (rigid fit of its patch), {frame}"
                          + ("" if free else ", from the body origin")))
        info.update(_axes(f"{i.name}.vel", "m/s", f"velocity of interface {i.name}, {frame}"
                          + ("" if free else ", elastic, relative to the base")))
        info.update(_axes(f"{i.name}.acc", "m/s2", f"acceleration of interface {i.name}, {frame}"
                          + ("" if free else ", absolute (accelerometer)")))
    if free:
        info.update(_axes("pos", "m", "position of the body frame's origin, global"))
        info.update(_axes("vel", "m/s", "velocity of the body frame's origin, global"))
        info.update({f"q_{c}": ("", f"orientation quaternion body -> global, scalar first, {c}") for c in "wxyz"})
        info.update({f"omega_{k}": ("rad/s", f"angular velocity, body frame, {k}") for k in (1, 2, 3)})
        info.update({f"alpha_{k}": ("rad/s2", f"angular acceleration, body frame, {k}") for k in (1, 2, 3)})
        info.update(_axes("com_pos", "m", "centre of mass (of the deformed body too), global"))
        info.update(_axes("com_vel", "m/s", "velocity of the centre of mass, global"))
        info["max_elastic_displacement"] = ("m", "largest elastic nodal displacement, body frame norm")
        info.update({f"rot_{a}": ("", f"rotation vector of the body frame (body -> global), global {a}, rad")
                     for a in AXES})
        info.update(_axes("omega", "rad/s", "angular velocity of the body frame, global"))
        info.update(_axes("alpha", "rad/s2", "angular acceleration of the body frame, global"))
    else:
        info.update(_axes("base_a", "m/s2", "acceleration of the base (body frame origin), body frame"))
        info.update(_axes("base_w", "rad/s", "angular velocity of the base, body frame"))
        info.update(_axes("base_dw", "rad/s2", "angular acceleration of the base, body frame"))
        info.update(_axes("reaction_F", "N", "force the body exerts on its clamps, body frame"))
        info.update(_axes("reaction_M", "N.m", "moment the body exerts on its clamps about the body origin, "
                                               "body frame"))
    what = "elastic natural frequency" if free else "natural frequency of the clamped structure"
    info.update({n: ("Hz", f"{what} {k}") for k, n in enumerate(_frequency_names(body), start=1)})
    return info


def _check_config(c, body) -> float:
    """Types and ranges of the parameters; returns the damping ratio used."""
    zeta = require_real(c.damping_ratio, "damping_ratio", "-1 (the body's) or 0 <= damping_ratio < 1", -1.0, 1.0,
                        hi_open=True)
    if zeta < 0:
        if zeta != -1.0:
            raise ParameterError("damping_ratio", f"got {c.damping_ratio!r}", "-1 (the body's) or 0 <= zeta < 1")
        zeta = body.damping_ratio
    require_real(c.internal_step, "internal_step", "0 (automatic) or a step > 0 s", 0.0)
    check_max_internal_steps(c.max_internal_steps)
    if not isinstance(c, FlexBodyConfig):
        return zeta
    require_str(c.scheme, "scheme", " | ".join(scheme_names("for_bodies")))
    scheme_class(c.scheme, "for_bodies")
    lo, hi = TOLERANCE_RANGE
    require_real(c.tolerance, "tolerance", f"{lo:g} <= tolerance < {hi:g}", lo, hi, hi_open=True)
    for name in _INITIAL:
        v = require_real(getattr(c, name), name, "a finite number")
        if body.kind == "clamped" and v != 0.0:
            raise ParameterError(name, f"{v:g}: a clamped body moves with its base", "0 for a clamped body")
    return zeta


def _frame_global(q_omega_alpha: np.ndarray) -> np.ndarray:
    """[rotation vector, omega, alpha] in global components from [q (scalar first), omega, alpha (body)]:
    omega_g = R omega, and alpha_g = d(R omega)/dt = R alpha since R (omega x omega) = 0."""
    q = q_omega_alpha[:4]
    n = float(np.linalg.norm(q))
    if not n > 0.0:
        return np.full(9, np.nan)
    w, v = q[0] / n, q[1:] / n
    if w < 0.0:                                    # the same rotation, angle in [0, pi]
        w, v = -w, -v
    s = float(np.linalg.norm(v))
    angle = 2.0 * math.atan2(s, w)
    rot = v * (angle / s) if s > 1e-12 else 2.0 * v
    R = rotation_matrix(rot).T                    # body -> global
    return np.concatenate([rot, R @ q_omega_alpha[4:7], R @ q_omega_alpha[7:10]])


class FlexBodySimulator:
    """State and step of one body (module docstring); ``messages``: what the model holds and chose, logged once,
    and the internal-step decisions when they change."""

    def __init__(self, body, config=None):
        if config is None:
            config = config_class(body)()
        self.body, self.config = body, config
        zeta = _check_config(config, body)
        self.input_names = input_names(body)
        self.output_names = output_names(body)
        engine = FreeEngine if body.kind == "free" else ClampedEngine
        self.engine = engine(body, config, zeta, self.input_names)
        self.inputs = dict.fromkeys(self.input_names, 0.0)
        self._u = np.zeros(len(self.input_names))
        self._f = np.asarray(body.natural_frequencies_hz, float)
        if body.kind == "free":
            L = output_layout(self.engine.dyn.nf, len(body.interfaces))
            per = [L.points.start + 18 * k + j for k in range(len(body.interfaces)) for j in range(9)]
            self._columns = np.r_[per, L.frame_origin, L.frame_origin_velocity, L.quaternion, L.omega, L.alpha,
                                  L.com_position, L.com_velocity, L.max_elastic_displacement]
            self._rotation = np.r_[L.quaternion, L.omega, L.alpha]
        self._last_split = None
        self.messages = [f"model: {body.summary()}", *body.messages,
                         f"damping ratio {zeta:g}" + (" (the body's)" if config.damping_ratio == -1.0 else "")]

    @property
    def time(self) -> float:
        return self.engine.t

    # ---- inputs
    def set_inputs(self, **inputs: float) -> None:
        index = {n: k for k, n in enumerate(self.input_names)}
        for name, value in inputs.items():
            if name not in index:
                raise ParameterError(name, "unknown input", ", ".join(self.input_names))
            if not finite_input(value):
                if isinstance(value, (int, float, np.floating, np.integer)):
                    raise NonFiniteError(name, f"input is {shown(value)}; allowed: a finite number")
                raise ParameterError(name, f"input is {shown(value)}", "a finite number")
        u = self._u.copy()
        for name, value in inputs.items():
            u[index[name]] = float(value)
        self._u = u
        self.inputs.update({k: float(v) for k, v in inputs.items()})
        self.engine.hold(u)

    def set_input_vector(self, values) -> None:
        """All inputs at once, in input_names order."""
        values = list(values)
        if len(values) != len(self.input_names):
            raise ParameterError("inputs", f"{len(values)} values", f"{len(self.input_names)} values")
        # the FMU's per-step path (finite floats, checked at once); anything else set_inputs checks and names
        if all(type(v) is float for v in values) and all(map(math.isfinite, values)):
            self._u = np.array(values)
            self.inputs = dict(zip(self.input_names, values))
            self.engine.hold(self._u)
            return
        self.set_inputs(**dict(zip(self.input_names, values)))

    # ---- stepping
    def step(self, step_size: float) -> None:
        """Advance by step_size (s) with the inputs held; the state is unchanged on failure."""
        if not (finite_input(step_size) and step_size > 0):
            raise ParameterError("step_size", f"got {shown(step_size)}", "> 0 s")
        with np.errstate(all="ignore"):          # overflow is found by value, whatever numpy's error mode
            n, why = self.engine.split(float(step_size))
            if n != self._last_split:
                self.messages.append(f"t = {self.time:.6g} s: communication step {step_size:g} s in {n} internal "
                                     f"step(s) of {step_size / n:.4g} s: {why}")
                self._last_split = n
            try:
                ok = self.engine.advance(float(step_size), n)
            except (ArithmeticError, ValueError, np.linalg.LinAlgError):
                ok = False
        if not ok:
            raise self._overflow("the state")

    def _overflow(self, what: str) -> NonFiniteError:
        name = self.engine.culprit()
        if name is not None:
            return NonFiniteError(name, f"{self.inputs[name]:g} makes {what} overflow (not finite) at t = "
                                  f"{self.time:.6g} s; allowed: inputs within the model's range")
        c = self.config
        if self.body.kind == "free" and any(getattr(c, n) for n in _INITIAL):
            name = max(_INITIAL, key=lambda n: abs(getattr(c, n)))
            return NonFiniteError(name, f"{getattr(c, name):g} makes {what} overflow (not finite) at t = "
                                  f"{self.time:.6g} s")
        return NonFiniteError("state", f"{what} overflows (not finite) at t = {self.time:.6g} s")

    # ---- outputs
    def output_vector(self, include_deferred: bool = True) -> np.ndarray:
        """All outputs in output_names order (max_elastic_displacement = -1 when include_deferred is False)."""
        with np.errstate(all="ignore"):
            if self.body.kind == "free":
                raw = self.engine.outputs(include_deferred)
                y = np.concatenate([raw[self._columns], _frame_global(raw[self._rotation]), self._f])
            else:
                y = self.engine.output_vector()
        # y.y is finite when y is (unless |y| > 1e154): the element-wise check only then
        if not y.dot(y) < math.inf and not np.all(np.isfinite(y)):
            bad = [self.output_names[i] for i in np.flatnonzero(~np.isfinite(y))]
            raise self._overflow(", ".join(bad[:4]))
        return y

    def deferred_output_vector(self) -> list[float]:
        return [float(self.output_vector()[self.output_names.index("max_elastic_displacement")])]

    def outputs(self) -> dict[str, float]:
        return dict(zip(self.output_names, self.output_vector().tolist()))

    def lti_probe(self):
        """A clamped body's maps as flexfmu.native.lti's Probe (flexfmu.body.lti_probe), for
        ``LtiModel.from_clamped_body``: the native FMU's linear system is extracted from them."""
        from flexfmu.body.lti_probe import clamped_body_probe      # on use: importing the simulator loads no ctypes
        return clamped_body_probe(self)

    # ---- state (JSON)
    def get_state(self) -> dict:
        return {"kind": self.body.kind, **self.engine.get(), "inputs": dict(self.inputs), "config": asdict(self.config)}

    def set_state(self, data: dict) -> None:
        if data.get("config") != asdict(self.config) or data.get("kind") != self.body.kind:
            raise ParameterError("FMUstate", "was taken with other parameters or another body",
                                 "a state of this configuration")
        inputs = data.get("inputs")
        if not isinstance(inputs, dict) or set(inputs) != set(self.input_names):
            raise ParameterError("FMUstate", "inputs of another body", "a state of this body")
        self.engine.put(data)
        self.set_inputs(**inputs)
