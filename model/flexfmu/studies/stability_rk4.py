"""Stability study 1 (flexfmu.studies.stability), the RK4 limit: the undamped modal RK4 amplification
|R(i dt omega)| against dt * omega_max: theory and the growth per step measured on the reframe integrator and the
fixed-frame baseline with the library's dt guard bypassed, and on the exponential scheme, which has no limit
(stability_rk4.png)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.integrator import RK4_STABILITY_LIMIT, FixedFrameBaseline, ReframeIntegrator
from flexfmu.studies.stability_common import BEAM_MODEL, beam, draw_chart


def rk4_amplification(y):
    """|R(i y)| of classical RK4, R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24, y = dt * omega (undamped mode)."""
    z = 1j * np.asarray(y, dtype=float)
    return np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)


def rk4_growth(integ, y, n_steps=20, amplitude=1e-7):
    """Measured growth per step of the highest flexible mode of the reframe integrator at dt * omega_max
    = y, starting from that mode alone (undamped, at rest otherwise).  The dt guard sits in
    ``advance_steps``/``run``; ``advance_steps(check_stability=False)`` steps past it."""
    d = integ.data
    w = d.omega_max
    dt = y / w
    q0 = np.zeros(d.nf)
    q0[-1] = amplitude
    s0 = integ.initial_state(q0=q0)
    s = integ.advance_steps(s0, dt, n_steps, check_stability=False)
    nm = d.n_modes
    a0 = math.hypot(s0.eta[nm - 1], s0.eta[-1] / w)
    a1 = math.hypot(s.eta[nm - 1], s.eta[-1] / w)
    return (a1 / a0) ** (1.0 / n_steps)


def baseline_growth(structure, basis, y, n_steps=20, amplitude=1e-7):
    """The same with the fixed-frame baseline; its guard is bypassed on the instance
    (``data.check_stability`` replaced by a no-op)."""
    base = FixedFrameBaseline(structure, basis)
    base.data.check_stability = lambda dt: None
    w = base.data.omega_max
    q0 = np.zeros(base.data.nf)
    q0[-1] = amplitude
    r = base.run(n_steps * y / w * (1 - 1e-12), y / w, q0=q0, every=n_steps)
    nm = base.data.n_modes
    a = np.hypot(r.eta[:, nm - 1], r.eta[:, -1] / w)
    return (a[-1] / a[0]) ** (1.0 / n_steps)


def exponential_growth(structure, basis, y, n_steps=20, amplitude=1e-7):
    """The same with the reframe ``exponential`` scheme (exact in the flexible oscillators, no dt guard)
    through the public API."""
    integ = ReframeIntegrator(structure, basis, scheme="exponential")
    d = integ.data
    w = d.omega_max
    q0 = np.zeros(d.nf)
    q0[-1] = amplitude
    s0 = integ.initial_state(q0=q0)
    s = integ.advance_steps(s0, y / w, n_steps)
    nm = d.n_modes
    a0 = math.hypot(s0.eta[nm - 1], s0.eta[-1] / w)
    a1 = math.hypot(s.eta[nm - 1], s.eta[-1] / w)
    return (a1 / a0) ** (1.0 / n_steps)


def study_rk4(figures: Path) -> dict:
    structure = beam()
    basis = modal_basis(structure, 3, damping_ratio=0.0)
    integ = ReframeIntegrator(structure, basis)
    w = integ.data.omega_max
    ys = np.array([0.5, 1.0, 1.5, 2.0, 2.4, 2.6, 2.7, 2.75, 2.8, 2.85, 2.9, 3.0, 3.1])
    measured = np.array([rk4_growth(integ, y) for y in ys])
    measured_base = np.array([baseline_growth(structure, basis, y) for y in ys])
    measured_exp = np.array([exponential_growth(structure, basis, y) for y in ys])
    theory = rk4_amplification(ys)
    print(f"\n== 1. RK4 limit: rod {BEAM_MODEL}, 3 flexible modes, undamped, omega_max = {w:.6g} rad/s "
          f"({w / 2 / math.pi:.5g} Hz); guard dt * omega_max <= {RK4_STABILITY_LIMIT}")
    print("   limit of |R(i y)| = 1: y = 2 sqrt(2) =", f"{2 * math.sqrt(2):.6f}")
    print(f"   {'dt*omega_max':>12} {'|R| theory':>11} {'reframe':>11} {'baseline':>11} {'exponential':>12}")
    for y, t, m, b, e in zip(ys, theory, measured, measured_base, measured_exp):
        print(f"   {y:12.3f} {t:11.6f} {m:11.6f} {b:11.6f} {e:12.9f}")
    far = [(y, exponential_growth(structure, basis, y)) for y in (10.0, 100.0)]
    print("   exponential scheme far beyond the limit: " + ", ".join(f"dt*omega_max {y:g}: {g:.9f}" for y, g in far))
    dev = float(np.max(np.abs(measured / theory - 1)))
    print(f"   max |measured / theory - 1| (reframe) = {dev:.2e}")

    def draw(plt, path):
        fig, ax = plt.subplots(figsize=(7, 4.5))
        yy = np.linspace(0.05, 3.2, 400)
        ax.plot(yy, rk4_amplification(yy), "k-", label="theory |R(i dt ω)|, RK4")
        ax.plot(ys, measured, "o", ms=7, mfc="none", label="measured: reframe (consistent), highest mode")
        ax.plot(ys, measured_base, "x", ms=7, label="measured: fixed-frame baseline, highest mode")
        ax.plot(ys, measured_exp, "s", ms=5, mfc="none", label="measured: reframe, scheme exponential (no limit)")
        ax.axvline(2 * math.sqrt(2), color="r", ls=":", label="2√2 = 2.83: |R| = 1")
        ax.axvline(RK4_STABILITY_LIMIT, color="gray", ls="--",
                   label=f"library refuses dt above {RK4_STABILITY_LIMIT}/ω_max (RK4 schemes)")
        ax.axhline(1.0, color="gray", lw=0.5)
        ax.set_xlabel("dt · ω_max (–)")
        ax.set_ylabel("growth of the mode amplitude per step (–)")
        ax.set_yscale("log")
        ax.set_yticks([0.5, 0.6, 0.8, 1.0, 1.5, 2.0])
        from matplotlib.ticker import NullFormatter, ScalarFormatter

        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_title("RK4 limit: growth per step of the highest flexible mode\n"
                     f"(bent rod, 3 undamped modes, ω_max = 2π·{w / 2 / math.pi:.0f} Hz)")
        ax.legend(fontsize=8, loc="upper left")
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)
    chart = draw_chart(figures, "stability_rk4.png", draw)
    return {"ys": ys, "theory": theory, "reframe": measured, "baseline": measured_base, "exponential": measured_exp,
            "chart": chart}
