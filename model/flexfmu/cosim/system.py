"""The description of a co-simulated system, shared by flexfmu.cosim.masters (which runs it) and
flexfmu.cosim.ssp (which writes and reads it as SSP): :class:`SimulatorSpec` (one FMU instance),
:class:`System` (instances, connections, start time, base step), and the OSP system structure file
(``OspSystemStructure.xml``) read (:func:`load_osp`) and written (:func:`write_osp`).

:func:`is_ssp_path` tells an SSP (``.ssp`` archive, ``.ssd`` file or a folder with SystemStructure.ssd)
from an OSP file; flexfmu.cosim.masters.load_system reads either.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from xml.etree import ElementTree as ET

from flexfmu.errors import ParameterError, require

OSP_NS = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"


@dataclass
class SimulatorSpec:
    """One FMU instance: name, FMU file, start values of parameters (name -> int/float/str/bool)."""

    name: str
    source: Path
    initial_values: dict = field(default_factory=dict)

    @property
    def model(self) -> str:
        return self.source.stem


@dataclass
class System:
    """A system: simulators (in the file's order, the Gauss-Seidel order), connections
    ((source instance, output), (target instance, input)), start time and base step (s)."""

    simulators: list
    connections: list
    base_step: float = 1e-3
    start_time: float = 0.0
    path: Path | None = None

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
            sims.append(replace(s, initial_values=iv))
        unknown = set(values) - {s.name for s in self.simulators}
        require(not unknown, "simulator", f"unknown {sorted(unknown)}", ", ".join(s.name for s in self.simulators))
        return replace(self, simulators=sims)


def is_ssp_path(path) -> bool:
    """Is ``path`` an SSP: a ``.ssp`` archive, an ``.ssd`` file or a folder with SystemStructure.ssd?"""
    path = Path(path)
    return path.suffix.lower() in (".ssp", ".ssd") or (path.is_dir() and (path / "SystemStructure.ssd").is_file())


def _tag(element) -> str:
    return element.tag.split("}", 1)[-1]


def _children(element, name):
    return [c for c in element if _tag(c) == name]


def load_osp(path, fmu_dir=None) -> System:
    """Read an OspSystemStructure.xml (Simulators with InitialValues, VariableConnections,
    BaseStepSize, StartTime).  FMU sources are relative to the file; fmu_dir overrides their folder."""
    path = Path(path)
    require(path.is_file(), "SYSTEM_FILE", f"{str(path)!r} not found",
            "an OspSystemStructure.xml file or an SSP (.ssp)")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ParameterError("SYSTEM_FILE", f"{path}: not XML ({exc})",
                             "an OspSystemStructure.xml file or an SSP (.ssp)") from None
    require(_tag(root) == "OspSystemStructure", "SYSTEM_FILE", f"{path}: root element is {_tag(root)!r}",
            "an OspSystemStructure.xml file or an SSP (.ssp)")
    base_step, start = 1e-3, 0.0
    sims, conns = [], []
    for child in root:
        tag = _tag(child)
        if tag == "BaseStepSize":
            base_step = float(child.text)
        elif tag == "StartTime":
            start = float(child.text)
        elif tag == "Algorithm":
            require(child.text.strip() == "fixedStep", "Algorithm", f"got {child.text.strip()!r}", "fixedStep")
        elif tag == "Simulators":
            for s in _children(child, "Simulator"):
                values = {}
                for ivs in _children(s, "InitialValues"):
                    for iv in _children(ivs, "InitialValue"):
                        (typed,) = list(iv)
                        kind, text = _tag(typed), typed.get("value")
                        values[iv.get("variable")] = {"Real": float, "Integer": int, "String": str,
                                                      "Boolean": lambda v: v.lower() in ("true", "1")}[kind](text)
                require(s.get("stepSize") is None, "stepSize", f"simulator {s.get('name')}: per-simulator step sizes",
                        "one common BaseStepSize")
                sims.append(SimulatorSpec(s.get("name"), (path.parent / s.get("source")).resolve(), values))
        elif tag == "Connections":
            for c in child:
                require(_tag(c) == "VariableConnection", "Connections", f"{_tag(c)} is not supported",
                        "VariableConnection")
                a, b = [(v.get("simulator"), v.get("name")) for v in _children(c, "Variable")]
                conns.append((a, b))
    system = System(sims, conns, base_step, start, path)
    if fmu_dir is not None:
        system = system.with_fmu_dir(fmu_dir)
    names = {s.name for s in sims}
    for a, b in conns:
        for inst, _ in (a, b):
            require(inst in names, "VariableConnection", f"unknown simulator {inst!r}", ", ".join(sorted(names)))
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
