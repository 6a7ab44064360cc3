"""A stress history to assess: the samples of one output against time, from arrays or a result CSV.

The CSVs ``flexfmu cosim --out`` (and fmpy, libcosim, ecos through it) write have a header row, the time first
(``time``), then one column per output (``instance.variable``); a column's stress is in Pa, as every flexfmu output.
"""
from __future__ import annotations

import csv
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError, require

from .sn_curve import unit_scale

#: names a result CSV's time column may have (the first that is present is the time); else the first column
TIME_COLUMNS = ("time", "t", "Time", "# time")
#: the fewest samples a history may have: one range needs two
MIN_SAMPLES = 2


@dataclass(frozen=True)
class StressHistory:
    """Stress samples ``stress`` (``unit``) at times ``time`` (s, increasing), named ``name``."""

    time: np.ndarray
    stress: np.ndarray
    name: str = "stress"
    unit: str = "Pa"

    def __post_init__(self):
        t = np.asarray(self.time, float)
        s = np.asarray(self.stress, float)
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "stress", s)
        unit_scale(self.unit, "stress unit")
        require(t.ndim == 1 and s.shape == t.shape, self.name,
                f"{s.size} stress samples against {t.size} times", "one stress per time")
        require(t.size >= MIN_SAMPLES, self.name, f"{t.size} sample(s): the history is too short",
                f"at least {MIN_SAMPLES} samples over a time span > 0")
        for values, what in ((t, "time"), (s, self.name)):
            if not np.all(np.isfinite(values)):
                k = int(np.flatnonzero(~np.isfinite(values))[0])
                raise ParameterError(what, f"sample {k} (t = {float(t[k])!r} s) is {float(values[k])!r}",
                                     "finite values (a run that diverged or a gap in the record?)")
        steps = np.diff(t)
        require(bool(np.all(steps > 0.0)), "time", f"not increasing at sample {int(np.argmin(steps > 0.0)) + 1}",
                "strictly increasing times")

    @property
    def duration(self) -> float:
        """The span the history covers, s."""
        return float(self.time[-1] - self.time[0])

    def in_unit(self, unit: str) -> np.ndarray:
        """The stresses in ``unit``."""
        return self.stress * (unit_scale(self.unit) / unit_scale(unit))

    def after(self, t_start: float | None) -> "StressHistory":
        """The samples at t >= t_start (None: all): a run's start-up transient left out."""
        if t_start is None:
            return self
        require(math.isfinite(t_start), "t-start", f"{t_start!r}", "a finite time, s")
        keep = self.time >= t_start
        n = int(keep.sum())
        require(n >= MIN_SAMPLES, "t-start", f"{t_start:g} s leaves {n} sample(s) of {self.name} "
                f"(record {self.time[0]:g} .. {self.time[-1]:g} s): the history is too short",
                f"a start time that leaves at least {MIN_SAMPLES} samples")
        return StressHistory(self.time[keep], self.stress[keep], self.name, self.unit)


def read_header(path) -> list[str]:
    """The column names of a result CSV (its first row); a ParameterError naming the file if it is missing or
    empty."""
    path = Path(path)
    require(path.is_file(), str(path), "no such file", "a result CSV (flexfmu cosim --out)")
    with path.open(newline="", encoding="utf-8") as f:
        header = next(csv.reader(f), [])
    require(bool(header), str(path), "the file is empty", "a header row, then one row per time")
    return [h.strip() for h in header]


def read_columns(path, columns=None) -> tuple[list[str], np.ndarray]:
    """The header and the numbers (rows x the ``columns`` asked for, default all) of a result CSV; a ParameterError
    naming the file for a file that is missing, empty, ragged or holds text where a number belongs (NaN and inf are
    read, and refused later by the history that holds them, naming the column).  numpy's C reader, which reads only
    the columns asked for: a long record of many outputs is read in seconds."""
    header = read_header(path)
    names = header if columns is None else list(columns)
    index = [header.index(c) for c in names]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")          # "empty input file": a header without rows
            values = np.loadtxt(path, delimiter=",", skiprows=1, usecols=index, ndmin=2, encoding="utf-8")
    except UserWarning:
        values = np.empty((0, len(names)))
    except ValueError as exc:
        # numpy names the line and the text it could not read, or the row with too few columns
        raise ParameterError(str(path), " ".join(str(exc).split()), "one number per column on every row") from None
    return names, values.reshape(-1, len(names))


def history_from_csv(path, column: str, *, time_column: str | None = None, unit: str = "Pa",
                     t_start: float | None = None, parameter: str = "gauge") -> StressHistory:
    """The history of ``column`` in the result CSV ``path`` (stress in ``unit``; from ``t_start`` on).  The time is
    ``time_column``, else the first of TIME_COLUMNS present, else the first column.  An unknown column is a
    ParameterError naming ``parameter`` and listing the file's columns."""
    header = read_header(path)
    if time_column is None:
        time_column = next((c for c in TIME_COLUMNS if c in header), header[0])
    columns = [c for c in header if c != time_column]
    require(time_column in header, "time-column", f"{time_column!r} is not a column of {path}",
            ", ".join(header))
    require(column in header and column != time_column, parameter, f"{column!r} is not a column of {path}",
            "one of its columns: " + ", ".join(columns))
    _, values = read_columns(path, (time_column, column))
    t, s = values[:, 0], values[:, 1]
    require(t.size >= MIN_SAMPLES, parameter, f"{path} holds {t.size} row(s): the history is too short",
            f"at least {MIN_SAMPLES} rows")
    if t_start is not None:    # before the checks: a transient left out may hold what they refuse
        require(math.isfinite(t_start), "t-start", f"{t_start!r}", "a finite time, s")
        keep = t >= t_start
        require(int(keep.sum()) >= MIN_SAMPLES, "t-start",
                f"{t_start:g} s leaves {int(keep.sum())} row(s) of {path} (t = {t[0]:g} .. {t[-1]:g} s): the history "
                "is too short", f"a start time that leaves at least {MIN_SAMPLES} rows")
        t, s = t[keep], s[keep]
    for values_, what in ((s, f"{parameter} {column}"), (t, f"time-column {time_column}")):
        if not np.all(np.isfinite(values_)):
            k = int(np.flatnonzero(~np.isfinite(values_))[0])
            raise ParameterError(what, f"the value at t = {float(t[k])!r} s is {float(values_[k])!r}",
                                 "finite values (a run that diverged, or a gap in the record?)")
    return StressHistory(t, s, column, unit)
