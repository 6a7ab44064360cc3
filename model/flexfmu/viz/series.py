"""A body's deformed shape over time (or over its modes) as nodal arrays: displacement u (m, body frame) and the von
Mises stress (Pa) of every node at every frame.

deformed_series: from the shape coordinates q(t) of an exported body, u(t) = Psi q(t) and sigma(t) = S q(t) (the
shape file's Psi and nodal stress shapes S, flexfmu.body.shape_file), von Mises by flexfmu.core.stress.von_mises.
mode_series: each mode of a model oscillating over one period, q(t) = sin(2 pi f t); modes_as_frames: the modes as
the frames of one series (frame k = mode k), for a VTK series of the modes.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flexfmu.body.shape_file import ShapeFile
from flexfmu.core.stress import von_mises
from flexfmu.errors import ParameterError


@dataclass(frozen=True)
class DeformedSeries:
    """t (T,) s (or the mode numbers); nodes (N, 3) m body frame, undeformed; cells {meshio type: (k, m) ints};
    displacement (T, N, 3) m body frame; von_mises (T, N) Pa, or None when the body has no stress shapes;
    name: the body's; labels: one per frame (empty: "t = ... s")."""

    t: np.ndarray
    nodes: np.ndarray
    cells: dict
    displacement: np.ndarray
    von_mises: np.ndarray | None
    name: str = ""
    labels: tuple = field(default_factory=tuple)

    @property
    def n_frames(self) -> int:
        return self.displacement.shape[0]

    def colour(self) -> tuple[np.ndarray, str]:
        """What the pictures colour by: (T, N) values and their name: the von Mises stress (Pa) when there is one,
        else the displacement's magnitude (m)."""
        if self.von_mises is not None:
            return self.von_mises, "von Mises"
        return np.linalg.norm(self.displacement, axis=2), "|u|"

    def label(self, k: int) -> str:
        return self.labels[k] if self.labels else f"t = {self.t[k]:.4g} s"


def deformed_series(shape: ShapeFile, q, t=None, *, labels=()) -> DeformedSeries:
    """Displacement u = Psi q and von Mises of sigma = S q at every node for each row of ``q`` (T, n) (one vector
    (n,) is one frame), at times ``t`` (T,) s (default 0, 1, ...).  ParameterError when q does not have the shape
    file's n columns or is not finite."""
    q = np.asarray(q, dtype=float)
    if q.ndim == 1:
        q = q[None, :]
    n = shape.n_coordinates
    if q.ndim != 2 or q.shape[1] != n or q.shape[0] < 1:
        raise ParameterError("q", f"shape {q.shape}", f"(frames, {n}): one column per shape coordinate "
                             f"({', '.join(shape.names[:3])}{', ...' if n > 3 else ''})")
    if not np.all(np.isfinite(q)):
        rows = np.flatnonzero(~np.all(np.isfinite(q), axis=1))
        raise ParameterError("q", f"NaN or infinite values in {rows.size} frames (the first: frame {rows[0]})",
                             "finite shape coordinates")
    t = np.arange(q.shape[0], dtype=float) if t is None else np.asarray(t, dtype=float).reshape(-1)
    if t.shape != (q.shape[0],) or not np.all(np.isfinite(t)):
        raise ParameterError("t", f"{t.shape[0]} times for {q.shape[0]} frames", "one finite time per frame")
    # (T, n) x (N, 3, n) -> (T, N, 3): one matrix product, u = Psi q for every frame
    displacement = np.einsum("tk,ndk->tnd", q, shape.Psi)
    stress = None
    if shape.stress is not None:             # by blocks of frames: the (frames, N, 6) stresses are never all held
        stress = np.empty(displacement.shape[:2])
        block = max(1, 2**22 // (6 * shape.nodes.shape[0]))
        for start in range(0, q.shape[0], block):
            stress[start:start + block] = von_mises(np.einsum("tk,nck->tnc", q[start:start + block], shape.stress))
    return DeformedSeries(t, shape.nodes, shape.cells, displacement, stress, shape.body, tuple(labels))


def _mode_shapes(nodes, shapes, stress_shapes, frequencies_hz):
    nodes = np.asarray(nodes, dtype=float)
    shapes = np.asarray(shapes, dtype=float)
    frequencies_hz = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    if shapes.ndim != 3 or shapes.shape[:2] != (nodes.shape[0], 3) or shapes.shape[2] != frequencies_hz.size:
        raise ParameterError("shapes", f"shape {shapes.shape}",
                             f"({nodes.shape[0]}, 3, {frequencies_hz.size}): one shape per frequency")
    if stress_shapes is not None:
        stress_shapes = np.asarray(stress_shapes, dtype=float)
        if stress_shapes.shape != (nodes.shape[0], 6, frequencies_hz.size):
            raise ParameterError("stress_shapes", f"shape {stress_shapes.shape}",
                                 f"({nodes.shape[0]}, 6, {frequencies_hz.size}) or none")
    return nodes, shapes, stress_shapes, frequencies_hz


def mode_series(nodes, cells, shapes, stress_shapes, frequencies_hz, *, n_frames: int = 24,
                name: str = "") -> list[DeformedSeries]:
    """One series per mode, each one period of q(t) = sin(2 pi f t) in ``n_frames`` frames: nodes (N, 3) m;
    shapes (N, 3, k) the mode shapes' displacements; stress_shapes (N, 6, k) Pa or None; frequencies_hz (k,)."""
    nodes, shapes, stress_shapes, frequencies_hz = _mode_shapes(nodes, shapes, stress_shapes, frequencies_hz)
    if not isinstance(n_frames, int) or n_frames < 2:
        raise ParameterError("n_frames", f"{n_frames!r}", "an integer >= 2")
    phase = 2.0 * np.pi * np.arange(n_frames) / n_frames
    out = []
    for k, f in enumerate(frequencies_hz):
        shape = ShapeFile(nodes, cells, shapes[:, :, k:k + 1],
                          None if stress_shapes is None else stress_shapes[:, :, k:k + 1], (f"mode_{k + 1}",),
                          {"body": f"{name} mode {k + 1}: {f:.4g} Hz".strip()})
        period = 1.0 / f if f > 0 else 1.0
        out.append(deformed_series(shape, np.sin(phase)[:, None], phase / (2.0 * np.pi) * period,
                                   labels=tuple(f"t = {j}/{n_frames} of the period" for j in range(n_frames))))
    return out


def modes_as_frames(nodes, cells, shapes, stress_shapes, frequencies_hz, *, name: str = "") -> DeformedSeries:
    """The modes as the frames of one series: frame k (time k + 1) is mode k + 1 at unit amplitude (the shapes as
    given, e.g. mass-normalised), for a VTK series that steps through the modes."""
    nodes, shapes, stress_shapes, frequencies_hz = _mode_shapes(nodes, shapes, stress_shapes, frequencies_hz)
    k = frequencies_hz.size
    shape = ShapeFile(nodes, cells, shapes, stress_shapes, tuple(f"mode_{j + 1}" for j in range(k)), {"body": name})
    return deformed_series(shape, np.eye(k), np.arange(1.0, k + 1.0),
                           labels=tuple(f"mode {j + 1}: {f:.4g} Hz" for j, f in enumerate(frequencies_hz)))
