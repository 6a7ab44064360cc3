"""Rounding-error bounds for comparing two double-precision implementations of the reframe kernels (the C
kernels against the numpy ones, the native FMU against the Python one): what may separate their states after n
steps and their output vectors, computed from the model data and the states (tests/error_bounds.py: the rules).

Both implementations evaluate the same formulas in different operation orders; each result is within
gamma_ops * (size of its terms) of the exact value [ASNA 3.1, 3.5], so their difference within twice that.
The bound below is a priori and deliberately generous (worst case over operation orders, any BLAS or compiler
without contraction); it is not fitted to measured differences.

* ops: the longest chain of roundings feeding one result.  One right-hand side (a stage): the mass blocks A, J, D
  (sums of <= 2 nf + 9 terms), the Schur-complement solve (sums of 3 + nf terms, a 3x3 elimination of <= 10
  dependent operations, back substitution 3 + nf), dT/dq (3 + 3 + nf + 4), the loads (3 + 2 nf per load, summed
  over the loads), the geometric force (9 + nf), Rodrigues and products with R (<= 12): bounded by
  80 + 8 nf + n_loads (3 + 2 nf) (+ 9 + nf with G).  A step chains four stages and the final update (Rodrigues,
  one polar Newton step, the mass solve): ops_step = 5 ops_stage.
* scale: the size of the terms of a step: the state x kappa(M) (velocities from momenta by a backward-stable
  solve with the generalised mass matrix M at the compared states), plus dt times the size T_b of the
  right-hand side's terms (stiffness k q and damping c qdot, loads, gyroscopic and centrifugal products of
  velocities with the mass coefficients, geometric stiffness) through the solve, (1 + kappa) ||M^-1|| T_b; x 6
  for the RK4 / ETD-RK4 combination of four stages.
* growth: a step's error is carried into the later steps by the linearised step map.  Its flexible part is the
  scheme's own 2 x 2 map per mode (RK4 polynomial of dt L, or e^{dt L} for the exponential scheme, L = [[0, 1],
  [-k, -c]]): max_j max_{k <= n} ||M_j^k||_2 computed here (the transient growth from q to qdot scales, ~omega);
  with geometric stiffness the coupled modes' map with K + K_g(omega) at the compared states; the rigid part
  (gyroscopic coupling d(omega x h)/dh, Lipschitz constant Lambda <= (1 + kappa(S)) |omega| with S the
  effective inertia J - A^T A / m - D D^T): a factor exp(n dt Lambda).  Condition numbers are of the matrices
  scaled to unit diagonal (the solves' errors do not depend on the coordinates' units).  The bound is
  implementations_bound(kappa S, ops_step, 1, n) x (flexible growth) x exp(n dt Lambda).
"""
from __future__ import annotations

import math

import numpy as np

from error_bounds import gamma, implementations_bound
from flexfmu.core.structure import N_RIGID
from flexfmu.reframe.kernels_numpy import _blocks, _dTdq
from flexfmu.reframe.layout import param_layout


def _split(P, nf, y):
    lay = param_layout(nf)
    nm = N_RIGID + nf
    eta = np.asarray(y, float)[12:]
    vw = P[lay.A6:lay.A6inv].reshape(6, 6) @ eta[nm:nm + N_RIGID]
    return vw[:3], vw[3:], eta[N_RIGID:nm], eta[nm + N_RIGID:]


def mass_matrix(P, nf, q) -> np.ndarray:
    """The generalised mass matrix [[m I, A, 0], [A^T, J, D], [0, D^T, I]] at q."""
    A, J, D = _blocks(np.asarray(P, float), nf, np.asarray(q, float))
    M = np.zeros((6 + nf, 6 + nf))
    M[:3, :3] = P[0] * np.eye(3)
    M[:3, 3:6] = A
    M[3:6, :3] = A.T
    M[3:6, 3:6] = J
    M[3:6, 6:] = D
    M[6:, 3:6] = D.T
    M[6:, 6:] = np.eye(nf)
    return M


def _n_loads(LP, nf):
    return int(np.asarray(LP).size // (5 + 6 * nf))


def ops_stage(nf, n_loads, has_G) -> int:
    return 80 + 8 * nf + n_loads * (3 + 2 * nf) + ((9 + nf) if has_G else 0)


def _equilibrated_cond(M) -> float:
    """kappa_2 of the symmetric positive definite M scaled to unit diagonal, D^-1/2 M D^-1/2: the rounding errors
    of the (symmetric, block-elimination) solves do not depend on the units of the coordinates, and Jacobi
    scaling is within a factor n of the best diagonal scaling (van der Sluis 1969; ASNA 7.3)."""
    d = 1.0 / np.sqrt(np.diag(M))
    return float(np.linalg.cond(M * d[:, None] * d[None, :]))


def _force_terms(P, LP, G, nf, y, sv_max) -> tuple[float, float, float, float]:
    """(size of the right-hand side's terms, kappa(M), ||M^-1||_2, kappa(S)) at state y, loads up to sv_max (S:
    the Schur complement J - A^T A / m - D D^T, the effective inertia):
    stiffness and damping |k q| + |c qdot|, loads, velocity products (gyroscopic, dT/dq, Mdot xi), geometric
    stiffness 2 |omega|^2 sum_ab |G_ab| |q| (|X_ab| <= 2 |omega|^2)."""
    lay = param_layout(nf)
    v, w, q, qd = _split(P, nf, y)
    M = mass_matrix(P, nf, q)
    minv = float(1.0 / np.linalg.svd(M, compute_uv=False)[-1])
    kappa = _equilibrated_cond(M)
    Sc = M[3:6, 3:6] - M[3:6, :3] @ M[:3, 3:6] / P[0] - M[3:6, 6:] @ M[6:, 3:6]
    kappa_S = _equilibrated_cond(Sc)
    stiff = float(np.max(np.abs(P[lay.k:lay.c] * q) + np.abs(P[lay.c:lay.A6] * qd), initial=0.0))
    n_loads = _n_loads(LP, nf)
    lp = float(np.max(np.abs(LP), initial=0.0))
    qn = float(np.max(np.abs(q), initial=0.0))
    # loads: f_b and R f (3 terms), Phi^T f (3 nf terms of |Phi| |f|), arm x f with arm = r + Phi q (2 |arm| |f|)
    loads = n_loads * sv_max * (3 + 3 * nf * lp + 2 * (lp + nf * lp * qn) + 3 * (1 + nf * lp))
    xi = np.abs(np.concatenate([v, w, qd]))
    absP = np.abs(P)
    # velocity products: dT/dq (a polynomial with products only: evaluated on |P|, |v|, |w|, |q|, |qdot| it is the
    # sum of its terms' sizes), gyroscopic w x h, v x p with |h|, |p| <= |M| |xi|, and Mdot xi (|Mdot| <= the
    # blocks of |P| at |qdot|) times |xi|
    dT = float(np.max(_dTdq(absP, nf, xi[:3], xi[3:6], np.abs(q), xi[6:]), initial=0.0)) if nf else 0.0
    Mdot = mass_matrix(absP, nf, xi[6:]) - np.diag(np.r_[np.full(3, absP[0]), np.zeros(3), np.ones(nf)])
    gyro = dT + 2 * float(np.max(xi)) * float(np.max(np.abs(M) @ xi)) + float(np.max(xi)) * float(np.max(Mdot @ xi))
    geo = 2 * float(np.dot(w, w)) * float(np.max(np.abs(np.asarray(G)).reshape(9, nf, nf).sum(axis=0) @ np.abs(q),
                                                  initial=0.0)) if np.asarray(G).size else 0.0
    return stiff + loads + gyro + geo, kappa, minv, kappa_S


def _flexible_growth(P, EX, G, nf, dt, n, ws) -> float:
    """max_{k <= n} ||M^k||_2, M the scheme's linear step map of the flexible modes: per mode (no G) the RK4
    polynomial of dt L_j or e^{dt L_j} (EX), L_j = [[0, 1], [-k_j, -c_j]]; with geometric stiffness the coupled
    L = [[0, I], [-(K + K_g(w)), -C]] (K_g = sum_ab X_ab G_ab, X = w w^T - |w|^2 I) at each w of ws."""
    if nf == 0:
        return 1.0
    lay = param_layout(nf)
    k, c = P[lay.k:lay.c], P[lay.c:lay.A6]
    G = np.asarray(G, float)
    mats = []
    if G.size:
        import scipy.linalg
        for w in ws:
            X = np.outer(w, w) - np.dot(w, w) * np.eye(3)
            Kg = (X.reshape(9) @ G.reshape(9, nf * nf)).reshape(nf, nf)
            L = np.block([[np.zeros((nf, nf)), np.eye(nf)], [-(np.diag(k) + Kg), -np.diag(c)]])
            Z = dt * L
            if np.asarray(EX).size:
                mats.append(scipy.linalg.expm(Z))
            else:
                Z2 = Z @ Z
                mats.append(np.eye(2 * nf) + Z + Z2 / 2 + Z2 @ Z / 6 + Z2 @ Z2 / 24)
        mats = np.array(mats)
    else:
        Z = np.zeros((nf, 2, 2))
        Z[:, 0, 1], Z[:, 1, 0], Z[:, 1, 1] = dt, -k * dt, -c * dt
        if np.asarray(EX).size:
            mats = np.asarray(EX, float).reshape(nf, 6, 2, 2)[:, 0]
        else:
            Z2 = Z @ Z
            mats = np.eye(2) + Z + Z2 / 2 + Z2 @ Z / 6 + Z2 @ Z2 / 24
    X = np.broadcast_to(np.eye(mats.shape[-1]), mats.shape).copy()
    worst = 1.0
    for _ in range(n):
        X = X @ mats
        worst = max(worst, float(np.max(np.linalg.norm(X, ord=2, axis=(1, 2)))))
    return worst


def steps_bound(P, LP, G, EX, nf, SV, dt, n, y0, y_ref) -> float:
    """Bound on max |y_a - y_b| of two implementations' states after n steps from y0 (y_ref: one of them)."""
    P, G = np.asarray(P, float), np.asarray(G, float)
    sv_max = float(np.max(np.abs(SV), initial=0.0))
    T, kappa, minv, kappa_S, w_max, ws = 0.0, 1.0, 0.0, 1.0, 0.0, []
    for y in (y0, y_ref):
        ws.append(_split(P, nf, y)[1])
        t, k_, mi, ks = _force_terms(P, LP, G, nf, y, sv_max)
        T, kappa, minv, kappa_S = max(T, t), max(kappa, k_), max(minv, mi), max(kappa_S, ks)
        w_max = max(w_max, float(np.linalg.norm(_split(P, nf, y)[1])))
    # the state (velocities from momenta by a backward-stable solve: relative error kappa gamma) and the stage
    # increments dt x (rates M^-1 b: error (1 + kappa) gamma ||M^-1|| T_b)
    S = kappa * max(float(np.max(np.abs(y0))), float(np.max(np.abs(y_ref)))) + 6 * dt * (1 + kappa) * minv * T
    lam = (1 + kappa_S) * w_max
    ops = 5 * ops_stage(nf, _n_loads(LP, nf), bool(G.size))
    return (implementations_bound(S, ops, 1.0, n) * _flexible_growth(P, EX, G, nf, dt, n, ws)
            * math.exp(n * dt * lam))


def outputs_bound(P, LP, G, nf, sv, y, PP, Psi, dpn, o_ref) -> float:
    """Bound on max |o_a - o_b| of two implementations' output vectors of state y: the accelerations x =
    M^-1 b (|x| <= ||M^-1|| T_b, T_b the size of b's terms; error <= (1 + kappa) gamma |x|-scale), carried
    into the point accelerations by (1 + |X_k| + ||Phi_k||_1 (1 + |q|)) and the centrifugal products (1 + |omega|)^2;
    the max elastic displacement's terms |Psi_i| |q|; the outputs' own size."""
    P, G = np.asarray(P, float), np.asarray(G, float)
    T, kappa, minv, _ = _force_terms(P, LP, G, nf, y, float(np.max(np.abs(sv), initial=0.0)))
    _, w, q, _ = _split(P, nf, y)
    PP = np.asarray(PP, float)
    qn = float(np.max(np.abs(q), initial=0.0))
    pk = 1.0
    if PP.size:
        pk += float(np.max(np.linalg.norm(PP[:, :3], axis=1))) + float(np.max(np.abs(PP[:, 3:]).reshape(
            PP.shape[0], 3, nf).sum(axis=2), initial=0.0)) * (1 + qn)
    psiq = 0.0
    if nf:
        n_nodes = Psi.shape[0] // dpn
        rows = (dpn * np.arange(n_nodes)[:, None] + np.arange(3)).ravel()
        psiq = float(np.max(np.abs(Psi[rows, N_RIGID:N_RIGID + nf]) @ np.abs(q))) * math.sqrt(3)
    ops = 2 * ops_stage(nf, _n_loads(LP, nf), bool(G.size)) + 3 * nf + 20   # outputs: rhs, Mdot xi, solve, points
    scale = (1 + kappa) * pk * (1 + float(np.linalg.norm(w))) ** 2 * (float(np.max(np.abs(o_ref))) + minv * T) + psiq
    return 2.0 * gamma(ops) * scale
