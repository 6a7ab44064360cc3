"""Fatigue of signed stress histories scanned over the places a crack may start: the fibres round a beam section's
outline, or the planes through a point of a solid body (a critical-plane scan on the normal stress).

Each scanned history is rainflow-counted (ASTM E1049-85) and its cycles' Miner damage summed on the curve; the
critical point is the one with the largest damage (ties, e.g. every range below a cut-off: the largest range), and
its history gets the full assessment (flexfmu.fatigue.assess_history: the binned table, equivalent ranges, rate and
life).

Why signed: the gauges' sigma_max and von_mises are the largest over a section, without sign; a fully reversed
stress of range S becomes two cycles of range S/2 in them, 2^(1-m) of the damage (docs/fatigue.md).

- ``section_scan``: sigma_xx = N / A + My z / Iy - Mz y / Iz at the points of flexfmu.fatigue.section_points (a
  circle: 72 angles, then the 20 angles 0.5 deg apart within 5 deg of the worst; a rectangle: corners and edge
  points).  Torsion and transverse shear are left out (the command reports the torsion's largest shear beside).
- ``critical_plane_scan``: the normal stress sigma_n = n^T sigma n on the planes of flexfmu.fatigue.plane_normals
  (every plane within ``step`` of a scanned one), then twice the planes of a cap of twice the last step round the
  worst so far, at a third of that step.  The normal-stress criterion: for stresses whose principal directions stay
  put (proportional loading) the critical plane is the first principal plane and its range the principal stress
  range; otherwise it is the range of the plane's own normal stress.  No shear on the plane, no mean stress.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.errors import require

from .assessment import DEFAULT_N_REF, FatigueAssessment, assess_history
from .counting import rainflow_cycles
from .damage import cycle_damage
from .history import StressHistory
from .plane_normals import angle_between_planes, cap_normals, hemisphere_normals, normal_stress
from .section_points import BeamSection, SectionPoints
from .sn_curve import SNCurve, unit_scale

#: the default step of the critical-plane scan's first set: 6.4 deg, 545 planes over the hemisphere
DEFAULT_PLANE_STEP = math.radians(6.4)
#: refinements of the critical-plane scan, each a cap of twice the step round the worst with a third of the step
DEFAULT_REFINEMENTS = 2
#: the circle's refinement round its worst angle: +-5 deg at 0.5 deg
CIRCLE_REFINE_HALF_WIDTH = math.radians(5.0)
CIRCLE_REFINE_STEP = math.radians(0.5)


@dataclass(frozen=True)
class PointScan:
    """Every scanned place's damage and largest range (curve unit), and the critical one's assessment.

    places: (k, 2) fibre coordinates y, z (m, section frame) or (k, 3) plane normals (body frame).
    labels: each place as text.  scanned: what was scanned, as a sentence.  notes: what was left out."""

    places: np.ndarray
    labels: tuple
    damage: np.ndarray
    largest_range: np.ndarray
    critical: int
    assessment: FatigueAssessment
    scanned: str
    notes: tuple = field(default_factory=tuple)

    @property
    def critical_label(self) -> str:
        return self.labels[self.critical]

    def summary_lines(self) -> list[str]:
        u = self.assessment.curve.unit
        d = self.damage
        lines = [f"scanned: {self.scanned}",
                 f"critical: {self.critical_label}: damage {d[self.critical]:.6e}, largest range "
                 f"{self.largest_range[self.critical]:.6g} {u}",
                 f"damage over the {d.size} places: {d.min():.4e} .. {d.max():.4e}"]
        return lines + list(self.notes)

    def write_places_csv(self, path) -> Path:
        """Every scanned place: its coordinates, label, damage and largest range (curve unit), critical first."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        u = self.assessment.curve.unit
        coords = ["y_m", "z_m"] if self.places.shape[1] == 2 else ["nx", "ny", "nz"]
        order = [self.critical] + [k for k in np.argsort(-self.damage, kind="stable") if k != self.critical]
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow([*coords, "place", "damage", f"largest_range_{u}"])
            for k in order:
                w.writerow([*(repr(float(c)) for c in self.places[k]), self.labels[k], repr(float(self.damage[k])),
                            repr(float(self.largest_range[k]))])
        return path


#: places evaluated at once: a block of samples x places is built per chunk, not for all places (a 60,000-sample
#: record on 815 planes would be 390 MB at once)
CHUNK = 32


def _damage_per_place(stress_of, count: int, curve: SNCurve) -> tuple[np.ndarray, np.ndarray]:
    """Miner damage and largest rainflow range of each of ``count`` places; ``stress_of(slice)`` gives the stress
    histories (samples x places of the slice) in the curve's unit."""
    damage, largest = np.zeros(count), np.zeros(count)
    for start in range(0, count, CHUNK):
        block = stress_of(slice(start, min(count, start + CHUNK)))
        for j in range(block.shape[1]):
            cycles = rainflow_cycles(np.ascontiguousarray(block[:, j]))
            if cycles.ranges.size:
                damage[start + j] = float(cycle_damage(cycles.ranges, cycles.counts, curve).sum())
                largest[start + j] = float(cycles.ranges.max())
    return damage, largest


def _worst(damage: np.ndarray, largest: np.ndarray) -> int:
    """The place with the largest damage; among equal damages (none above a cut-off) the largest range."""
    return int(np.lexsort((largest, damage))[-1])


def _checked_time(time, n_samples: int) -> np.ndarray:
    t = np.asarray(time, float)
    require(t.ndim == 1 and t.size == n_samples, "time", f"{t.size} times for {n_samples} samples",
            "one time per sample")
    return t


def section_scan(time, N, My, Mz, section: BeamSection, curve: SNCurve, *, name: str = "section", scf: float = 1.0,
                 n_ref: float = DEFAULT_N_REF, n_bins: int = 20, n_angles: int = 72, per_edge: int = 8,
                 torsion=None) -> PointScan:
    """The signed axial stress (Pa, x ``scf``) at the section's outline points from the section forces N (N), My,
    Mz (N m) sampled at ``time`` (s), each point's damage on ``curve``, and the critical point's assessment.
    ``torsion``: the torsion moment T (N m) samples, reported (its largest shear stress) but not assessed."""
    N, My, Mz = (np.asarray(v, float).ravel() for v in (N, My, Mz))
    require(N.size == My.size == Mz.size, "section forces", f"{N.size}, {My.size}, {Mz.size} samples of N, My, Mz",
            "as many samples of each")
    t = _checked_time(time, N.size)
    require(math.isfinite(scf) and scf > 0.0, "scf", f"{scf!r}", "a finite stress concentration factor > 0")
    to_curve = scf * unit_scale("Pa") / unit_scale(curve.unit)
    points = section.points(n_angles, per_edge)

    def stress_at(pts: SectionPoints):
        return lambda index: section.axial_stress(N, My, Mz, pts.take(index)) * to_curve

    damage, largest = _damage_per_place(stress_at(points), len(points), curve)
    scanned = (f"sigma_xx = N/A + My z/Iy - Mz y/Iz at {len(points)} points round the {section.describe()}: "
               + ("its corners and edges" if section.shape == "rectangle"
                  else f"its outer circle {360.0 / n_angles:g} deg apart"))
    if section.shape != "rectangle":
        k0 = _worst(damage, largest)
        half = round(CIRCLE_REFINE_HALF_WIDTH / CIRCLE_REFINE_STEP)
        steps = np.arange(-half, half + 1)
        fine = section.circle_points(points.angle[k0] + CIRCLE_REFINE_STEP * steps[steps != 0])   # k0 is scanned
        d_fine, l_fine = _damage_per_place(stress_at(fine), len(fine), curve)
        points = points.joined(fine)
        damage, largest = np.concatenate([damage, d_fine]), np.concatenate([largest, l_fine])
        scanned += (f", then {len(fine)} more {math.degrees(CIRCLE_REFINE_STEP):g} deg apart within "
                    f"{math.degrees(CIRCLE_REFINE_HALF_WIDTH):g} deg of the worst")
    k = _worst(damage, largest)
    sigma = section.axial_stress(N, My, Mz, points.take([k]))[:, 0]
    history = StressHistory(t, sigma * scf, f"{name} sigma_xx at {points.label(k)}"
                            + (f" x SCF {scf:g}" if scf != 1.0 else ""), "Pa")
    notes = ["left out: torsion and transverse shear (sigma_xx only; no multiaxial criterion)"]
    if torsion is not None:
        torsion = np.asarray(torsion, float).ravel()
        require(torsion.size == N.size, "torsion", f"{torsion.size} samples of T for {N.size} of N", "as many")
        tau = section.torsion_shear(torsion) * to_curve
        share = f"{100.0 * tau.max() / largest[k]:.3g} % of" if largest[k] > 0.0 else "against"
        notes.append(f"torsion: largest shear stress {tau.max():.4g} {curve.unit} (x SCF), {share} the critical "
                     f"fibre's largest axial range {largest[k]:.4g} {curve.unit}; not in sigma_xx")
    return PointScan(np.column_stack([points.y, points.z]), tuple(points.label(j) for j in range(len(points))),
                     damage, largest, k, assess_history(history, curve, n_ref=n_ref, n_bins=n_bins), scanned,
                     tuple(notes))


def _plane_label(n: np.ndarray) -> str:
    n = n if n[np.argmax(np.abs(n))] > 0 else -n        # of n and -n, the one whose largest component is positive
    return f"plane normal n = ({n[0]:+.4f}, {n[1]:+.4f}, {n[2]:+.4f})"


def critical_plane_scan(time, stress, curve: SNCurve, *, name: str = "gauge", unit: str = "Pa", scf: float = 1.0,
                        n_ref: float = DEFAULT_N_REF, n_bins: int = 20, step: float = DEFAULT_PLANE_STEP,
                        refinements: int = DEFAULT_REFINEMENTS) -> PointScan:
    """The normal stress history n^T sigma n (``unit``, x ``scf``) of stress tensors ``stress`` (samples, 6; VOIGT
    order, body frame) at ``time`` (s) on planes covering every orientation within ``step`` (rad), refined
    ``refinements`` times round the worst; each plane's damage on ``curve`` and the critical plane's assessment."""
    s = np.asarray(stress, float)
    require(s.ndim == 2 and s.shape[1] == 6, "stress", f"an array of shape {s.shape}", "(samples, 6), VOIGT order")
    t = _checked_time(time, s.shape[0])
    require(math.isfinite(scf) and scf > 0.0, "scf", f"{scf!r}", "a finite stress concentration factor > 0")
    require(isinstance(refinements, int) and 0 <= refinements <= 6, "refinements", f"{refinements!r}",
            "an integer 0 .. 6")
    to_curve = scf * unit_scale(unit) / unit_scale(curve.unit)
    normals = hemisphere_normals(step)

    def stress_on(planes: np.ndarray):
        return lambda index: normal_stress(s, planes[index]) * to_curve

    damage, largest = _damage_per_place(stress_on(normals), normals.shape[0], curve)
    n_coarse, h = normals.shape[0], step
    for _ in range(refinements):
        best = normals[_worst(damage, largest)]
        cap = cap_normals(best, 2.0 * h, h / 3.0)[1:]              # its centre is scanned already
        d, r = _damage_per_place(stress_on(cap), cap.shape[0], curve)
        normals, damage, largest = np.vstack([normals, cap]), np.concatenate([damage, d]), np.concatenate([largest, r])
        h /= 3.0
    k = _worst(damage, largest)
    label = _plane_label(normals[k])
    history = StressHistory(t, normal_stress(s, normals[k:k + 1])[:, 0] * scf,
                            f"{name} normal stress on the {label}" + (f" x SCF {scf:g}" if scf != 1.0 else ""), unit)
    scanned = (f"normal stress n^T sigma n on {n_coarse} planes (every plane within {math.degrees(step):.3g} deg of "
               "one)")
    if refinements:
        scanned += (f", then {normals.shape[0] - n_coarse} more in {refinements} cap(s) round the worst so far, each "
                    f"of twice the previous step's radius at a third of it (the last: every plane within "
                    f"{math.degrees(6.0 * h):.3g} deg of its centre within {math.degrees(h):.3g} deg of a scanned "
                    "one)")
    scanned += "; normals in the body frame"
    sigma_n = normal_stress(s, normals[k:k + 1])[:, 0]
    principal = np.linalg.eigvalsh(_tensor(s[int(np.argmax(np.abs(sigma_n)))]))[::-1]
    notes = ["left out: shear on the plane, mean stress (the normal-stress criterion; no Findley or other "
             "multiaxial criterion)",
             f"the critical normal makes {_axis_angle(normals[k], 0):.3g}, {_axis_angle(normals[k], 1):.3g}, "
             f"{_axis_angle(normals[k], 2):.3g} deg with the body x, y, z axes; the principal stresses where its "
             "|sigma_n| is largest: " + ", ".join(f"{p * to_curve:.4g}" for p in principal) + f" {curve.unit}"]
    return PointScan(normals, tuple(_plane_label(n) for n in normals), damage, largest, k,
                     assess_history(history, curve, n_ref=n_ref, n_bins=n_bins), scanned, tuple(notes))


def _tensor(voigt: np.ndarray) -> np.ndarray:
    xx, yy, zz, xy, yz, xz = voigt
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def _axis_angle(n: np.ndarray, axis: int) -> float:
    """The angle (deg, 0 .. 90) between the normal n (or -n) and the body axis ``axis``."""
    return math.degrees(angle_between_planes(n, np.eye(3)[axis]))
