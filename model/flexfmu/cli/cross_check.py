"""`flexfmu cross-check`: the FMI Cross-Check folders of flexfmu's native FMUs (flexfmu.fmi.cross_check)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _cross_check(args: argparse.Namespace) -> int:
    """Write the folders, print what was written, skipped and found; 1 when fmpy's validator or the rules found a
    problem."""
    from flexfmu.fmi.cross_check import generate

    report = generate(args.out_dir, models=args.model, fmi_versions=args.fmi_version, interfaces=args.interface,
                      platforms=args.platform, bracket=args.bracket, log=print)
    for note in report.notes:
        print(f"note: {note}")
    for (model, version, interface), (variable, value) in report.differences.items():
        print(f"{model} FMI {version} {interface}: fmpy reproduces the reference to {value:.2g} relative "
              f"(largest: {variable})")
    for problem in report.problems:
        print(f"flexfmu cross-check: problem: {problem}", file=sys.stderr)
    print(f"fmpy's cross-check validator: {len(report.problems)} problem(s) in {report.validated} model folder(s) "
          f"under {args.out_dir / 'fmus'}")
    return 1 if report.problems else 0


def add_parser(sub) -> None:
    """Add `flexfmu cross-check` to ``sub``, the sub-commands of build_parser."""
    from flexfmu.fmi.cross_check import INTERFACES, MODELS, PLATFORM_NAMES

    platforms = [name for pair in PLATFORM_NAMES.items() for name in pair if name]
    parser = sub.add_parser(
        "cross-check", help="the FMI Cross-Check folders of the native FMUs (FMU, reference, inputs, options)",
        description="Build the native FMUs of FFRBeam, ReframeBody and the bracket of examples/bracket exported "
                    "clamped, and write for each the folder fmus/<2.0|3.0>/<cs|me>/<platform>/flexfmu/<version>/"
                    "<Model>/ the FMI Cross-Check rules ask of an exporting tool: <Model>.fmu, <Model>_in.csv, "
                    "<Model>_ref.csv (the flexfmu library's result, not the FMU's), <Model>_ref.opt, README.md; "
                    "then check it with fmpy's cross-check validator and, on Linux x86-64, fmpy's simulation of "
                    "each FMU against its reference. See docs/cross_check.md.")
    parser.add_argument("out_dir", type=Path, metavar="OUT_DIR", help="the vendor folder: fmus/ is written in it")
    parser.add_argument("--model", nargs="+", default=list(MODELS), choices=list(MODELS), metavar="NAME",
                        help=f"the models (default: all: {', '.join(MODELS)})")
    parser.add_argument("--fmi-version", nargs="+", type=int, default=[2, 3], choices=(2, 3), metavar="{2,3}",
                        help="FMI 2.0 and/or 3.0 (default: both)")
    parser.add_argument("--interface", nargs="+", default=["cs"], choices=INTERFACES,
                        help="cs (default): co-simulation; me: model exchange (FFRBeam and the clamped bracket; "
                             "ReframeBody is skipped with the reason)")
    parser.add_argument("--platform", nargs="+", default=None, choices=platforms, metavar="NAME",
                        help="platform folders, in FMI 2.0's or 3.0's names (" + ", ".join(platforms) + "); "
                             "default: every platform each FMU has a binary for")
    parser.add_argument("--bracket", type=Path, default=None, metavar="JSON",
                        help="examples/bracket/bracket.json (default: the source checkout's; without it the "
                             "bracket is skipped)")
    parser.set_defaults(func=_cross_check)
