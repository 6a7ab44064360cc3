"""Drive FMI 3.0 FMUs through fmpy's low-level FMU3Slave, capturing the log (the FMI 3.0 counterpart of
fmu_helpers.Instance): one instance per object, start values by name, the FMI state read from a serialised FMU state's
header (csrc/front_common.c: "FLEXFMU-STATE\\n", u32 format, u32 runtime, u32 FMI state, ...)."""
from __future__ import annotations

import ctypes
import shutil
import struct

from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave, fmi3LogMessageCallback

STATE_PREFIX = b"FLEXFMU-STATE\n"
#: the FMI 3.0 front's states (csrc/flexfmu_fmi3.c), as the bits a serialised state's header holds
STATE_BITS = {"Instantiated": 1, "InitializationMode": 2, "StepMode": 4, "Terminated": 16}


class Instance3:
    """One FMI 3.0 co-simulation instance of ``fmu`` on an extraction of its own (or ``unzipped``, shared and kept);
    ``state``: how far it is brought (Instantiated, InitializationMode with ``start_values`` set, StepMode,
    Terminated)."""

    def __init__(self, fmu, name: str = "instance", *, state: str = "InitializationMode", unzipped=None,
                 start_time: float = 0.0, stop_time: float | None = None, **start_values):
        self.md = read_model_description(str(fmu))
        self.own_extraction = unzipped is None
        self.unzipped = extract(str(fmu)) if unzipped is None else unzipped
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.log: list[tuple[int, str, str]] = []

        def log_message(environment, status, category, message):
            self.log.append((status, (category or b"").decode(), (message or b"").decode()))

        self._callback = fmi3LogMessageCallback(log_message)       # kept: ctypes must not free it
        self.fmu = FMU3Slave(guid=self.md.guid, unzipDirectory=self.unzipped,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(loggingOn=True, logMessage=self._callback)
        if state == "Instantiated":
            return
        self.fmu.enterInitializationMode(startTime=start_time, stopTime=stop_time)
        self.set(**start_values)
        if state == "InitializationMode":
            return
        self.fmu.exitInitializationMode()
        if state == "Terminated":
            self.fmu.terminate()

    def set(self, **values):
        for name, value in values.items():
            setter = {"Float64": self.fmu.setFloat64, "Int32": self.fmu.setInt32, "Boolean": self.fmu.setBoolean,
                      "String": self.fmu.setString}[self.types[name]]
            setter([self.vr[name]], [value])

    def get(self, *names) -> list[float]:
        return self.fmu.getFloat64([self.vr[n] for n in names])

    def errors(self) -> list[str]:
        return [m for s, _, m in self.log if s >= 3]

    def fmi_state(self) -> str:
        """The instance's state, from the header of a serialised FMU state of it (fmi3GetFMUState is legal in every
        state and leaves it as it is)."""
        state = self.fmu.getFMUState()
        try:
            blob = self.fmu.serializeFMUState(state)
        finally:
            self.fmu.freeFMUState(state)
        assert blob.startswith(STATE_PREFIX)
        bits = struct.unpack_from("<I", blob, len(STATE_PREFIX) + 8)[0]
        return {v: k for k, v in STATE_BITS.items()}[bits]

    def expect_failure(self, call, *args, status=3, **kwargs):
        """Run an FMI call that must fail with ``status`` (fmi3Error = 3); returns the exception."""
        try:
            call(*args, **kwargs)
        except Exception as exc:
            assert getattr(exc, "status", None) == status, f"expected status {status}, got {exc!r}"
            return exc
        raise AssertionError(f"{getattr(call, '__name__', call)} did not fail")

    def raw(self, function: str, *args):
        """Call the FMI function ``function`` with ``args`` (after the instance) as they are, returning its status
        (fmpy's wrapper would raise on Discard and Error)."""
        f = self.fmu._functions[function]
        return f(self.fmu.component, *args)

    def call_with_defaults(self, function: str) -> int:
        """Call ``function`` with null pointers, zero sizes and zero values: its status."""
        f = self.fmu._functions[function]
        args = [self.fmu.component]
        for kind in f.argtypes[1:]:
            code = getattr(kind, "_type_", None) if isinstance(kind, type) else None
            if isinstance(code, str) and code in "fd":
                args.append(0.0)
            elif code == "?":
                args.append(False)
            elif isinstance(code, str) and code in "bBhHiIlLqQ":
                args.append(0)
            else:                                           # pointers, arrays, callbacks
                args.append(None)
        return f(*args)

    def free(self):
        if self.fmu is not None:
            self.fmu.freeInstance()
            self.fmu = None
        if self.own_extraction:
            shutil.rmtree(self.unzipped, ignore_errors=True)
