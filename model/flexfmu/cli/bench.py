"""`flexfmu bench [STUDY]`: a study of flexfmu.studies through its main(argv)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: ``flexfmu bench STUDY``: the module flexfmu.studies.<module>, each with main(argv) (benchmarks/<module>.py
#: are shells over the same).
BENCH_STUDIES = {"performance": "performance", "work-precision": "work_precision", "stability": "stability",
                 "spinup": "spinup"}


def _bench(args: argparse.Namespace) -> int:
    """Run a study of flexfmu.studies (default: performance) through its main(argv)."""
    import importlib

    module = BENCH_STUDIES[args.study]
    try:
        study = importlib.import_module(f"flexfmu.studies.{module}")
    except ModuleNotFoundError as exc:
        if exc.name != f"flexfmu.studies.{module}":
            raise                                  # a package the study needs: its own message names it
        print(f"flexfmu: error: bench {args.study}: no study module flexfmu.studies.{module} in "
              f"{Path(__file__).parents[1]}", file=sys.stderr)
        return 2
    return study.main((["--quick"] if args.quick else []) + (["--out", args.out] if args.out else []))


def add_parser(sub) -> None:
    """Add `flexfmu bench` to ``sub``, the sub-commands of build_parser."""
    bench = sub.add_parser(
        "bench", help="benchmark studies (flexfmu.studies; also benchmarks/<study>.py)",
        description="Run a benchmark study (flexfmu.studies.<study>; works from an installed flexfmu): performance "
                    "(default; the performance table, report performance.md), work-precision (error against CPU "
                    "time; report work_precision.md and charts), stability (tables and charts of the failure "
                    "modes), spinup (linear models against a geometrically exact reference). Reports and charts go "
                    "to docs/ and docs/figures/ when flexfmu is a source checkout's model/flexfmu (an editable "
                    "install), else to the current directory and ./figures/. The reference trajectories are "
                    "package data (flexfmu/data/references/). Charts need matplotlib and the Exudyn comparisons "
                    "Exudyn; without them those parts are skipped with the pip command. More options: "
                    "python -m flexfmu.studies.<study> --help.")
    bench.add_argument("study", nargs="?", choices=tuple(BENCH_STUDIES), default="performance",
                       help="which study (default performance)")
    bench.add_argument("--quick", action="store_true", help="the study's short version")
    bench.add_argument("--out", default=None, metavar="REPORT.md",
                       help="the study's Markdown report; its charts go to figures/ beside it (default: performance "
                            "and work-precision write docs/<study>.md of a source checkout, else ./<study>.md; "
                            "stability and spinup write no report and draw their charts into docs/figures/ or "
                            "./figures/); '-': no report")
    bench.set_defaults(func=_bench)
