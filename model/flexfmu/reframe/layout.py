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

The parameter offsets are computed here, by :func:`param_layout` (the C kernels' twin ffx_reframe_offsets,
flexfmu/native/csrc/reframe_kernels.h, is compared with it in tests/test_native_reframe_kernels.py and
tests/test_performance_equivalence.py).  The output positions are written by the output kernels;
tests/test_performance_equivalence.py checks that they are where :func:`output_layout` says.  Also declared
here: :data:`NOT_COMPUTED` (the skipped max-displacement search's output value); :data:`BLOCK` (the node blocks
of that search) is the C contract's FFX_REFRAME_BLOCK as its ctypes bindings (flexfmu.native.reframe, a layer
below) define it.

The kernels (flexfmu.reframe.kernels, kernels_numpy) import this module, never the other way round.
"""
from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

# nodes per block and blocks per superblock of the max-displacement search (flexfmu.reframe.kernel_data
# .max_displacement_blocks): FFX_REFRAME_BLOCK, one definition in the C kernels' bindings
from flexfmu.native.reframe import BLOCK

__all__ = ["ParamLayout", "param_layout", "OutputLayout", "output_layout", "STATE", "NOT_COMPUTED", "BLOCK"]

#: the max elastic displacement's place in the outputs when its search was skipped (a norm is never < 0; the C
#: kernels' twin FFX_REFRAME_NOT_COMPUTED)
NOT_COMPUTED = -1.0


class ParamLayout(NamedTuple):
    """Start offsets of the blocks of ``P`` (``end``: its length), in the order of ffx_reframe_offsets."""

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
    """Offsets of ``P``'s blocks for nf flexible modes (J0, A, B, C, D, k, c, A6, A6inv, com, end), as
    ffx_reframe_offsets: m (1), J0 (9), A_j (nf*9), B_j (nf*9), C_jk (nf*nf*9), D_j (nf*3*nf), k_F (nf),
    c_F (nf), A6 (36), A6^-1 (36), centre of mass (3)."""
    nf = int(nf)
    J0 = 1
    A = J0 + 9
    B = A + nf * 9
    C = B + nf * 9
    D = C + nf * nf * 9
    k = D + nf * 3 * nf
    c = k + nf
    A6 = c + nf
    A6inv = A6 + 36
    com = A6inv + 36
    return ParamLayout(J0, A, B, C, D, k, c, A6, A6inv, com, com + 3)


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
