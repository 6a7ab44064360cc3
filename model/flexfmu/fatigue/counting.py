"""Rainflow counting of a stress history (ASTM E1049-85, 5.4.4), by the ``rainflow`` package.

The package walks the history's reversals in Python; the reversals are found here first with numpy (the samples
where the slope changes sign, plateaus reduced to one sample, the first and last samples kept), so a long record
costs one numpy pass and a Python loop over its turning points only.  The cycles are the package's: full cycles
(count 1) closed inside the history and the residue's ranges as half cycles (count 0.5), as the standard counts
them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.errors import ParameterError, require

INSTALL_HINT = "pip install 'flexfmu[fatigue]' (or pip install 'rainflow>=3.2,<4')"


@dataclass(frozen=True)
class Cycles:
    """Counted cycles: ranges (max - min, the history's unit), means ((max + min) / 2), counts (1 or 0.5), and the
    sample indices where each cycle's range starts and ends (of the history given to ``rainflow_cycles``)."""

    ranges: np.ndarray
    means: np.ndarray
    counts: np.ndarray
    start: np.ndarray
    end: np.ndarray

    @property
    def total(self) -> float:
        """The number of cycles (half cycles count 0.5)."""
        return float(self.counts.sum())

    def scaled(self, factor: float) -> "Cycles":
        """The same cycles with ranges and means multiplied by ``factor`` (a unit change)."""
        return Cycles(self.ranges * factor, self.means * factor, self.counts, self.start, self.end)


def reversal_indices(history) -> np.ndarray:
    """Indices of the history's reversals: the first and last samples and every sample where the slope changes
    sign (of a plateau, its first sample).  A constant history has its first and last sample only."""
    x = np.asarray(history, float)
    n = x.size
    if n < 3:
        return np.arange(n)
    # the samples that differ from the one before: a plateau becomes its first sample
    moves = np.flatnonzero(np.diff(x) != 0.0) + 1
    keep = np.concatenate(([0], moves))
    if keep.size < 2:
        return np.array([0, n - 1])
    slope = np.sign(np.diff(x[keep]))
    turning = keep[1:-1][slope[:-1] * slope[1:] < 0]
    return np.concatenate(([0], turning, [n - 1]))


def rainflow_cycles(history) -> Cycles:
    """The rainflow cycles of ``history`` (a 1-D sequence of finite numbers, >= 2 samples)."""
    x = np.asarray(history, float)
    require(x.ndim == 1, "history", f"an array of shape {x.shape}", "a 1-D sequence of stresses")
    require(x.size >= 2, "history", f"{x.size} sample(s)", "at least 2 samples")
    if not np.all(np.isfinite(x)):
        bad = int(np.flatnonzero(~np.isfinite(x))[0])
        raise ParameterError("history", f"sample {bad} is {float(x[bad])!r}", "finite stresses")
    try:
        import rainflow
    except ImportError:
        raise ParameterError("rainflow", "rainflow counting needs the rainflow package", INSTALL_HINT) from None
    index = reversal_indices(x)
    rows = list(rainflow.extract_cycles(x[index].tolist()))
    if not rows:
        empty = np.zeros(0)
        return Cycles(empty, empty, empty, np.zeros(0, int), np.zeros(0, int))
    rng, mean, count, i0, i1 = (np.asarray(c) for c in zip(*rows))
    return Cycles(rng.astype(float), mean.astype(float), count.astype(float), index[i0.astype(int)],
                  index[i1.astype(int)])
