#!/usr/bin/env python3
"""Stability where methods fail: four studies, each a table on stdout and a chart.

    flexfmu bench stability [--quick] [--out REPORT.md]
    .venv/bin/python benchmarks/stability.py [--only rk4|rotation|cosim|tumbling] [--figures DIR]

1. rk4       the undamped modal RK4 amplification |R(i dt omega)| against dt * omega_max: theory and the
             growth per step measured on the reframe integrator and the fixed-frame baseline with the
             library's dt guard bypassed, and on the exponential scheme, which has no limit
             (stability_rk4.png).
2. rotation  a free rod spinning about its major principal axis: relative change of the distance
             between its two ends against the rotation angle, fixed-frame linear baseline, reframe
             (both schemes) and the baseline's analytic stretch (stability_rotation.png).
3. cosim     FFRBeam on a rigid Platform, explicit force/motion coupling: spectral radius of the
             linearised co-simulation step over mass ratio x communication step, both master
             schemes, cross-checked by direct runs (stability_cosim.png).
4. tumbling  a free rod tumbling about its intermediate principal axis: drift of the global angular
             momentum (and of the energy) against dt for the "paper" and "consistent" schemes
             (stability_tumbling.png).

docs/stability.md quotes the numbers this prints.  Runs in about two minutes on 2 cores.  Without matplotlib
the tables are printed and the charts skipped.  Each study is a module of its own (stability_rk4,
stability_rotation, stability_cosim, stability_tumbling; what they share is in stability_common); this one runs them.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from flexfmu.studies import common
from flexfmu.studies.stability_cosim import study_cosim
from flexfmu.studies.stability_rk4 import study_rk4
from flexfmu.studies.stability_rotation import study_rotation
from flexfmu.studies.stability_tumbling import study_tumbling


STUDIES = {"rk4": study_rk4, "rotation": study_rotation, "cosim": study_cosim, "tumbling": study_tumbling}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", choices=sorted(STUDIES), action="append", help="run only these studies")
    parser.add_argument("--out", type=Path, default=None, metavar="REPORT.md",
                        help="also write the printed tables and the charts' links as a Markdown report; the charts "
                             "then go to figures/ beside it (default: no report)")
    parser.add_argument("--figures", type=Path, default=None, metavar="DIR",
                        help="folder for the PNGs (default: figures/ beside --out; without --out docs/figures of a "
                             "source checkout, else ./figures)")
    parser.add_argument("--quick", action="store_true", help="skip the co-simulation map (the slowest study)")
    args = parser.parse_args(argv)
    figures = args.figures or common.figures_dir(args.out)
    charts = []
    with common.recording() as printed:
        for name in args.only or [n for n in STUDIES if not (args.quick and n == "cosim")]:
            t0 = time.perf_counter()
            charts.append(STUDIES[name](figures).get("chart"))
            print(f"   ({name}: {time.perf_counter() - t0:.0f} s)")
    if args.out is not None and str(args.out) != "-":
        path = common.write_text_report(
            args.out, "Stability studies" + (" (--quick)" if args.quick else ""),
            "Written by `flexfmu bench stability` (flexfmu.studies.stability); docs/stability.md explains the "
            "studies and quotes a full run.", printed.getvalue(), charts)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
