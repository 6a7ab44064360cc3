"""Converged modal analysis of a scene and the comparison with the paper's Table 3."""
from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources

import numpy as np

from flexfmu.ffr.assembly import BeamModel, boundary_clamps, build_beam_model
from flexfmu.errors import require
from flexfmu.linalg.modal import Modes, solve_modes
from flexfmu.ffr.scene import Scene, beam_model_dofs

PAPER_SCENE = "spatial_double_L"
# Which column set of the paper's Table 3 a boundary preset is compared with.
_PAPER_COLUMNS = {"XFF": "XFF", "XFX": "XFX", "FXF": "FXF", "FXF_mid": "FXF"}


@dataclass
class ModalResult:
    model: BeamModel
    modes: Modes
    elements_per_segment: int
    converged: bool
    history: list  # [(elements_per_segment, frequencies_hz)], the refinement sequence
    stopped: str = ""   # why the refinement stopped before converging, when a model size limit stopped it


def modal_analysis(scene: Scene, boundary: str = "scene", n_modes: int = 6, elements_per_segment: int = 0,
                   rtol: float = 1e-5, max_elements_per_segment: int = 256,
                   rotary_inertia: bool = False, dof_limit=None) -> ModalResult:
    """Frequencies and modes of ``scene``.  ``elements_per_segment = 0`` refines the mesh
    (doubling from 2) until the first ``n_modes`` frequencies change by less than ``rtol``.

    dof_limit: a flexfmu.core.checks.DofLimit.  A given mesh, or the refinement's first, above it is refused
    (ParameterError naming the scene); the refinement stops before a mesh above it, unconverged, saying so in
    ``stopped``."""
    require(isinstance(elements_per_segment, int) and elements_per_segment >= 0, "elements_per_segment",
            f"got {elements_per_segment!r}", "0 (refine until converged) or an integer >= 1")
    require(isinstance(n_modes, int) and n_modes >= 1, "n_modes", f"got {n_modes!r}", "an integer >= 1")

    clamps = boundary_clamps(scene, boundary)

    def too_large(n_el: int) -> bool:
        return dof_limit is not None and beam_model_dofs(scene, n_el, clamps) > dof_limit.limit

    def solve(n_el: int) -> tuple[BeamModel, Modes]:
        if dof_limit is not None:
            dof_limit.check(beam_model_dofs(scene, n_el, clamps), f"the beam model of scene {scene.name} "
                            f"({len(scene.points) - 1} segments at {n_el} elements per segment)", "scene",
                            "a scene with fewer segments, or fewer --elements-per-segment")
        model = build_beam_model(scene, boundary, n_el, rotary_inertia=rotary_inertia)
        require(n_modes <= model.n_free, "n_modes", f"{n_modes} modes asked of a model with {model.n_free} free DOFs",
                f"1 <= n_modes <= {model.n_free}")
        return model, solve_modes(model.K_free, model.M_free, n_modes)

    if elements_per_segment >= 1:
        model, modes = solve(elements_per_segment)
        return ModalResult(model, modes, elements_per_segment, False, [(elements_per_segment, modes.frequencies_hz)])
    # Start coarse, but with at least twice as many DOFs as modes asked for.
    n_el = 2
    n_segments = len(scene.points) - 1
    while 6 * (n_segments * n_el + 1) < 2 * n_modes and n_el < max_elements_per_segment:
        n_el *= 2
    model, modes = solve(n_el)
    history = [(n_el, modes.frequencies_hz)]
    while n_el < max_elements_per_segment:
        if too_large(2 * n_el):
            stopped = (f"not refined beyond {n_el} elements per segment: {2 * n_el} would exceed the limit of "
                       f"{dof_limit.limit:,} DOFs (raise it with {dof_limit.raise_with})")
            return ModalResult(model, modes, n_el, False, history, stopped)
        n_el *= 2
        new_model, new_modes = solve(n_el)
        history.append((n_el, new_modes.frequencies_hz))
        model, modes = new_model, new_modes
        # an unconstrained structure's first 6 modes are rigid: round-off around 0 Hz, nothing to converge
        n_rigid = 6 if model.n_free == model.n_dof else 0
        if _max_relative_change(history[-2][1][n_rigid:], history[-1][1][n_rigid:]) < rtol:
            return ModalResult(model, modes, n_el, True, history)
    return ModalResult(model, modes, n_el, False, history)


def _max_relative_change(old: np.ndarray, new: np.ndarray) -> float:
    """Largest relative change of the elastic frequencies.  Rigid-body modes (below 1e-3 of
    the highest frequency in both meshes) are round-off around 0 Hz and are left out."""
    if not len(new):
        return 0.0
    rigid = np.maximum(old, new) < 1e-3 * float(max(new.max(), old.max()))
    elastic = ~rigid
    if not elastic.any():
        return 0.0
    return float(np.max(np.abs(new[elastic] - old[elastic]) / old[elastic]))


def paper_tables() -> dict:
    """The papers' published figures (copy of shared/reference/paper_tables.json)."""
    text = (resources.files("flexfmu") / "data" / "paper_tables.json").read_text()
    return json.loads(text)


def paper_columns(boundary: str) -> dict[str, list[float]] | None:
    """Paper FFR, experiment and ANSYS frequencies (Hz) for a boundary preset, or None."""
    key = _PAPER_COLUMNS.get(boundary)
    if key is None:
        return None
    ref = paper_tables()["ffr_spatial_double_pendulum"]
    return {"paper_ffr": ref["paper_ffr_model"][key],
            "experiment": ref["experiment_fft"][key],
            "ansys": ref["ansys_beam188"][key]}


def _pct(ours: float, theirs: float) -> str:
    return f"{100.0 * (ours - theirs) / theirs:+7.2f}%"


def format_table(scene_name: str, result: ModalResult) -> str:
    """Readable table; for the paper's scene, the Table-3 columns and % differences too."""
    m = result.model
    head = (f"{scene_name}  boundary={m.boundary}  clamps at s={[round(float(s), 6) for s in m.clamp_s]} m  "
            f"elements/segment={result.elements_per_segment}"
            f"{' (converged)' if result.converged else ''}  free DOFs={m.n_free}")
    cols = paper_columns(m.boundary) if scene_name == PAPER_SCENE else None
    lines = [head] + ([f"note: {result.stopped}"] if result.stopped else [])
    if cols is None:
        lines.append(f"{'mode':>4} {'f (Hz)':>12}")
        lines += [f"{i + 1:>4} {f:12.3f}" for i, f in enumerate(result.modes.frequencies_hz)]
        return "\n".join(lines)
    if m.boundary == "FXF_mid":
        lines.append("note: the paper's FFR column clamps the first corner (its B2); its ANSYS model clamps "
                     "mid-segment 2 like FXF_mid")
    lines.append(f"{'mode':>4} {'ours (Hz)':>10} {'paper FFR':>10} {'d%':>8} {'experiment':>10} {'d%':>8} "
                 f"{'ANSYS':>8} {'d%':>8}")
    for i, f in enumerate(result.modes.frequencies_hz):
        row = f"{i + 1:>4} {f:10.2f}"
        for name in ("paper_ffr", "experiment", "ansys"):
            ref = cols[name]
            row += f" {ref[i]:10.2f} {_pct(f, ref[i]):>8}" if i < len(ref) else f" {'':>10} {'':>8}"
        lines.append(row)
    return "\n".join(lines)
