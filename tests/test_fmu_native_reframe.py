"""The native ReframeBody FMU (the reframe kind, csrc/native_reframe.c over reframe_kernels.c) against the Python
ReframeBody FMU: the paper's plate scenario (examples/reframe_plate.py) output for output, no Python in the
binary, FMU-state round trips, parameters refused as the Python FMU refuses them."""
from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

sys.path.insert(0, str(Path(__file__).parent))
from fmu_helpers import (Instance, discard_messages, error_messages, fmu_checker_findings,  # noqa: E402
                         refusal_messages)

ROOT = Path(__file__).resolve().parents[1]


def _plate_module():
    spec = importlib.util.spec_from_file_location("reframe_plate_test", ROOT / "examples" / "reframe_plate.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


PLATE = _plate_module()
STEP = 1e-3               # examples/reframe_plate.py's default communication step


@pytest.fixture(scope="session")
def native_reframe(tmp_path_factory):
    """{"default": the native ReframeBody (defaults), "python": the Python ReframeBody FMU}."""
    from flexfmu.fmi import native as build
    out = tmp_path_factory.mktemp("native_reframe")
    return {"default": build.build_registry_fmu("ReframeBody", target=out / "ReframeBody.fmu")}


def plate_record(fmu, t_end=1.0, step=STEP, **start):
    """The plate scenario: 50 N along [1 0 1]/sqrt(2) at the paper's load point as a 10 ms half-sine; all outputs."""
    from flexfmu.reframe.simulator import INPUT_NAMES, OUTPUT_NAMES
    t = np.arange(0.0, t_end + step / 2, step)
    shape = np.where(t < PLATE.PULSE, np.sin(np.pi * t / PLATE.PULSE), 0.0)
    signals = np.zeros(len(t), dtype=[("time", float)] + [(name, float) for name in INPUT_NAMES])
    signals["time"] = t
    signals["F_x"], signals["F_z"] = PLATE.FORCE[0] * shape, PLATE.FORCE[2] * shape
    return simulate_fmu(str(fmu), start_time=0.0, stop_time=t_end, step_size=step, output_interval=step,
                        input=signals, start_values=start, output=list(OUTPUT_NAMES))


def relative_difference(a, b) -> dict:
    out = {}
    for name in b.dtype.names[1:]:
        scale = float(np.max(np.abs(b[name])))
        out[name] = float(np.max(np.abs(a[name] - b[name]))) / (scale if scale > 0 else 1.0)
    return out


def test_plate_scenario_equals_the_python_fmu(native_reframe, fmus):
    native = plate_record(native_reframe["default"])
    python = plate_record(fmus["ReframeBody"])
    assert np.array_equal(native["time"], python["time"])
    diff = relative_difference(native, python)
    worst = max(diff, key=diff.get)
    print(f"native vs python ReframeBody, plate scenario 1 s: worst {worst} {diff[worst]:.3g}")
    assert diff[worst] <= 1e-10, diff
    assert np.max(np.abs(native["omega_2"])) > 0.01         # the body does spin up


@pytest.mark.parametrize("start", [{"damping_ratio": 0.02, "tolerance": 1e-6},
                                   {"internal_step": 2.5e-4, "force_follows_body": True},
                                   {"omega0_1": 3.0, "omega0_3": 250.0, "v0_y": 0.5}],
                         ids=["damping-tolerance", "internal_step-follower", "initial-spin"])
def test_runtime_parameters_equal_the_python_fmu(native_reframe, fmus, start):
    native = plate_record(native_reframe["default"], t_end=0.2, **start)
    python = plate_record(fmus["ReframeBody"], t_end=0.2, **start)
    diff = relative_difference(native, python)
    assert max(diff.values()) <= 1e-10, diff


def test_the_binary_needs_no_python(native_reframe, tmp_path):
    from fmpy import extract
    folder = extract(str(native_reframe["default"]), str(tmp_path / "x"))
    so = Path(folder) / "binaries" / "linux64" / "ReframeBody.so"
    if shutil.which("ldd"):
        libs = subprocess.run(["ldd", str(so)], capture_output=True, text=True, check=True).stdout
        assert "python" not in libs.lower(), libs
    md = read_model_description(str(native_reframe["default"]))
    assert md.coSimulation.needsExecutionTool is False or str(md.coSimulation.needsExecutionTool).lower() == "false"


H = 2e-3


def _steps(inst, n, start_step=0, **inputs):
    rows = []
    for k in range(start_step, start_step + n):
        inst.set(**inputs)
        inst.fmu.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
        rows.append(inst.get("omega_1", "omega_2", "out_acc_z", "com_pos_x", "q_w", "max_elastic_displacement"))
    return np.array(rows)


def test_fmu_state_get_set_serialise_round_trip(native_reframe):
    a = Instance(native_reframe["default"], "a", damping_ratio=0.03).initialize()
    b = Instance(native_reframe["default"], "b")
    try:
        _steps(a, 20, F_x=30.0, F_z=-20.0)
        state = a.fmu.getFMUstate()
        data = a.fmu.serializeFMUstate(state)
        first = _steps(a, 15, 20, F_z=5.0)
        a.fmu.setFMUstate(state)
        again = _steps(a, 15, 20, F_z=5.0)
        assert np.array_equal(first, again)
        b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(data))
        assert np.array_equal(_steps(b, 15, 20, F_z=5.0), first)
        assert b.fmu.getReal([b.vr["damping_ratio"]]) == [0.03]
        a.fmu.freeFMUstate(state)
    finally:
        a.free()
        b.free()




def searches(inst) -> int:
    """fmi2Terminate, then the count of max_elastic_displacement searches the reframe kind logs there (logAll)."""
    inst.fmu.terminate()
    (line,) = [m for s, category, m in inst.log if s == 0 and category == "logAll"
               and m.startswith("max_elastic_displacement: ")]
    return int(line.split()[1])


def deferred_read_record(fmu, python_fmu, cheap: str, forces: dict, n=40):
    """Three instances stepped alike (``forces``: input name -> peak of a 10 ms half-sine): ``lazy`` reads only
    ``cheap`` each step and max_elastic_displacement every 10th step, twice (after the others: the deferred
    computation alone), and once more after restoring an FMU state taken at step n/2 (taken without it), and after
    restoring that state serialised and deserialised; ``eager``
    and the Python FMU read both together.  Returns the search counts and the values read."""
    lazy, eager = Instance(fmu, "lazy").initialize(), Instance(fmu, "eager").initialize()
    python = Instance(python_fmu, "python").initialize()
    try:
        rows, lazy_max, python_rows = [], {}, []
        for k in range(n):
            shape = np.sin(np.pi * k * H / 0.01) if k * H < 0.01 else 0.0
            for inst in (lazy, eager, python):
                inst.set(**{name: peak * shape for name, peak in forces.items()})
                inst.fmu.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
            rows.append(eager.get(cheap, "max_elastic_displacement"))
            assert eager.get("max_elastic_displacement") == [rows[-1][1]]     # still valid: not searched again
            python_rows.append(python.get(cheap, "max_elastic_displacement"))
            assert lazy.get(cheap) == [rows[-1][0]]
            if k == n // 2:
                state = lazy.fmu.getFMUstate()
            if k % 10 == 9:
                lazy_max[k] = lazy.get("max_elastic_displacement")[0]
                assert lazy.get("max_elastic_displacement") == [lazy_max[k]]
        data = lazy.fmu.serializeFMUstate(state)
        lazy.fmu.setFMUstate(state)
        lazy_max["restored"] = lazy.get("max_elastic_displacement")[0]
        lazy.fmu.freeFMUstate(state)
        lazy.fmu.setFMUstate(lazy.fmu.deSerializeFMUstate(data))
        lazy_max["deserialised"] = lazy.get("max_elastic_displacement")[0]
        return {"lazy": searches(lazy), "eager": searches(eager), "lazy_max": lazy_max, "rows": np.array(rows),
                "python": np.array(python_rows)}
    finally:
        for inst in (lazy, eager, python):
            inst.free()


def check_deferred_reads(fmu, python_fmu, cheap: str, forces: dict, n: int = 40) -> None:
    """deferred_read_record's searches and values: one per initialisation, read and restored state (lazy), one per
    step (eager); the lazily read values equal the eager ones bit for bit and the Python FMU's to 1e-10."""
    got = deferred_read_record(fmu, python_fmu, cheap, forces, n=n)
    assert got["eager"] == 1 + n
    assert got["lazy"] == 1 + 4 + 2                   # initialisation, 4 reads, the restored states
    rows = got["rows"]
    assert all(got["lazy_max"][k] == rows[k, 1] for k in (9, 19, 29, 39))
    assert got["lazy_max"]["restored"] == got["lazy_max"]["deserialised"] == rows[n // 2, 1]
    assert np.max(rows[:, 1]) > 0
    scale = np.max(np.abs(got["python"]), axis=0)
    assert np.all(np.max(np.abs(rows - got["python"]), axis=0) <= 1e-10 * scale)


def test_max_elastic_displacement_is_computed_only_when_read(native_reframe, fmus):
    """The whole-mesh search runs at initialisation (every output once, as the Python FMU) and then only when
    max_elastic_displacement is read, once per state; computed alone it equals the value computed with the other
    outputs (bit for bit) and the Python FMU's."""
    check_deferred_reads(native_reframe["default"], fmus["ReframeBody"], "pos_x", {"F_x": 35.0, "F_z": 35.0})


BAD = {
    "tolerance out of range": lambda i: (i.set(tolerance=2.0), i.initialize()),
    "damping_ratio out of range": lambda i: (i.set(damping_ratio=1.0), i.initialize()),
    "max_internal_steps out of range": lambda i: (i.set(max_internal_steps=0), i.initialize()),
    "NaN input": lambda i: i.fmu.setReal([i.vr["F_x"]], [float("nan")]),
    "moment on a 3-DOF model": lambda i: (i.initialize(), i.set(M_x=1.0),
                                          i.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=H)),
}


@pytest.mark.parametrize("label", list(BAD))
def test_bad_parameters_and_inputs_are_refused_as_by_the_python_fmu(native_reframe, fmus, label):
    logs = refusal_messages((native_reframe["default"], fmus["ReframeBody"]), BAD[label])
    assert len(logs[0]) == 1 and logs[0] == logs[1], logs


def test_a_fixed_parameter_refuses_another_value(native_reframe):
    inst = Instance(native_reframe["default"], "fixed")
    try:
        inst.set(n_flexible_modes=10)                                   # its build value: fine
        inst.expect_failure(inst.set, n_flexible_modes=12)
        (message,) = error_messages(inst)
        assert "built with n_flexible_modes = 10" in message
        assert "flexfmu build --runtime native --fmu ReframeBody --set n_flexible_modes=12" in message
    finally:
        inst.free()


def test_a_too_long_step_is_discarded_as_by_the_python_fmu(native_reframe, fmus):
    logs = discard_messages((native_reframe["default"], fmus["ReframeBody"]), 0.5, internal_step=1e-3, max_internal_steps=10)
    assert logs[0] == logs[1] and len(logs[0]) == 1, logs


def test_fmpy_validate_and_the_fmu_checker_find_no_problem(native_reframe):
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(native_reframe["default"])) == []
    assert fmu_checker_findings(native_reframe["default"]) == ""
