"""Range and type checks of the simulators' parameters, the cap on internal steps, and naming the input
or parameter that drove a model out of the floating-point range (flexfmu.errors explains the error kinds).

The simulators check every parameter at construction (type, range), fail a step *before* changing their
state when it would need more internal steps than ``max_internal_steps`` (StepRejected when a smaller
communication step would do, ParameterError naming the cause when not even MIN_COMMUNICATION_STEP would: the rule
and its messages are flexfmu.native.step_policy's, one C implementation), and check the state and outputs for
overflow cheaply on the hot path, naming the culprit only on failure.
"""
from __future__ import annotations

import contextvars
import math
import numbers
import os
import sys

import numpy as np

from flexfmu.errors import NonFiniteError, ParameterError

#: Default cap on the internal steps of one communication step.  Measured need: at most 33 internal steps
#: per communication step in the test suite (ReframeBody, RK4 at 10 ms), 5 RK4 sub-steps (FFRBeam), a few
#: hundred in the studies (benchmarks/reframe_exponential.py: 5 ms in 1e-5 s steps = 500); 100 000 leaves a
#: margin of 200 over the studies and bounds a step at ~1-10 s of CPU (ReframeBody: 7-20 us per internal step
#: with 10 modes).
DEFAULT_MAX_INTERNAL_STEPS = 100_000
#: Allowed max_internal_steps: at least 1; at most 1e8 (minutes of CPU for one communication step).
MAX_INTERNAL_STEPS_RANGE = (1, 100_000_000)
#: The smallest communication step a co-simulation master is expected to take (s).  A step that would need
#: more than max_internal_steps is rejected (fmi2Discard: retry smaller) when a step of at least this size
#: would be within the cap; otherwise the input or parameter that makes it so is refused (fmi2Error).  The C step
#: policy has it as FFX_MIN_COMMUNICATION_STEP (flexfmu/native/csrc/step_policy.h; tests/test_step_policy.py).
MIN_COMMUNICATION_STEP = 1e-5
#: The material constants a model may have, SI: Young's modulus E (Pa) and density rho (kg/m^3).  Real solids
#: span E ~ 1e3 Pa (gels) .. 1.2e12 Pa (diamond) and rho ~ 0.2 (aerogels) .. 2.3e4 kg/m^3 (osmium); the ranges
#: leave decades of room for artificial materials (a quasi-rigid test rod: 1e6 x steel's E) and keep M, K and the
#: frequencies sqrt(E / rho) / size far inside the floating-point range (rho = 1e-300 made the mass matrix
#: underflow: NaN modes; a mm-t-s Nastran deck read as SI has rho = 7.85e-9).
YOUNG_MODULUS_RANGE = (1.0, 1e20)
DENSITY_RANGE = (1e-6, 1e6)


def is_real(value) -> bool:
    """A real number (int or float, numpy ones too), not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def is_int(value) -> bool:
    """An integer (numpy ones too), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def finite_input(value) -> bool:
    """math.isfinite for an input value, False (not an exception) for a string or an int too large for a float;
    cheap on the per-step path (a bool counts as 0 / 1, as float() makes it)."""
    try:
        return math.isfinite(value)
    except (TypeError, OverflowError):
        return False


def finite(value) -> bool:
    """A finite real number (False for bools, strings, huge ints that do not fit a float, ...)."""
    if not is_real(value):
        return False
    try:
        return math.isfinite(value)
    except (OverflowError, TypeError, ValueError):
        return False


def require_real(value, name: str, allowed: str, lo: float = -math.inf, hi: float = math.inf,
                 lo_open: bool = False, hi_open: bool = False) -> float:
    """``value`` as a float, or ParameterError naming ``name``: a finite real in [lo, hi] (ends open if asked)."""
    ok = finite(value)
    if ok:
        v = float(value)
        ok = (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        raise ParameterError(name, f"got {value!r}", allowed)
    return float(value)


def require_int(value, name: str, lo: int, hi: int, allowed: str | None = None) -> int:
    """``value`` as an int, or ParameterError naming ``name``: an integer (not a bool) in lo .. hi."""
    if not (is_int(value) and lo <= value <= hi):
        raise ParameterError(name, f"got {value!r}", allowed or f"an integer {lo} .. {hi}")
    return int(value)


def require_bool(value, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(name, f"got {value!r}", "true | false")
    return bool(value)


def require_str(value, name: str, allowed: str) -> str:
    if not isinstance(value, str):
        raise ParameterError(name, f"got {value!r} (not a string)", allowed)
    return value


def check_max_internal_steps(value) -> int:
    lo, hi = MAX_INTERNAL_STEPS_RANGE
    return require_int(value, "max_internal_steps", lo, hi,
                       f"an integer {lo} .. {hi:.0e} (default {DEFAULT_MAX_INTERNAL_STEPS})")


def shown(value, limit: int = 120) -> str:
    """repr of a value for a message, shortened (a path or a JSON value can be megabytes long)."""
    try:
        text = repr(value)
    except (RecursionError, ValueError):
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else f"{text[:limit // 2]}...{text[-limit // 4:]} ({len(text)} characters)"


def path_exists_as(path) -> str:
    """"file", "directory", "other" (a device, fifo, ...) or "missing" for a path; never raises (a name too long
    or with a NUL byte is "missing")."""
    import os
    import stat
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError, TypeError):
        return "missing"
    return "file" if stat.S_ISREG(mode) else "directory" if stat.S_ISDIR(mode) else "other"


def magnitude(value) -> float:
    """|value| as a float for ranking culprits: inf for non-finite (or unconvertible) values."""
    try:
        v = abs(float(value))
    except (OverflowError, TypeError, ValueError):
        return math.inf
    return v if math.isfinite(v) else math.inf


def culprit(scores: dict) -> str | None:
    """The name with the largest score (NaN and inf rank highest); None if all are 0 or there are none."""
    best, best_score = None, 0.0
    for name, score in scores.items():
        s = magnitude(score) if not (isinstance(score, float) and math.isnan(score)) else math.inf
        if s > best_score:
            best, best_score = name, s
    return best


def parameter_culprit(config, defaults, names) -> str:
    """Among the float parameters ``names`` of a config, the one farthest (in orders of magnitude) from its
    default: the likely cause when a product of parameters overflows."""
    scores = {}
    for name in names:
        value, ref = getattr(config, name), getattr(defaults, name)
        if not (finite(value) and finite(ref)):
            continue
        v, r = abs(float(value)), abs(float(ref))
        if v > 0 and r > 0:
            scores[name] = abs(math.log10(v) - math.log10(r))     # v / r may underflow to 0 or overflow
        elif v != r:
            scores[name] = 1.0
    return culprit(scores) or names[0]


def blame_inputs(inputs: dict, evaluate) -> str | None:
    """The input that alone makes ``evaluate(inputs) -> values`` non-finite (else the largest in magnitude among
    the non-zero ones), for a failure's message; evaluate is called with one input at a time, the others 0."""
    nonzero = {k: v for k, v in inputs.items() if v != 0.0}
    for name in sorted(nonzero, key=lambda k: -magnitude(nonzero[k])):
        alone = dict.fromkeys(inputs, 0.0)
        alone[name] = nonzero[name]
        try:
            with np.errstate(all="ignore"):
                values = np.asarray(evaluate(alone), dtype=float)
            if not np.all(np.isfinite(values)):
                return name
        except (ArithmeticError, ValueError):
            return name
    return culprit(nonzero)


def non_finite(name: str, what: str, value=None, unit: str = "") -> NonFiniteError:
    """NonFiniteError for ``name`` (an input or parameter) that made ``what`` overflow."""
    shown = (f"{float(value):.6g}{' ' + unit if unit else ''}" if finite(value)
             else "its value" if value is None else repr(value))
    return NonFiniteError(name, f"{shown} makes {what} overflow (not finite); allowed: a smaller magnitude, "
                                "within the model's floating-point range")


# ------------------------------------------------------------------------------------------- model size limits
#: The largest models flexfmu sets up unless told otherwise, in degrees of freedom (DOFs): the size whose set-up
#: fits 60 s of wall time and 8 GB of memory by the growth fitted to set-up times measured on the reference machine
#: (benchmarks/model_size_limits.py; docs/export.md, "Model size limits", has the measurements and the fits).
#: FFR beam models (6 DOFs per node): FFRBeam's, ReframeBody's beam:<scene>, and each mesh of flexfmu modal's
#: refinement of a scene.  A scene's model has at least 6 x (segments + 1) DOFs (one element per segment), so a scene
#: with too many segments is refused as soon as its points are counted.  FFRBeam's set-up of the slowest scenes
#: measured (long slender zig-zag rods) grows as ~n^3: 60 s at 67k DOFs with 4-6 other jobs on the 2 cores, 104k
#: with 1-2; memory 8 GB only near 2.5M DOFs.
MAX_BEAM_DOFS = 60_000
#: Solid models of ``flexfmu modal`` (a mesh's 3 DOFs per node, checked before the mesh is assembled; other model
#: files when they are read): reading, assembly, the model checks and the lowest modes, ~n^1.1: a tet4 box of 107k
#: DOFs took 42 s (free) and 33 s (clamped) and 1.5 GB with 1-2 other jobs running (59-83 s with 4-5); 60 s at
#: 146k DOFs by the fit, 8 GB at ~400k.
MAX_SOLID_DOFS = 110_000
#: The environment variable that replaces both limits, a whole number of DOFs, where no option does: the FMUs
#: FFRBeam and ReframeBody and library calls (the CLI's ``--max-dofs`` wins over it).
MAX_DOFS_ENV = "FLEXFMU_MAX_DOFS"
#: What a limit may be set to: 1 DOF .. 1e12 (beyond any memory).
MAX_DOFS_RANGE = (1, 10**12)
#: Models at least this large announce their assembly on stderr while a limit is in force (model_size_limit):
#: ~10 s of scikit-fem assembly and more on the reference machine.
ANNOUNCE_ASSEMBLY_DOFS = 30_000


class DofLimit:
    """A limit on a model's DOFs and how to raise it (``raise_with``: the option or environment variable)."""

    def __init__(self, limit: int, raise_with: str, default: bool):
        self.limit, self.raise_with, self.default = int(limit), raise_with, default

    def check(self, n_dof: int, what: str, parameter: str, smaller: str) -> None:
        """ParameterError naming ``parameter`` when ``n_dof`` exceeds the limit: "``what`` has N DOFs" (``what``: the
        model and how its size comes about), the limit and what to do (``smaller``: how to make the model smaller)."""
        if int(n_dof) <= self.limit:
            return
        basis = ("the size whose set-up fits 60 s and 8 GB on the reference machine, docs/export.md"
                 if self.default else "the limit set")
        raise ParameterError(parameter, f"{what} has {int(n_dof):,} DOFs, more than the {self.limit:,} DOFs allowed "
                             f"({basis})", f"at most {self.limit:,} DOFs: {smaller}; or raise the limit with "
                             f"{self.raise_with}")


def dof_limit(default: int, override=None, option: str | None = None) -> DofLimit:
    """The DOF limit in force: ``override`` (the value of the option named ``option``, e.g. the CLI's --max-dofs) if
    not None, else the environment variable MAX_DOFS_ENV if set, else ``default``; ParameterError naming the option
    or the variable for a value that is not a whole number in MAX_DOFS_RANGE."""
    lo, hi = MAX_DOFS_RANGE
    allowed = f"a whole number of DOFs, {lo} .. {hi:.0e}"
    variable = f"the environment variable {MAX_DOFS_ENV}=N"
    raise_with = f"{option} N or {variable}" if option else variable
    if override is not None:
        return DofLimit(require_int(override, option or "max_dofs", lo, hi, allowed), raise_with, False)
    text = os.environ.get(MAX_DOFS_ENV)
    if text is None or not text.strip():
        return DofLimit(default, raise_with, True)
    try:
        value = int(text.strip().replace("_", ""))
    except ValueError:
        raise ParameterError(MAX_DOFS_ENV, f"{shown(text)} is not a whole number", allowed) from None
    return DofLimit(require_int(value, MAX_DOFS_ENV, lo, hi, allowed), raise_with, False)


#: (DofLimit, parameter, smaller, label, stream) of the model_size_limit in force, or None
_ASSEMBLY_LIMIT: contextvars.ContextVar = contextvars.ContextVar("flexfmu_assembly_limit", default=None)


class model_size_limit:
    """Context in which the importers refuse a mesh above ``limit`` (a DofLimit) before assembling it (and announce
    the assembly of a large one on ``stream``, prefixed with ``label``).  Outside it they assemble any size: the
    library's default; ``flexfmu modal`` sets one."""

    def __init__(self, limit: DofLimit, parameter: str, smaller: str, label: str = "flexfmu", stream=None):
        self.value = (limit, parameter, smaller, label, stream)

    def __enter__(self):
        self._token = _ASSEMBLY_LIMIT.set(self.value)
        return self

    def __exit__(self, *exc):
        _ASSEMBLY_LIMIT.reset(self._token)


def check_assembly_size(n_dof: int, what: str) -> None:
    """Called by the importers before assembling a model of ``n_dof`` DOFs (``what``: the file and its nodes):
    ParameterError above the limit of the model_size_limit in force, nothing outside one."""
    active = _ASSEMBLY_LIMIT.get()
    if active is None:
        return
    limit, parameter, smaller, label, stream = active
    limit.check(n_dof, what, parameter, smaller)
    if n_dof >= ANNOUNCE_ASSEMBLY_DOFS:
        print(f"{label}: assembling {what} ({int(n_dof):,} DOFs) ...", file=stream or sys.stderr, flush=True)
