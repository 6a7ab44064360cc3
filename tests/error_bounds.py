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
