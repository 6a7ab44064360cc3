"""The signed axial stress of a beam section at points round its outline, from the section forces a gauge outputs.

A section given as text (``circle:D``, ``tube:DO,DI``, ``rectangle:B,H``; m) has the constants of
docs/scene_format.md, "Section constants and the local axes": a circle or tube Iy = Iz = pi (do^4 - di^4) / 64;
a rectangle of width B along z and height H along y, Iy = H B^3 / 12, Iz = B H^3 / 12.  With the section forces of
flexfmu.core.stress's convention (section frame: x along the rod towards larger arc length, y and z the section
axes; N > 0 tension), the axial stress at the fibre (y, z) is

    sigma_xx(y, z) = N / A + My z / Iy - Mz y / Iz        (Pa)

the formula of flexfmu.core.stress, evaluated here at every scanned point instead of as the section's largest |.|.

Points: a circle or tube at ``n`` angles of its outer circle (y = c cos(angle), z = c sin(angle), the angle from y
towards z); a rectangle at its four corners and ``per_edge - 1`` points inside each edge.  Inner fibres (a tube's
bore, a rectangle's interior) are not scanned: the bending part of their stress is a fraction of the outline's at
the same angle.  Torsion and transverse shear are left out of sigma_xx; ``torsion_shear`` gives the largest
torsion shear stress of the section for the command to report beside the axial ranges.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import ParameterError, require

SECTION_FORMS = "circle:D, tube:DO,DI or rectangle:B,H (m; B the width along z, H the height along y)"


@dataclass(frozen=True)
class SectionPoints:
    """Points of a section's outline (m, section frame); ``angle`` (rad, from y towards z) for a circle's points,
    None for a rectangle's."""

    y: np.ndarray
    z: np.ndarray
    angle: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.y.size)

    def take(self, index) -> "SectionPoints":
        """The points ``index`` (a slice or indices) of these."""
        return SectionPoints(self.y[index], self.z[index], None if self.angle is None else self.angle[index])

    def joined(self, other: "SectionPoints") -> "SectionPoints":
        """These points, then ``other``'s."""
        angle = None if self.angle is None or other.angle is None else np.concatenate([self.angle, other.angle])
        return SectionPoints(np.concatenate([self.y, other.y]), np.concatenate([self.z, other.z]), angle)

    def label(self, k: int) -> str:
        """Where point k is, as text."""
        where = f"y = {self.y[k] * 1e3:.4g} mm, z = {self.z[k] * 1e3:.4g} mm"
        if self.angle is None:
            return where
        return f"{math.degrees(float(self.angle[k])) % 360.0:.4g} deg from y towards z ({where})"


@dataclass(frozen=True)
class BeamSection:
    """A circle, tube or rectangle section: ``shape`` and its dimensions (m): circle (D,), tube (DO, DI),
    rectangle (B along z, H along y)."""

    shape: str
    dims: tuple

    @classmethod
    def from_text(cls, text: str, parameter: str = "section") -> "BeamSection":
        """``circle:D``, ``tube:DO,DI`` or ``rectangle:B,H`` (m) -> the section; a ParameterError naming ``parameter``
        otherwise."""
        shape, _, rest = str(text).strip().partition(":")
        shape = shape.strip().lower()
        wanted = {"circle": 1, "tube": 2, "rectangle": 2}
        if shape not in wanted:
            raise ParameterError(parameter, f"{text!r}: unknown shape {shape!r}", SECTION_FORMS)
        try:
            dims = tuple(float(v) for v in rest.split(","))
        except ValueError:
            raise ParameterError(parameter, f"{text!r}: {rest!r} is not {wanted[shape]} number(s)",
                                 SECTION_FORMS) from None
        require(len(dims) == wanted[shape], parameter,
                f"{text!r}: {shape} takes {wanted[shape]} dimension(s), got {len(dims)}", SECTION_FORMS)
        lengths = dims[:1] if shape == "tube" else dims          # a tube's bore may be 0 (a solid circle)
        require(all(math.isfinite(d) and d > 0.0 for d in lengths), parameter,
                f"{text!r}: a dimension is not a finite length > 0", SECTION_FORMS)
        if shape == "tube":
            require(math.isfinite(dims[1]) and 0.0 <= dims[1] < dims[0], parameter,
                    f"{text!r}: the inner diameter {dims[1]:g} m is not in [0, the outer {dims[0]:g} m)",
                    "tube:DO,DI with 0 <= DI < DO")
        return cls(shape, dims)

    @classmethod
    def from_constants(cls, shape: str, A: float, Iy: float, Iz: float, parameter: str = "section") -> "BeamSection":
        """The section whose constants (m^2, m^4) a circle, tube or rectangle of docs/scene_format.md has (a scene's
        Section): circle D^2 = 4 A / pi; tube DO^2 + DI^2 = 16 I / A, DO^2 - DI^2 = 4 A / pi; rectangle
        B^2 = 12 Iy / A (along z), H^2 = 12 Iz / A (along y).  A generic section has no outline: ParameterError."""
        require(all(math.isfinite(v) and v > 0.0 for v in (A, Iy, Iz)), parameter, f"A {A!r}, Iy {Iy!r}, Iz {Iz!r}",
                "finite section constants > 0")
        if shape == "circle":
            return cls("circle", (math.sqrt(4.0 * A / math.pi),))
        if shape == "tube":
            total, diff = 16.0 * Iy / A, 4.0 * A / math.pi
            return cls("tube", (math.sqrt(0.5 * (total + diff)), math.sqrt(max(0.0, 0.5 * (total - diff)))))
        if shape == "rectangle":
            return cls("rectangle", (math.sqrt(12.0 * Iy / A), math.sqrt(12.0 * Iz / A)))
        raise ParameterError(parameter, f"a {shape} section (A, Iy, Iz, J) has no outline to place fibres on",
                             "a circle, tube or rectangle section, or " + SECTION_FORMS)

    # ------------------------------------------------------------------ constants (docs/scene_format.md)
    @property
    def area(self) -> float:
        """A, m^2."""
        if self.shape == "rectangle":
            return self.dims[0] * self.dims[1]
        di = self.dims[1] if self.shape == "tube" else 0.0
        return math.pi * (self.dims[0] ** 2 - di ** 2) / 4.0

    @property
    def Iy(self) -> float:
        """int z^2 dA, m^4."""
        if self.shape == "rectangle":
            b, h = self.dims
            return h * b ** 3 / 12.0
        di = self.dims[1] if self.shape == "tube" else 0.0
        return math.pi * (self.dims[0] ** 4 - di ** 4) / 64.0

    @property
    def Iz(self) -> float:
        """int y^2 dA, m^4."""
        if self.shape == "rectangle":
            b, h = self.dims
            return b * h ** 3 / 12.0
        return self.Iy

    def describe(self) -> str:
        mm = ", ".join(f"{d * 1e3:g}" for d in self.dims)
        what = {"circle": "D", "tube": "DO, DI", "rectangle": "B (along z), H (along y)"}[self.shape]
        return f"{self.shape} {what} = {mm} mm"

    # ------------------------------------------------------------------ points and stresses
    def points(self, n_angles: int = 72, per_edge: int = 8) -> SectionPoints:
        """The scanned points: ``n_angles`` equally spaced angles of a circle's or tube's outer circle (the first at
        y), or a rectangle's corners and ``per_edge - 1`` points inside each edge (4 per_edge points)."""
        if self.shape == "rectangle":
            require(isinstance(per_edge, int) and 1 <= per_edge <= 1000, "per_edge", f"{per_edge!r}",
                    "an integer 1 .. 1000")
            b, h = self.dims
            s = np.arange(per_edge) / per_edge                      # 0 .. 1 along an edge, its end left out
            corners = [(h / 2, b / 2), (-h / 2, b / 2), (-h / 2, -b / 2), (h / 2, -b / 2)]   # (y, z), walked round
            y = np.concatenate([y0 + (y1 - y0) * s for (y0, _), (y1, _) in zip(corners, corners[1:] + corners[:1])])
            z = np.concatenate([z0 + (z1 - z0) * s for (_, z0), (_, z1) in zip(corners, corners[1:] + corners[:1])])
            return SectionPoints(y, z)
        require(isinstance(n_angles, int) and 4 <= n_angles <= 100000, "n_angles", f"{n_angles!r}",
                "an integer 4 .. 100000")
        return self.circle_points(2.0 * math.pi * np.arange(n_angles) / n_angles)

    def circle_points(self, angles) -> SectionPoints:
        """Points of a circle's or tube's outer circle at ``angles`` (rad, from y towards z)."""
        require(self.shape != "rectangle", "angles", "a rectangle has no angles", "a circle or tube section")
        a = np.asarray(angles, float)
        c = 0.5 * self.dims[0]
        # cos(pi / 2) is 6e-17, not 0: a fibre on an axis gets its exact coordinate
        cos, sin = (np.where(np.abs(v) < 1e-15, 0.0, v) for v in (np.cos(a), np.sin(a)))
        return SectionPoints(c * cos, c * sin, a)

    def axial_stress(self, N, My, Mz, points: SectionPoints) -> np.ndarray:
        """sigma_xx (Pa), samples x points, from the section forces N (N), My, Mz (N m) of every sample."""
        N, My, Mz = (np.asarray(v, float).reshape(-1, 1) for v in (N, My, Mz))
        return N / self.area + My * (points.z / self.Iy) - Mz * (points.y / self.Iz)

    def torsion_shear(self, T) -> np.ndarray:
        """The section's largest torsion shear stress |T| c / J (circle, tube: exact, J = Iy + Iz) or |T| t / J
        (rectangle, t the short side, J from Roark's formula as docs/scene_format.md: the thin-strip value), Pa."""
        T = np.abs(np.asarray(T, float))
        if self.shape == "rectangle":
            a, b = max(self.dims), min(self.dims)
            J = a * b ** 3 * (1.0 / 3.0 - 0.21 * (b / a) * (1.0 - b ** 4 / (12.0 * a ** 4)))
            return T * b / J
        return T * (0.5 * self.dims[0]) / (self.Iy + self.Iz)
