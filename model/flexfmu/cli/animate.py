"""`flexfmu animate RESULT.csv --fmu BODY.fmu`: the deformed body of a co-simulation (its shape coordinates q_1 ..
q_n recorded in the results CSV, its shape file read from the FMU) as an animation and a VTK series."""
from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError

#: the most frames drawn when --every is not given (a 10 s run at 1 ms has 10 001 rows)
MAX_DEFAULT_FRAMES = 150
_TIME_COLUMNS = ("time", "t")


def _shown(names: list[str], limit: int = 12) -> str:
    return ", ".join(names[:limit]) + (f", ... ({len(names)} in all)" if len(names) > limit else "")


def _instances(header: list[str]) -> list[str]:
    """The instance names of a results CSV's columns (instance.variable), in order of first appearance."""
    seen = []
    for column in header:
        if "." in column:
            name = column.split(".", 1)[0]
            if name not in seen:
                seen.append(name)
    return seen


def q_columns(header: list[str], names, instance: str | None, source: str) -> list[int]:
    """The CSV column of each shape coordinate ``names`` (q_1 ...), bare or prefixed by an instance name as
    flexfmu cosim writes them (``bracket.q_1``); ParameterError saying what the CSV holds when they are not all
    there or several instances have them (then --instance chooses)."""
    names = list(names)
    index = {column: k for k, column in enumerate(header)}
    if instance is not None:
        prefixes = [instance + "."]
        if prefixes[0] + names[0] not in index:
            raise ParameterError("instance", f"{source} has no column {instance}.{names[0]}",
                                 "an instance with shape coordinates: "
                                 + (_shown([c[:-len(names[0]) - 1] for c in header if c.endswith("." + names[0])])
                                    or "none in this CSV"))
    else:
        prefixes = [column[:-len(names[0])] for column in header
                    if column == names[0] or column.endswith("." + names[0])]
    if not prefixes:
        instances = _instances(header)
        raise ParameterError("RESULT", f"{source} has no shape coordinates {names[0]} ... {names[-1]} (bare or as "
                             f"INSTANCE.{names[0]}); it has {len(header)} columns"
                             + (f", of the instances {_shown(instances)}" if instances else "")
                             + f": {_shown(header)}",
                             "the results of a co-simulation that records the body's outputs q_1 ... q_n "
                             "(an FMU exported by this flexfmu outputs them)")
    if len(prefixes) > 1:
        raise ParameterError("instance", f"{len(prefixes)} instances of {source} have shape coordinates "
                             f"({_shown([p.rstrip('.') or '(no prefix)' for p in prefixes])})",
                             "--instance NAME, the one the FMU is")
    prefix = prefixes[0]
    missing = [name for name in names if prefix + name not in index]
    if missing:
        held = sorted((c for c in header if c.startswith(prefix + "q_")), key=len)
        raise ParameterError("RESULT", f"{source} lacks {_shown([prefix + m for m in missing])} of the FMU's "
                             f"{len(names)} shape coordinates (it holds {_shown(held) or 'none'})",
                             "the results of a run of this FMU (the same export)")
    return [index[prefix + name] for name in names]


def read_q(path, names, instance: str | None, every: int | None):
    """(t (T,), q (T, n), every K) from a results CSV: every K-th row (K default: at most MAX_DEFAULT_FRAMES
    frames) of the shape coordinates ``names``."""
    path = Path(path)
    if not path.is_file():
        raise ParameterError("RESULT", f"{path}: no such file", "a results CSV (flexfmu cosim --out)")
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        try:
            header = next(reader)
        except StopIteration:
            raise ParameterError("RESULT", f"{path} is empty", "a results CSV with a header row") from None
        except (csv.Error, UnicodeDecodeError) as exc:
            raise ParameterError("RESULT", f"{path} is not a CSV ({exc})", "a results CSV") from None
        header = [h.strip() for h in header]
        time_column = next((header.index(c) for c in _TIME_COLUMNS if c in header), None)
        if time_column is None:
            raise ParameterError("RESULT", f"{path} has no time column (its first columns: {_shown(header, 5)})",
                                 "a results CSV whose columns include time")
        columns = q_columns(header, names, instance, str(path))
        try:
            n_rows = sum(1 for row in reader if row)
        except (csv.Error, UnicodeDecodeError) as exc:
            raise ParameterError("RESULT", f"{path}: {exc}", "a results CSV") from None
    if n_rows == 0:
        raise ParameterError("RESULT", f"{path} has a header and no rows", "a results CSV with at least one row")
    if every is None:
        every = max(1, math.ceil(n_rows / MAX_DEFAULT_FRAMES))
    elif every < 1:
        raise ParameterError("every", f"{every}", "an integer >= 1")
    t, q = [], []
    # the second pass keeps the chosen rows' time and q columns only (a 10 s run at 1 ms has 10 001 rows of every
    # output of every instance)
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        next(reader)
        try:
            for k, row in enumerate(r for r in reader if r):
                if k % every == 0:
                    t.append(float(row[time_column]))
                    q.append([float(row[c]) for c in columns])
        except (ValueError, IndexError, csv.Error) as exc:
            raise ParameterError("RESULT", f"{path}: a row that is not numbers in every column ({exc})",
                                 "a results CSV of numbers") from None
    t, q = np.array(t), np.array(q)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
        bad = int(np.flatnonzero(~(np.isfinite(t) & np.all(np.isfinite(q), axis=1)))[0])
        raise ParameterError("RESULT", f"{path}: NaN or infinite shape coordinates at t = {float(t[bad])!r} s",
                             "a run that stayed finite")
    return t, q, every


def _animate(args: argparse.Namespace) -> int:
    from flexfmu.body.shape_file import read_fmu_shape, read_shape_file
    from flexfmu.viz.animate import animate
    from flexfmu.viz.series import deformed_series
    from flexfmu.viz.vtk import write_vtk_series

    if args.scale is not None and not (math.isfinite(args.scale) and args.scale > 0):
        raise ParameterError("scale", f"{args.scale!r}", "a finite factor > 0")
    if args.every is not None and args.every < 1:
        raise ParameterError("every", f"{args.every}", "an integer >= 1")
    fmu = Path(args.fmu)
    shape = read_shape_file(fmu) if fmu.suffix.lower() == ".npz" else read_fmu_shape(fmu)
    t, q, every = read_q(args.result, shape.names, args.instance, args.every)
    series = deformed_series(shape, q, t)
    stressed = series.von_mises is not None
    u = np.linalg.norm(series.displacement, axis=2)
    k_u = int(np.argmax(u.max(axis=1)))
    print(f"{args.result}: {len(t)} frames (every {every} rows), t = {t[0]:.6g} ... {t[-1]:.6g} s; "
          f"largest |u| {u[k_u].max():.4g} m at t = {t[k_u]:.6g} s"
          + (f"; largest von Mises {series.von_mises.max():.4g} Pa at t = "
             f"{t[int(np.argmax(series.von_mises.max(axis=1)))]:.6g} s" if stressed else
             "; no stress shapes in the FMU: coloured by |u|"))
    if args.vtk is not None:
        print(f"wrote {write_vtk_series(series, args.vtk)} ({len(t)} .vtu frames)")
    if args.out is not None:
        still = None if args.still is None else (k_u, args.still)
        done = animate(series, args.out, scale=args.scale, fps=args.fps, still=still,
                       title=f"{shape.body or fmu.stem} ({fmu.name}) in {Path(args.result).name}")
        print(f"wrote {done.path} ({done.frames} frames at {args.fps} per second; displacement x {done.scales[0]:.4g})"
              + (f" and {args.still} (t = {t[k_u]:.6g} s, the largest displacement)" if still else ""))
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu animate` to ``sub``, the sub-commands of build_parser."""
    parser = sub.add_parser(
        "animate", help="animate an exported body's deformed shape from a co-simulation's results",
        description="Draw the deformed body of a results CSV (flexfmu cosim --out): the shape coordinates q_1 ... "
                    "q_n the exported FMU outputs (columns q_K or INSTANCE.q_K) and the FMU's shape file "
                    "(resources/shape.npz: nodes, cells, u = Psi q, nodal stress S q) give every node's displacement "
                    "and von Mises stress. Writes a GIF (or MP4 with ffmpeg) and, with --vtk, a VTK series for "
                    "ParaView.")
    parser.add_argument("result", metavar="RESULT.csv", help="results CSV with a time column and the q columns")
    parser.add_argument("--fmu", required=True, metavar="BODY.fmu",
                        help="the FMU the body was run as (flexfmu export), or its shape.npz")
    parser.add_argument("--out", type=Path, default=Path("anim.gif"), metavar="OUT",
                        help="the animation, .gif or .mp4 (default anim.gif)")
    parser.add_argument("--vtk", type=Path, default=None, metavar="DIR",
                        help="also write DIR/frame_NNNN.vtu (point data displacement, von_mises) and DIR/frame.pvd")
    parser.add_argument("--scale", type=float, default=None, metavar="S",
                        help="displacement factor (default: the largest displacement drawn at 10 %% of the body's "
                             "size)")
    parser.add_argument("--fps", type=int, default=20, metavar="N", help="frames per second (default 20)")
    parser.add_argument("--every", type=int, default=None, metavar="K",
                        help=f"draw every K-th row (default: at most {MAX_DEFAULT_FRAMES} frames)")
    parser.add_argument("--instance", default=None, metavar="NAME",
                        help="the instance whose columns to read, when several have q columns")
    parser.add_argument("--still", type=Path, default=None, metavar="PNG",
                        help="also save the frame of the largest displacement as a picture")
    parser.set_defaults(func=_animate)
