"""Read and write a conventional structural model (:class:`~flexfmu.core.structure.Structure`) as ``.npz``.

File format: these ten keys, required::

    nodes           (N, 3) float   undeformed node coordinates, m, body frame
    dofs_per_node   ()     int     3 (solid: x, y, z) or 6 (beam: x, y, z, theta_x, theta_y, theta_z)
    M_data          (nnz,) float   mass matrix, CSR values
    M_indices       (nnz,) int     CSR column indices
    M_indptr        (n+1,) int     CSR row pointers
    M_shape         (2,)   int     (n, n), n = N * dofs_per_node
    K_data, K_indices, K_indptr, K_shape    the same four for the stiffness matrix

and these, optional (written only when the model has them; files without them load as before)::

    constrained_dofs  (k,)    int  sorted, unique DOF indices the model file fixes (Structure.constrained_dofs)
    node_set_names    (S,)    str  names of the node sets (Structure.node_sets), unique
    node_set_indptr   (S+1,)  int  set s holds node_set_nodes[node_set_indptr[s]:node_set_indptr[s + 1]]
    node_set_nodes    (n,)    int  node indices, sorted and unique within each set
    provenance        ()      str  JSON of Structure.provenance (source, format, reader, units, material, notes)
    cells_<type>      (n, k)  int  the volume cells of meshio cell type <type> (Structure.cells), node indices

DOFs are numbered node by node: DOF ``dofs_per_node * i + j`` is component ``j`` of node ``i``.
SI units throughout (kg, kg m^2, N/m, N m/rad).

Every problem found on load is a :class:`~flexfmu.errors.ParameterError` whose
``parameter`` is the offending key (``"M_shape"``, ``"K_data"``, ...).  The same checks are
available for an in-memory model as :func:`validate_structure`.
"""
from __future__ import annotations

import json
import zipfile
from dataclasses import asdict
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from flexfmu.core.checks import path_exists_as, shown
from flexfmu.errors import ParameterError
from flexfmu.core.structure import Provenance, Structure

MATRIX_KEYS = ("data", "indices", "indptr", "shape")
REQUIRED_KEYS = ("nodes", "dofs_per_node") + tuple(
    f"{m}_{part}" for m in ("M", "K") for part in MATRIX_KEYS
)
NODE_SET_KEYS = ("node_set_names", "node_set_indptr", "node_set_nodes")
OPTIONAL_KEYS = ("constrained_dofs",) + NODE_SET_KEYS + ("provenance",)
CELLS_PREFIX = "cells_"             # cells_<meshio type>: Structure.cells
#: nodes per cell of the cell types a Structure may carry (flexfmu.importers.elements assembles these)
CELL_NODES = {"tetra": 4, "tetra10": 10, "hexahedron": 8, "hexahedron20": 20, "hexahedron27": 27}
ALLOWED_DOFS_PER_NODE = (3, 6)
SYMMETRY_RTOL = 1e-8  # |A - A^T|_max <= SYMMETRY_RTOL * |A|_max; A is then symmetrised exactly
MASS_RTOL = 1e-8      # translational masses must agree to this relative tolerance


# --------------------------------------------------------------------------- checks
def _check_nodes(nodes, name: str) -> np.ndarray:
    try:
        arr = np.asarray(nodes, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(name, f"not a numeric array ({exc})", "(N, 3) finite floats, m") from None
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 1:
        raise ParameterError(name, f"shape {arr.shape}", "(N, 3) with N >= 1")
    if not np.all(np.isfinite(arr)):
        bad = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise ParameterError(name, f"non-finite coordinate at node {bad}", "finite floats")
    return arr


def _check_dofs_per_node(value, name: str) -> int:
    arr = np.asarray(value)
    if arr.shape != () or arr.dtype.kind not in "iuf" or arr.dtype == bool:
        raise ParameterError(name, f"{value!r} is not a scalar integer", "3 or 6")
    if arr.dtype.kind == "f" and (not np.isfinite(arr) or arr != np.round(arr)):
        raise ParameterError(name, f"{value!r} is not an integer", "3 or 6")
    dpn = int(arr)
    if dpn not in ALLOWED_DOFS_PER_NODE:
        raise ParameterError(name, f"{dpn}", "3 or 6")
    return dpn


def _csr_from_parts(prefix: str, parts: dict, n_dof: int) -> sp.csr_matrix:
    """Check the four CSR arrays of matrix ``prefix`` and build the matrix."""
    k_data, k_ind, k_ptr, k_shape = (f"{prefix}_{p}" for p in MATRIX_KEYS)
    shape = np.asarray(parts[k_shape])
    if shape.shape != (2,) or shape.dtype.kind not in "iu":
        raise ParameterError(k_shape, f"{shape!r} is not two integers", f"[{n_dof}, {n_dof}]")
    if tuple(int(s) for s in shape) != (n_dof, n_dof):
        raise ParameterError(
            k_shape, f"{tuple(int(s) for s in shape)} does not match N * dofs_per_node = {n_dof}",
            f"[{n_dof}, {n_dof}]")
    data = np.asarray(parts[k_data])
    if data.ndim != 1 or data.dtype.kind not in "iuf":
        raise ParameterError(k_data, f"shape {data.shape}, dtype {data.dtype}", "1-D float array")
    data = data.astype(float)
    if not np.all(np.isfinite(data)):
        raise ParameterError(k_data, f"{int(np.sum(~np.isfinite(data)))} non-finite value(s)", "finite floats")
    indptr = np.asarray(parts[k_ptr])
    if indptr.ndim != 1 or indptr.dtype.kind not in "iu" or indptr.size != n_dof + 1:
        raise ParameterError(k_ptr, f"shape {indptr.shape}, dtype {indptr.dtype}",
                             f"{n_dof + 1} integers (n_dof + 1)")
    if indptr[0] != 0 or indptr[-1] != data.size or np.any(np.diff(indptr) < 0):
        raise ParameterError(k_ptr, "not a CSR row pointer for the given data",
                             f"non-decreasing from 0 to len({k_data}) = {data.size}")
    indices = np.asarray(parts[k_ind])
    if indices.ndim != 1 or indices.dtype.kind not in "iu" or indices.size != data.size:
        raise ParameterError(k_ind, f"shape {indices.shape}, dtype {indices.dtype}",
                             f"{data.size} integers (same length as {k_data})")
    if indices.size and (indices.min() < 0 or indices.max() >= n_dof):
        raise ParameterError(k_ind, f"column index out of range [{indices.min()}, {indices.max()}]",
                             f"0 ... {n_dof - 1}")
    A = sp.csr_matrix((data, indices.astype(np.int64), indptr.astype(np.int64)), shape=(n_dof, n_dof))
    A.sum_duplicates()
    A.sort_indices()
    return A


def _check_matrix(A, name: str, n_dof: int, kind: str) -> sp.csr_matrix:
    """Shape, finiteness, symmetry and diagonal sign of M or K; returns a symmetric CSR copy.

    ``kind`` is "M" or "K"; ``name`` is what a ParameterError reports.
    """
    if not sp.issparse(A):
        try:
            A = sp.csr_matrix(np.asarray(A, dtype=float))
        except (TypeError, ValueError) as exc:
            raise ParameterError(name, f"not a matrix ({exc})", "sparse or dense (n_dof, n_dof) floats") from None
    A = sp.csr_matrix(A, dtype=float)
    if A.shape != (n_dof, n_dof):
        raise ParameterError(name, f"shape {A.shape} does not match N * dofs_per_node = {n_dof}",
                             f"({n_dof}, {n_dof})")
    if not np.all(np.isfinite(A.data)):
        raise ParameterError(name, f"{int(np.sum(~np.isfinite(A.data)))} non-finite value(s)", "finite floats")
    scale = float(np.max(np.abs(A.data))) if A.nnz else 0.0
    if kind == "M" and scale == 0.0:
        raise ParameterError(name, "mass matrix is zero", "symmetric positive semi-definite with mass > 0")
    At = A.T.tocsr()                      # once: used twice (0.03 s on the 51k-DOF plate)
    asym = A - At
    asym_max = float(np.max(np.abs(asym.data))) if asym.nnz else 0.0
    if asym_max > SYMMETRY_RTOL * scale:
        raise ParameterError(name, f"not symmetric: max|A - A^T| / max|A| = {asym_max / scale:.3g}",
                             f"symmetric to a relative tolerance of {SYMMETRY_RTOL:g}")
    A = ((A + At) * 0.5).tocsr()
    A.sum_duplicates()
    A.sort_indices()
    diag = A.diagonal()
    if np.any(diag < 0.0):
        i = int(np.argmin(diag))
        what = "mass" if kind == "M" else "stiffness"
        raise ParameterError(name, f"negative diagonal {what} {diag[i]:.6g} at DOF {i}: "
                             "matrix is not positive semi-definite", "diagonal >= 0")
    return A


def _check_translational_mass(M: sp.csr_matrix, dpn: int, name: str) -> None:
    n_dof = M.shape[0]
    masses = []
    for j in range(3):
        t = np.zeros(n_dof)
        t[j::dpn] = 1.0
        masses.append(float(t @ (M @ t)))
    masses = np.array(masses)
    if np.any(masses <= 0.0):
        raise ParameterError(name, f"rigid translation has no mass (masses x, y, z = {masses})",
                             "positive semi-definite with total mass > 0")
    spread = float(np.ptp(masses) / np.max(masses))
    if spread > MASS_RTOL:
        raise ParameterError(name, f"total mass differs by direction: x, y, z = {masses} kg",
                             f"the same total mass in x, y and z (relative tolerance {MASS_RTOL:g})")


def validate_structure(structure: Structure) -> Structure:
    """Check an in-memory model; return a copy with float CSR, exactly symmetric M and K.

    Raises :class:`ParameterError` naming ``structure.nodes``, ``structure.dofs_per_node``,
    ``structure.M`` or ``structure.K``.
    """
    nodes = _check_nodes(structure.nodes, "structure.nodes")
    dpn = _check_dofs_per_node(structure.dofs_per_node, "structure.dofs_per_node")
    n_dof = nodes.shape[0] * dpn
    M = _check_matrix(structure.M, "structure.M", n_dof, "M")
    K = _check_matrix(structure.K, "structure.K", n_dof, "K")
    _check_translational_mass(M, dpn, "structure.M")
    constrained = _check_constrained(getattr(structure, "constrained_dofs", ()), "structure.constrained_dofs", n_dof)
    sets = _check_node_sets(getattr(structure, "node_sets", {}) or {}, "structure.node_sets", nodes.shape[0])
    provenance = getattr(structure, "provenance", None) or Provenance()
    cells = _check_cells(getattr(structure, "cells", {}) or {}, "structure.cells", nodes.shape[0], dpn)
    return Structure(nodes=nodes, dofs_per_node=dpn, M=M, K=K, name=structure.name,
                     meta=dict(structure.meta), points=dict(getattr(structure, "points", {}) or {}),
                     constrained_dofs=constrained, node_sets=sets, provenance=provenance, cells=cells)


def _check_cells(cells, name: str, n_nodes: int, dpn: int) -> dict:
    """Structure.cells checked: known cell types, (n, k) node indices of the model, a solid's (3 DOFs per node)."""
    if not isinstance(cells, dict):
        raise ParameterError(name, f"{type(cells).__name__} is not a dict", "{meshio cell type: (n, k) node indices}")
    out = {}
    for cell_type, members in cells.items():
        where = f"{name}[{cell_type!r}]"
        if cell_type not in CELL_NODES:
            raise ParameterError(where, "unknown cell type", ", ".join(CELL_NODES))
        if dpn != 3:
            raise ParameterError(where, f"volume cells on a model of {dpn} DOFs per node", "3 DOFs per node (a solid)")
        arr = np.asarray(members)
        k = CELL_NODES[cell_type]
        if arr.ndim != 2 or arr.shape[1] != k or (arr.size and arr.dtype.kind not in "iu"):
            raise ParameterError(where, f"shape {arr.shape}, dtype {arr.dtype}", f"(n, {k}) integer node indices")
        if arr.size and (arr.min() < 0 or arr.max() >= n_nodes):
            raise ParameterError(where, "not node indices", f"integers 0 ... {n_nodes - 1}")
        out[str(cell_type)] = arr.astype(np.int64)
    return out


def _check_constrained(values, name: str, n_dof: int) -> np.ndarray:
    arr = np.asarray(values)
    if arr.size == 0:
        return np.zeros(0, dtype=np.int64)
    if arr.ndim != 1 or arr.dtype.kind not in "iu":
        raise ParameterError(name, f"shape {arr.shape}, dtype {arr.dtype}", "1-D integer DOF indices")
    if arr.min() < 0 or arr.max() >= n_dof:
        raise ParameterError(name, f"DOF index out of range [{arr.min()}, {arr.max()}]", f"0 ... {n_dof - 1}")
    return np.unique(arr.astype(np.int64))


def _check_node_sets(sets, name: str, n_nodes: int) -> dict:
    if not isinstance(sets, dict):
        raise ParameterError(name, f"{type(sets).__name__} is not a dict", "{set name: node indices}")
    out = {}
    for key, members in sets.items():
        arr = np.asarray(members)
        if arr.size == 0:
            out[str(key)] = np.zeros(0, dtype=np.int64)
            continue
        if arr.ndim != 1 or arr.dtype.kind not in "iu" or arr.min() < 0 or arr.max() >= n_nodes:
            raise ParameterError(f"{name}[{key!r}]", "not node indices", f"integers 0 ... {n_nodes - 1}")
        out[str(key)] = np.unique(arr.astype(np.int64))
    return out


def _optional_arrays(s: Structure) -> dict:
    arrays = {}
    if s.constrained_dofs.size:
        arrays["constrained_dofs"] = s.constrained_dofs.astype(np.int64)
    if s.node_sets:
        names = list(s.node_sets)
        arrays["node_set_names"] = np.array(names, dtype=str)
        arrays["node_set_indptr"] = np.cumsum([0] + [s.node_sets[k].size for k in names]).astype(np.int64)
        arrays["node_set_nodes"] = (np.concatenate([s.node_sets[k] for k in names]).astype(np.int64)
                                    if arrays["node_set_indptr"][-1] else np.zeros(0, dtype=np.int64))
    if s.provenance != Provenance():
        arrays["provenance"] = np.array(json.dumps(asdict(s.provenance)))
    for cell_type, cells in s.cells.items():
        arrays[CELLS_PREFIX + cell_type] = cells.astype(np.int64)
    return arrays


def _tuples(value):
    """JSON lists back to the tuples Provenance holds."""
    return tuple(_tuples(v) for v in value) if isinstance(value, list) else value


def _optional_from_parts(parts: dict, path: Path, n_nodes: int, n_dof: int):
    """(constrained_dofs, node_sets, provenance) from the optional keys; errors name the key."""
    constrained = _check_constrained(parts.get("constrained_dofs", ()), "constrained_dofs", n_dof)
    present = [k for k in NODE_SET_KEYS if k in parts]
    sets = {}
    if present:
        if len(present) != len(NODE_SET_KEYS):
            missing = next(k for k in NODE_SET_KEYS if k not in parts)
            raise ParameterError(missing, f"missing from {path.name} (the node set keys come together)",
                                 ", ".join(NODE_SET_KEYS))
        names, indptr, members = (parts[k] for k in NODE_SET_KEYS)
        if names.ndim != 1 or names.dtype.kind != "U" or len(set(names.tolist())) != names.size:
            raise ParameterError("node_set_names", f"shape {names.shape}, dtype {names.dtype}", "unique strings")
        if (indptr.ndim != 1 or indptr.dtype.kind not in "iu" or indptr.size != names.size + 1 or indptr[0] != 0
                or np.any(np.diff(indptr) < 0) or indptr[-1] != members.size):
            raise ParameterError("node_set_indptr", "not offsets into node_set_nodes",
                                 f"{names.size + 1} non-decreasing integers from 0 to len(node_set_nodes)")
        if members.size and (members.dtype.kind not in "iu" or members.min() < 0 or members.max() >= n_nodes):
            raise ParameterError("node_set_nodes", "not node indices", f"integers 0 ... {n_nodes - 1}")
        sets = {str(n): np.unique(members[indptr[i]:indptr[i + 1]].astype(np.int64)) for i, n in enumerate(names)}
    provenance = Provenance(source=str(path), format="npz")
    if "provenance" in parts:
        try:
            fields = json.loads(str(parts["provenance"]))
            provenance = Provenance(**{k: _tuples(v) for k, v in fields.items()})
        except (ValueError, TypeError) as exc:
            raise ParameterError("provenance", f"not a provenance JSON ({exc})",
                                 "JSON with source, format, reader, units, material, notes") from None
    return constrained, sets, provenance


# --------------------------------------------------------------------------- file I/O
def save_structure(path, structure: Structure) -> Path:
    """Write ``structure`` to ``path`` (``.npz``, the ten keys above and the optional ones it has);
    return the path written.

    The model is validated first (:func:`validate_structure`); ``name`` and ``meta`` are not
    part of the format and are not written.  A missing ``.npz`` suffix is added.
    """
    s = validate_structure(structure)
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    arrays = {"nodes": s.nodes, "dofs_per_node": np.array(s.dofs_per_node, dtype=np.int64)}
    for key, A in (("M", s.M), ("K", s.K)):
        arrays[f"{key}_data"] = A.data.astype(float)
        arrays[f"{key}_indices"] = A.indices.astype(np.int64)
        arrays[f"{key}_indptr"] = A.indptr.astype(np.int64)
        arrays[f"{key}_shape"] = np.array(A.shape, dtype=np.int64)
    arrays.update(_optional_arrays(s))
    np.savez_compressed(path, **arrays)
    return path


def load_structure(path) -> Structure:
    """Read and validate a ``.npz`` structural model; ``name`` is the file stem.

    Raises :class:`ParameterError` naming the offending key, or ``path`` if the file cannot
    be read, or the unexpected key if the file holds keys outside the format.
    """
    path = Path(path)
    kind = path_exists_as(path)
    if kind != "file":
        raise ParameterError("path", f"{shown(str(path))} is a directory" if kind == "directory" else
                             f"no such file: {shown(str(path))}", "an existing .npz file")
    if path.stat().st_size == 0:
        raise ParameterError("path", f"{shown(str(path))} is empty", "a .npz file")
    try:
        with np.load(path, allow_pickle=False) as npz:
            parts = {key: npz[key] for key in npz.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, RuntimeError) as exc:
        # RuntimeError: zlib / zipfile errors of a damaged archive
        raise ParameterError("path", f"{shown(str(path))} is not a readable .npz file ({exc})", "a .npz file") from None
    for key in REQUIRED_KEYS:
        if key not in parts:
            raise ParameterError(key, f"missing from {path.name}", "keys: " + ", ".join(REQUIRED_KEYS))
    extra = sorted(set(parts) - set(REQUIRED_KEYS) - set(OPTIONAL_KEYS)
                   - {CELLS_PREFIX + t for t in CELL_NODES})
    if extra:
        raise ParameterError(extra[0], f"unknown key in {path.name}",
                             "keys: " + ", ".join(REQUIRED_KEYS + OPTIONAL_KEYS) + ", cells_<type> ("
                             + ", ".join(CELL_NODES) + ")")

    nodes = _check_nodes(parts["nodes"], "nodes")
    dpn = _check_dofs_per_node(parts["dofs_per_node"], "dofs_per_node")
    n_dof = nodes.shape[0] * dpn
    M = _check_matrix(_csr_from_parts("M", parts, n_dof), "M_data", n_dof, "M")
    K = _check_matrix(_csr_from_parts("K", parts, n_dof), "K_data", n_dof, "K")
    _check_translational_mass(M, dpn, "M_data")
    constrained, sets, provenance = _optional_from_parts(parts, path, nodes.shape[0], n_dof)
    cells = {}
    for key in sorted(k for k in parts if k.startswith(CELLS_PREFIX)):
        cells.update(_check_cells({key[len(CELLS_PREFIX):]: parts[key]}, key, nodes.shape[0], dpn))
    return Structure(nodes=nodes, dofs_per_node=dpn, M=M, K=K, name=path.stem, meta={"source": str(path)},
                     constrained_dofs=constrained, node_sets=sets, provenance=provenance, cells=cells)
