"""Vector fitting of one radiation response K_ij(j w) (RAD.3, RAD.4 of flexfmu.wec.radiation: Gustavsen & Semlyen
1999, the poles relocated by iterated linear least squares, right-half-plane poles mirrored, the residues fitted
with K(0) = 0) and the block-diagonal state-space realisation of the pair fits."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from flexfmu.errors import ConvergenceError, require

DEFAULT_TOLERANCE = 0.02
DEFAULT_MAX_ORDER = 12
_VF_ITERATIONS = 30


# ------------------------------------------------------------------ vector fitting of one SISO response
@dataclass(frozen=True)
class PairFit:
    """The fit of K_ij: order, relative error (RAD.4), poles and residues (complex, conjugate pairs
    together; rad/s and K-units rad/s)."""

    i: int
    j: int
    order: int
    error: float
    poles: np.ndarray
    residues: np.ndarray
    errors_by_order: dict = field(default_factory=dict)
    unenforced_error: float | None = None        # RAD.4 of the vector fit before passivity enforcement

    def transfer(self, s) -> np.ndarray:
        s = np.asarray(s, complex)
        return np.sum(self.residues[None, :] / (s[:, None] - self.poles[None, :]), axis=1)


def _initial_poles(n, w_lo, w_hi):
    """Gustavsen's start: weakly damped complex pairs spread over the band (a real pole if n is odd)."""
    poles = []
    n_pairs = n // 2
    for b in np.linspace(w_lo, w_hi, n_pairs) if n_pairs else []:
        poles += [complex(-b / 100, b), complex(-b / 100, -b)]
    if n % 2:
        poles.append(complex(-0.5 * (w_lo + w_hi), 0.0))
    return np.array(poles)


def _basis(s, poles):
    """Real basis of the partial fractions: a real pole 1/(s-a); a pair (a, a*) -> 1/(s-a) + 1/(s-a*),
    j/(s-a) - j/(s-a*).  Returns (n_s, n) complex and, per column, how a coefficient maps to residues."""
    cols = []
    k = 0
    while k < len(poles):
        a = poles[k]
        if abs(a.imag) < 1e-12 * max(1.0, abs(a)):
            cols.append(1 / (s - a.real))
            k += 1
        else:
            cols.append(1 / (s - a) + 1 / (s - np.conj(a)))
            cols.append(1j / (s - a) - 1j / (s - np.conj(a)))
            k += 2
    return np.column_stack(cols)


def _coeffs_to_residues(coef, poles):
    res = np.empty(len(poles), complex)
    k = 0
    while k < len(poles):
        a = poles[k]
        if abs(a.imag) < 1e-12 * max(1.0, abs(a)):
            res[k] = coef[k]
            k += 1
        else:
            r = coef[k] + 1j * coef[k + 1]
            res[k], res[k + 1] = r, np.conj(r)
            k += 2
    return res


def _sorted_pairs(p):
    """Poles with conjugate pairs adjacent (positive imaginary part first), right-half-plane poles mirrored."""
    p = np.where(p.real > 0, -p.real + 1j * p.imag, p)
    real = np.sort(p[np.abs(p.imag) < 1e-12 * np.maximum(1.0, np.abs(p))].real)
    cplx = p[p.imag >= 1e-12 * np.maximum(1.0, np.abs(p))]
    out = []
    for a in sorted(cplx, key=lambda z: z.imag):
        out += [a, np.conj(a)]
    return np.array(list(real.astype(complex)) + out)


def _stack(M, rhs):
    return np.vstack([M.real, M.imag]), np.concatenate([rhs.real, rhs.imag])


def _fit_order(omega, K, n, scale):
    """Vector fitting of K(j w) (normalised by scale) with n poles: (poles, residues, relative error)."""
    s = 1j * omega
    Kn = K / scale
    poles = _initial_poles(n, omega[0] if omega[0] > 0 else omega[1], omega[-1])
    for _ in range(_VF_ITERATIONS):
        Phi = _basis(s, poles)
        M = np.hstack([Phi, -Kn[:, None] * Phi])                    # sigma K ~ sum c phi; sigma = 1 + sum d phi
        A_ls, b_ls = _stack(M, Kn)
        sol, *_ = np.linalg.lstsq(A_ls, b_ls, rcond=None)
        d = sol[Phi.shape[1]:]
        # zeros of sigma: eig(Lambda - b d^T) in the real block form
        Lam, bvec = _real_form(poles)
        new = np.linalg.eigvals(Lam - np.outer(bvec, d))
        new = _sorted_pairs(new)
        if len(new) != n or np.allclose(np.sort_complex(new), np.sort_complex(poles), rtol=1e-10, atol=1e-12):
            poles = new if len(new) == n else poles
            break
        poles = new
    # residues with K(0) = sum_m -r_m / p_m = 0: the basis columns' values at s = 0 form the constraint row
    Phi = _basis(s, poles)
    A_ls, b_ls = _stack(Phi, Kn)
    row = _basis(np.array([0.0 + 0.0j]), poles).real[0]
    N = scipy.linalg.null_space(row[None, :])
    y, *_ = np.linalg.lstsq(A_ls @ N, b_ls, rcond=None)
    coef = N @ y
    res = _coeffs_to_residues(coef, poles) * scale
    fit = np.sum(res[None, :] / (s[:, None] - poles[None, :]), axis=1)
    return poles, res, fit


def _real_form(poles):
    """Real block-diagonal Lambda and input vector b whose partial fractions are the real basis of _basis."""
    n = len(poles)
    Lam = np.zeros((n, n))
    b = np.zeros(n)
    k = 0
    while k < n:
        a = poles[k]
        if abs(a.imag) < 1e-12 * max(1.0, abs(a)):
            Lam[k, k] = a.real
            b[k] = 1.0
            k += 1
        else:
            Lam[k:k + 2, k:k + 2] = [[a.real, a.imag], [-a.imag, a.real]]
            b[k:k + 2] = [2.0, 0.0]
            k += 2
    return Lam, b


def fit_pair(omega, K, i=0, j=0, reference_norm=None, tolerance=DEFAULT_TOLERANCE,
             max_order=DEFAULT_MAX_ORDER, min_order: int = 2) -> PairFit:
    """Fit one K_ij(j w) (complex, (n,)) by RAD.3, the lowest order min_order .. max_order meeting the
    tolerance (RAD.4); ConvergenceError if none does."""
    omega = np.asarray(omega, float)
    K = np.asarray(K, complex)
    require(tolerance > 0, "tolerance", f"got {tolerance!r}", "> 0")
    require(isinstance(max_order, (int, np.integer)) and 2 <= max_order <= 40, "max_order", f"got {max_order!r}",
            "2 .. 40")
    ref = float(np.linalg.norm(K)) if reference_norm is None else float(reference_norm)
    scale = float(np.max(np.abs(K))) or 1.0
    errors = {}
    best = None
    for n in range(max(2, int(min_order)), max_order + 1):
        poles, res, fit = _fit_order(omega, K, n, scale)
        err = float(np.linalg.norm(fit - K) / ref)
        errors[n] = err
        if best is None or err < best[2]:
            best = (poles, res, err, n)
        if err <= tolerance:
            return PairFit(i, j, n, err, poles, res, errors)
    if best is None:
        raise ConvergenceError(f"K_{i}{j}: no order from {min_order} up to {max_order}; raise max_order")
    raise ConvergenceError(f"K_{i}{j}: no order up to {max_order} fits within {tolerance:g} (best {best[2]:.3g} at "
                           f"order {best[3]}); raise tolerance or max_order")


# ------------------------------------------------------------------ the realisation
def _assemble(pairs, coefs, d):
    """The block-diagonal realisation (A_r, B_r, C_r) of the pair fits with real coefficients coefs (a
    coupling pair realised for (i, j) and (j, i))."""
    blocks = []
    for pf, coef in zip(pairs, coefs):
        Lam, bvec = _real_form(pf.poles)
        for (a, b) in ([(pf.i, pf.j)] if pf.i == pf.j else [(pf.i, pf.j), (pf.j, pf.i)]):   # output a, input b
            blocks.append((a, b, Lam, bvec, coef))
    n = sum(blk[2].shape[0] for blk in blocks)
    A_r, B_r, C_r = np.zeros((n, n)), np.zeros((n, d)), np.zeros((d, n))
    k = 0
    for a, b, Lam, bvec, coef in blocks:
        m = Lam.shape[0]
        A_r[k:k + m, k:k + m] = Lam
        B_r[k:k + m, b] = bvec
        C_r[a, k:k + m] = coef
        k += m
    return A_r, B_r, C_r


def _residues_to_coeffs(res, poles):
    coef = np.empty(len(poles))
    k = 0
    while k < len(poles):
        a = poles[k]
        if abs(a.imag) < 1e-12 * max(1.0, abs(a)):
            coef[k] = res[k].real
            k += 1
        else:
            coef[k], coef[k + 1] = res[k].real, res[k].imag
            k += 2
    return coef
