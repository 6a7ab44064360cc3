"""The plain data object passed between steps: a conventional linear structural model.

scene -> mesh -> matrices -> :class:`Structure` -> modes -> integrator -> FMU.
Every model source (the FFR beam assembly, the scikit-fem plate, a user's
``.npz`` file) produces a :class:`Structure`; every consumer takes one.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp


@dataclass
class Structure:
    """Undeformed node positions and linear mass / stiffness matrices.

    nodes:          (N, 3) undeformed node coordinates, m, body frame.
    dofs_per_node:  3 (solids: x, y, z) or 6 (beams: x, y, z, theta_x, theta_y, theta_z).
    M, K:           (n_dof, n_dof) sparse CSR, DOF order node by node; SI units
                    (kg, kg m, kg m^2 / N/m, N, N m per rad).
    name:           free text for reports.
    """

    nodes: np.ndarray
    dofs_per_node: int
    M: sp.csr_matrix
    K: sp.csr_matrix
    name: str = ""
    meta: dict = field(default_factory=dict)

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]
