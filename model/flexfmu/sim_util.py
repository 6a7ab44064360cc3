"""Small helpers shared by the wave-energy-converter component façades (wave_excitation_sim,
hydrostatics_sim, platform_sim, pto_sim): input checks, plain-data state, variable descriptions."""
from __future__ import annotations

import math
from dataclasses import asdict, fields

import numpy as np

from flexfmu.errors import ParameterError, require

AXES = ("x", "y", "z")
#: the six generalised (rigid-body) directions, in the order of the 6-vectors
DOF6 = ("x", "y", "z", "rx", "ry", "rz")


def check_config(cfg) -> None:
    """Every numeric field finite."""
    for f in fields(cfg):
        value = getattr(cfg, f.name)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            require(np.isfinite(value), f.name, f"got {value!r}", "a finite number")


def check_inputs(inputs: dict, names: tuple) -> None:
    """Every name an input, every value finite (per step: the messages are built only on failure)."""
    for name, value in inputs.items():
        if name not in names:
            raise ParameterError(name, "unknown input", ", ".join(names))
        if not math.isfinite(value):
            raise ParameterError(name, f"input is {value!r}", "a finite number")


def check_step(step_size: float) -> None:
    require(np.isfinite(step_size) and step_size > 0, "step_size", f"got {step_size!r}", "> 0 s")


def check_state_config(data: dict, config) -> None:
    require(data.get("config") == asdict(config), "FMUstate", "was taken with other parameters",
            "a state of this instance's configuration")


class MemorylessSimulator:
    """Plumbing of a component whose outputs depend only on its inputs, parameters and time (no
    dynamic state): the time, the held inputs, the step and the plain-data state for FMI get/set.
    Subclasses set INPUTS (the input names) and compute outputs()."""

    INPUTS: tuple = ()

    def __init__(self, config):
        self.config = config
        self.t = 0.0
        self.inputs = dict.fromkeys(self.INPUTS, 0.0)

    @property
    def time(self) -> float:
        return self.t

    def set_inputs(self, **inputs: float) -> None:
        check_inputs(inputs, self.INPUTS)
        self.inputs.update({k: float(v) for k, v in inputs.items()})

    def step(self, step_size: float) -> None:
        check_step(step_size)
        self.t += step_size

    def get_state(self) -> dict:
        return {"t": self.t, "inputs": dict(self.inputs), "config": asdict(self.config)}

    def set_state(self, data: dict) -> None:
        check_state_config(data, self.config)
        self.t = float(data["t"])
        self.inputs = dict(data.get("inputs", {}))


def vector_info(prefix: str, unit: str, text: str, frame: str = "body") -> dict:
    return {f"{prefix}_{a}": (unit, f"{text}, {frame} {a}") for a in AXES}
