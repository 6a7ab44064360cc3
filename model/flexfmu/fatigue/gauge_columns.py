"""The columns of a result CSV that a signed stress history is made of, found by the gauge's name, and read.

- A beam section gauge PREFIX (FFRBeam's ``gauge_1``, or ``harvester.gauge_1`` as a co-simulation's CSV names it):
  ``PREFIX_N`` (N), ``PREFIX_My``, ``PREFIX_Mz`` (N m), and ``PREFIX_T`` (N m) when present.
- A solid gauge NAME (flexfmu export --gauge NAME=...): ``NAME.sigma_xx`` .. ``NAME.sigma_xz`` (Pa, body frame), in
  flexfmu.core.stress's VOIGT order.

A column that is missing is a ParameterError naming the option and listing the file's columns with that prefix, or,
when there are none, the gauges the file does hold.
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.errors import ParameterError, require

from .history import MIN_SAMPLES, TIME_COLUMNS, read_columns, read_header

SECTION_FORCES = ("N", "My", "Mz")
#: the stress components of a solid gauge, VOIGT order (flexfmu.core.stress)
TENSOR_COMPONENTS = ("sigma_xx", "sigma_yy", "sigma_zz", "sigma_xy", "sigma_yz", "sigma_xz")


def _missing(path, header, wanted, prefix, parameter, gauges, example) -> None:
    missing = [c for c in wanted if c not in header]
    if not missing:
        return
    found = [c for c in header if c.startswith(prefix)]
    if found:
        held = f"its columns starting with {prefix!r}: " + ", ".join(found)
    elif gauges:
        held = "the gauges it holds: " + ", ".join(gauges)
    else:
        held = f"it holds no gauge of this kind (no column ending in {example})"
    raise ParameterError(parameter, f"{path} has no column " + ", ".join(repr(c) for c in missing), held)


def section_columns(path, prefix: str, parameter: str = "section-gauge") -> tuple[list[str], str | None]:
    """The section force columns [PREFIX_N, PREFIX_My, PREFIX_Mz] of ``prefix`` in the result CSV, and PREFIX_T
    (None when absent)."""
    header = read_header(path)
    prefix = str(prefix).strip()
    require(bool(prefix), parameter, "an empty prefix", "a gauge's prefix, e.g. gauge_1 or harvester.gauge_1")
    wanted = [f"{prefix}_{q}" for q in SECTION_FORCES]
    gauges = sorted(c[:-len("_My")] for c in header if c.endswith("_My"))
    _missing(path, header, wanted, prefix, parameter, gauges, "_My")
    torsion = f"{prefix}_T"
    return wanted, torsion if torsion in header else None


def tensor_columns(path, name: str, parameter: str = "tensor-gauge") -> list[str]:
    """The six stress columns NAME.sigma_xx .. NAME.sigma_xz (VOIGT order) of the solid gauge ``name``."""
    header = read_header(path)
    name = str(name).strip()
    require(bool(name), parameter, "an empty name", "a gauge's name, e.g. tip (its columns tip.sigma_xx ..)")
    wanted = [f"{name}.{c}" for c in TENSOR_COMPONENTS]
    gauges = sorted(c[:-len(".sigma_xx")] for c in header if c.endswith(".sigma_xx"))
    _missing(path, header, wanted, name, parameter, gauges, ".sigma_xx")
    return wanted


def read_time_and_columns(path, columns, *, time_column: str | None = None, t_start: float | None = None,
                          parameter: str = "gauge") -> tuple[np.ndarray, np.ndarray]:
    """The time (s) and the ``columns`` (samples x columns) of a result CSV from ``t_start`` on, as
    flexfmu.fatigue.history_from_csv reads one column: the time ``time_column``, else the first of TIME_COLUMNS
    present, else the first column; NaN or inf refused naming the column and its time."""
    header = read_header(path)
    if time_column is None:
        time_column = next((c for c in TIME_COLUMNS if c in header), header[0])
    require(time_column in header, "time-column", f"{time_column!r} is not a column of {path}", ", ".join(header))
    _, values = read_columns(path, [time_column, *columns])
    t, v = values[:, 0], values[:, 1:]
    require(t.size >= MIN_SAMPLES, parameter, f"{path} holds {t.size} row(s): the history is too short",
            f"at least {MIN_SAMPLES} rows")
    if t_start is not None:
        require(math.isfinite(t_start), "t-start", f"{t_start!r}", "a finite time, s")
        keep = t >= t_start
        require(int(keep.sum()) >= MIN_SAMPLES, "t-start",
                f"{t_start:g} s leaves {int(keep.sum())} row(s) of {path} (t = {t[0]:g} .. {t[-1]:g} s): the history "
                "is too short", f"a start time that leaves at least {MIN_SAMPLES} rows")
        t, v = t[keep], v[keep]
    for j, column in enumerate([time_column, *columns]):
        x = t if j == 0 else v[:, j - 1]
        if not np.all(np.isfinite(x)):
            k = int(np.flatnonzero(~np.isfinite(x))[0])
            raise ParameterError(f"{'time-column' if j == 0 else parameter} {column}",
                                 f"the value at t = {float(t[k])!r} s is {float(x[k])!r}",
                                 "finite values (a run that diverged, or a gap in the record?)")
    steps = np.diff(t)
    require(bool(np.all(steps > 0.0)), f"time-column {time_column}",
            f"not increasing at row {int(np.argmin(steps > 0.0)) + 1} after t-start", "strictly increasing times")
    return t, v
