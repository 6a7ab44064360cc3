"""Writers of the fmi-cross-check files, shared by the reference generators in FFRBeam/ and ReframeBody/."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def num(x: float) -> str:
    return repr(float(x))          # shortest text that reads back to the same double


def write_csv(path: Path, names, columns) -> None:
    """fmi-cross-check CSV: quoted header, one row per time; columns (n_rows,) each."""
    cols = [np.asarray(c, float) for c in columns]
    lines = [",".join(f'"{n}"' for n in names)]
    lines += [",".join(num(c[i]) for c in cols) for i in range(len(cols[0]))]
    path.write_text("\n".join(lines) + "\n")


def step_table(step_times, values, stop_time):
    """Rows of a step-shaped input table: value k held on [t_k, t_{k+1}); a jump is two rows at one time.
    values (n_steps, n_inputs).  Runs of equal values are merged."""
    values = np.atleast_2d(np.asarray(values, float))
    edges = list(step_times) + [stop_time]
    rows = [(edges[0], values[0])]
    for k in range(1, len(values)):
        if np.array_equal(values[k], values[k - 1]):
            continue
        rows += [(edges[k], values[k - 1]), (edges[k], values[k])]
    rows.append((edges[-1], values[-1]))
    return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
