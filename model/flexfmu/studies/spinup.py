"""The spin-up study (Kane, Ryan & Banerjee 1987; ``flexfmu bench spinup``, benchmarks/spinup.py): every model of
:mod:`flexfmu.studies.spinup_models` against the geometrically exact Exudyn reference, the convergence checks and
the figure of docs/spinup.md.

The problem, the models, the reference and the metric are importable from here too."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from flexfmu.studies import common
from flexfmu.studies.spinup_models import (COMPARE_UNTIL, HUB_INERTIA, HUB_MASS, LENGTH, deviation, leaves_band,
                                           load_reference, run_ffr, run_reframe)
# the rest of the problem and the models: code written before they had a module of their own imports them from here
from flexfmu.studies.spinup_models import (EA, EI, MATERIAL, OMEGA_S, REFERENCE, RHO_A, SECTION, T_S,  # noqa: F401
                                           HUB_BANDWIDTH, HUB_DAMPING, Reference, SpinupResult, ffr_model,
                                           hub_acceleration, hub_angle, hub_rate, hub_scene, kane_scene, reframe_model)


STUDY = """Spin-up study (Kane, Ryan & Banerjee 1987): FFR and reframe models with and without geometric stiffening
against the geometrically exact Exudyn reference (flexfmu/data/references/spinup/trajectory.csv).

    flexfmu bench spinup [--quick] [--out REPORT.md]   # ~20 s: table on stdout, figures/spinup_tip_deflection.png
    .venv/bin/python benchmarks/spinup.py --no-figure  # table only

Metric: max_t |v - v_ref| / max_t |v_ref| over 0-20 s (peak |v_ref| = 0.5738 m).  Each method is also run at
half the step (dt / 2) and with more modes, to show that the numbers quoted are converged.  Times are CPU
seconds of one run on this machine (indicative only; the study is about accuracy and failure, not speed).
"""
DT = 0.01

# (label, runner, keyword arguments): the four comparisons of the figure, then the convergence checks.
RUNS = [
    ("FFR", run_ffr, {"geometric_stiffening": False}),
    ("FFR", run_ffr, {"geometric_stiffening": True}),
    ("reframe", run_reframe, {"geometric_stiffening": False}),
    ("reframe", run_reframe, {"geometric_stiffening": True}),
]
CHECKS = [
    ("FFR, dt/2", run_ffr, {"geometric_stiffening": True, "dt": DT / 2}),
    ("FFR, 14 modes, 32 elements", run_ffr, {"geometric_stiffening": True, "n_modes": 14, "elements": 32}),
    ("FFR, RK4 integrator", run_ffr, {"geometric_stiffening": True, "integrator": "rk4"}),
    ("reframe, dt/2", run_reframe, {"geometric_stiffening": True, "dt": DT / 2}),
    ("reframe, 12 flexible modes, 32 elements", run_reframe,
     {"geometric_stiffening": True, "n_flexible": 12, "elements": 32, "dt": DT / 2}),
    ("reframe, hub 10x lighter", run_reframe,
     {"geometric_stiffening": True, "hub_mass": HUB_MASS / 10, "hub_inertia": HUB_INERTIA / 10}),
    ("reframe, exponential scheme, dt = 0.05 s", run_reframe,
     {"geometric_stiffening": True, "scheme": "exponential", "dt": 0.05}),
]


def run_all(rows):
    """[(label, keyword arguments, SpinupResult, CPU s)] of the rows (label, runner, keyword arguments)."""
    import time

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
        dev = deviation(r, reference)
        k = int(np.argmin(r.v_tip[r.t <= COMPARE_UNTIL])) if not r.failed else None
        hub = (f"{r.info['hub_angle_error']:.1e} rad / {r.info['hub_position_error']:.1e} m"
               if "hub_angle_error" in r.info else "clamped")
        lines.append("| " + " | ".join([
            label, "yes" if r.geometric_stiffening else "no", f"{kw['dt']:g}",
            "-" if r.unstable_from is None else f"{r.unstable_from:.2f}",
            "-" if r.failure_time is None else f"{r.failure_time:.2f}",
            "diverged" if not np.isfinite(dev) else f"{100 * dev:.3f} %",
            "-" if (t5 := leaves_band(r, reference)) is None else f"{t5:.2f}",
            "-" if k is None else f"{r.v_tip[k]:.4f} at {r.t[k]:.2f}",
            hub, f"{cpu:.1f}"]) + " |")
    ref_peak = int(np.argmin(reference.v_tip))
    lines.append(f"| reference (Exudyn ANCF) | exact | 6.25e-4 | - | - | 0 | - | {reference.v_tip[ref_peak]:.4f} at "
                 f"{reference.t[ref_peak]:.2f} | prescribed | - |")
    return "\n".join(lines)


def figure(results, reference, path: Path, plt) -> None:
    """The tip deflection of the four runs against the reference and their errors (``plt``: matplotlib.pyplot)."""
    # (colour, line style, width, alpha): the two unstiffened runs coincide, so the reframe one is drawn wide
    # and pale under the FFR one
    styles = {("FFR", False): ("tab:red", "--", 1.6, 1.0), ("FFR", True): ("tab:blue", "-", 1.6, 1.0),
              ("reframe", False): ("tab:orange", "-", 5.0, 0.45), ("reframe", True): ("tab:green", "-.", 1.6, 1.0)}
    fig, (ax, ax_err) = plt.subplots(2, 1, figsize=(9, 7.5), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    sel = reference.t <= COMPARE_UNTIL
    ax.plot(reference.t[sel], reference.v_tip[sel], color="black", lw=3.0, alpha=0.35,
            label="reference: Exudyn geometrically exact (ANCF)")
    for label, _, r, _ in results:
        color, ls, lw, alpha = styles[(label, r.geometric_stiffening)]
        text = f"{label}, {'with' if r.geometric_stiffening else 'without'} stiffening"
        if r.failed:
            text += f" (unstable from {r.unstable_from:.2f} s, |v| > {LENGTH:g} m at {r.failure_time:.2f} s)"
        else:
            text += f" ({100 * deviation(r, reference):.2f} % of peak)"
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
    ax.text(0.3, -1.42, f"without stiffening: off the chart, |v| > {LENGTH:g} m by {fail:.2f} s",
            fontsize=8, color="tab:red")
    ax.set_ylabel("tip deflection v in the hub frame (m)")
    ax.set_title("Spin-up of a cantilever (Kane, Ryan & Banerjee 1987): linear models vs geometrically exact")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    ax_err.axhline(0.0, color="black", lw=0.6)
    ax_err.set_xlabel("time t (s)")
    ax_err.set_ylabel("v - v_ref (mm)")
    ax_err.set_xlim(0, COMPARE_UNTIL)
    ax_err.legend(fontsize=8, loc="lower right")
    ax_err.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    """The spin-up study: tables on stdout, the figure, and with --out a Markdown report of both."""
    import argparse

    ap = argparse.ArgumentParser(description=STUDY,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-figure", action="store_true", help="print the table only")
    ap.add_argument("--quick", action="store_true", help="skip the convergence and sensitivity runs")
    ap.add_argument("--out", type=Path, default=None, metavar="REPORT.md",
                    help="also write the printed tables and the figure's link as a Markdown report; the figure "
                         "then goes to figures/ beside it (default: no report)")
    ap.add_argument("--figures", type=Path, default=None, metavar="DIR",
                    help="folder for the figure (default: figures/ beside --out; without --out docs/figures of "
                         "a source checkout, else ./figures)")
    args = ap.parse_args(argv)
    chart = None
    with common.recording() as printed:
        reference = load_reference()
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
            plt = common.pyplot()
            if plt is None:
                print(common.skipped("figure spinup_tip_deflection.png", "matplotlib"))
            else:
                folder = args.figures or common.figures_dir(args.out)
                folder.mkdir(parents=True, exist_ok=True)
                chart = folder / "spinup_tip_deflection.png"
                figure(results, reference, chart, plt)
                print(f"wrote {chart}")
    if args.out is not None and str(args.out) != "-":
        path = common.write_text_report(
            args.out, "Spin-up study" + (" (--quick)" if args.quick else ""),
            "Written by `flexfmu bench spinup` (flexfmu.studies.spinup); docs/spinup.md explains the study. "
            "Reference: flexfmu/data/references/spinup (Exudyn ANCF, see its README).", printed.getvalue(), [chart])
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
