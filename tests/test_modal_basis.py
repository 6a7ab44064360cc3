"""Rigid-body modes, mass properties and the modal basis (flexfmu.linalg.modal_basis)."""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import flexfmu.linalg.modal_basis as mbm
from error_bounds import U, gamma
from flexfmu.core.blas import limited_for
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


# --------------------------------------------------------------------------- rounding-error bounds
#: LAPACK's symmetric eigensolver is backward stable [LAPACK Users' Guide 4.7]: the computed (s, U) of a symmetric n x n
#: G are an exact eigen-decomposition W diag(s) W^T of G + E with W orthogonal, ||E||_2 <= p(n) u ||G||_2 and
#: ||U - W||_2 <= p(n) u, p "a modestly growing function of n": for the 6 x 6 Gram matrix counted as 10 n^2 = 360
#: roundings (n - 2 Householder reflections, tridiagonal QR sweeps of n - 1 rotations each)
EIGH_6 = gamma(10 * 6 ** 2)


def _row_nnz(A) -> int:
    return int(np.diff(sp.csr_matrix(A).indptr).max())


class _RigidRounding:
    """What bounds the rounding of the rigid modes Phi = fl(B A) (flexfmu.linalg.modal_basis._rigid_orthonormal): B the
    unit rigid fields about the computed centre of mass c, G = B^T M B (symmetrised), A = G^-1/2 by eigh(G).  The
    parts are the code's own (_rigid_parts: elementwise operations and the same products on the same numbers).

    * G: M B (inner products of <= r_M terms), B^T (.) (n terms), the average with the transpose: |G - G_e| <=
      gamma_{n + r_M + 1} |B|^T |M| |B|, G_e = B^T M B exactly [ASNA 3.5];
    * eigh(G): exact for G + E2 with an orthogonal W (EIGH_6: eta);
    * A = fl(fl(U / sqrt(s)) U^T) = U S^-1/2 U^T + <= gamma_8 |U| S^-1/2 |U|^T (2-norm <= 6 gamma_8 (1 + eta)^2
      s_min^-1/2, as || |U| ||_2 <= ||U||_F), and U S^-1/2 U^T - W S^-1/2 W^T <= eta (2 + eta) s_min^-1/2: A = A_x + dA,
      A_x = W S^-1/2 W^T, ||dA||_2 <= alpha s_min^-1/2;
    * A_x (G + E2) A_x = I, so ||A_x G_e A_x - I||_2 <= (||G - G_e|| + eta ||G||) / s_min; with A_x G = W S^1/2 W^T -
      A_x E2 (||A_x G_e|| <= s_max^1/2 + (eta ||G|| + ||G - G_e||) / s_min^1/2) the terms of dA add 2 alpha ||A_x G_e||
      / s_min^1/2 + alpha^2 kappa (kappa = ||G_e|| / s_min): e_sym, a bound on ||A^T G_e A - I||_2;
    * Phi = B A + F1, |F1| <= gamma_6 |B| |A|: Phi^T M Phi - A^T G_e A = F1^T M B A + A^T B^T M F1 + F1^T M F1, of
      2-norm <= (2 gamma_6 + gamma_6^2) ||(|B||A|)^T |M| (|B||A|)||_2 (|X| <= Y entrywise gives ||X||_2 <= ||Y||_2).
    e_orth = e_sym + that bounds ||Phi^T M Phi - I||_2, Phi^T M Phi in exact arithmetic on the computed Phi.

    The exact rigid fields B_ex about c differ from B by the rounding of x - c (the cross products with unit vectors
    are exact): |B - B_ex| <= u |B| (1 + u), so Phi - B_ex A <= gamma_7 |B| |A| (``span``).

    ``basis``: a ModalBasis, whose centre of mass and A (rigid_transform) are taken as they are; without it they are
    computed again (the code's own calls; rigid_body_modes' Phi, asserted by the callers to be the same bits).  G is
    computed again here for its eigenvalues: the code's G is within ||G - G_e|| of the exact one as this one is, so
    its eigenvalues are within 2 ||G - G_e|| of these (Weyl), and the eigensolvers' eta ||G|| each."""

    def __init__(self, structure, basis=None):
        s = validate_structure(structure)
        self.M, self.absM, self.n, self.r_M = s.M, abs(s.M), s.n_dof, _row_nnz(s.M)
        if basis is None:
            _, self.c, self.B, G = mbm._rigid_parts(s)
            self.Phi, self.A = mbm._rigid_orthonormal(s)[:2]
        else:
            self.c, self.A = basis.center_of_mass, basis.rigid_transform
            self.B = mbm._unit_fields(np.asarray(s.nodes, float), s.dofs_per_node, self.c)
            G = self.B.T @ (s.M @ self.B)
            self.Phi = basis.rigid
        self.absB, self.absA = np.abs(self.B), np.abs(self.A)
        norm2 = lambda X: float(np.linalg.norm(X, 2))                   # noqa: E731
        E1 = gamma(self.n + self.r_M + 1) * norm2(self.absB.T @ (self.absM @ self.absB))
        eta = EIGH_6
        sv = np.linalg.eigvalsh(0.5 * (G + G.T))
        s_min = float(sv[0]) - 2 * E1 - 2 * eta * float(sv[-1])
        s_max = float(sv[-1]) + 2 * E1 + 2 * eta * float(sv[-1])
        alpha = eta * (2 + eta) + 6 * gamma(8) * (1 + eta) ** 2
        kappa = (s_max + E1) / s_min
        AxG = math.sqrt(s_max) + (eta * s_max + E1) / math.sqrt(s_min)
        self.e_sym = (E1 + eta * s_max) / s_min + 2 * alpha * AxG / math.sqrt(s_min) + alpha ** 2 * kappa
        BA = self.absB @ self.absA
        self.e_orth = self.e_sym + (2 * gamma(6) + gamma(6) ** 2) * norm2(BA.T @ (self.absM @ BA))
        self.span = gamma(7) * BA
        # ||A^-1||_2 from A's singular values, each within eta ||A|| of exact (the same backward-error model)
        sa = np.linalg.svd(self.A, compute_uv=False)
        self.inv_A = 1.0 / (sa[-1] - eta * sa[0])

    def orthonormality_exact(self, Phi):
        """Row 2-norms of E = Phi^T M Phi - I computed exactly (rational arithmetic on the doubles), each rounded up."""
        M = sp.csr_matrix(self.M)
        P = [[Fraction(float(v)) for v in row] for row in Phi]
        data = [Fraction(float(v)) for v in M.data]
        MP = []
        for i in range(M.shape[0]):
            acc = [Fraction(0)] * Phi.shape[1]
            for p in range(M.indptr[i], M.indptr[i + 1]):
                a, row = data[p], P[M.indices[p]]
                for k in range(len(acc)):
                    acc[k] += a * row[k]
            MP.append(acc)
        E = np.array([[float(sum(P[i][k] * MP[i][l] for i in range(len(P))) - (k == l))
                       for l in range(Phi.shape[1])] for k in range(Phi.shape[1])])
        # E rounded to double (u), the norms' 6 squares, sum and root (<= 9 roundings)
        return (1 + gamma(10)) * np.linalg.norm(E, axis=1)


def _exact_rigid_residual(K, nodes, dpn, c, A) -> np.ndarray:
    """K (B_ex A) in exact rational arithmetic (B_ex: the exact unit rigid fields about c), rounded to double."""
    K = sp.csr_matrix(K)
    cF = [Fraction(float(v)) for v in c]
    Bex = []
    for x in nodes:
        r = [Fraction(float(x[j])) - cF[j] for j in range(3)]
        rows = [[Fraction(0)] * 6 for _ in range(dpn)]
        for k in range(3):
            rows[k][k] = Fraction(1)
            if dpn == 6:
                rows[3 + k][3 + k] = Fraction(1)
        # e_k x r: (0, -r_z, r_y), (r_z, 0, -r_x), (-r_y, r_x, 0)
        rows[1][3], rows[2][3], rows[0][4], rows[2][4], rows[0][5], rows[1][5] = -r[2], r[1], r[2], -r[0], -r[1], r[0]
        Bex.extend(rows)
    data = [Fraction(float(v)) for v in K.data]
    AF = [[Fraction(float(v)) for v in row] for row in A]
    out = np.zeros((K.shape[0], 6))
    for i in range(K.shape[0]):
        acc = [Fraction(0)] * 6
        for p in range(K.indptr[i], K.indptr[i + 1]):
            a, b = data[p], Bex[K.indices[p]]
            for k in range(6):
                if b[k]:
                    acc[k] += a * b[k]
        for col in range(6):
            out[i, col] = float(sum(acc[k] * AF[k][col] for k in range(6)))
    return out


def _rigid_field_rounding(structure, a, theta, x0) -> np.ndarray:
    """|_rigid_field(..) - the exact rigid field|: x - x0 (1 rounding), theta x r (2 products and a difference), a + ..
    (1): <= gamma_4 (|a| + |theta| x |x - x0|) on the translations (|.| x |.|: the cross product's terms' sizes); the
    rotation DOFs hold theta itself."""
    dpn = structure.dofs_per_node
    r, th = np.abs(structure.nodes - x0), np.abs(theta)
    terms = np.stack([th[1] * r[:, 2] + th[2] * r[:, 1], th[2] * r[:, 0] + th[0] * r[:, 2],
                      th[0] * r[:, 1] + th[1] * r[:, 0]], axis=1)
    du = np.zeros(structure.n_dof)
    for j in range(3):
        du[j::dpn] = gamma(4) * (abs(a[j]) + terms[:, j])
    return du


def _rayleigh_ritz(structure, mb):
    """([V_0, V_1, V_2], Q) of the last steps of modal_basis for the basis ``mb`` of ``structure``: the candidates,
    twice M-projected off the rigid modes, and the Rayleigh-Ritz rotation (flexfmu.linalg.modal_basis._compute_modes),
    recomputed by the same calls under the same BLAS thread limit, so the same numbers (identity, asserted: V_2 Q is
    mb's flexible block bit for bit)."""
    s = validate_structure(structure)
    with limited_for(s.n_dof):
        Vs = [mbm._flexible_candidates(s.K, s.M, mb.rigid, mb.n_flexible, mb.method, mbm.DEFAULT_SIGMA)]
        for _ in range(2):
            Vs.append(mbm._project_out(mb.rigid, s.M, Vs[-1]))
        V = Vs[-1]
        Kr, Mr = V.T @ (s.K @ V), V.T @ (s.M @ V)
        _, Q = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
        assert np.array_equal(V @ Q, mb.flexible)
    return Vs, Q


# --------------------------------------------------------------------------- rigid modes
@pytest.mark.parametrize("which", ["plate", "chain"])
def test_rigid_modes_mass_orthonormal_and_strain_free(which, small_plate):
    s = small_plate if which == "plate" else bushing_chain()
    Phi = rigid_body_modes(s)
    assert Phi.shape == (s.n_dof, 6)
    r = _RigidRounding(s)
    assert np.array_equal(r.Phi, Phi)               # identity: the same calls on the same structure in this process
    absPhi = np.abs(Phi)
    # ||Phi^T M Phi - I||_2 <= e_orth (_RigidRounding: eigh's backward error over the Gram matrix's smallest
    # eigenvalue dominates), plus this product's own rounding gamma_{n + r_M} |Phi|^T |M| |Phi|
    err = np.abs(Phi.T @ (s.M @ Phi) - np.eye(6))
    bound = r.e_orth + gamma(r.n + r.r_M) * (absPhi.T @ (r.absM @ absPhi))
    print(f"\n{which}: max |Phi^T M Phi - I| = {err.max():.2e}, bound {bound.max():.2e} "
          f"(ratio {np.max(err / bound):.2g})")
    assert np.all(err <= bound)
    # strain free: K Phi is K's own residual on the exact rigid fields about c, K (B_ex A) (computed exactly: the
    # structure's assembly rounding, not the modes'), plus K (Phi - B_ex A) <= gamma_7 |K| |B| |A| and this product's
    # rounding gamma_{r_K} |K| |Phi| (r_K: the most entries in a row of K); the reference rounded to double: u
    absK = abs(s.K)
    ref = _exact_rigid_residual(s.K, s.nodes, s.dofs_per_node, r.c, r.A)
    bound = absK @ r.span + gamma(_row_nnz(s.K)) * (absK @ absPhi) + U * np.abs(ref)
    err = np.abs(s.K @ Phi - ref)
    print(f"max |K Phi - K B_ex A| = {err.max():.2e}, bound {bound.max():.2e} "
          f"(ratio {np.max(err / np.maximum(bound, 1e-300)):.2g})")
    assert np.all(err <= bound)


@pytest.mark.parametrize("which", ["plate", "chain"])
@pytest.mark.parametrize("kind", ["translation", "rotation", "both"])
def test_rigid_modes_reproduce_rigid_fields_exactly(which, kind, small_plate):
    s = small_plate if which == "plate" else bushing_chain()
    Phi = rigid_body_modes(s)
    a = np.array([0.3, -1.2, 0.7]) if kind != "rotation" else np.zeros(3)
    theta = np.array([2e-3, -1e-3, 3e-3]) if kind != "translation" else np.zeros(3)
    x0 = np.array([0.1, -0.2, 0.05])
    u = _rigid_field(s, a, theta, x0=x0)                                 # any axis point, not the COM
    q = Phi.T @ (s.M @ u)
    # u = u_r + du, u_r = B_ex t exactly (t = [a + theta x (c - x0); theta]) and du the field's own rounding
    # (_rigid_field_rounding); with w = A^-1 t, u_r = Phi w - F w (F = Phi - B_ex A <= gamma_7 |B| |A|) and
    # E = Phi^T M Phi - I: Phi Phi^T M u_r - u_r = Phi E w - Phi Phi^T M F w + F w.  E is computed exactly here (the
    # modes' orthonormality, which test_rigid_modes_mass_orthonormal_and_strain_free bounds a priori), the span
    # terms F a priori: what is tested is that the modes span the rigid fields to their rounding
    r = _RigidRounding(s)
    assert np.array_equal(r.Phi, Phi)               # identity: the same calls on the same structure in this process
    absPhi = np.abs(Phi)
    d = np.abs(r.c - x0)
    t = np.r_[np.abs(a) + [abs(theta[1]) * d[2] + abs(theta[2]) * d[1], abs(theta[2]) * d[0] + abs(theta[0]) * d[2],
                           abs(theta[0]) * d[1] + abs(theta[1]) * d[0]], np.abs(theta)] * (1 + gamma(4))
    w = r.inv_A * float(np.linalg.norm(t))                               # >= ||w||_2
    du = _rigid_field_rounding(s, a, theta, x0)
    span = r.span.sum(axis=1) * w                                        # >= |F w|
    bound = (absPhi @ (r.orthonormality_exact(Phi) * w) + absPhi @ (absPhi.T @ (r.absM @ span)) + span
             + absPhi @ (absPhi.T @ (r.absM @ du)) + du)
    # the check's own rounding: M u (r_M terms), Phi^T (.) (n), Phi q (6)
    dq = gamma(r.n + r.r_M) * (absPhi.T @ (r.absM @ np.abs(u)))
    bound += gamma(6) * (absPhi @ np.abs(q)) + absPhi @ dq
    err = np.abs(Phi @ q - u)
    print(f"\nmax |Phi Phi^T M u - u| = {err.max():.2e}, bound {bound.max():.2e} (ratio {np.max(err / bound):.2g})")
    assert np.all(err <= bound)


def test_mass_properties_of_point_masses_match_formula():
    s = bushing_chain()
    m, J_rot = s.meta["masses"], s.meta["rotary"]
    c = (m @ s.nodes) / m.sum()
    r = s.nodes - c
    J = sum(mi * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for mi, ri in zip(m, r)) + np.diag(J_rot.sum(axis=0))
    mp = mass_properties(s)
    n_nodes = s.nodes.shape[0]
    # lumped M: the code's x, y, z translation masses are sums of the n_nodes masses (exact products by 1), their
    # mean 3 more roundings; m.sum() here n_nodes: each within gamma_{n_nodes + 3} of sum m
    assert abs(mp.mass - m.sum()) <= 2 * gamma(n_nodes + 3) * m.sum()
    # first moments sum m x: the code's m (+-x) (1 rounding), n_nodes-term sums, the difference S_12 - S_21 of two
    # such sums (gamma_{n_nodes + 1}), / (2 mass) (mass: gamma_{n_nodes + 2}, the division 1); here m @ x and m.sum()
    # (n_nodes each) and the division: each side within gamma_{2 n_nodes + 5} of (m @ |x|) / sum m
    moment = (m @ np.abs(s.nodes)) / m.sum()
    dc = 2 * gamma(2 * n_nodes + 5) * moment
    assert np.all(np.abs(mp.center_of_mass - c) <= dc)
    # inertia about the computed COMs: the terms m (delta_kl |r|^2 - r_k r_l) + J_rot, |.| <= 2 (m |r|^2 + |J_rot|)
    # summed = 2 T; the code's x - c (1 rounding), B^T M B (inner products over all n_dof DOFs, rounded products) and
    # the symmetrisation: gamma_{n_dof + 8} 2 T; here |r|^2, the products and the n_nodes-term sum:
    # gamma_{n_nodes + 8} 2 T.
    # The two COMs differ from the exact one by <= dc each: the inertia about a point d off the COM is J_com +
    # m_tot (|d|^2 I - d d^T), <= 2 m_tot |d|^2 per entry
    T = float(m @ np.einsum("ij,ij->i", r, r)) + np.abs(J_rot).sum()
    bound = 2 * T * (gamma(s.n_dof + 8) + gamma(n_nodes + 8)) + 2 * m.sum() * 2 * float(dc @ dc)
    assert np.all(np.abs(mp.inertia - J) <= bound)
    mb = modal_basis(s, 0)
    assert np.all(np.abs(mb.inertia - J) <= bound)


def test_rigid_transform_maps_rigid_coordinates_to_translation_and_rotation(small_plate):
    mb = modal_basis(small_plate, 0)
    a, theta = np.array([1e-3, 2e-3, -3e-3]), np.array([-1e-3, 4e-3, 2e-3])
    u = _rigid_field(small_plate, a, theta, mb.center_of_mass)
    q = mb.rigid.T @ (small_plate.M @ u)
    # u = B_ex t + du (t = [a; theta], about c exactly), B_ex A = Phi - F: with w = A^-1 t and E = Phi^T M Phi - I,
    # A Phi^T M B_ex t = A (I + E) w - A Phi^T M F w = t + A E w - A Phi^T M F w (as in
    # test_rigid_modes_reproduce_rigid_fields_exactly: E computed exactly, F <= gamma_7 |B| |A| a priori); A Phi^T M du;
    # the check's rounding: q (gamma_{n + r_M} |Phi|^T |M| |u|), A q (gamma_6 |A| |q|)
    r = _RigidRounding(small_plate, mb)
    Phi = mb.rigid
    absPhi = np.abs(Phi)
    w = r.inv_A * float(np.linalg.norm(np.r_[a, theta]))
    du = _rigid_field_rounding(small_plate, a, theta, mb.center_of_mass)
    span = r.span.sum(axis=1) * w
    dq = gamma(r.n + r.r_M) * (absPhi.T @ (r.absM @ np.abs(u)))
    bound = r.absA @ (r.orthonormality_exact(Phi) * w + absPhi.T @ (r.absM @ (span + du)) + dq) \
        + gamma(6) * (r.absA @ np.abs(q))
    err = np.abs(mb.rigid_transform @ q - np.r_[a, theta])
    print(f"\nmax |A q - [a, theta]| = {err.max():.2e}, bound {bound.max():.2e} (ratio {np.max(err / bound):.2g})")
    assert np.all(err <= bound)


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
    # flexible modes are M-orthogonal to the rigid ones: the candidates V_0 are projected twice, V_{k+1} =
    # fl(V_k - Phi y^_k), y^_k = fl(Phi^T fl(M V_k)) within rho_k = gamma_{n + r_M} |Phi|^T |M| |V_k| of
    # y_k = Phi^T M V_k;
    # the subtraction and Phi y^ err by delta_k <= gamma_6 |Phi| |y^_k| + u |V_{k+1}| (1 + u), so y_{k+1} = (y_k - y^_k)
    # - E y^_k + Phi^T M delta_k with ||E||_2 <= e_orth (_RigidRounding); then Psi_F = fl(V_2 Q) (gamma_nf |V_2| |Q|)
    # and this product's own rounding gamma_{n + r_M} |Phi|^T |M| |Psi_F|
    Vs, Q = _rayleigh_ritz(s, mb)
    rr = _RigidRounding(s, mb)
    Phi, absPhi = mb.rigid, np.abs(mb.rigid)
    V_1, V = Vs[1], Vs[2]
    with limited_for(rr.n):
        y = Phi.T @ (rr.M @ V_1)                    # y^_1, as _project_out computes it
    delta = gamma(6) * (absPhi @ np.abs(y)) + U * (1 + U) * np.abs(V)
    y_bound = (gamma(rr.n + rr.r_M) * (absPhi.T @ (rr.absM @ np.abs(V_1))) + rr.e_orth * np.linalg.norm(y, axis=0)
               + absPhi.T @ (rr.absM @ delta))
    bound = (y_bound @ np.abs(Q) + absPhi.T @ (rr.absM @ (gamma(n) * (np.abs(V) @ np.abs(Q))))
             + gamma(rr.n + rr.r_M) * (absPhi.T @ (rr.absM @ np.abs(mb.flexible))))
    err = np.abs(Phi.T @ (s.M @ mb.flexible))
    print(f"\n{which}: max |Phi_R^T M Phi_F| = {err.max():.2e}, bound {bound.max():.2e} "
          f"(ratio {np.max(err / bound):.2g})")
    assert np.all(err <= bound)
    # ... and are eigenvectors
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
    # damping = fl(2 zeta omega) (2 zeta exact, one rounding); mb.omega = fl(2pi fl(omega / 2pi)) = omega (1 + d1)
    # (1 + d2) (the same double 2pi both times), 2 zeta times it one more: relative gamma_4 apart
    np.testing.assert_allclose(mb.damping[6:], 2 * 0.05 * mb.omega, rtol=gamma(4), atol=0)
    zeta = [0.01, 0.02, 0.03, 0.04, 0.05]
    mb2 = modal_basis(s, 5, damping_ratio=zeta)
    np.testing.assert_allclose(mb2.damping[6:], 2 * np.array(zeta) * mb2.omega, rtol=gamma(4), atol=0)
    # stiffness = lam; mb.omega = sqrt(lam) (1 + d)^3 (sqrt, / 2pi, * 2pi), squared: (1 + d)^7
    np.testing.assert_allclose(mb2.stiffness[6:], mb2.omega**2, rtol=gamma(7), atol=0)


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

        qK, qM = quadratic_form(s.K), quadratic_form(s.M)
        # the code's quotient (flexfmu.linalg.modal_basis: _stiffness_quotients / einsum(Psi_F, M V Q)):
        # numerator in long double (unit roundoff u_ld): row i of K psi sums r_i terms, within gamma_{r_i} (|K||psi|)_i
        # (worst case: the smooth mode's terms cancel, |psi|^T |K| |psi| / psi^T K psi ~ 4e8), the dot product n terms
        # of |psi| |K psi|, then rounded to double (u); denominator in double: M V (r_M terms), . Q (nf), einsum (n),
        # and M V Q against M Psi_F (Psi_F = fl(V Q): gamma_nf |V| |Q|): gamma_{n + r_M + 2 nf} |psi|^T |M| |V| |Q|
        Vs, Q = _rayleigh_ritz(small_plate, mb)
        u_ld = float(np.finfo(np.longdouble).eps) / 2
        x = np.abs(mb.flexible[:, 0])
        absK = abs(s.K)
        r = np.diff(s.K.indptr)
        rows = np.array([gamma(k, u_ld) for k in r]) * (absK @ x)
        Kpsi = np.abs(s.K @ mb.flexible[:, 0]) + gamma(int(r.max())) * (absK @ x)        # >= |K psi| (double here)
        e_num = float(x @ rows) + gamma(s.n_dof, u_ld) * float(x @ (Kpsi + rows)) + U * abs(float(qK))
        e_den = gamma(s.n_dof + _row_nnz(s.M) + 2 * 3) * float(x @ (abs(s.M) @ (np.abs(Vs[-1]) @ np.abs(Q[:, 0]))))
        a, b = e_num / abs(float(qK)), e_den / abs(float(qM))
        rel = (a + b) / (1 - b) * (1 + U) + U                           # and the quotient's rounding
        err = abs(float(Fraction(mb.stiffness[6]) / (qK / qM) - 1))
        print(f"\n{method}: |lambda / exact - 1| = {err:.2e}, bound {rel:.2e} (|psi|^T |K| |psi| / psi^T K psi = "
              f"{float(x @ (absK @ x)) / float(qK):.2g})")
        assert err <= rel, method


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
    # K + M = diag(3, -4, 4, 2) exactly; its LU solve is one division per entry, and SuperLU's equilibration (if it
    # applies any) scales b and the matrix by computed factors r, c and the solution by c: <= 5 roundings of 1 / d
    np.testing.assert_allclose(solve(np.ones(4)), 1.0 / np.array([3.0, -4.0, 4.0, 2.0]), rtol=gamma(5), atol=0)
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
