"""The work-precision study's charts and report (flexfmu.studies.work_precision): one PNG of three panels per
case, the conclusions drawn from a run's numbers, docs/work_precision.md with its hand-written notes."""
from __future__ import annotations

import math
import os
from pathlib import Path

from flexfmu.studies import common
from flexfmu.studies.work_precision_measure import (PANEL_TITLES, PANELS, Case, Point, ffr_auto_available,
                                                    ffr_integrators, observed_order, reframe_auto_available,
                                                    reframe_schemes)

TARGETS = (1e-2, 1e-4)            # error levels at which the cheapest method is reported


# --------------------------------------------------------------------------- charts
_COLORS = {"reframe consistent": "tab:blue", "reframe paper": "tab:orange", "reframe exponential": "tab:green",
           "fixed-frame baseline": "tab:gray", "Exudyn FFRF (gen.-alpha)": "tab:red",
           "FFR modal, exact (expm)": "tab:purple", "FFR modal, RK4": "tab:brown",
           "FFR modal, exact + static correction": "tab:olive"}
_MARKERS = ("o", "s", "^", "D", "v", "P", "X")


def _at_least_a_decade(ax) -> None:
    """Widen a log x-axis to one decade around its data (sweeps whose CPU time hardly changes would otherwise
    spread noise over the whole width) and label only the decades."""
    from matplotlib.ticker import LogLocator, NullFormatter
    xs = [x for line in ax.get_lines() for x in line.get_xdata() if x > 0]
    if xs:
        lo, hi = min(xs), max(xs)
        if hi / lo < 10.0:
            mid = math.sqrt(lo * hi)
            lo, hi = mid / math.sqrt(10.0), mid * math.sqrt(10.0)
        ax.set_xlim(lo / 1.3, hi * 1.3)
    ax.xaxis.set_major_locator(LogLocator(base=10.0))
    ax.xaxis.set_minor_formatter(NullFormatter())


def plot_case(case: Case, path: Path, plt) -> Path:
    """The case's three panels (``plt``: matplotlib.pyplot)."""
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.4))
    methods = list(dict.fromkeys(p.method for p in case.points))
    for ax, panel in zip(axes, PANELS):
        for k, method in enumerate(methods):
            pts = [p for p in case.points if p.panel == panel and p.method == method and not p.automatic
                   and math.isfinite(p.cpu) and math.isfinite(p.error) and p.error > 0]
            if not pts:
                continue
            color = _COLORS.get(method, f"C{k}")
            ax.plot([p.cpu for p in pts], [p.error for p in pts], marker=_MARKERS[k % len(_MARKERS)], color=color,
                    label=method, lw=1.5, ms=6)
            for j, p in enumerate(pts):
                if panel != "dt" or j in (0, len(pts) - 1):
                    ax.annotate(p.label, (p.cpu, p.error), textcoords="offset points", xytext=(4, 4), fontsize=7,
                                color=color)
        for p in case.points:
            if p.panel == panel and p.automatic and math.isfinite(p.cpu) and math.isfinite(p.error) and p.error > 0:
                ax.plot([p.cpu], [p.error], marker="*", ms=17, color=_COLORS.get(p.method, "k"), mec="k",
                        ls="none", label=f"automatic choice ({p.method}, {p.label.split(': ')[-1]} modes)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        _at_least_a_decade(ax)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_xlabel("CPU time, set-up + integration (s)" if panel == "mesh" else "CPU time of the integration (s)")
        ax.set_ylabel("error: max |u − u_ref| / max |u_ref| (–)")
        ax.set_title(f"{PANEL_TITLES[panel]}: {case.references.get(panel + '_short', '')}", fontsize=10)
    handles = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=min(len(handles), 4), fontsize=9,
               frameon=False)
    fig.suptitle(f"Work-precision, {case.title} — u: {case.quantity}", fontsize=12)
    fig.tight_layout(rect=(0, 0.09 if len(handles) > 4 else 0.06, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------- report
def fmt_err(e: float) -> str:
    if e is None or not math.isfinite(e):
        return "–" if e is None or math.isnan(e) else "diverged"
    return f"{e:.2e}"


def fmt_cpu(t: float) -> str:
    if t is None or not math.isfinite(t):
        return "–"
    return f"{t * 1e3:.1f} ms" if t < 1.0 else f"{t:.2f} s"


#: CPU times within this fraction count as equal when deciding whether a run is on the efficient front.
CPU_NOISE = 0.2


def dominated_by(point: Point, points) -> Point | None:
    """A point of the same panel with a smaller error at no more CPU time (within CPU_NOISE), if any: then
    ``point`` is not on the efficient front of that panel.  Automatic points do not dominate each other (the
    exact and RK4 automatic FFR runs tie to 4 digits)."""
    better = [q for q in points if q is not point and q.panel == point.panel and not q.automatic
              and math.isfinite(q.cpu)
              and math.isfinite(q.error) and q.cpu <= point.cpu * (1.0 + CPU_NOISE) and q.error < point.error]
    return min(better, key=lambda q: q.error) if better else None


def conclusions(case: Case) -> list[str]:
    """Sentences that state what the numbers of this case show (orders, plateaus, cheapest method per target)."""
    out = []
    pts = [p for p in case.points if math.isfinite(p.cpu) and math.isfinite(p.error)]
    methods = list(dict.fromkeys(p.method for p in case.points))
    for method in methods:
        row = sorted((p for p in pts if p.panel == "dt" and p.method == method), key=lambda p: -p.value)
        if len(row) >= 2:
            errs = ", ".join(f"{p.error:.1e}" for p in row)
            orders = [observed_order([a.value, b.value], [a.error, b.error]) for a, b in zip(row[:-1], row[1:])]
            out.append(f"{method}: time-step errors {errs} (dt {row[0].label} … {row[-1].label}); observed orders "
                       "between successive steps " + ", ".join("–" if q is None else f"{q:.2f}" for q in orders)
                       + ".")
    for panel in PANELS:
        for target in TARGETS:
            ok = [p for p in pts if p.panel == panel and p.error <= target and not p.automatic]
            if ok:
                best = min(ok, key=lambda p: p.cpu)
                out.append(f"{PANEL_TITLES[panel]} sweep, error ≤ {target:g}: cheapest is {best.method} at "
                           f"{best.label} ({fmt_cpu(best.cpu)}, error {best.error:.1e}).")
            else:
                out.append(f"{PANEL_TITLES[panel]} sweep: no run reached error ≤ {target:g}.")
    for p in pts:
        if p.automatic:
            dom = dominated_by(p, pts)
            out.append(f"{p.method}, {p.note}: {p.label.split(': ')[-1]} modes, error {p.error:.1e}, "
                       f"{fmt_cpu(p.cpu)} — " + ("on the efficient front of the panel (no run of any method is "
                                                f"more accurate at ≤ {1 + CPU_NOISE:g}× its CPU time)." if dom is None else
                                                f"not on the front: {dom.method} with {dom.label} modes reaches "
                                                f"{dom.error:.1e} in {fmt_cpu(dom.cpu)}."))
    refused = [p for p in case.points if p.note.startswith("refused")]
    for p in refused:
        out.append(f"{p.method} at {PANEL_TITLES[p.panel]} {p.label}: {p.note}.")
    return out


def write_report(path: Path, cases, figures, mach, quick, elapsed, extra_notes, today: str,
                 replotted: bool = False) -> None:
    lines = [
        "# Work-precision study",
        "",
        f"Made from {common.provenance()}.",
        "",
        "Written by `flexfmu bench work-precision` (flexfmu.studies.work_precision; also "
        "`benchmarks/work_precision.py`); the run: "
        + ("**--quick**" if quick else "**full**") + f", {today}, {elapsed:.0f} s; machine: {mach}."
        + (" Charts and text drawn again from the run's saved numbers (`--replot`)." if replotted else ""),
        "",
        "**What is measured.** For each case, one factor at a time is varied from the case's base model — the "
        "time step, the number of retained modes, the mesh — and each run's error is measured against the "
        "reference of that sweep (below). Error = max over the output times of |u − u_ref| divided by max over "
        "time of |u_ref|, u the case's output vector (stated per case). CPU time = `time.process_time` of this "
        "process, best of " + ("2 runs" if quick else "3 runs") + " (caches a method fills on its first run at a given "
        "time step, e.g. the exponential scheme's step matrices, are thus counted as set-up); the time-step and modes charts show the CPU "
        "time of the integration (incl. outputs), the mesh chart set-up (mesh, modes, integrator invariants) + "
        "integration. CPU times are noisy on a shared machine (±20 %); ratios only within this run.",
        "",
        "Methods found at run time: reframe schemes " + ", ".join(f"`{s}`" for s in reframe_schemes())
        + "; FFR integrators " + ", ".join(f"`{s}`" for s in ffr_integrators())
        + "; automatic model choice (f_max, tolerance): "
        + (" and ".join(name for name, ok in (("ReframeBody n_flexible_modes = -1", reframe_auto_available()),
                                              ("FFRBeam n_modes = -1, elements_per_segment = 0", ffr_auto_available()))
                        if ok) or "none") + ". Exudyn runs on the plate only (the model of the stored Exudyn "
        "reference, flexfmu/data/references/exudyn_plate); no Exudyn model of the rod or of the FFR beam was built.",
        "",
    ]
    for case, fig in zip(cases, figures):
        lines += [f"## {case.title}", "", case.description + ".", "", f"Output: {case.quantity}.", "",
                  f"Base model: {case.base}.", "", "References:", ""]
        lines += [f"- {PANEL_TITLES[p]}: {case.references[p]}" for p in PANELS if p in case.references]
        if fig is not None:                    # the chart, linked relative to the report
            lines += ["", f"![{case.title}]({Path(os.path.relpath(Path(fig).resolve(), path.parent.resolve())).as_posix()})"]
        lines += ["", "Conclusions (from this run's numbers):", ""]
        lines += [f"- {s}" for s in conclusions(case)]
        lines += ["", "| sweep | method | value | set-up CPU | integration CPU | error | note |",
                  "|---|---|---|---|---|---|---|"]
        for p in case.points:
            lines.append(f"| {PANEL_TITLES[p.panel]} | {p.method} | {p.label} | {fmt_cpu(p.setup_cpu)} | "
                         f"{fmt_cpu(p.run_cpu)} | {fmt_err(p.error)} | {p.note} |")
        lines.append("")
    if extra_notes:
        lines += [extra_notes.rstrip(), ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines))


def machine() -> str:
    """One line of the performance study's machine description."""
    from flexfmu.studies.performance_timing import machine as machine_facts

    m = machine_facts()
    return f"{m['cpu']}, {m['cores']} cores, Python {m['python']}, numpy {m['numpy']}"


#: Hand-written reading of the charts, appended to the report.  Its numbers are quoted from the full run of
#: 2026-11-21 08:37 UTC; re-read them after a new run.
NOTES = """## Reading the charts (full run of 2026-11-21 08:37 UTC)

**Time step.** The reframe `consistent` scheme is fourth order (rod: observed orders 3.25, 4.03, 3.90, 3.93;
plate: 3.0, 4.2, 4.2 down to 1.6e-7, where the plate panel meets the floor of its reference, the stored Exudyn
trajectory, ≈ 1.5e-7). The `exponential` scheme has the same order but a far smaller error constant, because
the modal part is exact: 1.1e-7 on the rod and 2.6e-7 (the reference floor) on the plate already at the
coarsest step, 2.5e-4 / 5e-4 s, in 15 / 20 ms. The printed `paper` scheme converges at first to second order
on the plate (8.4e-6 at dt = 3.1e-5 s), but on the rod it stalls at 4–6e-5 (it converges to its own limit,
defect (d) of docs/reframe.md), and its Python step costs 10–25× the consistent scheme's CPU time per step.
Exudyn's generalized-α on the same plate model is second order (orders 2.01): 2.1e-5 in 640 ms at
dt = 3.1e-5 s, where the consistent scheme reaches 3.0e-6 in 37 ms (dt = 1.25e-4 s) — 17× less CPU time for
a 7× smaller error. The fixed-frame linear baseline stops improving at 4.8e-5 on the plate (it turns
slowly, 0.05 rad/s) and at 1.2e-2 on the rod, which turns through a large angle: what is left is the error of
its small-rotation model, not of its time step.

**Number of modes.** Truncation dominates everything else in these cases: the plate's far-end deflection
with 10 modes is 5.7e-4 from the 60-mode reference, the rod's free-end deflection 3.1e-3 with 10 modes,
6.2e-4 with 20 and 1.2e-4 with 40 (all modes: the reference). With 40 modes the rod's dt·ω_max at dt = 5e-5 s
is 6.9: the consistent scheme and the baseline refuse the run (RK4 limit 2.8), the exponential scheme runs it
in 129 ms. In the reframe modes panel the CPU time grows slowly with the modes (plate: 35 ms for 2 modes,
78 ms for 30). In the FFR beam the per-step cost hardly depends on the modes (hammer: 92–101 ms for 1–40
modes; the Python per-step overhead dominates), so more modes are nearly free there. The static correction
(residual flexibility of the omitted modes) pays once the retained modes cover the input's band: hammer,
24 modes: 3.6e-5 with it, 8.5e-4 without; moving base, 6 modes: 8.8e-6 with, 7.3e-5 without. Below the
band it is harmful: with 1–3 modes under the 1 ms blow the error is 1.6–2.0 with the correction (0.75–0.85
without), because the omitted 40–300 Hz modes respond dynamically, not quasi-statically.

**Mesh.** The Hermite beams converge fast: rod free-end deflection 6.7e-3 (1 element per segment), 1.8e-3,
6.9e-5, 8.8e-6 (8) against 16 elements per segment; FFR hammer tip 4.6e-2, 7.2e-3, 5.1e-4, 5.3e-5 (8)
against 32. The plate's tetrahedral mesh converges slowly: 5.1e-2 (10x2x1), 1.2e-2 (20x2x1), 2.2e-3 (40x4x1)
against 80x6x2, so on the plate the mesh, not the time step or the integrator, limits the accuracy of the
paper's 20x2x1 load case. The script switches flexfmu's on-disk model cache off (FLEXFMU_CACHE=0) while it
measures, so the set-up CPU times are those of a fresh model. The integration CPU time does not depend on the mesh (rod: 25 ms for
24 … 150 DOFs; plate: 41–55 ms for 945 … 6561 DOFs).

**Automatic model choice** (stars; the simulators' own choice from f_max and tolerance 1e-3: every mode below
f_max, more above it until the mode-acceleration estimate of the truncation error is within tolerance/2, the
static correction, and for the FFR beam a mesh that resolves every retained mode; docs/model_size.md). It meets
the tolerance in every case: plate (f_max = 150 Hz, the band of the 10 ms pulse) 21 coordinates, 1.2e-4 in
69 ms, on the efficient front; rod (300 Hz) 16 coordinates, 4.8e-6 in 61 ms, on the front (the plain modal
sweep needs 40 modes for 1.2e-4). FFR hammer (1500 Hz, the band of the 1 ms blow): 24 modes on 12 elements
per segment, 5.1e-5 in 97 ms. It is flagged "not on the front" only because the panel's reference is the
8-element mesh: 24 modes with the static correction on that very mesh give 3.6e-5 at the same CPU; against a
16-element reference the automatic model is the more accurate one (4.1e-5 against 5.6e-5, docs/model_size.md).
Moving base (300 Hz): 15 modes, 8 elements per segment, 8.6e-6 in 461 ms; 12 modes give 7.9e-6 in 369 ms
(0.8× the CPU) — the rule guards `sensor_u` under a tip moment, an input this case never applies, so it keeps
more modes than this scene needs. The first choice (only the modes below f_max) missed the tolerance
(2.3e-3 on the hammer, 2.9e-3 on the plate): for response quantities the band of the input is not enough.

**FFR integrators.** With the inputs held at their mid-step value, the exact (matrix-exponential) step and
RK4 give the same errors to two digits in both FFR cases from dt = 2.5e-4 s on (second order, the hold's: orders
2.00; at 5e-4 s RK4's hammer error is 1.2e-1 against 9.4e-2) at the same CPU time within noise (hammer 8.7 vs
8.9 ms at dt = 1.25e-4 s; moving base 146 vs 146 ms),
so the input sampling, not the integrator, sets the accuracy of the FFR beam for a given step. With 6 modes
(dt·ω_max ≤ 1 here) RK4 is inside its stability limit; the exact step wins where retained modes are stiff
(RK4 must then sub-step, docs/stability.md, docs/model_size.md), which is why it stays the FFRBeam default.
"""
