"""The power matrix in the manner of IEC TS 62600-100 (flexfmu.wec.iec, flexfmu.wec.power_study,
flexfmu.wec.system.power_matrix, `flexfmu wec power-matrix`): the bins' statistics on synthetic runs against hand
computations, the confidence interval against scipy.stats.t, the energy flux and capture width against a hand sum
over a known spectrum, the bin checks refusing a grid before any run, the point absorber's sea state against the
lead's specification, and the command on the point absorber (both CSVs and the chart) and on the harvester's system.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats
from fmu_helpers import ROOT

from flexfmu.errors import ParameterError
from flexfmu.wec.iec import (IEC_HS_BIN_WIDTH, IEC_TE_BIN_WIDTH, SeaSpectrum, bin_statistics, check_bins,
                             confidence_interval, spectral_measures)
from flexfmu.wec.power_study import absorber_jonswap

pytest.importorskip("mhkit", reason="MHKiT missing: install the project with its dev (or iec) extra")

RHO, G = 1025.0, 9.81
HARVESTER_SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
ABSORBER_SYSTEM = ROOT / "examples" / "point_absorber" / "OspSystemStructure.xml"


# ---------------------------------------------------------------- statistics of a bin (synthetic runs)
def test_bin_statistics_of_synthetic_runs_equal_the_hand_computation():
    """Three runs and a failed one (NaN, left out): count 3, mean, std with N degrees of freedom (IEC formula D.5),
    min, max, capture width P / J and its ratio, each computed by hand."""
    powers = [90e3, 120e3, float("nan"), 105e3]
    flux, width = 15e3, 10.0
    got = bin_statistics(powers, flux, width)
    assert got["count"] == 3
    assert got["mean_power_W"] == pytest.approx(105e3, rel=1e-15)
    # deviations -15, 15, 0 kW: sum of squares 450e6, over N = 3
    assert got["std_power_W"] == pytest.approx(math.sqrt(450e6 / 3), rel=1e-14)
    assert got["min_power_W"] == 90e3 and got["max_power_W"] == 120e3
    assert got["mean_capture_width_m"] == pytest.approx(105e3 / 15e3, rel=1e-14)
    assert got["min_capture_width_m"] == pytest.approx(6.0, rel=1e-15)
    assert got["max_capture_width_m"] == pytest.approx(8.0, rel=1e-15)
    assert got["std_capture_width_m"] == pytest.approx(math.sqrt(450e6 / 3) / 15e3, rel=1e-14)
    assert got["capture_width_ratio"] == pytest.approx(0.7, rel=1e-14)
    # the interval: sample std (n - 1) = sqrt(450e6 / 2) = 15 kW; Student's t with 2 degrees of freedom has the
    # closed-form quantile t_p = (2p - 1) / sqrt(2 p (1 - p)): t_0.975 = 4.3027 (as the tables say)
    t = 0.95 / math.sqrt(2 * 0.975 * 0.025)
    assert t == pytest.approx(4.3027, abs=5e-5)
    half = t * 15e3 / math.sqrt(3)
    assert got["ci_half_width_W"] == pytest.approx(half, rel=1e-12)
    assert (got["ci_low_W"], got["ci_high_W"]) == pytest.approx((105e3 - half, 105e3 + half), rel=1e-12)


def test_a_bin_without_runs_is_empty_and_a_single_run_has_no_interval():
    empty = bin_statistics([float("nan")] * 3, 1e4, 10.0)
    assert empty["count"] == 0 and math.isnan(empty["mean_power_W"]) and math.isnan(empty["ci_low_W"])
    one = bin_statistics([5e4], 1e4, 10.0)
    assert one["count"] == 1 and one["mean_power_W"] == 5e4 and one["std_power_W"] == 0
    assert math.isnan(one["ci_half_width_W"])


@pytest.mark.parametrize("n, confidence", [(2, 0.95), (3, 0.95), (5, 0.9), (12, 0.99)])
def test_confidence_interval_equals_scipy_student_t(n, confidence):
    x = np.random.default_rng(n).normal(1e5, 2e4, n)
    low, high = confidence_interval(x, confidence)
    ref = scipy.stats.t.interval(confidence, n - 1, loc=x.mean(), scale=scipy.stats.sem(x))
    assert (low, high) == pytest.approx(ref, rel=1e-13)


def test_confidence_interval_refuses_a_level_outside_0_1():
    with pytest.raises(ParameterError, match="confidence"):
        confidence_interval([1.0, 2.0], 1.0)


# ---------------------------------------------------------------- the sea state: J, Te, Hm0
def test_energy_flux_and_capture_width_of_a_known_spectrum_equal_a_hand_sum():
    """Four components 0.1 rad/s apart: J = rho g sum S(w) c_g(w) dw with the deep-water group velocity g / (2 w),
    Hm0 = 4 sqrt(sum S dw), Te = 2 pi sum (S / w) dw / sum S dw, summed here term by term."""
    w = np.array([0.6, 0.7, 0.8, 0.9])
    s = np.array([0.5, 2.0, 1.5, 0.25])             # m^2 s / rad
    dw = 0.1
    got = spectral_measures(SeaSpectrum(w, s, dw, RHO, G))
    flux = RHO * G * dw * (0.5 * G / 1.2 + 2.0 * G / 1.4 + 1.5 * G / 1.6 + 0.25 * G / 1.8)
    m0 = dw * (0.5 + 2.0 + 1.5 + 0.25)
    m_1 = dw * (0.5 / 0.6 + 2.0 / 0.7 + 1.5 / 0.8 + 0.25 / 0.9)
    assert got.energy_flux == pytest.approx(flux, rel=1e-12)
    assert got.hm0 == pytest.approx(4 * math.sqrt(m0), rel=1e-13)
    assert got.te == pytest.approx(2 * math.pi * m_1 / m0, rel=1e-13)
    # the published deep-water form of the same flux (IEC TS 62600-100 / MHKiT): rho g^2 / (64 pi) Hm0^2 Te
    assert got.energy_flux == pytest.approx(RHO * G**2 / (64 * math.pi) * got.hm0**2 * got.te, rel=1e-12)
    stats = bin_statistics([0.25 * flux, 0.5 * flux], got.energy_flux, 10.0)
    assert stats["mean_capture_width_m"] == pytest.approx(0.375, rel=1e-12)
    assert stats["capture_width_ratio"] == pytest.approx(0.0375, rel=1e-12)


def _spec_jonswap(hs, tp, gamma, record_length):
    """The lead's specification of AbsorberWave's JONSWAP components, written out in angular frequency."""
    wp = 2 * math.pi / tp
    n = math.ceil(2.5 * record_length / tp - 1e-9)
    dw = 2.5 * wp / n
    w = 0.5 * wp + (np.arange(n) + 0.5) * dw
    sigma = np.where(w <= wp, 0.07, 0.09)
    shape = w**-5 * np.exp(-1.25 * (wp / w) ** 4) * gamma ** np.exp(-((w - wp) ** 2) / (2 * sigma**2 * wp**2))
    return w, (hs / 4) ** 2 * shape / (dw * shape.sum()), dw


@pytest.mark.parametrize("hs, tp, gamma, length", [(2.0, 8.0, 3.3, 1220.0), (1.0, 6.0, 1.0, 60.0),
                                                   (3.0, 12.0, 7.0, 1250.0)])
def test_absorber_sea_state_is_the_specified_one_and_its_record_does_not_repeat(hs, tp, gamma, length):
    """absorber_jonswap (MHKiT's JONSWAP shape in hertz) = the specification's components in rad/s; the spacing
    dw <= 2 pi / record_length; Hm0 of the band exactly Hs; Te / Tp of the band (about 0.9 for gamma 3.3)."""
    got = absorber_jonswap(hs, tp, gamma, length)
    w, s, dw = _spec_jonswap(hs, tp, gamma, length)
    assert got.d_omega == pytest.approx(dw, rel=1e-15) and got.d_omega <= 2 * math.pi / length
    np.testing.assert_allclose(got.omega, w, rtol=1e-15)
    np.testing.assert_allclose(got.density, s, rtol=1e-12)
    m = spectral_measures(got)
    assert m.hm0 == pytest.approx(hs, rel=1e-13)
    assert m.te == pytest.approx(2 * math.pi * np.sum(s / w) / np.sum(s), rel=1e-12)
    if gamma == 3.3:     # the ITTC fit of the infinite spectrum gives 0.9036; the band 0.5-3 w_p drops its tail
        assert 0.88 < m.te / tp < 0.93


# ---------------------------------------------------------------- the bins' checks
@pytest.mark.parametrize("kwargs, option", [
    ({"hs_bin_width": 0.6}, "hs-bin-width"),
    ({"hs_bin_width": 0.0}, "hs-bin-width"),
    ({"te_bin_width": 1.5}, "te-bin-width"),
    ({"te_bin_width": float("nan")}, "te-bin-width"),
    ({"runs_per_bin": 2}, "seeds"),
    ({"min_runs": 1}, "min-runs"),
    ({"heights": [1.0, 1.2, 2.0]}, "hs"),
    ({"energy_periods": [7.28, 7.6]}, "tp"),
])
def test_bin_checks_refuse_a_grid_naming_the_option(kwargs, option):
    args = {"heights": [1.0, 2.0, 3.0], "energy_periods": [5.46, 7.28, 9.10, 10.92], "runs_per_bin": 3, **kwargs}
    heights, periods = args.pop("heights"), args.pop("energy_periods")
    check_bins([1.0, 1.5], [7.0, 8.0], IEC_HS_BIN_WIDTH, IEC_TE_BIN_WIDTH, 3)      # the widest bins, side by side
    with pytest.raises(ParameterError) as err:
        check_bins(heights, periods, **args)
    assert err.value.parameter == option and err.value.allowed, err.value


# ---------------------------------------------------------------- the harvester's system through the same command
def _no_runs(monkeypatch):
    from flexfmu.wec import system as wec_system

    def run_case(*args, **kwargs):
        raise AssertionError("a co-simulation ran")
    monkeypatch.setattr(wec_system, "run_case", run_case)


def test_harvester_system_keeps_its_study_and_gets_the_bins_statistics(tmp_path, capsys):
    """The wave converter with its harvester (model scale): 60 s runs by default, the boundary, its bins unchecked
    (two seeds pass), and the bins' CSV with each cell's statistics of the same runs as the matrix."""
    import csv

    from flexfmu import cli
    out = tmp_path / "m.csv"
    status = cli.main(["wec", "power-matrix", str(HARVESTER_SYSTEM), "--hs", "0.05", "--tp", "1.4,2.0", "--seeds",
                       "2", "--t-end", "0.1", "--serial", "--boundary", "XFX", "--out", str(out), "--plot",
                       str(tmp_path / "m.png")])
    assert status == 0, capsys.readouterr().err
    with (tmp_path / "m_runs.csv").open() as f:
        runs = list(csv.DictReader(f))
    with (tmp_path / "m_bins.csv").open() as f:
        bins = list(csv.DictReader(f))
    assert [r["boundary"] for r in runs] == ["XFX"] * 4
    assert [(float(b["Hs_m"]), float(b["Tp_s"]), int(b["count"])) for b in bins] == [(0.05, 1.4, 2), (0.05, 2.0, 2)]
    for b, pair in zip(bins, (runs[:2], runs[2:])):
        powers = [float(r["mean_power_W"]) for r in pair]
        assert float(b["mean_power_W"]) == pytest.approx(np.mean(powers), rel=1e-15)
        assert float(b["std_power_W"]) == pytest.approx(np.std(powers), rel=1e-12)
        assert float(b["J_W_per_m"]) > 0 and "spectral_power_W" not in b
        # the box's beam (0.6 m) is its characteristic width
        assert float(b["capture_width_ratio"]) == pytest.approx(float(b["mean_power_W"]) / float(b["J_W_per_m"])
                                                                / 0.6, rel=1e-12)


def test_harvester_system_with_bin_checks_refuses_its_centimetre_grid(tmp_path, capsys, monkeypatch):
    from flexfmu import cli
    _no_runs(monkeypatch)
    status = cli.main(["wec", "power-matrix", str(HARVESTER_SYSTEM), "--hs", "0.05,0.3", "--tp", "2.0",
                       "--seeds", "3", "--t-end", "0.1", "--serial", "--bin-checks",
                       "--out", str(tmp_path / "m.csv"), "--plot", str(tmp_path / "m.png")])
    err = capsys.readouterr().err
    assert status == 2 and "error: hs: Hs 0.05 and 0.3 m are 0.25 m apart" in err, err
    assert not list(tmp_path.iterdir())


# ---------------------------------------------------------------- the point absorber
LINEAR = ("float.heave_only=true", "hydro.drag=false", "mooring.enabled=false")
#: plumbing runs: a minute at 50 ms (the file's 6.25 ms step is for the 20-minute study)
SHORT = {"t_end": 60.0, "step": 0.05}


def test_absorber_sea_state_by_mhkit_is_the_one_the_wave_plays():
    """absorber_jonswap (MHKiT's JONSWAP) = AbsorberWave's own components (flexfmu.wec.absorber.wave) for the
    record length a run sets, and the record does not repeat within the run: dw <= 2 pi / t_end."""
    from flexfmu.wec.absorber.wave import AbsorberWaveConfig, sea_components
    for hs, tp, length in ((1.0, 6.0, 1220.0), (3.0, 12.0, 1220.0), (2.0, 9.0, 1800.0), (2.0, 8.0, 60.0)):
        played = sea_components(AbsorberWaveConfig("jonswap", hs, tp, record_length=length))
        got = absorber_jonswap(hs, tp, 3.3, length)
        assert got.omega.size == played.omega.size and got.d_omega <= 2 * math.pi / length
        np.testing.assert_allclose(got.omega, played.omega, rtol=1e-14)
        np.testing.assert_allclose(got.density, played.density, rtol=1e-12)


def test_a_run_sets_the_record_length_to_its_length():
    from flexfmu.cosim.masters import load_system
    from flexfmu.wec.roles import roster
    from flexfmu.wec.system import Case, case_system
    system = case_system(load_system(ABSORBER_SYSTEM), Case(None, "jonswap", 2.0, 8.0, 5), 1220.0)
    wave = roster(system).one("wave").config
    assert (wave.sea_state, wave.wave_height, wave.wave_period, wave.seed, wave.record_length) == \
        ("jonswap", 2.0, 8.0, 5, 1220.0)


def test_absorber_defaults_are_twenty_minutes_after_the_ramp_and_checked_bins(tmp_path, monkeypatch):
    """Refused before any run: a boundary for a system without a harvester, and each bin check by its option."""
    from flexfmu.cosim.masters import load_system
    from flexfmu.wec.power_study import study_defaults
    from flexfmu.wec.roles import roster
    from flexfmu.wec.system import power_matrix
    d = study_defaults(roster(load_system(ABSORBER_SYSTEM)))
    assert (d.t_end, d.average_from, d.bin_checks, d.boundary, d.min_runs) == (1220.0, 20.0, True, None, 3)
    _no_runs(monkeypatch)
    for kwargs, option in [({"boundary": "XFF"}, "boundary"), ({"seeds": (1, 2)}, "seeds"),
                           ({"heights": (1.0, 1.2)}, "hs"), ({"periods": (8.0, 8.5)}, "tp"),
                           ({"hs_bin_width": 0.75}, "hs-bin-width"), ({"te_bin_width": 2.0}, "te-bin-width"),
                           ({"average_from": 60.0}, "average-from")]:
        args = {"heights": (2.0,), "periods": (8.0,), "seeds": (1, 2, 3), "scheduler": None, **SHORT, **kwargs}
        with pytest.raises(ParameterError) as err:
            power_matrix(ABSORBER_SYSTEM, **args)
        assert err.value.parameter == option, err.value
    # the study's grid passes the checks (its columns' Te, equal to rounding over Hs, are one Te each)
    with pytest.raises(AssertionError, match="a co-simulation ran"):
        power_matrix(ABSORBER_SYSTEM, (1.0, 2.0, 3.0), (6.0, 8.0, 10.0, 12.0), scheduler=None, **SHORT)


def _spectral_by_hand(hs, tp, length, damping):
    """P = sum_k S_k dw c w_k^2 |X_3 / Z|^2 from the hull's arrays (the lead's specification), written out here."""
    from flexfmu.wec.absorber.hull import absorber_hull
    hull = absorber_hull()
    w, s, dw = _spec_jonswap(hs, tp, 3.3, length)
    x3 = np.interp(w, hull.omega, hull.X[:, 2].real) + 1j * np.interp(w, hull.omega, hull.X[:, 2].imag)
    a33 = np.interp(w, hull.omega, hull.A[:, 2, 2])
    b33 = np.interp(w, hull.omega, hull.B[:, 2, 2])
    z = -w**2 * (hull.M_rb[2, 2] + a33) - 1j * w * (b33 + damping) + hull.C[2, 2]
    return float(np.sum(s * dw * damping * w**2 * np.abs(x3 / z) ** 2))


@pytest.mark.parametrize("configuration", ["linear", "default"])
def test_cli_point_absorber_writes_the_matrix_bins_runs_and_chart(configuration, tmp_path, capsys):
    """`flexfmu wec power-matrix` on the point absorber (short runs): the three CSVs and the heat map; each bin's
    statistics are those of its runs; the statistics window starts after the wave's 20 s ramp; in the linear
    configuration the frequency-domain prediction is written beside each bin's mean."""
    import csv

    from flexfmu import cli
    out = tmp_path / "pm.csv"
    sets = [a for s in (LINEAR if configuration == "linear" else ()) for a in ("--set", s)]
    heights = (1.0, 2.0) if configuration == "linear" else (2.0,)      # MoorDyn's runs take longer
    status = cli.main(["wec", "power-matrix", str(ABSORBER_SYSTEM), "--hs", ",".join(map(str, heights)), "--tp", "8",
                       "--seeds", "3",
                       "--t-end", str(SHORT["t_end"]), "--step", str(SHORT["step"]), "--serial", *sets,
                       "--out", str(out), "--plot", str(tmp_path / "pm.png")])
    assert status == 0, capsys.readouterr().err
    assert (tmp_path / "pm.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with out.open() as f:
        matrix = list(csv.reader(f))
    with (tmp_path / "pm_bins.csv").open() as f:
        bins = list(csv.DictReader(f))
    with (tmp_path / "pm_runs.csv").open() as f:
        runs = list(csv.DictReader(f))
    assert [float(x) for x in matrix[0][1:]] == [8.0] and [float(r[0]) for r in matrix[1:]] == list(heights)
    assert len(runs) == 3 * len(heights) and all(float(r["average_from_s"]) == 20.0 and "boundary" not in r for r in runs)
    assert all(float(r["record_length_s"]) == SHORT["t_end"] for r in runs)
    assert len(bins) == len(heights)
    for b, cell, row in zip(bins, (runs[:3], runs[3:]), matrix[1:]):
        powers = np.array([float(r["mean_power_W"]) for r in cell])
        assert int(b["count"]) == 3 and float(b["mean_power_W"]) == pytest.approx(powers.mean(), rel=1e-14)
        assert float(row[1]) == pytest.approx(powers.mean(), rel=1e-14)
        low, high = scipy.stats.t.interval(0.95, 2, loc=powers.mean(), scale=scipy.stats.sem(powers))
        assert (float(b["ci_low_W"]), float(b["ci_high_W"])) == pytest.approx((low, high), rel=1e-12)
        assert float(b["capture_width_ratio"]) == pytest.approx(powers.mean() / float(b["J_W_per_m"]) / 10.0,
                                                                rel=1e-12)
        assert b["Hm0_bin_m"] and b["Te_bin_s"]
        if configuration == "linear":
            expected = _spectral_by_hand(float(b["Hs_m"]), 8.0, SHORT["t_end"], 6.0e5)
            assert float(b["spectral_power_W"]) == pytest.approx(expected, rel=1e-12)
        else:
            assert "spectral_power_W" not in b
    # power grows as Hs^2 in the linear configuration: the 2 m cell's prediction is 4 x the 1 m cell's
    if configuration == "linear":
        assert float(bins[1]["spectral_power_W"]) == pytest.approx(4 * float(bins[0]["spectral_power_W"]),
                                                                    rel=1e-12)
