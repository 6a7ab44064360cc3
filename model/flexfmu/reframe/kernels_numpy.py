"""The numpy versions of the reframe kernels (:mod:`flexfmu.reframe.kernels`): the reference the C kernels
(flexfmu/native/csrc/reframe_kernels.c) are checked against (tests/test_native_reframe_kernels.py), and the
kernels themselves when the C library is not available or with FLEXFMU_NATIVE_KERNELS=0.  Import the kernels
from flexfmu.reframe.kernels, which picks the version.

The scalar helpers are here too (the C file has their twins: ffx_reframe_solve3, _bound, _block_norm,
_max_node_norm), except the rotation formulas, which have one home, flexfmu.core.rotation (Rodrigues, the
quaternion, the rotation-vector rate: twins ffx_reframe_rodrigues, _quaternion, _rate_coefficient), and the
layouts, declared in flexfmu.reframe.layout (twin ffx_reframe_offsets).  This module imports neither
flexfmu.reframe.kernels nor flexfmu.native: the dependency runs layout <- kernels_numpy <- kernels."""
from __future__ import annotations

import math

import numpy as np

from flexfmu.core.rotation import quaternion_from_rotation as _quaternion
from flexfmu.core.rotation import rodrigues as _rodrigues
from flexfmu.core.rotation import rotvec_rate_unchecked as _rotvec_rate
from flexfmu.core.structure import N_RIGID
from flexfmu.core.vec3 import cross as _cross
from flexfmu.reframe.layout import BLOCK, NOT_COMPUTED, param_layout


# --------------------------------------------------------------------------- scalar helpers
def _solve3(S, r):
    """S x = r for a 3x3 S (Gaussian elimination with partial pivoting)."""
    A = S.copy()
    b = r.copy()
    for k in range(3):
        p = k
        for i in range(k + 1, 3):
            if abs(A[i, k]) > abs(A[p, k]):
                p = i
        if p != k:
            for j in range(3):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
        for i in range(k + 1, 3):
            f = A[i, k] / A[k, k]
            for j in range(k, 3):
                A[i, j] -= f * A[k, j]
            b[i] -= f * b[k]
    x = np.empty(3)
    for i in range(2, -1, -1):
        s = b[i]
        for j in range(i + 1, 3):
            s -= A[i, j] * x[j]
        x[i] = s / A[i, i]
    return x


# --------------------------------------------------------------------------- max elastic displacement
def max_node_norm_numpy(Psi, col, dpn, order, bc, br, sc, sr, q):
    """max over nodes i of |Phi_i q| (Phi_i: node i's 3 translational rows of Psi, columns col ...): all
    nodes, vectorised (the numpy version of flexfmu.reframe.kernels.max_node_norm)."""
    nf = q.shape[0]
    if nf == 0:
        return 0.0
    n_nodes = order.shape[0]
    rows = (dpn * np.arange(n_nodes)[:, None] + np.arange(3)).ravel()
    u = np.dot(Psi[rows, col:col + nf], q).reshape(n_nodes, 3)
    return float(np.max(np.sqrt(np.einsum("ic,ic->i", u, u))))


def _block_norm(Psi, col, dpn, order, b, q, best):
    nf = q.shape[0]
    stop = min((b + 1) * BLOCK, order.shape[0])
    for k in range(b * BLOCK, stop):
        i = order[k]
        s = 0.0
        for c in range(3):
            row = Psi[dpn * i + c, col:col + nf]
            u = 0.0
            for j in range(nf):
                u += row[j] * q[j]
            s += u * u
        s = math.sqrt(s)
        if s > best:
            best = s
    return best


def _bound(C, r, b, q, qn):
    """Upper bound of |Phi_i q| over the nodes of a (super)block: |C_b q| + r_b |q| (C_b: the block's mean
    of Phi_i (3 x nf, row-major), r_b >= max |Phi_i - C_b|_F)."""
    nf = q.shape[0]
    Cb = C[b]
    s = 0.0
    for c in range(3):
        u = 0.0
        for j in range(nf):
            u += Cb[c * nf + j] * q[j]
        s += u * u
    return (math.sqrt(s) + r[b] * qn) * (1.0 + 1e-12)


def max_node_norm_blocks(Psi, col, dpn, order, bc, br, sc, sr, q):
    """max over nodes i of |Phi_i q| (Phi_i: node i's 3 translational rows of Psi, columns col ...),
    exactly, without visiting every node: the algorithm of the C kernels' ffx_reframe_max_node_norm, here in
    plain Python as its reference (tests; the numpy kernels use :func:`max_node_norm_numpy`).  Nodes in
    ``order`` (a space-filling curve) form blocks of BLOCK nodes and superblocks of BLOCK blocks, each with
    the mean C of its Phi_i and a radius r >= max |Phi_i - C|_F, so |C q| + r |q| bounds |Phi_i q| inside it.  Only (super)blocks whose bound
    reaches the maximum found so far are searched: O(n_nodes / BLOCK^2) bounds plus a few blocks in
    practice (mode shapes are smooth); all nodes in the worst case."""
    nf = q.shape[0]
    if nf == 0:
        return 0.0
    qn = math.sqrt(np.dot(q, q))
    ns = sc.shape[0]
    nb = bc.shape[0]
    sb = np.empty(ns)
    s0 = 0
    for s in range(ns):
        sb[s] = _bound(sc, sr, s, q, qn)
        if sb[s] > sb[s0]:
            s0 = s
    b0 = s0 * BLOCK
    best_bound = -1.0
    for b in range(s0 * BLOCK, min((s0 + 1) * BLOCK, nb)):
        x = _bound(bc, br, b, q, qn)
        if x > best_bound:
            best_bound = x
            b0 = b
    best = _block_norm(Psi, col, dpn, order, b0, q, 0.0)
    for s in range(ns):
        if sb[s] < best:
            continue
        for b in range(s * BLOCK, min((s + 1) * BLOCK, nb)):
            if b != b0 and _bound(bc, br, b, q, qn) >= best:
                best = _block_norm(Psi, col, dpn, order, b, q, best)
    return best


# --------------------------------------------------------------------------- the kernels
def _blocks(P, nf, q):
    """A(q), J(q), D(q) of the generalised mass matrix [[m I, A, 0], [A^T, J, D], [0, D^T, I]]."""
    lay = param_layout(nf)
    J = P[lay.J0:lay.J0 + 9].copy().reshape(3, 3)
    if nf == 0:
        return np.zeros((3, 3)), J, np.zeros((3, 0))
    A = np.dot(q, P[lay.A:lay.B].reshape(nf, 9)).reshape(3, 3)
    Cq = np.dot(q, P[lay.C:lay.D].reshape(nf, nf * 9)).reshape(nf, 9)
    J += (np.dot(q, P[lay.B:lay.C].reshape(nf, 9)) + np.dot(q, Cq)).reshape(3, 3)
    D = np.dot(q, P[lay.D:lay.k].reshape(nf, 3 * nf)).reshape(3, nf)
    return A, J, D


def _solve_mass(m, A, J, D, b1, b2, b3):
    """Solve [[m I, A, 0], [A^T, J, D], [0, D^T, I]] [x1; x2; x3] = [b1; b2; b3] (Schur complement on x2)."""
    nf = D.shape[1]
    S = J - np.dot(A.T, A) / m
    r = b2 - np.dot(A.T, b1) / m
    if nf:
        S -= np.dot(D, D.T)
        r -= np.dot(D, b3)
    x2 = _solve3(S, r)
    x1 = (b1 - np.dot(A, x2)) / m
    if nf:
        x3 = b3 - np.dot(D.T, x2)
    else:
        x3 = b3.copy()
    return x1, x2, x3


def _dTdq(P, nf, v, w, q, qd):
    """dT/dq_j = v^T A_j w + w^T B_j w + sum_k q_k w^T C_jk w + w^T D_j qdot."""
    lay = param_layout(nf)
    t1 = np.dot(np.dot(P[lay.A:lay.B].reshape(nf * 3, 3), w).reshape(nf, 3), v)
    t2 = 0.5 * np.dot(np.dot(P[lay.B:lay.C].reshape(nf * 3, 3), w).reshape(nf, 3), w)
    Wc = np.dot(np.dot(P[lay.C:lay.D].reshape(nf * nf * 3, 3), w).reshape(nf * nf, 3), w).reshape(nf, nf)
    t3 = np.dot(Wc, q)
    t4 = np.dot(np.dot(P[lay.D:lay.k].reshape(nf * 3, nf), qd).reshape(nf, 3), w)
    return t1 + t2 + t3 + t4


def _loads(LP, nf, deformed, sv, R, q):
    """Global force sum, body moment about the frame point, flexible generalised forces of one stage."""
    F_g = np.zeros(3)
    N_b = np.zeros(3)
    Q = np.zeros(nf)
    stride = 5 + 6 * nf
    for l in range(sv.shape[0]):
        base = l * stride
        f = sv[l, 0:3]
        mo = sv[l, 3:6]
        if LP[base] != 0.0:            # follower: body components
            f_b = f.copy()
            m_b = mo.copy()
            F_g += np.dot(R, f)
        else:
            f_b = np.dot(R.T, f)
            m_b = np.dot(R.T, mo)
            F_g += f
        arm = LP[base + 2:base + 5].copy()
        if nf:
            PhiT = LP[base + 5:base + 5 + 3 * nf].reshape(3, nf)
            if deformed:
                arm += np.dot(PhiT, q)
            Q += np.dot(PhiT.T, f_b)
        N_b += _cross(arm, f_b)
        if LP[base + 1] != 0.0:
            N_b += m_b
            if nf:
                Q += np.dot(LP[base + 5 + 3 * nf:base + 5 + 6 * nf].reshape(3, nf).T, m_b)
    return F_g, N_b, Q


def _geometric_force(G, nf, w, q):
    """-(sum_ab X_ab G_ab) q with X = skew(w) skew(w) = w w^T - |w|^2 I (the geometric-stiffness hook;
    G: (9 nf nf,) = (3, 3, nf, nf) row-major, body frame)."""
    X = np.outer(w, w)
    ww = np.dot(w, w)
    for a in range(3):
        X[a, a] -= ww
    Kg = np.dot(X.reshape(9), G.reshape(9, nf * nf)).reshape(nf, nf)
    return -np.dot(Kg, q)


def _rhs(P, LP, G, nf, deformed, sv, Rn, z, split):
    """Time derivative of the step-local state z = [phi, dpos, p_g, H, q, p_q] (the consistent scheme, flexfmu.reframe.integrator).

    split=True (exponential scheme): N(z) = z' - L z instead, with L z = [0 (12), p_q, -k q - c p_q]
    the flexible modes' linear oscillator block, computed without forming L z (no k q cancellation):
    q' - p_q = -D(q)^T w and p_q' + k q + c p_q = dT/dq + c D^T w + Q."""
    m = P[0]
    lay = param_layout(nf)
    phi = z[0:3]
    Rrel = _rodrigues(phi)
    R = np.dot(Rn, Rrel)
    p_b = np.dot(R.T, z[6:9])
    h = np.dot(Rrel.T, z[9:12])
    q = z[12:12 + nf]
    pq = z[12 + nf:]
    A, J, D = _blocks(P, nf, q)
    v, w, qd = _solve_mass(m, A, J, D, p_b, h, pq)
    F_g, N_b, Q = _loads(LP, nf, deformed, sv, R, q)
    out = np.empty(z.shape[0])
    out[0:3] = _rotvec_rate(phi, w)
    out[3:6] = np.dot(R, v)
    out[6:9] = F_g
    out[9:12] = np.dot(Rrel, N_b - _cross(v, p_b))
    if nf:
        if split:
            Dtw = np.dot(D.T, w)
            out[12:12 + nf] = -Dtw
            out[12 + nf:] = _dTdq(P, nf, v, w, q, qd) + P[lay.c:lay.A6] * Dtw + Q
        else:
            out[12:12 + nf] = qd
            out[12 + nf:] = _dTdq(P, nf, v, w, q, qd) - P[lay.k:lay.c] * q - P[lay.c:lay.A6] * qd + Q
        if G.shape[0]:
            out[12 + nf:] += _geometric_force(G, nf, w, q)
    return out


def _expmap(EX, nf, k, z, s):
    """[s z_frame; M_j (q_j, p_j) per mode]: matrix k of the exponential scheme's coefficients EX (nf, 6,
    2, 2 row-major) on the flexible pairs, the scalar s (its value for L = 0) on the 12 frame components."""
    X = EX.reshape(nf, 6, 2, 2)
    out = np.empty(z.shape[0])
    out[0:12] = s * z[0:12]
    q = z[12:12 + nf]
    p = z[12 + nf:]
    out[12:12 + nf] = X[:, k, 0, 0] * q + X[:, k, 0, 1] * p
    out[12 + nf:] = X[:, k, 1, 0] * q + X[:, k, 1, 1] * p
    return out


def _step(P, LP, G, EX, nf, deformed, sv, dt, y):
    """One step of y in place (flexfmu.reframe.integrator): classical RK4 (EX empty, scheme "consistent") or the
    exponential ETD-RK4 (EX = its coefficients, scheme "exponential"); False if not finite."""
    m = P[0]
    lay = param_layout(nf)
    A6 = P[lay.A6:lay.A6inv].reshape(6, 6)
    A6inv = P[lay.A6inv:lay.com].reshape(6, 6)
    nm = N_RIGID + nf
    Rn = y[3:12].copy().reshape(3, 3)
    eta = y[12:]
    vw = np.dot(A6, eta[nm:nm + N_RIGID])
    v = vw[0:3]
    w = vw[3:6]
    q = eta[N_RIGID:nm].copy()
    qd = eta[nm + N_RIGID:]
    A, J, D = _blocks(P, nf, q)
    z0 = np.zeros(12 + 2 * nf)
    z0[6:9] = np.dot(Rn, m * v + np.dot(A, w))
    h = np.dot(A.T, v) + np.dot(J, w)
    if nf:
        h += np.dot(D, qd)
        z0[12 + nf:] = np.dot(D.T, w) + qd
    z0[9:12] = h
    z0[12:12 + nf] = q
    if EX.shape[0] == 0:
        k1 = _rhs(P, LP, G, nf, deformed, sv[0], Rn, z0, False)
        k2 = _rhs(P, LP, G, nf, deformed, sv[1], Rn, z0 + 0.5 * dt * k1, False)
        k3 = _rhs(P, LP, G, nf, deformed, sv[1], Rn, z0 + 0.5 * dt * k2, False)
        k4 = _rhs(P, LP, G, nf, deformed, sv[2], Rn, z0 + dt * k3, False)
        z = z0 + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    else:
        # Cox-Matthews ETD-RK4 (flexfmu.reframe.schemes.exponential_coefficients): E1 = e^{hL}, E2 = e^{hL/2},
        # A2 = h/2 phi1(hL/2), B1, B2, B4 = h (phi1 - 3 phi2 + 4 phi3), h (2 phi2 - 4 phi3), h (4 phi3 - phi2).
        E2z0 = _expmap(EX, nf, 1, z0, 1.0)
        Nu = _rhs(P, LP, G, nf, deformed, sv[0], Rn, z0, True)
        a = E2z0 + _expmap(EX, nf, 2, Nu, 0.5 * dt)
        Na = _rhs(P, LP, G, nf, deformed, sv[1], Rn, a, True)
        b = E2z0 + _expmap(EX, nf, 2, Na, 0.5 * dt)
        Nb = _rhs(P, LP, G, nf, deformed, sv[1], Rn, b, True)
        c = _expmap(EX, nf, 1, a, 1.0) + _expmap(EX, nf, 2, 2.0 * Nb - Nu, 0.5 * dt)
        Nc = _rhs(P, LP, G, nf, deformed, sv[2], Rn, c, True)
        z = (_expmap(EX, nf, 0, z0, 1.0) + _expmap(EX, nf, 3, Nu, dt / 6.0) + _expmap(EX, nf, 4, Na + Nb, dt / 3.0)
             + _expmap(EX, nf, 5, Nc, dt / 6.0))
    Rrel = _rodrigues(z[0:3])
    R = np.dot(Rn, Rrel)
    R = 1.5 * R - 0.5 * np.dot(np.dot(R, R.T), R)          # one Newton step of the polar decomposition
    q = z[12:12 + nf].copy()
    A, J, D = _blocks(P, nf, q)
    v, w, qd = _solve_mass(m, A, J, D, np.dot(R.T, z[6:9]), np.dot(Rrel.T, z[9:12]), z[12 + nf:].copy())
    vw = np.empty(6)
    vw[0:3] = v
    vw[3:6] = w
    y[0:3] += z[3:6]
    y[3:12] = R.reshape(9)
    y[12:12 + N_RIGID] = 0.0
    y[12 + N_RIGID:12 + nm] = q
    y[12 + nm:12 + nm + N_RIGID] = np.dot(A6inv, vw)
    y[12 + nm + N_RIGID:] = qd
    for i in range(y.shape[0]):
        if not math.isfinite(y[i]):
            return False
    return True


def reframe_steps(P, LP, G, EX, nf, deformed, SV, held, t, dt, n, y):
    """n steps from state y at time t.  G: geometric stiffness (9 nf^2,) or empty; EX: exponential-scheme
    coefficients for this dt (24 nf,) or empty (RK4, the consistent scheme).  SV: (n, 3, n_loads, 6), or
    (1, ...) with held=True (the same load values every step).  Returns (new y, new t, steps done,
    status): status 0 ok, 1 the loads of step ``steps done`` are not finite, 2 that step's state is not
    finite."""
    y = y.copy()
    for k in range(n):
        sv = SV[0] if held else SV[k]
        for v in sv.ravel():
            if not math.isfinite(v):
                return y, t, k, 1
        if not _step(P, LP, G, EX, nf, deformed, sv, dt, y):
            return y, t + dt, k, 2
        t = t + dt
    return y, t, n, 0


def consistent_steps(P, LP, nf, deformed, SV, held, t, dt, n, y):
    """:func:`reframe_steps` of the consistent scheme without geometric stiffness."""
    return reframe_steps(P, LP, np.zeros(0), np.zeros(0), nf, deformed, SV, held, t, dt, n, y)


def consistent_outputs(P, LP, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    """:func:`reframe_outputs` without geometric stiffness."""
    return reframe_outputs(P, LP, np.zeros(0), nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr)


def reframe_outputs(P, LP, G, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    """All outputs of state y with load values sv (n_loads, 6) at its time (G: as :func:`reframe_steps`).
    PP: output points, one row
    [X - c (3), Phi rows (3*nf)] each.  Returns [frame origin 3, frame origin velocity 3, quaternion 4,
    omega 3, alpha 3, com position 3, com velocity 3, q nf, qdot nf, max elastic displacement 1, then per
    point position, velocity, acceleration (full), position, velocity, acceleration (rigid) 6 x 3].
    ``order`` empty: the max elastic displacement is not searched (NOT_COMPUTED = -1 in its place)."""
    m = P[0]
    lay = param_layout(nf)
    A6 = P[lay.A6:lay.A6inv].reshape(6, 6)
    com = P[lay.com:lay.end]
    nm = N_RIGID + nf
    pos = y[0:3]
    R = y[3:12].copy().reshape(3, 3)
    eta = y[12:]
    vw = np.dot(A6, eta[nm:nm + N_RIGID])
    v = vw[0:3].copy()
    w = vw[3:6].copy()
    q = eta[N_RIGID:nm].copy()
    qd = eta[nm + N_RIGID:].copy()
    A, J, D = _blocks(P, nf, q)
    p_b = m * v + np.dot(A, w)
    h = np.dot(A.T, v) + np.dot(J, w)
    if nf:
        h += np.dot(D, qd)
    F_g, N_b, Q = _loads(LP, nf, deformed, sv, R, q)
    F_b = np.dot(R.T, F_g)
    b1 = F_b - _cross(w, p_b)
    b2 = N_b - _cross(w, h) - _cross(v, p_b)
    b3 = np.zeros(nf)
    if nf:
        b3 = _dTdq(P, nf, v, w, q, qd) - P[lay.k:lay.c] * q - P[lay.c:lay.A6] * qd + Q
        if G.shape[0]:
            b3 = b3 + _geometric_force(G, nf, w, q)
        # minus Mdot xi: Mm is quadratic in q, d/dt along qdot: A(qd), J'(q; qd), D(qd)
        Ad = np.dot(qd, P[lay.A:lay.B].reshape(nf, 9)).reshape(3, 3)
        Cqd = np.dot(qd, P[lay.C:lay.D].reshape(nf, nf * 9)).reshape(nf, 9)
        Cq = np.dot(q, P[lay.C:lay.D].reshape(nf, nf * 9)).reshape(nf, 9)
        Jd = (np.dot(qd, P[lay.B:lay.C].reshape(nf, 9)) + np.dot(qd, Cq) + np.dot(q, Cqd)).reshape(3, 3)
        Dd = np.dot(qd, P[lay.D:lay.k].reshape(nf, 3 * nf)).reshape(3, nf)
        b1 = b1 - np.dot(Ad, w)
        b2 = b2 - (np.dot(Ad.T, v) + np.dot(Jd, w) + np.dot(Dd, qd))
        b3 = b3 - np.dot(Dd.T, w)
    vdot, alpha, qdd = _solve_mass(m, A, J, D, b1, b2, b3)
    a_o = vdot + _cross(w, v)
    n_p = PP.shape[0]
    out = np.empty(23 + 2 * nf + 18 * n_p)
    out[0:3] = pos - np.dot(R, com)
    out[3:6] = np.dot(R, v + _cross(w, -com))
    out[6:10] = _quaternion(R)
    out[10:13] = w
    out[13:16] = alpha
    out[16:19] = pos
    vc = m * v
    if nf:
        vc = vc + np.dot(A, w)
    out[19:22] = np.dot(R, vc) / m
    out[22:22 + nf] = q
    out[22 + nf:22 + 2 * nf] = qd
    # an empty node order skips the whole-mesh search (the one output that is not O(modes^2)): NOT_COMPUTED
    out[22 + 2 * nf] = max_node_norm_numpy(Psi, N_RIGID, dpn, order, bc, br, sc, sr, q) if order.shape[0] \
        else NOT_COMPUTED
    o = 23 + 2 * nf
    for k in range(n_p):
        X = PP[k, 0:3].copy()
        if nf:
            Phk = PP[k, 3:3 + 3 * nf].reshape(3, nf)
            u = np.dot(Phk, q)
            ud = np.dot(Phk, qd)
            udd = np.dot(Phk, qdd)
        else:
            u = np.zeros(3)
            ud = np.zeros(3)
            udd = np.zeros(3)
        yk = X + u
        b = o + 18 * k
        out[b:b + 3] = pos + np.dot(R, yk)
        out[b + 3:b + 6] = np.dot(R, v + _cross(w, yk) + ud)
        out[b + 6:b + 9] = np.dot(R, a_o + _cross(alpha, yk) + _cross(w, _cross(w, yk)) + 2.0 * _cross(w, ud) + udd)
        out[b + 9:b + 12] = pos + np.dot(R, X)
        out[b + 12:b + 15] = np.dot(R, v + _cross(w, X))
        out[b + 15:b + 18] = np.dot(R, a_o + _cross(alpha, X) + _cross(w, _cross(w, X)))
    return out
