"""ReframeBody's parameters and variables: the configuration (the FMU's parameters), its checks, the names of
the inputs and outputs and what every variable means (VARIABLE_INFO); flexfmu.reframe.simulator steps it.

The checks come in two parts: :func:`check_config`, types and ranges that need no model (before the cached set-up,
which hashes the values), and :func:`check_points`, the load and output points on the model's body.  A point is
on the body when it lies within max(patch radius, local node spacing) of its nearest node, the patch being that
node and the nodes of the elements around it (a beam node alone), the rule exported bodies' interfaces follow
(flexfmu.core.body_points): a point on or inside the meshed material, not one away from it.  The load acts on
the nearest node and the outputs are that node's, so a point off the body would silently move the load there
(load_point_x = 10 on the 1 m plate: the load at x = 0.5 m, turning the body the other way).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.core.body_points import bounding_box_text, default_patch, patch_reach
from flexfmu.core.checks import (DEFAULT_MAX_INTERNAL_STEPS, MAX_BEAM_DOFS, check_max_internal_steps, dof_limit, finite,
                                 is_int, path_exists_as, require_bool, require_real, require_str, shown)
from flexfmu.errors import ParameterError, require
from flexfmu.ffr.scene import beam_model_dofs, builtin_scene_names, load_scene
from flexfmu.reframe.models import BEAM_PREFIX, DEFAULT_ELEMENTS_PER_SEGMENT
from flexfmu.reframe.schemes import SCHEMES

AXES = ("x", "y", "z")
INPUT_NAMES = tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES)
OUTPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"vel_{a}" for a in AXES)
                + ("q_w", "q_x", "q_y", "q_z") + tuple(f"omega_{i}" for i in (1, 2, 3))
                + tuple(f"alpha_{i}" for i in (1, 2, 3)) + tuple(f"com_pos_{a}" for a in AXES)
                + tuple(f"com_vel_{a}" for a in AXES) + tuple(f"out_pos_{a}" for a in AXES)
                + tuple(f"out_vel_{a}" for a in AXES) + tuple(f"out_acc_{a}" for a in AXES)
                + tuple(f"out_acc_rigid_{a}" for a in AXES) + ("max_elastic_displacement",))
#: outputs whose cost grows with the mesh (a search over all nodes): output_vector(include_deferred=False)
#: leaves them out and deferred_output_vector() gives them, so the FMU computes them only when they are read
DEFERRED_OUTPUTS = ("max_elastic_displacement",)
#: tolerance: below 1e-8 the automatic model's static solve (shift 1e-8 omega_1^2) is no longer small against it
TOLERANCE_RANGE = (1e-8, 1.0)


@dataclass(frozen=True)
class ReframeBodyConfig:
    """Parameters, named and defaulted as in the FMU (defaults: the paper's plate and load case)."""

    model: str = "paper_plate"
    scheme: str = "exponential"     # wins on accuracy per CPU second (benchmarks/reframe_exponential.py)
    n_flexible_modes: int = 10
    f_max: float = 100.0            # Hz, for n_flexible_modes = -1
    tolerance: float = 1e-3         # static-correction and exponential-step tolerance
    damping_ratio: float = 0.05
    internal_step: float = 0.0
    load_point_x: float = -0.5      # the paper's load point, midway between P5 and P8
    load_point_y: float = 0.0
    load_point_z: float = 0.01
    output_point_x: float = -0.5    # P1
    output_point_y: float = -0.025
    output_point_z: float = 0.0
    force_follows_body: bool = False
    v0_x: float = 0.0
    v0_y: float = 0.0
    v0_z: float = 0.0
    omega0_1: float = 0.0
    omega0_2: float = 0.0
    omega0_3: float = 0.0
    max_internal_steps: int = DEFAULT_MAX_INTERNAL_STEPS


_POINTS = ("load_point_x", "load_point_y", "load_point_z", "output_point_x", "output_point_y", "output_point_z")
_INITIAL = ("v0_x", "v0_y", "v0_z", "omega0_1", "omega0_2", "omega0_3")


def check_config(c: ReframeBodyConfig) -> None:
    """Types and ranges that need no model (before the cached set-up, which hashes them)."""
    require_str(c.model, "model", "paper_plate | beam:<scene> | path to a .npz")
    require(isinstance(c.scheme, str) and c.scheme in SCHEMES, "scheme", f"got {c.scheme!r}", " | ".join(SCHEMES))
    require(is_int(c.n_flexible_modes) and c.n_flexible_modes >= -1, "n_flexible_modes", f"got {c.n_flexible_modes!r}",
            "-1 (choose from f_max, tolerance) or 0 .. number of flexible modes")
    for name in _POINTS + _INITIAL:
        require(finite(getattr(c, name)), name, f"got {getattr(c, name)!r}", "a finite number")
    require(finite(c.f_max) and c.f_max > 0.0, "f_max", f"got {c.f_max!r}", "> 0 Hz")
    lo, hi = TOLERANCE_RANGE
    require(finite(c.tolerance) and lo <= c.tolerance < hi, "tolerance", f"got {c.tolerance!r}",
            f"{lo:g} <= tolerance < {hi:g} (relative)")
    require_real(c.damping_ratio, "damping_ratio", "0 <= damping_ratio < 1", 0.0, 1.0, hi_open=True)
    require(finite(c.internal_step) and c.internal_step >= 0.0, "internal_step", f"got {c.internal_step!r}",
            "0 (automatic) or a step > 0 s")
    require_bool(c.force_follows_body, "force_follows_body")
    check_max_internal_steps(c.max_internal_steps)

def check_model_size(c: ReframeBodyConfig) -> None:
    """A beam:<scene> model within the DOF limit (flexfmu.core.checks.MAX_BEAM_DOFS, or the environment's
    FLEXFMU_MAX_DOFS) before it is built: ParameterError naming ``model``, its size, the limit and how to raise it,
    as soon as the scene's segments are counted.  Other models (and a scene that does not exist: load_model names
    it) pass."""
    spec = c.model.strip()
    if not spec.startswith(BEAM_PREFIX):
        return
    name = spec[len(BEAM_PREFIX):].strip()
    if name not in builtin_scene_names() and path_exists_as(name) != "file":
        return
    limit = dof_limit(MAX_BEAM_DOFS)
    n_el = DEFAULT_ELEMENTS_PER_SEGMENT

    def check(n_segments: int, scene=None) -> None:
        dofs = 6 * (n_segments * n_el + 1) if scene is None else beam_model_dofs(scene, n_el)
        limit.check(dofs, f"the free beam model of scene {shown(name)} ({n_segments} segments at {n_el} elements per "
                    "segment)", "model", "a scene with fewer segments")

    scene = load_scene(name, parameter="model", check_size=check)
    check(len(scene.points) - 1, scene)


def check_points(c: ReframeBodyConfig, structure) -> tuple[int, int]:
    """The nodes of the load and output points (the nearest ones), or ParameterError naming the coordinate of a
    point off the body (the module docstring's rule) that is farthest from its nearest node, and the allowed."""
    nodes = np.asarray(structure.nodes, dtype=float)
    found = []
    for what, names in (("load point", _POINTS[:3]), ("output point", _POINTS[3:])):
        point = np.array([float(getattr(c, n)) for n in names])
        reach = patch_reach(nodes, default_patch(structure, point), point)
        if not reach.on_body:
            near = nodes[reach.nearest]
            name = names[int(np.argmax(np.abs(point - near)))]
            raise ParameterError(name, f"the {what} ({', '.join(f'{v:g}' for v in point)}) m is {reach.distance:.4g} m "
                                 f"from the body's nearest node ({', '.join(f'{v:.6g}' for v in near)}) m: outside the "
                                 f"body ({getattr(structure, 'name', '') or c.model})",
                                 f"a point of the body, within max(patch radius, local node spacing) = {reach.reach:.4g} "
                                 f"m of its nearest node (as exported bodies' interfaces); the body spans "
                                 f"{bounding_box_text(nodes)}")
        found.append(reach.nearest)
    return found[0], found[1]


def _info(names, unit, text):
    return {n: (unit, f"{text}, {n.rsplit('_', 1)[-1]}") for n in names}


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "model": ("", "paper_plate | beam:<scene> (free-free bent rod) | path to a .npz structure file"),
    "scheme": ("", "exponential (default: exact in the modes' linear part, no RK4 stability limit) | consistent (RK4) | "
                   "paper (the printed scheme, first order)"),
    "n_flexible_modes": ("", "retained flexible modes; 0 = a rigid body; -1 = choose: the modes up to f_max and more "
                             "until the estimated dynamic truncation error of the load and output points is within "
                             "tolerance, plus a static correction of the load point if needed"),
    "f_max": ("Hz", "n_flexible_modes = -1: highest input frequency of interest (every flexible mode up to it is kept)"),
    "tolerance": ("", "n_flexible_modes = -1: allowed relative truncation error of the load and output points' "
                      "deflection (dynamic, and static before residual-flexibility vectors are added); scheme "
                      "exponential with internal_step = 0: rotation per internal step <= 0.5 tolerance^(1/4) rad; "
                      "1e-8 <= tolerance < 1"),
    "damping_ratio": ("", "modal damping ratio of every flexible mode, 0 <= zeta < 1"),
    "internal_step": ("s", "longest internal step; 0 = automatic (RK4 schemes: 90% of the stability limit, "
                           "sub-stepping a longer communication step; exponential: by accuracy); a given step is at "
                           "most the RK4 stability limit and at least 1e-05 s / max_internal_steps"),
    **_info(("load_point_x", "load_point_y", "load_point_z"), "m", "load point, undeformed body coordinates, on the "
            "body (within max(patch radius, local node spacing) of its nearest node; defaults: the plate's)"),
    **_info(("output_point_x", "output_point_y", "output_point_z"), "m", "output point, undeformed body "
            "coordinates, on the body (as the load point)"),
    "force_follows_body": ("", "false: F, M in the global frame; true: in the body frame"),
    **_info(("v0_x", "v0_y", "v0_z"), "m/s", "initial velocity of the centre of mass, global"),
    **_info(("omega0_1", "omega0_2", "omega0_3"), "rad/s", "initial angular velocity, body frame; |omega0| <= "
            "max_internal_steps x 0.5 tolerance^(1/4) / 1e-05 s (8.9e8 rad/s by default)"),
    "max_internal_steps": ("", "most internal steps per communication step, 1 .. 1e8 (default 100000), counted "
                               "before stepping: a longer communication step is rejected (fmi2Discard: take a smaller "
                               "one) while a 1e-05 s step would fit, else the input or parameter that needs so many "
                               "is refused (fmi2Error)"),
    **_info(("F_x", "F_y", "F_z"), "N", "force at the load point (global unless force_follows_body)"),
    **_info(("M_x", "M_y", "M_z"), "N.m", "moment at the load point (6-DOF models only)"),
    **_info(OUTPUT_NAMES[0:3], "m", "frame origin position, global"),
    **_info(OUTPUT_NAMES[3:6], "m/s", "frame origin velocity (rigid with the dummy body), global"),
    **_info(OUTPUT_NAMES[6:10], "", "orientation quaternion body -> global, scalar first"),
    **_info(OUTPUT_NAMES[10:13], "rad/s", "angular velocity, body frame"),
    **_info(OUTPUT_NAMES[13:16], "rad/s2", "angular acceleration, body frame"),
    **_info(OUTPUT_NAMES[16:19], "m", "centre of mass of the dummy rigid body, global (the deformed body's "
                                      "differs by second-order elastic terms on beam models)"),
    **_info(OUTPUT_NAMES[19:22], "m/s", "centre of mass velocity, global"),
    **_info(OUTPUT_NAMES[22:25], "m", "output point position, global, full motion"),
    **_info(OUTPUT_NAMES[25:28], "m/s", "output point velocity, global, full motion"),
    **_info(OUTPUT_NAMES[28:31], "m/s2", "output point acceleration, global, full motion"),
    **_info(OUTPUT_NAMES[31:34], "m/s2", "output point acceleration, embedded rigid part, global"),
    "max_elastic_displacement": ("m", "largest elastic nodal displacement"),
}
