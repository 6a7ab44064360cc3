"""Hot loops of the consistent and exponential reframe schemes (:mod:`flexfmu.reframe.integrator`): whole RK4 or
ETD-RK4 steps and the outputs of one state, in modal space, on flat arrays.

Compiled with numba when it is installed (``pip install flexfmu[perf]``; compiled code cached on disk in
the flexfmu cache folder, keyed by this file's content) and run as plain numpy code otherwise, or with ``FLEXFMU_NUMBA=0`` in the
environment.  Both run this very source; ``.py_func`` of a compiled kernel is its numpy version
(tests/test_performance_equivalence.py checks that they agree).

Files: this module holds the numba set-up, the helpers both versions share and the kernels' public names
(``consistent_steps``, ``reframe_steps``, ``consistent_outputs``, ``reframe_outputs``: compiled when numba
is there; ``*_numpy``: always the numpy ones); flexfmu.reframe.kernels_numpy the numpy versions;
kernels_nb_step and kernels_nb_outputs the compiled ones.

Everything here is O(n_modes^2) per step whatever the mesh size, except :func:`max_node_norm`
(O(number of nodes) in the worst case, a few nodes in practice: see its docstring).

Layouts of the flat arrays: ``P`` (model parameters), ``y`` (state) and the outputs of one state are
declared in :mod:`flexfmu.reframe.layout` (``_offsets`` below is its compiled twin for ``P``).  The
integrator (``ReframeIntegrator._setup_consistent``, ``_kernel_loads``, ``_point_data``) builds the others:

* ``LP`` loads, one block of 5 + 6 nf per load: follower (0/1), rotational DOFs (0/1), arm
  X_i - c (3), translational rows of Phi at the node (3*nf), rotational rows (3*nf, zeros if none).
* ``SV`` load values (n_steps or 1, 3 stages t, t + dt/2, t + dt, n_loads, 6 = force, moment).
* ``G`` geometric stiffness (9 nf^2: (3, 3, nf, nf) row-major, body frame) or empty: adds
  -(sum_ab X_ab G_ab) q_F, X = skew(omega)^2, to the flexible momentum rate.
* ``EX`` exponential-scheme coefficients for one dt (nf, 6, 2, 2 row-major: E1, E2, A2, B1, B2, B4 of
  :func:`flexfmu.reframe.schemes.exponential_coefficients`) or empty: classical RK4 (consistent scheme).
* ``PP`` output points, one row [X - c (3), translational rows of Phi (3*nf)] each.
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

    #: the files whose functions are compiled: one digest over all of them keys the cache, since the
    #: kernels in one call the helpers in another and numba does not track that
    _KERNEL_FILES = tuple(os.path.join(os.path.dirname(os.path.abspath(__file__)), name)
                          for name in ("kernels.py", "kernels_nb_step.py", "kernels_nb_outputs.py"))
    _digest = hashlib.sha256()
    for _file in _KERNEL_FILES:
        with open(_file, "rb") as _source:
            _digest.update(_source.read())
    _SOURCE_DIGEST = _digest.hexdigest()

    class _SourceHashLocator(_nb_caching._CacheLocator):
        """numba cache for the kernel files keyed by their content, not their path.  Every FMU extraction bundles
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
            if os.path.abspath(py_file) not in _KERNEL_FILES:
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
def _rodrigues_into(phi, R):
    """exp(skew(phi)) into the row-major (9,) array R: I + a K + b K K with K K = phi phi^T - |phi|^2 I,
    element by element so numba compiles it (flexfmu.core.vec3.rodrigues, used by the paper scheme, is
    the same formula with matrix products: equal up to rounding, compared in tests/test_rotation.py)."""
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


#: the compiled version, for the numba kernels (the numpy kernels call the interpreted one)
_rod9 = _jit(_rodrigues_into)


@_jit
def _rate_coefficient(th):
    """c(theta) of Eq. (22) (as flexfmu.core.rotation.rotvec_rate_coefficient)."""
    if th < _SERIES_THETA:
        t2 = th * th
        return 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 / 1209600.0))
    half = 0.5 * th
    return (1.0 - half * math.cos(half) / math.sin(half)) / (th * th)


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
    from flexfmu.reframe.layout import param_layout
    return param_layout(nf).end


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
    """Length of the outputs of one state (flexfmu.reframe.layout.output_layout)."""
    from flexfmu.reframe.layout import output_layout
    return output_layout(nf, n_points).size


#: the kernels the integrator calls, compiled when numba is installed, and their numpy versions (tests
#: compare them).  Bound on first use: the modules holding them import this one for its helpers.
_KERNELS = ("consistent_steps", "reframe_steps", "consistent_outputs", "reframe_outputs")
if not NUMBA:
    max_node_norm = max_node_norm_numpy               # noqa: F811


def __getattr__(name):
    base = name[:-len("_numpy")] if name.endswith("_numpy") else name
    if base not in _KERNELS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    if NUMBA and base == name:
        from flexfmu.reframe import kernels_nb_outputs, kernels_nb_step
        value = getattr(kernels_nb_step if "steps" in base else kernels_nb_outputs, "_nb_" + base)
    else:
        from flexfmu.reframe import kernels_numpy
        value = getattr(kernels_numpy, base)
    globals()[name] = value
    return value
