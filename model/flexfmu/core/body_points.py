"""Whether a point lies on a body given by its nodes: the one rule that exported bodies' interfaces
(flexfmu.body.interfaces) and ReframeBody's load and output points (flexfmu.reframe.body_config) apply.

A point P (undeformed body frame, m) is tied to a patch of nodes.  It lies on the body when it is within

    reach = max(patch radius, local spacing)

of the patch's node nearest to it, the patch radius being the largest distance of a patch node from the patch
centroid and the local spacing the distance from that nearest node to the closest other node of the structure
(with a relative slack of 1e-9 for the rounding of coordinates).  So a point on or inside the meshed material,
or at the centre of a ring of nodes (a bolt hole's wall), is accepted, and a point away from the body is not.

The default patch of a point is its nearest node and the nodes of the elements around it (3 DOFs per node: the
node's row of K's sparsity pattern), or that node alone on 6-DOF structures (beams): about one element around
the point on any mesh density.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: relative slack of the reach (round-off of the coordinates), of the reach and of the body's size
REACH_SLACK = 1e-9


@dataclass(frozen=True)
class PatchReach:
    """How far ``point`` is from its patch: ``distance`` (m) to the patch's nearest node ``nearest`` (a node
    index), the patch ``radius`` and the ``spacing`` at that node (m), ``reach`` = max(radius, spacing), the body's
    ``size`` (its bounding box's diagonal, m), and whether the point is ``on_body``."""

    distance: float
    nearest: int
    radius: float
    spacing: float
    reach: float
    size: float
    on_body: bool


def element_neighbours(K, node: int, dpn: int) -> np.ndarray:
    """Nodes coupled to ``node`` in K (CSR: the nodes of the elements around it), itself included (also when its
    rows are empty: a DOF the model file constrained may carry no stiffness)."""
    rows = K[node * dpn:(node + 1) * dpn]
    return np.union1d(rows.indices // dpn, [node])


def local_spacing(nodes: np.ndarray, node: int) -> float:
    """Distance (m) from ``node`` to the closest other node (0 for a one-node structure)."""
    d = np.linalg.norm(nodes - nodes[node], axis=1)
    d[node] = np.inf
    return float(d.min()) if d.size > 1 else 0.0


def default_patch(structure, point) -> np.ndarray:
    """The default patch of ``point`` (module docstring): node indices."""
    nodes = np.asarray(structure.nodes, dtype=float)
    nearest = int(np.argmin(np.linalg.norm(nodes - np.asarray(point, dtype=float), axis=1)))
    dpn = int(structure.dofs_per_node)
    if dpn == 6:
        return np.array([nearest])
    return element_neighbours(structure.K.tocsr(), nearest, dpn)


def patch_reach(nodes, members: np.ndarray, point) -> PatchReach:
    """:class:`PatchReach` of ``point`` (3,) to the patch ``members`` (node indices) of ``nodes`` (n, 3)."""
    nodes = np.asarray(nodes, dtype=float)
    point = np.asarray(point, dtype=float)
    xyz = nodes[members]
    radius = float(np.max(np.linalg.norm(xyz - xyz.mean(axis=0), axis=1)))
    d = np.linalg.norm(xyz - point, axis=1)
    nearest = int(members[np.argmin(d)])
    spacing = local_spacing(nodes, nearest)
    size = float(np.linalg.norm(np.ptp(nodes, axis=0))) or 1.0
    reach = max(radius, spacing)
    distance = float(d.min())
    return PatchReach(distance, nearest, radius, spacing, reach, size,
                      bool(distance <= reach * (1 + REACH_SLACK) + REACH_SLACK * size))


def bounding_box_text(nodes) -> str:
    """'x -0.5 .. 0.5, y -0.025 .. 0.025, z 0 .. 0.01 m': the span of the nodes."""
    nodes = np.asarray(nodes, dtype=float)
    lo, hi = nodes.min(axis=0), nodes.max(axis=0)
    return ", ".join(f"{a} {lo[k]:.6g} .. {hi[k]:.6g}" for k, a in enumerate("xyz")) + " m"
