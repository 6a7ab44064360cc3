"""ANSYS MAPDL ``.full`` files (ansys-mapdl-reader): mass and stiffness as MAPDL wrote them.

MAPDL numbers its equations in its own (wavefront) order; each equation is a (node number, DOF label) pair.
Here they become Structure's node-by-node order: nodes sorted by node number, DOF ``d * i + j`` for the
j-th DOF label of node i (UX, UY, UZ; or UX ... ROTZ).  The ``.full`` holds no coordinates: they come from an
archive (``.cdb``, :class:`ansys.mapdl.reader.Archive`) or a result file (``.rst``) of the same model,
named by ``coordinates=`` or found beside the ``.full`` under the same stem.

MAPDL writes no stiffness for the DOFs it constrains (``D`` commands): their rows and columns of K are a
placeholder (a unit diagonal) and those of M are dropped by the reader.  Both are zero here and the DOFs are
listed in ``constrained_dofs``: such a model is valid clamped (those DOFs removed), not free
(``meta["clamped_only"]``).

Units: MAPDL stores whatever consistent system the user worked in.  The file header names it when ``/UNITS``
was set (SI, MKS, MPA, CGS, BIN); "User Defined" means it was not, and ``length_unit`` (a system of
:mod:`flexfmu.importers.units`) says which it is (default: SI).  The example bundled with ansys-mapdl-reader
(``file.full`` with ``HexBeam.cdb`` / ``file.rst``, a 1 x 1 x 5 titanium bar of SOLID186) is in
inch, lbf, s (E = 16.9e6 psi, DENS = 4.1408e-4 lbf s^2/in^4 in ``file.rst``), so ``length_unit="in"``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp

from flexfmu.core.structure import Provenance, Structure
from flexfmu.errors import ModelFileError, ParameterError
from flexfmu.importers.build import versions
from flexfmu.importers.units import UNIT_DESCRIPTIONS, UNIT_SYSTEMS, check_length_unit, check_model_size

#: MAPDL DOF label numbers -> names; Structure takes the translations, or translations and rotations.
DOF_LABELS = {1: "UX", 2: "UY", 3: "UZ", 4: "ROTX", 5: "ROTY", 6: "ROTZ"}
#: MAPDL /UNITS systems (header text of ansys-mapdl-reader) -> flexfmu unit systems.
HEADER_UNITS = {"SI": "m", "MKS": "m", "MPA": "mm", "CSG": "cm", "U.S. Customary units (inches)": "in"}
COORDINATE_SUFFIXES = (".cdb", ".rst")


def _read(path: Path, what: str):
    from ansys.mapdl.reader import Archive, read_binary

    try:
        return Archive(str(path)) if path.suffix.lower() == ".cdb" else read_binary(str(path))
    except Exception as exc:          # the reader raises RuntimeError, ValueError, ... on foreign files
        raise ModelFileError(path, f"cannot be read as {what} by ansys-mapdl-reader ({type(exc).__name__}: {exc})",
                             f"a MAPDL {what}") from None


def _coordinates(full_path: Path, coordinates) -> tuple[Path, np.ndarray, np.ndarray, dict]:
    """(file, node numbers, node coordinates, node components) from an archive or a result file."""
    if coordinates is None:
        found = [full_path.with_suffix(s) for s in COORDINATE_SUFFIXES if full_path.with_suffix(s).is_file()]
        if not found:
            raise ModelFileError(full_path, "holds no node coordinates and neither "
                                 + " nor ".join(full_path.with_suffix(s).name for s in COORDINATE_SUFFIXES)
                                 + " is beside it", "coordinates=<archive .cdb or result .rst of the same model>",
                                 entity="coordinates")
        path = found[0]
    else:
        path = Path(coordinates)
        if path.suffix.lower() not in COORDINATE_SUFFIXES:
            raise ParameterError("coordinates", f"{str(path)!r} is neither a .cdb nor a .rst",
                                 "a MAPDL archive (.cdb) or result file (.rst)")
        if not path.is_file():
            raise ParameterError("coordinates", f"no such file: {str(path)!r}", "an existing .cdb or .rst")
    source = _read(path, "archive (.cdb)" if path.suffix.lower() == ".cdb" else "result file (.rst)")
    mesh = source if path.suffix.lower() == ".cdb" else getattr(source, "mesh", None)
    if mesh is None or not hasattr(mesh, "nnum"):
        raise ModelFileError(path, "is not a result file with a mesh", "a MAPDL result file (.rst)")
    sets = {str(k): np.asarray(v) for k, v in (getattr(mesh, "node_components", None) or {}).items()}
    return path, np.asarray(mesh.nnum), np.asarray(mesh.nodes, dtype=float)[:, :3], sets


def _dof_labels(full) -> list[int]:
    from ansys.mapdl.reader.common import read_table

    with open(full.filename, "rb") as f:        # third record: the DOF label numbers of the model
        read_table(f, skip=True)
        read_table(f, skip=True)
        return [int(v) for v in read_table(f)]


def _unit_system(path: Path, full, length_unit) -> tuple[str, str]:
    header = str(full._standard_header.get("units", "User Defined"))
    if header in HEADER_UNITS:
        system = HEADER_UNITS[header]
        if length_unit is not None and check_length_unit(length_unit) != system:
            raise ParameterError("length_unit", f"{length_unit!r}, but {path.name} says its units are {header}",
                                 f"{system} (or leave it out)")
        return system, f"MAPDL /UNITS {header}"
    if header != "User Defined":
        raise ModelFileError(path, f"MAPDL unit system {header!r} is not supported",
                             ", ".join(HEADER_UNITS) + " or User Defined with length_unit")
    system = "m" if length_unit is None else check_length_unit(length_unit)
    return system, "MAPDL units 'User Defined' (/UNITS not set), read as " + \
        ("SI (default)" if length_unit is None else f"length_unit={system!r}")


def _full_symmetric(A) -> sp.csr_matrix:
    """MAPDL stores one triangle of a symmetric matrix: the whole matrix."""
    A = sp.csr_matrix(A)
    if sp.tril(A, -1).nnz and sp.triu(A, 1).nnz:
        return A
    return (A + A.T - sp.diags(A.diagonal())).tocsr()


def load_ansys_full(path, *, coordinates=None, length_unit: str | None = None, name: str | None = None) -> Structure:
    """The Structure of a MAPDL ``.full`` file and the node coordinates of its ``.cdb`` or ``.rst``."""
    path = Path(path)
    full = _read(path, "full file (.full)")
    if type(full).__name__ != "FullFile":
        raise ModelFileError(path, f"is a MAPDL {type(full).__name__}, not a full file", "a MAPDL .full file")
    labels = _dof_labels(full)
    if labels not in ([1, 2, 3], [1, 2, 3, 4, 5, 6]):
        raise ModelFileError(path, "DOFs " + ", ".join(DOF_LABELS.get(v, f"label {v}") for v in labels),
                             "UX, UY, UZ or UX ... ROTZ (structural models)", entity="DOF labels")
    try:
        dof_ref, k, m = full.load_km(as_sparse=True, sort=False)     # MAPDL's equation order
    except Exception as exc:
        raise ModelFileError(path, f"matrices cannot be read ({type(exc).__name__}: {exc})",
                             "a .full file with stiffness and mass") from None
    if k is None or m is None:
        raise ModelFileError(path, "holds no " + ("stiffness" if k is None else "mass") + " matrix",
                             "a .full file of a modal analysis (stiffness and mass)")
    system, units_text = _unit_system(path, full, length_unit)
    coord_path, nnum, xyz, components = _coordinates(path, coordinates)

    dpn = len(labels)
    node_numbers, counts = np.unique(dof_ref[:, 0], return_counts=True)
    if np.any(counts != dpn):
        bad = int(node_numbers[np.argmax(counts != dpn)])
        raise ModelFileError(path, f"has {int(counts[np.argmax(counts != dpn)])} DOFs", f"all {dpn} DOFs per node",
                             entity=f"node {bad}")
    order = np.argsort(nnum)
    where = np.searchsorted(nnum[order], node_numbers)
    missing = (where >= nnum.size) | (nnum[order][np.minimum(where, nnum.size - 1)] != node_numbers)
    if np.any(missing):
        raise ModelFileError(coord_path, f"has no coordinates for node {int(node_numbers[missing][0])} of {path.name}",
                             "the archive or result file of the same model", entity=f"node {int(node_numbers[missing][0])}")
    nodes = xyz[order][where]

    # equation e of the file -> Structure DOF dpn * (node index) + (label index)
    dof_of_equation = dpn * np.searchsorted(node_numbers, dof_ref[:, 0]) + dof_ref[:, 1]
    P = sp.csr_matrix((np.ones(dof_of_equation.size), (dof_of_equation, np.arange(dof_of_equation.size))),
                      shape=(dof_of_equation.size,) * 2)
    length, force = UNIT_SYSTEMS[system]
    scale = np.where(np.arange(dof_of_equation.size) % dpn < 3, 1.0 / length, 1.0)   # S^-1: translations only
    S = sp.diags(scale)
    K = (force * length) * (S @ (P @ _full_symmetric(k) @ P.T) @ S)
    M = (force * length) * (S @ (P @ _full_symmetric(m) @ P.T) @ S)

    const = np.asarray(full.const).reshape(-1, 2)
    constrained = np.unique(dpn * np.searchsorted(node_numbers, const[:, 0]) + const[:, 1]).astype(np.int64)
    node_sets = {}
    for set_name, members in components.items():
        idx = np.searchsorted(node_numbers, members)
        ok = (idx < node_numbers.size) & (node_numbers[np.minimum(idx, node_numbers.size - 1)] == members)
        node_sets[set_name] = np.unique(idx[ok])
    notes = [f"{full.neqn} equations, DOFs " + ", ".join(DOF_LABELS[v] for v in labels),
             f"coordinates from {coord_path}"]
    if constrained.size:
        notes.append(f"{constrained.size} constrained DOFs: MAPDL wrote no stiffness for them; their rows of M and "
                     "K are zero, so the model is valid clamped (constrained DOFs removed) only")
    # the unit is assumed (SI) when neither the file (/UNITS) nor the caller names it
    assumed = length_unit is None and str(full._standard_header.get("units", "User Defined")) not in HEADER_UNITS
    size_note = check_model_size(path, nodes * length, system, assumed)
    if size_note:
        notes.append(f"warning: {size_note}")
    provenance = Provenance(source=str(path), format="ansys-full", reader=versions("ansys-mapdl-reader"),
                            units=f"{units_text}: {UNIT_DESCRIPTIONS[system]}, converted to SI", notes=tuple(notes))
    meta = {"source": str(path), "node_ids": node_numbers, "clamped_only": bool(constrained.size),
            "unit_system": system}
    return Structure(nodes=nodes * length, dofs_per_node=dpn, M=_tidy(M), K=_tidy(K), name=name or path.stem,
                     meta=meta, constrained_dofs=constrained, node_sets=node_sets, provenance=provenance)


def _tidy(A) -> sp.csr_matrix:
    A = ((A + A.T) * 0.5).tocsr()
    A.eliminate_zeros()
    A.sort_indices()
    return A
