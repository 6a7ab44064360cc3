"""The step policy: how a communication step is split into internal steps and refused beyond max_internal_steps,
written once in C (flexfmu/native/csrc/step_policy.c), called by the Python simulators through ctypes
(flexfmu.native.step_policy) and linked into the native FMUs.

The C functions against a table of cases (the count, the boundary at exactly the cap and just above it, the rounding
guard, the Discard / Error switch at MIN_COMMUNICATION_STEP, counts of 1e15 and more, NaN and infinite steps) with
the messages' exact words; the pure-Python reference (the fallback without a C compiler) equal to the C on a grid,
counts and every character of the messages; the public entry points, and the simulators without a compiler."""
import ctypes
import itertools
import json
import math
import os
import re
import subprocess
import sys

import pytest

from flexfmu.core.checks import MIN_COMMUNICATION_STEP
from flexfmu.errors import ParameterError, StepRejected
from flexfmu.native import step_policy as sp
from flexfmu.native.compiler import CSRC, CompilerError

try:
    LIB = sp.library()
except CompilerError as exc:                     # pragma: no cover - no C compiler on this machine
    pytest.skip(f"no C compiler: {exc}", allow_module_level=True)

HEADER = (CSRC / "step_policy.h").read_text()
INF, NAN = math.inf, math.nan
G = 1 - 1e-12
CAUSE = sp.Cause("F_x", "a smaller force", "3 N: ", " (held)")


def define(name: str):
    """The value of a #define of step_policy.h (a number or a parenthesised expression of numbers)."""
    text = re.search(rf"^#define {name} ([^/\n]+)", HEADER, re.M).group(1).strip()
    assert re.fullmatch(r"[0-9eE.+\-() ]+", text), text
    return eval(text, {})                        # noqa: S307 - digits, signs and parentheses only (checked)


def test_the_header_the_library_and_the_bindings_agree_on_the_constants():
    assert define("FFX_MIN_COMMUNICATION_STEP") == LIB.ffx_min_communication_step() == MIN_COMMUNICATION_STEP
    assert define("FFX_STEP_GUARD") == sp.GUARD == G
    assert (define("FFX_STEP_DISCARD"), define("FFX_STEP_ERROR")) == (sp.DISCARD, sp.ERROR) == (2, 3)   # fmi2Status
    assert (define("FFX_STEP_TEXT_SIZE"), define("FFX_STEP_MESSAGE_SIZE")) == (sp.TEXT_SIZE, sp.MESSAGE_SIZE)


# ---------------------------------------------------------------------------------------------- counts
#: (h, step, cap, n): n = max(1, ceil(h / step (1 - 1e-12))) within the cap, else 0
SPLITS = [
    (1e-3, 2.5e-4, 100, 4),
    (2.5e-4, 2.5e-4, 100, 1),                        # one step of exactly the limit
    (1e-5, 1e-3, 100, 1),                            # shorter than the limit
    (3e-4 * (1 + 1e-14), 1e-4, 100, 3),              # a rounding error above 3 steps: the guard keeps 3
    (3e-4 * (1 + 1e-11), 1e-4, 100, 4),              # beyond the guard: 4
    (1e-2, 1e-4, 100, 100),                          # exactly at the cap
    (1e-2 * (1 + 1e-13), 1e-4, 100, 100),            # a rounding error above it: within (the guard)
    (1.0000001e-2, 1e-4, 100, 0),                    # just above the cap: refused
    (1.0, 1e-3, 1, 0),
    (1e-3, 1e-3, 1, 1),                              # cap 1, one step
    (1e-3, INF, 5, 1),                               # no limit per internal step
    (1.0, 1e-16, 10**8, 0),                          # 1e16 steps
    (1e300, 1e-300, 10**8, 0),                       # an infinite ratio
    (NAN, 1e-4, 100, 0), (INF, 1e-4, 100, 0), (INF, INF, 100, 0), (-NAN, INF, 100, 0),
]
#: (ratio, count_scale, cap, n): capped as it is, counted as ceil(ratio count_scale), at least 1
COUNTS = [
    (5.0, 1.0, 10, 5), (4.5, 1.0, 10, 5), (0.25, 1.0, 10, 1), (0.0, 1.0, 1, 1), (1.0, 1.0, 1, 1),
    (10.0, 1.0, 10, 10), (math.nextafter(10.0, INF), 1.0, 10, 0),
    (5 * (1 + 1e-13), 1.0, 10, 6), (5 * (1 + 1e-13), G, 10, 5),          # the free bodies' guard: after the cap
    (10 * (1 + 1e-13), G, 10, 0),                                          # ... so capped unguarded
    (1e15, 1.0, 10**8, 0), (INF, 1.0, 10**8, 0), (NAN, 1.0, 10**8, 0), (NAN, G, 10**8, 0),
]


def _entry_points():
    """The C functions, the public names (their fast path, then C) and the Python reference."""
    return [("C", LIB.ffx_split_step, LIB.ffx_step_count), ("public", sp.split_step, sp.step_count),
            ("python", sp.split_step_python, sp.step_count_python)]


@pytest.mark.parametrize("h, step, cap, n", SPLITS, ids=[f"{c[0]!r}/{c[1]!r}/cap{c[2]}" for c in SPLITS])
def test_split_step_counts(h, step, cap, n):
    for name, split, _ in _entry_points():
        assert split(h, step, cap) == n, name


@pytest.mark.parametrize("ratio, scale, cap, n", COUNTS, ids=[f"{c[0]!r}*{c[1]!r}/cap{c[2]}" for c in COUNTS])
def test_step_count_counts(ratio, scale, cap, n):
    for name, _, count in _entry_points():
        assert count(ratio, scale, cap) == n, name


def test_public_counts_call_the_c_functions_beyond_their_fast_path():
    assert sp.NATIVE and sp.NATIVE_REASON is None
    assert sp._split_step is LIB.ffx_split_step and sp._step_count is LIB.ffx_step_count


# ---------------------------------------------------------------------------------------------- refusals
_DISCARD = "needs {} internal steps for this communication step of {} s (cap {}); take a smaller communication step " \
           "(<= {} s) or raise max_internal_steps"
_REASON = "even a 1e-05 s communication step needs more than max_internal_steps = {} internal steps"
#: (h, needed, cap, h_ok, rk4_limit, cause, status, detail) in today's words
REFUSALS = [
    (0.5, 5000.0, 100, 1e-2, 0.0, None, 2, _DISCARD.format(5000, 0.5, 100, 0.00999)),
    (0.5, 5000.0, 100, 1e-5, 0.0, CAUSE, 2, _DISCARD.format(5000, 0.5, 100, "9.99e-06")),      # the switch: Discard
    (0.5, 5000.0, 100, math.nextafter(1e-5, 0), 0.0, None, 3, _REASON.format(100)),           # ... Error below it
    (0.5, 5000.0, 100, math.nextafter(1e-5, 0), 0.0, CAUSE, 3, "3 N: " + _REASON.format(100) + " (held)"),
    (0.5, 5000.0, 100, 0.0, 0.0, sp.Cause("internal_step", ""), 3, _REASON.format(100)),
    (1.0, 123.4, 3, 1.0, 0.0, None, 2, _DISCARD.format(124, 1, 3, 0.999)),
    (1.0, 999999999999999.0, 3, 1.0, 0.0, None, 2, _DISCARD.format(999999999999999, 1, 3, 0.999)),
    (1.0, 1e15, 3, 1.0, 0.0, None, 2, _DISCARD.format("1e+15", 1, 3, 0.999)),                  # >= 1e15: %.3g
    (1e300, 8.0312e302, 10**8, INF, 0.0, None, 2, _DISCARD.format("8.03e+302", "1e+300", 100000000, "inf")),
    (INF, INF, 3, 1.0, 0.0, None, 2, _DISCARD.format("inf", "inf", 3, 0.999)),
    (NAN, -NAN, 3, 1.0, 0.0, None, 2, _DISCARD.format("nan", "nan", 3, 0.999)),                # never "-nan"
    (NAN, NAN, 3, NAN, 0.0, CAUSE, 3, "3 N: " + _REASON.format(3) + " (held)"),                 # no h_ok: Error
    (0.02, 14.45, 10, 10 * 0.9 * 1.384e-3, 1.384e-3, None, 2,
     "integrator rk4 needs 15 internal steps for this communication step of 0.02 s (cap 10; stable step limit "
     "0.001384 s); take a communication step <= 0.01245 s or raise max_internal_steps"),
    (1e-3, 40.0, 3, 3 * 0.9 * 2.8e-7, 2.8e-7, sp.Cause("base_w_x", "a smaller base rotation", "1e+07: the held base "
                                                         "motion makes "), 3,
     "1e+07: the held base motion makes integrator rk4: the stable step limit 2.8e-07 s (2.8 / omega_max) needs more "
     "than max_internal_steps = 3 sub-steps even for a 1e-05 s communication step"),
]


def _c_refusal(h, needed, cap, h_ok, rk4_limit, cause):
    out = sp._Refusal()
    status, detail = sp.refuse_c(h, needed, cap, h_ok, rk4_limit, cause, refusal=out)
    assert status == out.status
    return status, detail, out


@pytest.mark.parametrize("case", REFUSALS, ids=[f"{k}" for k in range(len(REFUSALS))])
def test_refusal_statuses_and_words(case):
    *args, status, detail = case
    c_status, c_detail, out = _c_refusal(*args)
    assert (c_status, c_detail) == (status, detail)
    assert sp.refuse_python(*args) == (status, detail)
    cause = args[-1]
    # the whole message (what a native FMU logs) is the Python exception's text
    error = (StepRejected("max_internal_steps", detail) if status == sp.DISCARD else
             ParameterError(cause.parameter if cause else "", detail, cause.allowed if cause else None))
    assert out.message.decode() == str(error)
    if status == sp.DISCARD:              # (an error's names point into the cause, which refuse_c has let go)
        assert out.parameter == b"max_internal_steps" and not out.allowed


def test_split_refusal_is_the_refusal_of_the_split_ratio():
    """ffx_split_refuse: needed = h / step (1 - 1e-12), h_ok = cap step (the fixed internal steps' h_ok)."""
    for h, step, cap in [(0.5, 1e-4, 100), (1e300, 2.5e-5, 3), (NAN, 1e-4, 7), (1.0, 1e-9, 5)]:
        expected = sp.refuse_python(h, h / step * G, cap, cap * step, 0.0, CAUSE)
        assert sp.split_refuse_c(h, step, cap, CAUSE) == sp.split_refuse_python(h, step, cap, CAUSE) == expected


def test_public_refusals_are_the_exceptions_and_ask_for_the_cause_only_for_an_error():
    def no_cause():
        raise AssertionError("the cause is asked for a Discard")
    exc = sp.refusal(0.5, 5000.0, 100, 1e-2, no_cause)
    assert isinstance(exc, StepRejected) and exc.parameter == "max_internal_steps"
    assert str(exc) == "max_internal_steps: " + _DISCARD.format(5000, 0.5, 100, 0.00999)
    exc = sp.refusal(0.5, 5000.0, 100, 1e-6, lambda: CAUSE)
    assert isinstance(exc, ParameterError) and (exc.parameter, exc.allowed) == ("F_x", "a smaller force")
    assert str(exc) == f"F_x: 3 N: {_REASON.format(100)} (held) (allowed: a smaller force)"
    exc = sp.split_refusal(0.5, 1e-4, 100, sp.Cause("internal_step", "a smaller value"))
    assert isinstance(exc, StepRejected) and "(<= 0.00999 s)" in str(exc)
    exc = sp.split_refusal(0.5, 1e-8, 100, sp.Cause("internal_step", "a smaller value"))
    assert str(exc) == f"internal_step: {_REASON.format(100)} (allowed: a smaller value)"


# ---------------------------------------------------------------------------------------------- C = Python reference
_H = [1e-6, 1e-5, 1e-4, 3e-4, 3e-4 * (1 + 1e-14), 1e-3, 0.0137, 0.02, 0.1, 1.0, 10.0, 1e10, 1e300, 5e-324, 0.0,
      INF, NAN, -1.0]
_STEP = [1e-8, 2.5e-5, 1e-4, 3e-4, 1.384e-3 * 0.9, 0.01, 1.0, INF, -1.0]      # (0: Python divides by zero)
_CAP = [1, 3, 100, 100_000, 100_000_000]


def test_counts_of_the_c_and_the_python_reference_are_equal_on_a_grid():
    """... and the public names' fast path (1 without C) with them, at its edges too."""
    for h, step, cap in itertools.product(_H, _STEP, _CAP):
        n = LIB.ffx_split_step(h, step, cap)
        assert n == sp.split_step_python(h, step, cap) == sp.split_step(h, step, cap), (h, step, cap)
    ratios = [r * s for r in (0.0, 0.5, 1.0, 2.0, 2.5, 99.0, 100.0, 1e5, 1e8, 1e15) for s in (1 - 1e-13, 1, 1 + 1e-13)]
    for ratio, scale, cap in itertools.product(ratios + [INF, -INF, NAN, -1.0], (1.0, G, 0.5), _CAP + [0]):
        n = LIB.ffx_step_count(ratio, scale, cap)
        assert n == sp.step_count_python(ratio, scale, cap) == sp.step_count(ratio, scale, cap), (ratio, scale, cap)
    for h, step, cap in [(1e-3, 1e-3, 0), (1e-3, 1e-3, -1), (INF, INF, 5), (5e-324, INF, 1), (1.0, 1.0, 1)]:
        assert LIB.ffx_split_step(h, step, cap) == sp.split_step(h, step, cap), (h, step, cap)


def test_messages_of_the_c_and_the_python_reference_are_equal_on_a_grid():
    needed = [2.0, 1e5 + 0.5, 123456789.1, 999999999999999.0, 1e15, 3.3e302, INF, NAN, -NAN]
    h_ok = [0.0, 9.99e-6, 1e-5, math.nextafter(1e-5, INF), 1.2345678e-3, 0.1, 69.53, 1e300, INF, NAN]
    causes = [None, CAUSE, sp.Cause("state", "inputs that keep |omega| <= 1.778e+09 rad/s", "the body spins at "
                                    "5e+04 rad/s at t = 0.25 s: ", " of at most 0.5 tolerance^(1/4) = 0.0889 rad")]
    n = 0
    for h, need, cap, ok, rk4, cause in itertools.product([1e-3, 0.5, 1e300, INF, NAN], needed, (1, 100_000), h_ok,
                                                          (0.0, 1.384e-3, 2.8e-7), causes):
        assert sp.refuse_c(h, need, cap, ok, rk4, cause) == sp.refuse_python(h, need, cap, ok, rk4, cause)
        n += 1
    assert n == 5 * 9 * 2 * 10 * 3 * 3


# ---------------------------------------------------------------------------------------------- without a compiler
_FALLBACK = r"""
import json, math
from flexfmu.native import step_policy as sp
from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
out = {"native": sp.NATIVE, "reason": sp.NATIVE_REASON, "python": sp._split_step is sp.split_step_python,
       "counts": [sp.split_step(h, 1e-4, 100) for h in (1e-4, 3e-4, 1e-2, 2e-2, math.nan)]}
sim = ReframeBodySimulator(ReframeBodyConfig(scheme="consistent", max_internal_steps=50))
out["split"] = [sim.internal_steps(h) for h in (1e-4, 1e-3, 0.005)]
for h in (0.1, 1e300):
    try:
        sim.step(h)
    except Exception as exc:
        out.setdefault("refused", []).append([type(exc).__name__, str(exc)])
print(json.dumps(out))
"""


def test_without_the_c_library_the_python_reference_steps_and_refuses_alike():
    """FLEXFMU_NATIVE_KERNELS=0 (as on a machine without a C compiler): the simulators take the Python reference,
    with the same counts and messages as the C."""
    runs = {}
    for flag in ("1", "0"):
        env = dict(os.environ, FLEXFMU_NATIVE_KERNELS=flag)
        proc = subprocess.run([sys.executable, "-c", _FALLBACK], env=env, capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, proc.stderr
        runs[flag] = json.loads(proc.stdout.strip().splitlines()[-1])
    c, py = runs["1"], runs["0"]
    assert c["native"] and not c["python"] and not py["native"] and py["python"]
    assert py["reason"] == "disabled by FLEXFMU_NATIVE_KERNELS=0"
    assert c["counts"] == py["counts"] == [1, 3, 100, 0, 0]
    assert c["split"] == py["split"] and c["refused"] == py["refused"] and len(c["refused"]) == 2
    assert c["refused"][0][0] == "StepRejected" and "(cap 50)" in c["refused"][0][1]


def test_the_refusal_struct_is_the_headers():
    """_Refusal mirrors ffx_step_refusal: the status, two names, the detail and the message buffers."""
    fields = [name for name, *_ in sp._Refusal._fields_]
    assert fields == ["status", "parameter", "allowed", "detail", "message"]
    assert ctypes.sizeof(sp._Refusal) >= sp.TEXT_SIZE + sp.MESSAGE_SIZE
    struct = re.sub(r"/\*.*?\*/", "", re.search(r"typedef struct \{([^}]*)\} ffx_step_refusal;", HEADER).group(1))
    assert re.findall(r"\b(status|parameter|allowed|detail|message)\b[\[;]", struct) == fields
