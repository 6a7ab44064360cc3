"""BLAS threads chosen by problem size (flexfmu.core.blas): one thread for small set-up work, the libraries'
own count for large, and the set-up entry points really run under that limit."""
from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.linalg  # noqa: F401  (loads scipy's OpenBLAS, so that the controller sees it)
import scipy.sparse as sp
from threadpoolctl import threadpool_info

from error_bounds import U, gamma
from flexfmu.core import blas
from flexfmu.errors import ParameterError
from flexfmu.linalg import modal
from flexfmu.linalg.modal import solve_modes

pytestmark = pytest.mark.unit


def blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_one_thread_below_the_threshold_all_above():
    assert blas.threads_for(0) == blas.threads_for(blas.SINGLE_THREAD_BELOW_DIM - 1) == 1
    import os
    assert blas.threads_for(blas.SINGLE_THREAD_BELOW_DIM) == (os.cpu_count() or 1)
    with pytest.raises(ParameterError, match="dimension"):
        blas.threads_for(-1)


def test_the_limit_holds_inside_and_is_restored_after():
    before = blas_threads()
    with blas.limited_for(150):
        assert blas_threads() and all(n == 1 for n in blas_threads())
    assert blas_threads() == before
    with blas.limited_for(10 * blas.SINGLE_THREAD_BELOW_DIM):      # large: the libraries' own setting
        assert blas_threads() == before
    with blas.single_thread():
        assert all(n == 1 for n in blas_threads())


def test_a_small_modal_analysis_runs_on_one_thread(monkeypatch):
    seen = []
    dense = modal.dense_low_modes

    def recording(K, M, n_modes):
        seen.append(blas_threads())
        return dense(K, M, n_modes)

    monkeypatch.setattr(modal, "dense_low_modes", recording)
    n = 40
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr()
    modes = solve_modes(K, sp.identity(n, format="csr"), 3)
    assert seen and all(n_threads == 1 for n_threads in seen[0])
    with mpmath.workdps(40):                  # the exact eigenvalues 2 - 2 cos(k pi / (n + 1)), rounded to double: u
        exact = np.array([float(2 - 2 * mpmath.cos(mpmath.pi * k / (n + 1))) for k in range(1, 4)])
    # M = I (the diagonal scaling by 1 / sqrt(1) is exact), K positive definite: mu = 1 / lambda from eigh(M, K):
    # * the Cholesky factor of the tridiagonal K: inner products of <= 2 terms, |dK| <= gamma_3 |L| |L^T| = gamma_3
    #   |L L^T| (the sign pattern of an M-matrix) [ASNA Thm 10.3]: lambda_k moves by <= gamma_3 (1 + gamma_3) ||K||_2
    #   (Weyl; || |K| ||_2 < 4);
    # * the reduction to C = L^-1 M L^-T and its symmetric eigensolver: backward stable relative to ||C||_2 = mu_1
    #   [LAPACK Users' Guide 4.7, 4.10], p(n) u counted as 10 n roundings: mu_k relative gamma_{10 n} mu_1 / mu_k;
    # * 1 / mu, sqrt, / 2 pi, * 2 pi and the square: 5 roundings more (gamma_8 generously), and the reference's u
    rel = gamma(3) * (1 + gamma(3)) * 4.0 / exact + gamma(10 * n) * exact / exact[0] + gamma(8) + 2 * U
    err = np.abs(modes.omega ** 2 - exact)
    print(f"\nmax |omega^2 - exact| / (bound exact) = {np.max(err / (rel * exact)):.2g}")
    assert np.all(err <= rel * exact * (1 + U))
