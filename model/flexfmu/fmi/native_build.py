"""How a native FMU is made from a NativeSource (flexfmu.fmi.native says what one is and makes them from the registry
and from exported bodies): its modelDescription, its model file's entries, its binary compiled from the C sources,
its sources/ and documentation, and the archive.

Layout of a native FMU:

    modelDescription.xml          needsExecutionTool="false", SourceFiles listed
    binaries/linux64/<id>.so      compiled here with the system C compiler (flexfmu.native.compiler)
    binaries/win64/<id>.dll       cross-compiled with MinGW-w64, when installed (flexfmu.native.compiler.PLATFORMS)
    binaries/aarch64-linux/<id>.so  cross-compiled with gcc-aarch64-linux-gnu, when installed
    resources/flexfmu_model.bin   the model (flexfmu.fmi.model_file)
    resources/flexfmu_build.json  flexfmu version, runtime "native", model, kind, GUID, the parameters frozen
    resources/shape.npz           an exported solid's shape file (NativeSource.resources; flexfmu animate)
    sources/                      every C source and header of the binary, fmi2 headers, CMakeLists.txt, README.md
    documentation/index.html      the model, the frozen parameters, the variables, how to rebuild

The model file's format and the entries every kind has: flexfmu.fmi.model_file; the LTI kind's entries:
csrc/native_lti.c's header comment; the reframe kind's: flexfmu.native.reframe; the wec kind's: csrc/native_wec.c's.
"""
from __future__ import annotations

import dataclasses
import hashlib
import html
import json
import math
import shlex
import tempfile
import threading
import uuid
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.fmi import archive, description_fmi3, model_file
from flexfmu.fmi.model_file import FORMAT_VERSION, MODEL_FILE, write_model_file

HERE = Path(__file__).resolve().parent
FMI_CSRC = HERE / "csrc"
BUILD_INFO = "flexfmu_build.json"
#: the C sources of a native FMU (every kind's): (folder, file) — compiled in this order, shipped in sources/
_FRONT = ("native_front.c", "flexfmu_fmi3.c", "flexfmu_native.c", "native_kinds.c", "native_lti.c", "native_reframe.c",
          "native_wec.c", "native_moordyn.c")
_FRONT_HEADERS = ("flexfmu_fmi2.c", "front_common.c", "front_common.h", "flexfmu_bridge.h", "native_kind.h",
                  "native_platform.h")
_KERNELS = ("lti_kernels.c", "derived_stress.c", "reframe_kernels.c", "step_policy.c")
_KERNEL_HEADERS = ("lti_kernels.h", "derived_stress.h", "reframe_kernels.h", "step_policy.h")
_FMI2_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
_FMI3_HEADERS = ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")     # fmpy ships them beside


# ---------------------------------------------------------------------------------------------- what is built
@dataclass
class NativeSource:
    """Everything a native FMU is made of: its name and description, the FMU spec its modelDescription comes from
    (flexfmu.fmi.registry.FmuSpec or flexfmu.fmi.body_fmu.ExportedSpec), the parameter values it is built with,
    which of them stay settable (``runtime``), the kind's model (an flexfmu.native.lti.LtiModel), the
    DefaultExperiment, the messages logged at initialisation, the divergence limit, the rebuild command, and the
    documentation page."""

    name: str
    description: str
    spec: object
    values: dict
    runtime: tuple
    lti: object
    experiment: dict
    kind: str = "lti"
    #: the kind's entries for kinds other than "lti": a function (inputs, outputs, params) -> {name: value}
    kind_entries: object = None
    #: the kind's own binaries (the moordyn kind: MoorDyn's library), or None: a function (binaries, missing) ->
    #: (binaries kept, platforms missing, {archive member: bytes})
    kind_files: object = None
    #: further files of resources/ {name: bytes} (an exported solid's shape file, flexfmu.body.shape_file)
    resources: dict = field(default_factory=dict)
    messages: list = field(default_factory=list)
    divergence_limit: float = math.inf
    divergence_allowed: str = "inputs within the model's range"
    rebuild: str = ""
    rebuild_settings: dict = field(default_factory=dict)
    log_split: bool = False
    documentation: str = ""
    info: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------- modelDescription
def _slave(source: NativeSource, resources: Path):
    """A pythonfmu slave declaring the source's spec's variables (flexfmu.fmi.variables), its parameters at the
    build values: what writes the modelDescription, as for the Python FMU of the same spec."""
    from pythonfmu import Fmi2Slave

    from flexfmu.fmi.variables import declare

    def __init__(self, **kwargs):
        Fmi2Slave.__init__(self, **kwargs)
        declare(self, source.spec, source.values)

    cls = type(source.name, (Fmi2Slave,), {"author": "flexfmu", "description": source.description,
                                           "__init__": __init__, "do_step": lambda self, t, h: True})
    return cls(instance_name="native-build", resources=str(resources))


def model_description(source: NativeSource, guid: str) -> bytes:
    """modelDescription.xml: pythonfmu's of the source's variables, completed as the Python FMUs' (flexfmu.fmi.build),
    with the native runtime's capabilities and source files."""
    from flexfmu import __version__
    from flexfmu.fmi.build import _complete_model_description

    with tempfile.TemporaryDirectory(prefix="flexfmu-native-") as tmp:
        slave = _slave(source, Path(tmp))
        slave.guid = guid
        root = slave.to_xml()
    cosim = root.find("CoSimulation")
    cosim.set("canGetAndSetFMUstate", "true")
    cosim.set("canSerializeFMUstate", "true")
    cosim.set("needsExecutionTool", "false")
    text = ET.tostring(root, encoding="unicode")
    completed = _complete_model_description(text, source.spec.variable_info, source.experiment)
    root = ET.fromstring(completed)
    root.set("generationTool", f"flexfmu {__version__} (native runtime)")
    cosim = root.find("CoSimulation")
    files = ET.SubElement(cosim, "SourceFiles")
    for name in (*_FRONT, *_KERNELS):
        ET.SubElement(files, "File", name=name)
    ET.indent(root, "\t")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


# ---------------------------------------------------------------------------------------------- model entries
def model_entries(source: NativeSource, guid: str) -> dict:
    """The model file's entries (flexfmu.fmi.model_file; the LTI kind's: csrc/native_lti.c)."""
    entries, inputs, outputs, params = model_file.entries(
        source.spec, kind=source.kind, name=source.name, guid=guid, values=source.values, runtime=source.runtime,
        messages=source.messages, divergence_limit=source.divergence_limit,
        divergence_allowed=source.divergence_allowed, rebuild=source.rebuild, rebuild_settings=source.rebuild_settings)
    if source.kind == "lti":
        from flexfmu.fmi.interfaces import state_nominals
        entries.update(_lti_entries(source.lti, inputs, outputs, params, source))
        entries["state.nominal"] = state_nominals(source.lti)
    else:
        entries.update(source.kind_entries(inputs, outputs, params))
    return entries


def _lti_entries(lti, inputs: list, outputs: list, params: list, source: NativeSource) -> dict:
    """The LTI kind's entries: the kernel's arrays and the maps from the FMU's variables (csrc/native_lti.c)."""
    position = {name: k for k, name in enumerate(inputs)}
    try:
        u_from = [position[lti.input_names[k]] for k in lti.u_from_input]
        p_from = [position[lti.input_names[k]] if k >= 0 else -1 for k in lti.p_from_input]
        y_to = [outputs.index(name) for name in lti.output_names]
    except (KeyError, ValueError) as exc:
        raise ParameterError("lti", f"the model names a variable the FMU does not have ({exc})") from None
    if sorted(y_to) != list(range(len(outputs))):
        raise ParameterError("lti", "its outputs are not the FMU's", ", ".join(outputs))
    p_param = [params.index(name) if (p_from[k] < 0 and name in params) else -1
               for k, name in enumerate(lti.param_names)]
    role = lambda name: params.index(name) if name in params else -1     # noqa: E731
    return {
        "lti.A": lti.A, "lti.B": lti.B, "lti.b": lti.b, "lti.Cx": lti.Cx, "lti.Cu": lti.Cu, "lti.y0": lti.y0,
        "lti.quad_row": lti.quad_row, "lti.quad_i": lti.quad_i, "lti.quad_j": lti.quad_j,
        "lti.quad_value": lti.quad_value,
        "lti.u_from_input": np.array(u_from, np.int32), "lti.p_from_input": np.array(p_from, np.int32),
        "lti.p_param": np.array(p_param, np.int32), "lti.p_start": lti.p_start,
        "lti.y_to_output": np.array(y_to, np.int32),
        "lti.internal_step": np.int32(role("internal_step")),
        "lti.max_internal_steps": np.int32(role("max_internal_steps") if "internal_step" in params else -1),
        "lti.log_split": np.int32(1 if source.log_split else 0), **model_file.derived_entries(lti),
    }


# ---------------------------------------------------------------------------------------------- the binary
_COMPILED: dict[str, bytes] = {}
_COMPILE_LOCK = threading.Lock()


def _fmi2_headers() -> Path:
    from flexfmu.fmi.runtime import _fmi2_headers as headers
    return headers()


def source_files() -> dict[str, Path]:
    """sources/ of a native FMU (LTI kind): file name -> path."""
    from flexfmu.native.compiler import CSRC
    files = {name: FMI_CSRC / name for name in (*_FRONT, *_FRONT_HEADERS)}
    files.update({name: CSRC / name for name in (*_KERNELS, *_KERNEL_HEADERS)})
    files.update({name: _fmi2_headers() / name for name in (*_FMI2_HEADERS, *_FMI3_HEADERS)})
    return files


def compile_binary() -> bytes:
    """The linux64 shared library of the native kinds (``compile_binaries``)."""
    return compile_binaries()[0]["linux64"]


def compile_binaries() -> tuple[dict[str, bytes], dict[str, str]]:
    """({platform: shared library}, {platform: what to install}): the native kinds' library for every platform of
    flexfmu.native.compiler.PLATFORMS whose compiler is installed (linux64 always: the system C compiler; win64 and
    aarch64-linux cross-compiled, in parallel), each compiled once per process and source digest with the IEEE flags
    (no fast-math, no FMA contraction), and the platforms left out for want of their compiler."""
    import platform
    import sys
    from concurrent.futures import ThreadPoolExecutor

    from flexfmu.fmi.runtime import RuntimeBuildError
    from flexfmu.native.compiler import (KERNEL_FLAGS, PLATFORMS, compile_shared, find_compiler, install_hint,
                                         platform_compiler)
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise RuntimeBuildError(f"native FMUs are built with a linux64 binary, not on {sys.platform}/"
                                f"{platform.machine()}: build the FMU on Linux x86-64, then rebuild its binary for "
                                "this platform from its sources/ (docs/fmu.md, 'Native runtime')")
    files = source_files()
    digest = hashlib.sha256(" ".join(KERNEL_FLAGS).encode())
    for name in sorted(files):
        digest.update(name.encode() + files[name].read_bytes())
    compilers = {p.name: platform_compiler(p) for p in PLATFORMS}
    compilers["linux64"] = find_compiler()              # none: CompilerError saying what to install
    missing = {p.name: install_hint(p) for p in PLATFORMS if compilers[p.name] is None}
    wanted = [p for p in PLATFORMS if compilers[p.name] is not None]
    keys = {p.name: hashlib.sha256(digest.digest() + f"{p}{compilers[p.name]}".encode()).hexdigest() for p in wanted}

    def compile_for(p) -> bytes:
        with tempfile.TemporaryDirectory(prefix="flexfmu-native-") as tmp:
            out = compile_shared([files[n] for n in (*_FRONT, *_KERNELS)], Path(tmp) / f"fmu{p.suffix}",
                                 include_dirs=(FMI_CSRC, _fmi2_headers()),
                                 extra_flags=("-fvisibility=hidden", "-Wno-format-truncation", *p.flags),
                                 libraries=p.libraries, compiler=compilers[p.name])
            return out.read_bytes()

    with _COMPILE_LOCK:
        todo = [p for p in wanted if keys[p.name] not in _COMPILED]
        with ThreadPoolExecutor(max_workers=max(1, len(todo))) as pool:
            for p, library in zip(todo, pool.map(compile_for, todo)):
                _COMPILED[keys[p.name]] = library
        return {p.name: _COMPILED[keys[p.name]] for p in wanted}, missing


CMAKE = """# Rebuild the binary of this native FMU for your platform (README.md beside this file):
#   cmake -S sources -B build -DCMAKE_BUILD_TYPE=Release
#   cmake --build build --config Release
# run in the unzipped FMU's folder: the library lands in binaries/<platform>/ (win64, darwin64, linux64; another
# folder with -DFMI_PLATFORM=..., e.g. aarch64-linux).
cmake_minimum_required(VERSION 3.13)
project(flexfmu_native_fmu C)
set(MODEL_IDENTIFIER "{name}")

add_library(${{MODEL_IDENTIFIER}} SHARED {sources})
set_target_properties(${{MODEL_IDENTIFIER}} PROPERTIES PREFIX "" C_STANDARD 99 C_VISIBILITY_PRESET hidden)
target_include_directories(${{MODEL_IDENTIFIER}} PRIVATE ${{CMAKE_CURRENT_SOURCE_DIR}})
if(MSVC)
  # IEEE arithmetic as written (no contraction into FMA): the numbers of the Linux build
  target_compile_definitions(${{MODEL_IDENTIFIER}} PRIVATE _CRT_SECURE_NO_WARNINGS)
  target_compile_options(${{MODEL_IDENTIFIER}} PRIVATE /fp:precise)
else()
  target_compile_options(${{MODEL_IDENTIFIER}} PRIVATE -ffp-contract=off -fno-fast-math)
  find_package(Threads REQUIRED)
  target_link_libraries(${{MODEL_IDENTIFIER}} PRIVATE m Threads::Threads ${{CMAKE_DL_LIBS}})
endif()
if(MINGW)
  # MinGW's C99 printf family (not msvcrt's), libgcc linked in: the DLL needs no DLL beyond Windows' own
  target_compile_definitions(${{MODEL_IDENTIFIER}} PRIVATE __USE_MINGW_ANSI_STDIO=1)
  target_link_options(${{MODEL_IDENTIFIER}} PRIVATE -static-libgcc)
endif()

if(FMI_PLATFORM)
  # given on the command line
elseif(WIN32)
  if(CMAKE_SIZEOF_VOID_P EQUAL 8)
    set(FMI_PLATFORM win64)
  else()
    set(FMI_PLATFORM win32)
  endif()
elseif(APPLE)
  set(FMI_PLATFORM darwin64)
else()
  set(FMI_PLATFORM linux64)
endif()
set(FMU_BINARIES "${{CMAKE_CURRENT_SOURCE_DIR}}/../binaries/${{FMI_PLATFORM}}")
# $<1:...>: no per-configuration subfolder with multi-configuration generators (Visual Studio, Xcode)
set_target_properties(${{MODEL_IDENTIFIER}} PROPERTIES
  RUNTIME_OUTPUT_DIRECTORY "$<1:${{FMU_BINARIES}}>"
  LIBRARY_OUTPUT_DIRECTORY "$<1:${{FMU_BINARIES}}>")
"""

README = """# Sources of {name}.fmu (flexfmu native runtime)

This FMU's binary is plain C99 (libc, libm, pthreads on POSIX; the Windows API on Windows): no Python. The
model is data (`resources/flexfmu_model.bin`), so the same sources build every native flexfmu FMU of this kind.

| file | what |
|---|---|
| `native_front.c` | the FMI 2.0 front (`flexfmu_fmi2.c`) in its native variant (`FLEXFMU_NATIVE`) |
| `flexfmu_fmi2.c`, `flexfmu_bridge.h` | the FMI 2.0 front: entry points, call-sequence table, logging |
| `flexfmu_fmi3.c` | the FMI 3.0 front: entry points, call-sequence table, logging (the same library serves both) |
| `front_common.c`, `front_common.h` | instance, lock, FMU-state header of both (compiled in `flexfmu_fmi2.c`) |
| `flexfmu_native.c`, `native_kind.h` | the native bridge: model file, variables, checks, FMU states |
| `native_lti.c`, `lti_kernels.c`, `lti_kernels.h` | the lti kind: a clamped body as a parameter-dependent LTI system |
| `derived_stress.c`, `derived_stress.h` | the lti kind's derived outputs: von Mises, a section's largest stresses |
| `native_reframe.c`, `reframe_kernels.c`, `reframe_kernels.h` | the reframe kind: a free body (exponential scheme) |
| `native_wec.c` | the wec kind: the point absorber's wave, float, hydro and PTO (its expm from `lti_kernels.c`) |
| `native_moordyn.c` | the moordyn kind: the Mooring's lines by MoorDyn's library, loaded from `binaries/linux64/` |
| `step_policy.c`, `step_policy.h` | both kinds: a communication step's internal steps, refused beyond max_internal_steps |
| `native_platform.h` | Windows: locks and the library's own path |
| `fmi2Functions.h`, `fmi2FunctionTypes.h`, `fmi2TypesPlatform.h` | the FMI 2.0 headers |
| `fmi3Functions.h`, `fmi3FunctionTypes.h`, `fmi3PlatformTypes.h` | the FMI 3.0 headers |

## Rebuild for another platform

Unzip the FMU, then in its folder (CMake >= 3.13 and a C compiler):

    cmake -S sources -B build -DCMAKE_BUILD_TYPE=Release
    cmake --build build --config Release

The library is written to `binaries/<platform>/` (`win64/{name}.dll`, `darwin64/{name}.dylib`,
`linux64/{name}.so`; `-DFMI_PLATFORM=NAME` for another folder). Zip the folder's content again
(modelDescription.xml at the top) as `{name}.fmu`.

The FMU came with the binaries its build machine could make: `linux64`, and, when its cross compilers were
installed, `win64` (MinGW-w64) and `aarch64-linux` (gcc-aarch64-linux-gnu); `documentation/index.html` says which.
FMI 2.0 names no folder for ARM Linux and its importers there (fmpy, fmusim, FMI Library) load `binaries/linux64`:
on such a machine copy `binaries/aarch64-linux/{name}.so` over `binaries/linux64/{name}.so`, or rebuild (CMake
writes `linux64` on any Linux).

- **Windows (MSVC)**: a "x64 Native Tools Command Prompt for VS" (Visual Studio 2015 or later: C99 designated
  initialisers, `snprintf`), then the two commands above (the Visual Studio generator is the default).
- **macOS**: `xcode-select --install` (clang) and CMake (e.g. `brew install cmake`); on Apple silicon add
  `-DCMAKE_OSX_ARCHITECTURES="arm64;x86_64"` for one library that runs on both (FMI 2.0 names both darwin64).
- **Linux**: gcc or clang; the library links libc, libm, libpthread and libdl only.
- **Cross-compiling** on Debian/Ubuntu (what the FMU's build does): for Windows, `apt-get install
  gcc-mingw-w64-x86-64`, then `cmake -S sources -B build-win64 -DCMAKE_SYSTEM_NAME=Windows
  -DCMAKE_C_COMPILER=x86_64-w64-mingw32-gcc -DCMAKE_BUILD_TYPE=Release`; for ARM Linux, `apt-get install
  gcc-aarch64-linux-gnu`, then `cmake -S sources -B build-arm -DCMAKE_SYSTEM_NAME=Linux
  -DCMAKE_SYSTEM_PROCESSOR=aarch64 -DCMAKE_C_COMPILER=aarch64-linux-gnu-gcc -DFMI_PLATFORM=aarch64-linux
  -DCMAKE_BUILD_TYPE=Release`; each followed by `cmake --build` of its folder.

Without CMake: compile `native_front.c flexfmu_fmi3.c flexfmu_native.c native_kinds.c native_lti.c native_reframe.c
native_wec.c native_moordyn.c lti_kernels.c derived_stress.c reframe_kernels.c step_policy.c` into one shared
library named `{name}` with C99, IEEE arithmetic (no fast-math, no FMA contraction: `-ffp-contract=off`), hidden
symbol visibility (only the fmi2* and fmi3* functions are exported) and libm, e.g.
`cc -std=c99 -O2 -fPIC -shared -fvisibility=hidden -ffp-contract=off -I. native_front.c flexfmu_fmi3.c
flexfmu_native.c native_kinds.c native_lti.c native_reframe.c native_wec.c native_moordyn.c lti_kernels.c
derived_stress.c reframe_kernels.c step_policy.c -o {name}.so -lm -lpthread -ldl`.

Built with flexfmu {version}; model-file format version {format_version}.
"""


# ---------------------------------------------------------------------------------------------- documentation
def _documentation(source: NativeSource, frozen: dict, built=("linux64",), missing=None) -> str:
    """documentation/index.html: the model, the runtime, the frozen and runtime parameters, the variables."""
    info = source.spec.variable_info
    rows = "\n".join(f"<tr><td><code>{html.escape(v)}</code></td><td>{html.escape(info[v][0])}</td>"
                     f"<td>{html.escape(info[v][1])}</td></tr>" for v in info)
    fixed = "\n".join(f"<tr><td><code>{html.escape(k)}</code></td><td><code>{html.escape(repr(v))}</code></td></tr>"
                      for k, v in frozen.items()) or "<tr><td colspan=2>none</td></tr>"
    runtime = ", ".join(f"<code>{html.escape(p.name)}</code>" for p in source.runtime) or "none"
    extra = source.documentation or ""
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(source.name)}</title></head>
<body>
<h1>{html.escape(source.name)}</h1>
<p>{html.escape(source.description)}.</p>
<p>A <b>native</b> flexfmu FMU (FMI 2.0 co-simulation): its binary is C only and needs no Python. The model is
<code>resources/{MODEL_FILE}</code>; <code>sources/</code> holds every C file of the binary and a CMakeLists.txt to
rebuild it for another platform (<code>sources/README.md</code>).</p>
{_platforms_html(source.name, built, missing or dict())}
<h2>Parameters fixed at build</h2>
<p>Another value than these is refused (fmi2Error, naming the parameter); rebuild with
<code>{html.escape(_rebuild_text(source))}</code>.</p>
<table border="1" cellspacing="0" cellpadding="3"><tr><th>parameter</th><th>value</th></tr>
{fixed}
</table>
<p>Settable until fmi2ExitInitializationMode: {runtime}.</p>
{extra}
<h2>Variables</h2>
<table border="1" cellspacing="0" cellpadding="3">
<tr><th>name</th><th>unit</th><th>description</th></tr>
{rows}
</table>
</body></html>
"""


def _platforms_html(name: str, built, missing: dict) -> str:
    """The documentation's paragraph on the binaries this FMU has and those it lacks."""
    from flexfmu.native.compiler import PLATFORMS
    folders = ", ".join(f"<code>binaries/{p.name}/{html.escape(name)}{p.suffix}</code>" for p in PLATFORMS
                        if p.name in built)
    text = f"<p>Binaries: {folders}.</p>"
    if "aarch64-linux" in built:
        text += ("<p>FMI 2.0 names no folder for ARM Linux, and its importers there (fmpy, fmusim, FMI Library) load "
                 "<code>binaries/linux64</code>: on such a machine copy the <code>aarch64-linux</code> library over "
                 "the <code>linux64</code> one, or rebuild from <code>sources/</code>.</p>")
    if missing:
        lacking = "; ".join(f"{html.escape(k)} ({html.escape(v)})" for k, v in missing.items())
        text += (f"<p>Not built, for want of the cross compiler on the machine that built this FMU: {lacking}. "
                 "Rebuild from <code>sources/</code> on that platform.</p>")
    return text


def _rebuild_text(source: NativeSource) -> str:
    return " ".join([source.rebuild, *(f"--set {k}={shlex.quote(v)}" for k, v in source.rebuild_settings.items()),
                     "--set NAME=VALUE"])


# ---------------------------------------------------------------------------------------------- the FMU
def with_interfaces(description: bytes, source: NativeSource, fmi_version: int, types: tuple) -> bytes:
    """The modelDescription ``description`` (co-simulation) with the interface ``types`` ("cs", "me") and, for a kind
    that gives them, directional derivatives (flexfmu.fmi.interfaces)."""
    from flexfmu.fmi import interfaces
    from flexfmu.fmi.variables import table

    directional = source.kind in interfaces.ODE_KINDS
    if types == ("cs",) and not directional:
        return description
    root = ET.fromstring(description)
    complete = interfaces.complete_fmi2 if fmi_version == 2 else interfaces.complete_fmi3
    complete(root, name=source.name, n_vars=len(table(source.spec, source.values)),
             nx=source.lti.nx if "me" in types else 0, types=types, directional=directional,
             nominals=interfaces.state_nominals(source.lti) if "me" in types else None)
    ET.indent(root, "\t")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


def build_native_fmu(source: NativeSource, target, *, fmi_version: int = 2, interface: str = "cs",
                     arrays: bool = False) -> Path:
    """Write the native FMU of ``source`` at ``target`` (NAME.fmu) and check it with fmpy's validation; ``fmi_version``
    3: an FMI 3.0 FMU (flexfmu.fmi.description_fmi3: its modelDescription, platform folders and buildDescription) of
    the same binary; ``interface``: "cs" (co-simulation), "me" (model exchange) or "both" (flexfmu.fmi.interfaces:
    model exchange for the kinds that are ODEs in fixed coordinates); ``arrays`` (FMI 3.0): the Float64 array views
    of flexfmu.fmi.fmi3_arrays (3-vectors, modal coordinates and natural frequencies, gauge tensors, shape
    coordinates q) beside the scalars."""
    from flexfmu.fmi.interfaces import check_interface
    from fmpy.validation import validate_fmu

    from flexfmu import __version__
    from flexfmu.fmi.runtime import RuntimeBuildError
    from flexfmu.native.compiler import PLATFORMS, PlatformsMissingWarning

    target = Path(target)
    guid = "{" + str(uuid.uuid4()) + "}"
    runtime_names = {p.name for p in source.runtime}
    with tempfile.TemporaryDirectory(prefix="flexfmu-native-") as tmp:
        if fmi_version not in (2, 3):
            raise ParameterError("fmi_version", f"got {fmi_version!r}", "2 or 3")
        types = check_interface(source.kind, interface)
        if arrays and fmi_version != 3:
            raise ParameterError("arrays", "FMI 2.0 has no array variables", "fmi_version=3")
        description = model_description(source, guid) if fmi_version == 2 else description_fmi3.model_description(
            source, guid)
        description = with_interfaces(description, source, fmi_version, types)
        entries = model_entries(source, guid)
        if arrays:
            from flexfmu.fmi import fmi3_arrays
            views = fmi3_arrays.source_plan(source, entries)
            description = fmi3_arrays.with_arrays(description, views)
            entries.update(views.entries())
        built = {**dataclasses.asdict(source.spec.config_class()), **source.values}
        frozen = {k: v for k, v in built.items() if k not in runtime_names}
        model_file = write_model_file(Path(tmp) / MODEL_FILE, entries)
        binaries, missing = compile_binaries()
        kind_files = {}
        if source.kind_files is not None:
            binaries, missing, kind_files = source.kind_files(binaries, missing)
        if missing:
            warnings.warn(PlatformsMissingWarning(
                f"{target.name}: built without the binaries for " + "; ".join(
                    f"{k} ({v})" for k, v in missing.items()) + ": the FMU runs on " + ", ".join(binaries)),
                stacklevel=2)
        info = {"version": __version__, "runtime": "native", "model": source.name, "kind": source.kind, "guid": guid,
                "format_version": FORMAT_VERSION, "parameters_fixed": frozen,
                "runtime_parameters": sorted(runtime_names), "platforms": sorted(binaries),
                "interfaces": list(types),
                "platforms_missing": missing, **source.info}
        members = {
            "modelDescription.xml": description,
            **{f"binaries/{p.name}/{source.name}{p.suffix}": binaries[p.name] for p in PLATFORMS if p.name in binaries},
            **kind_files, **{f"resources/{k}": v for k, v in source.resources.items()},
            f"resources/{MODEL_FILE}": model_file.read_bytes(),
            f"resources/{BUILD_INFO}": json.dumps(info, indent=1, default=str).encode(),
            "documentation/index.html": _documentation(source, frozen, binaries, missing).encode(),
            "sources/CMakeLists.txt": CMAKE.format(name=source.name, sources=" ".join((*_FRONT, *_KERNELS))).encode(),
            "sources/README.md": README.format(name=source.name, version=__version__,
                                               format_version=FORMAT_VERSION).encode(),
        }
        for name, path in source_files().items():
            members[f"sources/{name}"] = path.read_bytes()
        if fmi_version == 3:
            members = description_fmi3.fmi3_layout(members, source.name, (*_FRONT, *_KERNELS))
        target.parent.mkdir(parents=True, exist_ok=True)
        archive.write_members(target, members)
    problems = validate_fmu(str(target))
    if problems:
        raise RuntimeBuildError(f"{target}: fmpy validate found problems:\n" + "\n".join(problems))
    return target
