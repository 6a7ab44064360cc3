"""Model specifications (flexfmu.reframe.models): paper_plate, beam:<scene>, .npz, default points, bad specs."""
from __future__ import annotations

import json

import numpy as np
import pytest

from error_bounds import gamma
from flexfmu.errors import ParameterError
from flexfmu.core.io import save_structure
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.models import MODEL_ALLOWED, default_load_point, default_output_point, load_model
from flexfmu.reframe.plate import CORNERS, DEFAULT_DIVISIONS, LOAD_POINT

ROD_JSON = {
    "schema_version": 1, "name": "json_rod", "points": [[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.3, 0.2, 0.0]],
    "section": {"shape": "circle", "diameter": 0.01}, "material": {"E": 200e9, "nu": 0.29, "rho": 7850.0},
}


def test_paper_plate_default_mesh_and_points():
    s = load_model("paper_plate")
    assert s.dofs_per_node == 3
    assert s.meta["divisions"] == DEFAULT_DIVISIONS
    assert s.meta["model"] == "paper_plate" and s.meta["kind"] == "paper_plate"
    # mesh vertices from linspace (start + i step: gamma(4) of terms <= 3 X) and P2 midpoints (one more rounding)
    bound = gamma(5) * 3 * np.abs(s.nodes).max()
    np.testing.assert_allclose(s.nodes[default_load_point(s)], LOAD_POINT, rtol=0, atol=bound)   # midway P5-P8
    np.testing.assert_allclose(s.nodes[default_output_point(s)], CORNERS[0], rtol=0, atol=bound)  # P1


def test_paper_plate_options():
    s = load_model("paper_plate", divisions=(4, 1, 1), corner_mass=0.5)
    assert s.meta["divisions"] == (4, 1, 1)
    assert s.meta["corner_mass"] == 0.5
    bound = gamma(5) * 3 * np.abs(s.nodes).max()          # as in test_paper_plate_default_mesh_and_points
    np.testing.assert_allclose(s.nodes[default_load_point(s)], LOAD_POINT, rtol=0, atol=bound)


def test_beam_builtin_scene_free_free():
    s = load_model("beam:spatial_double_L")
    assert s.dofs_per_node == 6
    assert s.meta["elements_per_segment"] == 8 and s.meta["kind"] == "beam"
    assert s.n_nodes == 3 * 8 + 1
    assert default_load_point(s) == s.n_nodes - 1
    assert default_output_point(s) == 0
    # identity: a segment's end node is (1 - t) p0 + t p1 with t = (s1 - s0) / (s1 - s0) = 1 exactly (linspace ends
    # at s1), i.e. 0 p0 + p1: the scene's point, bit for bit
    np.testing.assert_array_equal(s.nodes[-1], [0.14, 0.15, 0.16])       # free end of the rod
    coarse = load_model("beam:spatial_double_L", elements_per_segment=2)
    assert coarse.n_nodes == 3 * 2 + 1
    mb = modal_basis(coarse, 2)                     # free-free: six rigid modes accepted, flexible > 0
    assert np.all(mb.frequencies_hz > 1.0)


def test_beam_scene_json_path(tmp_path):
    path = tmp_path / "rod.json"
    path.write_text(json.dumps(ROD_JSON))
    s = load_model(f"beam:{path}", elements_per_segment=3)
    assert s.n_nodes == 2 * 3 + 1
    # identity: the end nodes are the scene's points exactly (t = 1 and t = 0, see test_beam_builtin_scene_free_free)
    np.testing.assert_array_equal(s.nodes[default_load_point(s)], [0.3, 0.2, 0.0])
    np.testing.assert_array_equal(s.nodes[default_output_point(s)], [0.0, 0.0, 0.0])


def test_npz_round_trip(tmp_path):
    beam = load_model("beam:inclined_beam", elements_per_segment=2)
    path = save_structure(tmp_path / "inclined.npz", beam)
    s = load_model(str(path))
    assert s.meta["kind"] == "npz" and s.name == "inclined"
    np.testing.assert_array_equal(s.nodes, beam.nodes)
    assert abs(s.M - beam.M).max() == 0.0 and abs(s.K - beam.K).max() == 0.0
    assert default_load_point(s) == s.n_nodes - 1 and default_output_point(s) == 0


@pytest.mark.parametrize("spec", ["plate", "Paper_Plate", "", "   ", "beam", "model.npy", None, 3])
def test_unknown_model(spec):
    with pytest.raises(ParameterError) as exc:
        load_model(spec)
    assert exc.value.parameter == "model"
    assert exc.value.allowed == MODEL_ALLOWED
    assert "paper_plate | beam:<scene> | path to a .npz" in str(exc.value)


def test_unknown_scene_and_missing_file(tmp_path):
    with pytest.raises(ParameterError) as exc:
        load_model("beam:no_such_scene")
    assert exc.value.parameter == "model" and "spatial_double_L" in exc.value.allowed
    with pytest.raises(ParameterError) as exc:
        load_model("beam:")
    assert exc.value.parameter == "model"
    with pytest.raises(ParameterError) as exc:
        load_model(str(tmp_path / "missing.npz"))
    assert exc.value.parameter == "model" and "no such file" in str(exc.value)
    bad = tmp_path / "bad.npz"
    np.savez(bad, nodes=np.zeros((2, 3)))
    with pytest.raises(ParameterError) as exc:             # the file's own checks name the key
        load_model(str(bad))
    assert exc.value.parameter == "dofs_per_node"


def test_bad_options():
    with pytest.raises(ParameterError) as exc:
        load_model("beam:spatial_double_L", divisions=(4, 1, 1))
    assert exc.value.parameter == "divisions"
    with pytest.raises(ParameterError) as exc:
        load_model("paper_plate", elements_per_segment=4)
    assert exc.value.parameter == "elements_per_segment"
    with pytest.raises(ParameterError) as exc:
        load_model("beam:spatial_double_L", elements_per_segment=0)
    assert exc.value.parameter == "elements_per_segment"
    with pytest.raises(ParameterError) as exc:
        load_model("paper_plate", divisions=(0, 1, 1))
    assert exc.value.parameter == "divisions"
