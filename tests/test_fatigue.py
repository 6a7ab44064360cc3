"""flexfmu.fatigue and `flexfmu fatigue`: rainflow counting against ASTM E1049-85's worked example, Miner damage and
equivalent ranges against their closed forms, the named curves against the standards' tables, the damage rate over
weighted bins, the command end to end and its refusals.

References: ASTM E1049-85 (reapproved 2017), "Standard Practices for Cycle Counting in Fatigue Analysis", 5.4.4 and
its Fig. 6 (rainflow counting of the history -2, 1, -3, 5, -1, 3, -4, 4, -2 and the table of counts beside it);
DNV-RP-C203 (April 2016) Tables 2-1 and 2-2; BS 7608:1993 Table 10.
"""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

pytest.importorskip("rainflow")

from flexfmu.cli import main  # noqa: E402
from flexfmu.errors import ParameterError  # noqa: E402
from flexfmu.fatigue import (DamageBin, SNCurve, StressHistory, assess_history, curve_from_text,  # noqa: E402
                             damage_equivalent_range, equivalent_range, miner_damage, named_curve, rainflow_cycles,
                             sea_state_damage)
from flexfmu.fatigue.standard_curves import BS7608, CURVES, DNV_AIR  # noqa: E402

pytestmark = pytest.mark.unit

#: ASTM E1049-85, Fig. 6: the example history and the table of its rainflow counts (range: cycles), ranges 1 .. 10
ASTM_HISTORY = [-2, 1, -3, 5, -1, 3, -4, 4, -2]
ASTM_COUNTS = {10: 0.0, 9: 0.5, 8: 1.0, 7: 0.0, 6: 0.5, 5: 0.0, 4: 1.5, 3: 0.5, 2: 0.0, 1: 0.0}


def _by_range(cycles) -> dict:
    out = {}
    for r, n in zip(cycles.ranges, cycles.counts):
        out[float(r)] = out.get(float(r), 0.0) + float(n)
    return out


def cosine_cycles(range_pa: float, n_cycles: int, per_cycle: int = 40, period: float = 1.0):
    """A history of n_cycles whole cycles of range ``range_pa`` starting and ending at a trough (-range/2 cos),
    sampled so that every peak and trough is a sample: rainflow counts exactly n_cycles cycles of that range."""
    k = np.arange(n_cycles * per_cycle + 1)
    t = k * (period / per_cycle)
    return t, -0.5 * range_pa * np.cos(2.0 * np.pi * k / per_cycle)


# ---------------------------------------------------------------------------------------------- counting
def test_rainflow_counts_the_astm_e1049_example_as_the_standard_tables_it():
    counted = _by_range(rainflow_cycles(ASTM_HISTORY))
    assert set(counted) <= set(ASTM_COUNTS)
    for rng, cycles in ASTM_COUNTS.items():
        assert counted.get(float(rng), 0.0) == cycles, rng


def test_the_numpy_reversals_keep_the_rainflow_packages_cycles(rng):
    """The turning points found with numpy before the package's loop change no cycle: plateaus, repeated values and
    monotone runs included (a history quantised to a few levels has many of each)."""
    import rainflow

    for n in (2, 3, 5, 50, 2000):
        x = np.round(rng.normal(size=n) * 3.0)           # few levels: plateaus and repeated turning values
        ours = rainflow_cycles(x)
        theirs = sorted((r, m, c) for r, m, c, _, _ in rainflow.extract_cycles(x.tolist()))
        assert sorted(zip(ours.ranges, ours.means, ours.counts)) == theirs
        # the indices point at samples with the cycle's end values
        assert np.allclose(np.abs(x[ours.start] - x[ours.end]), ours.ranges, rtol=0, atol=0)


def test_a_history_with_a_nan_is_refused_naming_the_sample():
    with pytest.raises(ParameterError, match=r"^history: sample 2 is nan"):
        rainflow_cycles([0.0, 1.0, math.nan, 1.0])
    with pytest.raises(ParameterError, match=r"stress: sample 1 \(t = 1.0 s\) is inf"):
        StressHistory([0.0, 1.0, 2.0], [0.0, math.inf, 1.0])
    with pytest.raises(ParameterError, match="too short"):
        StressHistory([0.0], [1.0])


def test_a_constant_history_has_no_damage():
    t = np.linspace(0.0, 10.0, 11)
    a = assess_history(StressHistory(t, np.full(11, 5e7)), named_curve("DNV-D"))
    assert a.damage == 0.0 and math.isinf(a.life_seconds)


# ---------------------------------------------------------------------------------------------- damage
def test_miner_damage_of_a_constant_amplitude_cosine_is_n_s_m_over_a():
    S, n = 80.0, 250                                     # MPa: above DNV-D's knee, on its first slope
    t, stress = cosine_cycles(S * 1e6, n)               # Pa, as flexfmu's outputs
    one_slope = SNCurve(m=3.0, log10_a=12.164)
    a = assess_history(StressHistory(t, stress), one_slope)
    expected = n * S ** 3 / 10 ** 12.164
    # every range within a few ulps of S (cos of a sample at k pi), so the damage within 1e-12 relative
    assert a.cycles.total == n
    assert a.damage == pytest.approx(expected, rel=1e-12)
    assert a.damage_rate == pytest.approx(expected / (t[-1] - t[0]), rel=1e-12)
    # below DNV-D's knee the second slope: n S^5 / a2
    low = 40.0
    t, stress = cosine_cycles(low * 1e6, n)
    a = assess_history(StressHistory(t, stress), named_curve("DNV-D"))
    assert a.damage == pytest.approx(n * low ** 5 / 10 ** 15.606, rel=1e-12)


def test_a_cut_off_removes_the_cycles_below_it():
    curve = SNCurve(m=3.0, log10_a=12.0, cutoff=50.0)
    ranges, counts = np.array([40.0, 49.999, 50.0, 60.0]), np.array([1e6, 1e6, 10.0, 100.0])
    assert miner_damage(ranges, counts, curve) == pytest.approx((10.0 * 50.0 ** 3 + 100.0 * 60.0 ** 3) / 1e12,
                                                                rel=1e-14)
    # the named curve with its fatigue limit as cut-off: 40 MPa cycles no longer count; without, they do (m2 = 5)
    dnv = named_curve("DNV-D")
    assert miner_damage([40.0], [1e6], dnv.with_cutoff(dnv.fatigue_limit)) == 0.0
    assert miner_damage([40.0], [1e6], dnv) == pytest.approx(1e6 * 40.0 ** 5 / 10 ** 15.606, rel=1e-14)


def test_equivalent_range_of_a_two_level_block_in_closed_form():
    n1, s1, n2, s2, m, n_ref = 1000.0, 100.0, 1e6, 20.0, 3.0, 1e7
    expected = ((n1 * s1 ** 3 + n2 * s2 ** 3) / n_ref) ** (1.0 / 3.0)      # (9e9 / 1e7)^(1/3) = 9.6549 MPa
    assert expected == pytest.approx(900.0 ** (1.0 / 3.0), rel=1e-15)
    assert equivalent_range([s1, s2], [n1, n2], m, n_ref) == pytest.approx(expected, rel=1e-14)
    # on a one-slope curve the damage-equivalent range is the same number
    curve = SNCurve(m=m, log10_a=12.0)
    d = miner_damage([s1, s2], [n1, n2], curve)
    assert damage_equivalent_range(d, curve, n_ref) == pytest.approx(expected, rel=1e-13)
    # and on a two-slope curve it is the range whose N_ref cycles do the same damage on the curve
    dnv = named_curve("DNV-D")
    d = miner_damage([s1, s2], [n1, n2], dnv)
    s_eq = damage_equivalent_range(d, dnv, n_ref)
    assert miner_damage([s_eq], [n_ref], dnv) == pytest.approx(d, rel=1e-12)


# ---------------------------------------------------------------------------------------------- named curves
def test_dnv_d_curve_as_the_standard_tables_it():
    d = named_curve("DNV-D")
    # Table 2-1: N <= 1e7: log a1 = 12.164, m1 = 3; N > 1e7: log a2 = 15.606, m2 = 5; fatigue limit 52.63 MPa
    assert d.cycles_to_failure([100.0])[0] == pytest.approx(10 ** 12.164 * 100.0 ** -3, rel=1e-14)   # 1.459e6
    assert d.cycles_to_failure([30.0])[0] == pytest.approx(10 ** 15.606 * 30.0 ** -5, rel=1e-14)
    # log a to three decimals: the knee within 10^(0.001 / 2) - 1 = 0.12 % of the tabled 52.63 MPa
    assert d.range_at(1e7) == pytest.approx(52.63, rel=10 ** 0.0005 - 1 + 0.005 / 52.63)
    # Table 2-2 (seawater, cathodic protection): log a1 = 11.764 up to 1e6 cycles
    assert named_curve("dnv-d-cp").cycles_to_failure([100.0])[0] == pytest.approx(10 ** 11.764 * 1e-6, rel=1e-14)


@pytest.mark.parametrize("name", [n for n in CURVES if CURVES[n].m2 is not None and n.startswith("DNV")])
def test_each_dnv_curves_lines_meet_at_its_tabled_fatigue_limit(name):
    """Each two-slope DNV curve's range at 1e7 cycles, from its log a (three decimals), is the table's fatigue limit
    (two decimals) within their rounding: log10 S off by at most 0.001 / (m2 - m1) on the second line."""
    c = CURVES[name]
    bound = 10 ** (0.001 / abs(c.m2 - c.m)) - 1.0 + 0.005 / c.fatigue_limit
    assert c.range_at(1e7) == pytest.approx(c.fatigue_limit, rel=bound)


def test_bs7608_design_curves_are_the_mean_minus_two_standard_deviations():
    # Table 10's design constants C2 as it writes them, mantissa to two decimals x 10^exponent, and S0 at 1e7
    # cycles (whole MPa): each within half a unit of its last digit
    c2_table = {"B": (1.01, 15), "C": (4.23, 13), "D": (1.52, 12), "E": (1.04, 12), "F": (0.63, 12),
                "F2": (0.43, 12), "G": (0.25, 12), "W": (0.16, 12)}
    assert set(c2_table) == set(BS7608)
    for cls, (mantissa, exponent) in c2_table.items():
        curve = named_curve(f"BS-{cls}")
        assert 10 ** (curve.log10_a - exponent) == pytest.approx(mantissa, abs=0.005)
        assert curve.range_at(1e7) == pytest.approx(BS7608[cls][3], abs=0.5)
        assert curve.m2 == curve.m + 2.0 and curve.knee_cycles == pytest.approx(1e7, rel=1e-12)


def test_unknown_curve_names_the_choices():
    with pytest.raises(ParameterError, match="curve.*DNV-<class>.*" + ", ".join(DNV_AIR)):
        named_curve("DNV-Q")


@pytest.mark.parametrize("text", ["3", "3;12", "a,b", "3,12,x", "-3,12", "3,12,0", "3,nan", "3,12,4,5", ""])
def test_bad_sn_text_is_refused_naming_the_option(text):
    with pytest.raises(ParameterError, match=r"^sn: .*allowed: m,log10a"):
        curve_from_text(text)


# ---------------------------------------------------------------------------------------------- sea states
def test_damage_rate_over_weighted_bins():
    curve = SNCurve(m=3.0, log10_a=12.0)
    t1, s1 = cosine_cycles(60e6, 100, period=2.0)        # rate 100 * 60^3 / 1e12 / 200 s
    t2, s2 = cosine_cycles(30e6, 300, period=1.0)        # rate 300 * 30^3 / 1e12 / 300 s
    r1 = 100 * 60.0 ** 3 / 1e12 / 200.0
    r2 = 300 * 30.0 ** 3 / 1e12 / 300.0
    bins = [DamageBin("Hs 2 Tp 8", StressHistory(t1, s1), probability=0.3),
            DamageBin("Hs 1 Tp 6", StressHistory(t2, s2), probability=0.2)]
    result = sea_state_damage(bins, curve, design_life_years=20.0)
    year = 365.25 * 86400.0
    assert result.damage_rate == pytest.approx(0.3 * r1 + 0.2 * r2, rel=1e-12)
    assert result.annual_damage == pytest.approx((0.3 * r1 + 0.2 * r2) * year, rel=1e-12)
    assert result.life_years == pytest.approx(1.0 / result.annual_damage, rel=1e-14)
    assert result.lifetime_damage == pytest.approx(20.0 * result.annual_damage, rel=1e-14)
    assert "the rest does no damage" in result.table()
    # the same shares as hours per year give the same rate
    hours = [DamageBin(b.label, b.history, hours_per_year=b.probability * year / 3600.0) for b in bins]
    assert sea_state_damage(hours, curve).damage_rate == pytest.approx(result.damage_rate, rel=1e-12)
    with pytest.raises(ParameterError, match="sum to 1.1"):
        sea_state_damage([DamageBin("a", StressHistory(t1, s1), probability=0.6),
                          DamageBin("b", StressHistory(t2, s2), probability=0.5)], curve)


def test_bins_from_result_csvs(tmp_path):
    curve = named_curve("DNV-F")
    paths = []
    for k, S in enumerate((50e6, 90e6)):
        t, s = cosine_cycles(S, 60)
        paths.append(_write_csv(tmp_path / f"bin{k}.csv", t, {"beam.gauge_root_sigma_max": s}))
    bins = [DamageBin.from_csv(f"bin {k}", p, "beam.gauge_root_sigma_max", probability=0.5)
            for k, p in enumerate(paths)]
    result = sea_state_damage(bins, curve)
    expected = 0.5 * sum(60 * float(curve.cycles_to_failure([S])[0]) ** -1 / 60.0 for S in (50.0, 90.0))
    assert result.damage_rate == pytest.approx(expected, rel=1e-12)
    out = result.write_csv(tmp_path / "bins.csv")
    rows = list(csv.reader(out.open()))
    assert rows[0][7] == "weighted_rate"
    assert rows[-1][0] == "total" and float(rows[-1][7]) == pytest.approx(result.damage_rate, rel=1e-15)
    # both records as the seeds of one bin: their damage over their spans, 60 s each
    seeds = sea_state_damage([DamageBin.from_csv("two seeds", paths, "beam.gauge_root_sigma_max", probability=1.0)],
                             curve)
    assert seeds.damage_rate == pytest.approx(expected, rel=1e-12)
    assert seeds.rows()[0]["records"] == 2 and seeds.rows()[0]["record_s"] == pytest.approx(120.0, rel=1e-15)


# ---------------------------------------------------------------------------------------------- the command
def _write_csv(path, t, columns: dict):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", *columns])
        for k in range(len(t)):
            w.writerow([repr(float(t[k]))] + [repr(float(v[k])) for v in columns.values()])
    return path


def test_cli_end_to_end(tmp_path, capsys):
    S, n = 80.0, 200
    t, stress = cosine_cycles(S * 1e6, n, per_cycle=20, period=0.5)
    result = _write_csv(tmp_path / "result.csv", t, {"harvester.gauge_root_sigma_max": stress,
                                                      "harvester.gauge_root_von_mises": np.abs(stress)})
    table, chart = tmp_path / "out" / "table.csv", tmp_path / "hist.png"
    status = main(["fatigue", str(result), "--gauge", "harvester.gauge_root_sigma_max", "--curve", "DNV-D",
                   "--out", str(table), "--plot", str(chart)])
    out = capsys.readouterr().out
    assert status == 0
    damage = n * S ** 3 / 10 ** 12.164
    duration = t[-1] - t[0]
    for text in ("range from", "Miner damage", "equivalent range", "damage rate", "life at this rate",
                 "DNV-RP-C203", f"{damage:.6e}", f"{damage / duration:.6e}",
                 f"{duration / damage / 3600.0:.6g} h"):
        assert text in out, text
    assert chart.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and chart.stat().st_size > 10_000
    rows = list(csv.reader(table.open()))
    assert rows[0][:3] == ["range_from_MPa", "range_to_MPa", "cycles"]
    assert float(rows[-1][2]) == n and float(rows[-1][3]) == pytest.approx(damage, rel=1e-12)
    # --t-start leaves out the first half: half the cycles, the same rate
    status = main(["fatigue", str(result), "--gauge", "harvester.gauge_root_sigma_max", "--sn", "3,12.164",
                   "--t-start", str(t[len(t) // 2])])
    out = capsys.readouterr().out
    assert status == 0 and f"{damage / 2:.6e}" in out and f"{damage / duration:.6e}" in out


def _error(capsys, argv) -> str:
    assert main(["fatigue", *argv]) == 2
    return capsys.readouterr().err


def test_cli_refuses_bad_input_naming_the_option(tmp_path, capsys):
    t, stress = cosine_cycles(80e6, 10)
    good = _write_csv(tmp_path / "r.csv", t, {"a.gauge_x": stress, "a.other": stress})
    err = _error(capsys, [str(good), "--gauge", "a.nope", "--curve", "DNV-D"])
    assert "gauge: 'a.nope' is not a column" in err and "a.gauge_x, a.other" in err
    err = _error(capsys, [str(good), "--gauge", "a.gauge_x", "--sn", "3;12"])
    assert "sn: '3;12' is not two or three numbers" in err
    err = _error(capsys, [str(good), "--gauge", "a.gauge_x", "--curve", "DNV-Z"])
    assert "curve: no S-N curve named 'DNV-Z'" in err and "BS-<class>" in err
    err = _error(capsys, [str(good), "--gauge", "a.gauge_x", "--curve", "DNV-D-FC", "--cut-off", "limit"])
    assert "cut-off" in err and "no fatigue limit" in err
    err = _error(capsys, [str(good), "--gauge", "a.gauge_x", "--curve", "DNV-D", "--t-start", "1e9"])
    assert "t-start" in err and "too short" in err
    short = _write_csv(tmp_path / "short.csv", t[:1], {"a.gauge_x": stress[:1]})
    assert "too short" in _error(capsys, [str(short), "--gauge", "a.gauge_x", "--curve", "DNV-D"])
    bad = stress.copy()
    bad[7] = np.nan
    nan = _write_csv(tmp_path / "nan.csv", t, {"a.gauge_x": bad})
    err = _error(capsys, [str(nan), "--gauge", "a.gauge_x", "--curve", "DNV-D"])
    assert "gauge a.gauge_x" in err and "nan" in err and "finite" in err
    assert "no such file" in _error(capsys, [str(tmp_path / "none.csv"), "--gauge", "x", "--curve", "DNV-D"])
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("time,a.gauge_x,a.other\n0,1,2\n1,2\n")
    err = _error(capsys, [str(ragged), "--gauge", "a.other", "--curve", "DNV-D"])
    assert str(ragged) in err and "one number per column" in err
    text = tmp_path / "text.csv"
    text.write_text("time,a.gauge_x\n0,1\n1,oops\n")
    err = _error(capsys, [str(text), "--gauge", "a.gauge_x", "--curve", "DNV-D"])
    assert str(text) in err and "oops" in err
    err = _error(capsys, [str(good), "--gauge", "a.gauge_x", "--curve", "DNV-D", "--plot", str(tmp_path)])
    assert "plot" in err and "is a folder" in err
