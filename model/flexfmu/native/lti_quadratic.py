"""Polynomials of degree <= 2 in the held parameters p of flexfmu.native.lti: the monomials mono(p) in the order of
csrc/lti_kernels.h, and the exact fit of a quadratic from its values at 1 + 2 np + np (np - 1) / 2 sample points
(what flexfmu.native.lti's extraction evaluates the library's maps at)."""
from __future__ import annotations

import numpy as np

__all__ = ["n_monomials", "monomial_pairs", "monomials", "monomial_names", "sample_points", "fit_quadratic"]


# ---------------------------------------------------------------------------------------------- monomials
def n_monomials(n_p: int) -> int:
    return 1 + n_p + n_p * (n_p + 1) // 2


def monomial_pairs(n_p: int) -> list[tuple[int, int]]:
    """(i, j), i <= j, of the degree-2 monomials in their order (after 1 and p_0 .. p_{np-1})."""
    return [(i, j) for i in range(n_p) for j in range(i, n_p)]


def monomials(p) -> np.ndarray:
    """mono(p) in the order of lti_kernels.h."""
    p = np.asarray(p, dtype=float)
    n = p.size
    return np.concatenate([[1.0], p, [p[i] * p[j] for i, j in monomial_pairs(n)]])


def monomial_names(names) -> tuple[str, ...]:
    return ("1", *names, *(f"{names[i]}*{names[j]}" for i, j in monomial_pairs(len(names))))



# ---------------------------------------------------------------------------------------------- the fit
def sample_points(offsets):
    """The sample points of p: 0, a_i e_i, b_i e_i, a_i e_i + a_j e_j (i < j)."""
    n = len(offsets)
    pts = [np.zeros(n)]
    for i, (a, b) in enumerate(offsets):
        for s in (a, b):
            q = np.zeros(n)
            q[i] = s
            pts.append(q)
    for i in range(n):
        for j in range(i + 1, n):
            q = np.zeros(n)
            q[i], q[j] = offsets[i][0], offsets[j][0]
            pts.append(q)
    return pts


def fit_quadratic(values, offsets) -> np.ndarray:
    """Coefficients (nmono, ...) of the quadratic that takes ``values`` (in the order of sample_points) at the sample
    points: along each axis from f(0), f(a), f(b) (the 2x2 system solved in closed form); the mixed ones from
    f(a_i e_i + a_j e_j) - f(a_i e_i) - f(a_j e_j) + f(0) = c_ij a_i a_j."""
    n = len(offsets)
    f0 = values[0]
    lin, sq = [], []
    fa = {}
    for i, (a, b) in enumerate(offsets):
        va, vb = values[1 + 2 * i] - f0, values[2 + 2 * i] - f0
        fa[i] = values[1 + 2 * i]
        # c a + d a^2 = va, c b + d b^2 = vb
        d = (vb * a - va * b) / (a * b * (b - a))
        c = (va * b * b - vb * a * a) / (a * b * (b - a))
        lin.append(c)
        sq.append(d)
    mixed = {}
    k = 1 + 2 * n
    for i in range(n):
        for j in range(i + 1, n):
            mixed[i, j] = (values[k] - fa[i] - fa[j] + f0) / (offsets[i][0] * offsets[j][0])
            k += 1
    out = [f0, *lin]
    for i, j in monomial_pairs(n):
        out.append(sq[i] if i == j else mixed[i, j])
    return np.array(out)
