#!/usr/bin/env python3
# Over 500 lines on purpose: four independent studies, each a table and a chart, sharing their set-ups.
"""Stability where methods fail: four studies, each a table on stdout and a chart.

    flexfmu bench stability [--quick] [--out REPORT.md]
    .venv/bin/python benchmarks/stability.py [--only rk4|rotation|cosim|tumbling] [--figures DIR]

1. rk4       the undamped modal RK4 amplification |R(i dt omega)| against dt * omega_max: theory and the
             growth per step measured on the reframe integrator and the fixed-frame baseline with the
             library's dt guard bypassed, and on the exponential scheme, which has no limit
             (stability_rk4.png).
2. rotation  a free rod spinning about its major principal axis: relative change of the distance
             between its two ends against the rotation angle, fixed-frame linear baseline, reframe
             (both schemes) and the baseline's analytic stretch (stability_rotation.png).
3. cosim     FFRBeam on a rigid Platform, explicit force/motion coupling: spectral radius of the
             linearised co-simulation step over mass ratio x communication step, both master
             schemes, cross-checked by direct runs (stability_cosim.png).
4. tumbling  a free rod tumbling about its intermediate principal axis: drift of the global angular
             momentum (and of the energy) against dt for the "paper" and "consistent" schemes
             (stability_tumbling.png).

docs/stability.md quotes the numbers this prints.  Runs in about two minutes on 2 cores.  Without matplotlib
the tables are printed and the charts skipped.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from flexfmu.errors import FlexfmuError
from flexfmu.linalg.modal_basis import mass_properties, modal_basis
from flexfmu.reframe.models import load_model
from flexfmu.reframe.integrator import RK4_STABILITY_LIMIT, FixedFrameBaseline, ReframeIntegrator
from flexfmu.studies import common

BEAM_MODEL = "beam:spatial_double_L"     # free-free bent rod, 6 DOF per node
BEAM_ELEMENTS = 4                        # elements per segment: 13 nodes, flexible modes 148, 266, 280 Hz
AXES = "xyz"


# =========================================================================== shared helpers
def _chart(figures: Path, name: str, draw) -> Path | None:
    """figures/name drawn by draw(plt, path); without matplotlib the chart is skipped, saying so."""
    plt = common.pyplot()
    if plt is None:
        print("   " + common.skipped(f"chart {name}", "matplotlib"))
        return None
    figures.mkdir(parents=True, exist_ok=True)
    draw(plt, figures / name)
    return figures / name


def rk4_amplification(y):
    """|R(i y)| of classical RK4, R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24, y = dt * omega (undamped mode)."""
    z = 1j * np.asarray(y, dtype=float)
    return np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)


def beam(elements_per_segment: int = BEAM_ELEMENTS):
    return load_model(BEAM_MODEL, elements_per_segment=elements_per_segment)


def principal_axes(structure):
    """Principal moments (ascending) and axes (columns) of the rigid body (flexfmu.linalg.modal_basis.mass_properties:
    from M and the nodes, independent of the modal basis)."""
    props = mass_properties(structure)
    return props.principal_moments, props.principal_axes


def global_momentum_and_energy(integ, structure, state):
    """Angular momentum about the global origin (global components, from M and the nodal state) and
    the total energy T + V (from M and K) of a reframe state."""
    ns = integ.nodal_state(state)
    R = state.rotation
    Mw = structure.M @ ns.velocity_body
    Mw_g = (Mw.reshape(-1, 3) @ R.T).reshape(structure.nodes.shape[0], -1)
    L = np.cross(ns.positions, Mw_g[:, :3]).sum(axis=0)
    if structure.dofs_per_node == 6:
        L = L + Mw_g[:, 3:].sum(axis=0)
    energy = 0.5 * ns.velocity_body @ Mw + 0.5 * ns.displacement @ (structure.K @ ns.displacement)
    return L, float(energy)


def slope(x, y):
    """Least-squares slope of log y against log x."""
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


# =========================================================================== 1. RK4 limit
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
    chart = _chart(figures, "stability_rk4.png", draw)
    return {"ys": ys, "theory": theory, "reframe": measured, "baseline": measured_base, "exponential": measured_exp,
            "chart": chart}


# =========================================================================== 2. large rotation
def rotation_runs(spin=2 * math.pi, angle=math.pi, dt=2e-4, n_modes=3, elements=BEAM_ELEMENTS):
    """Free spin about the major principal axis at ``spin`` rad/s through ``angle`` rad: the rotation
    angle and the relative change of the end-to-end distance of the rod for the fixed-frame baseline
    and both reframe schemes, plus the baseline's analytic value sqrt(1 + theta^2 sin^2 beta) - 1
    (a point moved along the tangent, x + theta k x d; beta = angle between axis and d)."""
    structure = beam(elements)
    basis = modal_basis(structure, n_modes)
    _, axes = principal_axes(structure)
    k = axes[:, 2]
    w0 = spin * k
    ends = [0, structure.nodes.shape[0] - 1]
    d = structure.nodes[ends[1]] - structure.nodes[ends[0]]
    d0 = float(np.linalg.norm(d))
    t_end = angle / spin
    out = {}
    base = FixedFrameBaseline(structure, basis).run(t_end, dt, None, ends, omega0=w0)
    out["t"] = base.t
    out["theta"] = spin * base.t
    out["baseline"] = np.linalg.norm(base.point_position[:, 1] - base.point_position[:, 0], axis=1) / d0 - 1
    for scheme in ("consistent", "paper"):
        integ = ReframeIntegrator(structure, basis, scheme=scheme)
        integ.set_initial(omega0=w0)
        r = integ.run(t_end, dt, None, ends)
        out[scheme] = np.linalg.norm(r.point_position[:, 1] - r.point_position[:, 0], axis=1) / d0 - 1
    sin2 = float(np.linalg.norm(np.cross(k, d / d0)) ** 2)
    out["analytic"] = np.sqrt(1 + out["theta"] ** 2 * sin2) - 1
    out["centrifugal"] = (spin / (2 * math.pi * basis.frequencies_hz[0])) ** 2
    out["sin2beta"] = sin2
    return out


def study_rotation(figures: Path) -> dict:
    spin = 2 * math.pi
    r = rotation_runs(spin=spin, angle=math.pi)
    theta = r["theta"]
    grid_deg = np.array([1, 3, 10, 30, 90, 180])
    print(f"\n== 2. Large rotation: rod spinning at {spin:.4g} rad/s about its major principal axis "
          f"(sin^2 beta = {r['sin2beta']:.4f}), 3 modes, dt = 2e-4 s")
    print("   relative change of the end-to-end distance, max over [0, theta]:")
    print(f"   {'theta (deg)':>11} {'baseline':>10} {'analytic':>10} {'consistent':>11} {'paper':>10}")
    env = {name: np.maximum.accumulate(np.abs(r[name])) for name in ("baseline", "consistent", "paper", "analytic")}
    for g in grid_deg:
        i = int(np.argmin(np.abs(np.degrees(theta) - g)))
        print(f"   {g:11.0f} {env['baseline'][i]:10.3e} {env['analytic'][i]:10.3e} {env['consistent'][i]:11.3e} "
              f"{env['paper'][i]:10.3e}")
    print(f"   physical centrifugal stretch scale (Omega/omega_1)^2 = {r['centrifugal']:.3e}")
    sel = theta > 0
    def draw(plt, path):
        fig, ax = plt.subplots(figsize=(7, 4.5))
        deg = np.degrees(theta[sel])
        ax.loglog(deg, env["baseline"][sel], "-", lw=2.5, label="fixed-frame linear baseline")
        ax.loglog(deg, env["analytic"][sel], "k--", lw=1, label="baseline, analytic √(1+θ² sin²β) − 1")
        ax.loglog(deg, env["consistent"][sel], "-", lw=3, label="reframe, scheme consistent")
        ax.loglog(deg, env["paper"][sel], "-.", lw=1.5, label="reframe, scheme paper (on top of consistent)")
        ax.axhline(r["centrifugal"], color="gray", ls=":", label="physical centrifugal stretch (Ω/ω₁)²")
        ax.set_xlabel("rotation angle θ (degrees)")
        ax.set_ylabel("max |Δ end-to-end distance| / rigid distance (–)")
        ax.set_title("Large rotation: spurious stretching of the fixed-frame linear model\n"
                     "(free bent rod spinning at 1 rev/s about its major axis)")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)
    r["chart"] = _chart(figures, "stability_rotation.png", draw)
    return r


# =========================================================================== 3. co-simulation coupling
def platform_beam_system(mass_ratio: float, beam_values: dict | None = None):
    """FFRBeam (spatial double-L clamped at its first point, FMU defaults) on a rigid Platform with no
    water forces: the platform sends the mount point's acceleration and its angular velocity and
    acceleration (the beam's base motion), the beam returns its clamp reactions (the platform's
    payload load).  The platform's density rho is set so that beam mass / platform mass
    (rho L B T, without the added mass the Platform also carries) equals ``mass_ratio``."""
    from flexfmu.cosim.masters import SimulatorSpec, System
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    from flexfmu.wec.platform import PlatformConfig

    values = dict(beam_values or {})
    beam_mass = FFRBeamSimulator(FFRBeamConfig(**values)).dynamics.integrals.mass
    cfg = PlatformConfig()
    rho = beam_mass / (mass_ratio * cfg.length * cfg.beam * cfg.draft)
    conns = []
    for a in AXES:
        conns += [(("platform", f"mount_a_{a}"), ("beam", f"base_a_{a}")),
                  (("platform", f"omega_{a}"), ("beam", f"base_w_{a}")),
                  (("platform", f"alpha_{a}"), ("beam", f"base_dw_{a}")),
                  (("beam", f"reaction_F_{a}"), ("platform", f"payload_F_{a}")),
                  (("beam", f"reaction_M_{a}"), ("platform", f"payload_M_{a}"))]
    sims = [SimulatorSpec("platform", Path("Platform.fmu"), {"rho": rho}),
            SimulatorSpec("beam", Path("FFRBeam.fmu"), values)]
    return System(sims, conns, 1e-3)


def residual_inertia(config=None) -> np.ndarray:
    """The beam's rigid 6x6 inertia about its frame origin (base translation, rotation) minus the part its
    retained clamped modes carry: B_res = R^T M R - L^T L, L = Phi^T B2^T M R (FE matrices, dense
    eigensolve of (K_free, M_free)).  A base acceleration held over a step meets B_res as an
    instantaneous reaction; the retained modes answer dynamically."""
    import scipy.linalg

    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator

    cfg = config or FFRBeamConfig()
    model = FFRBeamSimulator(cfg).dynamics.model
    nodes = model.mesh.nodes
    R = np.zeros((model.n_dof, 6))
    for k in range(3):
        R[k::6, k] = 1.0
        rot = np.cross(np.eye(3)[k], nodes)
        for j in range(3):
            R[j::6, 3 + k] = rot[:, j]
        R[3 + k::6, 3 + k] = 1.0
    M, B2 = model.M.toarray(), model.B2.toarray()
    _, Phi = scipy.linalg.eigh(model.K_free.toarray(), model.M_free.toarray())
    L = Phi[:, :cfg.n_modes].T @ B2.T @ M @ R
    return R.T @ M @ R - L.T @ L


def instantaneous_loop_radius(mass_ratio: float) -> float:
    """Spectral radius of the instantaneous (h -> 0) part of the coupling loop: the held clamp reaction
    -B_res (a_m, alpha) turns into the platform's (a_m, alpha) = T Mp^-1 T^T (F, M_m) one exchange later
    (T: mount point <- O, Mp = M_rb + A about O)."""
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    from flexfmu.wec.platform import PlatformConfig, mass_matrix
    from flexfmu.core.vec3 import skew

    beam_mass = FFRBeamSimulator(FFRBeamConfig()).dynamics.integrals.mass
    cfg0 = PlatformConfig()
    cfg = PlatformConfig(rho=beam_mass / (mass_ratio * cfg0.length * cfg0.beam * cfg0.draft))
    Mp = mass_matrix(cfg)
    T = np.block([[np.eye(3), -skew(cfg.mount)], [np.zeros((3, 3)), np.eye(3)]])
    return float(np.max(np.abs(np.linalg.eigvals(T @ np.linalg.solve(Mp, T.T @ residual_inertia())))))


def cosim_run(system, h: float, scheme: str, n_steps: int = 200, kick: float = 1.0):
    """A direct run (library façades) of n_steps communication steps: a force kick (N, the beam's body z)
    on the beam's tip for the first step, then free.  Returns (peak |payload force| over the first and
    the last fifth of the run, the error message if a component reported divergence, else None).
    (About 20 ms per step: FFRBeam recomputes its step map whenever the base's angular velocity changes.)"""
    from flexfmu.cosim.masters import Master

    master = Master(system, "library")
    master.initialize()
    beam_slave = master.slaves["beam"]
    beam_slave.set(["F_z"], [kick])
    n = int(n_steps)
    peaks = []
    error = None
    try:
        for k in range(n):
            master.step(k * h, h, scheme)
            if k == 0:
                beam_slave.set(["F_z"], [0.0])
            F = [master.slaves["platform"].values[f"payload_F_{a}"] for a in AXES]
            peaks.append(math.sqrt(sum(f * f for f in F)))
    except FlexfmuError as exc:
        error = str(exc)
    peaks = np.array(peaks)
    m = max(1, n // 5)
    first = float(peaks[:m].max()) if peaks.size else math.inf
    last = float(peaks[-m:].max()) if peaks.size >= n else math.inf
    return first, last, error


def study_cosim(figures: Path, n_ratio: int = 19, n_step: int = 17) -> dict:
    from flexfmu.cosim.masters import STABILITY_TOLERANCE, spectral_radius

    ratios = np.geomspace(1e-3, 30.0, n_ratio)
    steps = np.geomspace(1e-5, 1e-1, n_step)
    schemes = ("gauss-seidel", "jacobi")
    rho = {s: np.zeros((n_ratio, n_step)) for s in schemes}
    t0 = time.perf_counter()
    for i, mu in enumerate(ratios):
        system = platform_beam_system(float(mu))
        for j, h in enumerate(steps):
            for s in schemes:
                rho[s][i, j] = spectral_radius(system, float(h), s)
    elapsed = time.perf_counter() - t0
    mu_rigid = 1.0 / instantaneous_loop_radius(1.0)          # the loop radius is proportional to mu
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator

    sim = FFRBeamSimulator(FFRBeamConfig())
    print(f"\n== 3. Co-simulation coupling: FFRBeam (spatial_double_L, XFF, 6 modes "
          f"{', '.join(f'{f:.0f}' for f in sim.frequencies_hz)} Hz, 1 % damping, beam mass "
          f"{sim.dynamics.integrals.mass:.4g} kg) on a rigid Platform (no water forces)")
    print(f"   {n_ratio} x {n_step} grid x 2 schemes of spectral radii in {elapsed:.0f} s; "
          f"instantaneous (residual-inertia) loop unstable above mass ratio {mu_rigid:.3f} at any step")
    for s in schemes:
        stable = rho[s] <= 1 + STABILITY_TOLERANCE
        print(f"   {s}: largest stable step per mass ratio (first unstable step on the grid)")
        for i in range(0, n_ratio, 2):
            bad = np.nonzero(~stable[i])[0]
            first = f"{steps[bad[0]]:.2e} s" if bad.size else "none up to 0.1 s"
            print(f"      mass ratio {ratios[i]:9.2e}: first unstable step {first}")
    checks = [(2e-3, 1e-4), (2e-3, 3e-3), (3e-2, 3e-4), (0.3, 1e-4), (0.3, 3e-3), (3.0, 3e-5), (10.0, 2e-5)]
    runs = []
    print("   direct runs (kick on the beam tip, 200 steps): peak |payload force| first / last fifth")
    for mu, h in checks:
        system = platform_beam_system(mu)
        for s in schemes:
            r = spectral_radius(system, h, s)
            first, last, err = cosim_run(system, h, s)
            grew = err is not None or last > 10 * first
            runs.append((mu, h, s, r, first, last, err, grew))
            verdict = ("diverged: " + err.split(" (allowed")[0]) if err else ("grew" if grew else "bounded")
            print(f"      mu {mu:7.1e} h {h:7.1e} {s:12s} rho {r:9.5f}  {first:9.3e} -> {last:9.3e}  {verdict}")

    def draw(plt, path):
        fig, axs = plt.subplots(1, 2, figsize=(11, 4.6), sharey=True)
        for ax, s in zip(axs, schemes):
            cs = ax.contourf(steps, ratios, np.minimum(rho[s], 10.0),
                             levels=[0, 1 + STABILITY_TOLERANCE, 1.01, 1.1, 2, 10.01],
                             colors=["#cfe8cf", "#fde0c5", "#f8b98b", "#ef7d57", "#c0392b"])
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.axhline(mu_rigid, color="k", ls="--", lw=1, label=f"instantaneous loop |λ| = 1: μ = {mu_rigid:.2f}")
            for mu, h, sc, r, first, last, err, grew in runs:
                if sc == s:
                    ax.plot(h, mu, "kx" if grew else "ko", ms=8, mfc="none" if not grew else None)
            ax.plot([], [], "ko", mfc="none", label="direct run bounded")
            ax.plot([], [], "kx", label="direct run diverged / grew")
            ax.set_xlabel("communication step h (s)")
            ax.set_title(f"{s} master")
        axs[0].set_ylabel("mass ratio μ = beam mass / platform mass (–)")
        cb = fig.colorbar(cs, ax=axs, ticks=[0, 1, 1.01, 1.1, 2, 10], format="%g")
        cb.set_label("spectral radius of the coupled step (green: ≤ 1, stable)")
        handles, labels = axs[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.45, 0.0), ncol=3, fontsize=9)
        fig.suptitle("Co-simulation coupling: FFRBeam on a rigid platform, stable (green) and unstable regions")
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
    chart = _chart(figures, "stability_cosim.png", draw)
    return {"ratios": ratios, "steps": steps, "rho": rho, "runs": runs, "mu_rigid": mu_rigid, "chart": chart}


# =========================================================================== 4. 3D tumbling
def tumbling_drift(scheme: str, dt: float, t_end: float = 2.0, spin: float = 8.0, n_modes: int = 3,
                   n_records: int = 40, elements=BEAM_ELEMENTS, perturbation: float = 0.05):
    """Free rod (undamped modes) spinning at ``spin`` rad/s about its intermediate principal axis with a
    ``perturbation`` (relative) about the major one, so that it tumbles (the intermediate axis flips):
    max over n_records times of |L(t) - L(0)| / |L(0)| (global angular momentum from M and the nodal
    state), of |E(t) - E(0)| / E(0) (E = T + V from M, K), and the largest angle (degrees) the body's
    intermediate axis turned away from its initial global direction."""
    structure = beam(elements)
    basis = modal_basis(structure, n_modes, damping_ratio=0.0)
    _, axes = principal_axes(structure)
    w0 = spin * (axes[:, 1] + perturbation * axes[:, 2])
    integ = ReframeIntegrator(structure, basis, scheme=scheme)
    s = integ.initial_state(omega0=w0)
    L0, E0 = global_momentum_and_energy(integ, structure, s)
    n_total = int(round(t_end / dt))
    chunk = max(1, n_total // n_records)
    dL = dE = flip = 0.0
    done = 0
    while done < n_total:
        k = min(chunk, n_total - done)
        s = integ.advance_steps(s, dt, k)
        done += k
        L, E = global_momentum_and_energy(integ, structure, s)
        dL = max(dL, float(np.linalg.norm(L - L0) / np.linalg.norm(L0)))
        dE = max(dE, abs(E - E0) / E0)
        axis_now = s.rotation @ axes[:, 1]
        flip = max(flip, math.degrees(math.acos(max(-1.0, min(1.0, float(axis_now @ axes[:, 1]))))))
    return dL, dE, flip


def study_tumbling(figures: Path) -> dict:
    dts = np.array([1.5e-3, 7.5e-4, 3.75e-4, 1.875e-4, 9.375e-5, 4.6875e-5])
    res = {s: np.array([tumbling_drift(s, float(dt)) for dt in dts]) for s in ("paper", "consistent")}
    print("\n== 4. 3D tumbling: rod, 3 undamped modes, 8 rad/s about the intermediate axis (+5 % about the "
          "major), 2 s; max relative drift over 40 records")
    print(f"   {'dt (s)':>9} {'paper dL':>10} {'consistent dL':>14} {'paper dE':>10} {'consistent dE':>14} "
          f"{'flip (deg)':>10}")
    for k, dt in enumerate(dts):
        print(f"   {dt:9.3e} {res['paper'][k, 0]:10.3e} {res['consistent'][k, 0]:14.3e} {res['paper'][k, 1]:10.3e} "
              f"{res['consistent'][k, 1]:14.3e} {res['consistent'][k, 2]:10.1f}")
    local = {name: [math.log2(res[sch][k, col] / res[sch][k + 1, col]) for k in range(len(dts) - 1)]
             for name, sch, col in (("paper dL", "paper", 0), ("paper dE", "paper", 1),
                                    ("consistent dE", "consistent", 1))}
    for name, orders in local.items():
        print(f"   local orders {name:14s}: " + ", ".join(f"{o:5.2f}" for o in orders))
    # fitted slopes: paper over its four largest steps (below them its drift grows again: it converges to
    # its own limit, defect (d) of docs/reframe.md); consistent energy over its three smallest steps (the
    # largest have dt * omega_max = 2.6 and 1.3: pre-asymptotic)
    slopes = {"paper dL": slope(dts[:4], res["paper"][:4, 0]), "paper dE": slope(dts[:4], res["paper"][:4, 1]),
              "consistent dE": slope(dts[3:], res["consistent"][3:, 1])}
    print("   fitted slopes: " + ", ".join(f"{k} {v:.2f}" for k, v in slopes.items()) + "; consistent dL: rounding")
    def draw(plt, path):
        fig, ax = plt.subplots(figsize=(7, 4.8))
        ax.loglog(dts, res["paper"][:, 0], "o-", color="C0",
                  label=f"paper: angular momentum (slope {slopes['paper dL']:.2f}, 4 largest dt)")
        ax.loglog(dts, res["paper"][:, 1], "s--", color="C0", mfc="none",
                  label=f"paper: energy (slope {slopes['paper dE']:.2f}, 4 largest dt)")
        ax.loglog(dts, res["consistent"][:, 0], "o-", color="C1", label="consistent: angular momentum (rounding)")
        ax.loglog(dts, res["consistent"][:, 1], "s--", color="C1", mfc="none",
                  label=f"consistent: energy (slope {slopes['consistent dE']:.2f}, 3 smallest dt)")
        ax.set_xlabel("time step dt (s)")
        ax.set_ylabel("max relative drift over 2 s (–)")
        ax.set_title("3D tumbling (free bent rod, spin about the intermediate axis):\n"
                     "drift of the global angular momentum and of the energy")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)
    chart = _chart(figures, "stability_tumbling.png", draw)
    return {"dts": dts, **res, "slopes": slopes, "chart": chart}


STUDIES = {"rk4": study_rk4, "rotation": study_rotation, "cosim": study_cosim, "tumbling": study_tumbling}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", choices=sorted(STUDIES), action="append", help="run only these studies")
    parser.add_argument("--out", type=Path, default=None, metavar="REPORT.md",
                        help="also write the printed tables and the charts' links as a Markdown report; the charts "
                             "then go to figures/ beside it (default: no report)")
    parser.add_argument("--figures", type=Path, default=None, metavar="DIR",
                        help="folder for the PNGs (default: figures/ beside --out; without --out docs/figures of a "
                             "source checkout, else ./figures)")
    parser.add_argument("--quick", action="store_true", help="skip the co-simulation map (the slowest study)")
    args = parser.parse_args(argv)
    figures = args.figures or common.figures_dir(args.out)
    charts = []
    with common.recording() as printed:
        for name in args.only or [n for n in STUDIES if not (args.quick and n == "cosim")]:
            t0 = time.perf_counter()
            charts.append(STUDIES[name](figures).get("chart"))
            print(f"   ({name}: {time.perf_counter() - t0:.0f} s)")
    if args.out is not None and str(args.out) != "-":
        path = common.write_text_report(
            args.out, "Stability studies" + (" (--quick)" if args.quick else ""),
            "Written by `flexfmu bench stability` (flexfmu.studies.stability); docs/stability.md explains the "
            "studies and quotes a full run.", printed.getvalue(), charts)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
