#!/usr/bin/env python3
"""Set-up wall time with the BLAS threads chosen by problem size (flexfmu.core.blas) against forced one thread
and forced all threads.

    .venv/bin/python benchmarks/setup_threads.py [--repeat 3] [--plate]

Tasks: the double-L scene's modal analysis (as `flexfmu modal spatial_double_L`), the FFRBeam FMU's set-up of
its default configuration (model, modes, static correction, dynamics), the free modes of the bracket example
(examples/bracket/bracket.json, a solid), a ReframeBody set-up of the beam scene (basis and integrator) and,
with --plate, of the paper plate (modal-basis cache off).  Each figure is the best of --repeat runs, the three
thread settings interleaved in one process so that the machine's load hits them alike.  Ratios > 1: the chosen
threads are faster.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "model"))

from threadpoolctl import threadpool_limits  # noqa: E402

from flexfmu.core import blas  # noqa: E402

ALL_THREADS = os.cpu_count() or 1


@contextmanager
def setting(name: str):
    """chosen: flexfmu's size rule; one / all: every library forced, the size rule switched off."""
    threshold = blas.SINGLE_THREAD_BELOW_DIM
    if name == "chosen":
        yield
        return
    blas.SINGLE_THREAD_BELOW_DIM = sys.maxsize if name == "one" else 0
    try:
        with threadpool_limits(limits=1 if name == "one" else ALL_THREADS, user_api="blas"):
            yield
    finally:
        blas.SINGLE_THREAD_BELOW_DIM = threshold


def tasks(with_plate: bool):
    """[(name, DOFs, callable)]: each callable redoes the whole set-up (caches bypassed)."""
    from flexfmu.body.modes import natural_modes
    from flexfmu.ffr.report import modal_analysis
    from flexfmu.ffr.scene import load_scene
    from flexfmu.ffr.simulator import FFRBeamConfig, _build
    from flexfmu.importers import load_structure
    from flexfmu.linalg import modal_basis as modal_basis_module
    from flexfmu.reframe import simulator as reframe_simulator
    from flexfmu.reframe.models import load_model

    scene = load_scene("spatial_double_L")
    bracket = load_structure(str(ROOT / "examples" / "bracket" / "bracket.json"))
    beam = load_model("beam:spatial_double_L")

    def reframe_setup(model: str):
        def run():
            reframe_simulator._structure.cache_clear()
            reframe_simulator._basis.cache_clear()
            reframe_simulator._integrator.__wrapped__(model, 10, 0.05, "consistent")
        return run

    modal_basis_module.CACHE_MIN_DOF = sys.maxsize            # no on-disk cache: the solve itself is timed
    out = [("double-L modal analysis (flexfmu modal)", "mesh study",
            lambda: modal_analysis(scene, "scene", n_modes=6)),
           ("FFRBeam set-up (default configuration)", "-", lambda: _build.__wrapped__(FFRBeamConfig())),
           ("bracket free modes (solid)", bracket.n_dof, lambda: natural_modes(bracket, n_modes=6)),
           ("ReframeBody set-up, beam:spatial_double_L", beam.n_dof, reframe_setup("beam:spatial_double_L"))]
    if with_plate:
        plate = load_model("paper_plate")
        out.append(("ReframeBody set-up, paper_plate", plate.n_dof, reframe_setup("paper_plate")))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--plate", action="store_true", help="also the paper plate (tens of seconds)")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error("--repeat: at least 1")
    rows = []
    for name, dofs, run in tasks(args.plate):
        run()                                                       # imports and first-call caches
        best = {"chosen": float("inf"), "one": float("inf"), "all": float("inf")}
        for _ in range(args.repeat):
            for key in best:
                with setting(key):
                    start = time.perf_counter()
                    run()
                    best[key] = min(best[key], time.perf_counter() - start)
        rows.append((name, dofs, best))
        print(f"  {name}: done", file=sys.stderr, flush=True)
    print(f"Machine: {ALL_THREADS} cores, load average {os.getloadavg()[0]:.1f}; best of {args.repeat} runs; "
          f"threshold {blas.SINGLE_THREAD_BELOW_DIM} DOFs.\n")
    print("| set-up task | DOFs | chosen (s) | one thread (s) | all threads (s) | one / chosen | all / chosen |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, dofs, b in rows:
        print(f"| {name} | {dofs} | {b['chosen']:.3f} | {b['one']:.3f} | {b['all']:.3f} | "
              f"{b['one'] / b['chosen']:.2f} | {b['all'] / b['chosen']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
