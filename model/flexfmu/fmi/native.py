# Over 500 lines on purpose: one job, a native FMU, whose parts (model file, modelDescription, model entries, binary,
# sources, documentation) are each a short function over the same NativeSource; the format spec is its docstring.
"""Native FMUs: an FMI 2.0 co-simulation FMU whose binary is C only (no Python in the host), built from an FMU spec
and a configuration (``flexfmu build --runtime native``) or from an exported body, clamped or free (``flexfmu
export ... --runtime native``).

The binary is the same front as the Python FMUs' (csrc/flexfmu_fmi2.c: entry points, call-sequence table, FMU-state
header, logging) compiled in its native variant and linked statically with the native bridge (csrc/flexfmu_native.c:
variables, checks, time, FMU states) and a model kind (csrc/native_lti.c on flexfmu/native/csrc/lti_kernels.c for
clamped bodies; csrc/native_reframe.c on flexfmu/native/csrc/reframe_kernels.c for free ones).  Everything about the model is data, in ``resources/flexfmu_model.bin`` (format below); the
modelDescription comes from the same source as the Python FMU's (a pythonfmu slave over flexfmu.fmi.plumbing for
the same spec, completed by flexfmu.fmi.build), so the variables, value references, units, descriptions and the
DefaultExperiment are the Python FMU's.  What differs: parameters that shape the model (FFRBeam's scene, boundary,
mesh, modes, ...) are fixed at build (their start value is the build value; another value is refused naming the
rebuild command); runtime parameters (damping_ratio, max_internal_steps, internal_step) stay settable until
fmi2ExitInitializationMode.

Layout of a native FMU:

    modelDescription.xml          needsExecutionTool="false", SourceFiles listed
    binaries/linux64/<id>.so      compiled here with the system C compiler (flexfmu.native.compiler)
    resources/flexfmu_model.bin   the model (below)
    resources/flexfmu_build.json  flexfmu version, runtime "native", model, kind, GUID, the parameters frozen
    sources/                      every C source and header of the binary, fmi2 headers, CMakeLists.txt, README.md
    documentation/index.html      the model, the frozen parameters, the variables, how to rebuild

Model file format (version FORMAT_VERSION = 1; little-endian throughout)::

    offset 0   16 bytes   magic b"flexfmu-native\\n\\0"
           16  u32        format version: a runtime that reads another version refuses the file, naming both
           20  u32        number of entries N
    N entries, each:
               u16        name length L, then L bytes: the name (UTF-8)
               u8         type: 1 float64, 2 int32, 3 string (UTF-8)
               u8         dimensions D (0 = a scalar, at most 8)
               D x u32    shape
               data       prod(shape) elements (1 for a scalar), row-major: float64 8 bytes, int32 4 bytes, a string
                          u32 length then its bytes
    nothing after the last entry.

Entries every native FMU has (read by csrc/flexfmu_native.c):

    kind, model, guid               strings: the model kind ("lti"), the model identifier, the GUID (checked
                                    against the host's fmuGUID at fmi2Instantiate)
    var.name, var.start_string      strings (n_vars), in value-reference order; start_string: a String's value
    var.type                        int32 (n_vars): 0 Real, 1 Integer, 2 Boolean, 3 String
    var.causality                   int32 (n_vars): 0 parameter, 1 input, 2 output
    var.index                       int32 (n_vars): position among the inputs / outputs / runtime parameters;
                                    -1 for a parameter fixed at build
    var.start                       float64 (n_vars): start (build) value of Real / Integer / Boolean variables
    param.lo, param.hi              float64 (n_params): the allowed range of each runtime parameter
    param.flags                     int32 (n_params): 1 lo open, 2 hi open, 4 integer, 8 has a special value
    param.special, param.replacement float64 (n_params): the special value (e.g. damping_ratio = -1) and the value
                                    the model gets for it (the body's own damping ratio)
    param.allowed                   strings (n_params): what is allowed, as the Python FMU's message says it
    divergence_limit                float64: the largest |state| entry before a step is refused (inf: none)
    divergence_allowed              string: the "allowed" text of that refusal
    rebuild                         string: the command that rebuilds the FMU (without --set options)
    rebuild.names, rebuild.values   strings: the fixed parameters built with other than their defaults and their
                                    values (shell-quoted): the refusal of another value names the command with
                                    these and the new NAME=VALUE
    messages                        strings: logged (status OK) at fmi2ExitInitializationMode
    outputs.deferred                int32 (n_deferred): the outputs (their index among the outputs) computed only
                                    when one of them is read, as the Python FMU's (the spec's deferred_outputs,
                                    flexfmu.fmi.plumbing: e.g. max_elastic_displacement, a search over the mesh);
                                    the others are computed at the first read after a step without them; absent:
                                    none

and the kind's entries, ``<kind>.*`` (the LTI kind's: csrc/native_lti.c's header comment).
"""
from __future__ import annotations

import dataclasses
import hashlib
import html
import json
import math
import shlex
import struct
import tempfile
import threading
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.fmi import archive

HERE = Path(__file__).resolve().parent
FMI_CSRC = HERE / "csrc"
MODEL_FILE = "flexfmu_model.bin"
BUILD_INFO = "flexfmu_build.json"
MAGIC = b"flexfmu-native\n\x00"
FORMAT_VERSION = 1
F64, I32, STR = 1, 2, 3
TYPES = {"Real": 0, "Integer": 1, "Boolean": 2, "String": 3}
CAUSALITIES = {"parameter": 0, "input": 1, "output": 2}
LO_OPEN, HI_OPEN, INTEGER, SPECIAL = 1, 2, 4, 8
#: the C sources of a native FMU of the LTI kind: (folder, file) — compiled in this order, shipped in sources/
_FRONT = ("native_front.c", "flexfmu_native.c", "native_lti.c", "native_reframe.c")
_FRONT_HEADERS = ("flexfmu_fmi2.c", "flexfmu_bridge.h", "native_kind.h", "native_platform.h")
_KERNELS = ("lti_kernels.c", "reframe_kernels.c", "step_policy.c")
_KERNEL_HEADERS = ("lti_kernels.h", "reframe_kernels.h", "step_policy.h")
_FMI2_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
#: FMU specs with a native form (flexfmu.fmi.registry names), and why the others have none yet
NATIVE_FMUS = ("FFRBeam", "ReframeBody")
NOT_YET: dict = {}


# ---------------------------------------------------------------------------------------------- the model file
def _encode(name: str, value) -> bytes:
    """One entry: name, type, shape, data (module docstring)."""
    key = name.encode("utf-8")
    if len(key) >= 1 << 16:
        raise ParameterError("entry", f"name {name[:40]!r}... too long", "< 65536 bytes")
    if isinstance(value, str) or (isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value)):
        items = [value] if isinstance(value, str) else list(value)
        shape = () if isinstance(value, str) else (len(items),)
        data = b"".join(struct.pack("<I", len(b)) + b for b in (s.encode("utf-8") for s in items))
        kind = STR
    else:
        array = np.asarray(value)
        if array.dtype.kind in "iub":
            if array.size and (array.min() < -2**31 or array.max() >= 2**31):
                raise ParameterError(name, "integers beyond int32", "int32 values")
            array, kind = np.array(array, dtype="<i4", order="C"), I32   # (ascontiguousarray makes 0-d 1-d)
        elif array.dtype.kind == "f":
            array, kind = np.array(array, dtype="<f8", order="C"), F64
        else:
            raise ParameterError(name, f"dtype {array.dtype}", "float64, int32 or strings")
        shape, data = array.shape, array.tobytes()
    if len(shape) > 8:
        raise ParameterError(name, f"{len(shape)} dimensions", "at most 8")
    return (struct.pack("<H", len(key)) + key + struct.pack("<BB", kind, len(shape))
            + b"".join(struct.pack("<I", n) for n in shape) + data)


def write_model_file(path, entries: dict) -> Path:
    """resources/flexfmu_model.bin from {name: float64/int32 array or scalar, str, or list of str}."""
    body = b"".join(_encode(name, value) for name, value in entries.items())
    path = Path(path)
    path.write_bytes(MAGIC + struct.pack("<II", FORMAT_VERSION, len(entries)) + body)
    return path


def read_model_file(path) -> dict:
    """The entries of a model file (numpy arrays, str, or lists of str); ParameterError naming what is wrong."""
    data = Path(path).read_bytes()
    if data[:16] != MAGIC:
        raise ParameterError(str(path), "not a flexfmu native model file (bad magic)")
    version, n = struct.unpack_from("<II", data, 16)
    if version != FORMAT_VERSION:
        raise ParameterError(str(path), f"model-file format version {version}", f"version {FORMAT_VERSION}")
    at, out = 24, {}
    for _ in range(n):
        (length,) = struct.unpack_from("<H", data, at)
        name = data[at + 2:at + 2 + length].decode("utf-8")
        at += 2 + length
        kind, ndim = struct.unpack_from("<BB", data, at)
        at += 2
        shape = struct.unpack_from(f"<{ndim}I", data, at)
        at += 4 * ndim
        count = int(np.prod(shape)) if ndim else 1
        if kind == STR:
            items = []
            for _ in range(count):
                (size,) = struct.unpack_from("<I", data, at)
                items.append(data[at + 4:at + 4 + size].decode("utf-8"))
                at += 4 + size
            out[name] = items[0] if ndim == 0 else items
        else:
            dtype = "<f8" if kind == F64 else "<i4"
            width = 8 if kind == F64 else 4
            array = np.frombuffer(data, dtype=dtype, count=count, offset=at).reshape(shape)
            at += width * count
            out[name] = array.copy()
    if at != len(data):
        raise ParameterError(str(path), f"{len(data) - at} bytes after the last entry", "none")
    return out


# ---------------------------------------------------------------------------------------------- what is built
@dataclass(frozen=True)
class RuntimeParameter:
    """A parameter settable until fmi2ExitInitializationMode, checked there as the Python FMU checks it: a finite
    number in [lo, hi] (ends open if asked; integers for Integer variables), or the special value, which the
    model gets as ``replacement``."""

    name: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    allowed: str = "a finite number"
    special: float | None = None
    replacement: float = math.nan

    @property
    def flags(self) -> int:
        return (LO_OPEN * self.lo_open | HI_OPEN * self.hi_open | SPECIAL * (self.special is not None))


def _max_internal_steps() -> RuntimeParameter:
    from flexfmu.core.checks import DEFAULT_MAX_INTERNAL_STEPS, MAX_INTERNAL_STEPS_RANGE
    lo, hi = MAX_INTERNAL_STEPS_RANGE
    return RuntimeParameter("max_internal_steps", lo, hi,
                            allowed=f"an integer {lo} .. {hi:.0e} (default {DEFAULT_MAX_INTERNAL_STEPS})")


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
    """A pythonfmu slave over flexfmu.fmi.plumbing for the source's spec (the Python FMU's class, made here), its
    parameters at the build values."""
    from pythonfmu import Fmi2Slave

    from flexfmu.fmi.plumbing import Plumbing

    spec = source.spec

    def __init__(self, **kwargs):
        Fmi2Slave.__init__(self, **kwargs)
        self.fmu = Plumbing(self, spec)

    cls = type(source.name, (Fmi2Slave,), {"author": "flexfmu", "description": source.description,
                                           "__init__": __init__, "do_step": lambda self, t, h: True})
    slave = cls(instance_name="native-build", resources=str(resources))
    unknown = set(source.values) - set(slave.fmu._values)
    if unknown:
        raise ParameterError(sorted(unknown)[0], "not a parameter of this FMU", ", ".join(slave.fmu._values))
    slave.fmu._values.update(source.values)
    return slave


def model_description(source: NativeSource, guid: str, slave) -> bytes:
    """modelDescription.xml: pythonfmu's of the slave, completed as the Python FMUs' (flexfmu.fmi.build), with the
    native runtime's capabilities and source files."""
    from flexfmu import __version__
    from flexfmu.fmi.build import _complete_model_description

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
def model_entries(source: NativeSource, guid: str, slave) -> dict:
    """The model file's entries (module docstring; the LTI kind's: csrc/native_lti.c)."""
    from pythonfmu import Boolean, Fmi2Causality, Integer, Real, String

    plumbing = slave.fmu
    variables = [plumbing._variables[vr] for vr in sorted(plumbing._variables)]
    type_of = {Real: "Real", Integer: "Integer", Boolean: "Boolean", String: "String"}
    runtime = {p.name: p for p in source.runtime}
    params = [v.name for v in variables if v.causality == Fmi2Causality.parameter and v.name in runtime]
    inputs, outputs = list(plumbing.input_names), list(plumbing.output_names)
    names, types, causalities, index, start, texts = [], [], [], [], [], []
    for v in variables:
        kind = type_of[type(v)]
        causality = {Fmi2Causality.parameter: "parameter", Fmi2Causality.input: "input",
                     Fmi2Causality.output: "output"}[v.causality]
        if causality == "parameter" and v.name in runtime and kind == "String":
            raise ParameterError(v.name, "a String parameter cannot stay settable in a native FMU",
                                 "fixed at build")
        names.append(v.name)
        types.append(TYPES[kind])
        causalities.append(CAUSALITIES[causality])
        index.append(params.index(v.name) if v.name in params else inputs.index(v.name) if causality == "input"
                     else outputs.index(v.name) if causality == "output" else -1)
        value = plumbing._values.get(v.name, 0.0) if causality == "parameter" else 0.0
        start.append(0.0 if kind == "String" else float(value))
        texts.append(str(value) if kind == "String" else "")
    rules = [runtime[name] for name in params]
    for rule in rules:
        if rule.special is not None and not math.isfinite(rule.replacement):
            raise ParameterError(rule.name, "a special value without a finite replacement")
    entries = {
        "kind": source.kind, "model": source.name, "guid": guid,
        "var.name": names, "var.type": np.array(types, np.int32), "var.causality": np.array(causalities, np.int32),
        "var.index": np.array(index, np.int32), "var.start": np.array(start, float), "var.start_string": texts,
        "param.lo": np.array([r.lo for r in rules], float), "param.hi": np.array([r.hi for r in rules], float),
        "param.flags": np.array([r.flags | INTEGER * (types[names.index(r.name)] == TYPES["Integer"])
                                 for r in rules], np.int32),
        "param.special": np.array([r.special if r.special is not None else 0.0 for r in rules], float),
        "param.replacement": np.array([r.replacement if r.special is not None else 0.0 for r in rules], float),
        "param.allowed": [r.allowed for r in rules],
        "divergence_limit": np.float64(source.divergence_limit),
        "divergence_allowed": source.divergence_allowed,
        "rebuild": source.rebuild,
        "rebuild.names": list(source.rebuild_settings),
        "rebuild.values": [shlex.quote(v) for v in source.rebuild_settings.values()],
        "messages": [str(m) for m in source.messages],
        "outputs.deferred": np.array([outputs.index(name) for name in getattr(source.spec, "deferred_outputs", ())],
                                     np.int32),
    }
    if source.kind == "lti":
        entries.update(_lti_entries(source.lti, inputs, outputs, params, source))
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
        "lti.log_split": np.int32(1 if source.log_split else 0),
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
    files.update({name: _fmi2_headers() / name for name in _FMI2_HEADERS})
    return files


def compile_binary() -> bytes:
    """The shared library of the LTI kind, compiled once per process and source digest with the system C compiler
    (flexfmu.native.compiler: IEEE flags, no fast-math)."""
    import platform
    import sys

    from flexfmu.fmi.runtime import RuntimeBuildError
    from flexfmu.native.compiler import KERNEL_FLAGS, compile_shared
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise RuntimeBuildError(f"native FMUs are built with a linux64 binary, not on {sys.platform}/"
                                f"{platform.machine()}: build the FMU on Linux x86-64, then rebuild its binary for "
                                "this platform from its sources/ (docs/fmu.md, 'Native runtime')")
    files = source_files()
    digest = hashlib.sha256(" ".join(KERNEL_FLAGS).encode())
    for name in sorted(files):
        digest.update(name.encode() + files[name].read_bytes())
    key = digest.hexdigest()
    with _COMPILE_LOCK:
        if key not in _COMPILED:
            with tempfile.TemporaryDirectory(prefix="flexfmu-native-") as tmp:
                out = compile_shared([files[n] for n in (*_FRONT, *_KERNELS)], Path(tmp) / "fmu.so",
                                     include_dirs=(FMI_CSRC, _fmi2_headers()),
                                     extra_flags=("-fvisibility=hidden", "-Wno-format-truncation"),
                                     libraries=("m", "pthread", "dl"))
                _COMPILED[key] = out.read_bytes()
        return _COMPILED[key]


CMAKE = """# Rebuild the binary of this native FMU for your platform (README.md beside this file):
#   cmake -S sources -B build -DCMAKE_BUILD_TYPE=Release
#   cmake --build build --config Release
# run in the unzipped FMU's folder: the library lands in binaries/<platform>/ (win64, darwin64, linux64).
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

if(WIN32)
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
| `flexfmu_fmi2.c`, `flexfmu_bridge.h` | the front: entry points, call-sequence table, FMU-state header, logging |
| `flexfmu_native.c`, `native_kind.h` | the native bridge: model file, variables, checks, FMU states |
| `native_lti.c`, `lti_kernels.c`, `lti_kernels.h` | the lti kind: a clamped body as a parameter-dependent LTI system |
| `native_reframe.c`, `reframe_kernels.c`, `reframe_kernels.h` | the reframe kind: a free body (exponential scheme) |
| `step_policy.c`, `step_policy.h` | both kinds: a communication step's internal steps, refused beyond max_internal_steps |
| `native_platform.h` | Windows: locks and the library's own path |
| `fmi2Functions.h`, `fmi2FunctionTypes.h`, `fmi2TypesPlatform.h` | the FMI 2.0 headers |

## Rebuild for another platform

Unzip the FMU, then in its folder (CMake >= 3.13 and a C compiler):

    cmake -S sources -B build -DCMAKE_BUILD_TYPE=Release
    cmake --build build --config Release

The library is written to `binaries/<platform>/` (`win64/{name}.dll`, `darwin64/{name}.dylib`,
`linux64/{name}.so`). Zip the folder's content again (modelDescription.xml at the top) as `{name}.fmu`.

- **Windows (MSVC)**: a "x64 Native Tools Command Prompt for VS" (Visual Studio 2015 or later: C99 designated
  initialisers, `snprintf`), then the two commands above (the Visual Studio generator is the default).
- **macOS**: `xcode-select --install` (clang) and CMake (e.g. `brew install cmake`); on Apple silicon add
  `-DCMAKE_OSX_ARCHITECTURES="arm64;x86_64"` for one library that runs on both (FMI 2.0 names both darwin64).
- **Linux**: gcc or clang; the library links libc, libm, libpthread and libdl only.

Without CMake: compile `native_front.c flexfmu_native.c native_lti.c native_reframe.c lti_kernels.c
reframe_kernels.c step_policy.c` into one shared library
named `{name}` with C99, IEEE arithmetic (no fast-math, no FMA contraction: `-ffp-contract=off`), hidden
symbol visibility (only the fmi2* functions are exported) and libm, e.g.
`cc -std=c99 -O2 -fPIC -shared -fvisibility=hidden -ffp-contract=off -I. native_front.c flexfmu_native.c
native_lti.c native_reframe.c lti_kernels.c reframe_kernels.c step_policy.c -o {name}.so -lm -lpthread -ldl`.

Built with flexfmu {version}; model-file format version {format_version}.
"""


# ---------------------------------------------------------------------------------------------- documentation
def _documentation(source: NativeSource, frozen: dict) -> str:
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
rebuild it for Windows or macOS (<code>sources/README.md</code>).</p>
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


def _rebuild_text(source: NativeSource) -> str:
    return " ".join([source.rebuild, *(f"--set {k}={shlex.quote(v)}" for k, v in source.rebuild_settings.items()),
                     "--set NAME=VALUE"])


# ---------------------------------------------------------------------------------------------- the FMU
def build_native_fmu(source: NativeSource, target) -> Path:
    """Write the native FMU of ``source`` at ``target`` (NAME.fmu) and check it with fmpy's validation."""
    from fmpy.validation import validate_fmu

    from flexfmu import __version__
    from flexfmu.fmi.runtime import RuntimeBuildError

    target = Path(target)
    guid = "{" + str(uuid.uuid4()) + "}"
    runtime_names = {p.name for p in source.runtime}
    with tempfile.TemporaryDirectory(prefix="flexfmu-native-") as tmp:
        slave = _slave(source, Path(tmp))
        description = model_description(source, guid, slave)
        entries = model_entries(source, guid, slave)
        frozen = {k: v for k, v in slave.fmu._values.items() if k not in runtime_names}
        model_file = write_model_file(Path(tmp) / MODEL_FILE, entries)
        binary = compile_binary()
        info = {"version": __version__, "runtime": "native", "model": source.name, "kind": source.kind, "guid": guid,
                "format_version": FORMAT_VERSION, "parameters_fixed": frozen,
                "runtime_parameters": sorted(runtime_names), **source.info}
        members = {
            "modelDescription.xml": description,
            f"binaries/linux64/{source.name}.so": binary,
            f"resources/{MODEL_FILE}": model_file.read_bytes(),
            f"resources/{BUILD_INFO}": json.dumps(info, indent=1, default=str).encode(),
            "documentation/index.html": _documentation(source, frozen).encode(),
            "sources/CMakeLists.txt": CMAKE.format(name=source.name, sources=" ".join((*_FRONT, *_KERNELS))).encode(),
            "sources/README.md": README.format(name=source.name, version=__version__,
                                               format_version=FORMAT_VERSION).encode(),
        }
        for name, path in source_files().items():
            members[f"sources/{name}"] = path.read_bytes()
        target.parent.mkdir(parents=True, exist_ok=True)
        archive.write_members(target, members)
    problems = validate_fmu(str(target))
    if problems:
        raise RuntimeBuildError(f"{target}: fmpy validate found problems:\n" + "\n".join(problems))
    return target


# ---------------------------------------------------------------------------------------------- FFRBeam
def _parse_value(name: str, text, default):
    """A --set value as the config field's type (that of its default)."""
    if not isinstance(text, str):
        return text
    try:
        if isinstance(default, bool):
            lowered = text.strip().lower()
            if lowered not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return lowered in ("true", "1")
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
    except ValueError:
        raise ParameterError(name, f"got {text!r}", f"a {type(default).__name__}") from None
    return text


def registry_source(name: str = "FFRBeam", settings: dict | None = None, *, model_name: str | None = None
                    ) -> NativeSource:
    """The native source of the registry FMU ``name`` with the parameters ``settings`` {name: value or text} (the
    rest at their defaults); ParameterError for an FMU without a native form or a configuration it cannot have."""
    from flexfmu.fmi import registry
    from flexfmu.fmi.body_fmu import check_model_identifier

    if name not in registry.BY_NAME:
        raise ParameterError("fmu", f"got {name!r}", " | ".join(registry.BY_NAME))
    if name not in NATIVE_FMUS:
        why = NOT_YET.get(name, "the native runtime has its kinds only for clamped bodies")
        raise ParameterError("runtime", f"{name} has no native form yet ({why})",
                             f"--runtime python for {name}; --runtime native for {', '.join(NATIVE_FMUS)}")
    spec = registry.BY_NAME[name]
    model_name = check_model_identifier(model_name or name)
    defaults = dataclasses.asdict(spec.config_class())
    values = dict(defaults)
    for key, text in (settings or {}).items():
        if key not in defaults:
            raise ParameterError(key, "not a parameter of " + name, ", ".join(defaults))
        values[key] = _parse_value(key, text, defaults[key])
    if name == "ReframeBody":
        return _reframe_source(spec, values, defaults, model_name)
    return _ffrbeam_source(spec, values, defaults, model_name)


def _ffrbeam_source(spec, values: dict, defaults: dict, model_name: str) -> NativeSource:
    from flexfmu.ffr import simulator as ffr
    from flexfmu.native.lti import LtiModel

    config = spec.config_class(**values)
    sim = ffr.FFRBeamSimulator(config)
    lti = LtiModel.from_ffrbeam(sim)
    # the modes chosen for n_modes = -1 depend on the damping ratio (the truncation estimate): then it is fixed too
    runtime = [_max_internal_steps()]
    if config.n_modes != -1:
        runtime.insert(0, RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True, allowed="0 <= damping_ratio < 1"))
    settings = {k: _cli_text(v) for k, v in values.items() if v != defaults[k] and k not in {p.name for p in runtime}}
    rebuild = f"flexfmu build --runtime native --fmu {spec.name}" + (f" --name {model_name}"
                                                                     if model_name != spec.name else "")
    return NativeSource(
        name=model_name, description=spec.description, spec=spec, values=values, runtime=tuple(runtime), lti=lti,
        experiment=dict(spec.experiment), messages=list(sim.messages), divergence_limit=ffr._DIVERGENCE_LIMIT,
        divergence_allowed="inputs within the linear model's range; spin below the first bending frequency",
        rebuild=rebuild, rebuild_settings=settings,
        info={"source": f"flexfmu.fmi.registry {spec.name}", "fit_error": lti.fit_error})


#: the reframe kind's runtime-parameter roles (csrc/native_reframe.c, reframe.role)
_REFRAME_ROLES = ("damping_ratio", "tolerance", "internal_step", "max_internal_steps", "v0_x", "v0_y", "v0_z",
                  "omega0_1", "omega0_2", "omega0_3", "force_follows_body")


def _reframe_source(spec, values: dict, defaults: dict, model_name: str) -> NativeSource:
    """ReframeBody (scheme "exponential") as the reframe kind (csrc/native_reframe.c): the arrays its Python
    simulator passes to the kernels, written once; the model (model, n_flexible_modes, f_max, the load and output
    points, scheme) fixed at build; damping_ratio and tolerance too when n_flexible_modes = -1 (the modes chosen
    depend on them)."""
    from flexfmu.reframe import simulator as rs
    from flexfmu.reframe.schemes import scheme_class

    config = spec.config_class(**values)
    # ReframeBody's model file has no scheme entry (reframe.body is an exported free body's): C steps code 0
    scheme_class(config.scheme, lambda s: s.native_code == 0, context="native: ",
                 hint=", the scheme the native ReframeBody steps (--runtime python for the others)")
    sim = rs.ReframeBodySimulator(config)
    integ = sim.integrator
    nf = integ.data.nf
    auto = config.n_flexible_modes == -1
    omega = np.sqrt(integ._kF)
    finite = "a finite number"
    lo, hi = rs.TOLERANCE_RANGE
    runtime = [RuntimeParameter("internal_step", 0.0, allowed="0 (automatic) or a step > 0 s"),
               _max_internal_steps(),
               *(RuntimeParameter(n, allowed=finite) for n in rs._INITIAL),
               RuntimeParameter("force_follows_body")]
    if not auto:
        # damping enters the kernels only as c_F = 2 zeta omega (flexfmu.linalg.modal_basis): recomputed at run time
        zeta = float(config.damping_ratio)
        if np.array_equal(integ._cF, 2.0 * np.full(nf, zeta) * omega):
            runtime.insert(0, RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True,
                                               allowed="0 <= damping_ratio < 1"))
        runtime.insert(1, RuntimeParameter("tolerance", lo, hi, hi_open=True,
                                           allowed=f"{lo:g} <= tolerance < {hi:g} (relative)"))
    names = {p.name for p in runtime}
    settings = {k: _cli_text(v) for k, v in values.items() if v != defaults[k] and k not in names}
    rebuild = f"flexfmu build --runtime native --fmu {spec.name}" + (f" --name {model_name}"
                                                                     if model_name != spec.name else "")
    order, bc, br, sc, sr = integ._umax
    LP = np.array(integ._kernel_loads(sim._loads), dtype=float)
    PP = np.array(integ._point_data(sim._points), dtype=float).reshape(1, 3 + 3 * nf)

    def entries(inputs, outputs, params):
        if list(inputs) != list(rs.INPUT_NAMES):
            raise ParameterError("reframe", "the FMU's inputs are not ReframeBody's", ", ".join(rs.INPUT_NAMES))
        columns = [int(sim._columns[rs.OUTPUT_NAMES.index(name)]) for name in outputs]
        return {
            "reframe.P": np.array(integ._P, dtype=float), "reframe.LP": LP, "reframe.PP": PP,
            "reframe.omega": omega, "reframe.Psi": np.ascontiguousarray(integ._Psi_c),
            "reframe.order": np.asarray(order, np.int32), "reframe.bc": bc, "reframe.br": br,
            "reframe.sc": sc, "reframe.sr": sr,
            "reframe.int": np.array([nf, integ.data.dpn, int(integ.deformed_load_arm), int(sim._accepts_moment), 1, 0],
                                    np.int32),
            "reframe.real": np.array([sim._arm, sim._J_min, sim._size, integ.data.mass], float),
            "reframe.columns": np.array(columns, np.int32),
            "reframe.role": np.array([params.index(n) if n in params else -1 for n in _REFRAME_ROLES], np.int32),
            "reframe.fixed": np.array([float(getattr(config, n)) for n in _REFRAME_ROLES], float),
        }

    return NativeSource(
        name=model_name, description=spec.description, spec=spec, values=values, runtime=tuple(runtime), lti=None,
        experiment=dict(spec.experiment), kind="reframe", kind_entries=entries, messages=list(sim.messages),
        rebuild=rebuild, rebuild_settings=settings, info={"source": f"flexfmu.fmi.registry {spec.name}"})


def _cli_text(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def build_registry_fmu(name: str = "FFRBeam", settings: dict | None = None, *, out=None, target=None,
                       model_name: str | None = None) -> Path:
    """``flexfmu build --runtime native``: the native FMU of the registry entry ``name`` into ``target`` (default
    ``out``/<model name>.fmu)."""
    source = registry_source(name, settings, model_name=model_name)
    if target is None:
        target = Path(out or "dist") / f"{source.name}.fmu"
    return build_native_fmu(source, target)


# ---------------------------------------------------------------------------------------------- exported bodies
def body_source(body, name: str, description: str | None = None, *, scheme: str = "exponential") -> NativeSource:
    """The native source of an exported body (flexfmu.body.FlexBody): a clamped one as the LTI kind, a free one as
    the reframe kind (:func:`_free_body_source`, its ``scheme`` fixed at build)."""
    from flexfmu.body.simulator import FlexBodySimulator, config_class
    from flexfmu.fmi.body_fmu import ExportedSpec, check_model_identifier, default_experiment, documentation_html
    from flexfmu.native.lti import LtiModel

    check_model_identifier(name)
    if body.kind != "clamped":
        return _free_body_source(body, name, description, scheme)
    description = description or body.summary()
    spec = ExportedSpec(name, description, body)
    config = config_class(body)()
    sim = FlexBodySimulator(body, config)
    lti = LtiModel.from_clamped_body(sim)
    zeta = float(body.damping_ratio)
    runtime = (RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True, special=-1.0, replacement=zeta,
                                allowed="-1 (the body's) or 0 <= damping_ratio < 1"),
               RuntimeParameter("internal_step", 0.0, allowed="0 (automatic) or a step > 0 s"),
               _max_internal_steps())
    page = documentation_html(name, body)
    summary = page[page.index("<h2>Model, source and reduction</h2>"):page.index("<h2>Variables</h2>")]
    return NativeSource(
        name=name, description=description, spec=spec, values=dataclasses.asdict(config), runtime=runtime, lti=lti,
        experiment=default_experiment(body), messages=[f"model: {body.summary()}", *body.messages],
        rebuild=f"flexfmu export MODEL -o {name}.fmu ... --runtime native", log_split=True, documentation=summary,
        info={"source": body.summary(), "fit_error": lti.fit_error})


def _free_body_source(body, name: str, description: str | None, scheme: str) -> NativeSource:
    """An exported free body as the reframe kind (csrc/native_reframe.c, its free-body entries): the arrays of
    its FlexBodySimulator's FreeDynamics written once, one load and one output point per interface, the outputs
    by the simulator's own columns plus the global frame vectors and the frequencies; ``scheme`` fixed at build,
    the other parameters settable."""
    from flexfmu.body.simulator import TOLERANCE_RANGE, FlexBodySimulator, _INITIAL, config_class
    from flexfmu.fmi.body_fmu import ExportedSpec, default_experiment, documentation_html
    from flexfmu.reframe.schemes import scheme_class

    code = scheme_class(scheme, lambda s: s.for_bodies and s.native_code is not None, context="native: ",
                        hint=", the free-body schemes with a native form").native_code
    description = description or body.summary()
    spec = ExportedSpec(name, description, body)
    config = config_class(body)(scheme=scheme)
    sim = FlexBodySimulator(body, config)
    engine, dyn = sim.engine, sim.engine.dyn
    nf = dyn.nf
    zeta = float(body.damping_ratio)
    lo, hi = TOLERANCE_RANGE
    runtime = (RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True, special=-1.0, replacement=zeta,
                                allowed="-1 (the body's) or 0 <= damping_ratio < 1"),
               RuntimeParameter("tolerance", lo, hi, hi_open=True, allowed=f"{lo:g} <= tolerance < {hi:g}"),
               RuntimeParameter("internal_step", 0.0, allowed="0 (automatic) or a step > 0 s"),
               _max_internal_steps(),
               *(RuntimeParameter(n, allowed="a finite number") for n in _INITIAL))
    order, bc, br, sc, sr = dyn.umax
    n_direct = len(sim._columns)
    first, loads = 0, []
    for moments in engine.moments:
        loads.append([first, 6 if moments else 3])
        first += loads[-1][1]
    limit = engine.limit                         # RK4_STABILITY_LIMIT / omega_max (consistent), else inf

    def entries(inputs, outputs, params):
        if list(inputs) != list(sim.input_names):
            raise ParameterError("reframe", "the FMU's inputs are not the body's", ", ".join(sim.input_names))
        columns = []
        for out in outputs:
            k = sim.output_names.index(out)
            columns.append(int(sim._columns[k]) if k < n_direct else -1 - (k - n_direct))
        return {
            "reframe.P": np.array(dyn.P, dtype=float), "reframe.LP": np.array(dyn.LP, dtype=float),
            "reframe.PP": np.array(dyn.PP, dtype=float).reshape(dyn.n_if, 3 + 3 * nf),
            "reframe.omega": np.sqrt(np.maximum(dyn.kF, 0.0)), "reframe.Psi": np.ascontiguousarray(dyn.Psi),
            "reframe.order": np.asarray(order, np.int32), "reframe.bc": bc, "reframe.br": br,
            "reframe.sc": sc, "reframe.sr": sr,
            "reframe.int": np.array([nf, 3, int(dyn.deformed), 1, 1, 0], np.int32),
            "reframe.real": np.array([0.0, 1.0, 0.0, dyn.mass], float),     # (arm, J_min, size: ReframeBody's)
            "reframe.columns": np.array(columns, np.int32),
            "reframe.role": np.array([params.index(n) if n in params else -1 for n in _REFRAME_ROLES], np.int32),
            "reframe.fixed": np.array([float(getattr(config, n)) if hasattr(config, n) else 0.0
                                       for n in _REFRAME_ROLES], float),
            "reframe.body": np.array([1, code, dyn.n_if, 0], np.int32),
            "reframe.loads": np.array(loads, np.int32).reshape(dyn.n_if, 2),
            "reframe.limit": np.array([limit], float),
            "reframe.extra": np.asarray(sim._f, float).reshape(-1),
        }

    page = documentation_html(name, body)
    summary = page[page.index("<h2>Model, source and reduction</h2>"):page.index("<h2>Variables</h2>")]
    return NativeSource(
        name=name, description=description, spec=spec, values=dataclasses.asdict(config), runtime=runtime, lti=None,
        experiment=default_experiment(body), kind="reframe", kind_entries=entries, messages=list(sim.messages),
        rebuild=f"flexfmu export MODEL -o {name}.fmu ... --runtime native", log_split=True, documentation=summary,
        info={"source": body.summary(), "scheme": scheme})


def export_native(body, target, *, description: str | None = None, scheme: str = "exponential") -> Path:
    """``flexfmu export ... --runtime native``: the native FMU of a clamped or free body at ``target`` (NAME.fmu);
    ``scheme``: a free body's, fixed at build."""
    from flexfmu.fmi.body_fmu import check_target
    name = check_target(target)
    return build_native_fmu(body_source(body, name, description, scheme=scheme), target)
