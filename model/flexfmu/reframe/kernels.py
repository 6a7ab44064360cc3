"""Hot loops of the consistent and exponential reframe schemes (:mod:`flexfmu.reframe.integrator`): whole RK4 or
ETD-RK4 steps and the outputs of one state, in modal space, on flat arrays.

Compiled with numba when it is installed (``pip install flexfmu[perf]``; compiled code cached on disk
next to this file) and run as plain numpy code otherwise, or with ``FLEXFMU_NUMBA=0`` in the
environment.  Both run this very source; ``.py_func`` of a compiled kernel is its numpy version
(tests/test_performance_equivalence.py checks that they agree).

Everything here is O(n_modes^2) per step whatever the mesh size, except :func:`max_node_norm`
(O(number of nodes) in the worst case, a few nodes in practice: see its docstring).

Layouts (built by ``flexfmu.reframe.integrator._ConsistentKernel``):

* ``P`` model parameters, nf flexible modes: m (1), J0 (9), A_j (nf*9), B_j + B_j^T (nf*9),
  C_jk (nf*nf*9), D_j (nf*3*nf), k_F (nf), c_F (nf), A6 (36), A6^-1 (36), centre of mass (3).
* ``LP`` loads, one block of 5 + 6 nf per load: follower (0/1), rotational DOFs (0/1), arm
  X_i - c (3), translational rows of Phi at the node (3*nf), rotational rows (3*nf, zeros if none).
* ``SV`` load values (n_steps or 1, 3 stages t, t + dt/2, t + dt, n_loads, 6 = force, moment).
* ``y`` state: frame point (3), rotation body -> global (9, row-major), eta (2 (6 + nf)).
* ``G`` geometric stiffness (9 nf^2: (3, 3, nf, nf) row-major, body frame) or empty: adds
  -(sum_ab X_ab G_ab) q_F, X = skew(omega)^2, to the flexible momentum rate.
* ``EX`` exponential-scheme coefficients for one dt (nf, 6, 2, 2 row-major: E1, E2, A2, B1, B2, B4 of
  ``flexfmu.reframe.integrator._exponential_coefficients``) or empty: classical RK4 (consistent scheme).
"""
from __future__ import annotations

import hashlib
import math
import os

import numpy as np


def cache_root() -> str:
    """Per-user cache folder of flexfmu (flexfmu.core.cache.cache_root: $FLEXFMU_CACHE_DIR, else
    $XDG_CACHE_HOME/flexfmu, else ~/.cache/flexfmu)."""
    from flexfmu.core.cache import cache_root as root
    return str(root())


_WANT_NUMBA = os.environ.get("FLEXFMU_NUMBA", "1").strip().lower() not in ("0", "false", "no", "off")
try:
    if not _WANT_NUMBA:
        raise ImportError("disabled by FLEXFMU_NUMBA=0")
    import numba as _numba

    # Reassociation and FMA contraction (vectorised loops) but no "no NaN / no Inf" assumptions: the
    # kernels check finiteness.
    _FASTMATH = {"contract", "reassoc", "nsz", "arcp"}

    from numba.core import caching as _nb_caching

    _THIS_FILE = os.path.abspath(__file__)
    with open(_THIS_FILE, "rb") as _source:
        _SOURCE_DIGEST = hashlib.sha256(_source.read()).hexdigest()

    class _SourceHashLocator(_nb_caching._CacheLocator):
        """numba cache for this file keyed by its content, not its path.  Every FMU extraction bundles
        flexfmu into a new folder, and numba's path-keyed cache would recompile these kernels
        (25-50 s) in each; keyed by content, one compile serves all copies of the same source."""

        def __init__(self, lineno: int):
            self._path = os.path.join(cache_root(), "numba", _SOURCE_DIGEST[:24])
            self._lineno = lineno

        def get_cache_path(self):
            return self._path

        def get_source_stamp(self):
            return _SOURCE_DIGEST

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            if os.path.abspath(py_file) != _THIS_FILE:
                return None
            locator = cls(py_func.__code__.co_firstlineno)
            try:
                locator.ensure_cache_path()
            except OSError:   # read-only home: numba falls back to its own locators
                return None
            return locator

    for _impl in (_nb_caching.CompileResultCacheImpl, _nb_caching.CodeLibraryCacheImpl):
        if _SourceHashLocator not in _impl._locator_classes:
            _impl._locator_classes = [_SourceHashLocator, *_impl._locator_classes]

    def _jit(fn):
        return _numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=_FASTMATH)(fn)

    NUMBA = True
except ImportError:      # pure numpy: the same functions, interpreted
    def _jit(fn):
        return fn

    NUMBA = False

def _py(fn):
    """The numpy versions: never compiled (numba would turn their small np.dot calls into BLAS calls)."""
    return fn


#: below this rotation angle Eq. (22)'s coefficient uses its series (as flexfmu.core.rotation)
_SERIES_THETA = 0.1
N_RIGID = 6


# --------------------------------------------------------------------------- small 3-vector helpers
@_py
def _cross(a, b):
    r = np.empty(3)
    r[0] = a[1] * b[2] - a[2] * b[1]
    r[1] = a[2] * b[0] - a[0] * b[2]
    r[2] = a[0] * b[1] - a[1] * b[0]
    return r


@_py
def _rodrigues(phi):
    """exp(skew(phi)) (as flexfmu.reframe.integrator._rodrigues)."""
    th2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]
    th = math.sqrt(th2)
    if th < 1e-4:
        a = 1.0 - th2 / 6.0 + th2 * th2 / 120.0
        b = 0.5 - th2 / 24.0 + th2 * th2 / 720.0
    else:
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / th2
    x, y, z = phi[0], phi[1], phi[2]
    R = np.empty((3, 3))
    # I + a K + b K K, K K = phi phi^T - th2 I
    R[0, 0] = 1.0 + b * (x * x - th2)
    R[1, 1] = 1.0 + b * (y * y - th2)
    R[2, 2] = 1.0 + b * (z * z - th2)
    R[0, 1] = -a * z + b * x * y
    R[1, 0] = a * z + b * x * y
    R[0, 2] = a * y + b * x * z
    R[2, 0] = -a * y + b * x * z
    R[1, 2] = -a * x + b * y * z
    R[2, 1] = a * x + b * y * z
    return R


@_jit
def _rate_coefficient(th):
    """c(theta) of Eq. (22) (as flexfmu.core.rotation.rotvec_rate_coefficient)."""
    if th < _SERIES_THETA:
        t2 = th * th
        return 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 / 1209600.0))
    half = 0.5 * th
    return (1.0 - half * math.cos(half) / math.sin(half)) / (th * th)


@_py
def _rotvec_rate(phi, w):
    th = math.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    pxw = _cross(phi, w)
    return w + 0.5 * pxw + _rate_coefficient(th) * _cross(phi, pxw)


@_jit
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


# --------------------------------------------------------------------------- model pieces
@_jit
def _offsets(nf):
    o_J0 = 1
    o_A = o_J0 + 9
    o_B = o_A + nf * 9
    o_C = o_B + nf * 9
    o_D = o_C + nf * nf * 9
    o_k = o_D + nf * 3 * nf
    o_c = o_k + nf
    o_A6 = o_c + nf
    o_A6i = o_A6 + 36
    o_com = o_A6i + 36
    return o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_com + 3


def param_size(nf: int) -> int:
    """Length of ``P`` for nf flexible modes."""
    return 1 + 9 + nf * 9 + nf * 9 + nf * nf * 9 + nf * 3 * nf + 2 * nf + 72 + 3


@_py
def _blocks(P, nf, q):
    """A(q), J(q), D(q) of the generalised mass matrix [[m I, A, 0], [A^T, J, D], [0, D^T, I]]."""
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    J = P[o_J0:o_J0 + 9].copy().reshape(3, 3)
    if nf == 0:
        return np.zeros((3, 3)), J, np.zeros((3, 0))
    A = np.dot(q, P[o_A:o_B].reshape(nf, 9)).reshape(3, 3)
    Cq = np.dot(q, P[o_C:o_D].reshape(nf, nf * 9)).reshape(nf, 9)
    J += (np.dot(q, P[o_B:o_C].reshape(nf, 9)) + np.dot(q, Cq)).reshape(3, 3)
    D = np.dot(q, P[o_D:o_k].reshape(nf, 3 * nf)).reshape(3, nf)
    return A, J, D


@_py
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


@_py
def _dTdq(P, nf, v, w, q, qd):
    """dT/dq_j = v^T A_j w + w^T B_j w + sum_k q_k w^T C_jk w + w^T D_j qdot."""
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    t1 = np.dot(np.dot(P[o_A:o_B].reshape(nf * 3, 3), w).reshape(nf, 3), v)
    t2 = 0.5 * np.dot(np.dot(P[o_B:o_C].reshape(nf * 3, 3), w).reshape(nf, 3), w)
    Wc = np.dot(np.dot(P[o_C:o_D].reshape(nf * nf * 3, 3), w).reshape(nf * nf, 3), w).reshape(nf, nf)
    t3 = np.dot(Wc, q)
    t4 = np.dot(np.dot(P[o_D:o_k].reshape(nf * 3, nf), qd).reshape(nf, 3), w)
    return t1 + t2 + t3 + t4


@_py
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


@_py
def _geometric_force(G, nf, w, q):
    """-(sum_ab X_ab G_ab) q with X = skew(w) skew(w) = w w^T - |w|^2 I (the geometric-stiffness hook;
    G: (9 nf nf,) = (3, 3, nf, nf) row-major, body frame)."""
    X = np.outer(w, w)
    ww = np.dot(w, w)
    for a in range(3):
        X[a, a] -= ww
    Kg = np.dot(X.reshape(9), G.reshape(9, nf * nf)).reshape(nf, nf)
    return -np.dot(Kg, q)


@_py
def _rhs(P, LP, G, nf, deformed, sv, Rn, z, split):
    """Time derivative of the step-local state z = [phi, dpos, p_g, H, q, p_q] (flexfmu.reframe.integrator._rhs).

    split=True (exponential scheme): N(z) = z' - L z instead, with L z = [0 (12), p_q, -k q - c p_q]
    the flexible modes' linear oscillator block, computed without forming L z (no k q cancellation):
    q' - p_q = -D(q)^T w and p_q' + k q + c p_q = dT/dq + c D^T w + Q."""
    m = P[0]
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
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
            out[12 + nf:] = _dTdq(P, nf, v, w, q, qd) + P[o_c:o_A6] * Dtw + Q
        else:
            out[12:12 + nf] = qd
            out[12 + nf:] = _dTdq(P, nf, v, w, q, qd) - P[o_k:o_c] * q - P[o_c:o_A6] * qd + Q
        if G.shape[0]:
            out[12 + nf:] += _geometric_force(G, nf, w, q)
    return out


@_py
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


@_py
def _step(P, LP, G, EX, nf, deformed, sv, dt, y):
    """One step of y in place (flexfmu.reframe.integrator): classical RK4 (EX empty, scheme "consistent") or the
    exponential ETD-RK4 (EX = its coefficients, scheme "exponential"); False if not finite."""
    m = P[0]
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    A6 = P[o_A6:o_A6i].reshape(6, 6)
    A6inv = P[o_A6i:o_com].reshape(6, 6)
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
        # Cox-Matthews ETD-RK4 (flexfmu.reframe.integrator._exponential_coefficients): E1 = e^{hL}, E2 = e^{hL/2},
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


@_py
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


@_py
def consistent_steps(P, LP, nf, deformed, SV, held, t, dt, n, y):
    """:func:`reframe_steps` of the consistent scheme without geometric stiffness."""
    return reframe_steps_numpy(P, LP, np.zeros(0), np.zeros(0), nf, deformed, SV, held, t, dt, n, y)


# --------------------------------------------------------------------------- outputs of one state
#: nodes per block and blocks per superblock of the max-displacement search
BLOCK = 16
#: the max elastic displacement's place in the outputs when its search was skipped (a norm is never < 0)
NOT_COMPUTED = -1.0


@_py
def max_node_norm_numpy(Psi, col, dpn, order, bc, br, sc, sr, q):
    """max over nodes i of |Phi_i q| (Phi_i: node i's 3 translational rows of Psi, columns col ...): all
    nodes, vectorised (the numpy version of :func:`max_node_norm`)."""
    nf = q.shape[0]
    if nf == 0:
        return 0.0
    n_nodes = order.shape[0]
    rows = (dpn * np.arange(n_nodes)[:, None] + np.arange(3)).ravel()
    u = np.dot(Psi[rows, col:col + nf], q).reshape(n_nodes, 3)
    return float(np.max(np.sqrt(np.einsum("ic,ic->i", u, u))))


@_jit
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


@_jit
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


@_jit
def max_node_norm(Psi, col, dpn, order, bc, br, sc, sr, q):
    """max over nodes i of |Phi_i q| (Phi_i: node i's 3 translational rows of Psi, columns col ...),
    exactly, without visiting every node.  Nodes in ``order`` (a space-filling curve) form blocks of
    BLOCK nodes and superblocks of BLOCK blocks, each with the mean C of its Phi_i and a radius r >=
    max |Phi_i - C|_F, so |C q| + r |q| bounds |Phi_i q| inside it.  Only (super)blocks whose bound
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


@_jit
def _quaternion(R):
    """(w, x, y, z), w >= 0, of the body -> global R (as flexfmu.reframe.integrator.quaternion_from_rotation)."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    k = 0
    best = tr
    for i in range(3):
        if R[i, i] > best:
            best = R[i, i]
            k = i + 1
    if k == 0:
        w = 0.5 * math.sqrt(1.0 + tr)
        x = (R[2, 1] - R[1, 2]) / (4 * w)
        y = (R[0, 2] - R[2, 0]) / (4 * w)
        z = (R[1, 0] - R[0, 1]) / (4 * w)
    elif k == 1:
        x = 0.5 * math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        w = (R[2, 1] - R[1, 2]) / (4 * x)
        y = (R[0, 1] + R[1, 0]) / (4 * x)
        z = (R[0, 2] + R[2, 0]) / (4 * x)
    elif k == 2:
        y = 0.5 * math.sqrt(1.0 - R[0, 0] + R[1, 1] - R[2, 2])
        w = (R[0, 2] - R[2, 0]) / (4 * y)
        x = (R[0, 1] + R[1, 0]) / (4 * y)
        z = (R[1, 2] + R[2, 1]) / (4 * y)
    else:
        z = 0.5 * math.sqrt(1.0 - R[0, 0] - R[1, 1] + R[2, 2])
        w = (R[1, 0] - R[0, 1]) / (4 * z)
        x = (R[0, 2] + R[2, 0]) / (4 * z)
        y = (R[1, 2] + R[2, 1]) / (4 * z)
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    n = math.sqrt(x * x + y * y + z * z)
    if n < 1e-8:
        scale = (2.0 / w) * (1.0 - (n / w) ** 2 / 3.0)
    else:
        scale = 2.0 * math.atan2(n, w) / n
    px, py, pz = scale * x, scale * y, scale * z
    th = math.sqrt(px * px + py * py + pz * pz)
    out = np.empty(4)
    out[0] = math.cos(0.5 * th)
    s = 0.5 if th == 0.0 else math.sin(0.5 * th) / th
    out[1] = s * px
    out[2] = s * py
    out[3] = s * pz
    return out


def output_size(nf: int, n_points: int) -> int:
    return 23 + 2 * nf + 18 * n_points


@_py
def consistent_outputs(P, LP, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    """:func:`reframe_outputs` without geometric stiffness."""
    return reframe_outputs_numpy(P, LP, np.zeros(0), nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr)


@_py
def reframe_outputs(P, LP, G, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    """All outputs of state y with load values sv (n_loads, 6) at its time (G: as :func:`reframe_steps`).
    PP: output points, one row
    [X - c (3), Phi rows (3*nf)] each.  Returns [frame origin 3, frame origin velocity 3, quaternion 4,
    omega 3, alpha 3, com position 3, com velocity 3, q nf, qdot nf, max elastic displacement 1, then per
    point position, velocity, acceleration (full), position, velocity, acceleration (rigid) 6 x 3].
    ``order`` empty: the max elastic displacement is not searched (NOT_COMPUTED = -1 in its place)."""
    m = P[0]
    o_J0, o_A, o_B, o_C, o_D, o_k, o_c, o_A6, o_A6i, o_com, o_end = _offsets(nf)
    A6 = P[o_A6:o_A6i].reshape(6, 6)
    com = P[o_com:o_end]
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
        b3 = _dTdq(P, nf, v, w, q, qd) - P[o_k:o_c] * q - P[o_c:o_A6] * qd + Q
        if G.shape[0]:
            b3 = b3 + _geometric_force(G, nf, w, q)
        # minus Mdot xi: Mm is quadratic in q, d/dt along qdot: A(qd), J'(q; qd), D(qd)
        Ad = np.dot(qd, P[o_A:o_B].reshape(nf, 9)).reshape(3, 3)
        Cqd = np.dot(qd, P[o_C:o_D].reshape(nf, nf * 9)).reshape(nf, 9)
        Cq = np.dot(q, P[o_C:o_D].reshape(nf, nf * 9)).reshape(nf, 9)
        Jd = (np.dot(qd, P[o_B:o_C].reshape(nf, 9)) + np.dot(qd, Cq) + np.dot(q, Cqd)).reshape(3, 3)
        Dd = np.dot(qd, P[o_D:o_k].reshape(nf, 3 * nf)).reshape(3, nf)
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


# =========================================================================== compiled (numba) versions
# The same computations as the numpy functions above, written as explicit loops over preallocated
# arrays (numba turns np.dot on 3-vectors into BLAS calls and every temporary into an allocation,
# which cost more than the arithmetic at these sizes).  3x3 matrices are row-major 9-vectors, D(q) is
# row-major (3, nf).  Used when numba is installed; tests check they match the numpy versions.
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
def _rod9(phi, R):
    th2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]
    th = math.sqrt(th2)
    if th < 1e-4:
        a = 1.0 - th2 / 6.0 + th2 * th2 / 120.0
        b = 0.5 - th2 / 24.0 + th2 * th2 / 720.0
    else:
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / th2
    x, y, z = phi[0], phi[1], phi[2]
    R[0] = 1.0 + b * (x * x - th2)
    R[4] = 1.0 + b * (y * y - th2)
    R[8] = 1.0 + b * (z * z - th2)
    R[1] = -a * z + b * x * y
    R[3] = a * z + b * x * y
    R[2] = a * y + b * x * z
    R[6] = -a * y + b * x * z
    R[5] = -a * x + b * y * z
    R[7] = a * x + b * y * z


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


#: the numpy versions, whatever is installed (tests compare them with the compiled ones)
consistent_steps_numpy = consistent_steps
consistent_outputs_numpy = consistent_outputs
reframe_steps_numpy = reframe_steps
reframe_outputs_numpy = reframe_outputs
if NUMBA:
    consistent_steps = _nb_consistent_steps           # noqa: F811
    consistent_outputs = _nb_consistent_outputs       # noqa: F811
    reframe_steps = _nb_reframe_steps                 # noqa: F811
    reframe_outputs = _nb_reframe_outputs             # noqa: F811
else:
    max_node_norm = max_node_norm_numpy               # noqa: F811
