"""flexfmu modal for every importable model: a table or JSON of the natural frequencies, clamped or free, and
a mode-shape PNG.  The reference is analytic: the free-free and clamped-free Euler-Bernoulli frequencies of a
slender solid bar meshed with quadratic hexahedra (hexahedron27, converged to well below the tolerances)."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from error_bounds import gamma

meshio = pytest.importorskip("meshio")

E, NU, RHO = 2.1e11, 0.3, 7850.0
L, B, H = 1.0, 0.02, 0.02           # m: slender (L/h = 50), so shear and Poisson effects stay ~1e-3


def hex27_bar(path, n=(40, 1, 1)):
    """A structured hexahedron27 mesh of [0, L] x [0, B] x [0, H] with node set 'root' (x = 0), as .vtu
    (meshio's node order for hexahedron27 is VTK's)."""
    nx, ny, nz = (2 * k + 1 for k in n)
    axes = [np.linspace(0, L, nx), np.linspace(0, B, ny), np.linspace(0, H, nz)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = np.arange(points.shape[0]).reshape(nx, ny, nz)
    # VTK_TRIQUADRATIC_HEXAHEDRON: 8 corners, 12 edge mid-nodes, 4 side faces (x-, x+, y-, y+), 2 (z-, z+), centre
    corners = [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 2), (2, 0, 2), (2, 2, 2), (0, 2, 2)]
    edges = [(1, 0, 0), (2, 1, 0), (1, 2, 0), (0, 1, 0), (1, 0, 2), (2, 1, 2), (1, 2, 2), (0, 1, 2),
             (0, 0, 1), (2, 0, 1), (2, 2, 1), (0, 2, 1)]
    faces = [(0, 1, 1), (2, 1, 1), (1, 0, 1), (1, 2, 1), (1, 1, 0), (1, 1, 2), (1, 1, 1)]
    cells = []
    for i in range(n[0]):
        for j in range(n[1]):
            for k in range(n[2]):
                cells.append([idx[2 * i + a, 2 * j + b, 2 * k + c] for a, b, c in corners + edges + faces])
    mesh = meshio.Mesh(points, [("hexahedron27", np.array(cells))], point_data={})
    meshio.write(str(path), mesh)
    (path.parent / (path.stem + ".json")).write_text(json.dumps(
        {"mesh": path.name, "material": {"E": E, "nu": NU, "rho": RHO}}))
    return idx[0].ravel()


def flexfmu(*args):
    return subprocess.run([sys.executable, "-m", "flexfmu", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def bar(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bar")
    path = folder / "bar.vtu"
    hex27_bar(path)
    return path


def _bending_hz(beta_l):
    I = B * H ** 3 / 12.0
    return (beta_l / L) ** 2 * np.sqrt(E * I / (RHO * B * H)) / (2 * np.pi)


def _timoshenko_drop(beta_l):
    """Relative lowering of a bending frequency by shear and rotary inertia, to first order:
    (beta r)^2 (1 + E / (kappa G)) / 2, r = H / sqrt(12), kappa = 5/6."""
    r = H / np.sqrt(12.0)
    return (beta_l * r / L) ** 2 * (1.0 + 2.0 * (1.0 + NU) / (5.0 / 6.0)) / 2.0


def test_modal_of_a_free_mesh_gives_the_free_free_beam_frequencies(bar, tmp_path):
    run = flexfmu("modal", bar.with_suffix(".json"), "--modes", 4, "--json", "--plot", tmp_path / "modes.png")
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout.splitlines()[0])
    # mass = mean of 1^T M_xx 1: per M entry <= 27 quadrature terms of ~50 roundings (shape functions, detJ from
    # linspace coordinates, products) and <= 8 elements; M @ 1 (<= 125 a row), the 729-node sum, the mean and
    # RHO L B H: < 1024; the terms sum to <= (5/4)^6 < 4 times the mass (quadratic Lagrange: sum |N_i| <= 5/4
    # a direction); the JSON float is repr, exact
    assert result["kind"] == "free" and result["mass_kg"] == pytest.approx(RHO * L * B * H, rel=4 * gamma(1024),
                                                                           abs=0)
    f = np.array(result["frequencies_hz"])
    # square section: each bending mode twice (y and z); beta_1 L = 4.7300, beta_2 L = 7.8532; the solid sits
    # below Euler-Bernoulli by shear and rotary inertia, by no more than the first-order Timoshenko drop
    beta = np.repeat([4.730041, 7.853205], 2)
    expected = _bending_hz(beta)
    drop = 1.0 - f / expected
    print(f"\nfree-free: {f} Hz vs Euler-Bernoulli {expected} Hz: lower by {drop}, Timoshenko {_timoshenko_drop(beta)}")
    assert np.all(drop > 0) and np.all(drop < _timoshenko_drop(beta))
    assert (tmp_path / "modes.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_modal_of_a_clamped_mesh_gives_the_cantilever_frequencies(bar):
    # the same bar as 20-node hexahedra (the first 20 nodes of each 27) in Abaqus .inp with an NSET at x = 0
    mesh = meshio.read(str(bar))
    root = np.nonzero(np.isclose(mesh.points[:, 0], 0.0))[0]
    inp = bar.with_name("bar_root.inp")
    meshio.write(str(inp), meshio.Mesh(mesh.points, [("hexahedron20", mesh.cells[0].data[:, :20])],
                                       point_sets={"root": root}))
    run = flexfmu("modal", inp, "--material", f"{E},{NU},{RHO}", "--clamp", "root", "--modes", 2, "--json")
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout.splitlines()[0])
    f = np.array(result["frequencies_hz"])
    expected = _bending_hz(np.repeat(1.875104, 2))
    deviation = f / expected - 1.0
    print(f"\nclamped-free: {f} Hz vs Euler-Bernoulli {expected} Hz: {deviation}")
    assert result["kind"] == "clamped"
    # shear lowers it (2.4e-4); the coarse mesh (one element across) raises it: measured +2.8e-3 with these
    # 20-node hexahedra, +1.8e-3 with the 27-node ones and +1.0e-3 at twice the resolution in every direction
    # (converging from above, as a conforming discretisation does)
    assert np.all((deviation > 0) & (deviation < 4e-3))


def test_modal_refuses_scene_options_on_a_mesh_and_mesh_options_on_a_scene(bar):
    run = flexfmu("modal", bar.with_suffix(".json"), "--boundary", "XFF")
    assert run.returncode == 2 and "scene options" in run.stderr
    run = flexfmu("modal", "spatial_double_L", "--material", "1,0.3,1")
    assert run.returncode == 2 and "material" in run.stderr
