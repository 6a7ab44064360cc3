"""The description of a co-simulated system, shared by flexfmu.cosim.masters (which runs it) and
flexfmu.cosim.ssp (which writes and reads it as SSP): :class:`SimulatorSpec` (one FMU instance),
:class:`System` (instances, connections, start time, base step), and the OSP system structure file
(``OspSystemStructure.xml``) read (:func:`load_osp`) and written (:func:`write_osp`).

:func:`is_ssp_path` tells an SSP (``.ssp`` archive, ``.ssd`` file or a folder with SystemStructure.ssd)
from an OSP file; flexfmu.cosim.masters.load_system reads either.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from xml.etree import ElementTree as ET

from flexfmu.cosim import xmlsource as xs
from flexfmu.errors import ParameterError, require

OSP_NS = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"


@dataclass
class SimulatorSpec:
    """One FMU instance: name, FMU file, start values of parameters (name -> int/float/str/bool).
    ``origin`` says where the system file declares it (``path:line <Simulator name="...">``) and
    ``value_origins`` where each start value is, for messages; a value set later (``--set``) has none."""

    name: str
    source: Path
    initial_values: dict = field(default_factory=dict)
    origin: str = field(default="", compare=False, repr=False)
    value_origins: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def model(self) -> str:
        return self.source.stem


@dataclass
class System:
    """A system: simulators (in the file's order, the Gauss-Seidel order), connections
    ((source instance, output), (target instance, input)), start time and base step (s).
    ``connection_origins`` says where the file declares each connection ({connection: where}), for messages."""

    simulators: list
    connections: list
    base_step: float = 1e-3
    start_time: float = 0.0
    path: Path | None = None
    connection_origins: dict = field(default_factory=dict, compare=False, repr=False)

    def connection_origin(self, connection) -> str:
        """Where the file declares a connection (``path:line <VariableConnection>``), or '' (one made later)."""
        return self.connection_origins.get(tuple(connection), "")

    def simulator_origin(self, name: str) -> str:
        """Where the file declares the simulator (``path:line <Simulator name=...>``), else the simulator's name."""
        return self.simulator(name).origin or f"simulator {name}"

    def simulator(self, name: str) -> SimulatorSpec:
        for s in self.simulators:
            if s.name == name:
                return s
        raise ParameterError("simulator", f"no simulator named {name!r}", ", ".join(s.name for s in self.simulators))

    def by_model(self, model: str) -> list:
        return [s for s in self.simulators if s.model == model]

    def with_fmu_dir(self, fmu_dir: Path) -> "System":
        """The same system with every FMU taken from fmu_dir (same file names)."""
        sims = [replace(s, source=Path(fmu_dir) / s.source.name) for s in self.simulators]
        return replace(self, simulators=sims)

    def with_values(self, values: dict) -> "System":
        """The same system with start values changed: {instance: {variable: value}}."""
        sims = []
        for s in self.simulators:
            iv = dict(s.initial_values)
            iv.update(values.get(s.name, {}))
            where = {k: v for k, v in s.value_origins.items() if k not in values.get(s.name, {})}
            sims.append(replace(s, initial_values=iv, value_origins=where))
        unknown = set(values) - {s.name for s in self.simulators}
        require(not unknown, "simulator", f"unknown {sorted(unknown)}", ", ".join(s.name for s in self.simulators))
        return replace(self, simulators=sims)


def is_ssp_path(path) -> bool:
    """Is ``path`` an SSP: a ``.ssp`` archive, an ``.ssd`` file or a folder with SystemStructure.ssd?"""
    path = Path(path)
    return path.suffix.lower() in (".ssp", ".ssd") or (path.is_dir() and (path / "SystemStructure.ssd").is_file())


_OSP_FILE = "an OspSystemStructure.xml file or an SSP (.ssp)"
_OSP_ELEMENTS = ("StartTime", "BaseStepSize", "Algorithm", "Simulators", "Connections")
_VALUE_TYPES = ("Real", "Integer", "Boolean", "String")


def typed_value(tree, element, kind: str, text: str | None):
    """A start value of type ``kind`` (Real, Integer, Boolean, String) from an element's ``value`` text."""
    allowed = {"Real": "a finite number", "Integer": "an integer", "Boolean": "true | false | 1 | 0",
               "String": "any text"}[kind]
    tree.require(text is not None, element, "no value attribute", f"value=\"...\": {allowed}")
    if kind == "String":
        return text
    if kind == "Boolean":
        low = text.strip().lower()
        tree.require(low in ("true", "false", "1", "0"), element, f"{text!r} is not a Boolean", allowed)
        return low in ("true", "1")
    try:
        value = int(text) if kind == "Integer" else float(text)
    except ValueError:
        raise tree.error(element, f"{text!r} is not {'an integer' if kind == 'Integer' else 'a number'}",
                         allowed) from None
    tree.require(kind == "Integer" or math.isfinite(value), element, f"{text!r} is not finite", allowed)
    return value


def _initial_values(tree, simulator, name: str) -> tuple[dict, dict]:
    """The start values of one Simulator element and the line of each (``where``)."""
    values, where, elements = {}, {}, {}
    for child in simulator:
        tree.require(xs.tag(child) == "InitialValues", child, f"{xs.tag(child)} is not supported", "InitialValues")
        for iv in child:
            tree.require(xs.tag(iv) == "InitialValue", iv, f"{xs.tag(iv)} is not supported in InitialValues",
                         "InitialValue")
            variable = tree.attribute(iv, "variable", 'variable="NAME" with one of Real, Integer, Boolean, String')
            typed = list(iv)
            tree.require(len(typed) == 1, iv, f"{len(typed)} values" if typed else "no value",
                         "one of Real, Integer, Boolean, String with value=\"...\"")
            kind = xs.tag(typed[0])
            tree.require(kind in _VALUE_TYPES, typed[0], f"{kind} is not a value type", ", ".join(_VALUE_TYPES))
            tree.require(variable not in elements, iv, f"{name}.{variable} is given twice (first at "
                         f"{tree.line(elements.get(variable))})", "one InitialValue per variable")
            elements[variable] = iv
            values[variable] = typed_value(tree, typed[0], kind, typed[0].get("value"))
            where[variable] = tree.where(iv)
    return values, where


def _text(connection) -> str:
    (sa, va), (sb, vb) = connection
    return f"{sa}.{va} -> {sb}.{vb}"


def _connection(tree, connection, names: dict) -> tuple:
    """((instance, variable), (instance, variable)) of one VariableConnection, both instances known."""
    variables = list(connection)
    for v in variables:
        tree.require(xs.tag(v) == "Variable", v, f"{xs.tag(v)} is not supported in a VariableConnection",
                     "two Variable elements")
    tree.require(len(variables) == 2, connection,
                 f"{len(variables)} Variable{'' if len(variables) == 1 else 's'}",
                 'two Variable elements: an output and the input it feeds')
    ends = []
    for v in variables:
        instance = tree.attribute(v, "simulator", 'simulator="INSTANCE" name="VARIABLE"')
        variable = tree.attribute(v, "name", 'simulator="INSTANCE" name="VARIABLE"')
        tree.require(instance in names, v, f"unknown simulator {instance!r}", ", ".join(names))
        ends.append((instance, variable))
    tree.require(ends[0] != ends[1], connection, f"{ends[0][0]}.{ends[0][1]} is connected to itself",
                 "an output and an input")
    return tuple(ends)


def load_osp(path, fmu_dir=None) -> System:
    """Read an OspSystemStructure.xml (Simulators with InitialValues, VariableConnections,
    BaseStepSize, StartTime).  FMU sources are relative to the file; fmu_dir overrides their folder.
    Anything wrong in the file is a ParameterError naming the file, the element's line and what is allowed."""
    path = Path(path)
    require(path.is_file(), "SYSTEM_FILE", f"{str(path)!r} not found", _OSP_FILE)
    tree = xs.parse(path, what=_OSP_FILE)
    root = tree.root
    tree.require(xs.tag(root) == "OspSystemStructure", root, f"the root element is {xs.tag(root)}", _OSP_FILE)
    base_step, start = 1e-3, 0.0
    seen: dict = {}
    sims, conns, conn_elements = [], [], {}
    names: dict = {}                                        # simulator name -> its element
    for child in root:
        tag = xs.tag(child)
        tree.require(tag in _OSP_ELEMENTS, child, f"{tag} is not supported", ", ".join(_OSP_ELEMENTS))
        tree.require(tag not in seen, child, f"{tag} is given twice (first at {tree.line(seen.get(tag))})",
                     f"{tag} once")
        seen[tag] = child
        if tag == "BaseStepSize":
            base_step = tree.number(child, child.text, "BaseStepSize", positive=True)
        elif tag == "StartTime":
            start = tree.number(child, child.text, "StartTime")
        elif tag == "Algorithm":
            text = (child.text or "").strip()
            tree.require(text == "fixedStep", child, f"{text!r}" if text else "empty", "fixedStep")
        elif tag == "Simulators":
            for s in child:
                tree.require(xs.tag(s) == "Simulator", s, f"{xs.tag(s)} is not supported in Simulators",
                             "Simulator")
                name = tree.attribute(s, "name", 'name="INSTANCE" source="MODEL.fmu"')
                tree.require(name not in names, s, f"two simulators named {name!r}: here and at "
                             f"{tree.line(names.get(name))}", "a name unique in the system")
                names[name] = s
                source = tree.attribute(s, "source", 'name="INSTANCE" source="MODEL.fmu" (relative to the file)')
                tree.require(s.get("stepSize") is None, s, "a per-simulator stepSize", "one common BaseStepSize")
                values, where = _initial_values(tree, s, name)
                sims.append(SimulatorSpec(name, (path.parent / source).resolve(), values,
                                          origin=tree.where(s), value_origins=where))
        elif tag == "Connections":
            pass                                            # read below, once every simulator is known
    for c in seen.get("Connections", ()):
        tree.require(xs.tag(c) == "VariableConnection", c, f"{xs.tag(c)} is not supported", "VariableConnection")
        connection = _connection(tree, c, names)
        tree.require(connection not in conn_elements, c, f"the connection {_text(connection)} is given twice (first "
                     f"at {tree.line(conn_elements.get(connection))})", "each connection once")
        conns.append(connection)
        conn_elements[connection] = c
    system = System(sims, conns, base_step, start, path,
                    connection_origins={k: tree.where(c) for k, c in conn_elements.items()})
    if fmu_dir is not None:
        system = system.with_fmu_dir(fmu_dir)
    return system


def write_osp(system: System, path, step: float | None = None, relative: bool = False) -> Path:
    """Write the system as an OspSystemStructure.xml with absolute FMU paths (for libcosim), or paths relative
    to the file's folder (a file to commit beside its FMUs' build folder)."""
    path = Path(path)
    ET.register_namespace("", OSP_NS)
    q = lambda t: f"{{{OSP_NS}}}{t}"   # noqa: E731
    root = ET.Element(q("OspSystemStructure"), version="0.1")
    ET.SubElement(root, q("StartTime")).text = repr(system.start_time)
    ET.SubElement(root, q("BaseStepSize")).text = repr(float(step if step is not None else system.base_step))
    ET.SubElement(root, q("Algorithm")).text = "fixedStep"
    sims = ET.SubElement(root, q("Simulators"))
    for s in system.simulators:
        source = Path(s.source).resolve()
        if relative:
            source = Path(os.path.relpath(source, path.resolve().parent))
        el = ET.SubElement(sims, q("Simulator"), name=s.name, source=source.as_posix())
        if s.initial_values:
            ivs = ET.SubElement(el, q("InitialValues"))
            for name, value in s.initial_values.items():
                iv = ET.SubElement(ivs, q("InitialValue"), variable=name)
                kind = ("Boolean" if isinstance(value, bool) else "Integer" if isinstance(value, int)
                        else "Real" if isinstance(value, float) else "String")
                text = (str(value).lower() if isinstance(value, bool) else repr(value) if isinstance(value, float)
                        else str(value))
                ET.SubElement(iv, q(kind), value=text)
    conns = ET.SubElement(root, q("Connections"))
    for (sa, va), (sb, vb) in system.connections:
        c = ET.SubElement(conns, q("VariableConnection"))
        ET.SubElement(c, q("Variable"), simulator=sa, name=va)
        ET.SubElement(c, q("Variable"), simulator=sb, name=vb)
    ET.indent(root, "    ")
    path.write_bytes(b'<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="utf-8"))
    return path
