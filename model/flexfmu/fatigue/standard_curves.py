"""Named S-N curves of welded steel details from DNV-RP-C203 and BS 7608 (stress ranges in MPa).

DNV-RP-C203, "Fatigue design of offshore steel structures", DNV GL, edition April 2016:

- Table 2-1, S-N curves in air ("DNV-<class>"): m1 and log10 a1 for N <= 1e7 cycles, m2 = 5 and log10 a2 beyond,
  and the fatigue limit at 1e7 cycles;
- Table 2-2, in seawater with cathodic protection ("DNV-<class>-CP"): the knee at 1e6 cycles, the same second
  line as in air;
- Table 2-4, in seawater for free corrosion ("DNV-<class>-FC"): one slope, no fatigue limit.

The numbers are the tables' (log10 a to three decimals, the fatigue limit in MPa to two); the knee each pair of
lines implies, 10^((log10 a1 - log10 a2) / (m1 - m2)), is within 0.04 % of the table's fatigue limit (checked in
tests/test_fatigue.py).  The RP's later editions revise some of the upper curves (B1 to C2); these are the 2016
values, which the D to W3 curves keep.  The thickness exponent k of the tables is not applied: scale the stress
by (t / t_ref)^k before the assessment where the detail needs it.

BS 7608:1993, "Code of practice for fatigue design and assessment of steel structures", Table 10 (details of
the basic S-N curves): per class the slope m, log10 of the mean curve's constant C0 and the standard deviation of
log10 N; the design curve ("BS-<class>") is the mean minus two standard deviations, log10 C2 = log10 C0 - 2 SD,
N = C2 S^-m.  Constant-amplitude stress ranges below the curve's value at 1e7 cycles (S0 in the table) do no
damage; under variable amplitude the standard extends the curve beyond 1e7 cycles with slope m + 2, which is the
curve given here (its ``fatigue_limit`` is S0 at 1e7 cycles).
"""
from __future__ import annotations

from flexfmu.errors import ParameterError

from .sn_curve import SNCurve

DNV_EDITION = "DNV-RP-C203 (DNV GL, edition April 2016)"
BS_EDITION = "BS 7608:1993"

#: DNV-RP-C203 (2016) Table 2-1, in air: class -> (m1, log10 a1 for N <= 1e7, m2, log10 a2 for N > 1e7,
#: fatigue limit at 1e7 cycles in MPa)
DNV_AIR = {
    "B1": (4.0, 15.117, 5.0, 17.146, 106.97),
    "B2": (4.0, 14.885, 5.0, 16.856, 93.59),
    "C": (3.0, 12.592, 5.0, 16.320, 73.10),
    "C1": (3.0, 12.449, 5.0, 16.081, 65.50),
    "C2": (3.0, 12.301, 5.0, 15.835, 58.48),
    "D": (3.0, 12.164, 5.0, 15.606, 52.63),
    "E": (3.0, 12.010, 5.0, 15.350, 46.78),
    "F": (3.0, 11.855, 5.0, 15.091, 41.52),
    "F1": (3.0, 11.699, 5.0, 14.832, 36.84),
    "F3": (3.0, 11.546, 5.0, 14.576, 32.75),
    "G": (3.0, 11.398, 5.0, 14.330, 29.24),
    "W1": (3.0, 11.261, 5.0, 14.101, 26.32),
    "W2": (3.0, 11.107, 5.0, 13.845, 23.39),
    "W3": (3.0, 10.970, 5.0, 13.617, 21.05),
}

#: DNV-RP-C203 (2016) Table 2-2, seawater with cathodic protection: class -> (m1, log10 a1 for N <= 1e6, m2,
#: log10 a2 for N > 1e6, the range at 1e7 cycles in MPa)
DNV_CATHODIC = {
    "B1": (4.0, 14.917, 5.0, 17.146, 106.97),
    "B2": (4.0, 14.685, 5.0, 16.856, 93.59),
    "C": (3.0, 12.192, 5.0, 16.320, 73.10),
    "C1": (3.0, 12.049, 5.0, 16.081, 65.50),
    "C2": (3.0, 11.901, 5.0, 15.835, 58.48),
    "D": (3.0, 11.764, 5.0, 15.606, 52.63),
    "E": (3.0, 11.610, 5.0, 15.350, 46.78),
    "F": (3.0, 11.455, 5.0, 15.091, 41.52),
    "F1": (3.0, 11.299, 5.0, 14.832, 36.84),
    "F3": (3.0, 11.146, 5.0, 14.576, 32.75),
    "G": (3.0, 10.998, 5.0, 14.330, 29.24),
    "W1": (3.0, 10.861, 5.0, 14.101, 26.32),
    "W2": (3.0, 10.707, 5.0, 13.845, 23.39),
    "W3": (3.0, 10.570, 5.0, 13.617, 21.05),
}

#: DNV-RP-C203 (2016) Table 2-4, seawater for free corrosion: class -> (m, log10 a), one slope for all N
DNV_FREE_CORROSION = {
    "B1": (3.0, 12.436), "B2": (3.0, 12.262), "C": (3.0, 12.115), "C1": (3.0, 11.972), "C2": (3.0, 11.824),
    "D": (3.0, 11.687), "E": (3.0, 11.533), "F": (3.0, 11.378), "F1": (3.0, 11.222), "F3": (3.0, 11.068),
    "G": (3.0, 10.921), "W1": (3.0, 10.784), "W2": (3.0, 10.630), "W3": (3.0, 10.493),
}

#: BS 7608:1993 Table 10: class -> (m, log10 C0 of the mean curve, standard deviation of log10 N, S0 = the design
#: curve's range at 1e7 cycles in MPa)
BS7608 = {
    "B": (4.0, 15.3697, 0.1821, 100.0),
    "C": (3.5, 14.0342, 0.2041, 78.0),
    "D": (3.0, 12.6007, 0.2095, 53.0),
    "E": (3.0, 12.5169, 0.2509, 47.0),
    "F": (3.0, 12.2370, 0.2183, 40.0),
    "F2": (3.0, 12.0900, 0.2279, 35.0),
    "G": (3.0, 11.7525, 0.1793, 29.0),
    "W": (3.0, 11.5662, 0.1846, 25.0),
}

#: how many standard deviations below the mean BS 7608's design curves lie
BS_DESIGN_SD = 2.0


def _dnv_two_slope(cls: str, row, environment: str, table: str) -> SNCurve:
    m1, log_a1, m2, log_a2, limit = row
    return SNCurve(m=m1, log10_a=log_a1, m2=m2, log10_a2=log_a2, unit="MPa", fatigue_limit=limit,
                   name=f"DNV-{cls}{environment}", source=f"{DNV_EDITION}, {table}")


def _bs_design(cls: str, row) -> SNCurve:
    m, log_c0, sd, s0 = row
    log_c2 = log_c0 - BS_DESIGN_SD * sd
    # the variable-amplitude extension: slope m + 2 through the design curve's point at 1e7 cycles
    log_s_knee = (log_c2 - 7.0) / m
    return SNCurve(m=m, log10_a=log_c2, m2=m + 2.0, log10_a2=7.0 + (m + 2.0) * log_s_knee, unit="MPa",
                   fatigue_limit=s0, name=f"BS-{cls}",
                   source=f"{BS_EDITION}, Table 10 (mean - 2 SD; slope m + 2 beyond 1e7 cycles)")


def _catalogue() -> dict[str, SNCurve]:
    out = {}
    for cls, row in DNV_AIR.items():
        out[f"DNV-{cls}"] = _dnv_two_slope(cls, row, "", "Table 2-1 (in air)")
    for cls, row in DNV_CATHODIC.items():
        out[f"DNV-{cls}-CP"] = _dnv_two_slope(cls, row, "-CP", "Table 2-2 (seawater, cathodic protection)")
    for cls, (m, log_a) in DNV_FREE_CORROSION.items():
        out[f"DNV-{cls}-FC"] = SNCurve(m=m, log10_a=log_a, unit="MPa", name=f"DNV-{cls}-FC",
                                       source=f"{DNV_EDITION}, Table 2-4 (seawater, free corrosion)")
    for cls, row in BS7608.items():
        out[f"BS-{cls}"] = _bs_design(cls, row)
    return out


CURVES = _catalogue()


def curve_names() -> list[str]:
    """The names ``named_curve`` knows: DNV-<class>, DNV-<class>-CP, DNV-<class>-FC, BS-<class>."""
    return list(CURVES)


def named_curve(name: str, parameter: str = "curve") -> SNCurve:
    """The named curve (case-insensitive: "DNV-D", "dnv-f3-cp", "BS-F2"); a ParameterError naming ``parameter``
    and listing the names otherwise."""
    by_key = {key.upper(): curve for key, curve in CURVES.items()}
    curve = by_key.get(str(name).strip().upper())
    if curve is None:
        dnv = ", ".join(DNV_AIR)
        bs = ", ".join(BS7608)
        raise ParameterError(parameter, f"no S-N curve named {name!r}",
                             f"DNV-<class> (in air), DNV-<class>-CP (seawater, cathodic protection), DNV-<class>-FC "
                             f"(free corrosion) with class {dnv}; BS-<class> with class {bs}")
    return curve
