"""How a communication step is split into internal steps and refused beyond ``max_internal_steps``: the rule of
csrc/step_policy.h (its comment states it), called through ctypes by FFRBeam's, ReframeBody's and the exported
bodies' simulators; the native FMUs link the same C.

    n = split_step(h, step, cap)          h / step (1 - 1e-12) internal steps, at least 1; 0: refused
    n = step_count(ratio, scale, cap)     a count the kind made itself (scale 1, or GUARD: capped as is, counted
                                          guarded); 0: refused
    raise split_refusal(h, step, cap, cause) / refusal(h, needed, cap, h_ok, cause[, rk4_limit])

A refusal is StepRejected (fmi2Discard) when a communication step of at least MIN_COMMUNICATION_STEP would fit the
cap (h_ok: the longest that does), else ParameterError naming ``cause`` (a :class:`Cause`, or a function giving one,
called only then).  What each kind keeps is its limit per internal step, its h_ok and its culprit.

The C library is compiled on first use (flexfmu.native.compiler, once per source digest).  Without a C compiler (or
with ``FLEXFMU_NATIVE_KERNELS=0``) the functions below ending in ``_python`` serve instead: the same rule in Python,
kept as the reference that tests/test_step_policy.py holds equal to the C on a grid of cases (counts and every
character of the messages), so a simulator steps and refuses alike on a machine without a compiler.  :data:`NATIVE`
says which is in use, :data:`NATIVE_REASON` why not C.

Cost: the simulators count once per communication step, and a ctypes call costs ~0.7 us, against ~0.1 us for the
few comparisons a step within its limit needs.  So split_step and step_count answer 1 themselves when the ratio is at
most 1 (the common case: no splitting), which the rule implies (ceil of at most 1, and 1 <= cap), and call the C
otherwise; tests/test_step_policy.py holds them equal to the C on its grid, boundaries included.
"""
from __future__ import annotations

import ctypes
import math
import os
import threading
from dataclasses import dataclass

from flexfmu.core.checks import MIN_COMMUNICATION_STEP
from flexfmu.errors import FlexfmuError, ParameterError, StepRejected
from flexfmu.native.compiler import CSRC, load_kernels

SOURCES = (CSRC / "step_policy.c",)
#: FFX_STEP_GUARD: h / step is counted as h / step (1 - 1e-12)
GUARD = 1 - 1e-12
_INF = math.inf
#: FFX_STEP_DISCARD, FFX_STEP_ERROR: the fmi2Status of a refusal
DISCARD, ERROR = 2, 3
#: FFX_STEP_TEXT_SIZE, FFX_STEP_MESSAGE_SIZE
TEXT_SIZE, MESSAGE_SIZE = 1024, 2048
_WANT_NATIVE = os.environ.get("FLEXFMU_NATIVE_KERNELS", "1").strip().lower() not in ("0", "false", "no", "off")


@dataclass(frozen=True)
class Cause:
    """What a refusal names when not even a MIN_COMMUNICATION_STEP step fits the cap: ParameterError(parameter,
    before + <reason> + after, allowed) (ffx_step_cause)."""

    parameter: str
    allowed: str
    before: str = ""
    after: str = ""


# ---------------------------------------------------------------------------------------------- the Python reference
def round_down(x: float, digits: int = 4) -> float:
    """x > 0 rounded down to ``digits`` significant digits: a bound quoted in a message that still holds."""
    if not (math.isfinite(x) and x > 0):
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return math.floor(x / scale * (1 - 1e-12)) * scale


def step_count_python(ratio: float, count_scale: float, cap: int) -> int:
    if not ratio <= cap:
        return 0
    n = ratio * count_scale
    return math.ceil(n) if n > 1.0 else 1


def split_step_python(h: float, step: float, cap: int) -> int:
    return step_count_python(h / step * GUARD, 1.0, cap)


def refuse_python(h: float, needed: float, cap: int, h_ok: float, rk4_limit: float = 0.0,
                  cause: Cause | None = None) -> tuple[int, str]:
    """(status, detail) as ffx_step_refuse: detail is what follows "parameter: " (and precedes " (allowed: ...)")."""
    count = f"{math.ceil(needed)}" if math.isfinite(needed) and needed < 1e15 else f"{needed:.3g}"
    rk4 = rk4_limit > 0
    if h_ok >= MIN_COMMUNICATION_STEP:
        if rk4:
            return DISCARD, (f"integrator rk4 needs {count} internal steps for this communication step of {h:g} s "
                             f"(cap {cap}; stable step limit {rk4_limit:.4g} s); take a communication step <= "
                             f"{round_down(h_ok):.4g} s or raise max_internal_steps")
        return DISCARD, (f"needs {count} internal steps for this communication step of {h:g} s (cap {cap}); take a "
                         f"smaller communication step (<= {round_down(h_ok):.4g} s) or raise max_internal_steps")
    if rk4:
        reason = (f"integrator rk4: the stable step limit {rk4_limit:.3g} s (2.8 / omega_max) needs more than "
                  f"max_internal_steps = {cap} sub-steps even for a {MIN_COMMUNICATION_STEP:g} s communication step")
    else:
        reason = (f"even a {MIN_COMMUNICATION_STEP:g} s communication step needs more than max_internal_steps = "
                  f"{cap} internal steps")
    return ERROR, (cause.before + reason + cause.after) if cause else reason


def split_refuse_python(h: float, step: float, cap: int, cause: Cause | None = None) -> tuple[int, str]:
    return refuse_python(h, h / step * GUARD, cap, cap * step, 0.0, cause)


# ---------------------------------------------------------------------------------------------- the C library
class _Cause(ctypes.Structure):
    _fields_ = [("parameter", ctypes.c_char_p), ("before", ctypes.c_char_p), ("after", ctypes.c_char_p),
                ("allowed", ctypes.c_char_p)]


class _Refusal(ctypes.Structure):
    _fields_ = [("status", ctypes.c_int), ("parameter", ctypes.c_char_p), ("allowed", ctypes.c_char_p),
                ("detail", ctypes.c_char * TEXT_SIZE), ("message", ctypes.c_char * MESSAGE_SIZE)]


_lock = threading.RLock()
_lib = None


def library() -> ctypes.CDLL:
    """The compiled step policy, prototypes declared (CompilerError when it cannot be compiled)."""
    global _lib
    with _lock:
        if _lib is None:
            lib = load_kernels("step_policy", SOURCES)
            d, lg, vp = ctypes.c_double, ctypes.c_long, ctypes.c_void_p
            for name, res, args in (("ffx_split_step", lg, [d, d, lg]), ("ffx_step_count", lg, [d, d, lg]),
                                    ("ffx_step_refuse", ctypes.c_int, [d, d, lg, d, d, vp, vp]),
                                    ("ffx_split_refuse", ctypes.c_int, [d, d, lg, vp, vp]),
                                    ("ffx_round_down", d, [d]), ("ffx_min_communication_step", d, [])):
                f = getattr(lib, name)
                f.restype, f.argtypes = res, args
            _lib = lib
    return _lib


def _c_cause(cause: Cause | None):
    if cause is None:
        return None
    return ctypes.byref(_Cause(*(s.encode() for s in (cause.parameter, cause.before, cause.after, cause.allowed))))


def refuse_c(h: float, needed: float, cap: int, h_ok: float, rk4_limit: float = 0.0, cause: Cause | None = None,
             refusal: _Refusal | None = None) -> tuple[int, str]:
    """(status, detail) of ffx_step_refuse (``refusal``: the C struct to fill, for the tests to read)."""
    out = _Refusal() if refusal is None else refusal
    status = library().ffx_step_refuse(h, needed, cap, h_ok, rk4_limit, _c_cause(cause), ctypes.byref(out))
    return status, out.detail.decode(errors="replace")


def split_refuse_c(h: float, step: float, cap: int, cause: Cause | None = None) -> tuple[int, str]:
    """(status, detail) of ffx_split_refuse."""
    out = _Refusal()
    status = library().ffx_split_refuse(h, step, cap, _c_cause(cause), ctypes.byref(out))
    return status, out.detail.decode(errors="replace")


def _bind() -> None:
    """Bind the counts and refusals to the C library, or to the Python reference when it is not available."""
    native, reason = False, "disabled by FLEXFMU_NATIVE_KERNELS=0"
    if _WANT_NATIVE:
        try:
            lib = library()
            native, reason = True, None
        except Exception as exc:      # CompilerError (no compiler, does not compile), OSError (cannot load)
            reason = f"C step policy unavailable: {exc}".strip()
    with _lock:
        if native:
            globals().update(_split_step=lib.ffx_split_step, _step_count=lib.ffx_step_count, _refuse=refuse_c,
                             _split_refuse=split_refuse_c)
        else:
            globals().update(_split_step=split_step_python, _step_count=step_count_python, _refuse=refuse_python,
                             _split_refuse=split_refuse_python)
        globals().update(NATIVE=native, NATIVE_REASON=reason)


# what _bind replaces on first use (loading, or compiling, the library then)
def _split_step(h, step, cap):
    _bind()
    return _split_step(h, step, cap)


def _step_count(ratio, count_scale, cap):
    _bind()
    return _step_count(ratio, count_scale, cap)


def _refuse(*args):
    _bind()
    return _refuse(*args)


def _split_refuse(*args):
    _bind()
    return _split_refuse(*args)


def __getattr__(name):
    if name in ("NATIVE", "NATIVE_REASON"):
        _bind()
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# ---------------------------------------------------------------------------------------------- counts
def split_step(h: float, step: float, cap: int) -> int:
    """Internal steps n >= 1 of a communication step h with internal steps of at most ``step`` (s), 0: refused
    (ffx_split_step).  Within the limit (0 < h < inf, h <= step) and cap >= 1: 1 without a call into C."""
    if 0.0 < h < _INF and h <= step and cap >= 1:
        return 1
    return _split_step(h, step, cap)


def step_count(ratio: float, count_scale: float, cap: int) -> int:
    """max(1, ceil(ratio count_scale)) when ratio <= cap, else 0 (ffx_step_count; count_scale in (0, 1]).  A ratio
    of at most 1 with cap >= 1: 1 without a call into C."""
    if ratio <= 1.0 and 0.0 < count_scale <= 1.0 and cap >= 1:
        return 1
    return _step_count(ratio, count_scale, cap)


# ---------------------------------------------------------------------------------------------- refusals
def refusal(h: float, needed: float, cap: int, h_ok: float, cause, rk4_limit: float = 0.0) -> FlexfmuError:
    """The error refusing a step h that needs ``needed`` internal steps (more than ``cap``, or NaN); ``h_ok``: the
    longest communication step within the cap; ``cause``: a Cause, or a function giving it (called only when the
    refusal is an error); ``rk4_limit`` > 0: FFRBeam's RK4 sub-steps under that stable step limit (its wording)."""
    status, detail = _refuse(h, needed, cap, h_ok, rk4_limit, None)
    if status == DISCARD:
        return StepRejected("max_internal_steps", detail)
    cause = cause() if callable(cause) else cause
    return ParameterError(cause.parameter, _refuse(h, needed, cap, h_ok, rk4_limit, cause)[1], cause.allowed)


def split_refusal(h: float, step: float, cap: int, cause: Cause) -> FlexfmuError:
    """The refusal of a step that split_step(h, step, cap) refused (ffx_split_refuse)."""
    status, detail = _split_refuse(h, step, cap, cause)
    if status == DISCARD:
        return StepRejected("max_internal_steps", detail)
    return ParameterError(cause.parameter, detail, cause.allowed)
