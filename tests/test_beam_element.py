"""Element rotation C^ij (Eqs. 8, 10, 11) and the 12-DOF element matrices."""
import numpy as np
import pytest

from error_bounds import gamma
from flexfmu.ffr.beam_element import element_dof_rotation, element_rotation, local_mass, local_stiffness

# Rounding of element_rotation: d = v / ||v|| carries <= gamma(5) relative per component (3 squares, 2 additions, a
# square root, a division; any summation order), Q = hypot(cx, cz) one more gamma(5) + 2u (hypot within 1 ulp), and
# each entry of R (at most three such factors, two roundings: -cx*cy/Q) therefore <= DELTA relative of the entry of the
# exactly orthogonal matrix built from the exact unit direction.
DELTA = gamma(3 * 5 + 2 + 2)
# C^T C - I: entries of C within DELTA |C|, the 3-term inner product adds gamma(3); |C|^T |C| <= 1 entrywise (unit
# columns, Cauchy-Schwarz), so |fl(C^T C) - I| <= 2 DELTA + gamma(3) (+ DELTA^2, covered by rounding gamma up).
ORTHO_BOUND = gamma(2 * (3 * 5 + 2 + 2) + 3 + 1)
# det by LU with partial pivoting: backward error |dC| <= gamma(3) |L||U| [ASNA Thm 9.3], |L| <= 1, |U| <= 2^2 max|C|
# <= 4, so |dC_ij| <= 12 gamma(3); d det = tr(adj(C) dC), |adj(C)| = |C^T| <= 1: <= 9 * 12 gamma(3); the entries'
# DELTA give tr(C^T E) <= DELTA sum C_ij^2 = 3 DELTA; the product of the 3 pivots gamma(2).
DET_BOUND = 3 * DELTA + 108 * gamma(3) + gamma(2)

AXES = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]


def _check_rotation(C, direction):
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    np.testing.assert_allclose(C.T @ C, np.eye(3), rtol=0, atol=ORTHO_BOUND)         # see ORTHO_BOUND
    assert np.linalg.det(C) == pytest.approx(1.0, rel=0, abs=DET_BOUND)               # see DET_BOUND
    # element x_bar along the element: two normalisations of one vector (different summation orders), each within
    # gamma(5) |d| of the exact unit vector
    np.testing.assert_allclose(C[:, 0], d, rtol=0, atol=2 * gamma(5) * np.abs(d).max())


@pytest.mark.parametrize("direction", AXES)
def test_rotation_orthogonal_along_body_axes(direction):
    C = element_rotation(np.array([direction], float))[0]
    _check_rotation(C, direction)


def test_rotation_orthogonal_random_and_nearly_vertical(rng):
    dirs = rng.normal(size=(500, 3))
    dirs = np.vstack([dirs, [[1e-13, 1.0, 0.0], [0.0, -1.0, 1e-11], [1e-8, 1.0, -1e-8]]])
    Cs = element_rotation(dirs)
    for C, d in zip(Cs, dirs):
        _check_rotation(C, d)


def test_gere_weaver_rule_z_bar_horizontal(rng):
    """Documented section-axis rule: z_bar is normal to body Y; y_bar leans towards +Y."""
    dirs = rng.normal(size=(200, 3))
    Cs = element_rotation(dirs)
    assert np.all(Cs[:, 1, 2] == 0.0)   # Y component of z_bar: R[2, 1] is assigned 0.0 (Eqs. 8, 10), exact
    assert np.all(Cs[:, 1, 1] >= 0)              # Y component of y_bar


def test_vertical_element_uses_eq10():
    C_up = element_rotation(np.array([[0.0, 2.0, 0.0]]))[0]
    # exact: Eq. 10 assigns the signs and zeros (sign of cy, 0.0, 1.0), no arithmetic on them
    # Gere & Weaver Eq. 10 (transposed to element->body): x_bar = +Y, y_bar = -X, z_bar = Z
    np.testing.assert_array_equal(C_up, np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    C_down = element_rotation(np.array([[0.0, -1.0, 0.0]]))[0]
    np.testing.assert_array_equal(C_down, np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))


def test_cbar_is_block_diagonal():
    C = element_rotation(np.array([[1.0, 2.0, 3.0]]))
    Cbar = element_dof_rotation(C)[0]
    # block diagonal: off-block products are exact zeros, each diagonal block is C^T C (ORTHO_BOUND)
    np.testing.assert_allclose(Cbar.T @ Cbar, np.eye(12), rtol=0, atol=ORTHO_BOUND)
    for k in range(4):   # exact: the blocks are copies of C
        np.testing.assert_array_equal(Cbar[3 * k:3 * k + 3, 3 * k:3 * k + 3], C[0])


def _rigid_modes_local(L):
    """Rigid motions of a 2-node element along x in local DOFs (translations, rotations about node 1)."""
    R = np.zeros((12, 6))
    for i in range(3):
        R[i, i] = R[6 + i, i] = 1.0
        R[3 + i, 3 + i] = R[9 + i, 3 + i] = 1.0
    # rotation about z moves node 2 by +L in y; about y moves node 2 by -L in z
    R[7, 5] = L
    R[8, 4] = -L
    return R


def test_element_stiffness_has_exactly_six_rigid_modes():
    L, E, G, A, Iy, Iz, J = 0.3, 2e11, 8e10, 1e-4, 2e-9, 3e-9, 4e-9
    K = local_stiffness(L, E, G, A, Iy, Iz, J)[0]
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-6 * np.abs(K).max())
    np.testing.assert_allclose(K @ _rigid_modes_local(L), 0.0, atol=1e-9 * np.abs(K).max())
    eig = np.linalg.eigvalsh(K)
    assert np.sum(np.abs(eig) < 1e-9 * eig.max()) == 6


def _congruence_bound(R, M, reference):
    """Bound on |fl(R^T M R) - exact|_ii against a closed form ``reference`` (n_ref roundings): the entries of M carry
    <= 7 roundings each (factor rho*Iz/(30 L): 3, pattern and two slope scalings: 3, the scatter +=: 1), the two
    12-term products gamma(24) [ASNA 3.5], all relative to the terms |R|^T |M| |R| (cancellation in the sum); the
    closed form m L^2 / 3 + rho I L itself carries <= 6 roundings of positive terms: gamma(6) |reference|."""
    terms = np.diag(np.abs(R).T @ np.abs(M) @ np.abs(R))
    return gamma(7 + 24) * terms + gamma(6) * np.abs(reference)


def test_element_mass_reproduces_mass_and_inertia():
    L, rho, A, Iy, Iz = 0.3, 7850.0, 1e-4, 2e-9, 3e-9
    M = local_mass(L, rho, A, Iy, Iz)[0]
    R = _rigid_modes_local(L)
    m = rho * A * L
    modal = R.T @ M @ R
    # rigid translations: m; rotation about the element axis: rho*Ip*L; about y, z through node 1: m L^2 / 3
    # (no rotary inertia).  Each within the rounding bound of the assembly and the congruence (_congruence_bound).
    want = np.array([m, m, m, rho * (Iy + Iz) * L, m * L**2 / 3, m * L**2 / 3])
    assert np.all(np.abs(np.diag(modal) - want) <= _congruence_bound(R, M, want))
    assert np.all(np.linalg.eigvalsh(M) > 0)
    Mr = local_mass(L, rho, A, Iy, Iz, rotary_inertia=True)[0]
    # rotary inertia adds rho*I*L to the rigid rotations about y and z
    want_r = want + np.array([0, 0, 0, 0, rho * Iy * L, rho * Iz * L])
    assert np.all(np.abs(np.diag(R.T @ Mr @ R) - want_r)[4:] <= _congruence_bound(R, Mr, want_r)[4:])
