"""HeavePTO: the point absorber's power take-off, a linear damper and spring in heave between the float and the earth
(what HeavePTO.fmu wraps; variable names are the FMU's):

    F_z = clip(-(damping vel_z + stiffness pos_z), -force_limit, force_limit)     (force_limit = 0: no limit)
    power = -F_z vel_z

F_z acts on the float along global z (at O, on the axis: no moment); power is the instantaneous power the PTO
absorbs (W; the spring's part of it averages out over a period).  Memoryless.

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) the PTO is what harvests: the ``power`` output.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.components import MemorylessSimulator, check_config
from flexfmu.wec.roles import HARVESTED, Panel, Role, Term, integral, mean_power

INPUT_NAMES = ("pos_z", "vel_z")
OUTPUT_NAMES = ("F_z", "power")


@dataclass(frozen=True)
class HeavePTOConfig:
    """Parameters, named and defaulted as in the FMU."""

    damping: float = 2.0e5          # N s/m
    stiffness: float = 0.0          # N/m
    force_limit: float = 0.0        # N; 0: no limit


def _check(cfg: HeavePTOConfig) -> None:
    check_config(cfg)
    require(cfg.damping >= 0, "damping", f"got {cfg.damping!r}", ">= 0 N.s/m")
    require(cfg.force_limit >= 0, "force_limit", f"got {cfg.force_limit!r}", ">= 0 N (0: no limit)")


class HeavePTOSimulator(MemorylessSimulator):
    """Inputs and outputs of one HeavePTO instance."""

    INPUTS = INPUT_NAMES

    def __init__(self, config: HeavePTOConfig = HeavePTOConfig()):
        _check(config)
        super().__init__(config)

    def force(self) -> float:
        c = self.config
        f = -(c.damping * self.inputs["vel_z"] + c.stiffness * self.inputs["pos_z"])
        if c.force_limit > 0:
            f = min(max(f, -c.force_limit), c.force_limit)
        return f

    def _outputs(self) -> dict[str, float]:
        f = self.force()
        return {"F_z": f, "power": -f * self.inputs["vel_z"]}


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "damping": ("", "damping c, N.s/m, >= 0"),
    "stiffness": ("N/m", "spring stiffness k (any finite value; negative: a negative spring)"),
    "force_limit": ("N", "the force is clipped to +-force_limit, >= 0; 0: no limit"),
    "pos_z": ("m", "heave displacement of the float's O, global z"),
    "vel_z": ("m/s", "heave velocity of the float's O, global z"),
    "F_z": ("N", "PTO force on the float, global z: clip(-(c vel_z + k pos_z), -force_limit, force_limit)"),
    "power": ("W", "instantaneous power the PTO absorbs, -F_z vel_z"),
}


class HeavePTORole(Role):
    """The harvester: the power output -F_z vel_z."""

    kind = "pto"

    def power(self, m, r):
        return np.asarray(r.col(m.name, "power"), float)

    def energy(self, m, r):
        return [Term(HARVESTED, "harvested: PTO" + m.suffix, integral(self.power(m, r), r.t))]

    def panels(self, m, r):
        t, p = r.t, self.power(m, r)
        mean = mean_power(p, t, t[t >= t[0] + 0.5 * (t[-1] - t[0])][0])
        return [Panel("power" + m.suffix, f"PTO power -F_z vel_z (c = {m.config.damping:g} N s/m){m.suffix}", "kW",
                      [(1e-3 * p, {"lw": 0.8, "label": "instantaneous"}),
                       (1e-3 * mean, {"color": "k", "ls": "--", "lw": 1,
                                      "label": f"mean over the second half: {1e-3 * mean:.4g} kW"})])]


#: what the PTO is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = HeavePTORole()
