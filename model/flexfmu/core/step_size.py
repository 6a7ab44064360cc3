"""When two step sizes are one step: the key of every cache keyed by a step size.

A host that computes each communication step as h = t(k+1) - t(k) (``fmpy.simulate_fmu``, libcosim,
Reference-FMUs' fmusim) passes steps that differ from its nominal step in their last bits: by up to about
eps |t| / h relative (eps = 2.2e-16), e.g. 2.6e-9 for a 20-minute record at 0.1 ms.  A cache keyed by the exact
step size (the exact zero-order-hold maps, the exponential scheme's coefficients, the radiation memory's
discretisation) then misses at almost every step and recomputes a matrix exponential, 10-20x the cost of the
step itself.  So a step within ``STEP_RTOL`` (relative) of a step already seen *is* that step: its cached entry
is reused, and the state advances by the cached step ``hc``.

Error bound.  The cached map applied where the host asked for h gives the exact solution of the held-input
model at a time shifted by |h - hc| <= STEP_RTOL hc, so over that step the state differs by at most
``STEP_RTOL * hc * max |x'|`` (x' the state's rate over the step).  For the host pattern above the shifts do not
add up: the steps h_k = t(k+1) - t(k) are exact differences (Sterbenz), they sum to t(N) - t(0), and N hc
differs from that by the rounding of the host's own clock, so the state stays within about
``ulp(t) * max |x'|`` of the exact solution at the host's time.  A host whose steps truly differ by less than
STEP_RTOL (a variable-step master) shifts the model's time by at most STEP_RTOL per second simulated (1 µs/s).
Where the cached coefficients feed a multi-stage step of the host's own length (the reframe exponential
scheme), the coefficients' error is |d EX / d dt| |dt - dtc| <= STEP_RTOL * dt * omega_max * |EX| per step,
the same order.

Which step stands for its variants is the first one seen, so it depends on what came before: the list lives
with each simulator instance (an FMU instance), never with a model object that instances share (the FFR
dynamics and the reframe integrator are cached per model), so a run never depends on another instance's steps
and two instances given the same calls compute the same bits.

The compiled kernels use the same tolerance (``FFX_STEP_RTOL`` in ``native/csrc/lti_kernels.h``;
tests/test_step_size.py checks that the two agree).
"""
from __future__ import annotations

STEP_RTOL = 1e-6
"""Relative difference under which two step sizes are one step (see the module's error bound)."""


def same_step(cached: float, h: float) -> bool:
    """True when step ``h`` (s) may reuse what was computed for step ``cached`` (s)."""
    return h == cached or abs(h - cached) <= STEP_RTOL * abs(cached)


class StepSizes:
    """The step sizes an instance has seen, each standing for every step within ``STEP_RTOL`` of it.

    ``canonical(h)`` returns the first-seen step that ``h`` is the same step as, else records and returns
    ``h``: cache keys built from it hit for the last-bit variants a host passes.  At most ``size`` steps are
    kept (a master that varies its step freely starts the list afresh, as :class:`~flexfmu.core.cache.
    BoundedCache` does)."""

    __slots__ = ("_known", "_size")

    def __init__(self, size: int = 16):
        self._known: list[float] = []
        self._size = size

    def canonical(self, h: float) -> float:
        for known in self._known:
            if h == known or abs(h - known) <= STEP_RTOL * known:
                return known
        if len(self._known) >= self._size:
            self._known.clear()
        self._known.append(h)
        return h
