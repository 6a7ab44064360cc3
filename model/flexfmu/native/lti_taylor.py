"""The moving-base step of a clamped body: the exact zero-order hold by the Taylor series of the step's exponential
applied to the step's own vector, for base motion that changes at every step (csrc/lti_kernels.c does the same in C,
ffx_lti_taylor_prepare / ffx_lti_taylor_steps; this module is its numpy form and holds the rule both follow).

With the inputs held, x' = A x + g (A = A(p), g = B(p) u + b(p), p the held base motion), so over a step h

    x+ = e^{hA} x + h phi_1(hA) g = x + sum_{k>=1} w_k,   w_1 = h (A x + g),   w_k = (h / k) A w_{k-1}

(the top rows of expm([[hA, h g], [0, 0]]) [x; 1]: X^k z = [(hA)^(k-1) w_1; 0]).  No matrix exponential and no maps:
K products A w, i.e. K nx^2 multiplications, where a new exponential costs ~10 (nx + nu + 1)^3.

Truncation.  In the weighted max norm ||y||_D = max_i |y_i| / d_i (any d > 0) with theta = ||D^-1 hA D||_inf,
||w_k||_D <= theta^(k-1) / k! ||w_1||_D, so the terms after the K-th sum to at most

    ||x+ - x_K||_D <= tail(theta, K) ||w_1||_D,   tail(theta, K) = sum_{k>K} theta^(k-1) / k!
                                                  <= theta^K / (K+1)! / (1 - theta / (K+2))   (theta < K + 2).

K is the least with tail <= u = 2^-53: the truncation is below the rounding of w_1 itself, i.e. the step is the
exact zero-order hold to rounding, like the exponential it replaces.  d balances A's constant part (``balance``:
for a mode ([[0, 1], [-w^2, -c]]) d_rate / d_disp = w, so theta ~ h w_max instead of h w_max^2).  The terms reach
theta^(k-1)/k! ||w_1|| before they fall, so rounding grows like (e^theta - 1)/theta: a step with theta above
THETA_SUBSTEP is taken as s = ceil(theta / THETA_SUBSTEP) equal sub-steps (each exact the same way).

The rule (here and in C), with p_before the base motion the step before held (at initialisation: held then):

* p = p_before (a fixed base): the maps, cached per (p, h), as before: one exponential for all the steps;
* a jump: the maps too.  A held value that jumps (inputs constant by segments) usually stays, and its one
  exponential then serves the steps that follow.  Jump or motion is told by the rate of change of A relative to
  the structure's own time scale 1 / ||A_0||, A(p) = sum_k mono_k(p) A_k:

      rate = sum_k |mono_k(p) - mono_k(p_before)| ||D^-1 A_k D||_inf / (h ||D^-1 A_0 D||_inf^2)  >  RATE_MAX

  (the sum bounds ||D^-1 (A(p) - A(p_before)) D||_inf): a signal sampled at the step changes A by h dA/dt, whatever
  h, while a jump's rate grows as h shrinks.  The wave converter's harvester (examples/wave_converter) at 1 ms:
  rate <= 1.4e-6 over a 4 s record (every step of a 20 s run by the series: benchmarks/moving_base_step.py);
  FFRBeam's base_w_z jumping by 0.3 rad/s: 2.6e-4 at 1 ms, 2.6e-3 at 0.1 ms;
* base motion that moves (rate <= RATE_MAX: a continuous signal sampled at the step, as a floating platform's
  rotation): the series, when it costs less than a new exponential, n s (K nx^2 + nx) < EXPM_COST_FACTOR
  (nx + nu + 1)^3 (n equal internal steps), else the maps (a step or base motion so large that the exponential's
  scaling and squaring is the cheaper exact method).

Every branch is the exact zero-order hold; they differ in rounding only (their last bits), and in cost.
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.native.lti_quadratic import fit_quadratic, monomial_pairs, sample_points

#: the unit roundoff: the truncation bound of the series is at most this times ||w_1||_D
UNIT_ROUNDOFF = 2.0 ** -53
#: the largest ||D^-1 hA D||_inf of one Taylor sub-step (rounding grows like (e^theta - 1) / theta: 4.5 here)
THETA_SUBSTEP = 2.5
#: a series longer than this is refused (theta <= THETA_SUBSTEP needs at most 29 terms)
MAX_TERMS = 60
#: a new exponential of the augmented matrix (n = nx + nu + 1) costs about this many n^3 multiply-adds (degree-13
#: Pade: ~6 products, the LU solve, the squarings); the series is used when it costs less
EXPM_COST_FACTOR = 10.0
#: Osborne sweeps of ``balance`` (each one pass over A's entries; the oscillator blocks settle in one)
BALANCE_SWEEPS = 20
#: a change of the held base motion faster than this (rate, module docstring) is a jump: new maps, not the series
RATE_MAX = 2.0 ** -14


def balance(A) -> np.ndarray:
    """Positive weights d (n,) that balance A: each i's off-diagonal row and column sums of |D^-1 A D| made equal
    (Osborne's iteration, d_i <- sqrt(r_i / c_i) with r_i = sum_{j != i} |a_ij| d_j, c_i = sum_{j != i} |a_ji| /
    d_j), BALANCE_SWEEPS sweeps in index order; an i with a zero row or column keeps its weight.  The same
    arithmetic as csrc/lti_kernels.c's balance()."""
    A = np.abs(np.asarray(A, dtype=float))
    n = A.shape[0]
    d = np.ones(n)
    for _ in range(BALANCE_SWEEPS):
        for i in range(n):
            r = c = 0.0
            for j in range(n):
                if j != i:
                    r += A[i, j] * d[j]
                    c += A[j, i] / d[j]
            if r > 0.0 and c > 0.0 and math.isfinite(r) and math.isfinite(c):
                d[i] = math.sqrt(r / c)
    return d


def scaled_norm(A, d) -> float:
    """||D^-1 A D||_inf = max_i sum_j |a_ij| d_j / d_i (0 for an empty A)."""
    if A.size == 0:
        return 0.0
    return float(((np.abs(A) @ d) / d).max())


def tail_bound(theta: float, terms: int) -> float:
    """An upper bound on sum_{k > terms} theta^(k-1) / k!: theta^K / (K+1)! / (1 - theta / (K+2)), inf where the
    geometric bound does not apply (theta >= K + 2)."""
    K = int(terms)
    if not theta < K + 2:
        return math.inf
    first = 1.0
    for k in range(1, K + 1):                  # theta^K / (K+1)!, built term by term (no overflow)
        first *= theta / (k + 1)
    return first / (1.0 - theta / (K + 2))


def _least_terms(t: float) -> int | None:
    """The least K <= MAX_TERMS with tail_bound(t, K) <= UNIT_ROUNDOFF (the loop csrc/lti_kernels.c runs), or None."""
    first = 1.0                                 # t^K / (K+1)! for K = 1, 2, ... (tail_bound's loop, kept)
    for K in range(1, MAX_TERMS + 1):
        first *= t / (K + 1)
        if t < K + 2 and first / (1.0 - t / (K + 2)) <= UNIT_ROUNDOFF:
            return K
    return None


def _thresholds() -> np.ndarray:
    """theta_K, K = 1 .. K(THETA_SUBSTEP): the largest t for which _least_terms(t) <= K (bisection to the last
    bit: the tail is increasing in t), so that taylor_plan looks K up instead of running the loop per step."""
    out = []
    for K in range(1, _least_terms(THETA_SUBSTEP) + 1):
        lo, hi = 0.0, THETA_SUBSTEP
        if _least_terms(hi) <= K:
            out.append(hi)
            break
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if mid in (lo, hi):
                break
            lo, hi = (mid, hi) if _least_terms(mid) <= K else (lo, mid)
        out.append(lo)
    return np.array(out)


_THETA_K = _thresholds()


def taylor_plan(theta: float) -> tuple[int, int] | None:
    """(sub-steps s, terms K) for a step with ||D^-1 hA D||_inf = theta: s = max(1, ceil(theta / THETA_SUBSTEP)),
    K the least with tail_bound(theta / s, K) <= UNIT_ROUNDOFF; None for theta not finite or negative."""
    if not (math.isfinite(theta) and theta >= 0.0):
        return None
    s = max(1, math.ceil(theta / THETA_SUBSTEP))
    t = theta / s
    K = int(np.searchsorted(_THETA_K, t)) + 1          # the first K whose threshold is >= t
    return s, K


def taylor_cost(nx: int, substeps: int, terms: int, n_steps: int = 1) -> float:
    """Multiply-adds of n_steps steps by the series: per sub-step K products A w (nx^2) and g (nx)."""
    return float(n_steps) * substeps * (terms * nx * nx + nx)


def expm_cost(nx: int, nu: int) -> float:
    """Multiply-adds of one new exponential of the augmented (nx + nu + 1) matrix (EXPM_COST_FACTOR n^3)."""
    n = nx + nu + 1
    return EXPM_COST_FACTOR * n * n * n


def change_rate(mono, mono_before, norms, h: float) -> float:
    """rate = sum_k |mono_k - mono_before_k| norms_k / (h norms_0^2) (norms_k = ||D^-1 A_k D||_inf, k = 0 the
    constant coefficient): how fast A changes against the structure's own time scale (module docstring)."""
    change = float(np.abs(np.asarray(mono) - np.asarray(mono_before)) @ norms)
    return change / (h * norms[0] * norms[0]) if change > 0.0 else 0.0


def choose(A, h: float, d, nu: int, n_steps: int = 1) -> tuple[int, int] | None:
    """The plan (s, K) for n_steps steps h with A (an (nx, nx) array) held, or None: the maps (a new exponential)
    are cheaper or the series does not apply.  theta = h ||D^-1 A D||_inf."""
    nx = A.shape[0]
    if nx == 0:
        return 1, 1
    plan = taylor_plan(h * scaled_norm(A, d))
    if plan is None or taylor_cost(nx, plan[0], plan[1], n_steps) >= expm_cost(nx, nu):
        return None
    return plan


_SERIES_PLANS: dict = {}


def _series_plan(terms: int):
    """(q, the coefficients 1/(j+1)! as (blocks, q)) of series_matrix for ``terms``."""
    plan = _SERIES_PLANS.get(terms)
    if plan is None:
        q = max(1, math.ceil(math.sqrt(terms)))
        blocks = -(-terms // q)
        c = np.zeros(blocks * q)
        c[:terms] = [1.0 / math.factorial(j + 1) for j in range(terms)]
        plan = _SERIES_PLANS[terms] = (q, c.reshape(blocks, q))
    return plan


def series_matrix(Y, terms: int) -> np.ndarray:
    """P(Y) = sum_{j < terms} Y^j / (j+1)! (n, n) by Paterson-Stockmeyer (q = ceil(sqrt(terms)) powers, Horner in
    Y^q): about 2 sqrt(terms) products, so a numpy step costs a few calls instead of one per term."""
    n = Y.shape[0]
    q, coef = _series_plan(terms)
    powers = np.empty((q + 1, n, n))
    powers[0] = np.eye(n)
    powers[1] = Y
    for i in range(2, q + 1):
        np.matmul(powers[i - 1], Y, out=powers[i])
    B = (coef @ powers[:q].reshape(q, n * n)).reshape(-1, n, n)
    P = B[-1]
    for b in range(B.shape[0] - 2, -1, -1):
        P = B[b] + P @ powers[q]
    return P


def taylor_steps(A, g, x, h: float, plan, n_steps: int = 1) -> np.ndarray:
    """x after n_steps exact steps h of x' = A x + g by the series with plan (s, K) (module docstring): each
    sub-step x + P(hs A) w_1, w_1 = hs (A x + g), P = series_matrix (the terms' sum as one matrix; csrc/lti_kernels.c
    sums the vectors w_k instead: the same series, other rounding)."""
    s, K = plan
    hs = h / s
    A = np.asarray(A, dtype=float)
    P = series_matrix(hs * A, K)
    x = np.array(x, dtype=float)
    for _ in range(n_steps * s):
        x = x + P @ (hs * (A @ x + g))
    return x


def truncation_bound(A, g, x, h: float, plan, d) -> float:
    """The bound on ||x+ - (what the series gives)||_D of one sub-step from x: tail(theta / s, K) ||w_1||_D, for
    the tests (rounding not included)."""
    s, K = plan
    hs = h / s
    w1 = hs * (np.asarray(A) @ x + g)
    return tail_bound(hs * scaled_norm(A, d), K) * float(np.max(np.abs(w1) / d))


# ---------------------------------------------------------------------------------------------- held polynomials
class HeldPolynomial:
    """Arrays that are polynomials of degree <= 2 in the held parameters p (np), as sum_k mono_k(p) C_k (monomials
    of flexfmu.native.lti_quadratic), evaluated by one product over the monomials whose coefficients are not zero.

    ``from_samples(f, n_p, constant)``: f(p) at the sample points 0, +-e_i, e_i + e_j (fit_quadratic with offsets
    +-1: exact for a quadratic up to rounding), ``constant`` the exact value at p = 0 (kept as C_0).  Call it on a
    copy of the model whose p-independent part holds no large terms (stiffness and damping set to zero), so that
    the differences that make C_k lose nothing to them; coefficients within 64 eps of the sizes they are
    differenced from are rounding and set to zero (as the quadratic output terms of flexfmu.native.lti)."""

    def __init__(self, coefficients: np.ndarray, n_p: int):
        self.n_p = int(n_p)
        coefficients = np.asarray(coefficients, dtype=float)
        self.shape = coefficients.shape[1:]
        flat = coefficients.reshape(coefficients.shape[0], -1)
        used = [k for k in range(flat.shape[0]) if k == 0 or np.any(flat[k] != 0.0)]
        self.used = np.array(used, dtype=np.intp)
        self._coefficients = np.ascontiguousarray(flat[self.used])
        pairs = monomial_pairs(self.n_p)
        self._i = np.array([i for i, _ in pairs], dtype=np.intp)
        self._j = np.array([j for _, j in pairs], dtype=np.intp)

    @classmethod
    def from_samples(cls, f, n_p: int, constant) -> "HeldPolynomial":
        offsets = [(1.0, -1.0)] * n_p
        points = sample_points(offsets)
        values = np.array([np.asarray(f(p), dtype=float) for p in points])
        coefficients = fit_quadratic(values, offsets)
        scale = np.abs(values).sum(axis=0)            # bounds the size of every value a coefficient differences
        noise = np.abs(coefficients) <= 64.0 * np.finfo(float).eps * scale
        coefficients[1:][noise[1:]] = 0.0
        coefficients[0] = np.asarray(constant, dtype=float)
        return cls(coefficients, n_p)

    def monomials(self, p) -> np.ndarray:
        """mono(p) at the monomials in use."""
        p = np.asarray(p, dtype=float)
        full = np.concatenate(([1.0], p, p[self._i] * p[self._j]))
        return full[self.used]

    def coefficient(self, j: int) -> np.ndarray:
        """The coefficient of the j-th monomial in use (monomial index used[j]), in the arrays' shape."""
        return self._coefficients[j].reshape(self.shape)

    def evaluate(self, mono) -> np.ndarray:
        """The arrays, flat, for the monomials in use ``mono`` (``monomials(p)``)."""
        return mono @ self._coefficients

    def __call__(self, p) -> np.ndarray:
        return self.evaluate(self.monomials(p)).reshape(self.shape)


class HeldSystem:
    """A clamped body's modal system x' = A(p) x + g, x = [eta; eta_dot] (nx = 2m), g = [0; F loads + f(p)], with
    ``step`` the polynomial of [A (nx, nx) flat, f (m)] in the held base motion p, ``force_map`` F (m, nu) and the
    rule of the module docstring: ``prepare`` gives what a step by the series needs, or None for the maps."""

    def __init__(self, step: HeldPolynomial, force_map):
        self.step = step
        self.force_map = np.asarray(force_map, dtype=float)
        self.m, self.nu = self.force_map.shape
        nx = self.nx = 2 * self.m
        #: the norm's weights: A's balance at p = 0 (its constant coefficient)
        self.weights = balance(step.coefficient(0)[:nx * nx].reshape(nx, nx))
        #: ||D^-1 A_k D||_inf per monomial in use: the change delta's weights
        self.norms = np.array([scaled_norm(step.coefficient(j)[:nx * nx].reshape(nx, nx), self.weights)
                               for j in range(step.used.size)])
        self._last = (None, None)        # (p, its monomials) of the last prepare

    def prepare(self, p, p_before, h: float, loads, n_steps: int = 1):
        """(A, g, plan) for n_steps steps h by the series with p held after p_before, or None: the maps (p equals
        p_before, a jump, or a new exponential is cheaper)."""
        mono = self.step.monomials(p)
        before = self._last[1] if np.array_equal(self._last[0], p_before) else self.step.monomials(p_before)
        self._last = (np.array(p, dtype=float), mono)     # the next step's p_before, usually
        rate = change_rate(mono, before, self.norms, h)
        if not 0.0 < rate <= RATE_MAX:
            return None
        nx = self.nx
        v = self.step.evaluate(mono)
        A = v[:nx * nx].reshape(nx, nx)
        plan = choose(A, h, self.weights, self.nu, n_steps)
        if plan is None:
            return None
        g = np.zeros(nx)
        g[self.m:] = self.force_map @ loads + v[nx * nx:]
        return A, g, plan
