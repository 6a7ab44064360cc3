"""What a model file may not get wrong silently: its length unit (never dropped, whatever else is given; a size
implausible in its unit warned about), input nested or scaled beyond what the models resolve (one line naming it
and the allowed range, no traceback), and degenerate cells (refused naming the cell and its nodes).

References independent of the code under test: the mesh's own coordinates scaled by hand, the mass bound of the
bracket's bounding box filled with steel, and the examples' documented results (docs/export.md)."""
from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from flexfmu.errors import ModelFileError, ParameterError
from flexfmu.importers import load_structure
from flexfmu.importers.units import PLAUSIBLE_SIZE, ModelSizeWarning

meshio = pytest.importorskip("meshio")

ROOT = Path(__file__).resolve().parents[1]
BRACKET = ROOT / "examples" / "bracket"
REFERENCE = Path(__file__).parent / "reference" / "importers"
STEEL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}


def flexfmu(*args):
    return subprocess.run([sys.executable, "-m", "flexfmu", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


def hex_box(path, size, divisions=(4, 2, 2), **extra):
    """A structured hexahedral mesh of [0, size] (the file's own numbers) written to ``path``."""
    axes = [np.linspace(0.0, s, d + 1) for s, d in zip(size, divisions)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    index = np.arange(points.shape[0]).reshape(*(d + 1 for d in divisions))
    cells = []
    for i in range(divisions[0]):
        for j in range(divisions[1]):
            for k in range(divisions[2]):
                c = index[i:i + 2, j:j + 2, k:k + 2]
                cells.append([c[0, 0, 0], c[1, 0, 0], c[1, 1, 0], c[0, 1, 0], c[0, 0, 1], c[1, 0, 1], c[1, 1, 1],
                              c[0, 1, 1]])
    meshio.write(str(path), meshio.Mesh(points, [("hexahedron", np.array(cells))], **extra))
    return points, np.array(cells)


# ------------------------------------------------------------------------------------ the length unit
def test_a_given_material_keeps_the_model_json_s_length_unit(tmp_path):
    """A mesh with a model JSON beside it in mm, loaded with a material of its own: the coordinates are still
    scaled from mm, the given material is used, and a length unit given again is refused."""
    points, _ = hex_box(tmp_path / "part.vtu", (80.0, 40.0, 5.0))
    (tmp_path / "part.json").write_text(json.dumps({"mesh": "part.vtu", "material": STEEL, "length_unit": "mm"}))
    aluminium = {"E": 7e10, "nu": 0.33, "rho": 2700.0}
    s = load_structure(tmp_path / "part.vtu", material=aluminium)
    np.testing.assert_array_equal(s.nodes, points * 1e-3)
    assert dict(s.provenance.material) == aluminium
    assert any("replacing part.json's" in note for note in s.provenance.notes)
    # the mass is the aluminium's rho times the volume in m^3 (0.08 x 0.04 x 0.005), to the rounding of the sum
    mass = float(np.ones(s.n_dof) @ (s.M @ np.ones(s.n_dof))) / 3.0
    assert mass == pytest.approx(2700.0 * 0.08 * 0.04 * 0.005, rel=1e-12)
    with pytest.raises(ParameterError, match=r"length_unit: given both as an argument and in .*part\.json"):
        load_structure(tmp_path / "part.vtu", material=aluminium, length_unit="m")


def test_the_bracket_with_material_on_the_command_line_keeps_its_mm(tmp_path):
    """The example bracket through its mesh with --material: its bolt-clamped frequencies are those of its model
    JSON (docs/export.md: f_1 = 474.57 Hz), and it weighs less than its bounding box full of steel (the attack
    found 2.2e8 kg and 0.47 Hz: the mesh read as metres)."""
    run = flexfmu("modal", BRACKET / "bracket.msh", "--material", "2.1e11,0.3,7850", "--clamp", "bolt_1,bolt_2",
                  "--json", "--modes", "2")
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    box = np.ptp(meshio.read(str(BRACKET / "bracket.msh")).points, axis=0) * 1e-3     # mm -> m
    assert 0.0 < result["mass_kg"] <= 7850.0 * np.prod(box)
    assert result["frequencies_hz"][0] == pytest.approx(474.572465, abs=5e-7)          # docs/export.md's 6 decimals
    assert "warning" not in run.stderr


# ------------------------------------------------------------------------------------ an implausible size
def test_a_mm_mesh_read_as_metres_is_warned_about_naming_length_unit(tmp_path):
    hex_box(tmp_path / "part.vtu", (80.0, 40.0, 5.0))
    with pytest.warns(ModelSizeWarning, match=r"part\.vtu: the model is 80 m across .*no length unit given.*"
                                              r"outside the plausible 0\.001 \.\. 10 m.*--length-unit"):
        s = load_structure(tmp_path / "part.vtu", material=STEEL)
    assert any("80 m across" in note for note in s.provenance.notes)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelSizeWarning)
        load_structure(tmp_path / "part.vtu", material=STEEL, length_unit="mm")     # 80 mm: plausible
        load_structure(tmp_path / "part.vtu", material=STEEL, length_unit="m")      # metres said: up to 1 km
    with pytest.warns(ModelSizeWarning, match=r"0\.0008 m across \(largest extent of its nodes; length unit mm\)"):
        hex_box(tmp_path / "tiny.vtu", (0.8, 0.4, 0.05))
        load_structure(tmp_path / "tiny.vtu", material=STEEL, length_unit="mm")
    run = flexfmu("modal", tmp_path / "part.vtu", "--material", "2.1e11,0.3,7850", "--modes", "1")
    assert run.returncode == 0
    lines = [line for line in run.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("flexfmu: warning: part.vtu: the model is 80 m across"), run.stderr


def test_the_plausible_sizes_are_the_documented_ones():
    assert PLAUSIBLE_SIZE == {"assumed": (1e-3, 10.0), "given": (1e-3, 1e3)}


# ------------------------------------------------------------------------------------ deep or extreme input
@pytest.fixture
def deep_json(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text('{"mesh": ' + "[" * 100_000 + "]" * 100_000 + "}")
    return path


def test_a_model_json_nested_100000_deep_is_one_line(deep_json):
    with pytest.raises(ModelFileError, match=r"deep\.json: nests JSON arrays or objects too deeply to read "
                                             r"\(allowed: a model JSON \(nested at most 2 levels\)"):
        load_structure(deep_json)
    for command in (["modal", deep_json], ["export", deep_json, "-o", deep_json.with_name("D.fmu"), "--modes", "2",
                                           "--interface", "a=0,0,0"]):
        run = flexfmu(*command)
        assert run.returncode == 2 and "Traceback" not in run.stderr and len(run.stderr.splitlines()) == 1, run.stderr
        assert "nests JSON arrays or objects too deeply" in run.stderr


def test_a_deep_json_beside_a_mesh_is_not_its_model_json(tmp_path):
    hex_box(tmp_path / "part.vtu", (0.08, 0.04, 0.005))
    (tmp_path / "part.json").write_text("[" * 100_000 + "]" * 100_000)
    assert load_structure(tmp_path / "part.vtu", material=STEEL).n_nodes == 45


@pytest.mark.parametrize("material, name, text", [
    ({"E": 2.1e11, "nu": 0.3, "rho": 1e-300}, "material.rho", r"1e-300 kg/m\^3 is outside 1e-06 \.\. 1e\+06 kg/m\^3"),
    ({"E": 1e-300, "nu": 0.3, "rho": 7850.0}, "material.E", r"1e-300 Pa is outside 1 \.\. 1e\+20 Pa"),
    ({"E": 2.1e11, "nu": 0.3, "rho": 1e300}, "material.rho", r"1e\+300 kg/m\^3 is outside"),
])
def test_a_material_beyond_the_range_models_resolve_is_refused(tmp_path, material, name, text):
    hex_box(tmp_path / "part.vtu", (0.08, 0.04, 0.005))
    with pytest.raises(ParameterError, match=text) as error:
        load_structure(tmp_path / "part.vtu", material=material)
    assert error.value.parameter == name and "density 1e-06 .. 1e+06 kg/m^3" in error.value.allowed
    run = flexfmu("modal", tmp_path / "part.vtu", "--material", ",".join(map(str, material.values())))
    assert run.returncode == 2 and run.stderr.startswith(f"flexfmu: error: {name}: ") and \
        len(run.stderr.splitlines()) == 1, run.stderr


def test_a_mm_deck_read_as_si_is_refused_by_its_density():
    with pytest.raises(ModelFileError, match=r"two_hex_mm\.bdf \[MAT1 30\.rho\]: 7\.85e-09 kg/m\^3 is outside 1e-06 "
                                             r"\.\. 1e\+06 kg/m\^3 \(the deck read in m, N, kg, s \(SI\): is it in "
                                             r"mm-t-s or in-lbf-s\? give its length unit\)"):
        load_structure(REFERENCE / "two_hex_mm.bdf")
    assert load_structure(REFERENCE / "two_hex_mm.bdf", length_unit="mm").n_nodes == 12


def _scene(tmp_path, **changes):
    scene = json.loads((ROOT / "model" / "flexfmu" / "scenes" / "spatial_double_L.json").read_text())
    scene.update(changes)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return path


@pytest.mark.parametrize("changes, name, text", [
    ({"section": {"shape": "rectangle", "width": 1.0, "height": 1e-9}}, "section",
     r"radii of gyration sqrt\(I / A\) from 2\.89e-10 to 0\.289 m on a 0\.45 m rod: too wide for a beam \(allowed: "
     r"sqrt\(max\(Iy, Iz\) / A\) <= 0\.1 x rod length = 0\.045 m and sqrt\(min\(Iy, Iz, J\) / A\) >= rod length / "
     r"1e\+06 = 4\.5e-07 m\)"),
    ({"section": {"shape": "rectangle", "width": 0.01, "height": 1e-9}}, "section",
     r"from 2\.89e-10 to 0\.00289 m on a 0\.45 m rod: 1\.56e\+09 of them long, too thin to resolve"),
    ({"material": {"E": 2e11, "nu": 0.29, "rho": 1e-300}}, "material.rho",
     r"1e-300 kg/m\^3 is outside the range models resolve \(allowed: 1e-06 \.\. 1e\+06 kg/m\^3\)"),
])
def test_a_scene_beyond_what_a_beam_model_resolves_is_refused(tmp_path, changes, name, text):
    from flexfmu.ffr.scene import load_scene

    path = _scene(tmp_path, **changes)
    with pytest.raises(ParameterError, match=text) as error:
        load_scene(path)
    assert error.value.parameter == name
    run = flexfmu("modal", path)
    assert run.returncode == 2 and run.stderr.startswith(f"flexfmu: error: {name}: ") and \
        len(run.stderr.splitlines()) == 1, run.stderr


def test_a_thin_strip_within_the_slenderness_limit_is_accepted(tmp_path):
    """A 10 mm x 10 um strip on the 0.45 m rod (L / r = 1.6e5): a beam the models resolve."""
    from flexfmu.ffr.scene import load_scene
    assert load_scene(_scene(tmp_path, section={"shape": "rectangle", "width": 0.01, "height": 1e-5})).section.A > 0


# ------------------------------------------------------------------------------------ degenerate cells
def _tet_box(tmp_path, extra_point=None, extra_cell=None, name="t.vtu"):
    """The unit cube's six Kuhn tetrahedra plus one more cell (and point)."""
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    cells = [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
    if extra_point is not None:
        points = np.vstack([points, extra_point])
    if extra_cell is not None:
        cells.append(extra_cell)
    meshio.write(str(tmp_path / name), meshio.Mesh(points, [("tetra", np.array(cells))]))
    return tmp_path / name


@pytest.mark.parametrize("case, point, cell, text", [
    ("coplanar nodes", None, [0, 1, 2, 3], r"\[tetra 6\]: is flat: its corners span no volume \(coinciding or "
                                           r"coplanar nodes\); its points 0, 1, 2, 3"),
    ("a repeated node", None, [0, 0, 1, 4], r"\[tetra 6\]: is flat: .*its points 0, 0, 1, 4"),
    ("a sliver 1e-9 thick", [0.4, 0.3, -1e-9], [0, 1, 3, 8],
     # det[e1, e2, e3] = 1e-9 over the longest edge (nodes 1 - 3, sqrt 2) cubed: 3.5e-10
     r"\[tetra 6\]: is nearly flat: the volume at its worst corner is 3\.5e-10 of its longest edge cubed; its "
     r"points 0, 1, 3, 8"),
])
def test_a_degenerate_cell_is_refused_naming_it_without_numpy_warnings(tmp_path, case, point, cell, text):
    path = _tet_box(tmp_path, point, cell)
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")                    # a numpy warning from the assembly would fail here
        with pytest.raises(ModelFileError, match=text) as error:
            load_structure(path, material=STEEL, length_unit="m")
    assert "cells whose every corner spans at least 1e-08 x (longest edge)^3" in error.value.allowed
    run = flexfmu("modal", path, "--material", "2.1e11,0.3,7850")
    assert run.returncode == 2 and len(run.stderr.splitlines()) == 1 and "[tetra 6]" in run.stderr, run.stderr


def test_a_flat_but_not_degenerate_sliver_is_accepted_with_the_same_mass(tmp_path):
    """A sliver 1e-5 thick (its worst corner 1e-5 of its edge cubed) is kept: it adds its own tiny volume."""
    path = _tet_box(tmp_path, [0.4, 0.3, -1e-5], [0, 1, 3, 8])
    s = load_structure(path, material=STEEL, length_unit="m")
    sliver = abs(np.linalg.det(np.array([[1, 0, 0], [0, 1, 0], [0.4, 0.3, -1e-5]]))) / 6.0
    mass = float(np.ones(s.n_dof) @ (s.M @ np.ones(s.n_dof))) / 3.0
    assert mass == pytest.approx(7850.0 * (1.0 + sliver), rel=1e-12)


def test_mirrored_hexahedra_are_accepted_and_folded_ones_refused(tmp_path):
    points, cells = hex_box(tmp_path / "box.vtu", (0.4, 0.1, 0.1))
    reference = load_structure(tmp_path / "box.vtu", material=STEEL)
    mirrored = cells.copy()
    mirrored[3] = cells[3][[4, 5, 6, 7, 0, 1, 2, 3]]            # top and bottom swapped: the same volume
    meshio.write(str(tmp_path / "mirrored.vtu"), meshio.Mesh(points, [("hexahedron", mirrored)]))
    s = load_structure(tmp_path / "mirrored.vtu", material=STEEL)
    assert abs(s.K - reference.K).max() <= 1e-12 * abs(reference.K).max()
    folded = cells.copy()
    folded[3] = cells[3][[0, 1, 3, 2, 4, 5, 7, 6]]              # a bow tie
    meshio.write(str(tmp_path / "folded.vtu"), meshio.Mesh(points, [("hexahedron", folded)]))
    with pytest.raises(ModelFileError, match=r"\[hexahedron 3\]: is folded over itself \(corners of opposite "
                                             r"orientation.*\); its points " + ", ".join(map(str, folded[3]))):
        load_structure(tmp_path / "folded.vtu", material=STEEL)
