"""PTO: a linear damper/generator between a harvester point and the platform that carries the
harvester (what PTO.fmu wraps; variable names are the FMU's).

The input is the point's velocity relative to the harvester's floating frame (FFRBeam's sensor_v with
sensor_s at the point); the damper pushes the point with F = -c v (body frame; to FFRBeam's F inputs
with load_s at the point) and its stator pushes the platform back with -F at the point's undeformed
position r_a (about the harvester frame's origin, the mount point; to Platform's pto inputs).  The
harvested (electrical) power is c |v|^2.  ``axis`` = 0 0 0 makes the damper isotropic; a direction
makes it act along that axis only (F = -c (v.n) n, power c (v.n)^2).  Memoryless.

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) the PTO is what harvests: c |v|^2 of the
velocity at its inputs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.components import AXES, MemorylessSimulator, check_config, vector_info
from flexfmu.wec.roles import HARVESTED, Panel, Role, Term, integral, mean_power

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


class PTORole(Role):
    """The harvester: power c |v|^2 (c (v.n)^2 along an axis) of the recorded velocity that feeds its inputs."""

    kind = "pto"

    def power(self, m, r):
        cfg = m.config
        v = r.input_vec(m.name, "v_{}")
        axis = np.array([cfg.axis_x, cfg.axis_y, cfg.axis_z])
        if np.linalg.norm(axis) > 0:
            axis = axis / np.linalg.norm(axis)
            return cfg.damping * (v @ axis) ** 2
        return cfg.damping * np.einsum("ij,ij->i", v, v)

    def energy(self, m, r):
        return [Term(HARVESTED, "harvested: PTO" + m.suffix, integral(self.power(m, r), r.t))]

    def diagnostics(self, m, r):
        # the work the held damper force actually did on the point it pushes (force of sample n over step n),
        # when the velocity it reads comes with the point's displacement (FFRBeam's sensor_v, sensor_u)
        src = m.roster.source(m.name, "v_x")
        if src is None or not src[1].startswith("sensor_v_"):
            return {}
        F, u = r.vec(m.name, "F_{}"), r.vec(src[0], "sensor_u_{}")
        return {"PTO: energy the held damper force took from the rod" + m.suffix:
                -float(np.sum(np.einsum("ij,ij->i", F[:-1], np.diff(u, axis=0))))}

    def panels(self, m, r):
        t, p = r.t, self.power(m, r)
        mean = mean_power(p, t, t[t >= t[0] + 0.5 * (t[-1] - t[0])][0])
        return [Panel("power" + m.suffix, f"harvested power c|v|^2 (c = {m.config.damping:g} N s/m){m.suffix}", "nW",
                      [(1e9 * p, {"lw": 0.8, "label": "instantaneous"}),
                       (1e9 * mean, {"color": "k", "ls": "--", "lw": 1,
                                     "label": f"mean over the second half: {1e9 * mean:.3g} nW"})])]


#: what the PTO is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = PTORole()
