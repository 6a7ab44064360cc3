"""Loggers that call back, probed in a child process with a time limit per call (flexfmu.fmi.diagnostics_runner):
a host's logger callback that calls fmi2GetReal, fmi2GetRealStatus or fmi2DoStep into the instance whose call is
logging.  docs/fmu.md ("Errors"): such a call is refused with fmi2Error (it would otherwise wait forever on the
instance), and the running call then says what was refused.  A deadlock shows as a hang (the child is killed after
the time limit), a call answered OK from inside the logger as silently wrong, and an instance that no longer answers
afterwards as a valid call refused."""
from __future__ import annotations

from pathlib import Path

from flexfmu.fmi.diagnostics_host import HOST
from flexfmu.fmi.diagnostics_runner import run_resumable

REENTRANT = HOST + r'''
PATH = CONFIG["fmu"]
INPUTS = [v.valueReference for v in variables(PATH, "Real", "input")]
OUTPUTS = [v.valueReference for v in variables(PATH, "Real", "output")]
TARGET_VR = (INPUTS or OUTPUTS)[0]          # NaN into an input is refused; into an output too (no input)


def inner_get_real(h):
    vr, value = (ctypes.c_uint * 1)(OUTPUTS[0]), (ctypes.c_double * 1)()
    return h.raw("fmi2GetReal", h.component, vr, 1, value)


def inner_get_real_status(h):
    value = ctypes.c_double()
    return h.raw("fmi2GetRealStatus", h.component, LAST_SUCCESSFUL_TIME, ctypes.byref(value))


def inner_do_step(h):
    return h.raw("fmi2DoStep", h.component, ctypes.c_double(0.0), ctypes.c_double(1e-3), 1)


CALLBACKS = {"fmi2GetReal": inner_get_real, "fmi2GetRealStatus": inner_get_real_status, "fmi2DoStep": inner_do_step}
TRIGGERS = {
    "a refused fmi2DoStep at a wrong time": (
        "initialised", True, lambda h: h.doStep(currentCommunicationPoint=5.0, communicationStepSize=1e-3)),
    "fmi2DoStep out of sequence": ("init", True,
                                   lambda h: h.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)),
    "a refused fmi2SetReal of NaN": ("initialised", True, lambda h: h.setReal([TARGET_VR], [float("nan")])),
    "fmi2ExitInitializationMode (when it logs)": ("init", False, lambda h: h.exitInitializationMode()),
    "fmi2SetDebugLogging with an unknown category (when it logs)": (
        "initialised", False, lambda h: h.setDebugLogging(True, ["no-such-category"])),
    "fmi2Terminate (when it logs)": ("initialised", False, lambda h: h.terminate()),
}


def reenter(trigger, callback):
    level, refused, outer_call = TRIGGERS[trigger]
    inner = CALLBACKS[callback]

    def probe_once(h, answers):
        h.begin(level)

        def on_log(status, text):
            if len(answers) < 3:
                answers.append(inner(h))
        h.on_log = on_log
        outer = 0
        try:
            outer_call(h)
        except FMICallException as exc:
            outer = exc.status
        h.on_log = None
        if not answers:
            return {"skip": True, "status": "OK", "note": "nothing logged: no call back made"}
        least = min(answers)
        out = {"status": STATUS[least] if 0 <= least < 5 else f"status {least}",
               "note": f"outer call answered {STATUS[outer]}; calls from the logger answered {answers}"}
        wrong = []
        if refused and outer <= 1:
            wrong.append(f"the outer call answered {STATUS[outer]}")
        if least >= 2 and not any("logger" in m for _, m in h.log):
            wrong.append("no message says that a call from the logger was refused")
        try:
            h.get(h.outputs[:1])
        except FMICallException as exc:
            wrong.append(f"fmi2GetReal afterwards answered {STATUS[exc.status]}")
        if wrong:
            out["wrong"] = "; ".join(wrong)
        return out

    def run():
        h, answers = None, []
        try:
            h = Host(PATH, "reentrant")
            out = probe_once(h, answers)
        except Exception as exc:
            out = {"status": "host exception", "detail": f"{type(exc).__name__}: {exc}"[:400]}
        if h is not None:
            out["internal"] = [m[:300] for _, m in h.log if "internal error" in m.lower()]
            out["messages"] = [m[:300] for st, m in h.log if st >= 2][:3]
            h.free()
        return out
    return run


for trigger in TRIGGERS:
    for callback in CALLBACKS:
        item(f"{callback} from the logger during {trigger}", "refuse", reenter(trigger, callback))
main()
'''


def reentrant_probes(fmu: Path, *, item_timeout: float = 30.0) -> list[dict]:
    """REENTRANT on ``fmu``: each trigger x call back on a fresh instance; a deadlock is a hang after item_timeout."""
    return run_resumable(REENTRANT, {"fmu": str(fmu)}, item_timeout=item_timeout)
