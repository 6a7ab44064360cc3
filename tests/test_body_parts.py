"""A body in pieces: a clamped model with a part not connected to the clamped nodes is refused (it used to pass
with frequencies 0, ..., 0.00027 Hz and an FMU whose loose part drifts), naming the loose part's nodes, as the
same model is refused as a free body.  The reference is the mesh itself: which nodes the second box has."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from flexfmu.body.build import build_body, node_parts
from flexfmu.body.modes import natural_modes
from flexfmu.errors import ParameterError
from flexfmu.importers import load_structure

meshio = pytest.importorskip("meshio")

STEEL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}


def _box(origin, size=(0.4, 0.04, 0.02), divisions=(10, 2, 1)):
    axes = [np.linspace(o, o + s, d + 1) for o, s, d in zip(origin, size, divisions)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    index = np.arange(points.shape[0]).reshape(*(d + 1 for d in divisions))
    cells = [[c[0, 0, 0], c[1, 0, 0], c[1, 1, 0], c[0, 1, 0], c[0, 0, 1], c[1, 0, 1], c[1, 1, 1], c[0, 1, 1]]
             for c in (index[i:i + 2, j:j + 2, k:k + 2] for i in range(divisions[0]) for j in range(divisions[1])
                       for k in range(divisions[2]))]
    return points, np.array(cells), index


@pytest.fixture(scope="module")
def two_boxes(tmp_path_factory):
    """A bar clamped at its root (node set 'root', x = 0) and a second bar 0.6 m beyond it, touching nothing."""
    first, cells, index = _box((0.0, 0.0, 0.0))
    second, _, _ = _box((1.0, 0.0, 0.0))
    n = first.shape[0]
    path = tmp_path_factory.mktemp("parts") / "two.inp"
    meshio.write(str(path), meshio.Mesh(np.vstack([first, second]), [("hexahedron", np.vstack([cells, cells + n]))],
                                        point_sets={"root": index[0].ravel(), "tip": index[-1].ravel()}))
    return path, n


def test_the_parts_are_the_two_boxes(two_boxes):
    path, n = two_boxes
    s = load_structure(path, material=STEEL)
    count, part = node_parts(s)
    assert count == 2 and np.all(part[:n] == part[0]) and np.all(part[n:] == part[n]) and part[0] != part[n]


def test_a_clamped_body_with_a_loose_part_is_refused_naming_it(two_boxes):
    path, n = two_boxes
    s = load_structure(path, material=STEEL)
    loose = (f"the loose part: {n} node(s) (indices of the model's nodes, 0-based: {n}, {n + 1}, {n + 2}, {n + 3}, "
             f"{n + 4}, ...; the first at (1, 0, 0) m)")
    with pytest.raises(ParameterError) as error:
        natural_modes(s, clamp="root")
    assert error.value.parameter == "clamp" and loose in str(error.value)
    assert "not connected to the clamped nodes (2 parts in all)" in str(error.value)
    with pytest.raises(ParameterError, match="not connected to the clamped nodes") as error:
        build_body(s, interfaces=[{"name": "tip", "point": [0.4, 0.02, 0.01]}], clamp="root", n_modes=3)
    assert loose in str(error.value)
    with pytest.raises(ParameterError, match=r"singular free body: 2 parts not connected to each other; a loose part: "
                                             + str(n)) as error:
        natural_modes(s)                                     # as a free body: the same logic, the same nodes
    assert error.value.parameter == "structure.K"


def test_the_cli_refuses_it_in_one_line(two_boxes, tmp_path):
    path, n = two_boxes
    for command in (["modal", path, "--clamp", "root"],
                    ["export", path, "--clamp", "root", "-o", tmp_path / "Two.fmu", "--modes", "3",
                     "--interface", "tip=tip"]):
        run = subprocess.run([sys.executable, "-m", "flexfmu", *map(str, command), "--material", "2.1e11,0.3,7850"],
                             capture_output=True, text=True, timeout=600)
        assert run.returncode == 2 and len(run.stderr.splitlines()) == 1, run.stderr
        assert f"the loose part: {n} node(s)" in run.stderr and "Traceback" not in run.stderr
    assert not (tmp_path / "Two.fmu").exists()


def test_a_part_held_at_one_node_only_is_refused(tmp_path):
    """A second box apart from the bar, one of its nodes in the clamp set: held in translation, free to turn."""
    first, cells, index = _box((0.0, 0.0, 0.0))
    second, cells2, index2 = _box((0.0, 0.0, 0.0), size=(0.02, 0.04, 0.4), divisions=(1, 2, 10))
    n = first.shape[0]
    points = np.vstack([first, second + [-0.02, 0.0, 0.021]])          # 1 mm above the bar
    root = np.concatenate([index[0].ravel(), [n + int(index2[0, 0, 0])]])
    path = tmp_path / "held_at_one_node.inp"
    meshio.write(str(path), meshio.Mesh(points, [("hexahedron", np.vstack([cells, cells2 + n]))],
                                        point_sets={"root": root}))
    s = load_structure(path, material=STEEL)
    with pytest.raises(ParameterError, match=r"leaves the body free to move \(3 rigid-body motion\(s\) not held; the "
                                             rf"part: {second.shape[0]} node\(s\) \(indices of the model's nodes, "
                                             rf"0-based: {n}, "):
        natural_modes(s, clamp="root")


def test_a_connected_clamped_bar_is_accepted(tmp_path):
    points, cells, index = _box((0.0, 0.0, 0.0))
    path = tmp_path / "bar.inp"
    meshio.write(str(path), meshio.Mesh(points, [("hexahedron", cells)], point_sets={"root": index[0].ravel()}))
    s = load_structure(path, material=STEEL)
    assert node_parts(s)[0] == 1
    assert natural_modes(s, clamp="root", n_modes=1).frequencies_hz[0] > 50.0    # Euler-Bernoulli: ~100 Hz
