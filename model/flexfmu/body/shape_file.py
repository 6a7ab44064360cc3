"""The deformed-shape file an exported body carries (``resources/shape.npz`` in its FMU): what a viewer needs to draw
the body from its shape coordinates q_1 .. q_n, the outputs of the FMU.

Format "flexfmu-shape", version 1: one ``np.savez_compressed`` archive, read with ``allow_pickle=False`` (no Python
objects, only arrays), holding

* ``header``: a JSON text (0-d string array): {"format": "flexfmu-shape", "version": 1, "body": name,
  "frame": "body", ...}, the writer's extra keys kept;
* ``nodes`` (N, 3): the undeformed node positions, m, body frame;
* ``cells/<type>`` (k, m) int64: node indices (0-based) of the cells of each meshio cell type (``tetra10``,
  ``triangle``, ``line``, ...), meshio's node order;
* ``Psi`` (N, 3, n): the displacement shapes, m per unit of q, body frame: u = Psi q exactly (the retained mode
  shapes first, then the static-correction shapes);
* ``stress`` (N, 6, n), optional: the nodal stress shapes, Pa per unit of q, body frame, VOIGT order
  (flexfmu.core.stress.VOIGT): sigma = S q;
* ``names`` (n,): the names of q's entries (the FMU's output names, ``q_1`` ...).

Written by write_shape_file and read by read_shape_file (read_fmu_shape: straight from an FMU), nowhere else, so a
change of the format is one change here and a new version number.
"""
from __future__ import annotations

import io
import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.errors import ModelFileError, ParameterError

SHAPE_FORMAT = "flexfmu-shape"
SHAPE_VERSION = 1
#: where an FMU keeps its shape file
FMU_SHAPE_MEMBER = "resources/shape.npz"
#: what a user does to get an FMU with a shape file (quoted by the errors)
HOW_TO_EXPORT = ("a solid body exported from a mesh by `flexfmu export MODEL -o BODY.fmu ...`, clamped or free, "
                 "either runtime (docs/export.md); the built-in FMUs (FFRBeam, ReframeBody, the wave converter's) and "
                 "models read as matrices carry none")
_CELL_PREFIX = "cells/"


@dataclass(frozen=True)
class ShapeFile:
    """The contents of a shape file: nodes (N, 3) m; cells {meshio type: (k, m) int64}; Psi (N, 3, n) m per unit q;
    stress (N, 6, n) Pa per unit q, or None; names (n,) of q; header (dict: format, version, body, frame, ...)."""

    nodes: np.ndarray
    cells: dict
    Psi: np.ndarray
    stress: np.ndarray | None
    names: tuple
    header: dict = field(default_factory=dict)

    @property
    def n_coordinates(self) -> int:
        return self.Psi.shape[2]

    @property
    def body(self) -> str:
        return str(self.header.get("body", ""))


def _check_arrays(nodes, cells, Psi, stress, names, where: str):
    """The arrays as float64 / int64 with consistent shapes, or ParameterError naming the offending one (``where``
    prefixes the name: the writer's argument or the file)."""
    nodes = np.asarray(nodes, dtype=float)
    if nodes.ndim != 2 or nodes.shape[1] != 3 or nodes.shape[0] < 1:
        raise ParameterError(f"{where}nodes", f"shape {nodes.shape}", "(N, 3) node positions, N >= 1")
    n_nodes = nodes.shape[0]
    Psi = np.asarray(Psi, dtype=float)
    if Psi.ndim != 3 or Psi.shape[:2] != (n_nodes, 3) or Psi.shape[2] < 1:
        raise ParameterError(f"{where}Psi", f"shape {Psi.shape}", f"({n_nodes}, 3, n) with n >= 1")
    n = Psi.shape[2]
    if stress is not None:
        stress = np.asarray(stress, dtype=float)
        if stress.shape != (n_nodes, 6, n):
            raise ParameterError(f"{where}stress", f"shape {stress.shape}", f"({n_nodes}, 6, {n}) or none")
    for name, array in (("nodes", nodes), ("Psi", Psi), ("stress", stress)):
        if array is not None and not np.all(np.isfinite(array)):
            raise ParameterError(f"{where}{name}", "holds NaN or infinite values", "finite numbers")
    names = tuple(str(x) for x in np.asarray(names, dtype=str).reshape(-1))
    if len(names) != n or len(set(names)) != n or not all(names):
        raise ParameterError(f"{where}names", f"{len(names)} names ({len(set(names))} distinct)",
                             f"{n} distinct non-empty names, one per column of Psi")
    if not isinstance(cells, dict):
        raise ParameterError(f"{where}cells", f"a {type(cells).__name__}", "a dict {meshio cell type: (k, m) ints}")
    checked = {}
    for kind, data in cells.items():
        kind = str(kind)
        data = np.asarray(data)
        if not kind or "/" in kind:
            raise ParameterError(f"{where}cells", f"cell type {kind!r}", "a meshio cell type name (tetra10, line, ...)")
        if data.ndim != 2 or data.shape[1] < 1 or (data.size and data.dtype.kind not in "iu"):
            raise ParameterError(f"{where}cells/{kind}", f"shape {data.shape}, dtype {data.dtype}",
                                 "(k, m) integer node indices")
        if data.size and (data.min() < 0 or data.max() >= n_nodes):
            raise ParameterError(f"{where}cells/{kind}", f"node indices {data.min()} ... {data.max()}",
                                 f"0 ... {n_nodes - 1} (the nodes)")
        checked[kind] = data.astype(np.int64)
    return nodes, checked, Psi, stress, names


def write_shape_file(path, nodes, cells, Psi, stress, names, header=None) -> Path:
    """Write a shape file (format in the module docstring) to ``path``: nodes (N, 3) m body frame; cells
    {meshio type: (k, m) node indices}; Psi (N, 3, n); stress (N, 6, n) or None; names (n,) of q; header: a dict
    of extra keys (body: the body's name; frame: "body" unless given), JSON-serialisable.  ``path`` may be a
    writable binary file object.  Returns the path (or the file object)."""
    nodes, cells, Psi, stress, names = _check_arrays(nodes, cells, Psi, stress, names, "")
    extra = dict(header or {})
    try:
        text = json.dumps({"frame": "body", **extra, "format": SHAPE_FORMAT, "version": SHAPE_VERSION})
    except (TypeError, ValueError) as exc:
        raise ParameterError("header", f"is not JSON-serialisable ({exc})", "a dict of str, numbers, lists") from None
    arrays = {"header": np.array(text), "nodes": nodes, "Psi": Psi, "names": np.array(names, dtype=str)}
    if stress is not None:
        arrays["stress"] = stress
    arrays.update({_CELL_PREFIX + kind: data for kind, data in cells.items()})
    if isinstance(path, (str, Path)):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("wb") as f:                   # a file object: savez would append .npz to a name
            np.savez_compressed(f, **arrays)
        return path
    np.savez_compressed(path, **arrays)
    return path


def read_shape_file(path, *, label: str | None = None) -> ShapeFile:
    """Read a shape file (a path, or a binary file object with ``label`` naming it in errors).  ModelFileError when
    it is no npz archive, is corrupted, is not a flexfmu shape file, has another version, or its arrays disagree."""
    name = label or str(path)
    try:
        with np.load(path, allow_pickle=False) as archive:
            data = {key: archive[key] for key in archive.files}
    except FileNotFoundError:
        raise ModelFileError(name, "no such file", "a shape file (.npz) written by flexfmu export") from None
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
        raise ModelFileError(name, f"is not a readable shape file: {type(exc).__name__}: {exc}",
                             f"a {SHAPE_FORMAT} .npz written by flexfmu export") from None
    if "header" not in data:
        raise ModelFileError(name, f"has no header: not a {SHAPE_FORMAT} file (it holds {', '.join(sorted(data))})",
                             f"a {SHAPE_FORMAT} .npz written by flexfmu export")
    try:
        header = json.loads(str(data["header"][()]))
        if not isinstance(header, dict):
            raise ValueError("not a JSON object")
    except (ValueError, TypeError, IndexError) as exc:
        raise ModelFileError(name, f"its header is not a JSON object ({exc})", f"a {SHAPE_FORMAT} header") from None
    if header.get("format") != SHAPE_FORMAT:
        raise ModelFileError(name, f"format {header.get('format')!r}", f"{SHAPE_FORMAT!r}")
    version = header.get("version")
    if type(version) is not int or version != SHAPE_VERSION:          # (True == 1 in Python: not a version)
        newer = type(version) is int and version > SHAPE_VERSION
        raise ModelFileError(name, f"{SHAPE_FORMAT} version {version!r}"
                             + (", newer than this flexfmu reads: update flexfmu" if newer else
                                ": re-export the FMU with this flexfmu"), f"version {SHAPE_VERSION}")
    missing = [key for key in ("nodes", "Psi", "names") if key not in data]
    if missing:
        raise ModelFileError(name, f"lacks {', '.join(missing)}", "nodes, Psi, names (and cells/<type>, stress)")
    cells = {key[len(_CELL_PREFIX):]: value for key, value in data.items() if key.startswith(_CELL_PREFIX)}
    try:
        nodes, cells, Psi, stress, names = _check_arrays(data["nodes"], cells, data["Psi"], data.get("stress"),
                                                         data["names"], "")
    except (ParameterError, ValueError, TypeError) as exc:
        raise ModelFileError(name, f"inconsistent arrays: {exc}", "the arrays of one flexfmu export") from None
    return ShapeFile(nodes, cells, Psi, stress, names, header)


def read_fmu_shape(fmu_path) -> ShapeFile:
    """The shape file of an FMU (its ``resources/shape.npz``), read from the zip without unpacking it.
    ModelFileError when the FMU cannot be read or carries no shape file (saying which FMUs carry one)."""
    fmu_path = Path(fmu_path)
    if not fmu_path.is_file():
        raise ModelFileError(fmu_path, "no such file", "an FMU (.fmu) with resources/shape.npz: " + HOW_TO_EXPORT)
    try:
        with zipfile.ZipFile(fmu_path) as fmu:
            if FMU_SHAPE_MEMBER not in fmu.namelist():
                raise ModelFileError(fmu_path, f"carries no {FMU_SHAPE_MEMBER} (no deformed shape to draw)",
                                     HOW_TO_EXPORT)
            payload = fmu.read(FMU_SHAPE_MEMBER)
    except (zipfile.BadZipFile, OSError, zlib.error, EOFError) as exc:
        raise ModelFileError(fmu_path, f"is not a readable FMU (zip): {type(exc).__name__}: {exc}",
                             "an FMU (.fmu) with resources/shape.npz: " + HOW_TO_EXPORT) from None
    return read_shape_file(io.BytesIO(payload), label=f"{fmu_path}:{FMU_SHAPE_MEMBER}")
