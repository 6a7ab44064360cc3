"""Unchecked 3-vector helpers for per-step hot paths (np.cross costs ~30 us per call; these ~1 us).

The checked, documented versions for user input live in :mod:`flexfmu.core.rotation`; they check
their input and then call these, so each formula exists once.
"""
from __future__ import annotations

import math

import numpy as np


def cross(a, b) -> np.ndarray:
    """a x b."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def skew(v) -> np.ndarray:
    """Cross-product matrix: skew(a) @ b == a x b."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rodrigues(phi) -> np.ndarray:
    """exp(skew(phi)) as I + a K + b K K, K = skew(phi) (= scipy ``Rotation.from_rotvec(phi).as_matrix()``;
    series for a, b below 1e-4 rad).  phi: float (3,) array, unchecked.

    The reframe kernels (flexfmu.reframe.kernels, numpy and C) evaluate the same formula element by element,
    K K = phi phi^T - |phi|^2 I, the form of the C kernels' loops; the two differ in rounding only
    (tests/test_rotation.py compares them), and each scheme keeps its own so its numbers do not change."""
    th2 = float(phi @ phi)
    th = math.sqrt(th2)
    if th < 1e-4:
        a = 1.0 - th2 / 6.0 + th2 * th2 / 120.0
        b = 0.5 - th2 / 24.0 + th2 * th2 / 720.0
    else:
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / th2
    K = skew(phi)
    return np.eye(3) + a * K + b * (K @ K)
