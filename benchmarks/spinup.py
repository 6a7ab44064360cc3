#!/usr/bin/env python3
"""Spin-up study (Kane, Ryan & Banerjee 1987): FFR and reframe models with and without geometric stiffening
against the geometrically exact Exudyn reference (tests/reference/spinup/trajectory.csv).

    .venv/bin/python benchmarks/spinup.py              # ~20 s: table on stdout, docs/figures/spinup_*.png
    .venv/bin/python benchmarks/spinup.py --no-figure  # table only

Metric: max_t |v - v_ref| / max_t |v_ref| over 0-20 s (peak |v_ref| = 0.5738 m).  Each method is also run at
half the step (dt / 2) and with more modes, to show that the numbers quoted are converged.  Times are CPU
seconds of one run on this machine (indicative only; the study is about accuracy and failure, not speed).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "model"))

from flexfmu.studies import spinup  # noqa: E402

REFERENCE = ROOT / "tests" / "reference" / "spinup" / "trajectory.csv"
FIGURES = ROOT / "docs" / "figures"
DT = 0.01

# (label, runner, keyword arguments): the four comparisons of the figure, then the convergence checks.
RUNS = [
    ("FFR", spinup.run_ffr, {"geometric_stiffening": False}),
    ("FFR", spinup.run_ffr, {"geometric_stiffening": True}),
    ("reframe", spinup.run_reframe, {"geometric_stiffening": False}),
    ("reframe", spinup.run_reframe, {"geometric_stiffening": True}),
]
CHECKS = [
    ("FFR, dt/2", spinup.run_ffr, {"geometric_stiffening": True, "dt": DT / 2}),
    ("FFR, 14 modes, 32 elements", spinup.run_ffr, {"geometric_stiffening": True, "n_modes": 14, "elements": 32}),
    ("FFR, RK4 integrator", spinup.run_ffr, {"geometric_stiffening": True, "integrator": "rk4"}),
    ("reframe, dt/2", spinup.run_reframe, {"geometric_stiffening": True, "dt": DT / 2}),
    ("reframe, 12 flexible modes, 32 elements", spinup.run_reframe,
     {"geometric_stiffening": True, "n_flexible": 12, "elements": 32, "dt": DT / 2}),
    ("reframe, hub 10x lighter", spinup.run_reframe,
     {"geometric_stiffening": True, "hub_mass": spinup.HUB_MASS / 10, "hub_inertia": spinup.HUB_INERTIA / 10}),
    ("reframe, exponential scheme, dt = 0.05 s", spinup.run_reframe,
     {"geometric_stiffening": True, "scheme": "exponential", "dt": 0.05}),
]


def run_all(rows):
    out = []
    for label, runner, kwargs in rows:
        kw = {"dt": DT, **kwargs}
        t0 = time.process_time()
        result = runner(**kw)
        cpu = time.process_time() - t0
        out.append((label, kw, result, cpu))
    return out


def table(results, reference) -> str:
    lines = ["| method | stiffening | dt (s) | unstable from (s) | fails at (s) | max \\|v - v_ref\\| / peak, 0-20 s "
             "| leaves the 5 % band at (s) | peak v (m) at t (s) | hub angle / position error | CPU (s) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for label, kw, r, cpu in results:
        dev = spinup.deviation(r, reference)
        k = int(np.argmin(r.v_tip[r.t <= spinup.COMPARE_UNTIL])) if not r.failed else None
        hub = (f"{r.info['hub_angle_error']:.1e} rad / {r.info['hub_position_error']:.1e} m"
               if "hub_angle_error" in r.info else "clamped")
        lines.append("| " + " | ".join([
            label, "yes" if r.geometric_stiffening else "no", f"{kw['dt']:g}",
            "-" if r.unstable_from is None else f"{r.unstable_from:.2f}",
            "-" if r.failure_time is None else f"{r.failure_time:.2f}",
            "diverged" if not np.isfinite(dev) else f"{100 * dev:.3f} %",
            "-" if (t5 := spinup.leaves_band(r, reference)) is None else f"{t5:.2f}",
            "-" if k is None else f"{r.v_tip[k]:.4f} at {r.t[k]:.2f}",
            hub, f"{cpu:.1f}"]) + " |")
    ref_peak = int(np.argmin(reference.v_tip))
    lines.append(f"| reference (Exudyn ANCF) | exact | 6.25e-4 | - | - | 0 | - | {reference.v_tip[ref_peak]:.4f} at "
                 f"{reference.t[ref_peak]:.2f} | prescribed | - |")
    return "\n".join(lines)


def figure(results, reference, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # (colour, line style, width, alpha): the two unstiffened runs coincide, so the reframe one is drawn wide
    # and pale under the FFR one
    styles = {("FFR", False): ("tab:red", "--", 1.6, 1.0), ("FFR", True): ("tab:blue", "-", 1.6, 1.0),
              ("reframe", False): ("tab:orange", "-", 5.0, 0.45), ("reframe", True): ("tab:green", "-.", 1.6, 1.0)}
    fig, (ax, ax_err) = plt.subplots(2, 1, figsize=(9, 7.5), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    sel = reference.t <= spinup.COMPARE_UNTIL
    ax.plot(reference.t[sel], reference.v_tip[sel], color="black", lw=3.0, alpha=0.35,
            label="reference: Exudyn geometrically exact (ANCF)")
    for label, _, r, _ in results:
        color, ls, lw, alpha = styles[(label, r.geometric_stiffening)]
        text = f"{label}, {'with' if r.geometric_stiffening else 'without'} stiffening"
        if r.failed:
            text += f" (unstable from {r.unstable_from:.2f} s, |v| > {spinup.LENGTH:g} m at {r.failure_time:.2f} s)"
        else:
            text += f" ({100 * spinup.deviation(r, reference):.2f} % of peak)"
        ax.plot(r.t, r.v_tip, color=color, ls=ls, lw=lw, alpha=alpha, label=text)
        if not r.failed:     # the error at the reference's own sample times (every 0.05 s, on the run's grid)
            v = np.interp(reference.t[sel], r.t, r.v_tip)
            ax_err.plot(reference.t[sel], 1e3 * (v - reference.v_tip[sel]), color=color, ls=ls, lw=1.4,
                        label=f"{label} with stiffening - reference")
    onset = next(r.unstable_from for label, _, r, _ in results if label == "FFR" and r.failed)
    ax.axvline(onset, color="gray", lw=0.8, ls="--")
    ax.text(onset + 0.15, 0.22, f"hub rate = first bending\nfrequency 3.80 rad/s ({onset:.2f} s)", fontsize=8,
            color="gray")
    ax.set_ylim(-1.5, 0.45)
    fail = max(r.failure_time for _, _, r, _ in results if r.failed)
    ax.text(0.3, -1.42, f"without stiffening: off the chart, |v| > {spinup.LENGTH:g} m by {fail:.2f} s",
            fontsize=8, color="tab:red")
    ax.set_ylabel("tip deflection v in the hub frame (m)")
    ax.set_title("Spin-up of a cantilever (Kane, Ryan & Banerjee 1987): linear models vs geometrically exact")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    ax_err.axhline(0.0, color="black", lw=0.6)
    ax_err.set_xlabel("time t (s)")
    ax_err.set_ylabel("v - v_ref (mm)")
    ax_err.set_xlim(0, spinup.COMPARE_UNTIL)
    ax_err.legend(fontsize=8, loc="lower right")
    ax_err.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-figure", action="store_true", help="print the table only")
    ap.add_argument("--quick", action="store_true", help="skip the convergence and sensitivity runs")
    ap.add_argument("--out", type=Path, default=None, help="folder for the figure (default docs/figures)")
    args = ap.parse_args(argv)
    reference = spinup.load_reference(REFERENCE)
    results = run_all(RUNS)
    print(table(results, reference))
    if not args.quick:
        checks = run_all(CHECKS)
        print()
        print("Convergence and sensitivity (all with stiffening):")
        print(table(checks, reference))
    for label, _, r, _ in results:
        if r.failed:
            print(f"{label} without stiffening: {r.failure_reason}")
    if not args.no_figure:
        folder = args.out or FIGURES
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "spinup_tip_deflection.png"
        figure(results, reference, path)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
