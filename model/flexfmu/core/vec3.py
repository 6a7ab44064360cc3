"""Unchecked 3-vector helpers for per-step hot paths (np.cross costs ~30 us per call; these ~1 us).

The checked, documented versions for user input live in :mod:`flexfmu.core.rotation`.
"""
from __future__ import annotations

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
