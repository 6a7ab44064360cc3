"""The wave-energy converter system (examples/wave_converter/): energy audit, harvested power, summary and chart of
a run, the sweep of boundary x sea state (serial or on Dask) and the power matrix.

The system is whatever the system file holds: each instance's registry row names its role (flexfmu.wec.roles:
the wave brings the energy in, the platform accounts for the work done on it, hydrostatics, the harvester and the
PTO for what they store, dissipate or harvest), and this module asks every instance for its part and keeps what is
system-level: the balance, the sums, the tables.  The example: WaveExcitation -> Platform <- Hydrostatics;
Platform -> FFRBeam base (mount point) -> clamp reactions -> Platform; FFRBeam sensor_v (at the harvester point)
-> PTO -> FFRBeam F (same point) and PTO stator -> Platform.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.cosim.masters import CosimResult, System, load_system, run
from flexfmu.errors import FlexfmuError, require
from flexfmu.wec.harvester import HARVESTER_POINT_S, harvester_values, point_position
from flexfmu.wec.hydrostatics import RADIATION_MEMORY_TERM
from flexfmu.wec.roles import CATEGORIES, WORK_IN, Recorded, mean_power, roster, summary_line
from flexfmu.wec.sweeps import MAX_STEEPNESS, PowerMatrix, check_run_count, check_runs, run_tasks, write_table

# the system's names, with those of the harvester, hydrostatics and the sweeps' machinery that callers have
# always imported from here
__all__ = ["HARVESTER_POINT_S", "MAX_STEEPNESS", "RADIATION_MEMORY_TERM", "Case", "EnergyBalance", "PowerMatrix",
           "beam_recorder", "energy_balance", "harvested_power", "harvester_values", "is_wec", "plot_result",
           "point_position", "power_matrix", "recorder", "roster", "run_case", "run_case_or_error", "summary", "sweep",
           "with_models", "write_table"]


def with_models(system: System, values_by_model: dict) -> System:
    """system.with_values keyed by model name instead of instance name (one instance of each model named)."""
    names = {}
    for model in values_by_model:
        found = system.by_model(model)
        require(len(found) == 1, "SYSTEM_FILE", f"{len(found)} {model} instances", f"exactly one {model}")
        names[model] = found[0].name
    return system.with_values({names[m]: v for m, v in values_by_model.items()})


def is_wec(system: System) -> bool:
    """Is the system a wave-energy converter: every instance a component with a role, a wave and a platform?"""
    try:
        roster(system)
        return True
    except FlexfmuError:
        return False


# ---------------------------------------------------------------- energy audit
def recorder(system: System):
    """A ``record`` callback for the library backend: the per-step values that only the components' state holds
    (the harvester's elastic kinetic energy and modal damping power), as ``instance.key``."""
    parts = [(m.name, f) for m in roster(system).members for f in [m.role.recorder(m)] if f is not None]

    def record(slaves):
        out = {}
        for name, f in parts:
            out.update({f"{name}.{key}": value for key, value in f(slaves).items()})
        return out
    return record


#: the recorder of the example, under its former name
beam_recorder = recorder


@dataclass
class EnergyBalance:
    """Energy terms (J) from t[0] to t[-1]: work in, changes of stored energy, dissipated, harvested."""

    terms: dict
    wave_work: float
    residual: float
    diagnostics: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)          # the work brought in, by source; wave_work is their sum

    @property
    def relative_residual(self) -> float:
        return self.residual / self.wave_work if self.wave_work else float("nan")

    def table(self) -> str:
        share = lambda value: 100 * value / self.wave_work if self.wave_work else float("nan")   # noqa: E731
        lines = [f"{label:48s} {value:14.6e} J" for label, value in self.inputs.items()]
        for name, value in self.terms.items():
            lines.append(f"  {name:46s} {value:14.6e} J  ({share(value):8.4f} %)")
        lines.append(f"{'residual (wave work - sum)':48s} {self.residual:14.6e} J  "
                     f"({100 * self.relative_residual:8.4f} %)")
        return "\n".join(lines)


def energy_balance(result: CosimResult, system: System) -> EnergyBalance:
    """Work brought in by the wave = d(kinetic) + d(potential) + dissipated + harvested + residual, from the
    recorded outputs (trapezoidal rule over the communication points) and the components' parameters.

    Each instance of the system file contributes its terms (flexfmu.wec.roles.Role.energy; the example's: the
    wave's work on the platform, exact; the platform's kinetic energy with added mass; hydrostatic potential and
    radiated energy; the harvester's rigid-body kinetic and strain energy and, with the library backend's
    recorder, its elastic kinetic energy and modal damping; the PTO's harvested c |v|^2).  The terms are summed
    by category (kinetic, potential, dissipated, harvested), in the file's order within each; the residual is
    what the co-simulation's coupling left unaccounted."""
    members = roster(system)
    r = Recorded(result, members)
    contributed = [term for m in members.members for term in m.role.energy(m, r)]
    for term in contributed:
        require(term.category in CATEGORIES + (WORK_IN,), "category", f"{term.label}: {term.category!r}",
                " | ".join(CATEGORIES + (WORK_IN,)))
    labels = [term.label for term in contributed]
    require(len(set(labels)) == len(labels), "label", f"two energy terms share a label: {labels}",
            "one label per term")
    inputs = {term.label: term.value for term in contributed if term.category == WORK_IN}
    terms = {term.label: term.value for category in CATEGORIES for term in contributed if term.category == category}
    wave_work = sum(inputs.values())
    residual = wave_work - sum(terms.values())
    diag = {}
    for m in members.members:
        diag.update(m.role.diagnostics(m, r))
    diag["mean harvested power over the last half (W)"] = float(np.mean(_power(r)[len(r.t) // 2:]))
    return EnergyBalance(terms, wave_work, residual, diag, inputs)


def _power(r: Recorded) -> np.ndarray:
    """The harvested power of every component that harvests, summed (W at the communication points)."""
    powers = [p for m in r.roster.members for p in [m.role.power(m, r)] if p is not None]
    return sum(powers) if powers else np.zeros_like(r.t, dtype=float)


def harvested_power(result: CosimResult, system: System, t_from: float) -> float:
    """Mean harvested power (W) from t_from to the end (c |v|^2 of the recorded relative velocity, every PTO)."""
    return mean_power(_power(Recorded(result, roster(system))), result.t, t_from)


# ---------------------------------------------------------------- summary and charts
def summary(result: CosimResult, system: System) -> str:
    """Motion amplitudes and mean harvested power over the second half of the run."""
    r = Recorded(result, roster(system))
    half = result.t >= result.t[0] + 0.5 * (result.t[-1] - result.t[0])
    lines = ["second half of the run (amplitude = half the peak-to-peak):"]
    for m in r.roster.members:
        lines += m.role.summary(m, r, half)
    lines.append(summary_line("mean harvested power", f"{harvested_power(result, system, result.t[half][0]):.4g} W"))
    return "\n".join(lines)


def plot_result(result: CosimResult, system: System, path) -> Path:
    """The components' panels against time (the example's: platform motion, harvester point motion, harvested
    power), PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = Recorded(result, roster(system))
    panels = {}
    for m in r.roster.members:
        for panel in m.role.panels(m, r):
            panels.setdefault(panel.key, (panel, []))[1].extend(panel.curves)
    fig, ax = plt.subplots(len(panels), 1, figsize=(9, 2.5 * len(panels)), sharex=True, squeeze=False)
    for a, (panel, curves) in zip(ax[:, 0], panels.values()):
        for y, style in curves:
            a.plot(result.t, y, **style) if np.ndim(y) else a.axhline(y, **style)
        a.set_ylabel(panel.ylabel)
        a.set_title(panel.title)
        a.grid(alpha=0.3)
        a.legend(loc="upper left", fontsize=8, ncol=4)
    ax[-1, 0].set_xlabel("time (s)")
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
    members = roster(system)
    values = harvester_values(case.boundary, members.one("harvester").config.scene)
    values["WaveExcitation"] = {"sea_state": case.sea_state, "wave_height": float(case.wave_height),
                                "wave_period": float(case.wave_period), "seed": int(case.seed)}
    system = with_models(system, values)
    result = run(system, t_end, step, scheme=scheme, backend=backend)
    t_avg = 0.5 * t_end if average_from is None else average_from
    if case.sea_state == "regular":          # a whole number of periods
        n = math.floor((t_end - t_avg) / case.wave_period)
        if n >= 1:
            t_avg = t_end - n * case.wave_period
    platform, harvester = members.one("platform").name, members.one("harvester").name
    sel = result.t >= t_avg - 1e-12
    amp = lambda key: 0.5 * float(np.ptp(result.columns[key][sel]))   # noqa: E731
    balance = energy_balance(result, system)
    return {"boundary": case.boundary, "sea_state": case.sea_state, "wave_height": case.wave_height,
            "wave_period": case.wave_period, "seed": case.seed,
            "mean_power_W": float(harvested_power(result, system, t_avg)),
            "heave_amplitude_m": amp(f"{platform}.pos_z"),
            "pitch_amplitude_rad": amp(f"{platform}.rot_y"),
            "roll_amplitude_rad": amp(f"{platform}.rot_x"),
            "tip_velocity_amplitude_m_s": max(amp(f"{harvester}.sensor_v_{a}") for a in "xyz"),
            "energy_residual": float(balance.relative_residual),
            "f_1_Hz": float(result.columns[f"{harvester}.f_1"][-1]),
            "wall_s": _time.perf_counter() - start}


def run_case_or_error(system_file: str, case: Case, *args) -> dict:
    """run_case, but a co-simulation that fails on purpose (a FlexfmuError: diverged, bad parameter)
    gives a row with NaN power and the error, so that one case does not lose a whole sweep."""
    try:
        return run_case(system_file, case, *args)
    except FlexfmuError as exc:
        return {"boundary": case.boundary, "sea_state": case.sea_state, "wave_height": case.wave_height,
                "wave_period": case.wave_period, "seed": case.seed, "mean_power_W": math.nan, "error": str(exc)}


def sweep(system_file, cases, t_end: float, step: float | None = None, scheme: str = "gauss-seidel",
          backend: str = "library", fmu_dir=None, scheduler: str | None = None, n_workers: int = 2,
          progress: bool = False, average_from: float | None = None, keep_going: bool = False) -> list[dict]:
    """Run each case (one co-simulation per task) and gather the rows into one table (list of dicts,
    in the order of ``cases``; flexfmu.wec.sweeps.run_tasks).  scheduler None: serially in this process (Dask
    not needed); "local": a dask.distributed LocalCluster with n_workers single-threaded worker processes;
    otherwise the address of a running Dask scheduler (e.g. "tcp://10.0.0.5:8786").
    keep_going: a failing case gives a row with NaN power and its error (run_case_or_error)."""
    system_file = str(Path(system_file).resolve())
    fmu_dir = None if fmu_dir is None else str(Path(fmu_dir).resolve())
    args = (t_end, step, scheme, backend, fmu_dir, average_from)
    task = run_case_or_error if keep_going else run_case
    return run_tasks(task, [(system_file, case) + args for case in cases], scheduler, n_workers, progress)


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
    # refused before the seeds are made (a range of 1e9 seeds is cheap, its tuple is not)
    check_run_count(heights.size * periods.size * len(seeds), "hs, tp, seeds")
    seeds = tuple(int(s) for s in seeds)
    require(heights.size >= 1 and bool(np.all(np.isfinite(heights) & (heights > 0))), "hs",
            f"got {heights.tolist()}", "one or more wave heights > 0 m")
    require(periods.size >= 1 and bool(np.all(np.isfinite(periods) & (periods > 0))), "tp",
            f"got {periods.tolist()}", "one or more peak periods > 0 s")
    require(len(seeds) >= 1 and len(set(seeds)) == len(seeds) and min(seeds) >= 0, "seeds", f"got {list(seeds)}",
            "one or more distinct seeds >= 0")
    require(boundary in HARVESTER_POINT_S, "boundary", f"got {boundary!r}", " | ".join(HARVESTER_POINT_S))
    require(max_steepness > 0, "max-steepness", f"got {max_steepness!r}", "> 0")
    # what every run would refuse, refused before the first (the CLI and library callers alike)
    loaded = load_system(system_file, fmu_dir=fmu_dir)
    check_runs(loaded, t_end, step, backend)
    g = roster(loaded).one("wave").config.g
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
