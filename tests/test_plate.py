"""The paper's plate (reframe-flexible-body, Section 4): mesh, DOF order, mass, inertia, frequencies.

Reference values: the plate's geometry and material give the mass and inertia exactly (the P2
consistent mass integrates x_i x_j exactly, so the FE values must match to round-off); the
paper's Table 1 gives the frequencies (see docs/plate_mesh_convergence.md for why those are
mesh-dependent).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from error_bounds import U, gamma
from flexfmu.errors import ParameterError
from flexfmu.linalg.modal_basis import mass_properties, modal_basis
from flexfmu.reframe.plate import (CORNERS, DEFAULT_DIVISIONS, PAPER_FREQUENCIES_HZ, plate_fe,
                           paper_plate)

PAPER = json.loads((Path(__file__).resolve().parents[1] / "model" / "flexfmu" / "data"
                    / "paper_tables.json").read_text())["reframe_plate_example"]

RHO, E, NU = 2700.0, 70e9, 0.33
L1, L2, L3 = 1.0, 0.05, 0.01
VOLUME = L1 * L2 * L3
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
MU = E / (2 * (1 + NU))

# Exact rigid-body properties of the stated geometry: plate + 8 x 1 kg corner masses,
# about the centre of mass (0, 0, L3/2).
M_PLATE = RHO * VOLUME
I_EXACT = np.array([
    M_PLATE / 12 * (L2**2 + L3**2) + 8 * ((L2 / 2) ** 2 + (L3 / 2) ** 2),
    M_PLATE / 12 * (L1**2 + L3**2) + 8 * ((L1 / 2) ** 2 + (L3 / 2) ** 2),
    M_PLATE / 12 * (L1**2 + L2**2) + 8 * ((L1 / 2) ** 2 + (L2 / 2) ** 2),
])


@pytest.fixture(scope="module")
def coarse():
    return paper_plate((10, 2, 1))


def _field(structure, fun):
    """DOF vector (node by node x, y, z) of the displacement field fun(nodes) -> (N, 3)."""
    return np.asarray(fun(structure.nodes), dtype=float).reshape(-1)

# --------------------------------------------------------------------------- rounding bounds
# Roundings behind one entry of the P2 mass matrix: a quadrature term w |det J| N_i N_j (det of a Jacobian from the
# rounded vertices: gamma(12), the box split's Jacobians being triangular, permanent = |det|; 3 products), the sum
# over <= 11 points (intorder 4), over <= 12 elements per node, the density, the symmetrisation, a corner mass.
M_ENTRY = 12 + 3 + 11 + 12 + 1 + 1 + 1
# The stiffness: gradients J^-T grad N with the inverse Jacobian's relative error <= kappa(J) gamma(10), relative to
# |G| <= kappa(J)^2 gamma(10) (kappa <= 26 on these meshes, measured by _max_jacobian_condition), the 36-term Gram
# products, the two form terms, <= 12 elements, the permutation (exact) and the symmetrisation.
K_ENTRY_EXTRA = 36 + 2 + 12 + 1


def _gram_scale(A, u, v=None):
    """sum_ij sqrt(A_ii A_jj) |u_i| |v_j| over the pattern of A.  A is a sum of positive semi-definite element Gram
    contributions, so the |terms| summed into A_ij add up to <= sqrt(A_ii A_jj) (Cauchy-Schwarz): this is the size of
    the terms behind u^T A v before cancellation (the P2 mass has negative entries)."""
    v = u if v is None else v
    P = A.tocsr(copy=True)
    P.data[:] = 1.0
    d = np.sqrt(np.abs(A.diagonal()))
    return float((d * np.abs(u)) @ (P @ (d * np.abs(v))))


def _form_bound(A, u, v=None, entry=M_ENTRY):
    """|fl(u^T A v) - u^T A v| with A's entries as assembled (``entry`` roundings each, relative to the Gram terms),
    the sparse product (row length) and the dot product (n_dof terms), and u, v within gamma(2) (node coordinates:
    grid points and midpoints, one rounding each) [ASNA 3.1, 3.5]."""
    row = int(np.diff(A.tocsr().indptr).max())
    return gamma(entry + row + A.shape[0] + 2 * 2) * _gram_scale(A, u, v)


def _max_jacobian_condition(divisions):
    mesh = plate_fe(divisions)[0]
    J = np.stack([mesh.p[:, mesh.t[k]] - mesh.p[:, mesh.t[0]] for k in (1, 2, 3)], axis=1).transpose(2, 0, 1)
    return float(np.linalg.cond(J).max())


# --------------------------------------------------------------------------- DOF order
def test_node_order_matches_scikit_fem_dof_locations():
    mesh, basis, nodes, perm = plate_fe((6, 2, 2))
    assert nodes.shape == (mesh.p.shape[1] + mesh.edges.shape[1], 3)
    assert perm.size == basis.N == 3 * nodes.shape[0]
    # scikit-fem DOF perm[3 i + j] sits at node i.  doflocs = A X + b (affine map, A = p_k - p_0 one rounding, a
    # 3-term product plus b): within gamma(5) (|A||X| + |b|) <= 3 gamma(5) max|p| (barycentric X, sum <= 1) of the
    # exact point; nodes: vertices exactly, midpoints one rounding, gamma(1) max|p|.
    bound = (3 * gamma(5) + gamma(1)) * np.abs(mesh.p).max()
    np.testing.assert_allclose(basis.doflocs[:, perm].T, np.repeat(nodes, 3, axis=0), rtol=0, atol=bound)


def test_node_order_maps_skfem_vector_field_components():
    """A linear vector field projected by scikit-fem, read through perm, is A x + b at each node."""
    from skfem import Basis

    mesh, basis, nodes, perm = plate_fe((6, 2, 2))
    # plate_fe's basis integrates only to degree 2 (enough for K); an L2 projection needs degree 4.
    basis = Basis(mesh, basis.elem, intorder=4)
    A = np.array([[1.0, 2.0, 3.0], [-4.0, 5.0, 6.0], [7.0, -8.0, 9.0]])
    b = np.array([0.1, -0.2, 0.3])
    u_skfem = basis.project(lambda x: np.einsum("ij,j...->i...", A, x) + b[:, None, None])
    np.testing.assert_allclose(u_skfem[perm].reshape(-1, 3), nodes @ A.T + b, atol=1e-9)


@pytest.mark.parametrize("field, energy_density", [
    (lambda x: np.column_stack([1e-3 * x[:, 0], 0 * x[:, 0], 0 * x[:, 0]]), 0.5 * (LAM + 2 * MU) * 1e-6),
    (lambda x: np.column_stack([0 * x[:, 0], 0 * x[:, 0], 1e-3 * x[:, 2]]), 0.5 * (LAM + 2 * MU) * 1e-6),
    (lambda x: np.column_stack([1e-3 * x[:, 2], 0 * x[:, 0], 0 * x[:, 0]]), 0.5 * MU * 1e-6),
    (lambda x: np.column_stack([0 * x[:, 0], 1e-3 * x[:, 0], 0 * x[:, 0]]), 0.5 * MU * 1e-6),
], ids=["stretch_x", "stretch_z", "shear_xz", "shear_xy"])
def test_uniform_strain_energy(coarse, field, energy_density):
    """K in node-by-node x, y, z order: uniform strain fields give the analytic strain energy."""
    u = _field(coarse, field)
    assert 0.5 * u @ (coarse.K @ u) == pytest.approx(energy_density * VOLUME, rel=1e-10)


def test_rigid_motion_has_no_strain_energy(coarse):
    theta, a = np.array([1e-3, -2e-3, 3e-3]), np.array([1.0, 2.0, 3.0])
    u = _field(coarse, lambda x: a + np.cross(theta, x))
    # K u = 0 in exact arithmetic.  Rounding: the product gamma(row) |K||u|; u = a + theta x x within gamma(4)
    # (|a| + |theta||x|) (3 terms, rounded midpoints): |K| |du|; K's entries within gamma(kappa^2 10 + K_ENTRY_EXTRA)
    # of the Gram terms, whose size per entry is <= (2 + 3 lam/mu) sqrt(K_ii K_jj) (|eps|^2, div^2 <= 3 |grad|^2 and
    # K_ii >= mu int |grad N|^2 for a one-component field): _gram_scale, row by row.
    K = coarse.K.tocsr()
    kappa = _max_jacobian_condition((10, 2, 1))
    du = gamma(4) * (np.abs(a).sum() + np.abs(theta).sum() * np.abs(coarse.nodes).max())
    P = K.copy()
    P.data[:] = 1.0
    d = np.sqrt(K.diagonal())
    entry = gamma(kappa**2 * 10 + K_ENTRY_EXTRA) * (2 + 3 * LAM / MU) * d * (P @ (d * np.abs(u)))
    row = int(np.diff(K.indptr).max())
    bound = gamma(row) * (abs(K) @ np.abs(u)) + (abs(K) @ np.full(u.size, du)) + entry
    assert np.all(np.abs(K @ u) <= bound)


@pytest.mark.parametrize("component, expected", [
    (0, RHO * L2 * L3 * L1**3 / 12 + 8 * 0.5**2),                    # u = (x, 0, 0)
    (1, RHO * L1 * L3 * L2**3 / 12 + 8 * 0.025**2),                  # u = (0, y, 0)
    (2, RHO * L1 * L2 * L3**3 / 3 + 4 * 0.01**2),                    # u = (0, 0, z), 4 top corners
])
def test_mass_matrix_second_moments(coarse, component, expected):
    u = np.zeros(coarse.n_dof)
    u[component::3] = coarse.nodes[:, component]
    # P2 mass integrates x_i x_j exactly: rounding only, _form_bound; the closed form <= 10 roundings of positive terms
    assert abs(u @ (coarse.M @ u) - expected) <= _form_bound(coarse.M, u) + gamma(10) * expected


# --------------------------------------------------------------------------- corners, meta
def test_corner_masses_sit_on_vertices(coarse):
    corner_nodes = coarse.meta["corner_nodes"]
    n_vertices = (10 + 1) * (2 + 1) * (1 + 1)
    assert all(i < n_vertices for i in corner_nodes)
    np.testing.assert_array_equal(coarse.nodes[corner_nodes], CORNERS)
    np.testing.assert_allclose(CORNERS * 1000, PAPER["corner_masses"]["corners_mm"])
    bare = paper_plate((10, 2, 1), corner_mass=0.0)
    added = (coarse.M - bare.M).tocoo()
    added.eliminate_zeros()
    dofs = sorted(3 * i + j for i in corner_nodes for j in range(3))
    assert sorted(added.row) == dofs and np.all(added.row == added.col)
    # the plate parts are the same computation (same code path, identical); fl(fl(a + 1) - a) is within
    # gamma(2) (|a| + 1) of 1, a the bare diagonal
    bound = gamma(2) * (np.abs(bare.M.diagonal()[added.row]) + 1.0)
    assert np.all(np.abs(added.data - 1.0) <= bound)


def test_matrices_exactly_symmetric(coarse):
    for A in (coarse.M, coarse.K):     # exact: _symmetric takes (A + A^T) / 2 and a + b == b + a in IEEE arithmetic
        assert abs(A - A.T).max() == 0.0


def test_named_points(coarse):
    pts = coarse.points
    np.testing.assert_array_equal(coarse.nodes[pts["load"]], [-0.5, 0.0, 0.01])
    assert (pts["R"], pts["P"], pts["Q"]) == (pts["P1"], pts["P2"], pts["P3"])
    assert coarse.dofs_per_node == 3 and coarse.n_dof == 3 * coarse.n_nodes


# --------------------------------------------------------------------------- mass, inertia
def test_total_mass(coarse):
    mp = mass_properties(coarse)
    # 1.35 kg plate + 8 kg: t^T M t (_form_bound, + the mean of three: gamma(3)), the decimal 9.35 within u
    for s, want in ((coarse, 9.35), (paper_plate((10, 2, 1), corner_mass=0.0), 1.35)):
        t = np.zeros(s.n_dof)
        t[0::3] = 1.0
        assert abs(mass_properties(s).mass - want) <= _form_bound(s.M, t) + gamma(3) * want + U * want
    # paper: 0.0093 Mg, i.e. 9.35 kg cut to 4 decimals of Mg
    assert 0.0 <= mp.mass - PAPER["totals"]["mass_Mg"] * 1000 < 0.1


def test_principal_inertias(coarse):
    """From M and the node positions via the rigid rotation fields (r^T M r), not a formula."""
    mp = mass_properties(coarse)
    # c = (S_ab - S_ba) / (2 m), S = t^T M r with r entries +-x_k: each S within _form_bound(M, t, |x|); the
    # difference, the division and the mass's own relative error add gamma(3) |c| + |c| rel(m)
    t = np.zeros(coarse.n_dof)
    t[0::3] = 1.0
    x = np.abs(coarse.nodes).max(axis=1).repeat(3)
    rel_m = _form_bound(coarse.M, t) / mp.mass
    bound = 2 * _form_bound(coarse.M, t, x) / (2 * mp.mass) + (gamma(3) + rel_m) * 0.005 + U * 0.005
    np.testing.assert_allclose(mp.center_of_mass, [0.0, 0.0, 0.005], rtol=0, atol=bound)
    np.testing.assert_allclose(mp.principal_moments, I_EXACT, rtol=1e-10)
    np.testing.assert_allclose(mp.principal_axes @ np.diag(mp.principal_moments) @ mp.principal_axes.T,
                               np.diag(I_EXACT), atol=1e-10)
    # the brief's figures (5.49e-3, 2.1127, 2.1178) kg m^2
    np.testing.assert_allclose(mp.principal_moments, [5.49e-3, 2.1127, 2.1178], rtol=5e-4)
    # the paper's figures (Mg mm^2 = 1e-3 kg m^2): I22, I33 to 5e-6; I11 is 0.16% low in the paper
    paper = 1e-3 * np.array([PAPER["totals"][k] for k in ("I11_Mg_mm2", "I22_Mg_mm2", "I33_Mg_mm2")])
    np.testing.assert_allclose(mp.principal_moments[1:], paper[1:], rtol=5e-6)
    assert mp.principal_moments[0] / paper[0] - 1 == pytest.approx(1.57e-3, abs=1e-5)


# --------------------------------------------------------------------------- frequencies
def test_paper_frequency_table_is_transcribed():
    table = [PAPER["flexible_mode_frequencies_Hz"][str(k)] for k in range(7, 17)]
    np.testing.assert_array_equal(PAPER_FREQUENCIES_HZ, table)


def test_default_mesh_frequencies_within_2_percent_of_table_1():
    s = paper_plate()
    assert s.meta["divisions"] == DEFAULT_DIVISIONS
    mb = modal_basis(s, 10)
    diff = mb.frequencies_hz / PAPER_FREQUENCIES_HZ - 1
    assert np.max(np.abs(diff)) < 0.02, np.round(100 * diff, 3)
    t = np.zeros(s.n_dof)
    t[0::3] = 1.0
    assert abs(mb.mass - 9.35) <= _form_bound(s.M, t) + (gamma(3) + U) * 9.35     # as test_total_mass


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("divisions", [(0, 1, 1), (10, 2), (10.0, 2, 1), (1000, 100, 10), "abc", 5])
def test_bad_divisions(divisions):
    with pytest.raises(ParameterError) as err:
        paper_plate(divisions)
    assert err.value.parameter == "divisions"
    assert "nx * ny * nz" in err.value.allowed


@pytest.mark.parametrize("corner_mass", [-1.0, float("nan"), "1"])
def test_bad_corner_mass(corner_mass):
    with pytest.raises(ParameterError) as err:
        paper_plate((4, 1, 1), corner_mass=corner_mass)
    assert err.value.parameter == "corner_mass"


def test_vectorised_stiffness_equals_scikit_fem_linear_elasticity():
    """plate._elasticity_stiffness (batched Gram products) is scikit-fem's linear_elasticity form."""
    from skfem import asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    from flexfmu.reframe.plate import POISSON, YOUNGS_MODULUS, _elasticity_stiffness, plate_fe

    _, basis, _, _ = plate_fe((6, 2, 2))
    lam, mu = lame_parameters(YOUNGS_MODULUS, POISSON)
    reference = asm(linear_elasticity(lam, mu), basis).tocsr()
    ours = _elasticity_stiffness(basis, lam, mu)
    assert ours.shape == reference.shape
    # two orders of the same sums from the same gradients: each within gamma(36 + 2 + elements per entry) of the
    # Gram terms, <= (2 + 3 lam/mu) sqrt(K_ii K_jj) (see test_rigid_motion_has_no_strain_energy); implementations_bound
    from error_bounds import implementations_bound
    n_el = int(np.bincount(basis.element_dofs.ravel()).max())
    diff = (ours - reference).tocoo()             # (entries zero in exact arithmetic may be stored in one only)
    d = np.sqrt(reference.diagonal())
    bound = implementations_bound((2 + 3 * lam / mu), 36 + 2 + n_el) * d[diff.row] * d[diff.col]
    assert np.all(np.abs(diff.data) <= bound)


def test_vectorised_stiffness_in_element_blocks(monkeypatch):
    """The element blocks of the vectorised assembly add up to the one-block matrix."""
    from skfem.models.elasticity import lame_parameters

    from flexfmu.reframe import plate

    _, basis, _, _ = plate.plate_fe((6, 2, 2))
    lam, mu = lame_parameters(plate.YOUNGS_MODULUS, plate.POISSON)
    whole = plate._elasticity_stiffness(basis, lam, mu)
    monkeypatch.setattr(plate, "_ELEMENT_CHUNK", 7)            # 144 elements: 21 blocks, the last partial
    blocks = plate._elasticity_stiffness(basis, lam, mu)
    assert abs(blocks - whole).max() == 0.0   # exact: each element block is the same batched product on the same data
