#!/usr/bin/env python3
"""Native against Python FMUs (docs/performance.md, "Native runtime"): one run, figures and ratios printed.

    .venv/bin/python benchmarks/native_runtime.py [--hammer-seconds 60] [--reframe-only]

1. Per-cycle cost (fmi2SetReal of the 3 force inputs + fmi2DoStep + fmi2GetReal of the 3 accelerometer outputs) of
   FFRBeam (defaults, 6 modes), native and Python, in the plain C host (examples/c_host, its own timer around the
   stepping loop) and through fmpy (FMU2Slave, perf_counter around the same loop).
2. The physical floor: the floating-point operations of one native step and output (matrix-vector products of
   the model's sizes) at this machine's measured rate (a single-threaded 2000 x 2000 matrix product, and a
   12 x 12 matrix-vector product in a tight numpy-free C loop is not attempted: the rate is the BLAS peak, so the
   floor is a lower bound).
3. The paper's hammer record: 60 s at 10 kS/s (a 1 ms, 20 N blow on F_x, F_y, F_z), XFF, in the C host: process
   wall time (load, instantiate, stepping, exit) of the native FMU.
4. The wave-converter example system (5 FMUs, 1 ms, 10 s, fmpy master) with the Python and with the native
   FFRBeam harvester.
5. ReframeBody (defaults: the paper's plate, 51k DOFs), native and Python, in the C host: per-cycle cost (setReal
   of F_x, F_y, F_z (a 10 ms pulse) + doStep (h = 1 ms) + getReal of out_acc_x/y/z); the native FMU also with
   max_elastic_displacement read every cycle (its whole-mesh search, computed only when read).
"""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))   # host_tools: compile the example C host the way the tests do

FORCES = ("F_x", "F_y", "F_z")
SENSOR = ("sensor_a_x", "sensor_a_y", "sensor_a_z")
REFRAME_ACC = ("out_acc_x", "out_acc_y", "out_acc_z")


def value_refs(fmu: Path) -> tuple[dict, str, str]:
    from fmpy import read_model_description
    md = read_model_description(str(fmu))
    return ({v.name: v.valueReference for v in md.modelVariables}, md.guid, md.coSimulation.modelIdentifier)


def c_host_cycle(host: Path, fmu: Path, n_steps: int, step: float, pulse: float, damping: float | None,
                 workdir: Path, outputs=SENSOR) -> dict:
    """Run the C host (bare environment: no PYTHON*, no LD_PRELOAD); its loop time and the process wall time."""
    from fmpy import extract
    vr, guid, ident = value_refs(fmu)
    folder = workdir / f"{fmu.parent.name}-{fmu.stem}-{n_steps}"
    if not folder.exists():
        extract(str(fmu), unzipdir=str(folder))
    cmd = [str(host), "--quiet", repr(step), str(n_steps), "--fmu", folder, ident, guid]
    if damping is not None:
        cmd += ["--set", "real", str(vr["damping_ratio"]), repr(damping)]
    for name, share in zip(FORCES, (1.0, 0.7, 0.4)):
        cmd += ["--pulse", str(vr[name]), repr(20.0 * share), repr(pulse)]
    for name in outputs:
        cmd += ["--output", str(vr[name])]
    env = {"PATH": "/usr/bin:/bin", "HOME": str(workdir)}
    start = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=3600)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"C host failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    loop = float(re.search(r"in ([0-9.]+) s \(", proc.stderr).group(1))
    return {"wall_s": wall, "loop_s": loop, "us_per_cycle": 1e6 * loop / n_steps, "last": proc.stdout.strip()}


def fmpy_cycle(fmu: Path, n_steps: int, step: float, workdir: Path) -> float:
    """us per (setReal 3 + doStep + getReal 3) through fmpy's FMU2Slave."""
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave
    vr, guid, ident = value_refs(fmu)
    folder = extract(str(fmu), unzipdir=str(workdir / f"{fmu.stem}-fmpy-{n_steps}"))
    slave = FMU2Slave(guid=guid, unzipDirectory=folder, modelIdentifier=ident, instanceName="bench")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    ins, outs = [vr[n] for n in FORCES], [vr[n] for n in SENSOR]
    values = [1.0, 0.7, 0.4]
    t = 0.0
    start = time.perf_counter()
    for _ in range(n_steps):
        slave.setReal(ins, values)
        slave.doStep(currentCommunicationPoint=t, communicationStepSize=step)
        slave.getReal(outs)
        t += step
    elapsed = time.perf_counter() - start
    slave.terminate()
    slave.freeInstance()
    return 1e6 * elapsed / n_steps


def machine_rate() -> float:
    """Double-precision flop/s of a single-threaded 2000 x 2000 matrix product (best of 3)."""
    from threadpoolctl import threadpool_limits
    a, b = np.random.default_rng(0).standard_normal((2, 2000, 2000))
    best = np.inf
    with threadpool_limits(1):
        for _ in range(3):
            start = time.perf_counter()
            a @ b
            best = min(best, time.perf_counter() - start)
    return 2 * 2000 ** 3 / best


def step_flops(fmu: Path) -> tuple[int, str]:
    """Flops of one native step and output evaluation, from the model file's sizes."""
    import zipfile

    from flexfmu.fmi.model_file import read_model_file
    with tempfile.TemporaryDirectory() as tmp, zipfile.ZipFile(fmu) as zf:
        zf.extract("resources/flexfmu_model.bin", tmp)
        entries = read_model_file(Path(tmp) / "resources" / "flexfmu_model.bin")
    _, nx, nu = np.shape(entries["lti.B"])
    ny = np.shape(entries["lti.Cx"])[1]
    nq = np.size(entries["lti.quad_value"])
    step = 2 * nx * nx + 2 * nx * nu + nx
    outputs = 2 * ny * (nx + nu) + ny + 3 * nq
    return step + outputs, f"nx {nx}, nu {nu}, ny {ny}, {nq} quadratic terms: step {step} + outputs {outputs}"


def wave_converter_wall(fmu_dir: Path, harvester: Path, t_end: float) -> float:
    from dataclasses import replace

    from flexfmu.cosim.masters import load_system, run
    system = load_system(ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml").with_fmu_dir(fmu_dir)
    sims = [replace(s, source=harvester) if s.model == "FFRBeam" else s for s in system.simulators]
    system = replace(system, simulators=sims)
    start = time.perf_counter()
    run(system, t_end)
    return time.perf_counter() - start


def reframe_rows(host: Path, python: Path, native: Path, cycles: int, workdir: Path) -> None:
    """5. ReframeBody native against Python in the C host (module docstring)."""
    h, pulse = 1e-3, 0.01
    print(f"ReframeBody (defaults), h = {h:g} s, cycle = setReal (F_x, F_y, F_z) + doStep + getReal "
          f"({', '.join(REFRAME_ACC)}), {cycles} cycles:")
    c_native = c_host_cycle(host, native, cycles, h, pulse, None, workdir, outputs=REFRAME_ACC)
    c_max = c_host_cycle(host, native, cycles, h, pulse, None, workdir,
                         outputs=REFRAME_ACC + ("max_elastic_displacement",))
    c_python = c_host_cycle(host, python, cycles, h, pulse, None, workdir, outputs=REFRAME_ACC)
    print(f"  {'host':8s} {'native (us)':>12s} {'Python (us)':>12s} {'Python / native':>16s}")
    print(f"  {'C host':8s} {c_native['us_per_cycle']:12.2f} {c_python['us_per_cycle']:12.2f} "
          f"{c_python['us_per_cycle'] / c_native['us_per_cycle']:16.1f}")
    print(f"  native, max_elastic_displacement read too every cycle: {c_max['us_per_cycle']:.2f} us "
          f"(+{c_max['us_per_cycle'] - c_native['us_per_cycle']:.2f} us: the whole-mesh search, only when read)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hammer-seconds", type=float, default=60.0)
    parser.add_argument("--cycles", type=int, default=20000, help="cycles per cost measurement (native x10)")
    parser.add_argument("--wec-seconds", type=float, default=10.0)
    parser.add_argument("--reframe-cycles", type=int, default=5000, help="cycles per ReframeBody measurement")
    parser.add_argument("--reframe-only", action="store_true", help="only 5. (ReframeBody in the C host)")
    parser.add_argument("--out", type=Path, help="also write what is printed as a report (docs/performance_native.md)")
    args = parser.parse_args(argv)
    from flexfmu.studies import common
    with common.recording() as printed:
        status = run(args)
    if args.out:
        common.write_text_report(args.out, "Native runtime: FMUs with no Python",
                                 "Printed by `benchmarks/native_runtime.py` (one run on a shared 2-core machine: "
                                 "figures from this run, ratios within it). " + __doc__.split("\n\n", 1)[1].strip(),
                                 printed.getvalue(), [])
    return status


def run(args) -> int:

    from host_tools import compile_c_host

    from flexfmu.cosim.masters import LibrarySlave, load_system
    from flexfmu.fmi.build import build
    from flexfmu.fmi.native import build_registry_fmu

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        python_dir, native_dir = tmp / "python", tmp / "native"
        build(python_dir)
        host = compile_c_host(tmp)
        if args.reframe_only:
            reframe_rows(host, python_dir / "ReframeBody.fmu", build_registry_fmu("ReframeBody", out=native_dir),
                         args.reframe_cycles, tmp)
            return 0
        native = build_registry_fmu("FFRBeam", out=native_dir)
        wec = load_system(ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml")
        harvester_values = {k: v for k, v in wec.by_model("FFRBeam")[0].initial_values.items()
                            if k in LibrarySlave(wec.by_model("FFRBeam")[0]).config.__dataclass_fields__}
        native_harvester = build_registry_fmu("FFRBeam", harvester_values, target=native_dir / "harvester" /
                                              "FFRBeam.fmu")
        python = python_dir / "FFRBeam.fmu"
        h = 1e-4
        print(f"FFRBeam (defaults), h = {h:g} s, cycle = setReal (3) + doStep + getReal (3):")
        c_native = c_host_cycle(host, native, 10 * args.cycles, h, 1e-3, None, tmp)
        c_python = c_host_cycle(host, python, args.cycles, h, 1e-3, None, tmp)
        f_native = fmpy_cycle(native, 10 * args.cycles, h, tmp)
        f_python = fmpy_cycle(python, args.cycles, h, tmp)
        flops, sizes = step_flops(native)
        rate = machine_rate()
        floor_us = 1e6 * flops / rate
        rows = [("C host", c_native["us_per_cycle"], c_python["us_per_cycle"]), ("fmpy", f_native, f_python)]
        print(f"  {'host':8s} {'native (us)':>12s} {'Python (us)':>12s} {'Python / native':>16s} "
              f"{'native / floor':>15s}")
        for name, nat, py in rows:
            print(f"  {name:8s} {nat:12.3f} {py:12.2f} {py / nat:16.1f} {nat / floor_us:15.1f}")
        print(f"  physical floor: {flops} flops per cycle ({sizes}) at {rate / 1e9:.1f} GFLOP/s "
              f"(single-threaded DGEMM 2000^3) = {floor_us:.3f} us")
        n = round(args.hammer_seconds / h)
        hammer = c_host_cycle(host, native, n, h, 1e-3, 0.002, tmp)
        print(f"hammer record, {args.hammer_seconds:g} s at {1 / h:g} S/s ({n} steps), XFF, native FFRBeam in the C "
              f"host: process wall time {hammer['wall_s']:.3f} s (stepping loop {hammer['loop_s']:.3f} s, "
              f"{hammer['us_per_cycle']:.3f} us per step); last line {hammer['last'][:60]}...")
        w_python = wave_converter_wall(python_dir, python_dir / "FFRBeam.fmu", args.wec_seconds)
        w_native = wave_converter_wall(python_dir, native_harvester, args.wec_seconds)
        print(f"wave-converter example, {args.wec_seconds:g} s at 1 ms, fmpy master: Python harvester "
              f"{w_python:.2f} s wall, native harvester {w_native:.2f} s (ratio {w_python / w_native:.2f}); "
              "the other four FMUs are Python")
        reframe_rows(host, python_dir / "ReframeBody.fmu", build_registry_fmu("ReframeBody", out=native_dir),
                     args.reframe_cycles, tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
