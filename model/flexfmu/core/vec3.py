"""Unchecked 3-vector helpers for per-step hot paths (np.cross costs ~30 us per call; these ~1 us).

The checked, documented versions for user input live in :mod:`flexfmu.core.rotation`; they check
their input and then call these, so each formula exists once.  The rotation formulas themselves
(Rodrigues, the rotation vector and quaternion of a matrix, the rotation-vector rate) live there too,
each with an unchecked hot-path form (:func:`flexfmu.core.rotation.rodrigues`, ...).
"""
from __future__ import annotations

import numpy as np

_F64 = np.dtype(np.float64)


def components(v):
    """The components of v: Python floats when v is a 1-D float64 numpy array (arithmetic on them is the same
    IEEE double arithmetic as on numpy scalars, several times faster), else v itself (unpacked by the caller:
    the rows of a (3, n) array, for instance)."""
    return v.tolist() if v.__class__ is np.ndarray and v.dtype is _F64 and v.ndim == 1 else v


def cross(a, b) -> np.ndarray:
    """a x b."""
    a0, a1, a2 = components(a)
    b0, b1, b2 = components(b)
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def skew(v) -> np.ndarray:
    """Cross-product matrix: skew(a) @ b == a x b."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
