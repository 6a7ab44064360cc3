"""Linear elasticity stiffness and consistent mass of volume cells with scikit-fem, node by node.

:func:`assemble` takes the nodes and blocks of cells (one cell type and one material each, nodes in meshio's
order, :mod:`flexfmu.importers.elements`) and returns M and K with DOF ``3 i + j`` = component j of node i:

    K = sum over cells of  int 2 mu eps(u) : eps(v) + lambda div u div v   (scikit-fem ``linear_elasticity``)
    M = sum over cells of  int rho u . v

Each block is assembled on its own scikit-fem mesh and its DOFs are mapped onto the nodes by entity: vertex k
of the scikit-fem mesh is a node, edge (a, b) is the edge node the cells name for the vertex pair {a, b},
face {a, b, c, d} likewise, and a cell's interior DOF is its centre node.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from flexfmu.errors import ModelFileError
from flexfmu.importers.elements import CELL_TYPES, SUPPORTED, CellType, entity_centroids
from flexfmu.importers.units import Material


@dataclass
class CellBlock:
    """Cells of one type and one material: ``cells`` (n_cells, n_nodes) node indices in meshio's order;
    ``ids`` the cells' numbers in the file (for messages; default: their rows)."""

    cell_type: str
    cells: np.ndarray
    material: Material
    ids: np.ndarray | None = None

    def cell_id(self, row: int) -> int:
        return int(self.ids[row]) if self.ids is not None else int(row)


def _entity_nodes(path, block: CellBlock, kind: str, local: tuple, offset: int, vertex_of: np.ndarray):
    """(sorted vertex tuples (n_entities, k), node per entity) of the cells' higher-order nodes of one kind;
    refuses two cells that put different nodes on the same edge or face (a non-conforming mesh)."""
    cells = block.cells
    keys = np.sort(np.concatenate([vertex_of[cells[:, list(e)]] for e in local]), axis=1)
    nodes = np.concatenate([cells[:, offset + i] for i in range(len(local))])
    rows = np.concatenate([np.arange(cells.shape[0])] * len(local))
    uniq, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    clash = np.nonzero(nodes != nodes[first][inverse])[0]
    if clash.size:
        i = int(clash[0])
        j = int(first[inverse[i]])
        raise ModelFileError(path, f"cells {block.cell_id(rows[j])} and {block.cell_id(rows[i])} put different "
                             f"nodes ({nodes[j]}, {nodes[i]}) on the same {kind}: the mesh is not conforming",
                             "one node per shared edge / face", entity=f"{block.cell_type} {block.cell_id(rows[i])}")
    return uniq, nodes[first]


def _lookup(path, block, kind, table_keys, table_nodes, query):
    """Nodes of the scikit-fem entities ``query`` (n, k sorted vertex tuples) in the cells' table."""
    both = np.concatenate([table_keys, np.sort(query, axis=1)])
    _, inverse = np.unique(both, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    position = np.full(inverse.max() + 1, -1)
    position[inverse[:len(table_keys)]] = np.arange(len(table_keys))
    found = position[inverse[len(table_keys):]]
    if np.any(found < 0):
        raise ModelFileError(path, f"scikit-fem finds a {kind} that no {block.cell_type} cell has a node on",
                             f"complete {block.cell_type} cells", entity=block.cell_type)
    return table_nodes[found]


def _check_node_positions(path, block: CellBlock, ct: CellType, points: np.ndarray) -> None:
    """Each edge / face / centre node must be nearest to its own entity of the cell: catches node orders
    other than meshio's and cells too distorted to assemble."""
    xyz = points[block.cells]
    centroids = entity_centroids(ct, xyz[:, :ct.n_vertices])
    higher = xyz[:, ct.n_vertices:]
    distance = np.linalg.norm(higher[:, :, None, :] - centroids[:, None, :, :], axis=-1)
    wrong = np.argmin(distance, axis=2) != np.arange(higher.shape[1])
    if np.any(wrong):
        row, k = (int(v) for v in np.argwhere(wrong)[0])
        raise ModelFileError(path, f"node {int(block.cells[row, ct.n_vertices + k])} (local node {ct.n_vertices + k})"
                             f" is not at its edge/face of the cell: node order other than meshio's "
                             f"{ct.name} order, or a cell too distorted", f"{ct.name} cells in meshio (VTK) node order",
                             entity=f"{ct.name} {block.cell_id(row)}")


def _block_basis(path, block: CellBlock, points: np.ndarray):
    """(vector scikit-fem basis, node index of each of its DOFs' nodes, component of each DOF)."""
    from skfem import Basis, ElementVector
    from skfem.assembly import Dofs

    ct = CELL_TYPES[block.cell_type]
    mesh_class, element_class = ct.skfem()
    if ct.quadratic:
        _check_node_positions(path, block, ct, points)
    corners = block.cells[:, :ct.n_vertices][:, ct.vertex_order()]
    vertices, t = np.unique(corners, return_inverse=True)
    t = t.reshape(corners.shape).T.astype(np.int64)
    mesh = mesh_class(np.ascontiguousarray(points[vertices].T), np.ascontiguousarray(t))
    vertex_of = np.full(points.shape[0], -1)
    vertex_of[vertices] = np.arange(vertices.size)

    # scikit-fem entity -> node, for vertices, edges, faces, cell centres
    scalar = Dofs(mesh, element_class())
    entity_node = {"nodal": vertices}
    if ct.edges:
        keys, nodes = _entity_nodes(path, block, "edge", ct.edges, ct.n_vertices, vertex_of)
        entity_node["edge"] = _lookup(path, block, "edge", keys, nodes, mesh.edges.T)
    if ct.faces:
        keys, nodes = _entity_nodes(path, block, "face", ct.faces, ct.n_vertices + len(ct.edges), vertex_of)
        entity_node["facet"] = _lookup(path, block, "face", keys, nodes, mesh.facets.T)
    if ct.centre:
        entity_node["interior"] = block.cells[:, -1]
    if ct.quadratic:
        # isoparametric geometry: the mesh's DOF locations are the file's nodes (curved cells stay curved)
        doflocs = np.zeros((3, scalar.N))
        for kind, nodes in entity_node.items():
            doflocs[:, getattr(scalar, f"{kind}_dofs")[0]] = points[nodes].T
        mesh = replace(mesh, doflocs=doflocs, elem=element_class, affine=False)

    basis = Basis(mesh, ElementVector(element_class()), intorder=ct.quadrature)
    node = np.full(basis.N, -1)
    component = np.full(basis.N, -1)
    for kind, nodes in entity_node.items():
        dofs = getattr(basis, f"{kind}_dofs")                  # (3, n_entities), row = component
        node[dofs] = nodes[None, :]
        component[dofs] = np.arange(3)[:, None]
    if np.any(node < 0):
        raise RuntimeError(f"scikit-fem's {ct.element} has DOFs on entities without nodes")
    return basis, node, component


def _elasticity_forms(material: Material):
    from skfem import BilinearForm
    from skfem.helpers import dot
    from skfem.models.elasticity import linear_elasticity

    rho = material.rho

    @BilinearForm
    def mass(u, v, w):
        return rho * dot(u, v)

    return mass, linear_elasticity(*material.lame())


def assemble(path, points: np.ndarray, blocks: list[CellBlock], integration: str = "full"
             ) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """M and K (3 N x 3 N, exactly symmetric CSR) of the cells in ``blocks`` on the N ``points`` (m);
    ``integration`` "full" or "reduced" (:mod:`flexfmu.importers.elements`)."""
    from skfem import Basis, asm

    n_dof = 3 * points.shape[0]
    parts_M, parts_K = [], []
    for block in blocks:
        if block.cell_type not in CELL_TYPES:
            raise ModelFileError(path, f"cell type {block.cell_type!r} is not supported", SUPPORTED,
                                 entity=block.cell_type)
        basis, node, component = _block_basis(path, block, points)
        global_dof = 3 * node + component
        mass, stiffness = _elasticity_forms(block.material)
        reduced = CELL_TYPES[block.cell_type].reduced
        stiffness_basis = (Basis(basis.mesh, basis.elem, intorder=reduced)
                           if integration == "reduced" and reduced is not None else basis)
        for form, b, parts in ((mass, basis, parts_M), (stiffness, stiffness_basis, parts_K)):
            local = asm(form, b).tocoo()
            parts.append(sp.csr_matrix((local.data, (global_dof[local.row], global_dof[local.col])),
                                       shape=(n_dof, n_dof)))
    return tuple(_symmetric(sum(parts[1:], parts[0])) for parts in (parts_M, parts_K))


def _symmetric(A) -> sp.csr_matrix:
    # quadrature round-off leaves ~1e-16 relative asymmetry
    A = ((A + A.T) * 0.5).tocsr()
    A.sum_duplicates()
    A.sort_indices()
    return A
