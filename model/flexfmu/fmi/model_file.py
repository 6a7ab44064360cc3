"""The model file, ``resources/flexfmu_model.bin``: what the one FMU runtime (csrc/flexfmu_native.c) reads on each
fmi2Instantiate, for every FMU whatever its kind: the variables in value-reference order (from
flexfmu.fmi.variables, as the modelDescription), the runtime parameters' checks, the GUID, and the kind's own entries
(flexfmu.fmi.native writes the native kinds'; a Python FMU's file has none, flexfmu.fmi.build).

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

Entries every model file has (read by csrc/flexfmu_native.c):

    kind, model, guid               strings: the model kind ("lti", "reframe", "python"), the model identifier, the GUID (checked
                                    against the host's fmuGUID at fmi2Instantiate)
    var.name, var.start_string      strings (n_vars), in value-reference order; start_string: a String's value
    var.type                        int32 (n_vars): 0 Real, 1 Integer, 2 Boolean, 3 String
    var.causality                   int32 (n_vars): 0 parameter, 1 input, 2 output
    var.index                       int32 (n_vars): position among the inputs / outputs / runtime parameters;
                                    -1 for a parameter fixed at build (a String parameter that stays settable:
                                    the Python kind's only)
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

and the kind's entries, ``<kind>.*`` (the LTI kind's: csrc/native_lti.c's header comment; the Python kind has none:
its simulator comes from the FMU's slave script, flexfmu.fmi.loader).  Among the LTI kind's, the derived outputs
(:func:`derived_entries`) are optional: a model file without them (an older one, or a model without gauges) loads
as before.
"""
from __future__ import annotations

import math
import shlex
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.fmi.variables import table

MODEL_FILE = "flexfmu_model.bin"
MAGIC = b"flexfmu-native\n\x00"
FORMAT_VERSION = 1
F64, I32, STR = 1, 2, 3
TYPES = {"Real": 0, "Integer": 1, "Boolean": 2, "String": 3}
CAUSALITIES = {"parameter": 0, "input": 1, "output": 2}
LO_OPEN, HI_OPEN, INTEGER, SPECIAL = 1, 2, 4, 8
#: the kinds whose simulators read String runtime parameters (native_kind.h's texts); the others have theirs fixed
TEXT_KINDS = ("python", "wec")
#: what a parameter of each type allows when nothing narrower is known (the Python kind's: its config checks more)
ALLOWED = {"Real": "a finite number", "Integer": "an integer", "Boolean": "a boolean", "String": "a UTF-8 string"}


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


def entries(spec, *, kind: str, name: str, guid: str, values: dict | None = None, runtime=None,
            messages=(), divergence_limit: float = math.inf,
            divergence_allowed: str = "inputs within the model's range", rebuild: str = "",
            rebuild_settings: dict | None = None) -> tuple[dict, list, list, list]:
    """The entries every model file has (module docstring) for the FMU of ``spec`` built with the parameter
    ``values``; ``runtime``: the RuntimeParameters that stay settable (None: every parameter, as the Python kind
    has them).  Returns (entries, input names, output names, runtime parameter names), the names in the runtime's
    order, for the kind's entries."""
    variables = table(spec, values)
    if runtime is None:
        runtime = [RuntimeParameter(v.name, allowed=ALLOWED[v.type]) for v in variables if v.causality == "parameter"]
    runtime = {p.name: p for p in runtime}
    params = [v.name for v in variables if v.causality == "parameter" and v.name in runtime]
    inputs = [v.name for v in variables if v.causality == "input"]
    outputs = [v.name for v in variables if v.causality == "output"]
    if kind not in TEXT_KINDS:
        for v in variables:
            if v.causality == "parameter" and v.name in runtime and v.type == "String":
                raise ParameterError(v.name, "a String parameter cannot stay settable in a native FMU",
                                     "fixed at build")
    index = [params.index(v.name) if v.name in params else inputs.index(v.name) if v.causality == "input"
             else outputs.index(v.name) if v.causality == "output" else -1 for v in variables]
    rules = [runtime[p] for p in params]
    for rule in rules:
        if rule.special is not None and not math.isfinite(rule.replacement):
            raise ParameterError(rule.name, "a special value without a finite replacement")
    type_of = {v.name: v.type for v in variables}
    rebuild_settings = rebuild_settings or {}
    common = {
        "kind": kind, "model": name, "guid": guid,
        "var.name": [v.name for v in variables],
        "var.type": np.array([TYPES[v.type] for v in variables], np.int32),
        "var.causality": np.array([CAUSALITIES[v.causality] for v in variables], np.int32),
        "var.index": np.array(index, np.int32),
        "var.start": np.array([0.0 if v.type == "String" else float(v.start) for v in variables], float),
        "var.start_string": [str(v.start) if v.type == "String" else "" for v in variables],
        "param.lo": np.array([r.lo for r in rules], float), "param.hi": np.array([r.hi for r in rules], float),
        "param.flags": np.array([r.flags | INTEGER * (type_of[r.name] == "Integer") for r in rules], np.int32),
        "param.special": np.array([r.special if r.special is not None else 0.0 for r in rules], float),
        "param.replacement": np.array([r.replacement if r.special is not None else 0.0 for r in rules], float),
        "param.allowed": [r.allowed for r in rules],
        "divergence_limit": np.float64(divergence_limit),
        "divergence_allowed": divergence_allowed,
        "rebuild": rebuild,
        "rebuild.names": list(rebuild_settings),
        "rebuild.values": [shlex.quote(v) for v in rebuild_settings.values()],
        "messages": [str(m) for m in messages],
        "outputs.deferred": np.array([outputs.index(n) for n in getattr(spec, "deferred_outputs", ())], np.int32),
    }
    return common, inputs, outputs, params


def derived_entries(lti) -> dict:
    """The LTI kind's derived-output entries (csrc/native_lti.c, csrc/derived_stress.h) of an LtiModel ``lti``:
    ``lti.derived.kind``, ``.shape``, ``.output`` int32 (n): the kind's code (1 tensor_von_mises, 2 section_sigma_max,
    3 section_von_mises), the section's shape (0 none, 1 circle, 2 tube, 3 rectangle), the output's index among the
    model's outputs; ``.sources`` int32 (n, 6): the sources' indices (-1 after the kind's 6 or 4); ``.fibres`` float64
    (n, 7): the SectionFibres constants A, Iy, Iz, J, y_max, z_max, torsion_arm (zeros for a tensor).  None for a model
    without derived outputs."""
    from flexfmu.native.lti_derived import derived_arrays
    if not lti.derived:
        return {}
    return {f"lti.derived.{k}": v for k, v in derived_arrays(lti.derived, lti.output_names).items()}
