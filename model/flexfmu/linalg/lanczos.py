"""The sparse eigensolver of flexfmu.linalg.modal_basis: block Lanczos on the shift-inverted problem with a
deflated subspace, and the factorisation of K - sigma M it applies (MKL PARDISO's sparse Cholesky through
ctypes when the optional pypardiso is installed, else SuperLU)."""
from __future__ import annotations

import contextlib
import ctypes
import glob
import importlib.util
import os
import sys
from functools import lru_cache

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexfmu.errors import ModalConvergenceError, ParameterError

EPS = np.finfo(float).eps


def _upper_triangle(A: sp.csr_matrix):
    """(data, indptr, indices) of the upper triangle of a CSR matrix with sorted indices, int32 indices,
    or None if a diagonal entry is not stored (PARDISO's symmetric storage needs every diagonal)."""
    n = A.shape[0]
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr))
    keep = A.indices >= rows
    indptr = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(np.bincount(rows[keep], minlength=n), out=indptr[1:])
    indices = A.indices[keep].astype(np.int32)
    if np.any(np.diff(indptr) == 0) or not np.array_equal(indices[indptr[:-1]], np.arange(n, dtype=np.int32)):
        return None
    return np.ascontiguousarray(A.data[keep], dtype=float), indptr, indices


@lru_cache(maxsize=1)
def _mkl_pardiso():
    """The ``pardiso`` function of Intel MKL when the optional ``pypardiso`` package is installed, else None.

    Only MKL's library is used (our own ctypes call below): ``pypardiso.PyPardisoSolver.solve`` hashes
    the matrix on every call and its library search takes ~0.2 s.  MKL's default Intel OpenMP layer ran
    PARDISO single-threaded here; the GNU OpenMP layer (when present and not chosen otherwise through
    MKL_THREADING_LAYER) factorises on two cores in half the time."""
    if importlib.util.find_spec("pypardiso") is None:
        return None
    paths = [os.environ.get("PYPARDISO_MKL_RT", "")]
    for root in (sys.prefix, sys.base_prefix):
        paths += sorted(glob.glob(os.path.join(root, "lib", "libmkl_rt.so*")), key=len)
        paths += sorted(glob.glob(os.path.join(root, "Library", "bin", "mkl_rt*.dll")), key=len)
    lib = None
    for path in filter(None, paths):
        try:
            lib = ctypes.CDLL(path)
            break
        except OSError:
            continue
    if lib is None:                                  # pypardiso's own (slower) search
        try:
            import pypardiso
            lib = pypardiso.PyPardisoSolver().libmkl
        except Exception:                            # noqa: BLE001 - any failure: no PARDISO, SuperLU
            return None
    if "MKL_THREADING_LAYER" not in os.environ and sys.platform.startswith("linux"):
        here = os.path.dirname(getattr(lib, "_name", "") or "")
        try:
            ctypes.CDLL("libgomp.so.1")
            if glob.glob(os.path.join(here, "libmkl_gnu_thread.so*")):
                lib.MKL_Set_Threading_Layer(3)      # MKL_THREADING_GNU
        except (OSError, AttributeError):
            pass
    pardiso = lib.pardiso
    pardiso.restype = None
    return pardiso


class _Pardiso:
    """Sparse Cholesky of a symmetric positive definite CSR matrix by MKL PARDISO (mtype 2)."""

    def __init__(self, pardiso, A: sp.csr_matrix, upper, metis: bool = False):
        self._pardiso = pardiso
        self.n = A.shape[0]
        self.data, self.indptr, self.indices = upper
        self.pt = np.zeros(64, dtype=np.int64)          # PARDISO's opaque handle
        self.iparm = np.zeros(64, dtype=np.int32)
        # Own settings, minimum-degree order, 0-based indices.  On the paper plate minimum degree analyses
        # in 0.25 s and factorises in ~0.25 s (two threads); METIS (iparm[1] = 2) fills a little less but
        # analyses in 0.7 s.  On solid 3D meshes METIS wins (``metis``): a clamped tet4 box of 56k DOFs
        # factorised in 3.6-4.9 s against 11-12 s, its solves twice as fast.
        self.iparm[[0, 1, 34]] = 1, 2 if metis else 0, 1
        try:
            self._call(12, np.zeros((self.n, 1), order="F"))   # analysis + numerical factorisation
        except RuntimeError:
            self.close()
            raise

    def _call(self, phase: int, B: np.ndarray) -> np.ndarray:
        X = np.zeros_like(B)
        err = ctypes.c_int32(0)
        i32 = ctypes.c_int32
        ptr = ctypes.c_void_p
        self._pardiso(ptr(self.pt.ctypes.data), ctypes.byref(i32(1)), ctypes.byref(i32(1)), ctypes.byref(i32(2)),
                      ctypes.byref(i32(phase)), ctypes.byref(i32(self.n)), ptr(self.data.ctypes.data),
                      ptr(self.indptr.ctypes.data), ptr(self.indices.ctypes.data), ptr(None),
                      ctypes.byref(i32(B.shape[1])), ptr(self.iparm.ctypes.data), ctypes.byref(i32(0)),
                      ptr(B.ctypes.data), ptr(X.ctypes.data), ctypes.byref(err))
        if err.value != 0:
            raise RuntimeError(f"PARDISO error {err.value} in phase {phase}")
        return X

    def solve(self, B: np.ndarray) -> np.ndarray:
        if np.ndim(B) == 1:
            return self._call(33, np.asfortranarray(B, dtype=float)[:, None])[:, 0]
        return self._call(33, np.asfortranarray(B, dtype=float))

    def close(self) -> None:
        """Release PARDISO's memory (the factor of the plate: ~100 MB)."""
        if self.pt.any():
            try:
                self._call(-1, np.zeros((self.n, 1), order="F"))
            finally:
                self.pt[:] = 0


def _shifted_solver(K, M, sigma: float, metis: bool = False):
    """(solve, close, backend): X = (K - sigma M)^{-1} B for a block B of right-hand sides, factorised once.

    backend "pardiso": MKL PARDISO's sparse Cholesky (optional pypardiso installed and FLEXFMU_PARDISO
    not "0"; falls back to SuperLU if PARDISO refuses the matrix, e.g. not positive definite), in METIS's
    nested-dissection order when ``metis`` (solid 3D meshes), else minimum degree.
    backend "superlu": SuperLU, COLAMD column order.  K and M are exactly symmetric (validate_structure),
    so A's CSR transpose is its CSC form without a copy.  A reverse Cuthill-McKee order (NATURAL,
    diagonal pivoting) and MMD_AT_PLUS_A both fill more and factorise slower on the paper plate (51k DOFs:
    COLAMD 2.67e7 nonzeros in L + U, ~1.4 s; docs/performance_notes.md)."""
    A = (K - sigma * M).tocsr()
    if os.environ.get("FLEXFMU_PARDISO", "1") != "0":
        pardiso = _mkl_pardiso()
        upper = _upper_triangle(A) if pardiso is not None else None
        if upper is not None:
            try:
                factor = _Pardiso(pardiso, A, upper, metis)
            except RuntimeError:
                pass                                # not positive definite etc.: SuperLU decides below
            else:
                return factor.solve, factor.close, "pardiso"
    try:
        lu = spla.splu(A.T)
    except RuntimeError as exc:
        raise ParameterError("structure.K", f"K - sigma M cannot be factorised ({exc})",
                             "K + |sigma| M non-singular: symmetric positive semi-definite K and M") from None
    return lu.solve, (lambda: None), "superlu"


def _normalize(Y: np.ndarray, MY: np.ndarray, G: np.ndarray, floor: float):
    """Y (Y^T M Y = G) M-orthonormalised symmetrically; directions with Gram eigenvalue <= floor dropped."""
    s, U = np.linalg.eigh(0.5 * (G + G.T))
    keep = s > floor
    T = U[:, keep] / np.sqrt(s[keep])
    return Y @ T, MY @ T


class _MBasis:
    """Growing M-orthonormal basis Q (columns, Fortran order: contiguous for one GEMM) and M Q alongside."""

    def __init__(self, M, n_dof: int, capacity: int):
        self.M = M
        self.Q = np.empty((n_dof, capacity), order="F")
        self.MQ = np.empty((n_dof, capacity), order="F")
        self.size = 0

    def orthonormalize(self, Y: np.ndarray):
        """(Qn, M Qn, C, G): Y M-orthogonalised against Q and M-orthonormalised.

        Two passes of block Gram-Schmidt, each followed by a symmetric normalisation, so the new block
        is orthogonal to round-off even after heavy cancellation ("twice is enough"); directions that
        vanish (Y already in span Q) are dropped.  C = Q^T M Y are the coefficients of Y on the basis,
        G = R^T M R the Gram matrix of R = Y - Q C (the Lanczos residual)."""
        Q, MQ = self.Q[:, :self.size], self.MQ[:, :self.size]
        C = MQ.T @ Y
        Y = Y - Q @ C
        MY = self.M @ Y
        G = Y.T @ MY
        G = 0.5 * (G + G.T)
        scale = float(np.max(np.sum(C ** 2, axis=0) + np.diag(G)))
        Y, MY = _normalize(Y, MY, G, (100.0 * EPS) ** 2 * max(scale, np.finfo(float).tiny))
        C2 = MQ.T @ Y                                   # second pass; M (Y - Q C2) = M Y - M Q C2
        Y = Y - Q @ C2
        MY = MY - MQ @ C2
        Y, MY = _normalize(Y, MY, Y.T @ MY, (100.0 * EPS) ** 2)
        return Y, MY, C, G

    def append(self, Qn: np.ndarray, MQn: np.ndarray) -> None:
        k = Qn.shape[1]
        if self.size + k > self.Q.shape[1]:
            capacity = max(2 * self.Q.shape[1], self.size + k)
            for name in ("Q", "MQ"):
                grown = np.empty((self.Q.shape[0], capacity), order="F")
                grown[:, :self.size] = getattr(self, name)[:, :self.size]
                setattr(self, name, grown)
        self.Q[:, self.size:self.size + k] = Qn
        self.MQ[:, self.size:self.size + k] = MQn
        self.size += k


def _block_lanczos(apply_op, M, Phi: np.ndarray, MPhi: np.ndarray, n: int, block: int, rtol: float,
                   max_dim: int, report=None) -> np.ndarray:
    """(n_dof, n) approximate lowest flexible eigenvectors by block Lanczos on the shift-inverted problem.

    The operator T = P (K - sigma M)^{-1} P^T M (apply_op(M X) = T X), self-adjoint in the M inner
    product on the flexible subspace, has the eigenvalues theta = 1 / (lambda - sigma); its largest
    belong to the lowest lambda (Phi: the deflated rigid modes).  The Krylov space of a random block of ``block``
    columns is built with full reorthogonalisation until every wanted Ritz pair has |T x - theta x|_M <= ``rtol``
    theta.  A block of 5 right-hand sides costs SuperLU ~0.5x the time per column of single solves
    (the factor is read once per block), PARDISO ~0.25x: fewer solve seconds than ARPACK's
    single-vector eigsh for all the 1.4x more columns (paper plate: 55 against 40;
    docs/performance_notes.md).  rtol = 1e-7 gives modes as exact as eigsh's to machine
    precision (residuals 1.4e-8 on the plate); 1e-6 leaves residuals of 1.6e-7.

    Returned are T x / theta for the Ritz vectors x, formed from the solves' outputs: a solve damps the
    high-frequency round-off that Gram-Schmidt leaves in x (|K x - lambda M x| / |K x| 1e-6 -> 1e-8 on
    the plate) at no extra solve.  Raises ModalConvergenceError if ``max_dim`` columns do not suffice.
    ``report(converged)``, if given, is called after every block with the number of wanted Ritz pairs converged so
    far (a progress display's count).
    """
    n_dof = M.shape[0]
    n_flexible = n_dof - Phi.shape[1]
    dim_max = min(n_flexible, max_dim)
    rng = np.random.default_rng(0)

    def random_block(size):
        X = rng.standard_normal((n_dof, size))
        return X - Phi @ (MPhi.T @ X)

    basis = _MBasis(M, n_dof, min(dim_max, 16 * block))
    Qk, MQk, _, _ = basis.orthonormalize(random_block(min(block, dim_max)))
    Ys = []                                         # T Q_k of every block: the solves' outputs
    H = np.zeros((0, 0))                            # Q^T M T Q
    while True:
        Yk = apply_op(MQk)
        basis.append(Qk, MQk)
        Ys.append(Yk)
        Qn, MQn, C, G = basis.orthonormalize(Yk)
        d_old, d = H.shape[0], basis.size
        H_new = np.zeros((d, d))
        H_new[:d_old, :d_old] = H
        H_new[:, d_old:] = C
        H_new[d_old:, :] = C.T
        H = H_new
        theta, Z = np.linalg.eigh(0.5 * (H + H.T))
        theta, Z = theta[::-1], Z[:, ::-1]
        m = min(n, d)
        Zk = Z[d_old:, :m]                          # T Q z - theta Q z = R_k z_k (R_k: the part of Yk outside Q)
        residual = np.sqrt(np.maximum(np.einsum("ij,ik,kj->j", Zk, G, Zk), 0.0)) / np.maximum(theta[:m], 1e-300)
        converged = d >= n and bool(np.all(residual <= rtol))
        if report is not None:
            report(int(np.count_nonzero(residual <= rtol)) if d >= n else 0)
        if converged or d >= dim_max:
            break
        if Qn.shape[1] == 0:                       # invariant subspace found early: continue from new vectors
            Qn, MQn, _, _ = basis.orthonormalize(random_block(min(block, dim_max - d)))
        Qk, MQk = Qn[:, :dim_max - d], MQn[:, :dim_max - d]
    if not converged and d < n_flexible:           # (the whole flexible space is exact)
        raise ModalConvergenceError(
            f"sparse eigensolver: {int(np.sum(residual > rtol))} of {n} modes not converged in a "
            f"{d}-dimensional search space (largest relative Ritz residual {np.max(residual):.3g} > "
            f"{rtol:g}); use fewer modes or method='dense'")
    if np.any(theta[:n] <= 0.0):
        raise ParameterError("structure.K", "K - sigma M is not positive definite on the flexible modes",
                             "symmetric positive semi-definite K, positive definite M, sigma < 0")
    V = np.zeros((n_dof, n))
    row = 0
    for Yj in Ys:
        V += Yj @ Z[row:row + Yj.shape[1], :n]
        row += Yj.shape[1]
    return V / theta[:n]



def _one_openblas_thread():
    """Context limiting OpenBLAS (numpy's BLAS) to one thread, MKL untouched (no-op without threadpoolctl).

    The Lanczos loop alternates PARDISO's OpenMP threads with numpy's Gram-Schmidt products; with both
    thread pools at two threads they spin against each other on two cores (paper plate: 2.4 s -> 2.0 s
    with one OpenBLAS thread).  With SuperLU one thread is as fast as two (2.7 s) at 1.3 s less CPU."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:
        return contextlib.nullcontext()
    return ThreadpoolController().select(internal_api="openblas").limit(limits=1)
