"""The 12-DOF 3D Timoshenko beam element: shear deformation and rotary inertia.

Przemieniecki, *Theory of Matrix Structural Analysis* (McGraw-Hill 1968), Ch. 5 (stiffness with shear
deformation) and Ch. 11 (consistent mass with shear deformation and rotary inertia); the same element is derived by
Davis, Henshell & Warburton, J. Sound Vib. 22 (1972) 475-487.  It is the two-node beam whose displacement
functions are the exact static deflections of a shear-deformable beam under end loads.  In
each bending plane, with the shear parameter

    Phi = 12 E I / (k G A L^2)                                                                          (T0)

(k: the section's shear coefficient, A_s = k A its shear area), and xi = x / L, the transverse displacement v and
the section rotation psi (theta_z in the x-y plane; -theta_y in the x-z plane, as the slopes of the
Euler-Bernoulli element) are interpolated from (v1, psi1, v2, psi2) by

    v   = [1 - 3xi^2 + 2xi^3 + Phi (1 - xi),  L (xi - 2xi^2 + xi^3 + Phi (xi - xi^2) / 2),
           3xi^2 - 2xi^3 + Phi xi,            L (-xi^2 + xi^3 - Phi (xi - xi^2) / 2)] / (1 + Phi),      (T1)
    psi = [6 (xi^2 - xi) / L,  1 - 4xi + 3xi^2 + Phi (1 - xi),
           6 (xi - xi^2) / L,  -2xi + 3xi^2 + Phi xi] / (1 + Phi),

so that the shear strain v' - psi is constant along the element.  Strain energy int E I psi'^2 + k G A (v' - psi)^2
gives the stiffness

    K = E I / ((1 + Phi) L^3) [[12, 6L, -12, 6L], [6L, (4 + Phi) L^2, -6L, (2 - Phi) L^2],
                               [-12, -6L, 12, -6L], [6L, (2 - Phi) L^2, -6L, (4 + Phi) L^2]],             (T2)

and the kinetic energy int rho A v^2 + rho I psi^2 the consistent mass, whose
coefficients are in :func:`_bending_mass`.  At Phi = 0 they are the Euler-Bernoulli element's stiffness and its
mass with rotary inertia.  Axial and torsional parts are the Euler-Bernoulli element's (linear, rho Ip torsional
inertia).  Rotary inertia is part of the theory, so it is always included.

The shear coefficient is Cowper's (Cowper 1966, J. Appl. Mech. 33:335-340) for the shaped sections,
or the section's ``shear_coefficient`` (required for a section given by its constants).
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.core.checks import shown
from flexfmu.errors import ParameterError
from flexfmu.ffr.elements.base import AXIAL, BEND_XY, BEND_XZ, TORSION, XZ_SIGN, BeamElement, scatter


def shear_coefficient(section, material) -> float:
    """k of (T0): the section's own ``shear_coefficient`` if given, else Cowper's (1966) for its shape."""
    given = getattr(section, "shear_coefficient", None)
    if given is not None:
        return float(given)
    nu = material.nu
    if section.shape == "circle":
        return 6 * (1 + nu) / (7 + 6 * nu)
    if section.shape == "rectangle":
        return 10 * (1 + nu) / (12 + 11 * nu)
    if section.shape == "tube":
        # m = di / do from A = pi (do^2 - di^2) / 4 and I = pi (do^4 - di^4) / 64: do^2 + di^2 = 16 I / A
        s, d = 16 * section.Iy / section.A, 4 * section.A / math.pi
        m2 = max(s - d, 0.0) / (s + d)
        return 6 * (1 + nu) * (1 + m2)**2 / ((7 + 6 * nu) * (1 + m2)**2 + (20 + 12 * nu) * m2)
    raise ParameterError("section.shear_coefficient", f"the Timoshenko element needs the shear coefficient of a "
                         f"section given by its constants (shape {shown(section.shape)})",
                         "a number 0 < k <= 1 in the section, or a circle, tube or rectangle")


def shear_parameters(L, section, material) -> tuple[np.ndarray, np.ndarray]:
    """(Phi_xy, Phi_xz) of (T0) per element: bending in the x-y plane (Iz) and in the x-z plane (Iy)."""
    L = np.atleast_1d(np.asarray(L, dtype=float))
    kGA = shear_coefficient(section, material) * material.G * section.A
    return 12 * material.E * section.Iz / (kGA * L**2), 12 * material.E * section.Iy / (kGA * L**2)


def _slope_scaled(c: np.ndarray, L: np.ndarray) -> np.ndarray:
    """(n, 4, 4) coefficients on (deflection1, slope1, deflection2, slope2) with the slope rows and columns * L."""
    scale = np.ones((L.size, 4))
    scale[:, 1] = L
    scale[:, 3] = L
    return c * scale[:, :, None] * scale[:, None, :]


def _symmetric(entries) -> np.ndarray:
    """(n, 4, 4) from the 10 upper-triangle arrays (n,) in row order 11, 12, 13, 14, 22, 23, 24, 33, 34, 44."""
    out = np.empty((entries[0].size, 4, 4))
    k = 0
    for i in range(4):
        for j in range(i, 4):
            out[:, i, j] = out[:, j, i] = entries[k]
            k += 1
    return out


def _bending_stiffness(EI, Phi: np.ndarray, L: np.ndarray) -> np.ndarray:
    """(T2), (n, 4, 4)."""
    one = np.ones_like(Phi)
    c = _symmetric([12 * one, 6 * one, -12 * one, 6 * one, 4 + Phi, -6 * one, 2 - Phi, 12 * one, -6 * one, 4 + Phi])
    return _slope_scaled(c, L) * (EI / ((1 + Phi) * L**3))[:, None, None]


def _bending_mass(rhoA, rhoI, Phi: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Consistent mass of one bending plane with rotary inertia (Przemieniecki 1968, Ch. 11), (n, 4, 4):
    rho A L / (1 + Phi)^2 [m_ij] + rho I / ((1 + Phi)^2 L) [r_ij], slope rows and columns times L."""
    P, P2 = Phi, Phi**2
    m11 = 13 / 35 + 7 / 10 * P + P2 / 3
    m12 = 11 / 210 + 11 / 120 * P + P2 / 24
    m13 = 9 / 70 + 3 / 10 * P + P2 / 6
    m14 = -(13 / 420 + 3 / 40 * P + P2 / 24)
    m22 = 1 / 105 + P / 60 + P2 / 120
    m24 = -(1 / 140 + P / 60 + P2 / 120)
    translation = _symmetric([m11, m12, m13, m14, m22, -m14, m24, m11, -m12, m22])
    one = np.ones_like(P)
    r12 = 1 / 10 - P / 2
    r22 = 2 / 15 + P / 6 + P2 / 3
    r24 = -1 / 30 - P / 6 + P2 / 6
    rotary = _symmetric([6 / 5 * one, r12, -6 / 5 * one, r12, r22, -r12, r24, 6 / 5 * one, -r12, r22])
    return _slope_scaled(translation * (rhoA * L / (1 + P)**2)[:, None, None]
                         + rotary * (rhoI / ((1 + P)**2 * L))[:, None, None], L)


def _bending_rows(xi: float, L: float, Phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(T1) at xi: the rows of v, psi and dv/dx on (v1, psi1, v2, psi2)."""
    x, P = float(xi), float(Phi)
    v = np.array([1 - 3 * x**2 + 2 * x**3 + P * (1 - x), L * (x - 2 * x**2 + x**3 + P * (x - x**2) / 2),
                  3 * x**2 - 2 * x**3 + P * x, L * (-x**2 + x**3 - P * (x - x**2) / 2)]) / (1 + P)
    psi = np.array([6 * (x**2 - x) / L, 1 - 4 * x + 3 * x**2 + P * (1 - x),
                    6 * (x - x**2) / L, -2 * x + 3 * x**2 + P * x]) / (1 + P)
    dv = np.array([(-6 * x + 6 * x**2 - P) / L, 1 - 4 * x + 3 * x**2 + P * (1 - 2 * x) / 2,
                   (6 * x - 6 * x**2 + P) / L, -2 * x + 3 * x**2 - P * (1 - 2 * x) / 2]) / (1 + P)
    return v, psi, dv


class TimoshenkoElement(BeamElement):
    """The shear-deformable element of the module docstring (scene ``"element": "timoshenko"``)."""

    name = "timoshenko"
    #: The shear strain v' - psi is constant in an element while a mode's shear force varies along it: the shear
    #: energy, and so the frequencies, converge as h^2 (the bending part as h^4; tests/test_beam_elements.py).
    convergence_order = 2

    def stiffness(self, L, section, material) -> np.ndarray:
        L = np.atleast_1d(np.asarray(L, dtype=float))
        phi_xy, phi_xz = shear_parameters(L, section, material)
        K = np.zeros((L.size, 12, 12))
        bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
        scatter(K, AXIAL, np.einsum("ij,n->nij", bar, material.E * section.A / L))
        scatter(K, TORSION, np.einsum("ij,n->nij", bar, material.G * section.J / L))
        scatter(K, BEND_XY, _bending_stiffness(material.E * section.Iz, phi_xy, L))
        scatter(K, BEND_XZ, _bending_stiffness(material.E * section.Iy, phi_xz, L), XZ_SIGN)
        return K

    def mass(self, L, section, material, rotary_inertia: bool = True) -> np.ndarray:
        """Consistent mass with rotary inertia (always: ``rotary_inertia`` is ignored)."""
        L = np.atleast_1d(np.asarray(L, dtype=float))
        phi_xy, phi_xz = shear_parameters(L, section, material)
        rho, A = material.rho, section.A
        M = np.zeros((L.size, 12, 12))
        bar = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
        scatter(M, AXIAL, np.einsum("ij,n->nij", bar, rho * A * L))
        scatter(M, TORSION, np.einsum("ij,n->nij", bar, rho * section.Ip * L))
        scatter(M, BEND_XY, _bending_mass(rho * A, rho * section.Iz, phi_xy, L))
        scatter(M, BEND_XZ, _bending_mass(rho * A, rho * section.Iy, phi_xz, L), XZ_SIGN)
        return M

    def shape_functions(self, xi: float, L: float, section, material) -> np.ndarray:
        """(T1) in both planes; the rotation rows are the section rotations, which differ from the slopes of the
        centre line by the shear strain."""
        phi_xy, phi_xz = (float(p[0]) for p in shear_parameters(L, section, material))
        x = float(xi)
        v, psi, _ = _bending_rows(x, L, phi_xy)
        w, chi, _ = _bending_rows(x, L, phi_xz)
        S = np.zeros((6, 12))
        S[0, AXIAL] = [1 - x, x]
        S[3, TORSION] = [1 - x, x]
        S[1, BEND_XY] = v
        S[5, BEND_XY] = psi
        S[2, BEND_XZ] = w * XZ_SIGN
        S[4, BEND_XZ] = -chi * XZ_SIGN
        return S

    def strain_gradients(self, xi: float, L: float, section, material) -> np.ndarray:
        phi_xy, phi_xz = (float(p[0]) for p in shear_parameters(L, section, material))
        G = np.zeros((3, 12))
        G[0, BEND_XY] = _bending_rows(xi, L, phi_xy)[2]
        G[1, BEND_XZ] = _bending_rows(xi, L, phi_xz)[2] * XZ_SIGN
        G[2, TORSION] = [-1.0 / L, 1.0 / L]
        return G
