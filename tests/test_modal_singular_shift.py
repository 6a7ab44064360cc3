"""The dense inverted eigenproblem of a free body (flexfmu.linalg.modal.dense_low_modes) and the decision to
shift it: a free body's K is singular, but in floating point its Cholesky factorisation may still complete with
pivots at round-off level (the slender 4 x 1 x 1 Kuhn-tetra box: last pivot 1e-5 against 4.6e10 on the diagonal).
Taking that as "K is positive definite, no shift" made eigh(M, K) fail on its own factorisation of K and
flexfmu modal call a healthy free model singular.

Reference: scipy.linalg.eigh of the full dense K, M (rigid modes included), an independent solver; both solve the
same matrices, so their difference is round-off: for each eigenvalue lambda, Weyl's bound on a backward-stable
solve gives |d lambda| <= gamma_n ||K|| / lambda_min(M) + gamma_n lambda ||M|| / lambda_min(M) (per solver), which
the tolerance below states.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from error_bounds import gamma
from flexfmu.core.structure import N_RIGID

meshio = pytest.importorskip("meshio")

STEEL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}


def slender_free_box(tmp_path, size=(1.0, 0.05, 0.05)):
    from test_importers import box_mesh
    from flexfmu.importers import load_structure

    points, cells = box_mesh("tetra", (4, 1, 1), size)
    path = tmp_path / "box.vtu"
    meshio.write(path, meshio.Mesh(points, [("tetra", cells)]))
    return load_structure(path, material=STEEL)


def eigenvalue_tolerance(K: np.ndarray, M: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Round-off bound of two backward-stable dense solves of K x = lambda M x (gamma_{n^2} per solve for the
    reductions and the tridiagonal QR; twice, one per solver)."""
    n = K.shape[0]
    norm_k, norm_m = np.linalg.norm(K, 2), np.linalg.norm(M, 2)
    m_min = float(np.linalg.eigvalsh(M)[0])
    return 2 * gamma(n * n) * (norm_k + np.abs(lam) * norm_m) / m_min


def test_cholesky_completing_on_a_singular_free_K_is_not_taken_as_definite(tmp_path):
    """The premise: LAPACK's Cholesky of this singular K completes (so the old test chose no shift)."""
    s = slender_free_box(tmp_path)
    K = s.K.toarray()
    try:      # the call the old shift decision made; whether it completes depends on the LAPACK build
        U = sla.cholesky(K)
        assert np.min(np.diag(U) ** 2 / np.diag(K)) < 1e-14      # it did: a round-off pivot
    except np.linalg.LinAlgError:
        pass
    from flexfmu.linalg.modal import dense_low_modes

    lam, phi = dense_low_modes(K, s.M.toarray(), N_RIGID + 3)
    reference = sla.eigh(K, s.M.toarray(), eigvals_only=True)[:N_RIGID + 3]
    tol = eigenvalue_tolerance(K, s.M.toarray(), reference)
    assert np.all(np.abs(lam - reference) <= tol)
    assert reference[N_RIGID] > 1e3 * tol[N_RIGID]    # the first elastic eigenvalue is resolved, not round-off


@pytest.mark.parametrize("size", [(1.0, 0.05, 0.05), (1.0, 0.125, 0.0625), (1.0, 1.0, 1.0)])
def test_natural_modes_of_a_small_free_box_match_dense_eigh(tmp_path, size):
    from flexfmu.body.modes import natural_modes

    s = slender_free_box(tmp_path, size)
    assert s.n_dof == 60
    K, M = s.K.toarray(), s.M.toarray()
    reference = sla.eigh(K, M, eigvals_only=True)
    elastic = reference[N_RIGID:N_RIGID + 3]
    tol = eigenvalue_tolerance(K, M, elastic)
    assert np.all(np.abs(reference[:N_RIGID]) <= eigenvalue_tolerance(K, M, reference[:N_RIGID]))   # 6 rigid
    modes = natural_modes(s, n_modes=3)
    lam = (2 * np.pi * modes.frequencies_hz) ** 2
    assert np.all(np.abs(lam - elastic) <= tol), (lam, elastic, tol)


def test_modal_basis_dense_path_of_the_slender_box(tmp_path):
    """modal_basis (flexfmu export of a free body) takes the same dense path."""
    from flexfmu.linalg.modal_basis import modal_basis

    s = slender_free_box(tmp_path)
    basis = modal_basis(s, 4, damping_ratio=0.0, method="dense", cache=False)
    K, M = s.K.toarray(), s.M.toarray()
    elastic = sla.eigh(K, M, eigvals_only=True)[N_RIGID:N_RIGID + 4]
    lam = (2 * np.pi * basis.frequencies_hz) ** 2
    assert np.all(np.abs(lam - elastic) <= eigenvalue_tolerance(K, M, elastic))
