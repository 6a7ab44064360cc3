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
    """flexfmu wec power-matrix: flexfmu.wec.system.power_matrix, its CSV and heat map.  Everything every run would
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
    heights, periods = _floats(args.hs, "hs"), _floats(args.tp, "tp")
    check_output_path(args.out, "out")
    check_output_path(args.out.with_name(args.out.stem + "_runs.csv"), "out")
    check_output_path(args.plot, "plot")
    scheduler = None if args.serial else (args.scheduler or "local")
    matrix = wec.power_matrix(args.system_file, heights, periods,
                              seeds=range(1, args.seeds + 1), t_end=args.t_end, step=args.step,
                              boundary=args.boundary, backend=args.backend, fmu_dir=args.fmu_dir,
                              scheduler=scheduler, n_workers=args.workers, max_steepness=max_steepness,
                              progress=True)
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
        print(f"wrote {wec.write_table(matrix.rows, args.out.with_name(args.out.stem + '_runs.csv'))}")
        print(f"wrote {matrix.plot(args.plot)}")
    if failed is not None:
        raise CosimulationError(f"power-matrix: {failed}" + ("" if np.isfinite(matrix.power).any()
                                                             else "; nothing written"))
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu wec` (power-matrix) to ``sub``, the sub-commands of build_parser."""
    wec_p = sub.add_parser("wec", help="wave-energy converter studies (examples/wave_converter/)")
    wec_sub = wec_p.add_subparsers(dest="wec_command", required=True)
    pm = wec_sub.add_parser(
        "power-matrix", help="mean harvested power over significant wave height x peak period (JONSWAP)",
        description="The power matrix of the wave-energy converter: per cell (Hs, Tp) one JONSWAP co-simulation per "
                    "seed, mean harvested power over the second half of each run, averaged over the seeds; on a Dask "
                    "LocalCluster (default), a running scheduler (--scheduler) or serially (--serial). Writes the "
                    "matrix as CSV (rows Hs, columns Tp, W; empty cells not computed: steeper than --max-steepness "
                    "or failed) and a heat map; one row per co-simulation in CSV_runs.csv.")
    pm.add_argument("system_file", metavar="SYSTEM_FILE", type=Path, nargs="?",
                    default=Path("examples/wave_converter/OspSystemStructure.xml"),
                    help="OspSystemStructure.xml or .ssp (default examples/wave_converter/OspSystemStructure.xml)")
    pm.add_argument("--hs", default="0.05,0.1,0.15,0.2", metavar="H1,H2,...",
                    help="significant wave heights, m (default 0.05,0.1,0.15,0.2)")
    pm.add_argument("--tp", default="1.0,1.2,1.4,1.6,2.0", metavar="T1,T2,...",
                    help="peak periods, s (default 1.0,1.2,1.4,1.6,2.0)")
    pm.add_argument("--seeds", type=int, default=3, metavar="N", help="random-phase seeds 1..N per cell (default 3)")
    pm.add_argument("--t-end", type=float, default=60.0, metavar="T", help="length of each run, s (default 60)")
    pm.add_argument("--step", type=float, default=None, metavar="H", help="communication step (default: the file's)")
    pm.add_argument("--boundary", default="XFF", metavar="B", help="harvester clamps: XFF (default), XFX, FXF")
    pm.add_argument("--backend", choices=("library", "fmu"), default="library",
                    help="library (default): the models the FMUs wrap; fmu: the FMUs (--fmu-dir)")
    pm.add_argument("--fmu-dir", type=Path, default=None, metavar="DIR", help="take the FMUs from DIR")
    pm.add_argument("--max-steepness", type=float, default=None, metavar="S",
                    help="skip cells steeper than 2 pi Hs / (g Tp^2) > S (default 1/15)")
    where = pm.add_mutually_exclusive_group()
    where.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a LocalCluster)")
    where.add_argument("--serial", action="store_true", help="run in this process, without Dask")
    pm.add_argument("--workers", type=int, default=2, metavar="N", help="LocalCluster workers (default 2)")
    pm.add_argument("--out", type=Path, default=Path("power_matrix.csv"), metavar="CSV",
                    help="the matrix (default power_matrix.csv)")
    pm.add_argument("--plot", type=Path, default=Path("power_matrix.png"), metavar="PNG",
                    help="the heat map (default power_matrix.png)")
    pm.set_defaults(func=_wec_power_matrix)
