#!/usr/bin/env python3
"""The step-Jacobian coupling scheme on the wave-converter example against Gauss-Seidel and Jacobi: the error of a
run at each step against a small-step reference, and the spectral radius of the linearised step; a chart.

    .venv/bin/python benchmarks/step_jacobian.py [--t-end 2] [--plot docs/figures/stability_step_jacobian.png]

Library façades (flexfmu cosim --master library), examples/wave_converter/OspSystemStructure.xml as it is (its waves
ramp up over 3 s).  Reference: Gauss-Seidel at 0.1 ms.  Error: max |y - y_ref| / max |y_ref| at the coarse run's
points, for the platform's heave and the harvester rod's sensor velocity; a run that diverges is marked.  Prints
every number it draws (docs/stability.md, "Step-Jacobian coupling").
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
GS_STEP_LIMIT = 2.239e-3
STEPS = (1e-3, GS_STEP_LIMIT, 2 * GS_STEP_LIMIT, 5 * GS_STEP_LIMIT)
SCHEMES = ("gauss-seidel", "jacobi", "step-jacobian")
OUTPUTS = ("platform.pos_z", "harvester.sensor_v_z")


def run_error(system, h, scheme, t_end, reference):
    from flexfmu.cosim.masters import run
    from flexfmu.errors import FlexfmuError
    n = int(round(t_end / h))
    started = time.perf_counter()
    try:
        result = run(system, t_end=n * h, step=h, scheme=scheme, backend="library")
    except (FlexfmuError, FloatingPointError) as exc:
        return {name: np.inf for name in OUTPUTS}, time.perf_counter() - started, str(exc)[:80]
    errors = {}
    for name in OUTPUTS:
        y = result.columns[name]
        ref = np.interp(result.t, reference.t, reference.columns[name])
        scale = np.abs(reference.columns[name]).max()
        errors[name] = float(np.abs(y - ref).max() / scale) if np.all(np.isfinite(y)) else np.inf
    return errors, time.perf_counter() - started, None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=2.0)
    parser.add_argument("--plot", type=Path, default=ROOT / "docs" / "figures" / "stability_step_jacobian.png")
    args = parser.parse_args(argv)
    from flexfmu.cosim.masters import load_system, run, spectral_radius
    system = load_system(SYSTEM)
    horizon = 4 * np.ceil(args.t_end / 4 / (5 * GS_STEP_LIMIT)) * 5 * GS_STEP_LIMIT
    reference = run(system, t_end=round(horizon / 1e-4) * 1e-4, step=1e-4, scheme="gauss-seidel", backend="library")
    table = {}
    for scheme in SCHEMES:
        for h in STEPS:
            rho = spectral_radius(system, h, scheme)
            errors, seconds, failure = run_error(system, h, scheme, args.t_end, reference)
            table[scheme, h] = (rho, errors)
            shown = "  ".join(f"{k} {v:.3g}" for k, v in errors.items())
            print(f"{scheme:14s} h = {h * 1e3:7.3f} ms  spectral radius {rho:.6f}  {shown}  ({seconds:.1f} s)"
                  + (f"  [{failure}]" if failure else ""), flush=True)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, name in zip(axes[:2], OUTPUTS):
        for scheme, marker in zip(SCHEMES, "osD"):
            e = [table[scheme, h][1][name] for h in STEPS]
            shown = [min(v, 10.0) for v in e]
            ax.loglog([h * 1e3 for h in STEPS], shown, marker=marker, label=scheme)
            for h, v in zip(STEPS, e):
                if not np.isfinite(v) or v >= 10:
                    ax.annotate("diverged", (h * 1e3, 10.0), fontsize=7, ha="center", va="bottom")
        ax.set_title(f"{name}: error vs Gauss-Seidel at 0.1 ms")
        ax.set_xlabel("communication step (ms)")
        ax.set_ylabel("max |y - y_ref| / max |y_ref|")
        ax.axvline(GS_STEP_LIMIT * 1e3, color="grey", ls=":", lw=1)
        ax.axvline(2 * GS_STEP_LIMIT * 1e3, color="grey", ls="--", lw=1)
        ax.axvline(5 * GS_STEP_LIMIT * 1e3, color="grey", ls="-.", lw=1)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    ax = axes[2]
    for scheme, marker in zip(SCHEMES, "osD"):
        ax.semilogx([h * 1e3 for h in STEPS], [table[scheme, h][0] for h in STEPS], marker=marker, label=scheme)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_title("spectral radius of the linearised step")
    ax.set_xlabel("communication step (ms); grey: GS limit, 2x, 5x")
    ax.set_ylabel("spectral radius (> 1: unstable)")
    for k, ls in ((1, ":"), (2, "--"), (5, "-.")):
        ax.axvline(k * GS_STEP_LIMIT * 1e3, color="grey", ls=ls, lw=1)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.suptitle("Wave converter (library facades): step-Jacobian coupling against Gauss-Seidel and Jacobi")
    fig.tight_layout()
    args.plot.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.plot, dpi=110)
    print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
