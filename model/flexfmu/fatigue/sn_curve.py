"""S-N curves: the cycles N a constant-amplitude stress range S takes to fail a detail.

One slope, as the standards write it:

    N = a S^-m,        log10 N = log10 a - m log10 S

Two options a curve may add below its first slope:

- a second slope m2 (log10 a2) below the knee range S_knee, where both lines meet: the curve the standards give for
  variable-amplitude loading (DNV-RP-C203: m2 = 5 beyond 1e7 cycles in air; BS 7608: m + 2 beyond 1e7);
- a cut-off (endurance) range S_cut: cycles of a smaller range do no damage (N infinite), the constant-amplitude
  fatigue limit when every cycle has the same range.

Ranges are in the curve's ``unit`` (MPa for the standards' curves); flexfmu's outputs are in Pa, and the functions
that take a history convert it (flexfmu.fatigue.assessment).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from flexfmu.errors import ParameterError, require

#: stress units a curve or a history may be in, and their size in Pa
STRESS_UNITS = {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9}


def unit_scale(unit: str, parameter: str = "unit") -> float:
    """The size of ``unit`` in Pa (STRESS_UNITS); a ParameterError naming ``parameter`` for any other unit."""
    require(unit in STRESS_UNITS, parameter, f"{unit!r} is no stress unit", ", ".join(STRESS_UNITS))
    return STRESS_UNITS[unit]


def _finite_positive(value, parameter: str, allowed: str) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ParameterError(parameter, f"{value!r} is not a number", allowed) from None
    require(math.isfinite(value) and value > 0.0, parameter, f"{value!r}", allowed)
    return value


@dataclass(frozen=True)
class SNCurve:
    """An S-N curve N(S) = a S^-m with an optional second slope below its knee and an optional cut-off.

    m, log10_a    the first slope and log10 of its intercept (S in ``unit``)
    m2, log10_a2  the second slope and its intercept, used for S below the knee range where the two lines meet
                  (both or neither)
    cutoff        the range below which a cycle does no damage (the fatigue or endurance limit), or None
    fatigue_limit the range the source tables give at 1e7 cycles (reported; a cut-off only when set as ``cutoff``)
    name, source  what the curve is and where its numbers come from
    """

    m: float
    log10_a: float
    m2: float | None = None
    log10_a2: float | None = None
    cutoff: float | None = None
    unit: str = "MPa"
    name: str = "custom"
    source: str = ""
    fatigue_limit: float | None = None

    def __post_init__(self):
        _finite_positive(self.m, "sn.m", "a finite slope m > 0")
        require(math.isfinite(float(self.log10_a)), "sn.log10_a", f"{self.log10_a!r}", "a finite log10 a")
        require((self.m2 is None) == (self.log10_a2 is None), "sn.m2",
                "a second slope needs both m2 and log10_a2", "both or neither")
        if self.m2 is not None:
            _finite_positive(self.m2, "sn.m2", "a finite second slope m2 > 0")
            require(math.isfinite(float(self.log10_a2)), "sn.log10_a2", f"{self.log10_a2!r}", "a finite log10 a2")
            require(self.m2 != self.m, "sn.m2", f"{self.m2!r} equals m", "a slope other than m (one line otherwise)")
        if self.cutoff is not None:
            _finite_positive(self.cutoff, "sn.cutoff", "a finite cut-off range > 0, or none")
        unit_scale(self.unit, "sn.unit")

    # ------------------------------------------------------------------ the curve
    @property
    def knee_range(self) -> float | None:
        """The range where the two slopes meet (None for one slope): log10 a - m log S = log10 a2 - m2 log S."""
        if self.m2 is None:
            return None
        return 10.0 ** ((self.log10_a - self.log10_a2) / (self.m - self.m2))

    @property
    def knee_cycles(self) -> float | None:
        """N at the knee (1e7 for DNV-RP-C203's curves in air), None for one slope."""
        knee = self.knee_range
        return None if knee is None else 10.0 ** (self.log10_a - self.m * math.log10(knee))

    def cycles_to_failure(self, ranges) -> np.ndarray:
        """N(S) for each range S (in ``unit``): inf at S = 0 and below the cut-off."""
        s = np.asarray(ranges, float)
        require(bool(np.all(np.isfinite(s))) and bool(np.all(s >= 0.0)), "ranges", "a range is negative or not finite",
                "finite ranges >= 0")
        out = np.full(s.shape, np.inf)
        positive = s > 0.0
        if self.cutoff is not None:
            positive &= s >= self.cutoff
        log_s = np.log10(s, where=positive, out=np.zeros_like(s))
        log_n = self.log10_a - self.m * log_s
        knee = self.knee_range
        if knee is not None:
            below = s < knee
            log_n = np.where(below, self.log10_a2 - self.m2 * log_s, log_n)
        out[positive] = 10.0 ** log_n[positive]
        return out

    def range_at(self, cycles: float) -> float:
        """The range S whose N(S) is ``cycles`` on the sloped lines (the inverse of the curve; a cut-off is not
        applied: below it this is the range the line would give)."""
        n = _finite_positive(cycles, "cycles", "a finite number of cycles > 0")
        knee_n = self.knee_cycles
        if knee_n is not None and n > knee_n:
            return 10.0 ** ((self.log10_a2 - math.log10(n)) / self.m2)
        return 10.0 ** ((self.log10_a - math.log10(n)) / self.m)

    # ------------------------------------------------------------------ variants and text
    def with_cutoff(self, cutoff: float | None) -> "SNCurve":
        """The same curve with cut-off ``cutoff`` (None: none)."""
        return replace(self, cutoff=cutoff)

    def describe(self) -> str:
        """One line: name, slopes, intercepts, knee, cut-off, unit."""
        text = f"{self.name}: m {self.m:g}, log10 a {self.log10_a:.3f}"
        if self.m2 is not None:
            text += (f"; m2 {self.m2:g}, log10 a2 {self.log10_a2:.3f} below the knee at {self.knee_range:.4g} "
                     f"{self.unit} ({self.knee_cycles:.3g} cycles)")
        if self.cutoff is not None:
            text += f"; no damage below {self.cutoff:.4g} {self.unit}"
        return text + f" (S in {self.unit})"


def curve_from_text(text: str, unit: str = "MPa", parameter: str = "sn") -> SNCurve:
    """An SNCurve from ``"m,log10a"`` or ``"m,log10a,cutoff"`` (S in ``unit``), e.g. "3,12.164,52.63" (DNV-RP-C203's
    D curve's first slope and its fatigue limit used as a cut-off); a ParameterError naming ``parameter`` otherwise."""
    allowed = "m,log10a or m,log10a,cutoff: numbers, m > 0, cutoff > 0 (e.g. 3,12.164 or 3,12.164,52.63)"
    parts = [p.strip() for p in str(text).split(",")]
    require(len(parts) in (2, 3) and all(parts), parameter, f"{text!r} is not two or three numbers", allowed)
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ParameterError(parameter, f"{text!r} is not two or three numbers", allowed) from None
    require(all(math.isfinite(v) for v in values), parameter, f"{text!r} holds a value that is not finite", allowed)
    require(values[0] > 0.0, parameter, f"m = {values[0]:g}", allowed)
    cutoff = values[2] if len(values) == 3 else None
    require(cutoff is None or cutoff > 0.0, parameter, f"cutoff = {cutoff}", allowed)
    return SNCurve(m=values[0], log10_a=values[1], cutoff=cutoff, unit=unit,
                   name=f"m {values[0]:g}, log10 a {values[1]:g}", source="given (--sn)")
