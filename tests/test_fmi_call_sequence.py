"""Every FMI 2.0 function in every state of an instance, against the call-sequence table printed in
docs/fmu.md (the specification): a call without ✓ returns fmi2Error with the one message
"fmi2X: illegal call sequence (state S)" and leaves the state as it was; a call with ✓ is not refused
for its sequence; an unsupported function is refused in every state."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from fmpy.fmi2 import fmi2DoStepStatus, fmi2LastSuccessfulTime, fmi2Terminated

from fmu_helpers import Instance

DOC = Path(__file__).resolve().parents[1] / "docs" / "fmu.md"
STATES = ["Instantiated", "InitializationMode", "StepComplete", "StepFailed", "Terminated", "Error"]
SMALL = {"model": "beam:spatial_double_L", "n_flexible_modes": 4, "scheme": "consistent",
         "max_internal_steps": 100, "load_point_x": 0.0, "load_point_y": 0.0, "load_point_z": 0.0,   # on the rod
         "output_point_x": 0.0, "output_point_y": 0.0, "output_point_z": 0.0}


def table() -> dict[str, list[str] | None]:
    """{function: the states where it is legal, or None when it is not supported} from docs/fmu.md."""
    text = DOC.read_text(encoding="utf-8")
    rows = {}
    header = next(line for line in text.splitlines() if line.startswith("| function | Instantiated"))
    assert [c.strip() for c in header.strip("|").split("|")][1:] == STATES
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("| function | Instantiated")) + 2
    for line in lines[first:]:   # the table's rows: up to the first line that is not one
        match = re.match(r"\| (fmi2\w+) \|(.*)\|$", line)
        if not match:
            break
        if match:
            cells = [c.strip() for c in match.group(2).split("|")]
            assert len(cells) == len(STATES), line
            rows[match.group(1)] = None if cells[0] == "—" else [s for s, c in zip(STATES, cells) if c == "✓"]
    return rows


TABLE = table()


def test_the_table_has_every_co_simulation_function():
    assert len(TABLE) == 31 and "fmi2DoStep" in TABLE and "fmi2Instantiate" not in TABLE


def instance_in(fmus, state: str) -> Instance:
    """A ReframeBody instance (a small model; it has variables of all four types) in ``state``."""
    inst = Instance(fmus["ReframeBody"], "seq", **SMALL)       # Instance starts in InitializationMode
    if state == "Instantiated":
        inst.fmu.reset()
        return inst
    if state == "InitializationMode":
        return inst
    inst.initialize()
    if state == "StepFailed":            # a step that needs more internal steps than the cap
        inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=10.0, status=2)
    elif state == "Terminated":
        inst.fmu.terminate()
    elif state == "Error":               # a step from another time than the FMU's
        inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=5.0, communicationStepSize=1e-3)
    inst.log.clear()
    return inst


def still_in(inst: Instance, state: str) -> bool:
    """Whether the instance is still in ``state``: a call whose outcome only that state gives."""
    fmu = inst.fmu
    inst.log.clear()
    try:
        if state == "Instantiated":
            fmu.setupExperiment(startTime=0.0)
        elif state == "InitializationMode":
            fmu.exitInitializationMode()
        elif state == "StepComplete":
            fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
        elif state == "StepFailed":
            return fmu.getStatus(fmi2DoStepStatus) == 2
        else:                            # Terminated, Error: a call refused naming that state
            fmu.getFMUstate() if state == "Error" else fmu.terminate()
            return False
    except Exception:
        return state in ("Terminated", "Error") and any(f"(state {state})" in m for _, _, m in inst.log)
    return True


def call(inst: Instance, function: str, donor):
    """Make the call with valid arguments; its status (0 when fmpy did not raise)."""
    fmu, vr = inst.fmu, inst.vr
    calls = {
        "fmi2SetDebugLogging": lambda: fmu.setDebugLogging(True, []),
        "fmi2SetupExperiment": lambda: fmu.setupExperiment(startTime=0.0),
        "fmi2EnterInitializationMode": fmu.enterInitializationMode,
        "fmi2ExitInitializationMode": fmu.exitInitializationMode,
        "fmi2Terminate": fmu.terminate,
        "fmi2Reset": fmu.reset,
        "fmi2FreeInstance": fmu.freeInstance,
        "fmi2GetReal": lambda: fmu.getReal([vr["omega_3"]]),
        "fmi2GetInteger": lambda: fmu.getInteger([vr["n_flexible_modes"]]),
        "fmi2GetBoolean": lambda: fmu.getBoolean([vr["force_follows_body"]]),
        "fmi2GetString": lambda: fmu.getString([vr["scheme"]]),
        "fmi2SetReal": lambda: fmu.setReal([vr["F_x"]], [1.0]),
        "fmi2SetInteger": lambda: fmu.setInteger([vr["n_flexible_modes"]], [4]),
        "fmi2SetBoolean": lambda: fmu.setBoolean([vr["force_follows_body"]], [False]),
        "fmi2SetString": lambda: fmu.setString([vr["scheme"]], ["consistent"]),
        "fmi2GetFMUstate": fmu.getFMUstate,
        "fmi2SetFMUstate": lambda: fmu.setFMUstate(donor[1]),
        "fmi2FreeFMUstate": lambda: fmu.freeFMUstate(donor[0].fmu.getFMUstate()),
        "fmi2SerializedFMUstateSize": lambda: fmu.serializeFMUstate(donor[1]),
        "fmi2SerializeFMUstate": lambda: fmu.serializeFMUstate(donor[1]),
        "fmi2DeSerializeFMUstate": lambda: fmu.deSerializeFMUstate(donor[0].fmu.serializeFMUstate(donor[1])),
        "fmi2GetDirectionalDerivative": lambda: fmu.getDirectionalDerivative([vr["omega_3"]], [vr["F_x"]], [1.0]),
        "fmi2SetRealInputDerivatives": lambda: fmu.setRealInputDerivatives([vr["F_x"]], [1], [0.0]),
        "fmi2GetRealOutputDerivatives": lambda: fmu.getRealOutputDerivatives([vr["omega_3"]], [1]),
        "fmi2DoStep": lambda: fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3),
        "fmi2CancelStep": fmu.cancelStep,
        "fmi2GetStatus": lambda: fmu.getStatus(fmi2DoStepStatus),
        "fmi2GetRealStatus": lambda: fmu.getRealStatus(fmi2LastSuccessfulTime),
        "fmi2GetIntegerStatus": lambda: fmu.getIntegerStatus(fmi2DoStepStatus),
        "fmi2GetBooleanStatus": lambda: fmu.getBooleanStatus(fmi2Terminated),
        "fmi2GetStringStatus": lambda: fmu.getStringStatus(fmi2DoStepStatus),
    }
    try:
        calls[function]()
    except Exception as exc:
        return getattr(exc, "status", None)
    return 0


@pytest.mark.parametrize("state", STATES)
def test_every_function_in_every_state_follows_the_table(fmus, state):
    donor_instance = Instance(fmus["ReframeBody"], "donor", **SMALL).initialize()
    donor = (donor_instance, donor_instance.fmu.getFMUstate())
    problems = []
    try:
        for function, legal in TABLE.items():
            inst = instance_in(fmus, state)
            status = call(inst, function, donor)
            messages = [m for s, _, m in inst.log if s >= 3]
            illegal = [m for m in messages if "illegal call sequence" in m]
            if legal is None:
                if status != 3 or not any(m.startswith(f"{function}: not supported") for m in messages):
                    problems.append(f"{function} in {state}: expected 'not supported', got {status} {messages}")
            elif state in legal:
                if illegal:
                    problems.append(f"{function} in {state} is legal but was refused: {illegal}")
            else:
                wanted = f"{function}: illegal call sequence (state {state})"
                if status != 3 or messages != [wanted]:
                    problems.append(f"{function} in {state}: expected [{wanted!r}] and 3, got {status} {messages}")
                elif not still_in(inst, state):
                    problems.append(f"{function} in {state} changed the state")
            if function == "fmi2FreeInstance":     # legal everywhere: freed (fmpy unloaded the library)
                inst.fmu = None
            inst.free()
    finally:
        donor[0].free()
    assert not problems, "\n".join(problems)
