"""The host side of the reliability probes: Python text that runs in a child process (flexfmu.fmi.diagnostics_runner)
and drives FMUs through fmpy's FMU2Slave, never importing flexfmu itself (a Python FMU must find the process free of
any other flexfmu build, and a native one needs none).

HOST defines, in the child:

- ``Host(path, name)``: an FMU instance (on the child's one extraction of that FMU), instantiated with a logger that
  keeps every message, and an ``_call`` that keeps every status (fmpy raises on Discard and worse only, so a
  Warning would otherwise look like OK); ``begin(level, start_time, values)`` brings it to "instantiated", "init"
  (initialisation mode) or "initialised"; ``raw(name, *args)`` calls an FMI function without fmpy's check.
- ``item(label, expect, run)``: one probe; ``probe(path, action, level=...)`` runs ``action(host)`` on a fresh
  instance and returns the outcome: the worst status of the action's calls, non-finite values returned, messages
  with "internal error", the error messages, and what the action found wrong (``raise Wrong(text)``).
- ``main()``: prints {"n": N}, then {"begin": i, "label"} and the result of each item from CONFIG["start"] on (with
  "stderr_at", the size of the child's stderr file before the call, when the call printed there).
- State helpers: ``state_header`` and ``restamp_crc`` (the layout of tests/fmu_helpers.py: "FLEXFMU-STATE\\n",
  u32 format, u32 runtime, u32 FMI state, u64 payload size, u32 CRC-32 of every byte after it, u32 GUID length,
  the GUID, the payload).
"""
from __future__ import annotations

HOST = r'''
import ctypes, json, math, os, pathlib, random, shutil, struct, sys, tempfile, time, zlib
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

CONFIG = json.loads(sys.argv[1])
STATUS = ("OK", "Warning", "Discard", "Error", "Fatal")
STATE_PREFIX = b"FLEXFMU-STATE\n"
CRC_AT = len(STATE_PREFIX) + 20
LAST_SUCCESSFUL_TIME = 2
_DESCRIPTIONS, _EXTRACTIONS = {}, {}


def say(**fields):
    sys.stdout.write(json.dumps(fields) + "\n")
    sys.stdout.flush()


class Wrong(Exception):
    """A probe's call returned, but its answer is wrong."""


def description(path):
    if path not in _DESCRIPTIONS:
        _DESCRIPTIONS[path] = read_model_description(path)
    return _DESCRIPTIONS[path]


def extraction(path):
    """One extraction of ``path`` per child, shared by its instances (in CONFIG["scratch"], which the parent deletes;
    a fresh one per instance costs 0.1 to 0.2 s for a Python FMU, whose resources hold the flexfmu package)."""
    if path not in _EXTRACTIONS:
        folder = CONFIG.get("scratch")
        _EXTRACTIONS[path] = extract(path, unzipdir=tempfile.mkdtemp(dir=folder) if folder else None)
    return _EXTRACTIONS[path]


def variables(path, kind=None, causality=None):
    return [v for v in description(path).modelVariables
            if (kind is None or v.type == kind) and (causality is None or v.causality == causality)]


class FMU2Host(FMU2Slave):
    # the name starts with FMU2: fmpy picks the fmi2 functions by the class's name
    def __init__(self, path, name="probe"):
        md = description(path)
        self.path, self.md, self.unzipped = path, md, extraction(path)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.types = {v.name: v.type for v in md.modelVariables}
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        self.inputs = [v.name for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
        self.statuses, self.log, self.on_log, self.freed = [], [], None, False
        super().__init__(guid=md.guid, unzipDirectory=self.unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                         instanceName=name)

        def logger(component, instance_name, status, category, message):
            text = (message or b"").decode("utf-8", "replace")
            self.log.append((status, text))
            if self.on_log is not None:
                self.on_log(status, text)

        self._logger = fmi2CallbackLoggerTYPE(logger)   # kept: ctypes must not free it
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = self._logger
        callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
        callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
        self._callbacks_kept = callbacks
        self.component = None

    def create(self):
        """fmi2Instantiate with the logger; a refusal (NULL) raised as fmi2Error."""
        self.component = self.fmi2Instantiate(self.instanceName.encode(), 1, self.md.guid.encode(),
                                              pathlib.Path(self.unzipped, "resources").as_uri().encode(),
                                              ctypes.byref(self._callbacks_kept), False, True)
        if not self.component:
            self.statuses.append(3)
            for status, text in self.log:       # seen by the parent when this ends the child
                print(f"fmi2Instantiate logged: {text[:400]}", file=sys.stderr)
            raise FMICallException(function="fmi2Instantiate", status=3)
        return self

    def _call(self, fname, *args):
        f = self._functions[fname]
        res = f(*args)
        if f.restype == ctypes.c_int:
            self.statuses.append(res)
            if res > 1:
                raise FMICallException(function=fname, status=res)
        return res

    def raw(self, fname, *args):
        """An FMI call without fmpy's check: its status."""
        return self._functions[fname](*args)

    def begin(self, level="initialised", start_time=0.0, values=None):
        self.create()
        if level == "instantiated":
            return self
        self.setupExperiment(startTime=start_time)
        self.enterInitializationMode()
        for name, value in (values or {}).items():
            self.set(name, value)
        if level == "initialised":
            self.exitInitializationMode()
        return self

    def set(self, name, value):
        kind, vr = self.types[name], [self.vr[name]]
        if kind == "Real":
            self.setReal(vr, [float(value)])
        elif kind == "Integer":
            self.setInteger(vr, [int(value)])
        elif kind == "Boolean":
            self.setBoolean(vr, [bool(value)])
        else:
            self.setString(vr, [str(value)])

    def get(self, names=None):
        names = self.outputs if names is None else names
        return self.getReal([self.vr[n] for n in names])

    def clock(self):
        value = ctypes.c_double()
        status = self.raw("fmi2GetRealStatus", self.component, LAST_SUCCESSFUL_TIME, ctypes.byref(value))
        return status, value.value

    def stepped(self, n=3, h=1e-3, t0=0.0, inputs=None):
        for name in (self.inputs[:3] if inputs is None else inputs):
            self.set(name, 0.5)
        for k in range(n):
            self.doStep(currentCommunicationPoint=t0 + k * h, communicationStepSize=h)
        return self

    def state_bytes(self):
        state = self.getFMUstate()
        blob = bytes(self.serializeFMUstate(state))
        self.freeFMUstate(state)
        return blob

    def deserialize(self, blob):
        """fmi2DeSerializeFMUstate, raw: (status, state handle or None)."""
        state = ctypes.c_void_p()
        buffer = ctypes.create_string_buffer(bytes(blob), max(len(blob), 1))
        status = self.raw("fmi2DeSerializeFMUstate", self.component, buffer, len(blob), ctypes.byref(state))
        return status, (state if status <= 1 else None)

    def free(self):
        if not self.freed:
            self.freed = True
            if self.component:
                self.fmi2FreeInstance(self.component)
            self.freeLibrary()


Host = FMU2Host


def nonfinite(value):
    if isinstance(value, (list, tuple)):
        return any(nonfinite(x) for x in value)
    return isinstance(value, float) and not math.isfinite(value)


def outcome_of(host, mark, value=None, exc=None):
    """The result of an action on ``host`` whose calls start at ``mark``."""
    worst = max(host.statuses[mark:], default=0) if host is not None else 0
    out = {}
    if isinstance(exc, FMICallException):
        worst = max(worst, exc.status)
    elif isinstance(exc, Wrong):
        out["wrong"] = str(exc)
    elif exc is not None:
        out["status"] = "host exception"
        out["detail"] = f"{type(exc).__name__}: {exc}"[:400]
    out.setdefault("status", STATUS[worst] if 0 <= worst < len(STATUS) else f"status {worst}")
    if isinstance(value, dict):
        out.update(value)
    elif nonfinite(value):
        out["nonfinite"] = True
        out["nonfinite_detail"] = "returned " + str([x for x in value if not math.isfinite(x)][:3])
    if host is not None:
        out["internal"] = [m[:300] for _, m in host.log if "internal error" in m.lower()]
        out["messages"] = [m[:300] for s, m in host.log if s >= 2][:3]
    return out


def probe(path, action, level="initialised", start_time=0.0, values=None, name="probe"):
    """action(host) on a fresh instance of ``path`` brought to ``level``; its outcome."""
    host = None
    try:
        host = Host(path, name)
        host.begin(level, start_time, values)
    except Exception as exc:
        out = outcome_of(host, 0, exc=exc)
        out["note"] = "set-up failed"
        if host is not None:
            host.free()
        return out
    mark = len(host.statuses)
    try:
        out = outcome_of(host, mark, value=action(host))
    except Exception as exc:
        out = outcome_of(host, mark, exc=exc)
    finally:
        host.free()
    return out


ITEMS = []


def item(label, expect, run):
    """expect: "refuse" (OK or Warning is silently wrong), "ok" (a refusal is a valid call refused), "any"."""
    ITEMS.append((label, expect, run))


def _stderr_size():
    try:
        return os.fstat(2).st_size
    except OSError:
        return 0


def main():
    say(n=len(ITEMS))
    for i in range(CONFIG.get("start", 0), len(ITEMS)):
        label, expect, run = ITEMS[i]
        say(begin=i, label=label)
        sys.stderr.flush()
        stderr_at = _stderr_size()
        tic = time.perf_counter()
        out = run()
        out.update(i=i, label=label, expect=expect, seconds=round(time.perf_counter() - tic, 4))
        sys.stderr.flush()
        if _stderr_size() > stderr_at:          # the call printed on the host's stderr: the parent reads it
            out["stderr_at"] = stderr_at
        say(**out)


def state_header(blob):
    at = len(STATE_PREFIX)
    fmt, runtime, fmi_state = struct.unpack_from("<3I", blob, at)
    payload, = struct.unpack_from("<Q", blob, at + 12)
    crc, guid_length = struct.unpack_from("<2I", blob, at + 20)
    return {"format": fmt, "runtime": runtime, "fmi_state": fmi_state, "payload": payload, "crc": crc,
            "payload_at": at + 28 + guid_length}


def restamp_crc(blob):
    """The state with its CRC-32 computed again (zlib): a payload changed on purpose reaches the bridge's checks."""
    body = bytes(blob[CRC_AT + 4:])
    return bytes(blob[:CRC_AT]) + struct.pack("<I", zlib.crc32(body)) + body


def with_payload(blob, payload):
    """``blob``'s header with another payload: its size and checksum made to match."""
    at = state_header(blob)["payload_at"]
    size_at = len(STATE_PREFIX) + 12
    head = bytearray(blob[:at])
    head[size_at:size_at + 8] = struct.pack("<Q", len(payload))
    return restamp_crc(bytes(head) + bytes(payload))
'''
