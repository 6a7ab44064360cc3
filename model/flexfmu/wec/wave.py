"""Linear wave loads on a floating box: Airy waves, a JONSWAP sea, Froude-Krylov forces, and the
minimal Cummins model's constant coefficients (hydrostatic restoring, added mass, radiation damping).

Conventions (all SI).  Global axes x forward, y to port, z up; z = 0 is the mean free surface.
The box (length L along x, beam W along y, draft T) floats with its waterplane centre O at the
origin; its generalised motion is xi = (surge, sway, heave, roll, pitch, yaw) of O: small
displacements and small rotations (linear seakeeping).  Forces and moments act about O.

Waves: the surface elevation is  eta(x, y, t) = sum_j a_j cos(k_j (x cos b + y sin b) - w_j t + phi_j)
with the dispersion relation  w^2 = g k tanh(k d)  (d <= 0: deep water, w^2 = g k).  Its undisturbed
dynamic pressure  p = rho g a Z(z) cos(...),  Z = cosh(k (z + d)) / cosh(k d)  (deep: e^{kz}),
integrated over the mean wetted surface of the box gives the Froude-Krylov force (no diffraction).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from flexfmu.errors import require

G = 9.81
RHO_SEA = 1025.0
DOF_NAMES = ("surge", "sway", "heave", "roll", "pitch", "yaw")


# ------------------------------------------------------------------ waves
def wave_number(omega, depth: float = 0.0, g: float = G) -> np.ndarray:
    """Wave number k (1/m) of angular frequency omega (rad/s): w^2 = g k tanh(k d); depth <= 0: deep water."""
    omega = np.asarray(omega, float)
    k = omega**2 / g
    if depth <= 0:
        return k
    k = np.maximum(k, omega / math.sqrt(g * depth))          # start above the root (shallow/deep limits)
    for _ in range(100):                                      # Newton on f(k) = g k tanh(kd) - w^2
        th = np.tanh(k * depth)
        f = g * k * th - omega**2
        df = g * th + g * k * depth * (1.0 - th**2)
        step = f / df
        k = k - step
        if np.all(np.abs(step) <= 1e-14 * k):
            break
    return k


def jonswap_spectrum(omega, hs: float, tp: float, gamma: float = 3.3) -> np.ndarray:
    """JONSWAP spectral density S(w) (m^2 s/rad) scaled so that 4 sqrt(m0) = hs (m0 over 0 .. 10 w_p)."""
    wp = 2 * math.pi / tp

    def shape(w):
        w = np.asarray(w, float)
        out = np.zeros_like(w)
        pos = w > 0
        wpos = w[pos]
        sigma = np.where(wpos <= wp, 0.07, 0.09)
        peak = gamma ** np.exp(-((wpos - wp) ** 2) / (2 * sigma**2 * wp**2))
        out[pos] = wpos**-5 * np.exp(-1.25 * (wp / wpos) ** 4) * peak
        return out

    grid = np.linspace(0.05 * wp, 10 * wp, 20001)
    m0 = np.trapezoid(shape(grid), grid)
    return shape(omega) * (hs / 4) ** 2 / m0


@dataclass(frozen=True)
class WaveComponents:
    """Discrete wave components: angular frequency (rad/s), wave number (1/m), amplitude (m), phase
    (rad), all (n,); heading (rad, direction of travel from the x axis) and water depth (m, <= 0 deep)."""

    omega: np.ndarray
    k: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    heading: float = 0.0
    depth: float = 0.0

    def elevation(self, t: float, x: float = 0.0, y: float = 0.0) -> float:
        arg = self.k * (x * math.cos(self.heading) + y * math.sin(self.heading)) - self.omega * t + self.phase
        return float(self.amplitude @ np.cos(arg))


def regular_wave(height: float, period: float, heading: float = 0.0, depth: float = 0.0,
                 g: float = G) -> WaveComponents:
    """One Airy component of height H (crest to trough, m) and period T (s); crest at O at t = 0."""
    require(np.isfinite(height) and height >= 0, "wave_height", f"got {height!r}", ">= 0 m")
    require(np.isfinite(period) and period > 0, "wave_period", f"got {period!r}", "> 0 s")
    w = np.array([2 * math.pi / period])
    return WaveComponents(w, wave_number(w, depth, g), np.array([height / 2]), np.zeros(1), heading, depth)


def jonswap_sea(hs: float, tp: float, gamma: float = 3.3, n_components: int = 64, seed: int = 1,
                heading: float = 0.0, depth: float = 0.0, g: float = G) -> WaveComponents:
    """A long-crested JONSWAP sea: n components equally spaced over 0.5 .. 3 w_p (each at its bin's
    centre), amplitudes sqrt(2 S(w) dw), phases uniform from ``numpy.random.default_rng(seed)``.
    The record repeats after 2 pi / dw."""
    require(np.isfinite(hs) and hs >= 0, "wave_height", f"got {hs!r}", ">= 0 m (significant height)")
    require(np.isfinite(tp) and tp > 0, "wave_period", f"got {tp!r}", "> 0 s (peak period)")
    require(np.isfinite(gamma) and gamma >= 1, "gamma", f"got {gamma!r}", ">= 1")
    require(isinstance(n_components, (int, np.integer)) and 1 <= n_components <= 2000, "n_components",
            f"got {n_components!r}", "1 .. 2000")
    wp = 2 * math.pi / tp
    edges = np.linspace(0.5 * wp, 3.0 * wp, n_components + 1)
    dw = edges[1] - edges[0]
    w = 0.5 * (edges[1:] + edges[:-1])
    amp = np.sqrt(2 * jonswap_spectrum(w, hs, tp, gamma) * dw)
    phase = np.random.default_rng(seed).uniform(0, 2 * math.pi, n_components)
    return WaveComponents(w, wave_number(w, depth, g), amp, phase, heading, depth)


# ------------------------------------------------------------------ the floating box
@dataclass(frozen=True)
class BoxParameters:
    """The floating box's parameters: length L (x), beam W (y), draft T (m); centre of gravity at
    (0, 0, z_G) from the waterplane centre O; radii of gyration about G (m); water density rho (kg/m^3)
    and gravity g (m/s^2).  The components' configs that describe the box derive from it (same names,
    same defaults, first in their parameter lists)."""

    length: float = 1.0
    beam: float = 0.6
    draft: float = 0.25
    z_G: float = -0.10
    r_xx: float = 0.20
    r_yy: float = 0.30
    r_zz: float = 0.33
    rho: float = RHO_SEA
    g: float = G

    def box(self) -> "FloatingBox":
        return FloatingBox(**{f.name: getattr(self, f.name) for f in fields(BoxParameters)})


@dataclass(frozen=True)
class FloatingBox(BoxParameters):
    """A rectangular box floating freely in equilibrium (mass = rho * displaced volume)."""

    def check(self) -> "FloatingBox":
        for name in ("length", "beam", "draft", "r_xx", "r_yy", "r_zz", "rho", "g"):
            value = getattr(self, name)
            require(np.isfinite(value) and value > 0, name, f"got {value!r}", "> 0")
        require(np.isfinite(self.z_G), "z_G", f"got {self.z_G!r}", "a finite height (m)")
        C = self.hydrostatic_stiffness()
        for i, name in ((3, "roll"), (4, "pitch")):
            require(C[i, i] > 0, "z_G", f"{self.z_G!r} m leaves the box unstable in {name} (GM <= 0)",
                    f"< {self._z_G_limit(i):.4g} m")
        return self

    @property
    def volume(self) -> float:
        return self.length * self.beam * self.draft

    @property
    def mass(self) -> float:
        return self.rho * self.volume

    def _z_G_limit(self, i: int) -> float:
        L, W, T = self.length, self.beam, self.draft
        I_wp = L * W**3 / 12 if i == 3 else W * L**3 / 12
        return I_wp / self.volume - T / 2

    def rigid_mass_matrix(self) -> np.ndarray:
        """6x6 rigid-body mass matrix about O (G at (0, 0, z_G))."""
        m = self.mass
        rG = np.array([0.0, 0.0, self.z_G])
        S = _skew(rG)
        I_O = m * np.diag([self.r_xx**2, self.r_yy**2, self.r_zz**2]) + m * (rG @ rG * np.eye(3) - np.outer(rG, rG))
        M = np.zeros((6, 6))
        M[:3, :3] = m * np.eye(3)
        M[:3, 3:] = -m * S
        M[3:, :3] = m * S
        M[3:, 3:] = I_O
        return M

    def added_mass(self) -> np.ndarray:
        """Constant, diagonal added mass (6x6) from 2D strip estimates, without 3D end corrections:
        surge/sway a surface-piercing plate of depth T (rho pi T^2 / 2 per unit width); heave a
        half-circle of the beam (rho pi W^2 / 8 per unit length); roll/pitch/yaw the rotational
        counterparts (a plate of half-width b in rotation: rho pi b^4 / 16 per unit length, half space)
        plus the horizontal strips at their lever arms."""
        L, W, T, rho = self.length, self.beam, self.draft, self.rho
        a11 = rho * math.pi * T**2 / 2 * W
        a22 = rho * math.pi * T**2 / 2 * L
        a33 = rho * math.pi * W**2 / 8 * L
        a44 = rho * math.pi * (W / 2) ** 4 / 16 * L + a22 * (T / 2) ** 2
        a55 = rho * math.pi * (L / 2) ** 4 / 16 * W + a11 * (T / 2) ** 2
        a66 = rho * math.pi * T**2 / 2 * (L**3 + W**3) / 12
        return np.diag([a11, a22, a33, a44, a55, a66])

    def hydrostatic_stiffness(self) -> np.ndarray:
        """Linear hydrostatic restoring about O: heave rho g A_wp; roll/pitch rho g (I_wp + V z_B) - m g z_G."""
        L, W, T, rho, g = self.length, self.beam, self.draft, self.rho, self.g
        V = self.volume
        C = np.zeros((6, 6))
        C[2, 2] = rho * g * L * W
        C[3, 3] = rho * g * (L * W**3 / 12 - V * T / 2) - self.mass * g * self.z_G
        C[4, 4] = rho * g * (W * L**3 / 12 - V * T / 2) - self.mass * g * self.z_G
        return C

    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies (rad/s) of heave, roll, pitch from the diagonal terms."""
        M = np.diag(self.rigid_mass_matrix() + self.added_mass())
        C = np.diag(self.hydrostatic_stiffness())
        return np.sqrt(C[2:5] / M[2:5])

    def radiation_damping(self, zeta) -> np.ndarray:
        """Constant, diagonal linear radiation damping from damping ratios zeta (6,): heave, roll and
        pitch 2 zeta sqrt(C (M + A)) (a fraction of critical), surge, sway and yaw 2 zeta w_heave (M + A)."""
        zeta = np.asarray(zeta, float)
        M = np.diag(self.rigid_mass_matrix() + self.added_mass())
        C = np.diag(self.hydrostatic_stiffness())
        w3 = math.sqrt(C[2] / M[2])
        B = 2 * zeta * w3 * M
        B[2:5] = 2 * zeta[2:5] * np.sqrt(np.maximum(C[2:5], 0.0) * M[2:5])
        return np.diag(B)


# ------------------------------------------------------------------ Froude-Krylov
_N_QUAD = 40   # Gauss points per face edge; resolves k L up to ~60


def froude_krylov_transfer(box: FloatingBox, waves: WaveComponents) -> np.ndarray:
    """Complex Froude-Krylov force and moment about O per unit wave amplitude, shape (6, n):
    the load of component j at time t is Re(X[:, j] a_j exp(i (phi_j - w_j t)))."""
    L, W, T = box.length, box.beam, box.draft
    xg, wg = np.polynomial.legendre.leggauss(_N_QUAD)
    cb, sb = math.cos(waves.heading), math.sin(waves.heading)
    k = waves.k[:, None]

    def Z(z):
        if waves.depth <= 0:
            return np.exp(k * z)
        d = waves.depth
        # cosh(k(z+d))/cosh(kd) without overflow
        return (np.exp(k * z) + np.exp(-k * (z + 2 * d))) / (1 + np.exp(-2 * k * d))

    def face(points, weights, normal):
        """-int p n dS and -int p (r x n) dS over one face: points (m, 3), weights (m,)."""
        x, y, z = points.T
        p = box.rho * box.g * Z(z[None, :]) * np.exp(1j * k * (x * cb + y * sb)[None, :])   # (n, m)
        integral = p @ weights                                                          # (n,)
        r_x_n = np.cross(points, normal)                                                # (m, 3)
        force = -np.outer(normal, integral)
        moment = -(p * weights) @ r_x_n                                                 # (n, 3)
        return np.vstack([force, moment.T])

    def grid(a0, a1, b0, b1):
        a = 0.5 * (a1 - a0) * xg + 0.5 * (a1 + a0)
        b = 0.5 * (b1 - b0) * xg + 0.5 * (b1 + b0)
        w = np.outer(wg, wg).ravel() * 0.25 * (a1 - a0) * (b1 - b0)
        A, B = np.meshgrid(a, b, indexing="ij")
        return A.ravel(), B.ravel(), w

    X = np.zeros((6, waves.omega.size), complex)
    ys, zs, w = grid(-W / 2, W / 2, -T, 0.0)
    for sign in (1.0, -1.0):                                     # x = +-L/2
        pts = np.column_stack([np.full_like(ys, sign * L / 2), ys, zs])
        X += face(pts, w, np.array([sign, 0.0, 0.0]))
    xs, zs, w = grid(-L / 2, L / 2, -T, 0.0)
    for sign in (1.0, -1.0):                                     # y = +-W/2
        pts = np.column_stack([xs, np.full_like(xs, sign * W / 2), zs])
        X += face(pts, w, np.array([0.0, sign, 0.0]))
    xs, ys, w = grid(-L / 2, L / 2, -W / 2, W / 2)               # bottom z = -T
    pts = np.column_stack([xs, ys, np.full_like(xs, -T)])
    X += face(pts, w, np.array([0.0, 0.0, -1.0]))
    return X


def ramp(t: float, ramp_time: float) -> float:
    """Smooth start: 0.5 (1 - cos(pi t / T_r)) for t < T_r, then 1 (T_r <= 0: no ramp)."""
    if ramp_time <= 0 or t >= ramp_time:
        return 1.0
    if t <= 0:
        return 0.0
    return 0.5 * (1.0 - math.cos(math.pi * t / ramp_time))


from flexfmu.core.vec3 import skew as _skew  # noqa: E402  (the one unchecked skew; used above at call time)
