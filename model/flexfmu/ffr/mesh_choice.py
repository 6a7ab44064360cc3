"""The automatic mesh of an FFR beam: flexfmu.sizing.mesh's convergence of the frequencies, on the meshes this
package builds (flexfmu.ffr.assembly.build_beam_model, the same boundary and extra nodes as the model itself)."""
from __future__ import annotations

import numpy as np

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.ffr.elements import get_element
from flexfmu.ffr.scene import Scene, beam_model_dofs
from flexfmu.linalg.cutoffs import MESH_SCAN_DENSE_MAX_DOF
from flexfmu.linalg.modal import solve_modes
from flexfmu.sizing.common import SAFETY_FACTOR
from flexfmu.sizing.mesh import MAX_ELEMENTS_PER_SEGMENT, MeshChoice, MeshFrequencies, converge_elements_per_segment


def mesh_frequencies(scene: Scene, boundary: str, extra_arc_lengths=(), dof_limit=None) -> MeshFrequencies:
    """flexfmu.sizing.mesh's ``mesh_frequencies`` of the beam models of ``scene``: (n, k) -> (the lowest
    min(k, n_free) frequencies in Hz of the model with n elements per segment, n_free); dense eigen solves up to
    MESH_SCAN_DENSE_MAX_DOF free DOFs (or when nearly all modes are asked for), shift-invert above.  ``dof_limit``
    (a flexfmu.core.checks.DofLimit): a mesh above it is refused, naming f_max, before it is built."""
    extra = tuple(extra_arc_lengths)

    def solve(elements_per_segment: int, n_modes: int) -> tuple[np.ndarray, int]:
        if dof_limit is not None:
            dof_limit.check(beam_model_dofs(scene, elements_per_segment, extra),
                            f"the automatic mesh's next candidate ({elements_per_segment} elements per segment on "
                            f"the {len(scene.points) - 1} segments of scene {scene.name})", "f_max",
                            "a lower f_max or a larger tolerance, a scene with fewer segments, or elements_per_segment "
                            "given")
        model = build_beam_model(scene, boundary, int(elements_per_segment), extra_arc_lengths=extra)
        k = min(n_modes, model.n_free)
        method = "dense" if model.n_free <= MESH_SCAN_DENSE_MAX_DOF or k >= model.n_free - 1 else "sparse"
        return solve_modes(model.K_free, model.M_free, k, method=method).frequencies_hz, model.n_free

    return solve


def choose_elements_per_segment(scene: Scene, boundary: str, f_max: float, tolerance: float, *,
                                extra_arc_lengths=(), min_modes: int = 1,
                                max_elements_per_segment: int = MAX_ELEMENTS_PER_SEGMENT,
                                safety_factor: float = SAFETY_FACTOR,
                                min_modes_parameter: str = "min_modes", dof_limit=None) -> MeshChoice:
    """Smallest elements per segment of ``scene``'s beam model (``boundary``, nodes also at
    ``extra_arc_lengths``) whose frequencies below f_max (and the first ``min_modes``, whatever their frequency)
    are within ``tolerance`` (relative) of the converged ones: flexfmu.sizing.mesh.converge_elements_per_segment
    on this model's meshes (the estimate, the a-priori refusal and the errors are described there); ``dof_limit``:
    as :func:`mesh_frequencies`'."""
    return converge_elements_per_segment(scene, mesh_frequencies(scene, boundary, extra_arc_lengths, dof_limit), f_max,
                                         tolerance, min_modes=min_modes,
                                         max_elements_per_segment=max_elements_per_segment,
                                         safety_factor=safety_factor, min_modes_parameter=min_modes_parameter,
                                         order=get_element(scene.element).convergence_order)
