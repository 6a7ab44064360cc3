"""The paper's spatial double pendulum (Koda et al. 2025, Sec. 3, Tables 1-3, Eqs. 16-19)."""
import json
from pathlib import Path

import numpy as np
import pytest

from flexfmu.ffr.assembly import boundary_matrix, build_beam_model
from flexfmu.ffr.report import format_table, modal_analysis, paper_columns, paper_tables
from flexfmu.ffr.scene import load_scene

from error_bounds import gamma

SHARED = Path(__file__).resolve().parents[2] / "shared" / "reference" / "paper_tables.json"


@pytest.fixture(scope="module")
def scene():
    return load_scene("spatial_double_L")


@pytest.fixture(scope="module")
def converged(scene):
    return {b: modal_analysis(scene, b, n_modes=6) for b in ("XFF", "XFX", "FXF", "FXF_mid")}


def test_scene_is_the_papers_specimen(scene):
    ref = paper_tables()["ffr_spatial_double_pendulum"]
    # norm(p_{i+1} - p_i): diff (1 rounding on |p_i| + |p_{i+1}|), 3 squares + 2 adds + sqrt (4, relative to L),
    # table parse (1): over-counted as gamma(6) on L + |p_i| + |p_{i+1}|
    p = np.abs(scene.points)
    scale = np.asarray(ref["geometry"]["segments_m"]) + np.linalg.norm(p[:-1] + p[1:], axis=1)
    assert np.all(np.abs(scene.segment_lengths - ref["geometry"]["segments_m"]) <= gamma(6) * scale)
    assert scene.section.A == pytest.approx(np.pi * ref["geometry"]["diameter_m"] ** 2 / 4)
    assert scene.material.E == ref["material"]["E_Pa"] and scene.material.rho == ref["material"]["density_kg_m3"]
    d = np.diff(scene.points, axis=0)
    assert np.allclose([d[0] @ d[1], d[1] @ d[2], d[0] @ d[2]], 0.0)   # mutually perpendicular


@pytest.mark.skipif(not SHARED.exists(), reason="shared/ not beside the checkout")
def test_packaged_paper_tables_are_a_copy_of_shared_reference():
    assert paper_tables() == json.loads(SHARED.read_text())


def test_b2_matrices_equal_eq16_for_one_element_per_segment(scene):
    """Four nodes x 6 DOF as in the paper: B2 of Eqs. 16a-c."""
    I = np.eye
    Z = np.zeros
    expected = {
        "XFF": np.vstack([Z((6, 18)), I(18)]),
        "XFX": np.vstack([Z((6, 12)), I(12), Z((6, 12))]),
        "FXF": np.block([[I(6), Z((6, 12))], [Z((6, 6)), Z((6, 12))], [Z((12, 6)), I(12)]]),
    }
    for boundary, B2 in expected.items():
        model = build_beam_model(scene, boundary, 1)
        assert model.mesh.n_nodes == 4
        np.testing.assert_array_equal(model.B2.toarray(), B2)
    assert boundary_matrix(4, []).toarray().tolist() == np.eye(24).tolist()   # FFF: identity


def test_frequencies_converge_and_compare_with_experiment(converged):
    for boundary, result in converged.items():
        assert result.converged, boundary
        print()
        print(format_table("spatial_double_L", result))
    xff = converged["XFF"].modes.frequencies_hz
    xfx = converged["XFX"].modes.frequencies_hz
    assert xff[0] == pytest.approx(38.8667, rel=0.03)    # experiment, Eq. 17
    assert xfx[0] == pytest.approx(149.007, rel=0.05)    # experiment, Eq. 19
    # boundary conditions tune the structure: XFF lowest, XFX highest (the paper's claim)
    fxf = converged["FXF"].modes.frequencies_hz
    assert xff[0] < fxf[0] < xfx[0]


def test_last_refinement_changed_frequencies_by_less_than_1e5(converged):
    for result in converged.values():
        (_, coarse), (_, fine) = result.history[-2:]
        assert np.max(np.abs(fine - coarse) / fine) < 1e-5


def test_fxf_variants_clamp_different_points(converged, scene):
    assert converged["FXF"].model.clamp_s == (pytest.approx(0.16),)
    assert converged["FXF_mid"].model.clamp_s == (pytest.approx(0.16 + 0.07),)
    mid_node = converged["FXF_mid"].model.clamped_nodes[0]
    # node = (1 - t) p_1 + t p_2, t = (s - s_1) / (s_2 - s_1), the s from cumsum'd norms (<= 6 roundings each on
    # the total length S), the midpoint (1) and two differences: |dt| (s_2 - s_1) <= 4 gamma(8) S; the blend adds
    # 3 roundings on |p_1| + |p_2|; the literal 1: over-counted as gamma(32) (S + |p_1| + |p_2|)
    S = scene.vertex_arc_lengths[-1]
    scale = S + np.abs(scene.points[1]) + np.abs(scene.points[2])
    node = converged["FXF_mid"].model.mesh.nodes[mid_node]
    assert np.all(np.abs(node - [0.07, 0.0, 0.16]) <= gamma(32) * scale)
    assert paper_columns("FXF_mid") == paper_columns("FXF")


def test_one_element_per_segment_is_close_to_converged(scene, converged):
    """The paper's own mesh (4 nodes) is already within 1 % of the converged first frequency."""
    coarse = modal_analysis(scene, "XFF", n_modes=2, elements_per_segment=1).modes.frequencies_hz
    assert coarse[0] == pytest.approx(converged["XFF"].modes.frequencies_hz[0], rel=0.01)
