"""The FMI 3.0 modelDescription.xml of a native FMU (co-simulation), from the same variable table as its FMI 2.0 one
and its model file (flexfmu.fmi.variables.table: names, value references in that order, types, causality, start
values, units, descriptions), so an FMU of either version runs the same runtime on the same model file.

What FMI 3.0 names otherwise: Real is Float64, Integer Int32 (the runtime's 32-bit int); a String's start value is a
``<Start value=...>`` child; the outputs are listed by value reference (``<Output>``, ``<InitialUnknown>``: their
values are computed, ``initial="calculated"``); the one independent variable ``time`` has the value reference
:data:`TIME_VALUE_REFERENCE` (after every runtime variable's; csrc/flexfmu_fmi3.c reads it as the FMU's time); the
GUID is the ``instantiationToken``.  Variables are scalars, with their FMI 2.0 names; a native FMU built with
``arrays=True`` adds Float64 array views of them (flexfmu.fmi.fmi3_arrays: 3-vectors, modal coordinates, natural
frequencies, value references from 2^30).

Also here: the text of an FMI 2.0 FMU's documentation or descriptions in FMI 3.0's names (:func:`fmi3_text`), and
``sources/buildDescription.xml`` (:func:`build_description`: FMI 3.0's list of the source files).
"""
from __future__ import annotations

import re
from datetime import datetime, timezone
from xml.etree import ElementTree as ET

#: the value reference of the independent variable ``time`` (csrc/flexfmu_fmi3.c TIME_VALUE_REFERENCE): 2^31 - 1, a
#: value that also fits a host's signed 32-bit value references
TIME_VALUE_REFERENCE = 2**31 - 1
TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
LOG_CATEGORIES = (("logStatusWarning", "Log messages with fmi3Warning status."),
                  ("logStatusDiscard", "Log messages with fmi3Discard status."),
                  ("logStatusError", "Log messages with fmi3Error status."),
                  ("logStatusFatal", "Log messages with fmi3Fatal status."),
                  ("logAll", "Log all messages."))
#: FMI 2.0 functions whose FMI 3.0 names are not fmi3 + the same name (csrc/flexfmu_fmi3.c RENAMED)
RENAMED = {"fmi2GetReal": "fmi3GetFloat64", "fmi2SetReal": "fmi3SetFloat64", "fmi2GetInteger": "fmi3GetInt32",
           "fmi2SetInteger": "fmi3SetInt32", "fmi2Instantiate": "fmi3InstantiateCoSimulation",
           "fmi2SetupExperiment": "fmi3EnterInitializationMode", "fmi2GetFMUstate": "fmi3GetFMUState",
           "fmi2SetFMUstate": "fmi3SetFMUState", "fmi2FreeFMUstate": "fmi3FreeFMUState",
           "fmi2SerializedFMUstateSize": "fmi3SerializedFMUStateSize",
           "fmi2SerializeFMUstate": "fmi3SerializeFMUState", "fmi2DeSerializeFMUstate": "fmi3DeserializeFMUState"}
_FMI2_NAME = re.compile(r"(?<![A-Za-z0-9_/\\.-])fmi2(\w*)")


def fmi3_text(text: str) -> str:
    """``text`` written for an FMI 2.0 FMU in FMI 3.0's terms: fmi2X functions and statuses as FMI 3.0 names them
    (fmi2GetReal -> fmi3GetFloat64, fmi2Discard -> fmi3Discard), "FMI 2.0" as "FMI 3.0"."""
    text = _FMI2_NAME.sub(lambda m: RENAMED.get(m.group(0), "fmi3" + m.group(1)), text)
    return text.replace("FMI 2.0", "FMI 3.0")


def _number(value) -> str:
    """A start value as the XML literal that reads back as the same number (Python's shortest round trip)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    return repr(float(value))


def model_description(source, guid: str, *, variables=None, units: dict | None = None) -> bytes:
    """modelDescription.xml (FMI 3.0 co-simulation) of a native FMU's source (flexfmu.fmi.native_build.NativeSource:
    its name, description, spec, the values built with, the DefaultExperiment); ``variables``: the table
    (default: flexfmu.fmi.variables.table(source.spec, source.values)), ``units``: SI base-unit exponents per
    unit (default: flexfmu.fmi.units.UNITS)."""
    from flexfmu import __version__
    from flexfmu.errors import ParameterError
    from flexfmu.fmi.variables import table

    if units is None:
        from flexfmu.fmi.units import UNITS as units
    rows = list(variables if variables is not None else table(source.spec, source.values))
    if len(rows) >= TIME_VALUE_REFERENCE:
        raise ParameterError("variables", f"{len(rows)} variables", f"fewer than {TIME_VALUE_REFERENCE}")
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": source.name, "instantiationToken": guid,
        "description": source.description, "author": "flexfmu",
        "generationTool": f"flexfmu {__version__} (native runtime)",
        "generationDateAndTime": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "structured"})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": source.name, "needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
        "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
        "canHandleVariableCommunicationStepSize": "true"})
    used = sorted({"s", *(v.unit for v in rows if v.unit and v.type == "Real")})
    unknown = [u for u in used if u not in units]
    if unknown:
        raise ParameterError("unit", f"{unknown[0]!r} has no SI definition", ", ".join(sorted(units)))
    unit_definitions = ET.SubElement(root, "UnitDefinitions")
    for name in used:
        ET.SubElement(ET.SubElement(unit_definitions, "Unit", name=name), "BaseUnit",
                      {k: str(v) for k, v in units[name].items()})
    categories = ET.SubElement(root, "LogCategories")
    for name, text in LOG_CATEGORIES:
        ET.SubElement(categories, "Category", name=name, description=text)
    ET.SubElement(root, "DefaultExperiment", {k: str(v) for k, v in source.experiment.items()})
    variables_element = ET.SubElement(root, "ModelVariables")
    ET.SubElement(variables_element, "Float64", name="time", valueReference=str(TIME_VALUE_REFERENCE),
                  description="simulation time", causality="independent", variability="continuous", unit="s")
    outputs = []
    for reference, v in enumerate(rows):
        attributes = {"name": v.name, "valueReference": str(reference), "description": fmi3_text(v.description),
                      "causality": v.causality}
        if v.causality == "parameter":
            attributes["variability"] = "fixed"
        elif v.type in ("Real",):
            attributes["variability"] = "continuous"
        else:
            attributes["variability"] = "discrete"
        if v.causality == "output":
            attributes["initial"] = "calculated"
            outputs.append(reference)
        element = ET.SubElement(variables_element, TYPES[v.type], attributes)
        if v.causality != "output":
            if v.type == "String":
                ET.SubElement(element, "Start", value=str(v.start))
            else:
                element.set("start", _number(v.start))
        if v.unit and v.type == "Real":
            element.set("unit", v.unit)
    structure = ET.SubElement(root, "ModelStructure")
    for reference in outputs:
        ET.SubElement(structure, "Output", valueReference=str(reference))
    for reference in outputs:
        ET.SubElement(structure, "InitialUnknown", valueReference=str(reference))
    ET.indent(root, "\t")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


def build_description(name: str, sources, description: str = "") -> bytes:
    """sources/buildDescription.xml: FMI 3.0's build configuration of the FMU ``name`` from the C files ``sources``
    (in sources/, compiled as one library; C99, libm)."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    configuration = ET.SubElement(root, "BuildConfiguration", modelIdentifier=name,
                                  description=description or "the native flexfmu runtime (sources/README.md)")
    files = ET.SubElement(configuration, "SourceFileSet", language="C99")
    for source in sources:
        ET.SubElement(files, "SourceFile", name=source)
    ET.SubElement(configuration, "Library", name="m")
    ET.indent(root, "\t")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


# ---------------------------------------------------------------------------------------------- the FMU's layout
#: FMI 2.0's platform folders (flexfmu.fmi.native_build's) and FMI 3.0's <architecture>-<operating system> ones
PLATFORM_FOLDERS = {"linux64": "x86_64-linux", "win64": "x86_64-windows", "darwin64": "x86_64-darwin",
                    "linux32": "x86-linux", "win32": "x86-windows", "aarch64-linux": "aarch64-linux"}

#: appended to sources/CMakeLists.txt: the library goes to FMI 3.0's folder (-DFMI_PLATFORM=NAME still decides)
CMAKE_FMI3 = """
# FMI 3.0 names the platform folders <architecture>-<operating system> (x86_64-linux, aarch64-linux,
# x86_64-windows, x86_64-darwin, aarch64-darwin): this FMU is FMI 3.0, its library goes there.
if(DEFINED CACHE{FMI_PLATFORM})
  set(FMI3_PLATFORM $CACHE{FMI_PLATFORM})
else()
  if(CMAKE_OSX_ARCHITECTURES MATCHES ";")
    message(WARNING "FMI 3.0 has one folder per architecture: build each of CMAKE_OSX_ARCHITECTURES alone")
  endif()
  if(CMAKE_OSX_ARCHITECTURES STREQUAL "arm64" OR (NOT CMAKE_OSX_ARCHITECTURES AND
     CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64|ARM64)$"))
    set(FMI3_ARCHITECTURE aarch64)
  elseif(CMAKE_SIZEOF_VOID_P EQUAL 8)
    set(FMI3_ARCHITECTURE x86_64)
  else()
    set(FMI3_ARCHITECTURE x86)
  endif()
  if(WIN32)
    set(FMI3_SYSTEM windows)
  elseif(APPLE)
    set(FMI3_SYSTEM darwin)
  else()
    set(FMI3_SYSTEM linux)
  endif()
  set(FMI3_PLATFORM "${FMI3_ARCHITECTURE}-${FMI3_SYSTEM}")
endif()
set_target_properties(${MODEL_IDENTIFIER} PROPERTIES
  RUNTIME_OUTPUT_DIRECTORY "$<1:${CMAKE_CURRENT_SOURCE_DIR}/../binaries/${FMI3_PLATFORM}>"
  LIBRARY_OUTPUT_DIRECTORY "$<1:${CMAKE_CURRENT_SOURCE_DIR}/../binaries/${FMI3_PLATFORM}>")
"""

README_FMI3 = """
## FMI 3.0

This FMU is FMI 3.0 co-simulation (`flexfmu_fmi3.c`, the same library's FMI 3.0 entry points; the binary also
exports the FMI 2.0 ones). FMI 3.0 names its platform folders `<architecture>-<operating system>`:
`binaries/x86_64-linux/{name}.so`, `binaries/aarch64-linux/{name}.so`, `binaries/x86_64-windows/{name}.dll`,
`binaries/x86_64-darwin/{name}.dylib`, `binaries/aarch64-darwin/{name}.dylib`; `CMakeLists.txt` writes the library
there (on macOS build each architecture alone: `-DCMAKE_OSX_ARCHITECTURES=arm64` or `x86_64`), and
`buildDescription.xml` lists the source files as FMI 3.0 does.
"""


def fmi3_layout(members: dict, name: str, sources) -> dict:
    """The archive members of a native FMU (flexfmu.fmi.native_build) laid out as FMI 3.0's: the binaries in FMI 3.0's
    platform folders, ``sources/buildDescription.xml`` from ``sources`` (the C files compiled), CMakeLists.txt
    writing to FMI 3.0's folder, the documentation in FMI 3.0's names, ``fmi_version`` 3 in flexfmu_build.json."""
    import json

    from flexfmu.errors import ParameterError

    out = {}
    for member, data in members.items():
        if member.startswith("binaries/"):
            _, folder, rest = member.split("/", 2)
            if folder not in PLATFORM_FOLDERS:
                raise ParameterError("platform", f"binaries/{folder} has no FMI 3.0 name", ", ".join(PLATFORM_FOLDERS))
            member = f"binaries/{PLATFORM_FOLDERS[folder]}/{rest}"
        elif member == "documentation/index.html":
            data = _fmi3_documentation(data.decode("utf-8")).encode("utf-8")
        elif member == "sources/CMakeLists.txt":
            data += CMAKE_FMI3.encode()
        elif member == "sources/README.md":
            data += README_FMI3.format(name=name).encode()
        elif member == "resources/flexfmu_build.json":
            info = json.loads(data)
            info["fmi_version"] = 3
            if isinstance(info.get("platforms"), list):
                info["platforms"] = sorted(PLATFORM_FOLDERS.get(p, p) for p in info["platforms"])
            data = json.dumps(info, indent=1, default=str).encode()
        out[member] = data
    out["sources/buildDescription.xml"] = build_description(name, sources)
    return out


def _fmi3_documentation(page: str) -> str:
    """An FMI 2.0 native FMU's documentation/index.html in FMI 3.0's names and folders."""
    # FMI 2.0's missing ARM folder is no matter in FMI 3.0, which names aarch64-linux
    page = re.sub(r"<p>FMI 2\.0 names no folder for ARM Linux.*?</p>", "", page, flags=re.S)
    for old, new in PLATFORM_FOLDERS.items():
        page = page.replace(f"binaries/{old}/", f"binaries/{new}/")
    return fmi3_text(page)
