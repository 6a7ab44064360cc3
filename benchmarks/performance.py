#!/usr/bin/env python3
"""Performance figures of issue 6: figure, ours, peer or limit, ratio; writes docs/performance.md.

    .venv/bin/python benchmarks/performance.py [--quick] [--out docs/performance.md | -]
    flexfmu bench [--quick] [--out ...]                     (the same)

Wall-clock times on this machine (shared, 2 cores: expect +-20 % between runs); every ratio in a table
comes from the same run.  --quick shortens the records and skips the largest meshes and Exudyn.
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

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT / "model") not in sys.path:
    sys.path.insert(0, str(ROOT / "model"))

FORCE = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)   # the reframe paper's load, 10 ms half-sine


def _best(fn, repeat=3):
    """Smallest wall time of ``repeat`` calls of fn() (s) — the least disturbed by other load."""
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
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

    from flexfmu import _reframe_kernels as kern
    numba_version = None
    if kern.NUMBA:
        import numba
        numba_version = numba.__version__
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba_version or "not used (numpy kernels)",
            "platform": platform.platform()}


# --------------------------------------------------------------------------- reframe
def _plate_integrator(divisions, n_flexible=10, scheme="consistent"):
    from flexfmu.modal_basis import modal_basis
    from flexfmu.plate import paper_plate
    from flexfmu.reframe import ReframeIntegrator

    t0 = time.perf_counter()
    plate = paper_plate(divisions)
    t1 = time.perf_counter()
    basis = modal_basis(plate, n_flexible)
    t2 = time.perf_counter()
    integ = ReframeIntegrator(plate, basis, scheme=scheme)
    t3 = time.perf_counter()
    return integ, {"assembly": t1 - t0, "modal": t2 - t1, "integrator": t3 - t2, "n_dof": plate.n_dof}


def reframe_step_times(integ, n=2000):
    """(single advance() call, batched advance_steps, output_vector) per call, s; paper's load, moving."""
    from flexfmu.plate import LOAD_POINT
    from flexfmu.reframe import RK4_STABILITY_LIMIT, PointLoad, half_sine_pulse

    # the paper's 1e-4 s, or less where many retained modes need it (RK4: dt * omega_max <= 2.8)
    dt = min(1e-4, 0.9 * RK4_STABILITY_LIMIT / integ.data.omega_max) if integ.data.omega_max > 0 else 1e-4
    loads = integ.prepare_loads(PointLoad(LOAD_POINT, half_sine_pulse(FORCE, 0.01)))
    s0 = integ.initial_state(omega0=(0.5, 0.2, 0.8))
    s0 = integ.advance_steps(s0, dt, 20, loads)              # loaded, deforming, compiled
    pts = integ.point_indices([integ.data.structure.meta["points"]["P1"]])

    def single():
        s = s0
        for _ in range(n):
            s = integ.advance(s, dt, loads)

    def batched():
        integ.advance_steps(s0, dt, n, loads)

    def outputs():
        for _ in range(n // 10):
            integ.output_vector(s0, loads, pts)

    return _best(single) / n, _best(batched) / n, _best(outputs) / (n // 10)


# --------------------------------------------------------------------------- FMUs through fmpy
def _build_fmus(out: Path) -> dict:
    import importlib.util
    spec = importlib.util.spec_from_file_location("build_fmus", ROOT / "build_scripts" / "build_fmus.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    import contextlib
    import io
    with contextlib.redirect_stdout(io.StringIO()):
        return {p.stem: p for p in module.build(out)}


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


def ffrbeam_hammer(fmu: Path, duration: float) -> dict:
    """The paper's hammer record: 1 ms half-sine blow, accelerometer read at 10 kS/s; s per 60 s record."""
    dt = 1e-4
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    pulse = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    sl = _Slave(fmu, boundary="XFF", damping_ratio=0.002, load_s=0.45, sensor_s=0.04)
    vin = [sl.vr[f"F_{a}"] for a in "xyz"]
    vout = [sl.vr[f"sensor_a_{a}"] for a in "xyz"]
    f = sl.fmu
    rec = np.empty((n, 3))
    t0 = time.perf_counter()
    for k in range(n):
        p = float(pulse[k])
        f.setReal(vin, [p, 0.7 * p, 0.4 * p])
        f.doStep(k * dt, dt)
        rec[k] = f.getReal(vout)
    low = time.perf_counter() - t0
    sl.free()
    # the same through fmpy.simulate_fmu (its own per-step Python: input interpolation, recorder)
    from fmpy import simulate_fmu
    m = min(n, 5000)
    sig = np.zeros(m + 1, dtype=[("time", float), ("F_x", float), ("F_y", float), ("F_z", float)])
    sig["time"] = np.arange(m + 1) * dt
    t0 = time.perf_counter()
    simulate_fmu(str(fmu), start_time=0.0, stop_time=m * dt, step_size=dt, output_interval=dt, input=sig,
                 start_values={"boundary": "XFF"}, output=["sensor_a_x", "sensor_a_y", "sensor_a_z"])
    sim = time.perf_counter() - t0
    return {"lowlevel_per_step": low / n, "simulate_fmu_per_step": sim / m, "peak": float(np.max(np.abs(rec)))}


def ffrbeam_library_step(n=20000):
    from flexfmu.ffr_beam_sim import FFRBeamConfig, FFRBeamSimulator
    sim = FFRBeamSimulator(FFRBeamConfig(boundary="XFF", damping_ratio=0.002, load_s=0.45, sensor_s=0.04))
    sim.set_input_vector([0.0] * 15)

    def run():
        for _ in range(n):
            sim.step(1e-4)
            sim.output_vector()
    return _best(run) / n


def noop_fmu_per_step(tmp: Path) -> float:
    """fmpy + pythonfmu floor: setReal(3) + doStep + getReal(3) on an FMU whose doStep does nothing."""
    script = tmp / "Noop.py"
    script.write_text(
        "from pythonfmu import Fmi2Slave, Fmi2Causality, Fmi2Variability, Real\n"
        "class Noop(Fmi2Slave):\n"
        "    author = 'bench'\n    description = 'no-op'\n"
        "    def __init__(self, **kw):\n"
        "        super().__init__(**kw)\n"
        "        self.v = dict.fromkeys([f'i{k}' for k in range(3)] + [f'o{k}' for k in range(3)], 0.0)\n"
        "        for k in range(3):\n"
        "            self.register_variable(Real(f'i{k}', causality=Fmi2Causality.input, "
        "variability=Fmi2Variability.continuous, getter=lambda k=k: self.v[f'i{k}'], "
        "setter=lambda x, k=k: self.v.__setitem__(f'i{k}', x)))\n"
        "            self.register_variable(Real(f'o{k}', causality=Fmi2Causality.output, "
        "variability=Fmi2Variability.continuous, getter=lambda k=k: self.v[f'o{k}']))\n"
        "    def do_step(self, t, h):\n        return True\n")
    from pythonfmu.builder import FmuBuilder
    fmu = Path(FmuBuilder.build_FMU(script, dest=tmp))
    sl = _Slave(fmu)
    vin = [sl.vr[f"i{k}"] for k in range(3)]
    vout = [sl.vr[f"o{k}"] for k in range(3)]
    n = 20000

    def run():
        for k in range(n):
            sl.fmu.setReal(vin, [0.0, 0.0, 0.0])
            sl.fmu.doStep(k * 1e-4, 1e-4)
            sl.fmu.getReal(vout)
    per = _best(run) / n
    sl.free()
    return per


def reframebody_overhead(fmu: Path, npz: Path, integ_batched_step: float, n_internal=10) -> dict:
    """doStep of ReframeBody through fmpy (communication step = n_internal internal steps of 1e-4 s)
    minus n_internal library steps: the FMU's per-call overhead (inputs, outputs, fmpy, pythonfmu)."""
    sl = _Slave(fmu, model=str(npz), n_flexible_modes=10, internal_step=1e-4)
    vin = [sl.vr[f"F_{a}"] for a in "xyz"]
    vout = [sl.vr[n] for n in ("omega_1", "omega_2", "omega_3", "out_acc_x", "out_acc_y", "out_acc_z")]
    f = sl.fmu
    h = n_internal * 1e-4
    state = {"t": 0.0}
    n = 1000

    def run():
        for _ in range(n):
            f.setReal(vin, [FORCE[0], 0.0, FORCE[2]])
            f.doStep(state["t"], h)
            state["t"] += h
            f.getReal(vout)
    per_call = _best(run) / n
    sl.free()
    return {"doStep": per_call, "overhead": per_call - n_internal * integ_batched_step, "init": sl.init_time}


def fmu_instantiation(fmu: Path, **start) -> float:
    """Instantiate + initialise in a fresh process (no in-process caches), s."""
    code = ("import sys, time; sys.path.insert(0, %r); from benchmarks.performance import _Slave; "
            "s = _Slave(%r, **%r); print(s.init_time)") % (str(ROOT), str(fmu), start)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    return float(out.stdout.strip().splitlines()[-1])


# --------------------------------------------------------------------------- Exudyn
def exudyn_comparison(quick: bool) -> dict | None:
    """CPU time to reach 1e-4 relative accuracy in omega and in the loaded point's elastic deflection,
    against the converged Exudyn reference trajectory (tests/reference/exudyn_plate, dt = 2.5e-6 s), for
    the reframe integrator and for Exudyn's own reduced-order FFRF (GeneralizedAlpha), both 1 s of the
    paper's load on the same plate (20x2x1), M, K, nodes and ten flexible modes."""
    try:
        import exudyn  # noqa: F401
    except ImportError:
        return None
    import importlib.util
    spec = importlib.util.spec_from_file_location("exu_gen", ROOT / "tests/reference/exudyn_plate/generate.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    ref = np.loadtxt(ROOT / "tests/reference/exudyn_plate/trajectory.csv", delimiter=",", comments="#", skiprows=1)
    cols = {name: k for k, name in enumerate(gen.COLUMNS)}
    after = ref[:, 0] > 0.012
    w_ref = ref[:, [cols[f"omega_{i}"] for i in (1, 2, 3)]]
    u_ref = ref[:, [cols[f"u_load_{c}"] for c in "xyz"]]

    def errors(w, u):
        ew = np.max(np.linalg.norm(w[after] - w_ref[after], axis=1)) / np.max(np.linalg.norm(w_ref[after], axis=1))
        eu = np.max(np.linalg.norm(u - u_ref, axis=1)) / np.max(np.linalg.norm(u_ref, axis=1))
        return float(ew), float(eu)

    from flexfmu.modal_basis import modal_basis
    from flexfmu.plate import LOAD_POINT, paper_plate
    from flexfmu.reframe import PointLoad, ReframeIntegrator, half_sine_pulse
    plate = paper_plate(gen.DIVISIONS)
    integ = ReframeIntegrator(plate, modal_basis(plate, gen.N_FLEXIBLE, gen.ZETA))
    load = PointLoad(LOAD_POINT, half_sine_pulse(gen.FORCE, gen.PULSE))
    node = integ.point_indices([LOAD_POINT])[0]
    Phi_load = integ.data.Phi[integ.data.trans_rows[node]]
    ours = []
    for dt in ((2e-4, 1e-4, 5e-5) if quick else (4e-4, 2e-4, 1e-4, 5e-5, 2.5e-5)):
        every = int(round(gen.OUTPUT_PERIOD / dt))
        integ.set_initial()
        t0 = time.process_time()
        r = integ.run(gen.T_END, dt, load, every=every)
        cpu = time.process_time() - t0
        ours.append((dt, cpu, *errors(r.omega, r.q @ Phi_load.T)))
    plate_fem, fem, _ = gen.build_fem()
    theirs = []
    for dt in ((1e-4, 5e-5) if quick else (2e-4, 1e-4, 5e-5, 2.5e-5)):
        t0 = time.process_time()
        table, _ = gen.simulate(fem, dt=dt)
        cpu = time.process_time() - t0
        theirs.append((dt, cpu, *errors(table[:, 1:4], table[:, 4:7])))

    def time_to(rows, tol=1e-4):
        ok = [r for r in rows if max(r[2], r[3]) <= tol]
        return min(ok, key=lambda r: r[1]) if ok else None
    return {"ours": ours, "exudyn": theirs, "ours_at": time_to(ours), "exudyn_at": time_to(theirs)}


# --------------------------------------------------------------------------- set-up
def frame_modal_time(target_dof=10_000) -> tuple[int, float]:
    from flexfmu.assembly import build_beam_model
    from flexfmu.modal import solve_modes
    from flexfmu.scene import load_scene
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


def run(quick: bool) -> tuple[list, list, dict]:
    rows, notes, extra = [], [], {}

    def row(figure, ours, peer, ratio, note=""):
        rows.append((figure, ours, peer, "–" if ratio is None else f"{ratio:.2f}", note))
        print(f"{figure:60s} {ours:>12s} {peer:>14s} {rows[-1][3]:>6s} {note}", flush=True)

    print(f"{'figure':60s} {'ours':>12s} {'peer / limit':>14s} {'ratio':>6s}")
    from flexfmu import _reframe_kernels as kern

    # (2) per step, m = 16, and (1) mesh independence
    small, info_s = _plate_integrator((10, 2, 1))
    one, batch, outs = reframe_step_times(small)
    row("reframe step, m = 16, one advance() call", fmt_t(one), "20 µs", one / 20e-6, f"{info_s['n_dof']} DOFs")
    row("reframe step, m = 16, batched (advance_steps, FMU)", fmt_t(batch), "20 µs", batch / 20e-6)
    row("reframe outputs of one state (output_vector)", fmt_t(outs), "–", None)
    if kern.NUMBA:
        kern_backup = kern.consistent_steps
        kern.consistent_steps = kern.consistent_steps_numpy
        _, batch_np, _ = reframe_step_times(small, n=200)
        kern.consistent_steps = kern_backup
        row("reframe step, m = 16, numpy fallback (FLEXFMU_NUMBA=0)", fmt_t(batch_np), fmt_t(batch), batch_np / batch,
            "vs numba")
    big_div = (40, 6, 2) if quick else (70, 8, 2)
    big, info_b = _plate_integrator(big_div)
    _, batch_big, outs_big = reframe_step_times(big)
    row(f"reframe step, m = 16, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(batch_big), fmt_t(batch),
        batch_big / batch, "limit 1.2")
    row(f"reframe outputs, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(outs_big), fmt_t(outs),
        outs_big / outs, "max elastic displacement search")
    del big
    gc.collect()

    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        fmus = _build_fmus(tmp / "dist")
        from flexfmu.io import save_structure
        npz = save_structure(tmp / "plate_10x2x1.npz", small.data.structure)
        floor = noop_fmu_per_step(tmp)
        row("fmpy + pythonfmu floor: setReal + doStep + getReal, no-op FMU", fmt_t(floor), "–", None)
        ov = reframebody_overhead(fmus["ReframeBody"], npz, batch)
        row("ReframeBody.fmu doStep (10 internal steps) through fmpy", fmt_t(ov["doStep"]), "–", None)
        row("  of which FMU overhead (doStep − 10 library steps)", fmt_t(ov["overhead"]), "10 µs",
            ov["overhead"] / 10e-6, "incl. outputs + fmpy floor")
        lib = ffrbeam_library_step()
        row("FFRBeam step + outputs, library (XFF, 6 modes)", fmt_t(lib), "–", None)
        duration = 1.0 if quick else 5.0
        hb = ffrbeam_hammer(fmus["FFRBeam"], duration)
        rec_low = hb["lowlevel_per_step"] * 600_000
        rec_sim = hb["simulate_fmu_per_step"] * 600_000
        row("FFRBeam 60 s hammer record @ 10 kS/s, fmpy FMU2Slave loop", fmt_t(rec_low), "12 s", rec_low / 12.0,
            f"from {duration:g} s")
        row("FFRBeam 60 s hammer record @ 10 kS/s, fmpy simulate_fmu", fmt_t(rec_sim), "12 s", rec_sim / 12.0,
            f"floor {fmt_t(floor * 600_000)} (no-op FMU)")
        t_ffr = fmu_instantiation(fmus["FFRBeam"])
        row("FFRBeam.fmu instantiation (default, fresh process)", fmt_t(t_ffr), "1 s", t_ffr / 1.0)
        t_npz = fmu_instantiation(fmus["ReframeBody"], model=str(npz))
        row(f"ReframeBody.fmu instantiation ({info_s['n_dof']}-DOF .npz, fresh process)", fmt_t(t_npz), "1 s",
            t_npz / 1.0)
        if not quick:
            t_rb = fmu_instantiation(fmus["ReframeBody"])
            row("ReframeBody.fmu instantiation (default paper_plate 51k DOFs)", fmt_t(t_rb), "1 s", t_rb / 1.0)

    # (4) Exudyn
    if not quick:
        ex = exudyn_comparison(quick)
        extra["exudyn"] = ex
        if ex and ex["ours_at"] and ex["exudyn_at"]:
            row("CPU time to 1e-4 in ω and tip deflection vs Exudyn (1 s)", fmt_t(ex["ours_at"][1]),
                fmt_t(ex["exudyn_at"][1]), ex["ours_at"][1] / ex["exudyn_at"][1],
                f"dt ours {ex['ours_at'][0]:g}, Exudyn {ex['exudyn_at'][0]:g}")

    # (5) set-up
    n_frame, t_frame = frame_modal_time()
    row(f"frame set-up: mesh + assembly + 10 modes, {n_frame} DOFs", fmt_t(t_frame), "2 s", t_frame / 2.0)
    if not quick:
        _, info_d = _plate_integrator((100, 8, 2))
        row(f"plate set-up: assembly, {info_d['n_dof']} DOFs", fmt_t(info_d["assembly"]), "–", None)
        row(f"plate modal basis (10 flexible), {info_d['n_dof']} DOFs", fmt_t(info_d["modal"]), "2 s",
            info_d["modal"] / 2.0)
        row(f"plate reframe invariants, {info_d['n_dof']} DOFs", fmt_t(info_d["integrator"]), "–", None)

    # (6) scaling
    scaling = []
    base_div = (20, 2, 1)
    for nfx in (0, 10, 30, 50, 100):
        integ, info = _plate_integrator(base_div, nfx)
        one, batch, outs = reframe_step_times(integ, n=500 if nfx >= 50 else 2000)
        scaling.append(("modes", 6 + nfx, info["n_dof"], batch, outs, info["assembly"] + info["modal"] + info["integrator"]))
    for div in ((10, 2, 1), (40, 4, 1), (80, 6, 2)) + (() if quick else ((150, 10, 2),)):
        integ, info = _plate_integrator(div, 10)
        one, batch, outs = reframe_step_times(integ, n=1000)
        scaling.append(("mesh", 16, info["n_dof"], batch, outs, info["assembly"] + info["modal"] + info["integrator"]))
        del integ
        gc.collect()
    extra["scaling"] = scaling
    extra["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return rows, notes, extra


def write_report(path: Path, rows, extra, mach, quick, elapsed):
    lines = [
        "# Performance (issue 6)",
        "",
        "Written by `benchmarks/performance.py` (also `flexfmu bench`); the last run"
        + (" (--quick)" if quick else "") + f", {elapsed:.0f} s. Wall-clock times on a shared machine: expect ±20 %"
        " between runs; each ratio is from this one run. Speed is measured here only, never asserted in tests;"
        " `tests/test_performance_equivalence.py` checks that the fast paths compute the same numbers.",
        "",
        f"Machine: {mach['cpu']}, {mach['cores']} cores; Python {mach['python']}, numpy {mach['numpy']}, "
        f"scipy {mach['scipy']}, numba {mach['numba']}; {mach['platform']}.",
        "",
        "| figure | ours | peer or limit | ratio | note |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {a} | {b} | {c} | {d} | {e} |" for a, b, c, d, e in rows]
    lines += ["", "## Scaling (plate, consistent scheme, batched steps of 1e-4 s)", "",
              "| varied | modes m | DOFs | step | outputs of a state | set-up (assembly + modes + invariants) |",
              "|---|---|---|---|---|---|"]
    lines += [f"| {k} | {m} | {n} | {fmt_t(a)} | {fmt_t(b)} | {fmt_t(c)} |" for k, m, n, a, b, c in extra["scaling"]]
    lines += ["", f"Peak resident memory of the benchmark process: {extra['peak_rss_mb']:.0f} MB.", ""]
    ex = extra.get("exudyn")
    if ex:
        lines += ["## Against Exudyn (plate 20x2x1, ten flexible modes, the paper's load, 1 s)", "",
                  "Errors against the converged Exudyn trajectory (tests/reference/exudyn_plate, dt = 2.5e-6 s): "
                  "max |ω − ω_ref| / max |ω_ref| after the load, and max |u − u_ref| / max |u_ref| of the loaded "
                  "point's elastic deflection; CPU time (process time) of the whole run incl. outputs every 1 ms.", "",
                  "| code | dt | CPU | ω error | deflection error |", "|---|---|---|---|---|"]
        lines += [f"| reframe (ours) | {dt:g} | {fmt_t(c)} | {a:.1e} | {b:.1e} |" for dt, c, a, b in ex["ours"]]
        lines += [f"| Exudyn GeneralizedAlpha | {dt:g} | {fmt_t(c)} | {a:.1e} | {b:.1e} |" for dt, c, a, b in ex["exudyn"]]
        lines += [""]
    notes = path.with_name("performance_notes.md")
    if notes.exists():
        lines += [notes.read_text().rstrip(), ""]
    path.write_text("\n".join(lines))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short records, no 51k-DOF plate, no Exudyn")
    parser.add_argument("--out", default=str(ROOT / "docs" / "performance.md"),
                        help="report file (default docs/performance.md); '-' prints only")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    mach = machine()
    print(f"machine: {mach}")
    rows, _, extra = run(args.quick)
    print("\nscaling (kind, modes, DOFs, step, outputs, set-up):")
    for k, m, n, a, b, c in extra["scaling"]:
        print(f"  {k:5s} m={m:4d} dofs={n:7d} step {fmt_t(a):>10s} outputs {fmt_t(b):>10s} set-up {fmt_t(c):>10s}")
    if args.out != "-":
        write_report(Path(args.out), rows, extra, mach, args.quick, time.perf_counter() - t0)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
