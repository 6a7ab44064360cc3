"""AbsorberHydro: hydrostatic restoring, radiation memory and quadratic drag on the point absorber's hull (what
AbsorberHydro.fmu wraps; variable names are the FMU's), the right-hand side of Cummins' equation whose left-hand side
M_total xi_ddot is the float's (flexfmu.wec.absorber.float_body):

    F = -C xi - C_r x_r - drag,     x_r' = A_r x_r + B_r xi_dot,
    drag_i = 1/2 rho Cd_i A_i |xi_dot_i| xi_dot_i   (drag = true; i over the six DOFs)

C, (A_r, B_r, C_r) from flexfmu.wec.absorber.hull (about O, global axes; the memory over all six DOFs).  Each step
advances the memory with the velocity input held over it, by the exact zero-order hold (Phi, Gamma) =
RadiationModel.discretize(h), recomputed only when the step changes beyond rounding (flexfmu.core.step_size):
x_r <- Phi x_r + Gamma xi_dot.  The outputs are those of the inputs as set now (F follows xi and, through the drag,
xi_dot directly; the memory force depends on the state only).  drag_power = sum_i drag_i xi_dot_i >= 0 (W) is the
power the drag dissipates.  A drag area of a rotation is the area times the cube of its arm (m^5).

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) it accounts for the hydrostatic potential
energy, the signed work of the radiation memory force and the energy the drag dissipates, of the motion at its
inputs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexfmu.core.step_size import same_step
from flexfmu.errors import DivergenceError, NonFiniteError, require
from flexfmu.wec.components import (AXES, DOF6, MemorylessSimulator, check_config, check_state_config, check_step,
                                    vector_info)
from flexfmu.wec.hydrostatics import RADIATION_MEMORY_TERM
from flexfmu.wec.roles import DISSIPATED, POTENTIAL, Role, Term, change, integral

INPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"rot_{a}" for a in AXES)
               + tuple(f"vel_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES))
OUTPUT_NAMES = tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES) + ("drag_power",)
_XI, _XI_DOT = slice(0, 6), slice(6, 12)
CD_NAMES = tuple(f"drag_coefficient_{d}" for d in DOF6)
AREA_NAMES = tuple(f"drag_area_{d}" for d in DOF6)
_DIVERGENCE_LIMIT = 1e12   # memory state: far beyond any linear-wave motion


@dataclass(frozen=True)
class AbsorberHydroConfig:
    """Parameters, named and defaulted as in the FMU (areas: the cylinder's, radius 5 m, draft 3 m)."""

    drag: bool = True
    drag_coefficient_x: float = 1.0
    drag_coefficient_y: float = 1.0
    drag_coefficient_z: float = 1.0
    drag_coefficient_rx: float = 0.0
    drag_coefficient_ry: float = 0.0
    drag_coefficient_rz: float = 0.0
    drag_area_x: float = 30.0                  # 2 r d, m^2
    drag_area_y: float = 30.0
    drag_area_z: float = math.pi * 5.0**2      # pi r^2, m^2
    drag_area_rx: float = 0.0                  # m^5
    drag_area_ry: float = 0.0
    drag_area_rz: float = 0.0


def _check(cfg: AbsorberHydroConfig) -> None:
    check_config(cfg)
    for name in CD_NAMES + AREA_NAMES:
        require(getattr(cfg, name) >= 0, name, f"got {getattr(cfg, name)!r}",
                ">= 0" + (" m^2 (m^5 for a rotation)" if name in AREA_NAMES else ""))


def drag_rates(cfg: AbsorberHydroConfig, rho: float) -> np.ndarray:
    """1/2 rho Cd_i A_i per DOF (6,); zeros when drag is off."""
    if not cfg.drag:
        return np.zeros(6)
    return np.array([0.5 * rho * getattr(cfg, c) * getattr(cfg, a) for c, a in zip(CD_NAMES, AREA_NAMES)])


class AbsorberHydroSimulator(MemorylessSimulator):
    """Inputs (the float's motion), radiation memory state and outputs of one AbsorberHydro instance."""

    INPUTS = INPUT_NAMES

    def __init__(self, config: AbsorberHydroConfig = AbsorberHydroConfig()):
        from flexfmu.wec.absorber.hull import absorber_hull
        _check(config)
        super().__init__(config)
        hull = absorber_hull()
        self.C = hull.C
        self.radiation = hull.radiation
        self.rates = drag_rates(config, hull.rho)
        if not np.all(np.isfinite(self.rates)):
            name = max(CD_NAMES + AREA_NAMES, key=lambda n: getattr(config, n))
            from flexfmu.errors import ParameterError
            raise ParameterError(name, f"{getattr(config, name)!r} makes the drag rate overflow (not finite)",
                                 "values whose product with rho / 2 stays within the floating-point range")
        self.memory_state = np.zeros(self.radiation.order)
        self._h = None                      # the step size Phi, Gamma were computed for
        self.Phi = self.Gamma = None

    def step(self, step_size: float) -> None:
        check_step(step_size)
        h = float(step_size)
        # a host's last-bit variants of one step reuse its discretisation (flexfmu.core.step_size: error bound)
        if self._h is None or not same_step(self._h, h):
            self.Phi, self.Gamma = self.radiation.discretize(h)
            self._h = h
        xi_dot = np.array([self.inputs[n] for n in INPUT_NAMES[_XI_DOT]])
        with np.errstate(all="ignore"):                     # overflow: checked by value below
            x = self.Phi @ self.memory_state + self.Gamma @ xi_dot
        size = float(np.max(np.abs(x))) if x.size else 0.0
        if not math.isfinite(size):
            raise NonFiniteError("step_size", f"{step_size!r} s makes the radiation memory state overflow at t = "
                                              f"{self.t!r} s; allowed: a smaller communication step")
        if size > _DIVERGENCE_LIMIT:
            raise DivergenceError("state", f"the radiation memory diverged at t = {self.t + h:.6g} s",
                                  "a communication step inside the coupling-stability limit "
                                  "(examples/point_absorber/README.md)")
        super().step(step_size)
        self.memory_state = x

    def memory_force(self) -> np.ndarray:
        """C_r x_r (the force on the float is minus this), (6,)."""
        return self.radiation.C_r @ self.memory_state

    def drag_force(self, xi_dot: np.ndarray) -> np.ndarray:
        """drag_i = 1/2 rho Cd_i A_i |xi_dot_i| xi_dot_i (the force on the float is minus this), (6,)."""
        return self.rates * np.abs(xi_dot) * xi_dot

    def _outputs(self) -> dict[str, float]:
        v = self.inputs
        xi = np.array([v[n] for n in INPUT_NAMES[_XI]])
        xi_dot = np.array([v[n] for n in INPUT_NAMES[_XI_DOT]])
        drag = self.drag_force(xi_dot)
        force = -self.C @ xi - self.memory_force() - drag
        return dict(zip(OUTPUT_NAMES, force.tolist() + [float(drag @ xi_dot)]))

    def get_state(self) -> dict:
        return {**super().get_state(), "memory": self.memory_state.tolist()}

    def set_state(self, data: dict) -> None:
        check_state_config(data, self.config)
        x = np.array(data["memory"], float)
        require(x.shape == self.memory_state.shape, "FMUstate", f"radiation memory of shape {x.shape}",
                f"a state of this instance's configuration ({self.memory_state.size} memory states)")
        self.memory_state = x
        super().set_state(data)


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "drag": ("", "true: quadratic drag 1/2 rho Cd_i A_i |xi_dot_i| xi_dot_i in each DOF; false: none"),
    **{f"drag_coefficient_{d}": ("", f"drag coefficient Cd in {d}, >= 0") for d in DOF6},
    **{f"drag_area_{d}": ("m2", f"drag area in {d}, >= 0") for d in AXES},
    **{f"drag_area_r{a}": ("", f"drag area in rotation about {a}: the area times the cube of its arm, m^5, >= 0")
       for a in AXES},
    **vector_info("pos", "m", "displacement of O (the float's waterplane centre)", "global"),
    **{f"rot_{a}": ("", f"small rotation about global {a}, rad") for a in AXES},
    **vector_info("vel", "m/s", "velocity of O", "global"),
    **vector_info("omega", "rad/s", "angular velocity", "global"),
    **vector_info("F", "N", "hydrostatic restoring, radiation memory and drag force on the float", "global"),
    **vector_info("M", "N.m", "hydrostatic restoring, radiation memory and drag moment on the float about O",
                  "global"),
    "drag_power": ("W", "power dissipated by the drag, sum_i drag_i xi_dot_i, >= 0"),
}


class AbsorberHydroRole(Role):
    """Hydrostatic potential energy 1/2 xi^T C xi, the signed work of the radiation memory force (radiated plus what
    the memory still holds, as flexfmu.wec.hydrostatics' bem mode) and the energy the drag dissipated, of the motion
    at its inputs.  The memory force C_r x_r is recovered from the recorded outputs: F + C xi + drag(xi_dot)."""

    kind = "hydro"

    def _energies(self, m, r):
        from flexfmu.wec.absorber.hull import absorber_hull
        hull = absorber_hull()
        xi = np.hstack([r.input_vec(m.name, "pos_{}"), r.input_vec(m.name, "rot_{}")])
        xi_dot = np.hstack([r.input_vec(m.name, "vel_{}"), r.input_vec(m.name, "omega_{}")])
        force = np.hstack([r.vec(m.name, "F_{}"), r.vec(m.name, "M_{}")])
        drag = drag_rates(m.config, hull.rho) * np.abs(xi_dot) * xi_dot
        memory = -force - xi @ hull.C.T - drag
        pe = 0.5 * np.einsum("ij,jk,ik->i", xi, hull.C, xi)
        return pe, np.einsum("ij,ij->i", xi_dot, memory), np.asarray(r.col(m.name, "drag_power"), float)

    def energy(self, m, r):
        pe, memory_power, drag_power = r.memo((m.name, "energies"), lambda: self._energies(m, r))
        return [Term(POTENTIAL, "potential: hydrostatic" + m.suffix, change(pe)),
                Term(DISSIPATED, RADIATION_MEMORY_TERM + m.suffix, integral(memory_power, r.t)),
                Term(DISSIPATED, "dissipated: drag" + m.suffix, integral(drag_power, r.t))]

    def diagnostics(self, m, r):
        # the work the held force did on the float against the energy of the motion: the coupling error of the
        # held force (first order in the step)
        fed = r.work_on_target(m.name, "F_x")
        if fed is None:
            return {}
        _, inp, work = fed
        pe, memory_power, drag_power = r.memo((m.name, "energies"), lambda: self._energies(m, r))
        label = f"hydro interface: work_{inp.split('_', 1)[0]} + dPE + radiated + drag{m.suffix}"
        return {label: change(work) + change(pe) + integral(memory_power + drag_power, r.t)}


#: what AbsorberHydro is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = AbsorberHydroRole()
