"""Stress and strain of a solid body's displacement shapes: what its gauges output (flexfmu export --gauge) and the
nodal stress shapes of its shape file.

The cells are a Structure's (``Structure.cells``: meshio cell type -> node indices in meshio's, VTK's, node order),
each isoparametric: x(X) = sum_k N_k(X) x_k over its nodes, u(X) = sum_k N_k(X) u_k, with X in scikit-fem's
reference cell (tetrahedra: the unit simplex; hexahedra: [0, 1]^3) and N_k scikit-fem's Lagrange functions of the
cell type (tetra: ElementTetP1, tetra10: ElementTetP2, hexahedron: ElementHex1, hexahedron20: ElementHexS2,
hexahedron27: ElementHex2; the elements flexfmu.importers assembles K with).  A node is matched to scikit-fem's
local function by its reference position (the function is 1 there, 0 at the other nodes).  Then

    grad u = sum_k u_k (J^-T grad_X N_k),   J = sum_k x_k (grad_X N_k)^T,
    eps = (grad u + grad u^T) / 2,          sigma = lambda tr(eps) I + 2 mu eps   (isotropic, one material)

as six components in flexfmu.core.stress.VOIGT order (tensor strains: eps_xy = gamma_xy / 2), body frame.

Where a gauge reads them:

* a point X (m, body frame): the cell containing it (the first found, within a relative 1e-9 of its reference
  cell's faces), evaluated at the point's reference coordinates (Newton's method on x(X) = point);
* a node set: the mean over its nodes of the nodal values, each the mean over the cells sharing the node of the
  cell's value at that node (the usual averaged nodal stress; at a node on a clamp or a corner the cells disagree
  and the mean is what post-processors show).

Stress and strain are linear in the displacement: for the retained shapes Phi (n_dof, m) of a body (modes, then
the static-correction vectors) they are (6, m) matrices, and a gauge's stress is S eta (flexfmu.body.simulator).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from flexfmu.core.checks import shown
from flexfmu.errors import ParameterError

#: meshio cell type -> (scikit-fem scalar element, vertices); the cells flexfmu.importers.elements assembles
CELL_ELEMENTS = {"tetra": ("ElementTetP1", 4), "tetra10": ("ElementTetP2", 4), "hexahedron": ("ElementHex1", 8),
                 "hexahedron20": ("ElementHexS2", 8), "hexahedron27": ("ElementHex2", 8)}
# meshio's (VTK's) local vertices in scikit-fem's reference cells, and the vertex pairs / quadruples of the edge and
# face nodes in meshio's order after the vertices (the same tables as flexfmu.importers.elements: VTK's)
_TET_VERTICES = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
_HEX_VERTICES = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
                         dtype=float)
_TET_EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))
_HEX_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7))
_HEX_FACES = ((0, 3, 7, 4), (1, 2, 6, 5), (0, 1, 5, 4), (3, 2, 6, 7), (0, 1, 2, 3), (4, 5, 6, 7))
#: a point is in a cell when its reference coordinates are inside the reference cell within this
INSIDE_TOL = 1e-9
NEWTON_STEPS = 30
GAUGE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")
GAUGE_ALLOWED = ("NAME=SET (the averaged nodal stress of a node set) or NAME=X,Y,Z (the stress at a point, m, body "
                 "frame); NAME a letter, then letters, digits or _ (at most 64), unique")
#: the model sources whose Structure carries cells (what a gauge needs)
GAUGE_SOURCES = ("meshes read with meshio (gmsh .msh, Abaqus .inp, VTK, ... or a model JSON naming one), Nastran "
                 "decks of solid elements, and .npz models saved with their cells")


class _CellShapes:
    """The Lagrange functions of one cell type in meshio's node order, from scikit-fem's element."""

    def __init__(self, cell_type: str):
        import skfem

        element_name, n_vertices = CELL_ELEMENTS[cell_type]
        self.element = getattr(skfem, element_name)()
        vertices = _TET_VERTICES if n_vertices == 4 else _HEX_VERTICES
        reference = [vertices]
        if cell_type in ("tetra10",):
            reference.append(np.array([vertices[list(e)].mean(axis=0) for e in _TET_EDGES]))
        if cell_type in ("hexahedron20", "hexahedron27"):
            reference.append(np.array([vertices[list(e)].mean(axis=0) for e in _HEX_EDGES]))
        if cell_type == "hexahedron27":
            reference.append(np.array([vertices[list(f)].mean(axis=0) for f in _HEX_FACES]))
            reference.append(vertices.mean(axis=0, keepdims=True))
        #: (k, 3) reference position of each of the cell's nodes (meshio order)
        self.reference = np.vstack(reference)
        self.tetrahedron = n_vertices == 4
        doflocs = np.asarray(self.element.doflocs, dtype=float)
        distance = np.linalg.norm(doflocs[:, None, :] - self.reference[None, :, :], axis=-1)
        #: scikit-fem's local function of each node
        self.function_of_node = np.argmin(distance, axis=0)
        if (np.sort(self.function_of_node) != np.arange(doflocs.shape[0])).any() or distance.min(axis=0).max() > 1e-12:
            raise RuntimeError(f"scikit-fem's {element_name} has no function at some node of a {cell_type} cell")

    def functions(self, X: np.ndarray):
        """(N (q, k), dN/dX (q, k, 3)) at reference points X (q, 3), the nodes in meshio order."""
        X = np.asarray(X, dtype=float).reshape(-1, 3)
        q, k = X.shape[0], self.reference.shape[0]
        N, dN = np.empty((q, k)), np.empty((q, k, 3))
        for node, i in enumerate(self.function_of_node):
            phi, dphi = self.element.lbasis(X.T, int(i))
            N[:, node], dN[:, node, :] = phi, np.asarray(dphi).T
        return N, dN

    def inside(self, X: np.ndarray, tol: float = INSIDE_TOL) -> np.ndarray:
        X = np.atleast_2d(X)
        if self.tetrahedron:
            return np.all(X >= -tol, axis=1) & (X.sum(axis=1) <= 1.0 + tol)
        return np.all((X >= -tol) & (X <= 1.0 + tol), axis=1)


def _gradients(shapes: _CellShapes, xyz: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Physical gradients (c, q, k, 3) of the nodal functions of cells with node coordinates xyz (c, k, 3) at the
    reference points X (q, 3) (the same in every cell)."""
    _, dN = shapes.functions(X)                                     # (q, k, 3)
    J = np.einsum("ckx,qka->cqxa", xyz, dN)                         # dx/dX
    return np.einsum("cqax,qka->cqkx", np.linalg.inv(J), dN)        # J^-T dN/dX: inv(J)[a, x] dN_a


def _strain_of_gradient(G: np.ndarray, U: np.ndarray) -> np.ndarray:
    """Strains (..., 6, m) from the gradients G (..., k, 3) of a cell's nodal functions and its nodal
    displacements U (..., k, 3, m)."""
    grad = np.einsum("...kb,...kam->...abm", G, U)                  # du_a / dx_b
    out = np.empty(grad.shape[:-3] + (6, grad.shape[-1]))
    for n, (a, b) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))):
        out[..., n, :] = 0.5 * (grad[..., a, b, :] + grad[..., b, a, :])
    return out


def stress_of_strain(strain: np.ndarray, E: float, nu: float) -> np.ndarray:
    """sigma = lambda tr(eps) I + 2 mu eps for tensor strains (..., 6, ...) in VOIGT order on axis -2."""
    strain = np.asarray(strain, dtype=float)
    lam, mu = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))
    out = 2.0 * mu * strain
    trace = strain[..., 0, :] + strain[..., 1, :] + strain[..., 2, :]
    for n in range(3):
        out[..., n, :] += lam * trace
    return out


def material_of(structure, what: str = "gauge") -> tuple[float, float]:
    """(E Pa, nu) of ``structure``'s one material (its provenance); ParameterError naming ``what`` otherwise."""
    material = getattr(structure.provenance, "material", ()) or ()
    pairs = dict(material) if material and all(isinstance(x, tuple) and len(x) == 2 and isinstance(x[0], str)
                                              for x in material) else {}
    if "E" not in pairs or "nu" not in pairs:
        why = ("its cells have several materials" if material else "its material is not known (no E, nu)")
        raise ParameterError(what, f"{structure.name or 'the model'}: {why}",
                             "a solid model of one isotropic material (E, nu in its provenance)")
    return float(pairs["E"]), float(pairs["nu"])


class SolidStress:
    """Stress and strain of displacement fields on ``structure``'s cells (module docstring)."""

    def __init__(self, structure, what: str = "gauge"):
        cells = getattr(structure, "cells", None) or {}
        if int(structure.dofs_per_node) != 3 or not cells:
            source = f"format {structure.provenance.format}" if structure.provenance.format else "matrices only"
            raise ParameterError(what, f"{structure.name or 'the model'} has no volume cells ({source}: a model "
                                 "read as matrices, or a beam), so no stress to evaluate",
                                 f"a solid model with its cells: {GAUGE_SOURCES}")
        unknown = sorted(set(cells) - set(CELL_ELEMENTS))
        if unknown:
            raise ParameterError(what, f"cell type {unknown[0]!r}", ", ".join(CELL_ELEMENTS))
        self.nodes = np.asarray(structure.nodes, dtype=float)
        self.cells = {t: np.asarray(c, dtype=np.int64) for t, c in cells.items() if len(c)}
        self.shapes = {t: _CellShapes(t) for t in self.cells}
        self.E, self.nu = material_of(structure, what)
        self._boxes = None

    # ------------------------------------------------------------------ points
    def locate(self, point) -> tuple[str, int, np.ndarray] | None:
        """(cell type, cell row, reference coordinates (3,)) of a cell containing ``point`` (m), else None."""
        point = np.asarray(point, dtype=float)
        if self._boxes is None:
            self._boxes = {}
            for t, c in self.cells.items():
                xyz = self.nodes[c]
                pad = 1e-9 * float(np.ptp(self.nodes, axis=0).max())
                self._boxes[t] = (xyz.min(axis=1) - pad, xyz.max(axis=1) + pad)
        for t, c in self.cells.items():
            lo, hi = self._boxes[t]
            for row in np.flatnonzero(np.all((lo <= point) & (point <= hi), axis=1)):
                X = self._reference_point(t, int(row), point)
                if X is not None and self.shapes[t].inside(X)[0]:
                    return t, int(row), X
        return None

    def _reference_point(self, cell_type: str, row: int, point: np.ndarray) -> np.ndarray | None:
        """Newton's method on x(X) = point from the reference cell's centre; None when it does not converge."""
        shapes = self.shapes[cell_type]
        xyz = self.nodes[self.cells[cell_type][row]]
        X = shapes.reference.mean(axis=0)
        size = float(np.ptp(xyz, axis=0).max())
        for _ in range(NEWTON_STEPS):
            N, dN = shapes.functions(X)
            r = N[0] @ xyz - point
            J = xyz.T @ dN[0]
            try:
                dX = np.linalg.solve(J, r)
            except np.linalg.LinAlgError:
                return None
            X = X - dX
            if np.linalg.norm(r) <= 1e-13 * size and np.abs(dX).max() <= 1e-12:
                return X
            if np.abs(X).max() > 10.0:                  # far outside: not this cell
                return None
        return X if np.linalg.norm(shapes.functions(X)[0][0] @ xyz - point) <= 1e-10 * size else None

    def strain_at(self, location, U: np.ndarray) -> np.ndarray:
        """Strain (6, m) at ``location`` (locate's result) of the displacement fields U (n_dof, m)."""
        cell_type, row, X = location
        nodes = self.cells[cell_type][row]
        G = _gradients(self.shapes[cell_type], self.nodes[nodes][None], X[None])[0, 0]     # (k, 3)
        Un = np.asarray(U, dtype=float).reshape(-1, 3, U.shape[1])[nodes]                   # (k, 3, m)
        return _strain_of_gradient(G, Un)

    # ------------------------------------------------------------------ nodal values
    def nodal_strain(self, U: np.ndarray, nodes=None, chunk: int = 2048) -> np.ndarray:
        """Averaged nodal strains (len(nodes), 6, m) of the displacement fields U (n_dof, m) (module docstring);
        ``nodes`` None: every node (a node in no cell gets 0)."""
        U = np.asarray(U, dtype=float)
        m = U.shape[1]
        Un = U.reshape(-1, 3, m)
        n_nodes = self.nodes.shape[0]
        wanted = np.ones(n_nodes, bool) if nodes is None else np.isin(np.arange(n_nodes), nodes)
        total = np.zeros((n_nodes, 6, m))
        count = np.zeros(n_nodes)
        for t, cells in self.cells.items():
            shapes = self.shapes[t]
            rows = np.flatnonzero(wanted[cells].any(axis=1))
            for start in range(0, rows.size, chunk):
                c = cells[rows[start:start + chunk]]                                      # (c, k)
                G = _gradients(shapes, self.nodes[c], shapes.reference)                   # (c, k_points, k, 3)
                eps = _strain_of_gradient(G, Un[c][:, None])                              # (c, k_points, 6, m)
                np.add.at(total, c.ravel(), eps.reshape(-1, 6, m))
                np.add.at(count, c.ravel(), 1.0)
        out = total / np.maximum(count, 1.0)[:, None, None]
        return out if nodes is None else out[np.asarray(nodes, dtype=np.int64)]

    def stress(self, strain: np.ndarray) -> np.ndarray:
        return stress_of_strain(strain, self.E, self.nu)


@dataclass(frozen=True)
class Gauge:
    """What the user asks for (--gauge NAME=SET | NAME=X,Y,Z): a node set's averaged nodal stress, or the stress
    at a point (m, body frame)."""

    name: str
    node_set: str | None = None
    point: tuple | None = None


@dataclass(frozen=True)
class GaugeData:
    """A resolved gauge as the body keeps it: strain and stress per retained coordinate (6, m) (VOIGT, body frame;
    1 and Pa per unit coordinate), and where it reads (text for the documentation)."""

    name: str
    where: str
    strain: np.ndarray
    stress: np.ndarray


def gauge_from_text(text: str) -> Gauge:
    """--gauge NAME=SET | NAME=X,Y,Z -> Gauge; ParameterError naming gauge otherwise."""
    name, sep, rest = str(text).partition("=")
    name, rest = name.strip(), rest.strip()
    if not sep or not rest:
        raise ParameterError("gauge", f"{text!r} has no '=' and place", GAUGE_ALLOWED)
    if not GAUGE_NAME.fullmatch(name):
        raise ParameterError("gauge", f"{text!r}: {name!r} is not a gauge name", GAUGE_ALLOWED)
    if "," in rest:
        try:
            values = [float(v) for v in rest.split(",")]
        except ValueError:
            raise ParameterError("gauge", f"{text!r}: the coordinates are not numbers", GAUGE_ALLOWED) from None
        if len(values) != 3 or not np.all(np.isfinite(values)):
            raise ParameterError("gauge", f"{text!r}: {len(values)} coordinate(s)", "three finite coordinates: "
                                 + GAUGE_ALLOWED)
        return Gauge(name, point=tuple(values))
    return Gauge(name, node_set=rest)


def locate_gauges(structure, gauges, evaluator: SolidStress | None = None) -> tuple:
    """Check the gauges (Gauge or --gauge text) on ``structure`` before any reduction: ParameterError naming gauge
    for a duplicate name, an unknown or empty node set, a point in no cell or a model without cells.  Returns
    (gauge, where it reads: a node array or locate's result) pairs for gauge_data."""
    gauges = [g if isinstance(g, Gauge) else gauge_from_text(g) for g in gauges]
    if not gauges:
        return ()
    names = [g.name for g in gauges]
    duplicate = next((n for n in names if names.count(n) > 1), None)
    if duplicate is not None:
        raise ParameterError("gauge", f"the name {duplicate!r} is given twice", GAUGE_ALLOWED)
    evaluator = evaluator or SolidStress(structure)
    sets = structure.node_sets or {}
    out = []
    for g in gauges:
        if g.node_set is not None:
            if g.node_set not in sets:
                raise ParameterError("gauge", f"{g.name}={g.node_set}: {shown(g.node_set)} is not a node set of "
                                     f"{structure.name or 'the model'}",
                                     "a node set: " + (", ".join(sorted(sets)) or "none in this model") + "; or "
                                     "NAME=X,Y,Z")
            members = np.asarray(sets[g.node_set], dtype=np.int64)
            if members.size == 0:
                raise ParameterError("gauge", f"{g.name}={g.node_set}: the node set selects no node",
                                     "a node set with nodes of the model")
            out.append((g, members))
            continue
        location = evaluator.locate(g.point)
        if location is None:
            lo, hi = evaluator.nodes.min(axis=0), evaluator.nodes.max(axis=0)
            raise ParameterError("gauge", f"{g.name}={','.join(f'{v:g}' for v in g.point)}: the point (m, body "
                                 "frame) is in no cell of the mesh",
                                 f"a point inside the body (its nodes span x {lo[0]:.4g} .. {hi[0]:.4g}, y "
                                 f"{lo[1]:.4g} .. {hi[1]:.4g}, z {lo[2]:.4g} .. {hi[2]:.4g} m)")
        out.append((g, location))
    return tuple(out)


def gauge_data(located, shapes: np.ndarray, evaluator: SolidStress) -> tuple[GaugeData, ...]:
    """The GaugeData of located gauges (locate_gauges) for the retained shapes (n_dof, m)."""
    out = []
    for g, place in located:
        if g.node_set is not None:
            strain = evaluator.nodal_strain(shapes, place).mean(axis=0)
            where = f"node set {g.node_set!r} ({place.size} nodes): averaged nodal stress"
        else:
            strain = evaluator.strain_at(place, shapes)
            where = (f"point ({', '.join(f'{v:.6g}' for v in g.point)}) m in {place[0]} cell {place[1]} "
                     f"(reference coordinates {', '.join(f'{v:.4g}' for v in place[2])})")
        out.append(GaugeData(g.name, where, strain, evaluator.stress(strain)))
    return tuple(out)


def resolve_gauges(structure, gauges, shapes: np.ndarray, evaluator: SolidStress | None = None
                   ) -> tuple[GaugeData, ...]:
    """locate_gauges, then gauge_data for the retained shapes (n_dof, m)."""
    evaluator = evaluator or SolidStress(structure)
    return gauge_data(locate_gauges(structure, gauges, evaluator), shapes, evaluator)
