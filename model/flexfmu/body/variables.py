"""The parameters of an exported body's FMU (FlexBodyConfig, ClampedBodyConfig), their checks and descriptions.
Which of them a body has, and its inputs and outputs, are its class's (flexfmu.body.model: FreeBody, ClampedBody);
flexfmu.body.simulator's module docstring lists them per kind.
"""
from __future__ import annotations

from dataclasses import dataclass

from flexfmu.core.checks import DEFAULT_MAX_INTERNAL_STEPS, check_max_internal_steps, require_real, require_str
from flexfmu.errors import ParameterError
from flexfmu.reframe.schemes import scheme_class, scheme_names

AXES = ("x", "y", "z")
TOLERANCE_RANGE = (1e-8, 1.0)
#: a free body's initial motion (FlexBodyConfig); a clamped body moves with its base, so they are 0 for it
INITIAL_MOTION = ("v0_x", "v0_y", "v0_z", "omega0_1", "omega0_2", "omega0_3")


@dataclass(frozen=True)
class FlexBodyConfig:
    """The FMU's parameters (variable_info describes each)."""

    damping_ratio: float = -1.0         # -1: the body's own (FlexBody.damping_ratio)
    scheme: str = "exponential"          # free bodies
    tolerance: float = 1e-3              # free bodies, scheme exponential, internal_step = 0
    internal_step: float = 0.0
    max_internal_steps: int = DEFAULT_MAX_INTERNAL_STEPS
    v0_x: float = 0.0
    v0_y: float = 0.0
    v0_z: float = 0.0
    omega0_1: float = 0.0
    omega0_2: float = 0.0
    omega0_3: float = 0.0


@dataclass(frozen=True)
class ClampedBodyConfig:
    """The parameters of a clamped body's FMU: those of FlexBodyConfig that act on it."""

    damping_ratio: float = -1.0         # -1: the body's own (FlexBody.damping_ratio)
    internal_step: float = 0.0
    max_internal_steps: int = DEFAULT_MAX_INTERNAL_STEPS


def axes_info(prefix: str, unit: str, text: str) -> dict[str, tuple[str, str]]:
    """{prefix_x: (unit, "text, x"), ...}: a vector's three variables."""
    return {f"{prefix}_{a}": (unit, f"{text}, {a}") for a in AXES}


def parameter_info(damping_ratio: float) -> dict[str, tuple[str, str]]:
    """name -> (unit, description) of every parameter of FlexBodyConfig, in its order (a body keeps those of its
    config class); ``damping_ratio``: the body's own, what -1 stands for."""
    return {
        "damping_ratio": ("", f"modal damping ratio of every elastic coordinate, 0 <= zeta < 1; -1 = the body's "
                              f"({damping_ratio:g})"),
        "scheme": ("", "exponential (exact in the modes' linear part, no stability limit) | consistent (RK4)"),
        "tolerance": ("", "scheme exponential, internal_step = 0: rotation per internal step <= "
                          "0.5 tolerance^(1/4) rad; 1e-8 <= tolerance < 1"),
        "internal_step": ("s", "longest internal step; 0 = automatic (free: 90% of the RK4 stability limit, or by "
                               "accuracy for scheme exponential; clamped: one exact step per communication step)"),
        "max_internal_steps": ("", "most internal steps per communication step, 1 .. 1e8, counted before stepping: "
                                   "a longer communication step is rejected (fmi2Discard) while a 1e-05 s step "
                                   "would fit"),
        **axes_info("v0", "m/s", "initial velocity of the centre of mass, global"),
        **{f"omega0_{k}": ("rad/s", f"initial angular velocity, body frame, {k}") for k in (1, 2, 3)},
    }


def check_config(c, body) -> float:
    """Types and ranges of the parameters ``c`` (FlexBodyConfig or ClampedBodyConfig) for ``body``; returns the
    damping ratio used.  The body refuses an initial motion it cannot have (FlexBody.check_initial_motion)."""
    zeta = require_real(c.damping_ratio, "damping_ratio", "-1 (the body's) or 0 <= damping_ratio < 1", -1.0, 1.0,
                        hi_open=True)
    if zeta < 0:
        if zeta != -1.0:
            raise ParameterError("damping_ratio", f"got {c.damping_ratio!r}", "-1 (the body's) or 0 <= zeta < 1")
        zeta = body.damping_ratio
    require_real(c.internal_step, "internal_step", "0 (automatic) or a step > 0 s", 0.0)
    check_max_internal_steps(c.max_internal_steps)
    if not isinstance(c, FlexBodyConfig):
        return zeta
    require_str(c.scheme, "scheme", " | ".join(scheme_names("for_bodies")))
    scheme_class(c.scheme, "for_bodies")
    lo, hi = TOLERANCE_RANGE
    require_real(c.tolerance, "tolerance", f"{lo:g} <= tolerance < {hi:g}", lo, hi, hi_open=True)
    for name in INITIAL_MOTION:
        body.check_initial_motion(name, require_real(getattr(c, name), name, "a finite number"))
    return zeta
