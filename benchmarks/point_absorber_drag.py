#!/usr/bin/env python3
"""Viscous drag's effect on the point absorber (docs/wave_converter.md, "Drag"): the mean PTO power against the
regular wave's height, co-simulated with drag off and on, beside the linear frequency-domain prediction.

    .venv/bin/python benchmarks/point_absorber_drag.py [--period 6] [--heights 0.5,1,2,3,4,5,6]

The example system (examples/point_absorber/OspSystemStructure.xml) through the library master (Gauss-Seidel at the
file's 6.25 ms), PTO damping 6e5 N s/m, in three configurations: heave only without drag and mooring (the linear
model: its power grows as H^2, and must equal the frequency-domain prediction), heave only with drag (the
quadratic heave drag 1/2 rho Cd A |v| v, Cd 1, A = pi r^2, takes a share growing with the velocity: the power grows
slower than H^2), and the default configuration (six DOFs, drag, MoorDyn's lines).  Each run: the 20 s ramp, 60 s of
settling, then the mean over 4 whole periods (flexfmu.wec.absorber.verification's window).

Writes examples/point_absorber/drag_effect.csv and docs/figures/point_absorber_drag.png (power against H, and
the power over H^2, where the linear model is a horizontal line) and prints the table.
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
CSV = ROOT / "examples" / "point_absorber" / "drag_effect.csv"
CHART = ROOT / "docs" / "figures" / "point_absorber_drag.png"
DAMPING = 6.0e5
CONFIGURATIONS = {
    "heave only, no drag (linear)": ("float.heave_only=true", "hydro.drag=false", "mooring.enabled=false"),
    "heave only, drag": ("float.heave_only=true", "hydro.drag=true", "mooring.enabled=false"),
    "six DOF, drag, mooring (default)": ("float.heave_only=false", "hydro.drag=true", "mooring.enabled=true"),
}


def mean_power(assignments, height: float, period: float, n_periods: int = 4) -> tuple[float, float, float]:
    """(mean PTO power W, heave amplitude m, wall s) over n_periods whole periods after the ramp and settling."""
    from flexfmu.cosim.masters import load_system, run, with_assignments
    from flexfmu.wec.absorber.verification import SETTLE_TIME, SYSTEM_FILE
    system = load_system(SYSTEM_FILE)
    step = system.base_step
    ramp = 20.0
    system = with_assignments(system, tuple(assignments) + (
        "wave.sea_state=regular", f"wave.wave_height={height!r}", f"wave.wave_period={period!r}",
        f"wave.ramp_time={ramp!r}", f"pto.damping={DAMPING!r}", "pto.stiffness=0", "pto.force_limit=0"))
    n_per = int(round(period / step))
    k0 = int(math.ceil((ramp + SETTLE_TIME) / step - 1e-9))
    n = n_per * n_periods
    start = time.perf_counter()
    result = run(system, (k0 + n) * step, step, scheme="gauss-seidel", backend="library")
    wall = time.perf_counter() - start
    sel = slice(k0, k0 + n)
    z, t = result.columns["float.pos_z"][sel], result.t[sel]
    amplitude = abs(2 / n * np.sum(z * np.exp(-2j * math.pi / period * t)))
    return float(np.mean(result.columns["pto.power"][sel])), float(amplitude), wall


def plot(rows, period: float, path: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    heights = np.array(sorted({r["wave_height_m"] for r in rows}))
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    predicted = np.array([next(r["predicted_power_W"] for r in rows if r["wave_height_m"] == h) for h in heights])
    fine = np.linspace(0, heights.max(), 100)
    ax.plot(fine, predicted[-1] * (fine / heights[-1]) ** 2 / 1e3, "k-", lw=1, label="linear, frequency domain")
    ax2.axhline(predicted[-1] / heights[-1] ** 2 / 1e3, color="k", lw=1, label="linear, frequency domain")
    for label, style in zip(CONFIGURATIONS, ("o", "s", "^")):
        p = np.array([next(r["mean_power_W"] for r in rows if r["wave_height_m"] == h and r["configuration"] == label)
                      for h in heights])
        ax.plot(heights, p / 1e3, style + "--", ms=5, label=label)
        ax2.plot(heights, p / heights ** 2 / 1e3, style + "--", ms=5, label=label)
    ax.set_xlabel("wave height H (m)")
    ax.set_ylabel("mean PTO power (kW)")
    ax.set_title(f"regular waves, T = {period:g} s, PTO damping {DAMPING:.0e} N s/m", fontsize=9)
    ax2.set_xlabel("wave height H (m)")
    ax2.set_ylabel("mean PTO power / H$^2$ (kW/m$^2$)")
    ax2.set_title("the linear model is flat here; drag bends it down", fontsize=9)
    ax2.set_ylim(bottom=0)
    for a in (ax, ax2):
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--period", type=float, default=6.0, help="wave period, s (default 6)")
    parser.add_argument("--heights", default="0.5,1,2,3,4,5,6", help="wave heights, m")
    args = parser.parse_args(argv)
    from flexfmu.wec.absorber.frequency_domain import regular_wave_response
    from flexfmu.wec.absorber.hull import absorber_hull
    heights = [float(h) for h in args.heights.split(",")]
    rows = []
    print("| configuration | H (m) | heave amplitude (m) | mean power (kW) | linear prediction (kW) | ratio | wall (s) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for label, assignments in CONFIGURATIONS.items():
        for h in heights:
            power, amplitude, wall = mean_power(assignments, h, args.period)
            _, predicted = regular_wave_response(absorber_hull(), h, args.period, DAMPING)
            rows.append({"configuration": label, "wave_height_m": h, "wave_period_s": args.period,
                         "heave_amplitude_m": amplitude, "mean_power_W": power, "predicted_power_W": predicted})
            print(f"| {label} | {h:g} | {amplitude:.4g} | {power / 1e3:.4g} | {predicted / 1e3:.4g} | "
                  f"{power / predicted:.4f} | {wall:.1f} |", flush=True)
    CSV.parent.mkdir(parents=True, exist_ok=True)
    with CSV.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {CSV.relative_to(ROOT)} and {plot(rows, args.period, CHART).relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
