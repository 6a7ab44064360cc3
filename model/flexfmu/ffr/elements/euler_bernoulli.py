"""The 12-DOF 3D Euler-Bernoulli beam element of the FFR model (Koda et al. 2025, Sec. 2): linear axial and
torsion, cubic Hermite bending in both planes, consistent mass with axial and torsional inertia and optional
rotary inertia (Przemieniecki 1968).  No shear deformation.

Local element DOF order per node: (u, v, w, theta_x, theta_y, theta_z) along the
element axes (x_bar along the element, y_bar, z_bar the section axes); node 1 then node 2.
Sign convention: theta_z = dv/dx, theta_y = -dw/dx (right-handed rotations).
All functions are vectorised over elements (leading axis).
"""
from __future__ import annotations

import numpy as np

from flexfmu.ffr.elements.base import AXIAL, BEND_XY, BEND_XZ, TORSION, XZ_SIGN, BeamElement, scatter

_HERMITE_K = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], dtype=float)
_HERMITE_M = np.array([[156, 22, 54, -13], [22, 4, 13, -3], [54, 13, 156, -22], [-13, -3, -22, 4]], dtype=float)
_ROTARY_M = np.array([[36, 3, -36, 3], [3, 4, -3, -1], [-36, -3, 36, -3], [3, -1, -3, 4]], dtype=float)


def _hermite_block(pattern: np.ndarray, factor: np.ndarray, L: np.ndarray) -> np.ndarray:
    """(n, 4, 4) block on (deflection1, slope1, deflection2, slope2): factor * pattern with slope rows/cols * L."""
    scale = np.ones((L.size, 4))
    scale[:, 1] = L
    scale[:, 3] = L
    return np.einsum("ij,n->nij", pattern, factor) * scale[:, :, None] * scale[:, None, :]


def local_stiffness(L, E, G, A, Iy, Iz, J) -> np.ndarray:
    """Element stiffness in element axes, (n, 12, 12).  L per element; the rest scalars or per element."""
    L = np.atleast_1d(np.asarray(L, dtype=float))
    n = L.size
    bc = lambda x: np.broadcast_to(np.asarray(x, dtype=float), (n,))  # noqa: E731
    E, G, A, Iy, Iz, J = map(bc, (E, G, A, Iy, Iz, J))
    K = np.zeros((n, 12, 12))
    bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
    scatter(K, AXIAL, np.einsum("ij,n->nij", bar, E * A / L))
    scatter(K, TORSION, np.einsum("ij,n->nij", bar, G * J / L))
    scatter(K, BEND_XY, _hermite_block(_HERMITE_K, E * Iz / L**3, L))
    scatter(K, BEND_XZ, _hermite_block(_HERMITE_K, E * Iy / L**3, L), XZ_SIGN)
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
    scatter(Mloc, AXIAL, np.einsum("ij,n->nij", bar, rho * A * L))
    scatter(Mloc, TORSION, np.einsum("ij,n->nij", bar, rho * (Iy + Iz) * L))
    scatter(Mloc, BEND_XY, _hermite_block(_HERMITE_M, rho * A * L / 420.0, L))
    scatter(Mloc, BEND_XZ, _hermite_block(_HERMITE_M, rho * A * L / 420.0, L), XZ_SIGN)
    if rotary_inertia:
        scatter(Mloc, BEND_XY, _hermite_block(_ROTARY_M, rho * Iz / (30.0 * L), L))
        scatter(Mloc, BEND_XZ, _hermite_block(_ROTARY_M, rho * Iy / (30.0 * L), L), XZ_SIGN)
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
    S[1, BEND_XY] = [h1, h2, h3, h4]
    S[2, BEND_XZ] = np.array([h1, h2, h3, h4]) * XZ_SIGN
    S[5, BEND_XY] = [d1, d2, d3, d4]
    S[4, BEND_XZ] = -np.array([d1, d2, d3, d4]) * XZ_SIGN
    return S


class EulerBernoulliElement(BeamElement):
    """The Euler-Bernoulli element above as an element object (the default of every scene)."""

    name = "euler_bernoulli"

    def stiffness(self, L, section, material) -> np.ndarray:
        return local_stiffness(L, material.E, material.G, section.A, section.Iy, section.Iz, section.J)

    def mass(self, L, section, material, rotary_inertia: bool = False) -> np.ndarray:
        return local_mass(L, material.rho, section.A, section.Iy, section.Iz, rotary_inertia=rotary_inertia)

    def shape_functions(self, xi: float, L: float, section=None, material=None) -> np.ndarray:
        return local_shape_functions(xi, L)

    def strain_gradients(self, xi: float, L: float, section=None, material=None) -> np.ndarray:
        # v' and w' are the slopes theta_z and -theta_y of the Hermite interpolation; theta_x is linear.
        S = local_shape_functions(xi, L)
        dt = np.zeros(12)
        dt[3], dt[9] = -1.0 / L, 1.0 / L
        return np.array([S[5], -S[4], dt])
