"""Damage over a sea-state scatter diagram or a power matrix's bins: each bin's damage rate from its own stress
history, weighted by how much of the time the bin occurs.

With bin i's damage rate r_i (1/s, its records' Miner damage over their spans: one record, or one per seed) and its share of the time p_i
(a probability, or hours per year / the year's 8766 hours):

    r = sum_i p_i r_i                       the long-term damage rate, 1/s
    D_year = r * 365.25 * 86400 s           the damage per year; life = 1 / D_year years
    D_life = D_year * design life           the lifetime damage (when a design life is given)

The shares may sum to less than 1: the rest of the time (calm, the converter parked) does no damage.  Each record
should be long enough to hold the bin's load cycles in their proportions (a few hundred of the lowest wave
frequency's cycles); a record's residue is counted as half cycles, a bias that shrinks with its length.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexfmu.errors import require

from .assessment import DEFAULT_N_REF, SECONDS_PER_YEAR, assess_history
from .damage import equivalent_range
from .history import StressHistory, history_from_csv
from .sn_curve import SNCurve

HOURS_PER_YEAR = SECONDS_PER_YEAR / 3600.0


@dataclass(frozen=True)
class DamageBin:
    """A sea state or power-matrix bin: its label, its stress record(s) (one StressHistory, or several: a power
    matrix's seeds), and its share of the time, as a ``probability`` (0 .. 1) or as ``hours_per_year``
    (0 .. 8766), one of the two.  Several records make one rate: their damage summed over their spans summed."""

    label: str
    history: StressHistory | tuple
    probability: float | None = None
    hours_per_year: float | None = None

    def __post_init__(self):
        records = (self.history,) if isinstance(self.history, StressHistory) else tuple(self.history)
        require(len(records) >= 1 and all(isinstance(r, StressHistory) for r in records), f"bin {self.label}",
                "no stress history", "a StressHistory or a sequence of them")
        object.__setattr__(self, "history", records)
        given = [v for v in (self.probability, self.hours_per_year) if v is not None]
        require(len(given) == 1, f"bin {self.label}", "give its probability or its hours per year",
                "exactly one of probability, hours_per_year")
        if self.probability is not None:
            p = self.probability
            require(math.isfinite(p) and 0.0 <= p <= 1.0, f"bin {self.label}: probability", f"{p!r}", "0 .. 1")
        else:
            h = self.hours_per_year
            require(math.isfinite(h) and 0.0 <= h <= HOURS_PER_YEAR, f"bin {self.label}: hours_per_year", f"{h!r}",
                    f"0 .. {HOURS_PER_YEAR:g} h")

    @property
    def share(self) -> float:
        """The bin's share of the time."""
        return self.probability if self.probability is not None else self.hours_per_year / HOURS_PER_YEAR

    @classmethod
    def from_csv(cls, label: str, paths, column: str, *, probability: float | None = None,
                 hours_per_year: float | None = None, t_start: float | None = None, unit: str = "Pa") -> "DamageBin":
        """A bin whose record is ``column`` of the result CSV ``paths`` (one path, or several: one per seed) from
        ``t_start`` on."""
        paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
        return cls(label, tuple(history_from_csv(path, column, unit=unit, t_start=t_start, parameter=f"bin {label}")
                                for path in paths), probability, hours_per_year)


@dataclass(frozen=True)
class BinDamage:
    """One bin's records assessed on the curve."""

    label: str
    share: float
    assessments: tuple

    @property
    def duration(self) -> float:
        return float(sum(a.duration for a in self.assessments))

    @property
    def damage(self) -> float:
        return float(sum(a.damage for a in self.assessments))

    @property
    def cycles(self) -> float:
        return float(sum(a.cycles.total for a in self.assessments))

    @property
    def damage_rate(self) -> float:
        """The records' damage over their spans, 1/s."""
        return self.damage / self.duration

    def equivalent_range(self, m: float, n_ref: float) -> float:
        """(sum n_i S_i^m / N_ref)^(1/m) over every record's cycles."""
        ranges = np.concatenate([a.cycles.ranges for a in self.assessments])
        counts = np.concatenate([a.cycles.counts for a in self.assessments])
        return equivalent_range(ranges, counts, m, n_ref) if ranges.size else 0.0


@dataclass(frozen=True)
class SeaStateDamage:
    """The bins' assessments and the weighted totals."""

    curve: SNCurve
    bins: tuple
    n_ref: float
    design_life_years: float | None

    @property
    def damage_rate(self) -> float:
        """sum_i p_i r_i, 1/s."""
        return float(sum(b.share * b.damage_rate for b in self.bins))

    @property
    def annual_damage(self) -> float:
        return self.damage_rate * SECONDS_PER_YEAR

    @property
    def life_years(self) -> float:
        return math.inf if self.annual_damage <= 0.0 else 1.0 / self.annual_damage

    @property
    def lifetime_damage(self) -> float | None:
        """The damage over the design life (None without one)."""
        return None if self.design_life_years is None else self.annual_damage * self.design_life_years

    def rows(self) -> list[dict]:
        """Per bin: label, share, records, record_s (their spans summed), cycles, record_damage, damage_rate (1/s),
        weighted_rate (p r, 1/s), damage_share (of the weighted rate), equivalent_range (curve unit, N_ref cycles,
        the curve's first slope)."""
        total = self.damage_rate
        out = []
        for b in self.bins:
            weighted = b.share * b.damage_rate
            out.append({"label": b.label, "share": b.share, "records": len(b.assessments), "record_s": b.duration,
                        "cycles": b.cycles, "record_damage": b.damage, "damage_rate": b.damage_rate,
                        "weighted_rate": weighted, "damage_share": weighted / total if total > 0.0 else 0.0,
                        "equivalent_range": b.equivalent_range(self.curve.m, self.n_ref)})
        return out

    def table(self) -> str:
        """The bins and the totals as text."""
        u = self.curve.unit
        lines = [f"damage over {len(self.bins)} bins on {self.curve.describe()}",
                 f"{'bin':>16} {'share':>9} {'records':>7} {'record s':>9} {'cycles':>10} {'damage':>11} "
                 f"{'rate 1/s':>11} {'p x rate':>11} {'of total':>8} {'S_eq ' + u:>10}"]
        for r in self.rows():
            lines.append(f"{r['label']:>16} {r['share']:9.4g} {r['records']:7d} {r['record_s']:9.4g} "
                         f"{r['cycles']:10.5g} {r['record_damage']:11.4e} {r['damage_rate']:11.4e} "
                         f"{r['weighted_rate']:11.4e} {100.0 * r['damage_share']:7.2f}% {r['equivalent_range']:10.4g}")
        shares = sum(b.share for b in self.bins)
        lines.append(f"time in the bins: {100.0 * shares:.4g} %" + ("" if shares >= 1.0 - 1e-9 else
                                                                       " (the rest does no damage)"))
        lines.append(f"long-term damage rate: {self.damage_rate:.6e} per s; per year {self.annual_damage:.6e}")
        lines.append("life: unlimited (no damage)" if math.isinf(self.life_years)
                     else f"life: {self.life_years:.6g} years")
        if self.design_life_years is not None:
            lines.append(f"damage over the design life of {self.design_life_years:g} years: {self.lifetime_damage:.6e}")
        lines.append(f"(S_eq: equivalent range of N_ref = {self.n_ref:.3g} cycles of each bin's records, slope m "
                     f"{self.curve.m:g})")
        return "\n".join(lines)

    def write_csv(self, path) -> Path:
        """The rows as CSV (rates in 1/s, S_eq in the curve's unit) with a last row ``total``."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        keys = ("label", "share", "records", "record_s", "cycles", "record_damage", "damage_rate", "weighted_rate",
                "damage_share", "equivalent_range")
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(keys[:-1] + (f"equivalent_range_{self.curve.unit}",))
            for r in self.rows():
                w.writerow([r["label"], repr(float(r["share"])), str(r["records"])]
                           + [repr(float(r[k])) for k in keys[3:]])
            w.writerow(["total", repr(float(sum(b.share for b in self.bins))), "", "", "", "",
                        "", repr(self.damage_rate), "1.0", ""])
        return path


def sea_state_damage(bins, curve: SNCurve, *, design_life_years: float | None = None,
                     n_ref: float = DEFAULT_N_REF, n_bins: int = 20) -> SeaStateDamage:
    """Assess each bin's records on ``curve`` and weight the bins' damage rates by their shares of the time (module
    docstring).  ``bins``: DamageBin objects (DamageBin.from_csv for result CSVs)."""
    bins = list(bins)
    require(len(bins) >= 1, "bins", "none given", "one or more DamageBin")
    labels = [b.label for b in bins]
    require(len(set(labels)) == len(labels), "bins", "two bins share a label", "distinct labels")
    shares = [b.share for b in bins]
    require(sum(shares) <= 1.0 + 1e-9, "bins", f"the shares of the time sum to {sum(shares):.6g}",
            "probabilities summing to <= 1, or <= 8766 hours per year in all")
    if design_life_years is not None:
        require(math.isfinite(design_life_years) and design_life_years > 0.0, "design_life_years",
                f"{design_life_years!r}", "a finite number of years > 0")
    assessed = tuple(BinDamage(b.label, b.share, tuple(assess_history(h, curve, n_ref=n_ref, n_bins=n_bins)
                                                       for h in b.history))
                     for b in bins)
    return SeaStateDamage(curve, assessed, float(n_ref), design_life_years)
