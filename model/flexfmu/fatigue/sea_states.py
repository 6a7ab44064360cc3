"""Damage over a sea-state scatter diagram or a power matrix's bins: each bin's damage rate from its own stress
history, weighted by how much of the time the bin occurs.

With bin i's damage rate r_i (1/s, its record's Miner damage over the record's span) and its share of the time p_i
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

from flexfmu.errors import require

from .assessment import DEFAULT_N_REF, SECONDS_PER_YEAR, FatigueAssessment, assess_history
from .history import StressHistory, history_from_csv
from .sn_curve import SNCurve

HOURS_PER_YEAR = SECONDS_PER_YEAR / 3600.0


@dataclass(frozen=True)
class DamageBin:
    """A sea state or power-matrix bin: its label, its stress history, and its share of the time, as a
    ``probability`` (0 .. 1) or as ``hours_per_year`` (0 .. 8766), one of the two."""

    label: str
    history: StressHistory
    probability: float | None = None
    hours_per_year: float | None = None

    def __post_init__(self):
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
    def from_csv(cls, label: str, path, column: str, *, probability: float | None = None,
                 hours_per_year: float | None = None, t_start: float | None = None, unit: str = "Pa") -> "DamageBin":
        """A bin whose history is ``column`` of the result CSV ``path`` from ``t_start`` on."""
        return cls(label, history_from_csv(path, column, unit=unit, t_start=t_start, parameter=f"bin {label}"),
                   probability, hours_per_year)


@dataclass(frozen=True)
class SeaStateDamage:
    """The bins' assessments and the weighted totals."""

    curve: SNCurve
    labels: tuple
    shares: tuple
    assessments: tuple
    design_life_years: float | None

    @property
    def damage_rate(self) -> float:
        """sum_i p_i r_i, 1/s."""
        return float(sum(p * a.damage_rate for p, a in zip(self.shares, self.assessments)))

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
        """Per bin: label, share, record_s, cycles, record_damage, damage_rate (1/s), weighted_rate (p r, 1/s),
        damage_share (of the weighted rate), equivalent_range (curve unit, N_ref cycles)."""
        total = self.damage_rate
        out = []
        for label, p, a in zip(self.labels, self.shares, self.assessments):
            weighted = p * a.damage_rate
            out.append({"label": label, "share": p, "record_s": a.duration, "cycles": a.cycles.total,
                        "record_damage": a.damage, "damage_rate": a.damage_rate, "weighted_rate": weighted,
                        "damage_share": weighted / total if total > 0.0 else 0.0,
                        "equivalent_range": a.equivalent_range})
        return out

    def table(self) -> str:
        """The bins and the totals as text."""
        u = self.curve.unit
        n_ref = self.assessments[0].n_ref
        lines = [f"damage over {len(self.labels)} bins on {self.curve.describe()}",
                 f"{'bin':>16} {'share':>9} {'record s':>9} {'cycles':>10} {'damage':>11} {'rate 1/s':>11} "
                 f"{'p x rate':>11} {'of total':>8} {'S_eq ' + u:>10}"]
        for r in self.rows():
            lines.append(f"{r['label']:>16} {r['share']:9.4g} {r['record_s']:9.4g} {r['cycles']:10.5g} "
                         f"{r['record_damage']:11.4e} {r['damage_rate']:11.4e} {r['weighted_rate']:11.4e} "
                         f"{100.0 * r['damage_share']:7.2f}% {r['equivalent_range']:10.4g}")
        shares = sum(self.shares)
        lines.append(f"time in the bins: {100.0 * shares:.4g} %" + ("" if shares >= 1.0 - 1e-9 else
                                                                       " (the rest does no damage)"))
        lines.append(f"long-term damage rate: {self.damage_rate:.6e} per s; per year {self.annual_damage:.6e}")
        lines.append("life: unlimited (no damage)" if math.isinf(self.life_years)
                     else f"life: {self.life_years:.6g} years")
        if self.design_life_years is not None:
            lines.append(f"damage over the design life of {self.design_life_years:g} years: {self.lifetime_damage:.6e}")
        lines.append(f"(S_eq: equivalent range of N_ref = {n_ref:.3g} cycles per record, slope m {self.curve.m:g})")
        return "\n".join(lines)

    def write_csv(self, path) -> Path:
        """The rows as CSV (rates in 1/s, S_eq in the curve's unit) with a last row ``total``."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        keys = ("label", "share", "record_s", "cycles", "record_damage", "damage_rate", "weighted_rate",
                "damage_share", "equivalent_range")
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(keys[:-1] + (f"equivalent_range_{self.curve.unit}",))
            for r in self.rows():
                w.writerow([r["label"]] + [repr(float(r[k])) for k in keys[1:]])
            w.writerow(["total", repr(float(sum(self.shares))), "", "", "", "", repr(self.damage_rate), "1.0", ""])
        return path


def sea_state_damage(bins, curve: SNCurve, *, design_life_years: float | None = None,
                     n_ref: float = DEFAULT_N_REF, n_bins: int = 20) -> SeaStateDamage:
    """Assess each bin's history on ``curve`` and weight the damage rates by the bins' shares of the time (module
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
    assessments: list[FatigueAssessment] = [assess_history(b.history, curve, n_ref=n_ref, n_bins=n_bins)
                                            for b in bins]
    return SeaStateDamage(curve, tuple(labels), tuple(shares), tuple(assessments), design_life_years)
