"""FMI 3.0 co-simulation FMUs of every native kind (csrc/flexfmu_fmi3.c over the one runtime;
flexfmu.fmi.description_fmi3): each built twice from one NativeSource, as FMI 2.0 and as FMI 3.0, and run through
fmpy (and fmusim when built): fmpy's validation finds no problem; the FMI 3.0 FMU's records equal the FMI 2.0 FMU's
(the paper's hammer record for FFRBeam XFF, XFX and FXF, ReframeBody's plate under a half-sine, the bracket of
examples/bracket exported clamped under base motion and free under interface forces); every FMI 3.0 function in
every state follows the table of docs/fmu.md; bad calls are refused with fmi3Error and one message in FMI 3.0's
names; FMU states round-trip."""
from __future__ import annotations

import ctypes
import importlib.util
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

sys.path.insert(0, str(Path(__file__).parent))
from fmi3_helpers import STATE_PREFIX, Instance3  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "fmu.md"
H = 1e-3
#: FMI 3.0 against FMI 2.0: the same binary, model file and runtime, called in the same order with the same numbers,
#: so the same operations: equal bit for bit; the bound allows only for a host passing a time or value differently
#: rounded (relative, per output over the record)
RTOL = 1e-12
STATES = ["Instantiated", "InitializationMode", "StepMode", "Terminated"]


def _hammer_module():
    spec = importlib.util.spec_from_file_location("hammer_test", ROOT / "examples" / "hammer_test.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HAMMER = _hammer_module()


@pytest.fixture(scope="module")
def twins(tmp_path_factory):
    """{case: {2: FMI 2.0 FMU, 3: FMI 3.0 FMU}}, each pair from one NativeSource: FFRBeam set up for the hammer
    record (XFF, XFX, FXF), ReframeBody at its defaults, the bracket exported clamped at its bolts and free."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.native import body_source, registry_source
    from flexfmu.fmi.native_build import build_native_fmu
    from flexfmu.importers import load_structure

    out = tmp_path_factory.mktemp("fmi3")
    sources = {bc: registry_source("FFRBeam", {"boundary": bc, "load_s": s[0], "sensor_s": s[1]})
               for bc, s in HAMMER.SETUPS.items()}
    sources["ReframeBody"] = registry_source("ReframeBody")
    structure = load_structure(ROOT / "examples" / "bracket" / "bracket.json")
    tip = interface_from_text("tip=arm_top")
    clamped = build_body(structure, interfaces=[tip], clamp=clamp_from_text(structure, "bolt_1,bolt_2"), f_max=2000.0)
    free = build_body(structure, interfaces=[tip, interface_from_text("bolt=bolt_1")], f_max=2000.0)
    sources["clamped"] = body_source(clamped, "BracketClamped")
    sources["free"] = body_source(free, "BracketFree")
    return {case: {v: build_native_fmu(source, out / f"fmi{v}" / case / f"{source.name}.fmu", fmi_version=v)
                   for v in (2, 3)} for case, source in sources.items()}


def relative_difference(a, b) -> dict:
    """{output: max |a - b| / max |b|} over two simulate_fmu records."""
    out = {}
    for name in b.dtype.names[1:]:
        scale = float(np.max(np.abs(b[name])))
        out[name] = float(np.max(np.abs(a[name] - b[name]))) / (scale if scale > 0 else 1.0)
    return out


def record(fmu, t_end: float, step: float, forces: dict, **start):
    """simulate_fmu with the inputs {name: f(t)} sampled every step; every output."""
    md = read_model_description(str(fmu))
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    t = np.arange(0.0, t_end + step / 2, step)
    signals = np.zeros(len(t), dtype=[("time", float)] + [(name, float) for name in inputs])
    signals["time"] = t
    for name, f in forces.items():
        signals[name] = f(t)
    return simulate_fmu(str(fmu), start_time=0.0, stop_time=t_end, step_size=step, output_interval=step,
                        input=signals, start_values=start)


def pulse(amplitude, width):
    return lambda t: np.where(t < width, amplitude * np.sin(np.pi * t / width), 0.0)


CASES = {   # case: (duration, step, inputs, start values)
    **{bc: (2.0, 1.0 / HAMMER.SAMPLE_RATE, {"F_x": pulse(20.0, 1e-3), "F_y": pulse(14.0, 1e-3),
                                             "F_z": pulse(8.0, 1e-3)},
            {"boundary": bc, "damping_ratio": 0.002, "load_s": HAMMER.SETUPS[bc][0], "sensor_s": HAMMER.SETUPS[bc][1]})
       for bc in HAMMER.SETUPS},
    "ReframeBody": (0.5, H, {"F_x": pulse(50.0 / 2**0.5, 0.01), "F_z": pulse(50.0 / 2**0.5, 0.01)}, {}),
    "clamped": (0.3, H, {"base_a_z": lambda t: 9.81 * np.sin(40 * t), "base_w_x": lambda t: 0.5 * np.sin(7 * t),
                         "base_dw_x": lambda t: 3.5 * np.cos(7 * t), "tip.F_y": pulse(5.0, 0.01)}, {}),
    "free": (0.3, H, {"tip.F_x": pulse(20.0, 0.01), "tip.F_z": pulse(50.0, 0.01), "bolt.F_y": pulse(-10.0, 0.01)},
             {"omega0_1": 2.0}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_fmpy_validation_finds_no_problem(twins, case):
    assert validate_fmu(str(twins[case][3])) == []
    md = read_model_description(str(twins[case][3]))
    assert md.fmiVersion == "3.0" and md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert not md.coSimulation.needsExecutionTool and md.coSimulation.canHandleVariableCommunicationStepSize
    # the FMI 2.0 names, value references and units; the one independent variable is time
    fmi2 = {v.name: (v.valueReference, v.causality, v.unit) for v in read_model_description(str(twins[case][2]))
            .modelVariables}
    fmi3 = {v.name: (v.valueReference, v.causality, v.unit) for v in md.modelVariables if v.name != "time"}
    assert fmi3 == fmi2
    assert [v.causality for v in md.modelVariables if v.name == "time"] == ["independent"]


@pytest.mark.parametrize("case", list(CASES))
def test_fmi3_records_equal_the_fmi2_records(twins, case):
    t_end, step, forces, start = CASES[case]
    fmi3, fmi2 = (record(twins[case][v], t_end, step, forces, **start) for v in (3, 2))
    assert len(fmi3) == len(fmi2) == int(round(t_end / step)) + 1 and np.array_equal(fmi3["time"], fmi2["time"])
    difference = relative_difference(fmi3, fmi2)
    worst = max(difference, key=difference.get)
    identical = all(np.array_equal(fmi3[n], fmi2[n]) for n in fmi2.dtype.names)
    print(f"\n{case}: FMI 3.0 vs FMI 2.0, {len(fmi2)} samples of {len(difference)} outputs: worst relative "
          f"difference {difference[worst]:.2e} ({worst}); bit for bit: {identical}")
    assert difference[worst] <= RTOL, difference
    assert max(np.max(np.abs(fmi2[n])) for n in fmi2.dtype.names[1:] if "acc" in n or "_a_" in n) > 1e-3


def test_one_binary_serves_both_versions(twins):
    """The FMI 3.0 FMU's library is the FMI 2.0 FMU's, byte for byte; it exports the fmi2 and fmi3 functions and
    nothing else, and links no Python."""
    for case in ("XFF", "free"):
        with zipfile.ZipFile(twins[case][2]) as zf2, zipfile.ZipFile(twins[case][3]) as zf3:
            name = read_model_description(str(twins[case][3])).coSimulation.modelIdentifier
            so3 = zf3.read(f"binaries/x86_64-linux/{name}.so")
            assert so3 == zf2.read(f"binaries/linux64/{name}.so")
            assert not [n for n in zf3.namelist() if n.startswith("binaries/linux64")]
            assert "sources/buildDescription.xml" in zf3.namelist()
    folder = Path(extract(str(twins["XFF"][3])))
    try:
        so = folder / "binaries" / "x86_64-linux" / "FFRBeam.so"
        symbols = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True,
                                 check=True).stdout
        exported = {line.split()[-1] for line in symbols.splitlines() if " T " in line}
        assert {n[:4] for n in exported} == {"fmi2", "fmi3"} and "fmi3DoStep" in exported
        assert "python" not in subprocess.run(["ldd", str(so)], capture_output=True, text=True).stdout.lower()
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# ---------------------------------------------------------------------------------------------- the call sequence
def table() -> dict[str, list[str] | None]:
    """{function: the states where it is legal, or None when it is not provided} from docs/fmu.md's FMI 3.0 table."""
    text = DOC.read_text(encoding="utf-8")
    header = next(line for line in text.splitlines() if line.startswith("| FMI 3.0 function |"))
    assert [c.strip() for c in header.strip("|").split("|")][1:] == STATES
    rows = {}
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("| FMI 3.0 function |")) + 2
    for line in lines[first:]:   # the table's rows: up to the first line that is not one
        match = re.match(r"\| (fmi3\w+) \|(.*)\|$", line)
        if not match:
            break
        if match:
            cells = [c.strip() for c in match.group(2).split("|")]
            assert len(cells) == len(STATES), line
            rows[match.group(1)] = None if cells[0] == "—" else [s for s, c in zip(STATES, cells) if c == "✓"]
    return rows


TABLE = table()


def test_the_table_has_every_fmi3_function_of_an_instance():
    header = (Path(__import__("fmpy").__file__).parent / "c-code" / "fmi3Functions.h").read_text()
    declared = set(re.findall(r"#define (fmi3\w+)\s+fmi3FullName", header))
    without_instance = {"fmi3GetVersion", "fmi3InstantiateModelExchange", "fmi3InstantiateCoSimulation",
                        "fmi3InstantiateScheduledExecution"}
    assert set(TABLE) == declared - without_instance and len(TABLE) == 71


def call(inst: Instance3, function: str, donor) -> int:
    """Make the call with valid arguments (a function not provided: null pointers, zeros); its status."""
    fmu, vr = inst.fmu, inst.vr
    calls = {
        "fmi3SetDebugLogging": lambda: fmu.setDebugLogging(True, []),
        "fmi3FreeInstance": lambda: (fmu.freeInstance(), setattr(inst, "fmu", None)),
        "fmi3Reset": fmu.reset,
        "fmi3EnterInitializationMode": lambda: fmu.enterInitializationMode(startTime=0.0),
        "fmi3ExitInitializationMode": fmu.exitInitializationMode,
        "fmi3Terminate": fmu.terminate,
        "fmi3DoStep": lambda: fmu.doStep(0.0, H),
        "fmi3GetFloat64": lambda: fmu.getFloat64([vr["sensor_a_z"]]),
        "fmi3GetInt32": lambda: fmu.getInt32([vr["n_modes"]]),
        "fmi3GetBoolean": lambda: fmu.getBoolean([vr["geometric_stiffening"]]),
        "fmi3GetString": lambda: fmu.getString([vr["boundary"]]),
        "fmi3SetFloat64": lambda: fmu.setFloat64([vr["F_x"]], [1.0]),
        "fmi3SetInt32": lambda: fmu.setInt32([vr["max_internal_steps"]], [1000]),
        "fmi3SetBoolean": lambda: fmu.setBoolean([vr["geometric_stiffening"]], [False]),
        "fmi3SetString": lambda: fmu.setString([vr["boundary"]], ["XFF"]),
        "fmi3GetFMUState": lambda: fmu.freeFMUState(fmu.getFMUState()),
        "fmi3SetFMUState": lambda: fmu.setFMUState(donor[1]),
        "fmi3FreeFMUState": lambda: fmu.freeFMUState(donor[0].fmu.getFMUState()),
        "fmi3SerializedFMUStateSize": lambda: fmu.serializeFMUState(donor[1]),
        "fmi3SerializeFMUState": lambda: fmu.serializeFMUState(donor[1]),
        "fmi3DeserializeFMUState": lambda: fmu.freeFMUState(
            fmu.deserializeFMUState(donor[0].fmu.serializeFMUState(donor[1]))),
    }
    if function not in calls:
        return inst.call_with_defaults(function)
    try:
        calls[function]()
    except Exception as exc:
        return getattr(exc, "status", None)
    return 0


@pytest.mark.parametrize("state", STATES)
def test_every_function_in_every_state_follows_the_table(twins, state):
    """Legal (✓): not refused for its sequence.  Illegal: fmi3Error, the one message "fmi3X: illegal call sequence
    (state S)", and the instance is Terminated (FMI 3.0: every fmi3Error).  Not provided (—): fmi3Error,
    "fmi3X: not provided ..." in every state, Terminated too."""
    fmu = twins["XFF"][3]
    unzipped = extract(str(fmu))
    donor = Instance3(fmu, "donor", state="StepMode", unzipped=unzipped)
    donor_state = donor.fmu.getFMUState()
    problems = []
    try:
        for function, legal in TABLE.items():
            inst = Instance3(fmu, "seq", state=state, unzipped=unzipped)
            inst.log.clear()
            status = call(inst, function, (donor, donor_state))
            errors = inst.errors()
            if legal is not None and state in legal:
                if any("illegal call sequence" in m for m in errors):
                    problems.append(f"{function} in {state}: refused although legal: {errors}")
            else:
                expected = (f"{function}: illegal call sequence (state {state})" if legal is not None
                            else f"{function}: not provided")
                after = inst.fmi_state()
                if status != 3 or len(errors) != 1 or not errors[0].startswith(expected) or after != "Terminated":
                    problems.append(f"{function} in {state}: got {status}, {errors}, then {after}")
            if inst.fmu is not None:
                inst.free()
    finally:
        donor.fmu.freeFMUState(donor_state)
        donor.free()
        shutil.rmtree(unzipped, ignore_errors=True)
    assert not problems, "\n".join(problems)


# ---------------------------------------------------------------------------------------------- refusals
BAD_CALLS = {   # name: (state, call(inst) that must be refused, the start of its one message, or a function of inst)
    "unknown value reference": ("StepMode", lambda i: i.fmu.getFloat64([9999]),
                                "fmi3GetFloat64: unknown value reference 9999"),
    "another type": ("StepMode", lambda i: i.fmu.getInt32([i.vr["F_x"]]),
                     lambda i: f"fmi3GetInt32: value reference {i.vr['F_x']} is 'F_x', a Float64 variable; use "
                               "fmi3GetFloat64"),
    "NaN input": ("StepMode", lambda i: i.fmu.setFloat64([i.vr["F_x"]], [float("nan")]), "fmi3SetFloat64: F_x"),
    "output set": ("InitializationMode", lambda i: i.fmu.setFloat64([i.vr["tip_u_x"]], [1.0]),
                   "fmi3SetFloat64: 'tip_u_x' is an output"),
    "fixed parameter": ("InitializationMode", lambda i: i.fmu.setString([i.vr["boundary"]], ["FXF"]),
                        "fmi3SetString: boundary: got 'FXF', but this native FMU was built with boundary = 'XFF'"),
    "parameter after initialisation": ("StepMode", lambda i: i.fmu.setFloat64([i.vr["damping_ratio"]], [0.1]),
                                       "fmi3SetFloat64: damping_ratio: a fixed parameter can be set only before "
                                       "fmi3ExitInitializationMode"),
    "out of range": ("InitializationMode", lambda i: (i.set(damping_ratio=1.5), i.fmu.exitInitializationMode()),
                     "damping_ratio: got 1.5 (allowed: 0 <= damping_ratio < 1)"),
    "time set": ("StepMode", lambda i: i.fmu.setFloat64([2**31 - 1], [1.0]),
                 "fmi3SetFloat64: value reference 2147483647 is 'time', the independent variable"),
    "nValues": ("StepMode", lambda i: refused(i.raw("fmi3GetFloat64", (ctypes.c_uint32 * 1)(13), 1,
                                                    (ctypes.c_double * 2)(), 2)),
                "fmi3GetFloat64: nValues: got 2 for 1 value references"),
    "wrong time": ("StepMode", lambda i: i.fmu.doStep(5.0, H),
                   "currentCommunicationPoint: got 5.0 s, expected the FMU's time 0.0 s (roll back with "
                   "fmi3SetFMUState"),
    "step not positive": ("StepMode", lambda i: i.fmu.doStep(0.0, -H),
                          "fmi3DoStep: communicationStepSize must be finite and > 0 s"),
    "a state of another FMU": ("StepMode", lambda i: i.fmu.deserializeFMUState(b"FLEXFMU-STATE\n" + bytes(40)),
                               "fmi3DeserializeFMUState: the state was serialized in format 0"),
}


class Refused(Exception):
    def __init__(self, status):
        super().__init__(f"status {status}")
        self.status = status


def refused(status: int) -> None:
    """Raise as fmpy does for a status worse than fmi3Warning (a raw call's)."""
    if status > 1:
        raise Refused(status)


@pytest.mark.parametrize("label", list(BAD_CALLS))
def test_a_bad_call_is_refused_with_fmi3error_and_one_message(twins, label):
    """Error, never Fatal; one message in FMI 3.0's names (the runtime's FMI 2.0 names translated); the instance is
    Terminated, and fmi3Reset brings it back for a run that works."""
    state, bad, message = BAD_CALLS[label]
    inst = Instance3(twins["XFF"][3], "bad", state=state)
    try:
        inst.log.clear()
        inst.expect_failure(bad, inst)
        errors = inst.errors()
        message = message(inst) if callable(message) else message      # one that names a value reference
        assert len(errors) == 1 and message in errors[0], errors
        assert "fmi2" not in errors[0] and " Real " not in errors[0], errors
        assert inst.fmi_state() == "Terminated"
        inst.fmu.reset()
        inst.fmu.enterInitializationMode(startTime=0.0)
        inst.fmu.exitInitializationMode()
        inst.set(F_z=1.0)
        inst.fmu.doStep(0.0, H)
        assert inst.get("tip_u_z")[0] != 0.0 and inst.fmi_state() == "StepMode"
    finally:
        inst.free()


def test_instantiation_with_event_mode_is_refused(twins):
    inst = Instance3(twins["XFF"][3], "probe", state="Instantiated")
    try:
        with pytest.raises(Exception, match="Failed to instantiate"):
            inst.fmu.instantiate(eventModeUsed=True, logMessage=inst._callback)
        assert inst.errors() == ["fmi3InstantiateCoSimulation: eventModeUsed: this FMU has no Event Mode "
                                 "(hasEventMode is false); instantiate it with eventModeUsed = false"]
    finally:
        inst.fmu = None
        inst.free()


def test_a_discarded_step_stays_in_step_mode_at_its_start(twins):
    """More internal steps than max_internal_steps: fmi3Discard, lastSuccessfulTime the step's start, the instance
    still in Step Mode; a smaller step from the same point is taken."""
    inst = Instance3(twins["ReframeBody"][3], "discard", internal_step=1e-4, max_internal_steps=5)
    try:
        inst.fmu.exitInitializationMode()
        inst.set(F_x=1.0)
        flags = [ctypes.c_bool(True) for _ in range(3)]
        last = ctypes.c_double(-1.0)
        status = inst.raw("fmi3DoStep", 0.0, 1e-3, True, *map(ctypes.byref, flags), ctypes.byref(last))
        assert status == 2 and last.value == 0.0 and not any(f.value for f in flags)
        assert inst.fmi_state() == "StepMode"
        assert [m for s, _, m in inst.log if s == 2] and all("fmi2" not in m for _, _, m in inst.log)
        assert inst.fmu.doStep(0.0, 5e-4) == (False, False, False, 5e-4)
    finally:
        inst.free()


def test_time_and_stop_time(twins):
    """time (the independent variable) reads as the FMU's time among other values; a step past stopTime is
    refused."""
    inst = Instance3(twins["XFF"][3], "time", start_time=2.5, stop_time=2.5 + 2 * H)
    try:
        time = 2**31 - 1
        assert inst.fmu.getFloat64([time]) == [2.5]
        inst.fmu.exitInitializationMode()
        inst.set(F_z=1.0)
        inst.fmu.doStep(2.5, H)
        got = inst.fmu.getFloat64([inst.vr["tip_u_z"], time, inst.vr["F_z"]])
        assert got[1:] == [2.5 + H, 1.0] and got[0] == inst.get("tip_u_z")[0] != 0.0
        inst.fmu.doStep(2.5 + H, H)
        inst.expect_failure(inst.fmu.doStep, 2.5 + 2 * H, H)
        assert "ends after stopTime" in inst.errors()[0]
    finally:
        inst.free()


def test_an_fmi2_instance_is_refused_by_the_fmi3_functions(twins, tmp_path):
    """One library holds both fronts: an FMI 2.0 instance handed to an FMI 3.0 function is not one of its instances
    (refused, nothing read beyond its label)."""
    from fmpy.fmi2 import FMU2Slave
    folder = Path(extract(str(twins["XFF"][3]), unzipdir=str(tmp_path / "fmu")))
    (folder / "binaries" / "linux64").mkdir()
    shutil.copy(folder / "binaries" / "x86_64-linux" / "FFRBeam.so", folder / "binaries" / "linux64" / "FFRBeam.so")
    md = read_model_description(str(twins["XFF"][3]))
    fmu2 = FMU2Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier="FFRBeam", instanceName="two")
    fmu2.instantiate()
    try:
        library = ctypes.CDLL(str(folder / "binaries" / "linux64" / "FFRBeam.so"))
        library.fmi3Terminate.argtypes, library.fmi3Terminate.restype = [ctypes.c_void_p], ctypes.c_int
        assert library.fmi3Terminate(fmu2.component) == 3
        fmu2.setupExperiment(startTime=0.0)                    # the FMI 2.0 instance is untouched
        fmu2.enterInitializationMode()
        fmu2.exitInitializationMode()
    finally:
        fmu2.freeInstance()


# ---------------------------------------------------------------------------------------------- FMU states
def test_fmu_states_round_trip(twins):
    """fmi3GetFMUState / fmi3SetFMUState roll back bit for bit (also out of Terminated); serialised states carry the
    front's header (runtime native, FMI state Step Mode) and deserialise to the same run; a state of the FMI 2.0 twin
    (another GUID) and a damaged one are refused."""
    inst = Instance3(twins["XFF"][3], "states")
    names = ("sensor_a_x", "sensor_a_y", "tip_u_z", "reaction_M_y")

    def run(t0, n):
        rows = []
        for k in range(n):
            inst.set(F_z=np.sin(30.0 * (t0 + k * H)))
            inst.fmu.doStep(t0 + k * H, H)
            rows.append(inst.get(*names))
        return np.array(rows)

    try:
        inst.fmu.exitInitializationMode()
        run(0.0, 10)
        state = inst.fmu.getFMUState()
        first = run(10 * H, 20)
        inst.fmu.terminate()
        inst.fmu.setFMUState(state)
        assert inst.fmi_state() == "StepMode"
        assert np.array_equal(run(10 * H, 20), first)
        blob = inst.fmu.serializeFMUState(state)
        assert blob.startswith(STATE_PREFIX)
        assert np.frombuffer(blob[len(STATE_PREFIX):len(STATE_PREFIX) + 12], "<u4").tolist() == [2, 2, 4]
        again = inst.fmu.deserializeFMUState(blob)
        inst.fmu.setFMUState(again)
        assert np.array_equal(run(10 * H, 20), first)
        inst.fmu.freeFMUState(again)
        damaged = bytearray(blob)
        damaged[-1] ^= 1
        inst.expect_failure(inst.fmu.deserializeFMUState, bytes(damaged))
        assert "damaged (its CRC-32" in inst.errors()[-1]
        inst.fmu.reset()
        from fmu_helpers import Instance
        other = Instance(twins["XFF"][2], "fmi2").initialize()
        try:
            foreign = other.fmu.serializeFMUstate(other.fmu.getFMUstate())
        finally:
            other.free()
        inst.expect_failure(inst.fmu.deserializeFMUState, foreign)
        assert inst.errors()[-1] == ("fmi3DeserializeFMUState: the state is of another FMU or build (its GUID "
                                     "differs)")
        inst.fmu.freeFMUState(state)
    finally:
        inst.free()


# ---------------------------------------------------------------------------------------------- hosts and CLI
def _fmusim() -> Path | None:
    """fmusim (Reference-FMUs, built by benchmarks/build_fmusim.sh): $FMUSIM, on PATH, or the benchmarks' build folder
    beside this checkout."""
    import os
    for candidate in (os.environ.get("FMUSIM"), shutil.which("fmusim"), ROOT.parent / "fmusim-build" / "fmusim"):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    return None


def test_fmusim_runs_the_fmi3_fmu_as_the_fmi2_one(twins, tmp_path):
    fmusim = _fmusim()
    if fmusim is None:
        pytest.skip("fmusim not built (benchmarks/build_fmusim.sh SOURCE_DIR BUILD_DIR; or set FMUSIM)")
    inputs = tmp_path / "hammer.csv"
    t = np.arange(0.0, 0.0505, 1e-4)
    force = pulse(20.0, 1e-3)(t)
    np.savetxt(inputs, np.column_stack([t, force, 0.4 * force]), delimiter=",", header="time,F_x,F_z",
               comments="", fmt="%.17g")
    outputs = {}
    for version in (2, 3):
        out = tmp_path / f"out{version}.csv"
        run = subprocess.run([str(fmusim), "--interface-type", "cs", "--stop-time", "0.05", "--output-interval", "1e-4",
                              "--start-value", "damping_ratio", "0.002", "--input-file", str(inputs),
                              "--output-file", str(out), str(twins["XFF"][version])],
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stdout + run.stderr
        lines = out.read_text().splitlines()
        outputs[version] = ([name.strip('"') for name in lines[0].split(",")], lines[1:])
    (names, rows), (names2, rows2) = outputs[3], outputs[2]
    assert names == names2 and len(rows) == 501 and rows == rows2     # the same numbers, printed alike
    accelerometer = np.array([float(row.split(",")[names.index("sensor_a_z")]) for row in rows])
    assert np.max(np.abs(accelerometer)) > 1e-3


def test_cli_builds_fmi3_native(tmp_path):
    """(The Python runtime's FMI 3.0 FMUs, built and exported by the CLI: tests/test_fmu_fmi3_python.py.)"""
    def flexfmu(*args):
        return subprocess.run([sys.executable, "-m", "flexfmu", *map(str, args)], capture_output=True, text=True,
                              timeout=600)
    built = flexfmu("build", "--runtime", "native", "--fmi-version", "3", "--set", "boundary=XFX", "--out", tmp_path)
    assert built.returncode == 0, built.stderr
    assert validate_fmu(str(tmp_path / "FFRBeam.fmu")) == [] and "FMI 3.0" in built.stdout
