"""Rigid-body modes, mass properties and the modal basis (flexfmu.linalg.modal_basis)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.sparse as sp

import flexfmu.linalg.modal_basis as mbm
from flexfmu.errors import ParameterError
from flexfmu.core.io import validate_structure
from flexfmu.linalg.modal_basis import mass_properties, modal_basis, rigid_body_modes
from flexfmu.reframe.plate import paper_plate
from flexfmu.core.structure import Structure


def _skew(r):
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def bushing_chain(n_nodes: int = 12, seed: int = 1) -> Structure:
    """A free-free 6-DOF test structure: nodes on a bent space curve, lumped mass and rotary
    inertia, neighbours joined by bushings (translational spring at the midpoint of the two
    nodes, rotational spring on the relative rotation).  Rigid motion stores no energy exactly.
    """
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, n_nodes)
    nodes = np.column_stack([s, 0.3 * s**2, 0.2 * np.sin(3.0 * s)])
    n_dof = 6 * n_nodes
    masses = 0.5 + rng.random(n_nodes)
    rotary = 1e-3 * (1.0 + rng.random((n_nodes, 3)))
    mdiag = np.zeros(n_dof)
    for i in range(n_nodes):
        mdiag[6 * i:6 * i + 3] = masses[i]
        mdiag[6 * i + 3:6 * i + 6] = rotary[i]
    K = np.zeros((n_dof, n_dof))
    kt, kr = 1e6, 1e3
    for a in range(n_nodes - 1):
        b = a + 1
        mid = 0.5 * (nodes[a] + nodes[b])
        D = np.hstack([-np.eye(3), _skew(mid - nodes[a]), np.eye(3), -_skew(mid - nodes[b])])
        R = np.hstack([np.zeros((3, 3)), -np.eye(3), np.zeros((3, 3)), np.eye(3)])
        Ke = kt * D.T @ D + kr * R.T @ R
        idx = np.r_[6 * a:6 * a + 6, 6 * b:6 * b + 6]
        K[np.ix_(idx, idx)] += Ke
    return Structure(nodes=nodes, dofs_per_node=6, M=sp.diags(mdiag).tocsr(), K=sp.csr_matrix(K),
                     name="bushing chain", meta={"masses": masses, "rotary": rotary})


@pytest.fixture(scope="module")
def small_plate():
    return paper_plate((4, 1, 1))          # a few hundred DOFs: dense path by default


@pytest.fixture(scope="module")
def coarse_plate():
    return paper_plate((20, 2, 1))         # ~2 000 DOFs: sparse path


def _rigid_field(structure, a, theta, x0):
    """Displacement of an infinitesimal rigid motion u = a + theta x (x - x0) (+ rotation DOFs)."""
    dpn = structure.dofs_per_node
    u = np.zeros(structure.n_dof)
    disp = a + np.cross(theta, structure.nodes - x0)
    for j in range(3):
        u[j::dpn] = disp[:, j]
    if dpn == 6:
        for j in range(3):
            u[3 + j::dpn] = theta[j]
    return u


# --------------------------------------------------------------------------- rigid modes
@pytest.mark.parametrize("which", ["plate", "chain"])
def test_rigid_modes_mass_orthonormal_and_strain_free(which, small_plate):
    s = small_plate if which == "plate" else bushing_chain()
    Phi = rigid_body_modes(s)
    assert Phi.shape == (s.n_dof, 6)
    np.testing.assert_allclose(Phi.T @ (s.M @ Phi), np.eye(6), atol=1e-12)
    KPhi = s.K @ Phi
    assert np.max(np.abs(KPhi)) <= 1e-12 * abs(s.K).max() * np.max(np.abs(Phi))


@pytest.mark.parametrize("which", ["plate", "chain"])
@pytest.mark.parametrize("kind", ["translation", "rotation", "both"])
def test_rigid_modes_reproduce_rigid_fields_exactly(which, kind, small_plate):
    s = small_plate if which == "plate" else bushing_chain()
    Phi = rigid_body_modes(s)
    a = np.array([0.3, -1.2, 0.7]) if kind != "rotation" else np.zeros(3)
    theta = np.array([2e-3, -1e-3, 3e-3]) if kind != "translation" else np.zeros(3)
    u = _rigid_field(s, a, theta, x0=np.array([0.1, -0.2, 0.05]))   # any axis point, not the COM
    q = Phi.T @ (s.M @ u)
    np.testing.assert_allclose(Phi @ q, u, rtol=0, atol=1e-12 * np.max(np.abs(u)))


def test_mass_properties_of_point_masses_match_formula():
    s = bushing_chain()
    m, J_rot = s.meta["masses"], s.meta["rotary"]
    c = (m @ s.nodes) / m.sum()
    r = s.nodes - c
    J = sum(mi * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for mi, ri in zip(m, r)) + np.diag(J_rot.sum(axis=0))
    mp = mass_properties(s)
    assert mp.mass == pytest.approx(m.sum(), rel=1e-14)
    np.testing.assert_allclose(mp.center_of_mass, c, atol=1e-14)
    np.testing.assert_allclose(mp.inertia, J, rtol=0, atol=1e-13 * np.abs(J).max())
    mb = modal_basis(s, 0)
    np.testing.assert_allclose(mb.inertia, J, rtol=0, atol=1e-13 * np.abs(J).max())


def test_rigid_transform_maps_rigid_coordinates_to_translation_and_rotation(small_plate):
    mb = modal_basis(small_plate, 0)
    a, theta = np.array([1e-3, 2e-3, -3e-3]), np.array([-1e-3, 4e-3, 2e-3])
    u = _rigid_field(small_plate, a, theta, mb.center_of_mass)
    q = mb.rigid.T @ (small_plate.M @ u)
    np.testing.assert_allclose(mb.rigid_transform @ q, np.r_[a, theta], atol=1e-15)


# --------------------------------------------------------------------------- modal basis
@pytest.mark.parametrize("which", ["small_plate", "coarse_plate", "chain"])
def test_basis_orthonormal_and_stiffness_diagonal(which, request):
    s = bushing_chain() if which == "chain" else request.getfixturevalue(which)
    n = 10
    mb = modal_basis(s, n)
    Psi = mb.shapes
    assert Psi.shape == (s.n_dof, 6 + n)
    assert mb.method == ("sparse" if which == "coarse_plate" else "dense")
    np.testing.assert_allclose(Psi.T @ (s.M @ Psi), np.eye(6 + n), rtol=0, atol=1e-10)
    Kq = Psi.T @ (s.K @ Psi)
    scale = np.abs(Kq).max()
    off = Kq - np.diag(np.diag(Kq))
    assert np.abs(off).max() <= 1e-8 * scale
    assert np.abs(Kq[:6, :6]).max() <= 1e-8 * scale
    # Psi^T K Psi is itself computed in floating point: its error is ~eps |K| |psi|^2, i.e. relative to
    # the largest entry (as the off-diagonal checks above), not to each eigenvalue (the per-entry
    # rtol=1e-8 held on the lowest mode only by the luck of BLAS threading: 1.1e-8 single-threaded).
    np.testing.assert_allclose(np.diag(Kq)[6:], mb.stiffness[6:], rtol=0, atol=1e-8 * scale)
    assert np.all(mb.stiffness[:6] == 0.0)
    # flexible modes are M-orthogonal to the rigid ones and are eigenvectors
    assert np.abs(mb.rigid.T @ (s.M @ mb.flexible)).max() <= 1e-12
    resid = s.K @ mb.flexible - (s.M @ mb.flexible) * mb.stiffness[6:]
    assert np.abs(resid).max() <= 1e-7 * np.abs(s.K @ mb.flexible).max()
    assert np.all(np.diff(mb.frequencies_hz) >= 0) and mb.frequencies_hz[0] > 0


def test_dense_and_sparse_agree(small_plate):
    dense = modal_basis(small_plate, 12, method="dense")
    sparse = modal_basis(small_plate, 12, method="sparse")
    assert (dense.method, sparse.method) == ("dense", "sparse")
    np.testing.assert_allclose(sparse.frequencies_hz, dense.frequencies_hz, rtol=1e-9)
    # same mode shapes up to sign: |Psi_d^T M Psi_s| = I on the flexible block
    overlap = np.abs(dense.flexible.T @ (small_plate.M @ sparse.flexible))
    np.testing.assert_allclose(overlap, np.eye(12), atol=1e-6)
    # identity: the rigid modes are built from the node positions by the same code whatever the eigensolver
    np.testing.assert_array_equal(sparse.rigid, dense.rigid)


def test_damping_diag():
    s = bushing_chain()
    mb = modal_basis(s, 5, damping_ratio=0.05)
    np.testing.assert_array_equal(mb.damping[:6], 0.0)
    np.testing.assert_allclose(mb.damping[6:], 2 * 0.05 * mb.omega, rtol=1e-15)
    zeta = [0.01, 0.02, 0.03, 0.04, 0.05]
    mb2 = modal_basis(s, 5, damping_ratio=zeta)
    np.testing.assert_allclose(mb2.damping[6:], 2 * np.array(zeta) * mb2.omega, rtol=1e-15)
    np.testing.assert_allclose(mb2.stiffness[6:], mb2.omega**2, rtol=1e-12)


def test_zero_flexible_modes_is_a_rigid_body(small_plate):
    mb = modal_basis(small_plate, 0)
    assert mb.shapes.shape == (small_plate.n_dof, 6)
    assert mb.n_flexible == 0 and mb.frequencies_hz.shape == (0,) and mb.method == "none"
    np.testing.assert_allclose(mb.shapes, rigid_body_modes(small_plate), atol=0)


def test_all_flexible_modes_dense():
    s = bushing_chain(4)
    mb = modal_basis(s, s.n_dof - 6)
    np.testing.assert_allclose(mb.shapes.T @ (s.M @ mb.shapes), np.eye(s.n_dof), atol=1e-10)


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("n", [-1, 10_000, 2.5, "3", True])
def test_bad_n_flexible(n):
    s = bushing_chain()
    with pytest.raises(ParameterError) as err:
        modal_basis(s, n)
    assert err.value.parameter == "n_flexible"
    assert f"0 ... {s.n_dof - 6}" in err.value.allowed


@pytest.mark.parametrize("zeta", [-0.1, 1.5, float("nan"), [0.05, 0.05]])
def test_bad_damping_ratio(zeta):
    with pytest.raises(ParameterError) as err:
        modal_basis(bushing_chain(), 3, damping_ratio=zeta)
    assert err.value.parameter == "damping_ratio"


def test_constrained_structure_is_rejected():
    s = bushing_chain()
    K = s.K.tolil()
    for j in range(6):                       # clamp node 0 with penalty springs
        K[j, j] += 1e9
    clamped = Structure(s.nodes, 6, s.M, K.tocsr())
    with pytest.raises(ParameterError) as err:
        modal_basis(clamped, 3)
    assert err.value.parameter == "structure.K"
    assert "rigid-body" in str(err.value)


def test_disconnected_structure_is_rejected():
    s = bushing_chain(6)
    cut = s.K.toarray()                       # remove the bushing between nodes 2 and 3
    a, b = 2, 3
    mid = 0.5 * (s.nodes[a] + s.nodes[b])
    D = np.hstack([-np.eye(3), _skew(mid - s.nodes[a]), np.eye(3), -_skew(mid - s.nodes[b])])
    R = np.hstack([np.zeros((3, 3)), -np.eye(3), np.zeros((3, 3)), np.eye(3)])
    idx = np.r_[6 * a:6 * a + 6, 6 * b:6 * b + 6]
    cut[np.ix_(idx, idx)] -= 1e6 * D.T @ D + 1e3 * R.T @ R
    with pytest.raises(ParameterError) as err:
        modal_basis(Structure(s.nodes, 6, s.M, sp.csr_matrix(cut)), 3)
    assert err.value.parameter == "structure.K"
    assert "zero-energy" in str(err.value)


def test_indefinite_mass_is_rejected():
    s = bushing_chain()
    M = s.M.tolil()
    M[3, 3] = -1e-3
    with pytest.raises(ParameterError) as err:
        modal_basis(Structure(s.nodes, 6, M.tocsr(), s.K), 3)
    assert err.value.parameter == "structure.M"


def test_bad_method_and_sigma(small_plate):
    with pytest.raises(ParameterError) as err:
        modal_basis(small_plate, 2, method="lanczos")
    assert err.value.parameter == "method"
    with pytest.raises(ParameterError) as err:
        modal_basis(small_plate, 2, method="sparse", sigma=1.0)
    assert err.value.parameter == "sigma"


def test_colinear_nodes_without_rotary_inertia_are_rejected():
    """Three point masses on a line: rotation about the line has no inertia -> < 6 rigid modes."""
    nodes = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
    M = sp.identity(9, format="csr")
    K = sp.csr_matrix((9, 9))
    with pytest.raises(ParameterError) as err:
        rigid_body_modes(Structure(nodes, 3, M, K))
    assert err.value.parameter == "structure.M"
    assert "no inertia" in str(err.value)


# --------------------------------------------------------------------------- sparse eigensolver
def _pardiso_installed() -> bool:
    return mbm._mkl_pardiso() is not None


@pytest.mark.skipif(np.finfo(np.longdouble).eps >= np.finfo(float).eps,
                    reason="numpy longdouble is plain double on this platform")
def test_eigenvalues_are_exact_rayleigh_quotients(small_plate):
    """omega^2 = psi^T K psi / psi^T M psi of the returned mode, checked in exact rational arithmetic: the
    first mode is the worst case (|K||psi| / |K psi| ~ 5e8), where the double-precision quotient scatters
    by ~3e-9 relative; the basis accumulates it in extended precision."""
    s = validate_structure(small_plate)
    for method in ("dense", "sparse"):
        mb = modal_basis(small_plate, 3, method=method)
        psi = [Fraction(x) for x in mb.flexible[:, 0]]

        def quadratic_form(A):
            A = A.tocoo()
            return sum(Fraction(a) * psi[i] * psi[j] for a, i, j in zip(A.data, A.row, A.col))

        exact = quadratic_form(s.K) / quadratic_form(s.M)
        assert abs(Fraction(mb.stiffness[6]) / exact - 1) <= 1e-11, method


def test_shifted_solver_backends(monkeypatch):
    """A block of right-hand sides is solved exactly; an indefinite K - sigma M goes to SuperLU."""
    rng = np.random.default_rng(3)
    B = rng.standard_normal((40, 3))
    G = rng.standard_normal((40, 40))
    K = sp.csr_matrix(G @ G.T)                                   # positive definite
    M = sp.identity(40, format="csr")
    for env, expected in (("0", "superlu"), ("1", "pardiso" if _pardiso_installed() else "superlu")):
        monkeypatch.setenv("FLEXFMU_PARDISO", env)
        solve, close, backend = mbm._shifted_solver(K, M, -1.0)
        try:
            assert backend == expected
            np.testing.assert_allclose((K + M) @ solve(B), B, atol=1e-10)
        finally:
            close()
    monkeypatch.setenv("FLEXFMU_PARDISO", "1")
    K_indefinite = sp.diags([2.0, -5.0, 3.0, 1.0]).tocsr()
    solve, close, backend = mbm._shifted_solver(K_indefinite, sp.identity(4, format="csr"), -1.0)
    assert backend == "superlu"
    np.testing.assert_allclose(solve(np.ones(4)), 1.0 / np.array([3.0, -4.0, 4.0, 2.0]), rtol=1e-14)
    close()


@pytest.mark.skipif(not _pardiso_installed(), reason="optional pypardiso (MKL PARDISO) not installed")
def test_pardiso_and_superlu_give_the_same_basis(coarse_plate, monkeypatch):
    bases = {}
    for env in ("0", "1"):
        monkeypatch.setenv("FLEXFMU_PARDISO", env)
        bases[env] = modal_basis(coarse_plate, 10, cache=False)
    np.testing.assert_allclose(bases["1"].frequencies_hz, bases["0"].frequencies_hz, rtol=1e-9)
    overlap = np.abs(bases["0"].flexible.T @ (coarse_plate.M @ bases["1"].flexible))
    np.testing.assert_allclose(overlap, np.eye(10), atol=1e-6)


def test_sparse_solver_reports_non_convergence(coarse_plate, monkeypatch):
    monkeypatch.setattr(mbm, "KRYLOV_MAX_DIM", 20)              # two blocks: far from converged
    with pytest.raises(mbm.ModalConvergenceError, match="not converged"):
        modal_basis(coarse_plate, 10, method="sparse", cache=False)


def test_modes_that_are_not_eigenvectors_are_rejected(small_plate, monkeypatch):
    """The residual check of every returned mode: a random subspace gives Ritz vectors, not eigenvectors."""
    def random_candidates(K, M, Phi, n, method, sigma):
        return np.random.default_rng(0).standard_normal((M.shape[0], n))

    monkeypatch.setattr(mbm, "_flexible_candidates", random_candidates)
    with pytest.raises(mbm.ModalConvergenceError, match="not eigenvectors"):
        modal_basis(small_plate, 3, cache=False)
