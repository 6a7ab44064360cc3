#!/usr/bin/env python3
"""The wave-energy converter's studies (docs/wave_converter.md): each writes a chart into docs/figures/
(or --figures) and prints its numbers.

    python examples/wave_converter/studies.py tuning    [--serial | --scheduler ADDRESS] [--backend fmu|library]
    python examples/wave_converter/studies.py stability
    python examples/wave_converter/studies.py energy
    python examples/wave_converter/studies.py run       [--fmu-dir dist]

tuning:    harvested power against wave period for XFF, XFX, FXF (one co-simulation per case, on a Dask
           LocalCluster by default), plus the harvester's own base-excitation response over a wide band.
stability: spectral radius of the linearised coupled step against the communication step (both schemes),
           the first unstable step, and direct runs on either side of it.
energy:    the energy balance's residual against the step (both schemes).
run:       the example through the FMUs (fmpy master, Gauss-Seidel, 1 ms): motion and power chart.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SYSTEM = HERE / "OspSystemStructure.xml"
BOUNDARIES = ("XFF", "XFX", "FXF")
COLORS = {"XFF": "tab:blue", "XFX": "tab:red", "FXF": "tab:green"}
PERIODS = (0.6, 0.8, 1.0, 1.2, 1.3, 1.4, 1.5, 1.6, 1.8, 2.0, 2.5, 3.0)


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def harvester_response(boundary: str, periods, damping: float) -> np.ndarray:
    """Mean harvested power (W) of the harvester alone, its base shaken harmonically with 1 m/s^2
    amplitude, averaged over the three axes (steady state of the clamped modal model with the PTO
    damper at the harvester point and the modal damping of the system file)."""
    from flexfmu.cosim.masters import LibrarySlave, load_system
    from flexfmu.ffr.simulator import FFRBeamSimulator
    from flexfmu.wec.system import harvester_values

    system = load_system(SYSTEM)
    spec = system.by_model("FFRBeam")[0]
    cfg = LibrarySlave(spec).config
    vals = harvester_values(boundary, cfg.scene)["FFRBeam"]
    dyn = FFRBeamSimulator(type(cfg)(**{**cfg.__dict__, **vals})).dynamics
    phi = dyn.sensor_map                                        # (3, m)
    out = []
    for T in periods:
        w = 2 * math.pi / T
        Z = -w**2 * np.eye(dyn.m) + 1j * w * (np.diag(dyn.damping) + damping * phi.T @ phi) + np.diag(dyn.stiffness)
        p = 0.0
        for axis in range(3):
            eta = np.linalg.solve(Z, -dyn.F_a0[:, axis])
            v = 1j * w * (phi @ eta)
            p += 0.5 * damping * float(np.real(v.conj() @ v)) / 3
        out.append(p)
    return np.array(out)


def tuning(args) -> int:
    from flexfmu.cosim.masters import load_system
    from flexfmu.wec.roles import roster
    from flexfmu.wec.system import Case, sweep, write_table

    cases = [Case(b, "regular", args.wave_height, T) for b in BOUNDARIES for T in PERIODS]
    scheduler = None if args.serial else (args.scheduler or "local")
    start = time.perf_counter()
    rows = sweep(SYSTEM, cases, args.t_end, args.step, "gauss-seidel", args.backend,
                 fmu_dir=args.fmu_dir, scheduler=scheduler, n_workers=args.workers, progress=True)
    print(f"{len(rows)} co-simulations in {time.perf_counter() - start:.0f} s "
          f"({'serial' if scheduler is None else 'Dask ' + scheduler})")
    table = write_table(rows, HERE / "tuning_results.csv")
    print(f"wrote {table}")
    for r in rows:
        print(f"{r['boundary']} T = {r['wave_period']:4.2f} s  P = {r['mean_power_W']:.4g} W  heave {r['heave_amplitude_m']:.4g} m  "
              f"pitch {math.degrees(r['pitch_amplitude_rad']):.3g} deg  residual {100 * r['energy_residual']:+.3f} %")
    damping = roster(load_system(SYSTEM)).one("pto").config.damping

    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    for b in BOUNDARIES:
        sel = [r for r in rows if r["boundary"] == b]
        f1 = sel[0]["f_1_Hz"]
        ax[0].semilogy([r["wave_period"] for r in sel], [r["mean_power_W"] for r in sel], "o-", color=COLORS[b],
                       label=f"{b} (f1 = {f1:.1f} Hz)")
    ax[0].set_xlabel("wave period T (s)")
    ax[0].set_ylabel("mean harvested power (W)")
    ax[0].set_title(f"co-simulation: regular waves H = {args.wave_height:g} m, heading 30 deg", fontsize=10)
    ax[0].grid(alpha=0.3, which="both")
    ax[0].legend(fontsize=8)
    periods = np.geomspace(2e-3, 5.0, 1500)
    for b in BOUNDARIES:
        ax[1].loglog(periods, harvester_response(b, periods, damping), color=COLORS[b], label=b)
    ax[1].axvspan(min(PERIODS), max(PERIODS), color="0.85", label="wave periods of the left panel")
    ax[1].set_xlabel("excitation period (s)")
    ax[1].set_ylabel("mean harvested power (W) per (1 m/s$^2$)$^2$")
    ax[1].set_title("the harvester alone: base shaken at 1 m/s$^2$ (axis average)", fontsize=10)
    ax[1].grid(alpha=0.3, which="both")
    ax[1].legend(fontsize=8)
    fig.suptitle(f"frequency tuning by the clamps: spatial double-L harvester, PTO c = {damping:g} N s/m at the "
                 "free tip (XFX: second corner)", fontsize=11)
    fig.tight_layout()
    path = Path(args.figures) / "wave_tuning.png"
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")
    return 0


def stability(args) -> int:
    from flexfmu.cosim.masters import load_system, run, spectral_radius

    system = load_system(SYSTEM)
    hs = np.geomspace(2e-4, 0.15, args.points)
    results = {}
    for scheme in ("gauss-seidel", "jacobi"):
        start = time.perf_counter()
        rho = np.array([spectral_radius(system, float(h), scheme) for h in hs])
        first = next((h for h, r in zip(hs, rho) if r > 1 + 1e-6), None)
        # refine the first unstable step by bisection
        if first is not None:
            i = int(np.argmax(hs == first))
            lo, hi = hs[i - 1], first
            while hi - lo > 0.005 * lo:
                mid = math.sqrt(lo * hi)
                if spectral_radius(system, mid, scheme) > 1 + 1e-6:
                    hi = mid
                else:
                    lo = mid
            first = (lo, hi)
        results[scheme] = (rho, first)
        print(f"{scheme}: first unstable step between {first[0] * 1e3:.4g} and {first[1] * 1e3:.4g} ms "
              f"({time.perf_counter() - start:.0f} s)")
    nopto = system.with_values({"pto": {"damping": 0.0}})
    rho_nopto = {s: np.array([spectral_radius(nopto, float(h), s) for h in hs]) for s in ("gauss-seidel", "jacobi")}
    first_nopto = {}
    for s in rho_nopto:
        first_nopto[s] = next((h for h, r in zip(hs, rho_nopto[s]) if r > 1 + 1e-6), float("nan"))
        print(f"{s}, PTO damping 0: first unstable step on the grid {first_nopto[s] * 1e3:.4g} ms")
    # direct runs on either side of each limit, started suddenly (no ramp: every harvester mode is
    # excited): growth of the harvester point velocity
    sudden = system.with_values({"wave": {"ramp_time": 0.0}})
    for scheme, (rho, (lo, hi)) in results.items():
        for h in (0.9 * lo, 1.15 * hi):
            h = round(h * 1e6) / 1e6
            try:
                r = run(sudden, round(3.0 / h) * h, h, scheme=scheme, backend="library")
                v = np.abs(r["harvester.sensor_v_z"])
                n = len(v) // 6
                print(f"  direct run {scheme} h = {h * 1e3:.3f} ms: max |v_tip,z| first 0.5 s {v[:n].max():.3g}, "
                      f"last 0.5 s {v[-n:].max():.3g} m/s")
            except Exception as exc:     # divergence is reported as an error
                print(f"  direct run {scheme} h = {h * 1e3:.3f} ms: {exc}")

    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 4.8))
    for scheme, color in (("gauss-seidel", "tab:blue"), ("jacobi", "tab:orange")):
        rho, (lo, hi) = results[scheme]
        ax.semilogx(hs * 1e3, rho, "-", color=color, lw=1.5, label=f"{scheme}: first unstable at {hi * 1e3:.3g} ms")
        ax.semilogx(hs * 1e3, rho_nopto[scheme], ":", color=color, lw=1.5,
                    label=f"{scheme}, PTO off: first unstable at {first_nopto[scheme] * 1e3:.3g} ms")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axvline(system.base_step * 1e3, color="0.4", ls="--", lw=1, label=f"example step {system.base_step * 1e3:g} ms")
    ax.set_xlabel("communication step h (ms)")
    ax.set_ylabel("spectral radius of the linearised coupled step")
    ax.set_ylim(0.995, 1.12)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title("coupling stability of the wave-energy converter (> 1: unstable)", fontsize=11)
    fig.tight_layout()
    path = Path(args.figures) / "wave_stability.png"
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")
    return 0


def energy(args) -> int:
    from flexfmu.cosim.masters import load_system, run
    from flexfmu.wec.system import beam_recorder, energy_balance

    system = load_system(SYSTEM)
    for scheme, steps in (("gauss-seidel", (2e-3, 1e-3, 5e-4)), ("jacobi", (1e-3, 5e-4))):
        for h in steps:
            start = time.perf_counter()
            r = run(system, args.t_end, h, scheme=scheme, backend="library", record=beam_recorder(system))
            b = energy_balance(r, system)
            print(f"{scheme:12s} h = {h * 1e3:5.3f} ms: residual {100 * b.relative_residual:+.4f} % of the wave work "
                  f"{b.wave_work:.4g} J; hydro interface {b.diagnostics['hydro interface: work_hydro + dPE + radiated']:+.4g} J "
                  f"({time.perf_counter() - start:.0f} s)", flush=True)
            if scheme == "gauss-seidel" and h == 1e-3:
                print(b.table())
    return 0


def example_run(args) -> int:
    from flexfmu.cosim.masters import load_system, run
    from flexfmu.wec.system import energy_balance, plot_result, summary

    system = load_system(SYSTEM, fmu_dir=args.fmu_dir)
    r = run(system, args.t_end, None, scheme="gauss-seidel", backend="fmu", progress=True)
    print(summary(r, system))
    print(energy_balance(r, system).table())
    path = plot_result(r, system, Path(args.figures) / "wave_converter_run.png")
    print(f"wrote {path}")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", choices=("tuning", "stability", "energy", "run"))
    parser.add_argument("--figures", default=str(ROOT / "docs" / "figures"), help="chart folder")
    parser.add_argument("--t-end", type=float, default=20.0, help="co-simulated time per run, s (default 20)")
    parser.add_argument("--step", type=float, default=None, help="communication step (default: the file's)")
    parser.add_argument("--wave-height", type=float, default=0.05)
    parser.add_argument("--serial", action="store_true", help="tuning: run serially, without Dask")
    parser.add_argument("--scheduler", default=None, help="tuning: a Dask scheduler address (default: LocalCluster)")
    parser.add_argument("--workers", type=int, default=2, help="tuning: LocalCluster workers")
    parser.add_argument("--backend", choices=("library", "fmu"), default="library")
    parser.add_argument("--fmu-dir", default=str(ROOT / "dist"))
    parser.add_argument("--points", type=int, default=120, help="stability: steps on the scan grid")
    args = parser.parse_args(argv)
    return {"tuning": tuning, "stability": stability, "energy": energy, "run": example_run}[args.study](args)


if __name__ == "__main__":
    sys.exit(main())
