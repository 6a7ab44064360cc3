"""The fatigue assessment of one stress history on one S-N curve: rainflow cycles, Miner damage binned by range,
equivalent ranges, the damage rate per second of the record and the life it implies."""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexfmu.errors import require

from .counting import Cycles, rainflow_cycles
from .damage import RangeBins, bin_by_range, cycle_damage, damage_equivalent_range, equivalent_range
from .history import StressHistory
from .sn_curve import SNCurve

SECONDS_PER_HOUR = 3600.0
#: a Julian year, 365.25 days
SECONDS_PER_YEAR = 365.25 * 86400.0
#: the reference cycle count of the equivalent ranges (the standards' curves' knee in air)
DEFAULT_N_REF = 1e7


@dataclass(frozen=True)
class FatigueAssessment:
    """One history on one curve.  Ranges in the curve's unit; ``duration`` the record's span in s."""

    name: str
    curve: SNCurve
    cycles: Cycles
    damage_per_cycle: np.ndarray
    duration: float
    bins: RangeBins
    n_ref: float

    @property
    def damage(self) -> float:
        """Miner's sum over the record."""
        return float(self.damage_per_cycle.sum())

    @property
    def damage_rate(self) -> float:
        """Damage per second of the record, 1/s."""
        return self.damage / self.duration

    @property
    def life_seconds(self) -> float:
        """Seconds until D = 1 at this damage rate (inf without damage)."""
        return math.inf if self.damage_rate <= 0.0 else 1.0 / self.damage_rate

    @property
    def equivalent_range(self) -> float:
        """(sum n_i S_i^m / N_ref)^(1/m) with the curve's first slope m, over every counted cycle."""
        if self.cycles.ranges.size == 0:
            return 0.0
        return equivalent_range(self.cycles.ranges, self.cycles.counts, self.curve.m, self.n_ref)

    @property
    def damage_equivalent_range(self) -> float:
        """The range whose N_ref cycles do the record's damage on the curve itself (its slopes and cut-off)."""
        return damage_equivalent_range(self.damage, self.curve, self.n_ref)

    # ------------------------------------------------------------------ output
    def rows(self) -> list[dict]:
        """One dict per range bin: range_from, range_to (curve unit), cycles, damage, damage_share."""
        total = self.damage
        return [{"range_from": float(lo), "range_to": float(hi), "cycles": float(c), "damage": float(d),
                 "damage_share": float(d / total) if total > 0.0 else 0.0}
                for lo, hi, c, d in zip(self.bins.edges[:-1], self.bins.edges[1:], self.bins.cycles,
                                        self.bins.damage)]

    def table(self) -> str:
        """The bins and the totals as text."""
        u = self.curve.unit
        lines = [f"{self.name}: rainflow cycles (ASTM E1049-85) on {self.curve.describe()}",
                 f"{'range from':>12} {'range to':>12} {'cycles':>12} {'damage':>12} {'share':>7}   ({u})"]
        for row in self.rows():
            lines.append(f"{row['range_from']:12.4g} {row['range_to']:12.4g} {row['cycles']:12.6g} "
                         f"{row['damage']:12.4e} {100.0 * row['damage_share']:6.2f}%")
        return "\n".join(lines + self.summary_lines())

    def summary_lines(self) -> list[str]:
        u = self.curve.unit
        life = self.life_seconds
        lines = [f"cycles: {self.cycles.total:.6g} over {self.duration:.6g} s (largest range "
                 f"{(self.cycles.ranges.max() if self.cycles.ranges.size else 0.0):.4g} {u})",
                 f"Miner damage: {self.damage:.6e}",
                 f"equivalent range (m {self.curve.m:g}, N_ref {self.n_ref:.3g}): {self.equivalent_range:.6g} {u}"]
        if self.curve.m2 is not None or self.curve.cutoff is not None:
            s_eq = self.damage_equivalent_range
            below = self.curve.cutoff is not None and 0.0 < s_eq < self.curve.cutoff
            lines.append(f"damage-equivalent range on the curve (N_ref {self.n_ref:.3g}): {s_eq:.6g} {u}"
                         + (" (below the cut-off: on the sloped line extended)" if below else ""))
        lines.append(f"damage rate: {self.damage_rate:.6e} per s")
        if math.isinf(life):
            lines.append("life: unlimited (no cycle does damage on this curve)")
        else:
            lines.append(f"life at this rate: {life / SECONDS_PER_HOUR:.6g} h = {life / SECONDS_PER_YEAR:.6g} years")
        return lines

    def write_csv(self, path) -> Path:
        """The bins as CSV (range_from, range_to in the curve's unit, cycles, damage, damage_share) with a last
        row ``total``; the summary's numbers are in the text table."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        u = self.curve.unit
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow([f"range_from_{u}", f"range_to_{u}", "cycles", "damage", "damage_share"])
            for row in self.rows():
                w.writerow([repr(row[k]) for k in ("range_from", "range_to", "cycles", "damage", "damage_share")])
            w.writerow(["total", "", repr(self.cycles.total), repr(self.damage), "1.0" if self.damage > 0 else "0.0"])
        return path


def assess_history(history: StressHistory, curve: SNCurve, *, n_ref: float = DEFAULT_N_REF,
                   n_bins: int = 20) -> FatigueAssessment:
    """Rainflow-count ``history``, convert its ranges to the curve's unit and take each cycle's Miner damage on
    ``curve``; the bins split 0 .. the largest range into ``n_bins``."""
    require(math.isfinite(n_ref) and n_ref > 0.0, "n-ref", f"{n_ref!r}", "a finite reference cycle count > 0")
    cycles = rainflow_cycles(history.in_unit(curve.unit))
    damage = cycle_damage(cycles.ranges, cycles.counts, curve)
    bins = bin_by_range(cycles.ranges, cycles.counts, damage, n_bins)
    return FatigueAssessment(history.name, curve, cycles, damage, history.duration, bins, float(n_ref))
