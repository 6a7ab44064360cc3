"""The FFR beam's modes: its load patterns (flexfmu.ffr.dynamics Eq. (*)), the truncation estimate for them, the
static correction (residual flexibility, Eq. (RF) of flexfmu.sizing.model_size) and the report of what an FFRBeam
model retains (ModelChoice)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexfmu.errors import require
from flexfmu.sizing.common import SAFETY_FACTOR, TruncationEstimate, truncation_errors
from flexfmu.sizing.mesh import MeshChoice


def residual_flexibility(K_free, shapes: np.ndarray, eigenvalues: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """R @ loads with R = K^-1 - Phi Lambda^-1 Phi^T (Eq. RF), on the free DOFs.

    K_free (n, n) positive definite (sparse or dense); shapes Phi (n, m) mass-normalised;
    eigenvalues Lambda (m,) = omega_i^2 (rad^2/s^2); loads (n, k) load patterns.  Returns (n, k): the
    quasi-static displacement per unit of each pattern that the m retained modes miss."""
    loads = np.asarray(loads, float)
    shapes = np.asarray(shapes, float)
    eigenvalues = np.asarray(eigenvalues, float)
    require(shapes.shape[0] == loads.shape[0] == K_free.shape[0], "loads",
            f"shapes {shapes.shape}, loads {loads.shape}, K {K_free.shape}", "the same number of free DOFs")
    require(bool(np.all(eigenvalues > 0)), "eigenvalues", "a retained mode has omega^2 <= 0",
            "a clamped structure (positive definite K)")
    if shapes.shape[1] == K_free.shape[0]:     # every mode retained: R = 0 exactly
        return np.zeros_like(loads)
    if sp.issparse(K_free):
        static = spla.splu(sp.csc_matrix(K_free)).solve(loads)
    else:
        static = np.linalg.solve(np.asarray(K_free, float), loads)
    return static - shapes @ ((shapes.T @ loads) / eigenvalues[:, None])


LOAD_PATTERN_NAMES = (("F_x", "F_y", "F_z", "M_x", "M_y", "M_z", "base_a_x", "base_a_y", "base_a_z")
                      + tuple(f"X_{a}{b}" for a in "xyz" for b in "xyz"))


def ffr_load_patterns(dynamics) -> np.ndarray:
    """(n_dof, 18) physical load patterns of flexfmu.ffr.dynamics Eq. (*), all DOFs, body frame:
    columns 0-8 multiply the inputs [F, M, a0] (load-point force S_F^T, moment S_M^T, inertial load
    -S_bar^T of the base acceleration), columns 9-17 multiply X_ab = ([alpha]x + [omega]x^2)_ab
    (row-major a, b): -P_ab, the inertial load of the held base rotation on the undeformed rod."""
    n = dynamics.model.n_dof
    ints = dynamics.integrals
    rotation = -ints.P.reshape(9, n).T
    return np.hstack([dynamics.load.full_translation(n).T, dynamics.load.full_rotation(n).T, -ints.S_bar.T,
                      rotation])


#: The load groups of Eq. (*) whose truncation error is estimated (columns of ffr_load_patterns).
FFR_LOAD_GROUPS = {"F": slice(0, 3), "M": slice(3, 6), "base_a": slice(6, 9), "base rotation": slice(9, 18)}


def ffr_truncation_errors(model, modes, patterns: np.ndarray, points: dict, f_max: float,
                          damping_ratio: float) -> TruncationEstimate:
    """Eq. (E) for an FFR beam: the displacement outputs ``points`` ({name: PointShape}, e.g. tip_u and
    sensor_u) under the load groups of Eq. (*) (``patterns`` = :func:`ffr_load_patterns`, all DOFs), for
    the computed ``modes`` (free DOFs, mass-normalised) of ``model``; the full static responses from one
    sparse LU of K."""
    free = model.B2.T @ patterns
    static = spla.splu(sp.csc_matrix(model.K_free)).solve(free)
    shapes = np.asarray(modes.shapes, float)
    lam = modes.omega**2
    n = model.n_dof
    complete = shapes.shape[1] == model.n_free
    output_modal, static_full = {}, {}
    load_modal = {g: shapes.T @ free[:, cols] for g, cols in FFR_LOAD_GROUPS.items()}
    for name, point in points.items():
        rows = point.full_translation(n) @ model.B2
        output_modal[name] = np.asarray(rows @ shapes)
        for g, cols in FFR_LOAD_GROUPS.items():
            static_full[(name, g)] = np.asarray(rows @ static[:, cols])
    return truncation_errors(output_modal, load_modal, lam, modes.frequencies_hz, static_full, f_max, damping_ratio,
                             complete=complete)


@dataclass
class StaticCorrection:
    """Residual-flexibility terms of the outputs for the load vector z = [F, M, a0, X_ab (9)] (18,):

    sensor_u += sensor @ z, tip_u += tip @ z (m, body frame), elastic energy += 1/2 z^T energy z (J);
    residual (n_dof, 18): the residual displacement per pattern on all DOFs (for term-by-term checks)."""

    sensor: np.ndarray
    tip: np.ndarray
    energy: np.ndarray
    residual: np.ndarray = field(repr=False)


def ffr_static_correction(dynamics) -> StaticCorrection:
    """The static correction of an FFRBeamDynamics' displacement outputs and strain energy."""
    model = dynamics.model
    patterns = ffr_load_patterns(dynamics)
    free = model.B2.T @ patterns
    residual_free = residual_flexibility(model.K_free, dynamics.modes.shapes, dynamics.stiffness, free)
    residual = model.B2 @ residual_free
    n = model.n_dof
    energy = free.T @ residual_free          # z^T (G^T R G) z = f^T R f
    return StaticCorrection(sensor=dynamics.sensor.full_translation(n) @ residual,
                            tip=dynamics.tip.full_translation(n) @ residual,
                            energy=0.5 * (energy + energy.T), residual=residual)


# ---------------------------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class TruncationChoice:
    """Why n_modes = -1 kept the modes it kept: n_below_f_max of them lie below f_max; the estimated dynamic
    truncation error (Eq. (E)) of the retained set, the output and load group it comes from, and the static
    share of the omitted modes that the static correction supplies."""

    n_below_f_max: int
    error: float
    worst: str
    static_residual: float
    all_modes: bool = False       # every mode of the mesh kept: the complete basis, no truncation error


@dataclass(frozen=True)
class ModelChoice:
    """What an FFR beam model retains and why; ``message()`` is what the FMU logs.

    mesh: the mesh choice (None when elements_per_segment was given); modes_chosen: n_modes chosen
    from f_max (False: given); frequencies_hz: the chosen mesh's lowest frequencies (the retained
    ones and, when there is one, the first omitted); n_free: free DOFs of the chosen mesh."""

    f_max: float
    tolerance: float
    elements_per_segment: int
    mesh: MeshChoice | None
    n_modes: int
    modes_chosen: bool
    frequencies_hz: np.ndarray
    n_free: int
    static_correction: bool
    truncation: TruncationChoice | None = None

    @property
    def messages(self) -> tuple[str, ...]:
        """What to log: :meth:`message` when anything was chosen (mesh, modes) or corrected, else nothing."""
        return (self.message(),) if self.mesh is not None or self.modes_chosen or self.static_correction else ()

    def message(self) -> str:
        band = (f" (f_max = {self.f_max:g} Hz, tolerance = {self.tolerance:g})" if self.mesh is not None
                else f" (f_max = {self.f_max:g} Hz)" if self.modes_chosen else "")
        parts = [f"model size{band}:"]
        mesh = self.mesh
        if mesh is None:
            parts.append(f"elements_per_segment = {self.elements_per_segment} (given);")
        else:
            which = f"{len(mesh.relative_errors)} frequencies below f_max"
            if self.truncation is not None and len(mesh.relative_errors) > mesh.n_below_f_max:
                which = f"{len(mesh.relative_errors)} retained frequencies"
            why = (f"elements_per_segment = {mesh.elements_per_segment} (chosen: estimated relative error of the "
                   f"{which} at most {mesh.worst_error:.2e} (mode "
                   f"{mesh.worst_mode}, {mesh.chosen_hz[mesh.worst_mode - 1]:.6g} Hz), x{mesh.safety_factor:g} "
                   f"safety = {mesh.safety_factor * mesh.worst_error:.2e} <= {mesh.tolerance:g}; h^{mesh.order} "
                   f"Richardson reference from {mesh.reference_meshes[0]}/{mesh.reference_meshes[1]} elements")
            if mesh.rejected is not None:
                n_rej = mesh.rejected[0]
                why += (f"; {n_rej} element{'s' if n_rej > 1 else ''} per segment: error {mesh.rejected[1]:.2e}, "
                        "rejected")
            parts.append(why + ");")
        shown = self.frequencies_hz[:self.n_modes]
        tr = self.truncation
        band = 6 if tr is not None and tr.all_modes else max(tr.n_below_f_max, 6) if tr is not None else 0
        if tr is not None and self.n_modes > band + 1:
            head = shown[:band]                                       # long lists: the band, then the last
            retained = ", ".join(f"{f:.6g}" for f in head) + f", ..., {shown[-1]:.6g}"
        else:
            retained = ", ".join(f"{f:.6g}" for f in shown)
        omitted = self.frequencies_hz[self.n_modes:]
        nxt = f"; first omitted {omitted[0]:.6g} Hz" if omitted.size else "; no mode omitted"
        how = "chosen: every mode below f_max" if self.modes_chosen else "given"
        if self.modes_chosen and not np.any(self.frequencies_hz[:1] < self.f_max):
            how = "chosen: no mode below f_max, the fundamental kept"
        tr = self.truncation
        if tr is not None and tr.all_modes:
            highest = float(self.frequencies_hz[self.n_modes - 1])
            how = ("chosen: every mode of the mesh kept, the complete modal basis, so there is no truncation error"
                   + (f"; the mesh's highest frequency {highest:.6g} Hz is below f_max: this mesh does not resolve the "
                      "band up to f_max (more elements_per_segment would)" if highest < self.f_max
                      else ""))
        elif tr is not None:
            how = (f"chosen: the {tr.n_below_f_max} mode{'s' if tr.n_below_f_max != 1 else ''} below f_max and "
                   f"{self.n_modes - tr.n_below_f_max} above, until the estimated dynamic truncation error of tip_u "
                   f"and sensor_u (mode acceleration, omitted modes amplified as at f_max) is {tr.error:.2e}, "
                   f"x{SAFETY_FACTOR:g} safety <= {self.tolerance:g}, worst: {tr.worst}")
        parts.append(f"n_modes = {self.n_modes} of {self.n_free} ({how}: {retained} Hz{nxt});")
        if self.static_correction and self.n_modes >= self.n_free:
            parts.append("static correction not needed (no mode omitted)")
        elif self.static_correction:
            parts.append(f"static correction on (residual flexibility of the {self.n_free - self.n_modes} omitted "
                         "modes for F, M, base_a and base rotation: sensor_u, tip_u and elastic_energy equal the "
                         "full model's in the quasi-static limit; sensor_v, sensor_a and reactions uncorrected)")
        else:
            parts.append("static correction off")
        return " ".join(parts)

