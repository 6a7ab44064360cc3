"""The radiation memory of Cummins' equation as a state-space model fitted to a BEM database.

Cummins' equation about O (flexfmu.wec.bem's DOFs and frames):

    (M + A_inf) xi_ddot + int_0^t K(t - tau) xi_dot(tau) dtau + C xi = F_exc

with the retardation (radiation impulse-response) function and its transform (s = j w, time dependence
e^{j w t} here)

    K(t) = (2 / pi) int_0^inf B(w) cos(w t) dw                                     (RAD.1)
    K(j w) = int_0^inf K(t) e^{-j w t} dt = B(w) + j w (A(w) - A_inf)              (RAD.2)

RAD.2 follows from RAD.1 and the Kramers-Kronig relation of A and B; it is the frequency response the
fit matches.  Each DOF pair (i, j) is fitted on its own by vector fitting (Gustavsen & Semlyen 1999,
the frequency-domain identification Perez & Fossen 2008 recommend for radiation models):

    K_ij(s) ~ sum_m r_m / (s - p_m)       (strictly proper: K(j w) -> 0 as w -> inf)         (RAD.3)

the poles relocated by the iterated linear least-squares problem sigma(s) K(s) ~ sum c_m/(s - a_m),
sigma(s) = 1 + sum d_m/(s - a_m) (the new poles are the zeros of sigma); any pole in the right
half plane is mirrored (stable by construction); the residues are then fitted by linear least squares
with the constraint K(0) = sum -r_m/p_m = 0 (B(0) = 0 and w (A - A_inf) -> 0: no static radiation
force).  The order is the lowest of 2 .. max_order whose relative fit error

    eps_ij = || K_fit - K ||_2 / || K_ref ||_2     over the database's frequencies           (RAD.4)

(K_ref = K_ij on the diagonal, sqrt(|| K_ii || || K_jj ||) off it) is below the tolerance.  The pairs are
assembled into one block-diagonal realisation x_dot = A_r x + B_r xi_dot, F_mem = C_r x (D_r = 0, no
direct feedthrough), the radiation force being -A_inf xi_ddot - F_mem.  Passivity of the coupled
model (the Hermitian part of K(j w) positive semi-definite for all w) is checked, not enforced:
:meth:`RadiationModel.passivity_margin` (negative excursions where B is nearly zero stay within the fit
error; enforcing passivity, e.g. by residue perturbation, is not done).

For a co-simulation component with a fixed step h and its velocity input held over the step, the
exact zero-order-hold discretisation is

    x_{k+1} = Phi x_k + Gamma u_k,   Phi = e^{A_r h},   Gamma = int_0^h e^{A_r s} ds B_r      (RAD.5)

(:class:`RadiationMemory`), exact for a held input whatever h.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from flexfmu.errors import ConvergenceError, require

DEFAULT_DOFS = ("surge", "heave", "pitch")     # head seas: the DOFs the platform moves in
DEFAULT_TOLERANCE = 0.02
DEFAULT_MAX_ORDER = 12
DEFAULT_FIT_OMEGA_MAX = 10.0                 # rad/s: the example box's BEM data (5 cm panels) is noisy above ~11
_VF_ITERATIONS = 30
_COUPLING_THRESHOLD = 1e-3                     # off-diagonal pairs below this x diagonal norms are zero


# ------------------------------------------------------------------ direct transforms (independent of the fit)
def _with_zero(omega, B):
    """Prepend w = 0, B = 0 (radiation damping vanishes at zero frequency) to a grid starting above 0."""
    omega = np.asarray(omega, float)
    B = np.asarray(B, float)
    if omega[0] > 0:
        omega = np.concatenate([[0.0], omega])
        B = np.concatenate([np.zeros((1,) + B.shape[1:]), B])
    return omega, B


def impulse_response(omega, B, t) -> np.ndarray:
    """K(t) by RAD.1 (trapezoidal rule over the database's frequencies, B linear to 0 at w = 0, 0 beyond the
    last frequency): (n_t,) + B.shape[1:]."""
    w, Bw = _with_zero(omega, B)
    t = np.atleast_1d(np.asarray(t, float))
    kern = np.cos(np.outer(t, w))                                   # (n_t, n_w)
    wts = np.diff(np.concatenate([[w[0]], 0.5 * (w[1:] + w[:-1]), [w[-1]]]))
    return (2 / math.pi) * np.tensordot(kern * wts, Bw, axes=(1, 0))


def step_response(omega, B, t) -> np.ndarray:
    """R(t) = int_0^t K = (2 / pi) int B(w) sin(w t) / w dw (same quadrature as :func:`impulse_response`)."""
    w, Bw = _with_zero(omega, B)
    t = np.atleast_1d(np.asarray(t, float))
    wts = np.diff(np.concatenate([[w[0]], 0.5 * (w[1:] + w[:-1]), [w[-1]]]))
    kern = t[:, None] * np.sinc(np.outer(t, w) / math.pi)           # sin(w t)/w, = t at w = 0
    return (2 / math.pi) * np.tensordot(kern * wts, Bw, axes=(1, 0))


def frequency_response(omega, A, B, A_inf) -> np.ndarray:
    """K(j w) = B(w) + j w (A(w) - A_inf), RAD.2."""
    omega = np.asarray(omega, float)
    return np.asarray(B) + 1j * omega.reshape((-1,) + (1,) * (np.ndim(B) - 1)) * (np.asarray(A) - np.asarray(A_inf))


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
             max_order=DEFAULT_MAX_ORDER) -> PairFit:
    """Fit one K_ij(j w) (complex, (n,)) by RAD.3, the lowest order 2 .. max_order meeting the tolerance
    (RAD.4); ConvergenceError if none does."""
    omega = np.asarray(omega, float)
    K = np.asarray(K, complex)
    require(tolerance > 0, "tolerance", f"got {tolerance!r}", "> 0")
    require(isinstance(max_order, (int, np.integer)) and 2 <= max_order <= 40, "max_order", f"got {max_order!r}",
            "2 .. 40")
    ref = float(np.linalg.norm(K)) if reference_norm is None else float(reference_norm)
    scale = float(np.max(np.abs(K))) or 1.0
    errors = {}
    best = None
    for n in range(2, max_order + 1):
        poles, res, fit = _fit_order(omega, K, n, scale)
        err = float(np.linalg.norm(fit - K) / ref)
        errors[n] = err
        if best is None or err < best[2]:
            best = (poles, res, err, n)
        if err <= tolerance:
            return PairFit(i, j, n, err, poles, res, errors)
    raise ConvergenceError(f"K_{i}{j}: no order up to {max_order} fits within {tolerance:g} (best {best[2]:.3g} at "
                           f"order {best[3]}); raise tolerance or max_order")


# ------------------------------------------------------------------ the assembled model
@dataclass(frozen=True)
class RadiationModel:
    """The radiation memory over ``dofs`` (names of DOF_NAMES): x_dot = A_r x + B_r xi_dot, F_mem = C_r x.
    A_inf: infinite-frequency added mass over the same DOFs (to put on the body's mass)."""

    dofs: tuple
    A_r: np.ndarray
    B_r: np.ndarray
    C_r: np.ndarray
    A_inf: np.ndarray
    pairs: tuple
    tolerance: float

    @property
    def order(self) -> int:
        return self.A_r.shape[0]

    def transfer(self, omega) -> np.ndarray:
        """K_fit(j w), (n, d, d)."""
        omega = np.atleast_1d(np.asarray(omega, float))
        n = self.order
        out = np.empty((omega.size, len(self.dofs), len(self.dofs)), complex)
        for k, w in enumerate(omega):
            out[k] = self.C_r @ np.linalg.solve(1j * w * np.eye(n) - self.A_r, self.B_r)
        return out

    def impulse(self, t) -> np.ndarray:
        """K_fit(t) = C_r e^{A_r t} B_r, (n_t, d, d)."""
        ev, V = np.linalg.eig(self.A_r)
        CV, VB = self.C_r @ V, np.linalg.solve(V, self.B_r)
        t = np.atleast_1d(np.asarray(t, float))
        return np.real(np.einsum("ik,tk,kj->tij", CV, np.exp(np.outer(t, ev)), VB))

    def max_real_eigenvalue(self) -> float:
        return float(np.max(np.linalg.eigvals(self.A_r).real))

    def passivity_margin(self, omega) -> float:
        """min over omega of the smallest eigenvalue of the Hermitian part of K_fit(j w), divided by the
        largest |K_fit| over the band: >= 0 is passive on the grid."""
        K = self.transfer(omega)
        herm = 0.5 * (K + np.conj(np.transpose(K, (0, 2, 1))))
        lam = np.linalg.eigvalsh(herm)[:, 0]
        return float(lam.min() / np.max(np.abs(K)))

    def discretize(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """(Phi, Gamma) of RAD.5 by one matrix exponential of [[A_r, B_r], [0, 0]] h."""
        require(isinstance(h, (int, float)) and math.isfinite(h) and h > 0, "step_size", f"got {h!r}", "> 0 s")
        n, m = self.B_r.shape
        aug = np.zeros((n + m, n + m))
        aug[:n, :n], aug[:n, n:] = self.A_r * h, self.B_r * h
        E = scipy.linalg.expm(aug)
        return E[:n, :n], E[:n, n:]


def fit_radiation(ds, dofs=DEFAULT_DOFS, tolerance: float = DEFAULT_TOLERANCE,
                  max_order: int = DEFAULT_MAX_ORDER, omega_max: float = DEFAULT_FIT_OMEGA_MAX) -> RadiationModel:
    """Fit the radiation memory of a BEM database (flexfmu.wec.bem.hydro_database) over ``dofs``: one
    vector fit per DOF pair whose K is not zero (off-diagonal pairs below 1e-3 of the diagonal norms, zero
    by the hull's symmetry, are left out; K_ji = K_ij is fitted once and realised for both)."""
    from flexfmu.wec.bem import coefficients
    c = coefficients(ds, dofs)
    require(isinstance(omega_max, (int, float)) and np.sum(c.omega <= omega_max) >= 8, "omega_max",
            f"got {omega_max!r}", f"a frequency with >= 8 of the database's frequencies below it "
            f"({c.omega[min(7, c.omega.size - 1)]:.4g} .. {c.omega[-1]:.4g} rad/s)")
    band = c.omega <= omega_max
    d = len(c.dofs)
    K = frequency_response(c.omega, c.A, c.B, c.A_inf)[band]        # (n, d, d)
    omega = c.omega[band]
    norms = np.linalg.norm(K, axis=0)
    blocks = []
    pairs = []
    for i in range(d):
        for j in range(i, d):
            ref = norms[i, i] if i == j else math.sqrt(norms[i, i] * norms[j, j])
            if i != j and norms[i, j] < _COUPLING_THRESHOLD * ref:
                continue
            Kij = 0.5 * (K[:, i, j] + K[:, j, i])                    # symmetric by reciprocity; BEM noise averaged
            pf = fit_pair(omega, Kij, i, j, ref, tolerance, max_order)
            pairs.append(pf)
            targets = [(i, j)] if i == j else [(i, j), (j, i)]
            for (a, b) in targets:                                   # output a, input b
                Lam, bvec = _real_form(pf.poles)
                coef = _residues_to_coeffs(pf.residues, pf.poles)
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
    model = RadiationModel(c.dofs, A_r, B_r, C_r, c.A_inf, tuple(pairs), tolerance)
    # the realisation must reproduce the partial fractions (a check of _real_form against _basis)
    Kfit = model.transfer(omega)
    for pf in pairs:
        direct = pf.transfer(1j * omega)
        if not np.allclose(Kfit[:, pf.i, pf.j], direct, rtol=1e-8, atol=1e-10 * np.max(np.abs(direct))):
            raise ConvergenceError(f"K_{pf.i}{pf.j}: the state-space realisation does not reproduce the fit")
    return model


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


# ------------------------------------------------------------------ fixed-step component
class RadiationMemory:
    """The radiation memory force for a fixed communication step h (RAD.5): ``step(velocity)`` advances
    with the velocity (over the model's dofs, m/s and rad/s) held over the step; ``force`` is the memory
    force on the body -C_r x (N, N m about O), a function of the state only (no direct feedthrough)."""

    def __init__(self, model: RadiationModel, step_size: float):
        self.model = model
        self.h = float(step_size)
        self.Phi, self.Gamma = model.discretize(self.h)
        self.x = np.zeros(model.order)

    def reset(self) -> None:
        self.x = np.zeros(self.model.order)

    @property
    def force(self) -> np.ndarray:
        return -(self.model.C_r @ self.x)

    def step(self, velocity) -> np.ndarray:
        u = np.asarray(velocity, float)
        require(u.shape == (len(self.model.dofs),) and np.all(np.isfinite(u)), "velocity",
                f"shape {u.shape}", f"{len(self.model.dofs)} finite values ({', '.join(self.model.dofs)})")
        self.x = self.Phi @ self.x + self.Gamma @ u
        return self.force

    def simulate(self, velocities) -> np.ndarray:
        """Memory forces after each of a sequence of held velocities (n_steps, d) -> (n_steps, d)."""
        return np.array([self.step(u) for u in np.asarray(velocities, float)])
