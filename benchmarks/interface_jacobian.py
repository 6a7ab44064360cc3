#!/usr/bin/env python3
"""The interface-Jacobian coupling scheme (flexfmu.cosim.coupling) against Jacobi and Gauss-Seidel
(docs/stability.md, "Interface-Jacobian coupling"): prints the measured numbers, draws
docs/figures/stability_interface_jacobian.png.

    .venv/bin/python benchmarks/interface_jacobian.py [--figures docs/figures] [--skip-mass-ratio]

1. The wave-energy converter (examples/wave_converter/OspSystemStructure.xml, library façades): the step limit of
   each scheme (flexfmu.cosim.masters.step_limit), the spectral radii at 2x and 5x the Gauss-Seidel limit, direct
   runs there (started without the wave ramp so that every mode of the harvester is excited: bounded or diverged),
   and the error of each scheme against a 0.1 ms Gauss-Seidel reference over the communication step.
2. The harvester's inertial loop alone: FFRBeam on a rigid Platform (flexfmu.studies.stability_cosim, docs/
   stability.md study 3) over the mass ratio beam / platform: the step limit of each scheme.
About 10 minutes on 2 cores.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
SCHEMES = ("gauss-seidel", "jacobi", "interface-jacobian")
COLORS = {"gauss-seidel": "tab:blue", "jacobi": "tab:orange", "interface-jacobian": "tab:green"}
DASHES = {"gauss-seidel": "--", "jacobi": "--", "interface-jacobian": ":"}   # GS and IJ limits may coincide
REFERENCE_STEP = 1e-4                      # s, Gauss-Seidel
ERROR_STEPS = (2.5e-4, 5e-4, 1e-3, 2e-3, 4e-3)
ERROR_T_END = 2.0                          # s: every error step divides it, and their common times are every 4 ms
ERROR_OUTPUTS = ("platform.pos_z", "harvester.sensor_v_z")
RUN_T_END = 3.0                            # s: the direct runs at 2x and 5x the Gauss-Seidel limit
MASS_RATIOS = (0.03, 0.3, 1.0, 3.0, 10.0)


def limits(system, label: str) -> dict:
    from flexfmu.cosim.masters import step_limit

    found = {}
    for scheme in SCHEMES:
        start = time.perf_counter()
        try:
            found[scheme] = step_limit(system, scheme, h_min=1e-5 if label != "wave" else 1e-4,
                                       h_max=0.1 if label != "wave" else 0.5)
        except Exception as exc:     # noqa: BLE001 - "unstable even at h_min" is a result here
            found[scheme] = 0.0
            print(f"  {label} {scheme}: {exc}")
        print(f"  {label} {scheme}: step limit {found[scheme] * 1e3:.4g} ms ({time.perf_counter() - start:.0f} s)",
              flush=True)
    return found


def direct_run(system, h: float, scheme: str):
    """(peak |tip velocity z| in the first and the last sixth, the divergence message or None), no wave ramp."""
    from flexfmu.cosim.masters import run
    from flexfmu.errors import FlexfmuError

    sudden = system.with_values({"wave": {"ramp_time": 0.0}})
    try:
        r = run(sudden, round(RUN_T_END / h) * h, h, scheme=scheme, backend="library")
    except FlexfmuError as exc:
        return None, None, str(exc)
    v = np.abs(r["harvester.sensor_v_z"])
    n = max(1, len(v) // 6)
    return float(v[:n].max()), float(v[-n:].max()), None


def errors(system) -> dict:
    """{scheme: {output: [relative max error at each of ERROR_STEPS (inf: diverged)]}} against the reference."""
    from flexfmu.cosim.masters import run
    from flexfmu.errors import FlexfmuError

    start = time.perf_counter()
    ref = run(system, ERROR_T_END, REFERENCE_STEP, scheme="gauss-seidel", backend="library")
    print(f"  reference: Gauss-Seidel at {REFERENCE_STEP * 1e3:g} ms, {ERROR_T_END:g} s "
          f"({time.perf_counter() - start:.0f} s)", flush=True)
    common = max(ERROR_STEPS)
    every_ref = int(round(common / REFERENCE_STEP))
    out = {s: {o: [] for o in ERROR_OUTPUTS} for s in SCHEMES}
    for scheme in SCHEMES:
        for h in ERROR_STEPS:
            start = time.perf_counter()
            try:
                r = run(system, ERROR_T_END, h, scheme=scheme, backend="library")
            except FlexfmuError:
                r = None
            cost = (time.perf_counter() - start) / (ERROR_T_END / h)
            every = int(round(common / h))
            texts = []
            for o in ERROR_OUTPUTS:
                y_ref = ref[o][::every_ref]
                e = math.inf if r is None else float(np.abs(r[o][::every] - y_ref).max() / np.abs(y_ref).max())
                out[scheme][o].append(e)
                texts.append(f"{o} {e:.3g}")
            print(f"  {scheme:18s} h = {h * 1e3:5.2f} ms: relative max error {', '.join(texts)} "
                  f"({cost * 1e3:.2f} ms per step)", flush=True)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    parser.add_argument("--skip-mass-ratio", action="store_true", help="leave out part 2 (about 3 minutes)")
    args = parser.parse_args(argv)
    from flexfmu.cosim.masters import STABILITY_TOLERANCE, load_system, spectral_radius

    t0 = time.perf_counter()
    system = load_system(SYSTEM)
    print("== 1. the wave-energy converter (library façades)")
    found = limits(system, "wave")
    nopto = system.with_values({"pto": {"damping": 0.0}})
    print("  with the PTO off (damping 0): the spectral radius at 20 ms (below the hydrostatic limit, above the "
          "PTO-rod one)")
    for scheme in SCHEMES:
        print(f"    {scheme}: {spectral_radius(nopto, 0.02, scheme):.6f}")
    gs = found["gauss-seidel"]
    print(f"  spectral radius at 2x and 5x the Gauss-Seidel limit ({gs * 1e3:.4g} ms), and direct runs there "
          f"({RUN_T_END:g} s, no ramp: peak |harvester sensor_v_z| in the first and the last sixth):")
    at_multiples = {}
    for factor in (2, 5):
        h = round(factor * gs * 1e6) / 1e6
        for scheme in SCHEMES:
            rho = spectral_radius(system, h, scheme)
            first, last, failed = direct_run(system, h, scheme)
            run_text = (f"diverged ({failed.split(':', 1)[-1].strip()[:60]})" if failed else
                        f"{first:.3g} -> {last:.3g} m/s, {'bounded' if last <= first else 'growing'}")
            verdict = "stable" if rho <= 1 + STABILITY_TOLERANCE else "unstable"
            at_multiples[(factor, scheme)] = rho
            print(f"    {factor}x = {h * 1e3:.3f} ms {scheme:18s}: spectral radius {rho:.6f} ({verdict}); run "
                  f"{run_text}", flush=True)
    print("  error against the reference over the step:")
    errs = errors(system)

    ratios = {}
    if not args.skip_mass_ratio:
        from flexfmu.studies.stability_cosim import instantaneous_loop_radius, platform_beam_system
        print("== 2. FFRBeam on a rigid Platform (no water): step limit over the mass ratio beam / platform")
        for mu in MASS_RATIOS:
            print(f"  mass ratio {mu:g} (instantaneous added-mass loop radius {instantaneous_loop_radius(mu):.3f})")
            ratios[mu] = limits(platform_beam_system(mu), f"mu = {mu:g}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker  # noqa: F401 - matplotlib.ticker.NullFormatter below

    panels = len(ERROR_OUTPUTS) + (1 if ratios else 0)
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.6))
    hs = np.array(ERROR_STEPS) * 1e3
    for ax, o in zip(axes, ERROR_OUTPUTS):
        top = max(e for s in SCHEMES for e in errs[s][o] if math.isfinite(e)) * 3
        for scheme in SCHEMES:
            e = np.array(errs[scheme][o])
            ok = np.isfinite(e)
            ax.loglog(hs[ok], e[ok], "o-", color=COLORS[scheme], label=scheme)
            if (~ok).any():
                ax.loglog(hs[~ok], np.full((~ok).sum(), top), "x", color=COLORS[scheme], ms=10, mew=2,
                          label=f"{scheme}: diverged")
            ax.axvline(found[scheme] * 1e3, color=COLORS[scheme], ls=DASHES[scheme], lw=1.2,
                       label=f"{scheme} step limit {found[scheme] * 1e3:.3g} ms")
        ax.set_xticks(hs, [f"{h:g}" for h in hs])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("communication step h (ms)")
        ax.set_ylabel("max |y - y_ref| / max |y_ref|")
        ax.set_title(f"wave converter, {o}\nvs Gauss-Seidel at {REFERENCE_STEP * 1e3:g} ms, {ERROR_T_END:g} s",
                     fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    if ratios:
        ax = axes[-1]
        mus = np.array(MASS_RATIOS)
        for scheme, floor in zip(SCHEMES, (1.3e-2, 1.0e-2, None)):
            lim = np.array([ratios[mu][scheme] for mu in MASS_RATIOS])
            ok = lim > 0
            ax.loglog(mus[ok], lim[ok] * 1e3, "o-", color=COLORS[scheme], label=scheme)
            if (~ok).any():
                ax.loglog(mus[~ok], np.full((~ok).sum(), floor), "v", color=COLORS[scheme], ms=9,
                          label=f"{scheme}: unstable at every step (from 1e-5 s)")
        mu_loop = 1.0 / instantaneous_loop_radius(1.0)
        ax.axvline(mu_loop, color="k", ls=":", lw=1, label=f"added-mass loop gain 1 (mass ratio {mu_loop:.2f})")
        ax.set_xlabel("mass ratio beam / platform")
        ax.set_ylabel("step limit (ms)")
        ax.set_title("FFRBeam on a rigid platform: the inertial loop alone", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8, loc="upper right")        # the curves fall from the upper left
    fig.suptitle("interface-Jacobian coupling against Jacobi and Gauss-Seidel", fontsize=11)
    fig.tight_layout()
    args.figures.mkdir(parents=True, exist_ok=True)
    path = args.figures / "stability_interface_jacobian.png"
    fig.savefig(path, dpi=110)
    print(f"wrote {path} ({time.perf_counter() - t0:.0f} s in all)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
