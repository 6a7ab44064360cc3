"""The volume cell types flexfmu assembles, in meshio's (= VTK's) node order, and their scikit-fem elements.

Every node of a cell carries three DOFs; scikit-fem's DOFs of a cell are identified with the cell's nodes by
*entity* (vertex, edge, face, cell centre), not by local position, so scikit-fem's own local numbering never
matters:

==============  ========================  =====================  ============================================
meshio type     scikit-fem element        quadrature (degree)    nodes
==============  ========================  =====================  ============================================
tetra           ElementTetP1              2 (mass exact)         4 vertices
tetra10         ElementTetP2              4 (mass exact)         4 vertices, 6 edge nodes
hexahedron      ElementHex1               3 (2x2x2 Gauss)        8 vertices
hexahedron20    ElementHexS2 (serendip.)  5 (3x3x3 Gauss)        8 vertices, 12 edge nodes
hexahedron27    ElementHex2               5 (3x3x3 Gauss)        8 vertices, 12 edge, 6 face nodes, 1 centre
==============  ========================  =====================  ============================================

``integration="reduced"`` integrates the stiffness of the quadratic hexahedra with 2x2x2 Gauss points (Abaqus
C3D20R, MAPDL SOLID186's default); the mass and the other cells keep the rules above.
Quadratic cells are isoparametric: their edge (and face, centre) nodes may lie off the straight edges
(curved geometry).  The quadrature is exact for M and K on straight-sided tetrahedra and on parallelepipeds.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# VTK's local edges and faces of the hexahedron (meshio uses VTK's node order; gmsh's is converted on read).
HEX_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7))
HEX_FACES = ((0, 3, 7, 4), (1, 2, 6, 5), (0, 1, 5, 4), (3, 2, 6, 7), (0, 1, 2, 3), (4, 5, 6, 7))
TET_EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))
#: each corner and its three neighbours along the edges, right-handed in a cell of positive volume (VTK order)
HEX_CORNERS = ((1, 3, 4), (2, 0, 5), (3, 1, 6), (0, 2, 7), (7, 5, 0), (4, 6, 1), (5, 7, 2), (6, 4, 3))
TET_CORNERS = ((1, 2, 3),)
#: a cell is degenerate when the volume spanned by a corner's three edges is below this fraction of its longest
#: edge cubed (a unit cube: 1; a regular tetrahedron: 0.71), or when its corners differ in orientation (folded).
#: The determinant's rounding is ~1e-15 of the edge cubed, so 1e-8 is far above noise; a cell below it held a
#: node by almost no stiffness in one direction (a sliver 1e-9 thick: "more than six zero-energy modes") or, at
#: zero volume, made scikit-fem divide by zero (NaN in K, pages of numpy warnings).
FLAT_CELL_RTOL = 1e-8


@dataclass(frozen=True)
class CellType:
    """One supported volume cell type: its local node layout (meshio order) and scikit-fem objects."""

    name: str
    n_vertices: int
    edges: tuple = ()          # local vertex pairs of the edge nodes, in node order after the vertices
    faces: tuple = ()          # local vertex quadruples of the face nodes, after the edge nodes
    centre: bool = False       # one node at the cell centre, last
    mesh: str = ""             # scikit-fem linear mesh class
    element: str = ""          # scikit-fem scalar element class
    quadrature: int = 2        # scikit-fem intorder
    reduced: int | None = None # intorder of the stiffness with integration="reduced"

    @property
    def n_nodes(self) -> int:
        return self.n_vertices + len(self.edges) + len(self.faces) + int(self.centre)

    @property
    def quadratic(self) -> bool:
        return self.n_nodes > self.n_vertices

    def vertex_order(self) -> np.ndarray:
        """scikit-fem's vertex order of the cell as indices into meshio's vertex order."""
        if self.mesh == "MeshHex1":
            from skfem.io.meshio import INV_HEX_MAPPING     # scikit-fem's own meshio conversion
            return np.asarray(INV_HEX_MAPPING[:8])
        return np.arange(self.n_vertices)

    def skfem(self):
        """(linear mesh class, scalar element class)."""
        import skfem
        return getattr(skfem, self.mesh), getattr(skfem, self.element)


CELL_TYPES = {c.name: c for c in (
    CellType("tetra", 4, mesh="MeshTet1", element="ElementTetP1", quadrature=2),
    CellType("tetra10", 4, TET_EDGES, mesh="MeshTet1", element="ElementTetP2", quadrature=4),
    CellType("hexahedron", 8, mesh="MeshHex1", element="ElementHex1", quadrature=3),
    CellType("hexahedron20", 8, HEX_EDGES, mesh="MeshHex1", element="ElementHexS2", quadrature=5,
             reduced=3),
    CellType("hexahedron27", 8, HEX_EDGES, HEX_FACES, True, mesh="MeshHex1", element="ElementHex2",
             quadrature=5, reduced=3),
)}
INTEGRATIONS = ("full", "reduced")
#: meshio's other names for the same cells (Abaqus C3D4H is read as "tetra4").
ALIASES = {"tetra4": "tetra", "hexahedron8": "hexahedron"}
SUPPORTED = ", ".join(CELL_TYPES)


def check_integration(value) -> str:
    from flexfmu.errors import ParameterError
    if value not in INTEGRATIONS:
        raise ParameterError("integration", f"{value!r}", " | ".join(INTEGRATIONS))
    return value


def volume_cell_types() -> set:
    """All 3-D cell types meshio knows (supported or not)."""
    from meshio._mesh import topological_dimension
    return {name for name, dim in topological_dimension.items() if dim == 3}


def corner_volumes(cell_type: CellType, corner_xyz: np.ndarray) -> np.ndarray:
    """(n_cells, n_corners): det[e1, e2, e3] / (longest edge)^3 at each corner of each cell, e_k its edges to the
    corner's neighbours (HEX_CORNERS, TET_CORNERS), from the corner coordinates (n_cells, n_vertices, 3): a
    straight-sided cell's local volume measure, positive for meshio's (VTK's) orientation, 0 for a flat cell."""
    xyz = np.asarray(corner_xyz, dtype=float)
    corners = HEX_CORNERS if cell_type.n_vertices == 8 else TET_CORNERS
    edges = HEX_EDGES if cell_type.n_vertices == 8 else TET_EDGES
    longest = np.max(np.stack([np.linalg.norm(xyz[:, a] - xyz[:, b], axis=-1) for a, b in edges], axis=1), axis=1)
    out = np.empty((xyz.shape[0], len(corners)))
    with np.errstate(all="ignore"):                 # 0 / 0 of a cell whose nodes coincide: NaN, refused
        for k, (a, b, c) in enumerate(corners):
            e = np.stack([xyz[:, a] - xyz[:, k], xyz[:, b] - xyz[:, k], xyz[:, c] - xyz[:, k]], axis=1)
            out[:, k] = np.linalg.det(e) / longest**3
    return out


def entity_centroids(cell_type: CellType, corner_xyz: np.ndarray) -> np.ndarray:
    """(n_cells, n_nodes - n_vertices, 3): the centroid of each higher-order node's entity (edge, face,
    cell) from the cells' corner coordinates (n_cells, n_vertices, 3)."""
    parts = [corner_xyz[:, list(e)].mean(axis=1) for e in cell_type.edges + cell_type.faces]
    if cell_type.centre:
        parts.append(corner_xyz.mean(axis=1))
    return np.stack(parts, axis=1)
