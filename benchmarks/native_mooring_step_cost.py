#!/usr/bin/env python3
"""Cost per communication step of the native Mooring (the moordyn kind, csrc/native_moordyn.c) by the tiny C host of
benchmarks/native_wec_step_cost.py (no Python in the loop: per step fmi2SetReal of the 12 inputs, fmi2DoStep,
fmi2GetReal of the 9 outputs), beside the Python simulator's step (flexfmu.wec.mooring.MooringSimulator, the Python
FMU's) and the native FMU's fmi2GetFMUstate / fmi2SetFMUstate (what a rollback coupling scheme pays per step).

    .venv/bin/python benchmarks/native_mooring_step_cost.py [--steps 12000] [--step 0.01] [--repeat 3]

Each figure is the fastest of --repeat runs (a shared machine's other load only slows a run down).  The C host's
inputs are small bounded values changing every step (positions and rotations within 0.05); the lines' cost hardly
depends on them: it is MoorDyn's ceil(h / internal_time_step) RK2 steps of 3 x 20 segments.  Not in the per-step
figure: each instance's set-up at fmi2ExitInitializationMode (MoorDyn's static initial condition), printed apart.
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path


def _python_step(steps: int, h: float, repeat: int) -> float:
    from flexfmu.wec.mooring import MooringSimulator
    w = 2 * math.pi / 8.0
    best = float("inf")
    for _ in range(repeat):
        sim = MooringSimulator()
        sim.outputs()
        start = time.perf_counter()
        for k in range(steps):
            t = k * h
            sim.set_inputs(pos_x=0.5 * math.sin(w * t), vel_x=0.5 * w * math.cos(w * t))
            sim.step(h)
            sim.outputs()
        best = min(best, (time.perf_counter() - start) / steps)
    return best


def _states_and_setup(fmu: Path, repeat: int) -> tuple[float, float, float]:
    """(fastest set-up to the first outputs, fmi2GetFMUstate, fmi2SetFMUstate) in seconds, through fmpy."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from fmu_helpers import Instance
    setup, get, put = float("inf"), float("inf"), float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        inst = Instance(fmu, "bench").initialize()
        setup = min(setup, time.perf_counter() - start)
        inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
        for _ in range(100):
            a = time.perf_counter()
            state = inst.fmu.getFMUState()
            b = time.perf_counter()
            inst.fmu.setFMUState(state)
            c = time.perf_counter()
            inst.fmu.freeFMUState(state)
            get, put = min(get, b - a), min(put, c - b)
        inst.free()
    return setup, get, put


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=12000)
    parser.add_argument("--step", type=float, default=0.01)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    from fmpy import extract
    from native_wec_step_cost import _host, _time

    from flexfmu.fmi.native import build_registry_fmu
    from flexfmu.wec.mooring import MooringConfig
    record = 1200.0 / args.step
    dt = MooringConfig().internal_time_step
    print(f"{args.steps} steps of {args.step} s (internal_time_step {dt:g} s: {math.ceil(args.step / dt)} MoorDyn "
          f"steps each); a 20-minute record is {record:.0f} steps\n")
    with tempfile.TemporaryDirectory(prefix="mooring-bench-") as tmp:
        folder = Path(tmp)
        host = _host(folder)
        fmu = build_registry_fmu("Mooring", target=folder / "Mooring.fmu")
        unzipped = Path(extract(str(fmu), str(folder / "Mooring")))
        library = unzipped / "binaries" / "linux64" / "Mooring.so"
        seconds = _time(host, fmu, unzipped, library, args.steps, args.step, repeat=args.repeat)
        native = seconds / args.steps
        python = _python_step(min(args.steps, 3000), args.step, args.repeat)
        setup, get, put = _states_and_setup(fmu, args.repeat)
    print("| Mooring | us/step | s per 20-min record |")
    print("|---|---|---|")
    print(f"| native (C host) | {native * 1e6:.1f} | {native * record:.1f} |")
    print(f"| Python simulator | {python * 1e6:.1f} | {python * record:.1f} |")
    print(f"\nnative set-up (instantiate to the first outputs, MoorDyn's static solve): {setup:.2f} s; "
          f"fmi2GetFMUstate {get * 1e6:.0f} us, fmi2SetFMUstate {put * 1e6:.0f} us (through fmpy)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
