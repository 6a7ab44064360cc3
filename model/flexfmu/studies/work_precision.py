#!/usr/bin/env python3
"""Work-precision study: error against a converged reference versus CPU time, over the
time step, the number of modes and the mesh, for every method; PNG charts + docs/work_precision.md.

    flexfmu bench work-precision [--quick] [--out REPORT.md | -]
    .venv/bin/python benchmarks/work_precision.py [--quick] [--out-dir DIR] [--out PATH | -]      (the same)

Cases: the reframe body on the paper's plate (its load case) and on the free-free bent rod
(beam:spatial_double_L, a pulse at the free end: rigid + elastic motion); the FFR beam (spatial double-L,
XFF) under a hammer impulse and on a moving base.  One factor at a time: each chart panel varies one of
time step / number of modes / mesh from the case's base model and measures the error against the
reference of that sweep (docs/work_precision.md states each reference and why it is converged).

CPU times are time.process_time of this process, best of a few repeats (shared machine: +-20 %); every
ratio is from one run.  --quick: shorter records, fewer and smaller sweep points, one repeat (~2 min).
The report defaults to docs/work_precision.md of a source checkout, else ./work_precision.md, its charts to
figures/ beside it.  Without Exudyn the plate has no Exudyn runs and a self-converged time-step reference;
without matplotlib the charts are skipped.
Methods that other modules add later (a reframe scheme in flexfmu.reframe.integrator.SCHEMES, the FFR ``integrator``
field, the automatic model choice ``n_modes=-1`` / ``n_flexible_modes=-1`` with ``f_max`` / ``tolerance``)
are detected at run time and included when present.

The parts: work_precision_measure (error norm, CPU time, the methods present), work_precision_body and
work_precision_ffr (the cases, their references and sweeps), work_precision_report (charts, report, notes).
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import time
from pathlib import Path

from flexfmu.errors import FlexfmuError
from flexfmu.studies import common
from flexfmu.studies.work_precision_body import plate_case, plate_exudyn, reference_scheme, rod_case, sweep_body
from flexfmu.studies.work_precision_ffr import _ffr_config, base_case, hammer_case, hammer_input, run_ffr, sweep_ffr
from flexfmu.studies.work_precision_measure import Case, Point, exudyn_generator, reframe_schemes
from flexfmu.studies.work_precision_report import NOTES, conclusions, machine, plot_case, write_report
# the study's building blocks, importable from the study itself (tests/test_work_precision.py looks for them here)
from flexfmu.studies.work_precision_body import run_baseline, run_reframe  # noqa: F401
from flexfmu.studies.work_precision_ffr import HAMMER_PULSE, ffr_reference  # noqa: F401
from flexfmu.studies.work_precision_measure import observed_order, relative_max_error  # noqa: F401
from flexfmu.studies.work_precision_report import dominated_by  # noqa: F401


# --------------------------------------------------------------------------- driver
def _warm_up() -> None:
    """Load (on first use: compile) the C kernels and fill import caches before anything is timed."""
    from flexfmu.reframe.models import load_model
    from flexfmu.reframe.integrator import ReframeIntegrator
    rod = load_model("beam:spatial_double_L", elements_per_segment=2)
    for scheme in reframe_schemes():
        try:
            ReframeIntegrator(rod, 2, scheme=scheme).run(2e-3, 1e-4, None, every=5)
        except FlexfmuError:
            pass
    run_ffr(_ffr_config(2, 2), 1e-4, 1e-3, hammer_input, 5e-4)


def run(quick: bool, only=None) -> list:
    repeat = 2 if quick else 3
    _warm_up()
    cases = []
    if only in (None, "plate"):
        bc = plate_case(quick)
        gen = exudyn_generator()
        if gen is None:
            print(common.skipped("plate: the Exudyn runs and the Exudyn time-step reference", "exudyn"), flush=True)
        exudyn, exudyn_ref = plate_exudyn(gen, bc.t_end) if gen is not None else (None, None)
        c = bc.case
        c.base = (f"mesh {bc.mesh_label(bc.base_mesh)} ({bc.build(bc.base_mesh).n_dof} DOFs), {bc.base_modes} flexible "
                  f"modes, dt = {bc.base_dt:g} s")
        c.references = {
            "dt": ("the stored Exudyn trajectory of the same model (flexfmu/data/references/exudyn_plate: ObjectFFRF"
                   "reducedOrder, generalized-α, dt = 2.5e-6 s) — an independent code. Its own error, extrapolated "
                   "from Exudyn's second-order convergence in this panel (error at dt = 3.125e-5 s × (2.5e-6 / "
                   "3.125e-5)²), is ≈ 1e-7: the floor the reframe schemes reach." if exudyn_ref is not None else
                   f"the consistent scheme at dt = {bc.ref_dt:g} s (Exudyn not installed)."),
            "dt_short": f"{bc.mesh_label(bc.base_mesh)}, {bc.base_modes} modes",
            "modes": (f"{bc.ref_modes} flexible modes on the base mesh, the {reference_scheme()} scheme at "
                      f"dt = {bc.modes_dt / 2:g} s; every run at dt = {bc.modes_dt:g} s. The reference keeps 2× the sweep's "
                      "largest count; its own truncation error is not measured (a 3-D solid's modal series "
                      "converges slowly)."),
            "modes_short": f"{bc.mesh_label(bc.base_mesh)}, dt {bc.modes_dt:g} s, ref. {bc.ref_modes} modes",
            "mesh": (f"the {bc.mesh_label(bc.ref_mesh)} mesh with {bc.base_modes} flexible modes, consistent scheme at "
                     f"dt = {bc.ref_dt:g} s; every run at dt = {bc.base_dt:g} s. The reference's own mesh error is "
                     "not measured; it is smaller than the last sweep point's if the convergence continues."),
            "mesh_short": f"{bc.base_modes} modes, ref. {bc.mesh_label(bc.ref_mesh)}",
        }
        print(f"plate: {c.description}")
        cases.append(sweep_body(bc, repeat, exudyn, exudyn_ref))
    if only in (None, "rod"):
        bc = rod_case(quick)
        c = bc.case
        c.base = (f"{bc.mesh_label(bc.base_mesh)} ({bc.build(bc.base_mesh).n_dof} DOFs), {bc.base_modes} flexible "
                  f"modes, dt = {bc.base_dt:g} s")
        c.references = {
            "dt": (f"the consistent scheme on the same model at dt = {bc.ref_dt:.3g} s (self-convergence: it is "
                   "fourth order here, so its error is ~(ref dt / finest dt)^4 = 1/16 … 1/256 of the finest run's)."),
            "dt_short": f"{bc.mesh_label(bc.base_mesh)}, {bc.base_modes} modes",
            "modes": (f"every flexible mode of the model ({bc.build(bc.base_mesh).n_dof - 6}), the {reference_scheme()} "
                      f"scheme (no stability limit) at dt = {bc.modes_dt / 2:.3g} s; every run at dt = {bc.modes_dt:g} s "
                      "(the consistent scheme refuses mode counts whose dt·ω_max exceeds 2.8)."),
            "modes_short": f"{bc.mesh_label(bc.base_mesh)}, dt {bc.modes_dt:g} s, ref. all modes",
            "mesh": (f"{bc.mesh_label(bc.ref_mesh)} with {bc.base_modes} flexible modes, consistent scheme at "
                     f"dt = {bc.ref_dt:.3g} s; Hermite beam elements converge as h⁴ (docs/ffr_model.md), so the "
                     "reference's own error is ~1/16 of the finest sweep point's."),
            "mesh_short": f"{bc.base_modes} modes, ref. {bc.mesh_label(bc.ref_mesh)}",
        }
        print(f"rod: {c.description}")
        cases.append(sweep_body(bc, repeat))
    for key, make in (("ffr_hammer", hammer_case), ("ffr_base", base_case)):
        if only not in (None, key):
            continue
        fc = make(quick)
        c = fc.case
        c.base = f"{fc.base_eps} elements per segment, {fc.base_modes} modes"
        if fc.analytic:
            ref = ("the closed-form solution of the same model's decoupled modal equations under the continuous "
                   "half-sine blow (hammer_analytic; no time step, so exact up to rounding; checked against "
                   "DOP853 to 1e-11)")
        else:
            ref = ("the model's equations of motion (ffr_dynamics Eq. (*)) with the continuous input, integrated "
                   "by scipy DOP853 at rtol 1e-11 piecewise between the input's kinks — independent of the FFR "
                   "step")
        ref_modes = "every mode of the model" if fc.ref_modes is None else f"{fc.ref_modes} modes"
        c.references = {
            "dt": f"{ref}, same model. The FFR runs hold the input at its mid-step value over each step.",
            "dt_short": f"{fc.base_eps} el/seg, {fc.base_modes} modes",
            "modes": (f"{ref}, {ref_modes} ({fc.base_eps} elements per segment); every run at dt = {fc.modes_dt:g} s"
                      + " (its time error, from the time-step sweep, is the floor of this panel)."),
            "modes_short": (f"{fc.base_eps} el/seg, dt {fc.modes_dt:g} s, ref. "
                            + ("all modes" if fc.ref_modes is None else f"{fc.ref_modes} modes")),
            "mesh": (f"{ref}, {fc.ref_eps} elements per segment, {fc.base_modes} modes; every run at "
                     f"dt = {fc.mesh_dt:g} s; h⁴ convergence makes the reference's own error ~1/16 of the finest "
                     "sweep point's."),
            "mesh_short": f"{fc.base_modes} modes, dt {fc.mesh_dt:g} s, ref. {fc.ref_eps} el/seg",
        }
        print(f"{key}: {c.description}")
        cases.append(sweep_ffr(fc, repeat))
    return cases


def save_run(path: Path, cases, mach: str, quick: bool, elapsed: float, today: str) -> None:
    """Every number of a run as JSON, so that the charts and the report can be drawn again (--replot)."""
    import json
    data = {"quick": quick, "date": today, "elapsed_s": elapsed, "machine": mach,
            "cases": [{"key": c.key, "title": c.title, "description": c.description, "quantity": c.quantity,
                       "references": c.references, "base": c.base,
                       "points": [dataclasses.asdict(p) for p in c.points]} for c in cases]}
    path.write_text(json.dumps(data, indent=1, allow_nan=True))


def load_run(path: Path):
    import json
    data = json.loads(Path(path).read_text())
    cases = []
    for c in data["cases"]:
        case = Case(c["key"], c["title"], c["description"], c["quantity"], c["references"], c["base"])
        case.points = [Point(**p) for p in c["points"]]
        cases.append(case)
    return cases, data["machine"], data["quick"], data["elapsed_s"], data["date"]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short records, fewer sweep points, two repeats")
    parser.add_argument("--out-dir", type=Path, default=None,
                        help="folder of the PNG charts (default: figures/ beside the report)")
    parser.add_argument("--save", type=Path, default=None, metavar="JSON",
                        help="also write every number of the run as JSON (for --replot)")
    parser.add_argument("--out", "--doc", dest="doc", default=str(common.default_report_dir() / "work_precision.md"),
                        help="Markdown report (default: docs/work_precision.md of a source checkout, else "
                             "./work_precision.md); '-' writes none")
    parser.add_argument("--case", choices=("plate", "rod", "ffr_hammer", "ffr_base"), default=None,
                        help="run one case only (default: all)")
    parser.add_argument("--replot", type=Path, default=None, metavar="JSON",
                        help="draw the charts and the report again from a run saved with --save")
    args = parser.parse_args(argv)
    if args.out_dir is None:
        args.out_dir = common.figures_dir(args.doc)
    if args.replot is not None:
        cases, mach, quick, elapsed, today = load_run(args.replot)
    else:
        t0 = time.perf_counter()
        mach = machine()
        print(f"machine: {mach}")
        # set-up CPU times must not come from flexfmu's on-disk cache of models and modal bases
        saved = os.environ.get("FLEXFMU_CACHE")
        os.environ["FLEXFMU_CACHE"] = "0"
        try:
            cases = run(args.quick, args.case)
        finally:
            if saved is None:
                os.environ.pop("FLEXFMU_CACHE", None)
            else:
                os.environ["FLEXFMU_CACHE"] = saved
        quick, elapsed = args.quick, time.perf_counter() - t0
        today = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        if args.save is not None:
            save_run(args.save, cases, mach, quick, elapsed, today)
    plt = common.pyplot()
    if plt is None:
        print(common.skipped("the charts", "matplotlib"))
        figures = [None] * len(cases)
    else:
        args.out_dir.mkdir(parents=True, exist_ok=True)
        figures = [plot_case(c, args.out_dir / f"work_precision_{c.key}.png", plt) for c in cases]
        for f in figures:
            print(f"wrote {f}")
    for c in cases:
        print(f"\n{c.title}:")
        for sentence in conclusions(c):
            print(f"  - {sentence}")
    if args.doc != "-":
        write_report(Path(args.doc), cases, figures, mach, quick, elapsed, NOTES, today,
                     replotted=args.replot is not None)
        print(f"wrote {args.doc}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
