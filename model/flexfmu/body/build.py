"""build_body: a Structure and its interfaces -> the reduced :class:`~flexfmu.body.model.FlexBody`.

Steps: check the structure (flexfmu.core.io.validate_structure); resolve the interfaces' patches
(flexfmu.body.interfaces); choose the retained coordinates (flexfmu.sizing.interfaces: n_modes given, or the
modes for f_max and tolerance with the static correction at the interfaces); compute the reduced arrays
(flexfmu.body.free or flexfmu.body.clamped); keep the interface rows and the provenance.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from flexfmu.body.clamped import base_patterns, clamped_invariants, rigid_fields
from flexfmu.body.free import free_invariants
from flexfmu.body.interfaces import resolve_interfaces
from flexfmu.body.model import ClampedBody, FlexBody, FreeBody, InterfaceData
from flexfmu.body.stress import SolidStress, gauge_data, gauge_from_text, locate_gauges
from flexfmu.core.blas import limited_for
from flexfmu.core.checks import finite, shown
from flexfmu.core.io import validate_structure
from flexfmu.core.structure import Structure, node_set
from flexfmu.errors import ParameterError
from flexfmu.sizing.interfaces import LoadCase, clamped_modes, free_modes

#: a rigid motion counts as held when its singular value on the fixed DOFs is above this fraction of the largest
_FREE_MOTION_RTOL = 1e-8


def clamped_dofs(structure: Structure, clamp) -> tuple[np.ndarray, str]:
    n_dof = structure.nodes.shape[0] * int(structure.dofs_per_node)
    dpn = int(structure.dofs_per_node)
    if clamp == "file":
        dofs = np.unique(np.asarray(structure.constrained_dofs, dtype=np.int64).ravel())
        if dofs.size == 0:
            raise ParameterError("clamp", '"file": the model file constrains no DOF',
                                 "a node-set name, or None (a free body)")
        if dofs[0] < 0 or dofs[-1] >= n_dof:
            raise ParameterError("structure.constrained_dofs", f"indices outside 0 .. {n_dof - 1}",
                                 "DOF indices of the model")
        return dofs, f"the model file's {dofs.size} constrained DOF(s)"
    if isinstance(clamp, str):
        sets = structure.node_sets or {}
        if clamp not in sets:
            known = ", ".join(sorted(map(str, sets))) or "none in this model"
            raise ParameterError("clamp", f"unknown node set {shown(clamp)}",
                                 f'None (free), "file", or a node set: {known}')
        nodes = np.unique(np.asarray(sets[clamp], dtype=np.int64).ravel())
        nodes = nodes[(nodes >= 0) & (nodes < structure.nodes.shape[0])]
        if nodes.size == 0:
            raise ParameterError("clamp", f"node set {clamp!r} selects no node", "a node set with nodes of the model")
        return (nodes[:, None] * dpn + np.arange(dpn)).ravel(), f"node set {clamp!r} ({nodes.size} node(s), all DOFs)"
    raise ParameterError("clamp", f"{shown(clamp)}", 'None (a free body), "file" (the model\'s constraints) or a '
                         "node-set name")


def clamp_from_text(structure: Structure, spec: str | None):
    """A --clamp text -> build_body's clamp: None (default: the file's constrained DOFs when it has some, else
    free), "free", "file", a node-set name, or several joined by commas (their union, added to node_sets)."""
    if spec is None:
        return "file" if len(structure.constrained_dofs) else None
    if "," in spec:                     # several node sets held together, e.g. both bolt holes
        structure.node_sets = {**structure.node_sets,
                               spec: np.unique(np.concatenate([node_set(structure, name) for name in spec.split(",")]))}
    return None if spec == "free" else spec


def _provenance(structure: Structure, reduction: dict) -> dict:
    p = structure.provenance
    out = {}
    if p is not None and dataclasses.is_dataclass(p):
        material = ", ".join(f"{x[0]} = {x[1]:g}" if isinstance(x, tuple) and len(x) == 2 and isinstance(x[1], float)
                             else str(x) for x in p.material)
        out = {"source": str(p.source), "format": str(p.format), "reader": str(p.reader), "units": str(p.units),
               "material": material, "notes": [str(x) for x in p.notes]}
    out["reduction"] = reduction
    return out


def build_body(structure: Structure, *, interfaces, clamp=None, n_modes=None, f_max=None, tolerance=None,
               damping_ratio: float = 0.02, name: str | None = None, added_mass=None, gauges=(),
               with_shapes: bool = False) -> FlexBody:
    """The reduced body of ``structure`` with ``interfaces`` (Interface or dicts, flexfmu.body.interfaces): a
    FreeBody or a ClampedBody (flexfmu.body.model).

    clamp:          None: a free body (the model's constraints ignored); "file": clamped on the model file's
                    constrained DOFs; a node-set name: clamped on all DOFs of those nodes (the base).
    n_modes:        retained modes; or f_max (Hz) and tolerance (default 1e-3): every mode up to f_max, more
                    until the interfaces' estimated truncation error is within tolerance, and the static
                    correction (flexfmu.sizing.interfaces).
    damping_ratio:  the body's default modal damping ratio, 0 <= zeta < 1 (the FMU parameter may override it).
    added_mass:     {interface name: (6, 6) mass matrix about its point (kg, kg m, kg m^2; [translation;
                    rotation], body axes)}: a rigid mass carried by the interface's patch, M += D^T A D with D the
                    patch's rigid fit (Eq. (I3)), so its rigid motion carries exactly A (e.g. a hull's
                    infinite-frequency added mass, flexfmu.wec.barge).  A free body's must be a point mass at the
                    point (translational block m I, no coupling block): the reframe kernels carry one mass.
    gauges:         stress and strain gauges (flexfmu.body.stress.Gauge or --gauge texts NAME=SET | NAME=X,Y,Z) of
                    a solid body: outputs NAME.sigma_*, NAME.von_mises, NAME.eps_* (flexfmu.body.stress); a free
                    body's are S q of its flexible coordinates q (the residual vectors among them when f_max sizes
                    it), relative to its floating frame.
    with_shapes:    also attach ``body.shape_data`` (not saved with the body): the nodes, cells, the retained shapes
                    Psi (N, 3, m) and the nodal stress shapes (N, 6, m) of a solid body (a free body's flexible
                    shapes, body frame), what the FMU's shape file holds (flexfmu.body.shape_file); None for a body
                    without cells.
    """
    if not isinstance(structure, Structure):
        raise ParameterError("structure", f"{type(structure).__name__}", "a flexfmu Structure")
    if not (finite(damping_ratio) and 0.0 <= damping_ratio < 1.0):
        raise ParameterError("damping_ratio", f"{shown(damping_ratio)}", "0 <= damping_ratio < 1")
    gauges = [g if not isinstance(g, str) else gauge_from_text(g) for g in (gauges or ())]
    checked = validate_structure(structure)
    # a model without cells, an unknown set, a point outside the mesh: refused before the reduction's work
    evaluator = SolidStress(checked) if gauges else None
    located = locate_gauges(checked, gauges, evaluator) if gauges else ()
    # the whole reduction (modes, sizing, static correction, invariants): one choke point for the BLAS threads
    with limited_for(checked.n_dof):
        body, shapes = _reduced_body(structure, checked, interfaces, clamp, n_modes, f_max, tolerance, damping_ratio,
                                     name, added_mass)
        if gauges:
            body.gauges = gauge_data(located, shapes, evaluator)
            body.messages = body.messages + tuple(f"gauge {g.name}: {g.where}" for g in body.gauges)
            if body.n_coordinates == body.n_modes:
                body.messages = body.messages + (
                    "gauges: no static-correction vectors (n_modes given, or the interfaces' static translation "
                    "was within tolerance): a gauge's quasi-static stress carries the modes' truncation error",)
        if with_shapes:
            body.shape_data = shape_data(checked, body, shapes) if checked.cells else None
        return body


def shape_data(structure: Structure, body: FlexBody, shapes: np.ndarray) -> dict:
    """What the shape file of ``body`` holds (flexfmu.body.shape_file): nodes (N, 3) m and cells of ``structure``,
    Psi (N, 3, m) the retained shapes (u = Psi q), S (N, 6, m) their averaged nodal stresses (Pa per unit q), the
    names of q and the body's name."""
    evaluator = SolidStress(structure, "shape file")
    m = shapes.shape[1]
    return {"nodes": np.asarray(structure.nodes, float), "cells": dict(structure.cells),
            "Psi": shapes.reshape(-1, 3, m), "S": evaluator.stress(evaluator.nodal_strain(shapes)),
            "names": body.shape_names(), "name": body.name}


def _reduced_body(structure: Structure, checked: Structure, interfaces, clamp, n_modes, f_max, tolerance,
                  damping_ratio: float, name: str | None, added_mass) -> tuple[FlexBody, np.ndarray]:
    """build_body after its checks (``checked``: the validated structure): the body and its retained shapes
    (n_dof, m), zero on the clamped DOFs."""
    checked = dataclasses.replace(checked, node_sets=structure.node_sets or {},
                                  constrained_dofs=structure.constrained_dofs, provenance=structure.provenance)
    patches = resolve_interfaces(checked, interfaces)
    if added_mass:
        checked = _with_added_mass(checked, patches, added_mass, free=clamp is None)
    n_dof = checked.n_dof
    groups = {}
    for p in patches:
        G = p.loads(n_dof)
        groups[f"{p.name} force"] = G[:, :3]
        if p.moments:
            groups[f"{p.name} moment"] = G[:, 3:]
    outputs = {p.name: p.translation(n_dof) for p in patches}
    size = {"n_modes": n_modes, "f_max": f_max, "tolerance": tolerance, "damping_ratio": float(damping_ratio)}
    if clamp is None and structure.meta.get("clamped_only"):
        raise ParameterError("clamp", f"free: {structure.name or 'the model'} keeps no mass or stiffness for its "
                             f"{len(structure.constrained_dofs)} constrained DOF(s) (as MAPDL writes them), so it "
                             "has no free-body form", '"file" (clamped on those DOFs) or a node set')
    if clamp is None:
        body_class, fixed, how = FreeBody, np.zeros(0, dtype=np.int64), "free (no clamp)"
        check_parts(checked, fixed, how)
        sized = free_modes(checked, LoadCase(groups, outputs), **size)
        arrays = free_invariants(checked, sized.basis)
        mass, com, inertia = float(sized.basis.mass), sized.basis.center_of_mass, sized.basis.inertia
    else:
        body_class = ClampedBody
        fixed, how = clamped_dofs(checked, clamp)
        free = np.setdiff1d(np.arange(n_dof), fixed)
        if free.size == 0:
            raise ParameterError("clamp", f"{how} fixes every DOF", "a clamp that leaves the body free to deform")
        check_parts(checked, fixed, how)
        _check_held(checked, fixed, how)
        groups.update(base_patterns(checked))
        try:
            sized = clamped_modes(checked, free, LoadCase(groups, outputs), **size)
        except RuntimeError as exc:                    # SuperLU: "Factor is exactly singular"
            raise ParameterError("clamp", f"{how} leaves the body free to move ({exc})",
                                 "clamps that hold every rigid-body motion") from None
        arrays = clamped_invariants(checked, sized.shapes)
        mass = float(arrays["mass"])
        com = arrays["first_moment"] / mass
        J0 = arrays["J0"]
        inertia = J0 - mass * (com @ com * np.eye(3) - np.outer(com, com))   # parallel axes: about the COM
    shapes = sized.shapes
    data = tuple(InterfaceData(name=p.name, point=p.point, nodes=p.nodes, dofs=p.dofs, D=p.D, shapes=shapes[p.dofs],
                               moments=p.moments, rule=p.rule) for p in patches)
    reduction = {"kind": body_class.kind, "clamp": how, "retained modes": int(sized.n_modes),
                 "residual vectors": int(sized.eigenvalues.size - sized.n_modes),
                 "size": f"n_modes = {n_modes}" if n_modes is not None else
                 f"f_max = {f_max:g} Hz, tolerance = {1e-3 if tolerance is None else tolerance:g}",
                 "static correction": "on" if sized.eigenvalues.size > sized.n_modes else "off",
                 "damping ratio": float(damping_ratio)}
    body = body_class(name=name if name is not None else (structure.name or ""),
                      dofs_per_node=int(checked.dofs_per_node), interfaces=data,
                      eigenvalues=np.asarray(sized.eigenvalues, float), n_modes=int(sized.n_modes),
                      natural_frequencies_hz=np.asarray(sized.natural_hz, float), mass=mass,
                      center_of_mass=np.asarray(com, float), inertia=np.asarray(inertia, float),
                      damping_ratio=float(damping_ratio), arrays=arrays, provenance=_provenance(structure, reduction),
                      messages=tuple(sized.messages), clamped_dofs=fixed)
    return body, shapes


def _with_added_mass(structure: Structure, patches, added_mass: dict, free: bool) -> Structure:
    """``structure`` with M += D^T A D per interface (build_body's added_mass)."""
    by_name = {p.name: p for p in patches}
    extra = sp.csr_matrix(structure.M.shape)
    for name, A in added_mass.items():
        where = f"added_mass[{name!r}]"
        if name not in by_name:
            raise ParameterError(where, "no such interface", ", ".join(by_name) or "an interface name")
        A = np.asarray(A, dtype=float)
        if A.shape != (6, 6) or not np.all(np.isfinite(A)) or not np.allclose(A, A.T, rtol=1e-12, atol=0.0):
            raise ParameterError(where, f"shape {A.shape}, finite and symmetric: "
                                 f"{A.shape == (6, 6) and bool(np.all(np.isfinite(A)))}", "a finite symmetric 6x6")
        if np.linalg.eigvalsh(A).min() < -1e-12 * max(1.0, float(np.abs(A).max())):
            raise ParameterError(where, "not positive semi-definite", "a mass matrix (kinetic energy >= 0)")
        if free:
            m = A[0, 0]
            if not (np.allclose(A[:3, :3], m * np.eye(3), rtol=1e-12, atol=0.0) and not np.any(A[:3, 3:])):
                raise ParameterError(where, "a free body's added mass must be a point mass at the interface point",
                                     "translational block m I and a zero coupling block (the reframe kernels "
                                     "carry one mass); apply the rest as a force")
        p = by_name[name]
        D = p.D[:6] if p.moments else p.D[:3]
        block = D.T @ (A if p.moments else A[:3, :3]) @ D
        if not p.moments and np.any(A[3:, 3:]):
            raise ParameterError(where, f"interface {name} carries no moment, so its patch fits no rotation",
                                 "a rotational block of zero, or a patch that carries moments")
        rows, cols = np.meshgrid(p.dofs, p.dofs, indexing="ij")
        extra = extra + sp.csr_matrix((block.ravel(), (rows.ravel(), cols.ravel())), shape=structure.M.shape)
    return dataclasses.replace(structure, M=(structure.M + extra).tocsr())


def node_parts(structure: Structure) -> tuple[int, np.ndarray]:
    """(number of parts, part of each node): the nodes joined by stiffness (a nonzero entry of K between any of
    their DOFs; a node without any is a part of its own)."""
    from scipy.sparse.csgraph import connected_components

    dpn = int(structure.dofs_per_node)
    n = int(structure.nodes.shape[0])
    K = sp.coo_matrix(structure.K)
    coupled = K.data != 0.0
    graph = sp.csr_matrix((np.ones(int(coupled.sum())), (K.row[coupled] // dpn, K.col[coupled] // dpn)), shape=(n, n))
    return connected_components(graph, directed=False)


def _nodes_text(structure: Structure, members: np.ndarray, shown_ids: int = 5) -> str:
    """'12 node(s) (indices 40, 41, ... of the model's nodes, 0-based; the first at (x, y, z) m)', the file's node
    numbers instead when it numbers them (Nastran GRIDs, MAPDL nodes)."""
    ids = structure.meta.get("node_ids") if isinstance(structure.meta, dict) else None
    numbers = np.asarray(ids)[members] if ids is not None and len(ids) == structure.nodes.shape[0] else members
    first = ", ".join(str(int(k)) for k in numbers[:shown_ids]) + (", ..." if members.size > shown_ids else "")
    kind = "the file's node numbers" if numbers is not members else "indices of the model's nodes, 0-based"
    x = np.asarray(structure.nodes, dtype=float)[members[0]]
    return f"{members.size} node(s) ({kind}: {first}; the first at ({x[0]:.4g}, {x[1]:.4g}, {x[2]:.4g}) m)"


def check_parts(structure: Structure, fixed: np.ndarray, how: str) -> None:
    """Refuse a body in pieces (node_parts): free (``fixed`` empty), any second part ("singular free body", as the
    modal basis would find: more than six zero-energy modes); clamped, any part the clamp does not hold by all its
    rigid-body motions (not connected to the clamped set: it would drift).  The message names the part's nodes."""
    n_parts, part = node_parts(structure)
    if n_parts == 1:
        return
    sizes = np.bincount(part, minlength=n_parts)
    if fixed.size == 0:
        loose = [k for k in np.argsort(-sizes, kind="stable")[1:]]        # every part but the largest
        members = np.flatnonzero(part == loose[0])
        raise ParameterError("structure.K", f"singular free body: {n_parts} parts not connected to each other; "
                             f"{'a' if n_parts == 2 else 'the first'} loose part: {_nodes_text(structure, members)}",
                             "a connected free-free structure with exactly six rigid-body modes")
    dpn = int(structure.dofs_per_node)
    fixed_nodes = np.zeros(structure.nodes.shape[0], dtype=bool)
    fixed_nodes[np.asarray(fixed, dtype=np.int64) // dpn] = True
    fully_fixed = np.zeros(structure.nodes.shape[0] * dpn, dtype=bool)
    fully_fixed[fixed] = True
    fully_fixed = fully_fixed.reshape(-1, dpn).all(axis=1)
    for k in np.argsort(-sizes, kind="stable"):
        members = np.flatnonzero(part == k)
        if np.all(fully_fixed[members]):
            continue                        # nothing of it moves (a clamped node the model file keeps no K for)
        if not np.any(fixed_nodes[members]):
            raise ParameterError("clamp", f"{how} leaves a part of the body free: it is not connected to the clamped "
                                 f"nodes ({n_parts} parts in all); the loose part: {_nodes_text(structure, members)}",
                                 "every part of the body connected to the clamped nodes (one connected structure)")
        part_dofs = (members[:, None] * dpn + np.arange(dpn)).ravel()
        _check_held(structure, np.flatnonzero(np.isin(part_dofs, fixed)), how, members,
                    f"; the part: {_nodes_text(structure, members)}" if n_parts > 1 else "")


def _check_held(structure, fixed: np.ndarray, how: str, members=None, where: str = "") -> None:
    """Refuse clamps that leave a rigid-body motion free: the six rigid fields (translations, rotations about the
    centroid, scaled by the size) restricted to the fixed DOFs must have rank 6.  ``members``: the nodes of one
    part (``fixed`` then indexes the part's DOFs, node by node), default all."""
    nodes = np.asarray(structure.nodes, dtype=float)
    if members is not None:
        nodes = nodes[members]
    centre = nodes.mean(axis=0)
    size = float(np.linalg.norm(np.ptp(nodes, axis=0))) or 1.0
    T, S0 = rigid_fields(nodes - centre, int(structure.dofs_per_node))
    rigid = np.hstack([T, S0 / size])[fixed]
    sv = np.linalg.svd(rigid, compute_uv=False) if rigid.size else np.zeros(0)
    rank = int(np.count_nonzero(sv > _FREE_MOTION_RTOL * max(sv.max(initial=0.0), 1.0)))
    if rank < 6:
        raise ParameterError("clamp", f"{how} leaves the body free to move ({6 - rank} rigid-body motion(s) not held"
                             f"{where})", "clamps that hold every rigid-body motion (e.g. three non-colinear nodes "
                             "of a solid, or one beam node)")
