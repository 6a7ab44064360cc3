"""The flat arrays of the reframe kernels (:mod:`flexfmu.reframe.kernels`), declared once.

* ``P`` model parameters for nf flexible modes (:func:`param_layout`): m (1), J0 (9), A_j (nf*9),
  B_j + B_j^T (nf*9), C_jk (nf*nf*9), D_j (nf*3*nf), k_F (nf), c_F (nf), A6 (36), A6^-1 (36), centre of
  mass (3).
* ``y`` state (:data:`STATE`): frame point (3), rotation body -> global (9, row-major), eta
  (2 (6 + nf)) = [q_R, q_F, qdot_R, qdot_F].
* the outputs of one state (:func:`output_layout`): frame origin (3), its velocity (3), quaternion (4),
  omega (3), alpha (3), centre-of-mass position (3) and velocity (3), q (nf), qdot (nf), max elastic
  displacement (1), then per output point position, velocity, acceleration and their rigid parts
  (6 x 3).

The parameter offsets are computed by the kernels' ``_offsets(nf)`` (flexfmu.reframe.kernels; the C kernels'
twin ffx_reframe_offsets, flexfmu/native/csrc/reframe_kernels.h, is compared with it in
tests/test_performance_equivalence.py); :func:`param_layout` names them.  The output positions are written
by the output kernels; tests/test_performance_equivalence.py
checks that they are where :func:`output_layout` says.
"""
from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

__all__ = ["ParamLayout", "param_layout", "OutputLayout", "output_layout", "STATE"]


class ParamLayout(NamedTuple):
    """Start offsets of the blocks of ``P`` (``end``: its length), in the order of ``kernels._offsets``."""

    J0: int
    A: int
    B: int
    C: int
    D: int
    k: int
    c: int
    A6: int
    A6inv: int
    com: int
    end: int


@lru_cache(maxsize=64)
def param_layout(nf: int) -> ParamLayout:
    """Offsets of ``P`` for nf flexible modes: the kernels' own ``_offsets`` (one definition; imported here on
    first use, as flexfmu.reframe.kernels_numpy imports this module)."""
    from flexfmu.reframe.kernels import _offsets

    return ParamLayout(*(int(o) for o in _offsets(nf)))


class _StateLayout(NamedTuple):
    position: slice
    rotation: slice
    eta: slice


#: the state vector y (eta runs to the end)
STATE = _StateLayout(position=slice(0, 3), rotation=slice(3, 12), eta=slice(12, None))


class OutputLayout(NamedTuple):
    """Places of the outputs of one state with nf flexible modes and n_points output points."""

    frame_origin: slice
    frame_origin_velocity: slice
    quaternion: slice
    omega: slice
    alpha: slice
    com_position: slice
    com_velocity: slice
    q: slice
    qd: slice
    max_elastic_displacement: int
    points: slice                 # (n_points, 6, 3) row-major: position, velocity, acceleration, rigid ones
    size: int


def output_layout(nf: int, n_points: int) -> OutputLayout:
    """The output vector's layout for nf flexible modes and n_points output points."""
    o = 22 + 2 * nf
    return OutputLayout(frame_origin=slice(0, 3), frame_origin_velocity=slice(3, 6), quaternion=slice(6, 10),
                        omega=slice(10, 13), alpha=slice(13, 16), com_position=slice(16, 19),
                        com_velocity=slice(19, 22), q=slice(22, 22 + nf), qd=slice(22 + nf, o),
                        max_elastic_displacement=o, points=slice(o + 1, o + 1 + 18 * n_points),
                        size=o + 1 + 18 * n_points)
