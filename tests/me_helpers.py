"""Helpers of the model-exchange and directional-derivative tests: the hammer record's inputs as a co-simulation host
holds them and as a model-exchange host must be given them to see the same thing, and comparisons of records."""
from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import numpy as np
from fmpy import read_model_description

ROOT = Path(__file__).resolve().parents[1]


def hammer_module():
    spec = importlib.util.spec_from_file_location("hammer_test", ROOT / "examples" / "hammer_test.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HAMMER = hammer_module()
#: the hammer record's FFRBeam settings per boundary (examples/hammer_test.py), fixed at build in a native FMU
HAMMER_SETTINGS = {bc: {"boundary": bc, "load_s": s[0], "sensor_s": s[1], "damping_ratio": 0.002}
                   for bc, s in HAMMER.SETUPS.items()}
STEP = 1.0 / HAMMER.SAMPLE_RATE


def hammer_force(t):
    """The hammer blow (examples/hammer_test.py): a 1 ms half-sine of 20 N along x, 0.7 and 0.4 of it along y, z."""
    pulse = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    return {"F_x": pulse, "F_y": 0.7 * pulse, "F_z": 0.4 * pulse}


def signals(fmu, t, values: dict):
    md = read_model_description(str(fmu))
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    out = np.zeros(len(t), dtype=[("time", float)] + [(name, float) for name in inputs])
    out["time"] = t
    for name, value in values.items():
        out[name] = value
    return out


def held_signals(fmu, t, values: dict):
    """The inputs ``values`` ({name: samples at t}) as a co-simulation host gives them (each held over its step), and
    the same inputs as a model-exchange host must get them to see that: each sample held until the next, a
    discontinuity (two rows at one time: fmpy's input events) wherever a value changes."""
    changes = [k for k in range(1, len(t)) if any(values[n][k] != values[n][k - 1] for n in values)]
    rows_t, rows = [t[0]], {n: [values[n][0]] for n in values}
    changed = set(changes)
    for k in range(1, len(t)):
        if k in changed:
            rows_t.append(t[k])
            for n in values:
                rows[n].append(values[n][k - 1])
        rows_t.append(t[k])
        for n in values:
            rows[n].append(values[n][k])
    return signals(fmu, t, values), signals(fmu, np.array(rows_t), {n: np.array(v) for n, v in rows.items()})


def at_points(record, t):
    """The rows of a model-exchange record at the times t, before any event there (a co-simulation output at t_k is
    that of the inputs held over the step before)."""
    times, first = np.unique(record["time"], return_index=True)
    assert np.allclose(times, t, rtol=0, atol=1e-12)
    return record[first]


def relative_difference(a, b, names) -> dict:
    """{output: max |a - b| / max |b|} over two records."""
    out = {}
    for name in names:
        scale = float(np.max(np.abs(b[name])))
        out[name] = float(np.max(np.abs(a[name] - b[name]))) / (scale if scale > 0 else 1.0)
    return out


def fmusim_path() -> Path | None:
    """fmusim (Reference-FMUs, built by benchmarks/build_fmusim.sh): $FMUSIM, on PATH, or the benchmarks' build
    folder beside this checkout."""
    import os
    for candidate in (os.environ.get("FMUSIM"), shutil.which("fmusim"), ROOT.parent / "fmusim-build" / "fmusim"):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    return None


class MeInstance:
    """One FMI 2.0 instance of ``interface`` ("me": fmpy's FMU2Model, "cs": FMU2Slave) on its own extraction, with a
    log list, initialised (model exchange: in Continuous-Time Mode); vr lookup by name."""

    def __init__(self, fmu, interface: str = "me", name: str = "instance", **start_values):
        import ctypes

        from fmpy import extract
        from fmpy.fmi2 import FMU2Model, FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

        self.md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[str] = []

        def logger(component, instance_name, status, category, message):
            self.log.append((message or b"").decode())

        self._logger = fmi2CallbackLoggerTYPE(logger)   # keep a reference: ctypes must not free it
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = self._logger
        callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
        callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
        cls, element = (FMU2Model, self.md.modelExchange) if interface == "me" else (FMU2Slave, self.md.coSimulation)
        element = element or self.md.coSimulation or self.md.modelExchange
        self.fmu = cls(guid=self.md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier=element.modelIdentifier,
                       instanceName=name)
        self.interface = interface
        self.fmu.instantiate(callbacks=callbacks, loggingOn=True)
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for key, value in start_values.items():
            self.fmu.setReal([self.vr[key]], [float(value)])
        self.fmu.exitInitializationMode()
        if interface == "me":
            self.fmu.newDiscreteStates()
            self.fmu.enterContinuousTimeMode()
        self.states = [d.variable.derivative.valueReference for d in self.md.derivatives]
        self.derivatives = [d.variable.valueReference for d in self.md.derivatives]

    def set(self, **values):
        self.fmu.setReal([self.vr[n] for n in values], [float(v) for v in values.values()])

    def get(self, *names):
        return np.array(self.fmu.getReal([self.vr[n] for n in names]))

    def free(self):
        self.fmu.freeInstance()
