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

The vector fit of one pair and the realisation (RAD.3, RAD.4) are in flexfmu.wec.radiation_fit, the passivity test
and enforcement (RAD.6-RAD.9) in flexfmu.wec.radiation_passivity; their public names are re-exported here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from flexfmu.errors import ConvergenceError, require
from flexfmu.wec.radiation_fit import (DEFAULT_MAX_ORDER, DEFAULT_TOLERANCE, PairFit, _assemble, _coeffs_to_residues,
                                       _residues_to_coeffs, fit_pair)
from flexfmu.wec.radiation_passivity import (DEFAULT_PASSIVITY_DELTA, PassivityReport, _enforce, _PassivityProblem,
                                             imaginary_axis_zeros)

DEFAULT_DOFS = ("surge", "heave", "pitch")     # head seas: the DOFs the platform moves in
DEFAULT_FIT_OMEGA_MAX = 10.0                 # rad/s: the example box's BEM data (5 cm panels) is noisy above ~11
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
