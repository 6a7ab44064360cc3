"""FMU states that cannot be confused or damaged, and loggers that call back: what the front
(model/flexfmu/fmi/csrc/flexfmu_fmi2.c) guarantees for both runtimes.

- A serialised state carries its format, runtime, size, the FMU's GUID and a CRC-32 of everything after the checksum
  field; any single-bit flip, truncation or extension is refused with one message before the bridge reads the payload.
- An in-memory state is labelled with its runtime and GUID: a state of another FMU or runtime in the same process is
  refused (it used to crash a Python FMU given a native one's state, and a native FMU read past another's arrays).
- A host's logger that calls into the instance whose call is logging is refused (fmi2Error) instead of waiting forever
  on the instance's lock, and the outer call says so once it is done.
"""
from __future__ import annotations

import ctypes
import subprocess
import sys
import textwrap
import zlib
from pathlib import Path

import pytest
from fmpy import read_model_description

from fmu_helpers import STATE_CRC_AT, STATE_PREFIX, Instance, restamp_crc, state_header

H = 1e-3
LOADS = {"F_y": 2.0, "base_w_z": 0.7}
RUNTIME_IDS = {"python": 1, "native": 2}


@pytest.fixture(scope="module")
def ffrbeams(fmus, tmp_path_factory):
    """FFRBeam in both runtimes, and a second native FMU (another boundary: another GUID)."""
    from flexfmu.fmi import native
    out = tmp_path_factory.mktemp("states")
    return {"python": fmus["FFRBeam"],
            "native": native.build_registry_fmu("FFRBeam", target=out / "FFRBeam.fmu"),
            "native XFX": native.build_registry_fmu("FFRBeam", {"boundary": "XFX"}, target=out / "x" / "FFRBeam.fmu")}


def stepped(fmu, name: str, n: int = 3) -> Instance:
    inst = Instance(fmu, name).initialize()
    for k in range(n):
        inst.set(**LOADS)
        inst.fmu.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
    return inst


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_a_serialised_state_carries_its_runtime_size_and_a_crc32_zlib_agrees_with(ffrbeams, runtime):
    inst = stepped(ffrbeams[runtime], "s")
    try:
        blob = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        header = state_header(blob)
        assert blob.startswith(STATE_PREFIX) and header["format"] == 2
        assert header["runtime"] == RUNTIME_IDS[runtime]
        assert header["guid"] == read_model_description(str(ffrbeams[runtime])).guid
        assert header["payload_at"] + header["payload"] == len(blob)
        assert header["crc"] == zlib.crc32(blob[STATE_CRC_AT + 4:])
    finally:
        inst.free()


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_every_single_bit_flip_truncation_and_extension_is_refused(ffrbeams, runtime):
    """CRC-32 detects every single-bit error (its polynomial has more than one term); the size and header checks
    come first.  Every bit of the native state, every 7th bit of the (larger) Python one; each refused with
    fmi2Error and one message, and the instance steps on afterwards."""
    inst = stepped(ffrbeams[runtime], "flip")
    try:
        blob = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        deserialize = inst.fmu._functions["fmi2DeSerializeFMUstate"]   # the raw call: a status, no exception
        stride = 1 if runtime == "native" else 7
        accepted = []
        for bit in range(0, 8 * len(blob), stride):
            damaged = bytearray(blob)
            damaged[bit // 8] ^= 1 << (bit % 8)
            state = ctypes.c_void_p()
            buffer = ctypes.create_string_buffer(bytes(damaged), len(damaged))
            if deserialize(inst.fmu.component, buffer, len(damaged), ctypes.byref(state)) != 3:
                accepted.append(bit)
        assert not accepted, f"{len(accepted)} damaged states accepted, e.g. bits {accepted[:5]}"
        for label, bad in {"truncated": blob[:-1], "extended": blob + b"\0", "empty": b""}.items():
            inst.log.clear()
            inst.expect_failure(inst.fmu.deSerializeFMUstate, bad)
            assert len([m for s, _, m in inst.log if s == 3]) == 1, (label, inst.log)
        inst.log.clear()
        inst.expect_failure(inst.fmu.deSerializeFMUstate, blob[:STATE_CRC_AT] + b"\0\0\0\0" + blob[STATE_CRC_AT + 4:])
        assert any("CRC-32" in m for _, _, m in inst.log), inst.log
        inst.fmu.setFMUstate(inst.fmu.deSerializeFMUstate(blob))           # the intact state still restores
        inst.fmu.doStep(currentCommunicationPoint=3 * H, communicationStepSize=H)
    finally:
        inst.free()


def test_a_restamped_checksum_lets_the_bridge_judge_the_payload(ffrbeams):
    """With a valid checksum over a changed payload the bridge's own checks still refuse what is not a state."""
    inst = stepped(ffrbeams["native"], "restamp")
    try:
        blob = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        at = state_header(blob)["payload_at"]
        inst.log.clear()
        inst.expect_failure(inst.fmu.deSerializeFMUstate, restamp_crc(blob[:at] + b"\xff" * 8 + blob[at + 8:]))
        assert any("not a native flexfmu state" in m for _, _, m in inst.log), inst.log
    finally:
        inst.free()


@pytest.mark.parametrize("giver, taker, why", [
    ("native", "python", "native-runtime FMU"),
    ("python", "native", "Python-runtime FMU"),
    ("native XFX", "native", "another FMU"),
])
def test_an_in_memory_state_of_another_fmu_or_runtime_is_refused(ffrbeams, giver, taker, why):
    """Both FMUs loaded in one process; the state handle of one given to the other: refused by its label, before
    the bridge touches it (no crash, no garbage read), and the taker steps on."""
    a, b = stepped(ffrbeams[giver], "giver"), stepped(ffrbeams[taker], "taker")
    try:
        state = a.fmu.getFMUstate()
        b.log.clear()
        b.expect_failure(b.fmu.setFMUstate, state)
        assert any(why in m and "fmi2SetFMUstate" in m for _, _, m in b.log), b.log
        b.log.clear()
        b.expect_failure(b.fmu.serializeFMUstate, state)
        a.fmu.freeFMUstate(state)
    finally:
        a.free()
        b.free()


REENTRANT_HOST = textwrap.dedent('''
    """A host whose logger calls the instance back while the instance's refused fmi2DoStep logs."""
    import ctypes, sys
    sys.path.insert(0, {tests!r})
    from fmu_helpers import Instance

    inst = Instance({fmu!r}, "reentrant")
    if {initialise!r}:
        inst.initialize()
    answers = []

    class CallingBack(list):
        def append(self, entry):
            super().append(entry)
            if len(answers) < 3:
                value = (ctypes.c_double * 1)()
                vr = (ctypes.c_uint * 1)(inst.vr["tip_u_x"])
                answers.append(inst.fmu._functions["fmi2GetReal"](inst.fmu.component, vr, 1, value))

    inst.log = CallingBack()
    try:
        inst.fmu.doStep(currentCommunicationPoint=5.0, communicationStepSize=1e-3)
    except Exception as exc:
        print("outer status", getattr(exc, "status", None))
    print("answers", answers)
    print("messages", [m for _, _, m in inst.log])
    inst.get("tip_u_x")                      # the instance answers afterwards (its refused step left it in Error)
    print("answered after")
    inst.free()
''')


@pytest.mark.parametrize("initialise", [True, False], ids=["step at a wrong time", "step out of sequence"])
@pytest.mark.parametrize("runtime", ["python", "native"])
def test_a_logger_that_calls_back_is_refused_and_never_deadlocks(ffrbeams, runtime, initialise, tmp_path):
    """In a child process with a time limit, so a deadlock fails the test instead of hanging the suite.  The step is
    refused by the bridge (a wrong communication point) or by the front's call-sequence table (before
    initialisation): both log, and the logger's call back is refused and reported either way."""
    script = tmp_path / "host.py"
    script.write_text(REENTRANT_HOST.format(tests=str(Path(__file__).parent), fmu=str(ffrbeams[runtime]),
                                            initialise=initialise))
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-3000:]
    out = run.stdout
    assert "outer status 3" in out                        # the refused step itself
    assert "answers [3" in out                            # the call from the logger: fmi2Error
    assert "called from the logger callback while fmi2DoStep was running" in out, out
    assert "answered after" in out


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_the_clock_is_checked_in_absolute_terms_at_a_large_start_time(ffrbeams, runtime):
    """From t0 = 1e6 s with 0.1 ms steps the old relative check (1e-9 |t| = 1 ms) let a skipped step through.  The
    clock is the host's last point plus its step: a host computing t(k) = t0 + k h and passing the constant h, and
    one passing h = t(k+1) - t(k), step on for 300 steps; a skipped step, a repeated one and one off by 1e-4 h
    (1e-8 s, beyond 16 eps t0 = 3.6e-9 s) are refused; fmi2LastSuccessfulTime is the host's time."""
    t0, h = 1e6, 1e-4
    for host in ("constant step", "clock step"):
        inst = Instance(ffrbeams[runtime], "clock", start_time=t0).initialize()
        try:
            for k in range(300):
                t, t_next = t0 + k * h, t0 + (k + 1) * h
                inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h if host == "constant step"
                                else t_next - t)
            assert inst.fmu.getRealStatus(2) == pytest.approx(t0 + 300 * h, rel=0, abs=64 * 2.2e-16 * t0)
            for label, t in {"skipped": t0 + 301 * h, "repeated": t0 + 299 * h,
                             "off by 1e-4 h": t0 + 300 * h + 1e-8}.items():
                inst.log.clear()
                state = inst.fmu.getFMUstate()
                inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)
                assert any("currentCommunicationPoint" in m for _, _, m in inst.log), (host, label, inst.log)
                inst.fmu.setFMUstate(state)                   # back to StepComplete at t0 + 300 h
                inst.fmu.freeFMUstate(state)
            inst.fmu.doStep(currentCommunicationPoint=t0 + 300 * h, communicationStepSize=h)
        finally:
            inst.free()


def test_a_python_state_whose_time_is_not_finite_is_refused(ffrbeams):
    """A serialised Python-FMU state with NaN in the FMU's clock (the runtime's layout, as a native FMU's) or in its
    simulator's time (the simulator's JSON at the layout's end; the checksum stamped again, so the payload's own
    checks are what refuse it)."""
    import json
    import struct
    inst = stepped(ffrbeams["python"], "nan")
    try:
        blob = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        at = state_header(blob)["payload_at"]
        payload = blob[at:]
        sim_at = payload.index(b'{"format"')
        assert int.from_bytes(payload[sim_at - 8:sim_at], "little") == len(payload) - sim_at
        for where in ("sim", "clock"):
            if where == "sim":
                state = json.loads(payload[sim_at:])
                state["sim"]["t"] = float("nan")
                text = json.dumps(state).encode()         # NaN as JSON's extension: what a file can hold
                new_payload = payload[:sim_at - 8] + len(text).to_bytes(8, "little") + text
            else:                                           # the runtime's layout: f64 clock at offset 48
                new_payload = payload[:48] + struct.pack("<d", float("nan")) + payload[56:]
            size_at = len(STATE_PREFIX) + 12
            body = blob[:size_at] + len(new_payload).to_bytes(8, "little") + blob[size_at + 8:at] + new_payload
            inst.log.clear()
            inst.expect_failure(inst.fmu.deSerializeFMUstate, restamp_crc(body))
            assert any("not finite" in m for _, _, m in inst.log), (where, inst.log)
    finally:
        inst.free()
