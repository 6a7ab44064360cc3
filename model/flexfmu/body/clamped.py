"""A clamped body on a moving base: the FFR beam's Eq. (*) (flexfmu.ffr.dynamics) for any Structure, its inertia
integrals taken from the mass matrix M instead of a beam's centre line.

Frame and fields.  The body frame is the base's; its origin O is the Structure's coordinate origin; every vector
below is in body components.  u (n_dof) is the elastic displacement (zero on the clamped DOFs), u = Phi eta with
Phi (n_dof, m) the retained coordinates (modes of the clamped structure, then residual vectors), Phi^T M Phi = I,
Phi^T K Phi = Lambda.  On the DOFs:

    T   (n_dof, 3)  unit translations: 1 on the translational DOFs of every node, 0 on rotational DOFs;
    S0  (n_dof, 3)  unit rotations about O: e_k x x_i on node i's translations, e_k on its rotations;
    L_k (n_dof, n_dof)  e_k x (.) applied to every node's translation (0 on rotational DOFs);
                    L(w) = sum_k w_k L_k = sum_ab [w]x_ab E_ab with E_ab putting component b of each node's
                    translation into component a.

Kinetic energy of the nodal model (the one the reframe integrator uses, flexfmu.reframe.kernel_data), the base
moving with velocity v and angular velocity w:

    T = 1/2 w_n^T M w_n,    w_n = T v + S0 w + L(w) u + u_dot.                                          (B0)

It is exact for rigid motion (T and S0 are rigid fields every element reproduces) and for any motion of solid
meshes (3 DOFs per node, one interpolation for x, y, z: M = m (x) I3 commutes with every E_ab).  Lagrange's
equations for u with (v, w) prescribed give the elastic terms of

    M u_dd + (C + M L(w) + L(w) M) u_d + (K + M L(alpha) + L(w) M L(w)) u
        = Q - M a_base,    a_base = T a0 + S0 alpha + L(w) S0 w,                                        (B1)

(L(w)^T = -L(w): the gyroscopic matrix is skew, the centrifugal one symmetric).  The base's load is d'Alembert's:
M times the base's rigid acceleration field at the nodes, a0 + alpha x x_i + w x (w x x_i) on the translations,
alpha on the rotations.  Lagrange's own base terms, M T v_d + L(w) M T v + M S0 alpha + L(w) M S0 w, equal it
for solids; on beams M T a0 (a0 = v_d + w x v) keeps the equations Galilean invariant, and M L(w) S0 w is exact
where the centripetal field is (a spinning straight rod) while L(w) M S0 w is not.  In the retained coordinates
(Phi^T L_k = -(L_k Phi)^T):

    eta_dd + (Z + G) eta_d + (Lambda + H) eta = Phi^T Q - Sa a0 - Sw alpha + sum_kl w_k w_l R_kl,         (B2)
    G = sum_k w_k (B_k - B_k^T),    H = sum_k alpha_k B_k - sum_kl w_k w_l N_kl,
    B_k = Phi^T M L_k Phi,  N_kl = (L_k Phi)^T M (L_l Phi),  R_kl = -Phi^T M L_k S0 e_l,
    Sa = Phi^T M T,  Sw = Phi^T M S0,  Z = diag(2 zeta omega_j).

Relation to (*).  Its inertia shape integrals are, from M,

    S_bar = T^T M (exact),   sum_ab X_ab P_ab = M S0 alpha + M L(w) S0 w,   M_ab = M E_ab            (B3)

(X = [alpha]x + [w]x^2, W = [w]x): for isotropic M (solids) M E_ab = E_ab M, so 2 sum W_ab M_ab = M L(w) + L(w) M
and sum X_ab M_ab = M L(alpha) + L(w) M L(w), and (B1) is (*) exactly.  On 6-DOF nodes (beams) (B0) rotates the
nodes' translations where (*) rotates the Hermite-interpolated field between them: the couplings to w and alpha
then differ from the centre-line quadrature by O(h^2) in the element length h (spatial double-L: the matrices G
and H by 5e-3 ... 9e-3 at 8 and 3e-4 ... 6e-4 at 32 elements per segment, the response to a base rotation by
~1e-4 at 8, tests/test_body_clamped.py), and M carries the cross-sections' torsional (and, when
assembled, bending) rotary inertia, which (*) leaves out and which couples to alpha through M S0 alpha (the
sections' torques J alpha; relative size ~ d^2 / (8 L^2)).  The sections' gyroscopic w x (J w) is not in (B0)
(linear in the nodal rotations, as in the reframe integrator).  The base acceleration a0 enters exactly for both.

Reactions (Newton-Euler of the whole structure, damping internal: no net force or moment).  What the structure
exerts on its clamps, body frame, about O:

    F_base = sum_I F_I - F_in,    M_base = sum_I (M_I + (x_I + u_I) x F_I) - M_in,                         (B4)
    F_in = T^T f_in,   M_in = S0^T f_in + sum_i u_i x f0_i      (to first order in u),

with f_in the inertia force of (B1) (its left side's M, L terms and M a_base) and f0 = M a_base its part without u.
The rigid parts are the exact rigid-body ones (first moment mc = T^T M x, J0 = S0^T M S0, both about O):

    T^T f0 = m a0 + alpha x mc + w x (w x mc),    S0^T f0 = mc x a0 + J0 alpha + w x (J0 w),            (B5)

and the elastic parts, for a test field V = T or S0 (V^T L(w) = -sum_k w_k (L_k V)^T),

    V^T f1 = V^T M (L(alpha) u + L(w) u_d + u_dd) - sum_k w_k (L_k V)^T M (L(w) u + u_d).                (B6)

The interface loads F_I, M_I act at the interface points x_I (moved by u_I, the interfaces' translation).
"""
from __future__ import annotations

import numpy as np

from flexfmu.errors import ParameterError

#: the base-load patterns of (B1) whose moment arm term sum_i u_i x f0_i is tabulated: M T e_a (3), M S0 e_a (3),
#: M L_k S0 e_l (9, row-major k, l)
N_BASE_PATTERNS = 15


def rigid_fields(nodes: np.ndarray, dpn: int) -> tuple[np.ndarray, np.ndarray]:
    """T and S0 (n_dof, 3) of the module docstring."""
    n = nodes.shape[0]
    T = np.zeros((n * dpn, 3))
    S0 = np.zeros((n * dpn, 3))
    eye = np.eye(3)
    for k in range(3):
        T[k::dpn, k] = 1.0
        rot = np.cross(eye[k], nodes)
        for j in range(3):
            S0[j::dpn, k] = rot[:, j]
        if dpn == 6:
            S0[3 + k::dpn, k] = 1.0
    return T, S0


def rotate_translations(X: np.ndarray, k: int, dpn: int) -> np.ndarray:
    """L_k X: e_k x (each node's translation) for every column of X (n_dof, c); 0 on rotational DOFs."""
    out = np.zeros_like(X)
    x, y, z = (X[c::dpn] for c in range(3))
    if k == 0:
        out[1::dpn], out[2::dpn] = -z, y
    elif k == 1:
        out[0::dpn], out[2::dpn] = z, -x
    else:
        out[0::dpn], out[1::dpn] = -y, x
    return out


def _node_cross(U: np.ndarray, G: np.ndarray, dpn: int) -> np.ndarray:
    """(3, cols of U, cols of G): sum_i u_i x g_i over the nodes' translations, for every pair of columns."""
    u = [U[c::dpn] for c in range(3)]
    g = [G[c::dpn] for c in range(3)]
    return np.stack([u[1].T @ g[2] - u[2].T @ g[1], u[2].T @ g[0] - u[0].T @ g[2], u[0].T @ g[1] - u[1].T @ g[0]])


def clamped_invariants(structure, shapes: np.ndarray) -> dict:
    """The arrays of (B2)-(B6) for retained coordinates ``shapes`` (n_dof, m) of ``structure`` (zero on the
    clamped DOFs, M-orthonormal).  Keys: mass, first_moment (mc), J0 (about O), Sa, Sw (m, 3), B (3, m, m),
    N (3, 3, m, m), R (3, 3, m), Vp (2, 3, m) = V^T M Phi, Va (2, 3, 3, m) = V^T M L_k Phi, Vq (2, 3, 3, 3, m) =
    (L_k V)^T M L_l Phi, Vr (2, 3, 3, m) = (L_k V)^T M Phi (V = T, S0), arm (15, 3, m) the first-order arm term
    sum_i u_i x f0_i per unit base pattern (N_BASE_PATTERNS)."""
    dpn = int(structure.dofs_per_node)
    M = structure.M.tocsr()
    Phi = np.asarray(shapes, dtype=float)
    nodes = np.asarray(structure.nodes, dtype=float)
    if Phi.ndim != 2 or Phi.shape[0] != M.shape[0]:
        raise ParameterError("shapes", f"shape {Phi.shape}", f"({M.shape[0]}, m)")
    T, S0 = rigid_fields(nodes, dpn)
    V = np.hstack([T, S0])                                          # the test fields
    MT, MS0, MPhi = M @ T, M @ S0, M @ Phi
    LPhi = [rotate_translations(Phi, k, dpn) for k in range(3)]
    MLPhi = [M @ X for X in LPhi]
    LV = [rotate_translations(V, k, dpn) for k in range(3)]
    MLS0 = [M @ rotate_translations(S0, k, dpn) for k in range(3)]  # M L_k S0: centripetal patterns
    mass = float(np.mean(np.diag(T.T @ MT)))
    position = np.zeros(M.shape[0])                                 # x_i on the translations: a linear field
    for c in range(3):
        position[c::dpn] = nodes[:, c]
    J0 = S0.T @ MS0
    f3 = [slice(0, 3), slice(3, 6)]                                 # V = [T, S0]
    out = {
        "mass": np.array(mass), "first_moment": T.T @ (M @ position), "J0": 0.5 * (J0 + J0.T),
        "Sa": Phi.T @ MT, "Sw": Phi.T @ MS0,
        "B": np.stack([Phi.T @ X for X in MLPhi]),
        "N": np.stack([np.stack([LPhi[k].T @ MLPhi[l] for l in range(3)]) for k in range(3)]),
        "R": np.stack([-(Phi.T @ MLS0[k]).T for k in range(3)]),
        "Vp": np.stack([V[:, f].T @ MPhi for f in f3]),
        "Va": np.stack([np.stack([V[:, f].T @ MLPhi[k] for k in range(3)]) for f in f3]),
        "Vq": np.stack([np.stack([np.stack([LV[k][:, f].T @ MLPhi[l] for l in range(3)]) for k in range(3)])
                        for f in f3]),
        "Vr": np.stack([np.stack([LV[k][:, f].T @ MPhi for k in range(3)]) for f in f3]),
    }
    base = np.hstack([MT, MS0] + MLS0)                            # the 3 + 3 + 9 base patterns of f0
    out["arm"] = _node_cross(Phi, base, dpn).transpose(2, 0, 1)     # (15, 3, m)
    return {k: np.array(v, dtype=float, order="C") for k, v in out.items()}


def base_patterns(structure) -> dict:
    """The base's inertial load patterns of (B1) on all DOFs (for the model size): base_a: -M T (a0),
    base_alpha: -M S0 (alpha), base_spin: -M L_k S0 e_l (w_k w_l)."""
    dpn = int(structure.dofs_per_node)
    M = structure.M.tocsr()
    T, S0 = rigid_fields(np.asarray(structure.nodes, dtype=float), dpn)
    return {"base_a": -(M @ T), "base_alpha": -(M @ S0),
            "base_spin": -np.hstack([M @ rotate_translations(S0, k, dpn) for k in range(3)])}
