"""Plane normals for a critical-plane scan, and the normal stress of a stress tensor history on them.

The normal stress on the plane of unit normal n (body frame) is

    sigma_n(t) = n^T sigma(t) n
               = sxx nx^2 + syy ny^2 + szz nz^2 + 2 (sxy nx ny + syz ny nz + sxz nx nz)

with the tensor in flexfmu.core.stress's VOIGT order (xx, yy, zz, xy, yz, xz; tensor shear components).  n and -n
are one plane, so the normals cover a hemisphere.

The normals are rings of equal polar angle rather than a Fibonacci spiral, because the rings have a covering radius
that can be stated: with a step h, the rings sit every dphi <= h in polar angle (the pole one of them) and each ring
holds ceil(2 pi sin(phi) / h) equally spaced normals (the equator ring over half the circle, its other half being
the same planes), so every direction lies within dphi / 2 <= h / 2 of a ring along its meridian and within h / 2 of
a normal along that ring: within h of a normal of the set (the triangle inequality; a tighter bound is about
h / sqrt(2)).  ``cap_normals`` builds the same rings round a given normal out to a given angle, for refinement.
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.errors import require


def _rings(step: float, polar_extent: float, half_equator: bool) -> np.ndarray:
    """Unit vectors round the +z axis: rings every <= step in polar angle from 0 to polar_extent (rad), each ring
    with normals <= step apart along it.  half_equator: the ring at pi/2 over half the circle only."""
    n_rings = max(1, math.ceil(polar_extent / step))
    out = [np.array([[0.0, 0.0, 1.0]])]
    for k in range(1, n_rings + 1):
        phi = polar_extent * k / n_rings
        at_equator = half_equator and k == n_rings and abs(phi - math.pi / 2) < 1e-12
        span = math.pi if at_equator else 2.0 * math.pi
        count = max(1, math.ceil(span * math.sin(phi) / step))
        theta = span * np.arange(count) / count
        out.append(np.column_stack([math.sin(phi) * np.cos(theta), math.sin(phi) * np.sin(theta),
                                    np.full(count, math.cos(phi))]))
    return np.vstack(out)


def hemisphere_normals(step: float) -> np.ndarray:
    """Plane normals (k, 3) covering every plane to within ``step`` (rad, 0.001 .. 0.5): every direction is within
    ``step`` of a normal or of its opposite (the module's rings)."""
    require(math.isfinite(step) and 1e-3 <= step <= 0.5, "step", f"{step!r} rad", "0.001 .. 0.5 rad")
    return _rings(step, math.pi / 2, half_equator=True)


def cap_normals(centre, radius: float, step: float) -> np.ndarray:
    """Normals (k, 3) within ``radius`` (rad) of the unit vector ``centre``, every direction of that cap within
    ``step`` of one of them (the module's rings round ``centre``; the first normal is ``centre`` itself)."""
    require(math.isfinite(radius) and 0.0 < radius <= math.pi, "radius", f"{radius!r} rad", "0 < radius <= pi")
    require(math.isfinite(step) and 0.0 < step <= radius, "step", f"{step!r} rad", f"0 < step <= radius {radius!r}")
    c = np.asarray(centre, float)
    c = c / np.linalg.norm(c)
    local = _rings(step, radius, half_equator=False)
    # an orthonormal frame (e1, e2, c): the rings' +z axis turned onto c
    helper = np.array([1.0, 0.0, 0.0]) if abs(c[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, c)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(c, e1)
    return local @ np.vstack([e1, e2, c])


def normal_stress(stress, normals) -> np.ndarray:
    """sigma_n = n^T sigma n (samples x normals) of stress tensors ``stress`` (samples, 6; VOIGT order) on the planes
    of unit ``normals`` (k, 3)."""
    s = np.asarray(stress, float)
    n = np.asarray(normals, float)
    require(s.ndim == 2 and s.shape[1] == 6, "stress", f"an array of shape {s.shape}", "(samples, 6), VOIGT order")
    require(n.ndim == 2 and n.shape[1] == 3, "normals", f"an array of shape {n.shape}", "(k, 3) unit vectors")
    nx, ny, nz = n[:, 0], n[:, 1], n[:, 2]
    # the six products of the normal's components, in VOIGT order, shear ones doubled (the tensor is symmetric)
    weights = np.vstack([nx * nx, ny * ny, nz * nz, 2.0 * nx * ny, 2.0 * ny * nz, 2.0 * nx * nz])   # (6, k)
    return s @ weights


def angle_between_planes(a, b) -> float:
    """The angle (rad, 0 .. pi/2) between the planes of unit normals a and b (n and -n one plane)."""
    cos = abs(float(np.dot(a, b)) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.acos(min(1.0, cos))
