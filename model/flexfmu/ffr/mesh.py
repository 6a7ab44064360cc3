"""Mesh of a scene: nodes along the polyline, two-node beam elements of the scene's element type, element frames.

Corner nodes are shared by the two segments that meet there (displacement and
nodal-rotation continuity in the body frame) while every element keeps its own
orientation C^ij: that is how the slope discontinuity enters (Koda et al. 2025, Sec. 2).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flexfmu.errors import require
from flexfmu.ffr.elements import BeamElement, get_element
from flexfmu.ffr.scene import Scene, check_arc_length

# Extra nodes closer than this fraction of the element length to an existing node are merged into it.
_MERGE_FRACTION = 1e-6


@dataclass
class Mesh:
    """nodes (N, 3) m body frame; node_s (N,) arc length m; elements (E, 2) node indices;
    element_segment (E,) polyline segment index; element_length (E,) m;
    element_rotation (E, 3, 3) C^ij element -> body; element: the element type (its matrices and interpolation,
    flexfmu.ffr.elements), the one the scene names."""

    scene: Scene
    nodes: np.ndarray
    node_s: np.ndarray
    elements: np.ndarray
    element_segment: np.ndarray
    element_length: np.ndarray
    element_rotation: np.ndarray
    elements_per_segment: int
    element: BeamElement = field(default_factory=get_element)

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def n_dof(self) -> int:
        return 6 * self.n_nodes

    def node_at(self, s: float, parameter: str = "s") -> int:
        """Index of the node at arc length s (the mesh must have one there)."""
        s = check_arc_length(self.scene, s, parameter)
        i = int(np.argmin(np.abs(self.node_s - s)))
        tol = _MERGE_FRACTION * float(self.element_length.min()) * 2
        require(abs(self.node_s[i] - s) <= tol, parameter,
                f"no mesh node at s = {s} m; pass it in extra_arc_lengths when meshing")
        return i

    def locate(self, s: float, parameter: str = "s") -> tuple[int, float]:
        """Element index and local coordinate xi in [0, 1] of arc length s."""
        s = check_arc_length(self.scene, s, parameter)
        s_start = self.node_s[self.elements[:, 0]]
        e = int(np.clip(np.searchsorted(s_start, s, side="right") - 1, 0, len(self.elements) - 1))
        xi = (s - s_start[e]) / self.element_length[e]
        return e, float(np.clip(xi, 0.0, 1.0))


def build_mesh(scene: Scene, elements_per_segment: int, extra_arc_lengths=()) -> Mesh:
    """Uniform ``elements_per_segment`` elements per segment, plus a node at every clamp,
    point mass and ``extra_arc_lengths`` entry that falls inside a segment."""
    require(isinstance(elements_per_segment, (int, np.integer)) and not isinstance(elements_per_segment, bool)
            and elements_per_segment >= 1, "elements_per_segment",
            f"got {elements_per_segment!r}", "an integer >= 1")
    vertex_s = scene.vertex_arc_lengths
    wanted = [check_arc_length(scene, s, "extra_arc_lengths") for s in extra_arc_lengths]
    wanted += list(scene.clamps) + [pm.s for pm in scene.point_masses]

    node_s_parts, node_xyz_parts, elements, element_segment = [], [], [], []
    node_count = 0
    for seg in range(len(vertex_s) - 1):
        s0, s1 = vertex_s[seg], vertex_s[seg + 1]
        h = (s1 - s0) / elements_per_segment
        local = list(np.linspace(s0, s1, elements_per_segment + 1))
        for s in wanted:
            if s0 < s < s1 and min(abs(np.array(local) - s)) > _MERGE_FRACTION * h:
                local.append(s)
        local = np.sort(np.array(local))
        t = ((local - s0) / (s1 - s0))[:, None]
        xyz = (1 - t) * scene.points[seg] + t * scene.points[seg + 1]
        if seg > 0:  # the corner node is shared with the previous segment
            local, xyz = local[1:], xyz[1:]
            first = node_count - 1
        else:
            first = 0
        node_s_parts.append(local)
        node_xyz_parts.append(xyz)
        n_new = len(local)
        idx = np.concatenate([[first], node_count + np.arange(n_new)]) if seg > 0 else np.arange(n_new)
        elements.append(np.column_stack([idx[:-1], idx[1:]]))
        element_segment.append(np.full(len(idx) - 1, seg))
        node_count += n_new

    node_s = np.concatenate(node_s_parts)
    nodes = np.vstack(node_xyz_parts)
    elements = np.vstack(elements).astype(np.int64)
    vectors = nodes[elements[:, 1]] - nodes[elements[:, 0]]
    lengths = np.linalg.norm(vectors, axis=1)
    element = get_element(scene.element)
    return Mesh(scene=scene, nodes=nodes, node_s=node_s, elements=elements,
                element_segment=np.concatenate(element_segment), element_length=lengths,
                element_rotation=element.rotation(vectors / lengths[:, None]),
                elements_per_segment=int(elements_per_segment), element=element)
