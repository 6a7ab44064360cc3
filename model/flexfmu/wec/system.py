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

from flexfmu.cosim.masters import CosimResult, System, load_system, run, with_assignments
from flexfmu.errors import FlexfmuError, require
from flexfmu.wec.harvester import HARVESTER_POINT_S, harvester_values, point_position
from flexfmu.wec.hydrostatics import RADIATION_MEMORY_TERM
from flexfmu.wec.iec import CONFIDENCE, IEC_HS_BIN_WIDTH, IEC_TE_BIN_WIDTH, MIN_RUNS_PER_BIN
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
    """One co-simulation of a sweep: harvester boundary (None: the system has no harvester) and sea state (regular:
    H, T; jonswap: Hs, Tp, seed)."""

    boundary: str | None = "XFF"
    sea_state: str = "regular"
    wave_height: float = 0.05
    wave_period: float = 1.4
    seed: int = 1


def case_system(system: System, case: Case, t_end: float) -> System:
    """The system with the case's start values: the wave member's sea state (and, when it takes one, its record
    length set to the run's length t_end, so that the record does not repeat within the run), the harvester's
    boundary where there is a harvester."""
    members = roster(system)
    harvesters = members.of_kind("harvester")
    require(case.boundary is None or len(harvesters) == 1, "boundary", f"got {case.boundary!r} for a system "
            f"with {len(harvesters)} harvesters", "a boundary only for a system with one harvester")
    values = {}
    if case.boundary is not None:
        by_model = harvester_values(case.boundary, harvesters[0].config.scene)
        for model, v in by_model.items():
            found = system.by_model(model)
            require(len(found) == 1, "SYSTEM_FILE", f"{len(found)} {model} instances", f"exactly one {model}")
            values[found[0].name] = v
    wave = members.one("wave")
    values[wave.name] = {"sea_state": case.sea_state, "wave_height": float(case.wave_height),
                         "wave_period": float(case.wave_period), "seed": int(case.seed)}
    if "record_length" in getattr(type(wave.config), "__dataclass_fields__", {}):
        values[wave.name]["record_length"] = float(t_end)
    return system.with_values(values)


def run_case(system_file: str, case: Case, t_end: float, step: float | None = None, scheme: str = "gauss-seidel",
             backend: str = "library", fmu_dir: str | None = None, average_from: float | None = None,
             assignments: tuple = ()) -> dict:
    """One co-simulation (one Dask task): the system file with the start values ``assignments``
    ("INSTANCE.VARIABLE=VALUE") and the case's (case_system); returns one table row: the case, mean harvested
    power and motion amplitudes from ``average_from`` (default: half the run) to the end, the energy balance
    residual and the wall time."""
    start = _time.perf_counter()
    system = with_assignments(load_system(system_file, fmu_dir=fmu_dir), assignments)
    system = case_system(system, case, t_end)
    members = roster(system)
    result = run(system, t_end, step, scheme=scheme, backend=backend)
    t_avg = 0.5 * t_end if average_from is None else average_from
    if case.sea_state == "regular":          # a whole number of periods
        n = math.floor((t_end - t_avg) / case.wave_period)
        if n >= 1:
            t_avg = t_end - n * case.wave_period
    platform = members.one("platform").name
    sel = result.t >= t_avg - 1e-12
    amp = lambda key: 0.5 * float(np.ptp(result.columns[key][sel]))   # noqa: E731
    balance = energy_balance(result, system)
    row = {"boundary": case.boundary, "sea_state": case.sea_state, "wave_height": case.wave_height,
           "wave_period": case.wave_period, "seed": case.seed,
           "mean_power_W": float(harvested_power(result, system, t_avg)),
           "average_from_s": float(result.t[sel][0]),
           "record_length_s": getattr(members.one("wave").config, "record_length", None),
           "heave_amplitude_m": amp(f"{platform}.pos_z"),
           "pitch_amplitude_rad": amp(f"{platform}.rot_y"),
           "roll_amplitude_rad": amp(f"{platform}.rot_x")}
    if case.boundary is None:
        del row["boundary"]
    if row["record_length_s"] is None:
        del row["record_length_s"]
    for harvester in members.of_kind("harvester"):
        row["tip_velocity_amplitude_m_s"] = max(amp(f"{harvester.name}.sensor_v_{a}") for a in "xyz")
    row["energy_residual"] = float(balance.relative_residual)
    for harvester in members.of_kind("harvester"):
        row["f_1_Hz"] = float(result.columns[f"{harvester.name}.f_1"][-1])
    row["wall_s"] = _time.perf_counter() - start
    return row


def run_case_or_error(system_file: str, case: Case, *args) -> dict:
    """run_case, but a co-simulation that fails on purpose (a FlexfmuError: diverged, bad parameter)
    gives a row with NaN power and the error, so that one case does not lose a whole sweep."""
    try:
        return run_case(system_file, case, *args)
    except FlexfmuError as exc:
        row = {"boundary": case.boundary, "sea_state": case.sea_state, "wave_height": case.wave_height,
               "wave_period": case.wave_period, "seed": case.seed, "mean_power_W": math.nan, "error": str(exc)}
        if case.boundary is None:
            del row["boundary"]
        return row


def sweep(system_file, cases, t_end: float, step: float | None = None, scheme: str = "gauss-seidel",
          backend: str = "library", fmu_dir=None, scheduler: str | None = None, n_workers: int = 2,
          progress: bool = False, average_from: float | None = None, keep_going: bool = False,
          assignments=()) -> list[dict]:
    """Run each case (one co-simulation per task) and gather the rows into one table (list of dicts,
    in the order of ``cases``; flexfmu.wec.sweeps.run_tasks).  scheduler None: serially in this process (Dask
    not needed); "local": a dask.distributed LocalCluster with n_workers single-threaded worker processes;
    otherwise the address of a running Dask scheduler (e.g. "tcp://10.0.0.5:8786").
    keep_going: a failing case gives a row with NaN power and its error (run_case_or_error).
    assignments: "INSTANCE.VARIABLE=VALUE" start values of every case (flexfmu.cosim.masters.with_assignments)."""
    system_file = str(Path(system_file).resolve())
    fmu_dir = None if fmu_dir is None else str(Path(fmu_dir).resolve())
    args = (t_end, step, scheme, backend, fmu_dir, average_from)
    if assignments:
        args += (tuple(str(a) for a in assignments),)
    task = run_case_or_error if keep_going else run_case
    return run_tasks(task, [(system_file, case) + args for case in cases], scheduler, n_workers, progress)


def power_matrix(system_file, heights=None, periods=None, seeds=(1, 2, 3), t_end: float | None = None,
                 step: float | None = None, boundary: str | None = None, scheme: str = "gauss-seidel",
                 backend: str = "library", fmu_dir=None, scheduler: str | None = "local", n_workers: int = 2,
                 average_from: float | None = None, max_steepness: float = MAX_STEEPNESS, progress: bool = False,
                 assignments=(), bin_checks: bool | None = None, hs_bin_width: float = IEC_HS_BIN_WIDTH,
                 te_bin_width: float = IEC_TE_BIN_WIDTH, min_runs: int = MIN_RUNS_PER_BIN,
                 confidence: float = CONFIDENCE) -> PowerMatrix:
    """Mean harvested power over a grid of significant wave height x peak period, in the manner of
    IEC TS 62600-100 (flexfmu.wec.iec): per cell (a bin centred on its sea state: Hm0 = Hs, Te of the wave's
    spectrum) one JONSWAP co-simulation per seed (the system's wave member with sea_state jonswap, and its record as
    long as the run where it takes one), the runs' mean powers from ``average_from`` to the end, and per bin their
    count, mean, std, min, max, confidence interval of the mean, the sea state's energy flux J, the capture width
    and its ratio, and (linear configurations of the point absorber) the frequency-domain prediction; on Dask
    (``sweep``: scheduler "local", an address, or None for serial).

    The defaults come from the system (flexfmu.wec.power_study.study_defaults): the point absorber's runs are
    20 minutes after the wave's ramp, statistics over those 20 minutes, bins checked (bin_checks) against the
    standard's widths and min_runs seeds; the harvester's system keeps its 60 s runs, the second half and its
    boundary (XFF), its bins unchecked unless bin_checks is True.  ``assignments`` ("INSTANCE.VARIABLE=VALUE") are
    every run's start values.  Cells steeper than ``max_steepness`` (2 pi Hs / (g Tp^2)) are not run.  A failing
    co-simulation leaves its seed out (its row keeps the error); a cell whose seeds all failed stays empty."""
    from flexfmu.wec.iec import bin_edges, check_bins, spectral_measures
    from flexfmu.wec.power_study import cell_statistics, sea_spectrum, study_defaults

    loaded = with_assignments(load_system(system_file, fmu_dir=fmu_dir), assignments)
    members = roster(loaded)
    defaults = study_defaults(members)
    heights = np.asarray(defaults.heights if heights is None else heights, float).ravel()
    periods = np.asarray(defaults.periods if periods is None else periods, float).ravel()
    # refused before the seeds are made (a range of 1e9 seeds is cheap, its tuple is not)
    check_run_count(heights.size * periods.size * len(seeds), "hs, tp, seeds")
    seeds = tuple(int(s) for s in seeds)
    require(heights.size >= 1 and bool(np.all(np.isfinite(heights) & (heights > 0))), "hs",
            f"got {heights.tolist()}", "one or more wave heights > 0 m")
    require(periods.size >= 1 and bool(np.all(np.isfinite(periods) & (periods > 0))), "tp",
            f"got {periods.tolist()}", "one or more peak periods > 0 s")
    require(len(seeds) >= 1 and len(set(seeds)) == len(seeds) and min(seeds) >= 0, "seeds", f"got {list(seeds)}",
            "one or more distinct seeds >= 0")
    if defaults.boundary is None:
        require(boundary is None, "boundary", f"got {boundary!r}: the system has no harvester", "no boundary")
    else:
        boundary = defaults.boundary if boundary is None else boundary
        require(boundary in HARVESTER_POINT_S, "boundary", f"got {boundary!r}", " | ".join(HARVESTER_POINT_S))
    require(max_steepness > 0, "max-steepness", f"got {max_steepness!r}", "> 0")
    t_end = defaults.t_end if t_end is None else t_end
    average_from = defaults.average_from if average_from is None else average_from
    # what every run would refuse, refused before the first (the CLI and library callers alike)
    check_runs(loaded, t_end, step, backend)
    require(average_from is None or (math.isfinite(average_from) and loaded.start_time <= average_from < t_end),
            "average-from", f"got {average_from!r} s", f"{loaded.start_time:g} <= t < t-end = {t_end:g} s")
    wave = members.one("wave")
    g = wave.config.g if hasattr(wave.config, "g") else 9.81
    cells = [(i, j) for i, hs in enumerate(heights) for j, tp in enumerate(periods)
             if 2 * math.pi * hs / (g * tp * tp) <= max_steepness * (1 + 1e-12)]
    # the sea states the runs play: their spectra, Hm0, Te and J (MHKiT), and the bins they make
    spectra = {c: sea_spectrum(wave, heights[c[0]], periods[c[1]], t_end if defaults.record_length else None)
               for c in cells}
    measures = {c: spectral_measures(spectra[c]) for c in cells}
    checked = defaults.bin_checks if bin_checks is None else bool(bin_checks)
    if checked and cells:
        # one Te per Tp: the cells of a column share their spectrum's shape (their Te differ in rounding only)
        te_of_column = {j: measures[(i, j)].te for i, j in cells}
        check_bins(sorted({heights[i] for i, _ in cells}), sorted(te_of_column.values()), hs_bin_width,
                   te_bin_width, len(seeds), min_runs)
        for c in cells:
            low, high = bin_edges(heights[c[0]], hs_bin_width)
            require(low <= measures[c].hm0 < high, "hs", f"the sea state Hs {heights[c[0]]:g} m, Tp "
                    f"{periods[c[1]]:g} s plays Hm0 = {measures[c].hm0:.4g} m, outside its bin {low:g} .. {high:g} m",
                    "a wave whose spectrum keeps Hm0 within half a bin (--hs-bin-width) of Hs")
    cases = [Case(boundary, "jonswap", float(heights[i]), float(periods[j]), s) for i, j in cells for s in seeds]
    start = _time.perf_counter()
    rows = sweep(system_file, cases, t_end, step, scheme, backend, fmu_dir, scheduler, n_workers, progress,
                 average_from, keep_going=True, assignments=assignments) if cases else []
    table = cell_statistics(loaded, members, heights, periods, cells, rows, len(seeds), spectra, measures,
                            hs_bin_width if checked else None, te_bin_width if checked else None, min_runs,
                            confidence)
    return PowerMatrix(heights, periods, table.power, rows, boundary, float(t_end), seeds,
                       _time.perf_counter() - start, bins=table.bins, ci_half_width=table.ci_half_width,
                       energy_periods=table.energy_periods, average_from=average_from,
                       characteristic_width=table.characteristic_width, confidence=confidence,
                       configuration=table.configuration, bin_checks=checked)
