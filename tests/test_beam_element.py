"""Element rotation C^ij (Eqs. 8, 10, 11) and the 12-DOF element matrices."""
import numpy as np
import pytest

from flexfmu.ffr.beam_element import element_dof_rotation, element_rotation, local_mass, local_stiffness

AXES = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]


def _check_rotation(C, direction):
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    np.testing.assert_allclose(C.T @ C, np.eye(3), atol=1e-14)
    assert np.linalg.det(C) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(C[:, 0], d, atol=1e-14)   # element x_bar along the element


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
    assert np.all(np.abs(Cs[:, 1, 2]) < 1e-14)   # Y component of z_bar
    assert np.all(Cs[:, 1, 1] >= 0)              # Y component of y_bar


def test_vertical_element_uses_eq10():
    C_up = element_rotation(np.array([[0.0, 2.0, 0.0]]))[0]
    # Gere & Weaver Eq. 10 (transposed to element->body): x_bar = +Y, y_bar = -X, z_bar = Z
    np.testing.assert_array_equal(C_up, np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    C_down = element_rotation(np.array([[0.0, -1.0, 0.0]]))[0]
    np.testing.assert_array_equal(C_down, np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))


def test_cbar_is_block_diagonal():
    C = element_rotation(np.array([[1.0, 2.0, 3.0]]))
    Cbar = element_dof_rotation(C)[0]
    np.testing.assert_allclose(Cbar.T @ Cbar, np.eye(12), atol=1e-14)
    for k in range(4):
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


def test_element_mass_reproduces_mass_and_inertia():
    L, rho, A, Iy, Iz = 0.3, 7850.0, 1e-4, 2e-9, 3e-9
    M = local_mass(L, rho, A, Iy, Iz)[0]
    R = _rigid_modes_local(L)
    m = rho * A * L
    modal = R.T @ M @ R
    np.testing.assert_allclose(np.diag(modal)[:3], m, rtol=1e-14)
    # rotation about the element axis: rho*Ip*L; about y, z through node 1: m L^2 / 3 (no rotary inertia)
    assert modal[3, 3] == pytest.approx(rho * (Iy + Iz) * L, rel=1e-13)
    assert modal[4, 4] == pytest.approx(m * L**2 / 3, rel=1e-13)
    assert modal[5, 5] == pytest.approx(m * L**2 / 3, rel=1e-13)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    Mr = local_mass(L, rho, A, Iy, Iz, rotary_inertia=True)[0]
    # rotary inertia adds rho*I*L to the rigid rotations about y and z
    assert (R.T @ Mr @ R)[4, 4] == pytest.approx(m * L**2 / 3 + rho * Iy * L, rel=1e-12)
    assert (R.T @ Mr @ R)[5, 5] == pytest.approx(m * L**2 / 3 + rho * Iz * L, rel=1e-12)
