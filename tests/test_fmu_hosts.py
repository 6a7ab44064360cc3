"""Third-party FMI tooling on our FMUs: fmu-manipulation-toolbox's checker and DNV's libcosim
(libcosimpy) as a host, which must reproduce fmpy's results: one FMU in this process, three kinds
of FMU coupled in one execution, and two executions one after the other in one fresh process (run as
a subprocess so that a crash, also at exit, fails the test instead of ending the session)."""
import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from fmpy import read_model_description

from fmu_helpers import Instance
from host_tools import (describe, fresh_fmu_copy, host_environment, jacobi_reference_in, libcosim_times, run_host,
                        value_references)

LIBCOSIM_MISSING = "libcosimpy (DNV's libcosim) is not installed: install the project's dev extra"


def _libcosim():
    """libcosimpy's classes; the test is skipped (not a collection error) when it is missing."""
    pytest.importorskip("libcosimpy", reason=LIBCOSIM_MISSING)
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    return SimpleNamespace(CosimExecution=CosimExecution, CosimLogLevel=CosimLogLevel,
                           log_output_level=log_output_level, CosimManipulator=CosimManipulator,
                           CosimObserver=CosimObserver, CosimLocalSlave=CosimLocalSlave)


@pytest.mark.parametrize("name", ["FFRBeam", "ReframeBody"])
def test_fmu_manipulation_toolbox_check_passes(fmus, name):
    fmutool = Path(sys.executable).with_name("fmutool")   # the project venv's console script (dev extra)
    assert fmutool.exists(), "fmu-manipulation-toolbox missing: install the project with its dev extra"
    out = subprocess.run([fmutool, "-input", str(fmus[name]), "-check"], capture_output=True, text=True,
                         timeout=300)
    text = out.stdout + out.stderr
    assert out.returncode == 0, text
    assert "seems to be compliant with FMI-2.0" in text and "No semantic error" in text, text


CASES = {
    "FFRBeam": ({"boundary": "XFX", "damping_ratio": 0.02, "load_s": 0.3},
                lambda t: {"F_z": 1.5 * np.sin(60 * t), "base_a_x": 0.5, "base_w_z": 0.3},
                ["sensor_u_y", "sensor_a_x", "sensor_u_z", "reaction_F_z", "reaction_M_x"]),
    "ReframeBody": ({"model": "beam:spatial_double_L", "n_flexible_modes": 4, "load_point_x": 0.14,
                     "load_point_y": 0.15, "load_point_z": 0.16,
                     "output_point_x": 0.0, "output_point_y": 0.0, "output_point_z": 0.0, "omega0_3": 1.0},
                    lambda t: {"F_x": 2.0 * np.cos(30 * t), "M_z": 0.01},
                    ["omega_1", "omega_2", "omega_3", "com_vel_x", "out_acc_y", "q_w", "max_elastic_displacement"]),
}


@pytest.mark.parametrize("name", list(CASES))
def test_libcosim_host_matches_fmpy(fmus, name):
    lc = _libcosim()
    CosimExecution, CosimLocalSlave, CosimObserver = lc.CosimExecution, lc.CosimLocalSlave, lc.CosimObserver
    CosimManipulator, CosimLogLevel, log_output_level = lc.CosimManipulator, lc.CosimLogLevel, lc.log_output_level
    start, inputs, outputs = CASES[name]
    fmu = str(fmus[name])
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    kind = {v.name: v.type for v in md.modelVariables}
    h, n_steps = 1e-3, 25

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(step_size=int(round(h * 1e9)))   # ns
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=fmu, instance_name=name))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    manipulator = CosimManipulator.create_override()
    execution.add_manipulator(manipulator)
    for key, value in start.items():
        setter = {"Real": execution.real_initial_value, "Integer": execution.integer_initial_value,
                  "String": execution.string_initial_value}[kind[key]]
        setter(index, vr[key], value)
    host = []
    for k in range(n_steps):
        values = inputs(k * h)
        manipulator.slave_real_values(index, [vr[n] for n in values], list(values.values()))
        execution.step()
        host.append(observer.last_real_values(index, [vr[n] for n in outputs]))

    inst = Instance(fmus[name], "fmpy", **start).initialize()
    ours = []
    for k, (t, dt) in enumerate(libcosim_times(n_steps, int(round(h * 1e9)))):   # libcosim's doStep arguments
        inst.set(**inputs(k * h))
        inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=dt)
        ours.append(inst.get(*outputs))
    inst.free()
    host, ours = np.array(host), np.array(ours)
    scale = np.abs(ours).max(axis=0)
    assert np.all(scale > 0)
    # identity: libcosim runs in this process, so the FMU is the same binary in the same interpreter, environment
    # and cache, called with the same doubles (the same inputs; libcosim's time points and steps from integer ns)
    np.testing.assert_array_equal(host, ours)


# ---------------------------------------------------------------- libcosim in a fresh process
STEP_NS, N_STEPS = 1_000_000, 25
# Three kinds of FMU in one execution: the wave force drives the beam and the free body.
MIXED = {
    "components": {"beam": ("FFRBeam", {"boundary": "XFX", "damping_ratio": 0.02, "load_s": 0.3}),
                   "body": ("ReframeBody", {"model": "beam:spatial_double_L", "n_flexible_modes": 4,
                                            "load_point_x": 0.14, "load_point_y": 0.15, "load_point_z": 0.16,
                                            "output_point_x": 0.0, "output_point_y": 0.0, "output_point_z": 0.0,
                                            "omega0_3": 1.0}),
                   "wave": ("WaveExcitation", {"wave_height": 0.002, "ramp_time": 0.0})},
    "connections": [("wave", "F_z", "beam", "F_z"), ("wave", "F_x", "body", "F_x"), ("wave", "M_y", "body", "M_y")],
    "outputs": [("beam", "sensor_a_x"), ("beam", "reaction_F_z"), ("beam", "reaction_M_y"), ("body", "com_vel_x"),
                ("body", "omega_2"), ("body", "out_acc_y"), ("wave", "F_x"), ("wave", "F_z")],
}
PAIR = {   # the second execution of the sequence case: FFRBeam alone, its load held by a start value
    "components": {"beam": ("FFRBeam", {"damping_ratio": 0.02, "F_z": 1.5, "base_a_x": 0.5})},
    "connections": [],
    "outputs": [("beam", "sensor_a_x"), ("beam", "reaction_F_z"), ("beam", "reaction_M_y")],
}

LIBCOSIM_DRIVER = r"""
import json, sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave
spec = json.loads(sys.argv[1])
log_output_level(CosimLogLevel.ERROR)
results = []
for run in spec["executions"]:
    execution = CosimExecution.from_step_size(step_size=spec["step_ns"])
    index = {}
    for s in run["slaves"]:
        index[s["name"]] = execution.add_local_slave(CosimLocalSlave(fmu_path=s["fmu"], instance_name=s["name"]))
        for vr, kind, value in s["start"]:
            assert getattr(execution, kind + "_initial_value")(index[s["name"]], vr, value), (s["name"], vr)
    for a, va, b, vb in run["connections"]:
        assert execution.connect_real_variables(index[a], va, index[b], vb) == 0, (a, va, b, vb)   # C status
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    rows = []
    for k in range(spec["steps"]):
        assert execution.step(), f"libcosim step {k + 1} failed"
        rows.append([observer.last_real_values(index[n], [vr])[0] for n, vr in run["outputs"]])
    results.append([[repr(x) for x in r] for r in rows])
    del observer, execution      # libcosim frees the execution and its FMU instances here
    print(f"execution {len(results)} done", file=sys.stderr, flush=True)
print("RESULTS " + json.dumps(results))
"""


def _execution_spec(fmus, spec, fmu_dir: Path) -> dict:
    """The driver's description of one execution, each FMU a fresh copy under fmu_dir (libcosim
    unpacks it anew)."""
    slaves = []
    for name, (model, start) in spec["components"].items():
        fmu = fresh_fmu_copy(fmus[model], fmu_dir / name)
        md = read_model_description(str(fmu))
        kinds = {v.name: v.type for v in md.modelVariables}
        vr = value_references(fmu)
        slaves.append({"name": name, "fmu": str(fmu),
                       "start": [[vr[k], {"Real": "real", "Integer": "integer", "String": "string",
                                          "Boolean": "boolean"}[kinds[k]], v] for k, v in start.items()]})
    vrs = {name: value_references(fmus[model]) for name, (model, _) in spec["components"].items()}
    return {"slaves": slaves,
            "connections": [[a, vrs[a][va], b, vrs[b][vb]] for a, va, b, vb in spec["connections"]],
            "outputs": [[n, vrs[n][v]] for n, v in spec["outputs"]]}


@pytest.fixture(scope="module")
def home(tmp_path_factory):
    """One HOME for the module's host processes: flexfmu's cache (compiled kernels) is filled once."""
    return tmp_path_factory.mktemp("libcosim_home")


def _run_libcosim_process(executions: list, tmp_path: Path, home: Path):
    pytest.importorskip("libcosimpy", reason=LIBCOSIM_MISSING)
    env = host_environment(home)   # a Python host: the venv's python finds libcosimpy itself
    payload = json.dumps({"step_ns": STEP_NS, "steps": N_STEPS, "executions": executions})
    proc = run_host([sys.executable, "-c", LIBCOSIM_DRIVER, payload], env, tmp_path, timeout=180)
    message = describe(proc, env)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULTS ")]
    assert lines, message
    results = [np.array([[float(x) for x in row] for row in rows]) for rows in json.loads(lines[-1][8:])]
    return proc, results, message


def _reference(fmus, spec, home, tmp_path):
    """fmpy's Jacobi run of spec, in a subprocess in the libcosim process's environment (host_environment(home)):
    the same FMU binaries, FMI calls, doubles, HOME (flexfmu cache entries) and BLAS settings (they select the
    kernels of the Python FMUs' set-up), so the same computation.  Run in the test process instead it is not
    (another environment and cache: the C host's test measured 2e-12 apart with OPENBLAS_CORETYPE=Prescott)."""
    components = {name: (fmus[model], start) for name, (model, start) in spec["components"].items()}
    rows = jacobi_reference_in(components, spec["connections"], spec["outputs"], libcosim_times(N_STEPS, STEP_NS),
                               host_environment(home), tmp_path)
    return rows[1:]    # libcosim's observer has no values before the first step


def _assert_close(got, reference, message, what):
    assert got.shape == reference.shape, f"{what}: {got.shape} vs {reference.shape}" + message
    scale = np.abs(reference).max(axis=0)
    assert np.all(scale > 0), f"{what}: an output stays zero"
    # identity: the same FMUs, calls, doubles and environment (_reference); repr round-trips exactly
    if not np.array_equal(got, reference):
        worst = np.max(np.abs(got - reference) / scale)
        pytest.fail(f"{what}: not bit for bit, relative difference {worst:.3g}" + message)


def test_libcosim_runs_three_kinds_of_fmu_in_one_execution(fmus, home, tmp_path):
    """FFRBeam, ReframeBody and WaveExcitation in one libcosim execution (one process, one Python
    interpreter for all three), the wave's force and moment connected to the beam and the body."""
    proc, (got,), message = _run_libcosim_process([_execution_spec(fmus, MIXED, tmp_path / "fmus")], tmp_path,
                                                 home)
    _assert_close(got, _reference(fmus, MIXED, home, tmp_path), message, "one execution")
    assert proc.returncode == 0, "results match fmpy, but the process did not end normally" + message


def test_libcosim_two_executions_one_after_the_other(fmus, home, tmp_path):
    """A second execution in the same process after the first is destroyed, each on freshly copied
    FMUs (libcosim unpacks each copy anew): the second must work and give fmpy's numbers too."""
    first = _execution_spec(fmus, MIXED, tmp_path / "first")
    second = _execution_spec(fmus, PAIR, tmp_path / "second")
    proc, results, message = _run_libcosim_process([first, second], tmp_path, home)
    assert len(results) == 2, message
    _assert_close(results[0], _reference(fmus, MIXED, home, tmp_path), message, "first execution")
    _assert_close(results[1], _reference(fmus, PAIR, home, tmp_path), message, "second execution")
    assert proc.returncode == 0, "results match fmpy, but the process did not end normally" + message
