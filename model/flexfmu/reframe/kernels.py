"""Hot loops of the consistent and exponential reframe schemes (:mod:`flexfmu.reframe.integrator`): whole RK4 or
ETD-RK4 steps and the outputs of one state, in modal space, on flat arrays.

Two implementations of the same equations: C (flexfmu/native/csrc/reframe_kernels.c, the one compiled
implementation, called here through ctypes by :mod:`flexfmu.native.reframe` and linked into native FMUs) and
numpy (:mod:`flexfmu.reframe.kernels_numpy`, the reference; tests/test_native_reframe_kernels.py compares
them).  The public names (``consistent_steps``, ``reframe_steps``, ``consistent_outputs``,
``reframe_outputs``, ``max_node_norm``) are the C ones when a C compiler is available or the library is
already in the cache (compiled once per source digest into ``<cache root>/native``,
flexfmu.native.compiler), else the numpy ones; ``FLEXFMU_NATIVE_KERNELS=0`` in the environment forces numpy.
``*_numpy`` are always the numpy ones.  :data:`NATIVE` (bound on first use, as the kernels: the library is
loaded, and compiled if needed, then) says which; :data:`NATIVE_REASON` why not C.

This module holds the scalar helpers of the numpy kernels (the C file has their twins: ffx_reframe_rodrigues,
_rate_coefficient, _solve3, _quaternion, _offsets, _bound, _block_norm, _max_node_norm) and the public names.

Everything here is O(n_modes^2) per step whatever the mesh size, except :func:`max_node_norm`
(O(number of nodes) in the worst case, a few nodes in practice: see :func:`max_node_norm_blocks`).

Layouts of the flat arrays: ``P`` (model parameters), ``y`` (state) and the outputs of one state are
declared in :mod:`flexfmu.reframe.layout` (``_offsets`` below gives ``P``'s offsets); the C header
flexfmu/native/csrc/reframe_kernels.h documents all of them for C callers.  The integrator
(``ReframeIntegrator._setup_consistent``, ``_kernel_loads``, ``_point_data``) builds the others:

* ``LP`` loads, one block of 5 + 6 nf per load: follower (0/1), rotational DOFs (0/1), arm
  X_i - c (3), translational rows of Phi at the node (3*nf), rotational rows (3*nf, zeros if none).
* ``SV`` load values (n_steps or 1, 3 stages t, t + dt/2, t + dt, n_loads, 6 = force, moment).
* ``G`` geometric stiffness (9 nf^2: (3, 3, nf, nf) row-major, body frame) or empty: adds
  -(sum_ab X_ab G_ab) q_F, X = skew(omega)^2, to the flexible momentum rate.
* ``EX`` exponential-scheme coefficients for one dt (nf, 6, 2, 2 row-major: E1, E2, A2, B1, B2, B4 of
  :func:`flexfmu.reframe.schemes.exponential_coefficients`) or empty: classical RK4 (consistent scheme).
* ``PP`` output points, one row [X - c (3), translational rows of Phi (3*nf)] each.

The C kernels need C-contiguous float64 arrays (int64 for the node order), which is how the integrator and
flexfmu.body.free make them; other arrays are converted per call (correct, slower).
"""
from __future__ import annotations

import math
import os
import warnings

import numpy as np


#: FLEXFMU_NATIVE_KERNELS=0 (false, no, off): the numpy kernels even when the C library is available
_WANT_NATIVE = os.environ.get("FLEXFMU_NATIVE_KERNELS", "1").strip().lower() not in ("0", "false", "no", "off")


#: below this rotation angle Eq. (22)'s coefficient uses its series (as flexfmu.core.rotation)
_SERIES_THETA = 0.1
N_RIGID = 6


# --------------------------------------------------------------------------- small 3-vector helpers
def _rodrigues_into(phi, R):
    """exp(skew(phi)) into the row-major (9,) array R: I + a K + b K K with K K = phi phi^T - |phi|^2 I,
    element by element as the C kernels' ffx_reframe_rodrigues (flexfmu.core.vec3.rodrigues, used by the paper
    scheme, is the same formula with matrix products: equal up to rounding, compared in tests/test_rotation.py)."""
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


def _rate_coefficient(th):
    """c(theta) of Eq. (22) (as flexfmu.core.rotation.rotvec_rate_coefficient)."""
    if th < _SERIES_THETA:
        t2 = th * th
        return 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 / 1209600.0))
    half = 0.5 * th
    return (1.0 - half * math.cos(half) / math.sin(half)) / (th * th)


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
def _offsets(nf):
    """Start offsets of P's blocks (J0, A, B, C, D, k, c, A6, A6inv, com, end), as ffx_reframe_offsets."""
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


#: the kernels the integrator calls: C when the library is available (see the module docstring), numpy
#: otherwise; ``*_numpy`` always numpy.  Bound on first use (loading, or compiling, the library then).
_KERNELS = ("consistent_steps", "reframe_steps", "consistent_outputs", "reframe_outputs", "max_node_norm")


def _native():
    """The C bindings (flexfmu.native.reframe) with the library loaded, or the reason they are not used."""
    if not _WANT_NATIVE:
        return None, "disabled by FLEXFMU_NATIVE_KERNELS=0"
    try:
        from flexfmu.native import reframe as native
        native.library()
    except Exception as exc:          # CompilerError (no compiler, does not compile), OSError (cannot load)
        reason = f"C kernels unavailable: {exc}".strip()
        warnings.warn(f"flexfmu: {reason}; the reframe kernels run as numpy (about 30x slower per step). "
                      "Install a C compiler (gcc, clang) or set FLEXFMU_NATIVE_KERNELS=0 to silence this.",
                      RuntimeWarning, stacklevel=3)
        return None, reason
    return native, None


def _use_native() -> bool:
    if "NATIVE" not in globals():
        native, reason = _native()
        globals().update(NATIVE=native is not None, NATIVE_REASON=reason)
    return NATIVE


def __getattr__(name):
    if name in ("NATIVE", "NATIVE_REASON"):
        _use_native()
        return globals()[name]
    base = name[:-len("_numpy")] if name.endswith("_numpy") else name
    if base not in _KERNELS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    if base == "max_node_norm":
        value = max_node_norm_numpy
        if name == base and _use_native():
            from flexfmu.native import reframe as native
            value = native.max_node_norm
    elif name == base and _use_native():
        from flexfmu.native import reframe as native
        value = getattr(native, base)
    else:
        from flexfmu.reframe import kernels_numpy
        value = getattr(kernels_numpy, base)
    globals()[name] = value
    return value
