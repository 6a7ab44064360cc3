#!/usr/bin/env python3
"""Set-up time and memory against model size, and the sizes that fit 60 s and 8 GB: the measurements behind
flexfmu.core.checks.MAX_BEAM_DOFS and MAX_SOLID_DOFS (docs/export.md, "Model size limits").

    .venv/bin/python benchmarks/model_size_limits.py [--beam 100,300,600,1000,1500,2000]
                                                      [--solid 32,48,64,80,100] [--timeout 400] [--out FILE]

Each case runs in a child process of its own (limits raised with FLEXFMU_MAX_DOFS, the on-disk cache off, address
space capped at 10 GB, a time-out), which reports its wall time, CPU time and peak resident memory:

* beam: FFRBeam's set-up (FFRBeamSimulator with the default parameters: 8 elements per segment, 6 modes, clamped
  at the first point) of a zig-zag rod of N segments, 0.1 m each, 10 mm steel: the slowest family of scenes measured
  (its lowest modes crowd together, so the shift-invert eigen-solver needs the most iterations; a random 3-D
  polyline of 1000 segments took 4.4 s, this one 27-45 s);
* solid: ``flexfmu modal`` of a tet4 box 1 x 0.25 x 0.25 m of n x n/4 x n/4 cubes (6 Kuhn tetrahedra each, the
  tests' box_mesh), steel, free and clamped at x = 0 (an Abaqus .inp with a node set): reading, assembly (scikit-fem),
  the model checks and the 6 lowest modes.

Then t = a n^b and memory = c n^d are fitted (least squares in log-log) to the largest three sizes of each series
and solved for 60 s and 8 GB.  The machine is shared (2 cores; other jobs run): the load average is printed with
each case, and the fit is to wall time, the conservative choice.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PYTHON = sys.executable
STEEL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}
BUDGET_S, BUDGET_BYTES = 60.0, 8e9
CHILD_ADDRESS_SPACE = 10 * 2**30

_CHILD = r"""
import json, resource, sys, time, warnings
warnings.simplefilter("ignore")
kind, arg = sys.argv[1], sys.argv[2]
t0 = time.perf_counter()
status, dofs = "ok", None
try:
    if kind == "beam":
        from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
        dofs = FFRBeamSimulator(FFRBeamConfig(scene=arg)).dynamics.model.n_dof
    else:
        from flexfmu.cli import main
        status = "ok" if main(json.loads(arg)) == 0 else "refused"
except MemoryError:
    status = "out of memory"
except Exception as exc:
    status = f"{type(exc).__name__}: {str(exc)[:160]}"
wall = time.perf_counter() - t0
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "rss": usage.ru_maxrss * 1024,
                  "status": status, "n_dof": dofs}), file=sys.stderr)
"""


def zigzag_scene(n_segments: int, folder: Path) -> Path:
    points = [[round(0.08 * i, 9), 0.06 * (i % 2), 0.0] for i in range(n_segments + 1)]
    path = folder / f"zigzag{n_segments}.json"
    path.write_text(json.dumps({"name": f"zigzag{n_segments}", "points": points,
                                "section": {"shape": "circle", "diameter": 0.01}, "material": STEEL,
                                "clamps": [0.0]}))
    return path


def tet_box(n: int, folder: Path) -> tuple[Path, int]:
    """An Abaqus .inp of the n x n/4 x n/4 tet4 box with the node set "clamp" at x = 0; (path, nodes)."""
    import meshio

    sys.path.insert(0, str(ROOT / "tests"))
    from test_importers import box_mesh

    points, cells = box_mesh("tetra", (n, n // 4, n // 4), (1.0, 0.25, 0.25))
    path = folder / f"box{n}.inp"
    meshio.write(path, meshio.Mesh(points, [("tetra", cells)],
                                   point_sets={"clamp": np.flatnonzero(points[:, 0] == 0.0)}))
    return path, len(points)


def run_child(kind: str, arg: str, timeout: float) -> dict:
    env = dict(os.environ, FLEXFMU_MAX_DOFS=str(10**12), FLEXFMU_CACHE="0",
               PYTHONPATH=str(ROOT / "model") + os.pathsep + os.environ.get("PYTHONPATH", ""))

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (CHILD_ADDRESS_SPACE, CHILD_ADDRESS_SPACE))

    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    try:
        done = subprocess.run([PYTHON, "-c", _CHILD, kind, arg], env=env, capture_output=True, text=True,
                              timeout=timeout, preexec_fn=cap)
    except subprocess.TimeoutExpired:
        return {"wall": time.perf_counter() - t0, "cpu": math.nan, "rss": math.nan,
                "status": f"timed out after {timeout:.0f} s", "load": load}
    lines = [line for line in done.stderr.splitlines() if line.startswith("{")]
    result = json.loads(lines[-1]) if lines else {"wall": time.perf_counter() - t0, "cpu": math.nan,
                                                  "rss": math.nan, "status": f"exit {done.returncode}"}
    result["load"] = load
    return result


def fit(sizes, values):
    """(a, b) of value = a size^b, least squares in log-log over the given points."""
    b, log_a = np.polyfit(np.log(sizes), np.log(values), 1)
    return math.exp(log_a), b


def largest_within(rows, key, budget):
    ok = [r for r in rows if r["status"] == "ok"]
    if len(ok) < 2:
        return math.nan, (math.nan, math.nan)
    last = ok[-3:]
    a, b = fit([r["dofs"] for r in last], [r[key] for r in last])
    return (budget / a) ** (1.0 / b), (a, b)


def report(title: str, rows: list, out) -> None:
    print(f"\n{title}\n", file=out)
    print("| DOFs | size | wall (s) | CPU (s) | peak memory (MB) | load | outcome |", file=out)
    print("|---:|---|---:|---:|---:|---:|---|", file=out)
    for r in rows:
        print(f"| {r['dofs']:,} | {r['size']} | {r['wall']:.1f} | {r['cpu']:.1f} | {r['rss'] / 1e6:.0f} | "
              f"{r['load']:.1f} | {r['status']} |", file=out)
    n_time, (a, b) = largest_within(rows, "wall", BUDGET_S)
    n_mem, (c, d) = largest_within(rows, "rss", BUDGET_BYTES)
    print(f"\nfit over the largest three: wall = {a:.3g} n^{b:.2f} s -> 60 s at {n_time:,.0f} DOFs; "
          f"memory = {c:.3g} n^{d:.2f} B -> 8 GB at {n_mem:,.0f} DOFs", file=out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--beam", default="100,300,600,1000,1500,2000", help="segments of the zig-zag scenes")
    parser.add_argument("--solid", default="32,48,64,80,100", help="divisions along the tet box's length")
    parser.add_argument("--timeout", type=float, default=400.0, help="seconds per case")
    parser.add_argument("--out", type=Path, default=None, help="also write the tables (markdown) here")
    args = parser.parse_args(argv)
    outputs = [sys.stdout] + ([open(args.out, "w")] if args.out else [])
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        beam = []
        for n in (int(v) for v in args.beam.split(",") if v):
            r = run_child("beam", str(zigzag_scene(n, folder)), args.timeout)
            beam.append({**r, "dofs": r.get("n_dof") or 6 * (8 * n + 2), "size": f"{n} segments"})
            print(f"beam {n}: {beam[-1]}", file=sys.stderr, flush=True)
        solids = {"free": [], "clamped": []}
        for n in (int(v) for v in args.solid.split(",") if v):
            path, nodes = tet_box(n, folder)
            for how, extra in (("free", []), ("clamped", ["--clamp", "clamp"])):
                cli = ["modal", str(path), "--material", "2.1e11,0.3,7850", *extra]
                r = run_child("solid", json.dumps(cli), args.timeout)
                solids[how].append({**r, "dofs": 3 * nodes, "size": f"{n} x {n // 4} x {n // 4} cubes, {nodes:,} nodes"})
                print(f"solid {how} {n}: {solids[how][-1]}", file=sys.stderr, flush=True)
    for out in outputs:
        report("FFRBeam set-up, default parameters, zig-zag rod (flexfmu.core.checks.MAX_BEAM_DOFS)", beam, out)
        for how, rows in solids.items():
            report(f"flexfmu modal of a tet4 box, {how} (flexfmu.core.checks.MAX_SOLID_DOFS)", rows, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
