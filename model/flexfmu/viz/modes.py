"""The mode shapes of a model as pictures: each mode's nodal displacement (the translations of its DOFs) and, for a
solid model with its cells, its averaged nodal von Mises stress (flexfmu.body.stress), as series to animate
(flexfmu.viz.series.mode_series) or to write as VTK (modes_as_frames)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.viz.series import DeformedSeries, mode_series, modes_as_frames


@dataclass(frozen=True)
class ModePictures:
    """nodes (N, 3) m; cells {meshio type: node indices}; shapes (N, 3, k) the modes' translations; stress
    (N, 6, k) Pa of each mode shape, or None (why_no_stress says why); frequencies_hz (k,); name."""

    nodes: np.ndarray
    cells: dict
    shapes: np.ndarray
    stress: np.ndarray | None
    frequencies_hz: np.ndarray
    name: str
    why_no_stress: str = ""

    def oscillating(self, n_frames: int = 24) -> list[DeformedSeries]:
        """Each mode over one period (the animation's panels)."""
        return mode_series(self.nodes, self.cells, self.shapes, self.stress, self.frequencies_hz,
                           n_frames=n_frames, name=self.name)

    def as_frames(self) -> DeformedSeries:
        """The modes as the frames of one series (the VTK series: frame k = mode k + 1)."""
        return modes_as_frames(self.nodes, self.cells, self.shapes, self.stress, self.frequencies_hz, name=self.name)


def mode_pictures(structure, shapes, frequencies_hz, *, cells=None, name: str = "") -> ModePictures:
    """The pictures of the mode shapes ``shapes`` (n_dof, k), all DOFs, of ``structure``: cells default to the
    structure's (Structure.cells); the stress of each mode shape when the structure is a solid with cells and one
    isotropic material (flexfmu.body.stress.SolidStress), else none (the pictures colour by |u|)."""
    nodes = np.asarray(structure.nodes, dtype=float)
    dpn = int(structure.dofs_per_node)
    shapes = np.asarray(shapes, dtype=float)
    if shapes.ndim != 2 or shapes.shape[0] != nodes.shape[0] * dpn:
        raise ParameterError("shapes", f"shape {shapes.shape}", f"({nodes.shape[0] * dpn}, k): every DOF of the model")
    cells = dict(getattr(structure, "cells", None) or {}) if cells is None else dict(cells)
    translations = shapes.reshape(nodes.shape[0], dpn, -1)[:, :3, :]
    stress, why = None, ""
    if dpn != 3 or not cells:
        why = "a beam model (no stress field)" if dpn != 3 else "the model has no cells (read as matrices)"
    else:
        from flexfmu.body.stress import SolidStress

        try:
            evaluator = SolidStress(structure, "animate")
        except ParameterError as exc:                 # no material, a cell type without shape functions
            why = str(exc)
        else:
            stress = evaluator.stress(evaluator.nodal_strain(shapes))
    return ModePictures(nodes, cells, np.ascontiguousarray(translations), stress,
                        np.asarray(frequencies_hz, dtype=float).reshape(-1), name or structure.name, why)
