"""SSP 1.0 (Modelica Association, System Structure and Parameterization) for the systems of
flexfmu.cosim.system: write a ``.ssp`` archive from a System, read one back into a System.

The one description of a system stays the OSP file (``OspSystemStructure.xml``): ``write_ssp``
turns the System read from it into a ``.ssp``, so the two cannot drift — the archive is a build
product (it holds the built FMUs) and is never edited by hand.

The archive:

    SystemStructure.ssd      one ssd:System; per simulator an ssd:Component (source
                             resources/<Model>.fmu, in the OSP file's order), its connectors
                             (every connected input and output, every start value as a
                             parameter connector) and its start values as an inline
                             ssv:ParameterSet named "start"; the connections; ssd:DefaultExperiment
                             with the start time and, as libcosim's annotation, the base step
    resources/<Model>.fmu    each FMU once

SSP has no communication step of its own: libcosim reads it from the
``com.opensimulationplatform`` annotation (osp:FixedStepAlgorithm baseStepSize), and so does
``load_ssp``; without it the System's default step applies.  libcosim's SSP parser matches element
names literally, prefixes included (boost property trees know no namespaces), so the archive uses
the usual prefixes ssd, ssc, ssv and osp.
"""
from __future__ import annotations

import atexit
import shutil
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from flexfmu.cosim.system import SimulatorSpec, System, is_ssp_path, load_osp
from flexfmu.errors import FlexfmuError, ParameterError, require

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
OSP = "http://opensimulationplatform.com/SSP/OSPAnnotations"
OSP_ANNOTATION = "com.opensimulationplatform"
#: the parameter set every component's start values are in (ecos: --parameterSet start; libcosim
#: applies a component's first set by default)
PARAMETER_SET = "start"
_TYPES = {"Real": float, "Integer": int, "String": str,
          "Boolean": lambda text: text.strip().lower() in ("true", "1")}


def _kind(value) -> str:
    return ("Boolean" if isinstance(value, bool) else "Integer" if isinstance(value, int)
            else "Real" if isinstance(value, float) else "String")


def _text(value) -> str:
    return str(value).lower() if isinstance(value, bool) else repr(value) if isinstance(value, float) else str(value)


def ssd_tree(system, step: float | None = None) -> ET.Element:
    """The SystemStructure.ssd of a System (FMU sources resources/<file name>)."""
    for prefix, uri in (("ssd", SSD), ("ssc", SSC), ("ssv", SSV), ("osp", OSP)):
        ET.register_namespace(prefix, uri)
    def d(tag): return f"{{{SSD}}}{tag}"       # noqa: E704
    def c(tag): return f"{{{SSC}}}{tag}"       # noqa: E704
    def v(tag): return f"{{{SSV}}}{tag}"       # noqa: E704
    def o(tag): return f"{{{OSP}}}{tag}"       # noqa: E704

    name = Path(system.path).stem if system.path is not None else "system"
    root = ET.Element(d("SystemStructureDescription"), name=name, version="1.0")
    sys_el = ET.SubElement(root, d("System"), name=name)
    elements = ET.SubElement(sys_el, d("Elements"))
    connectors = {s.name: {} for s in system.simulators}        # instance -> variable -> (kind, type)
    for (sa, va), (sb, vb) in system.connections:
        connectors[sa][va] = ("output", "Real")
        connectors[sb][vb] = ("input", "Real")
    for s in system.simulators:
        comp = ET.SubElement(elements, d("Component"), name=s.name, source=f"resources/{Path(s.source).name}",
                             type="application/x-fmu-sharedlibrary")
        conns = ET.SubElement(comp, d("Connectors"))
        for var, value in s.initial_values.items():
            if var not in connectors[s.name]:
                el = ET.SubElement(conns, d("Connector"), name=var, kind="parameter")
                ET.SubElement(el, c(_kind(value)))
        for var, (kind, typ) in connectors[s.name].items():
            el = ET.SubElement(conns, d("Connector"), name=var, kind=kind)
            ET.SubElement(el, c(typ))
        if s.initial_values:
            bindings = ET.SubElement(comp, d("ParameterBindings"))
            values = ET.SubElement(ET.SubElement(bindings, d("ParameterBinding")), d("ParameterValues"))
            pset = ET.SubElement(values, v("ParameterSet"), version="1.0", name=PARAMETER_SET)
            params = ET.SubElement(pset, v("Parameters"))
            for var, value in s.initial_values.items():
                p = ET.SubElement(params, v("Parameter"), name=var)
                ET.SubElement(p, v(_kind(value)), value=_text(value))
    links = ET.SubElement(sys_el, d("Connections"))
    for (sa, va), (sb, vb) in system.connections:
        ET.SubElement(links, d("Connection"), startElement=sa, startConnector=va, endElement=sb, endConnector=vb)
    exp = ET.SubElement(root, d("DefaultExperiment"), startTime=repr(float(system.start_time)))
    ann = ET.SubElement(ET.SubElement(exp, d("Annotations")), c("Annotation"), type=OSP_ANNOTATION)
    ET.SubElement(ET.SubElement(ann, o("Algorithm")), o("FixedStepAlgorithm"),
                  baseStepSize=repr(float(system.base_step if step is None else step)))
    ET.indent(root, "  ")
    return root


def write_ssp(system, path, step: float | None = None) -> Path:
    """Write the system as an SSP 1.0 archive with its FMUs in resources/ (each FMU file once)."""
    path = Path(path)
    sources = {}
    for s in system.simulators:
        src = Path(s.source)
        require(src.is_file(), "source", f"{s.name}: FMU {str(src)!r} not found",
                "an FMU file (build them with: flexfmu build, or pass --fmu-dir)")
        other = sources.setdefault(src.name, src.resolve())
        require(other == src.resolve(), "source", f"two different FMUs named {src.name}: {other}, {src}",
                "one FMU per file name (they share resources/)")
    text = b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(ssd_tree(system, step), encoding="utf-8")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("SystemStructure.ssd", text)
        for name, src in sources.items():
            zf.write(src, f"resources/{name}", compress_type=zipfile.ZIP_STORED)   # an FMU is a zip already
    tmp.replace(path)
    return path


# ---------------------------------------------------------------- reading
_EXTRACTED: list[str] = []


def _cleanup():
    for folder in _EXTRACTED:
        shutil.rmtree(folder, ignore_errors=True)


atexit.register(_cleanup)


def _tag(element) -> str:
    return element.tag.split("}", 1)[-1]


def _child(element, name):
    for c in element:
        if _tag(c) == name:
            return c
    return None


def _children(element, name):
    return [c for c in element if _tag(c) == name] if element is not None else []


def _parameter_set(pset, where: str) -> dict:
    values = {}
    for p in _children(_child(pset, "Parameters"), "Parameter"):
        typed = [t for t in p if _tag(t) in _TYPES or _tag(t) in ("Enumeration", "Binary")]
        require(len(typed) == 1, "ParameterValues", f"{where}: parameter {p.get('name')!r} has no value",
                "one of ssv:Real, Integer, Boolean, String")
        kind = _tag(typed[0])
        require(kind in _TYPES, "ParameterValues", f"{where}.{p.get('name')}: ssv:{kind} is not supported",
                "ssv:Real, Integer, Boolean, String")
        try:
            values[p.get("name")] = _TYPES[kind](typed[0].get("value"))
        except (TypeError, ValueError):
            raise ParameterError(f"{where}.{p.get('name')}", f"{typed[0].get('value')!r} is not a {kind}",
                                 f"a {kind} value") from None
    return values


def _parse_xml(path: Path, what: str):
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ParameterError("SYSTEM_FILE", f"{path}: not XML ({exc})", what) from None


def load_ssp(path, fmu_dir=None) -> System:
    """Read an SSP: a ``.ssp`` archive (extracted to a temporary folder, removed at exit), a folder
    with SystemStructure.ssd, or an ``.ssd`` file.  Components (in the file's order: the
    Gauss-Seidel order) with their FMU sources and the start values of their ParameterBindings
    (inline ParameterValues or .ssv files; later bindings override earlier ones), the connections,
    the start time and the base step (libcosim's osp:FixedStepAlgorithm annotation, else 1 ms)."""
    path = Path(path)
    what = "an SSP: a .ssp archive, a folder with SystemStructure.ssd, or an .ssd file"
    require(path.exists(), "SYSTEM_FILE", f"{str(path)!r} not found", what)
    if path.is_file() and path.suffix.lower() == ".ssp":
        folder = Path(tempfile.mkdtemp(prefix="flexfmu_ssp_"))
        _EXTRACTED.append(str(folder))
        try:
            with zipfile.ZipFile(path) as zf:
                zf.extractall(folder)
        except zipfile.BadZipFile:
            raise ParameterError("SYSTEM_FILE", f"{path}: not a zip archive", what) from None
        ssd = folder / "SystemStructure.ssd"
    elif path.is_dir():
        ssd = path / "SystemStructure.ssd"
    else:
        ssd = path
    require(ssd.is_file(), "SYSTEM_FILE", f"{path}: no SystemStructure.ssd", what)
    root = _parse_xml(ssd, what)
    require(_tag(root) == "SystemStructureDescription", "SYSTEM_FILE", f"{ssd}: root element is {_tag(root)!r}",
            "ssd:SystemStructureDescription")
    system_el = _child(root, "System")
    require(system_el is not None, "SYSTEM_FILE", f"{ssd}: no ssd:System", "one ssd:System")
    start, base_step = 0.0, 1e-3
    exp = _child(root, "DefaultExperiment")
    if exp is not None:
        start = float(exp.get("startTime", "0"))
        for ann in _children(_child(exp, "Annotations"), "Annotation"):
            if ann.get("type") == OSP_ANNOTATION:
                for alg in _children(_child(ann, "Algorithm"), "FixedStepAlgorithm"):
                    base_step = float(alg.get("baseStepSize"))
    sims = []
    for el in _child(system_el, "Elements") if _child(system_el, "Elements") is not None else []:
        require(_tag(el) == "Component", "Elements", f"{ssd}: ssd:{_tag(el)} {el.get('name')!r} is not supported",
                "ssd:Component (no nested systems or signal dictionaries)")
        name, source = el.get("name"), el.get("source")
        require(bool(name) and bool(source), "Component", f"{ssd}: a component without name or source",
                "name and source")
        require("://" not in source, "Component", f"{name}: source {source!r} is not a file in the archive",
                "a relative path such as resources/X.fmu")
        values = {}
        for binding in _children(_child(el, "ParameterBindings"), "ParameterBinding"):
            if binding.get("source"):
                ssv = ssd.parent / binding.get("source")
                require(ssv.is_file(), "ParameterBinding", f"{name}: {ssv} not found", "an .ssv file in the SSP")
                pset = _parse_xml(ssv, "an SSV parameter set")
                values.update(_parameter_set(pset, name))
            else:
                for pv in _children(binding, "ParameterValues"):
                    for pset in _children(pv, "ParameterSet"):
                        values.update(_parameter_set(pset, name))
        sims.append(SimulatorSpec(name, (ssd.parent / source).resolve(), values))
    names = {s.name for s in sims}
    conns = []
    for c in _children(_child(system_el, "Connections"), "Connection"):
        require(not [t for t in c if _tag(t) in ("LinearTransformation", "BooleanMappingTransformation",
                                                   "IntegerMappingTransformation", "EnumerationMappingTransformation")],
                "Connection", f"{c.get('startElement')}.{c.get('startConnector')}: a transformation",
                "plain connections (an output to an input, unchanged)")
        a = (c.get("startElement"), c.get("startConnector"))
        b = (c.get("endElement"), c.get("endConnector"))
        for inst, _ in (a, b):
            require(inst in names, "Connection", f"unknown component {inst!r} (connections to the system's own "
                    "connectors are not supported)", ", ".join(sorted(names)))
        conns.append((a, b))
    system = System(sims, conns, base_step, start, path)
    if fmu_dir is not None:
        system = system.with_fmu_dir(fmu_dir)
    return system


def main(argv=None) -> int:
    """python -m flexfmu.cosim.ssp SYSTEM_FILE -o OUT.ssp [--fmu-dir DIR]: an OSP file (or an SSP) as .ssp."""
    import argparse
    import sys

    parser = argparse.ArgumentParser(prog="python -m flexfmu.cosim.ssp", description=main.__doc__)
    parser.add_argument("system_file", type=Path)
    parser.add_argument("-o", "--output", type=Path, required=True)
    parser.add_argument("--fmu-dir", type=Path, default=None)
    args = parser.parse_args(argv)
    try:
        load = load_ssp if is_ssp_path(args.system_file) else load_osp
        system = load(args.system_file, fmu_dir=args.fmu_dir)
        print(f"wrote {write_ssp(system, args.output)}")
    except FlexfmuError as exc:
        print(f"flexfmu: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
