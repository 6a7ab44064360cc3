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

from flexfmu.cosim import xmlsource as xs
from flexfmu.cosim.system import SimulatorSpec, System, is_ssp_path, load_osp, typed_value
from flexfmu.errors import FlexfmuError, ParameterError, require

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
OSP = "http://opensimulationplatform.com/SSP/OSPAnnotations"
OSP_ANNOTATION = "com.opensimulationplatform"
#: the parameter set every component's start values are in (ecos: --parameterSet start; libcosim
#: applies a component's first set by default)
PARAMETER_SET = "start"
_TYPES = ("Real", "Integer", "Boolean", "String")


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


def _child(element, name):
    """The first child with this tag (namespaces ignored), or None."""
    found = xs.children(element, name)
    return found[0] if found else None


_VALUE_KINDS = "one of ssv:Real, Integer, Boolean, String"


def _parameter_set(tree, pset, where: str) -> tuple[dict, dict]:
    """The values of one ssv:ParameterSet and where each is (its ssv:Parameter)."""
    values, origins = {}, {}
    for p in xs.children(_child(pset, "Parameters"), "Parameter"):
        name = tree.attribute(p, "name", f'name="VARIABLE" with {_VALUE_KINDS}')
        typed = [t for t in p if xs.tag(t) not in ("Unit", "Annotations")]
        tree.require(len(typed) == 1, p, f"{where}.{name}: {len(typed)} values" if typed else f"{where}.{name}: no "
                     "value", _VALUE_KINDS)
        kind = xs.tag(typed[0])
        tree.require(kind in _TYPES, typed[0], f"{where}.{name}: ssv:{kind} is not supported", _VALUE_KINDS)
        values[name] = typed_value(tree, typed[0], kind, typed[0].get("value"))
        origins[name] = tree.where(p)
    return values, origins


def _experiment(tree, root) -> tuple[float, float]:
    """Start time and base step: ssd:DefaultExperiment's startTime and libcosim's osp:FixedStepAlgorithm
    annotation (else 0 s and 1 ms)."""
    start, base_step = 0.0, 1e-3
    exp = _child(root, "DefaultExperiment")
    if exp is not None:
        if exp.get("startTime") is not None:
            start = tree.number(exp, exp.get("startTime"), "startTime")
        for ann in xs.children(_child(exp, "Annotations"), "Annotation"):
            if ann.get("type") == OSP_ANNOTATION:
                for alg in xs.children(_child(ann, "Algorithm"), "FixedStepAlgorithm"):
                    tree.require(alg.get("baseStepSize") is not None, alg, "no baseStepSize",
                                 'baseStepSize="H", a finite number > 0, s')
                    base_step = tree.number(alg, alg.get("baseStepSize"), "baseStepSize", positive=True)
    return start, base_step


def _component(tree, el, ssd: Path, prefix: str, names: dict) -> SimulatorSpec:
    """One ssd:Component: its FMU and the start values of its ParameterBindings (inline ParameterValues or .ssv
    files; later bindings override earlier ones).  ``prefix`` + a file's path in the SSP names it in messages."""
    tree.require(xs.tag(el) == "Component", el, f"ssd:{xs.tag(el)} is not supported",
                 "ssd:Component (no nested systems or signal dictionaries)")
    name = tree.attribute(el, "name", 'name="INSTANCE" source="resources/MODEL.fmu"')
    tree.require(name not in names, el, f"two components named {name!r}: here and at {tree.line(names.get(name))}",
                 "a name unique in the system")
    names[name] = el
    source = tree.attribute(el, "source", 'source="resources/MODEL.fmu", a file in the SSP')
    tree.require("://" not in source, el, f"source {source!r} is not a file in the archive",
                 "a relative path such as resources/X.fmu")
    values, origins = {}, {}
    for binding in xs.children(_child(el, "ParameterBindings"), "ParameterBinding"):
        if binding.get("source"):
            ssv = ssd.parent / binding.get("source")
            tree.require(ssv.is_file(), binding, f"{name}: {ssv} not found", "an .ssv file in the SSP")
            ssv_tree = xs.parse(ssv, prefix + binding.get("source"), "an SSV parameter set")
            more = _parameter_set(ssv_tree, ssv_tree.root, name)
        else:
            more = ({}, {})
            for pv in xs.children(binding, "ParameterValues"):
                for pset in xs.children(pv, "ParameterSet"):
                    found = _parameter_set(tree, pset, name)
                    more[0].update(found[0])
                    more[1].update(found[1])
        values.update(more[0])
        origins.update(more[1])
    return SimulatorSpec(name, (ssd.parent / source).resolve(), values, origin=tree.where(el),
                         value_origins=origins)


_TRANSFORMATIONS = ("LinearTransformation", "BooleanMappingTransformation", "IntegerMappingTransformation",
                    "EnumerationMappingTransformation")


def _connection(tree, c, names: dict) -> tuple:
    ends = []
    for element, connector in (("startElement", "startConnector"), ("endElement", "endConnector")):
        allowed = "startElement, startConnector, endElement and endConnector"
        instance = tree.attribute(c, element, allowed)
        variable = tree.attribute(c, connector, allowed)
        tree.require(instance in names, c, f"unknown component {instance!r} (connections to the system's own "
                     "connectors are not supported)", ", ".join(names))
        ends.append((instance, variable))
    tree.require(not [t for t in c if xs.tag(t) in _TRANSFORMATIONS], c, "a transformation",
                 "plain connections (an output to an input, unchanged)")
    tree.require(ends[0] != ends[1], c, f"{ends[0][0]}.{ends[0][1]} is connected to itself",
                 "an output and an input")
    return tuple(ends)


def load_ssp(path, fmu_dir=None) -> System:
    """Read an SSP: a ``.ssp`` archive (extracted to a temporary folder, removed at exit), a folder
    with SystemStructure.ssd, or an ``.ssd`` file.  Components (in the file's order: the
    Gauss-Seidel order) with their FMU sources and the start values of their ParameterBindings
    (inline ParameterValues or .ssv files; later bindings override earlier ones), the connections,
    the start time and the base step (libcosim's osp:FixedStepAlgorithm annotation, else 1 ms).
    Anything wrong in the file is a ParameterError naming the file (inside an archive: ``x.ssp!SystemStructure.ssd``),
    the element's line and what is allowed."""
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
        ssd, prefix = folder / "SystemStructure.ssd", f"{path}!"     # a file in the archive: x.ssp!resources/..
    elif path.is_dir():
        ssd, prefix = path / "SystemStructure.ssd", f"{path}/"
    else:
        ssd, prefix = path, f"{path.parent}/"
    require(ssd.is_file(), "SYSTEM_FILE", f"{path}: no SystemStructure.ssd", what)
    tree = xs.parse(ssd, str(path) if ssd == path else prefix + ssd.name, what)
    root = tree.root
    tree.require(xs.tag(root) == "SystemStructureDescription", root, f"the root element is {xs.tag(root)}",
                 "ssd:SystemStructureDescription")
    system_el = _child(root, "System")
    tree.require(system_el is not None, root, "no ssd:System", "one ssd:System")
    start, base_step = _experiment(tree, root)
    names: dict = {}
    sims = [_component(tree, el, ssd, prefix, names)
            for elements in xs.children(system_el, "Elements") for el in elements]
    conns, declared = [], {}
    for c in xs.children(_child(system_el, "Connections"), "Connection"):
        connection = _connection(tree, c, names)
        tree.require(connection not in declared, c, f"this connection is given twice (first at "
                     f"{tree.line(declared.get(connection))})", "each connection once")
        conns.append(connection)
        declared[connection] = c
    system = System(sims, conns, base_step, start, path,
                    connection_origins={k: tree.where(c) for k, c in declared.items()})
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
