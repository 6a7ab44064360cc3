#!/usr/bin/env python3
# Over 500 lines on purpose: one report of many independent measurements, each a short function.
"""Performance figures: figure, ours, peer or limit, ratio; writes docs/performance.md.

    flexfmu bench [performance] [--quick] [--out REPORT.md | -]
    .venv/bin/python benchmarks/performance.py [--quick] [--out ...]        (the same)

CPU time for per-step figures, wall time for set-up (see CLOCK); shared 2-core machine: expect +-20 %
between runs; every ratio in a table comes from the same run.  --quick extrapolates the 60 s records
from 1 s and skips the largest meshes, the default plate and Exudyn.  The report defaults to docs/performance.md
of a source checkout, else ./performance.md; without Exudyn its comparison is skipped.
"""
from __future__ import annotations

import argparse
import gc
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from flexfmu.studies import common

FORCE = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)   # the reframe paper's load, 10 ms half-sine


# Per-step figures are CPU time of this process (single-threaded work: the compiled kernels, fmpy,
# pythonfmu), which other jobs on the shared cores disturb far less than wall time; set-up and fresh-process
# figures are wall time (they include multi-threaded BLAS and process start-up).
CLOCK = time.process_time


def _best(fn, repeat=3):
    """Smallest CPU time of ``repeat`` calls of fn() (s) — the least disturbed by other load."""
    best = math.inf
    for _ in range(repeat):
        t0 = CLOCK()
        fn()
        best = min(best, CLOCK() - t0)
    return best


def machine() -> dict:
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import scipy

    from flexfmu.reframe import kernels as kern
    if kern.NATIVE:
        from flexfmu.native.compiler import KERNEL_FLAGS, find_compiler
        flags = " ".join(f for f in KERNEL_FLAGS if f.startswith(("-O", "-ffp")))
        kernels = f"C ({Path(find_compiler()).name} {flags})"
    else:
        kernels = f"numpy ({kern.NATIVE_REASON})"
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "kernels": kernels, "platform": platform.platform()}


# --------------------------------------------------------------------------- reframe
def _plate_integrator(divisions, n_flexible=10, scheme="consistent"):
    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.plate import paper_plate
    from flexfmu.reframe.integrator import ReframeIntegrator

    t0 = time.perf_counter()
    plate = paper_plate(divisions)
    t1 = time.perf_counter()
    basis = modal_basis(plate, n_flexible, cache=False)          # the computation, not the on-disk cache
    t2 = time.perf_counter()
    integ = ReframeIntegrator(plate, basis, scheme=scheme)
    t3 = time.perf_counter()
    return integ, {"assembly": t1 - t0, "modal": t2 - t1, "integrator": t3 - t2, "n_dof": plate.n_dof}


def reframe_step_times(integ, n=2000):
    """(single advance() call, batched advance_steps, output_vector, output_vector without the max elastic
    displacement search) per call, s; paper's load, moving."""
    from flexfmu.reframe.plate import LOAD_POINT
    from flexfmu.reframe.integrator import RK4_STABILITY_LIMIT, PointLoad, half_sine_pulse

    # the paper's 1e-4 s, or less where many retained modes need it (RK4: dt * omega_max <= 2.8)
    dt = min(1e-4, 0.9 * RK4_STABILITY_LIMIT / integ.data.omega_max) if integ.data.omega_max > 0 else 1e-4
    loads = integ.prepare_loads(PointLoad(LOAD_POINT, half_sine_pulse(FORCE, 0.01)))
    s0 = integ.initial_state(omega0=(0.5, 0.2, 0.8))
    s0 = integ.advance_steps(s0, dt, 20, loads)              # loaded, deforming, compiled
    pts = integ.point_indices([integ.data.structure.points["P1"]])

    def single():
        s = s0
        for _ in range(n):
            s = integ.advance(s, dt, loads)

    def batched():
        integ.advance_steps(s0, dt, n, loads)

    def outputs(max_elastic=True):
        for _ in range(n // 10):
            integ.output_vector(s0, loads, pts, max_elastic=max_elastic)

    return (_best(single) / n, _best(batched) / n, _best(outputs) / (n // 10),
            _best(lambda: outputs(False)) / (n // 10))


# --------------------------------------------------------------------------- FMUs through fmpy
def _build_fmus(out: Path) -> dict:
    import contextlib
    import io

    from flexfmu.fmi.build import build
    with contextlib.redirect_stdout(io.StringIO()):
        return {p.stem: p for p in build(out)}


class _Slave:
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
    sl = _Slave(fmu, **FFR_HAMMER_START)
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
    return _best(run) / n


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
    sl = _Slave(fmu)
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
    times["cycle"] = _best(cycle) / (10 * n)
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
    sl = _Slave(fmu, **start)
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
    code = ("import os, sys, time; from flexfmu.studies.performance import _Slave; "
            "s = _Slave(%r, **%r); s.free(); print(s.init_time, flush=True); os._exit(0)") % (str(fmu), start)
    # -P: the current directory is not put on sys.path, so the child imports the flexfmu this process runs
    out = subprocess.run([sys.executable, "-P", "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, **(env or {})})
    return float(out.stdout.strip().splitlines()[-1])


# --------------------------------------------------------------------------- Exudyn
def exudyn_comparison(quick: bool) -> dict | None:
    """CPU time to reach 1e-4 relative accuracy in omega and in the loaded point's elastic deflection,
    against the converged Exudyn reference trajectory (flexfmu/data/references/exudyn_plate, dt = 2.5e-6 s), for
    the reframe integrator (consistent and exponential schemes) and for Exudyn's own reduced-order FFRF
    (GeneralizedAlpha), both 1 s of the paper's load on the same plate (20x2x1), M, K, nodes and ten
    flexible modes."""
    try:
        import exudyn  # noqa: F401
    except ImportError:
        return None
    from flexfmu.studies.references import load_generator, reference_path
    gen = load_generator("exudyn_plate")
    lines = [line for line in reference_path("exudyn_plate").read_text().splitlines()
             if line.strip() and not line.startswith("#")]
    cols = {name: k for k, name in enumerate(lines[0].split(","))}              # the header row
    ref = np.loadtxt(lines[1:], delimiter=",")
    after = ref[:, 0] > 0.012
    w_ref = ref[:, [cols[f"omega_{i}"] for i in (1, 2, 3)]]
    u_ref = ref[:, [cols[f"u_load_{c}"] for c in "xyz"]]

    def errors(w, u):
        ew = np.max(np.linalg.norm(w[after] - w_ref[after], axis=1)) / np.max(np.linalg.norm(w_ref[after], axis=1))
        eu = np.max(np.linalg.norm(u - u_ref, axis=1)) / np.max(np.linalg.norm(u_ref, axis=1))
        return float(ew), float(eu)

    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.plate import LOAD_POINT, paper_plate
    from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, half_sine_pulse
    plate = paper_plate(gen.DIVISIONS)
    basis = modal_basis(plate, gen.N_FLEXIBLE, gen.ZETA)
    load = PointLoad(LOAD_POINT, half_sine_pulse(gen.FORCE, gen.PULSE))
    by_scheme = {}
    for scheme, steps in (("consistent", (5e-4, 2.5e-4, 1e-4, 5e-5, 2.5e-5)),
                          ("exponential", (1e-3, 5e-4, 2.5e-4, 1e-4, 5e-5))):   # divide the 1 ms output
        integ = ReframeIntegrator(plate, basis, scheme=scheme)
        node = integ.point_indices([LOAD_POINT])[0]
        Phi_load = integ.data.Phi[integ.data.trans_rows[node]]
        integ.run(0.01, 1e-4, load)                     # warm-up (kernel loading): not timed
        rows = []
        for dt in (steps[1:4] if quick else steps):
            every = int(round(gen.OUTPUT_PERIOD / dt))
            integ.set_initial()
            t0 = time.process_time()
            r = integ.run(gen.T_END, dt, load, every=every)
            cpu = time.process_time() - t0
            rows.append((dt, cpu, *errors(r.omega, r.q @ Phi_load.T)))
        by_scheme[scheme] = rows
    plate_fem, fem, _ = gen.build_fem()
    gen.simulate(fem, dt=1e-4, t_end=0.01)              # warm-up: not timed
    theirs = []
    for dt in ((1e-4, 5e-5) if quick else (2e-4, 1e-4, 5e-5, 2.5e-5)):
        t0 = time.process_time()
        table, _ = gen.simulate(fem, dt=dt)
        cpu = time.process_time() - t0
        theirs.append((dt, cpu, *errors(table[:, 1:4], table[:, 4:7])))

    def time_to(rows, tol=1e-4):
        ok = [r for r in rows if max(r[2], r[3]) <= tol]
        return min(ok, key=lambda r: r[1]) if ok else None
    return {"ours": by_scheme, "exudyn": theirs, "ours_at": {k: time_to(v) for k, v in by_scheme.items()},
            "exudyn_at": time_to(theirs)}


# --------------------------------------------------------------------------- set-up
def frame_modal_time(target_dof=10_000) -> tuple[int, float]:
    from flexfmu.ffr.assembly import build_beam_model
    from flexfmu.linalg.modal import solve_modes
    from flexfmu.ffr.scene import load_scene
    scene = load_scene("spatial_double_L")
    n_seg = len(scene.points) - 1
    eps = max(1, int(round(target_dof / (6 * n_seg))))
    t0 = time.perf_counter()
    model = build_beam_model(scene, "XFF", eps)
    solve_modes(model.K_free, model.M_free, 10)
    return model.n_free, time.perf_counter() - t0


# --------------------------------------------------------------------------- report
def fmt_t(seconds: float) -> str:
    if seconds is None or not math.isfinite(seconds):
        return "–"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.1f} µs"
    if seconds < 1.0:
        return f"{seconds * 1e3:.1f} ms"
    return f"{seconds:.2f} s"


def peak_memory_mb() -> float:
    """Peak resident memory of this process, MB: VmHWM of /proc/self/status (Linux: reset at exec, unlike
    ru_maxrss, which a child started by fork + exec inherits from its parent), else ru_maxrss."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def scaling_row(divisions, n_flexible: int, n_steps: int) -> dict:
    """One scaling row, meant for a fresh process (its peak memory is the row's): set-up times, batched
    step and outputs of a state, peak resident memory."""
    integ, info = _plate_integrator(divisions, n_flexible)
    _, batch, outs, _ = reframe_step_times(integ, n=n_steps)
    return {**info, "modes": 6 + n_flexible, "step": batch, "outputs": outs, "peak_rss_mb": peak_memory_mb()}


def _scaling_row_subprocess(divisions, n_flexible: int, n_steps: int) -> dict:
    import json
    arg = ",".join(map(str, divisions)) + f":{n_flexible}:{n_steps}"
    out = subprocess.run([sys.executable, "-P", "-m", "flexfmu.studies.performance", "--scaling-row", arg],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def run(quick: bool) -> tuple[list, list, dict]:
    rows, notes, extra = [], [], {}

    def row(figure, ours, peer, ratio, note=""):
        rows.append((figure, ours, peer, "–" if ratio is None else f"{ratio:.2f}", note))
        print(f"{figure:60s} {ours:>12s} {peer:>14s} {rows[-1][3]:>6s} {note}", flush=True)

    print(f"{'figure':60s} {'ours':>12s} {'peer / limit':>14s} {'ratio':>6s}")
    from flexfmu.reframe import kernels as kern

    # (2) per step, m = 16, and (1) mesh independence
    small, info_s = _plate_integrator((10, 2, 1))
    one, batch, outs, outs_lean = reframe_step_times(small)
    row("reframe step, m = 16, one advance() call", fmt_t(one), "20 µs", one / 20e-6, f"{info_s['n_dof']} DOFs")
    row("reframe step, m = 16, batched (advance_steps, FMU)", fmt_t(batch), "20 µs", batch / 20e-6)
    row("reframe outputs of one state (output_vector)", fmt_t(outs), "–", None)
    row("  without the max elastic displacement search", fmt_t(outs_lean), "–", None, "O(modes²): all other outputs")
    expo, _ = _plate_integrator((10, 2, 1), scheme="exponential")
    _, batch_exp, _, _ = reframe_step_times(expo)
    row("reframe step, m = 16, exponential scheme (FMU default), batched", fmt_t(batch_exp), "20 µs",
        batch_exp / 20e-6, "same dt")
    del expo
    if kern.NATIVE:
        kern_backup = kern.consistent_steps
        kern.consistent_steps = kern.consistent_steps_numpy
        _, batch_np, _, _ = reframe_step_times(small, n=200)
        kern.consistent_steps = kern_backup
        row("reframe step, m = 16, numpy fallback (FLEXFMU_NATIVE_KERNELS=0)", fmt_t(batch_np), fmt_t(batch),
            batch_np / batch, "vs C")
    big_div = (40, 6, 2) if quick else (70, 8, 2)
    big, info_b = _plate_integrator(big_div)
    _, batch_big, outs_big, outs_lean_big = reframe_step_times(big)
    row(f"reframe step, m = 16, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(batch_big), fmt_t(batch),
        batch_big / batch, "limit 1.2")
    row(f"reframe outputs, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(outs_big), fmt_t(outs),
        outs_big / outs, "max elastic displacement search")
    row(f"reframe outputs without that search, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(outs_lean_big),
        fmt_t(outs_lean), outs_lean_big / outs_lean, "limit 1.2")
    del big
    gc.collect()

    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        fmus = _build_fmus(tmp / "dist")
        noop = build_noop_fmu(tmp)
        from flexfmu.core.io import save_structure
        npz = save_structure(tmp / "plate_10x2x1.npz", small.data.structure)
        noop_calls = noop_fmu_calls(noop)
        floor = noop_calls["cycle"]
        row("fmpy + pythonfmu floor per call (no-op FMU): setReal(3) / doStep / getReal(6)",
            " / ".join(fmt_t(noop_calls[c]) for c in ("setReal", "doStep", "getReal")), "–", None,
            "median per call")
        rb = reframebody_calls(fmus["ReframeBody"], npz)
        fmu, held, lib, lib_held = rb["fmu"], rb["fmu_held"], rb["lib"], rb["lib_held"]
        lib_step = lib["set_input_vector"] + lib["step"]
        row("ReframeBody.fmu doStep (10 internal steps, new force each call) through fmpy", fmt_t(fmu["doStep"]),
            "–", None, "median per call")
        row("  the library: set_input_vector + step (10 internal steps)", fmt_t(lib_step), "–", None,
            f"{fmt_t(lib['set_input_vector'])} + {fmt_t(lib['step'])}")
        row("  doStep overhead: doStep − library", fmt_t(fmu["doStep"] - lib_step), "10 µs",
            (fmu["doStep"] - lib_step) / 10e-6, f"floor (no-op doStep) {fmt_t(noop_calls['doStep'])}")
        row("  doStep overhead, force held: doStep − library step", fmt_t(held["doStep"] - lib_held["step"]),
            "10 µs", (held["doStep"] - lib_held["step"]) / 10e-6, "no input change")
        row("  setReal(3 forces)", fmt_t(fmu["setReal"]), fmt_t(noop_calls["setReal"]),
            fmu["setReal"] / noop_calls["setReal"], "vs no-op FMU")
        row("  getReal(6 outputs), computed on this first read", fmt_t(fmu["getReal"]),
            fmt_t(noop_calls["getReal"] + lib["output_vector"]), fmu["getReal"] / (noop_calls["getReal"]
                                                                               + lib["output_vector"]),
            f"vs no-op getReal + library outputs {fmt_t(lib['output_vector'])}")
        row("  getReal(max_elastic_displacement) after those", fmt_t(rb["fmu_max"]["getReal max"]), "–", None,
            "the deferred whole-mesh search")
        cycle = fmu["setReal"] + fmu["doStep"] + fmu["getReal"]
        lib_cycle = lib_step + lib["output_vector"]
        noop_cycle = noop_calls["setReal"] + noop_calls["doStep"] + noop_calls["getReal"]
        row("  whole call cycle setReal + doStep + getReal − library (incl. outputs)", fmt_t(cycle - lib_cycle),
            "10 µs", (cycle - lib_cycle) / 10e-6, f"of which the no-op floor {fmt_t(noop_cycle)}")
        row("  the same beyond the floor", fmt_t(cycle - lib_cycle - noop_cycle), "10 µs",
            (cycle - lib_cycle - noop_cycle) / 10e-6, "our FMU layer")

        lib = ffrbeam_library_step()
        row("FFRBeam step + outputs, library (XFF, 6 modes)", fmt_t(lib), "–", None)
        duration = 1.0 if quick else HAMMER_RECORD
        low, how = record_time(lambda d: ffrbeam_lowlevel(fmus["FFRBeam"], d)["seconds"], duration)
        row("FFRBeam 60 s hammer record @ 10 kS/s, fmpy FMU2Slave loop", fmt_t(low), "12 s", low / 12.0, how)
        floor_low = floor * HAMMER_RECORD / HAMMER_DT
        row("  beyond the FMU2Slave floor (600 000 × no-op step)", fmt_t(low - floor_low), fmt_t(floor_low),
            None, "ours / floor: " + f"{(low - floor_low) / floor_low:.2f}")
        sim, how = record_time(lambda d: simulate_fmu_record(fmus["FFRBeam"], d, ("F_x", "F_y", "F_z"),
                                                             [f"sensor_a_{a}" for a in "xyz"], FFR_HAMMER_START),
                               duration)
        sim_floor, _ = record_time(lambda d: simulate_fmu_record(noop, d, ("i0", "i1", "i2"), ("o0", "o1", "o2"), {}),
                                   duration)
        row("FFRBeam 60 s hammer record, fmpy.simulate_fmu (user's route)", fmt_t(sim), "12 s", sim / 12.0, how)
        row("  the same simulate_fmu call on the no-op FMU (floor)", fmt_t(sim_floor), "12 s", sim_floor / 12.0,
            "fmpy input + recorder + pythonfmu")
        row("  FFRBeam beyond that floor", fmt_t(sim - sim_floor), fmt_t(sim_floor), (sim - sim_floor) / sim_floor)

        t_ffr = fmu_instantiation(fmus["FFRBeam"])
        row("FFRBeam.fmu instantiation (default, fresh process)", fmt_t(t_ffr), "1 s", t_ffr / 1.0)
        t_npz = fmu_instantiation(fmus["ReframeBody"], model=str(npz))
        row(f"ReframeBody.fmu instantiation ({info_s['n_dof']}-DOF .npz, fresh process)", fmt_t(t_npz), "1 s",
            t_npz / 1.0)
        if not quick:
            t_cold = fmu_instantiation(fmus["ReframeBody"], env={"FLEXFMU_CACHE": "0"})
            row("ReframeBody.fmu instantiation, default plate 51k DOFs, no model cache", fmt_t(t_cold), "1 s",
                t_cold / 1.0, "fresh process, FLEXFMU_CACHE=0")
            fmu_instantiation(fmus["ReframeBody"])                  # fills the on-disk cache if empty
            t_warm = fmu_instantiation(fmus["ReframeBody"])
            row("ReframeBody.fmu instantiation, default plate 51k DOFs, cache warm", fmt_t(t_warm), "1 s",
                t_warm / 1.0, "fresh process, on-disk model cache")

    # (4) Exudyn
    if not quick:
        ex = exudyn_comparison(quick)
        extra["exudyn"] = ex
        if ex is None:
            print(common.skipped("the comparison with Exudyn", "exudyn"), flush=True)
        for scheme, at in (ex or {}).get("ours_at", {}).items():
            theirs = ex["exudyn_at"]
            if at and theirs:
                row(f"CPU time to 1e-4 in ω and deflection vs Exudyn, {scheme}", fmt_t(at[1]), fmt_t(theirs[1]),
                    at[1] / theirs[1], f"dt ours {at[0]:g}, Exudyn {theirs[0]:g}")
            else:
                row(f"CPU time to 1e-4 in ω and deflection vs Exudyn, {scheme}", "–", "–", None,
                    "1e-4 not reached by " + ("ours" if not at else "Exudyn"))

    # (5) set-up
    n_frame, t_frame = frame_modal_time()
    row(f"frame set-up: mesh + assembly + 10 modes, {n_frame} DOFs", fmt_t(t_frame), "2 s", t_frame / 2.0)
    if not quick:
        from flexfmu.linalg.modal_basis import _mkl_pardiso, modal_basis
        from flexfmu.reframe.models import load_model
        pardiso = _mkl_pardiso() is not None and os.environ.get("FLEXFMU_PARDISO", "1") != "0"
        _, info_d = _plate_integrator((100, 8, 2))
        row(f"plate set-up: mesh + assembly, {info_d['n_dof']} DOFs", fmt_t(info_d["assembly"]), "–", None)
        row(f"plate modal basis (10 flexible), {info_d['n_dof']} DOFs", fmt_t(info_d["modal"]), "2 s",
            info_d["modal"] / 2.0, "block Lanczos, shift-invert, computed, "
            + ("MKL PARDISO (pardiso extra)" if pardiso else "SuperLU (no pardiso extra)"))
        if pardiso:                        # the same without the optional extra
            os.environ["FLEXFMU_PARDISO"] = "0"
            try:
                plate = load_model("paper_plate")
                t0 = time.perf_counter()
                modal_basis(plate, 10, cache=False)
                t_superlu = time.perf_counter() - t0
            finally:
                del os.environ["FLEXFMU_PARDISO"]
            row("  the same with SuperLU (FLEXFMU_PARDISO=0, the default install)", fmt_t(t_superlu), "2 s",
                t_superlu / 2.0, "scipy's direct solver only")
        row(f"plate reframe invariants, {info_d['n_dof']} DOFs", fmt_t(info_d["integrator"]), "–", None)
        modal_basis(load_model("paper_plate"), 10)                    # fills the cache if empty
        t0 = time.perf_counter()
        modal_basis(load_model("paper_plate"), 10)
        t_hit = time.perf_counter() - t0
        row(f"plate model + modal basis from the on-disk cache, {info_d['n_dof']} DOFs", fmt_t(t_hit), "2 s",
            t_hit / 2.0, "load_model + modal_basis, cache hit")

    # (6) scaling: each row in a fresh process (its own peak memory)
    scaling = []
    base_div = (20, 2, 1)
    for nfx in (0, 10, 30, 50, 100):
        r = _scaling_row_subprocess(base_div, nfx, 500 if nfx >= 50 else 2000)
        scaling.append(("modes", r))
        print(f"  scaling modes m={r['modes']}: step {fmt_t(r['step'])}", flush=True)
    for div in ((10, 2, 1), (40, 4, 1), (80, 6, 2)) + (() if quick else ((100, 8, 2), (150, 10, 2))):
        r = _scaling_row_subprocess(div, 10, 1000)
        scaling.append(("mesh", r))
        print(f"  scaling mesh {r['n_dof']} DOFs: step {fmt_t(r['step'])}, set-up "
              f"{fmt_t(r['assembly'] + r['modal'] + r['integrator'])}, {r['peak_rss_mb']:.0f} MB", flush=True)
    extra["scaling"] = scaling
    extra["peak_rss_mb"] = peak_memory_mb()
    return rows, notes, extra


def write_report(path: Path, rows, extra, mach, quick, elapsed):
    lines = [
        "# Performance",
        "",
        f"Made from {common.provenance()}.",
        "",
        "Written by `flexfmu bench` (flexfmu.studies.performance; also `benchmarks/performance.py`); the last run"
        + (" (--quick)" if quick else "") + f", {elapsed:.0f} s wall. Per-step and record figures are CPU time of"
        " the benchmark process (best of several; the machine's two cores are shared with other jobs, which"
        " inflate wall time far more than CPU time); the FMU figures marked \"median per call\" are the median wall"
        " time of each FMI call through fmpy (interleaved with the library's calls they are compared with);"
        " set-up and fresh-process instantiation figures are wall time. Expect ±20 % between runs; each ratio is from this one run. Speed is measured here only, never"
        " asserted in tests; `tests/test_performance_equivalence.py` checks that the fast paths compute the"
        " same numbers.",
        "",
        f"Machine: {mach['cpu']}, {mach['cores']} cores; Python {mach['python']}, numpy {mach['numpy']}, "
        f"scipy {mach['scipy']}, reframe kernels {mach['kernels']}; {mach['platform']}.",
        "",
        "| figure | ours | peer or limit | ratio | note |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {a} | {b} | {c} | {d} | {e} |" for a, b, c, d, e in rows]
    lines += ["", "## Scaling (plate, consistent scheme, batched steps of 1e-4 s or the RK4 limit)", "",
              "Each row in a fresh process: set-up = mesh + assembly, modal basis (computed, not cached), "
              "reframe invariants; peak memory = the process's peak resident set (the smallest rows show the "
              "baseline of the interpreter and its imports: numpy, scipy, scikit-fem).", "",
              "| varied | modes m | DOFs | step | outputs of a state | mesh + assembly | modal basis | invariants "
              "| set-up total | peak memory |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {k} | {r['modes']} | {r['n_dof']} | {fmt_t(r['step'])} | {fmt_t(r['outputs'])} | "
              f"{fmt_t(r['assembly'])} | {fmt_t(r['modal'])} | {fmt_t(r['integrator'])} | "
              f"{fmt_t(r['assembly'] + r['modal'] + r['integrator'])} | {r['peak_rss_mb']:.0f} MB |"
              for k, r in extra["scaling"]]
    lines += ["", f"Peak resident memory of the benchmark process itself: {extra['peak_rss_mb']:.0f} MB.", ""]
    ex = extra.get("exudyn")
    if ex:
        lines += ["## Against Exudyn (plate 20x2x1, ten flexible modes, the paper's load, 1 s)", "",
                  "Errors against the converged Exudyn trajectory (flexfmu/data/references/exudyn_plate, "
                  "dt = 2.5e-6 s): max |ω − ω_ref| / max |ω_ref| after the load, and max |u − u_ref| / max |u_ref| of the loaded "
                  "point's elastic deflection; CPU time (process time) of the whole run incl. outputs every 1 ms.", "",
                  "| code | dt | CPU | ω error | deflection error |", "|---|---|---|---|---|"]
        lines += [f"| reframe, {scheme} (ours) | {dt:g} | {fmt_t(c)} | {a:.1e} | {b:.1e} |"
                  for scheme, rows in ex["ours"].items() for dt, c, a, b in rows]
        lines += [f"| Exudyn GeneralizedAlpha | {dt:g} | {fmt_t(c)} | {a:.1e} | {b:.1e} |" for dt, c, a, b in ex["exudyn"]]
        lines += [""]
    # hand-written history and the other generated pages are linked, not pasted: each says when it was made
    lines += ["## More", "",
              "- [Native runtime](performance_native.md): native against Python FMUs, generated by "
              "`benchmarks/native_runtime.py --out docs/performance_native.md`.",
              "- [Step sizes a host passes](host_steps.md): every FMU kind in a host that passes h = t(k+1) − t(k) "
              "against a constant-step host, generated by `benchmarks/host_steps.py --out docs/host_steps.md`.",
              "- [Performance history](performance_notes.md): what changed in the hot loops, round by round, with "
              "the figures measured at the time.", ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short records, no 51k-DOF plate, no Exudyn")
    parser.add_argument("--out", default=str(common.default_report_dir() / "performance.md"),
                        help="report file (default: docs/performance.md of a source checkout, else ./performance.md); "
                             "'-' prints only")
    parser.add_argument("--scaling-row", help=argparse.SUPPRESS)     # nx,ny,nz:n_flexible:n_steps (internal)
    args = parser.parse_args(argv)
    if args.scaling_row:
        import json
        div, nfx, n_steps = args.scaling_row.split(":")
        print(json.dumps(scaling_row(tuple(int(v) for v in div.split(",")), int(nfx), int(n_steps))))
        return 0
    t0 = time.perf_counter()
    mach = machine()
    print(f"machine: {mach}")
    rows, _, extra = run(args.quick)
    if args.out != "-":
        write_report(Path(args.out), rows, extra, mach, args.quick, time.perf_counter() - t0)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
