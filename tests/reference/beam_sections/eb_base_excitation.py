"""Root bending moment of a uniform Euler-Bernoulli cantilever whose clamp is shaken sideways: a0 sin(w t),
steady state, with the same modal damping ratio zeta in every mode (each mode's damping 2 zeta omega_n, as
FFRBeam's).  Closed-form modes and a modal series whose quasi-static part is summed in closed form; written from the
textbook formulas, nothing imported from flexfmu (a reference for FFRBeam's gauges).

    .venv/bin/python tests/reference/beam_sections/eb_base_excitation.py   # rewrites eb_base_excitation_case.csv

Sources: the cantilever's modes: R. D. Blevins, *Formulas for Natural Frequency and Mode Shape* (1979), Table 8-1
(beta_n L, sigma_n); L. Meirovitch, *Fundamentals of Vibrations* (2001), Secs. 8.6 (modes) and 8.11 (base motion,
modal participation); the undamped closed form (9) by Krylov's functions (S. Timoshenko, D. H. Young, W. Weaver,
*Vibration Problems in Engineering*, 4th ed. (1974), Sec. 5.11).

Derivation
----------
(1) Relative transverse deflection w(x, t) along the acceleration's direction e_a, x along the rod from the clamp:
        rho A w_tt + (modal damping) + EI w_xxxx = -rho A a(t),   w(0) = w_x(0) = 0,  w_xx(L) = w_xxx(L) = 0.
(2) Modes: phi_n(x) = [cosh b x - cos b x - sigma_n (sinh b x - sin b x)] / sqrt(rho A L), b = beta_n,
        1 + cos(beta_n L) cosh(beta_n L) = 0,  sigma_n = (cosh + cos) / (sinh + sin) of beta_n L,
        omega_n^2 = EI beta_n^4 / (rho A);   int rho A phi_n^2 dx = 1 (mass-normalised).
(3) Modal equations q_n'' + 2 zeta omega_n q_n' + omega_n^2 q_n = -Gamma_n a(t),
        Gamma_n = int rho A phi_n dx = sqrt(rho A L) 2 sigma_n / (beta_n L).
(4) Root moment M(t) = EI w_xx(0, t) = sum_n EI phi_n''(0) q_n,  phi_n''(0) = 2 beta_n^2 / sqrt(rho A L).
    M is the moment of the section at the clamp in the gauges' convention (the part beyond the cut on the part
    before it), its component along e_x cross e_a: by equilibrium of the whole rod M = -int rho A x a_abs dx, and
    statically -rho A a0 L^2 / 2 (the check: the static limit of (7) and of (9)).  For a rod along body X that is
    Mz for base_a_y and -My for base_a_z.
(5) For a(t) = a0 e^{i w t}: M = a0 G(w) e^{i w t},  G(w) = -sum_n EI phi_n''(0) Gamma_n H_n(w),
        H_n(w) = 1 / (omega_n^2 - w^2 + 2 i zeta omega_n w).
(6) EI phi_n''(0) Gamma_n / omega_n^2 = (rho A L^2 / 2) s_n,  s_n = 8 sigma_n / (beta_n L)^3,  sum_n s_n = 1 (the
    static series; checked numerically in the tests).
(7) Quasi-static part in closed form, the dynamic remainder as a series:
        G(w) = -(rho A L^2 / 2) [1 + sum_n s_n (omega_n^2 H_n(w) - 1)],
        omega_n^2 H_n - 1 = (w^2 - 2 i zeta omega_n w) / (omega_n^2 - w^2 + 2 i zeta omega_n w)   (~ n^-7 for n >> 1).
    For a0 sin(w t) the steady state is M(t) = a0 |G| sin(w t + arg G).
(8) Truncation after N terms (N >= 3, omega_{N+1} >= 2 w): for n > N, beta_n L >= (n - 0.51) pi, sigma_n <= 1.001,
    |omega_n^2 H_n - 1| <= (w^2 + 2 zeta omega_n w) / (0.75 omega_n^2), omega_n = c (beta_n L)^2,
    c = omega_1 / 1.8751^2:
        |G - G_N| / (rho A L^2 / 2) <= (8.008 / 0.75) sum_{n>N} [w^2 / (c^2 x_n^7) + 2 zeta w / (c x_n^5)]
                                   <= 10.68 [w^2 / (6 c^2 pi^7 (N - 0.51)^6) + 2 zeta w / (4 c pi^5 (N - 0.51)^4)].
    truncation_bound() returns this; with the default N = 200 it is 1.2e-12 of rho A L^2 / 2 at w = omega_1, 2.3e-11
    at 20 omega_1 (it grows like w).
(9) Check, undamped (zeta = 0), by Krylov's functions: W = a0 / w^2 + homogeneous; the boundary conditions give
        G0(w) = -rho A L^2 sinh z sin z / (z^2 (1 + cosh z cos z)),   z = L (rho A w^2 / EI)^(1/4),
    -> -rho A L^2 / 2 as w -> 0, poles at the natural frequencies.
(10) The clamp's reaction moment by d'Alembert, R = -int rho A x a_abs dx (what FFRBeam's reaction_M outputs), is not
    (4) when zeta > 0: integrating x (1) over the rod, EI w_xx(0) = R - int x c dx, the damping forces' moment; with
    modal damping int x c dx = sum_n 2 zeta omega_n q_n' int x rho A phi_n dx
                              = sum_n 2 zeta q_n' EI phi_n''(0) / omega_n.
    So R = a0 G_R e^{i w t} with the mode-n factor (1 + 2 i zeta w / omega_n), which gives
        G_R(w) = -(rho A L^2 / 2) [1 + sum_n s_n w^2 H_n(w)]     (= -int rho A x a_abs dx, a_abs = a0 - w^2 W),
    whose tail terms s_n |w^2 H_n| are bounded by the first part of (8): truncation_bound() bounds it too.
    A strain gauge reads the elastic moment (4)-(7); the two differ by ~2 zeta w / omega_1 of the mode-1 term.
(11) Along the rod, at distance x from the clamp: M(x) = EI w_xx(x) = a0 G(w, x) e^{i w t},
        G(w, x) = -rho A (L - x)^2 / 2 - sum_n t_n(x) (omega_n^2 H_n(w) - 1),
        t_n(x) = EI phi_n''(x) Gamma_n / omega_n^2 = rho A L^2 2 sigma_n psi_n(beta_n x) / (beta_n L)^3,
        psi_n(u) = cosh u + cos u - sigma_n (sinh u + sin u)   (= 2 at u = 0: t_n(0) = (rho A L^2 / 2) s_n),
    the quasi-static part -rho A (L - x)^2 / 2 (the inertia load beyond x) again in closed form.  |psi_n| <= 4.43 on
    the rod (cosh u - sigma sinh u = ((1 - sigma) e^u + (1 + sigma) e^-u) / 2 with |1 - sigma| e^z <= 2.83; the
    largest found, n <= 200, is 2, at the root), so the series' tail is at most 4.43 / 2 times (8):
    truncation_bound(w, x=...) returns that.
(12) Check of (11), undamped, Krylov's functions S, T, U = (cosh + cos) / 2, (sinh + sin) / 2, (cosh - cos) / 2:
        G0(w, x) = -(rho A / beta^2) [U(beta x) + k_c S(beta x) + k_d T(beta x)],  beta = z / L,
        k_c = sinh z sin z / (1 + cosh z cos z),  k_d = -(cosh z sin z + cos z sinh z) / (1 + cosh z cos z);
    at x = 0 it is (9), at x = L zero (the free end).
(13) Shear force at x, the same convention (the part beyond on the part before, along e_a): from the equilibrium of
    the part beyond, V = int_x^L p ds and dM/dx = -V, so V(x) = -EI w_xxx(x) (elastic, like M) = a0 G_V(w, x) e^{i w t},
        G_V(w, x) = -rho A (L - x) + sum_n v_n(x) (omega_n^2 H_n(w) - 1),
        v_n(x) = EI phi_n^(3)(x) Gamma_n / omega_n^2 = rho A L 2 sigma_n psi_n'(beta_n x) / (beta_n L)^2,
        psi_n'(u) = sinh u - sin u - sigma_n (cosh u + cos u)   (-2 sigma_n at the root),
    quasi-statically -rho A a0 (L - x), the inertia load beyond x.  |psi_n'| <= 4.43 as |psi_n|, so the tail after N
    terms is at most 11.83 rho A L [w^2 / (5 c^2 pi^5 (N - 0.51)^5) + 2 zeta w / (3 c pi^3 (N - 0.51)^3)]
    (shear_truncation_bound; the terms fall like n^-6 and n^-4, slower than the moment's).
(14) Check of (13), undamped: G0_V(w, x) = (rho A / beta) [T(beta x) + k_c V(beta x) + k_d S(beta x)],
    V = (sinh - sin) / 2, k_c, k_d of (12); at x = L zero, quasi-statically -rho A (L - x).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

HERE = Path(__file__).resolve().parent
DEFAULT_TERMS = 200
CASE_CSV = HERE / "eb_base_excitation_case.csv"


def cantilever_roots(n_terms: int) -> np.ndarray:
    """beta_n L, n = 1 .. n_terms: the roots of 1 + cos x cosh x = 0, i.e. cos x + 1 / cosh x = 0 (no overflow)."""
    return np.array(_roots(int(n_terms)))


@lru_cache(maxsize=32)
def _roots(n_terms: int) -> tuple:
    roots = []
    for n in range(1, n_terms + 1):
        centre = (n - 0.5) * math.pi
        roots.append(brentq(lambda x: math.cos(x) + 2.0 * math.exp(-x) / (1.0 + math.exp(-2.0 * x)),
                            centre - 0.6, centre + 0.6,
                            xtol=1e-15, rtol=4 * np.finfo(float).eps))
    return tuple(roots)


def mode_sigma(beta_L: np.ndarray) -> np.ndarray:
    """sigma_n = (cosh x + cos x) / (sinh x + sin x), in the form that does not overflow."""
    x = np.asarray(beta_L, float)
    inv_cosh = 1.0 / np.cosh(np.minimum(x, 700.0))
    return (1.0 + np.cos(x) * inv_cosh) / (np.tanh(x) + np.sin(x) * inv_cosh)


def mode_curvature_shape(beta_L: np.ndarray, xi: float) -> np.ndarray:
    """psi_n(beta_n L xi) of Eq. (11), xi = x / L in [0, 1], in the form that does not overflow:
    cosh u - sigma sinh u = ((1 - sigma) e^u + (1 + sigma) e^-u) / 2 with
    (1 - sigma) e^u = (sin z - cos z - e^-z) e^(u - z) / ((1 - e^-2z) / 2 + sin z e^-z),  z = beta_n L."""
    z = np.asarray(beta_L, float)
    u = z * xi
    sigma = mode_sigma(z)
    ez = np.exp(-z)
    one_minus_sigma_eu = (np.sin(z) - np.cos(z) - ez) * np.exp(u - z) / ((1 - ez**2) / 2 + np.sin(z) * ez)
    return (one_minus_sigma_eu + (1 + sigma) * np.exp(-u)) / 2 + np.cos(u) - sigma * np.sin(u)


def mode_shear_shape(beta_L: np.ndarray, xi: float) -> np.ndarray:
    """psi_n'(beta_n L xi) of Eq. (13), overflow-free as mode_curvature_shape:
    sinh u - sigma cosh u = ((1 - sigma) e^u - (1 + sigma) e^-u) / 2."""
    z = np.asarray(beta_L, float)
    u = z * xi
    sigma = mode_sigma(z)
    ez = np.exp(-z)
    one_minus_sigma_eu = (np.sin(z) - np.cos(z) - ez) * np.exp(u - z) / ((1 - ez**2) / 2 + np.sin(z) * ez)
    return (one_minus_sigma_eu - (1 + sigma) * np.exp(-u)) / 2 - np.sin(u) - sigma * np.cos(u)


@dataclass(frozen=True)
class Cantilever:
    """A uniform Euler-Bernoulli cantilever: length L (m), E (Pa), I (m^4, about the bending axis), rho (kg/m^3),
    A (m^2), modal damping ratio zeta."""

    L: float
    E: float
    I: float
    rho: float
    A: float
    zeta: float = 0.0

    @property
    def static_root_moment(self) -> float:
        """rho A L^2 / 2 (N m per m/s^2): the magnitude of the root moment under a steady a0 = 1."""
        return self.rho * self.A * self.L**2 / 2

    def natural_frequencies(self, n_terms: int = DEFAULT_TERMS) -> np.ndarray:
        """omega_n (rad/s), Eq. (2)."""
        return cantilever_roots(n_terms) ** 2 * math.sqrt(self.E * self.I / (self.rho * self.A)) / self.L**2

    def mode_shape(self, n: int, x) -> np.ndarray:
        """Mass-normalised phi_n(x) (1/sqrt(kg)), Eq. (2) (for the tests' quadratures)."""
        bL = cantilever_roots(n)[-1]
        b, s = bL / self.L, mode_sigma(bL)
        x = np.asarray(x, float)
        return (np.cosh(b * x) - np.cos(b * x) - s * (np.sinh(b * x) - np.sin(b * x))) / math.sqrt(
            self.rho * self.A * self.L)

    def root_moment_shares(self, n_terms: int = DEFAULT_TERMS) -> np.ndarray:
        """s_n = 8 sigma_n / (beta_n L)^3, Eq. (6)."""
        x = cantilever_roots(n_terms)
        return 8.0 * mode_sigma(x) / x**3

    def root_moment_transfer(self, w, n_terms: int = DEFAULT_TERMS) -> np.ndarray:
        """G(w) (N m per m/s^2, complex), Eq. (7): root moment a0 Im(G e^{i w t}) for base acceleration
        a0 sin(w t); w (rad/s) scalar or array."""
        w = np.atleast_1d(np.asarray(w, float))[:, None]
        omega = self.natural_frequencies(n_terms)[None, :]
        shares = self.root_moment_shares(n_terms)[None, :]
        damping = 2j * self.zeta * omega * w
        dynamic = (w**2 - damping) / (omega**2 - w**2 + damping)
        G = -self.static_root_moment * (1.0 + np.sum(shares * dynamic, axis=1))
        return G

    def moment_transfer(self, w, x: float, n_terms: int = DEFAULT_TERMS) -> np.ndarray:
        """G(w, x) (N m per m/s^2, complex), Eq. (11): the bending moment at distance x (m) from the clamp, same
        convention as root_moment_transfer (which it equals at x = 0)."""
        w = np.atleast_1d(np.asarray(w, float))[:, None]
        z = cantilever_roots(n_terms)
        omega = self.natural_frequencies(n_terms)[None, :]
        terms = (self.rho * self.A * self.L**2 * 2.0 * mode_sigma(z) * mode_curvature_shape(z, x / self.L) / z**3)
        damping = 2j * self.zeta * omega * w
        dynamic = (w**2 - damping) / (omega**2 - w**2 + damping)
        return -self.rho * self.A * (self.L - x) ** 2 / 2 - np.sum(terms[None, :] * dynamic, axis=1)

    def undamped_moment_transfer(self, w, x: float) -> np.ndarray:
        """G0(w, x) (N m per m/s^2, real) of the undamped cantilever in closed form, Eq. (12)."""
        w = np.atleast_1d(np.asarray(w, float))
        beta = (self.rho * self.A * w**2 / (self.E * self.I)) ** 0.25
        z, u = beta * self.L, beta * x
        den = 1.0 + np.cosh(z) * np.cos(z)
        k_c = np.sinh(z) * np.sin(z) / den
        k_d = -(np.cosh(z) * np.sin(z) + np.cos(z) * np.sinh(z)) / den
        S, T, U = (np.cosh(u) + np.cos(u)) / 2, (np.sinh(u) + np.sin(u)) / 2, (np.cosh(u) - np.cos(u)) / 2
        return -self.rho * self.A / beta**2 * (U + k_c * S + k_d * T)

    def truncation_bound(self, w, n_terms: int = DEFAULT_TERMS, x: float = 0.0) -> np.ndarray:
        """Bound on |G - G_N| (N m per m/s^2) of the series cut after n_terms, Eq. (8) (at the root, x = 0) and
        Eq. (11) (x > 0: 4.43 / 2 times the root's)."""
        if x > 0.0:
            return 4.43 / 2 * self.truncation_bound(w, n_terms)
        w = np.abs(np.atleast_1d(np.asarray(w, float)))
        omega = self.natural_frequencies(n_terms + 1)
        if n_terms < 3 or np.any(omega[-1] < 2 * w):
            raise ValueError("truncation_bound needs n_terms >= 3 and omega_{N+1} >= 2 w")
        c = omega[0] / cantilever_roots(1)[0] ** 2
        m = n_terms - 0.51
        return self.static_root_moment * 10.68 * (w**2 / (6 * c**2 * math.pi**7 * m**6)
                                                  + 2 * self.zeta * w / (4 * c * math.pi**5 * m**4))

    def shear_transfer(self, w, x: float, n_terms: int = DEFAULT_TERMS) -> np.ndarray:
        """G_V(w, x) (N per m/s^2, complex), Eq. (13): the shear force at distance x (m) from the clamp along the
        acceleration's direction, the part beyond the cut on the part before it."""
        w = np.atleast_1d(np.asarray(w, float))[:, None]
        z = cantilever_roots(n_terms)
        omega = self.natural_frequencies(n_terms)[None, :]
        terms = self.rho * self.A * self.L * 2.0 * mode_sigma(z) * mode_shear_shape(z, x / self.L) / z**2
        damping = 2j * self.zeta * omega * w
        dynamic = (w**2 - damping) / (omega**2 - w**2 + damping)
        return -self.rho * self.A * (self.L - x) + np.sum(terms[None, :] * dynamic, axis=1)

    def undamped_shear_transfer(self, w, x: float) -> np.ndarray:
        """G0_V(w, x) (N per m/s^2, real) of the undamped cantilever in closed form, Eq. (14)."""
        w = np.atleast_1d(np.asarray(w, float))
        beta = (self.rho * self.A * w**2 / (self.E * self.I)) ** 0.25
        z, u = beta * self.L, beta * x
        den = 1.0 + np.cosh(z) * np.cos(z)
        k_c = np.sinh(z) * np.sin(z) / den
        k_d = -(np.cosh(z) * np.sin(z) + np.cos(z) * np.sinh(z)) / den
        S, T, V = (np.cosh(u) + np.cos(u)) / 2, (np.sinh(u) + np.sin(u)) / 2, (np.sinh(u) - np.sin(u)) / 2
        return self.rho * self.A / beta * (T + k_c * V + k_d * S)

    def shear_truncation_bound(self, w, n_terms: int = DEFAULT_TERMS) -> np.ndarray:
        """Bound on |G_V - G_V,N| (N per m/s^2) of the shear series cut after n_terms, Eq. (13), any x."""
        w = np.abs(np.atleast_1d(np.asarray(w, float)))
        omega = self.natural_frequencies(n_terms + 1)
        if n_terms < 3 or np.any(omega[-1] < 2 * w):
            raise ValueError("shear_truncation_bound needs n_terms >= 3 and omega_{N+1} >= 2 w")
        c = omega[0] / cantilever_roots(1)[0] ** 2
        m = n_terms - 0.51
        return self.rho * self.A * self.L * 11.83 * (w**2 / (5 * c**2 * math.pi**5 * m**5)
                                                     + 2 * self.zeta * w / (3 * c * math.pi**3 * m**3))

    def root_reaction_transfer(self, w, n_terms: int = DEFAULT_TERMS) -> np.ndarray:
        """G_R(w) (N m per m/s^2, complex), Eq. (10): the clamp's d'Alembert reaction moment (inertia only), which
        also balances the damping forces; same convention and sign as root_moment_transfer."""
        w = np.atleast_1d(np.asarray(w, float))[:, None]
        omega = self.natural_frequencies(n_terms)[None, :]
        shares = self.root_moment_shares(n_terms)[None, :]
        H = 1.0 / (omega**2 - w**2 + 2j * self.zeta * omega * w)
        return -self.static_root_moment * (1.0 + np.sum(shares * w**2 * H, axis=1))

    def undamped_root_moment_transfer(self, w) -> np.ndarray:
        """G0(w) (N m per m/s^2, real) of the undamped cantilever in closed form, Eq. (9)."""
        w = np.atleast_1d(np.asarray(w, float))
        z = self.L * (self.rho * self.A * w**2 / (self.E * self.I)) ** 0.25
        return -self.rho * self.A * self.L**2 * np.sinh(z) * np.sin(z) / (z**2 * (1.0 + np.cosh(z) * np.cos(z)))


#: The tabulated case (eb_base_excitation_case.csv): a steel rod, 1 m, 10 mm diameter, zeta = 0.03.
CASE = Cantilever(L=1.0, E=200e9, I=math.pi * 0.01**4 / 64, rho=7850.0, A=math.pi * 0.01**2 / 4, zeta=0.03)


def write_case_csv(path: Path = CASE_CSV) -> None:
    """Amplitude and phase of the root moment per unit base acceleration over w / omega_1 = 0.1 .. 20 and at
    the first three natural frequencies."""
    omega = CASE.natural_frequencies(3)
    ratios = np.unique(np.concatenate([np.round(np.arange(0.1, 20.0001, 0.1), 10), omega / omega[0]]))
    w = ratios * omega[0]
    G = CASE.root_moment_transfer(w)
    bound = CASE.truncation_bound(w)
    lines = ['"w_over_omega_1","f_Hz","amplitude_Nm_per_mps2","phase_rad","truncation_bound_Nm_per_mps2"']
    lines += [f"{r!r},{wi / (2 * math.pi)!r},{abs(g)!r},{float(np.angle(g))!r},{b!r}"
              for r, wi, g, b in zip(ratios.tolist(), w.tolist(), G.tolist(), bound.tolist())]
    path.write_text("\n".join(lines) + "\n")
    print(f"{path.name}: {len(ratios)} rows, omega_1..3 = {omega.tolist()} rad/s")


if __name__ == "__main__":
    write_case_csv()
