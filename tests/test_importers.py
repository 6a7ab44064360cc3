"""Model files -> Structure (flexfmu.importers): solid meshes through meshio and scikit-fem, Nastran decks.

References independent of the code under test: the Timoshenko cantilever's closed-form frequency equation,
exact strain energies of linear displacement fields (patch test), rho * volume, rigid-body modes, and the
same model written by hand or by meshio in other formats (tests/reference/importers/README.md).
The meshes are generated here from a structured lattice with numpy, in meshio's (VTK's) node order.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as sla
from scipy.optimize import brentq

import flexfmu
from flexfmu.errors import ModelFileError, ParameterError
from flexfmu.importers import load_structure, node_set

meshio = pytest.importorskip("meshio")
REFERENCE = __import__("pathlib").Path(__file__).parent / "reference" / "importers"
STEEL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}


def _assembly_bounds(s, n_el_nodes=20, elements_per_node=24, n_qp=27):
    """Entrywise bounds on the rounding of s.K and s.M against the exact FE matrices of the same mesh (each of two
    implementations, unit systems or files carries this much): (K bound, M bound) as functions of (row, col).

    Both are sums of positive semi-definite element Gram contributions, so the |terms| behind A_ij add up to
    <= sqrt(A_ii A_jj) (Cauchy-Schwarz), for K times (2 + 3 lam/mu) (|eps|^2, div^2 <= 3 |grad|^2, K_ii >= mu int
    |grad N|^2).  Roundings: the Jacobian sum_a x_a dN_a relative to its terms, g = max|x| / h_min times n_el_nodes;
    gradients J^-T grad N relative to |grad| <= kappa^2 (10 + n_el_nodes g), kappa the largest corner-Jacobian
    condition number; |det J| relative <= 6 kappa^3 gamma(3 n_el_nodes g) (permanent / det); quadrature n_qp * 9
    terms; elements per node; unit conversions (4)."""
    from error_bounds import gamma
    x = np.asarray(s.nodes, float)
    spacing = min(np.diff(np.unique(x[:, k])).min() for k in range(3))
    g = np.abs(x).max() / spacing
    kappa = np.ptp(x, axis=0).max() / spacing                # corner Jacobians of a box mesh: <= extent / spacing
    common = n_qp * 9 + 2 + elements_per_node + 4
    ops_k = kappa**2 * (10 + n_el_nodes * g) + common
    ops_m = 6 * kappa**3 * 3 * n_el_nodes * g + common
    lam = STEEL["E"] * STEEL["nu"] / ((1 + STEEL["nu"]) * (1 - 2 * STEEL["nu"]))
    mu = STEEL["E"] / (2 * (1 + STEEL["nu"]))
    dk, dm = np.sqrt(np.abs(s.K.diagonal())), np.sqrt(np.abs(s.M.diagonal()))
    return (lambda i, j: gamma(ops_k) * (2 + 3 * lam / mu) * dk[i] * dk[j],
            lambda i, j: gamma(ops_m) * dm[i] * dm[j])


def _within_assembly_bounds(a, b):
    """|a.K - b.K| and |a.M - b.M| entrywise within the sum of both matrices' _assembly_bounds."""
    ka, ma = _assembly_bounds(a)
    kb, mb = _assembly_bounds(b)
    for A, B, fa, fb in ((a.K, b.K, ka, kb), (a.M, b.M, ma, mb)):
        d = (A - B).tocoo()
        if not np.all(np.abs(d.data) <= fa(d.row, d.col) + fb(d.row, d.col)):
            return False
    return True

# ----------------------------------------------------------------------------------------- meshes
# VTK hexahedron: corners on a doubled lattice (edge nodes at odd lattice coordinates).
HEX_CORNERS = np.array([(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 2), (2, 0, 2), (2, 2, 2), (0, 2, 2)])
HEX_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7))
HEX_FACES = ((0, 3, 7, 4), (1, 2, 6, 5), (0, 1, 5, 4), (3, 2, 6, 7), (0, 1, 2, 3), (4, 5, 6, 7))
KUHN_TETS = ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6))
TET_EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))


def box_mesh(cell_type: str, divisions, size):
    """(points, cells) of a box [0, size] split into divisions hexahedra (tetra: 6 Kuhn tetrahedra each)."""
    n = np.asarray(divisions)
    shape = 2 * n + 1
    base = np.stack(np.meshgrid(*(np.arange(k) for k in n), indexing="ij"), -1).reshape(-1, 3) * 2
    corners = base[:, None, :] + HEX_CORNERS[None]
    if cell_type.startswith("hexahedron"):
        local = [corners]
        if cell_type in ("hexahedron20", "hexahedron27"):
            local.append(np.stack([(corners[:, a] + corners[:, b]) // 2 for a, b in HEX_EDGES], 1))
        if cell_type == "hexahedron27":
            local.append(np.stack([corners[:, list(f)].sum(1) // 4 for f in HEX_FACES], 1))
            local.append(corners.sum(1)[:, None] // 8)
    else:
        tets = np.concatenate([corners[:, list(k)] for k in KUHN_TETS])
        local = [tets]
        if cell_type == "tetra10":
            local.append(np.stack([(tets[:, a] + tets[:, b]) // 2 for a, b in TET_EDGES], 1))
    lattice = np.concatenate(local, 1)
    ids = (lattice[..., 0] * shape[1] + lattice[..., 1]) * shape[2] + lattice[..., 2]
    used, cells = np.unique(ids, return_inverse=True)
    ijk = np.stack(np.unravel_index(used, tuple(shape)), -1)
    return ijk / (2 * n) * np.asarray(size, float), cells.reshape(ids.shape)


def write_gmsh22(path, points, cell_type, cells, clamp_nodes):
    """gmsh 2.2 file: the volume cells (physical "body") and the clamp nodes as vertices (physical "clamp")."""
    mesh = meshio.Mesh(points, [(cell_type, cells), ("vertex", clamp_nodes[:, None])],
                       cell_data={"gmsh:physical": [np.full(len(cells), 1), np.full(len(clamp_nodes), 2)],
                                  "gmsh:geometrical": [np.full(len(cells), 1), np.full(len(clamp_nodes), 1)]},
                       field_data={"body": np.array([1, 3]), "clamp": np.array([2, 0])})
    meshio.write(path, mesh, file_format="gmsh22")
    return path


def clamped(structure, dofs):
    keep = np.setdiff1d(np.arange(structure.n_dof), dofs)
    return structure.K[keep][:, keep].tocsc(), structure.M[keep][:, keep].tocsc()


def lowest_frequencies(K, M, k):
    w = sla.eigsh(K, k=k, M=M, sigma=-1.0, which="LM", return_eigenvectors=False)
    return np.sort(np.sqrt(np.abs(w))) / (2 * np.pi)


# ----------------------------------------------------------------------------------------- references
def timoshenko_cantilever_hz(E, nu, rho, length, h):
    """First bending frequency of a clamped-free Timoshenko beam with a square h x h section: the root of the
    closed-form frequency equation (T. C. Huang, J. Appl. Mech. 28, 1961; Han, Benaroya & Wei, J. Sound Vib.
    225, 1999), shear coefficient 10 (1 + nu) / (12 + 11 nu) (Cowper)."""
    r2 = h**2 / 12 / length**2
    s2 = 2 * (1 + nu) * (12 + 11 * nu) / (10 * (1 + nu)) * r2

    def characteristic(b):
        root = np.sqrt((r2 - s2)**2 + 4 / b**2)
        alpha, beta = np.sqrt(0.5 * (root - (r2 + s2))), np.sqrt(0.5 * (root + (r2 + s2)))
        return (2 + (b**2 * (r2 - s2)**2 + 2) * np.cosh(b * alpha) * np.cos(b * beta)
                - b * (r2 + s2) / np.sqrt(1 - b**2 * r2 * s2) * np.sinh(b * alpha) * np.sin(b * beta)
                ) / np.cosh(b * alpha)

    b = brentq(characteristic, 2.0, 5.0)          # Euler-Bernoulli: b = 1.8751^2 = 3.516
    return b * np.sqrt(E * h**2 / 12 / (rho * length**4)) / (2 * np.pi)


def test_timoshenko_reference_tends_to_euler_bernoulli():
    eb = 1.875104069**2 / (2 * np.pi) * np.sqrt(2.1e11 * 0.05**2 / 12 / 7850.0)
    assert timoshenko_cantilever_hz(2.1e11, 0.3, 7850.0, 1.0, 0.05) < eb
    assert timoshenko_cantilever_hz(2.1e11, 0.3, 7850.0, 100.0, 0.05) * 100.0**2 == pytest.approx(eb, rel=1e-6)


# ----------------------------------------------------------------------------------------- convergence
LENGTH, HEIGHT = 1.0, 0.05          # L / h = 20
REFINEMENTS = {                     # uniform refinement; quadratic meshes need fewer cells
    "hexahedron": [(10, 1, 1), (20, 2, 2), (40, 4, 4)],
    "tetra": [(10, 1, 1), (20, 2, 2), (40, 4, 4)],
    "hexahedron20": [(4, 1, 1), (8, 1, 1), (16, 2, 2)],
    "hexahedron27": [(4, 1, 1), (8, 1, 1), (16, 2, 2)],
    "tetra10": [(4, 1, 1), (8, 1, 1), (16, 2, 2)],
}
# Error bounds on the finest mesh, measured (finest error in brackets) with the 3-D solid's own limit
# ~0.3 % above Timoshenko (a fully clamped end face also stops the section's Poisson contraction):
# linear hexahedra lock in bending [5.6 %], linear tetrahedra lock more [18.5 %].
FINEST_BOUND = {"hexahedron": 0.07, "tetra": 0.20, "hexahedron20": 0.01, "hexahedron27": 0.01, "tetra10": 0.01}


@pytest.fixture(scope="module")
def cantilever_errors(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cantilever")
    reference = timoshenko_cantilever_hz(STEEL["E"], STEEL["nu"], STEEL["rho"], LENGTH, HEIGHT)
    errors = {}
    for cell_type, meshes in REFINEMENTS.items():
        rows = []
        for divisions in meshes:
            points, cells = box_mesh(cell_type, divisions, (LENGTH, HEIGHT, HEIGHT))
            path = write_gmsh22(folder / f"{cell_type}_{divisions[0]}.msh", points, cell_type, cells,
                                np.flatnonzero(points[:, 0] == 0.0))
            s = load_structure(path, material=STEEL)
            clamp = node_set(s, "clamp")
            f = lowest_frequencies(*clamped(s, (3 * clamp[:, None] + np.arange(3)).ravel()), 2)
            if cell_type.startswith("hexahedron"):                # square section, symmetric mesh: a pair
                assert f[1] == pytest.approx(f[0], rel=1e-6)
            rows.append((s.n_dof, f[0], (f[0] - reference) / reference))
        errors[cell_type] = rows
    print(f"\nfirst bending frequency of a clamped steel bar 1 x 0.05 x 0.05 m, Timoshenko {reference:.4f} Hz")
    for cell_type, rows in errors.items():
        print(f"  {cell_type:13s}" + "".join(f"  {n:6d} DOFs {f:8.4f} Hz {e:+.2e}" for n, f, e in rows))
    return errors


@pytest.mark.parametrize("cell_type", list(REFINEMENTS))
def test_cantilever_frequency_converges_to_timoshenko(cantilever_errors, cell_type):
    errors = [e for _, _, e in cantilever_errors[cell_type]]
    assert all(e > 0 for e in errors)                          # conforming displacement FE: from above
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < FINEST_BOUND[cell_type]


def test_quadratic_cells_converge_much_faster_than_linear(cantilever_errors):
    # with fewer DOFs (1503 to 2475 vs 3075) the quadratic error is 8 to 11 times smaller (measured)
    linear = min(cantilever_errors[t][2][2] for t in ("hexahedron", "tetra"))
    for cell_type in ("hexahedron20", "hexahedron27", "tetra10"):
        n_dof, _, error = cantilever_errors[cell_type][2]
        assert n_dof < cantilever_errors["hexahedron"][2][0]
        assert error < linear / 5


# ----------------------------------------------------------------------------------------- exactness
@pytest.mark.parametrize("cell_type", list(REFINEMENTS))
def test_patch_test_and_mass_on_a_distorted_mesh(tmp_path, cell_type, rng):
    """u = A x: the strain energy u.K.u / 2 is V (lambda tr(eps)^2 + 2 mu eps:eps) / 2 exactly on any mesh
    whose cells reproduce linear fields; rigid motions cost nothing; the total mass is rho V.  Every DOF
    mapped to a wrong node or component breaks these."""
    points, cells = box_mesh(cell_type, (3, 2, 2), (0.3, 0.2, 0.1))
    inner = np.all((points > 1e-9) & (points < np.array([0.3, 0.2, 0.1]) - 1e-9), axis=1)
    step = 0.025                                                 # the smallest node spacing (z, quadratic)
    points = points + inner[:, None] * rng.uniform(-0.2, 0.2, points.shape) * step   # curved quadratic cells too
    meshio.write(tmp_path / "box.vtu", meshio.Mesh(points, [(cell_type, cells)]))
    s = load_structure(tmp_path / "box.vtu", material=STEEL)
    A = rng.standard_normal((3, 3)) * 1e-3
    u = (s.nodes @ A.T).ravel()
    eps = 0.5 * (A + A.T)
    lam = STEEL["E"] * STEEL["nu"] / ((1 + STEEL["nu"]) * (1 - 2 * STEEL["nu"]))
    mu = STEEL["E"] / (2 * (1 + STEEL["nu"]))
    volume = 0.3 * 0.2 * 0.1
    assert u @ (s.K @ u) == pytest.approx(volume * (lam * np.trace(eps)**2 + 2 * mu * np.sum(eps * eps)), rel=1e-10)
    W = np.array([[0, -1, 2], [1, 0, -3], [-2, 3, 0]]) * 1e-3               # infinitesimal rotation
    rigid = (s.nodes @ W.T + np.array([1.0, -2.0, 0.5])).ravel()
    assert np.abs(s.K @ rigid).max() < 1e-9 * np.abs(s.K).max() * np.abs(rigid).max()
    for j in range(3):
        t = np.zeros(s.n_dof)
        t[j::3] = 1.0
        assert t @ (s.M @ t) == pytest.approx(STEEL["rho"] * volume, rel=1e-10)


# ----------------------------------------------------------------------------------------- formats
NASTRAN_ORDER = {  # Nastran's node order as meshio (VTK) indices: CHEXA G9-G12 bottom, G13-G16 vertical, G17-G20 top
    "hexahedron": list(range(8)), "hexahedron20": list(range(12)) + list(range(16, 20)) + list(range(12, 16)),
    "tetra": list(range(4)), "tetra10": list(range(10)),
}


def _fixed(value) -> str:
    text = f"{value:.6g}"
    text = text if ("." in text or "e" in text) else text + "."   # a Nastran real has a decimal point
    assert len(text) <= 8 and float(text) == value
    return f"{text:>8s}"


def write_bdf(path, points, cell_type, cells, clamp, *, scale=1.0, material=STEEL, free_field=False):
    """A Nastran deck by hand: GRID, CTETRA / CHEXA (continuations), PSOLID, MAT1, SPC1, in fixed small
    field or free field; coordinates times ``scale``."""
    card = "CTETRA" if cell_type.startswith("tetra") else "CHEXA"
    lines = ["SOL 103", "CEND", "SPC = 7", "BEGIN BULK"]

    def emit(fields):
        if free_field:                          # continuation lines start with an empty field
            lines.append(",".join(str(f) for f in fields[:9]))
            lines.extend("," + ",".join(str(f) for f in fields[i:i + 8]) for i in range(9, len(fields), 8))
            return
        head, rest = fields[:9], fields[9:]
        lines.append(head[0].ljust(8) + "".join(_fixed(f) if isinstance(f, float) else f"{f:>8}" for f in head[1:]))
        while rest:
            chunk, rest = rest[:8], rest[8:]
            lines.append(" " * 8 + "".join(f"{f:>8}" for f in chunk))

    for i, p in enumerate(points * scale):
        emit(["GRID", i + 1, "", *(float(v) for v in p)])
    for e, c in enumerate(cells):
        emit([card, e + 1, 3, *(int(n) + 1 for n in c[NASTRAN_ORDER[cell_type]])])
    emit(["PSOLID", 3, 4])
    emit(["MAT1", 4, material["E"], "", material["nu"], material["rho"]])
    emit(["SPC1", 7, 123, *(int(n) + 1 for n in clamp)])
    lines.append("ENDDATA")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("cell_type", ["hexahedron20", "tetra10", "hexahedron", "tetra"])
def test_same_mesh_through_msh_inp_vtu_bdf_gives_same_matrices(tmp_path, cell_type):
    points, cells = box_mesh(cell_type, (4, 1, 1), (1.0, 0.125, 0.0625))
    clamp = np.flatnonzero(points[:, 0] == 0.0)
    models = {"msh": load_structure(write_gmsh22(tmp_path / "m.msh", points, cell_type, cells, clamp),
                                    material=STEEL)}
    meshio.write(tmp_path / "m.inp", meshio.Mesh(points, [(cell_type, cells)], point_sets={"clamp": clamp}))
    models["inp"] = load_structure(tmp_path / "m.inp", material=STEEL)
    meshio.write(tmp_path / "m.vtu", meshio.Mesh(points * 1000.0, [(cell_type, cells)]))
    models["vtu in mm"] = load_structure(tmp_path / "m.vtu", material=STEEL, length_unit="mm")
    models["bdf fixed"] = load_structure(write_bdf(tmp_path / "m.bdf", points, cell_type, cells, clamp))
    mm_steel = {"E": STEEL["E"] * 1e-6, "nu": STEEL["nu"], "rho": STEEL["rho"] * 1e-12}     # MPa, t/mm^3
    models["bdf free, mm"] = load_structure(write_bdf(tmp_path / "mm.nas", points, cell_type, cells, clamp,
                                                      scale=1000.0, material=mm_steel, free_field=True),
                                            length_unit="mm")
    ref = models["msh"]
    clamp_dofs = (3 * clamp[:, None] + np.arange(3)).ravel()
    from error_bounds import gamma
    print(f"\n{cell_type}: max |A - A_msh| / max |A_msh|")
    for label, s in models.items():
        dK = abs(s.K - ref.K).max() / abs(ref.K).max()
        dM = abs(s.M - ref.M).max() / abs(ref.M).max()
        print(f"  {label:13s} K {dK:.1e}  M {dM:.1e}")
        # coordinates: multiples of 1/16 (exact in every file); in mm x 1000 and back: <= 2 roundings
        np.testing.assert_allclose(s.nodes, ref.nodes, rtol=0, atol=gamma(2) * np.abs(ref.nodes).max())
        assert _within_assembly_bounds(s, ref)   # two assemblies (units, node orders) of one mesh: rounding only
    for label in ("bdf fixed", "bdf free, mm"):
        np.testing.assert_array_equal(models[label].constrained_dofs, np.sort(clamp_dofs))
        np.testing.assert_array_equal(models[label].node_sets["SPC_7"], clamp)
    np.testing.assert_array_equal(node_set(ref, "clamp"), clamp)
    np.testing.assert_array_equal(node_set(models["inp"], "clamp"), clamp)


def test_hand_written_gmsh41_and_nastran_files(tmp_path):
    """tests/reference/importers: two unit hexahedra as a gmsh 4.1 file with physical groups (and its model
    JSON) and as a fixed-field Nastran deck in mm, t, s with continuation lines."""
    via_json = load_structure(REFERENCE / "two_hex_gmsh41.json")
    via_sibling = load_structure(REFERENCE / "two_hex_gmsh41.msh")         # finds the JSON beside the mesh
    deck = load_structure(REFERENCE / "two_hex_mm.bdf", length_unit="mm")
    # exact: the sibling lookup reads the same JSON and mesh, the same computation
    assert via_json.name == "two_hex" and abs(via_sibling.K - via_json.K).max() == 0.0
    assert {k: v.tolist() for k, v in via_json.node_sets.items()} == {
        "body": list(range(12)), "clamp": [0, 3, 6, 9], "tip": [11]}
    assert deck.node_sets["SPC_5"].tolist() == [0, 3, 6, 9]
    assert deck.constrained_dofs.tolist() == [d for n in (0, 3, 6, 9) for d in (3 * n, 3 * n + 1, 3 * n + 2)]
    assert _within_assembly_bounds(deck, via_json)      # mm, t, s vs SI: rounding only (_assembly_bounds)
    t = np.tile([1.0, 0.0, 0.0], 12)
    # t^T M t: the entries within _assembly_bounds (terms sqrt(M_ii M_jj)), the product and the dot (36 terms)
    from error_bounds import gamma
    _, bound_m = _assembly_bounds(deck)
    d = np.sqrt(deck.M.diagonal())
    m = deck.M.tocoo()
    scale = float(np.sum(bound_m(m.row, m.col) * t[m.row] * t[m.col]) + gamma(72) * (d @ t) ** 2)
    assert abs(t @ (deck.M @ t) - 7850.0 * 2.0) <= scale
    assert deck.provenance.format == "nastran" and "mm" in deck.provenance.units
    assert via_json.provenance.material == (("E", 2.1e11), ("nu", 0.3), ("rho", 7850.0))
    assert any("1 quad" in note for note in via_json.provenance.notes)      # boundary cells: node sets only


def test_unused_nodes_are_dropped_and_sets_renumbered(tmp_path):
    points, cells = box_mesh("hexahedron", (2, 1, 1), (2.0, 1.0, 1.0))
    stray = np.vstack([[[5.0, 5.0, 5.0]], points])                      # point 0 is in no cell
    meshio.write(tmp_path / "s.inp", meshio.Mesh(stray, [("hexahedron", cells + 1)],
                                                 point_sets={"stray_and_first": np.array([0, 1])}))
    s = load_structure(tmp_path / "s.inp", material=STEEL)
    assert s.n_nodes == points.shape[0]
    np.testing.assert_array_equal(s.nodes, points)
    assert s.node_sets["stray_and_first"].tolist() == [0]
    assert any("1 point(s) in no volume cell dropped" in n for n in s.provenance.notes)


def test_free_solid_has_six_rigid_modes(tmp_path):
    points, cells = box_mesh("hexahedron27", (3, 1, 1), (0.3, 0.05, 0.05))
    meshio.write(tmp_path / "b.vtu", meshio.Mesh(points, [("hexahedron27", cells)]))
    s = load_structure(tmp_path / "b.vtu", material=STEEL)
    f = lowest_frequencies(s.K.tocsc(), s.M.tocsc(), 7)
    assert np.all(f[:6] < 1e-3 * f[6])


def test_reduced_integration_is_softer_for_quadratic_hexahedra(tmp_path):
    points, cells = box_mesh("hexahedron20", (4, 1, 1), (1.0, 0.05, 0.05))
    meshio.write(tmp_path / "b.vtu", meshio.Mesh(points, [("hexahedron20", cells)]))
    full = load_structure(tmp_path / "b.vtu", material=STEEL)
    reduced = load_structure(tmp_path / "b.vtu", material=STEEL, integration="reduced")
    assert abs(reduced.M - full.M).max() == 0.0     # exact: the integration option changes K only, M the same code
    u = np.random.default_rng(3).standard_normal(full.n_dof)
    assert u @ (reduced.K @ u) < u @ (full.K @ u)
    assert reduced.meta["integration"] == "reduced"


# ----------------------------------------------------------------------------------------- .npz, dispatch
def test_npz_keeps_constrained_dofs_node_sets_and_provenance(tmp_path):
    s = load_structure(REFERENCE / "two_hex_mm.bdf", length_unit="mm")
    path = flexfmu.save_structure(tmp_path / "deck.npz", s)
    back = load_structure(path)
    np.testing.assert_array_equal(back.constrained_dofs, s.constrained_dofs)
    assert {k: v.tolist() for k, v in back.node_sets.items()} == {k: v.tolist() for k, v in s.node_sets.items()}
    assert back.provenance == s.provenance
    assert abs(back.K - s.K).max() == 0.0     # exact: a save/load round trip copies the bits


def test_existing_specs_go_through_load_model():
    beam = load_structure("beam:spatial_double_L", elements_per_segment=2)
    assert beam.dofs_per_node == 6 and beam.meta["kind"] == "beam"
    assert beam.provenance.source == "beam:spatial_double_L" and beam.provenance.format == "beam"
    with pytest.raises(ParameterError, match="material"):
        load_structure("beam:spatial_double_L", material=STEEL)


# ----------------------------------------------------------------------------------------- bad input
def _mesh_file(tmp_path, name, cells, points=None):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [1, 1, 0]], float) \
        if points is None else points
    meshio.write(tmp_path / name, meshio.Mesh(points, cells))
    return tmp_path / name


def test_unsupported_volume_cell_is_named(tmp_path):
    path = _mesh_file(tmp_path, "w.vtu", [("wedge", np.array([[0, 1, 2, 3, 4, 5]]))])
    with pytest.raises(ModelFileError, match=r"w\.vtu \[wedge cells\]: volume cell type 'wedge' is not supported "
                                             r"\(allowed: tetra, tetra10, hexahedron, hexahedron20, hexahedron27\)"):
        load_structure(path, material=STEEL)


def test_mesh_without_volume_cells(tmp_path):
    path = _mesh_file(tmp_path, "shell.vtu", [("triangle", np.array([[0, 1, 2]]))])
    with pytest.raises(ModelFileError, match=r"shell\.vtu: no volume cells"):
        load_structure(path, material=STEEL)


def test_missing_material(tmp_path):
    path = _mesh_file(tmp_path, "t.vtu", [("tetra", np.array([[0, 1, 2, 3]]))])
    with pytest.raises(ModelFileError, match=r"t\.vtu \[material\]: no material.*t\.json"):
        load_structure(path)


def test_material_out_of_range():
    with pytest.raises(ParameterError, match=r"material\.nu: 0\.5 is not in \(-1, 0\.5\)"):
        load_structure(REFERENCE / "two_hex_gmsh41.msh", material={"E": 1e9, "nu": 0.5, "rho": 1000.0})


def test_node_set_not_found():
    s = load_structure(REFERENCE / "two_hex_gmsh41.json")
    with pytest.raises(ParameterError, match=r"node_set: 'root' is not a node set of 'two_hex' "
                                             r"\(allowed: body, clamp, tip\)"):
        node_set(s, "root")


def test_missing_file_and_unknown_type(tmp_path):
    with pytest.raises(ParameterError, match=r"source: no such file or model: '.*nope\.msh'"):
        load_structure(tmp_path / "nope.msh", material=STEEL)
    (tmp_path / "part.step").write_text("ISO-10303-21;")
    with pytest.raises(ParameterError, match=r"source: .*part\.step': unknown file type \.step"):
        load_structure(tmp_path / "part.step")


@pytest.mark.parametrize("name, text, expected", [
    ("junk.msh", "$MeshFormat\nnot a mesh\n", r"junk\.msh: cannot be read as .*gmsh.* by meshio"),
    ("junk.inp", "*NODE\n1, a, b\n", r"junk\.inp: cannot be read as abaqus by meshio"),
    ("junk.bdf", "BEGIN BULK\nGRID,1,,x,0.,0.\nENDDATA\n", r"junk\.bdf: cannot be read by pyNastran"),
    ("junk.json", "{not json", r"junk\.json: is not valid JSON"),
])
def test_unparsable_files(tmp_path, name, text, expected):
    (tmp_path / name).write_text(text)
    with pytest.raises(ModelFileError, match=expected) as error:
        load_structure(tmp_path / name, **({"material": STEEL} if name.endswith((".msh", ".inp")) else {}))
    assert "\n" not in str(error.value)                    # one line for the CLI


def test_model_json_errors(tmp_path):
    (tmp_path / "a.json").write_text('{"mesh": "a.msh", "material": {"E": 1e9, "nu": 0.3, "rho": 1}, "units": "mm"}')
    with pytest.raises(ModelFileError, match=r"a\.json \[units\]: unknown key"):
        load_structure(tmp_path / "a.json")
    (tmp_path / "b.json").write_text('{"mesh": "b.msh", "material": {"E": 1e9, "nu": 0.3}}')
    with pytest.raises(ModelFileError, match=r"b\.json \[material\.rho\]: missing"):
        load_structure(tmp_path / "b.json")
    (tmp_path / "c.json").write_text('{"mesh": "c.msh", "material": {"E": 1e9, "nu": 0.3, "rho": 1}, "length_unit": "ft"}')
    with pytest.raises(ModelFileError, match=r"c\.json \[length_unit\]: 'ft' is not a known length unit"):
        load_structure(tmp_path / "c.json")


def test_misordered_quadratic_cell_is_named(tmp_path):
    points, cells = box_mesh("tetra10", (1, 1, 1), (1.0, 1.0, 1.0))
    cells[4, [4, 5]] = cells[4, [5, 4]]                   # two edge nodes swapped in cell 4
    path = tmp_path / "t10.vtu"
    meshio.write(path, meshio.Mesh(points, [("tetra10", cells)]))
    with pytest.raises(ModelFileError, match=r"\[tetra10 4\]: node \d+ \(local node 4\) is not at its edge"):
        load_structure(path, material=STEEL)


NASTRAN_BAD = {
    "missing GRID": ("CTETRA,12,1,1,2,3,99\nPSOLID,1,2\nMAT1,2,2.1e11,,0.3,7850.",
                     r"\[CTETRA 12\]: node 99 is not defined by a GRID card"),
    "missing MAT1": ("CTETRA,12,1,1,2,3,4\nPSOLID,1,2", r"\[PSOLID 1\]: material 2 is missing"),
    "no density": ("CTETRA,12,1,1,2,3,4\nPSOLID,1,2\nMAT1,2,2.1e11,,0.3", r"\[MAT1 2\]: rho is missing or zero"),
    "unsupported element": ("CPENTA,5,1,1,2,3,4,5,6\nPSOLID,1,2\nMAT1,2,2.1e11,,0.3,7850.",
                            r"\[CPENTA 5\]: CPENTA with 6 nodes is not supported \(allowed: CTETRA"),
    "mass element": ("CTETRA,12,1,1,2,3,4\nCONM2,40,4,,1.0\nPSOLID,1,2\nMAT1,2,2.1e11,,0.3,7850.",
                     r"\[CONM2 40\]: CONM2 is not supported"),
    "no elements": ("PSOLID,1,2\nMAT1,2,2.1e11,,0.3,7850.", r"\[CTETRA/CHEXA\]: no elements"),
}


@pytest.mark.parametrize("case", list(NASTRAN_BAD))
def test_nastran_errors_name_the_card(tmp_path, case):
    cards, expected = NASTRAN_BAD[case]
    grids = "\n".join(f"GRID,{i + 1},,{x:.1f},{y:.1f},{z:.1f}" for i, (x, y, z) in
                      enumerate([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1), (1, 1, 0)]))
    path = tmp_path / "deck.bdf"
    path.write_text(f"BEGIN BULK\n{grids}\n{cards}\nENDDATA\n")
    with pytest.raises(ModelFileError, match=r"deck\.bdf " + expected):
        load_structure(path)
