"""AbsorberFloat: the point absorber's hull as a rigid body in linear seakeeping (what AbsorberFloat.fmu wraps;
variable names are the FMU's), the left-hand side of Cummins' equation

    M_total xi_ddot = Q_wave + Q_hydro + Q_pto + Q_mooring,      M_total = M_rb + A_inf

(flexfmu.wec.absorber.hull: O the waterplane centre on the axis, global axes, xi = (x, y, z, rx, ry, rz) of O;
every input group a force and a moment about O, global axes).  heave_only = true restrains the other five DOFs:
xi_ddot = (0, 0, Q_z / M_total[2, 2], 0, 0, 0).

The inputs are held over each step, for which the step is exact (constant acceleration), as the Platform's
(flexfmu.wec.platform):  d = h xi_dot + h^2 / 2 xi_ddot,  work_g += Q_g . d,  xi += d,  xi_dot += h xi_ddot;
so the float's own balance d(kinetic_energy) = sum of work_* holds to rounding (with heave_only too: the restrained
DOFs do not move, so the loads along them do no work).

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) the float is the platform: it accounts for the
work each input group does on it, its kinetic energy and its motion.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from flexfmu.errors import DivergenceError, NonFiniteError
from flexfmu.core.checks import blame_inputs
from flexfmu.wec.components import AXES, check_config, check_inputs, check_state_config, check_step, vector_info
from flexfmu.wec.platform import PlatformRole
from flexfmu.wec.roles import KINETIC, Term, change

GROUPS = ("wave", "hydro", "pto", "mooring")
INPUT_NAMES = tuple(f"{g}_{k}_{a}" for g in GROUPS for k in "FM" for a in AXES)
OUTPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"rot_{a}" for a in AXES)
                + tuple(f"vel_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES)
                + tuple(f"acc_{a}" for a in AXES) + tuple(f"alpha_{a}" for a in AXES)
                + ("kinetic_energy",) + tuple(f"work_{g}" for g in GROUPS))
_DIVERGENCE_LIMIT = 1e3   # m or rad: far outside the linear model


@dataclass(frozen=True)
class AbsorberFloatConfig:
    """Parameters, named and defaulted as in the FMU."""

    heave_only: bool = False


class AbsorberFloatSimulator:
    """State (xi, xi_dot, work per input group, t) and step of one AbsorberFloat instance."""

    def __init__(self, config: AbsorberFloatConfig = AbsorberFloatConfig()):
        from flexfmu.wec.absorber.hull import absorber_hull
        check_config(config)
        self.config = config
        self.M = absorber_hull().M_total
        self.M_inv = np.linalg.inv(self.M)
        self.xi = np.zeros(6)
        self.xi_dot = np.zeros(6)
        self.t = 0.0
        self.work = np.zeros(len(GROUPS))
        self.inputs = dict.fromkeys(INPUT_NAMES, 0.0)

    @property
    def time(self) -> float:
        return self.t

    def set_inputs(self, **inputs: float) -> None:
        check_inputs(inputs, INPUT_NAMES)
        self.inputs.update({k: float(v) for k, v in inputs.items()})

    def group_loads(self) -> np.ndarray:
        """Generalised loads about O of each input group, (4, 6), global axes."""
        v = self.inputs
        return np.array([[v[n] for n in INPUT_NAMES[6 * i:6 * i + 6]] for i in range(len(GROUPS))])

    def _acceleration(self, Q: np.ndarray) -> np.ndarray:
        if self.config.heave_only:
            acc = np.zeros(6)
            acc[2] = Q[2] / self.M[2, 2]
            return acc
        return self.M_inv @ Q

    def acceleration(self) -> np.ndarray:
        return self._acceleration(self.group_loads().sum(axis=0))

    def step(self, step_size: float) -> None:
        """Advance by step_size with the inputs held: constant acceleration, exact."""
        check_step(step_size)
        h = step_size
        with np.errstate(all="ignore"):                     # overflow: checked by value below
            Q = self.group_loads()
            acc = self._acceleration(Q.sum(axis=0))
            d_xi = h * self.xi_dot + 0.5 * h * h * acc
            xi, xi_dot = self.xi + d_xi, self.xi_dot + h * acc
            size = float(np.max(np.abs(np.concatenate([xi, xi_dot]))))
            work = self.work + Q @ d_xi
        if not np.isfinite(size) or not np.all(np.isfinite(work)) or not np.isfinite(self.t + h):
            raise self._overflow(h)                          # the state is still that of the step's start
        if size > _DIVERGENCE_LIMIT:
            raise DivergenceError("state", f"diverged at t = {self.t + h:.6g} s (|xi|, |xi_dot| up to {size:.3g})",
                                  "a communication step inside the coupling-stability limit "
                                  "(examples/point_absorber/README.md)")
        self.work = work
        self.xi, self.xi_dot, self.t = xi, xi_dot, self.t + h

    def _overflow(self, h: float) -> NonFiniteError:
        """NonFiniteError naming the input that alone makes the step overflow (else the step size)."""
        if not np.isfinite(self.t + h):
            return NonFiniteError("step_size", f"the time {self.t!r} s + {h!r} s overflows")

        def increments(inputs):
            saved = self.inputs
            self.inputs = inputs
            try:
                Q = self.group_loads()
                acc = self._acceleration(Q.sum(axis=0))
                return np.concatenate([0.5 * h * h * acc, h * acc, Q @ (0.5 * h * h * acc)])
            finally:
                self.inputs = saved
        name = blame_inputs(dict(self.inputs), increments)
        if name is None or self.inputs.get(name, 0.0) == 0.0:
            return NonFiniteError("step_size", f"{h!r} s makes the state overflow (not finite) at t = {self.t!r} "
                                               "s: the state diverged; allowed: a smaller communication step")
        return NonFiniteError(name, f"{self.inputs[name]:.6g} makes the state overflow (not finite) at t = "
                                    f"{self.t!r} s: the state diverged; allowed: inputs within the model's range")

    def outputs(self) -> dict[str, float]:
        with np.errstate(all="ignore"):
            values = self._outputs()
        if not np.isfinite(sum(values.values())):
            raise self._overflow(0.0)
        return values

    def _outputs(self) -> dict[str, float]:
        values = np.concatenate([self.xi, self.xi_dot, self.acceleration(),
                                 [0.5 * self.xi_dot @ self.M @ self.xi_dot], self.work])
        return dict(zip(OUTPUT_NAMES, values.tolist()))

    def get_state(self) -> dict:
        return {"xi": self.xi.tolist(), "xi_dot": self.xi_dot.tolist(), "t": self.t, "work": self.work.tolist(),
                "inputs": dict(self.inputs), "config": asdict(self.config)}

    def set_state(self, data: dict) -> None:
        check_state_config(data, self.config)
        self.xi = np.array(data["xi"], float)
        self.xi_dot = np.array(data["xi_dot"], float)
        self.t = float(data["t"])
        self.work = np.array(data["work"], float)
        self.inputs = dict(data["inputs"])


_GROUP_TEXT = {"wave": "wave excitation", "hydro": "hydrostatic restoring, radiation memory and drag",
               "pto": "PTO", "mooring": "mooring lines"}

#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "heave_only": ("", "true: surge, sway, roll, pitch and yaw restrained (heave alone); false: all six DOFs"),
    **{k: v for g, text in _GROUP_TEXT.items()
       for k, v in {**vector_info(f"{g}_F", "N", f"{text} force on the float", "global"),
                    **vector_info(f"{g}_M", "N.m", f"{text} moment on the float about O", "global")}.items()},
    **vector_info("pos", "m", "displacement of O (the waterplane centre on the axis)", "global"),
    **{f"rot_{a}": ("", f"small rotation about global {a}, rad") for a in AXES},
    **vector_info("vel", "m/s", "velocity of O", "global"),
    **vector_info("omega", "rad/s", "angular velocity", "global"),
    **vector_info("acc", "m/s2", "acceleration of O for the inputs as set now", "global"),
    **vector_info("alpha", "rad/s2", "angular acceleration for the inputs as set now", "global"),
    "kinetic_energy": ("J", "kinetic energy with the infinite-frequency added mass, 1/2 xi_dot^T (M_rb + A_inf) "
                            "xi_dot"),
    **{f"work_{g}": ("J", f"work done on the float by the {text} inputs since t = 0 (exact for inputs held over "
                          "each step)") for g, text in _GROUP_TEXT.items()},
}


class AbsorberFloatRole(PlatformRole):
    """The floating body (the platform of the system): the work done on it by each input group, its kinetic
    energy, its motion."""

    label = "float"

    def input_work(self, m, r, input_name):
        group = input_name.split("_", 1)[0]
        return r.col(m.name, f"work_{group}") if input_name in INPUT_NAMES else None

    def energy(self, m, r):
        return [Term(KINETIC, "kinetic: float incl. added mass" + m.suffix, change(r.col(m.name, "kinetic_energy")))]

    def diagnostics(self, m, r):
        # exact for held inputs: what is left is rounding
        ke, work = r.col(m.name, "kinetic_energy"), [r.col(m.name, f"work_{g}") for g in GROUPS]
        return {"float: d(kinetic) - sum of work_*" + m.suffix: change(ke) - sum(change(w) for w in work)}


#: what the float is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = AbsorberFloatRole()
