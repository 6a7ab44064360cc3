"""`flexfmu wec ...`: the wave-energy converter's studies (the power matrix)."""
from __future__ import annotations

import argparse
from pathlib import Path

from flexfmu.errors import CosimulationError, ParameterError


def _floats(text: str, name: str) -> list:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ParameterError(name, f"{text!r} is not a comma-separated list of numbers", "e.g. 1.0,1.4,2.0") from None


def _wec_power_matrix(args: argparse.Namespace) -> int:
    """flexfmu wec power-matrix: flexfmu.wec.system.power_matrix, its CSVs and heat map.  Everything every run would
    refuse is checked before the first (exit 2); runs that fail make it exit 2 after writing what was computed,
    saying how many failed, why and the first one's message; a matrix without a computed cell is not written."""
    import numpy as np

    from flexfmu.cosim.checks import check_output_path
    from flexfmu.wec import system as wec
    from flexfmu.wec.sweeps import failure_summary

    if args.seeds < 1:
        raise ParameterError("seeds", f"{args.seeds}", "integer >= 1")
    if args.workers < 1:
        raise ParameterError("workers", f"{args.workers}", "integer >= 1")
    max_steepness = wec.MAX_STEEPNESS if args.max_steepness is None else args.max_steepness
    heights = None if args.hs is None else _floats(args.hs, "hs")
    periods = None if args.tp is None else _floats(args.tp, "tp")
    check_output_path(args.out, "out")
    for suffix in ("_runs.csv", "_bins.csv"):
        check_output_path(args.out.with_name(args.out.stem + suffix), "out")
    check_output_path(args.plot, "plot")
    scheduler = None if args.serial else (args.scheduler or "local")
    iec_options = {k: v for k, v in (("hs_bin_width", args.hs_bin_width), ("te_bin_width", args.te_bin_width),
                                     ("min_runs", args.min_runs)) if v is not None}
    matrix = wec.power_matrix(args.system_file, heights, periods,
                              seeds=range(1, args.seeds + 1), t_end=args.t_end, step=args.step,
                              boundary=args.boundary, backend=args.backend, fmu_dir=args.fmu_dir,
                              scheduler=scheduler, n_workers=args.workers, max_steepness=max_steepness,
                              progress=True, assignments=tuple(args.set), average_from=args.average_from,
                              bin_checks=args.bin_checks, **iec_options)
    if not matrix.rows:   # nothing was run
        raise ParameterError("max-steepness", f"every cell of --hs x --tp is steeper than {max_steepness:g} "
                             "(2 pi Hs / (g Tp^2))", "a grid with a cell within --max-steepness (default 1/15)")
    n_runs = len(matrix.rows)
    print(f"{n_runs} co-simulations ({np.isfinite(matrix.power).sum()} of {matrix.power.size} cells) in "
          f"{matrix.wall_s:.0f} s ({'serial' if scheduler is None else 'Dask ' + scheduler})")
    for row in matrix.rows:
        if row.get("error"):
            print(f"  failed: Hs {row['wave_height']:g} m, Tp {row['wave_period']:g} s, seed {row['seed']}: "
                  f"{row['error']}")
    failed = failure_summary(matrix.rows)
    if np.isfinite(matrix.power).any():
        print(f"wrote {matrix.write_csv(args.out)}")
        print(f"wrote {matrix.write_bins_csv(args.out.with_name(args.out.stem + '_bins.csv'))}")
        print(f"wrote {wec.write_table(matrix.rows, args.out.with_name(args.out.stem + '_runs.csv'))}")
        print(f"wrote {matrix.plot(args.plot)}")
    if failed is not None:
        raise CosimulationError(f"power-matrix: {failed}" + ("" if np.isfinite(matrix.power).any()
                                                             else "; nothing written"))
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu wec` (power-matrix) to ``sub``, the sub-commands of build_parser."""
    wec_p = sub.add_parser("wec", help="wave-energy converter studies (examples/point_absorber/, "
                           "examples/wave_converter/)")
    wec_sub = wec_p.add_subparsers(dest="wec_command", required=True)
    pm = wec_sub.add_parser(
        "power-matrix", help="mean absorbed power over significant wave height x peak period (JONSWAP, "
                             "IEC TS 62600-100 statistics)",
        description="The power matrix of a wave-energy converter: per cell (Hs, Tp) one JONSWAP co-simulation per "
                    "seed, each run's mean absorbed power over its statistics window, and per cell (a bin centred on "
                    "its sea state: Hm0 = Hs, Te of the wave's spectrum) the count, mean, std, min and max of the "
                    "runs' means, the confidence interval of the mean, the energy flux J, capture width and its "
                    "ratio (IEC TS 62600-100, by MHKiT), and in the point absorber's linear configuration the "
                    "frequency-domain prediction. The point absorber (the default system): 20-minute sea states "
                    "after the wave's ramp, statistics over those 20 minutes, the wave's record as long as the run, "
                    "bins checked (widths <= 0.5 m x 1 s, no two sea states in one bin, >= --min-runs seeds). The "
                    "harvester's wave converter: 60 s runs, their second half, --boundary, bins unchecked unless "
                    "--bin-checks. On a Dask LocalCluster (default), a running scheduler (--scheduler) or serially "
                    "(--serial). Writes the matrix as CSV (rows Hs, columns Tp, W; empty cells not computed: steeper "
                    "than --max-steepness or failed), the bins' statistics in CSV_bins.csv, one row per "
                    "co-simulation in CSV_runs.csv, and a heat map with each cell's confidence interval.")
    pm.add_argument("system_file", metavar="SYSTEM_FILE", type=Path, nargs="?",
                    default=Path("examples/point_absorber/OspSystemStructure.xml"),
                    help="OspSystemStructure.xml or .ssp (default examples/point_absorber/OspSystemStructure.xml)")
    pm.add_argument("--hs", default=None, metavar="H1,H2,...",
                    help="significant wave heights, m (default: point absorber 1,2,3; harvester 0.05,0.1,0.15,0.2)")
    pm.add_argument("--tp", default=None, metavar="T1,T2,...",
                    help="peak periods, s (default: point absorber 6,8,10,12; harvester 1.0,1.2,1.4,1.6,2.0)")
    pm.add_argument("--seeds", type=int, default=3, metavar="N", help="random-phase seeds 1..N per cell (default 3)")
    pm.add_argument("--t-end", type=float, default=None, metavar="T",
                    help="length of each run, s (default: point absorber the wave's ramp + 1200; harvester 60)")
    pm.add_argument("--average-from", type=float, default=None, metavar="T",
                    help="start of each run's statistics window, s (default: point absorber the end of the wave's "
                         "ramp; harvester half the run)")
    pm.add_argument("--step", type=float, default=None, metavar="H", help="communication step (default: the file's)")
    pm.add_argument("--set", action="append", default=[], metavar="INSTANCE.VARIABLE=VALUE",
                    help="a start value of every run, e.g. float.heave_only=true (repeatable)")
    pm.add_argument("--boundary", default=None, metavar="B",
                    help="harvester clamps: XFF (default), XFX, FXF; only for a system with a harvester")
    pm.add_argument("--backend", choices=("library", "fmu"), default="library",
                    help="library (default): the models the FMUs wrap; fmu: the FMUs (--fmu-dir)")
    pm.add_argument("--fmu-dir", type=Path, default=None, metavar="DIR", help="take the FMUs from DIR")
    pm.add_argument("--max-steepness", type=float, default=None, metavar="S",
                    help="skip cells steeper than 2 pi Hs / (g Tp^2) > S (default 1/15)")
    pm.add_argument("--bin-checks", action=argparse.BooleanOptionalAction, default=None,
                    help="check the bins against IEC TS 62600-100 (default: on for the point absorber, off for the "
                         "model-scale harvester)")
    pm.add_argument("--hs-bin-width", type=float, default=None, metavar="W",
                    help="Hm0 width of each bin, m (default and most: 0.5)")
    pm.add_argument("--te-bin-width", type=float, default=None, metavar="W",
                    help="Te width of each bin, s (default and most: 1.0)")
    pm.add_argument("--min-runs", type=int, default=None, metavar="N",
                    help="fewest runs (seeds) per bin when checked (default 3)")
    where = pm.add_mutually_exclusive_group()
    where.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a LocalCluster)")
    where.add_argument("--serial", action="store_true", help="run in this process, without Dask")
    pm.add_argument("--workers", type=int, default=2, metavar="N", help="LocalCluster workers (default 2)")
    pm.add_argument("--out", type=Path, default=Path("power_matrix.csv"), metavar="CSV",
                    help="the matrix (default power_matrix.csv; beside it CSV_bins.csv and CSV_runs.csv)")
    pm.add_argument("--plot", type=Path, default=Path("power_matrix.png"), metavar="PNG",
                    help="the heat map (default power_matrix.png)")
    pm.set_defaults(func=_wec_power_matrix)
