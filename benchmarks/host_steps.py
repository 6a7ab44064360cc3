#!/usr/bin/env python3
"""Per-cycle cost of every FMU kind in a host that passes h = t(k+1) - t(k) against a constant-step host.

    .venv/bin/python benchmarks/host_steps.py [--quick] [--out docs/host_steps.md]

fmpy.simulate_fmu, libcosim and fmusim compute each communication step as the difference of their clock, so the
steps differ in their last bits; fmpy's FMU2Slave loops, ecos and a constant-step C host pass one h.  Caches keyed
by the step size take such variants as one step (flexfmu.core.step_size), so both hosts should cost the same.

Host: examples/c_host/fmi2_host.c, with and without ``--clock-steps`` (its own CLOCK_MONOTONIC timer around the
stepping loop: fmi2SetReal of the held force inputs, fmi2DoStep, fmi2GetReal of up to six outputs), in a bare
environment (PATH and HOME only).  Each figure is the best of --repeats runs of the same process, the two hosts
interleaved; the ratio is clock / constant from this one run.  Speed is measured here only, never asserted in
tests; tests/test_step_size.py checks that both hosts compute the same numbers.
"""
from __future__ import annotations

import argparse
import platform
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))   # host_tools: compile the example C host the way the tests do

BRACKET = ROOT / "examples" / "bracket" / "bracket.json"


def describe_fmu(fmu: Path):
    from fmpy import read_model_description
    md = read_model_description(str(fmu))
    real = [v for v in md.modelVariables if v.type == "Real"]
    forces = [v for v in real if v.causality == "input" and re.search(r"(^|\.)F_[xyz]$", v.name)][:3]
    outputs = [v for v in real if v.causality == "output"][:6]
    return md, forces, outputs


def host_cycle(host: Path, fmu: Path, n_steps: int, step: float, workdir: Path, clock: bool,
               start: dict | None = None) -> float:
    """µs per set/step/get cycle from the C host's own timer around its stepping loop."""
    from fmpy import extract
    md, forces, outputs = describe_fmu(fmu)
    folder = workdir / f"{fmu.parent.name}-{fmu.stem}"
    if not folder.exists():
        extract(str(fmu), unzipdir=str(folder))
    cmd = [str(host), "--quiet", *(["--clock-steps"] if clock else []), repr(step), str(n_steps),
           "--fmu", str(folder), md.coSimulation.modelIdentifier, md.guid]
    vr = {v.name: v.valueReference for v in md.modelVariables}
    for name, (kind, value) in (start or {}).items():
        cmd += ["--set", kind, str(vr[name]), str(value)]
    for v, value in zip(forces, (1.0, 0.7, 0.4)):
        cmd += ["--input", str(v.valueReference), repr(value)]
    for v in outputs:
        cmd += ["--output", str(v.valueReference)]
    env = {"PATH": "/usr/bin:/bin", "HOME": str(workdir)}
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=3600)
    if proc.returncode != 0:
        raise RuntimeError(f"C host failed on {fmu} ({proc.returncode}):\n{proc.stderr[-3000:]}")
    loop = float(re.search(r"in ([0-9.]+) s \(", proc.stderr).group(1))
    return 1e6 * loop / n_steps


def build_fmus(out: Path, quick: bool) -> list[tuple[str, str, Path, int, float, dict]]:
    """(kind, runtime, FMU, cycles, step, start values) for every native and Python FMU kind."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi import native
    from flexfmu.fmi.build import build
    from flexfmu.fmi.export import export_fmu
    from flexfmu.importers import load_structure

    scale = 0.2 if quick else 1.0
    python = {p.stem: p for p in build(out / "python")}
    bracket = load_structure(BRACKET)
    tip = [interface_from_text("tip=arm_top")]
    clamped = build_body(bracket, interfaces=tip, clamp=clamp_from_text(bracket, "bolt_1,bolt_2"), f_max=2000.0)
    free = build_body(bracket, interfaces=tip, f_max=2000.0)
    rows = [("FFRBeam", "native", native.build_registry_fmu("FFRBeam", target=out / "n" / "FFRBeam.fmu"),
             int(100000 * scale), 1e-4, {}),
            ("FFRBeam", "python", python["FFRBeam"], int(20000 * scale), 1e-4, {}),
            ("exported clamped bracket", "native", export_fmu(clamped, out / "cn" / "Bracket.fmu", runtime="native"),
             int(50000 * scale), 1e-4, {}),
            ("exported clamped bracket", "python", export_fmu(clamped, out / "cp" / "Bracket.fmu"),
             int(10000 * scale), 1e-4, {}),
            ("ReframeBody (exponential)", "native",
             native.build_registry_fmu("ReframeBody", target=out / "n" / "ReframeBody.fmu"), int(20000 * scale), 1e-3, {}),
            ("ReframeBody (exponential)", "python", python["ReframeBody"], int(5000 * scale), 1e-3, {}),
            ("exported free bracket (exponential)", "native",
             export_fmu(free, out / "fn" / "Bracket.fmu", runtime="native"), int(20000 * scale), 1e-4, {}),
            ("exported free bracket (exponential)", "python", export_fmu(free, out / "fp" / "Bracket.fmu"),
             int(5000 * scale), 1e-4, {})]
    for name in ("WaveExcitation", "Hydrostatics", "Platform", "PTO"):
        rows.append((name, "python", python[name], int(10000 * scale), 1e-3, {}))
    rows.append(("Hydrostatics (bem: radiation memory)", "python", python["Hydrostatics"], int(5000 * scale), 1e-3,
                 {"hydrodynamics": ("string", "bem")}))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a fifth of the cycles (a smoke run)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per FMU and host; the best counts")
    parser.add_argument("--out", type=Path, help="also write the table as Markdown to this file")
    parser.add_argument("--fmusim", type=Path, help="also the 60 s hammer record in this fmusim beside a no-op FMU "
                                                    "(benchmarks/fmusim_hammer.py; build fmusim with "
                                                    "benchmarks/build_fmusim.sh)")
    args = parser.parse_args(argv)
    from host_tools import compile_c_host

    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        host = compile_c_host(tmp)
        lines = ["| FMU kind | runtime | constant step (µs/cycle) | h = t(k+1) − t(k) (µs/cycle) | ratio |",
                 "|---|---|---|---|---|"]
        for kind, runtime, fmu, cycles, step, start in build_fmus(tmp / "fmus", args.quick):
            best = {False: float("inf"), True: float("inf")}
            for _ in range(args.repeats):
                for clock in (False, True):
                    best[clock] = min(best[clock], host_cycle(host, fmu, cycles, step, tmp, clock, start))
            line = (f"| {kind} | {runtime} | {best[False]:.2f} | {best[True]:.2f} | "
                    f"{best[True] / best[False]:.2f} |")
            print(line, flush=True)
            lines.append(line)
    from flexfmu.studies.common import provenance
    header = (f"Made by `benchmarks/host_steps.py` from {provenance()} ({platform.machine()}, "
              f"{platform.platform()}, Python {platform.python_version()}).")
    fmusim_text = ""
    if args.fmusim:
        proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "fmusim_hammer.py"), "--fmusim",
                               str(args.fmusim)], capture_output=True, text=True, timeout=7200)
        fmusim_text = (proc.stdout if proc.returncode == 0 else
                       f"fmusim_hammer.py failed (exit {proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        print(fmusim_text)
    if args.out:
        args.out.write_text("\n".join(["# Step sizes a host passes", "", header, "", __doc__.split("\n\n", 2)[2].strip(),
                                       "", *lines, ""]
                                      + (["## The hammer record in fmusim", "",
                                          "Printed by `benchmarks/fmusim_hammer.py` (fmusim built by "
                                          "`benchmarks/build_fmusim.sh`), in the same run:", "", "```text",
                                          fmusim_text.strip(), "```", ""] if fmusim_text else [])),
                           encoding="utf-8")
    print(header)
    return 0


if __name__ == "__main__":
    sys.exit(main())
