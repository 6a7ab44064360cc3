"""Stability study 2 (flexfmu.studies.stability), large rotation: a free rod spinning about its major principal
axis: relative change of the distance between its two ends against the rotation angle, fixed-frame linear
baseline, reframe (both schemes) and the baseline's analytic stretch (stability_rotation.png)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.integrator import FixedFrameBaseline, ReframeIntegrator
from flexfmu.studies.stability_common import BEAM_ELEMENTS, beam, draw_chart, principal_axes


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
    r["chart"] = draw_chart(figures, "stability_rotation.png", draw)
    return r
