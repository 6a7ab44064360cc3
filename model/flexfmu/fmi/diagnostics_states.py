"""Foreign and damaged FMU states, probed in a child process (flexfmu.fmi.diagnostics_runner): what docs/fmu.md
promises for both runtimes ("Serialised FMU states", "Errors"): a state of another FMU or runtime, in memory or
serialised, is refused; so is every single-bit flip (CRC-32 detects them all), a truncated or extended state, and a
payload with a non-finite number or sizes that do not add up even when its checksum is stamped again, so that the
bridge's own checks judge it.  The payload offsets are those of flexfmu_native.c's serialize_state: "FXNATIVE",
u32 version, u32 n_vars, n_inputs, n_outputs, nx, u32 flags, f64 time, start time, clock, f64 values[n_vars],
held[n_inputs], outputs[n_outputs], x[nx], the String parameters, u64 length and the kind's own state (JSON for
the Python kind)."""
from __future__ import annotations

from pathlib import Path

from flexfmu.fmi.diagnostics_host import HOST
from flexfmu.fmi.diagnostics_runner import run_resumable

STATES = HOST + r'''
PATH = CONFIG["fmu"]
NAN, INF = float("nan"), float("inf")


def run_with(action):
    """action(open_host): its dict (with "status"); every instance it opened freed after, their messages kept."""
    hosts = []

    def open_host(path=PATH, name="target", steps=3, level="initialised"):
        h = Host(path, name)
        hosts.append(h)
        h.begin(level)
        if steps:
            h.stepped(steps)
        return h

    try:
        out = dict(action(open_host))
    except Wrong as exc:
        out = {"status": "OK", "wrong": str(exc)}
    except FMICallException as exc:
        out = {"status": STATUS[exc.status] if exc.status < 5 else "host exception",
               "detail": f"{exc.function} answered {exc.status} in the probe's own set-up"}
        if exc.function != "fmi2SetFMUstate":
            out["status"] = "host exception"
    except Exception as exc:
        out = {"status": "host exception", "detail": f"{type(exc).__name__}: {exc}"[:400]}
    finally:
        out_internal = [m[:300] for h in hosts for _, m in h.log if "internal error" in m.lower()]
        messages = [m[:300] for _, m in (hosts[0].log if hosts else []) if _ >= 2][-3:]
        for h in reversed(hosts):
            try:
                h.free()
            except Exception:
                pass
    out["internal"], out["messages"] = out_internal, messages
    return out


def use_if_accepted(host, status, state):
    """A damaged state the FMU accepted: restore it and step, to see what it does with it."""
    out = {"status": STATUS[status] if 0 <= status < 5 else f"status {status}"}
    if state is not None:
        try:
            host.setFMUstate(state)
            host.freeFMUstate(state)
            t = host.clock()[1]
            host.doStep(currentCommunicationPoint=t, communicationStepSize=1e-3)
            values = host.get()
            if nonfinite(values):
                out["nonfinite"] = True
                out["nonfinite_detail"] = "outputs after restoring it and stepping: " + str(values[:4])
            out["note"] = "accepted; restored and stepped: OK"
        except FMICallException as exc:
            out["note"] = f"accepted by fmi2DeSerializeFMUstate; then {exc.function} answered {exc.status}"
    return out


# the state every damage starts from (a fresh instance, 3 steps with loads): the same bytes in each child
_first = Host(PATH, "first")
_first.begin()
_first.stepped(3)
BLOB = _first.state_bytes()
_first.free()
HEAD = state_header(BLOB)
AT = HEAD["payload_at"]
PAYLOAD = BLOB[AT:]
N_VARS, N_IN, N_OUT, NX = struct.unpack_from("<4I", PAYLOAD, 12)
KIND_AT = PAYLOAD.find(b'{"format"')            # the Python kind's simulator state (JSON), else -1


def deserialize_item(label, expect, make):
    def action(open_host):
        host = open_host()
        status, state = host.deserialize(make())
        return use_if_accepted(host, status, state)
    item(label, expect, lambda: run_with(action))


# controls: what must work
def round_trip(open_host):
    h = open_host()
    before, blob = h.get(), h.state_bytes()
    h.stepped(2, t0=3e-3)
    status, state = h.deserialize(blob)
    if status > 1:
        return {"status": STATUS[status]}
    h.setFMUstate(state)
    h.freeFMUstate(state)
    if h.get() != before:
        raise Wrong("the outputs after restoring the serialised state differ from those it was taken with")
    h.doStep(currentCommunicationPoint=3e-3, communicationStepSize=1e-3)
    return {"status": "OK"}
item("serialised state restored (control)", "ok", lambda: run_with(round_trip))


def early_state(open_host):
    h = open_host(steps=0, level="instantiated")
    state = h.getFMUstate()
    h.setupExperiment(startTime=0.0)
    h.enterInitializationMode()
    h.exitInitializationMode()
    h.stepped(2)
    h.setFMUstate(state)
    h.freeFMUstate(state)
    h.setupExperiment(startTime=0.0)
    h.enterInitializationMode()
    h.exitInitializationMode()
    h.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    return {"status": "OK"}
item("state taken before initialisation, restored after it (control)", "ok", lambda: run_with(early_state))

# another FMU's or runtime's state
for partner in CONFIG.get("partners", []):
    what = f"{partner['relation']} ({partner['name']})"

    def set_foreign(open_host, partner=partner):
        target, giver = open_host(), open_host(partner["path"], "giver")
        state = giver.getFMUstate()
        status = target.raw("fmi2SetFMUstate", target.component, state)
        giver.freeFMUstate(state)
        out = {"status": STATUS[status]}
        if status <= 1:                          # accepted: see what stepping on it does
            target.doStep(currentCommunicationPoint=target.clock()[1], communicationStepSize=1e-3)
            out["nonfinite"] = nonfinite(target.get())
        return out
    item(f"fmi2SetFMUstate with the in-memory state of {what}", "refuse", lambda p=set_foreign: run_with(p))

    def serialize_foreign(open_host, partner=partner):
        target, giver = open_host(), open_host(partner["path"], "giver")
        state = giver.getFMUstate()
        size = ctypes.c_size_t()
        status = target.raw("fmi2SerializedFMUstateSize", target.component, state, ctypes.byref(size))
        giver.freeFMUstate(state)
        return {"status": STATUS[status]}
    item(f"fmi2SerializedFMUstateSize of the in-memory state of {what}", "refuse",
         lambda p=serialize_foreign: run_with(p))

    def deserialize_foreign(open_host, partner=partner):
        target, giver = open_host(), open_host(partner["path"], "giver")
        status, state = target.deserialize(giver.state_bytes())
        return use_if_accepted(target, status, state)
    item(f"fmi2DeSerializeFMUstate of the serialised state of {what}", "refuse",
         lambda p=deserialize_foreign: run_with(p))

# every single-bit flip (or a sample beyond a size), in chunks
n_bits = 8 * len(BLOB)
if n_bits <= CONFIG.get("all_flips_below_bits", 65536):
    BITS = list(range(n_bits))
else:
    rng = random.Random(CONFIG.get("seed", 20261128))
    BITS = list(range(8 * AT)) + sorted(rng.sample(range(8 * AT, n_bits), CONFIG.get("flips", 4096)))
CHUNK = 2048
for first in range(0, len(BITS), CHUNK):
    chunk = BITS[first:first + CHUNK]

    def flips(open_host, chunk=chunk):
        host = open_host()
        counts, accepted = {}, []
        for bit in chunk:
            damaged = bytearray(BLOB)
            damaged[bit // 8] ^= 1 << (bit % 8)
            status, state = host.deserialize(damaged)
            name = STATUS[status] if 0 <= status < 5 else f"status {status}"
            counts[name] = counts.get(name, 0) + 1
            if state is not None:
                accepted.append(bit)
                host.freeFMUstate(state)
        out = {"counts": counts, "status": max(counts, key=counts.get)}
        if accepted:
            out["wrong_count"] = len(accepted)
            out["wrong"] = f"{len(accepted)} flipped states accepted, bits {accepted[:6]}"
        return out
    item(f"single-bit flips {chunk[0]} .. {chunk[-1]} ({len(chunk)} of {n_bits} bits)", "refuse",
         lambda f=flips: run_with(f))

# truncated and extended
for length in sorted({0, 1, len(STATE_PREFIX), AT - 1, AT, AT + 8, len(BLOB) // 2, len(BLOB) - 8, len(BLOB) - 1}):
    if 0 <= length < len(BLOB):
        deserialize_item(f"truncated to {length} of {len(BLOB)} bytes", "refuse", lambda n=length: BLOB[:n])
for extra in (b"\0", b"\0" * 8, bytes(range(256)) * 16, BLOB):
    deserialize_item(f"extended by {len(extra)} bytes", "refuse", lambda e=extra: BLOB + e)


# payloads changed on purpose, checksum stamped again
def patched(offset, fmt, value):
    def make():
        p = bytearray(PAYLOAD)
        struct.pack_into(fmt, p, offset, value)
        return with_payload(BLOB, p)
    return make


VALUES_AT = 56
HELD_AT = VALUES_AT + 8 * N_VARS
OUTPUTS_AT = HELD_AT + 8 * N_IN
X_AT = OUTPUTS_AT + 8 * N_OUT
EDITS = [("NaN time since the start", 32, "<d", NAN, "refuse"), ("NaN start time", 40, "<d", NAN, "refuse"),
         ("NaN clock", 48, "<d", NAN, "refuse"), ("infinite clock", 48, "<d", INF, "refuse"),
         ("NaN first variable value", VALUES_AT, "<d", NAN, "refuse"),
         ("layout version 99", 8, "<I", 99, "refuse"), ("sizes of another model", 12, "<I", N_VARS + 1, "refuse"),
         ("unknown flags", 28, "<I", 8, "refuse")]
if N_IN:
    EDITS.append(("NaN held input", HELD_AT, "<d", NAN, "refuse"))
if N_OUT:
    EDITS.append(("NaN output", OUTPUTS_AT, "<d", NAN, "refuse"))
if NX:
    EDITS += [("NaN first state entry", X_AT, "<d", NAN, "refuse"),
              ("NaN last state entry", X_AT + 8 * (NX - 1), "<d", NAN, "refuse"),
              ("infinite state entry", X_AT, "<d", INF, "refuse"),
              ("state entry 1e300", X_AT, "<d", 1e300, "any")]
for label, offset, fmt, value, expect in EDITS:
    deserialize_item(f"restamped payload: {label}", expect, patched(offset, fmt, value))
deserialize_item("restamped payload: not FXNATIVE", "refuse", lambda: with_payload(BLOB, b"XX" + PAYLOAD[2:]))
deserialize_item("restamped payload: one byte more", "refuse", lambda: with_payload(BLOB, PAYLOAD + b"\0"))
deserialize_item("restamped payload: one byte less", "refuse", lambda: with_payload(BLOB, PAYLOAD[:-1]))

if KIND_AT > 0:                                   # the Python kind: its simulator's state, JSON
    SIM = json.loads(PAYLOAD[KIND_AT:])

    def first_float(node, path=()):
        if isinstance(node, float):
            return path
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for key, child in items:
            found = first_float(child, path + (key,))
            if found is not None:
                return found
        return None

    def sim_edit(change):
        def make():
            state = json.loads(PAYLOAD[KIND_AT:])
            change(state)
            text = json.dumps(state).encode()
            return with_payload(BLOB, PAYLOAD[:KIND_AT - 8] + struct.pack("<Q", len(text)) + text)
        return make

    def set_at(path, value):
        def change(state):
            node = state
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = value
        return change

    where = first_float(SIM.get("sim", SIM))
    if where is not None:
        where = ("sim",) + where if "sim" in SIM else where
        name = ".".join(map(str, where))
        deserialize_item(f"restamped simulator state: NaN at {name}", "refuse", sim_edit(set_at(where, NAN)))

    def overflowing_number():                     # JSON's number 1e999: inf in Python's reader
        text = PAYLOAD[KIND_AT:].replace(b'"format"', b'"overflow": 1e999, "format"', 1)
        return with_payload(BLOB, PAYLOAD[:KIND_AT - 8] + struct.pack("<Q", len(text)) + text)
    deserialize_item("restamped simulator state: a number 1e999", "refuse", overflowing_number)
    deserialize_item("restamped simulator state: format 99", "refuse", sim_edit(set_at(("format",), 99)))
    deserialize_item("restamped simulator state: another model", "refuse",
                     sim_edit(set_at(("model",), "another model")))

    def cut_json():
        text = PAYLOAD[KIND_AT:][:-10]
        return with_payload(BLOB, PAYLOAD[:KIND_AT - 8] + struct.pack("<Q", len(text)) + text)
    deserialize_item("restamped simulator state: JSON cut short", "refuse", cut_json)
main()
'''


def state_probes(fmu: Path, partners: list[dict], *, flips: int = 4096, all_flips_below_bits: int = 65536,
                 item_timeout: float = 120.0) -> list[dict]:
    """STATES on ``fmu``: partners [{"path", "name", "relation"}] (FMUs loaded in the same process: another FMU,
    the other runtime's FMU of the same model), every single-bit flip of its serialised state when it has at most
    ``all_flips_below_bits`` bits, else its header's bits and ``flips`` others drawn at random (seeded)."""
    return run_resumable(STATES, {"fmu": str(fmu), "partners": partners, "flips": flips,
                                  "all_flips_below_bits": all_flips_below_bits}, item_timeout=item_timeout)
