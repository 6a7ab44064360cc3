"""Build the FMUs of flexfmu.fmi.registry, bundling this flexfmu package (a source checkout or an
installed one), then complete modelDescription.xml with what pythonfmu cannot declare and validate the
result with fmpy.

    flexfmu build [--out dist] [--fmi-version 2|3]     (also: python build_scripts/build_fmus.py [--out dist])

Post-processing: units and UnitDefinitions, a DefaultExperiment, outputs declared
initial="calculated" with InitialUnknowns (their start values depend on the parameters), and the
flexfmu runtime (flexfmu.fmi.runtime) in place of pythonfmu's binary.

FMI 3.0 (``fmi_version=3``): pythonfmu writes FMI 2.0 only, so the FMU is built as above and then given the FMI 3.0
modelDescription of flexfmu.fmi.description_fmi3 from the same variable table (flexfmu.fmi.variables.table, as the
model file's), the same GUID (its instantiationToken, which the runtime checks against the model file), FMI 3.0's
layout (binaries/x86_64-linux/) and the FMI 3.0 front (flexfmu.fmi.runtime.compile_runtime(..., 3)) over the same
bridge: the same runtime steps the same model file.
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path
from xml.etree import ElementTree as ET

from flexfmu import __version__
from flexfmu.errors import ParameterError
from flexfmu.fmi import archive, registry, runtime
from flexfmu.fmi.loader import package_build_id
from flexfmu.fmi.units import UNITS  # SI base-unit exponents of every unit used

PACKAGE = Path(__file__).resolve().parents[1]      # the flexfmu package this module belongs to



def _complete_model_description(xml_text: str, info: dict, experiment: dict) -> bytes:
    root = ET.fromstring(xml_text)
    used = sorted({unit for unit, _ in info.values() if unit})
    children = list(root)
    insert_at = next(i for i, c in enumerate(children) if c.tag == "CoSimulation") + 1
    unit_defs = ET.Element("UnitDefinitions")
    for name in used:
        unit = ET.SubElement(unit_defs, "Unit", name=name)
        ET.SubElement(unit, "BaseUnit", {k: str(v) for k, v in UNITS[name].items()})
    root.insert(insert_at, unit_defs)
    model_variables = root.find("ModelVariables")
    root.insert(list(root).index(model_variables), ET.Element("DefaultExperiment", experiment))

    output_indices = []
    for index, var in enumerate(model_variables, start=1):
        unit, description = info[var.get("name")]
        var.set("description", description)
        typed = var[0]
        if unit and typed.tag == "Real":
            typed.set("unit", unit)
        if var.get("causality") == "output":
            var.set("initial", "calculated")
            typed.attrib.pop("start", None)
            output_indices.append(index)
    structure = root.find("ModelStructure")
    initial = ET.SubElement(structure, "InitialUnknowns")
    for index in output_indices:
        ET.SubElement(initial, "Unknown", index=str(index))
    ET.indent(root, "\t")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


def _rewrite_model_description(fmu: Path, info: dict, experiment: dict, documentation: dict | None = None) -> None:
    members = archive.read_members(fmu)
    members["modelDescription.xml"] = _complete_model_description(
        members["modelDescription.xml"].decode("utf-8"), info, experiment)
    for name, text in (documentation or {}).items():
        members[f"documentation/{name}"] = text.encode("utf-8")
    archive.write_members(fmu, members)


def _as_fmi3(fmu: Path, spec, experiment: dict) -> None:
    """The FMI 2.0 Python FMU at ``fmu`` (built by build_one, its front an FMI 3.0 one) made FMI 3.0, in place."""
    from types import SimpleNamespace

    from flexfmu.fmi import description_fmi3

    members = archive.read_members(fmu)
    fmi2 = ET.fromstring(members["modelDescription.xml"])
    name = fmi2.find("CoSimulation").get("modelIdentifier")
    source = SimpleNamespace(name=name, description=spec.description, spec=spec, values=None, experiment=experiment)
    root = ET.fromstring(description_fmi3.model_description(source, fmi2.get("guid")))
    # what the Python runtime differs in from the native one, for which description_fmi3 writes: its tool, and a
    # Python installation it needs on the host (FMI 2.0's needsExecutionTool, as pythonfmu declares it)
    root.set("generationTool", f"flexfmu {__version__} (Python runtime)")
    root.find("CoSimulation").set("needsExecutionTool", fmi2.find("CoSimulation").get("needsExecutionTool", "true"))
    ET.indent(root, "\t")
    members["modelDescription.xml"] = b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")
    members = description_fmi3.fmi3_layout(members, name, ())
    members.pop("sources/buildDescription.xml")        # a Python FMU ships no C sources to build
    archive.write_members(fmu, members)


def build_one(spec, target: Path, runtime_files, *, experiment: dict | None = None, resources: tuple[Path, ...] = (),
              documentation: dict | None = None, fmi_version: int = 2) -> Path:
    """The FMU of ``spec`` (flexfmu.fmi.slave.FmuModel) at ``target``: its slave script (flexfmu.fmi.slave), the
    bundled flexfmu, the files ``resources`` (in resources/, where the slave finds them at build time too: pythonfmu
    instantiates it there), the completed modelDescription (DefaultExperiment ``experiment``, else the spec's),
    the model file, ``documentation`` {file name: text} in documentation/, the runtime; validated.
    ``fmi_version`` 3: FMI 3.0 co-simulation, ``runtime_files`` from runtime.compile_runtime(folder, 3)."""
    from fmpy.validation import validate_fmu
    from pythonfmu.builder import FmuBuilder

    from flexfmu.fmi.slave import slave_script

    if fmi_version not in (2, 3):
        raise ParameterError("fmi_version", f"got {fmi_version!r}", "2 or 3")
    name = spec.name
    script_text = slave_script(spec)
    experiment = spec.experiment if experiment is None else experiment
    front, bridge = runtime_files
    if (runtime.FMI3_ENTRY in Path(front).read_bytes()) != (fmi_version == 3):
        raise ParameterError("runtime_files", f"the front {front} is not of FMI version {fmi_version}",
                             f"runtime.compile_runtime(folder, {fmi_version})")
    build_info = {"version": __version__, "build_id": package_build_id(str(PACKAGE))}
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "slave" / f"{name}.py"
        script.parent.mkdir()
        script.write_text(script_text, encoding="utf-8")
        # Bundle a clean copy of the package (no caches) under the import name flexfmu.
        package = Path(tmp) / "flexfmu"
        shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        fmu = Path(FmuBuilder.build_FMU(script, dest=tmp, project_files=[package, *map(Path, resources)],
                                        canGetAndSetFMUstate=True, canSerializeFMUstate=True))
        # the slave script, readable beside the documentation (the runtime loads the copy in resources/)
        documentation = {**(documentation or {}), f"{name}_slave.py": script_text}
        _rewrite_model_description(fmu, spec.variable_info, experiment, documentation)
        runtime.install(fmu, front, bridge, {**build_info, "slave_script": script.name}, spec)
        if fmi_version == 3:
            _as_fmi3(fmu, spec, experiment)
        target = Path(target)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(fmu), target)
    problems = validate_fmu(str(target))
    if problems:
        raise runtime.RuntimeBuildError(f"{target}: fmpy validate found problems:\n" + "\n".join(problems))
    return target


def build(out: Path, fmi_version: int = 2) -> list[Path]:
    """Every FMU of flexfmu.fmi.registry into the folder ``out``, FMI 2.0 or (``fmi_version`` 3) FMI 3.0
    co-simulation."""
    out.mkdir(parents=True, exist_ok=True)
    runtime_files = runtime.compile_runtime(runtime.build_folder(), fmi_version)
    version = "FMI 3.0; " if fmi_version == 3 else ""
    built = []
    for spec in registry.FMUS:
        target = build_one(spec, out / f"{spec.name}.fmu", runtime_files, fmi_version=fmi_version)
        print(f"built {target} ({version}fmpy validate: no problems)")
        built.append(target)
    return built


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("dist"), help="output folder (default: dist)")
    parser.add_argument("--fmi-version", type=int, choices=(2, 3), default=2, help="2 (default) or 3")
    args = parser.parse_args(argv)
    build(args.out, args.fmi_version)
    return 0
