"""Hot loops of the consistent and exponential reframe schemes (:mod:`flexfmu.reframe.integrator`): whole RK4 or
ETD-RK4 steps and the outputs of one state, in modal space, on flat arrays.

Two implementations of the same equations: C (flexfmu/native/csrc/reframe_kernels.c, the one compiled
implementation, called here through ctypes by :mod:`flexfmu.native.reframe` and linked into native FMUs) and
numpy (:mod:`flexfmu.reframe.kernels_numpy`, the reference; tests/test_native_reframe_kernels.py compares
them).  The public names (``consistent_steps``, ``reframe_steps``, ``consistent_outputs``,
``reframe_outputs``, ``max_node_norm``) are the C ones when a C compiler is available or the library is
already in the cache (compiled once per source digest into ``<cache root>/native``,
flexfmu.native.compiler), else the numpy ones; ``FLEXFMU_NATIVE_KERNELS=0`` in the environment forces numpy.
``*_numpy`` are always the numpy ones.  :data:`NATIVE` (bound on first use, as the kernels: the library is
loaded, and compiled if needed, then) says which; :data:`NATIVE_REASON` why not C.

This module holds only the public names and the choice between C and numpy.  The numpy kernels and their scalar
helpers are in :mod:`flexfmu.reframe.kernels_numpy`, the rotation formulas they share with the rest of flexfmu
in :mod:`flexfmu.core.rotation`, the layouts and constants (``BLOCK``, ``NOT_COMPUTED``) in
:mod:`flexfmu.reframe.layout`; the C file has the twins (ffx_reframe_rodrigues, _rate_coefficient, _solve3,
_quaternion, _offsets, _bound, _block_norm, _max_node_norm).  Imports run one way: layout <- kernels_numpy <-
kernels (kernels_numpy and the C bindings are imported on first use).

Everything here is O(n_modes^2) per step whatever the mesh size, except :func:`max_node_norm`
(O(number of nodes) in the worst case, a few nodes in practice: see
:func:`flexfmu.reframe.kernels_numpy.max_node_norm_blocks`).

Layouts of the flat arrays: ``P`` (model parameters), ``y`` (state) and the outputs of one state are
declared in :mod:`flexfmu.reframe.layout` (``param_layout`` gives ``P``'s offsets); the C header
flexfmu/native/csrc/reframe_kernels.h documents all of them for C callers.  The integrator
(``ReframeIntegrator._setup_consistent``, ``_kernel_loads``, ``_point_data``) builds the others:

* ``LP`` loads, one block of 5 + 6 nf per load: follower (0/1), rotational DOFs (0/1), arm
  X_i - c (3), translational rows of Phi at the node (3*nf), rotational rows (3*nf, zeros if none).
* ``SV`` load values (n_steps or 1, 3 stages t, t + dt/2, t + dt, n_loads, 6 = force, moment).
* ``G`` geometric stiffness (9 nf^2: (3, 3, nf, nf) row-major, body frame) or empty: adds
  -(sum_ab X_ab G_ab) q_F, X = skew(omega)^2, to the flexible momentum rate.
* ``EX`` exponential-scheme coefficients for one dt (nf, 6, 2, 2 row-major: E1, E2, A2, B1, B2, B4 of
  :func:`flexfmu.reframe.schemes.exponential_coefficients`) or empty: classical RK4 (consistent scheme).
* ``PP`` output points, one row [X - c (3), translational rows of Phi (3*nf)] each.

The C kernels need C-contiguous float64 arrays (int64 for the node order), which is how the integrator and
flexfmu.body.free make them; other arrays are converted per call (correct, slower).
"""
from __future__ import annotations

import os
import warnings

# BLOCK, NOT_COMPUTED: the kernels' constants, which callers read as kernels.BLOCK and kernels.NOT_COMPUTED
from flexfmu.reframe.layout import BLOCK, NOT_COMPUTED, output_layout, param_layout  # noqa: F401


#: FLEXFMU_NATIVE_KERNELS=0 (false, no, off): the numpy kernels even when the C library is available
_WANT_NATIVE = os.environ.get("FLEXFMU_NATIVE_KERNELS", "1").strip().lower() not in ("0", "false", "no", "off")


def param_size(nf: int) -> int:
    """Length of ``P`` for nf flexible modes."""
    return param_layout(nf).end


def output_size(nf: int, n_points: int) -> int:
    """Length of the outputs of one state (flexfmu.reframe.layout.output_layout)."""
    return output_layout(nf, n_points).size


#: the kernels the integrator calls: C when the library is available (see the module docstring), numpy
#: otherwise; ``*_numpy`` always numpy.  Bound on first use (loading, or compiling, the library then).
_KERNELS = ("consistent_steps", "reframe_steps", "consistent_outputs", "reframe_outputs", "max_node_norm")


def _native():
    """The C bindings (flexfmu.native.reframe) with the library loaded, or the reason they are not used."""
    if not _WANT_NATIVE:
        return None, "disabled by FLEXFMU_NATIVE_KERNELS=0"
    try:
        from flexfmu.native import reframe as native
        native.library()
    except Exception as exc:          # CompilerError (no compiler, does not compile), OSError (cannot load)
        reason = f"C kernels unavailable: {exc}".strip()
        warnings.warn(f"flexfmu: {reason}; the reframe kernels run as numpy (about 30x slower per step). "
                      "Install a C compiler (gcc, clang) or set FLEXFMU_NATIVE_KERNELS=0 to silence this.",
                      RuntimeWarning, stacklevel=3)
        return None, reason
    return native, None


def _use_native() -> bool:
    if "NATIVE" not in globals():
        native, reason = _native()
        globals().update(NATIVE=native is not None, NATIVE_REASON=reason)
    return NATIVE


def __getattr__(name):
    if name in ("NATIVE", "NATIVE_REASON"):
        _use_native()
        return globals()[name]
    base = name[:-len("_numpy")] if name.endswith("_numpy") else name
    if base not in _KERNELS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    if name == base and _use_native():
        from flexfmu.native import reframe as native
        value = getattr(native, base)
    else:
        from flexfmu.reframe import kernels_numpy
        value = getattr(kernels_numpy, base + "_numpy" if base == "max_node_norm" else base)
    globals()[name] = value
    return value
