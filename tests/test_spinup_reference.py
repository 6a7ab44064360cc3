"""Sanity checks of the geometrically exact spin-up reference.

flexfmu/data/references/spinup/trajectory.csv is written by generate.py beside it (Exudyn ANCF cable
elements, see the README there); this test reads only the CSV.  Each check can fail on a wrong reference:

* the hub angle column (the root-slope angle measured in Exudyn) is the prescribed theta(t) to 1e-9 rad;
* the deflection stays bounded - below the static tip deflection of a cantilever *without* centrifugal
  stiffening under the largest Euler load (rho A alpha_max x), which a stiffened beam cannot exceed by more than
  a small dynamic overshoot - and does not grow after the spin-up;
* during the spin-up the tip follows the quasi-static linear solution with centrifugal stiffening (the slow
  manoeuvre, 15 s against a first period of 1.4-1.7 s, makes the response quasi-static) and peaks, lagging the
  hub (v < 0), near the largest hub acceleration (7.5 s);
* after 15 s (alpha = 0, omega = 6 rad/s) the centrifugal load of a straight beam is purely axial, so the steady
  tip deflection is 0: v oscillates about 0 with the first in-plane frequency of the rotating beam and the
  amplitude a one-mode adiabatic estimate of the vibration left by the ramp predicts (a few mm, < 1% of the
  peak), and the axial displacement is the centrifugal stretch rho A omega^2 L^3 / (3 EA).

`pytest -s` prints the numbers.
"""
from __future__ import annotations

import numpy as np
import pytest

from flexfmu.studies.references import reference_path

REFERENCE = reference_path("spinup")
L, EI, RHO_A, EA = 10.0, 1.4e4, 1.2, 2.8e7
OMEGA_S, T_S = 6.0, 15.0
ALPHA_MAX = 2 * OMEGA_S / T_S                      # 0.8 rad/s^2 at t = 7.5 s


def theta(t):
    spin = OMEGA_S / T_S * (t * t / 2 + (T_S / (2 * np.pi)) ** 2 * (np.cos(2 * np.pi * t / T_S) - 1))
    return np.where(t < T_S, spin, OMEGA_S * t - OMEGA_S * T_S / 2)


def omega(t):
    return np.where(t < T_S, OMEGA_S / T_S * (t - T_S / (2 * np.pi) * np.sin(2 * np.pi * t / T_S)), OMEGA_S)


def alpha(t):
    return np.where(t < T_S, OMEGA_S / T_S * (1 - np.cos(2 * np.pi * t / T_S)), 0.0)


def rotating_beam(n=10):
    """Linear in-plane bending in the hub frame, clamped root, cubic Hermite elements: bending stiffness K,
    geometric stiffness G per omega^2 (tension rho A omega^2 (L^2 - x^2)/2), mass M, Euler load f per alpha.
    Quasi-static: (K + omega^2 (G - M)) v = -alpha f (-omega^2 M: transverse centrifugal softening)."""
    h = L / n
    xg, wg = np.polynomial.legendre.leggauss(5)
    nd = 2 * (n + 1)
    K, G, M, f = np.zeros((nd, nd)), np.zeros((nd, nd)), np.zeros((nd, nd)), np.zeros(nd)
    for e in range(n):
        sl = slice(2 * e, 2 * e + 4)
        for xi, w in zip(xg, wg):
            s = (xi + 1) / 2
            x, wt = (e + s) * h, w * h / 2
            N = np.array([1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, h * (s**3 - s**2)])
            dN = np.array([6 * s**2 - 6 * s, h * (1 - 4 * s + 3 * s**2), 6 * s - 6 * s**2, h * (3 * s**2 - 2 * s)]) / h
            ddN = np.array([12 * s - 6, h * (6 * s - 4), 6 - 12 * s, h * (6 * s - 2)]) / h**2
            K[sl, sl] += EI * np.outer(ddN, ddN) * wt
            G[sl, sl] += RHO_A * (L * L - x * x) / 2 * np.outer(dN, dN) * wt
            M[sl, sl] += RHO_A * np.outer(N, N) * wt
            f[sl] += RHO_A * x * N * wt
    return K[2:, 2:], G[2:, 2:], M[2:, 2:], f[2:]


BEAM = rotating_beam()


def quasi_static_tip(t):
    K, G, M, f = BEAM
    return np.array([np.linalg.solve(K + float(omega(s)) ** 2 * (G - M), -float(alpha(s)) * f)[-2]
                     for s in np.atleast_1d(t)])


def first_frequency(w):
    from scipy.linalg import eigh
    K, G, M, _ = BEAM
    return float(np.sqrt(eigh(K + w * w * (G - M), M, eigvals_only=True, subset_by_index=[0, 0])[0]))


@pytest.fixture(scope="module")
def ref():
    with open(REFERENCE) as f:
        lines = [line.strip() for line in f if line.strip() and not line.startswith("#")]
    header = lines[0].split(",")
    data = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    assert header == ["t", "hub_angle", "v_tip", "u_tip"]
    return {name: data[:, i] for i, name in enumerate(header)}


def test_time_grid_and_hub_angle_is_the_prescribed_motion(ref):
    t = ref["t"]
    assert t[-1] >= 20.0
    np.testing.assert_allclose(t, 0.05 * np.arange(t.size), atol=1e-9)
    err = np.max(np.abs(ref["hub_angle"] - theta(t)))
    print(f"\nmax |hub angle - theta(t)| = {err:.2e} rad over {t[0]}..{t[-1]} s")
    assert err <= 1e-9
    # the formula itself: continuous theta and omega at 15 s, omega = 6 rad/s after
    assert abs(float(theta(T_S - 1e-12)) - float(theta(T_S))) < 1e-9
    assert abs(float(omega(T_S - 1e-12)) - OMEGA_S) < 1e-9


def test_deflection_stays_bounded(ref):
    t, v, u = ref["t"], ref["v_tip"], ref["u_tip"]
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(u))
    # static tip deflection of a non-rotating cantilever under the triangular Euler load rho A alpha_max x
    v_unstiffened = 11 * RHO_A * ALPHA_MAX * L * L**4 / (120 * EI)          # 0.629 m
    vmax = np.max(np.abs(v))
    print(f"\nmax |v_tip| = {vmax:.4f} m; unstiffened static bound {v_unstiffened:.4f} m")
    assert vmax < v_unstiffened
    assert np.max(np.abs(u)) < 0.05                      # foreshortening of the bent beam, ~ -int v'^2/2 < 2 cm
    # no growth after the spin-up: the last 5 s are no larger than the first 5 s at 6 rad/s (linear FFR
    # without stiffening diverges here)
    first = (t >= T_S) & (t <= T_S + 5)
    last = t >= t[-1] - 5
    assert np.max(np.abs(v[last])) <= 1.05 * np.max(np.abs(v[first]))


def test_spin_up_follows_the_quasi_static_stiffened_solution(ref):
    t, v = ref["t"], ref["v_tip"]
    v_qs = quasi_static_tip(t)
    dev = np.max(np.abs(v - v_qs))
    i, j = np.argmax(np.abs(v)), np.argmax(np.abs(v_qs))
    print(f"\npeak v_tip {v[i]:.4f} m at {t[i]:.2f} s; quasi-static stiffened peak {v_qs[j]:.4f} m at {t[j]:.2f} s;"
          f" max |v - v_qs| = {dev:.4f} m")
    assert dev < 0.025 * abs(v[i])                        # measured 0.0075 m = 1.3% of the peak
    assert abs(v[i] - v_qs[j]) < 0.02 * abs(v_qs[j])      # geometric nonlinearity + dynamics: ~1%


def test_maximum_occurs_during_spin_up_lagging_the_hub(ref):
    t, v = ref["t"], ref["v_tip"]
    i = int(np.argmax(np.abs(v)))
    late = t >= T_S
    print(f"\npeak |v_tip| {abs(v[i]):.4f} m at {t[i]:.2f} s; after {T_S} s max {np.max(np.abs(v[late])):.2e} m")
    assert 0.0 < t[i] < T_S
    assert 5.0 <= t[i] <= 10.0                            # around the largest hub acceleration at 7.5 s
    assert v[i] < -0.5                                    # lags the hub (Euler force -rho A alpha x)
    assert abs(v[i]) > 50 * np.max(np.abs(v[late]))


def test_steady_state_after_spin_up(ref):
    t, v, u = ref["t"], ref["v_tip"], ref["u_tip"]
    late = t >= T_S
    tl, vl = t[late], v[late]
    peak = np.max(np.abs(v))
    amp = np.max(np.abs(vl))
    # frequency of the residual vibration from the zero crossings
    k = np.where(np.sign(vl[:-1]) * np.sign(vl[1:]) < 0)[0]
    tz = tl[k] - vl[k] * (tl[k + 1] - tl[k]) / (vl[k + 1] - vl[k])
    w_meas = np.pi * (tz.size - 1) / (tz[-1] - tz[0])
    w_lin = first_frequency(OMEGA_S)
    # one-mode adiabatic (WKB) estimate of the free vibration the smooth ramp leaves behind:
    # y = v - v_qs obeys y'' + w1(t)^2 y = -v_qs''; amplitude at T_S = |int v_qs'' e^{i phi} / sqrt(w1 w1(T_S))|
    s = np.linspace(0.0, T_S, 1501)
    w1 = np.array([first_frequency(float(omega(x))) for x in s])
    phi = np.concatenate([[0.0], np.cumsum(0.5 * (w1[1:] + w1[:-1]) * np.diff(s))])
    acc = np.gradient(np.gradient(quasi_static_tip(s), s), s)
    amp_est = abs(np.trapezoid(acc * np.exp(1j * phi) / np.sqrt(w1 * w1[-1]), s))
    stretch = RHO_A * OMEGA_S**2 * L**3 / (3 * EA)
    print(f"\nt >= {T_S} s: mean v_tip {vl.mean():.2e} m, amplitude {amp:.3e} m ({amp / peak:.2%} of the peak; "
          f"one-mode estimate {amp_est:.3e} m); frequency {w_meas:.4f} rad/s (linear rotating beam {w_lin:.4f}); "
          f"mean u_tip {u[late].mean():.5e} m (rho A w^2 L^3/(3 EA) = {stretch:.5e} m)")
    assert abs(vl.mean()) < 0.05 * amp                    # oscillates about the steady value 0
    assert amp < 0.01 * peak
    assert abs(amp - amp_est) < 0.1 * amp_est              # measured 3.64 mm, estimate 3.79 mm
    assert abs(w_meas - w_lin) < 0.005 * w_lin
    assert abs(u[late].mean() - stretch) < 0.005 * stretch
