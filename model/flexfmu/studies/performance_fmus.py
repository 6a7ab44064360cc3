"""The performance study's figures of the FMUs through fmpy (flexfmu.studies.performance): the hammer record of
FFRBeam, per-call costs of ReframeBody against the library doing the same work, the floor of a no-op
pythonfmu FMU, instantiation in a fresh process."""
from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from flexfmu.studies.performance_library import FORCE
from flexfmu.studies.performance_timing import CLOCK, best_time


def build_fmus(out: Path) -> dict:
    import contextlib
    import io

    from flexfmu.fmi.build import build
    with contextlib.redirect_stdout(io.StringIO()):
        return {p.stem: p for p in build(out)}


class Slave:
    def __init__(self, fmu: Path, **start):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        types = {v.name: v.type for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=extract(str(fmu)),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="bench")
        t0 = time.perf_counter()
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in start.items():
            {"Real": lambda: self.fmu.setReal([self.vr[name]], [float(value)]),
             "Integer": lambda: self.fmu.setInteger([self.vr[name]], [int(value)]),
             "String": lambda: self.fmu.setString([self.vr[name]], [str(value)]),
             "Boolean": lambda: self.fmu.setBoolean([self.vr[name]], [bool(value)])}[types[name]]()
        self.fmu.exitInitializationMode()
        self.init_time = time.perf_counter() - t0

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


HAMMER_RECORD = 60.0        # s, the paper's record: accelerometer at 10 kS/s
HAMMER_DT = 1e-4


def hammer_signal(duration: float, names=("F_x", "F_y", "F_z")) -> np.ndarray:
    """The hammer blow (1 ms half-sine, 20 N peak, spread over three axes) sampled at 10 kS/s as an
    fmpy input table: fields time and the three input names."""
    n = int(round(duration / HAMMER_DT))
    t = np.arange(n + 1) * HAMMER_DT
    pulse = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    sig = np.zeros(n + 1, dtype=[("time", float)] + [(name, float) for name in names])
    sig["time"] = t
    for name, share in zip(names, (1.0, 0.7, 0.4)):
        sig[name] = share * pulse
    return sig


FFR_HAMMER_START = {"boundary": "XFF", "damping_ratio": 0.002, "load_s": 0.45, "sensor_s": 0.04}


def ffrbeam_lowlevel(fmu: Path, duration: float) -> dict:
    """The record through fmpy's FMU2Slave (setReal, doStep, getReal per sample), s for ``duration``."""
    sig = hammer_signal(duration)
    n = sig.size - 1
    sl = Slave(fmu, **FFR_HAMMER_START)
    vin = [sl.vr[f"F_{a}"] for a in "xyz"]
    vout = [sl.vr[f"sensor_a_{a}"] for a in "xyz"]
    f = sl.fmu
    forces = np.column_stack([sig["F_x"], sig["F_y"], sig["F_z"]]).tolist()
    rec = np.empty((n, 3))
    t0 = CLOCK()
    for k in range(n):
        f.setReal(vin, forces[k])
        f.doStep(k * HAMMER_DT, HAMMER_DT)
        rec[k] = f.getReal(vout)
    elapsed = CLOCK() - t0
    sl.free()
    return {"seconds": elapsed, "steps": n, "peak": float(np.max(np.abs(rec)))}


def simulate_fmu_record(fmu: Path, duration: float, inputs, outputs, start_values) -> float:
    """The route a user takes: fmpy.simulate_fmu with the input table (the force inputs only: fmpy warns
    about the others and leaves them at their start values), communication and output step 1e-4 s; CPU
    time of the whole call (extraction, instantiation, the loop, the result), s."""
    import contextlib
    import io

    from fmpy import simulate_fmu
    sig = hammer_signal(duration, inputs)
    t0 = CLOCK()
    with contextlib.redirect_stdout(io.StringIO()):          # fmpy's "missing input" warnings
        simulate_fmu(str(fmu), start_time=0.0, stop_time=duration, step_size=HAMMER_DT,
                     output_interval=HAMMER_DT, input=sig, start_values=start_values, output=list(outputs))
    return CLOCK() - t0


def record_time(measure, duration: float) -> tuple[float, str]:
    """Seconds for the 60 s record: measured whole when duration is 60 s; else from a short call (fixed
    cost) and a ``duration`` call (per-step cost) extrapolated to 600 000 steps."""
    if duration >= HAMMER_RECORD:
        return measure(HAMMER_RECORD), "whole record"
    fixed = measure(10 * HAMMER_DT)
    per_step = (measure(duration) - fixed) / (duration / HAMMER_DT - 10)
    return fixed + per_step * HAMMER_RECORD / HAMMER_DT, f"from {duration:g} s"


def ffrbeam_library_step(n=20000):
    from flexfmu.ffr.simulator import INPUT_NAMES, FFRBeamConfig, FFRBeamSimulator
    sim = FFRBeamSimulator(FFRBeamConfig(**FFR_HAMMER_START))
    sim.set_input_vector([0.0] * len(INPUT_NAMES))          # after the blow: the record's 599 990 other steps

    def run():
        for _ in range(n):
            sim.step(1e-4)
            sim.output_vector()
    return best_time(run) / n


N_NOOP_OUT = 6      # as many outputs as the ReframeBody master below reads


def build_noop_fmu(tmp: Path) -> Path:
    """A pythonfmu FMU with three Real inputs i0..i2 and N_NOOP_OUT outputs o0.. whose doStep does nothing:
    the floor of fmpy + pythonfmu under any Python FMU."""
    script = tmp / "Noop.py"
    script.write_text(
        "from pythonfmu import Fmi2Slave, Fmi2Causality, Fmi2Variability, Real\n"
        "class Noop(Fmi2Slave):\n"
        "    author = 'bench'\n    description = 'no-op'\n"
        "    def __init__(self, **kw):\n"
        "        super().__init__(**kw)\n"
        f"        self.v = dict.fromkeys([f'i{{k}}' for k in range(3)] + [f'o{{k}}' for k in range({N_NOOP_OUT})], 0.0)\n"
        "        for k in range(3):\n"
        "            self.register_variable(Real(f'i{k}', causality=Fmi2Causality.input, "
        "variability=Fmi2Variability.continuous, getter=lambda k=k: self.v[f'i{k}'], "
        "setter=lambda x, k=k: self.v.__setitem__(f'i{k}', x)))\n"
        f"        for k in range({N_NOOP_OUT}):\n"
        "            self.register_variable(Real(f'o{k}', causality=Fmi2Causality.output, "
        "variability=Fmi2Variability.continuous, getter=lambda k=k: self.v[f'o{k}']))\n"
        "    def do_step(self, t, h):\n        return True\n")
    from pythonfmu.builder import FmuBuilder
    return Path(FmuBuilder.build_FMU(script, dest=tmp))


def _per_call(calls: dict, n: int, blocks: int = 5) -> dict:
    """Median wall time (perf_counter) of each of ``calls`` {name: fn(k)}, called in turn for k < n, the
    smallest median of ``blocks`` blocks, s.  Per-call medians shrug off the interruptions of a shared
    machine; the timer's own cost (~0.1 us per call) is included in every figure alike."""
    names = list(calls)
    fns = [calls[name] for name in names]
    clock = time.perf_counter
    best = dict.fromkeys(names, math.inf)
    for _ in range(blocks):
        samples = [np.empty(n) for _ in names]
        for k in range(n):
            for j, fn in enumerate(fns):
                t0 = clock()
                fn(k)
                samples[j][k] = clock() - t0
        for name, x in zip(names, samples):
            best[name] = min(best[name], float(np.median(x)))
    return best


def noop_fmu_calls(fmu: Path, n: int = 2000) -> dict:
    """fmpy + pythonfmu floor per call on the no-op FMU through FMU2Slave: setReal(3), doStep, getReal(6)
    (as many values as the ReframeBody master reads), s; and "cycle", the three in a loop (CPU time per
    loop pass, best of three: the floor under a whole record)."""
    sl = Slave(fmu)
    vin = [sl.vr[f"i{k}"] for k in range(3)]
    vout = [sl.vr[f"o{k}"] for k in range(N_NOOP_OUT)]
    f = sl.fmu
    h = 1e-4
    clock = {"t": 0.0}

    def do_step(_k=None):
        f.doStep(clock["t"], h)
        clock["t"] += h

    times = _per_call({"setReal": lambda k: f.setReal(vin, [1e-3 * k, 0.0, 0.0]), "doStep": do_step,
                       "getReal": lambda k: f.getReal(vout)}, n)

    def cycle():
        for k in range(10 * n):
            f.setReal(vin, [0.0, 0.0, 0.0])
            do_step()
            f.getReal(vout[0:3])
    times["cycle"] = best_time(cycle) / (10 * n)
    sl.free()
    return times


def reframebody_calls(fmu: Path, npz: Path, n_internal=10, n=500) -> dict:
    """Per-call cost of ReframeBody through fmpy's FMU2Slave against the library doing the same work.

    Master: setReal of the force (a new value at every call: a coupled master), doStep of n_internal
    internal steps of 1e-4 s, getReal of six outputs (omega, output-point acceleration); the same with the
    force held (no input change), and with max_elastic_displacement read as well.  Library, same
    configuration: ReframeBodySimulator.set_input_vector (a new force), .step, .output_vector without the
    deferred search.  Medians per call (:func:`_per_call`), s."""
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
    start = {"model": str(npz), "n_flexible_modes": 10, "internal_step": 1e-4}
    sl = Slave(fmu, **start)
    lib = ReframeBodySimulator(ReframeBodyConfig(**start))
    vin = [sl.vr[f"F_{a}"] for a in "xyz"]
    vout = [sl.vr[name] for name in ("omega_1", "omega_2", "omega_3", "out_acc_x", "out_acc_y", "out_acc_z")]
    vmax = [sl.vr["max_elastic_displacement"]]
    f = sl.fmu
    h = n_internal * 1e-4
    force = [[FORCE[0] * (1.0 + 1e-6 * k), 0.0, FORCE[2] * (1.0 + 1e-6 * k)] for k in range(n)]
    clock = {"fmu": 0.0}

    def do_step(k):
        f.doStep(clock["fmu"], h)
        clock["fmu"] += h

    # FMU and library calls interleaved, so that both see the same state of the shared machine
    fmu_changing = _per_call({"setReal": lambda k: f.setReal(vin, force[k]), "doStep": do_step,
                              "getReal": lambda k: f.getReal(vout),
                              "lib set_input_vector": lambda k: lib.set_input_vector(force[k] + [0.0, 0.0, 0.0]),
                              "lib step": lambda k: lib.step(h),
                              "lib output_vector": lambda k: lib.output_vector(include_deferred=False)}, n)
    fmu_held = _per_call({"setReal": lambda k: f.setReal(vin, force[0]), "doStep": do_step,
                          "getReal": lambda k: f.getReal(vout), "lib step": lambda k: lib.step(h)}, n)
    fmu_max = _per_call({"setReal": lambda k: f.setReal(vin, force[k]), "doStep": do_step,
                         "getReal": lambda k: f.getReal(vout), "getReal max": lambda k: f.getReal(vmax)}, n)
    lib_changing = {name[4:]: value for name, value in fmu_changing.items() if name.startswith("lib ")}
    lib_held = {"step": fmu_held["lib step"]}
    init = sl.init_time
    sl.free()
    return {"fmu": fmu_changing, "fmu_held": fmu_held, "fmu_max": fmu_max, "lib": lib_changing,
            "lib_held": lib_held, "init": init}


def fmu_instantiation(fmu: Path, env: dict | None = None, **start) -> float:
    """Instantiate + initialise in a fresh process (no in-process caches), s; ``env``: extra environment."""
    # os._exit: measured and freed; interpreter teardown with pythonfmu's binary loaded has aborted (SIGABRT)
    # now and then on this machine after the figure was printed, which is not what is measured here
    code = ("import os, sys, time; from flexfmu.studies.performance_fmus import Slave; "
            "s = Slave(%r, **%r); s.free(); print(s.init_time, flush=True); os._exit(0)") % (str(fmu), start)
    # -P: the current directory is not put on sys.path, so the child imports the flexfmu this process runs
    out = subprocess.run([sys.executable, "-P", "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, **(env or {})})
    return float(out.stdout.strip().splitlines()[-1])
