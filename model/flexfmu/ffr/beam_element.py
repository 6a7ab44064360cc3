"""12-DOF 3D Euler-Bernoulli beam element and its element-to-body rotation (Koda et al. 2025, Eqs. 8-11).

Local element DOF order per node: (u, v, w, theta_x, theta_y, theta_z) along the
element axes (x_bar along the element, y_bar, z_bar the section axes); node 1 then node 2.
Sign convention: theta_z = dv/dx, theta_y = -dw/dx (right-handed rotations).
All functions are vectorised over elements (leading axis).
"""
from __future__ import annotations

import numpy as np



def element_rotation(directions: np.ndarray) -> np.ndarray:
    """C^ij: element-to-body rotation matrices, shape (n, 3, 3), from unit element axes (n, 3).

    Columns of C are the element axes x_bar, y_bar, z_bar in body components, so a
    vector with element components a has body components C @ a.  This is the
    transpose of Gere & Weaver's member rotation matrix R (body -> member), which the
    paper prints as Eq. 8 with Y as the reference ("vertical") axis:
        R = [[ cx,        cy,  cz       ],
             [-cx*cy/Q,   Q,  -cy*cz/Q  ],
             [-cz/Q,      0,   cx/Q     ]],   Q = sqrt(cx^2 + cz^2),
    and, for an element parallel to Y (Q = 0), Eq. 10:
        R = [[0, cy, 0], [-cy, 0, 0], [0, 0, 1]].
    So z_bar is horizontal (normal to Y and to the element) and y_bar leans towards +Y.
    """
    d = np.atleast_2d(np.asarray(directions, dtype=float))
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    cx, cy, cz = d[:, 0], d[:, 1], d[:, 2]
    # Eq. 8 is exact for any Q > 0 (hypot avoids underflow), so Eq. 10 is used only for
    # Q == 0.  For nearly vertical elements the section axes follow the tiny horizontal
    # component (inherent to the Gere & Weaver rule; irrelevant for circular sections).
    Q = np.hypot(cx, cz)
    vertical = Q == 0.0
    Qs = np.where(vertical, 1.0, Q)
    R = np.empty((d.shape[0], 3, 3))
    R[:, 0, :] = d
    R[:, 1, 0] = -cx * cy / Qs
    R[:, 1, 1] = Q
    R[:, 1, 2] = -cy * cz / Qs
    R[:, 2, 0] = -cz / Qs
    R[:, 2, 1] = 0.0
    R[:, 2, 2] = cx / Qs
    if vertical.any():  # Eq. 10
        sgn = np.sign(cy[vertical])
        Rv = np.zeros((int(vertical.sum()), 3, 3))
        Rv[:, 0, 1] = sgn
        Rv[:, 1, 0] = -sgn
        Rv[:, 2, 2] = 1.0
        R[vertical] = Rv
    return np.transpose(R, (0, 2, 1))


def element_dof_rotation(C: np.ndarray) -> np.ndarray:
    """C_bar (Eq. 11): (n, 12, 12) block-diagonal diag(C, C, C, C).

    e_body = C_bar @ e_element; the paper's Eq. 11 prints the transpose, the map
    from body to element nodal coordinates used inside B_D1 (Eq. 13).
    """
    n = C.shape[0]
    Cbar = np.zeros((n, 12, 12))
    for k in range(4):
        Cbar[:, 3 * k:3 * k + 3, 3 * k:3 * k + 3] = C
    return Cbar


_HERMITE_K = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], dtype=float)
_HERMITE_M = np.array([[156, 22, 54, -13], [22, 4, 13, -3], [54, 13, 156, -22], [-13, -3, -22, 4]], dtype=float)
_ROTARY_M = np.array([[36, 3, -36, 3], [3, 4, -3, -1], [-36, -3, 36, -3], [3, -1, -3, 4]], dtype=float)


def _hermite_block(pattern: np.ndarray, factor: np.ndarray, L: np.ndarray) -> np.ndarray:
    """(n, 4, 4) block on (deflection1, slope1, deflection2, slope2): factor * pattern with slope rows/cols * L."""
    scale = np.ones((L.size, 4))
    scale[:, 1] = L
    scale[:, 3] = L
    return np.einsum("ij,n->nij", pattern, factor) * scale[:, :, None] * scale[:, None, :]


# Local DOF indices of each sub-problem.  For bending in the x-z plane the slope is
# -theta_y, handled by the sign vector below.
_AXIAL = [0, 6]
_TORSION = [3, 9]
_BEND_XY = [1, 5, 7, 11]   # v1, theta_z1, v2, theta_z2
_BEND_XZ = [2, 4, 8, 10]   # w1, theta_y1, w2, theta_y2
_XZ_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


def _scatter(target: np.ndarray, idx: list[int], block: np.ndarray, sign: np.ndarray | None = None) -> None:
    if sign is not None:
        block = block * sign[None, :, None] * sign[None, None, :]
    target[:, np.ix_(idx, idx)[0], np.ix_(idx, idx)[1]] += block


def local_stiffness(L, E, G, A, Iy, Iz, J) -> np.ndarray:
    """Element stiffness in element axes, (n, 12, 12).  L per element; the rest scalars or per element."""
    L = np.atleast_1d(np.asarray(L, dtype=float))
    n = L.size
    bc = lambda x: np.broadcast_to(np.asarray(x, dtype=float), (n,))  # noqa: E731
    E, G, A, Iy, Iz, J = map(bc, (E, G, A, Iy, Iz, J))
    K = np.zeros((n, 12, 12))
    bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
    _scatter(K, _AXIAL, np.einsum("ij,n->nij", bar, E * A / L))
    _scatter(K, _TORSION, np.einsum("ij,n->nij", bar, G * J / L))
    _scatter(K, _BEND_XY, _hermite_block(_HERMITE_K, E * Iz / L**3, L))
    _scatter(K, _BEND_XZ, _hermite_block(_HERMITE_K, E * Iy / L**3, L), _XZ_SIGN)
    return K


def local_mass(L, rho, A, Iy, Iz, rotary_inertia: bool = False) -> np.ndarray:
    """Consistent element mass in element axes, (n, 12, 12).

    Includes axial and torsional inertia (rho*Ip with Ip = Iy + Iz, which equals rho*J for
    circular sections); rotary inertia of the bending slopes only if ``rotary_inertia``.
    """
    L = np.atleast_1d(np.asarray(L, dtype=float))
    n = L.size
    bc = lambda x: np.broadcast_to(np.asarray(x, dtype=float), (n,))  # noqa: E731
    rho, A, Iy, Iz = map(bc, (rho, A, Iy, Iz))
    Mloc = np.zeros((n, 12, 12))
    bar = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
    _scatter(Mloc, _AXIAL, np.einsum("ij,n->nij", bar, rho * A * L))
    _scatter(Mloc, _TORSION, np.einsum("ij,n->nij", bar, rho * (Iy + Iz) * L))
    _scatter(Mloc, _BEND_XY, _hermite_block(_HERMITE_M, rho * A * L / 420.0, L))
    _scatter(Mloc, _BEND_XZ, _hermite_block(_HERMITE_M, rho * A * L / 420.0, L), _XZ_SIGN)
    if rotary_inertia:
        _scatter(Mloc, _BEND_XY, _hermite_block(_ROTARY_M, rho * Iz / (30.0 * L), L))
        _scatter(Mloc, _BEND_XZ, _hermite_block(_ROTARY_M, rho * Iy / (30.0 * L), L), _XZ_SIGN)
    return Mloc


def local_shape_functions(xi: float, L: float) -> np.ndarray:
    """Centre-line interpolation S in element axes, (6, 12): rows (u, v, w, theta_x, theta_y, theta_z).

    xi in [0, 1] is the position along the element.  Translations use linear (axial)
    and Hermite (bending) shape functions; rotation rows are the exact derivatives
    (theta_z = dv/dx, theta_y = -dw/dx) and linear torsion.
    """
    x = float(xi)
    h1, h2 = 1 - 3 * x**2 + 2 * x**3, L * (x - 2 * x**2 + x**3)
    h3, h4 = 3 * x**2 - 2 * x**3, L * (-x**2 + x**3)
    d1, d2 = (-6 * x + 6 * x**2) / L, 1 - 4 * x + 3 * x**2
    d3, d4 = (6 * x - 6 * x**2) / L, -2 * x + 3 * x**2
    S = np.zeros((6, 12))
    S[0, [0, 6]] = [1 - x, x]
    S[3, [3, 9]] = [1 - x, x]
    S[1, _BEND_XY] = [h1, h2, h3, h4]
    S[2, _BEND_XZ] = np.array([h1, h2, h3, h4]) * _XZ_SIGN
    S[5, _BEND_XY] = [d1, d2, d3, d4]
    S[4, _BEND_XZ] = -np.array([d1, d2, d3, d4]) * _XZ_SIGN
    return S
