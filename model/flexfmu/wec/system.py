# Over 500 lines on purpose: the system studies (energy audit, power, tuning sweep, power matrix) share the
# runs, their Dask distribution and their tables.
"""The wave-energy converter system (examples/wave_converter/): energy audit, harvested power,
frequency-tuning sweep (serial or on Dask).

The system: WaveExcitation -> Platform <- Hydrostatics; Platform -> FFRBeam base (mount point) ->
clamp reactions -> Platform; FFRBeam sensor_v (at the harvester point) -> PTO -> FFRBeam F (same
point) and PTO stator -> Platform.  Instances are found by their FMU model name, one of each.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.cosim.masters import CosimResult, LibrarySlave, System, load_system, run
from flexfmu.core.progress import progress_bar
from flexfmu.errors import ParameterError, require

#: arc length (m) of the harvester point (PTO and sensor) per boundary: the free tip, except for XFX,
#: whose tip is clamped: there the second corner.
HARVESTER_POINT_S = {"XFF": 0.45, "FXF": 0.45, "FXF_mid": 0.45, "XFX": 0.30}
MODELS = ("WaveExcitation", "Platform", "Hydrostatics", "FFRBeam", "PTO")


def roles(system: System) -> dict:
    """{model name: instance name} of the five components (exactly one each)."""
    out = {}
    for model in MODELS:
        found = system.by_model(model)
        require(len(found) == 1, "SYSTEM_FILE", f"{len(found)} {model} instances",
                f"exactly one {model} (the wave-energy converter system)")
        out[model] = found[0].name
    return out


def _config(system: System, model: str):
    spec = system.by_model(model)[0]
    return LibrarySlave(spec).config


def point_position(scene: str, s: float) -> np.ndarray:
    """Undeformed body-frame position of arc length s on a scene's polyline."""
    from flexfmu.ffr.scene import load_scene
    pts = np.asarray(load_scene(scene).points, float)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    acc = np.concatenate([[0.0], np.cumsum(seg)])
    i = min(int(np.searchsorted(acc, s, side="right")) - 1, len(seg) - 1)
    return pts[i] + (s - acc[i]) / seg[i] * (pts[i + 1] - pts[i])


def harvester_values(boundary: str, scene: str = "spatial_double_L") -> dict:
    """Start values that put the harvester point (FFRBeam load_s = sensor_s, PTO attach) where a
    boundary leaves it free to move: {instance model: {variable: value}}."""
    require(boundary in HARVESTER_POINT_S, "boundary", f"got {boundary!r}", " | ".join(HARVESTER_POINT_S))
    s = HARVESTER_POINT_S[boundary]
    r = point_position(scene, s)
    return {"FFRBeam": {"boundary": boundary, "load_s": s, "sensor_s": s},
            "PTO": {"attach_x": float(r[0]), "attach_y": float(r[1]), "attach_z": float(r[2])}}


def with_models(system: System, values_by_model: dict) -> System:
    """system.with_values keyed by model name instead of instance name."""
    names = roles(system)
    return system.with_values({names[m]: v for m, v in values_by_model.items()})


# ---------------------------------------------------------------- energy audit
def beam_recorder(system: System):
    """A ``record`` callback for the library backend: the harvester's elastic kinetic energy (with its
    coupling to the base motion) and modal damping power at each communication point."""
    from flexfmu.ffr.dynamics import _cross_integral
    names = roles(system)

    def record(slaves):
        beam = slaves[names["FFRBeam"]].sim
        plat = slaves[names["Platform"]]
        dyn = beam.dynamics
        ed = beam.state.eta_dot
        v_m = np.array(plat.get(["mount_v_x", "mount_v_y", "mount_v_z"]))
        w = np.array(plat.get(["omega_x", "omega_y", "omega_z"]))
        s_v = dyn.S_bar_hat @ ed                                        # int rho S q_dot
        Pqd = np.einsum("abk,k->ab", dyn.P_hat, ed)                     # int rho (S q_dot)_a u0_b
        ke_el = 0.5 * float(ed @ ed) + float(v_m @ s_v) + float(w @ _cross_integral(Pqd.T))
        return {"beam_elastic_kinetic": ke_el, "beam_damping_power": float(ed @ (dyn.damping * ed))}
    return record


def _trapz(y, t) -> float:
    return float(np.trapezoid(y, t))


#: the energy-balance term of the radiation memory (Hydrostatics with hydrodynamics = bem)
RADIATION_MEMORY_TERM = "radiation memory: radiated + held (signed work)"


@dataclass
class EnergyBalance:
    """Energy terms (J) from t[0] to t[-1]: work in, changes of stored energy, dissipated, harvested."""

    terms: dict
    wave_work: float
    residual: float
    diagnostics: dict = field(default_factory=dict)

    @property
    def relative_residual(self) -> float:
        return self.residual / self.wave_work if self.wave_work else float("nan")

    def table(self) -> str:
        lines = [f"{'work done by the wave force':48s} {self.wave_work:14.6e} J"]
        for name, value in self.terms.items():
            lines.append(f"  {name:46s} {value:14.6e} J  ({100 * value / self.wave_work:8.4f} %)")
        lines.append(f"{'residual (wave work - sum)':48s} {self.residual:14.6e} J  "
                     f"({100 * self.relative_residual:8.4f} %)")
        return "\n".join(lines)


def energy_balance(result: CosimResult, system: System) -> EnergyBalance:
    """Work done by the wave force = d(kinetic) + d(potential) + dissipated + harvested, from the
    recorded outputs (trapezoidal rule over the communication points) and the components' parameters.

    The wave work is the work the wave force did on the platform in the co-simulation (the force held
    over each step; the Platform's work_wave output, exact); the diagnostics give the trapezoid of the
    continuous force's power over the samples too, which differs by the excitation's sampling.

    Kinetic: the platform's (with added mass, its output) and the harvester's rigid-body part (its
    inertia about the mount point and the mount point's motion); with the library backend also the
    harvester's elastic kinetic energy.  Potential: hydrostatic 1/2 xi^T C xi and the harvester's strain
    energy (its output).  Dissipated: radiation xi_dot^T B xi_dot and, with the library backend, the
    harvester's modal damping.  Harvested: c |v|^2 of the harvester point's relative velocity.

    Hydrostatics with hydrodynamics = bem: the database's stiffness C, and in place of the damping the
    work of the radiation memory force, the integral of its signed power (Hydrostatics' radiation_power
    output, xi_dot^T F_mem).  That work is the energy that left the body through the memory: what was
    radiated away plus what the memory state still holds and returns later.  The balance closes with it
    over any interval; only its split into radiated and held energy is not defined by the fitted state
    (it has no unique storage function), and over whole periods in steady state the held part does not
    change, so there the term is the radiated energy."""
    from flexfmu.ffr.simulator import FFRBeamSimulator
    from flexfmu.wec.hydrostatics import bem_model, coefficients

    names = roles(system)
    P, W, B = names["Platform"], names["WaveExcitation"], names["FFRBeam"]
    d = lambda y: float(y[-1] - y[0])   # noqa: E731
    c = result.columns
    t = result.t
    vec = lambda inst, fmt: np.column_stack([c[f"{inst}.{fmt.format(a)}"] for a in "xyz"])   # noqa: E731
    xi = np.hstack([vec(P, "pos_{}"), vec(P, "rot_{}")])
    xi_dot = np.hstack([vec(P, "vel_{}"), vec(P, "omega_{}")])
    f_wave = np.hstack([vec(W, "F_{}"), vec(W, "M_{}")])
    hydro_cfg = _config(system, "Hydrostatics")
    memory = hydro_cfg.hydrodynamics == "bem"
    if memory:
        C = bem_model(hydro_cfg)[0]
    else:
        C, Bm = coefficients(hydro_cfg)
    # the work the wave force did in the co-simulation: the held force over each step, exact (Platform
    # output); the continuous force's trapezoid integral differs by the sampling of the excitation
    wave_work = d(c[f"{P}.work_wave"])
    wave_work_sampled = _trapz(np.einsum("ij,ij->i", f_wave, xi_dot), t)
    pe = 0.5 * np.einsum("ij,jk,ik->i", xi, C, xi)
    if memory:
        # signed: the memory returns part of the energy it took; the recorded output is the power of the
        # memory force the component held at each communication point
        rad_power = np.asarray(c[f"{names['Hydrostatics']}.radiation_power"], float)
    else:
        rad_power = np.einsum("ij,jk,ik->i", xi_dot, Bm, xi_dot)
    # harvester rigid-body kinetic energy
    beam = FFRBeamSimulator(_config(system, "FFRBeam"))
    ints = beam.dynamics.integrals
    v_m, w = vec(P, "mount_v_{}"), vec(P, "omega_{}")
    ke_rigid = (0.5 * ints.mass * np.einsum("ij,ij->i", v_m, v_m)
                + np.einsum("ij,ij->i", v_m, np.cross(w, ints.first_moment))
                + 0.5 * np.einsum("ij,jk,ik->i", w, ints.J0, w))
    pto_cfg = _config(system, "PTO")
    v = vec(B, "sensor_v_{}")
    axis = np.array([pto_cfg.axis_x, pto_cfg.axis_y, pto_cfg.axis_z])
    if np.linalg.norm(axis) > 0:
        axis = axis / np.linalg.norm(axis)
        harvest_power = pto_cfg.damping * (v @ axis) ** 2
    else:
        harvest_power = pto_cfg.damping * np.einsum("ij,ij->i", v, v)
    terms = {
        "kinetic: platform incl. added mass": d(c[f"{P}.kinetic_energy"]),
        "kinetic: harvester rigid-body": d(ke_rigid),
    }
    if "beam_elastic_kinetic" in result.extra:
        terms["kinetic: harvester elastic (library)"] = d(result.extra["beam_elastic_kinetic"])
    terms["potential: hydrostatic"] = d(pe)
    terms["potential: harvester strain"] = d(c[f"{B}.elastic_energy"])
    terms[RADIATION_MEMORY_TERM if memory else "dissipated: radiation damping"] = _trapz(rad_power, t)
    if "beam_damping_power" in result.extra:
        terms["dissipated: harvester modal damping (library)"] = _trapz(result.extra["beam_damping_power"], t)
    terms["harvested: PTO"] = _trapz(harvest_power, t)
    residual = wave_work - sum(terms.values())
    diag = {
        "wave work of the continuous force (trapezoid over the samples)": wave_work_sampled,
        "platform: d(kinetic) - sum of work_*": d(c[f"{P}.kinetic_energy"])
        - sum(d(c[f"{P}.work_{g}"]) for g in ("wave", "hydro", "payload", "pto")),
        "hydro interface: work_hydro + dPE + radiated": d(c[f"{P}.work_hydro"]) + d(pe) + _trapz(rad_power, t),
        "mean harvested power over the last half (W)": float(np.mean(harvest_power[len(t) // 2:])),
        # the work the held damper force actually did on the rod (force of sample n over step n)
        "PTO: energy the held damper force took from the rod": -float(np.sum(np.einsum(
            "ij,ij->i", vec(names["PTO"], "F_{}")[:-1], np.diff(vec(B, "sensor_u_{}"), axis=0)))),
    }
    return EnergyBalance(terms, wave_work, residual, diag)


def harvested_power(result: CosimResult, system: System, t_from: float) -> float:
    """Mean harvested power (W) from t_from to the end (c |v|^2 of the recorded relative velocity)."""
    names = roles(system)
    pto_cfg = _config(system, "PTO")
    v = np.column_stack([result.columns[f"{names['FFRBeam']}.sensor_v_{a}"] for a in "xyz"])
    axis = np.array([pto_cfg.axis_x, pto_cfg.axis_y, pto_cfg.axis_z])
    p = pto_cfg.damping * ((v @ (axis / np.linalg.norm(axis))) ** 2 if np.linalg.norm(axis) > 0
                           else np.einsum("ij,ij->i", v, v))
    sel = result.t >= t_from
    return _trapz(p[sel], result.t[sel]) / (result.t[sel][-1] - result.t[sel][0])


# ---------------------------------------------------------------- summary and charts
def is_wec(system: System) -> bool:
    try:
        roles(system)
        return True
    except Exception:
        return False


def summary(result: CosimResult, system: System) -> str:
    """Motion amplitudes and mean harvested power over the second half of the run."""
    names = roles(system)
    P, B = names["Platform"], names["FFRBeam"]
    half = result.t >= result.t[0] + 0.5 * (result.t[-1] - result.t[0])
    amp = lambda key: 0.5 * float(np.ptp(result.columns[key][half]))   # noqa: E731
    lines = ["second half of the run (amplitude = half the peak-to-peak):",
             f"  platform surge, sway, heave   {amp(P + '.pos_x'):.4g}, {amp(P + '.pos_y'):.4g}, {amp(P + '.pos_z'):.4g} m",
             f"  platform roll, pitch, yaw     {math.degrees(amp(P + '.rot_x')):.4g}, "
             f"{math.degrees(amp(P + '.rot_y')):.4g}, {math.degrees(amp(P + '.rot_z')):.4g} deg",
             f"  harvester point, relative     {max(amp(f'{B}.sensor_u_{a}') for a in 'xyz'):.4g} m, "
             f"{max(amp(f'{B}.sensor_v_{a}') for a in 'xyz'):.4g} m/s (largest component)",
             f"  mean harvested power          {harvested_power(result, system, result.t[half][0]):.4g} W"]
    return "\n".join(lines)


def plot_result(result: CosimResult, system: System, path) -> Path:
    """Platform motion, harvester point motion and harvested power against time (PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = roles(system)
    P, B, W = names["Platform"], names["FFRBeam"], names["WaveExcitation"]
    c, t = result.columns, result.t
    pto_cfg = _config(system, "PTO")
    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    ax[0].plot(t, c[f"{W}.eta"], "k", lw=0.8, label="wave elevation at O")
    ax[0].plot(t, c[f"{P}.pos_z"], label="heave")
    ax[0].plot(t, c[f"{P}.pos_x"], label="surge")
    ax[0].plot(t, c[f"{P}.pos_y"], label="sway")
    ax[0].set_ylabel("m")
    ax[0].set_title("platform translation")
    ax[1].plot(t, np.degrees(c[f"{P}.rot_x"]), label="roll")
    ax[1].plot(t, np.degrees(c[f"{P}.rot_y"]), label="pitch")
    ax[1].plot(t, np.degrees(c[f"{P}.rot_z"]), label="yaw")
    ax[1].set_ylabel("deg")
    ax[1].set_title("platform rotation")
    for a in "xyz":
        ax[2].plot(t, 1e6 * c[f"{B}.sensor_u_{a}"], lw=0.8, label=f"u_{a}")
    ax[2].set_ylabel("um")
    ax[2].set_title("harvester point: elastic displacement relative to the platform (body frame)")
    v = np.column_stack([c[f"{B}.sensor_v_{a}"] for a in "xyz"])
    p = pto_cfg.damping * np.einsum("ij,ij->i", v, v)
    ax[3].plot(t, 1e9 * p, lw=0.8, label="instantaneous")
    half = t >= t[0] + 0.5 * (t[-1] - t[0])
    mean = harvested_power(result, system, t[half][0])
    ax[3].axhline(1e9 * mean, color="k", ls="--", lw=1, label=f"mean over the second half: {1e9 * mean:.3g} nW")
    ax[3].set_ylabel("nW")
    ax[3].set_title(f"harvested power c|v|^2 (c = {pto_cfg.damping:g} N s/m)")
    ax[3].set_xlabel("time (s)")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(loc="upper left", fontsize=8, ncol=4)
    fig.suptitle(f"wave-energy converter co-simulation: {result.master}, h = {result.step:g} s", fontsize=11)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ---------------------------------------------------------------- sweeps (serial or Dask)
@dataclass(frozen=True)
class Case:
    """One co-simulation of a sweep: harvester boundary and sea state (regular: H, T; jonswap: Hs, Tp, seed)."""

    boundary: str = "XFF"
    sea_state: str = "regular"
    wave_height: float = 0.05
    wave_period: float = 1.4
    seed: int = 1


def run_case(system_file: str, case: Case, t_end: float, step: float | None = None, scheme: str = "gauss-seidel",
             backend: str = "library", fmu_dir: str | None = None, average_from: float | None = None) -> dict:
    """One co-simulation (one Dask task): the system file with the case's boundary and sea state;
    returns one table row: the case, mean harvested power and motion amplitudes from ``average_from``
    (default: half the run) to the end, the energy balance residual and the wall time."""
    start = _time.perf_counter()
    system = load_system(system_file, fmu_dir=fmu_dir)
    values = harvester_values(case.boundary, _config(system, "FFRBeam").scene)
    values["WaveExcitation"] = {"sea_state": case.sea_state, "wave_height": float(case.wave_height),
                                "wave_period": float(case.wave_period), "seed": int(case.seed)}
    system = with_models(system, values)
    result = run(system, t_end, step, scheme=scheme, backend=backend)
    t_avg = 0.5 * t_end if average_from is None else average_from
    if case.sea_state == "regular":          # a whole number of periods
        n = math.floor((t_end - t_avg) / case.wave_period)
        if n >= 1:
            t_avg = t_end - n * case.wave_period
    names = roles(system)
    sel = result.t >= t_avg - 1e-12
    amp = lambda key: 0.5 * float(np.ptp(result.columns[key][sel]))   # noqa: E731
    balance = energy_balance(result, system)
    return {"boundary": case.boundary, "sea_state": case.sea_state, "wave_height": case.wave_height,
            "wave_period": case.wave_period, "seed": case.seed,
            "mean_power_W": float(harvested_power(result, system, t_avg)),
            "heave_amplitude_m": amp(f"{names['Platform']}.pos_z"),
            "pitch_amplitude_rad": amp(f"{names['Platform']}.rot_y"),
            "roll_amplitude_rad": amp(f"{names['Platform']}.rot_x"),
            "tip_velocity_amplitude_m_s": max(amp(f"{names['FFRBeam']}.sensor_v_{a}") for a in "xyz"),
            "energy_residual": float(balance.relative_residual),
            "f_1_Hz": float(result.columns[f"{names['FFRBeam']}.f_1"][-1]),
            "wall_s": _time.perf_counter() - start}


def run_case_or_error(system_file: str, case: Case, *args) -> dict:
    """run_case, but a co-simulation that fails on purpose (a FlexfmuError: diverged, bad parameter)
    gives a row with NaN power and the error, so that one case does not lose a whole sweep."""
    from flexfmu.errors import FlexfmuError
    try:
        return run_case(system_file, case, *args)
    except FlexfmuError as exc:
        return {"boundary": case.boundary, "sea_state": case.sea_state, "wave_height": case.wave_height,
                "wave_period": case.wave_period, "seed": case.seed, "mean_power_W": math.nan, "error": str(exc)}


def sweep(system_file, cases, t_end: float, step: float | None = None, scheme: str = "gauss-seidel",
          backend: str = "library", fmu_dir=None, scheduler: str | None = None, n_workers: int = 2,
          progress: bool = False, average_from: float | None = None, keep_going: bool = False) -> list[dict]:
    """Run each case (one co-simulation per task) and gather the rows into one table (list of dicts,
    in the order of ``cases``).  scheduler None: serially in this process (Dask not needed);
    "local": a dask.distributed LocalCluster with n_workers single-threaded worker processes;
    otherwise the address of a running Dask scheduler (e.g. "tcp://10.0.0.5:8786").
    keep_going: a failing case gives a row with NaN power and its error (run_case_or_error)."""
    system_file = str(Path(system_file).resolve())
    fmu_dir = None if fmu_dir is None else str(Path(fmu_dir).resolve())
    args = (t_end, step, scheme, backend, fmu_dir, average_from)
    task = run_case_or_error if keep_going else run_case
    if scheduler is None:
        rows = []
        with progress_bar(len(cases), "sweep", enabled=progress, unit="co-simulation") as bar:
            for i, case in enumerate(cases):
                rows.append(task(system_file, case, *args))
                bar.update_to(i + 1)
        return rows
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise ParameterError("scheduler", "dask.distributed is not installed",
                             "none (serial), or install the 'cluster' extra: pip install flexfmu[cluster]") from None
    cluster = None
    if scheduler == "local":
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=":0")
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        futures = [client.submit(task, system_file, case, *args, pure=False) for case in cases]
        if progress:
            with progress_bar(len(cases), "sweep", unit="co-simulation") as bar:
                for i, _ in enumerate(as_completed(futures)):
                    bar.update_to(i + 1)
        return client.gather(futures)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def write_table(rows: list[dict], path) -> Path:
    import csv
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        names = list(dict.fromkeys(k for r in rows for k in r))    # an error row has other columns
        w = csv.DictWriter(f, fieldnames=names, restval="")
        w.writeheader()
        w.writerows(rows)
    return path


# ---------------------------------------------------------------- power matrix
#: the usual limiting steepness of a sea state, 2 pi Hs / (g Tp^2) (DNV-RP-C205): steeper cells are
#: not computed and stay empty in the matrix
MAX_STEEPNESS = 1 / 15


@dataclass
class PowerMatrix:
    """Mean harvested power (W) over irregular (JONSWAP) seas: ``power[i, j]`` for significant wave
    height ``heights[i]`` and peak period ``periods[j]``, the mean over the seeds; NaN where not
    computed (steeper than max_steepness, or every seed failed).  ``rows`` is one row per co-simulation."""

    heights: np.ndarray
    periods: np.ndarray
    power: np.ndarray
    rows: list
    boundary: str
    t_end: float
    seeds: tuple
    wall_s: float = 0.0

    def write_csv(self, path) -> Path:
        """IEC TS 62600-100 layout: rows Hs (m), columns Tp (s), mean power in W, empty where not computed."""
        import csv
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["Hs_m \\ Tp_s"] + [repr(float(t)) for t in self.periods])
            for hs, row in zip(self.heights, self.power):
                w.writerow([repr(float(hs))] + ["" if not np.isfinite(p) else repr(float(p)) for p in row])
        return path

    def plot(self, path) -> Path:
        """The matrix as a heat map in the table's layout (Hs down, Tp across; log colour scale), the
        value of each computed cell written in it, empty cells blank."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.colors import LogNorm

        nh, nt = self.power.shape
        fig, ax = plt.subplots(figsize=(max(5.0, 2.4 + 1.1 * nt), max(3.2, 1.8 + 0.6 * nh)))
        data = np.ma.masked_invalid(np.where(self.power > 0, self.power, np.nan))
        norm = LogNorm(vmin=data.min(), vmax=data.max()) if data.count() and data.min() < data.max() else None
        im = ax.imshow(data, cmap="viridis", norm=norm, aspect="auto")
        for i in range(nh):
            for j in range(nt):
                p = self.power[i, j]
                if np.isfinite(p):
                    light = norm is not None and norm(p) < 0.5
                    ax.text(j, i, f"{p:.2g}", ha="center", va="center", fontsize=8,
                            color="white" if light else "black")
        ax.set_xticks(range(nt), [f"{t:g}" for t in self.periods])
        ax.set_yticks(range(nh), [f"{h:g}" for h in self.heights])
        ax.set_xlabel("peak period Tp (s)")
        ax.set_ylabel("significant wave height Hs (m)")
        ax.set_xticks(np.arange(nt + 1) - 0.5, minor=True)
        ax.set_yticks(np.arange(nh + 1) - 0.5, minor=True)
        ax.grid(which="minor", color="0.7", lw=0.5)
        ax.tick_params(which="minor", length=0)
        if data.count():
            fig.colorbar(im, ax=ax, label="mean harvested power (W)")
        ax.set_title(f"mean harvested power (W), harvester {self.boundary}\nJONSWAP, mean of {len(self.seeds)} "
                     f"seeds, {self.t_end:g} s runs; empty: not computed", fontsize=9)
        fig.tight_layout()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=120)
        plt.close(fig)
        return path


def power_matrix(system_file, heights, periods, seeds=(1, 2, 3), t_end: float = 60.0, step: float | None = None,
                 boundary: str = "XFF", scheme: str = "gauss-seidel", backend: str = "library", fmu_dir=None,
                 scheduler: str | None = "local", n_workers: int = 2, average_from: float | None = None,
                 max_steepness: float = MAX_STEEPNESS, progress: bool = False) -> PowerMatrix:
    """Mean harvested power over a grid of significant wave height x peak period: per cell one JONSWAP
    co-simulation per seed (the system file's WaveExcitation with sea_state jonswap), mean power from
    ``average_from`` (default half the run) to the end, averaged over the seeds; on Dask (``sweep``:
    scheduler "local", an address, or None for serial).  Cells steeper than ``max_steepness``
    (2 pi Hs / (g Tp^2)) are not run.  A failing co-simulation leaves its seed out (its row keeps the
    error); a cell whose seeds all failed stays empty."""
    heights = np.asarray(heights, float).ravel()
    periods = np.asarray(periods, float).ravel()
    seeds = tuple(int(s) for s in seeds)
    require(heights.size >= 1 and bool(np.all(np.isfinite(heights) & (heights > 0))), "hs",
            f"got {heights.tolist()}", "one or more wave heights > 0 m")
    require(periods.size >= 1 and bool(np.all(np.isfinite(periods) & (periods > 0))), "tp",
            f"got {periods.tolist()}", "one or more peak periods > 0 s")
    require(len(seeds) >= 1 and len(set(seeds)) == len(seeds) and min(seeds) >= 0, "seeds", f"got {list(seeds)}",
            "one or more distinct seeds >= 0")
    require(boundary in HARVESTER_POINT_S, "boundary", f"got {boundary!r}", " | ".join(HARVESTER_POINT_S))
    require(max_steepness > 0, "max-steepness", f"got {max_steepness!r}", "> 0")
    g = _config(load_system(system_file, fmu_dir=fmu_dir), "WaveExcitation").g
    cells = [(i, j) for i, hs in enumerate(heights) for j, tp in enumerate(periods)
             if 2 * math.pi * hs / (g * tp * tp) <= max_steepness * (1 + 1e-12)]
    cases = [Case(boundary, "jonswap", float(heights[i]), float(periods[j]), s) for i, j in cells for s in seeds]
    power = np.full((heights.size, periods.size), np.nan)
    start = _time.perf_counter()
    rows = sweep(system_file, cases, t_end, step, scheme, backend, fmu_dir, scheduler, n_workers, progress,
                 average_from, keep_going=True) if cases else []
    for k, (i, j) in enumerate(cells):
        values = [r["mean_power_W"] for r in rows[k * len(seeds):(k + 1) * len(seeds)]]
        values = [v for v in values if np.isfinite(v)]
        if values:
            power[i, j] = float(np.mean(values))
    return PowerMatrix(heights, periods, power, rows, boundary, float(t_end), seeds, _time.perf_counter() - start)
