"""The lowest natural modes of a large held (clamped) structure, K positive definite on the DOFs the clamp leaves
free: block Lanczos on the inverted problem with one sparse Cholesky factorisation of K (flexfmu.linalg.lanczos: MKL
PARDISO when the optional pypardiso is installed, else SuperLU), the solver flexfmu.linalg.modal_basis uses for free
bodies, here without a rigid subspace to deflate; then a Rayleigh-Ritz step, the Rayleigh quotients in extended
precision and the residual check of every mode, as there.

flexfmu.linalg.modal.solve_modes' sparse path (ARPACK's single-vector eigsh in shift-invert mode on SuperLU,
factorised twice: once to estimate the shift) suits the banded beam models it serves; on a solid mesh SuperLU's
factor fills in and ARPACK needs many solves: a clamped tet4 box of 56 355 DOFs took 212 s and 1.4 GB there
(docs/export.md, "Model size limits", has this path's times).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from flexfmu.core.progress import progress_bar
from flexfmu.errors import ParameterError
from flexfmu.linalg.lanczos import _block_lanczos, _one_openblas_thread, _shifted_solver
from flexfmu.linalg.modal import Modes
from flexfmu.linalg.modal_basis import (KRYLOV_BLOCK, KRYLOV_MAX_DIM, KRYLOV_RTOL, ZERO_EIG_RTOL, _check_residuals,
                                        _stiffness_quotients)


def lanczos_modes(K, M, n_modes: int, *, progress: bool = False, label: str = "modes") -> Modes:
    """The lowest ``n_modes`` eigenpairs of K phi = lambda M phi, K symmetric positive definite (a held structure),
    M symmetric positive definite: frequencies in Hz, shapes M-orthonormal.

    progress: show the count of converged modes on stderr while the solve runs (flexfmu.core.progress: a tqdm bar
    on a terminal, a line per 10 % elsewhere, nothing for solves under a second), labelled ``label``.

    Raises RuntimeError when K cannot be factorised or has a zero-energy mode (the structure is not held in
    every direction), ModalConvergenceError (a RuntimeError too) when the Krylov space of KRYLOV_MAX_DIM columns
    does not converge or a mode fails its residual check."""
    K, M = sp.csr_matrix(K, dtype=float), sp.csr_matrix(M, dtype=float)
    n_dof = K.shape[0]
    if not (isinstance(n_modes, (int, np.integer)) and 1 <= n_modes < n_dof):
        raise ParameterError("n_modes", f"got {n_modes!r}", f"1 .. {n_dof - 1} (DOFs of the model, less one)")
    try:
        solve, close, _ = _shifted_solver(K, M, 0.0, metis=True)     # held solids: 3D meshes (see _Pardiso)
    except ParameterError as exc:          # singular K: SuperLU's "Factor is exactly singular"
        raise RuntimeError(f"K cannot be factorised: {exc}") from None
    empty = np.zeros((n_dof, 0))
    bar = progress_bar(int(n_modes), label, enabled=progress, unit="mode")
    try:
        with _one_openblas_thread():
            V = _block_lanczos(solve, M, empty, empty, int(n_modes), KRYLOV_BLOCK, KRYLOV_RTOL, KRYLOV_MAX_DIM,
                               report=bar.update_to)
    finally:
        close()
        bar.close()
    KV, MV = K @ V, M @ V
    Kr, Mr = V.T @ KV, V.T @ MV
    lam, Q = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    shapes = V @ Q
    m_diag = M.diagonal()
    lam_scale = float(np.max(K.diagonal()[m_diag > 0] / m_diag[m_diag > 0]))      # ~ the largest lambda
    if lam[0] <= ZERO_EIG_RTOL * lam_scale:
        raise RuntimeError(f"K has a zero-energy mode (lambda_1 = {lam[0]:.3g} rad^2/s^2, round-off level "
                           f"{ZERO_EIG_RTOL * lam_scale:.3g})")
    absK = sp.csr_matrix((np.abs(K.data), K.indices, K.indptr), shape=K.shape)
    _check_residuals(KV @ Q, MV @ Q, absK @ np.abs(shapes), lam, "sparse")
    lam = _stiffness_quotients(K, shapes) / np.einsum("ij,ij->j", shapes, MV @ Q)
    order = np.argsort(lam)
    return Modes(frequencies_hz=np.sqrt(np.maximum(lam[order], 0.0)) / (2 * np.pi), shapes=shapes[:, order],
                 method="lanczos")
