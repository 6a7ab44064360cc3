"""Scene validation: every bad input gets a clear error naming the field; CLI exit code 2."""
import copy
import json
import subprocess
import sys

import pytest

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.cli import main as cli_main
from flexfmu.errors import ParameterError
from flexfmu.ffr.scene import builtin_scene_names, load_scene, scene_from_dict

GOOD = {"name": "ok", "points": [[0, 0, 0], [0, 0, 0.2], [0.1, 0, 0.2]],
        "section": {"shape": "circle", "diameter": 0.008},
        "material": {"E": 200e9, "nu": 0.29, "rho": 7850}}


def _with(path, value):
    d = copy.deepcopy(GOOD)
    *keys, last = path
    target = d
    for k in keys:
        target = target[k]
    if value is _DELETE:
        del target[last]
    else:
        target[last] = value
    return d


_DELETE = object()

BAD = [
    ("one point", _with(["points"], [[0, 0, 0]]), "points"),
    ("no points", _with(["points"], _DELETE), "points"),
    ("point not 3 numbers", _with(["points"], [[0, 0, 0], [1, 0]]), "points[1]"),
    ("nan coordinate", _with(["points"], [[0, 0, 0], [float("nan"), 0, 0]]), "points[1]"),
    ("zero-length segment", _with(["points"], [[0, 0, 0], [0, 0, 0.2], [0, 0, 0.2]]), "points[2]"),
    ("fold-back", _with(["points"], [[0, 0, 0], [0, 0, 0.2], [0, 0, 0.1]]), "points[1]"),
    ("E zero", _with(["material", "E"], 0.0), "material.E"),
    ("E negative", _with(["material", "E"], -1e9), "material.E"),
    ("rho negative", _with(["material", "rho"], -7850), "material.rho"),
    ("rho string", _with(["material", "rho"], "steel"), "material.rho"),
    ("nu too large", _with(["material", "nu"], 0.5), "material.nu"),
    ("nu too small", _with(["material", "nu"], -1.0), "material.nu"),
    ("diameter zero", _with(["section", "diameter"], 0.0), "section.diameter"),
    ("tube inner >= outer", _with(["section"], {"shape": "tube", "outer_diameter": 0.01, "inner_diameter": 0.01}),
     "section.inner_diameter"),
    ("rectangle height negative", _with(["section"], {"shape": "rectangle", "width": 0.01, "height": -0.002}),
     "section.height"),
    ("generic Iz zero", _with(["section"], {"A": 1e-4, "Iy": 1e-9, "Iz": 0.0, "J": 1e-9}), "section.Iz"),
    ("unknown shape", _with(["section"], {"shape": "hexagon", "diameter": 0.01}), "section.shape"),
    ("clamp outside", _with(["clamps"], [0.5]), "clamps[0]"),
    ("clamp negative", _with(["clamps"], [-0.01]), "clamps[0]"),
    ("mass outside", _with(["point_masses"], [{"s": 0.31, "mass": 1.0}]), "point_masses[0].s"),
    ("mass non-positive", _with(["point_masses"], [{"s": 0.1, "mass": 0.0}]), "point_masses[0].mass"),
    ("unknown field", _with(["colour"], "red"), "colour"),
    ("unknown section field", _with(["section", "radius"], 0.004), "section.radius"),
    ("unknown material field", _with(["material", "G"], 80e9), "material.G"),
    ("unknown mass field", _with(["point_masses"], [{"s": 0.1, "mass": 1.0, "inertia": 2}]),
     "point_masses[0].inertia"),
    ("schema version", _with(["schema_version"], 2), "schema_version"),
]


@pytest.mark.parametrize("label, data, field", BAD, ids=[b[0] for b in BAD])
def test_bad_scene_names_the_field(label, data, field):
    with pytest.raises(ParameterError) as info:
        scene_from_dict(data)
    assert info.value.parameter == field
    assert str(info.value).startswith(field + ":")


@pytest.mark.parametrize("label, data, field", BAD[:1] + BAD[5:7] + BAD[17:18] + BAD[21:22],
                         ids=[b[0] for b in BAD[:1] + BAD[5:7] + BAD[17:18] + BAD[21:22]])
def test_cli_exits_2_with_the_field_named(tmp_path, capsys, label, data, field):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    assert cli_main(["modal", str(path)]) == 2
    err = capsys.readouterr().err
    assert field in err and "Traceback" not in err


def test_cli_rejects_unknown_boundary_and_missing_scene(capsys):
    with pytest.raises(SystemExit) as info:
        cli_main(["modal", "spatial_double_L", "--boundary", "XYZ"])
    assert info.value.code == 2
    assert "--boundary" in capsys.readouterr().err
    assert cli_main(["modal", "no_such_scene_or_file"]) == 2
    assert "scene" in capsys.readouterr().err


def test_unknown_boundary_in_library_and_fxf_on_single_segment():
    scene = load_scene("spatial_double_L")
    with pytest.raises(ParameterError, match="boundary"):
        build_beam_model(scene, "XYZ", 2)
    rod = scene_from_dict({**GOOD, "points": [[0, 0, 0], [1, 0, 0]]})
    with pytest.raises(ParameterError, match="boundary"):
        build_beam_model(rod, "FXF_mid", 2)


def test_invalid_json_file_is_reported(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{not json")
    with pytest.raises(ParameterError, match="not valid JSON"):
        load_scene(path)


def test_builtin_scenes_load_and_are_valid():
    assert {"spatial_double_L", "inclined_beam", "c_section"} <= set(builtin_scene_names())
    for name in builtin_scene_names():
        scene = load_scene(name)
        assert scene.name == name and len(scene.points) == 4


def test_section_constants():
    import math
    tube = scene_from_dict(_with(["section"], {"shape": "tube", "outer_diameter": 0.02, "inner_diameter": 0.01}))
    assert tube.section.A == pytest.approx(math.pi * (0.02**2 - 0.01**2) / 4)
    assert tube.section.J == pytest.approx(math.pi * (0.02**4 - 0.01**4) / 32)
    rect = scene_from_dict(_with(["section"], {"shape": "rectangle", "width": 0.02, "height": 0.01}))
    assert rect.section.Iz == pytest.approx(0.02 * 0.01**3 / 12)   # about z_bar: height cubed
    assert rect.section.Iy == pytest.approx(0.01 * 0.02**3 / 12)
    # Saint-Venant torsion constant of a 2:1 rectangle: 0.229 a b^3 (Roark, table 10.7 beta = 0.229)
    assert rect.section.J == pytest.approx(0.229 * 0.02 * 0.01**3, rel=0.01)


def test_clamps_and_point_masses_get_mesh_nodes_and_mass():
    scene = scene_from_dict({**GOOD, "clamps": [0.05], "point_masses": [{"s": 0.2537, "mass": 0.3}]})
    model = build_beam_model(scene, "scene", 2)
    assert 0.05 in model.mesh.node_s.round(12) and 0.2537 in model.mesh.node_s.round(12)
    assert model.clamped_nodes.size == 1
    import numpy as np
    ones_x = np.zeros(model.n_dof)
    ones_x[0::6] = 1.0
    # rounding: local entries 7 (test_beam_element), C_bar M C_bar^T as a 144-term einsum, 2 elements and a point
    # mass per node, the sparse product and the dot: gamma(n) times the terms, sum_e |C|^T t |M_tt| |C|^T t <= 3 m_e
    # (|C_ij| <= 1; the translational entries of the local mass are positive and sum to 3 m_e); the closed-form
    # total_mass <= gamma(10) relative (positive terms)
    from error_bounds import gamma
    n = 7 + 146 + 3 + int(np.diff(model.M.tocsr().indptr).max()) + model.n_dof
    bound = gamma(n) * 3 * scene.total_mass + gamma(10) * scene.total_mass
    assert abs(ones_x @ model.M @ ones_x - scene.total_mass) <= bound
    assert scene.total_mass == pytest.approx(7850 * np.pi * 0.008**2 / 4 * 0.3 + 0.3)


def test_cli_json_prints_exactly_one_object():
    out = subprocess.run([sys.executable, "-m", "flexfmu", "modal", "spatial_double_L", "--boundary", "XFF",
                          "--json"], capture_output=True, text=True, check=True).stdout
    data = json.loads(out)
    assert data["boundary"] == "XFF" and data["converged"] is True
    assert isinstance(data["n_dof"], int) and len(data["frequencies_hz"]) == 6
    assert data["frequencies_hz"][0] == pytest.approx(38.8667, rel=0.03)
