"""Drive built FMUs through fmpy's low-level FMU2Slave, capturing the log.  Every Instance extracts
its FMU afresh and deletes the extraction when freed, as fmpy.simulate_fmu does: a shared extraction
would hide what users meet on their second load."""
from __future__ import annotations

import ctypes
import shutil
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

ROOT = Path(__file__).resolve().parents[1]


def build_fmus(out: Path) -> dict[str, Path]:
    from flexfmu.fmi.build import build
    return {p.stem: p for p in build(out)}


class Instance:
    """One FMU instance, on its own extraction, with a log list; vr lookup by name; set/get by name."""

    def __init__(self, fmu: Path, name: str = "instance", *, start_time: float = 0.0, **start_values):
        self.md = read_model_description(str(fmu))
        self.unzipped = extract(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.log: list[tuple[int, str, str]] = []
        self.failed = False   # set after a failed call

        def logger(component, instance_name, status, category, message):
            self.log.append((status, (category or b"").decode(), (message or b"").decode()))

        self._logger = fmi2CallbackLoggerTYPE(logger)   # keep a reference: ctypes must not free it
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = self._logger
        callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
        callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzipped,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=callbacks, loggingOn=True)
        self.fmu.setupExperiment(startTime=start_time)
        self.fmu.enterInitializationMode()
        self.set(**start_values)

    def initialize(self):
        self.fmu.exitInitializationMode()
        return self

    def set(self, **values):
        for name, value in values.items():
            kind = self.types[name]
            if kind == "Real":
                self.fmu.setReal([self.vr[name]], [float(value)])
            elif kind == "Integer":
                self.fmu.setInteger([self.vr[name]], [int(value)])
            elif kind == "Boolean":
                self.fmu.setBoolean([self.vr[name]], [bool(value)])
            else:
                self.fmu.setString([self.vr[name]], [str(value)])

    def get(self, *names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def messages(self) -> str:
        return "\n".join(m for _, _, m in self.log)

    def expect_failure(self, call, *args, status=3, **kwargs):
        """Run an FMI call that must fail with ``status`` (fmi2Error = 3); returns the exception."""
        try:
            call(*args, **kwargs)
        except Exception as exc:   # fmpy raises FMICallException with .status
            self.failed = True
            assert getattr(exc, "status", None) == status, f"expected status {status}, got {exc!r}"
            return exc
        raise AssertionError(f"{getattr(call, '__name__', call)} did not fail")

    def free(self):
        """Free the instance (fmi2FreeInstance is legal in every state) and delete the extraction."""
        if self.fmu is not None:
            self.fmu.freeInstance()       # fmpy unloads the library here too
            self.fmu = None
        shutil.rmtree(self.unzipped, ignore_errors=True)


def error_messages(inst) -> list[str]:
    """The messages an instance logged with status fmi2Error or worse."""
    return [m for s, _, m in inst.log if s >= 3]


def refusal_messages(fmu_files, action, name: str = "bad") -> list[list[str]]:
    """For each FMU file: a new instance, ``action(instance)`` expected to be refused (Instance.expect_failure), and
    the error messages it logged; compares the refusals of two runtimes of one model."""
    logs = []
    for fmu in fmu_files:
        inst = Instance(fmu, name)
        try:
            inst.expect_failure(action, inst)
            logs.append(error_messages(inst))
        finally:
            inst.free()
    return logs


#: The serialised FMU state's header (csrc/flexfmu_fmi2.c): "FLEXFMU-STATE\n", u32 format, u32 runtime, u32 FMI
#: state, u64 payload size, u32 CRC-32 of every byte after it, u32 GUID length, the GUID, the bridge's payload.
STATE_PREFIX = b"FLEXFMU-STATE\n"
STATE_CRC_AT = len(STATE_PREFIX) + 20


def state_header(blob: bytes) -> dict:
    """The fields of a serialised state's header."""
    at = len(STATE_PREFIX)
    fmt, runtime, fmi_state = struct.unpack_from("<3I", blob, at)
    payload, = struct.unpack_from("<Q", blob, at + 12)
    crc, guid_length = struct.unpack_from("<2I", blob, at + 20)
    return {"format": fmt, "runtime": runtime, "fmi_state": fmi_state, "payload": payload, "crc": crc,
            "guid": blob[at + 28:at + 28 + guid_length].decode(), "payload_at": at + 28 + guid_length}


def restamp_crc(blob: bytes) -> bytes:
    """A serialised state with its CRC-32 computed again by zlib (an implementation independent of the FMU's): a
    payload changed on purpose then reaches the bridge's own checks."""
    body = bytes(blob[STATE_CRC_AT + 4:])
    return bytes(blob[:STATE_CRC_AT]) + struct.pack("<I", zlib.crc32(body)) + body


def fmu_checker_findings(fmu) -> str:
    """'' when fmu-manipulation-toolbox's checker (fmutool -check: XSD and semantic checks of the modelDescription)
    finds the FMU compliant, else its report."""
    fmutool = Path(sys.executable).with_name("fmutool")
    assert fmutool.exists(), "fmu-manipulation-toolbox missing: install the project with its dev extra"
    out = subprocess.run([fmutool, "-input", str(fmu), "-check"], capture_output=True, text=True, timeout=300)
    text = out.stdout + out.stderr
    return "" if "seems to be compliant with FMI-2.0" in text and "No semantic error" in text else text[-3000:]


def discard_messages(fmu_files, step_size: float, **start) -> list[list[str]]:
    """For each FMU file: an initialised instance with ``start`` values, one fmi2DoStep of ``step_size`` from 0
    expected to be discarded (fmi2Discard), and the messages logged with that status."""
    logs = []
    for fmu in fmu_files:
        inst = Instance(fmu, "cap", **start).initialize()
        try:
            inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=step_size,
                                status=2)
            logs.append([m for s, _, m in inst.log if s == 2])
        finally:
            inst.free()
    return logs


def clock_and_constant_step_runs(fmu, inputs: dict, step: float, n: int, t0: float = 1e3, **start):
    """Every output after each of n steps (arrays (n, n_outputs), outputs in modelDescription order) from two
    hosts stepping the FMU with the same held ``inputs`` from t0: one passing h = t(k+1) - t(k) with
    t(k) = t0 + k step, as fmpy.simulate_fmu, libcosim and fmusim do (steps that differ in their last bits: by
    about eps t0 / step relative), and one passing the first of those steps every time, as a constant-step host
    does.  Also returns the largest relative difference of the clock steps from the first."""
    md = read_model_description(str(fmu))
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    clock_steps = [(t0 + (k + 1) * step) - (t0 + k * step) for k in range(n)]
    runs = []
    for steps in (clock_steps, [clock_steps[0]] * n):
        inst = Instance(fmu, "clock", start_time=t0, **start).initialize()
        try:
            inst.set(**inputs)
            t, rows = t0, []
            for h in steps:
                inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                t += h
                rows.append(inst.get(*outputs))
            runs.append(np.array(rows))
        finally:
            inst.free()
    jitter = max(abs(h - clock_steps[0]) for h in clock_steps) / clock_steps[0]
    return runs[0], runs[1], jitter
