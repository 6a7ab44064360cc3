"""Both FMUs through fmpy.simulate_fmu against the reference results in tests/reference/<FMU>/<case>/.

The layout is fmi-cross-check's: <FMU>_in.csv (inputs; absent when there are none), <FMU>_ref.csv (time +
the checked outputs), <FMU>_ref.opt (StartTime, StopTime, StepSize, RelTol), README.md (provenance), plus
<FMU>_start.json with the parameter start values, which that layout has no place for.  The references are
made by independent means (each case's README; generators tests/reference/<FMU>/generate.py).

Conventions (also in tests/reference/FFRBeam/README.md and tests/reference/ReframeBody/README.md):
  * a String start value naming a file in the case folder (a scene JSON, a .npz model) is passed to the FMU
    as that file's absolute path (the FMUs would resolve a relative path against the host's working directory);
  * the FMUs hold their inputs over each communication step, so the input tables are step-shaped: constant
    between rows of different times, a jump is two rows at one time, and every jump falls on a communication
    point (checked here).  fmpy sets inputs at communication points only and takes the value after a jump, so
    the FMU holds exactly the tabulated piecewise-constant input, and so would a host that interpolates
    linearly between rows.  Inputs the table does not list are set to 0 (their default), which also keeps
    fmpy from warning about them;
  * fmpy runs with StepSize as communication step and output interval; every reference time must be an
    output time (to 1e-9 of a step);
  * pass criterion per column c and reference time t: |y_FMU(t) - y_ref(t)| <= RelTol * scale_c with
    scale_c = max_t |y_ref,c|, relative to the column's largest magnitude.  A column that is exactly zero
    throughout the reference (a component that vanishes by symmetry, e.g. omega_1 of the paper's load on the
    rigid plate; the generators write such components as exact zeros) takes the scale of its vector: the
    largest scale of the columns with the same name up to the last "_" (omega_2 for omega_1).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.util import read_csv


REFERENCE = Path(__file__).resolve().parent / "reference"
FMUS = ("FFRBeam", "ReframeBody")
CASES = sorted(p.parent for fmu in FMUS for p in (REFERENCE / fmu).glob(f"*/{fmu}_ref.csv"))
OPT_KEYS = ("StartTime", "StopTime", "StepSize", "RelTol")


def test_every_fmu_has_reference_cases():
    for fmu in FMUS:
        assert any(c.parent.name == fmu for c in CASES), f"no reference case in {REFERENCE / fmu}"


def read_opt(path: Path) -> dict[str, float]:
    opt = {}
    for line in path.read_text().splitlines():
        if line.strip():
            key, value = (part.strip() for part in line.split(",", 1))
            opt[key] = float(value)
    assert set(OPT_KEYS) <= set(opt), f"{path.name} lacks {set(OPT_KEYS) - set(opt)}"
    return opt


def start_values(case: Path, fmu: str) -> dict:
    values = json.loads((case / f"{fmu}_start.json").read_text())
    return {k: str((case / v).resolve()) if isinstance(v, str) and (case / v).is_file() else v
            for k, v in values.items()}


def input_signals(case: Path, fmu: str, md, step: float) -> np.ndarray | None:
    path = case / f"{fmu}_in.csv"
    if not path.is_file():
        return None
    table = read_csv(path)
    names = [v.name for v in md.modelVariables if v.causality == "input"]
    columns = [n for n in table.dtype.names if n != "time"]
    unknown = set(columns) - set(names)
    assert not unknown, f"{path.name}: columns {sorted(unknown)} are not inputs of {fmu}"
    t = table["time"]
    values = np.column_stack([table[n] for n in columns])
    assert np.all(np.diff(t) >= 0), f"{path.name}: time must not decrease"
    ramps = np.flatnonzero((np.diff(t) > 0) & np.any(values[1:] != values[:-1], axis=1))
    assert not ramps.size, f"{path.name}: not step-shaped, the inputs change between t = {t[ramps[0]]} and {t[ramps[0] + 1]}"
    jumps = t[1:][np.diff(t) == 0]
    off = np.abs(jumps / step - np.round(jumps / step)) > 1e-9
    assert not off.any(), f"{path.name}: jumps at t = {jumps[off]} are not communication points"
    signals = np.zeros(len(table), dtype=[("time", float)] + [(n, float) for n in names])
    for n in table.dtype.names:
        signals[n] = table[n]
    return signals


def column_scales(ref: np.ndarray, columns: list[str]) -> dict[str, float]:
    """max_t |y_ref,c|; for a column that is exactly zero throughout, the largest such value among the columns
    of the same vector (same name up to the last "_")."""
    own = {c: float(np.max(np.abs(ref[c]))) for c in columns}
    vector: dict[str, float] = {}
    for c, s in own.items():
        key = c.rsplit("_", 1)[0]
        vector[key] = max(vector.get(key, 0.0), s)
    scales = {c: own[c] if own[c] > 0 else vector[c.rsplit("_", 1)[0]] for c in columns}
    assert all(s > 0 for s in scales.values()), f"reference columns without a scale: {scales}"
    return scales


@pytest.mark.parametrize("case", CASES, ids=[f"{c.parent.name}/{c.name}" for c in CASES])
def test_reference_case(fmus, case):
    fmu = case.parent.name
    assert (case / "README.md").is_file(), f"{case} has no README.md of provenance"
    assert f"{fmu}_start.json" in (case / "README.md").read_text(), "the README must explain the start-value file"
    opt = read_opt(case / f"{fmu}_ref.opt")
    ref = read_csv(case / f"{fmu}_ref.csv")
    columns = [c for c in ref.dtype.names if c != "time"]
    md = read_model_description(str(fmus[fmu]))
    outputs = {v.name for v in md.modelVariables if v.causality == "output"}
    assert set(columns) <= outputs, f"reference columns {sorted(set(columns) - outputs)} are not outputs of {fmu}"

    h = opt["StepSize"]
    tic = time.perf_counter()
    res = simulate_fmu(str(fmus[fmu]),   # a fresh extraction per case, as users run it
                       fmi_type="CoSimulation", start_time=opt["StartTime"],
                       stop_time=opt["StopTime"], step_size=h, output_interval=h,
                       relative_tolerance=opt["RelTol"], start_values=start_values(case, fmu),
                       input=input_signals(case, fmu, md, h), output=columns)
    elapsed = time.perf_counter() - tic

    rows = np.searchsorted(res["time"], ref["time"] - 1e-9 * h)
    rows = np.minimum(rows, len(res) - 1)
    off_grid = np.abs(res["time"][rows] - ref["time"]) > 1e-9 * h
    assert not off_grid.any(), f"reference times not on the FMU's output grid: {ref['time'][off_grid][:5]}"

    tol = opt["RelTol"]
    scales = column_scales(ref, columns)
    report, failures = [], []
    for c in columns:
        got, want = res[c][rows], ref[c]
        dev = np.abs(got - want) / scales[c]
        worst = int(np.argmax(dev))
        report.append(f"  {c:<16} max rel. deviation {dev[worst]:.2e} (scale {scales[c]:.4g})")
        bad = np.flatnonzero(dev > tol)
        if bad.size:
            k = bad[0]
            failures.append(f"{c}: {bad.size} of {len(dev)} times beyond RelTol {tol:g}; first at t = "
                            f"{ref['time'][k]:.6g} s: FMU {got[k]:.12g}, reference {want[k]:.12g}, relative "
                            f"deviation {dev[k]:.3e}; worst at t = {ref['time'][worst]:.6g} s ({dev[worst]:.3e})")
    print(f"\n{fmu}/{case.name}: {len(ref)} reference times, simulate_fmu {elapsed:.2f} s, RelTol {tol:g}")
    print("\n".join(report))
    assert not failures, f"{fmu}/{case.name} (scale = max |reference column|):\n" + "\n".join(failures)
