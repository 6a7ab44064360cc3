"""Platform: a floating box as a rigid body with 6 DOF in linear seakeeping form, the left-hand side of
the minimal Cummins model (what Platform.fmu wraps; variable names are the FMU's).

    (M_rb + A) xi_ddot = Q_wave + Q_hydro + Q_payload + Q_pto

xi = (x, y, z, rx, ry, rz): displacement and small rotation of the waterplane centre O (global axes;
to first order the body axes).  M_rb is the rigid-body mass matrix about O, A the constant added mass
(flexfmu.wec.wave.FloatingBox, from the same box parameters as Hydrostatics); with hydrodynamics = "bem"
A is the infinite-frequency added mass A_inf of the box's BEM database (flexfmu.wec.bem, 6x6 with its
surge-pitch and sway-roll coupling), the frequency-dependent rest being Hydrostatics' radiation memory.  Wave and hydrostatic
loads act about O; the payload (a harvester's clamp reactions) and PTO (its stator) loads act
about the mount point r_m and are moved to O here.  The mount point's motion is an output, for a
structure on a moving base (FFRBeam's base_a/base_w/base_dw):
a_m = xi_ddot_t + alpha x r_m, omega, alpha (linear kinematics).

Inputs are held over each step, for which the step is exact (constant acceleration), so the work
each input group does on the platform is exact too (the work_* outputs): the platform's own energy
balance d(kinetic_energy) = sum of work_* holds to rounding.

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) the platform accounts for the work each
input group does on it (what the wave's work in the audit is), its kinetic energy, and its motion.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np

from flexfmu.errors import DivergenceError, NonFiniteError
from flexfmu.wec.hydrostatics import BOX_INFO, BOX_NAMES, checked_box
from flexfmu.core.checks import blame_inputs
from flexfmu.wec.components import (AXES, HYDRODYNAMICS_INFO, bem_added_mass_inf, bem_database, box_parameters,
                                    check_config, check_finite_build, check_hydrodynamics, check_inputs,
                                    check_state_config, checked_outputs, check_step, vector_info)
from flexfmu.core.vec3 import cross as _cross
from flexfmu.wec.roles import KINETIC, Panel, Role, Term, amplitude, change, summary_line
from flexfmu.wec.wave import BoxParameters

GROUPS = ("wave", "hydro", "payload", "pto")
INPUT_NAMES = tuple(f"{g}_{k}_{a}" for g in GROUPS for k in "FM" for a in AXES)
OUTPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"rot_{a}" for a in AXES)
                + tuple(f"vel_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES)
                + tuple(f"acc_{a}" for a in AXES) + tuple(f"alpha_{a}" for a in AXES)
                + tuple(f"mount_a_{a}" for a in AXES) + tuple(f"mount_v_{a}" for a in AXES)
                + ("kinetic_energy",) + tuple(f"work_{g}" for g in GROUPS))
_DIVERGENCE_LIMIT = 1e3   # m or rad: far outside the linear model


@dataclass(frozen=True)
class PlatformConfig(BoxParameters):
    """Parameters, named and defaulted as in the FMU: the box's (flexfmu.wec.wave.BoxParameters), then these."""

    mount_x: float = 0.0
    mount_y: float = 0.0
    mount_z: float = 0.15
    hydrodynamics: str = "constant"

    @property
    def mount(self) -> np.ndarray:
        return np.array([self.mount_x, self.mount_y, self.mount_z])


def mass_matrix(cfg: PlatformConfig) -> np.ndarray:
    """M_rb + A about O (6x6)."""
    check_config(cfg)                      # before the cache: it hashes the config
    check_hydrodynamics(cfg)
    return _mass_matrix(cfg)


@lru_cache(maxsize=16)
def _mass_matrix(cfg: PlatformConfig) -> np.ndarray:
    box = checked_box(cfg)
    try:
        with np.errstate(all="ignore"):
            A = box.added_mass() if cfg.hydrodynamics == "constant" else bem_added_mass_inf(bem_database(
                box_parameters(cfg)))
            M = box.rigid_mass_matrix() + A
            M_inv = np.linalg.inv(M)
    except (OverflowError, ZeroDivisionError, ValueError, np.linalg.LinAlgError):
        M = M_inv = np.array([np.nan])
    check_finite_build(cfg, BOX_NAMES, M, M_inv)
    return M


class PlatformSimulator:
    """State (xi, xi_dot, t, work per input group) and step of one Platform instance."""

    def __init__(self, config: PlatformConfig = PlatformConfig()):
        self.config = config
        self.M = mass_matrix(config)
        self.M_inv = np.linalg.inv(self.M)
        self.r_m = config.mount
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
        """Generalised loads about O of each input group, (4, 6)."""
        v = self.inputs
        Q = np.zeros((len(GROUPS), 6))
        for i, g in enumerate(GROUPS):
            F = np.array([v[f"{g}_F_{a}"] for a in AXES])
            M = np.array([v[f"{g}_M_{a}"] for a in AXES])
            if g in ("payload", "pto"):
                M = M + _cross(self.r_m, F)
            Q[i, :3], Q[i, 3:] = F, M
        return Q

    def acceleration(self) -> np.ndarray:
        return self.M_inv @ self.group_loads().sum(axis=0)

    def step(self, step_size: float) -> None:
        """Advance by step_size with the inputs held: constant acceleration, exact."""
        check_step(step_size)
        h = step_size
        with np.errstate(all="ignore"):                     # overflow: checked by value below
            Q = self.group_loads()
            acc = self.M_inv @ Q.sum(axis=0)
            d_xi = h * self.xi_dot + 0.5 * h * h * acc
            xi, xi_dot = self.xi + d_xi, self.xi_dot + h * acc
            size = float(np.max(np.abs(np.concatenate([xi, xi_dot]))))
            work = self.work + Q @ d_xi
        if not np.isfinite(size) or not np.all(np.isfinite(work)) or not np.isfinite(self.t + h):
            raise self._overflow(h)                          # the state is still that of the step's start
        if size > _DIVERGENCE_LIMIT:
            raise DivergenceError("state", f"diverged at t = {self.t + h:.6g} s (|xi|, |xi_dot| up to {size:.3g})",
                                 "a communication step inside the coupling-stability limit "
                                 "(docs/wave_converter.md)")
        self.work = work
        self.xi, self.xi_dot, self.t = xi, xi_dot, self.t + h

    def _overflow(self, h: float) -> NonFiniteError:
        """NonFiniteError naming the input that alone makes the step overflow (else the step size or the state)."""
        if not np.isfinite(self.t + h):
            return NonFiniteError("step_size", f"the time {self.t!r} s + {h!r} s overflows")

        def increments(inputs):
            saved = self.inputs
            self.inputs = inputs
            try:
                Q = self.group_loads()
                acc = self.M_inv @ Q.sum(axis=0)
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
        return checked_outputs(self)

    def _outputs(self) -> dict[str, float]:
        acc = self.acceleration()
        alpha, omega = acc[3:], self.xi_dot[3:]
        mount_a = acc[:3] + _cross(alpha, self.r_m)
        mount_v = self.xi_dot[:3] + _cross(omega, self.r_m)
        values = np.concatenate([self.xi, self.xi_dot, acc, mount_a, mount_v,
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


_GROUP_TEXT = {"wave": ("wave excitation", "about O", "global"),
               "hydro": ("hydrostatic restoring and radiation", "about O", "global"),
               "payload": ("payload (harvester clamp reaction)", "about the mount point", "body"),
               "pto": ("PTO stator", "about the mount point", "body")}

#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    **BOX_INFO,
    **{f"mount_{a}": ("m", f"payload mount point from the waterplane centre O, {a}") for a in AXES},
    "hydrodynamics": HYDRODYNAMICS_INFO,
    **{k: v for g, (text, about, frame) in _GROUP_TEXT.items()
       for k, v in {**vector_info(f"{g}_F", "N", f"{text} force", frame),
                    **vector_info(f"{g}_M", "N.m", f"{text} moment {about}", frame)}.items()},
    **vector_info("pos", "m", "displacement of the waterplane centre O", "global"),
    **{f"rot_{a}": ("", f"small rotation about global {a}, rad") for a in AXES},
    **vector_info("vel", "m/s", "velocity of O", "global"),
    **vector_info("omega", "rad/s", "angular velocity", "global"),
    **vector_info("acc", "m/s2", "acceleration of O (for the inputs held in the last step)", "global"),
    **vector_info("alpha", "rad/s2", "angular acceleration (for the inputs held in the last step)", "global"),
    **vector_info("mount_a", "m/s2", "acceleration of the mount point", "body"),
    **vector_info("mount_v", "m/s", "velocity of the mount point", "body"),
    "kinetic_energy": ("J", "kinetic energy including the added mass, 1/2 xi_dot^T (M_rb + A) xi_dot (bem: A_inf)"),
    **{f"work_{g}": ("J", f"work done on the platform by the {_GROUP_TEXT[g][0]} inputs since t = 0 (exact for "
                          "inputs held over each step)") for g in GROUPS},
}


class PlatformRole(Role):
    """The floating body: the work done on it by each input group, its kinetic energy, its motion."""

    kind = "platform"
    #: what the summary and the chart call the body
    label = "platform"

    def input_work(self, m, r, input_name):
        group = input_name.split("_", 1)[0]
        return r.col(m.name, f"work_{group}") if input_name in INPUT_NAMES else None

    def energy(self, m, r):
        return [Term(KINETIC, "kinetic: platform incl. added mass" + m.suffix, change(r.col(m.name, "kinetic_energy")))]

    def diagnostics(self, m, r):
        # exact for held inputs: what is left is rounding
        ke, work = r.col(m.name, "kinetic_energy"), [r.col(m.name, f"work_{g}") for g in GROUPS]
        return {"platform: d(kinetic) - sum of work_*" + m.suffix: change(ke) - sum(change(w) for w in work)}

    def summary(self, m, r, sel):
        amp = lambda v: amplitude(r.col(m.name, v), sel)   # noqa: E731
        return [summary_line(f"{self.label}{m.suffix} surge, sway, heave",
                             f"{amp('pos_x'):.4g}, {amp('pos_y'):.4g}, {amp('pos_z'):.4g} m"),
                summary_line(f"{self.label}{m.suffix} roll, pitch, yaw", f"{math.degrees(amp('rot_x')):.4g}, "
                             f"{math.degrees(amp('rot_y')):.4g}, {math.degrees(amp('rot_z')):.4g} deg")]

    def panels(self, m, r):
        c = lambda v: r.col(m.name, v)   # noqa: E731
        return [Panel("translation", f"{self.label} translation", "m",
                      [(c(f"pos_{a}"), {"label": label + m.suffix}) for a, label in (("z", "heave"), ("x", "surge"),
                                                                                     ("y", "sway"))]),
                Panel("rotation", f"{self.label} rotation", "deg",
                      [(np.degrees(c(f"rot_{a}")), {"label": label + m.suffix})
                       for a, label in (("x", "roll"), ("y", "pitch"), ("z", "yaw"))])]


#: what the platform is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = PlatformRole()
