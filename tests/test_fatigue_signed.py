"""Signed stress histories for fatigue (flexfmu.fatigue.section_scan, critical_plane_scan, flexfmu fatigue
--section-gauge / --tensor-gauge) against closed forms.

References, independent of the code under test:
- beam bending: sigma_xx = N/A + My z/Iy - Mz y/Iz with a circle's I = pi D^4 / 64 (textbook), a rectangle's
  Iy = H B^3 / 12; the unsigned section stress from flexfmu.core.stress.SectionFibres (the gauges' own formula);
- Miner's sum of n cycles of range S on N = a S^-m: n S^m / a;
- the normal stress on a plane, sigma_n = n^T sigma n: uniaxial S gives S cos^2(angle to the axis), pure shear tau
  gives tau sin(2 theta) in its plane (Mohr's circle), largest at 45 deg.

Histories start at a trough (-cos) with every peak and trough a sample, so that rainflow (ASTM E1049-85) closes
exactly n cycles of the full range; the sampled peaks of a shifted phase are within cos(pi / P) of the true ones
(P samples per period).
"""
from __future__ import annotations

import csv
import math
import re

import numpy as np
import pytest

pytest.importorskip("rainflow")

from test_fatigue import _write_csv  # noqa: E402  (a result CSV as the commands read it)

from flexfmu.cli import main  # noqa: E402
from flexfmu.core.stress import SectionFibres  # noqa: E402
from flexfmu.errors import ParameterError  # noqa: E402
from flexfmu.fatigue import (BeamSection, assess_history, critical_plane_scan, curve_from_text,  # noqa: E402
                             rainflow_cycles, section_scan, StressHistory)
from flexfmu.fatigue.plane_normals import (angle_between_planes, cap_normals, hemisphere_normals,  # noqa: E402
                                           normal_stress)
from flexfmu.fatigue.signed_scan import DEFAULT_PLANE_STEP, DEFAULT_REFINEMENTS  # noqa: E402

pytestmark = pytest.mark.unit

D = 0.01                                   # m, the circle's diameter
C = D / 2
I_CIRCLE = math.pi * D ** 4 / 64           # m^4
A_CIRCLE = math.pi * D ** 2 / 4
#: the final resolution of the default critical-plane scan: each refinement divides the step by 3
FINAL_STEP = DEFAULT_PLANE_STEP / 3 ** DEFAULT_REFINEMENTS


def trough_start(n_cycles: int, per_cycle: int = 40, period: float = 1.0):
    """t and -cos(w t) over n whole periods, every peak and trough a sample."""
    k = np.arange(n_cycles * per_cycle + 1)
    return k * (period / per_cycle), -np.cos(2.0 * np.pi * k / per_cycle)


def _curve(m: float, log10a: float):
    return curve_from_text(f"{m},{log10a}", unit="MPa", parameter="sn")


# ---------------------------------------------------------------------------------------------- beam sections
@pytest.mark.parametrize("m", [3.0, 5.0])
def test_fully_reversed_bending_signed_against_unsigned_is_2_to_the_m_minus_1(m):
    n, M0 = 30, 4.0                                     # cycles, N m
    t, wave = trough_start(n)
    My, zero = M0 * wave, np.zeros_like(wave)
    curve = _curve(m, 3 * m + 3)
    scan = section_scan(t, zero, My, zero, BeamSection.from_text(f"circle:{D}"), curve)
    S = 2.0 * M0 * C / I_CIRCLE / 1e6                   # MPa: the critical fibre's range (z = +-c)
    a = 10.0 ** (3 * m + 3)
    assert abs(abs(scan.places[scan.critical][1]) - C) < 1e-15 and abs(scan.places[scan.critical][0]) < 1e-15
    cycles = scan.assessment.cycles
    assert cycles.total == n and np.allclose(cycles.ranges, S, rtol=1e-12)
    assert scan.assessment.damage == pytest.approx(n * S ** m / a, rel=1e-12)
    # the gauges' unsigned sigma_max folds the reversal: 2n cycles of half the range
    fibres = SectionFibres.of("circle", A_CIRCLE, I_CIRCLE, I_CIRCLE, 2 * I_CIRCLE)
    unsigned = assess_history(StressHistory(t, fibres.sigma_max(zero, My, zero), "sigma_max"), curve)
    assert unsigned.cycles.total == 2 * n and np.allclose(unsigned.cycles.ranges, S / 2, rtol=1e-12)
    assert scan.assessment.damage / unsigned.damage == pytest.approx(2.0 ** (m - 1), rel=1e-12)


def test_rotating_bending_gives_every_fibre_the_same_range():
    n, M0, P = 20, 3.0, 360
    k = np.arange(n * P + 1)
    t, w = k / P, 2.0 * np.pi * k / P
    zero = np.zeros(k.size)
    curve = _curve(3.0, 12.0)
    scan = section_scan(t, zero, M0 * np.cos(w), M0 * np.sin(w), BeamSection.from_text(f"circle:{D}"), curve)
    S = 2.0 * M0 * C / I_CIRCLE / 1e6
    # sigma = (M0 c / I) sin(angle - w t): each fibre's peaks sampled within cos(pi / P) of the true ones
    assert scan.largest_range.size == 72 + 20
    assert np.all(scan.largest_range <= S * (1 + 1e-12))
    assert np.all(scan.largest_range >= S * math.cos(math.pi / P) - 1e-12 * S)
    # n periods: between n - 1 closed cycles of the sampled range and n of the full one (the residue's halves)
    assert np.all(scan.damage <= n * S ** 3 / 1e12 * (1 + 1e-12))
    assert np.all(scan.damage >= (n - 1) * (S * math.cos(math.pi / P)) ** 3 / 1e12)


def test_oblique_bending_plane_is_found_within_the_refined_step():
    """M0 (cos a, sin a) in (My, Mz): sigma = (M0 c / I) sin(angle - a), largest at a +- 90 deg; the 72 angles and the
    refinement 0.5 deg apart put the critical fibre within 0.25 deg of it, its range within cos(0.25 deg) of 2 S."""
    n, M0, a = 10, 2.0, math.radians(37.3)
    t, wave = trough_start(n)
    zero = np.zeros_like(wave)
    scan = section_scan(t, zero, M0 * math.cos(a) * wave, M0 * math.sin(a) * wave, BeamSection.from_text(f"circle:{D}"),
                        _curve(3.0, 12.0))
    y, z = scan.places[scan.critical]
    off = abs((math.atan2(z, y) - a) % math.pi - math.pi / 2)
    assert off <= math.radians(0.25) + 1e-12
    S = 2 * M0 * C / I_CIRCLE / 1e6
    assert S * math.cos(math.radians(0.25)) <= scan.largest_range[scan.critical] <= S * (1 + 1e-12)
    assert scan.largest_range[:72].max() < S * math.cos(math.radians(2.0))        # the coarse angles alone miss it


def test_rectangle_bending_about_each_axis_finds_the_far_edge():
    B, H, M0, n = 0.02, 0.005, 2.0, 10                  # m (B along z, H along y), N m
    t, wave = trough_start(n)
    zero = np.zeros_like(wave)
    section = BeamSection.from_text(f"rectangle:{B},{H}")
    curve = _curve(3.0, 12.0)
    about_y = section_scan(t, zero, M0 * wave, zero, section, curve)
    assert abs(abs(about_y.places[about_y.critical][1]) - B / 2) < 1e-15
    assert about_y.largest_range.max() == pytest.approx(2 * M0 * (B / 2) / (H * B ** 3 / 12) / 1e6, rel=1e-12)
    about_z = section_scan(t, zero, zero, M0 * wave, section, curve)
    assert abs(abs(about_z.places[about_z.critical][0]) - H / 2) < 1e-15
    assert about_z.largest_range.max() == pytest.approx(2 * M0 * (H / 2) / (B * H ** 3 / 12) / 1e6, rel=1e-12)
    assert len(about_z.places) == 32                     # 4 corners + 7 points inside each edge


def test_axial_force_adds_the_same_stress_at_every_fibre():
    n = 10
    t, wave = trough_start(n)
    zero = np.zeros_like(wave)
    N0 = 1000.0
    scan = section_scan(t, N0 * wave, zero, zero, BeamSection.from_text(f"tube:{D},{D / 2}"), _curve(3.0, 12.0))
    area = math.pi * (D ** 2 - (D / 2) ** 2) / 4
    assert np.allclose(scan.largest_range, 2 * N0 / area / 1e6, rtol=1e-12)


# ---------------------------------------------------------------------------------------------- planes
def test_the_normals_cover_every_plane_within_their_step(rng):
    """The rings' stated covering angle: every direction within step of a normal (or its opposite)."""
    probes = rng.normal(size=(20000, 3))
    probes /= np.linalg.norm(probes, axis=1, keepdims=True)
    for step in (DEFAULT_PLANE_STEP, math.radians(15.0)):
        normals = hemisphere_normals(step)
        assert np.allclose(np.linalg.norm(normals, axis=1), 1.0) and np.all(normals[:, 2] >= -1e-15)
        nearest = np.arccos(np.clip(np.max(np.abs(probes @ normals.T), axis=1), -1, 1))
        assert nearest.max() <= step
    centre = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    radius, step = 0.2, 0.02
    cap = cap_normals(centre, radius, step)
    inside = probes[np.arccos(np.clip(probes @ centre, -1, 1)) <= radius]
    local = rng.normal(size=(5000, 3)) * 0.1 + centre                # directions near the centre, most in the cap
    local /= np.linalg.norm(local, axis=1, keepdims=True)
    inside = np.vstack([inside, local[np.arccos(np.clip(local @ centre, -1, 1)) <= radius]])
    assert inside.shape[0] > 1000
    assert np.arccos(np.clip(np.max(inside @ cap.T, axis=1), -1, 1)).max() <= step
    assert np.allclose(cap[0], centre)


def test_normal_stress_is_n_sigma_n(rng):
    stress = rng.normal(size=(7, 6))
    normals = rng.normal(size=(5, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    for i in range(7):
        xx, yy, zz, xy, yz, xz = stress[i]
        tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        expected = np.einsum("ki,ij,kj->k", normals, tensor, normals)
        assert np.allclose(normal_stress(stress[i:i + 1], normals)[0], expected, rtol=1e-13, atol=1e-13)


def test_uniaxial_stress_critical_plane_is_normal_to_the_axis():
    n, S = 20, 50e6                                      # Pa
    t, wave = trough_start(n)
    stress = np.zeros((wave.size, 6))
    stress[:, 0] = S * wave
    scan = critical_plane_scan(t, stress, _curve(3.0, 12.0))
    normal = scan.places[scan.critical]
    # sigma_n = S cos^2(angle to x): the scan's last step bounds the angle and the range
    assert angle_between_planes(normal, [1.0, 0.0, 0.0]) <= FINAL_STEP
    rng_mpa = scan.assessment.cycles.ranges.max()
    assert 2 * S / 1e6 * math.cos(FINAL_STEP) ** 2 <= rng_mpa <= 2 * S / 1e6 * (1 + 1e-12)
    assert scan.assessment.cycles.total == n


def test_pure_shear_critical_plane_is_at_45_degrees():
    n, tau = 20, 40e6
    t, wave = trough_start(n)
    stress = np.zeros((wave.size, 6))
    stress[:, 3] = tau * wave                            # sigma_xy
    scan = critical_plane_scan(t, stress, _curve(3.0, 12.0))
    normal = scan.places[scan.critical]
    # sigma_n = 2 tau nx ny >= tau cos(2 delta) at delta from (1, +-1, 0)/sqrt(2): the nearest scanned normal (within
    # FINAL_STEP) gives range >= 2 tau cos(2 FINAL_STEP); that range puts n within acos(sqrt(cos 2h) cos h) of 45 deg
    h = FINAL_STEP
    rng_mpa = scan.assessment.cycles.ranges.max()
    assert 2 * tau / 1e6 * math.cos(2 * h) <= rng_mpa <= 2 * tau / 1e6 * (1 + 1e-12)
    bound = math.acos(math.sqrt(math.cos(2 * h)) * math.cos(h))
    off = min(angle_between_planes(normal, [1.0, 1.0, 0.0]), angle_between_planes(normal, [1.0, -1.0, 0.0]))
    assert off <= bound
    assert bound < math.radians(1.5)                     # the statement the docs make: within ~1.2 deg


def test_signed_tensor_reversal_counts_as_the_von_mises_cannot():
    """Uniaxial reversal: the plane's signed range is twice von Mises' (|S|), half the cycles: 2^(m-1) the damage."""
    n, S = 20, 50e6
    t, wave = trough_start(n)
    stress = np.zeros((wave.size, 6))
    stress[:, 0] = S * wave
    curve = _curve(3.0, 12.0)
    signed = critical_plane_scan(t, stress, curve).assessment.damage
    unsigned = assess_history(StressHistory(t, np.abs(S * wave)), curve).damage
    assert rainflow_cycles(np.abs(S * wave)).total == 2 * n
    # the found plane's range is within cos^2(FINAL_STEP) of 2S
    assert 4.0 * math.cos(FINAL_STEP) ** 6 <= signed / unsigned <= 4.0 * (1 + 1e-12)


# ---------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("text", ["circle", "circle:0", "circle:-1", "circle:nan", "circle:a", "circle:1,2",
                                  "tube:0.01", "tube:0.01,0.02", "tube:0.01,0.01", "tube:0.01,-1e-3", "rectangle:1",
                                  "ellipse:1,2", ""])
def test_bad_section_text_is_refused_naming_the_option(text):
    with pytest.raises(ParameterError) as info:
        BeamSection.from_text(text, "section")
    message = str(info.value)
    assert message.startswith("section") and ("circle:D" in message or "DI < DO" in message)


@pytest.mark.parametrize("text", ["circle:0.008", "tube:0.012,0.007", "tube:0.01,0", "rectangle:0.02,0.005"])
def test_a_section_from_its_constants_has_its_dimensions(text):
    """What a scene's Section holds (A, Iy, Iz) gives back the dimensions (rounding: 1e-14)."""
    section = BeamSection.from_text(text)
    again = BeamSection.from_constants(section.shape, section.area, section.Iy, section.Iz)
    assert again.shape == section.shape and np.allclose(again.dims, section.dims, rtol=1e-14, atol=1e-16)
    with pytest.raises(ParameterError, match="section: a generic section"):
        BeamSection.from_constants("generic", section.area, section.Iy, section.Iz)


def test_scans_refuse_mismatched_arrays():
    t = np.arange(5.0)
    section = BeamSection.from_text("circle:0.01")
    with pytest.raises(ParameterError, match="time"):
        section_scan(t[:4], t, t, t, section, _curve(3, 12))
    with pytest.raises(ParameterError, match="section forces"):
        section_scan(t, t, t[:4], t, section, _curve(3, 12))
    with pytest.raises(ParameterError, match="stress"):
        critical_plane_scan(t, np.zeros((5, 5)), _curve(3, 12))
    with pytest.raises(ParameterError, match="scf"):
        critical_plane_scan(t, np.zeros((5, 6)), _curve(3, 12), scf=-1.0)


# ---------------------------------------------------------------------------------------------- the command
def _result(tmp_path, n=10, M0=3.0, tau=20e6):
    t, wave = trough_start(n)
    zero = np.zeros_like(wave)
    columns = {f"h.gauge_1_{q}": v for q, v in (("N", zero), ("Vy", zero), ("Vz", zero), ("T", 0.05 * M0 * wave),
                                                 ("My", M0 * wave), ("Mz", zero))}
    columns.update({f"tip.sigma_{c}": (tau * wave if c == "xy" else zero)
                    for c in ("xx", "yy", "zz", "xy", "yz", "xz")})
    return _write_csv(tmp_path / "result.csv", t, columns), t


def test_cli_section_gauge_end_to_end(tmp_path, capsys):
    n, M0 = 10, 3.0
    result, t = _result(tmp_path, n, M0)
    table, places = tmp_path / "bins.csv", tmp_path / "places.csv"
    status = main(["fatigue", str(result), "--section-gauge", "h.gauge_1", "--section", "circle:0.01", "--sn", "3,12",
                   "--bins", "4", "--out", str(table), "--scan-out", str(places)])
    out = capsys.readouterr().out
    assert status == 0
    S = 2 * M0 * C / I_CIRCLE / 1e6
    damage = n * S ** 3 / 1e12
    for text in ("scanned: sigma_xx = N/A + My z/Iy - Mz y/Iz at 72 points", f"Miner damage: {damage:.6e}",
                 "left out: torsion", "torsion: largest shear stress"):
        assert text in out, text
    assert re.search(r"critical: (90|270) deg from y towards z", out)
    rows = list(csv.reader(table.open()))
    assert float(rows[-1][3]) == pytest.approx(damage, rel=1e-12)
    rows = list(csv.reader(places.open()))
    assert rows[0] == ["y_m", "z_m", "place", "damage", "largest_range_MPa"] and len(rows) == 1 + 72 + 20
    assert float(rows[1][3]) == pytest.approx(damage, rel=1e-12)


def test_cli_section_from_a_scene_equals_the_section_given(tmp_path, capsys):
    """--section scene:spatial_double_L (circle 8 mm, docs/scene_format.md) is --section circle:0.008."""
    result, _ = _result(tmp_path)
    damages = []
    for section in ("scene:spatial_double_L", "circle:0.008"):
        assert main(["fatigue", str(result), "--section-gauge", "h.gauge_1", "--section", section, "--sn", "3,12"]) == 0
        out = capsys.readouterr().out
        assert "at the circle D = 8 mm" in out
        damages.append(float(re.search(r"Miner damage: (\S+)", out).group(1)))
    assert damages[0] == pytest.approx(damages[1], rel=1e-6)        # printed to 7 digits
    err = _error(capsys, [str(result), "--section-gauge", "h.gauge_1", "--section", "scene:nosuch", "--sn", "3,12"])
    assert "section: 'nosuch'" in err


def test_cli_tensor_gauge_end_to_end(tmp_path, capsys):
    n, tau = 10, 20e6
    result, _ = _result(tmp_path, n, tau=tau)
    status = main(["fatigue", str(result), "--tensor-gauge", "tip", "--sn", "3,12"])
    out = capsys.readouterr().out
    assert status == 0
    assert "scanned: normal stress n^T sigma n on 545 planes" in out and "critical: plane normal" in out
    assert "left out: shear on the plane, mean stress" in out and "45, 45, 90 deg with the body x, y, z axes" in out


def _error(capsys, argv) -> str:
    assert main(["fatigue", *argv]) == 2
    return capsys.readouterr().err


def test_cli_refuses_bad_signed_input_naming_the_option(tmp_path, capsys):
    result, t = _result(tmp_path)
    r = str(result)
    err = _error(capsys, [r, "--section-gauge", "gauge_1", "--section", "circle:0.01", "--sn", "3,12"])
    assert "section-gauge" in err and "'gauge_1_N'" in err and "the gauges it holds: h.gauge_1" in err
    err = _error(capsys, [r, "--section-gauge", "h.gauge", "--section", "circle:0.01", "--sn", "3,12"])
    assert "columns starting with 'h.gauge': h.gauge_1_N, h.gauge_1_Vy" in err
    err = _error(capsys, [r, "--tensor-gauge", "tap", "--sn", "3,12"])
    assert "tensor-gauge" in err and "'tap.sigma_xx'" in err and "the gauges it holds: tip" in err
    err = _error(capsys, [r, "--section-gauge", "h.gauge_1", "--sn", "3,12"])
    assert "section: missing" in err and "circle:D" in err
    err = _error(capsys, [r, "--section-gauge", "h.gauge_1", "--section", "square:1", "--sn", "3,12"])
    assert "section: 'square:1'" in err and "rectangle:B,H" in err
    err = _error(capsys, [r, "--gauge", "tip.sigma_xx", "--section", "circle:0.01", "--sn", "3,12"])
    assert "section" in err and "--section-gauge" in err
    err = _error(capsys, [r, "--section-gauge", "h.gauge_1", "--section", "circle:0.01", "--unit", "MPa",
                          "--sn", "3,12"])
    assert "unit" in err and "Pa" in err
    err = _error(capsys, [r, "--gauge", "tip.sigma_xx", "--sn", "3,12", "--scan-out", str(tmp_path / "p.csv")])
    assert "scan-out" in err
    for argv in ([r, "--sn", "3,12"], [r, "--gauge", "tip.sigma_xx", "--tensor-gauge", "tip", "--sn", "3,12"]):
        with pytest.raises(SystemExit) as info:
            main(["fatigue", *argv])
        assert info.value.code == 2
        assert "--gauge" in capsys.readouterr().err
    # a NaN in a section force named by its column and time
    bad = np.zeros(t.size)
    bad[3] = np.nan
    nan = _write_csv(tmp_path / "nan.csv", t, {"g_N": np.zeros(t.size), "g_My": bad, "g_Mz": np.zeros(t.size)})
    err = _error(capsys, [str(nan), "--section-gauge", "g", "--section", "circle:0.01", "--sn", "3,12"])
    assert "section-gauge g_My" in err and "nan" in err
