"""The compiled outputs of one state of the reframe kernels (:mod:`flexfmu.reframe.kernels`, which documents the layouts
and picks compiled or numpy versions): the same equations as flexfmu.reframe.kernels_numpy, written as
loops on preallocated arrays so numba compiles them without temporaries.  Cached on disk with the other
kernel files (flexfmu.reframe.kernels._KERNEL_FILES): a change here recompiles all of them."""
from __future__ import annotations

import numpy as np

from flexfmu.reframe.kernels import N_RIGID, NOT_COMPUTED, _jit, _offsets, _quaternion, max_node_norm
from flexfmu.reframe.kernels_nb_step import (_cr, _lin, _mtv, _mv, _nb_blocks, _nb_dTdq, _nb_geometric_force,
                                             _nb_loads, _nb_solve_mass)


@_jit
def _nb_consistent_outputs(P, LP, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    return _nb_reframe_outputs(P, LP, np.zeros(0), nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr)


@_jit
def _nb_reframe_outputs(P, LP, G, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    m = P[0]
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    nm = N_RIGID + nf
    e = 12
    R = y[3:12].copy()
    vw = np.empty(6)
    for a in range(6):
        s = 0.0
        for b in range(6):
            s += P[o_A6 + 6 * a + b] * y[e + nm + b]
        vw[a] = s
    v = vw[0:3].copy()
    w = vw[3:6].copy()
    q = y[e + N_RIGID:e + nm].copy()
    qd = y[e + nm + N_RIGID:e + 2 * nm].copy()
    A9 = np.empty(9)
    J9 = np.empty(9)
    D = np.empty(3 * nf)
    Cq = np.empty(9 * nf)
    _nb_blocks(P, nf, q, A9, J9, D, Cq)
    p_b = np.empty(3)
    h = np.empty(3)
    for a in range(3):
        p_b[a] = m * v[a] + A9[3 * a] * w[0] + A9[3 * a + 1] * w[1] + A9[3 * a + 2] * w[2]
        s = A9[a] * v[0] + A9[3 + a] * v[1] + A9[6 + a] * v[2] \
            + J9[3 * a] * w[0] + J9[3 * a + 1] * w[1] + J9[3 * a + 2] * w[2]
        for k in range(nf):
            s += D[a * nf + k] * qd[k]
        h[a] = s
    F_g = np.empty(3)
    N_b = np.empty(3)
    Q = np.empty(nf)
    _nb_loads(LP, nf, deformed, sv, R, q, F_g, N_b, Q)
    F_b = np.empty(3)
    _mtv(R, F_g, F_b)
    t1 = np.empty(3)
    t2 = np.empty(3)
    b1 = np.empty(3)
    b2 = np.empty(3)
    _cr(w, p_b, t1)
    for a in range(3):
        b1[a] = F_b[a] - t1[a]
    _cr(w, h, t1)
    _cr(v, p_b, t2)
    for a in range(3):
        b2[a] = N_b[a] - t1[a] - t2[a]
    b3 = np.empty(nf)
    if nf:
        _nb_dTdq(P, nf, v, w, qd, Cq, b3)
        for j in range(nf):
            b3[j] += -P[o_k + j] * q[j] - P[o_c + j] * qd[j] + Q[j]
        if G.shape[0]:
            _nb_geometric_force(G, nf, w, q, b3)
        # minus Mdot xi (Mm quadratic in q): A(qd), B(qd) + sum_k (qd_k Cq_k + q_k Cqd_k), D(qd)
        Ad = np.empty(9)
        Bd = np.empty(9)
        Dd = np.empty(3 * nf)
        Cqd = np.empty(9 * nf)
        _lin(P, nf, qd, Ad, Bd, Dd, Cqd)
        Jd = np.empty(9)
        for ab in range(9):
            s = Bd[ab]
            for k in range(nf):
                s += qd[k] * Cq[9 * k + ab] + q[k] * Cqd[9 * k + ab]
            Jd[ab] = s
        for a in range(3):
            b1[a] -= Ad[3 * a] * w[0] + Ad[3 * a + 1] * w[1] + Ad[3 * a + 2] * w[2]
            s = Ad[a] * v[0] + Ad[3 + a] * v[1] + Ad[6 + a] * v[2] \
                + Jd[3 * a] * w[0] + Jd[3 * a + 1] * w[1] + Jd[3 * a + 2] * w[2]
            for k in range(nf):
                s += Dd[a * nf + k] * qd[k]
            b2[a] -= s
        for k in range(nf):
            b3[k] -= Dd[k] * w[0] + Dd[nf + k] * w[1] + Dd[2 * nf + k] * w[2]
    vdot = np.empty(3)
    alpha = np.empty(3)
    qdd = np.empty(nf)
    _nb_solve_mass(m, A9, J9, D, nf, b1, b2, b3, vdot, alpha, qdd)
    a_o = np.empty(3)
    _cr(w, v, t1)
    for a in range(3):
        a_o[a] = vdot[a] + t1[a]
    n_p = PP.shape[0]
    out = np.empty(23 + 2 * nf + 18 * n_p)
    com = P[o_com:o_end]
    _mv(R, com, t1)
    for a in range(3):
        out[a] = y[a] - t1[a]
    _cr(w, com, t1)
    for a in range(3):
        t2[a] = v[a] - t1[a]
    _mv(R, t2, out[3:6])
    out[6:10] = _quaternion(R.reshape(3, 3))
    for a in range(3):
        out[10 + a] = w[a]
        out[13 + a] = alpha[a]
        out[16 + a] = y[a]
        t1[a] = (m * v[a] + A9[3 * a] * w[0] + A9[3 * a + 1] * w[1] + A9[3 * a + 2] * w[2]) / m
    _mv(R, t1, out[19:22])
    for k in range(nf):
        out[22 + k] = q[k]
        out[22 + nf + k] = qd[k]
    if order.shape[0]:
        out[22 + 2 * nf] = max_node_norm(Psi, N_RIGID, dpn, order, bc, br, sc, sr, q)
    else:                  # skipped on request (an empty node order): see reframe_outputs
        out[22 + 2 * nf] = NOT_COMPUTED
    o = 23 + 2 * nf
    X = np.empty(3)
    u = np.empty(3)
    ud = np.empty(3)
    udd = np.empty(3)
    yk = np.empty(3)
    acc = np.empty(3)
    c1 = np.empty(3)
    c2 = np.empty(3)
    for p in range(n_p):
        for a in range(3):
            X[a] = PP[p, a]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for j in range(nf):
                ph = PP[p, 3 + a * nf + j]
                s0 += ph * q[j]
                s1 += ph * qd[j]
                s2 += ph * qdd[j]
            u[a] = s0
            ud[a] = s1
            udd[a] = s2
            yk[a] = X[a] + u[a]
        b = o + 18 * p
        for rigid in range(2):
            r = X if rigid else yk
            base = b + 9 * rigid
            _mv(R, r, t1)
            for a in range(3):
                out[base + a] = y[a] + t1[a]
            _cr(w, r, c1)
            for a in range(3):
                t2[a] = v[a] + c1[a] + (0.0 if rigid else ud[a])
            _mv(R, t2, out[base + 3:base + 6])
            _cr(w, c1, c2)                     # omega x (omega x r)
            _cr(alpha, r, t1)
            _cr(w, ud, t2)
            for a in range(3):
                acc[a] = a_o[a] + t1[a] + c2[a]
                if not rigid:
                    acc[a] += 2.0 * t2[a] + udd[a]
            _mv(R, acc, out[base + 6:base + 9])
    return out
