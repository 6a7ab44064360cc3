"""Small dense LAPACK calls on one BLAS thread.

On a busy 2-core machine OpenBLAS's worker threads turn a 19 x 19 ``scipy.linalg.expm`` from 30 µs
into 1.5-10 ms (measured: the threads spin waiting for cores the other processes hold).  The FFR
step recomputes such an exponential whenever the base rotation input changes, i.e. every
communication step in a platform co-simulation, so those calls run under a one-thread limit
(threadpoolctl, ~60 µs per call).  Large set-up work (assembly, eigen-solves) keeps all threads.
"""
from __future__ import annotations

from contextlib import nullcontext

_controller = None


def single_thread():
    """Context manager limiting the loaded BLAS libraries to one thread (no-op without threadpoolctl)."""
    global _controller
    if _controller is None:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:            # optional at run time: only slower
            _controller = False
        else:
            _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas") if _controller else nullcontext()
