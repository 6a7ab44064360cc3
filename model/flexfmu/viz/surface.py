"""What a picture of a mesh draws: the outer surface of its solid cells (the faces that belong to one cell only), its
shell cells, and, when it has no faces at all, its line cells (beams).  Faces by their corner nodes (a quadratic
cell's mid-side nodes are left out: flat faces), quadrilaterals split into two triangles, so one (k, 3) array
holds every face."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# the faces of each solid cell type, as corner positions in meshio's node order (outward normals)
_TET = ((0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2))
_HEX = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
_WEDGE = ((0, 2, 1), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5))
_PYRAMID = ((0, 3, 2, 1), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4))
SOLID_FACES = {"tetra": _TET, "tetra10": _TET, "hexahedron": _HEX, "hexahedron20": _HEX, "hexahedron27": _HEX,
               "wedge": _WEDGE, "wedge15": _WEDGE, "wedge18": _WEDGE, "pyramid": _PYRAMID, "pyramid13": _PYRAMID,
               "pyramid14": _PYRAMID}
#: shell cells: their corners
SHELL_CORNERS = {"triangle": (0, 1, 2), "triangle6": (0, 1, 2), "triangle7": (0, 1, 2), "quad": (0, 1, 2, 3),
                 "quad8": (0, 1, 2, 3), "quad9": (0, 1, 2, 3)}
LINE_ENDS = {"line": (0, 1), "line3": (0, 1), "line4": (0, 1)}


@dataclass(frozen=True)
class Outline:
    """triangles (k, 3) node indices of the faces to draw; lines (m, 2) of the segments to draw (beams, only when
    there are no faces); points (p,) of nodes drawn as dots (when there is neither)."""

    triangles: np.ndarray
    lines: np.ndarray
    points: np.ndarray


def _triangulated(faces: list[np.ndarray]) -> np.ndarray:
    """Triangles of faces given as (k, 3) and (k, 4) arrays: a quad (a, b, c, d) -> (a, b, c), (a, c, d)."""
    out = [np.zeros((0, 3), dtype=np.int64)]
    for f in faces:
        if f.shape[1] == 3:
            out.append(f)
        else:
            out += [f[:, [0, 1, 2]], f[:, [0, 2, 3]]]
    return np.vstack(out)


def _once(faces: np.ndarray) -> np.ndarray:
    """The rows of ``faces`` whose node set no other row has (a solid's outer faces)."""
    if faces.shape[0] == 0:
        return faces
    keys = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return faces[counts[inverse.reshape(-1)] == 1]


def outline(cells: dict, n_nodes: int) -> Outline:
    """The faces (and lines, points) that show a mesh of ``cells`` {meshio type: (k, m) node indices}."""
    solid = {3: [], 4: []}
    for kind, data in cells.items():
        for face in SOLID_FACES.get(kind, ()):
            solid[len(face)].append(np.asarray(data, dtype=np.int64)[:, face])
    outer = [_once(np.vstack(solid[size])) for size in (3, 4) if solid[size]]
    solid_keys = None
    shells = []
    for kind, corners in SHELL_CORNERS.items():
        if kind in cells and len(cells[kind]):
            if solid_keys is None:
                solid_keys = {tuple(sorted(row)) for group in outer for row in group.tolist()}
            faces = np.asarray(cells[kind], dtype=np.int64)[:, corners]
            # a shell cell on a solid's face (a surface group of the mesh file) is drawn by the solid already
            keep = np.array([tuple(sorted(row)) not in solid_keys for row in faces], dtype=bool)
            shells.append(faces[keep])
    triangles = _triangulated(outer + shells)
    lines = np.zeros((0, 2), dtype=np.int64)
    if triangles.shape[0] == 0:
        segments = [np.asarray(cells[k], dtype=np.int64)[:, list(ends)] for k, ends in LINE_ENDS.items()
                    if k in cells and len(cells[k])]
        if segments:
            lines = np.vstack(segments)
    points = np.zeros(0, dtype=np.int64)
    if triangles.shape[0] == 0 and lines.shape[0] == 0:
        points = np.arange(n_nodes, dtype=np.int64)
    return Outline(triangles, lines, points)
