"""The wave-energy converter as a system of FMUs (examples/wave_converter/OspSystemStructure.xml): both
masters (our fmpy loop and libcosim) on the same file agree, the FMUs equal the library, the energy
balance closes, the coupling-stability limit, and `flexfmu cosim`."""
import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from error_bounds import U
from fmu_helpers import ROOT, Instance

from flexfmu import cli
from flexfmu.core import progress
from flexfmu.cosim.masters import (STABILITY_TOLERANCE, Master, load_system, run, run_libcosim, spectral_radius,
                           write_osp)
from flexfmu.errors import FlexfmuError, ParameterError
from flexfmu.wec.system import beam_recorder, energy_balance, harvester_values, point_position, with_models

SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
# Measured with examples/wave_converter/studies.py stability (docs/wave_converter.md)
GS_LIMIT = 4.13e-3
JACOBI_LIMIT = 1.095e-3


@pytest.fixture(scope="module")
def fmu_dir(fmus):
    """The session's one build (tests/conftest.py): the folder holding every FMU."""
    return next(iter(fmus.values())).parent


def _max_rel_diff(a, b, rows_a=slice(None), rows_b=slice(None)):
    worst, where = 0.0, None
    for key in a.columns:
        x, y = a[key][rows_a], b[key][rows_b]
        scale = np.abs(x).max()
        if scale == 0:
            assert np.all(y == 0), key
            continue
        err = np.abs(x - y).max() / scale
        if err > worst:
            worst, where = err, key
    return worst, where


@pytest.mark.parametrize("name", ["WaveExcitation", "Hydrostatics", "Platform", "PTO"])
def test_component_fmus_pass_the_checker_and_report_bad_parameters(fmu_dir, name):
    fmutool = Path(sys.executable).with_name("fmutool")
    out = subprocess.run([fmutool, "-input", str(fmu_dir / f"{name}.fmu"), "-check"], capture_output=True, text=True,
                         timeout=300)
    assert "seems to be compliant with FMI-2.0" in out.stdout + out.stderr and "No semantic error" in out.stdout + out.stderr
    bad = {"WaveExcitation": ("sea_state", "storm"), "Hydrostatics": ("z_G", 0.3), "Platform": ("draft", -1.0),
           "PTO": ("damping", -2.0)}[name]
    inst = Instance(fmu_dir / f"{name}.fmu", **{bad[0]: bad[1]})
    inst.expect_failure(inst.fmu.exitInitializationMode)
    assert bad[0] in inst.messages()
    inst.free()


def test_system_file_connects_every_input_once_and_round_trips(tmp_path):
    system = load_system(SYSTEM)
    assert [s.model for s in system.simulators] == ["WaveExcitation", "Platform", "Hydrostatics", "FFRBeam", "PTO"]
    master = Master(system, "library")             # checks each connection joins an output to an input
    targets = [target for _, target in system.connections]
    assert len(targets) == len(set(targets)) == 51
    fed = {name: {vb for sb, vb in targets if sb == name} for name in master.order}
    assert fed["platform"] == set(master.slaves["platform"].input_names)
    # acc_* / alpha_* feed only the lagged added mass of a flexible platform (added_mass = point, the barge)
    assert fed["hydro"] == {n for n in master.slaves["hydro"].input_names if not n.startswith(("acc_", "alpha_"))}
    assert fed["pto"] == set(master.slaves["pto"].input_names)
    # the box is described identically to the platform and to hydrostatics, and the PTO sits at the tip
    box = ("length", "beam", "draft", "z_G", "r_xx", "r_yy", "r_zz", "rho", "g")
    p, h = system.simulator("platform").initial_values, system.simulator("hydro").initial_values
    assert all(p[k] == h[k] for k in box)
    beam, pto = system.simulator("harvester").initial_values, system.simulator("pto").initial_values
    assert beam["load_s"] == beam["sensor_s"] == 0.45
    assert np.allclose([pto[f"attach_{a}"] for a in "xyz"], point_position("spatial_double_L", 0.45))
    again = load_system(write_osp(system, tmp_path / "copy.xml"))
    assert again.connections == system.connections
    assert [s.initial_values for s in again.simulators] == [s.initial_values for s in system.simulators]


def test_fmpy_master_on_the_fmus_equals_the_library(fmu_dir):
    system = load_system(SYSTEM, fmu_dir=fmu_dir)
    for scheme in ("gauss-seidel", "jacobi"):
        fmu = run(system, 0.2, scheme=scheme, backend="fmu")
        lib = run(system, 0.2, scheme=scheme, backend="library")
        worst, where = _max_rel_diff(fmu, lib)
        # identity: the FMUs run the same library simulators in this process (one interpreter, numpy, BLAS and
        # cache), driven by the same master with the same time points, steps and doubles
        assert worst == 0.0, (scheme, worst, where)


def test_libcosim_and_the_fmpy_master_agree_to_1e9(fmu_dir):
    """Same file, same scheme (Jacobi: libcosim's fixed-step algorithm), same step: every output of
    every FMU at every communication point."""
    system = load_system(SYSTEM, fmu_dir=fmu_dir).with_values({"wave": {"ramp_time": 0.1}})
    ours = run(system, 0.5, scheme="jacobi", backend="fmu")
    theirs = run_libcosim(system, 0.5)
    # two roundings of t_k = k dt: libcosim's k n / 1e9 (integer ns n, one correctly rounded division: <= u t_k)
    # and ours t0 + k h (h = fl(dt) <= u dt off, then the product and the sum: <= 3 u t_k)
    assert np.all(np.abs(theirs.t - ours.t[1:]) <= 4 * U * np.abs(ours.t[1:]))
    assert abs(ours["platform.pos_z"]).max() > 1e-4           # the platform moves
    worst, where = _max_rel_diff(theirs, ours, slice(None), slice(1, None))
    assert worst <= 1e-9, (worst, where)


def test_energy_balance_closes_within_one_percent():
    """The constant-coefficient model's audit (its radiation damping term; the example itself runs the BEM model,
    whose audit is tests/test_wave_bem_cosim.py's): Gauss-Seidel at the example's 1 ms step, wave work = kinetic
    + potential + dissipated + harvested (every term, the harvester's elastic kinetic energy and modal damping
    from the library state); -0.60 % measured, the held hydrostatic force's first-order coupling error."""
    system = load_system(SYSTEM).with_values({n: {"hydrodynamics": "constant"} for n in ("wave", "platform", "hydro")})
    result = run(system, 6.0, scheme="gauss-seidel", backend="library", record=beam_recorder(system))
    balance = energy_balance(result, system)
    assert balance.wave_work > 1.0
    assert abs(balance.relative_residual) < 0.01, balance.table()
    terms = balance.terms
    assert terms["harvested: PTO"] > 0 and terms["dissipated: harvester modal damping (library)"] > 0
    assert terms["dissipated: radiation damping"] > 0.5 * balance.wave_work
    # the platform's own bookkeeping is exact: d(kinetic) = sum of the work of its held inputs
    assert abs(balance.diagnostics["platform: d(kinetic) - sum of work_*"]) < 1e-9 * balance.wave_work
    # the residual is the (first-order) coupling error of the held hydrostatic force
    assert abs(balance.diagnostics["hydro interface: work_hydro + dPE + radiated"]) > 0.5 * abs(balance.residual)


def test_coupling_stability_limit_linear_analysis_and_direct_runs():
    system = load_system(SYSTEM)
    assert spectral_radius(system, 1e-3, "gauss-seidel") <= 1 + STABILITY_TOLERANCE
    assert spectral_radius(system, 1e-3, "jacobi") <= 1 + STABILITY_TOLERANCE
    assert spectral_radius(system, 0.98 * GS_LIMIT, "gauss-seidel") <= 1 + STABILITY_TOLERANCE
    assert spectral_radius(system, 1.02 * GS_LIMIT, "gauss-seidel") > 1 + STABILITY_TOLERANCE
    assert spectral_radius(system, 1.02 * JACOBI_LIMIT, "jacobi") > 1 + STABILITY_TOLERANCE
    # direct runs started suddenly (no ramp: every harvester mode is excited): Jacobi just outside its
    # limit grows by orders of magnitude where 1 ms does not; Gauss-Seidel at 4.2 ms diverges
    sudden = system.with_values({"wave": {"ramp_time": 0.0}})
    peak = {}
    for h in (1e-3, 1.5e-3):
        r = run(sudden, round(2.0 / h) * h, h, scheme="jacobi", backend="library")
        v = np.abs(r["harvester.sensor_v_z"])
        peak[h] = (v[: len(v) // 6].max(), v[-len(v) // 6:].max())
    assert peak[1e-3][1] < peak[1e-3][0]                  # decays after the start
    assert peak[1.5e-3][1] > 10 * peak[1.5e-3][0]           # grows
    with pytest.raises(FlexfmuError, match="diverged"):
        run(sudden, 4.2e-3 * 700, 4.2e-3, scheme="gauss-seidel", backend="library")


def test_cli_cosim_writes_csv_prints_energy_and_progress(fmu_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(progress, "DEFAULT_DELAY_S", 0.0)      # a short run shows its progress too
    out = tmp_path / "results.csv"
    status = cli.main(["cosim", str(SYSTEM), "--t-end", "0.3", "--out", str(out), "--fmu-dir", str(fmu_dir),
                       "--every", "10"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "energy balance" in captured.out and "mean harvested power" in captured.out
    assert "flexfmu cosim: 100 % (t = 0.3 s of 0.3 s" in captured.err and "warning" not in captured.err
    progress_lines = [line for line in captured.err.splitlines() if " % (t = " in line]
    assert "\r" not in captured.err and 1 <= len(progress_lines) <= 11      # a log, not a redrawn bar
    with out.open() as f:
        rows = list(csv.reader(f))
    assert rows[0][0] == "time" and "platform.pos_z" in rows[0] and "pto.power" in rows[0]
    assert len(rows) == 1 + 31 and float(rows[-1][0]) == pytest.approx(0.3)


def test_cli_cosim_warns_outside_the_stability_limit(capsys):
    status = cli.main(["cosim", str(SYSTEM), "--t-end", "0.012", "--step", "0.002", "--scheme", "jacobi",
                       "--master", "library"])
    err = capsys.readouterr().err
    assert status == 0
    assert "warning" in err and "coupling-stability limit" in err
    assert cli.main(["cosim", "no/such/OspSystemStructure.xml", "--t-end", "1"]) == 2
    assert "SYSTEM_FILE" in capsys.readouterr().err


def test_harvester_point_per_boundary_and_errors(tmp_path):
    system = load_system(SYSTEM)
    xfx = with_models(system, harvester_values("XFX"))
    assert xfx.simulator("harvester").initial_values["load_s"] == 0.30
    assert np.allclose([xfx.simulator("pto").initial_values[f"attach_{a}"] for a in "xyz"], [0.14, 0.0, 0.16])
    with pytest.raises(ParameterError, match="boundary"):
        harvester_values("FFF")
    with pytest.raises(ParameterError, match="step"):
        run(system, 1.0, 0.3, backend="library")                 # does not divide the run
    missing = system.with_fmu_dir(tmp_path)
    with pytest.raises(ParameterError, match="not found"):
        run(missing, 0.01, backend="fmu")
    with pytest.raises(FlexfmuError, match="diverged"):          # far outside the limit
        run(system.with_values({"wave": {"ramp_time": 0.0}}), 3.0, 0.01, scheme="jacobi", backend="library")
    assert math.isfinite(GS_LIMIT)


def test_step_limit_finds_the_narrow_band_below_the_wide_instability():
    """Gauss-Seidel stability of the example comes in bands (the rod's modes aliased by the step): a narrow one at
    2.25-2.26 ms (its 5th mode, 219 Hz, at the Nyquist frequency 1/(2h)) below the wide instability from 4.14 ms.
    step_limit's fine scan (ratio 1.05) finds the narrow band; a coarse one (ratio ~1.43) steps over it."""
    from flexfmu.cosim.masters import step_limit
    system = load_system(SYSTEM)
    fine = step_limit(system, rtol=0.002)
    coarse = step_limit(system, rtol=0.002, scan_ratio=1.43)
    print(f"\nGauss-Seidel step limit: fine scan {fine * 1e3:.4f} ms, coarse scan {coarse * 1e3:.4f} ms")
    assert 2.2e-3 < fine < 2.26e-3
    assert spectral_radius(system, fine) <= 1 + STABILITY_TOLERANCE
    assert spectral_radius(system, 2.26e-3) > 1 + 1e-3            # the band, at a step of its own
    assert coarse > 4e-3
