"""Hydrostatics: linear hydrostatic restoring and linear radiation damping of a floating box, the
force side of the minimal Cummins model (what Hydrostatics.fmu wraps; variable names are the FMU's).

    F = -C xi - B xi_dot        (about the waterplane centre O, global axes)

with the constant, diagonal coefficients of flexfmu.wec.wave.FloatingBox.  Its constant added mass A
belongs to the left-hand side (M + A) xi_ddot of Cummins' equation and is carried by the Platform
(platform_sim), which computes it from the same box parameters: moved to the body for stability,
as WEC-Sim does (a delayed added-mass force is unstable in co-simulation whenever A > M).
Memoryless: the outputs follow the inputs (direct feedthrough); no convolution memory.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.components import AXES, MemorylessSimulator, check_config, check_finite_build, vector_info
from flexfmu.wec.wave import BoxParameters, FloatingBox

INPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"rot_{a}" for a in AXES)
               + tuple(f"vel_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES))
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

    def zeta(self) -> np.ndarray:
        return np.array([getattr(self, n) for n in ZETA_NAMES])


def coefficients(cfg: HydrostaticsConfig) -> tuple[np.ndarray, np.ndarray]:
    """(C, B), 6x6 each."""
    check_config(cfg)                      # before the cache: it hashes the config
    return _coefficients(cfg)


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
        self.C, self.B = coefficients(config)

    def _outputs(self) -> dict[str, float]:
        v = self.inputs
        xi = np.array([v[n] for n in INPUT_NAMES[:6]])
        xi_dot = np.array([v[n] for n in INPUT_NAMES[6:]])
        force = -self.C @ xi - self.B @ xi_dot
        values = force.tolist() + [0.5 * float(xi @ self.C @ xi), float(xi_dot @ self.B @ xi_dot)]
        return dict(zip(OUTPUT_NAMES, values))


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
               "surge, sway, yaw: at the heave natural frequency), 0 .. 10") for n in ZETA_NAMES},
    **vector_info("pos", "m", "displacement of the waterplane centre O", "global"),
    **{f"rot_{a}": ("", f"small rotation about global {a}, rad") for a in AXES},
    **vector_info("vel", "m/s", "velocity of O", "global"),
    **vector_info("omega", "rad/s", "angular velocity", "global"),
    **vector_info("F", "N", "hydrostatic restoring plus radiation damping force", "global"),
    **vector_info("M", "N.m", "hydrostatic restoring plus radiation damping moment about O", "global"),
    "potential_energy": ("J", "hydrostatic potential energy 1/2 xi^T C xi"),
    "radiation_power": ("", "power radiated (dissipated) by the radiation damping, xi_dot^T B xi_dot, W"),
}
