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
direct feedthrough), the radiation force being -A_inf xi_ddot - F_mem.

For a co-simulation component with a fixed step h and its velocity input held over the step, the
exact zero-order-hold discretisation is

    x_{k+1} = Phi x_k + Gamma u_k,   Phi = e^{A_r h},   Gamma = int_0^h e^{A_r s} ds B_r      (RAD.5)

(:class:`RadiationMemory`), exact for a held input whatever h.

Passivity (the memory never returns more energy to the body than it took: int_0^t xi_dot . F_mem >= 0 from
rest, for every motion) is, for the stable, symmetric K_fit,

    Re K_fit(j w) >= 0 (positive semi-definite) for all w >= 0                                (RAD.6)

The vector fit alone does not give it: where B ~ 0 (surge of the example box below ~2.5 rad/s), where B is
nearly singular (its surge-pitch block below ~4 rad/s: B15^2 = B11 B55 to 0.3 %, by the Haskind relation
B_ij ~ int X_i X_j* d beta with surge and pitch excitation alike in long waves) and beyond the fitted band,
where nothing constrains the fit, Re K_fit has negative eigenvalues.  It is enforced (``fit_radiation(...,
enforce_passivity=True)``, the default) by residue perturbation (Grivet-Talocia, IEEE Trans. Circuits
Syst. I 51 (2004); Grivet-Talocia & Gustavsen, Passive Macromodeling, Wiley 2016): poles (A_r, B_r) kept,
the real coefficients of C_r changed, on which K_fit depends linearly.  Violations are measured by

    mu(w) = lambda_min(T Re K_fit(j w) T) / s(w),   T = diag(max_w |K_ii|)^(-1/2),
    s(w) = (w / w_lo)^2 / ((1 + (w / w_lo)^2) (1 + (w / w_hi)^2))                          (RAD.7)

(w_lo, w_hi the database's first and last fitted frequencies): the congruence T makes every DOF count at
its own scale, s follows Re K_fit's w^2 decay at w -> 0 (K_fit(0) = 0) and 1/w^2 at w -> inf, so mu is
finite at both ends (limits C_r A_r^-3 B_r w_lo^2 and -C_r A_r B_r / w_hi^2).  mu is evaluated on a check
grid (log 1e-3 .. 1e4 rad/s, 200 per decade, linear 0.01 rad/s steps to 2 w_hi, and the two limits); its
local minima below delta are refined, and at each the eigenvectors v with eigenvalues below delta give a
linear constraint v^T T Re dK(j w) T v / s(w) >= delta - (current value).  Between grid points, the
frequencies where an eigenvalue of Re K_fit crosses zero are found exactly from the zeros of
Phi(s) = K_fit(s) + K_fit^T(-s): with D = 0 there is no Hamiltonian matrix (the positive-real lemma's needs
D + D^T invertible); K(0) = 0 and the symmetry give Phi(s) = s^2 Phi_2(s), Phi_2 = K_2(s) + K_2^T(-s),
K_2 = C_r (s - A_r)^-1 A_r^-2 B_r, whose zeros are the finite eigenvalues of a pencil of order 2n + d
(:func:`imaginary_axis_zeros`)

    crossing frequencies = { w > 0 : j w a zero of Phi_2 }                                     (RAD.8)

and the minimum of mu in each band between crossings is constrained too.  The change of the coefficients
minimises the change of the fit over the database's frequencies in the RAD.4 measure,

    sum_pairs m_p || dK_p ||^2 / ref_p^2   (m_p = 2 for a coupling pair, realised twice)       (RAD.9)

subject to the constraints (and K(0) = 0: the change is restricted to the null space of that row): a
least-distance program, solved exactly through non-negative least squares (Lawson & Hanson, Solving Least
Squares Problems, ch. 23).  Constraints accumulate, each solve starts from the vector fit (cutting planes),
until mu >= 0 on the grid and RAD.8 has no crossing.  The vector fit's residues are least-squares optimal
for their poles, so the enforced error is sqrt(eps_fit^2 + || dK ||^2 / ref^2).  If a pair's error then
exceeds the tolerance, its poles cannot be made passive closely enough: that pair is refitted at the next
order meeting the tolerance and the enforcement repeated (:class:`PassivityReport` keeps every round).
For the example box (head seas) the unenforced lowest orders (5, 6, 4, 5: 26 states) would end at RAD.4 errors
of 6.1 %, 2.8 %, 10.2 %, 6.1 % (surge, surge-pitch, heave, pitch); the enforced model has orders 7, 7, 10, 6
(37 states) and errors 1.86 %, 1.17 %, 1.63 %, 1.51 % (0.11 %, 0.17 %, 0.05 %, 1.28 % before enforcement).
:meth:`RadiationModel.passivity_margin` (a grid), :meth:`RadiationModel.crossing_frequencies` (RAD.8) and
:meth:`RadiationModel.asymptotic_margins` check a model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.optimize

from flexfmu.errors import ConvergenceError, require

DEFAULT_DOFS = ("surge", "heave", "pitch")     # head seas: the DOFs the platform moves in
DEFAULT_TOLERANCE = 0.02
DEFAULT_MAX_ORDER = 12
DEFAULT_FIT_OMEGA_MAX = 10.0                 # rad/s: the example box's BEM data (5 cm panels) is noisy above ~11
_VF_ITERATIONS = 30
_COUPLING_THRESHOLD = 1e-3                     # off-diagonal pairs below this x diagonal norms are zero
DEFAULT_PASSIVITY_DELTA = 1e-4    # the margin each enforcement constraint asks for, in units of mu (RAD.7)
_PASSIVITY_ITERATIONS = 60
_CHECK_DECADES = (-3.0, 4.0)      # log grid 1e-3 .. 1e4 rad/s (mu's limits at 0 and inf are exact points)
_CHECK_PER_DECADE = 200
_CHECK_LINEAR_STEP = 0.01         # rad/s, over 0 .. 2 omega_max
_CROSSING_TOLERANCE = 1e-7        # |Re z| / |z| below which a zero of Phi_2 counts as imaginary
_CROSSING_RANGE = 1e4             # zeros of Phi_2 beyond this x the largest |pole| are the pencil's infinite ones


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
    passivity: "PassivityReport | None" = None      # what the enforcement did (None: not enforced)

    @property
    def order(self) -> int:
        return self.A_r.shape[0]

    def transfer(self, omega) -> np.ndarray:
        """K_fit(j w), (n, d, d)."""
        omega = np.atleast_1d(np.asarray(omega, float))
        n = self.order
        out = np.empty((omega.size, len(self.dofs), len(self.dofs)), complex)
        for k in range(0, omega.size, 512):                 # batched solves, 512 frequencies at a time
            w = omega[k:k + 512]
            M = 1j * w[:, None, None] * np.eye(n)[None] - self.A_r[None]
            out[k:k + 512] = self.C_r @ np.linalg.solve(M, np.broadcast_to(self.B_r, (w.size,) + self.B_r.shape))
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
        largest |K_fit| over the band: >= 0 is passive on the grid (at w = 0, where K_fit(0) = 0, the value is
        zero to rounding, ~1e-16: leave w = 0 out of a grid meant to show >= 0)."""
        K = self.transfer(omega)
        herm = 0.5 * (K + np.conj(np.transpose(K, (0, 2, 1))))
        lam = np.linalg.eigvalsh(herm)[:, 0]
        return float(lam.min() / np.max(np.abs(K)))

    def crossing_frequencies(self) -> np.ndarray:
        """Frequencies w > 0 where an eigenvalue of the Hermitian part of K_fit(j w) is zero (RAD.8): none, with
        one frequency where it is positive definite, means passive at every frequency, not only on a grid."""
        return imaginary_axis_zeros(self.A_r, self.B_r, self.C_r)

    def asymptotic_margins(self) -> tuple[float, float]:
        """Smallest eigenvalues of the low- and high-frequency limits of the Hermitian part, Re K_fit(j w) / w^2
        -> C_r A_r^-3 B_r (w -> 0, K_fit(0) = 0) and w^2 Re K_fit(j w) -> -C_r A_r B_r (w -> inf), each over the
        largest |entry| of its matrix: >= 0 for a passive model."""
        out = []
        for M in (self.C_r @ np.linalg.matrix_power(np.linalg.inv(self.A_r), 3) @ self.B_r,
                  -self.C_r @ self.A_r @ self.B_r):
            M = 0.5 * (M + M.T)
            out.append(float(np.linalg.eigvalsh(M)[0] / np.max(np.abs(M))))
        return out[0], out[1]

    def discretize(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """(Phi, Gamma) of RAD.5 by one matrix exponential of [[A_r, B_r], [0, 0]] h."""
        require(isinstance(h, (int, float)) and math.isfinite(h) and h > 0, "step_size", f"got {h!r}", "> 0 s")
        n, m = self.B_r.shape
        aug = np.zeros((n + m, n + m))
        aug[:n, :n], aug[:n, n:] = self.A_r * h, self.B_r * h
        E = scipy.linalg.expm(aug)
        return E[:n, :n], E[:n, n:]


def fit_radiation(ds, dofs=DEFAULT_DOFS, tolerance: float = DEFAULT_TOLERANCE,
                  max_order: int = DEFAULT_MAX_ORDER, omega_max: float = DEFAULT_FIT_OMEGA_MAX,
                  enforce_passivity: bool = True, passivity_delta: float = DEFAULT_PASSIVITY_DELTA) -> RadiationModel:
    """Fit the radiation memory of a BEM database (flexfmu.wec.bem.hydro_database) over ``dofs``: one
    vector fit per DOF pair whose K is not zero (off-diagonal pairs below 1e-3 of the diagonal norms, zero
    by the hull's symmetry, are left out; K_ji = K_ij is fitted once and realised for both).  With
    ``enforce_passivity`` (the default) the residues are then perturbed to the nearest passive model
    (RAD.6-RAD.9; the poles, K(0) = 0 and the symmetry kept, each constraint asking for mu >= passivity_delta),
    a pair whose error that takes above the tolerance refitted at the next order; ConvergenceError if no
    order up to max_order does (:attr:`RadiationModel.passivity` reports what was done)."""
    from flexfmu.wec.bem import coefficients
    c = coefficients(ds, dofs)
    require(isinstance(omega_max, (int, float)) and np.sum(c.omega <= omega_max) >= 8, "omega_max",
            f"got {omega_max!r}", f"a frequency with >= 8 of the database's frequencies below it "
            f"({c.omega[min(7, c.omega.size - 1)]:.4g} .. {c.omega[-1]:.4g} rad/s)")
    require(isinstance(passivity_delta, (int, float)) and 0 < passivity_delta < 0.1, "passivity_delta",
            f"got {passivity_delta!r}", "0 < delta < 0.1")
    band = c.omega <= omega_max
    d = len(c.dofs)
    K = frequency_response(c.omega, c.A, c.B, c.A_inf)[band]        # (n, d, d)
    omega = c.omega[band]
    norms = np.linalg.norm(K, axis=0)
    pairs, refs, K_pairs = [], [], []
    for i in range(d):
        for j in range(i, d):
            ref = norms[i, i] if i == j else math.sqrt(norms[i, i] * norms[j, j])
            if i != j and norms[i, j] < _COUPLING_THRESHOLD * ref:
                continue
            Kij = 0.5 * (K[:, i, j] + K[:, j, i])                    # symmetric by reciprocity; BEM noise averaged
            pairs.append(fit_pair(omega, Kij, i, j, ref, tolerance, max_order))
            refs.append(ref)
            K_pairs.append(Kij)
    report = None
    if enforce_passivity:
        scale = 1 / np.sqrt(np.max(np.abs(K[:, range(d), range(d)]), axis=0))
        w_lo = float(omega[omega > 0][0])
        rounds = []
        first = None
        while True:
            problem = _PassivityProblem(pairs, refs, omega, K_pairs, d, scale, w_lo, float(omega[-1]),
                                        float(passivity_delta))
            iterations, mu0, mu1, errors0, crossings0 = _enforce(problem, float(omega[-1]))
            errors1 = problem.errors()
            first = first or (float(mu0.min()), tuple(crossings0))
            rounds.append({(pf.i, pf.j): (pf.order, e0, e1) for pf, e0, e1 in zip(pairs, errors0, errors1)})
            bad = [k for k, e in enumerate(errors1) if e > tolerance]
            if not bad:
                break
            # RAD.9: the poles of this order cannot be made passive within the tolerance: the next order
            for k in bad:
                pf = pairs[k]
                if pf.order >= max_order:
                    raise ConvergenceError(
                        f"K_{pf.i}{pf.j}: no passive fit within {tolerance:g} up to order {max_order} (passivity "
                        f"enforcement takes {errors0[k]:.3g} to {errors1[k]:.3g}, RAD.4); raise tolerance or max_order")
                nxt = fit_pair(omega, K_pairs[k], pf.i, pf.j, refs[k], tolerance, max_order, pf.order + 1)
                pairs[k] = PairFit(nxt.i, nxt.j, nxt.order, nxt.error, nxt.poles, nxt.residues,
                                   {**pf.errors_by_order, **nxt.errors_by_order})
        pairs = [PairFit(pf.i, pf.j, pf.order, e, pf.poles, _coeffs_to_residues(cf, pf.poles), pf.errors_by_order,
                         pf.error) for pf, cf, e in zip(pairs, problem.coefs(), errors1)]
        report = PassivityReport(iterations, len(problem.cuts_h), first[0], float(mu1), tuple(rounds),
                                 first[1], tuple(imaginary_axis_zeros(*_assemble(pairs, problem.coefs(), d))),
                                 float(passivity_delta))
    A_r, B_r, C_r = _assemble(pairs, [_residues_to_coeffs(pf.residues, pf.poles) for pf in pairs], d)
    model = RadiationModel(c.dofs, A_r, B_r, C_r, c.A_inf, tuple(pairs), tolerance, report)
    # the realisation must reproduce the partial fractions (a check of _real_form against _basis)
    Kfit = model.transfer(omega)
    for pf in pairs:
        direct = pf.transfer(1j * omega)
        if not np.allclose(Kfit[:, pf.i, pf.j], direct, rtol=1e-8, atol=1e-10 * np.max(np.abs(direct))):
            raise ConvergenceError(f"K_{pf.i}{pf.j}: the state-space realisation does not reproduce the fit")
    return model


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
