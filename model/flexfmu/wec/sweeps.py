"""The machinery of the wave-energy converter's sweeps that does not depend on the system (flexfmu.wec.system
runs the cases): the checks before the first task (:func:`check_runs`), tasks run serially or on Dask, their rows
written as a table, what failed (:func:`failure_summary`), and the power matrix's table and chart in the
IEC TS 62600-100 layout (never written empty).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.core.progress import progress_bar
from flexfmu.cosim.checks import MAX_RESULT_BYTES, check_result_memory, check_system, n_steps
from flexfmu.errors import ParameterError, require


#: The most co-simulations one sweep takes: its cases and their rows are held in memory, and at a second or more
#: per run 10^5 runs are a day on one worker.  A larger study is several sweeps.
MAX_SWEEP_RUNS = 100_000


def check_run_count(n_runs: int, what: str) -> None:
    """Refuse a sweep of more than MAX_SWEEP_RUNS co-simulations before its cases are made; ``what`` names the
    options that multiply to n_runs."""
    require(n_runs <= MAX_SWEEP_RUNS, what, f"{n_runs:.4g} co-simulations",
            f"at most {MAX_SWEEP_RUNS:g} in one sweep")


def check_runs(system, t_end: float, step: float | None, backend: str,
               max_result_bytes: float = MAX_RESULT_BYTES) -> None:
    """What every co-simulation of a sweep would refuse, checked once before the first: the run's length (t_end,
    step: finite, > 0, dividing), the system against its FMUs or models (flexfmu.cosim.checks.check_system) and
    the memory of one run's results.  A sweep's runs differ in start values only, so each would fail alike."""
    h = system.base_step if step is None else step
    n = n_steps(t_end, system.start_time, h)
    check_result_memory(n, check_system(system, backend).n_outputs, h, max_result_bytes)


def failure_summary(rows: list[dict]) -> str | None:
    """None when no row has an error; else one line: how many failed, how many for each cause (the parameter an
    error names, before its first colon) and the first failure's case and message."""
    failed = [r for r in rows if r.get("error")]
    if not failed:
        return None
    causes: dict = {}
    for r in failed:
        cause = str(r["error"]).split(":", 1)[0]
        causes[cause] = causes.get(cause, 0) + 1
    first = failed[0]
    return (f"{len(failed)} of {len(rows)} co-simulations failed (by cause: "
            + ", ".join(f"{c}: {k}" for c, k in causes.items())
            + f"); the first, Hs {first['wave_height']:g} m, Tp {first['wave_period']:g} s, seed {first['seed']}: "
            + " ".join(str(first["error"]).split()))


def run_tasks(task, arguments, scheduler: str | None = None, n_workers: int = 2, progress: bool = False) -> list:
    """task(*args) for each args of ``arguments`` (one co-simulation per task), the results in their order.
    scheduler None: serially in this process (Dask not needed); "local": a dask.distributed LocalCluster with
    n_workers single-threaded worker processes; otherwise the address of a running Dask scheduler
    (e.g. "tcp://10.0.0.5:8786")."""
    if scheduler is None:
        rows = []
        with progress_bar(len(arguments), "sweep", enabled=progress, unit="co-simulation") as bar:
            for i, args in enumerate(arguments):
                rows.append(task(*args))
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
        futures = [client.submit(task, *args, pure=False) for args in arguments]
        if progress:
            with progress_bar(len(arguments), "sweep", unit="co-simulation") as bar:
                for i, _ in enumerate(as_completed(futures)):
                    bar.update_to(i + 1)
        return client.gather(futures)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def write_table(rows: list[dict], path) -> Path:
    """The rows (dicts) as CSV, one column per key in the order they first appear."""
    import csv
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        names = list(dict.fromkeys(k for r in rows for k in r))    # an error row has other columns
        w = csv.DictWriter(f, fieldnames=names, restval="")
        w.writeheader()
        w.writerows(rows)
    return path


#: the usual limiting steepness of a sea state, 2 pi Hs / (g Tp^2) (DNV-RP-C205): steeper cells are
#: not computed and stay empty in the matrix
MAX_STEEPNESS = 1 / 15


@dataclass
class PowerMatrix:
    """Mean harvested power (W) over irregular (JONSWAP) seas: ``power[i, j]`` for significant wave
    height ``heights[i]`` and peak period ``periods[j]``, the mean over the seeds; NaN where not
    computed (steeper than max_steepness, or every seed failed).  ``rows`` is one row per co-simulation.
    The standard's statistics (flexfmu.wec.iec, flexfmu.wec.power_study.cell_statistics): ``bins``, one dict per
    computed bin; ``ci_half_width[i, j]`` the half width of the confidence interval of the mean (W, NaN for fewer
    than two runs); ``energy_periods[j]`` the energy period Te (s) of the column's sea states; ``average_from`` the
    start of each run's statistics window (s; None: half the run); ``characteristic_width`` (m) that the capture-width
    ratio divides by; ``configuration`` a name of the system's configuration; ``bin_checks`` whether the bins were
    checked against the standard's widths and minimum count."""

    heights: np.ndarray
    periods: np.ndarray
    power: np.ndarray
    rows: list
    boundary: str | None
    t_end: float
    seeds: tuple
    wall_s: float = 0.0
    bins: list = field(default_factory=list)
    ci_half_width: np.ndarray | None = None
    energy_periods: np.ndarray | None = None
    average_from: float | None = None
    characteristic_width: float = float("nan")
    confidence: float = 0.95
    configuration: str = ""
    bin_checks: bool = False

    def _require_a_cell(self) -> None:
        require(bool(np.isfinite(self.power).any()), "power matrix", "no cell computed (every cell too steep or "
                "every run failed)", "a matrix with at least one computed cell")

    def write_csv(self, path) -> Path:
        """IEC TS 62600-100 layout: rows Hs (m), columns Tp (s), mean power in W, empty where not computed.
        A matrix without a computed cell is refused: an empty table would pass for a result."""
        import csv
        self._require_a_cell()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["Hs_m \\ Tp_s"] + [repr(float(t)) for t in self.periods])
            for hs, row in zip(self.heights, self.power):
                w.writerow([repr(float(hs))] + ["" if not np.isfinite(p) else repr(float(p)) for p in row])
        return path

    def write_bins_csv(self, path) -> Path:
        """One row per computed bin: its sea state (Hs, Tp, Hm0, Te, J), the statistics of its runs' mean powers
        (count, mean, std, min, max, confidence interval), capture width and ratio, and the frequency-domain
        prediction where there is one.  Refused without a computed cell."""
        self._require_a_cell()
        return write_table(self.bins, path)

    def _window(self) -> str:
        if self.average_from is None:
            return "second half of each run"
        return f"{self.average_from:g} .. {self.t_end:g} s of each run"

    def plot(self, path) -> Path:
        """The matrix as a heat map in the table's layout (Hs down, Tp across with each column's Te; log colour
        scale), the mean of each computed cell written in it with the confidence interval of the mean (+- its half
        width), empty cells blank.  A matrix without a computed cell is refused."""
        self._require_a_cell()
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        nh, nt = self.power.shape
        fig, ax = plt.subplots(figsize=(max(5.0, 2.6 + 1.35 * nt), max(3.4, 2.0 + 0.75 * nh)))
        self.draw(ax)
        fig.tight_layout()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=120)
        plt.close(fig)
        return path

    def draw(self, ax, title: str | None = None) -> None:
        """The heat map of :meth:`plot` on a matplotlib axes (its colour bar beside it), with each bin's
        frequency-domain prediction ("FD") where the bins have one; ``title`` replaces the one that says what was
        run."""
        self._require_a_cell()
        from matplotlib.colors import LogNorm

        nh, nt = self.power.shape
        top = float(np.nanmax(np.abs(self.power)))
        scale, unit = (1e3, "kW") if top >= 1e3 else (1.0, "W")
        data = np.ma.masked_invalid(np.where(self.power > 0, self.power / scale, np.nan))
        norm = LogNorm(vmin=data.min(), vmax=data.max()) if data.count() and data.min() < data.max() else None
        im = ax.imshow(data, cmap="viridis", norm=norm, aspect="auto")
        half = self.ci_half_width
        predicted = {(b["Hs_m"], b["Tp_s"]): b["spectral_power_W"] for b in self.bins if "spectral_power_W" in b}
        for i in range(nh):
            for j in range(nt):
                p = self.power[i, j]
                if np.isfinite(p):
                    light = norm is not None and norm(p / scale) < 0.5
                    text = f"{p / scale:.3g}"
                    if half is not None and np.isfinite(half[i, j]):
                        text += f"\n\u00b1 {half[i, j] / scale:.2g}"
                    fd = predicted.get((float(self.heights[i]), float(self.periods[j])))
                    if fd is not None:
                        text += f"\nFD {fd / scale:.3g}"
                    ax.text(j, i, text, ha="center", va="center", fontsize=8,
                            color="white" if light else "black")
        te = self.energy_periods
        labels = [f"{t:g}" + (f"\n({e:.2f})" if te is not None and np.isfinite(e) else "")
                  for t, e in zip(self.periods, te if te is not None else [np.nan] * nt)]
        ax.set_xticks(range(nt), labels)
        ax.set_yticks(range(nh), [f"{h:g}" for h in self.heights])
        ax.set_xlabel("peak period Tp (s)" + ("\n(energy period Te of the spectrum, s)" if te is not None else ""))
        ax.set_ylabel("significant wave height Hs (m)")
        ax.set_xticks(np.arange(nt + 1) - 0.5, minor=True)
        ax.set_yticks(np.arange(nh + 1) - 0.5, minor=True)
        ax.grid(which="minor", color="0.7", lw=0.5)
        ax.tick_params(which="minor", length=0)
        if data.count():
            ax.figure.colorbar(im, ax=ax, label=f"mean absorbed power ({unit})")
        if title is None:
            what = f"harvester {self.boundary}" if self.boundary else (self.configuration or "")
            ci = (f"\u00b1: {100 * self.confidence:g} % confidence interval of the mean (Student t, n - 1 dof); "
                  if half is not None and np.isfinite(half).any() else "")
            ci += "FD: frequency-domain prediction; " if predicted else ""
            title = (f"mean absorbed power ({unit}), {what}\nJONSWAP, {len(self.seeds)} seeds per cell, "
                     f"{self.t_end:g} s runs, mean over {self._window()}\n{ci}empty: not computed")
        ax.set_title(title, fontsize=8)
