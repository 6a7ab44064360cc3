"""The plain data object passed between steps: a conventional linear structural model.

scene -> mesh -> matrices -> :class:`Structure` -> modes -> integrator -> FMU.
Every model source (the FFR beam assembly, the scikit-fem plate, a user's
``.npz`` file) produces a :class:`Structure`; every consumer takes one.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from flexfmu.core.checks import shown
from flexfmu.errors import ParameterError

#: Rigid-body modes of a free structure in 3-D (three translations, three rotations): the first columns of a
#: modal basis (flexfmu.linalg.modal_basis) and of the reframe integrator's eta (flexfmu.reframe.layout; the C
#: kernels' twin is FFX_REFRAME_N_RIGID).  Defined once, here; every user imports it from this module.
N_RIGID = 6


@dataclass(frozen=True)
class Provenance:
    """Where a model came from and how it was read: what export documentation and reports quote.

    source:   the file (or spec such as ``paper_plate``) the model was read from.
    format:   its format, e.g. "gmsh", "abaqus", "vtu", "nastran", "ansys-full", "npz", "beam-scene".
    reader:   the libraries (with versions) that read and assembled it.
    units:    how the file's numbers became SI (e.g. "file in mm, scaled by 1e-3 to m").
    material: E (Pa), nu, rho (kg/m^3) used in the assembly, when flexfmu assembled the matrices.
    notes:    anything else a user should know (element types, dropped cells, ...).
    """

    source: str = ""
    format: str = ""
    reader: str = ""
    units: str = "SI (m, kg, s, N)"
    material: tuple = ()
    notes: tuple = ()


@dataclass
class Structure:
    """Undeformed node positions and linear mass / stiffness matrices.

    nodes:            (N, 3) undeformed node coordinates, m, body frame.
    dofs_per_node:    3 (solids: x, y, z) or 6 (beams: x, y, z, theta_x, theta_y, theta_z).
    M, K:             (n_dof, n_dof) sparse CSR, DOF order node by node; SI units
                      (kg, kg m, kg m^2 / N/m, N, N m per rad).
    name:             free text for reports.
    meta:             free-form details for reports (divisions, material, ...); nothing in the numerics reads it.
    points:           named node indices (the plate's P1 ... P8 and load point; R, P, Q: the reference points
                      of the paper's reframe scheme): what the integrator and the model defaults read.
    constrained_dofs: sorted DOF indices the model file fixes (ANSYS D, Nastran SPC); M and K still hold
                      them: a clamped body drops them, a free body ignores them.
    node_sets:        named node index sets from the file (gmsh physical groups, Abaqus NSET, Nastran
                      SPC sets, ...), for clamps and interfaces.
    provenance:       where the model came from (:class:`Provenance`).
    cells:            the volume cells of a solid mesh: meshio cell type ("tetra", "tetra10", "hexahedron",
                      "hexahedron20", "hexahedron27") -> (n, k) node indices in meshio's (VTK's) node order; what
                      stresses and strains are evaluated on (flexfmu.body.stress).  Empty for models read as
                      matrices (Nastran DMIG / OP2, MAPDL .full, a .npz without cells) and for beams.
    """

    nodes: np.ndarray
    dofs_per_node: int
    M: sp.csr_matrix
    K: sp.csr_matrix
    name: str = ""
    meta: dict = field(default_factory=dict)
    points: dict = field(default_factory=dict)
    constrained_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    node_sets: dict = field(default_factory=dict)
    provenance: Provenance = field(default_factory=Provenance)
    cells: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]


def node_set(structure, name: str):
    """The sorted node indices of ``structure``'s node set ``name``; ParameterError listing the sets if absent."""
    sets = getattr(structure, "node_sets", None) or {}
    if name not in sets:
        raise ParameterError("node_set", f"{name!r} is not a node set of {shown(structure.name or 'the model')}",
                             ", ".join(sorted(sets)) or "none: the model file defines no node sets")
    return sets[name]
