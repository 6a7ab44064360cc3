"""Command-line interface: a thin shell over library functions.

    flexfmu modal SCENE [--boundary B] [--elements-per-segment N] [--modes K] [--json] [--plot PNG]
                  [--max-dofs N] [--animate [OUT.gif]] [--vtk DIR]
    flexfmu modal MODEL [--material E,NU,RHO] [--length-unit U] [--nodes FILE] [--clamp SPEC] [--modes K]
                  [--json] [--plot PNG] [--max-dofs N] [--animate [OUT.gif]] [--vtk DIR]
    flexfmu export MODEL -o OUT.fmu [--material E,NU,RHO] [--nodes FILE] [--clamp SPEC]
                  [--interface NAME=X,Y,Z]... [--modes N | --f-max HZ [--tolerance TOL]] [--damping ZETA]
                  [--runtime python|native]
    flexfmu build [--out dist] [--runtime python|native [--fmu FFRBeam|ReframeBody] [--set NAME=VALUE]...
                  [--name ID]]
    flexfmu reframe MODEL [--scheme consistent|exponential|paper] [--t-end T] [--dt DT] [--modes N]
                    [--force FX,FY,FZ] [--omega0 W1,W2,W3] [--every K] [--out result.csv]
    flexfmu cosim SYSTEM_FILE --t-end T [--step H] [--out results.csv] [--master fmpy|libcosim|ecos|library]
                    [--scheme gauss-seidel|jacobi|interface-jacobian|step-jacobian] [--fmu-dir DIR] [--plot PNG]
                    [--set INSTANCE.VARIABLE=VALUE]...
    flexfmu animate RESULT.csv --fmu BODY.fmu [--out anim.gif] [--vtk DIR] [--scale S] [--fps N] [--every K]
                    [--instance NAME] [--still PNG]
    flexfmu fatigue RESULT.csv --gauge COLUMN (--sn m,log10a[,cutoff] | --curve DNV-D|BS-F ...) [--cut-off S|limit]
                    [--unit Pa] [--t-start T] [--out table.csv] [--plot hist.png]
    flexfmu wec power-matrix [SYSTEM_FILE] [--hs H1,H2,..] [--tp T1,T2,..] [--seeds N] [--t-end T]
                    [--serial | --scheduler ADDRESS] [--out power_matrix.csv] [--plot power_matrix.png]
    flexfmu bench [performance|work-precision|stability|spinup] [--quick] [--out FILE]
    flexfmu cross-check OUT_DIR [--model NAME...] [--fmi-version 2 3] [--interface cs me] [--platform NAME...]
    flexfmu main            the modal report of the paper's specimen (python3 tasks.py main does more)

Bad input exits with status 2 and a one-line message naming the parameter.
"""
from __future__ import annotations

import argparse
import sys

# one module per command, its parser and handler together; the library does the work
from flexfmu.cli import animate, bench, build, cosim, cross_check, export, fatigue, modal, reframe, wec
from flexfmu.cli.bench import BENCH_STUDIES
from flexfmu.errors import FlexfmuError

__all__ = ["BENCH_STUDIES", "build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="flexfmu", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for command in (modal, export, build, reframe, cosim, fatigue, animate, wec, bench, cross_check):
        command.add_parser(sub)
    modal.add_main_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except FlexfmuError as exc:
        print(f"flexfmu: error: {exc}", file=sys.stderr)
        return 2
