"""Passivity of the fitted radiation memory (RAD.6-RAD.9 of flexfmu.wec.radiation): the test (mu on a check grid,
the crossing frequencies of the pencil of Phi_2) and the enforcement by residue perturbation (Grivet-Talocia), a
least-distance program over cutting planes solved through non-negative least squares."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize

from flexfmu.errors import ConvergenceError
from flexfmu.wec.radiation_fit import _assemble, _basis, _residues_to_coeffs

DEFAULT_PASSIVITY_DELTA = 1e-4    # the margin each enforcement constraint asks for, in units of mu (RAD.7)
_PASSIVITY_ITERATIONS = 60
_CHECK_DECADES = (-3.0, 4.0)      # log grid 1e-3 .. 1e4 rad/s (mu's limits at 0 and inf are exact points)
_CHECK_PER_DECADE = 200
_CHECK_LINEAR_STEP = 0.01         # rad/s, over 0 .. 2 omega_max
_CROSSING_TOLERANCE = 1e-7        # |Re z| / |z| below which a zero of Phi_2 counts as imaginary
_CROSSING_RANGE = 1e4             # zeros of Phi_2 beyond this x the largest |pole| are the pencil's infinite ones


# ------------------------------------------------------------------ passivity: test and enforcement
def _shape(omega, w_lo, w_hi):
    """s(w) of RAD.7: ~ (w / w_lo)^2 at low and ~ (w_hi / w)^2 at high frequency, ~ 1 in between."""
    x, y = (omega / w_lo) ** 2, (omega / w_hi) ** 2
    return x / ((1 + x) * (1 + y))


def _normalised_rows(poles, omega, w_lo, w_hi) -> np.ndarray:
    """rho (n_w, n) with Re K(j w) / s(w) = rho(w) . coef for a fit with these poles and real coefficients
    coef (the basis of _basis) whose K(0) = 0; at w = 0 the limit of Re K / s (w_lo^2 times the w^2
    coefficient, per pole 1 / a^3), at w = inf its limit (the 1 / w^2 coefficient over w_hi^2, per pole -a).
    Below the smallest |pole| each basis function is taken minus its value at 0 (jw / (a (jw - a)) in place
    of 1 / (jw - a), the same for a coef with K(0) = 0), free of the cancellation of K(0) at low frequency."""
    omega = np.asarray(omega, float)
    a = np.asarray(poles, complex)
    zero, inf = omega == 0, np.isinf(omega)
    low = ~(zero | inf) & (omega < np.min(np.abs(a)))
    high = ~(zero | inf | low)
    vals = np.empty((omega.size, a.size), complex)
    vals[zero] = w_lo**2 / a**3
    vals[inf] = -a / w_hi**2
    s = 1j * omega[low, None]
    vals[low] = s / (a * (s - a)) / _shape(omega[low], w_lo, w_hi)[:, None]
    s = 1j * omega[high, None]
    vals[high] = 1 / (s - a) / _shape(omega[high], w_lo, w_hi)[:, None]
    cols = []
    k = 0
    while k < a.size:
        if abs(a[k].imag) < 1e-12 * max(1.0, abs(a[k])):
            cols.append(vals[:, k].real)
            k += 1
        else:
            cols += [(vals[:, k] + vals[:, k + 1]).real, (1j * (vals[:, k] - vals[:, k + 1])).real]
            k += 2
    return np.column_stack(cols)


class _PassivityProblem:
    """The residue perturbation of a set of pair fits (Grivet-Talocia's approach, poles kept).

    Unknowns: per pair the change of its real coefficients, restricted to K(0) = 0, c_p = c0_p + N_p y_p.
    Objective: sum_p m_p || dK_p ||^2 / ref_p^2 over the database's frequencies (m_p = 2 for a coupling pair,
    realised for (i, j) and (j, i)): the change of the RAD.4 errors.  With W = Q R (per pair) and z = R y the
    problem min ||z||^2 subject to the linear constraints G z >= h is a least-distance program, solved
    exactly by non-negative least squares (Lawson & Hanson, ch. 23).  Constraints (cuts): at a frequency w
    (or the limits w = 0, inf), for an eigenvector v of mu's matrix (RAD.7) whose eigenvalue is below delta,
    v^T T Re K(j w) T v / s(w) >= delta, linear in the coefficients."""

    def __init__(self, pairs, refs, omega, K_pairs, d, scale, w_lo, w_hi, delta):
        self.pairs, self.d, self.t = pairs, d, scale
        self.w_lo, self.w_hi, self.delta = w_lo, w_hi, delta
        self.omega = omega
        self.K_pairs = K_pairs
        self.refs = refs
        self.blocks = []
        for pf, ref in zip(pairs, refs):
            c0 = _residues_to_coeffs(pf.residues, pf.poles)
            N = scipy.linalg.null_space(_basis(np.array([0j]), pf.poles).real)      # K(0) = 0
            Phi = _basis(1j * omega, pf.poles)
            mult = 1.0 if pf.i == pf.j else 2.0
            W = np.vstack([Phi.real, Phi.imag]) @ N * math.sqrt(mult) / ref
            R = np.linalg.qr(W, mode="r")
            self.blocks.append(dict(c0=c0, N=N, Phi=Phi, R=R))
        sizes = [blk["N"].shape[1] for blk in self.blocks]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)])
        self.R = scipy.linalg.block_diag(*[blk["R"] for blk in self.blocks])
        self.y = np.zeros(self.offsets[-1])
        self.cuts_a, self.cuts_h = [], []

    def coefs(self, y=None):
        y = self.y if y is None else y
        return [blk["c0"] + blk["N"] @ y[self.offsets[k]:self.offsets[k + 1]] for k, blk in enumerate(self.blocks)]

    def rows(self, omega):
        return [_normalised_rows(pf.poles, omega, self.w_lo, self.w_hi) for pf in self.pairs]

    def matrices(self, rows, coefs=None):
        """mu's matrices T Re K T / s over the rows' frequencies, (n_w, d, d)."""
        coefs = self.coefs() if coefs is None else coefs
        H = np.zeros((rows[0].shape[0], self.d, self.d))
        for pf, r, c in zip(self.pairs, rows, coefs):
            v = r @ c
            H[:, pf.i, pf.j] += v
            if pf.i != pf.j:
                H[:, pf.j, pf.i] += v
        return H * self.t[None, :, None] * self.t[None, None, :]

    def mu(self, omega):
        return np.linalg.eigvalsh(self.matrices(self.rows(np.atleast_1d(omega))))[:, 0]

    def add_cuts(self, w) -> int:
        rows = self.rows(np.array([w]))
        lam, V = np.linalg.eigh(self.matrices(rows)[0])
        added = 0
        for q in np.flatnonzero(lam < self.delta):
            u = self.t * V[:, q]
            a = np.zeros(self.y.size)
            h = self.delta
            for k, (pf, r, blk) in enumerate(zip(self.pairs, rows, self.blocks)):
                g = u[pf.i] * u[pf.j] * (1.0 if pf.i == pf.j else 2.0)
                a[self.offsets[k]:self.offsets[k + 1]] = g * (r[0] @ blk["N"])
                h -= g * (r[0] @ blk["c0"])
            nrm = np.linalg.norm(a)
            if nrm > 0:
                self.cuts_a.append(a / nrm)
                self.cuts_h.append(h / nrm)
                added += 1
        return added

    def solve(self) -> None:
        """The least-distance program over all cuts so far: y of the smallest weighted change."""
        G = scipy.linalg.solve_triangular(self.R, np.array(self.cuts_a).T, trans="T").T      # a R^{-1}
        h = np.array(self.cuts_h)
        scale = np.linalg.norm(G, axis=1)
        G, h = G / scale[:, None], h / scale
        E = np.vstack([G.T, h[None, :]])
        f = np.zeros(E.shape[0])
        f[-1] = 1.0
        u, _ = scipy.optimize.nnls(E, f, maxiter=50 * E.shape[1])
        r = E @ u - f
        if abs(r[-1]) < 1e-12:
            raise ConvergenceError("passivity enforcement: the constraints on the residues are infeasible")
        z = -r[:-1] / r[-1]
        self.y = scipy.linalg.solve_triangular(self.R, z)

    def errors(self, coefs=None):
        coefs = self.coefs() if coefs is None else coefs
        return [float(np.linalg.norm(blk["Phi"] @ c - Kp) / ref)
                for blk, c, Kp, ref in zip(self.blocks, coefs, self.K_pairs, self.refs)]


def _check_grid(omega_max) -> np.ndarray:
    lo, hi = _CHECK_DECADES
    grid = np.concatenate([[0.0, np.inf], np.logspace(lo, hi, round((hi - lo) * _CHECK_PER_DECADE) + 1),
                           np.arange(1, round(2 * omega_max / _CHECK_LINEAR_STEP) + 1) * _CHECK_LINEAR_STEP])
    return np.unique(grid)


def _refine(problem, lo, hi):
    """(w, mu) at the minimum of mu over [lo, hi] (0 < lo < hi < inf): nested log grids, three levels of 64."""
    for _ in range(3):
        w = np.geomspace(lo, hi, 65)
        mu = problem.mu(w)
        k = int(np.argmin(mu))
        lo, hi = w[max(k - 1, 0)], w[min(k + 1, w.size - 1)]
    return float(w[k]), float(mu[k])


def _local_minima(problem, grid, mu, below):
    """Grid local minima of mu below ``below``, refined between their neighbours (w = 0 and inf as they are)."""
    out = []
    for k in range(grid.size):
        if mu[k] >= below or (k > 0 and mu[k - 1] < mu[k]) or (k + 1 < grid.size and mu[k + 1] < mu[k]):
            continue
        if not 0 < grid[k] < np.inf:
            out.append((float(grid[k]), float(mu[k])))
            continue
        lo = grid[k - 1] if grid[k - 1] > 0 else grid[k] / 10
        hi = grid[k + 1] if np.isfinite(grid[k + 1]) else grid[k] * 10
        out.append(min(_refine(problem, lo, hi), (float(grid[k]), float(mu[k])), key=lambda p: p[1]))
    return out


def _band_minima(problem, crossings, grid_max):
    """Minima of mu between consecutive crossing frequencies (the bands where its sign changes)."""
    edges = np.concatenate([[0.0], np.sort(crossings), [np.inf]])
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        lo = lo if lo > 0 else min(hi, grid_max) * 1e-3
        hi = hi if np.isfinite(hi) else max(lo, 1.0) * 1e3
        w = np.geomspace(lo, hi, 257)
        mu = problem.mu(w)
        k = int(np.argmin(mu))
        out.append(_refine(problem, w[max(k - 1, 0)], w[min(k + 1, w.size - 1)]))
    return out


def imaginary_axis_zeros(A, B, C) -> np.ndarray:
    """Frequencies w > 0 at which the Hermitian part of K(j w) = C (j w - A)^{-1} B is singular (an eigenvalue
    crosses or touches zero), for a real, stable, symmetric K with K(0) = 0 and no feedthrough (RAD.8).

    With D = 0 the Hamiltonian matrix of the positive-real lemma does not exist (it needs D + D^T
    invertible); the test uses the zeros of the para-Hermitian Phi(s) = K(s) + K^T(-s) instead, the
    extended Hamiltonian pencil.  K(0) = 0 and K symmetric make Phi(s) = s^2 Phi_2(s) with
    Phi_2(s) = K_2(s) + K_2^T(-s), K_2 = C (s - A)^{-1} A^{-2} B: dividing the double zero at s = 0 out leaves
    no cluster of zeros at the origin to mistake for crossings.  The zeros of Phi_2 are the finite
    generalised eigenvalues of [[A_P, B_P], [C_P, 0]] - z [[I, 0], [0, 0]] with A_P = diag(A, -A^T),
    B_P = [A^{-2} B; C^T], C_P = [C, -(A^{-2} B)^T]; Re K(j w) = -w^2 Phi_2(j w) / 2 changes sign only at
    imaginary ones.  A zero counts as imaginary if |Re z| <= 1e-7 |z| (measured: crossings of the example's
    unenforced fits at <= 1.5e-12, the nearest zeros of the enforced ones at >= 6e-4); zeros beyond 1e4 x the
    largest |pole| are left out (rounding leaves some of the pencil's infinite eigenvalues finite there; far
    above the poles Re K(j w) ~ -C A B / w^2, whose sign RadiationModel.asymptotic_margins checks)."""
    A, B, C = (np.asarray(x, float) for x in (A, B, C))
    n, d = B.shape
    B2 = np.linalg.solve(A, np.linalg.solve(A, B))
    M = np.zeros((2 * n + d, 2 * n + d))
    M[:n, :n], M[n:2 * n, n:2 * n] = A, -A.T
    M[:n, 2 * n:], M[n:2 * n, 2 * n:] = B2, C.T
    M[2 * n:, :n], M[2 * n:, n:2 * n] = C, -B2.T
    E = np.zeros_like(M)
    E[:2 * n, :2 * n] = np.eye(2 * n)
    alpha, beta = scipy.linalg.eigvals(M, E, homogeneous_eigvals=True)
    finite = np.abs(beta) > 1e-12 * np.abs(alpha)
    z = alpha[finite] / beta[finite]
    z = z[np.abs(z) < _CROSSING_RANGE * max(1.0, np.max(np.abs(np.linalg.eigvals(A))))]
    on_axis = (np.abs(z.real) <= _CROSSING_TOLERANCE * np.abs(z)) & (z.imag > 0)
    return np.sort(z[on_axis].imag)


@dataclass(frozen=True)
class PassivityReport:
    """What the passivity enforcement of :func:`fit_radiation` did: iterations and number of constraints of
    its last round, mu's minimum on the check grid (0 .. 1e4 rad/s and the limits, RAD.7) of the first,
    unenforced fit and of the result, per round {(i, j): (order, RAD.4 error before, after)} (a new round
    with a higher order for each pair the enforcement took above the tolerance, RAD.9), the crossing
    frequencies (RAD.8) of the first fit and of the result (none: passive at every frequency), delta."""

    iterations: int
    constraints: int
    mu_before: float
    mu_after: float
    rounds: tuple
    crossings_before: tuple
    crossings_after: tuple
    delta: float


def _enforce(problem, omega_max):
    """Iterate cuts and least-distance solves until mu >= 0 on the check grid (and at its refined local minima)
    and the pencil of RAD.8 has no imaginary zeros; (iterations, mu on the grid before, the final minimum,
    RAD.4 errors before, crossing frequencies before)."""
    grid = _check_grid(omega_max)
    grid_rows = problem.rows(grid)

    def grid_mu():
        return np.linalg.eigvalsh(problem.matrices(grid_rows))[:, 0]
    mu0 = grid_mu()
    errors0 = problem.errors()
    crossings0 = _model_crossings(problem)
    crossings = np.array([])
    worst = float(mu0.min())
    for it in range(_PASSIVITY_ITERATIONS + 1):
        mu = grid_mu()
        points = _local_minima(problem, grid, mu, problem.delta)
        worst = min([float(mu.min())] + [m for _, m in points])
        if worst >= 0:                       # clean on the grid: the pencil looks between its points
            crossings = crossings0 if it == 0 else _model_crossings(problem)
            if crossings.size == 0:
                return it, mu0, worst, errors0, crossings0
            points += [(w, m) for w, m in _band_minima(problem, crossings, grid[-2]) if m < problem.delta]
        if it == _PASSIVITY_ITERATIONS or sum(problem.add_cuts(w) for w, _ in points) == 0:
            break
        problem.solve()
    raise ConvergenceError(f"passivity enforcement: not passive after {it} iterations (min mu {worst:.3g}, "
                           f"{crossings.size} crossing frequencies)")


def _model_crossings(problem):
    A, B, C = _assemble(problem.pairs, problem.coefs(), problem.d)
    return imaginary_axis_zeros(A, B * problem.t[None, :], problem.t[:, None] * C)
