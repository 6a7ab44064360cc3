"""FMI 3.0 array variables of a native FMU: further views of values the runtime already has, beside the scalars with
their FMI 2.0 names (which stay as they are, so an FMI 3.0 FMU equals its FMI 2.0 twin value for value).

- **3-vectors**: every three Float64 inputs or outputs ``P_x``, ``P_y``, ``P_z`` (one causality, one unit; not a
  quaternion's, which has ``P_w`` too) are also the array ``P`` (``P_xyz`` when ``P`` is taken) of
  ``<Dimension start="3"/>``: setting the array sets the three scalars, reading it reads them.
- **Modes**: the structural parameter ``n_retained_modes`` (UInt64, ``causality="structuralParameter"``,
  ``variability="fixed"``, start = the number of retained modes n, fixed at build: another value is refused naming
  it) sizes, through ``<Dimension valueReference=.../>``, ``natural_frequencies`` (Hz, a constant output: the retained
  modes' undamped natural frequencies as the model has them) and, for the kinds whose continuous states are the modal
  coordinates (the LTI kind: FFRBeam, exported clamped bodies; x = [eta; eta_dot]), ``modal_coordinates`` (eta_1 ..
  eta_n, the states x[0 .. n-1]) and ``modal_rates`` (x[n .. 2n-1]), outputs read from the state value references in
  co-simulation and model exchange alike.  The reframe kind (free bodies) gets ``n_retained_modes`` and
  ``natural_frequencies`` (its model file's ``reframe.omega``); its state is no continuous state the runtime exposes,
  so it has no modal-coordinate arrays.
- **Tensors**: every six Float64 outputs (or inputs) ``P_xx``, ``P_yy``, ``P_zz``, ``P_xy``, ``P_yz``, ``P_xz`` of one
  causality and unit (a symmetric tensor's components, flexfmu.core.stress.VOIGT order) are also the array ``P``
  (``P_voigt`` when ``P`` is taken) of ``<Dimension start="6"/>``: an exported body's gauges' ``G.sigma`` (Pa) and
  ``G.eps`` (1).
- **Shape coordinates**: an exported body's outputs q_1 .. q_n (the retained modes' coordinates, then the
  static-correction vectors'; u = Psi q, its resources/shape.npz; a free body's in its floating body frame) are also
  the array ``q``, sized by the structural parameter ``n_shape_coordinates`` (UInt64, fixed at build as
  ``n_retained_modes``). The LTI kind's q are its states x[0 .. n-1], so ``q`` reads as ``modal_coordinates``
  there; ``q`` is the view under the shape file's names, and the free bodies' one.

Value references: a block of its own from :data:`ARRAY_VALUE_REFERENCE_BASE` = 2^30 (``n_retained_modes`` first, then
the 3-vectors and the modal arrays, then the tensors, ``n_shape_coordinates`` and ``q``: an FMU without tensors or
shape coordinates numbers its views as before they existed), above every runtime value reference (variables 0 ..
n_vars - 1, continuous states and derivatives after them) and below description_fmi3.TIME_VALUE_REFERENCE (2^31 - 1).

The runtime learns the views from the model file (:meth:`Arrays.entries`: ``fmi3.array.*``: names, value references,
sizes, input flags, per element the runtime value reference it views or -1 for a constant, and the constants;
``fmi3.size.*``: the structural parameters, their values and the end of their refusal) and hands them to the FMI 3.0
front (BridgeApi.arrays, csrc/flexfmu_bridge.h), which expands an array's value reference into its elements'
(csrc/flexfmu_fmi3.c).  FMI 2.0 never sees them.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from xml.etree import ElementTree as ET

import numpy as np

from flexfmu.errors import ParameterError

#: the first value reference of the FMI 3.0 views (csrc/flexfmu_native.c checks that it is above every runtime one)
ARRAY_VALUE_REFERENCE_BASE = 2**30
#: the structural parameter that sizes the modal arrays
SIZE_NAME = "n_retained_modes"
#: the structural parameter that sizes the shape coordinates' array ``q``
SHAPE_SIZE_NAME = "n_shape_coordinates"
#: a symmetric tensor's components, the order of its array (flexfmu.core.stress.VOIGT)
TENSOR = ("xx", "yy", "zz", "xy", "yz", "xz")
#: the FMU parameters that choose the number of retained modes (named in the refusal of another value)
MODE_PARAMETERS = ("n_modes", "n_flexible_modes")
AXES = ("x", "y", "z")


@dataclass(frozen=True)
class StructuralParameter:
    name: str
    reference: int
    value: int
    description: str
    fixed: str           # the end of the refusal of another value: why it is fixed, how to get another


@dataclass(frozen=True)
class ArrayVariable:
    name: str
    reference: int
    causality: str       # input, output
    variability: str     # continuous, constant
    unit: str
    description: str
    elements: tuple      # per element: the runtime value reference it views, or -1 (the constant in ``values``)
    values: tuple        # per element: the constant (0.0 where an element is a runtime value)
    starts: tuple = ()   # an input's start values (its scalars')
    size: str = ""       # the structural parameter giving its size ("": a fixed size, len(elements))


@dataclass(frozen=True)
class Arrays:
    """The FMI 3.0 views of one FMU: its structural parameters and array variables."""

    sizes: tuple
    arrays: tuple

    def entries(self) -> dict:
        """The model file's fmi3.* entries (csrc/flexfmu_native.c load_arrays); none when there is no view."""
        out = {}
        if self.arrays:
            out.update({
                "fmi3.array.name": [a.name for a in self.arrays],
                "fmi3.array.reference": np.array([a.reference for a in self.arrays], np.int32),
                "fmi3.array.size": np.array([len(a.elements) for a in self.arrays], np.int32),
                "fmi3.array.input": np.array([a.causality == "input" for a in self.arrays], np.int32),
                "fmi3.array.element": np.array([e for a in self.arrays for e in a.elements], np.int32),
                "fmi3.array.value": np.array([v for a in self.arrays for v in a.values], float),
            })
        if self.sizes:
            out.update({
                "fmi3.size.name": [s.name for s in self.sizes],
                "fmi3.size.reference": np.array([s.reference for s in self.sizes], np.int32),
                "fmi3.size.value": np.array([s.value for s in self.sizes], np.int32),
                "fmi3.size.fixed": [s.fixed for s in self.sizes],
            })
        return out


# ---------------------------------------------------------------------------------------------- what is viewed
def _vector_description(texts: list[str]) -> str:
    """The description of a 3-vector from its scalars' ("force at load_s, body x" -> "force at load_s: (x, y, z) in
    the body frame"): their common text without the axis, the frame (its last part, when it names one) said."""
    stems = [re.sub(r",?\s*[xyz]\s*$", "", text) for text in texts]
    stem = stems[0] if len(set(stems)) == 1 else stems[0].rstrip(", ")
    head, comma, frame = stem.rpartition(", ")
    named = re.match(r"(body frame|global frame|body|global)\b(.*)$", frame)
    if comma and named:
        word, rest = named.groups()
        return f"{head}: (x, y, z) in the {word if word.endswith('frame') else word + ' frame'}{rest}"
    return f"{stem}: (x, y, z)"


def vectors(rows) -> list[tuple[str, list[int], object]]:
    """(name, the value references of P_x, P_y, P_z, the P_x row) of every 3-vector among the Real inputs and outputs
    of ``rows`` (flexfmu.fmi.variables.table: value reference = position), in the order of their P_x."""
    position = {v.name: k for k, v in enumerate(rows)}
    taken = set(position)
    out = []
    for k, v in enumerate(rows):
        if not (v.name.endswith("_x") and v.type == "Real" and v.causality in ("input", "output")):
            continue
        prefix = v.name[:-2]
        members = [position.get(f"{prefix}_{a}") for a in AXES]
        if (None in members or f"{prefix}_w" in position
                or any((rows[m].type, rows[m].causality, rows[m].unit) != (v.type, v.causality, v.unit)
                       for m in members)):
            continue
        name = prefix
        while name in taken:           # "P" taken by a scalar: "P_xyz"
            name += "_xyz" if name == prefix else "_"
        taken.add(name)
        out.append((name, members, v))
    return out


def tensors(rows, taken=()) -> list[tuple[str, list[int], object]]:
    """(name, the value references of P_xx .. P_xz in :data:`TENSOR` order, the P_xx row) of every symmetric tensor
    among the Real inputs and outputs of ``rows`` (flexfmu.fmi.variables.table): six components of one prefix,
    causality and unit, and no P_yx, P_zy, P_zx (a full matrix's, as a rotation's r_xx .. r_zz); in the order of
    their P_xx; ``taken``: names of other views (the vectors'), avoided as the scalars' are."""
    position = {v.name: k for k, v in enumerate(rows)}
    taken = set(position) | set(taken)
    out = []
    for v in rows:
        if not (v.name.endswith("_xx") and v.type == "Real" and v.causality in ("input", "output")):
            continue
        prefix = v.name[:-3]
        members = [position.get(f"{prefix}_{c}") for c in TENSOR]
        if (None in members or any(f"{prefix}_{c}" in position for c in ("yx", "zy", "zx"))   # a full matrix's
                or any((rows[m].type, rows[m].causality, rows[m].unit) != (v.type, v.causality, v.unit)
                       for m in members)):
            continue
        name = prefix if prefix not in taken else prefix + "_voigt"
        while name in taken:
            name += "_"
        taken.add(name)
        out.append((name, members, v))
    return out


def _tensor_description(text: str) -> str:
    """A tensor's description from its xx component's ("stress sigma_xx, body frame, at gauge G: ..." -> "stress
    sigma (xx, yy, zz, xy, yz, xz), body frame, at gauge G: ...")."""
    components = "(" + ", ".join(TENSOR) + ")"
    return text.replace("_xx", " " + components, 1) if "_xx" in text else f"{text}: {components}"


def natural_frequencies(kind: str, entries: dict) -> np.ndarray | None:
    """(n,) the retained modes' undamped natural frequencies (Hz) as the model file has them, or None: the LTI kind's
    from A(0) = [[0, I], [-diag(omega^2), 0]] (the modal coordinates and their rates; None when A(0) is not of that
    form), the reframe kind's from reframe.omega."""
    if kind == "lti":
        A0 = np.asarray(entries["lti.A"])[0]
        nx = A0.shape[0]
        n = nx // 2
        if nx == 0 or nx % 2 or np.any(A0[:n, :n]) or not np.array_equal(A0[:n, n:], np.eye(n)):
            return None
        stiffness = A0[n:, :n]
        omega2 = -np.diag(stiffness)
        if np.any(stiffness - np.diag(np.diag(stiffness))) or not np.all(omega2 > 0):
            return None
        return np.sqrt(omega2) / (2.0 * math.pi)
    if kind == "reframe" and "reframe.omega" in entries:
        omega = np.asarray(entries["reframe.omega"], float).ravel()
        return omega / (2.0 * math.pi) if omega.size and np.all(omega > 0) else None
    return None


def plan(rows, kind: str, entries: dict, *, rebuild: str = "", shapes: tuple = ()) -> Arrays:
    """The FMI 3.0 views of an FMU whose variables are ``rows`` (flexfmu.fmi.variables.table) and whose model file
    has ``entries`` (flexfmu.fmi.native_build.model_entries); ``rebuild``: the command that rebuilds it with another
    number of modes (the end of the structural parameters' refusal); ``shapes``: the names of its shape coordinates
    (q_1 .. q_n, outputs among ``rows``; an exported body's), viewed as the array ``q``."""
    n_vars = len(rows)
    nx = int(np.asarray(entries["lti.A"]).shape[1]) if kind == "lti" else 0
    own = n_vars + 2 * nx                          # the runtime's value references: variables, states, derivatives
    if own >= ARRAY_VALUE_REFERENCE_BASE:
        raise ParameterError("variables", f"{own} value references", f"fewer than {ARRAY_VALUE_REFERENCE_BASE}")
    reference = iter(range(ARRAY_VALUE_REFERENCE_BASE, 2**31 - 1))
    frequencies = natural_frequencies(kind, entries)
    sizes, arrays = [], []
    if frequencies is not None:
        n = len(frequencies)
        views = ["modal_coordinates", "modal_rates"] if kind == "lti" else []
        views.append("natural_frequencies")
        sizes.append(StructuralParameter(
            SIZE_NAME, next(reference), n, "number of retained modes, fixed at build: the size of "
            + ", ".join(views),
            f"fixed at build: the number of retained modes, which sizes {', '.join(views)}; for another number "
            f"rebuild the FMU{' (' + rebuild + ')' if rebuild else ''}"))
    vector_views = vectors(rows)
    for name, members, first in vector_views:
        arrays.append(ArrayVariable(
            name, next(reference), first.causality, "continuous", first.unit,
            _vector_description([rows[m].description for m in members]), tuple(members), (0.0,) * 3,
            tuple(float(rows[m].start) for m in members) if first.causality == "input" else ()))
    if frequencies is not None:
        n = len(frequencies)
        if kind == "lti":
            arrays.append(ArrayVariable(
                "modal_coordinates", next(reference), "output", "continuous", "",
                "modal coordinates eta_k of the retained modes (mass-normalised modes: eta in m kg^0.5): the "
                "continuous states x[0 .. n-1]", tuple(range(n_vars, n_vars + n)), (0.0,) * n, size=SIZE_NAME))
            arrays.append(ArrayVariable(
                "modal_rates", next(reference), "output", "continuous", "",
                "rates eta_dot_k of the modal coordinates (m kg^0.5 / s): the continuous states x[n .. 2n-1]",
                tuple(range(n_vars + n, n_vars + 2 * n)), (0.0,) * n, size=SIZE_NAME))
        arrays.append(ArrayVariable(
            "natural_frequencies", next(reference), "output", "constant", "Hz",
            "undamped natural frequencies of the retained modes, as the model integrates them", (-1,) * n,
            tuple(float(f) for f in frequencies), size=SIZE_NAME))
    for name, members, first in tensors(rows, taken=[name for name, _, _ in vector_views]):
        arrays.append(ArrayVariable(
            name, next(reference), first.causality, "continuous", first.unit, _tensor_description(first.description),
            tuple(members), (0.0,) * 6,
            tuple(float(rows[m].start) for m in members) if first.causality == "input" else ()))
    if shapes:
        position = {v.name: k for k, v in enumerate(rows)}
        missing = [name for name in shapes if name not in position or rows[position[name]].causality != "output"]
        if missing:
            raise ParameterError("shapes", f"{missing[0]!r} is no output of the FMU", "the names of its q outputs")
        n = len(shapes)
        sizes.append(StructuralParameter(
            SHAPE_SIZE_NAME, next(reference), n, "number of shape coordinates (retained modes, then static-correction "
            "vectors), fixed at build: the size of q",
            "fixed at build: the number of shape coordinates (retained modes and static-correction vectors), which "
            f"sizes q; for another number rebuild the FMU{' (' + rebuild + ')' if rebuild else ''}"))
        arrays.append(ArrayVariable(
            "q", next(reference), "output", "continuous", "",
            f"shape coordinates {shapes[0]} .. {shapes[-1]} (the retained modes', then the static-correction "
            "vectors'; m kg^0.5): the displacement of every node is u = Psi q (resources/shape.npz)",
            tuple(position[name] for name in shapes), (0.0,) * n, size=SHAPE_SIZE_NAME))
    return Arrays(tuple(sizes), tuple(arrays))


def source_plan(source, entries: dict) -> Arrays:
    """:func:`plan` of a flexfmu.fmi.native_build.NativeSource whose model file has ``entries``."""
    from flexfmu.fmi.variables import table

    parameter = next((p for p in MODE_PARAMETERS if p in source.values), None)
    settings = [f"--set {k}={v}" for k, v in source.rebuild_settings.items() if k != parameter]
    if parameter:
        settings.append(f"--set {parameter}=N")
    elif source.rebuild.startswith("flexfmu export"):
        settings.append("--modes N")
    rebuild = " ".join([source.rebuild, *settings]) if source.rebuild else ""
    body = getattr(source.spec, "body", None)            # an exported body's (flexfmu.fmi.body_fmu.ExportedSpec)
    shapes = tuple(body.shape_names()) if body is not None else ()
    return plan(table(source.spec, source.values), source.kind, entries, rebuild=rebuild, shapes=shapes)


# ---------------------------------------------------------------------------------------------- modelDescription
def _number(value: float) -> str:
    return repr(float(value))


def with_arrays(description: bytes, arrays: Arrays, units: dict | None = None) -> bytes:
    """The FMI 3.0 modelDescription ``description`` (flexfmu.fmi.description_fmi3, with its interfaces) with the
    views ``arrays``: the structural parameters before the arrays (a host resolves a Dimension's valueReference
    among the variables read so far), the output arrays listed as Output (and InitialUnknown, but the constants),
    their units defined."""
    if units is None:
        from flexfmu.fmi.units import UNITS as units
    if not (arrays.sizes or arrays.arrays):
        return description
    root = ET.fromstring(description)
    if root.get("fmiVersion") != "3.0":
        raise ParameterError("fmi_version", f"a modelDescription of FMI {root.get('fmiVersion')}",
                             "3.0 (FMI 2.0 has no array variables)")
    variables = root.find("ModelVariables")
    names = {v.get("name") for v in variables}
    clash = sorted(names & {v.name for v in (*arrays.sizes, *arrays.arrays)})
    if clash:
        raise ParameterError("variables", f"{clash[0]!r} is both a scalar and an array view", "distinct names")
    definitions = root.find("UnitDefinitions")
    defined = {u.get("name") for u in definitions} if definitions is not None else set()
    for unit in sorted({a.unit for a in arrays.arrays if a.unit} - defined):
        if unit not in units:
            raise ParameterError("unit", f"{unit!r} has no SI definition", ", ".join(sorted(units)))
        if definitions is None:
            definitions = ET.Element("UnitDefinitions")
            root.insert(list(root).index(variables), definitions)
        ET.SubElement(ET.SubElement(definitions, "Unit", name=unit), "BaseUnit",
                      {k: str(v) for k, v in units[unit].items()})
    for s in arrays.sizes:
        ET.SubElement(variables, "UInt64", name=s.name, valueReference=str(s.reference), description=s.description,
                      causality="structuralParameter", variability="fixed", start=str(s.value))
    for a in arrays.arrays:
        attributes = {"name": a.name, "valueReference": str(a.reference), "description": a.description,
                      "causality": a.causality, "variability": a.variability}
        if a.variability == "constant":
            attributes["start"] = " ".join(_number(v) for v in a.values)
        elif a.causality == "input":
            attributes["start"] = " ".join(_number(v) for v in a.starts)
        else:
            attributes["initial"] = "calculated"
        if a.unit:
            attributes["unit"] = a.unit
        element = ET.SubElement(variables, "Float64", attributes)
        reference = next((str(s.reference) for s in arrays.sizes if s.name == a.size), None) if a.size else None
        ET.SubElement(element, "Dimension", {"valueReference": reference} if reference
                      else {"start": str(len(a.elements))})
    structure = root.find("ModelStructure")
    children = list(structure)
    last_output = max((k for k, c in enumerate(children) if c.tag == "Output"), default=-1)
    outputs = [a for a in arrays.arrays if a.causality == "output"]
    for k, a in enumerate(outputs):
        structure.insert(last_output + 1 + k, ET.Element("Output", valueReference=str(a.reference)))
    children = list(structure)
    last_initial = max((k for k, c in enumerate(children) if c.tag == "InitialUnknown"),
                       default=max((k for k, c in enumerate(children)
                                    if c.tag in ("Output", "ContinuousStateDerivative")), default=-1))
    calculated = [a for a in outputs if a.variability != "constant"]
    for k, a in enumerate(calculated):
        structure.insert(last_initial + 1 + k, ET.Element("InitialUnknown", valueReference=str(a.reference)))
    ET.indent(root, "\t")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")
