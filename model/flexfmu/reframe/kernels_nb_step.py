"""The compiled steps of the reframe kernels (:mod:`flexfmu.reframe.kernels`, which documents the layouts
and picks compiled or numpy versions): the same equations as flexfmu.reframe.kernels_numpy, written as
loops on preallocated arrays so numba compiles them without temporaries.  Cached on disk with the other
kernel files (flexfmu.reframe.kernels._KERNEL_FILES): a change here recompiles all of them."""
from __future__ import annotations

import math

import numpy as np

from flexfmu.reframe.kernels import N_RIGID, _jit, _offsets, _rate_coefficient, _rod9, _solve3


@_jit
def _mv(R, x, out):
    """out = R x (R row-major 3x3)."""
    for a in range(3):
        out[a] = R[3 * a] * x[0] + R[3 * a + 1] * x[1] + R[3 * a + 2] * x[2]


@_jit
def _mtv(R, x, out):
    """out = R^T x."""
    for a in range(3):
        out[a] = R[a] * x[0] + R[3 + a] * x[1] + R[6 + a] * x[2]


@_jit
def _mm(A, B, out):
    for a in range(3):
        for b in range(3):
            out[3 * a + b] = A[3 * a] * B[b] + A[3 * a + 1] * B[3 + b] + A[3 * a + 2] * B[6 + b]


@_jit
def _cr(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@_jit
def _lin(P, nf, x, A9, B9, D, Cx):
    """A(x) = sum x_j A_j, B(x) = sum x_j (B_j + B_j^T), D(x) = sum x_j D_j, Cx[k] = sum_j x_j C_jk."""
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    PA = P[o_A:o_B]
    PB = P[o_B:o_C]
    PC = P[o_C:o_D]
    PD = P[o_D:o_k]
    for ab in range(9):
        A9[ab] = 0.0
        B9[ab] = 0.0
    D[:] = 0.0
    Cx[:] = 0.0
    n3 = 3 * nf
    n9 = 9 * nf
    for j in range(nf):
        xj = x[j]
        Aj = PA[9 * j:9 * j + 9]
        Bj = PB[9 * j:9 * j + 9]
        for ab in range(9):
            A9[ab] += xj * Aj[ab]
            B9[ab] += xj * Bj[ab]
        Dj = PD[n3 * j:n3 * j + n3]
        for i in range(n3):
            D[i] += xj * Dj[i]
        Cj = PC[n9 * j:n9 * j + n9]
        for i in range(n9):
            Cx[i] += xj * Cj[i]


@_jit
def _nb_blocks(P, nf, q, A9, J9, D, Cq):
    """A(q), J(q) = J0 + B(q) + sum_k q_k Cq_k, D(q); Cq as in _lin."""
    B9 = np.empty(9)
    _lin(P, nf, q, A9, B9, D, Cq)
    for ab in range(9):
        J9[ab] = P[1 + ab] + B9[ab]
    for k in range(nf):
        qk = q[k]
        Ck = Cq[9 * k:9 * k + 9]
        for ab in range(9):
            J9[ab] += qk * Ck[ab]


@_jit
def _nb_solve_mass(m, A9, J9, D, nf, b1, b2, b3, x1, x2, x3):
    S = np.empty((3, 3))
    r = np.empty(3)
    for a in range(3):
        Da = D[a * nf:a * nf + nf]
        for b in range(a, 3):
            Db = D[b * nf:b * nf + nf]
            s = 0.0
            for k in range(nf):
                s += Da[k] * Db[k]
            S[a, b] = J9[3 * a + b] - (A9[a] * A9[b] + A9[3 + a] * A9[3 + b] + A9[6 + a] * A9[6 + b]) / m - s
        s = 0.0
        for k in range(nf):
            s += Da[k] * b3[k]
        r[a] = b2[a] - (A9[a] * b1[0] + A9[3 + a] * b1[1] + A9[6 + a] * b1[2]) / m - s
    for a in range(3):                    # J symmetric: S too
        for b in range(a):
            S[a, b] = S[b, a]
    x = _solve3(S, r)
    for a in range(3):
        x2[a] = x[a]
    for c in range(3):
        x1[c] = (b1[c] - (A9[3 * c] * x[0] + A9[3 * c + 1] * x[1] + A9[3 * c + 2] * x[2])) / m
    D0 = D[0:nf]
    D1 = D[nf:2 * nf]
    D2 = D[2 * nf:3 * nf]
    for k in range(nf):
        x3[k] = b3[k] - (D0[k] * x[0] + D1[k] * x[1] + D2[k] * x[2])


@_jit
def _nb_loads(LP, nf, deformed, sv, R9, q, F_g, N_b, Q):
    for a in range(3):
        F_g[a] = 0.0
        N_b[a] = 0.0
    for j in range(nf):
        Q[j] = 0.0
    stride = 5 + 6 * nf
    f_b = np.empty(3)
    m_b = np.empty(3)
    tmp = np.empty(3)
    arm = np.empty(3)
    for l in range(sv.shape[0]):
        base = l * stride
        f = sv[l, 0:3]
        mo = sv[l, 3:6]
        if LP[base] != 0.0:
            for a in range(3):
                f_b[a] = f[a]
                m_b[a] = mo[a]
            _mv(R9, f, tmp)
            for a in range(3):
                F_g[a] += tmp[a]
        else:
            _mtv(R9, f, f_b)
            _mtv(R9, mo, m_b)
            for a in range(3):
                F_g[a] += f[a]
        for a in range(3):
            arm[a] = LP[base + 2 + a]
        o = base + 5
        for a in range(3):
            s = 0.0
            for j in range(nf):
                Q[j] += LP[o + a * nf + j] * f_b[a]
                s += LP[o + a * nf + j] * q[j]
            if deformed:
                arm[a] += s
        _cr(arm, f_b, tmp)
        for a in range(3):
            N_b[a] += tmp[a]
        if LP[base + 1] != 0.0:
            o = base + 5 + 3 * nf
            for a in range(3):
                N_b[a] += m_b[a]
                for j in range(nf):
                    Q[j] += LP[o + a * nf + j] * m_b[a]


@_jit
def _nb_dTdq(P, nf, v, w, qd, Cq, out):
    """dT/dq_j = v^T A_j w + w^T B_j w + w^T (sum_k q_k C_jk) w + w^T D_j qdot (C_jk = C_kj^T)."""
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    PA = P[o_A:o_B]
    PB = P[o_B:o_C]
    PD = P[o_D:o_k]
    vw = np.empty(9)
    ww = np.empty(9)
    for a in range(3):
        for b in range(3):
            vw[3 * a + b] = v[a] * w[b]
            ww[3 * a + b] = w[a] * w[b]
    n3 = 3 * nf
    for j in range(nf):
        Aj = PA[9 * j:9 * j + 9]
        Bj = PB[9 * j:9 * j + 9]
        Cj = Cq[9 * j:9 * j + 9]
        s = 0.0
        for ab in range(9):
            s += Aj[ab] * vw[ab] + (0.5 * Bj[ab] + Cj[ab]) * ww[ab]
        Dj = PD[n3 * j:n3 * j + n3]
        for a in range(3):
            Dja = Dj[a * nf:a * nf + nf]
            t = 0.0
            for k in range(nf):
                t += Dja[k] * qd[k]
            s += w[a] * t
        out[j] = s


@_jit
def _nb_geometric_force(G, nf, w, q, out):
    """out += -(sum_ab X_ab G_ab) q, X = w w^T - |w|^2 I (as _geometric_force)."""
    ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    X = np.empty(9)
    for a in range(3):
        for b in range(3):
            X[3 * a + b] = w[a] * w[b] - (ww if a == b else 0.0)
    n2 = nf * nf
    for j in range(nf):
        s = 0.0
        for k in range(nf):
            g = 0.0
            for ab in range(9):
                g += X[ab] * G[ab * n2 + j * nf + k]
            s += g * q[k]
        out[j] -= s


@_jit
def _nb_rhs(P, LP, G, nf, deformed, sv, Rn9, z, split, out):
    m = P[0]
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    Rrel = np.empty(9)
    R = np.empty(9)
    _rod9(z[0:3], Rrel)
    _mm(Rn9, Rrel, R)
    p_b = np.empty(3)
    h = np.empty(3)
    _mtv(R, z[6:9], p_b)
    _mtv(Rrel, z[9:12], h)
    q = z[12:12 + nf]
    pq = z[12 + nf:12 + 2 * nf]
    A9 = np.empty(9)
    J9 = np.empty(9)
    D = np.empty(3 * nf)
    Cq = np.empty(9 * nf)
    _nb_blocks(P, nf, q, A9, J9, D, Cq)
    v = np.empty(3)
    w = np.empty(3)
    qd = np.empty(nf)
    _nb_solve_mass(m, A9, J9, D, nf, p_b, h, pq, v, w, qd)
    F_g = np.empty(3)
    N_b = np.empty(3)
    Q = np.empty(nf)
    _nb_loads(LP, nf, deformed, sv, R, q, F_g, N_b, Q)
    # rotation-vector rate (Eqs. 20-22)
    phi = z[0:3]
    th = math.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    pxw = np.empty(3)
    ppw = np.empty(3)
    _cr(phi, w, pxw)
    _cr(phi, pxw, ppw)
    c = _rate_coefficient(th)
    for a in range(3):
        out[a] = w[a] + 0.5 * pxw[a] + c * ppw[a]
    _mv(R, v, out[3:6])
    for a in range(3):
        out[6 + a] = F_g[a]
    vxp = np.empty(3)
    _cr(v, p_b, vxp)
    for a in range(3):
        vxp[a] = N_b[a] - vxp[a]
    _mv(Rrel, vxp, out[9:12])
    if nf:
        dT = np.empty(nf)
        _nb_dTdq(P, nf, v, w, qd, Cq, dT)
        if split:                              # N = z' - L z (exponential scheme, see _rhs)
            for j in range(nf):
                Dtw = D[j] * w[0] + D[nf + j] * w[1] + D[2 * nf + j] * w[2]
                out[12 + j] = -Dtw
                out[12 + nf + j] = dT[j] + P[o_c + j] * Dtw + Q[j]
        else:
            for j in range(nf):
                out[12 + j] = qd[j]
                out[12 + nf + j] = dT[j] - P[o_k + j] * q[j] - P[o_c + j] * qd[j] + Q[j]
        if G.shape[0]:
            _nb_geometric_force(G, nf, w, q, out[12 + nf:12 + 2 * nf])


@_jit
def _nb_expmap(EX, nf, k, z, s, add, out):
    """out (+)= [s z_frame; EX_k (q_j, p_j)] (as _expmap): added to out if add, else written (out may be
    uninitialised then)."""
    for i in range(12):
        out[i] = (out[i] if add else 0.0) + s * z[i]
    for j in range(nf):
        o = 24 * j + 4 * k
        qj = z[12 + j]
        pj = z[12 + nf + j]
        out[12 + j] = (out[12 + j] if add else 0.0) + EX[o] * qj + EX[o + 1] * pj
        out[12 + nf + j] = (out[12 + nf + j] if add else 0.0) + EX[o + 2] * qj + EX[o + 3] * pj


@_jit
def _nb_step(P, LP, G, EX, nf, deformed, sv, dt, y):
    m = P[0]
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    nm = N_RIGID + nf
    nz = 12 + 2 * nf
    Rn = y[3:12].copy()
    e = 12                                   # eta starts at y[12]
    vw = np.empty(6)
    for a in range(6):
        s = 0.0
        for b in range(6):
            s += P[o_A6 + 6 * a + b] * y[e + nm + b]
        vw[a] = s
    v = vw[0:3]
    w = vw[3:6]
    q = y[e + N_RIGID:e + nm].copy()
    qd = y[e + nm + N_RIGID:e + 2 * nm]
    A9 = np.empty(9)
    J9 = np.empty(9)
    D = np.empty(3 * nf)
    Cq = np.empty(9 * nf)
    _nb_blocks(P, nf, q, A9, J9, D, Cq)
    z0 = np.zeros(nz)
    pb = np.empty(3)
    for a in range(3):
        pb[a] = m * v[a] + A9[3 * a] * w[0] + A9[3 * a + 1] * w[1] + A9[3 * a + 2] * w[2]
    _mv(Rn, pb, z0[6:9])
    for a in range(3):
        s = A9[a] * v[0] + A9[3 + a] * v[1] + A9[6 + a] * v[2] \
            + J9[3 * a] * w[0] + J9[3 * a + 1] * w[1] + J9[3 * a + 2] * w[2]
        for k in range(nf):
            s += D[a * nf + k] * qd[k]
        z0[9 + a] = s
    for k in range(nf):
        z0[12 + k] = q[k]
        z0[12 + nf + k] = D[k] * w[0] + D[nf + k] * w[1] + D[2 * nf + k] * w[2] + qd[k]
    k1 = np.empty(nz)
    k2 = np.empty(nz)
    k3 = np.empty(nz)
    k4 = np.empty(nz)
    zs = np.empty(nz)
    if EX.shape[0] == 0:                     # classical RK4 (consistent scheme)
        _nb_rhs(P, LP, G, nf, deformed, sv[0], Rn, z0, False, k1)
        for i in range(nz):
            zs[i] = z0[i] + 0.5 * dt * k1[i]
        _nb_rhs(P, LP, G, nf, deformed, sv[1], Rn, zs, False, k2)
        for i in range(nz):
            zs[i] = z0[i] + 0.5 * dt * k2[i]
        _nb_rhs(P, LP, G, nf, deformed, sv[1], Rn, zs, False, k3)
        for i in range(nz):
            zs[i] = z0[i] + dt * k3[i]
        _nb_rhs(P, LP, G, nf, deformed, sv[2], Rn, zs, False, k4)
        z = zs
        for i in range(nz):
            z[i] = z0[i] + (dt / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    else:                                    # Cox-Matthews ETD-RK4 (exponential scheme, see _step)
        E2z0 = np.empty(nz)
        a = np.empty(nz)
        tmp = np.empty(nz)
        _nb_expmap(EX, nf, 1, z0, 1.0, False, E2z0)
        _nb_rhs(P, LP, G, nf, deformed, sv[0], Rn, z0, True, k1)
        a[:] = E2z0
        _nb_expmap(EX, nf, 2, k1, 0.5 * dt, True, a)
        _nb_rhs(P, LP, G, nf, deformed, sv[1], Rn, a, True, k2)
        zs[:] = E2z0
        _nb_expmap(EX, nf, 2, k2, 0.5 * dt, True, zs)
        _nb_rhs(P, LP, G, nf, deformed, sv[1], Rn, zs, True, k3)
        _nb_expmap(EX, nf, 1, a, 1.0, False, zs)
        for i in range(nz):
            tmp[i] = 2.0 * k3[i] - k1[i]
        _nb_expmap(EX, nf, 2, tmp, 0.5 * dt, True, zs)
        _nb_rhs(P, LP, G, nf, deformed, sv[2], Rn, zs, True, k4)
        z = zs
        _nb_expmap(EX, nf, 0, z0, 1.0, False, z)
        _nb_expmap(EX, nf, 3, k1, dt / 6.0, True, z)
        for i in range(nz):
            tmp[i] = k2[i] + k3[i]
        _nb_expmap(EX, nf, 4, tmp, dt / 3.0, True, z)
        _nb_expmap(EX, nf, 5, k4, dt / 6.0, True, z)
    Rrel = np.empty(9)
    R1 = np.empty(9)
    _rod9(z[0:3], Rrel)
    _mm(Rn, Rrel, R1)
    RRt = np.empty(9)
    for a in range(3):
        for b in range(3):
            RRt[3 * a + b] = R1[3 * a] * R1[3 * b] + R1[3 * a + 1] * R1[3 * b + 1] + R1[3 * a + 2] * R1[3 * b + 2]
    R = np.empty(9)
    _mm(RRt, R1, R)
    for i in range(9):
        R[i] = 1.5 * R1[i] - 0.5 * R[i]
    q1 = z[12:12 + nf].copy()
    _nb_blocks(P, nf, q1, A9, J9, D, Cq)
    b1 = np.empty(3)
    b2 = np.empty(3)
    _mtv(R, z[6:9], b1)
    _mtv(Rrel, z[9:12], b2)
    v1 = np.empty(6)
    qd1 = np.empty(nf)
    _nb_solve_mass(m, A9, J9, D, nf, b1, b2, z[12 + nf:12 + 2 * nf], v1[0:3], v1[3:6], qd1)
    for a in range(3):
        y[a] += z[3 + a]
    for i in range(9):
        y[3 + i] = R[i]
    for i in range(N_RIGID):
        y[e + i] = 0.0
    for k in range(nf):
        y[e + N_RIGID + k] = q1[k]
        y[e + nm + N_RIGID + k] = qd1[k]
    for a in range(6):
        s = 0.0
        for b in range(6):
            s += P[o_A6i + 6 * a + b] * v1[b]
        y[e + nm + a] = s
    for i in range(y.shape[0]):
        if not math.isfinite(y[i]):
            return False
    return True


@_jit
def _nb_reframe_steps(P, LP, G, EX, nf, deformed, SV, held, t, dt, n, y):
    y = y.copy()
    for k in range(n):
        sv = SV[0] if held else SV[k]
        if not held or k == 0:
            for v in sv.ravel():
                if not math.isfinite(v):
                    return y, t, k, 1
        if not _nb_step(P, LP, G, EX, nf, deformed, sv, dt, y):
            return y, t + dt, k, 2
        t = t + dt
    return y, t, n, 0


@_jit
def _nb_consistent_steps(P, LP, nf, deformed, SV, held, t, dt, n, y):
    return _nb_reframe_steps(P, LP, np.zeros(0), np.zeros(0), nf, deformed, SV, held, t, dt, n, y)
