"""PTO: a linear damper/generator between a harvester point and the platform that carries the
harvester (what PTO.fmu wraps; variable names are the FMU's).

The input is the point's velocity relative to the harvester's floating frame (FFRBeam's sensor_v with
sensor_s at the point); the damper pushes the point with F = -c v (body frame; to FFRBeam's F inputs
with load_s at the point) and its stator pushes the platform back with -F at the point's undeformed
position r_a (about the harvester frame's origin, the mount point; to Platform's pto inputs).  The
harvested (electrical) power is c |v|^2.  ``axis`` = 0 0 0 makes the damper isotropic; a direction
makes it act along that axis only (F = -c (v.n) n, power c (v.n)^2).  Memoryless.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.components import AXES, MemorylessSimulator, check_config, vector_info

INPUT_NAMES = tuple(f"v_{a}" for a in AXES)
OUTPUT_NAMES = (tuple(f"F_{a}" for a in AXES) + tuple(f"stator_F_{a}" for a in AXES)
                + tuple(f"stator_M_{a}" for a in AXES) + ("power",))


@dataclass(frozen=True)
class PTOConfig:
    """Parameters, named and defaulted as in the FMU (the point: the spatial double-L's tip)."""

    damping: float = 2.0
    attach_x: float = 0.14
    attach_y: float = 0.15
    attach_z: float = 0.16
    axis_x: float = 0.0
    axis_y: float = 0.0
    axis_z: float = 0.0


def _check(cfg: PTOConfig) -> np.ndarray | None:
    check_config(cfg)
    require(cfg.damping >= 0, "damping", f"got {cfg.damping!r}", ">= 0 N.s/m")
    axis = np.array([cfg.axis_x, cfg.axis_y, cfg.axis_z])
    scale = float(np.max(np.abs(axis)))
    if scale == 0:
        return None
    with np.errstate(over="ignore", under="ignore"):
        n = float(np.linalg.norm(axis))
    if not 0 < n < math.inf:                  # a direction: scaled first when its norm over- or underflows
        axis = axis / scale
        n = float(np.linalg.norm(axis))
    return axis / n


class PTOSimulator(MemorylessSimulator):
    """Inputs and outputs of one PTO instance."""

    INPUTS = INPUT_NAMES

    def __init__(self, config: PTOConfig = PTOConfig()):
        super().__init__(config)
        self.axis = _check(config)
        self.r_a = np.array([config.attach_x, config.attach_y, config.attach_z])

    def force(self) -> np.ndarray:
        v = np.array([self.inputs[n] for n in INPUT_NAMES])
        if self.axis is not None:
            v = (v @ self.axis) * self.axis
        return -self.config.damping * v

    def _outputs(self) -> dict[str, float]:
        F = self.force()
        c = self.config.damping
        power = float(F @ F) / c if c > 0 else 0.0
        r = self.r_a
        stator_M = -np.array([r[1] * F[2] - r[2] * F[1], r[2] * F[0] - r[0] * F[2], r[0] * F[1] - r[1] * F[0]])
        return dict(zip(OUTPUT_NAMES, F.tolist() + (-F).tolist() + stator_M.tolist() + [power]))


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "damping": ("", "damper rate c, N.s/m, >= 0"),
    **{f"attach_{a}": ("m", f"undeformed position of the harvester point in the harvester frame, {a}") for a in AXES},
    **{f"axis_{a}": ("", f"damper axis, {a} (0 0 0: isotropic)") for a in AXES},
    **vector_info("v", "m/s", "velocity of the harvester point relative to the harvester frame"),
    **vector_info("F", "N", "damper force on the harvester point"),
    **vector_info("stator_F", "N", "stator force on the platform (at the point)"),
    **vector_info("stator_M", "N.m", "stator moment on the platform about the harvester frame origin"),
    "power": ("", "harvested power c |v|^2, W"),
}
