"""The FMI 2.0 shim (build_scripts/fmi2_shim.c) on a tiny pythonfmu probe FMU, driven through fmpy.

The probe logs an fmi2Error message naming the variable and then raises for a bad parameter, a
NaN input, a step <= 0 and a fixed parameter set after initialisation.  It raises without logging
for a huge input (a genuine fatal).  Sequences that would crash a process without the shim run in
a subprocess (this file run as a script) so that a segfault cannot take the test session down.
"""
from __future__ import annotations

import gc
import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fmu_helpers import ROOT, Instance  # noqa: E402

ERROR, FATAL = 3, 4

PROBE_SOURCE = '''
import math
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status


class ShimProbe(Fmi2Slave):
    description = "FMI shim probe: y integrates k*u"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 2.0
        self.u = 0.0
        self.y = 0.0
        self.initialised = False
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                    setter=self._set_k))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def _fail(self, message):
        self.log(message, Fmi2Status.error)
        raise ValueError(message)

    def _set_k(self, value):
        if self.initialised:
            self._fail("k: a fixed parameter cannot be set after initialisation")
        self.k = value

    def exit_initialization_mode(self):
        if self.k < 0:
            self._fail(f"k: must be >= 0, got {self.k}")
        self.initialised = True
        self.log(f"initialised with k={self.k}")

    def do_step(self, current_time, step_size):
        if step_size <= 0:
            self._fail(f"step_size: must be > 0, got {step_size}")
        if math.isnan(self.u):
            self._fail("u: input is NaN")
        if self.u > 1e6:
            raise RuntimeError("unexpected failure")   # a bug, not a bad input: no fmi2Error message
        self.y += self.k * self.u * step_size
        return True

    def _get_fmu_state(self):
        return {"k": self.k, "u": self.u, "y": self.y, "initialised": self.initialised}

    def _set_fmu_state(self, state):
        self.__dict__.update(state)
'''


def _shim_module():
    spec = importlib.util.spec_from_file_location("fmi2_shim", ROOT / "build_scripts" / "fmi2_shim.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def build_probe(folder: Path, shim: bool = True) -> Path:
    from pythonfmu.builder import FmuBuilder
    folder.mkdir(parents=True, exist_ok=True)
    script = folder / "ShimProbe.py"
    script.write_text(PROBE_SOURCE)
    fmu = Path(FmuBuilder.build_FMU(script, dest=folder / "out", canGetAndSetFMUstate=True,
                                    canSerializeFMUstate=True))
    if shim:
        _shim_module().apply_shim(fmu)
    return fmu


@pytest.fixture(scope="session")
def probe(tmp_path_factory) -> Path:
    return build_probe(tmp_path_factory.mktemp("shim_probe"))


@pytest.fixture(scope="session")
def unshimmed_probe(tmp_path_factory) -> Path:
    return build_probe(tmp_path_factory.mktemp("raw_probe"), shim=False)


def run_scenario(fmu: Path, scenario: str, *args: str) -> dict:
    """Run a scenario of this file in a fresh Python process; returns its JSON report."""
    proc = subprocess.run([sys.executable, __file__, scenario, str(fmu), *args],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"scenario {scenario} {args} exited with {proc.returncode}:\n{proc.stdout}\n{proc.stderr}"
    return json.loads(proc.stdout.strip().splitlines()[-1])


def start(fmu: Path, name: str = "probe", **start_values) -> Instance:
    """Instantiated probe in initialization mode."""
    return Instance(fmu, name, **start_values)


def churn():
    """Run the garbage collector and allocate, so that a use of a freed Python slave would crash."""
    gc.collect()
    junk = [[i] * 8 for i in range(200_000)]
    del junk
    gc.collect()


# ---------------------------------------------------------------- the package and the normal path

def test_shim_replaces_linux_binary_only(probe, unshimmed_probe):
    import zipfile
    with zipfile.ZipFile(probe) as zf:
        names = set(zf.namelist())
        shim_size = zf.getinfo("binaries/linux64/ShimProbe.so").file_size
        inner_size = zf.getinfo("binaries/linux64/ShimProbe_pythonfmu.so").file_size
    assert "binaries/win64/ShimProbe.dll" in names
    assert shim_size < inner_size      # the small C shim, not pythonfmu's C++ library
    # pythonfmu's raw modelDescription lacks InitialUnknowns (build_fmus.py adds them): same problems
    assert validate_fmu(str(probe)) == validate_fmu(str(unshimmed_probe))


def test_apply_shim_twice_keeps_the_pythonfmu_library(tmp_path, probe, unshimmed_probe):
    import shutil
    import zipfile
    again = tmp_path / "again.fmu"
    shutil.copy(probe, again)
    _shim_module().apply_shim(again)
    with zipfile.ZipFile(again) as zf, zipfile.ZipFile(unshimmed_probe) as raw:
        assert zf.read("binaries/linux64/ShimProbe_pythonfmu.so") == raw.read("binaries/linux64/ShimProbe.so")
        assert len(zf.namelist()) == len(raw.namelist()) + 1
    inst = start(again, k=1.0).initialize()
    inst.set(u=math.nan)
    assert inst.expect_failure(inst.fmu.doStep, 0.0, 0.1).status == ERROR


def test_missing_gcc_is_a_clear_error(tmp_path, unshimmed_probe, monkeypatch):
    import shutil
    module = _shim_module()
    monkeypatch.setattr(module.shutil, "which", lambda name: None)
    fmu = tmp_path / "raw.fmu"
    shutil.copy(unshimmed_probe, fmu)
    before = fmu.read_bytes()
    with pytest.raises(module.ShimError, match="gcc not found"):
        module.apply_shim(fmu)
    assert fmu.read_bytes() == before          # the FMU is left untouched


def test_normal_stepping(probe):
    inst = start(probe, k=3.0).initialize()
    inst.set(u=1.5)
    for i in range(4):
        inst.fmu.doStep(currentCommunicationPoint=0.1 * i, communicationStepSize=0.1)
    assert inst.get("y")[0] == pytest.approx(3.0 * 1.5 * 0.4)
    assert "initialised with k=3.0" in inst.messages()      # slave messages reach the host
    inst.free()


def test_simulate_fmu_through_the_shim(probe):
    res = simulate_fmu(str(probe), start_time=0.0, stop_time=1.0, step_size=0.25,
                       start_values={"k": 0.5, "u": 2.0}, output=["y"])
    assert res["y"][-1] == pytest.approx(1.0)


def test_reset_of_a_healthy_instance(probe):
    inst = start(probe, k=1.0).initialize()
    inst.set(u=1.0)
    inst.fmu.doStep(0.0, 1.0)
    inst.fmu.reset()
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    inst.fmu.exitInitializationMode()
    assert inst.get("y")[0] == 0.0 and inst.get("k")[0] == 2.0   # back to the start values
    inst.free()


def test_two_instances_are_independent(probe):
    a = start(probe, "a", k=1.0).initialize()
    b = start(probe, "b", k=10.0).initialize()
    a.set(u=1.0)
    b.set(u=2.0)
    a.fmu.doStep(0.0, 0.5)
    b.fmu.doStep(0.0, 0.25)
    assert a.get("y")[0] == pytest.approx(0.5)
    assert b.get("y")[0] == pytest.approx(5.0)
    a.free()
    b.free()


def test_fmu_state_get_set_and_serialize(probe):
    inst = start(probe, k=2.0).initialize()
    inst.set(u=1.0)
    inst.fmu.doStep(0.0, 0.5)
    state = inst.fmu.getFMUstate()
    blob = inst.fmu.serializeFMUstate(state)
    inst.fmu.doStep(0.5, 0.5)
    assert inst.get("y")[0] == pytest.approx(2.0)
    inst.fmu.setFMUstate(state)
    assert inst.get("y")[0] == pytest.approx(1.0)
    restored = inst.fmu.deSerializeFMUstate(blob)
    inst.fmu.doStep(0.5, 0.5)
    inst.fmu.setFMUstate(restored)
    assert inst.get("y")[0] == pytest.approx(1.0)
    inst.fmu.freeFMUstate(state)
    inst.fmu.freeFMUstate(restored)
    inst.free()


def test_error_messages_reach_the_host_with_debug_logging_off(probe):
    """pythonfmu drops every message when logging is off; the shim still reports errors."""
    inst = start(probe, k=1.0)
    inst.fmu.setDebugLogging(False, [])
    inst.initialize()
    assert inst.log == []                       # the fmi2OK message is filtered out
    inst.set(u=math.nan)
    exc = inst.expect_failure(inst.fmu.doStep, 0.0, 0.1)
    assert exc.status == ERROR
    assert [m for s, _, m in inst.log if s == ERROR and "u: input is NaN" in m]


# ---------------------------------------------------------------- errors (subprocesses)

ERROR_CASES = {
    # case: (variable named in the message, failing FMI function)
    "k_negative": ("k", "fmi2ExitInitializationMode"),
    "u_nan": ("u", "fmi2DoStep"),
    "step_zero": ("step_size", "fmi2DoStep"),
    "step_negative": ("step_size", "fmi2DoStep"),
    "fixed_after_init": ("k", "fmi2SetReal"),
}


@pytest.mark.parametrize("then", ["reset", "free"])
@pytest.mark.parametrize("case", list(ERROR_CASES))
def test_error_returns_fmi2error_and_instance_stays_usable(probe, case, then):
    report = run_scenario(probe, "error", case, then)
    variable, function = ERROR_CASES[case]
    assert report["status"] == ERROR, report
    assert "status 3 (error)" in report["exception"] and function in report["exception"]
    assert any(s == ERROR and m.startswith(f"{variable}:") for s, m in report["log"]), report["log"]
    assert all(s != FATAL for s, m in report["log"]), report["log"]
    assert report["terminate"] == 0                         # answered by the shim, no crash
    assert report["get_after_error"] == ERROR              # refused, not forwarded (freed slave)
    assert report["free_state_after_error"] == 0
    if then == "reset":
        assert report["y_after_reset"] == pytest.approx(1.5)   # fresh instance: k=3, u=1, h=0.5
    assert report["done"]


def test_genuine_fatal_stays_fatal(probe):
    report = run_scenario(probe, "fatal")
    assert report["status"] == FATAL
    assert "status 4 (fatal)" in report["exception"]
    assert any(s == FATAL and "Fatal py exception" in m for s, m in report["log"]), report["log"]
    assert report["get_after_fatal"] == FATAL
    assert report["done"]                                   # fmi2FreeInstance did not crash


def test_rollback_with_set_fmu_state_after_an_error(probe):
    report = run_scenario(probe, "rollback")
    assert report["status"] == ERROR
    assert report["y_after_rollback"] == pytest.approx(1.0)      # the state saved before the error
    assert report["y_after_retry"] == pytest.approx(1.0 + 2.0 * 0.5 * 0.5)


def test_error_in_one_instance_leaves_the_other_alone(probe):
    report = run_scenario(probe, "two")
    assert report["status_a"] == ERROR
    assert report["y_b"] == pytest.approx(10.0 * 2.0 * 0.5)


def test_without_shim_pythonfmu_returns_fatal_and_crashes_afterwards(unshimmed_probe):
    """Why the shim never calls a broken pythonfmu component again: the freed Python slave is used."""
    proc = subprocess.run([sys.executable, __file__, "raw", str(unshimmed_probe)],
                          capture_output=True, text=True, timeout=300)
    assert "status 4 (fatal)" in proc.stdout
    assert proc.returncode != 0 and "survived" not in proc.stdout


# ---------------------------------------------------------------- subprocess scenarios

def _attempt(call, *args):
    """Status of an FMI call made through fmpy (0 when it succeeded) and the exception text."""
    try:
        call(*args)
    except FMICallException as exc:
        return exc.status, str(exc)
    return 0, ""


def _scenario_error(fmu: Path, case: str, then: str) -> dict:
    inst = start(fmu, k=-1.0 if case == "k_negative" else 2.0)
    saved = inst.fmu.getFMUstate()
    if case == "k_negative":
        status, text = _attempt(inst.fmu.exitInitializationMode)
    else:
        inst.initialize()
        if case == "u_nan":
            inst.set(u=math.nan)
            status, text = _attempt(inst.fmu.doStep, 0.0, 0.1)
        elif case in ("step_zero", "step_negative"):
            status, text = _attempt(inst.fmu.doStep, 0.0, 0.0 if case == "step_zero" else -0.1)
        else:   # fixed_after_init
            status, text = _attempt(inst.fmu.setReal, [inst.vr["k"]], [5.0])
    report = {"status": status, "exception": text, "log": [(s, m) for s, _, m in inst.log]}
    churn()
    report["terminate"] = _attempt(inst.fmu.terminate)[0]
    churn()
    report["get_after_error"] = _attempt(inst.get, "y")[0]
    report["free_state_after_error"] = _attempt(inst.fmu.freeFMUstate, saved)[0]
    churn()
    if then == "reset":
        inst.fmu.reset()
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        inst.set(k=3.0)
        inst.initialize()
        inst.set(u=1.0)
        inst.fmu.doStep(0.0, 0.5)
        report["y_after_reset"] = inst.get("y")[0]
        inst.fmu.terminate()
    inst.fmu.freeInstance()
    churn()
    report["done"] = True
    return report


def _scenario_fatal(fmu: Path) -> dict:
    inst = start(fmu).initialize()
    inst.set(u=2e6)
    status, text = _attempt(inst.fmu.doStep, 0.0, 0.1)
    report = {"status": status, "exception": text, "log": [(s, m) for s, _, m in inst.log]}
    churn()
    report["get_after_fatal"] = _attempt(inst.get, "y")[0]
    inst.fmu.freeInstance()     # not allowed after fmi2Fatal by FMI 2.0, but many hosts do it
    churn()
    report["done"] = True
    return report


def _scenario_rollback(fmu: Path) -> dict:
    inst = start(fmu, k=2.0).initialize()
    inst.set(u=1.0)
    inst.fmu.doStep(0.0, 0.5)
    state = inst.fmu.getFMUstate()
    status, _ = _attempt(inst.fmu.doStep, 0.5, -1.0)
    churn()
    inst.fmu.setFMUstate(state)
    report = {"status": status, "y_after_rollback": inst.get("y")[0]}
    inst.set(u=0.5)
    inst.fmu.doStep(0.5, 0.5)
    report["y_after_retry"] = inst.get("y")[0]
    inst.fmu.freeFMUstate(state)
    inst.fmu.terminate()
    inst.fmu.freeInstance()
    return report


def _scenario_two(fmu: Path) -> dict:
    a = start(fmu, "a").initialize()
    b = start(fmu, "b", k=10.0).initialize()
    a.set(u=math.nan)
    status_a, _ = _attempt(a.fmu.doStep, 0.0, 0.5)
    churn()
    b.set(u=2.0)
    b.fmu.doStep(0.0, 0.5)
    report = {"status_a": status_a, "y_b": b.get("y")[0]}
    a.fmu.terminate()
    a.fmu.freeInstance()
    churn()
    b.fmu.terminate()
    b.fmu.freeInstance()
    return report


def _scenario_raw(fmu: Path) -> dict:
    """Plain pythonfmu: after its fatal, fmi2Terminate uses the freed Python slave."""
    inst = start(fmu).initialize()
    inst.set(u=math.nan)
    status, text = _attempt(inst.fmu.doStep, 0.0, 0.1)
    print(text, flush=True)
    churn()
    inst.fmu.terminate()
    print("survived", flush=True)
    return {"status": status}


if __name__ == "__main__":
    scenario, fmu_arg, *rest = sys.argv[1:]
    runner = {"error": _scenario_error, "fatal": _scenario_fatal, "rollback": _scenario_rollback,
              "two": _scenario_two, "raw": _scenario_raw}[scenario]
    print(json.dumps(runner(Path(fmu_arg), *rest)), flush=True)
