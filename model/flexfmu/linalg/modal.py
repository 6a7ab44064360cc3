"""Natural frequencies and mass-normalised mode shapes: eig(K, M) (Koda et al. 2025, Sec. 3).

Dense ``scipy.linalg.eigh`` for small models, sparse shift-invert ``eigsh`` for large
ones; both return the same (tested).  A negative shift keeps K - sigma*M positive
definite even for free-free structures, whose rigid-body eigenvalues are ~0; it is set to
1e-3 of the highest requested eigenvalue (estimated first), see ``solve_modes``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexfmu.core.blas import limited_for
from flexfmu.errors import require
from flexfmu.linalg.cutoffs import BEAM_MODES_DENSE_MAX_DOF

DENSE_LIMIT = BEAM_MODES_DENSE_MAX_DOF  # free DOFs up to which the dense solver is used by default (why: cutoffs)


@dataclass
class Modes:
    """frequencies_hz (k,), ascending; shapes (n, k) with shapes.T @ M @ shapes = I."""

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    method: str

    @property
    def omega(self) -> np.ndarray:
        """Angular natural frequencies, rad/s."""
        return 2 * np.pi * self.frequencies_hz


def _eigenvalues_to_hz(lam: np.ndarray) -> np.ndarray:
    # Rigid-body eigenvalues come out as round-off of either sign: negative ones are 0 Hz.
    return np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)


def definite_beyond_round_off(K: np.ndarray, M: np.ndarray) -> bool:
    """Whether K is positive definite by more than the backward error of its own Cholesky factorisation.

    A completed Cholesky factorisation does not prove a singular K definite: the computed factor is the exact
    one of K + dK with |dK| <= gamma_{n+1} |L| |L^T| (Higham, ASNA Thm 10.3), so a free body's K may factorise
    with pivots at round-off level (the slender 4 x 1 x 1 Kuhn-tetra box: 1e-5 against 4.6e10 on the diagonal),
    and eigh(M, K) then fails on the same matrix or returns garbage.  Two steps of inverse iteration with the
    factor (x <- K^-1 M x: components along the smallest eigenvalue grow by 1 / lambda_min per step) find the
    softest direction; K counts as definite only when that direction's energy x^T K x exceeds the round-off
    floor gamma_{n+1} |x|^T (|L| |L^T| + |K|) |x| (the factor's backward error plus the evaluation of x^T K x).
    Two triangular solves and three products: O(n^2) beside the factorisation's O(n^3)."""
    try:
        L = sla.cholesky(K, lower=True)
    except sla.LinAlgError:
        return False
    n = K.shape[0]
    x = np.random.default_rng(0).standard_normal(n)     # fixed start: the same decision on every run
    for _ in range(2):
        x = sla.cho_solve((L, True), M @ x)
        peak = float(np.max(np.abs(x)))
        if not np.isfinite(peak) or peak == 0.0:
            return False
        x /= peak
    u = np.finfo(float).eps / 2
    gamma = (n + 1) * u / (1 - (n + 1) * u)
    ax = np.abs(x)
    absL = np.abs(L)
    floor = gamma * float(ax @ (absL @ (absL.T @ ax)) + ax @ (np.abs(K) @ ax))
    return float(x @ (K @ x)) > floor


def dense_low_modes(K: np.ndarray, M: np.ndarray, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Lowest eigenpairs via the inverted problem M phi = mu (K + s M) phi, lambda = 1/mu - s.

    eigh(K, M) reduces with the Cholesky factor of M and loses about eps * lambda_max / lambda_1
    in the low modes (~1e-9 for slender beams); the largest mu of the inverted problem are
    accurate to ~eps * (lambda + s) / s.  s = 0 when K is positive definite beyond round-off
    (definite_beyond_round_off: a free body's K may factorise with round-off pivots); otherwise (free
    structures) s = 1e-3 of the highest requested eigenvalue from a first estimate.
    """
    n = K.shape[0]
    s = 0.0
    if not definite_beyond_round_off(K, M):
        # up to 6 more than requested: when only rigid-body modes are requested (their eigenvalues are
        # round-off), the first elastic one still sets the scale of the shift
        estimate = sla.eigh(K, M, subset_by_index=[0, min(n, n_modes + 6) - 1], eigvals_only=True)
        round_off = 1e-9 * float(np.max(np.abs(np.diag(K)))) / float(np.max(np.diag(M)))
        scale = float(estimate[n_modes - 1]) if estimate[n_modes - 1] > round_off else \
            next((float(x) for x in estimate if x > round_off), 0.0)
        s = 1e-3 * scale if scale > 0 else 1e-6 * float(np.median(np.diag(K)))
    mu, phi = sla.eigh(M, K + s * M, subset_by_index=[n - n_modes, n - 1])
    return (1.0 / mu - s)[::-1], phi[:, ::-1]


def solve_modes(K, M, n_modes: int, method: str = "auto") -> Modes:
    """Lowest ``n_modes`` eigenpairs of K phi = lambda M phi (symmetric, M positive definite)."""
    n = K.shape[0]
    require(isinstance(n_modes, (int, np.integer)) and 1 <= n_modes <= n, "n_modes",
            f"got {n_modes!r}", f"1 <= n_modes <= {n} (number of free DOFs)")
    require(method in ("auto", "dense", "sparse"), "method", f"got {method!r}", "auto | dense | sparse")
    if method == "auto":
        method = "dense" if n <= DENSE_LIMIT or n_modes >= n - 1 else "sparse"
    with limited_for(n):          # small problems: BLAS threads only wait for cores (flexfmu.core.blas)
        return _solve_modes(K, M, n_modes, method)


def _solve_modes(K, M, n_modes: int, method: str) -> Modes:
    # Symmetric diagonal scaling D = diag(M)^-1/2: translational and rotational DOFs differ by
    # orders of magnitude in mass, which costs the generalised solvers digits otherwise.
    m_diag = M.diagonal() if sp.issparse(M) else np.diag(M)
    require(bool(np.all(m_diag > 0)), "M", "mass matrix has a non-positive diagonal entry",
            "positive definite on the free DOFs")
    d = 1.0 / np.sqrt(m_diag)
    D = sp.diags(d)
    Ks, Ms = (D @ sp.csr_matrix(K) @ D), (D @ sp.csr_matrix(M) @ D)
    if method == "dense":
        lam, phi = dense_low_modes(Ks.toarray(), Ms.toarray(), n_modes)
    else:
        # Shift as in the dense path: 1e-3 of the highest requested eigenvalue, estimated by a first
        # pass at sigma = -1 (tiny in these scaled units).  A shift far below the wanted eigenvalues
        # clusters them after inversion and ARPACK crawls (247 s at 10k DOFs with -1e-6 median(K/M));
        # one far too small loses the elastic modes of free structures next to the rigid ones.
        Kc, Mc = Ks.tocsc(), Ms.tocsc()
        estimate, vectors = spla.eigsh(Kc, k=n_modes, M=Mc, sigma=-1.0, which="LM")
        sigma = -1e-3 * max(float(np.max(estimate)), 1.0)
        lam, phi = spla.eigsh(Kc, k=n_modes, M=Mc, sigma=sigma, which="LM", v0=vectors.sum(axis=1))
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
    phi = d[:, None] * phi
    # eigsh's vectors are M-orthonormal only to its tolerance: normalise exactly (both paths).
    phi = phi / np.sqrt(np.einsum("ik,ik->k", phi, M @ phi))
    return Modes(frequencies_hz=_eigenvalues_to_hz(lam), shapes=phi, method=method)
