"""Reliability report of flexfmu's FMUs and co-simulation CLI -> docs/reliability.md.

    python benchmarks/reliability.py [--dist dist] [--out docs/reliability.md] [--cycles 2000] [--runs 20]
                                     [--flips 4096] [--jobs 2] [--quick]

Probes every FMU kind in both runtimes (the Python FMUs of ``--dist``; native FFRBeam and ReframeBody and an exported
clamped and free body in both runtimes, built here: benchmarks/reliability_fmus.py), each probe group in a process
of its own per FMU with a time limit per call, so a crash or a hang is counted and the report goes on
(flexfmu.fmi.diagnostics_runner):

1. bad values and calls (flexfmu.fmi.diagnostics.BATTERY), extreme parameter values included;
2. foreign and damaged FMU states (flexfmu.fmi.diagnostics_states);
3. loggers that call the instance back while it logs (flexfmu.fmi.diagnostics_reentrant);
4. large start times: the clock, skipped and repeated steps (flexfmu.fmi.diagnostics_clock);
5. `flexfmu cosim` and `flexfmu wec power-matrix` on broken system files and arguments (benchmarks/reliability_cli.py);
6. concurrent first loads of a Python FMU's build (flexfmu.fmi.diagnostics_loads);

then instantiate/free cycles with the resident memory, and host processes run to exit under CPU load.  The first
section of the report is the summary: per group, crashes, hangs, silently wrong results, internal-error messages.
``--quick`` shrinks everything for a smoke run (a few minutes).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from reliability_cli import bundled_flexfmu, cosim_cases, power_matrix_cases, run_case  # noqa: E402
from reliability_fmus import fmus_under_test, partners  # noqa: E402
from reliability_report import render  # noqa: E402

from flexfmu.errors import FlexfmuError  # noqa: E402
from flexfmu.fmi.diagnostics import battery, cycles, exit_stress  # noqa: E402
from flexfmu.fmi.diagnostics_clock import clock_probes  # noqa: E402
from flexfmu.fmi.diagnostics_loads import concurrent_first_loads  # noqa: E402
from flexfmu.fmi.diagnostics_reentrant import reentrant_probes  # noqa: E402
from flexfmu.fmi.diagnostics_states import state_probes  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: seconds a battery call may take before it counts as a hang: ReframeBody (python) with n_flexible_modes = -1 chooses
#: its modes on the paper's plate (51255 DOFs) in fmi2ExitInitializationMode, 44 s alone on this machine, over 60 s
#: beside another probe
BATTERY_TIMEOUT = 300.0
#: the Python FMUs whose concurrent first loads are probed: one of the dist build, one exported
FIRST_LOAD_FMUS = ("FFRBeam (python)", "FreePlate (python)")
#: the FMUs each exit-stress process loads (by their report names), when present
EXIT_STRESS_FMUS = ("FFRBeam (python)", "Hydrostatics (python)", "WaveExcitation (python)", "PTO (python)",
                    "FFRBeam (native)", "ReframeBody (native)")


def settings(args) -> dict:
    quick = args.quick
    return {"quick": quick,
            "cycles": args.cycles if args.cycles is not None else (50 if quick else 2000),
            "runs": args.runs if args.runs is not None else (4 if quick else 20),
            "flips": args.flips if args.flips is not None else (256 if quick else 4096),
            "all_flips_below_bits": 0 if quick else 65536,
            "clock_steps": 5 if quick else 20,
            "first_load_rounds": 3 if quick else 8, "first_load_processes": 3,
            "cosim_masters": ("library",) if quick else ("library", "fmpy")}


def cycles_result(fmu, n: int) -> dict:
    try:
        early, late = cycles(fmu.path, n)
        return {"early": early, "late": late}
    except FlexfmuError as exc:
        return {"failure": "crash", "detail": str(exc)[-400:]}
    except subprocess.TimeoutExpired:
        return {"failure": "hang", "detail": f"{n} cycles did not end within the time limit"}


def collect(fmus, dist: Path, work: Path, config: dict, jobs: int) -> dict:
    """Every probe's results: {"fmus", "battery", "states", "reentrant", "clock", "cycles": {fmu name: ...},
    "cli": [case results], "exit": Counter, "seconds": {group: wall time}}."""
    data = {"fmus": fmus, "config": config, "seconds": {}}
    for fmu in fmus:            # the runtime copies made once, before probes start the FMUs in parallel
        if fmu.runtime == "python":
            cycles_result(fmu, 0)
    tasks = {}
    for fmu in fmus:
        tasks[("battery", fmu.name)] = lambda f=fmu: battery(f.path, quick=config["quick"],
                                                             item_timeout=BATTERY_TIMEOUT)
        tasks[("states", fmu.name)] = lambda f=fmu: state_probes(
            f.path, partners(f, fmus), flips=config["flips"], all_flips_below_bits=config["all_flips_below_bits"])
        tasks[("reentrant", fmu.name)] = lambda f=fmu: reentrant_probes(f.path)
        tasks[("clock", fmu.name)] = lambda f=fmu: clock_probes(f.path, steps=config["clock_steps"])
        tasks[("cycles", fmu.name)] = lambda f=fmu: cycles_result(f, config["cycles"])
    for fmu in fmus:
        if fmu.name in FIRST_LOAD_FMUS:
            tasks[("loads", fmu.name)] = lambda f=fmu: concurrent_first_loads(
                f.path, processes=config["first_load_processes"], rounds=config["first_load_rounds"])
    cli_dist = [f.path for f in fmus if f.group == "dist"]
    pythonpath = bundled_flexfmu(cli_dist[0], work / "cli_flexfmu") if cli_dist else None
    cases = (cosim_cases(work / "cli", dist, masters=config["cosim_masters"])
             + power_matrix_cases(work / "cli", dist))
    for k, case in enumerate(cases):
        tasks[("cli", k)] = lambda c=case: run_case(c, pythonpath=pythonpath)

    def timed(key):
        tic = time.perf_counter()
        out = tasks[key]()
        return out, time.perf_counter() - tic

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        futures = {key: pool.submit(timed, key) for key in tasks}
        for (group, name), future in futures.items():
            out, seconds = future.result()
            data.setdefault(group, {})[name] = out
            data["seconds"][group] = data["seconds"].get(group, 0.0) + seconds
            print(f"  {group:9s} {name}: {seconds:.1f} s", flush=True)
    data["cli"] = [data["cli"][k] for k in range(len(cases))]
    data["cli_from"] = "the flexfmu the dist FMUs bundle" if pythonpath else "the installed flexfmu"
    by_name = {f.name: f for f in fmus}
    stress = [by_name[n].path for n in EXIT_STRESS_FMUS if n in by_name]
    tic = time.perf_counter()
    data["exit"] = exit_stress(stress, config["runs"])
    data["exit_fmus"] = [n for n in EXIT_STRESS_FMUS if n in by_name]
    data["seconds"]["exit"] = time.perf_counter() - tic
    return data


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dist", type=Path, default=ROOT / "dist", help="the Python FMUs (flexfmu build --out DIR)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "reliability.md")
    parser.add_argument("--cycles", type=int, default=None, help="instantiate/free cycles per FMU (default 2000)")
    parser.add_argument("--runs", type=int, default=None, help="exit-stress host processes (default 20)")
    parser.add_argument("--flips", type=int, default=None,
                        help="single-bit flips drawn from a state larger than 8 KiB (default 4096; smaller states: "
                             "every bit)")
    parser.add_argument("--jobs", type=int, default=2, help="probe processes at once (default 2)")
    parser.add_argument("--quick", action="store_true", help="a smoke run: fewer cycles, flips, steps and runs")
    args = parser.parse_args(argv)
    if not list(args.dist.glob("*.fmu")):
        print(f"no FMUs in {args.dist}: build them first (flexfmu build --out {args.dist})", file=sys.stderr)
        return 2
    tic = time.perf_counter()
    config = settings(args)
    with tempfile.TemporaryDirectory(prefix="flexfmu-reliability-") as tmp:
        work = Path(tmp)
        print("building the native and exported FMUs ...", flush=True)
        fmus = fmus_under_test(args.dist, work / "fmus")
        data = collect(fmus, args.dist, work, config, args.jobs)
    data["total_seconds"] = time.perf_counter() - tic
    text = render(data, args.dist)
    args.out.write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
