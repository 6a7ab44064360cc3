"""Hydrostatics: linear hydrostatic restoring and linear radiation damping of a floating box, the
force side of the minimal Cummins model (what Hydrostatics.fmu wraps; variable names are the FMU's).

    F = -C xi - B xi_dot        (about the waterplane centre O, global axes)

with the constant, diagonal coefficients of flexfmu.wec.wave.FloatingBox.  Its constant added mass A
belongs to the left-hand side (M + A) xi_ddot of Cummins' equation and is carried by the Platform
(platform_sim), which computes it from the same box parameters: moved to the body for stability,
as WEC-Sim does (a delayed added-mass force is unstable in co-simulation whenever A > M).
Memoryless: the outputs follow the inputs (direct feedthrough); no convolution memory.

hydrodynamics = "bem" replaces both coefficients by the box's BEM database (flexfmu.wec.bem):

    F = -C_bem xi - F_mem,   F_mem = C_r x,   x_dot = A_r x + B_r xi_dot

C_bem the exactly integrated hydrostatic stiffness, F_mem the radiation memory of Cummins' equation (the
convolution of the retardation function with the velocity) as the state-space fit of
flexfmu.wec.radiation over all six DOFs, stepped with the exact zero-order hold of the velocity input held
over each communication step (RadiationMemory).  Its infinite-frequency part A_inf xi_ddot is the
Platform's (hydrodynamics = "bem" there too).  The memory state is part of get_state/set_state; the
zeta_* parameters are not used.  The memory force depends on the state only, so F still follows xi
directly but xi_dot only through the state.

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) it accounts for the hydrostatic potential
energy and the radiated energy (bem: the signed work of the memory force) of the motion at its inputs.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import math

import numpy as np

from flexfmu.errors import DivergenceError, NonFiniteError, require
from flexfmu.core.step_size import same_step
from flexfmu.wec.components import (AXES, HYDRODYNAMICS_INFO, MemorylessSimulator, bem_added_mass_inf, bem_database,
                                    box_parameters,
                                    check_config, check_finite_build, check_hydrodynamics, check_state_config,
                                    check_step, vector_info)
from flexfmu.wec.roles import DISSIPATED, POTENTIAL, Role, Term, change, integral
from flexfmu.wec.wave import BoxParameters, FloatingBox

INPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"rot_{a}" for a in AXES)
               + tuple(f"vel_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES)
               + tuple(f"acc_{a}" for a in AXES) + tuple(f"alpha_{a}" for a in AXES))
_XI, _XI_DOT, _XI_DDOT = slice(0, 6), slice(6, 12), slice(12, 18)
#: who carries the added mass (A, or A_inf with bem): "platform" (all of it: the rigid Platform) or "point"
#: (a flexible body carries the point-mass part of flexfmu.wec.barge.split_added_mass; this component applies
#: the rest, -A_lagged xi_ddot, from the acc_* / alpha_* inputs: the body's acceleration, one step behind)
ADDED_MASS = ("platform", "point")
OUTPUT_NAMES = (tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES)
                + ("potential_energy", "radiation_power"))
ZETA_NAMES = ("zeta_surge", "zeta_sway", "zeta_heave", "zeta_roll", "zeta_pitch", "zeta_yaw")


@dataclass(frozen=True)
class HydrostaticsConfig(BoxParameters):
    """Parameters, named and defaulted as in the FMU: the box's (flexfmu.wec.wave.BoxParameters), then these."""

    zeta_surge: float = 0.10
    zeta_sway: float = 0.10
    zeta_heave: float = 0.15
    zeta_roll: float = 0.05
    zeta_pitch: float = 0.10
    zeta_yaw: float = 0.10
    hydrodynamics: str = "constant"
    added_mass: str = "platform"

    def zeta(self) -> np.ndarray:
        return np.array([getattr(self, n) for n in ZETA_NAMES])


def coefficients(cfg: HydrostaticsConfig) -> tuple[np.ndarray, np.ndarray]:
    """(C, B), 6x6 each, of hydrodynamics = constant (whatever cfg.hydrodynamics says)."""
    check_config(cfg)                      # before the cache: it hashes the config
    return _coefficients(cfg)


def bem_model(cfg: HydrostaticsConfig):
    """(C, radiation model) of hydrodynamics = bem: the database's hydrostatic stiffness (6x6) and the
    radiation memory fitted over all six DOFs (flexfmu.wec.radiation.fit_radiation, its default tolerance)."""
    check_config(cfg)
    checked_box(cfg)                       # the same parameter checks as the constant model
    return _bem_model(box_parameters(cfg))


@lru_cache(maxsize=16)
def _bem_model(params):
    from flexfmu.wec import bem, radiation
    from flexfmu.wec.wave import DOF_NAMES
    ds = bem_database(params)
    return bem.coefficients(ds).C, radiation.fit_radiation(ds, DOF_NAMES)


@lru_cache(maxsize=16)
def _coefficients(cfg: HydrostaticsConfig) -> tuple[np.ndarray, np.ndarray]:
    box = checked_box(cfg)
    for name in ZETA_NAMES:
        require(0.0 <= getattr(cfg, name) < 10.0, name, f"got {getattr(cfg, name)!r}", "0 .. 10")
    try:
        with np.errstate(all="ignore"):                               # overflow: checked by value below
            C, B = box.hydrostatic_stiffness(), box.radiation_damping(cfg.zeta())
    except (OverflowError, ZeroDivisionError, ValueError):           # Python float arithmetic of the box
        C = B = np.array([np.nan])
    check_finite_build(cfg, BOX_NAMES, C, B)
    return C, B


BOX_NAMES = ("length", "beam", "draft", "z_G", "r_xx", "r_yy", "r_zz", "rho", "g")


def checked_box(cfg) -> FloatingBox:
    """cfg.box() checked: sizes, densities and gravity > 0, coefficients finite (else the parameter that
    overflows them is named), then stable in roll and pitch."""
    box = cfg.box()
    for name in ("length", "beam", "draft", "r_xx", "r_yy", "r_zz", "rho", "g"):
        require(getattr(cfg, name) > 0, name, f"got {getattr(cfg, name)!r}", "> 0")
    try:
        with np.errstate(all="ignore"):
            arrays = (box.hydrostatic_stiffness(), box.rigid_mass_matrix(), box.added_mass())
    except (OverflowError, ZeroDivisionError, ValueError):           # Python float arithmetic of the box
        arrays = (np.array([np.nan]),)
    check_finite_build(cfg, BOX_NAMES, *arrays)
    return box.check()


class HydrostaticsSimulator(MemorylessSimulator):
    """Inputs (platform motion) and outputs of one Hydrostatics instance."""

    INPUTS = INPUT_NAMES

    def __init__(self, config: HydrostaticsConfig = HydrostaticsConfig()):
        super().__init__(config)
        check_config(config)
        check_hydrodynamics(config)
        require(config.added_mass in ADDED_MASS, "added_mass", f"got {config.added_mass!r}", " | ".join(ADDED_MASS))
        self.memory = None                 # the radiation memory (hydrodynamics = bem), for the last step size
        if config.hydrodynamics == "constant":
            self.C, self.B = coefficients(config)
        else:
            self.C, self.radiation = bem_model(config)
            self.B = np.zeros((6, 6))
            self.memory_state = np.zeros(self.radiation.order)
        self.A_lagged = None
        if config.added_mass == "point":
            from flexfmu.wec.barge import split_added_mass
            A = (config.box().added_mass() if config.hydrodynamics == "constant"
                 else bem_added_mass_inf(bem_database(box_parameters(config))))
            self.A_lagged = split_added_mass(A)[1]

    def step(self, step_size: float) -> None:
        if self.config.hydrodynamics == "constant":
            return super().step(step_size)
        check_step(step_size)
        from flexfmu.wec.radiation import RadiationMemory
        # a host's last-bit variants of one step reuse its discretisation (flexfmu.core.step_size: error bound)
        if self.memory is None or not same_step(self.memory.h, float(step_size)):
            # the exact zero-order hold depends on the step: rediscretised when the master changes it
            self.memory = RadiationMemory(self.radiation, step_size)
        xi_dot = np.array([self.inputs[n] for n in INPUT_NAMES[_XI_DOT]])
        with np.errstate(all="ignore"):                     # overflow: checked by value below
            x = self.memory.Phi @ self.memory_state + self.memory.Gamma @ xi_dot
        size = float(np.max(np.abs(x)))
        if not math.isfinite(size):
            raise NonFiniteError("step_size", f"{step_size!r} s makes the radiation memory state overflow at t = "
                                              f"{self.t!r} s; allowed: a smaller communication step")
        if size > _DIVERGENCE_LIMIT:
            raise DivergenceError("state", f"the radiation memory diverged at t = {self.t + step_size:.6g} s",
                                  "a communication step inside the coupling-stability limit "
                                  "(docs/wave_converter.md)")
        super().step(step_size)
        self.memory_state = x

    def memory_force(self) -> np.ndarray:
        """F_mem = C_r x (the force on the body is -F_mem), (6,); zero for hydrodynamics = constant."""
        if self.config.hydrodynamics == "constant":
            return np.zeros(6)
        return self.radiation.C_r @ self.memory_state

    def _outputs(self) -> dict[str, float]:
        v = self.inputs
        xi = np.array([v[n] for n in INPUT_NAMES[_XI]])
        xi_dot = np.array([v[n] for n in INPUT_NAMES[_XI_DOT]])
        if self.config.hydrodynamics == "constant":
            force = -self.C @ xi - self.B @ xi_dot
            values = [0.5 * float(xi @ self.C @ xi), float(xi_dot @ self.B @ xi_dot)]
        else:
            f_mem = self.memory_force()
            force = -self.C @ xi - f_mem
            values = [0.5 * float(xi @ self.C @ xi), float(xi_dot @ f_mem)]
        if self.A_lagged is not None:
            force = force - self.A_lagged @ np.array([v[n] for n in INPUT_NAMES[_XI_DDOT]])
        values = force.tolist() + values
        return dict(zip(OUTPUT_NAMES, values))

    def get_state(self) -> dict:
        state = super().get_state()
        if self.config.hydrodynamics == "bem":
            state["memory"] = self.memory_state.tolist()
        return state

    def set_state(self, data: dict) -> None:
        check_state_config(data, self.config)
        if self.config.hydrodynamics == "bem":
            x = np.array(data["memory"], float)
            require(x.shape == self.memory_state.shape, "FMUstate", f"radiation memory of shape {x.shape}",
                    f"a state of this instance's configuration ({self.memory_state.size} memory states)")
            self.memory_state = x
        super().set_state(data)


_DIVERGENCE_LIMIT = 1e12   # memory state (N s m-ish): far beyond any linear-wave motion


BOX_INFO: dict[str, tuple[str, str]] = {
    "length": ("m", "box length (x), > 0"),
    "beam": ("m", "box beam (y), > 0"),
    "draft": ("m", "box draft, > 0 (the box floats freely: mass = rho * length * beam * draft)"),
    "z_G": ("m", "height of the centre of gravity above the waterplane (negative: below), roll/pitch stable"),
    "r_xx": ("m", "roll radius of gyration about G, > 0"),
    "r_yy": ("m", "pitch radius of gyration about G, > 0"),
    "r_zz": ("m", "yaw radius of gyration about G, > 0"),
    "rho": ("", "water density, kg/m3, > 0"),
    "g": ("m/s2", "gravity, > 0"),
}

#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    **BOX_INFO,
    **{n: ("", f"radiation damping ratio in {n.split('_')[1]} (heave, roll, pitch: fraction of critical; "
               "surge, sway, yaw: at the heave natural frequency), 0 .. 10; not used with hydrodynamics = bem")
       for n in ZETA_NAMES},
    "hydrodynamics": HYDRODYNAMICS_INFO,
    **vector_info("pos", "m", "displacement of the waterplane centre O", "global"),
    **{f"rot_{a}": ("", f"small rotation about global {a}, rad") for a in AXES},
    **vector_info("vel", "m/s", "velocity of O", "global"),
    **vector_info("omega", "rad/s", "angular velocity", "global"),
    "added_mass": ("", "who carries the added mass (A; A_inf with bem): platform (all of it, the rigid Platform) | "
                       "point (a flexible body carries the point-mass part A_33 I + the rotational block at O, "
                       "flexfmu.wec.barge; the rest -A_lagged xi_ddot is added here from acc_*, alpha_*)"),
    **vector_info("acc", "m/s2", "acceleration of O (added_mass = point)", "global"),
    **vector_info("alpha", "rad/s2", "angular acceleration (added_mass = point)", "global"),
    **vector_info("F", "N", "hydrostatic restoring plus radiation damping (bem: radiation memory) force",
                  "global"),
    **vector_info("M", "N.m", "hydrostatic restoring plus radiation damping (bem: radiation memory) moment about O",
                  "global"),
    "potential_energy": ("J", "hydrostatic potential energy 1/2 xi^T C xi"),
    "radiation_power": ("", "power radiated (dissipated) by the radiation damping, xi_dot^T B xi_dot, W (bem: "
                            "xi_dot^T F_mem, the memory force's power, instantaneous, of either sign)"),
}


#: the energy-balance term of the radiation memory (hydrodynamics = bem)
RADIATION_MEMORY_TERM = "radiation memory: radiated + held (signed work)"


class HydrostaticsRole(Role):
    """Hydrostatic potential energy 1/2 xi^T C xi and the radiated energy, of the motion at its inputs.

    With hydrodynamics = bem: the database's stiffness C, and in place of the damping the work of the radiation
    memory force, the integral of its signed power (the radiation_power output, xi_dot^T F_mem).  That work is the
    energy that left the body through the memory: what was radiated away plus what the memory state still holds
    and returns later.  The balance closes with it over any interval; only its split into radiated and held energy
    is not defined by the fitted state (it has no unique storage function), and over whole periods in steady state
    the held part does not change, so there the term is the radiated energy."""

    kind = "hydrostatics"

    def _energies(self, m, r):
        """(potential energy, radiated power, memory?) at the communication points."""
        xi = np.hstack([r.input_vec(m.name, "pos_{}"), r.input_vec(m.name, "rot_{}")])
        xi_dot = np.hstack([r.input_vec(m.name, "vel_{}"), r.input_vec(m.name, "omega_{}")])
        memory = m.config.hydrodynamics == "bem"
        if memory:
            C = bem_model(m.config)[0]
            # signed: the memory returns part of the energy it took; the recorded output is the power of the
            # memory force the component held at each communication point
            rad_power = np.asarray(r.col(m.name, "radiation_power"), float)
        else:
            C, B = coefficients(m.config)
            rad_power = np.einsum("ij,jk,ik->i", xi_dot, B, xi_dot)
        return 0.5 * np.einsum("ij,jk,ik->i", xi, C, xi), rad_power, memory

    def energy(self, m, r):
        pe, rad_power, memory = r.memo((m.name, "energies"), lambda: self._energies(m, r))
        return [Term(POTENTIAL, "potential: hydrostatic" + m.suffix, change(pe)),
                Term(DISSIPATED, (RADIATION_MEMORY_TERM if memory else "dissipated: radiation damping") + m.suffix,
                     integral(rad_power, r.t))]

    def diagnostics(self, m, r):
        # the work the held force did on the body against the energy of the motion: the coupling error of the
        # held force (first order in the step)
        fed = r.work_on_target(m.name, "F_x")
        if fed is None:
            return {}
        _, inp, work = fed
        pe, rad_power, _ = r.memo((m.name, "energies"), lambda: self._energies(m, r))
        label = f"hydro interface: work_{inp.split('_', 1)[0]} + dPE + radiated{m.suffix}"
        return {label: change(work) + change(pe) + integral(rad_power, r.t)}


#: what Hydrostatics is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = HydrostaticsRole()
