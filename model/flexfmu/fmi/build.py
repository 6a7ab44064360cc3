"""Build the FMUs of flexfmu.fmi.registry, bundling this flexfmu package (a source checkout or an
installed one), then complete modelDescription.xml with what pythonfmu cannot declare and validate the
result with fmpy.

    flexfmu build [--out dist]          (also: python build_scripts/build_fmus.py [--out dist])

Post-processing: units and UnitDefinitions, a DefaultExperiment, outputs declared
initial="calculated" with InitialUnknowns (their start values depend on the parameters), and the
flexfmu runtime (flexfmu.fmi.runtime) in place of pythonfmu's binary.
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path
from xml.etree import ElementTree as ET

from flexfmu import __version__
from flexfmu.fmi import archive, registry, runtime
from flexfmu.fmi.loader import package_build_id

PACKAGE = Path(__file__).resolve().parents[1]      # the flexfmu package this module belongs to

# SI base-unit exponents of every unit used.
UNITS = {
    "m": {"m": 1}, "m/s": {"m": 1, "s": -1}, "m/s2": {"m": 1, "s": -2}, "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2}, "Hz": {"s": -1}, "J": {"kg": 1, "m": 2, "s": -2},
    "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2}, "s": {"s": 1}, "kg": {"kg": 1},
}


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


def build_one(spec, target: Path, runtime_files, *, experiment: dict | None = None, resources: tuple[Path, ...] = (),
              documentation: dict | None = None) -> Path:
    """The FMU of ``spec`` (flexfmu.fmi.slave.FmuModel) at ``target``: its slave script (flexfmu.fmi.slave), the
    bundled flexfmu, the files ``resources`` (in resources/, where the slave finds them at build time too: pythonfmu
    instantiates it there), the completed modelDescription (DefaultExperiment ``experiment``, else the spec's),
    the model file, ``documentation`` {file name: text} in documentation/, the runtime; validated."""
    from fmpy.validation import validate_fmu
    from pythonfmu.builder import FmuBuilder

    from flexfmu.fmi.slave import slave_script

    name = spec.name
    script_text = slave_script(spec)
    experiment = spec.experiment if experiment is None else experiment
    front, bridge = runtime_files
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
        target = Path(target)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(fmu), target)
    problems = validate_fmu(str(target))
    if problems:
        raise runtime.RuntimeBuildError(f"{target}: fmpy validate found problems:\n" + "\n".join(problems))
    return target


def build(out: Path) -> list[Path]:
    """Every FMU of flexfmu.fmi.registry into the folder ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    runtime_files = runtime.compile_runtime(runtime.build_folder())
    built = []
    for spec in registry.FMUS:
        target = build_one(spec, out / f"{spec.name}.fmu", runtime_files)
        print(f"built {target} (fmpy validate: no problems)")
        built.append(target)
    return built


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("dist"), help="output folder (default: dist)")
    args = parser.parse_args(argv)
    build(args.out)
    return 0
