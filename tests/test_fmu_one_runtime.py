"""The one runtime under every FMU: a Python FMU's variables, checks and states are the native runtime's
(model/flexfmu/fmi/csrc/flexfmu_native.c) over its Python kind (native_python.c), so the two runtimes answer the
same bad call with the same status, and what used to reach the Python side as an "internal error" is refused by
name.
"""
from __future__ import annotations

import ctypes
import struct

import pytest
from fmpy.fmi2 import fmi2String, fmi2ValueReference

from fmu_helpers import Instance, restamp_crc, state_header
from test_fmu_states import H, ffrbeams, stepped  # noqa: F401  (ffrbeams: FFRBeam in both runtimes, a fixture)


def no_internal_error(inst: Instance) -> None:
    assert not any("internal error" in m for _, _, m in inst.log), inst.log


def test_a_string_that_is_not_utf8_is_refused_naming_the_parameter(fmus):
    inst = Instance(fmus["WaveExcitation"], "w")
    try:
        refs = (fmi2ValueReference * 1)(inst.vr["sea_state"])
        status = inst.fmu.dll.fmi2SetString(inst.fmu.component, refs, 1, (fmi2String * 1)(b"\xff\xfe"))
        assert status == 3
        assert any("sea_state" in m and "not UTF-8" in m for _, _, m in inst.log), inst.log
        no_internal_error(inst)
    finally:
        inst.free()


def test_a_settable_string_parameter_reaches_the_simulator(fmus):
    """A String parameter set before initialisation is the simulator's: an unknown sea state is refused by the
    simulator's own check, naming it; a known one is read back."""
    inst = Instance(fmus["WaveExcitation"], "w", sea_state="storm")
    try:
        inst.expect_failure(inst.fmu.exitInitializationMode)
        assert any("sea_state" in m and "storm" in m for _, _, m in inst.log), inst.log
    finally:
        inst.free()
    inst = Instance(fmus["WaveExcitation"], "w", sea_state="jonswap").initialize()
    try:
        assert inst.fmu.getString([inst.vr["sea_state"]]) == [b"jonswap"]
        inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    finally:
        inst.free()


def test_tiny_gravity_is_refused_naming_g(fmus):
    """g = 5e-324 (a subnormal) underflows the wave numbers: a named refusal, not an internal error."""
    inst = Instance(fmus["WaveExcitation"], "w", g=5e-324)
    try:
        inst.expect_failure(inst.fmu.exitInitializationMode)
        assert any(m.startswith("g:") or " g:" in m for _, _, m in inst.log), inst.log
        no_internal_error(inst)
    finally:
        inst.free()


def test_a_serialise_buffer_too_small_is_refused_by_name(fmus):
    inst = stepped(fmus["FFRBeam"], "s")
    try:
        state = inst.fmu.getFMUstate()
        size = ctypes.c_size_t()
        assert inst.fmu.dll.fmi2SerializedFMUstateSize(inst.fmu.component, state, ctypes.byref(size)) == 0
        buffer = ctypes.create_string_buffer(size.value)
        assert inst.fmu.dll.fmi2SerializeFMUstate(inst.fmu.component, state, buffer, size.value - 1) == 3
        assert any("size" in m and "needs" in m for _, _, m in inst.log), inst.log
        no_internal_error(inst)
        inst.fmu.freeFMUstate(state)
    finally:
        inst.free()


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_a_state_taken_before_initialisation_cannot_be_stepped(ffrbeams, runtime):
    """A serialised state of an instance not yet initialised, its FMI state edited to "step complete" (and its
    checksum stamped again): a step after restoring it is refused by name, never run on no simulator."""
    inst = Instance(ffrbeams[runtime], "s")
    try:
        blob = bytearray(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        fmi_state_at = len(b"FLEXFMU-STATE\n") + 8
        for step_complete in range(1, 16):       # the front's state codes: whichever it takes, no step may run
            blob[fmi_state_at:fmi_state_at + 4] = struct.pack("<I", step_complete)
            inst.log.clear()
            try:
                state = inst.fmu.deSerializeFMUstate(restamp_crc(bytes(blob)))
                inst.fmu.setFMUstate(state)
            except Exception:                     # refused: nothing was restored
                continue
            inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=H)
            no_internal_error(inst)
    finally:
        inst.free()


BAD_STEPS = {"h = 1e300": 1e300, "h = -1": -1.0, "h = 0": 0.0, "h = NaN": float("nan")}


@pytest.mark.parametrize("label", BAD_STEPS)
def test_both_runtimes_answer_a_bad_step_with_the_same_status(ffrbeams, label):
    statuses = {}
    for runtime, fmu in ffrbeams.items():
        inst = stepped(fmu, runtime, n=1)
        try:
            statuses[runtime] = inst.fmu.dll.fmi2DoStep(inst.fmu.component, ctypes.c_double(H),
                                                         ctypes.c_double(BAD_STEPS[label]), 1)
            no_internal_error(inst)
        finally:
            inst.free()
    assert statuses["python"] == statuses["native"] and statuses["python"] in (2, 3), statuses


def test_both_runtimes_refuse_a_state_with_nan_in_its_clock_alike(ffrbeams):
    """The runtime's layout is the same for both (its clock at payload offset 48): NaN there is refused by the
    payload's own check once the checksum is stamped again."""
    for runtime, fmu in ffrbeams.items():
        inst = stepped(fmu, runtime)
        try:
            blob = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
            at = state_header(blob)["payload_at"]
            bad = blob[:at + 48] + struct.pack("<d", float("nan")) + blob[at + 56:]
            inst.log.clear()
            inst.expect_failure(inst.fmu.deSerializeFMUstate, restamp_crc(bad))
            assert any("time not finite" in m for _, _, m in inst.log), (runtime, inst.log)
        finally:
            inst.free()


@pytest.mark.parametrize("name", ["FFRBeam", "ReframeBody", "WaveExcitation", "Hydrostatics", "Platform", "PTO"])
def test_nan_anywhere_in_a_python_simulators_state_is_refused(fmus, name):
    """Every number of the simulator's JSON state (the end of the runtime's layout), in turn NaN (JSON's extension) or
    1e999 (which parses to infinity), the checksum stamped again: refused at fmi2DeSerializeFMUstate, naming the
    number, never restored (Platform's state vector, the simulators' times)."""
    import json
    import re
    inst = Instance(fmus[name], "s").initialize()
    try:
        inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
        blob = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        at = state_header(blob)["payload_at"]
        payload = blob[at:]
        sim_at = payload.index(b'{"format"')
        text = payload[sim_at:].decode()
        json.loads(text)
        numbers = list(re.finditer(r'(?<=[:\[,] )-?\d[\d.eE+-]*', text))
        assert numbers
        for match in numbers[:40]:
            for bad in ("NaN", "1e999"):
                changed = (text[:match.start()] + bad + text[match.end():]).encode()
                new_payload = payload[:sim_at - 8] + len(changed).to_bytes(8, "little") + changed
                size_at = len(b"FLEXFMU-STATE\n") + 12
                body = blob[:size_at] + len(new_payload).to_bytes(8, "little") + blob[size_at + 8:at] + new_payload
                inst.log.clear()
                inst.expect_failure(inst.fmu.deSerializeFMUstate, restamp_crc(body))
                assert any("not finite" in m for _, _, m in inst.log), (match.group(), bad, inst.log)
    finally:
        inst.free()


def test_an_infinite_state_vector_is_refused_where_no_divergence_limit_is_set(tmp_path):
    """The reframe kind has no divergence limit (+inf): +inf in a serialised state vector is still refused at
    fmi2DeSerializeFMUstate (it passed the |x| <= limit test), as NaN is."""
    from flexfmu.fmi import native
    fmu = native.build_registry_fmu("ReframeBody", target=tmp_path / "ReframeBody.fmu")
    inst = Instance(fmu, "r").initialize()
    try:
        inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
        blob = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        for bad in (float("inf"), float("-inf"), float("nan")):   # the state vector's last entry, before the u64
            changed = blob[:-16] + struct.pack("<d", bad) + blob[-8:]   # size of the kind's own state (0)
            inst.log.clear()
            inst.expect_failure(inst.fmu.deSerializeFMUstate, restamp_crc(changed))
            assert any("not finite" in m for _, _, m in inst.log), (bad, inst.log)
    finally:
        inst.free()
