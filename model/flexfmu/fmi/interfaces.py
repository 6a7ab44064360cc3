"""The FMI interfaces of a native FMU: co-simulation, model exchange or both, and what model exchange and directional
derivatives add to its modelDescription.xml (FMI 2.0 and 3.0).

Model exchange is offered by the kinds that are ODEs in fixed coordinates (the LTI kind: FFRBeam and exported
clamped bodies, x' = A(p) x + B(p) u + b(p), csrc/native_lti.c); the host integrates their continuous states.  Free
bodies (the reframe kind) are co-simulation only: the reframe method is a stepping method (each step is taken in an
inertial frame that follows the rigid-body motion), not a right-hand side; so are the point-absorber components and
the native Mooring (CO_SIMULATION_ONLY says why, in the refusal).

The continuous states are the kind's state vector x (the modal coordinates eta_k of the retained modes, then their
rates eta_dot_k): value references after the model file's variables (n_vars .. n_vars + nx - 1), their derivatives
the next nx (csrc/flexfmu_native.c, BridgeApi in flexfmu_bridge.h).  Directional derivatives (outputs and state
derivatives with respect to inputs and states) are exact in the LTI kind and provided in both interfaces.
"""
from __future__ import annotations

from xml.etree import ElementTree as ET

import numpy as np

from flexfmu.errors import ParameterError

#: the values of ``--interface``
INTERFACES = ("cs", "me", "both")
#: the kinds that are ODEs in fixed coordinates (model exchange) and that give exact directional derivatives
ODE_KINDS = ("lti",)
#: why a kind that is no ODE in fixed coordinates offers co-simulation only
CO_SIMULATION_ONLY = {
    "reframe": "a free body (the reframe kind) is co-simulation only: the reframe method is a stepping method (each "
               "step in an inertial frame that follows the rigid-body motion), not a right-hand side",
    "wec": "the point-absorber components (the wec kind) are co-simulation only: they step exactly for inputs held "
           "over a communication step, and their right-hand sides (the float's and the radiation memory's) are not "
           "offered as model exchange",
    "moordyn": "the native Mooring (the moordyn kind) is co-simulation only: MoorDyn integrates its lines with its own "
               "time steps and gives no right-hand side",
}


def check_interface(kind: str, interface: str) -> tuple:
    """The interface types ("cs", "me") of ``interface`` for a model of ``kind``; a ParameterError naming
    ``interface`` when it is not one of INTERFACES or the kind offers no model exchange."""
    if interface not in INTERFACES:
        raise ParameterError("interface", f"got {interface!r}", " | ".join(INTERFACES))
    types = ("cs", "me") if interface == "both" else (interface,)
    if "me" in types and kind not in ODE_KINDS:
        why = CO_SIMULATION_ONLY.get(kind, f"the {kind} kind is co-simulation only")
        raise ParameterError("interface", f"{interface}: {why}", "cs")
    return types


def state_names(nx: int) -> list[tuple[str, str]]:
    """(name, description) of the continuous states: x = [eta; eta_dot] (the LTI kind's order)."""
    if nx % 2:
        return [(f"x_{k + 1}", f"continuous state {k + 1}") for k in range(nx)]
    n = nx // 2
    return ([(f"eta_{k + 1}", f"modal coordinate of retained mode {k + 1} (mass-normalised mode: eta in m kg^0.5)")
             for k in range(n)]
            + [(f"eta_dot_{k + 1}", f"rate of the modal coordinate of retained mode {k + 1}") for k in range(n)])


#: the base acceleration that sets the states' nominal sizes (m/s^2): the body's own weight
STANDARD_GRAVITY = 9.80665


def state_nominals(lti) -> np.ndarray:
    """The continuous states' nominal values (their typical sizes; a host's integrator scales its absolute tolerance
    by them, and the default 1 would be far too loose for modal coordinates of ~1e-6): for x = [eta; eta_dot] with
    eta'' = -omega_k^2 eta_k - L_k . a_base + ..., the static modal deflection under the body's own weight as if every
    mode carried all of the participating mass, g sqrt(sum |L_k|^2) / omega_k^2, and its rate at omega_k,
    g sqrt(sum |L_k|^2) / omega_k.  A model without base-acceleration inputs, or whose A(0) is not of that form,
    gets 1 (FMI's default)."""
    nx = lti.nx
    ones = np.ones(nx)
    n = nx // 2
    names = list(lti.u_names)
    base_a = [names.index(f"base_a_{a}") for a in "xyz" if f"base_a_{a}" in names]
    A0 = lti.A[0]
    if nx % 2 or not base_a or not np.array_equal(A0[:n, n:], np.eye(n)) or np.any(A0[:n, :n]):
        return ones
    omega2 = -np.diag(A0[n:, :n])
    participation = lti.B[0][n:, base_a]
    scale = STANDARD_GRAVITY * float(np.sqrt(np.sum(participation ** 2)))
    if not (np.all(omega2 > 0) and scale > 0 and np.isfinite(scale)):
        return ones
    omega = np.sqrt(omega2)
    return np.concatenate([scale / omega2, scale / omega])


def _variables(root: ET.Element) -> ET.Element:
    return root.find("ModelVariables")


# ---------------------------------------------------------------------------------------------- FMI 2.0
def complete_fmi2(root: ET.Element, *, name: str, n_vars: int, nx: int, types: tuple, directional: bool,
                  nominals=None) -> None:
    """Complete the FMI 2.0 modelDescription ``root`` (co-simulation, from native_build) with model exchange (when
    "me" in ``types``: the ModelExchange element, the states and derivatives, ModelStructure's Derivatives and
    InitialUnknowns), without co-simulation when "cs" is not in ``types``, and directional derivatives."""
    cosim = root.find("CoSimulation")
    if directional:
        cosim.set("providesDirectionalDerivative", "true")
    if "me" not in types:
        return
    me = ET.Element("ModelExchange", {"modelIdentifier": name, "needsExecutionTool": "false",
                                      "completedIntegratorStepNotNeeded": "true",
                                      "canBeInstantiatedOnlyOncePerProcess": "false",
                                      "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true",
                                      "providesDirectionalDerivative": "true" if directional else "false"})
    sources = cosim.find("SourceFiles")
    if sources is not None:
        me.append(ET.fromstring(ET.tostring(sources)))
    position = list(root).index(cosim)
    root.insert(position, me)
    if "cs" not in types:
        root.remove(cosim)
    root.set("numberOfEventIndicators", "0")
    variables = _variables(root)
    if len(variables) != n_vars:
        raise ParameterError("variables", f"{len(variables)} in the modelDescription", f"{n_vars} (the model file's)")
    names = state_names(nx)
    for k, (state, text) in enumerate(names):
        element = ET.SubElement(variables, "ScalarVariable", name=state, valueReference=str(n_vars + k),
                                description=text, causality="local", variability="continuous", initial="calculated")
        ET.SubElement(element, "Real", {} if nominals is None else {"nominal": repr(float(nominals[k]))})
    for k, (state, _) in enumerate(names):
        element = ET.SubElement(variables, "ScalarVariable", name=f"der({state})", valueReference=str(n_vars + nx + k),
                                description=f"time derivative of {state}", causality="local",
                                variability="continuous", initial="calculated")
        ET.SubElement(element, "Real", derivative=str(n_vars + k + 1))   # the state's 1-based index
    structure = root.find("ModelStructure")
    derivatives = ET.Element("Derivatives")
    for k in range(nx):
        ET.SubElement(derivatives, "Unknown", index=str(n_vars + nx + k + 1))
    outputs = structure.find("Outputs")
    structure.insert(list(structure).index(outputs) + 1 if outputs is not None else 0, derivatives)
    initial = structure.find("InitialUnknowns")
    if initial is None:
        initial = ET.SubElement(structure, "InitialUnknowns")
    indices = sorted({int(u.get("index")) for u in initial} | set(range(n_vars + 1, n_vars + 2 * nx + 1)))
    for child in list(initial):
        initial.remove(child)
    for index in indices:
        ET.SubElement(initial, "Unknown", index=str(index))


# ---------------------------------------------------------------------------------------------- FMI 3.0
def complete_fmi3(root: ET.Element, *, name: str, n_vars: int, nx: int, types: tuple, directional: bool,
                  nominals=None) -> None:
    """As complete_fmi2 for an FMI 3.0 modelDescription (description_fmi3.model_description)."""
    cosim = root.find("CoSimulation")
    if directional:
        cosim.set("providesDirectionalDerivatives", "true")
    if "me" not in types:
        return
    me = ET.Element("ModelExchange", {"modelIdentifier": name, "needsExecutionTool": "false",
                                      "needsCompletedIntegratorStep": "false",
                                      "canBeInstantiatedOnlyOncePerProcess": "false",
                                      "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
                                      "providesDirectionalDerivatives": "true" if directional else "false"})
    root.insert(list(root).index(cosim), me)
    if "cs" not in types:
        root.remove(cosim)
    variables = _variables(root)
    names = state_names(nx)
    for k, (state, text) in enumerate(names):
        element = ET.SubElement(variables, "Float64", name=state, valueReference=str(n_vars + k), description=text,
                                causality="local", variability="continuous", initial="calculated")
        if nominals is not None:
            element.set("nominal", repr(float(nominals[k])))
    for k, (state, _) in enumerate(names):
        ET.SubElement(variables, "Float64", name=f"der({state})", valueReference=str(n_vars + nx + k),
                      description=f"time derivative of {state}", causality="local", variability="continuous",
                      initial="calculated", derivative=str(n_vars + k))
    structure = root.find("ModelStructure")
    children = list(structure)
    outputs = [c for c in children if c.tag == "Output"]
    initial = [c for c in children if c.tag == "InitialUnknown"]
    for child in children:
        structure.remove(child)
    for child in outputs:
        structure.append(child)
    for k in range(nx):
        ET.SubElement(structure, "ContinuousStateDerivative", valueReference=str(n_vars + nx + k))
    references = sorted({int(c.get("valueReference")) for c in initial} | set(range(n_vars, n_vars + 2 * nx)))
    for reference in references:
        ET.SubElement(structure, "InitialUnknown", valueReference=str(reference))
