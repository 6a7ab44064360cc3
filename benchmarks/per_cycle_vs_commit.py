#!/usr/bin/env python3
"""Per-cycle cost of every FMU kind built from this checkout against the same kinds built from another commit,
measured in one run.

    .venv/bin/python benchmarks/per_cycle_vs_commit.py --base REV [--quick] [--repeats 3] [--out FILE]

A restructuring must not make any FMU slower.  The base commit is checked out with ``git worktree`` into a
temporary folder; each tree builds its FMUs in its own Python process (PYTHONPATH pointing at that tree's package,
so neither build sees the other's flexfmu) with that tree's benchmarks/host_steps.py, and each FMU carries its own
code (the native ones compiled in, the Python ones bundled).  Both sets then run in the C host of
examples/c_host (constant step; fmi2SetReal of the held forces, fmi2DoStep, fmi2GetReal of up to six outputs), the
base and the current FMU of a kind interleaved, best of --repeats; the ratio current / base is from this one run.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))        # host_tools: the C host compiled the way the tests do
sys.path.insert(0, str(ROOT / "benchmarks"))

BUILD = """
import json, sys
from pathlib import Path
sys.path.insert(0, {benchmarks!r})
import host_steps
rows = host_steps.build_fmus(Path({out!r}), {quick!r})
print("ROWS" + json.dumps([[kind, runtime, str(fmu), cycles, step, start] for kind, runtime, fmu, cycles, step, start
                           in rows]))
"""


def build_in(tree: Path, out: Path, quick: bool) -> list:
    """The FMU rows of ``tree`` (a checkout), built by its own host_steps.build_fmus with its own package."""
    env = {**os.environ, "PYTHONPATH": str(tree / "model")}
    code = BUILD.format(benchmarks=str(tree / "benchmarks"), out=str(out), quick=quick)
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=7200)
    if proc.returncode != 0:
        raise RuntimeError(f"building the FMUs of {tree} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}")
    line = next(line for line in proc.stdout.splitlines() if line.startswith("ROWS"))
    return json.loads(line[4:])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", required=True, help="the commit to compare with (e.g. the one before a change)")
    parser.add_argument("--quick", action="store_true", help="a fifth of the cycles (a smoke run)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per FMU and tree; the best counts")
    parser.add_argument("--out", type=Path, help="also write the table as Markdown to this file")
    args = parser.parse_args(argv)
    from host_steps import host_cycle
    from host_tools import compile_c_host

    base_rev = subprocess.run(["git", "rev-parse", "--short", args.base], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    with tempfile.TemporaryDirectory(prefix="per_cycle_") as tmp_name:
        tmp = Path(tmp_name)
        base_tree = tmp / "base"
        subprocess.run(["git", "worktree", "add", "--detach", str(base_tree), base_rev], cwd=ROOT, check=True,
                       capture_output=True)
        try:
            host = compile_c_host(tmp)
            rows = {"base": build_in(base_tree, tmp / "base-fmus", args.quick),
                    "current": build_in(ROOT, tmp / "current-fmus", args.quick)}
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base_tree)], cwd=ROOT, capture_output=True)
        base = {(kind, runtime): (Path(fmu), cycles, step, start) for kind, runtime, fmu, cycles, step, start
                in rows["base"]}
        lines = [f"| FMU kind | runtime | {base_rev} (µs/cycle) | current (µs/cycle) | current / base |",
                 "|---|---|---|---|---|"]
        for kind, runtime, fmu, cycles, step, start in rows["current"]:
            if (kind, runtime) not in base:
                continue
            base_fmu = base[(kind, runtime)][0]
            start = {name: tuple(value) for name, value in start.items()}
            best = {"base": float("inf"), "current": float("inf")}
            for _ in range(args.repeats):
                for which, path in (("base", base_fmu), ("current", Path(fmu))):
                    work = tmp / which
                    work.mkdir(exist_ok=True)
                    best[which] = min(best[which], host_cycle(host, path, cycles, step, work, False, start))
            line = (f"| {kind} | {runtime} | {best['base']:.2f} | {best['current']:.2f} | "
                    f"{best['current'] / best['base']:.2f} |")
            print(line, flush=True)
            lines.append(line)
    from flexfmu.studies.common import provenance
    header = (f"Made by `benchmarks/per_cycle_vs_commit.py --base {base_rev}` from {provenance()} "
              f"({platform.machine()}, {platform.platform()}, Python {platform.python_version()}).")
    print(header)
    if args.out:
        args.out.write_text("\n".join(["# Per-cycle cost against an earlier commit", "", header, "",
                                       __doc__.split("\n\n", 2)[2].strip(), "", *lines, ""]), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
