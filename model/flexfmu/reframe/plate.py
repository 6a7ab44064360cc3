"""The paper's flexible plate (reframe-flexible-body, Section 4) as a :class:`Structure`.

1000 x 50 x 10 mm aluminium plate (E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3), occupying
x in [-0.5, 0.5], y in [-0.025, 0.025], z in [0, 0.01] m, with a 1 kg point mass at each of
the eight corners P1 ... P8 (the paper's numbering).  Meshed and assembled with scikit-fem:
``MeshTet.init_tensor`` (each box of an nx x ny x nz grid split into six tetrahedra), quadratic
tetrahedra (tetra10, ``ElementVector(ElementTetP2())``), ``linear_elasticity`` for K and the
scalar ``mass`` form, expanded to x, y, z, for M.

Nodes are all P2 DOF nodes: the mesh vertices (in ``mesh.p`` order) followed by the edge
midpoints (in ``mesh.edges`` order); DOF ``3 i + j`` is component j of node i.  scikit-fem's own
DOF numbering is mapped onto this order explicitly (:func:`plate_fe`).

Note on mesh convergence: a point mass on a single node of a 3-D solid sits on a singularity
(the displacement under a point force in 3-D elasticity is unbounded), so the modes in which
the corner masses move most (torsion near 86 Hz, axial near 534 Hz) keep softening under
refinement instead of converging.  The paper's Table 1 belongs to its particular mesh; the
default divisions here reproduce it within 0.6% (docs/plate_mesh_convergence.md).
"""
from __future__ import annotations

import numbers

import numpy as np
import scipy.sparse as sp

from flexfmu.errors import ParameterError
from flexfmu.core.structure import Structure

LENGTHS = (1.0, 0.05, 0.01)          # m, L1 x L2 x L3
X_RANGE = (-0.5, 0.5)
Y_RANGE = (-0.025, 0.025)
Z_RANGE = (0.0, 0.01)
YOUNGS_MODULUS = 70e9                # Pa
POISSON = 0.33
DENSITY = 2700.0                     # kg/m^3
CORNER_MASS = 1.0                    # kg at each corner
CORNERS = np.array([                 # P1 ... P8, m (paper: mm)
    [-0.5, -0.025, 0.0], [0.5, -0.025, 0.0], [0.5, 0.025, 0.0], [-0.5, 0.025, 0.0],
    [-0.5, -0.025, 0.01], [0.5, -0.025, 0.01], [0.5, 0.025, 0.01], [-0.5, 0.025, 0.01],
])
LOAD_POINT = 0.5 * (CORNERS[4] + CORNERS[7])      # midway between P5 and P8: (-0.5, 0, 0.01)
DEFAULT_DIVISIONS = (100, 8, 2)      # 51 255 DOFs; Table 1 within 0.6%
MAX_CELLS = 50_000                   # nx * ny * nz limit (~1.6 million DOFs)

# Paper, Table 1: first ten flexible modes (modes 7-16), Hz.
PAPER_FREQUENCIES_HZ = np.array([24.5282, 85.8433, 93.2656, 117.3671, 206.1601,
                                 359.8918, 387.63, 534.3499, 544.946, 579.7381])


def _check_divisions(divisions) -> tuple[int, int, int]:
    allowed = f"three integers (nx, ny, nz) >= 1 with nx * ny * nz <= {MAX_CELLS}"
    try:
        d = tuple(divisions)
    except TypeError:
        raise ParameterError("divisions", f"{divisions!r} is not a sequence", allowed) from None
    if len(d) != 3 or any(isinstance(v, bool) or not isinstance(v, numbers.Integral) for v in d):
        raise ParameterError("divisions", f"{divisions!r}", allowed)
    d = tuple(int(v) for v in d)
    if min(d) < 1 or d[0] * d[1] * d[2] > MAX_CELLS:
        raise ParameterError("divisions", f"{d}", allowed)
    return d


def _check_corner_mass(corner_mass) -> float:
    if isinstance(corner_mass, bool) or not (isinstance(corner_mass, numbers.Real) and np.isfinite(corner_mass)
                                             and corner_mass >= 0):
        raise ParameterError("corner_mass", f"{corner_mass!r}", "finite number >= 0 (kg)")
    return float(corner_mass)


def plate_fe(divisions=DEFAULT_DIVISIONS):
    """scikit-fem objects of the bare plate (no corner masses), for inspection and tests.

    Returns ``(mesh, basis, nodes, perm)``: ``basis`` is the vector P2 basis, ``nodes`` the
    (N, 3) node coordinates (vertices, then edge midpoints) and ``perm`` the map from the
    node-by-node DOF order to scikit-fem's: DOF ``3 i + j`` of the Structure is scikit-fem DOF
    ``perm[3 i + j]``.  The basis integrates to degree 2 (exact for K on straight-sided P2,
    not for a P2 mass or an L2 projection: use ``Basis(mesh, basis.elem, intorder=4)``).
    """
    from skfem import Basis, ElementTetP2, ElementVector, MeshTet

    nx, ny, nz = _check_divisions(divisions)
    mesh = MeshTet.init_tensor(np.linspace(*X_RANGE, nx + 1), np.linspace(*Y_RANGE, ny + 1),
                               np.linspace(*Z_RANGE, nz + 1))
    # Straight-sided P2: strain is linear, so a degree-2 rule integrates K exactly.
    basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=2)
    nodes = np.vstack([mesh.p.T, mesh.p[:, mesh.edges].mean(axis=1).T])
    # nodal_dofs: (3, n_vertices), edge_dofs: (3, n_edges); row = component.
    perm = np.concatenate([basis.nodal_dofs.T.ravel(), basis.edge_dofs.T.ravel()])
    if perm.size != basis.N or np.unique(perm).size != basis.N:
        raise RuntimeError("scikit-fem P2 vector basis has DOFs other than vertex and edge DOFs")
    return mesh, basis, nodes, perm


_ELEMENT_CHUNK = 20_000          # elements per block of the vectorised stiffness assembly (memory ~ 0.5 GB)


def _elasticity_stiffness(basis, lam: float, mu: float) -> sp.csr_matrix:
    """K of isotropic linear elasticity on a vector basis: the bilinear form of scikit-fem's
    ``linear_elasticity`` (a(u, v) = 2 mu eps(u) : eps(v) + lam div u div v over ``basis.dx``),
    vectorised over the elements as batched matrix products instead of scikit-fem's one kernel call per
    pair of element DOFs (900 for tetra10): about half the assembly time of the default plate."""
    n_local = basis.Nbfun
    dofs = basis.element_dofs.astype(np.int32)                   # (n_local, n_elements)
    n_el = dofs.shape[1]
    size = n_local * n_local
    data = np.empty(n_el * size)
    rows = np.empty(n_el * size, dtype=np.int32)
    cols = np.empty(n_el * size, dtype=np.int32)
    for start in range(0, n_el, _ELEMENT_CHUNK):
        sl = slice(start, min(start + _ELEMENT_CHUNK, n_el))
        # (3 components, 3 derivatives, n_el, n_qp, n_local) -> strains weighted by sqrt(dx), so that the
        # element matrices are Gram matrices E^T E over (quadrature point, strain component).
        G = np.stack([basis.basis[i][0].grad[:, :, sl] for i in range(n_local)], axis=-1)
        eps = 0.5 * (G + G.transpose(1, 0, 2, 3, 4))
        root = np.sqrt(basis.dx[sl])[:, :, None]                  # (n_el, n_qp, 1), dx > 0
        E = (eps * root).transpose(2, 3, 0, 1, 4).reshape(root.shape[0], -1, n_local)
        D = (eps[0, 0] + eps[1, 1] + eps[2, 2]) * root              # divergence, (n_el, n_qp, n_local)
        Ke = 2.0 * mu * np.matmul(E.transpose(0, 2, 1), E) + lam * np.matmul(D.transpose(0, 2, 1), D)
        d = dofs[:, sl].T                                          # (n_el, n_local)
        out = slice(start * size, sl.stop * size)
        data[out] = Ke.ravel()
        rows[out] = np.repeat(d, n_local, axis=1).ravel()
        cols[out] = np.tile(d, (1, n_local)).ravel()
    K = sp.csr_matrix((data, (rows, cols)), shape=(basis.N, basis.N))
    K.eliminate_zeros()                                            # as scikit-fem's assembly
    return K


def _assemble(divisions):
    from skfem import Basis, ElementTetP2, asm
    from skfem.models.elasticity import lame_parameters
    from skfem.models.poisson import mass

    mesh, basis, nodes, perm = plate_fe(divisions)
    K = _elasticity_stiffness(basis, *lame_parameters(YOUNGS_MODULUS, POISSON))
    K = K[perm][:, perm]
    # Scalar P2 mass (P2 x P2 is degree 4), node ordered, then expanded to x, y, z per node.
    sbasis = Basis(mesh, ElementTetP2(), intorder=4)
    sperm = np.concatenate([sbasis.nodal_dofs[0], sbasis.edge_dofs[0]])
    Ms = DENSITY * asm(mass, sbasis).tocsr()[sperm][:, sperm]
    M = sp.kron(Ms, sp.identity(3), format="csr")
    # Quadrature round-off leaves ~1e-16 relative asymmetry: make both exactly symmetric.
    return mesh, nodes, _symmetric(M), _symmetric(K)


def _symmetric(A) -> sp.csr_matrix:
    A = ((A + A.T) * 0.5).tocsr()
    A.sum_duplicates()
    A.sort_indices()
    return A


def _find_node(nodes: np.ndarray, point) -> int:
    d = np.linalg.norm(nodes - np.asarray(point, dtype=float), axis=1)
    return int(np.argmin(d))


def paper_plate(divisions=DEFAULT_DIVISIONS, *, corner_mass: float = CORNER_MASS) -> Structure:
    """The paper's plate with eight corner point masses; 3 DOFs per node, SI units.

    divisions:    (nx, ny, nz) boxes along x, y, z, each split into six tetra10 elements.
                  Default (100, 8, 2): 51 255 DOFs, first ten flexible frequencies within
                  0.6% of the paper's Table 1, assembly + modal analysis about 5 s.
    corner_mass:  kg added to x, y and z of each corner node (paper: 1 kg); >= 0.

    points: name -> node index for P1 ... P8, the load point and the reference points R = P1, P = P2,
    Q = P3.  meta: ``corner_nodes`` (8 node indices, P1 ... P8), ``load_point`` (m), ``divisions``,
    ``n_elements``, ``material``, ``element``, ``paper_frequencies_hz``.
    """
    d = _check_divisions(divisions)
    corner_mass = _check_corner_mass(corner_mass)
    mesh, nodes, M, K = _assemble(d)

    corner_nodes = [_find_node(nodes, c) for c in CORNERS]
    n_vertices = mesh.p.shape[1]
    for name, idx, c in zip((f"P{i}" for i in range(1, 9)), corner_nodes, CORNERS):
        if idx >= n_vertices or np.linalg.norm(nodes[idx] - c) > 1e-12:
            raise RuntimeError(f"corner {name} {c} is not a mesh vertex")
    lumped = np.zeros(M.shape[0])
    for idx in corner_nodes:
        lumped[3 * idx:3 * idx + 3] += corner_mass
    M = (M + sp.diags(lumped)).tocsr()

    points = {f"P{i}": idx for i, idx in enumerate(corner_nodes, start=1)}
    load_node = _find_node(nodes, LOAD_POINT)
    points["load"] = load_node
    points.update(R=corner_nodes[0], P=corner_nodes[1], Q=corner_nodes[2])
    meta = {
        "source": "reframe-flexible-body, Section 4",
        "divisions": d,
        "n_elements": int(mesh.t.shape[1]),
        "element": "tetra10 (scikit-fem ElementVector(ElementTetP2()))",
        "material": {"E": YOUNGS_MODULUS, "nu": POISSON, "rho": DENSITY},
        "corner_mass": float(corner_mass),
        "corner_nodes": corner_nodes,
        "load_point": LOAD_POINT.copy(),
        "load_point_offset": float(np.linalg.norm(nodes[load_node] - LOAD_POINT)),
        "paper_frequencies_hz": PAPER_FREQUENCIES_HZ.copy(),
    }
    name = f"paper_plate {d[0]}x{d[1]}x{d[2]}"
    return Structure(nodes=nodes, dofs_per_node=3, M=M, K=K, name=name, meta=meta, points=points)
