"""Rounding-error bounds and extended-precision references for the tests' tight comparisons.

The project's rule: a comparison tighter than 1e-10 states what bounds its error.  Either

* identity: the same operations in the same order on the same machine give the same bits (save/restore, two runs,
  a C caller of the same compiled kernel) -- asserted exactly, with the reason next to the assertion; or
* a bound, computed from the actual data: a multiple of the unit roundoff u = 2^-53 times the size of the
  compared quantity times an operation count (and a condition / growth factor where the error propagates); or
* an extended-precision reference (mpmath, 40 digits) in place of a second double-precision implementation that
  has its own error (scipy.linalg.expm).

The bounds are a priori (worst case over the order of the operations: any BLAS kernel, blocking, FMA or not),
so they hold on every machine; they are not tuned to what one machine printed.

References: N. J. Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed. (2002) [ASNA];
N. J. Higham, The scaling and squaring method for the matrix exponential revisited, SIMAX 26 (2005) [H05];
A. H. Al-Mohy, N. J. Higham, A new scaling and squaring algorithm for the matrix exponential, SIMAX 31 (2009)
[AMH09]; N. J. Higham, Functions of Matrices (2008) [FM].
"""
from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

import numpy as np

EPS = float(np.finfo(float).eps)        # 2^-52, the spacing of doubles at 1
U = EPS / 2                             # 2^-53, the unit roundoff: |fl(a op b) - a op b| <= U |a op b|


def gamma(n: float, u: float = U) -> float:
    """gamma_n = n u / (1 - n u) [ASNA 3.1]: the relative error bound of n successive roundings, e.g. of a sum or
    inner product of n terms in any order: |fl(sum x_i) - sum x_i| <= gamma_{n-1} sum |x_i|."""
    assert n * u < 0.5
    return n * u / (1.0 - n * u)


# ------------------------------------------------------------------------------------- matrix exponential
THETA13 = 4.25                          # AMH09 Alg. 5.1: ||2^-s A|| <= theta_13 for the degree-13 Pade
_B13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0, 129060195264000.0,
        10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0, 40840800.0, 960960.0, 16380.0, 182.0, 1.0)


def _ell13(A: np.ndarray) -> int:
    """AMH09 eq. (5.1), m = 13: the extra squarings that keep the backward error <= u for a non-normal A."""
    norm = np.abs(A).sum(axis=0).max()
    if norm == 0.0:
        return 0
    p = np.linalg.matrix_power(np.abs(A), 27)
    abs_c = math.factorial(13) ** 2 / (math.factorial(26) * math.factorial(27))   # |c_27| of the Pade error
    alpha = abs_c * p.sum(axis=0).max() / norm
    return max(0, math.ceil(math.log2(alpha / U) / 26)) if alpha > 0 else 0


def _squarings(W: np.ndarray) -> int:
    """An upper bound on the number s of squarings AMH09 Alg. 5.1 takes: eta <= ||W||_1 gives s <= s1, the
    1-norm choice [H05]; the ell correction is taken at both s1 and at the eta choice and the larger kept."""
    norm1 = np.abs(W).sum(axis=0).max()
    candidates = []
    d = [np.abs(np.linalg.matrix_power(W, k)).sum(axis=0).max() ** (1.0 / k) for k in (6, 8, 10)]
    eta = min(max(d[0], d[1]), max(d[1], d[2]))
    for x in (norm1, eta):
        s = max(0, math.ceil(math.log2(x / THETA13))) if x > THETA13 else 0
        candidates.append(s + _ell13(W / 2.0 ** s))
    return max(candidates)


def _growth(W: np.ndarray) -> float:
    """e^mu, mu = max(mu_2(W), 0) with mu_2 the logarithmic 2-norm (largest eigenvalue of (W + W^T)/2):
    ||e^{tW}||_2 <= e^{t mu} for 0 <= t <= 1 (the logarithmic-norm bound, Dahlquist 1958)."""
    return math.exp(max(float(np.linalg.eigvalsh(0.5 * (W + W.T)).max()), 0.0))


def expm_error_bound(W: np.ndarray) -> float:
    """An a-priori bound on ||fl(expm(W)) - e^W||_2 for a double-precision degree-13 Pade scaling-and-squaring
    expm (AMH09 Alg. 5.1: flexfmu's ffx_lti_expm and scipy.linalg.expm), first order in u, from W itself:

    * mu = max(mu_2(W), 0), mu_2 the logarithmic 2-norm (largest eigenvalue of (W + W^T)/2): ||e^{tW}||_2 <=
      e^{t mu} for 0 <= t <= 1 (the logarithmic-norm bound, Dahlquist 1958).  It is the growth that matters, not ||W||: for the balanced
      oscillator blocks of the exponential scheme mu <= 0.81 whatever omega dt.
    * truncation: r13(2^-s W)^(2^s) = e^{W + dW}, ||dW||_1 <= u ||W||_1 [AMH09]; with L(W, E) =
      int_0^1 e^{W(1-t)} E e^{Wt} dt, ||e^{W+dW} - e^W||_2 <= e^mu ||dW||_2 <= e^mu sqrt(n) u ||W||_1.
    * evaluation of r13(A), A = 2^-s W (exact scaling): U, V by products nested to depth 5 with inner sums of n
      and <= 8 additions: |p^ - p| <= gamma_{5n+8} p(|A|), the same for q [H05, ASNA 3.5]; the solve q r = p
      by LU with partial pivoting adds gamma_{3n} growth; relative 1-norm error of r <= kappa_1(q) (gamma_{5n+8}
      (||p(|A|)||_1/||p(A)||_1 + ||q(|A|)||_1/||q(A)||_1) + gamma_{3n}), kappa and the ratios computed here.
      In the 2-norm (factor n: ||E||_2 <= sqrt(n)||E||_1, ||X||_1 <= sqrt(n)||X||_2, ||X||_2 <= e^{mu/2^s}),
      propagated through s squarings (X -> X^(2^s): factor 2^s ||X||^(2^s - 1)): <= 2^s n r_rel e^mu.
    * squarings: the k-th adds <= gamma_n || |X||X| ||_2 <= n gamma_n ||X_k||_2^2, propagated through the
      remaining ones: total <= n gamma_n (2^s - 1) e^{2 mu} [ASNA 3.5 (powers), H05].
    """
    W = np.asarray(W, float)
    n = W.shape[0]
    growth = _growth(W)
    s = _squarings(W)
    A = W / 2.0 ** s
    absA = np.abs(A)
    I = np.eye(n)

    def pq(M):
        P = [I, M]
        for _ in range(12):
            P.append(P[-1] @ M)
        even = sum(_B13[k] * P[k] for k in range(0, 14, 2))
        odd = sum(_B13[k] * P[k] for k in range(1, 14, 2))
        return even + odd, even - odd                       # p13(M), q13(M)

    p, q = pq(A)
    p_abs, q_abs = pq(absA)
    n1 = lambda M: np.abs(M).sum(axis=0).max()              # noqa: E731
    kappa = float(np.linalg.cond(q, 1))
    r_rel = kappa * (gamma(5 * n + 8) * (n1(p_abs) / n1(p) + n1(q_abs) / n1(q)) + gamma(3 * n))
    truncation = growth * math.sqrt(n) * U * n1(W)
    evaluation = 2.0 ** s * n * r_rel * growth
    squaring = n * gamma(n) * (2.0 ** s - 1.0) * growth ** 2
    return truncation + evaluation + squaring


# ------------------------------------------------------------- matrix exponential of an unbalanced argument
#: AMH09 Table 3.1 / scipy.linalg.expm: the largest ||2^-s A|| for which the degree-m Pade approximant's backward
#: error is <= u
THETA = {3: 1.495585217958292e-2, 5: 2.539398330063230e-1, 7: 9.504178996162932e-1, 9: 2.097847961257068e0,
         13: 4.25}


def _pade(m: int) -> list[Fraction]:
    """The coefficients b_j of the degree-m Pade numerator p_m(x) = sum b_j x^j of e^x (q_m(x) = p_m(-x))."""
    f = math.factorial
    return [Fraction(f(2 * m - j) * f(m), f(2 * m) * f(j) * f(m - j)) for j in range(m + 1)]


@lru_cache(maxsize=None)
def _backward_series(m: int, terms: int = 160) -> tuple[float, ...]:
    """|c_k|, k = 0 .. terms - 1, of h_{2m+1}(x) = log(e^-x r_m(x)) = sum_{k >= 2m+1} c_k x^k [H05 (2.4), AMH09],
    r_m = p_m / q_m: the power series in exact rational arithmetic (e^-x r_m = 1 + ..., then log(1 + y) by
    l_k = s_k - (1/k) sum_{j<k} j l_j s_{k-j})."""
    b = _pade(m)
    p = b + [Fraction(0)] * (terms - len(b))
    q = [c * (-1) ** j for j, c in enumerate(b)] + [Fraction(0)] * (terms - len(b))
    r = [Fraction(0)] * terms                                   # r = p / q (q_0 = 1)
    for k in range(terms):
        r[k] = (p[k] - sum(q[j] * r[k - j] for j in range(1, min(k, m) + 1))) / q[0]
    e = [Fraction((-1) ** k, math.factorial(k)) for k in range(terms)]
    s = [sum(e[j] * r[k - j] for j in range(k + 1)) for k in range(terms)]
    log = [Fraction(0)] * terms
    for k in range(1, terms):
        log[k] = s[k] - sum(j * log[j] * s[k - j] for j in range(1, k)) / k
    return tuple(float(abs(c)) for c in log)


def ffx_squarings(W: np.ndarray) -> range:
    """The squarings ffx_lti_expm takes for W (flexfmu/native/csrc/lti_kernels.c, AMH09 Alg. 5.1 with degree 13):
    s = ceil(log2(eta / theta_13)), eta = min(max(d6, d8), max(d8, d10)), d_k = ||W^k||_1^(1/k), then + ceil(log2(
    || |2^-s W|^27 ||_1 / ||2^-s W||_1 / ell_13) / 26); replicated here (the same formulas: the products' rounding
    can move a ceiling only when its argument is within rounding of an integer, and then both counts are given)."""
    W = np.asarray(W, float)
    norm = float(np.abs(W).sum(axis=0).max())
    if norm == 0.0:
        return range(0, 1)
    n1 = lambda X: float(np.abs(X).sum(axis=0).max())       # noqa: E731

    def ceilings(x):                       # ceil(x); within 1e-9 of an integer k: both k and k + 1
        k = round(x)
        return {k, k + 1} if abs(x - k) < 1e-9 else {math.ceil(x)}

    W2 = W @ W
    W4 = W2 @ W2
    d6, d8, d10 = n1(W4 @ W2) ** (1 / 6), n1(W4 @ W4) ** (1 / 8), n1(W4 @ W4 @ W2) ** (1 / 10)
    eta = min(max(d6, d8), max(d8, d10))
    counts = set()
    for s in {max(c, 0) for c in ceilings(math.log2(eta / THETA[13]))}:
        absA = np.abs(W) * 2.0 ** -s
        v = absA.sum(axis=0)
        for _ in range(26):
            v = v @ absA
        ratio = float(v.max()) / (norm * 2.0 ** -s) / 1.2573361865339437e+19
        counts.update(s + max(e, 0) for e in (ceilings(math.log2(ratio) / 26) if ratio > 1.0 else {0}))
    return range(min(counts), max(counts) + 1)


def expm_error_bound_scaled(W: np.ndarray, d, growth: float, choices, lu_growth: float = 1.0) -> float:
    """A bound on ||D^-1 (fl(expm(W)) - e^W) D||_2, D = diag(d) with d powers of two, for a Pade scaling and squaring
    run on W itself (ffx_lti_expm, scipy.linalg.expm) when W is far from balanced and D^-1 W D is not, first order:

    * a power-of-two scaling commutes with the rounding of every product, sum and exact scaling by 2^-s: the computed
      fl(expm(W)) is D X' D^-1 with X' what the same algorithm computes from W' = D^-1 W D with W's choices (degree
      m, squarings s: ``choices``, the (m, s) pairs it may take on W; pivots of the solve: ``lu_growth``, the growth
      || |L'||U'| ||_1 / ||q'||_1 of W's LU in the scaled coordinates, 1 in expm_error_bound);
    * ``growth`` >= sup_{0 <= t <= 1} ||e^{t W'}||_2 (>= 1) in place of the logarithmic-norm bound e^mu: a product
      e^{t1 W'} e^{t2 W'} is then <= growth^2;
    * truncation: r_m(2^-s W')^(2^s) = e^{W' + dW'}, dW' = 2^s h_{2m+1}(2^-s W'), ||h(A)||_1 <= sum_{k>2m} |c_k|
      alpha_p(A)^k with alpha_p = max(d_p, d_{p+1}) for p (p - 1) <= 2m + 1 [AMH09 Thm 4.2] (d_k from the computed
      powers, raised by their rounding gamma_{(k-1) n} || |W'|^k ||_1): the series summed (_backward_series), in the
      2-norm sqrt(n); ||e^{W'+dW'} - e^{W'}||_2 <= growth^2 ||dW'||_2;
    * evaluation: as in expm_error_bound with p_m, q_m of A = 2^-s W' and the solve's gamma_{3n} times lu_growth;
      ||r||_2 <= growth, carried through s squarings: 2^s n r_rel growth^3;
    * squarings: each <= n gamma_n ||X_k||_2^2 <= n gamma_n growth^2, carried by the remaining ones (2^(s-k) products
      of two powers e^{t W'}): n gamma_n (2^s - 1) growth^4."""
    W = np.asarray(W, float)
    d = np.asarray(d, float)
    Wp = W / d[:, None] * d[None, :]
    n = W.shape[0]
    n1 = lambda X: float(np.abs(X).sum(axis=0).max())       # noqa: E731
    absW = np.abs(Wp)
    powers, abs_powers = [np.eye(n)], [np.eye(n)]
    for k in range(1, 8):
        powers.append(powers[-1] @ Wp)
        abs_powers.append(abs_powers[-1] @ absW)
    dk = [0.0] + [(n1(powers[k]) + gamma(max(k - 1, 1) * n) * n1(abs_powers[k])) ** (1.0 / k) for k in range(1, 8)]
    I = np.eye(n)
    worst = 0.0
    for m, s in choices:
        ell = 2 * m + 1
        alpha = min(max(dk[p], dk[p + 1]) for p in range(1, 7) if p * (p - 1) <= ell)
        x = alpha / 2.0 ** s
        c = _backward_series(m)
        terms = [c[k] * x ** k for k in range(ell, len(c))]
        # the terms beyond: the last 20 decay by r per term (r^10 = the ratio of the last two windows' largest):
        # <= last r / (1 - r)
        last, before = max(terms[-10:]), max(terms[-20:-10])
        r = (last / before) ** 0.1 if before > 0.0 else 0.0
        if not r < 0.9:
            raise ValueError(f"the backward-error series at degree {m}, ||2^-s W'|| ~ {x:.3g} does not converge "
                             "within its terms: no bound")
        truncation = growth ** 2 * math.sqrt(n) * 2.0 ** s * (sum(terms) + last * r / (1 - r))
        A = Wp / 2.0 ** s
        b = [float(v) for v in _pade(m)]

        def pq(M):
            P, acc_p, acc_q = I, b[0] * I, b[0] * I
            for j in range(1, m + 1):
                P = P @ M
                acc_p = acc_p + b[j] * P
                acc_q = acc_q + (-1) ** j * b[j] * P
            return acc_p, acc_q

        p, q = pq(A)
        p_abs, q_abs = pq(np.abs(A))
        kappa = float(np.linalg.cond(q, 1))
        r_rel = kappa * (gamma(5 * n + 8) * (n1(p_abs) / n1(p) + n1(q_abs) / n1(q)) + gamma(3 * n) * lu_growth)
        evaluation = 2.0 ** s * n * r_rel * growth ** 3
        squaring = n * gamma(n) * (2.0 ** s - 1.0) * growth ** 4
        worst = max(worst, truncation + evaluation + squaring)
    return worst


def lu_growth_scaled(W: np.ndarray, d, m: int, s: int) -> float:
    """|| |L'||U'| ||_1 / ||q'^T||_1 for the LU with partial pivoting that a Pade scaling and squaring run on W takes of
    q_m(2^-s W)^T (ffx_lti_expm and scipy.linalg.expm solve R (V - U) = V + U through (V - U)^T), seen in the scaled
    coordinates of D = diag(d): q'^T = D q^T D^-1 = P (D_p L D_p^-1) (D_p U D^-1), D_p = P^T D P.  The pivots are
    those of scipy.linalg.lu on q as computed here (the kernels' q to rounding: a near tie may pick the other row)."""
    import scipy.linalg
    W = np.asarray(W, float)
    d = np.asarray(d, float)
    n = W.shape[0]
    A = W / 2.0 ** s
    b = [float(v) for v in _pade(m)]
    P, q = np.eye(n), b[0] * np.eye(n)
    for j in range(1, m + 1):
        P = P @ A
        q = q + (-1) ** j * b[j] * P
    perm, L, U = scipy.linalg.lu(q.T)
    dp = perm.T @ d
    Ls, Us = L * dp[:, None] / dp[None, :], U * dp[:, None] / d[None, :]
    qs = (q.T * d[:, None]) / d[None, :]
    return float(np.abs(np.abs(Ls) @ np.abs(Us)).sum(axis=0).max() / np.abs(qs).sum(axis=0).max())


def taylor_reference_error_bound(M: np.ndarray, u: float, degree: int = 40, radius: float = 0.25) -> float:
    """A bound on ||X^ - e^M||_2 for a reference e^M computed in a precision of unit roundoff u by the Taylor
    polynomial of the given degree of A = M / 2^s (||A||_1 <= radius) squared s times:
    truncation sum_{k>degree} radius^k / k! (relative to ||e^A||_1 >= e^-radius); terms T_k = T_{k-1} A / k:
    |T^_k - T_k| <= gamma_{k(n+1)} |A|^k / k!, summed with the additions: relative <= gamma_{(degree+1)(n+2)}
    e^{2 radius} (1-norm); then as in expm_error_bound: 2^s n rel e^mu + n gamma_n (2^s - 1) e^{2 mu}."""
    M = np.asarray(M, float)
    n = M.shape[0]
    norm = float(np.abs(M).sum(axis=0).max())
    s = max(0, math.ceil(math.log2(norm / radius))) if norm > 0 else 0
    growth = _growth(M)
    tail = radius ** (degree + 1) / math.factorial(degree + 1) * 2 * math.exp(radius)
    r_rel = gamma((degree + 1) * (n + 2), u) * math.exp(2 * radius) + tail
    return 2.0 ** s * n * r_rel * growth + n * gamma(n, u) * (2.0 ** s - 1.0) * growth ** 2


def mp_expm(W: np.ndarray, dps: int = 40):
    """e^W of the double matrix W (taken exactly) in mpmath at ``dps`` digits: an mpmath matrix.  At 40 digits its
    own error (~1e-38 relative for the moderate norms here) is below 1e-20 of any double-precision bound."""
    import mpmath
    with mpmath.workdps(dps):
        return mpmath.expm(mpmath.matrix([[mpmath.mpf(float(x)) for x in row] for row in np.asarray(W, float)]))


# ------------------------------------------------------------------------------------- general bounds
def implementations_bound(scale: float, ops: int, growth: float = 1.0, n_steps: int = 1) -> float:
    """Bound on |a - b| for two double-precision evaluations a, b of the same exact quantity by different
    operation orders (C vs numpy, native vs Python FMU, any BLAS kernel): each is within gamma_ops * scale of the
    exact value per step (``ops`` the longest chain of roundings feeding one result, e.g. an inner-product length
    plus the terms added to it; ``scale`` the size of the terms, sum |x_i| or ||A|| ||x||), and a step's error is
    carried into later steps amplified by at most ``growth`` (a bound on ||Ad||, or 1 for a contraction) over
    ``n_steps`` steps: 2 gamma_ops scale * sum_k growth^k [ASNA 3.1, 3.5]."""
    carried = float(n_steps) if growth == 1.0 else (growth ** n_steps - 1.0) / (growth - 1.0)
    return 2.0 * gamma(ops) * scale * carried


def matvec_bound(A, x) -> np.ndarray:
    """Componentwise bound on |fl(A x) - A x| for any summation order: gamma_n |A| |x| [ASNA 3.5]."""
    A, x = np.asarray(A, float), np.asarray(x, float)
    return gamma(A.shape[-1]) * (np.abs(A) @ np.abs(x))
