"""BLAS threads chosen by problem size: one thread for small matrices, the libraries' own count for large ones.

On a busy 2-core machine OpenBLAS's and MKL's worker threads spin waiting for cores the other processes hold.
Per step, a 19 x 19 ``scipy.linalg.expm`` goes from 30 µs to 1.5-10 ms that way; in set-up (modal analysis,
sizing, the reduced body) small dense eigen-solves and factorisations become 3-8 times slower.

Measured on this machine (2 cores, OpenBLAS 0.3.30 SkylakeX; best of several runs; benchmarks/setup_threads.py
and docs/threads.md), time with one thread / time with two:

=========  ===========================  ======================================
dimension  idle machine                 shared (load 3-4 on the 2 cores)
=========  ===========================  ======================================
100-300    0.8-1.5 (eigh ~1.0)          --
400-500    eigh 1.1-1.2, matmul 0.9     eigh 0.3-0.7, lu 0.12, matmul 1.5
800-1200   --                           eigh 0.3-0.5, lu 0.2-0.5, matmul 0.6-1
1600-2400  --                           eigh 0.9-1.5, lu 0.5, matmul 0.8-0.9
=========  ===========================  ======================================

Threads gain at most ~1.2-1.5x below ~2000 when the machine is idle, and lose 2-8x when it is shared, so
matrices below SINGLE_THREAD_BELOW_DIM run on one thread.  Every dense set-up path of flexfmu is below it (the
dense/sparse cut-offs of flexfmu.linalg.cutoffs are 200-1000 DOFs); the large sparse models (solid bodies of
thousands of DOFs) keep the libraries' count, where PARDISO's parallel factorisation pays.

Both OpenBLAS (numpy's and scipy's copies) and MKL are limited through threadpoolctl's "blas" API.  MKL's
PARDISO follows mkl_set_num_threads: under the limit it starts no OpenMP worker (checked: the process's thread
count), so the "openmp" API (libiomp5, loaded by MKL) need not be limited.  Without threadpoolctl all of this
is a no-op: only slower.
"""
from __future__ import annotations

import os
import sys
from contextlib import nullcontext

from flexfmu.core.checks import require_int

#: Square-matrix dimension (DOFs) from which set-up work keeps the BLAS libraries' own thread count.
SINGLE_THREAD_BELOW_DIM = 2000

_controller = None
_modules_seen = -1


def _threadpool_controller():
    """A cached threadpoolctl controller, or False without threadpoolctl.

    The controller knows the libraries loaded when it was made (8 ms to make), but MKL comes with pypardiso and
    scipy's OpenBLAS with scipy.linalg, possibly later: it is made again whenever modules were imported since."""
    global _controller, _modules_seen
    if _controller is False or (_controller is not None and len(sys.modules) == _modules_seen):
        return _controller
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:            # optional at run time: only slower
        _controller = False
    else:
        _controller = ThreadpoolController()
        _modules_seen = len(sys.modules)
    return _controller


def threads_for(dimension: int) -> int:
    """BLAS threads for dense work on square matrices of ``dimension`` (DOFs): 1 below SINGLE_THREAD_BELOW_DIM,
    else the machine's cores (``os.cpu_count()``; in :func:`limited_for`: the libraries' own setting)."""
    dimension = require_int(dimension, "dimension", 0, sys.maxsize, "a matrix dimension >= 0 (DOFs)")
    return 1 if dimension < SINGLE_THREAD_BELOW_DIM else max(1, os.cpu_count() or 1)


def limited_for(dimension: int):
    """Context manager: the loaded BLAS libraries (OpenBLAS, MKL) on :func:`threads_for` threads for work on
    matrices of ``dimension``.  Above the threshold nothing changes, so a user's OPENBLAS_NUM_THREADS or
    MKL_NUM_THREADS still holds.  Nests (threadpoolctl restores each library's count on exit)."""
    if threads_for(dimension) > 1:
        return nullcontext()
    return single_thread()


def single_thread():
    """Context manager limiting the loaded BLAS libraries to one thread (no-op without threadpoolctl)."""
    controller = _threadpool_controller()
    return controller.limit(limits=1, user_api="blas") if controller else nullcontext()
