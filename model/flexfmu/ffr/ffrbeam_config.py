"""FFRBeam's variables (flexfmu.ffr.simulator): the input and output names, the parameters (FFRBeamConfig) and
their checks, and the variable table the FMU build writes into modelDescription.xml."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.core.checks import DEFAULT_MAX_INTERNAL_STEPS, check_max_internal_steps, finite, is_int, require_str
from flexfmu.errors import require
from flexfmu.ffr.assembly import BOUNDARY_PRESETS
from flexfmu.sizing.mesh import MAX_ELEMENTS_PER_SEGMENT, check_band

AXES = ("x", "y", "z")
FORCE_INPUTS = tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES)
BASE_INPUTS = (tuple(f"base_a_{a}" for a in AXES) + tuple(f"base_w_{a}" for a in AXES)
               + tuple(f"base_dw_{a}" for a in AXES))
INPUT_NAMES = FORCE_INPUTS + BASE_INPUTS
N_REPORTED_FREQUENCIES = 6
#: strain gauges (flexfmu.ffr.gauges): parameters gauge_K_s, K = 1 .. GAUGE_SLOTS; per gauge the six section forces
#: (force then moment, section frame x y z) and the section's largest axial and von Mises stresses
GAUGE_SLOTS = 3
SECTION_FORCES = ("N", "Vy", "Vz", "T", "My", "Mz")
GAUGE_QUANTITIES = SECTION_FORCES + ("sigma_max", "von_mises")


def gauge_output(k: int, quantity: str) -> str:
    """The output name of gauge k's ``quantity`` (one of GAUGE_QUANTITIES)."""
    return f"gauge_{k}_{quantity}"


GAUGE_OUTPUTS = tuple(gauge_output(k, q) for k in range(1, GAUGE_SLOTS + 1) for q in GAUGE_QUANTITIES)
OUTPUT_NAMES = (tuple(f"sensor_{k}_{a}" for k in "uva" for a in AXES) + tuple(f"tip_u_{a}" for a in AXES)
                + tuple(f"reaction_F_{a}" for a in AXES) + tuple(f"reaction_M_{a}" for a in AXES)
                + tuple(f"f_{i}" for i in range(1, N_REPORTED_FREQUENCIES + 1)) + ("elastic_energy",)
                + GAUGE_OUTPUTS)
ENERGY_OUTPUT = OUTPUT_NAMES.index("elastic_energy")
#: where gauge k's six section forces are in OUTPUT_NAMES (the linear rows; sigma_max and von_mises follow them)
GAUGE_ROWS = tuple(ENERGY_OUTPUT + 1 + len(GAUGE_QUANTITIES) * (k - 1) for k in range(1, GAUGE_SLOTS + 1))
INTEGRATORS = ("exact", "rk4")
#: RK4 sub-steps stay at or below this fraction of the stability limit (margin for the damping terms).
RK4_STEP_FRACTION = 0.9


@dataclass(frozen=True)
class FFRBeamConfig:
    """Parameters, named and defaulted as in the FMU.  load_s = -1 means the last point.

    elements_per_segment = 0 and n_modes = -1 mean "choose" (from f_max and tolerance);
    static_correction: -1 = on when n_modes = -1 (the modes are chosen), 0 = off, 1 = on."""

    scene: str = "spatial_double_L"
    boundary: str = "XFF"
    elements_per_segment: int = 8
    n_modes: int = 6
    damping_ratio: float = 0.01
    load_s: float = -1.0
    sensor_s: float = 0.04
    f_max: float = 300.0
    tolerance: float = 1e-3
    static_correction: int = -1
    integrator: str = "exact"
    geometric_stiffening: bool = False
    max_internal_steps: int = DEFAULT_MAX_INTERNAL_STEPS
    gauge_1_s: float = -1.0
    gauge_2_s: float = -1.0
    gauge_3_s: float = -1.0

    @property
    def gauge_arc_lengths(self) -> tuple:
        """gauge_K_s of K = 1 .. GAUGE_SLOTS (m, -1 = no gauge), in slot order."""
        return tuple(getattr(self, f"gauge_{k}_s") for k in range(1, GAUGE_SLOTS + 1))


_is_int = is_int


def _check_config(cfg: FFRBeamConfig) -> None:
    require_str(cfg.scene, "scene", "a built-in scene name or a path to a scene JSON")
    require(isinstance(cfg.boundary, str) and cfg.boundary in BOUNDARY_PRESETS and cfg.boundary != "free", "boundary",
            f"got {cfg.boundary!r}", "XFF | XFX | FXF | FXF_mid | scene")
    require(_is_int(cfg.elements_per_segment) and 0 <= cfg.elements_per_segment <= MAX_ELEMENTS_PER_SEGMENT,
            "elements_per_segment", f"got {cfg.elements_per_segment!r}",
            f"0 (choose from f_max and tolerance) or 1 .. {MAX_ELEMENTS_PER_SEGMENT}")
    require(_is_int(cfg.n_modes) and (cfg.n_modes == -1 or cfg.n_modes >= 1), "n_modes",
            f"got {cfg.n_modes!r}", "-1 (choose: every mode below f_max) or 1 .. number of free DOFs")
    require(finite(cfg.damping_ratio) and 0.0 <= cfg.damping_ratio < 1.0, "damping_ratio",
            f"got {cfg.damping_ratio!r}", "0 <= damping_ratio < 1")
    for name in ("load_s", "sensor_s"):           # the range (the rod's length) is checked with the scene
        require(finite(getattr(cfg, name)), name, f"got {getattr(cfg, name)!r}",
                "an arc length in m (load_s: or -1 = the last point)")
    for k, s in enumerate(cfg.gauge_arc_lengths, start=1):   # the range (the rod's length) is checked with the scene
        require(finite(s) and (s == -1.0 or s >= 0.0), f"gauge_{k}_s", f"got {s!r}",
                "-1 (no gauge) or an arc length 0 <= s <= the rod's length in m")
    check_band(cfg.f_max, cfg.tolerance)
    require(isinstance(cfg.static_correction, (int, np.integer)) and cfg.static_correction in (-1, 0, 1),
            "static_correction", f"got {cfg.static_correction!r}", "-1 (on when n_modes = -1), 0 (off), 1 (on)")
    require(isinstance(cfg.integrator, str) and cfg.integrator in INTEGRATORS, "integrator", f"got {cfg.integrator!r}",
            " | ".join(INTEGRATORS))
    require(isinstance(cfg.geometric_stiffening, (bool, np.bool_)), "geometric_stiffening",
            f"got {cfg.geometric_stiffening!r}", "true | false")
    check_max_internal_steps(cfg.max_internal_steps)


def _axis_info(prefix: str, unit: str, text: str) -> dict:
    return {f"{prefix}_{a}": (unit, f"{text}, body {a}") for a in AXES}


_SECTION_FRAME = ("section frame of the element after gauge_{k}_s (at the last point: the last element): x along "
                  "the rod towards larger arc length, y and z the element's section axes (docs/scene_format.md); "
                  "what the part beyond the cut exerts on the part before it")


def _gauge_info(k: int) -> dict:
    frame = _SECTION_FRAME.format(k=k)
    return {gauge_output(k, "N"): ("N", f"gauge {k}: axial force (tension > 0), {frame}"),
            gauge_output(k, "Vy"): ("N", f"gauge {k}: shear force along y, {frame}"),
            gauge_output(k, "Vz"): ("N", f"gauge {k}: shear force along z, {frame}"),
            gauge_output(k, "T"): ("N.m", f"gauge {k}: torque about x, about the centroid, {frame}"),
            gauge_output(k, "My"): ("N.m", f"gauge {k}: bending moment about y (sigma_xx = N/A + My z/Iy - Mz y/Iz), "
                                           f"{frame}"),
            gauge_output(k, "Mz"): ("N.m", f"gauge {k}: bending moment about z, {frame}"),
            gauge_output(k, "sigma_max"): ("Pa", f"gauge {k}: largest |axial stress| on the section from N, My, Mz "
                                                 "(circle, tube, rectangle sections)"),
            gauge_output(k, "von_mises"): ("Pa", f"gauge {k}: largest von Mises stress on the section from axial "
                                                 "force, bending and torsion (transverse shear left out; rectangle: "
                                                 "an upper bound)")}


#: name -> (unit, description) of every FMU variable; the FMU build writes these into modelDescription.xml.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "scene": ("", "built-in scene name (spatial_double_L, inclined_beam, c_section) or path to a scene JSON"),
    "boundary": ("", "clamps: XFF | XFX | FXF (first corner) | FXF_mid (mid segment 2) | scene"),
    "elements_per_segment": ("", "beam elements per polyline segment, 1 .. 512; 0 = choose: the fewest whose "
                             "frequencies below f_max are within tolerance of the converged ones"),
    "n_modes": ("", "retained modes, 1 .. number of free DOFs; -1 = choose: every mode below f_max and more above "
                "it until the estimated dynamic truncation error of tip_u and sensor_u is within tolerance"),
    "damping_ratio": ("", "modal damping ratio of every retained mode, 0 <= zeta < 1"),
    "load_s": ("m", "arc length of the load point from the first point; -1 = the last point"),
    "sensor_s": ("m", "arc length of the sensor (accelerometer) point"),
    "f_max": ("Hz", "highest frequency of interest, for n_modes = -1 and elements_per_segment = 0 (> 0)"),
    "tolerance": ("", "relative error allowed, 1e-6 .. 0.1: of the retained frequencies when elements_per_segment = 0, "
                  "of the displacement outputs' modal truncation when n_modes = -1"),
    "static_correction": ("", "residual flexibility of the omitted modes in sensor_u, tip_u and elastic_energy "
                          "(exact quasi-static deflection): -1 = on when n_modes = -1, 0 = off, 1 = on"),
    "integrator": ("", "exact (zero-order-hold matrix exponential, any step) | rk4 (classical RK4, sub-stepped "
                   "automatically below its stability limit 2.8 / omega_max)"),
    "geometric_stiffening": ("", "add the geometric (centrifugal) stiffness of the held base motion's "
                             "inertial load"),
    "max_internal_steps": ("", "integrator rk4: most sub-steps per communication step, 1 .. 1e8 (default 100000), "
                               "counted before stepping: a longer communication step is rejected (fmi2Discard: take a "
                               "smaller one) while a 1e-05 s step would fit, else the input or parameter that needs so "
                               "many is refused (fmi2Error)"),
    **_axis_info("F", "N", "force at load_s"),
    **_axis_info("M", "N.m", "moment at load_s"),
    **_axis_info("base_a", "m/s2", "acceleration of the floating-frame origin (base)"),
    **_axis_info("base_w", "rad/s", "angular velocity of the floating frame (base)"),
    **_axis_info("base_dw", "rad/s2", "angular acceleration of the floating frame (base)"),
    **_axis_info("sensor_u", "m", "elastic displacement of the sensor point"),
    **_axis_info("sensor_v", "m/s", "elastic velocity of the sensor point relative to the frame"),
    **_axis_info("sensor_a", "m/s2", "total acceleration of the sensor point incl. base motion (accelerometer)"),
    **_axis_info("tip_u", "m", "elastic displacement of the last point"),
    **_axis_info("reaction_F", "N", "force the structure exerts on its clamps (sum)"),
    **_axis_info("reaction_M", "N.m", "moment the structure exerts on its clamps, about the frame origin"),
    **{f"f_{i}": ("Hz", f"natural frequency {i} of the clamped structure (0 = not available)")
       for i in range(1, N_REPORTED_FREQUENCIES + 1)},
    "elastic_energy": ("J", "strain energy of the retained modes (plus the static correction's when on)"),
    **{f"gauge_{k}_s": ("m", f"arc length of strain gauge {k} from the first point (a mesh node; at a corner the "
                             "section after it); -1 = no gauge (its outputs 0)") for k in range(1, GAUGE_SLOTS + 1)},
    **{name: info for k in range(1, GAUGE_SLOTS + 1) for name, info in _gauge_info(k).items()},
}
