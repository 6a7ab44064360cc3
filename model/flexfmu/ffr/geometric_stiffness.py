"""Geometric (stress) stiffness of a beam structure prestressed by the inertial load of its frame's motion.

Why: a linear floating-frame model keeps the centrifugal *softening* -omega^2 M of the transverse motion
(ffr_dynamics Eq. (*)) but not the *stiffening* by the tension that the same rotation induces.  A cantilever
spun faster than its first bending frequency then loses positive stiffness and diverges (the spin-up of Kane,
Ryan & Banerjee 1987).  The missing term is the geometric stiffness of that prestress, computed here.

Load field.  In a frame whose origin accelerates with a0 and which turns with omega, alpha (held, body frame),
a centre-line point u0 carries the d'Alembert load  b = -rho A (a0 + X u0)  per unit length,
X = [alpha]x + [omega]x^2, and a point mass m at r the load -m (a0 + X r).  It is linear in the 12 numbers
(X_ab, a0_a), so it is the sum of 12 unit load patterns

    b = sum_ab X_ab b_ab + sum_a a0_a b_a,    b_ab(x) = -rho A e_a u0_b(x),    b_a = -rho A e_a.       (1)

Quasi-static prestress.  For each pattern the consistent nodal loads f_p = int S^T b_p dx (+ point masses) are
applied to the linear structure, K u_p = f_p:
  * clamped structure: on the free DOFs (K_free);
  * free structure (no clamps): inertia relief first.  The rigid body accelerates as a whole under f_p with
    (a_R, alpha_R) about the centre of mass c: m a_R = F_p, J_c alpha_R = M_c,p (total force and moment of b_p);
    adding its d'Alembert field -rho A (a_R + alpha_R x (u0 - c)) makes the load self-equilibrated.  Any one
    node is then clamped to remove the rigid modes: its reaction is zero, and the element forces do not
    depend on the choice.  (J_c is pseudo-inverted: a straight rod has no centre-line inertia about its axis,
    and no load moment about it either.)
The rigid-body inertia is the centre-line mass rho A plus the scene's point masses (the convention of
flexfmu.ffr.dynamics.inertia_integrals); the torsional inertia rho Ip of the sections is left out.

Axial force (tension > 0) along an element of length L, element axes: from the element end forces
r = K^e d^e - f^e (K^e, d^e, f^e in element axes), N(0) = -r_0, and axial equilibrium N' = -p with p the
axial component of b (linear along a straight element):

    N(xi) = N(0) - L [p_1 (xi - xi^2 / 2) + p_2 xi^2 / 2],    xi = x / L in [0, 1],                     (2)

exact for the distributed load (the axial bar's nodal solution is exact), not an element average.

Geometric stiffness of an element: the second-order strain energy of the prestress, Green's axial strain
eps = u' + (v'^2 + w'^2) / 2 plus the Wagner term of torsion,

    K_G^e = int_0^L N(x) [ v'^T v' + w'^T w' + (Ip / A) theta_x'^T theta_x' ] dx,                        (3)

with the rows of v', w' and theta_x' the element type's strain_gradients (flexfmu.ffr.elements; for the
Euler-Bernoulli element the theta_z and -theta_y rows of its Hermite interpolation, theta_x linear).  For the
Euler-Bernoulli element and constant N this is the textbook matrix N/(30 L) [36, 3L, -36, 3L; 3L, 4L^2, -3L, -L^2;
...] per bending plane plus N Ip / (A L) [1, -1; -1, 1] in torsion (Przemieniecki 1968, McGuire, Gallagher &
Ziemian 2000, Sec. 9.3).  N is quadratic and v' quadratic in xi (the derivative of a cubic deflection, for both
element types), so 4 Gauss points integrate (3) exactly.  Only the
axial force is taken: the shear- and moment-dependent terms of the full 3D geometric stiffness are left out
(they vanish for a straight rod under a centrifugal or uniform load along it, and are of the order of the
bending deflection otherwise).  K_G^e is turned to body axes with C_bar K_G^e C_bar^T and assembled.  The element
end forces r and the consistent loads f^e use the element type's stiffness and shape functions.

Result (body frame, unconstrained DOFs), with (1) and the linearity of (2)-(3):

    K_G(X, a0) = sum_ab X_ab G_ab + sum_a a0_a G_a.                                                     (4)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexfmu.errors import require
from flexfmu.ffr.assembly import BeamModel, boundary_matrix
from flexfmu.ffr.elements import BeamElement, get_element

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)    # exact to degree 7: N (2) x v'^2 (4) = 6
N_PATTERNS = 12                                           # 9 X_ab patterns (row-major a, b), then 3 a0_a


@dataclass
class InertialGeometricStiffness:
    """Geometric stiffness matrices of the 12 unit inertial load patterns of Eq. (1), body frame.

    X[a][b]:  sparse (n_dof, n_dof), G_ab of Eq. (4): for X_ab = 1 (N m^-1 per s^-2, i.e. kg).
    a0[a]:    sparse (n_dof, n_dof), G_a of Eq. (4): for a0_a = 1 m/s^2 (N/m per m/s^2, i.e. kg/m).
    axial_force: (12, n_elements, 2) element axial forces N (N, tension > 0) at the element's first and last
              node for each unit pattern (order: X_00, X_01, ..., X_22, a0_0, a0_1, a0_2).
    free:     True when the structure has no clamp (inertia relief was used).
    """

    X: list
    a0: list
    axial_force: np.ndarray
    free: bool

    def combine(self, X, a0=(0.0, 0.0, 0.0)) -> sp.csr_matrix:
        """K_G of Eq. (4) for X (3, 3) (s^-2) and a0 (3,) (m/s^2), body frame."""
        X, a0 = np.asarray(X, float), np.asarray(a0, float)
        out = sum(X[a, b] * self.X[a][b] for a in range(3) for b in range(3))
        return (out + sum(a0[a] * self.a0[a] for a in range(3))).tocsr()

    def modal(self, Phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Projections on the columns of Phi (n_dof, m): (G_X (3, 3, m, m), G_a0 (3, m, m))."""
        G_X = np.array([[Phi.T @ (self.X[a][b] @ Phi) for b in range(3)] for a in range(3)])
        G_a0 = np.array([Phi.T @ (self.a0[a] @ Phi) for a in range(3)])
        return G_X, G_a0


def _gauss_point_matrices(L: np.ndarray, ratio: np.ndarray, element: BeamElement, section=None,
                          material=None) -> np.ndarray:
    """(4, n, 12, 12): weight x [v'^T v' + w'^T w' + (Ip/A) theta_x'^T theta_x'] at each Gauss point of Eq. (3)."""
    out = np.zeros((len(_GAUSS_X), L.size, 12, 12))
    for g, (xg, wg) in enumerate(zip(_GAUSS_X, _GAUSS_W)):
        xi = 0.5 * (xg + 1.0)
        for e in range(L.size):
            dv, dw, dt = element.strain_gradients(xi, L[e], section, material)
            out[g, e] = 0.5 * wg * L[e] * (np.outer(dv, dv) + np.outer(dw, dw) + ratio[e] * np.outer(dt, dt))
    return out


def local_geometric_stiffness(L, N_gauss, Ip_over_A, element: BeamElement | None = None, section=None,
                              material=None) -> np.ndarray:
    """K_G^e of Eq. (3) in element axes, (n, 12, 12), from the axial force at the 4 Gauss points
    N_gauss (n, 4) (N, tension > 0) of elements of length L (n,) (m); Ip_over_A (m^2) scalar or (n,).
    element (default Euler-Bernoulli) and the section and material it may need give v', w' and theta_x'."""
    L = np.atleast_1d(np.asarray(L, float))
    N_gauss = np.asarray(N_gauss, float).reshape(L.size, len(_GAUSS_X))
    ratio = np.broadcast_to(np.asarray(Ip_over_A, float), L.shape)
    element = get_element() if element is None else element
    return np.einsum("eg,geij->eij", N_gauss, _gauss_point_matrices(L, ratio, element, section, material))


def _pattern_loads(model: BeamModel):
    """Load density of the 12 unit patterns of Eq. (1) at the element nodes, (12, n_el, 2, 3) N/m body frame,
    and at the point masses, (12, n_pm, 3) N, with the point-mass nodes and positions."""
    mesh = model.mesh
    scene = mesh.scene
    rhoA = scene.material.rho * scene.section.A
    ends = mesh.nodes[mesh.elements]                              # (n_el, 2, 3)
    pm_nodes = np.array([mesh.node_at(pm.s, "point_masses.s") for pm in scene.point_masses], dtype=np.int64)
    pm_mass = np.array([pm.mass for pm in scene.point_masses])
    pm_pos = mesh.nodes[pm_nodes] if pm_nodes.size else np.zeros((0, 3))
    b = np.zeros((N_PATTERNS, len(mesh.elements), 2, 3))
    f_pm = np.zeros((N_PATTERNS, pm_nodes.size, 3))
    for a in range(3):
        for c in range(3):
            b[3 * a + c, :, :, a] = -rhoA * ends[:, :, c]
            f_pm[3 * a + c, :, a] = -pm_mass * pm_pos[:, c]
        b[9 + a, :, :, a] = -rhoA
        f_pm[9 + a, :, a] = -pm_mass
    return b, f_pm, pm_nodes, pm_mass, pm_pos


def _relieve(model: BeamModel, b, f_pm, pm_mass, pm_pos) -> None:
    """Inertia relief of a free structure (module docstring), in place: add the d'Alembert field of the rigid
    acceleration that the total force and moment of each pattern would give the free body."""
    mesh = model.mesh
    rhoA = mesh.scene.material.rho * mesh.scene.section.A
    ends = mesh.nodes[mesh.elements]
    L = mesh.element_length
    # Centre-line mass, centre of mass and inertia about it; force and moment of the pattern (integrands at
    # most quadratic along an element: exact with 3 Gauss points).
    gx, gw = np.polynomial.legendre.leggauss(3)
    xi = 0.5 * (gx + 1.0)
    w = 0.5 * gw[None, :] * L[:, None]                           # (n_el, n_gp) length weights
    pts = (1 - xi)[None, :, None] * ends[:, None, 0] + xi[None, :, None] * ends[:, None, 1]
    mass = rhoA * w.sum() + pm_mass.sum()
    c = (rhoA * np.einsum("eg,egk->k", w, pts) + pm_mass @ pm_pos) / mass
    r = pts - c
    rp = pm_pos - c
    J = (rhoA * (np.einsum("eg,egk,egk->", w, r, r) * np.eye(3) - np.einsum("eg,ega,egb->ab", w, r, r))
         + (np.einsum("p,pk,pk->", pm_mass, rp, rp) * np.eye(3) - np.einsum("p,pa,pb->ab", pm_mass, rp, rp)))
    J_pinv = np.linalg.pinv(J, rcond=1e-10)
    for p in range(N_PATTERNS):
        bg = (1 - xi)[None, :, None] * b[p, :, None, 0] + xi[None, :, None] * b[p, :, None, 1]
        F = np.einsum("eg,egk->k", w, bg) + f_pm[p].sum(axis=0)
        Mc = np.einsum("eg,egk->k", w, np.cross(r, bg)) + np.cross(rp, f_pm[p]).sum(axis=0)
        a_R = F / mass
        al_R = J_pinv @ Mc
        # d'Alembert field of the rigid acceleration a_R + al_R x (x - c), linear along each element
        b[p] -= rhoA * (a_R + np.cross(al_R, ends - c))
        f_pm[p] -= pm_mass[:, None] * (a_R + np.cross(al_R, rp))


def inertial_geometric_stiffness(model: BeamModel, *, free_hold_node: int = 0) -> InertialGeometricStiffness:
    """G_ab and G_a of Eq. (4) for a beam structure (clamped, or free: inertia relief), see the module docstring.

    free_hold_node: the node clamped during the quasi-static solve of a free structure (after the relief the
    load is self-equilibrated, so the result does not depend on it; tests vary it)."""
    mesh = model.mesh
    scene = mesh.scene
    sec, mat = scene.section, scene.material
    element = mesh.element
    n, n_el = model.n_dof, len(mesh.elements)
    L = mesh.element_length
    C = mesh.element_rotation                                     # (n_el, 3, 3) element -> body
    Cbar = element.dof_rotation(C)                               # (n_el, 12, 12)
    dofs = (6 * mesh.elements[:, :, None] + np.arange(6)).reshape(-1, 12)

    b, f_pm, pm_nodes, pm_mass, pm_pos = _pattern_loads(model)
    free = model.clamped_nodes.size == 0
    require(isinstance(free_hold_node, (int, np.integer)) and 0 <= free_hold_node < mesh.n_nodes,
            "free_hold_node", f"got {free_hold_node!r}", f"a node index 0 .. {mesh.n_nodes - 1}")
    if free:
        _relieve(model, b, f_pm, pm_mass, pm_pos)

    # Consistent element loads, element axes: f^e = int S_local^T (C^T b) dx, b linear along the element.
    f_loc = np.zeros((N_PATTERNS, n_el, 12))
    for xg, wg in zip(_GAUSS_X, _GAUSS_W):
        xi = 0.5 * (xg + 1.0)
        b_loc = np.einsum("eka,pek->pea", C, (1 - xi) * b[:, :, 0] + xi * b[:, :, 1])   # C^T b
        for e in range(n_el):
            S = element.shape_functions(xi, L[e], sec, mat)[:3]   # (3, 12) translations, element axes
            f_loc[:, e] += 0.5 * wg * L[e] * b_loc[:, e] @ S
    f = np.zeros((N_PATTERNS, n))
    np.add.at(f.T, dofs, np.einsum("eij,pej->eip", Cbar, f_loc))
    for k, node in enumerate(pm_nodes):
        f[:, 6 * node:6 * node + 3] += f_pm[:, k]

    # Quasi-static displacements: clamped structure, or (free) one node clamped after the relief.
    B2 = model.B2 if not free else boundary_matrix(mesh.n_nodes, [int(free_hold_node)])
    lu = spla.splu(sp.csc_matrix(B2.T @ model.K @ B2))
    u = (B2 @ lu.solve(np.ascontiguousarray((B2.T @ f.T)))).T    # (12, n)

    # Element end forces and the axial force (2) at the element ends and Gauss points.
    K_loc = element.stiffness(L, sec, mat)
    d_loc = np.einsum("eji,pej->pei", Cbar, u[:, dofs])          # C_bar^T u
    r = np.einsum("eij,pej->pei", K_loc, d_loc) - f_loc
    N1 = -r[:, :, 0]
    p_ends = np.einsum("ek,pemk->pem", C[:, :, 0], b)            # axial component of b at both ends
    p1, p2 = p_ends[:, :, 0], p_ends[:, :, 1]

    def axial(xi):
        return N1 - L * (p1 * (xi - 0.5 * xi**2) + p2 * 0.5 * xi**2)

    axial_force = np.stack([axial(0.0), axial(1.0)], axis=-1)
    N_gauss = np.stack([axial(0.5 * (xg + 1.0)) for xg in _GAUSS_X], axis=-1)    # (12, n_el, 4)

    # Eq. (3) is linear in N: the Gauss-point matrices once (body axes), then weighted per pattern.
    unit = _gauss_point_matrices(L, np.full(n_el, sec.Ip / sec.A), element, sec, mat)
    unit_body = np.einsum("eij,gejk,elk->geil", Cbar, unit, Cbar)   # C_bar K_G C_bar^T
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    mats = []
    for p in range(N_PATTERNS):
        Ge = np.einsum("eg,geij->eij", N_gauss[p], unit_body)
        G = sp.csr_matrix((Ge.ravel(), (rows, cols)), shape=(n, n))
        mats.append(((G + G.T) * 0.5).tocsr())
    return InertialGeometricStiffness(X=[mats[3 * a:3 * a + 3] for a in range(3)], a0=mats[9:],
                                      axial_force=axial_force, free=free)
