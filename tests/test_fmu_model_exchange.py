"""Model exchange (FMI 2.0 and 3.0) of the native FMUs that are ODEs in fixed coordinates: FFRBeam and exported
clamped bodies (flexfmu.fmi.interfaces, csrc/native_lti.c's derivatives).

The co-simulation step is the exact zero-order hold of x' = A(p) x + B(p) u + b(p); model exchange gives a host
that same right-hand side.  So with the inputs held as a co-simulation host holds them (each sample until the next:
input events where they change), an integrator reproduces the co-simulation record to its own accuracy.  The bound,
1e-6 of each output's largest value over the record, is asked of model exchange; CVode's global error scales with
its tolerance (atol = rtol x the states' nominals, flexfmu.fmi.interfaces.state_nominals): over the 2 s hammer
record (XFF) it measured 2.5e-5 at rtol 1e-8, 6.8e-7 at 1e-10, 1.4e-8 at 1e-12, so 1e-12 leaves a margin of ~70.
With the nominal 1 (FMI's default) the modal coordinates (~1e-4 for the hammer, ~1e-7 for the bracket) were below
the absolute tolerance: 3e-5 at rtol 1e-10 and 3.7 % on the bracket.
"""
from __future__ import annotations

import ctypes
import subprocess

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu
from me_helpers import (HAMMER_SETTINGS, ROOT, STEP, MeInstance, at_points, fmusim_path, hammer_force,
                        held_signals, relative_difference)

from flexfmu.errors import ParameterError

pytestmark = pytest.mark.fmu
RTOL_CVODE = 1e-12
BOUND = 1e-6
#: the bracket keeps modes up to ~10 kHz (8 retained): CVode takes ~40 steps per output interval of 0.1 ms
BRACKET_STEP = 1e-4


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """FFRBeam for the hammer record (XFF, XFX, FXF; FMI 2.0, and XFF in FMI 3.0) and the bracket exported clamped at
    its bolts, each with both interfaces; ReframeBody (a free body: co-simulation only)."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.native import build_registry_fmu, export_native
    from flexfmu.importers import load_structure

    out = tmp_path_factory.mktemp("me")
    built = {(bc, 2): build_registry_fmu("FFRBeam", settings, target=out / "2" / bc / "FFRBeam.fmu", interface="both")
             for bc, settings in HAMMER_SETTINGS.items()}
    built["XFF", 3] = build_registry_fmu("FFRBeam", HAMMER_SETTINGS["XFF"], target=out / "3" / "FFRBeam.fmu",
                                         fmi_version=3, interface="both")
    structure = load_structure(ROOT / "examples" / "bracket" / "bracket.json")
    clamped = build_body(structure, interfaces=[interface_from_text("tip=arm_top")],
                         clamp=clamp_from_text(structure, "bolt_1,bolt_2"), n_modes=8)
    built["bracket", 2] = export_native(clamped, out / "bracket" / "BracketClamped.fmu", interface="both")
    built["bracket-me", 3] = export_native(clamped, out / "bracket3" / "BracketClamped.fmu", fmi_version=3,
                                           interface="me")
    built["ReframeBody", 2] = build_registry_fmu("ReframeBody", target=out / "free" / "ReframeBody.fmu")
    return built


def doubles(n: int, value: float = 0.0):
    return (ctypes.c_double * n)(*([value] * n))


def outputs_of(fmu):
    return [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output"]


@pytest.mark.parametrize("key", [("XFF", 2), ("XFF", 3), ("bracket", 2), ("bracket-me", 3)])
def test_fmpy_validation_finds_no_problem_and_the_states_are_the_modal_coordinates(fmus, key):
    fmu = fmus[key]
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.modelExchange is not None
    assert (md.coSimulation is None) == (key[0] == "bracket-me")
    states = [d.variable.derivative.name for d in md.derivatives]
    n = len(states) // 2
    assert n >= 1 and states == [f"eta_{k}" for k in range(1, n + 1)] + [f"eta_dot_{k}" for k in range(1, n + 1)]
    if key[1] == 2:
        assert md.modelExchange.providesDirectionalDerivative
    else:   # fmpy 0.3 does not read FMI 3.0's attribute
        from xml.etree import ElementTree as ET
        from zipfile import ZipFile
        root = ET.fromstring(ZipFile(fmu).read("modelDescription.xml"))
        assert root.find("ModelExchange").get("providesDirectionalDerivatives") == "true"
    nominals = [float(d.variable.derivative.nominal) for d in md.derivatives]
    assert all(0 < v < 1 for v in nominals)       # modal coordinates' sizes (kg^0.5 m), not FMI's default 1


@pytest.mark.parametrize("bc", list(HAMMER_SETTINGS))
def test_model_exchange_in_cvode_matches_co_simulation_on_the_hammer_record(fmus, bc):
    fmu = fmus[bc, 2]
    t = np.arange(0.0, 2.0 + STEP / 2, STEP)
    cs_inputs, me_inputs = held_signals(fmu, t, hammer_force(t))
    names = outputs_of(fmu)
    cs = simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=2.0, step_size=STEP, output_interval=STEP,
                      input=cs_inputs, output=names)
    me = simulate_fmu(str(fmu), fmi_type="ModelExchange", stop_time=2.0, step_size=STEP, output_interval=STEP,
                      input=me_inputs, output=names, relative_tolerance=RTOL_CVODE)
    differences = relative_difference(at_points(me, t), cs, names)
    assert max(differences.values()) < BOUND, sorted(differences.items(), key=lambda kv: -kv[1])[:3]
    assert np.max(np.abs(cs["sensor_a_x"])) > 0.1                     # the blow shows: a record, not zeros


def test_fmi3_model_exchange_matches_fmi2_co_simulation(fmus):
    t = np.arange(0.0, 0.5 + STEP / 2, STEP)
    cs_inputs, me_inputs = held_signals(fmus["XFF", 2], t, hammer_force(t))
    names = outputs_of(fmus["XFF", 2])
    cs = simulate_fmu(str(fmus["XFF", 2]), fmi_type="CoSimulation", stop_time=0.5, step_size=STEP,
                      output_interval=STEP, input=cs_inputs, output=names)
    me = simulate_fmu(str(fmus["XFF", 3]), fmi_type="ModelExchange", stop_time=0.5, step_size=STEP,
                      output_interval=STEP, input=me_inputs, output=names, relative_tolerance=RTOL_CVODE)
    assert max(relative_difference(at_points(me, t), cs, names).values()) < BOUND


def test_clamped_body_on_a_moving_base_model_exchange_matches_co_simulation(fmus):
    """The bracket on a shaking, rotating base: the base motion enters A(p), b(p) (held in co-simulation)."""
    t = np.arange(0.0, 0.05 + BRACKET_STEP / 2, BRACKET_STEP)
    values = {"base_a_z": 9.81 * np.sin(40 * t), "base_w_x": 0.5 * np.sin(7 * t), "base_dw_x": 3.5 * np.cos(7 * t),
              "tip.F_y": np.where(t < 0.01, 5.0 * np.sin(np.pi * t / 0.01), 0.0)}
    names = outputs_of(fmus["bracket", 2])
    cs_inputs, me_inputs = held_signals(fmus["bracket", 2], t, values)
    cs = simulate_fmu(str(fmus["bracket", 2]), fmi_type="CoSimulation", stop_time=0.05, step_size=BRACKET_STEP,
                      output_interval=BRACKET_STEP, input=cs_inputs, output=names)
    for key in (("bracket", 2), ("bracket-me", 3)):
        me = simulate_fmu(str(fmus[key]), fmi_type="ModelExchange", stop_time=0.05, step_size=BRACKET_STEP,
                          output_interval=BRACKET_STEP, input=me_inputs, output=names, relative_tolerance=RTOL_CVODE)
        differences = relative_difference(at_points(me, t), cs, names)
        assert max(differences.values()) < BOUND, (key, sorted(differences.items(), key=lambda kv: -kv[1])[:3])


def _states_after_blow(fmu, t_after: float) -> dict:
    """{"cs": bytes, "me": bytes}: the serialised FMU states of a co-simulation instance run through the hammer blow
    to t_after, and of a model-exchange instance (in Continuous-Time Mode) set to its continuous states at t_after
    (read through their value references, which co-simulation instances read too)."""
    cs = MeInstance(fmu, "cs", "blow")
    t = np.arange(0.0, t_after - STEP / 2, STEP)
    force = hammer_force(t)
    for k, tk in enumerate(t):
        cs.set(**{n: force[n][k] for n in force})
        cs.fmu.doStep(tk, STEP)
    cs.set(**{n: 0.0 for n in force})
    x = cs.fmu.getReal(cs.states)
    me = MeInstance(fmu, "me", "blow")
    me.fmu.setTime(cs.fmu.getRealStatus(2))   # fmi2LastSuccessfulTime: the FMU's time
    me.fmu.setContinuousStates((ctypes.c_double * len(x))(*x), len(x))
    states = {}
    for name, inst in (("cs", cs), ("me", me)):
        states[name] = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        inst.free()
    assert np.max(np.abs(x)) > 0
    return states


def test_fmusim_model_exchange_matches_co_simulation_after_the_blow(fmus, tmp_path):
    """fmusim does not restart its integrator at an input discontinuity (it reads the left value at the jump), so a
    held input cannot be given to it exactly: both fmusim runs start from FMU states after the blow (fmpy's
    co-simulation to 1.1 ms; the model-exchange state set to the same continuous states) and ring down with no
    input, in fmusim's own calls of every interface function."""
    fmusim = fmusim_path()
    if fmusim is None:
        pytest.skip("fmusim not built (benchmarks/build_fmusim.sh SOURCE_DIR BUILD_DIR; or set FMUSIM)")
    fmu = fmus["XFF", 2]
    t_after = 0.0011
    runs = {}
    for interface, state in _states_after_blow(fmu, t_after).items():
        (tmp_path / f"{interface}.state").write_bytes(state)
        out = tmp_path / f"{interface}.csv"
        command = [str(fmusim), "--interface-type", interface, "--start-time", repr(t_after), "--stop-time", "0.3",
                   "--output-interval", str(STEP), "--initial-fmu-state-file", str(tmp_path / f"{interface}.state"),
                   "--output-file", str(out), str(fmu)]
        if interface == "me":
            command[1:1] = ["--solver", "cvode", "--tolerance", str(RTOL_CVODE)]
        run = subprocess.run(command, capture_output=True, text=True, timeout=600, env={"PATH": "/usr/bin:/bin"})
        assert run.returncode == 0, run.stdout + run.stderr
        runs[interface] = np.genfromtxt(out, delimiter=",", names=True)
    names = [n for n in runs["cs"].dtype.names if n != "time"]
    cs, me = runs["cs"], runs["me"]
    _, first = np.unique(me["time"], return_index=True)
    me = me[first]
    assert len(me) == len(cs) > 2000 and np.allclose(me["time"], cs["time"], rtol=0, atol=1e-9)
    differences = relative_difference(me, cs, names)
    assert max(differences.values()) < BOUND, sorted(differences.items(), key=lambda kv: -kv[1])[:3]
    assert np.max(np.abs(cs["tip_u_x"])) > 1e-5                     # it rings


# ---------------------------------------------------------------------------------------------- refusals
def test_free_bodies_are_co_simulation_only(fmus, tmp_path):
    from flexfmu.fmi.native import build_registry_fmu
    with pytest.raises(ParameterError, match="interface.*stepping method"):
        build_registry_fmu("ReframeBody", target=tmp_path / "ReframeBody.fmu", interface="me")
    with pytest.raises(ParameterError, match="interface.*cs \\| me \\| both"):
        build_registry_fmu("FFRBeam", target=tmp_path / "FFRBeam.fmu", interface="ME")
    # fmi2Instantiate(fmi2ModelExchange) of a free body returns NULL and tells the host's logger why
    from fmpy import extract
    from fmpy.fmi2 import FMU2Model, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    md = read_model_description(str(fmus["ReframeBody", 2]))
    log = []
    logger = fmi2CallbackLoggerTYPE(lambda c, n, status, cat, m: log.append((status, (m or b"").decode())))
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = logger
    callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
    callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
    inst = FMU2Model(guid=md.guid, unzipDirectory=extract(str(fmus["ReframeBody", 2])),
                     modelIdentifier=md.coSimulation.modelIdentifier, instanceName="me")
    with pytest.raises(Exception):
        inst.instantiate(callbacks=callbacks, loggingOn=True)
    assert [m for status, m in log if status == 3] == [
        "fmi2Instantiate: this model (kind 'reframe') is co-simulation only: it is advanced by its own stepping "
        "method (fmuType/interface: co-simulation)"], log


def test_model_exchange_calls_refused_with_a_message(fmus):
    inst = MeInstance(fmus["XFF", 2], "me")
    n = len(inst.states)
    try:
        for call, args, expected in [
                (inst.fmu.setContinuousStates, (doubles(n, np.nan), n), "continuous state 0: got nan"),
                (inst.fmu.setContinuousStates, (doubles(n + 1), n + 1), f"got {n + 1} states"),
                (inst.fmu.getDerivatives, (doubles(n), n - 1), f"got {n - 1} derivatives"),
                (inst.fmu.getNominalsOfContinuousStates, (doubles(n + 2), n + 2), f"got {n + 2}"),
                (inst.fmu.setTime, (float("inf"),), "time: got inf"),
                (inst.fmu.getEventIndicators, (doubles(1), 1), "0 event indicators")]:
            inst.log.clear()
            with pytest.raises(Exception):
                call(*args)
            assert any(expected in m for m in inst.log), (expected, inst.log)
        # co-simulation calls are not legal in model exchange, nor are states set through fmi2SetReal
        inst.log.clear()
        with pytest.raises(Exception):
            inst.fmu.setReal([inst.states[0]], [1.0])
        assert any("set with fmi2SetContinuousStates" in m for m in inst.log), inst.log
        # an FMU state of a co-simulation instance is not set in a model-exchange one
        cs = MeInstance(fmus["XFF", 2], "cs")
        state = cs.fmu.deSerializeFMUstate(cs.fmu.serializeFMUstate(cs.fmu.getFMUstate()))
        cs.free()
        inst.log.clear()
        with pytest.raises(Exception):
            inst.fmu.setFMUstate(state)
        assert any("taken by a co-simulation instance" in m for m in inst.log), inst.log
    finally:
        inst.free()


# ---------------------------------------------------------------------------------------------- the call sequence
ME_STATES = ["Instantiated", "InitializationMode", "EventMode", "ContinuousTimeMode", "Terminated"]
DOC = ROOT / "docs" / "fmu.md"


def me_table(version: int) -> dict[str, list[str]]:
    """{function: the states where it is legal} from docs/fmu.md's model-exchange table of FMI ``version``."""
    import re
    lines = DOC.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| FMI {version}.0 ME function |"))
    assert [c.strip() for c in lines[start].strip("|").split("|")][1:] == ME_STATES
    rows = {}
    for line in lines[start + 2:]:
        match = re.match(rf"\| (fmi{version}\w+) \|(.*)\|$", line)
        if not match:
            break
        cells = [c.strip() for c in match.group(2).split("|")]
        rows[match.group(1)] = [s for s, c in zip(ME_STATES, cells) if c == "✓"]
    return rows


class RawMe:
    """A model-exchange instance (fmpy's FMU2Model or FMU3Model) brought to ``state``, its log captured."""

    def __init__(self, fmu, version: int, state: str):
        from fmpy import extract
        self.md = read_model_description(str(fmu))
        self.log: list[str] = []
        identifier = self.md.modelExchange.modelIdentifier
        if version == 2:
            from fmpy.fmi2 import FMU2Model, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
            self._logger = fmi2CallbackLoggerTYPE(lambda c, n, s, cat, m: self.log.append((m or b"").decode()))
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = self._logger
            callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
            callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
            self.fmu = FMU2Model(guid=self.md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier=identifier,
                                 instanceName="seq")
            self.fmu.instantiate(callbacks=callbacks, loggingOn=True)
            steps = [lambda: self.fmu.setupExperiment(startTime=0.0), self.fmu.enterInitializationMode,
                     self.fmu.exitInitializationMode, self.fmu.enterContinuousTimeMode]
        else:
            from fmpy.fmi3 import FMU3Model, fmi3LogMessageCallback
            self._logger = fmi3LogMessageCallback(lambda e, s, cat, m: self.log.append((m or b"").decode()))
            self.fmu = FMU3Model(guid=self.md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier=identifier,
                                 instanceName="seq")
            self.fmu.instantiate(loggingOn=True, logMessage=self._logger)
            steps = [lambda: None, lambda: self.fmu.enterInitializationMode(startTime=0.0),
                     self.fmu.exitInitializationMode, self.fmu.enterContinuousTimeMode]
        target = {"Instantiated": 1, "InitializationMode": 2, "EventMode": 3, "ContinuousTimeMode": 4,
                  "Terminated": 3}[state]
        for step in steps[:target]:
            step()
        if state == "Terminated":
            self.fmu.terminate()
        self.log.clear()

    def call(self, function: str) -> int:
        """``function`` with null pointers, zero sizes and zero values: its status (a call refused for its
        arguments is still not refused for its sequence)."""
        if function in self.fmu._functions:
            f = self.fmu._functions[function]
        else:   # a co-simulation function the model-exchange wrapper does not bind
            f = getattr(self.fmu.dll, function)
            f.restype = ctypes.c_int
            f.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int] + (
                [ctypes.c_void_p] * 4 if function.startswith("fmi3") else [])
        args = [self.fmu.component]
        for kind in f.argtypes[1:]:
            code = getattr(kind, "_type_", None) if isinstance(kind, type) else None
            if isinstance(code, str) and code in "fd":
                args.append(0.0)
            elif isinstance(code, str) and code in "bBhHiIlLqQ?":
                args.append(0)
            else:
                args.append(None)
        return f(*args)


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("state", ME_STATES)
def test_every_model_exchange_function_in_every_state_follows_the_table(fmus, version, state):
    table = me_table(version)
    fmu = fmus["XFF", version]
    problems = []
    for function, legal in table.items():
        inst = RawMe(fmu, version, state)
        try:
            status = inst.call(function)
            sequence = [m for m in inst.log if "illegal call sequence" in m]
            if state in legal and sequence:
                problems.append(f"{function} in {state}: refused although legal: {sequence}")
            if state not in legal and (status != 3 or not any(f"(state {state})" in m for m in sequence)):
                problems.append(f"{function} in {state}: got {status}, {inst.log}")
        finally:
            if function.endswith("FreeInstance"):
                continue
            inst.fmu.freeInstance()
    assert not problems, "\n".join(problems)


def test_cli_builds_model_exchange_and_refuses_it_where_there_is_none(tmp_path):
    import sys

    def flexfmu(*args):
        return subprocess.run([sys.executable, "-m", "flexfmu", *map(str, args)], capture_output=True, text=True,
                              timeout=600)
    built = flexfmu("build", "--runtime", "native", "--interface", "both", "--set", "n_modes=4", "--out", tmp_path)
    assert built.returncode == 0, built.stderr
    assert "co-simulation and model exchange" in built.stdout
    md = read_model_description(str(tmp_path / "FFRBeam.fmu"))
    assert md.modelExchange is not None and md.coSimulation is not None and len(md.derivatives) == 8
    for args, expected in [
            (("build", "--interface", "me", "--out", tmp_path), "--interface: me: the Python runtime's FMUs are "
                                                                "co-simulation only"),
            (("build", "--runtime", "native", "--fmu", "ReframeBody", "--interface-type", "me", "--out", tmp_path),
             "interface: me: a free body (the reframe kind) is co-simulation only"),
            (("export", ROOT / "examples" / "bracket" / "bracket.json", "-o", tmp_path / "B.fmu", "--interface", "me",
              "--modes", "4"), "'me' names no body interface; the FMI interface type is --interface-type")]:
        run = flexfmu(*args)
        assert run.returncode == 2 and expected in run.stderr, run.stderr
