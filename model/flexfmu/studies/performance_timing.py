"""How the performance study (flexfmu.studies.performance) times a figure and describes where it ran: the clock,
the best of repeated calls, the peak memory of a process, the machine."""
from __future__ import annotations

import math
import os
import platform
import resource
import time
from pathlib import Path

import numpy as np


# Per-step figures are CPU time of this process (single-threaded work: the compiled kernels, fmpy,
# pythonfmu), which other jobs on the shared cores disturb far less than wall time; set-up and fresh-process
# figures are wall time (they include multi-threaded BLAS and process start-up).
CLOCK = time.process_time


def best_time(fn, repeat=3):
    """Smallest CPU time of ``repeat`` calls of fn() (s) — the least disturbed by other load."""
    best = math.inf
    for _ in range(repeat):
        t0 = CLOCK()
        fn()
        best = min(best, CLOCK() - t0)
    return best


def machine() -> dict:
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import scipy

    from flexfmu.reframe import kernels as kern
    if kern.NATIVE:
        from flexfmu.native.compiler import KERNEL_FLAGS, find_compiler
        flags = " ".join(f for f in KERNEL_FLAGS if f.startswith(("-O", "-ffp")))
        kernels = f"C ({Path(find_compiler()).name} {flags})"
    else:
        kernels = f"numpy ({kern.NATIVE_REASON})"
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "kernels": kernels, "platform": platform.platform()}


def peak_memory_mb() -> float:
    """Peak resident memory of this process, MB: VmHWM of /proc/self/status (Linux: reset at exec, unlike
    ru_maxrss, which a child started by fork + exec inherits from its parent), else ru_maxrss."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
