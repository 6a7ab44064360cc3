"""From a read mesh (points, volume cell blocks, named node sets, fixed DOFs) to a :class:`Structure`.

Shared by the mesh readers (:mod:`flexfmu.importers.solid`, :mod:`flexfmu.importers.nastran`): drops the
nodes no volume cell uses (they would carry DOFs without stiffness and make K singular), renumbers cells,
node sets and constraints onto the kept nodes, scales lengths to metres and assembles M and K.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flexfmu.core.checks import check_assembly_size
from flexfmu.core.structure import Provenance, Structure
from flexfmu.errors import ModelFileError
from flexfmu.importers.assembly import CellBlock, assemble
from flexfmu.importers.elements import CELL_TYPES, FLAT_CELL_RTOL, SUPPORTED, corner_volumes
from flexfmu.importers.units import UNIT_SYSTEMS, check_model_size


@dataclass
class ReadMesh:
    """What a reader found: ``points`` (N, 3) in the file's length unit; ``blocks`` of volume cells (point
    indices); ``node_sets`` name -> point indices; ``fixed`` (n, 2) point index and component 0-2;
    ``point_ids`` the points' numbers in the file (GRID ids, ...), if it numbers them."""

    points: np.ndarray
    blocks: list[CellBlock]
    node_sets: dict = field(default_factory=dict)
    fixed: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    point_ids: np.ndarray | None = None
    notes: list = field(default_factory=list)


def _point_name(read: ReadMesh, index: int) -> str:
    return f"node {int(read.point_ids[index])}" if read.point_ids is not None else f"point {index}"


def structure_from_mesh(path, read: ReadMesh, *, length_unit: str, name: str, file_format: str, reader: str,
                        units_text: str | None = None, integration: str = "full", unit_assumed: bool = False
                        ) -> Structure:
    """Assemble ``read`` into a Structure (see the module docstring); ``length_unit`` is a key of
    :data:`flexfmu.importers.units.UNIT_SYSTEMS` (``unit_assumed``: none was given; the model's size is checked
    for plausibility, flexfmu.importers.units.PLAUSIBLE_SIZE); materials in ``read.blocks`` are SI already."""
    if not read.blocks or all(b.cells.shape[0] == 0 for b in read.blocks):
        raise ModelFileError(path, "no volume cells", f"a mesh with volume cells: {SUPPORTED}")
    n_points = read.points.shape[0]
    used = np.zeros(n_points, dtype=bool)
    for block in read.blocks:
        if block.cells.size and (block.cells.min() < 0 or block.cells.max() >= n_points):
            row = int(np.argwhere((block.cells < 0) | (block.cells >= n_points))[0, 0])
            raise ModelFileError(path, f"refers to a point outside 0 ... {n_points - 1}", "existing points",
                                 entity=f"{block.cell_type} {block.cell_id(row)}")
        used[block.cells.ravel()] = True
    kept = np.flatnonzero(used)
    # the size limit in force (flexfmu modal's --max-dofs), before the checks and the assembly spend time and memory
    n_cells = sum(b.cells.shape[0] for b in read.blocks)
    check_assembly_size(3 * kept.size, f"{path} ({kept.size:,} nodes in {n_cells:,} cells)")
    new_index = np.full(n_points, -1)
    new_index[kept] = np.arange(kept.size)
    notes = list(read.notes)
    if kept.size < n_points:
        notes.append(f"{n_points - kept.size} point(s) in no volume cell dropped "
                     f"(first: {_point_name(read, int(np.flatnonzero(~used)[0]))})")

    points = np.asarray(read.points, dtype=float)[kept] * UNIT_SYSTEMS[length_unit][0]
    if not np.all(np.isfinite(points)):
        bad = int(kept[np.argwhere(~np.isfinite(points))[0, 0]])
        raise ModelFileError(path, "non-finite coordinate", "finite coordinates", entity=_point_name(read, bad))
    size_note = check_model_size(path, points, length_unit, unit_assumed)
    if size_note:
        notes.append(f"warning: {size_note}")
    _refuse_degenerate_cells(path, read)
    blocks = [CellBlock(b.cell_type, new_index[b.cells], b.material, b.ids) for b in read.blocks if b.cells.size]
    M, K = assemble(path, points, blocks, integration)

    node_sets = {}
    for set_name, members in read.node_sets.items():
        members = new_index[np.asarray(members, dtype=np.int64)]
        node_sets[str(set_name)] = np.unique(members[members >= 0])
    fixed = np.asarray(read.fixed, dtype=np.int64).reshape(-1, 2)
    unused_fixed = fixed[new_index[fixed[:, 0]] < 0]
    if unused_fixed.size:
        notes.append(f"constraints on {np.unique(unused_fixed[:, 0]).size} point(s) in no volume cell ignored")
    fixed = fixed[new_index[fixed[:, 0]] >= 0]
    constrained = np.unique(3 * new_index[fixed[:, 0]] + fixed[:, 1]).astype(np.int64)

    cell_counts = {}
    for b in blocks:
        cell_counts[b.cell_type] = cell_counts.get(b.cell_type, 0) + b.cells.shape[0]
    notes.insert(0, "cells: " + ", ".join(f"{n} {t}" for t, n in cell_counts.items()) + f"; {integration} integration")
    materials = {b.material for b in blocks}
    meta = {"source": str(path), "cells": cell_counts, "integration": integration}
    if read.point_ids is not None:
        meta["node_ids"] = np.asarray(read.point_ids)[kept]
    scale = UNIT_SYSTEMS[length_unit][0]
    units = units_text or ("SI (m)" if length_unit == "m" else f"coordinates in {length_unit}, scaled by {scale:g} to m")
    provenance = Provenance(source=str(path), format=file_format, reader=reader, units=units,
                            material=next(iter(materials)).as_tuple() if len(materials) == 1 else
                            tuple(m.as_tuple() for m in sorted(materials, key=lambda m: (m.E, m.nu, m.rho))),
                            notes=tuple(notes))
    cells = {}                                 # per meshio type, the blocks' cells in order (stresses read them)
    for b in blocks:
        cells[b.cell_type] = np.vstack([cells[b.cell_type], b.cells]) if b.cell_type in cells else b.cells
    return Structure(nodes=points, dofs_per_node=3, M=M, K=K, name=name, meta=meta, constrained_dofs=constrained,
                     node_sets=node_sets, provenance=provenance, cells=cells)


def _refuse_degenerate_cells(path, read: ReadMesh) -> None:
    """ModelFileError naming the first cell (its number and nodes) that is flat, has coinciding nodes or is folded
    over itself (corners of both orientations): flexfmu.importers.elements.FLAT_CELL_RTOL.  A cell of the mirrored
    orientation throughout is accepted (its volume is the same)."""
    points = np.asarray(read.points, dtype=float)
    for block in read.blocks:
        ct = CELL_TYPES.get(block.cell_type)
        if ct is None or not block.cells.size:
            continue
        q = corner_volumes(ct, points[block.cells[:, :ct.n_vertices]])
        oriented = np.where(np.sum(q, axis=1, keepdims=True) < 0, -q, q)       # mirrored cells: their own sign
        bad = ~(np.min(oriented, axis=1) >= FLAT_CELL_RTOL)                   # NaN (coinciding nodes) included
        if np.any(bad):
            row = int(np.flatnonzero(bad)[0])
            worst = float(np.min(oriented[row]))
            what = ("folded over itself (corners of opposite orientation: a node order other than meshio's, or a "
                    "cell turned inside out)" if worst < 0 else
                    "flat: its corners span no volume (coinciding or coplanar nodes)" if not worst > 1e-15 else
                    f"nearly flat: the volume at its worst corner is {worst:.2g} of its longest edge cubed")
            nodes = ", ".join(_point_name(read, int(i)).split()[-1] for i in block.cells[row])
            kind = "node" if read.point_ids is not None else "point"
            raise ModelFileError(path, f"is {what}; its {kind}s {nodes}"
                                 + (f" ({bad.sum()} such cells in all)" if bad.sum() > 1 else ""),
                                 f"cells whose every corner spans at least {FLAT_CELL_RTOL:g} x (longest edge)^3, "
                                 "all corners of one orientation", entity=f"{block.cell_type} {block.cell_id(row)}")


def versions(*packages: str) -> str:
    """'meshio 5.3.5, scikit-fem 12.0.2' for the installed packages."""
    from importlib.metadata import PackageNotFoundError, version

    out = []
    for p in packages:
        try:
            out.append(f"{p} {version(p)}")
        except PackageNotFoundError:
            out.append(p)
    return ", ".join(out)
