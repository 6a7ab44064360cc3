#!/usr/bin/env python3
"""The wave-energy converter's studies (docs/wave_converter.md): each writes a chart into docs/figures/
(or --figures) and prints its numbers.

    python examples/wave_converter/studies.py tuning    [--serial | --scheduler ADDRESS] [--backend fmu|library]
    python examples/wave_converter/studies.py stability
    python examples/wave_converter/studies.py energy
    python examples/wave_converter/studies.py run       [--fmu-dir dist]
    python examples/wave_converter/studies.py harvest

tuning:    harvested power against wave period for XFF, XFX, FXF (one co-simulation per case, on a Dask
           LocalCluster by default), plus the harvester's own base-excitation response over a wide band.
stability: spectral radius of the linearised coupled step against the communication step (both schemes),
           the first unstable step, and direct runs on either side of it.
energy:    the energy balance's residual against the step (both schemes).
run:       the example through the FMUs (fmpy master, Gauss-Seidel, 1 ms): motion and power chart.
harvest:   the mean harvested power of the file's system (its hydrodynamics) in its regular wave, at T = 2 s, in a
           JONSWAP sea and for each boundary, against the quasi-static prediction: the rod's static compliance
           times the platform's acceleration at the mount, from the recorded motion and from the BEM RAO.
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


#: harvest: (boundary, sea state, H or Hs (m), T or Tp (s), run length (s)); the rest as in the file (heading 30 deg).
#: The box's roll has potential-flow damping only (resonance 1.49 s, next to the waves): its start transient takes
#: minutes to die out, hence the long runs (regular: mean over the last 20 s of 150 s; JONSWAP: over the whole
#: records in the second half of 600 s, within 2 % of each other from 250 s on).
HARVEST_CASES = (("XFF", "regular", 0.05, 1.4, 150.0), ("FXF", "regular", 0.05, 1.4, 150.0),
                 ("XFX", "regular", 0.05, 1.4, 150.0), ("XFF", "regular", 0.05, 2.0, 150.0),
                 ("XFF", "jonswap", 0.05, 1.4, 600.0))


def rod_compliance(system) -> dict:
    """The harvester point's quasi-static response: its elastic displacement (body frame) per unit base
    acceleration, G_a (3, 3; m per m/s^2 = s^2), and per unit base angular acceleration, G_alpha (3, 3; s^2 m),
    of the modal model the co-simulation's rod integrates (eta = Lambda^-1 f with flexfmu.ffr.dynamics' base-motion
    modal force -F_a0 a0 - P_hat : [alpha]x, its retained modes only), the same with the residual flexibility
    of the omitted modes (the whole finite-element model's static answer), the point's static compliance to
    a force at it (whole model, m/N), the rod's mass and its clamped frequencies (Hz)."""
    from flexfmu.cosim.masters import LibrarySlave
    from flexfmu.ffr.dynamics import _skew
    from flexfmu.ffr.simulator import FFRBeamSimulator
    from flexfmu.sizing.beam import ffr_static_correction

    sim = FFRBeamSimulator(LibrarySlave(system.by_model("FFRBeam")[0]).config)
    dyn = sim.dynamics
    inv = 1.0 / dyn.stiffness
    rotation = [_skew(e) for e in np.eye(3)]
    G_a = -dyn.sensor_map @ (inv[:, None] * dyn.F_a0)
    G_alpha = np.column_stack([-dyn.sensor_map @ (inv * np.einsum("ab,abk->k", X, dyn.P_hat)) for X in rotation])
    residual = ffr_static_correction(dyn).sensor               # per z = [F, M, a0, X_ab (9)]
    force = dyn.sensor_map @ (inv[:, None] * dyn.load_force_map) + residual[:, 0:3]
    return {"G_a": G_a, "G_alpha": G_alpha, "G_a_full": G_a + residual[:, 6:9],
            "G_alpha_full": G_alpha + np.column_stack([residual[:, 9:] @ X.ravel() for X in rotation]),
            "force_compliance": force, "mass": float(dyn.integrals.mass),
            "f_hz": np.asarray(sim.frequencies_hz, float)}


def quasi_static_displacement(base_a, base_alpha, rod) -> np.ndarray:
    """Elastic displacement of the harvester point (rows: samples or frequencies) for the base's acceleration and
    angular acceleration (body frame), quasi-statically: u = G_a a + G_alpha alpha."""
    return base_a @ rod["G_a"].T + base_alpha @ rod["G_alpha"].T


def rao_power(system, rod, omega, amplitude, heading_deg: float) -> float:
    """Mean harvested power (W) predicted without co-simulation: the platform's BEM RAO (flexfmu.wec.bem, the
    platform's rigid mass), its acceleration at the mount -w^2 (xi + theta x r_mount) and angular acceleration
    -w^2 theta per component, the quasi-static point velocity -i w u and the damper's 1/2 c |v|^2 per component
    (the components are orthogonal over the record)."""
    from flexfmu.cosim.masters import LibrarySlave
    from flexfmu.wec import bem
    from flexfmu.wec.components import bem_database, box_parameters
    from flexfmu.wec.roles import roster

    cfg = LibrarySlave(system.by_model("Platform")[0]).config
    box = box_parameters(cfg)
    mount = np.array([cfg.mount_x, cfg.mount_y, cfg.mount_z])
    omega = np.atleast_1d(np.asarray(omega, float))
    _, rao = bem.response_amplitude_operator(bem_database(box, heading_deg), box.box().rigid_mass_matrix(),
                                             heading_deg, omega)
    w2 = omega[:, None] ** 2
    u = quasi_static_displacement(-w2 * (rao[:, :3] + np.cross(rao[:, 3:], mount)), -w2 * rao[:, 3:], rod)
    c = roster(system).one("pto").config.damping
    return float(np.sum(0.5 * c * omega**2 * np.sum(np.abs(u) ** 2, axis=1) * np.atleast_1d(amplitude) ** 2))


def harvest(args) -> int:
    from flexfmu.cosim.masters import load_system, run
    from flexfmu.wec.roles import roster
    from flexfmu.wec.system import harvester_values, with_models, write_table
    from flexfmu.wec.wave import jonswap_sea

    base = load_system(SYSTEM)
    members = roster(base)
    wave, platform = members.one("wave").name, members.one("platform").name
    harvester, pto = members.one("harvester").name, members.one("pto").name
    print(f"hydrodynamics: {base.simulator(wave).initial_values.get('hydrodynamics', 'constant')}")
    rows = []
    for boundary, sea, height, period, t_end in HARVEST_CASES:
        t_end = args.t_end or t_end
        system = with_models(base, harvester_values(boundary)).with_values(
            {wave: {"sea_state": sea, "wave_height": height, "wave_period": period}})
        rod = rod_compliance(system)
        wcfg = roster(system).one("wave").config
        c = roster(system).one("pto").config.damping
        start = time.perf_counter()
        r = run(system, t_end, args.step, scheme="gauss-seidel", backend="library")
        wall = time.perf_counter() - start
        if sea == "regular":                      # the last whole periods within the last 20 s
            omega, amplitude = np.array([2 * math.pi / period]), np.array([height / 2])
            window = period * math.floor(20.0 / period)
        else:               # the whole records (2 pi / dw) in the second half: the components are orthogonal over one
            waves = jonswap_sea(height, period, wcfg.gamma, wcfg.n_components, wcfg.seed, math.radians(wcfg.heading))
            omega, amplitude = waves.omega, waves.amplitude
            record = 2 * math.pi / (omega[1] - omega[0])
            window = record * max(1, math.floor(0.5 * t_end / record))
        sel = r.t >= r.t[-1] - window - 1e-9
        col = r.columns
        a = np.column_stack([col[f"{platform}.mount_a_{x}"] for x in "xyz"])
        alpha = np.column_stack([col[f"{platform}.alpha_{x}"] for x in "xyz"])
        v = np.gradient(quasi_static_displacement(a, alpha, rod), r.t, axis=0)
        measured = float(np.mean(col[f"{pto}.power"][sel]))
        recorded = float(c * np.mean(np.sum(v[sel] ** 2, axis=1)))
        frequency = float(rao_power(system, rod, omega, amplitude, wcfg.heading))
        # the power in the window's first and second half: how steady the window is
        half = r.t[sel][0] + 0.5 * window
        early = float(np.mean(col[f"{pto}.power"][sel & (r.t < half)]))
        late = float(np.mean(col[f"{pto}.power"][sel & (r.t >= half)]))
        row = {"boundary": boundary, "sea_state": sea, "height_m": height, "period_s": period,
               "f_1_Hz": float(col[f"{harvester}.f_1"][-1]), "window_s": window, "power_W": measured,
               "power_halves_W": (early, late), "quasi_static_recorded_W": recorded,
               "quasi_static_rao_W": frequency,
               "mount_a_rms_m_s2": float(np.sqrt(np.mean(np.sum(a[sel] ** 2, axis=1)))),
               "sensor_u_rms_m": float(np.sqrt(np.mean(sum(col[f"{harvester}.sensor_u_{x}"][sel] ** 2
                                                           for x in "xyz")))),
               "wall_s": wall, "rod": rod}
        rows.append(row)
        print(f"{boundary} {sea:8s} H {height:g} m T {period:g} s: f_1 {row['f_1_Hz']:.2f} Hz, mean power "
              f"{measured:.4g} W over the last {window:.2f} s (halves {early:.4g}, {late:.4g}); quasi-static from "
              f"the record {recorded:.4g} W ({100 * (recorded / measured - 1):+.2f} %), from the BEM RAO "
              f"{frequency:.4g} W ({100 * (frequency / measured - 1):+.2f} %); mount acceleration rms "
              f"{row['mount_a_rms_m_s2']:.4g} m/s2; {wall:.0f} s", flush=True)
    for row in rows[:3]:                          # one per boundary
        rod = row["rod"]
        w1 = 2 * math.pi * rod["f_hz"][0]
        compliance, directions = np.linalg.eigh(0.5 * (rod["force_compliance"] + rod["force_compliance"].T))
        print(f"{row['boundary']}: f = {np.round(rod['f_hz'][:4], 2).tolist()} Hz; w_1^2 G_a (dimensionless) = "
              f"{np.round(w1**2 * rod['G_a'], 3).tolist()}; largest entry of G_a, retained modes / whole model "
              f"{np.abs(rod['G_a']).max() / np.abs(rod['G_a_full']).max():.4f}; softest static stiffness to a force "
              f"at the point {1 / compliance[-1]:.4g} N/m along {np.round(directions[:, -1], 3).tolist()}; rod "
              f"mass {rod['mass']:.4g} kg")
    table = write_table([{k: v for k, v in row.items() if k not in ("rod", "power_halves_W")} for row in rows],
                        HERE / "harvest_results.csv")
    print(f"wrote {table}")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", choices=("tuning", "stability", "energy", "run", "harvest"))
    parser.add_argument("--figures", default=str(ROOT / "docs" / "figures"), help="chart folder")
    parser.add_argument("--t-end", type=float, default=None,
                        help="co-simulated time per run, s (default 20; harvest: 150 and 600, for the box's slow "
                             "roll)")
    parser.add_argument("--step", type=float, default=None, help="communication step (default: the file's)")
    parser.add_argument("--wave-height", type=float, default=0.05)
    parser.add_argument("--serial", action="store_true", help="tuning: run serially, without Dask")
    parser.add_argument("--scheduler", default=None, help="tuning: a Dask scheduler address (default: LocalCluster)")
    parser.add_argument("--workers", type=int, default=2, help="tuning: LocalCluster workers")
    parser.add_argument("--backend", choices=("library", "fmu"), default="library")
    parser.add_argument("--fmu-dir", default=str(ROOT / "dist"))
    parser.add_argument("--points", type=int, default=120, help="stability: steps on the scan grid")
    args = parser.parse_args(argv)
    if args.t_end is None and args.study != "harvest":          # harvest: each case's own
        args.t_end = 20.0
    return {"tuning": tuning, "stability": stability, "energy": energy, "run": example_run,
            "harvest": harvest}[args.study](args)


if __name__ == "__main__":
    sys.exit(main())
