#!/usr/bin/env python3
"""The point absorber's speed table (docs/wave_converter.md, "Speed"): each master, Python against native
components, real-time factor, measured in one run on this machine.

    .venv/bin/python benchmarks/point_absorber_speed.py [--t-sim 1200] [--t-python 60] [--step H] [--every K]

Every run is the example system examples/point_absorber/OspSystemStructure.xml in a JONSWAP sea (Hs 2 m, Tp 8 s,
seed 1) at the file's communication step (or --step), in a subprocess pinned to one core (``taskset -c 0`` where it
exists), so each figure is one core's.  Native components (no Python in the host) run the full --t-sim (default a
20-minute sea state); the Python ones a shorter --t-python, their real-time factor being a rate.  The wall time is
the co-simulation's (load, instantiate, run; the result arrays included), not the process's start-up.  Printed: a
Markdown table, master x components x configuration, with the wall time, the real-time factor (simulated /
wall) and the wall time a 20-minute sea state takes at that rate.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OSP = ROOT / "examples" / "point_absorber" / "OspSystemStructure.xml"
COMPONENTS = ("AbsorberWave", "AbsorberFloat", "AbsorberHydro", "HeavePTO", "Mooring")
#: what the native FMUs fix at build that the system file sets: the lines' MoorDyn step (3 per communication step)
BUILD_SETTINGS = {"Mooring": ["--set", "internal_time_step=0.0020833333333333333"]}
SEA = ["wave.sea_state=jonswap", "wave.wave_height=2.0", "wave.wave_period=8.0", "wave.seed=1"]
CONFIGURATIONS = {
    "default (6 DOF, drag, MoorDyn)": [],
    "linear (heave only, no drag, no mooring)": ["float.heave_only=true", "hydro.drag=false",
                                                 "mooring.enabled=false"],
}

DRIVER = r"""
import json, sys, time
from flexfmu.cosim import masters
system_file, fmu_dir, master, t_end, step, every, assignments = json.loads(sys.argv[1])
system = masters.load_system(system_file, fmu_dir=fmu_dir)
system = masters.with_assignments(system, assignments)
if "wave.record_length" not in " ".join(assignments):
    system = masters.with_assignments(system, [f"wave.record_length={t_end!r}"])
start = time.perf_counter()
if master == "libcosim":
    r = masters.run_libcosim(system, t_end, step, every=every)
elif master == "ecos":
    r = masters.run_ecos(system, t_end, step, every=every)
else:
    r = masters.run(system, t_end, step, scheme="gauss-seidel", backend="library" if master == "library" else "fmu")
wall = time.perf_counter() - start
power = r["pto.power"]
print("RESULT " + json.dumps({"wall": wall, "points": int(r.t.size), "t_end": float(r.t[-1]),
                               "mean_power": float(power[r.t >= 0.5 * t_end].mean())}))
"""


def build(out: Path, runtime: str) -> Path:
    """The five components' FMUs of one runtime in ``out`` (named as the system file's sources)."""
    out.mkdir(parents=True, exist_ok=True)
    if runtime == "python":
        subprocess.run([sys.executable, "-m", "flexfmu", "build", "--out", str(out)], check=True, cwd=ROOT,
                       stdout=subprocess.DEVNULL)
    else:
        for name in COMPONENTS:
            subprocess.run([sys.executable, "-m", "flexfmu", "build", "--runtime", "native", "--fmu", name, "--out",
                            str(out)] + BUILD_SETTINGS.get(name, []), check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    return out


def measure(master: str, fmu_dir: Path | None, t_end: float, step: float | None, every: int, assignments) -> dict:
    pin = ["taskset", "-c", "0"] if shutil.which("taskset") else []
    args = json.dumps([str(OSP), None if fmu_dir is None else str(fmu_dir), master, t_end, step, every, assignments])
    proc = subprocess.run(pin + [sys.executable, "-c", DRIVER, args], capture_output=True, text=True, cwd=ROOT)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    if proc.returncode != 0 or not lines:
        return {"error": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
    return json.loads(lines[-1][len("RESULT "):])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--t-sim", type=float, default=1200.0, help="simulated time of the native runs, s")
    parser.add_argument("--t-python", type=float, default=60.0, help="simulated time of the Python runs, s")
    parser.add_argument("--step", type=float, default=None, help="communication step (default: the file's)")
    parser.add_argument("--every", type=int, default=10, help="libcosim/ecos: record every K-th point")
    parser.add_argument("--only-native", action="store_true", help="skip the Python components")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="flexfmu_pa_speed_") as tmp:
        dirs = {"native": build(Path(tmp) / "native", "native")}
        if not args.only_native:
            dirs["python"] = build(Path(tmp) / "python", "python")
        runs = [("libcosim", "native"), ("ecos", "native"), ("fmpy", "native")]
        if not args.only_native:
            runs += [("library", "python"), ("fmpy", "python"), ("libcosim", "python")]
        print("| master | components | configuration | simulated (s) | wall (s) | real-time factor | "
              "20 min sea state (s) | mean power (kW) |")
        print("|---|---|---|---:|---:|---:|---:|---:|")
        for master, runtime in runs:
            t_end = args.t_sim if runtime == "native" else args.t_python
            for label, assignments in CONFIGURATIONS.items():
                fmu_dir = None if master == "library" else dirs[runtime]
                got = measure(master, fmu_dir, t_end, args.step, args.every, SEA + assignments)
                components = "library (Python)" if master == "library" else f"{runtime} FMUs"
                if "error" in got:
                    print(f"| {master} | {components} | {label} | {t_end:g} | failed: {got['error']} | | | |")
                    continue
                rtf = got["t_end"] / got["wall"]
                print(f"| {master} | {components} | {label} | {got['t_end']:g} | {got['wall']:.2f} | {rtf:.0f} | "
                      f"{1200.0 / rtf:.1f} | {got['mean_power'] / 1e3:.3g} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
