"""Stability study 3 (flexfmu.studies.stability), co-simulation coupling: FFRBeam on a rigid Platform, explicit
force/motion coupling: spectral radius of the linearised co-simulation step over mass ratio x communication step,
both master schemes, cross-checked by direct runs (stability_cosim.png)."""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from flexfmu.errors import FlexfmuError
from flexfmu.studies.stability_common import draw_chart

AXES = "xyz"


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
    chart = draw_chart(figures, "stability_cosim.png", draw)
    return {"ratios": ratios, "steps": steps, "rho": rho, "runs": runs, "mu_rigid": mu_rigid, "chart": chart}
