"""What an FFRBeam configuration builds (flexfmu.ffr.simulator): the mesh, the modes and the dynamics, chosen from
f_max and tolerance when asked (flexfmu.sizing), cached per configuration, since instances of one FMU share them."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from flexfmu.core.blas import limited_for
from flexfmu.core.checks import MAX_BEAM_DOFS, dof_limit, shown
from flexfmu.core.stress import SectionFibres
from flexfmu.errors import require
from flexfmu.ffr.assembly import boundary_clamps, build_beam_model
from flexfmu.ffr.dynamics import FFRBeamDynamics
from flexfmu.ffr.ffrbeam_config import N_REPORTED_FREQUENCIES, FFRBeamConfig, _check_config
from flexfmu.ffr.mesh_choice import choose_elements_per_segment
from flexfmu.ffr.scene import beam_model_dofs, check_arc_length, load_scene
from flexfmu.linalg.modal import solve_modes
from flexfmu.sizing.beam import (ModelChoice, StaticCorrection, TruncationChoice, ffr_load_patterns,
                                 ffr_static_correction, ffr_truncation_errors)
from flexfmu.sizing.common import SAFETY_FACTOR

#: n_modes = -1: more modes are computed until the bound on the uncomputed ones is below this part of tolerance.
TAIL_FRACTION = 0.1


@dataclass(frozen=True)
class _Built:
    """What a configuration builds: the dynamics, the reported frequencies f_1..f_6 (Hz), the model
    choice (for the log) and the static correction (None when off or nothing is omitted)."""

    dynamics: FFRBeamDynamics
    frequencies_hz: np.ndarray
    choice: ModelChoice
    correction: StaticCorrection | None
    derived_outputs: tuple = ()       # the gauges' stresses (flexfmu.core.stress.DerivedStress)


def _lowest_modes(model, n_wanted: int, f_max: float | None = None):
    """The lowest max(n_wanted, 1) modes, more while the highest solved is below f_max (Hz)."""
    k = min(max(n_wanted, 1), model.n_free)
    modes = solve_modes(model.K_free, model.M_free, k)
    while f_max is not None and k < model.n_free and modes.frequencies_hz[-1] < f_max:
        k = min(2 * k, model.n_free)
        modes = solve_modes(model.K_free, model.M_free, k)
    return modes


def _truncated_modes(model, cfg: FFRBeamConfig, load_s: float, sensor_s: float, mesh_choice):
    """(n_modes, modes computed, TruncationChoice, TruncationEstimate) for n_modes = -1 on ``model``: at least the modes below
    f_max (their converged frequencies when the mesh was chosen), then the fewest whose estimated dynamic
    truncation error of tip_u and sensor_u is within tolerance (Eq. (E) of flexfmu.sizing.model_size), computed
    from the lowest modes in doubling batches (the rest bounded by their static residual)."""
    first = solve_modes(model.K_free, model.M_free, 1)
    with limited_for(model.n_dof):     # a small model's dense set-up: one BLAS thread (flexfmu.core.blas)
        probe = FFRBeamDynamics(model, first, cfg.damping_ratio, load_s, sensor_s)   # load patterns and points
    patterns = ffr_load_patterns(probe)
    points = {"tip_u": probe.tip, "sensor_u": probe.sensor}
    k = min(model.n_free, 16)
    # k doubles up to n_free: at most log2(n_free) + 2 rounds; with every mode computed the basis is complete
    # and keeping all of them has no truncation error (errors[n_free] = 0), so the last round always decides.
    for _ in range(2 + max(1, model.n_free).bit_length()):
        modes = solve_modes(model.K_free, model.M_free, k)
        below = (mesh_choice.n_below_f_max if mesh_choice is not None
                 else int(np.count_nonzero(modes.frequencies_hz < cfg.f_max)))
        if below < k or k == model.n_free:
            estimate = ffr_truncation_errors(model, modes, patterns, points, cfg.f_max, cfg.damping_ratio)
            n_modes = estimate.smallest(cfg.tolerance / SAFETY_FACTOR, at_least=max(1, min(below, k)))
            # decided once the modes beyond those computed (bounded together, errors[k]) are well within it
            settled = estimate.errors[-1] <= TAIL_FRACTION * cfg.tolerance
            if k == model.n_free and n_modes is None:
                n_modes = k
            if n_modes is not None and ((n_modes < k and settled) or k == model.n_free):
                return n_modes, modes, TruncationChoice(
                    n_below_f_max=min(below, k), error=float(estimate.errors[n_modes]), worst=estimate.worst[n_modes],
                    static_residual=float(estimate.static_residual[n_modes]),
                    all_modes=n_modes == model.n_free), estimate
        k = min(2 * k, model.n_free)
    raise AssertionError("unreachable: the last round computes every mode")


def _check_scene_size(limit, cfg: FFRBeamConfig, n_segments: int, scene=None, extra=()) -> None:
    """The scene's model within ``limit`` (a flexfmu.core.checks.DofLimit), before it is built: from the count of
    segments alone while the scene is read (``scene`` None), then with its extra nodes; elements_per_segment = 0 is
    counted at one element per segment, the fewest the automatic mesh chooses (each of its meshes is checked)."""
    n_el = int(cfg.elements_per_segment) or 1
    dofs = 6 * (n_segments * n_el + 1) if scene is None else beam_model_dofs(scene, n_el, extra)
    limit.check(dofs, f"the beam model of scene {shown(cfg.scene)} ({n_segments} segments at {n_el} element(s) per "
                "segment" + (", the fewest the automatic mesh chooses" if cfg.elements_per_segment == 0 else "") + ")",
                "scene",
                "a scene with fewer segments" + (", or fewer elements_per_segment" if n_el > 1 else ""))


@lru_cache(maxsize=8)
def _build(cfg: FFRBeamConfig) -> _Built:
    """Model, modes and dynamics for a configuration; cached, since instances of one FMU share them.  The model's
    size is checked before anything is built (MAX_BEAM_DOFS, or the environment's FLEXFMU_MAX_DOFS)."""
    _check_config(cfg)
    limit = dof_limit(MAX_BEAM_DOFS)
    scene = load_scene(cfg.scene, check_size=lambda n_segments: _check_scene_size(limit, cfg, n_segments))
    load_s = scene.total_length if cfg.load_s == -1.0 else check_arc_length(scene, cfg.load_s, "load_s")
    sensor_s = check_arc_length(scene, cfg.sensor_s, "sensor_s")
    gauge_s = tuple(None if s == -1.0 else _gauge_arc_length(scene, s, f"gauge_{k}_s")
                    for k, s in enumerate(cfg.gauge_arc_lengths, start=1))
    if any(s is not None for s in gauge_s):             # before anything is built: a generic section is refused
        SectionFibres.of(scene.section.shape, scene.section.A, scene.section.Iy, scene.section.Iz, scene.section.J,
                         name=f"gauge_{next(k for k, s in enumerate(gauge_s, start=1) if s is not None)}_s")
    require(len(boundary_clamps(scene, cfg.boundary)) > 0, "boundary",
            f"{cfg.boundary!r} clamps nothing in scene {scene.name}", "a boundary with at least one clamp")
    mesh_choice, truncation = None, None
    n_el = int(cfg.elements_per_segment)
    extra = (load_s, sensor_s) + tuple(s for s in gauge_s if s is not None)      # gauges sit on nodes
    _check_scene_size(limit, cfg, len(scene.points) - 1, scene, extra + boundary_clamps(scene, cfg.boundary))
    if n_el == 0:
        mesh_choice = choose_elements_per_segment(scene, cfg.boundary, cfg.f_max, cfg.tolerance,
                                                  extra_arc_lengths=extra, min_modes=max(cfg.n_modes, 1),
                                                  min_modes_parameter="n_modes", dof_limit=limit)
        n_el = mesh_choice.elements_per_segment
    model = build_beam_model(scene, cfg.boundary, n_el, extra_arc_lengths=extra)
    if cfg.n_modes == -1:
        # Modes below f_max, then more until the dynamic truncation error (flexfmu.sizing.model_size Eq. (E)) is
        # within tolerance; with the mesh chosen, the mesh is then re-chosen so that every *retained*
        # frequency is resolved to the tolerance (docs/model_size.md: looser allowances for the modes above
        # f_max failed the response test), and the modes again on that mesh (settles in one or two rounds:
        # the mesh only grows).
        for _ in range(4):
            n_modes, modes, truncation, _ = _truncated_modes(model, cfg, load_s, sensor_s, mesh_choice)
            if mesh_choice is None:
                break
            finer = choose_elements_per_segment(scene, cfg.boundary, cfg.f_max, cfg.tolerance,
                                                extra_arc_lengths=extra, min_modes=n_modes,
                                                min_modes_parameter="f_max",     # the retained modes, from f_max
                                                dof_limit=limit)
            if finer.elements_per_segment <= n_el:
                if finer.elements_per_segment == n_el:
                    mesh_choice = finer
                break
            mesh_choice, n_el = finer, finer.elements_per_segment
            model = build_beam_model(scene, cfg.boundary, n_el, extra_arc_lengths=extra)
        modes = _lowest_modes(model, max(n_modes + 1, N_REPORTED_FREQUENCIES)) if modes.shapes.shape[1] < min(
            max(n_modes + 1, N_REPORTED_FREQUENCIES), model.n_free) else modes
    else:
        n_modes = int(cfg.n_modes)
        require(n_modes <= model.n_free, "n_modes", f"got {n_modes}", f"1 .. {model.n_free} (free DOFs)")
        # one more than retained only when the choice is logged (the first omitted mode is reported)
        logged = mesh_choice is not None or cfg.static_correction == 1
        modes = _lowest_modes(model, max(n_modes + int(logged), N_REPORTED_FREQUENCIES))
    reported = np.zeros(N_REPORTED_FREQUENCIES)   # 0 Hz = not available (fewer free DOFs than 6)
    shown = modes.frequencies_hz[:N_REPORTED_FREQUENCIES]
    reported[:shown.size] = shown
    retained = type(modes)(modes.frequencies_hz[:n_modes], modes.shapes[:, :n_modes], modes.method)
    corrected = cfg.static_correction == 1 or (cfg.static_correction == -1 and cfg.n_modes == -1)
    with limited_for(model.n_dof):     # the dense invariants of a small model: one BLAS thread (flexfmu.core.blas)
        dynamics = FFRBeamDynamics(model, retained, cfg.damping_ratio, load_s, sensor_s, integrator=cfg.integrator,
                                   geometric_stiffening=bool(cfg.geometric_stiffening), gauge_s=gauge_s)
        correction = ffr_static_correction(dynamics) if corrected and n_modes < model.n_free else None
    choice = ModelChoice(f_max=float(cfg.f_max), tolerance=float(cfg.tolerance), elements_per_segment=n_el,
                         mesh=mesh_choice, n_modes=n_modes, modes_chosen=cfg.n_modes == -1,
                         frequencies_hz=modes.frequencies_hz[:n_modes + 1].copy(), n_free=model.n_free,
                         static_correction=corrected, truncation=truncation)
    return _Built(dynamics, reported, choice, correction, dynamics.gauges.derived_outputs(scene.section))


def _gauge_arc_length(scene, s: float, name: str) -> float:
    """A gauge's arc length checked against the rod (the ends within rounding); the error names -1 as well."""
    total = scene.total_length
    require(-1e-9 * total <= s <= total * (1 + 1e-9), name, f"arc length {s!r} m is outside the rod",
            f"-1 (no gauge) or 0 <= {name} <= {total:.6g} m")
    return check_arc_length(scene, s, name)
