"""Stress measures the gauges output: von Mises of a stress tensor, and the largest axial and von Mises stresses of a
beam section from its section forces.  The one home of these formulas in Python; the native runtime evaluates the
same equations in C (its derived outputs), so the two agree to rounding.

Conventions
-----------
* Stress and strain tensors as six components in the order VOIGT = (xx, yy, zz, xy, yz, xz): tensor components
  (sigma_xy, not 2 sigma_xy; the strains likewise eps_xy = gamma_xy / 2), Pa and 1.
* A beam section's forces (N, Vy, Vz, T, My, Mz) are the resultant force (N) and moment about the section's centroid
  (N m) that the part of the rod beyond the cut (larger arc length) exerts on the part before it, in the section frame:
  x along the rod's tangent towards larger arc length, y and z the element's section axes (docs/scene_format.md).
  N > 0 is tension; the axial stress at the fibre (y, z) is  sigma_xx = N / A + My z / Iy - Mz y / Iz.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import ParameterError

VOIGT = ("xx", "yy", "zz", "xy", "yz", "xz")
#: the section shapes whose fibres a gauge can place (a generic section gives A, Iy, Iz, J but no outline)
SECTION_SHAPES = ("circle", "tube", "rectangle")


def von_mises(stress) -> np.ndarray:
    """Von Mises stress (Pa) of stress tensors ``stress`` (..., 6) in VOIGT order:
    sqrt(1/2 ((sxx - syy)^2 + (syy - szz)^2 + (szz - sxx)^2) + 3 (sxy^2 + syz^2 + sxz^2))."""
    s = np.asarray(stress, dtype=float)
    sxx, syy, szz, sxy, syz, sxz = (s[..., k] for k in range(6))
    return np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                   + 3.0 * (sxy * sxy + syz * syz + sxz * sxz))


@dataclass(frozen=True)
class SectionFibres:
    """Where a section's largest stresses sit, from its constants (A, Iy, Iz, J: m^2, m^4) and shape.

    circle / tube: outer radius c; sigma_max = |N| / A + hypot(My, Mz) c / I and the torsional shear T c / J are
    exact (Saint-Venant; J = 2 I), both largest on the outer fibre, so von Mises = sqrt(sigma_max^2 + 3 tau^2) is the
    section's largest.  rectangle (width b along z, height h along y, from Iy = h b^3 / 12, Iz = b h^3 / 12):
    sigma_max = |N| / A + |My| b / (2 Iy) + |Mz| h / (2 Iz) at a corner is exact; the shear T t / J (t the short side)
    is the thin-strip value (Roark), and von Mises = sqrt(sigma_max^2 + 3 tau^2) combines the two largest, which a
    rectangle has at different points: an upper bound there.  The transverse shear of Vy, Vz (zero on the outer
    fibre of a circle) is left out of both."""

    shape: str
    A: float
    Iy: float
    Iz: float
    J: float
    y_max: float      # m: the largest |y| of the outline
    z_max: float      # m: the largest |z|
    torsion_arm: float  # m: tau_max = |T| torsion_arm / J

    @classmethod
    def of(cls, shape: str, A: float, Iy: float, Iz: float, J: float, name: str = "section") -> "SectionFibres":
        """The fibres of a section given by its constants; ParameterError for a shape without an outline."""
        if shape in ("circle", "tube"):
            # A = pi (do^2 - di^2) / 4 and I = A (do^2 + di^2) / 16 give the outer diameter
            outer_d2 = 0.5 * (16.0 * Iy / A + 4.0 * A / math.pi)
            c = 0.5 * math.sqrt(outer_d2)
            return cls(shape, A, Iy, Iz, J, c, c, c)
        if shape == "rectangle":
            b, h = math.sqrt(12.0 * Iy / A), math.sqrt(12.0 * Iz / A)
            return cls(shape, A, Iy, Iz, J, 0.5 * h, 0.5 * b, min(b, h))
        raise ParameterError(name, f"a {shape} section has no outline to place the stress on",
                             "a circle, tube or rectangle section (the gauges' stresses need its fibres)")

    def sigma_max(self, N, My, Mz):
        """Largest |sigma_xx| on the section (Pa) for axial force N (N) and bending moments My, Mz (N m)."""
        N, My, Mz = (np.asarray(v, dtype=float) for v in (N, My, Mz))
        if self.shape == "rectangle":
            return np.abs(N) / self.A + np.abs(My) * self.z_max / self.Iy + np.abs(Mz) * self.y_max / self.Iz
        return np.abs(N) / self.A + np.hypot(My, Mz) * self.z_max / self.Iy

    def von_mises(self, N, T, My, Mz):
        """Largest von Mises stress on the section (Pa) from axial force, torsion and bending (see the class)."""
        sigma = self.sigma_max(N, My, Mz)
        tau = np.abs(np.asarray(T, dtype=float)) * self.torsion_arm / self.J
        return np.sqrt(sigma * sigma + 3.0 * tau * tau)


#: the kinds of derived stress output: a von Mises stress of six stress outputs (VOIGT order), and a beam section's
#: largest axial or von Mises stress of its section forces (N, T, My, Mz)
DERIVED_KINDS = ("tensor_von_mises", "section_sigma_max", "section_von_mises")


@dataclass(frozen=True)
class DerivedStress:
    """An output computed from other outputs of the same FMU, not linear in the state: what a simulator lists in its
    ``derived_outputs`` so that the native runtime's extraction leaves it out of the linear fit and evaluates it in C
    after the linear outputs, by the same formula.

    output:  the derived output's name.
    kind:    one of DERIVED_KINDS.
    sources: the names of the outputs it is computed from: six stress outputs in VOIGT order (tensor_von_mises), or
             a gauge's (N, T, My, Mz) outputs (section_*).
    fibres:  the section's SectionFibres (section_*), None for tensor_von_mises."""

    output: str
    kind: str
    sources: tuple
    fibres: SectionFibres | None = None

    def __post_init__(self):
        if self.kind not in DERIVED_KINDS:
            raise ValueError(f"derived kind {self.kind!r} is not one of {DERIVED_KINDS}")
        wanted = 6 if self.kind == "tensor_von_mises" else 4
        if len(self.sources) != wanted or (self.fibres is None) != (self.kind == "tensor_von_mises"):
            raise ValueError(f"derived output {self.output!r}: {self.kind} takes {wanted} sources"
                             + (" and no fibres" if wanted == 6 else " and the section's fibres"))

    def evaluate(self, values):
        """The derived value from the source outputs' ``values`` (in ``sources`` order; arrays broadcast)."""
        if self.kind == "tensor_von_mises":
            return von_mises(np.stack([np.asarray(v, dtype=float) for v in values], axis=-1))
        N, T, My, Mz = values
        if self.kind == "section_sigma_max":
            return self.fibres.sigma_max(N, My, Mz)
        return self.fibres.von_mises(N, T, My, Mz)


def evaluate_derived(derived, names, y) -> None:
    """Overwrite the derived outputs of the output vector ``y`` (names ``names``, a tuple) in place from its sources."""
    index = {name: k for k, name in enumerate(names)}
    for d in derived:
        y[index[d.output]] = d.evaluate([y[index[s]] for s in d.sources])
