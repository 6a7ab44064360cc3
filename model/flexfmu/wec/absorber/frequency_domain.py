"""The point absorber's frequency-domain prediction from the same BEM database (flexfmu.wec.absorber.hull): heave only,
no drag, no mooring, a PTO of damping c (N s/m) and stiffness k (N/m), linear waves of heading 0.

    Z(w)   = -w^2 (M_rb33 + A33(w)) - i w (B33(w) + c) + C33 + k          (N/m; Capytaine's e^{-i w t})
    RAO(w) = X_3(w) / Z(w)                                                   (m/m: heave per unit wave amplitude)
    regular wave of height H, period T (w = 2 pi / T, a = H / 2):
        heave amplitude |RAO(w)| a,   mean PTO power P = 1/2 c w^2 |RAO(w)|^2 a^2
    a sea of components w_k, spectral density S_k over bins dw:
        P = sum_k S_k dw c w_k^2 |RAO(w_k)|^2,   heave spectrum S_z(w) = |RAO(w)|^2 S(w)

A33, B33 and X_3 between the database's frequencies: re and im interpolated linearly (as the wave component does).
The PTO's stiffness k stores and returns energy: its mean power is zero, so P is the damper's.
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.errors import require


def _interp(hull, omega):
    from flexfmu.wec.absorber.wave import interpolate_excitation
    w = np.atleast_1d(np.asarray(omega, float))
    X3 = interpolate_excitation(hull, w, "omega")[:, 2]
    A33 = np.interp(w, hull.omega, hull.A[:, 2, 2])
    B33 = np.interp(w, hull.omega, hull.B[:, 2, 2])
    return w, X3, A33, B33


def _check_pto(damping: float, stiffness: float) -> None:
    require(math.isfinite(damping) and damping >= 0, "damping", f"got {damping!r}", ">= 0 N.s/m")
    require(math.isfinite(stiffness), "stiffness", f"got {stiffness!r}", "a finite N/m")


def impedance(hull, omega, damping: float, stiffness: float = 0.0) -> np.ndarray:
    """Z(w) of the module docstring, (n,) complex (N/m)."""
    _check_pto(damping, stiffness)
    w, _, A33, B33 = _interp(hull, omega)
    return -w**2 * (hull.M_rb[2, 2] + A33) - 1j * w * (B33 + damping) + hull.C[2, 2] + stiffness


def heave_rao(hull, omega, damping: float, stiffness: float = 0.0) -> np.ndarray:
    """RAO(w) = X_3(w) / Z(w), (n,) complex (m/m)."""
    w, X3, _, _ = _interp(hull, omega)
    return X3 / impedance(hull, w, damping, stiffness)


def regular_wave_response(hull, height: float, period: float, damping: float,
                          stiffness: float = 0.0) -> tuple[float, float]:
    """(heave amplitude (m), mean PTO power (W)) in a regular wave of height H (m) and period T (s)."""
    require(math.isfinite(height) and height >= 0, "wave_height", f"got {height!r}", ">= 0 m")
    require(math.isfinite(period) and period > 0, "wave_period", f"got {period!r}", "> 0 s")
    w = 2 * math.pi / period
    amplitude = abs(complex(heave_rao(hull, w, damping, stiffness)[0])) * height / 2
    return amplitude, 0.5 * damping * w**2 * amplitude**2


def spectral_mean_power(hull, omega, density, d_omega: float, damping: float, stiffness: float = 0.0) -> float:
    """P = sum_k S_k dw c w_k^2 |RAO(w_k)|^2 (W) of a sea of components at ``omega`` (rad/s) with spectral
    densities ``density`` (m^2 s/rad) over bins of width d_omega (rad/s)."""
    w = np.atleast_1d(np.asarray(omega, float))
    S = np.atleast_1d(np.asarray(density, float))
    require(S.shape == w.shape and np.all(np.isfinite(S)) and np.all(S >= 0), "density", f"shape {S.shape}",
            f"{w.size} finite values >= 0 (one per frequency)")
    require(math.isfinite(d_omega) and d_omega > 0, "d_omega", f"got {d_omega!r}", "> 0 rad/s")
    rao = heave_rao(hull, w, damping, stiffness)
    return float(np.sum(S * d_omega * damping * w**2 * np.abs(rao) ** 2))


def heave_spectrum(hull, omega, density, damping: float, stiffness: float = 0.0) -> np.ndarray:
    """S_z(w) = |RAO(w)|^2 S(w) (m^2 s/rad) at ``omega`` (rad/s) for the wave spectrum ``density``."""
    rao = heave_rao(hull, omega, damping, stiffness)
    return np.abs(rao) ** 2 * np.asarray(density, float)


def optimal_damping(hull, period: float) -> float:
    """The PTO damping (N s/m) that maximises the mean power in a regular wave of period T (s) with k = 0:
    c = sqrt(B33^2 + (w (M_rb33 + A33) - C33 / w)^2) (P = 1/2 c w^2 |X_3|^2 a^2 / |Z|^2, maximal over c there)."""
    w, _, A33, B33 = _interp(hull, 2 * math.pi / period)
    return float(np.hypot(B33[0], w[0] * (hull.M_rb[2, 2] + A33[0]) - hull.C[2, 2] / w[0]))
