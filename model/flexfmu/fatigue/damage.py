"""Palmgren-Miner damage of counted cycles on an S-N curve, the equivalent constant-amplitude range, and the
damage binned by range.

Miner's sum  D = sum_i n_i / N(S_i): failure is predicted at D = 1; each cycle's damage is independent of the order
and of the mean stress (no mean-stress correction here).

Equivalent range for a one-slope curve of slope m and a reference count N_ref:

    S_eq = (sum_i n_i S_i^m / N_ref)^(1/m)

so that N_ref cycles of S_eq do the damage of the counted cycles on that line.  For a curve with two slopes or a
cut-off no single m makes that true for every range: ``equivalent_range`` keeps the formula with the caller's m
(flexfmu.fatigue.assessment passes the curve's first slope, the one its larger ranges lie on), and
``damage_equivalent_range`` gives the range whose N_ref cycles do the same Miner damage on the curve itself,
S = N^-1(N_ref / D): the two agree on a one-slope curve without a cut-off.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import require

from .sn_curve import SNCurve


def _checked(ranges, counts) -> tuple[np.ndarray, np.ndarray]:
    s = np.asarray(ranges, float).ravel()
    n = np.asarray(counts, float).ravel()
    require(s.shape == n.shape, "counts", f"{n.size} counts for {s.size} ranges", "one count per range")
    require(bool(np.all(np.isfinite(s))) and bool(np.all(s >= 0.0)), "ranges", "a range is negative or not finite",
            "finite ranges >= 0")
    require(bool(np.all(np.isfinite(n))) and bool(np.all(n >= 0.0)), "counts", "a count is negative or not finite",
            "finite counts >= 0")
    return s, n


def cycle_damage(ranges, counts, curve: SNCurve) -> np.ndarray:
    """Each cycle's Miner damage n_i / N(S_i) (ranges in the curve's unit); 0 below a cut-off and for S = 0."""
    s, n = _checked(ranges, counts)
    return n / curve.cycles_to_failure(s)


def miner_damage(ranges, counts, curve: SNCurve) -> float:
    """Miner's sum D = sum n_i / N(S_i) of cycles ``counts`` of ranges ``ranges`` (the curve's unit)."""
    return float(cycle_damage(ranges, counts, curve).sum())


def equivalent_range(ranges, counts, m: float, n_ref: float) -> float:
    """S_eq = (sum n_i S_i^m / N_ref)^(1/m): the constant range of N_ref cycles with the same damage on a one-slope
    curve of slope m (ranges' unit)."""
    s, n = _checked(ranges, counts)
    require(math.isfinite(m) and m > 0.0, "m", f"{m!r}", "a finite slope > 0")
    require(math.isfinite(n_ref) and n_ref > 0.0, "n-ref", f"{n_ref!r}", "a finite reference cycle count > 0")
    # scaled by the largest range: S^m of 1e8 Pa with m = 5 is 1e40, fine, but of 1e9 with m = 8 is not
    top = float(s.max()) if s.size else 0.0
    if top == 0.0:
        return 0.0
    return top * float(np.sum(n * (s / top) ** m) / n_ref) ** (1.0 / m)


def damage_equivalent_range(damage: float, curve: SNCurve, n_ref: float) -> float:
    """The range whose ``n_ref`` cycles do Miner damage ``damage`` on ``curve`` (its sloped lines; 0 for no
    damage)."""
    require(math.isfinite(n_ref) and n_ref > 0.0, "n-ref", f"{n_ref!r}", "a finite reference cycle count > 0")
    if damage <= 0.0:
        return 0.0
    return curve.range_at(n_ref / damage)


@dataclass(frozen=True)
class RangeBins:
    """Cycles and damage binned by range: bin k holds ranges in [edges[k], edges[k+1]) (the last bin includes its
    upper edge)."""

    edges: np.ndarray
    cycles: np.ndarray
    damage: np.ndarray


def bin_by_range(ranges, counts, damage, n_bins: int = 20, top: float | None = None) -> RangeBins:
    """Bin the cycles ``counts`` of ranges ``ranges`` and their damage ``damage`` into ``n_bins`` equal bins of range
    from 0 to ``top`` (default: the largest range).  Each cycle's damage is its own (from its exact range), summed
    per bin: binning changes nothing in the totals."""
    s, n = _checked(ranges, counts)
    d = np.asarray(damage, float).ravel()
    require(d.shape == s.shape, "damage", f"{d.size} damages for {s.size} ranges", "one damage per range")
    require(isinstance(n_bins, (int, np.integer)) and 1 <= n_bins <= 1000, "bins", f"{n_bins!r}",
            "an integer 1 .. 1000")
    top = float(s.max()) if top is None and s.size else (top or 0.0)
    if top <= 0.0:
        top = 1.0
    edges = np.linspace(0.0, top, n_bins + 1)
    k = np.clip(np.searchsorted(edges, s, side="right") - 1, 0, n_bins - 1)
    return RangeBins(edges, np.bincount(k, weights=n, minlength=n_bins),
                     np.bincount(k, weights=d, minlength=n_bins))
