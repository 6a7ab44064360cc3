"""Assembly through the modified connectivity B_D1 and boundary conditions through B2.

Koda et al. 2025: Eq. 13 defines B_D1^ij = C_bar^ij B1^ij (element nodal coordinates in
element axes from the body's nodal vector), Eqs. 14-15 assemble
    M_fD = B2^T (sum_j B_D1^jT M_ff^j B_D1^j) B2,    K_fD likewise,
and Eq. 16 builds B2 by deleting the columns of clamped DOFs from the identity.
The sum is assembled directly as a sparse matrix (scatter-add of C_bar M C_bar^T),
which is what the product with the Boolean B1 does, without forming B1.  The element
matrices M_ff^j, K_ff^j are those of the mesh's element type (flexfmu.ffr.elements).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from flexfmu.errors import require
from flexfmu.ffr.mesh import Mesh, build_mesh
from flexfmu.ffr.scene import Scene
from flexfmu.core.structure import Structure

BOUNDARY_PRESETS = ("XFF", "XFX", "FXF", "FXF_mid", "scene", "free")
BOUNDARY_HELP = {
    "XFF": "first point clamped (paper's Eq. 16a)",
    "XFX": "first and last points clamped (Eq. 16b)",
    "FXF": "first interior vertex clamped (the paper's B2, Eq. 16c)",
    "FXF_mid": "midpoint of segment 2 clamped (the paper's ANSYS model, Sec. 3.2)",
    "scene": "the scene's own 'clamps' (none = free-free)",
    "free": "no clamps: six rigid-body modes",
}


def boundary_clamps(scene: Scene, boundary: str) -> tuple[float, ...]:
    """Arc lengths (m) clamped by a boundary preset.

    The paper is inconsistent about FXF: its B2 (Eq. 16c) clamps node 2, the first
    corner, while its ANSYS model clamps the midpoint of segment 2.  Both are offered.
    """
    require(boundary in BOUNDARY_PRESETS, "boundary", f"unknown boundary {boundary!r}",
            " | ".join(BOUNDARY_PRESETS))
    vertex_s = scene.vertex_arc_lengths
    if boundary in ("FXF", "FXF_mid"):
        require(len(vertex_s) >= 3, "boundary",
                f"{boundary} needs a scene with at least 2 segments; {scene.name} has 1",
                "XFF | XFX | scene | free")
    return {
        "XFF": lambda: (0.0,),
        "XFX": lambda: (0.0, float(vertex_s[-1])),
        "FXF": lambda: (float(vertex_s[1]),),
        "FXF_mid": lambda: (0.5 * float(vertex_s[1] + vertex_s[2]),),
        "scene": lambda: tuple(scene.clamps),
        "free": lambda: (),
    }[boundary]()


def boundary_matrix(n_nodes: int, clamped_nodes) -> sp.csr_matrix:
    """B2 (Eq. 16): (6 n_nodes, n_free) identity with the clamped nodes' 6 columns removed."""
    fixed = np.zeros(6 * n_nodes, dtype=bool)
    for node in clamped_nodes:
        fixed[6 * node:6 * node + 6] = True
    free = np.flatnonzero(~fixed)
    return sp.csr_matrix((np.ones(free.size), (free, np.arange(free.size))), shape=(6 * n_nodes, free.size))


def assemble(mesh: Mesh, rotary_inertia: bool = False) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Unconstrained body-frame M and K (sum over elements of B_D1^T M^j B_D1), plus point masses."""
    sec, mat, element = mesh.scene.section, mesh.scene.material, mesh.element
    L = mesh.element_length
    Kloc = element.stiffness(L, sec, mat)
    Mloc = element.mass(L, sec, mat, rotary_inertia=rotary_inertia)
    Cbar = element.dof_rotation(mesh.element_rotation)
    Kb = np.einsum("nij,njk,nlk->nil", Cbar, Kloc, Cbar)   # C_bar K C_bar^T
    Mb = np.einsum("nij,njk,nlk->nil", Cbar, Mloc, Cbar)
    dofs = (6 * mesh.elements[:, :, None] + np.arange(6)).reshape(-1, 12)   # B1 as index lists
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    n = mesh.n_dof
    K = sp.csr_matrix((Kb.ravel(), (rows, cols)), shape=(n, n))
    M = sp.csr_matrix((Mb.ravel(), (rows, cols)), shape=(n, n))
    if mesh.scene.point_masses:
        lumped = np.zeros(n)
        for pm in mesh.scene.point_masses:
            node = mesh.node_at(pm.s, "point_masses.s")
            lumped[6 * node:6 * node + 3] += pm.mass
        M = (M + sp.diags(lumped)).tocsr()
    # Exact symmetry (the triple products round differently in each triangle).
    return ((M + M.T) * 0.5).tocsr(), ((K + K.T) * 0.5).tocsr()


@dataclass
class BeamModel:
    """Everything the FFR beam's later steps need: mesh, unconstrained and constrained matrices."""

    mesh: Mesh
    boundary: str
    clamp_s: tuple[float, ...]
    clamped_nodes: np.ndarray
    M: sp.csr_matrix        # unconstrained, body frame
    K: sp.csr_matrix
    B2: sp.csr_matrix       # (n_dof, n_free)
    M_free: sp.csr_matrix   # B2^T M B2  (Eq. 14)
    K_free: sp.csr_matrix   # B2^T K B2  (Eq. 15)
    rotary_inertia: bool = False

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def n_free(self) -> int:
        return self.B2.shape[1]

    def structure(self) -> Structure:
        """The unconstrained model as a conventional linear structural model."""
        return Structure(nodes=self.mesh.nodes.copy(), dofs_per_node=6, M=self.M, K=self.K,
                         name=self.mesh.scene.name,
                         meta={"source": "ffr_beam", "elements_per_segment": self.mesh.elements_per_segment})


def build_beam_model(scene: Scene, boundary: str = "scene", elements_per_segment: int = 8,
                     rotary_inertia: bool = False, extra_arc_lengths=()) -> BeamModel:
    """Scene -> mesh -> M, K -> B2 -> constrained M, K.  Extra nodes go where clamps,
    point masses and ``extra_arc_lengths`` (e.g. sensor or load points) fall."""
    clamp_s = boundary_clamps(scene, boundary)
    mesh = build_mesh(scene, elements_per_segment, extra_arc_lengths=tuple(extra_arc_lengths) + clamp_s)
    clamped = np.array(sorted({mesh.node_at(s, "clamps") for s in clamp_s}), dtype=np.int64)
    with np.errstate(all="ignore"):                    # overflow: checked by value below
        M, K = assemble(mesh, rotary_inertia=rotary_inertia)
    for name, A in (("M", M), ("K", K)):
        # E I / L^3, rho A L, ... of extreme scene constants overflow (or underflow to a zero mass)
        require(bool(np.all(np.isfinite(A.data))) and float(np.max(np.abs(A.data), initial=0.0)) > 0.0, "scene",
                f"{scene.name}: the {'mass' if name == 'M' else 'stiffness'} matrix of {elements_per_segment} elements "
                "per segment is not finite (or zero): the material, section or lengths are beyond the floating-point "
                "range",
                "material, section and coordinates whose products (E I / L^3, rho A L) stay within 1e-300 .. 1e300")
    B2 = boundary_matrix(mesh.n_nodes, clamped)
    return BeamModel(mesh=mesh, boundary=boundary, clamp_s=clamp_s, clamped_nodes=clamped, M=M, K=K, B2=B2,
                     M_free=(B2.T @ M @ B2).tocsr(), K_free=(B2.T @ K @ B2).tocsr(),
                     rotary_inertia=rotary_inertia)
