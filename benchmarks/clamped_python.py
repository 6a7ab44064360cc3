#!/usr/bin/env python3
"""Per-cycle cost of the Python exported clamped body against the Python FFRBeam FMU, through fmpy's FMU2Slave.

    .venv/bin/python benchmarks/clamped_python.py [--cycles 5000] [--rounds 5]

Both FMUs are built into a temporary folder: the bracket of examples/bracket clamped at bolt_1, bolt_2 with the
interface tip=arm_top and modes up to 2000 Hz (what ``flexfmu export examples/bracket/bracket.json --clamp
bolt_1,bolt_2 --interface tip=arm_top --f-max 2000`` writes), and the registry's FFRBeam (``flexfmu build``).

A cycle is what a co-simulation master does per communication step: fmi2SetReal of every input (the forces
vary from step to step, the base motion is held), fmi2DoStep of 1e-4 s, fmi2GetReal of every output.  The two
FMUs run interleaved, ``rounds`` times ``cycles`` cycles each; each figure is the best round, so that the
other load on the machine weighs the same on both.  Speed is measured here only, never asserted in tests.
"""
from __future__ import annotations

import argparse
import math
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BRACKET = ROOT / "examples" / "bracket" / "bracket.json"
STEP = 1e-4                                  # s, the examples' communication step
#: the held base motion, body frame: gravity-like acceleration (m/s^2), a slow spin (rad/s) and spin-up (rad/s^2)
BASE = {"base_a_z": -9.81, "base_w_z": 2.0, "base_dw_z": 0.5}


def build_fmus(out: Path) -> dict[str, Path]:
    """{label: FMU} of the Python exported clamped bracket and the Python FFRBeam."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi import registry, runtime
    from flexfmu.fmi.build import build_one
    from flexfmu.fmi.export import export_fmu
    from flexfmu.importers import load_structure

    bracket = load_structure(BRACKET)
    clamped = build_body(bracket, interfaces=[interface_from_text("tip=arm_top")],
                         clamp=clamp_from_text(bracket, "bolt_1,bolt_2"), f_max=2000.0)
    spec = next(s for s in registry.FMUS if s.name == "FFRBeam")
    runtime_files = runtime.compile_runtime(runtime.build_folder())
    ffrbeam = build_one(spec, out / "FFRBeam.fmu", runtime_files)
    return {"exported clamped bracket": export_fmu(clamped, out / "clamped" / "Bracket.fmu"),
            "FFRBeam": ffrbeam}


class Cycler:
    """One initialised instance of an FMU and its set/step/get cycle."""

    def __init__(self, fmu: Path, workdir: Path):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(str(fmu))
        real = [v for v in md.modelVariables if v.type == "Real"]
        self.inputs = [v for v in real if v.causality == "input"]
        self.outputs = [v.valueReference for v in real if v.causality == "output"]
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), unzipdir=str(workdir)),
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.t = 0.0
        self.k = 0

    def input_values(self, k: int) -> list[float]:
        """Forces and moments varying with the step k (N, N.m), the base motion held."""
        values = []
        for j, v in enumerate(self.inputs):
            name = v.name.rsplit(".", 1)[-1]
            if name in BASE:
                values.append(BASE[name])
            elif name.startswith(("F_", "M_")):
                values.append((10.0 if name.startswith("F_") else 1.0) * math.sin(0.01 * k + j))
            else:
                values.append(0.0)
        return values

    def run(self, cycles: int) -> float:
        """µs per cycle over ``cycles`` cycles (the input values computed before the timer starts)."""
        vrs = [v.valueReference for v in self.inputs]
        table = [self.input_values(self.k + k) for k in range(cycles)]
        fmu, outputs, t = self.fmu, self.outputs, self.t
        start = time.perf_counter()
        for values in table:
            fmu.setReal(vrs, values)
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=STEP)
            t += STEP
            fmu.getReal(outputs)
        elapsed = time.perf_counter() - start
        self.t, self.k = t, self.k + cycles
        return 1e6 * elapsed / cycles

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=5000, help="cycles per round and FMU (default 5000)")
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds (default 5)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        fmus = build_fmus(tmp / "fmus")
        cyclers = {label: Cycler(fmu, tmp / f"x{k}") for k, (label, fmu) in enumerate(fmus.items())}
        for c in cyclers.values():                   # warm-up: map caches filled, code paths loaded
            c.run(200)
        best = dict.fromkeys(cyclers, math.inf)
        for _ in range(args.rounds):
            for label, c in cyclers.items():
                best[label] = min(best[label], c.run(args.cycles))
        for c in cyclers.values():
            c.free()
    from flexfmu.studies.common import provenance
    print(f"benchmarks/clamped_python.py from {provenance()} ({platform.machine()}, Python "
          f"{platform.python_version()}): set all inputs / doStep {STEP:g} s / get all outputs, best of "
          f"{args.rounds} x {args.cycles} cycles")
    for label, us in best.items():
        print(f"  {label:28s} {us:8.2f} µs/cycle")
    ratio = best["exported clamped bracket"] / best["FFRBeam"]
    print(f"  ratio clamped / FFRBeam      {ratio:8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
