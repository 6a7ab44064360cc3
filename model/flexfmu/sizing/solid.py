"""A free body's modal basis for ReframeBody's n_flexible_modes = -1: the modes for a frequency band and a
tolerance (Eq. (E) of flexfmu.sizing.model_size with the residual vectors' own dynamics), the exact static
deflections with inertia relief, and the residual-flexibility vectors of the static correction."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from flexfmu.errors import ParameterError
from flexfmu.core.structure import N_RIGID
from flexfmu.linalg.modal_basis import ModalBasis, modal_basis
from flexfmu.sizing.common import SAFETY_FACTOR, truncation_errors

MAX_AUTO_MODES = 200        # n_flexible_modes = -1 computes at most this many modes
_SHIFT = 1e-8               # K + shift * omega_1^2 M for the static solve (relative error ~ shift)


@dataclass(frozen=True)
class BasisChoice:
    """What a free body's model retains and why (the ReframeBody counterpart of :class:`ModelChoice`):
    the modal basis (with the residual-flexibility vectors when the static correction is on) and the
    messages the FMU logs."""

    basis: ModalBasis
    messages: tuple[str, ...] = ()


def _select(basis: ModalBasis, n: int) -> ModalBasis:
    """The rigid modes and the first n flexible modes of a basis."""
    cols = list(range(N_RIGID + n))
    return dataclasses.replace(basis, shapes=basis.shapes[:, cols], frequencies_hz=basis.frequencies_hz[:n],
                               stiffness=basis.stiffness[cols], damping=basis.damping[cols],
                               damping_ratio=basis.damping_ratio[:n])


def load_point_rows(structure, node: int) -> np.ndarray:
    """DOF rows of a node's translations (and rotations on 6-DOF models)."""
    dpn = int(structure.dofs_per_node)
    return node * dpn + np.arange(6 if dpn == 6 else 3)


def static_deflections(structure, basis: ModalBasis, rows) -> np.ndarray:
    """Exact elastic static deflections (n_dof, len(rows)) of the free-free model under a unit load on each
    DOF row: :func:`static_responses` of those unit loads."""
    F = np.zeros((structure.n_dof, len(rows)))
    F[np.asarray(rows), np.arange(len(rows))] = 1.0
    return static_responses(structure, basis, F)


def static_responses(structure, basis: ModalBasis, loads) -> np.ndarray:
    """Exact elastic static deflections (n_dof, k) of the free-free model under the load patterns ``loads``
    (n_dof, k), with inertia relief (the load minus the inertia forces of the rigid acceleration it causes),
    M-orthogonal to the rigid modes: one sparse factorisation of K + s M (s = 1e-8 omega_1^2; relative
    error ~1e-8 of the first mode's share) and one refinement step."""
    M, K = structure.M.tocsc(), structure.K.tocsc()
    PR = basis.shapes[:, :N_RIGID]
    lam1 = float(basis.stiffness[N_RIGID]) if basis.n_flexible else float(np.max(K.diagonal() / M.diagonal()))
    lu = spla.splu((K + _SHIFT * lam1 * M).tocsc())
    F = np.array(loads, dtype=float)
    F -= M @ (PR @ (PR.T @ F))                              # inertia relief: PR^T F = 0 now
    U = lu.solve(F)
    U += lu.solve(F - K @ U - _SHIFT * lam1 * (M @ U))      # iterative refinement
    return U - PR @ (PR.T @ (M @ U))


def _static_error(C_full, C_modal, n_trans) -> float:
    """Relative spectral-norm error of the load point's compliance, worst of the force and moment blocks."""
    errs = []
    for sl in (slice(0, n_trans), slice(n_trans, C_full.shape[0])):
        full = C_full[sl, sl]
        if full.size:
            errs.append(np.linalg.norm(C_modal[sl, sl] - full, 2) / max(np.linalg.norm(full, 2), 1e-300))
    return float(max(errs))


def modal_compliance(basis: ModalBasis, rows) -> np.ndarray:
    """sum_j phi_j(rows) phi_j(rows)^T / k_j over the flexible columns: the basis' static compliance."""
    Phi = basis.shapes[np.asarray(rows), N_RIGID:]
    return (Phi / basis.stiffness[N_RIGID:]) @ Phi.T


def reframe_truncation_errors(structure, basis: ModalBasis, U: np.ndarray, load_rows, output_rows, f_max: float,
                              damping_ratio: float):
    """Eq. (E) of flexfmu.sizing.model_size for a free body: the elastic displacement of the load point and of the output
    point (translations) under a force (and, on 6-DOF models, a moment) at the load point, inertia-relieved;
    U = :func:`static_deflections` for the load rows gives the full static responses (the modes beyond those
    computed are bounded by the residual they leave).  The static correction of ReframeBody is a set of Ritz
    vectors, which respond at their Rayleigh frequency: ``ritz_residual`` (see truncation_errors)."""
    load_rows = np.asarray(load_rows)
    Phi = basis.shapes[:, N_RIGID:]
    groups = {"force": slice(0, 3)}
    if load_rows.size == 6:
        groups["moment"] = slice(3, 6)
    points = {"load point": load_rows[:3], "output point": np.asarray(output_rows)[:3]}
    output_modal = {name: Phi[rows] for name, rows in points.items()}
    load_modal = {g: Phi[load_rows[cols]].T for g, cols in groups.items()}
    static_full = {(name, g): U[rows][:, cols] for name, rows in points.items() for g, cols in groups.items()}
    complete = basis.shapes.shape[1] == structure.n_dof           # every mode of the model: nothing omitted
    return truncation_errors(output_modal, load_modal, basis.stiffness[N_RIGID:], basis.frequencies_hz, static_full,
                             f_max, damping_ratio, ritz_residual=True, complete=complete)


class ModeSearch(NamedTuple):
    """:func:`mode_search`'s result: the last computed modes ``full`` and their flexible frequencies (Hz), how
    many were computed (n_try), how many lie at or below f_max, the truncation estimate (None if not needed),
    how many to keep (None: the computed ones do not reach the tolerance) and the static responses U."""

    full: object
    freqs: np.ndarray
    n_try: int
    n_below: int
    estimate: object
    n_keep: int | None
    U: np.ndarray | None


def _with_frequencies(basis: ModalBasis):
    return basis, basis.frequencies_hz


def mode_search(n_max: int, solve, static, estimate, f_max: float, tolerance: float) -> ModeSearch:
    """The fewest modes for a band and a tolerance: compute 8, 16, ... (up to n_max) of the lowest modes
    (``solve(n) -> (modes, flexible frequencies Hz)``) until every mode up to f_max is computed and the estimated
    dynamic truncation error (``estimate(modes, U) -> TruncationEstimate``, Eq. (E) of flexfmu.sizing.model_size,
    U = ``static(modes)`` the full static responses) settles within tolerance / SAFETY_FACTOR, the modes not
    computed being bounded within a tenth of the tolerance."""
    n_try, U = min(8, n_max), None
    for _ in range(2 + n_max.bit_length()):              # n_try doubles up to n_max, where the loop ends
        full, freqs = solve(n_try)
        if U is None and n_try:
            U = static(full)
        n_below = int(np.count_nonzero(freqs <= f_max))
        found, n_keep = None, None
        if n_try and (n_below < n_try or n_try >= n_max):
            found = estimate(full, U)
            n_keep = found.smallest(tolerance / SAFETY_FACTOR, at_least=n_below)
        settled = found is not None and found.errors[-1] <= 0.1 * tolerance   # uncomputed modes' bound
        if n_try >= n_max or (n_keep is not None and n_keep < n_try and settled):
            break
        n_try = min(2 * n_try, n_max)
    return ModeSearch(full, freqs, n_try, n_below, found, n_keep, U)


def kept_message(prefix: str, noun: str, outputs: str, found: ModeSearch, n_keep: int, complete: bool, f_max: float,
                 tolerance: float) -> str:
    """What a mode search kept and why, for the log (``outputs``: what the truncation error was estimated of)."""
    freqs, n_try, n_below, estimate = found.freqs, found.n_try, found.n_below, found.estimate
    kept = freqs[:n_keep]
    shown = ", ".join(f"{f:.4g}" for f in kept[:6]) + (f", ..., {kept[-1]:.4g}" if n_keep > 6 else "")
    if estimate is not None and complete and n_keep == n_try:
        why = (f"every flexible mode of the model, the complete modal basis, so there is no truncation error; "
               f"{n_below} of them up to f_max = {f_max:g} Hz")
    elif estimate is not None:
        met = SAFETY_FACTOR * estimate.errors[n_keep] <= tolerance
        why = (f"the {n_below} up to f_max = {f_max:g} Hz and {n_keep - n_below} above, "
               + ("until" if met else "all computed (limit); NOT within tolerance:")
               + f" the estimated dynamic truncation error of {outputs} (mode "
               f"acceleration, omitted modes and residual vectors amplified as at f_max) is {estimate.errors[n_keep]:.2g}"
               f", x{SAFETY_FACTOR:g} safety {'<=' if met else '>'} {tolerance:g}, worst: {estimate.worst[n_keep]}")
    else:
        why = f"every mode up to f_max = {f_max:g} Hz"
    return (f"{prefix}: kept {n_keep} {noun} ({why})" + (f": {shown} Hz" if n_keep else "")
            + (f"; the next is at {freqs[n_keep]:.4g} Hz" if n_keep < freqs.size else
               f"; limit of {MAX_AUTO_MODES} modes reached" if n_keep == MAX_AUTO_MODES else ""))


def residual_vectors(M, K, shapes: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residual-flexibility vectors of static responses U (n, k) that the retained ``shapes`` (n, m,
    M-orthonormal) miss: U made M-orthogonal to the shapes, M-orthonormalised (directions below 1e-12 of the
    largest dropped) and K-diagonalised.  Returns W (n, r) and their Rayleigh quotients omega^2 (r,)."""
    R = U.copy()
    for _ in range(2):                                   # M-orthogonal to every retained mode ("twice is enough")
        R -= shapes @ (shapes.T @ (M @ R))
    Mr = R.T @ (M @ R)
    mu, V = np.linalg.eigh(0.5 * (Mr + Mr.T))
    keep = mu > 1e-12 * mu.max()
    W = R @ (V[:, keep] / np.sqrt(mu[keep]))             # M-orthonormal residual vectors
    Kw = W.T @ (K @ W)
    lam, Y = sla.eigh(0.5 * (Kw + Kw.T))
    return W @ Y, lam


def auto_basis(structure, f_max: float, tolerance: float, damping_ratio: float, load_node: int,
               output_node: int | None = None) -> BasisChoice:
    """The basis and its messages for ``n_flexible_modes = -1``: the flexible modes up to f_max (Hz), then more until the
    estimated dynamic truncation error of the load and output points' deflection is within ``tolerance``
    (flexfmu.sizing.model_size Eq. (E), with the residual vectors' own dynamics), plus, if the static deflection of the
    load or output point under loads at the load point from these modes is more than ``tolerance`` off the full
    model's, the residual flexibility vectors of the load point (flexfmu.reframe.simulator's module docstring,
    docs/model_size.md)."""
    output_node = load_node if output_node is None else output_node
    n_max = min(structure.n_dof - N_RIGID, MAX_AUTO_MODES)
    rows = load_point_rows(structure, load_node)
    out_rows = load_point_rows(structure, output_node)[:3]
    zeta = float(np.atleast_1d(damping_ratio)[0])
    found = mode_search(n_max, lambda n: _with_frequencies(modal_basis(structure, n, damping_ratio)),
                        lambda full: static_deflections(structure, full, rows),
                        lambda full, U: reframe_truncation_errors(structure, full, U, rows, out_rows, f_max, zeta),
                        f_max, tolerance)
    full, freqs, n_try, n_below, estimate, n_keep, U = found
    complete = n_try == structure.n_dof - N_RIGID         # every flexible mode of the model computed
    if not complete and n_try and n_below >= n_try:
        # the band itself holds more modes than n_flexible_modes = -1 computes: a truncated basis would silently
        # drop modes below f_max
        raise ParameterError("f_max", f"{f_max:g} Hz: the model has more than {n_try} flexible modes up to f_max, "
                             f"the most n_flexible_modes = -1 keeps (mode {n_try} is at {freqs[n_try - 1]:.6g} Hz)",
                             f"f_max < {freqs[n_try - 1]:.6g} Hz, or n_flexible_modes given "
                             f"(0 .. {structure.n_dof - N_RIGID})")
    if n_keep is None:                                   # the cap reached: keep all computed
        n_keep = n_try
    basis = _select(full, n_keep)
    msgs = [kept_message("n_flexible_modes = -1", "flexible mode(s)", "the load and output points' deflection", found,
                         n_keep, complete, f_max, tolerance)]
    if U is None:
        return BasisChoice(basis, tuple(msgs))
    C_full = U[rows]
    C_full = 0.5 * (C_full + C_full.T)
    C_out = U[out_rows]

    def static_error(b):
        load_err = _static_error(C_full, modal_compliance(b, rows), 3)
        Phi_o, Phi_l = b.shapes[out_rows, N_RIGID:], b.shapes[np.asarray(rows), N_RIGID:]
        modal_out = (Phi_o / b.stiffness[N_RIGID:]) @ Phi_l.T
        out_err = max(np.linalg.norm(modal_out[:, sl] - C_out[:, sl], 2) / max(np.linalg.norm(C_out[:, sl], 2), 1e-300)
                      for sl in (slice(0, 3), slice(3, len(rows))) if C_out[:, sl].size)
        return max(load_err, out_err)

    err = static_error(basis)
    if err <= tolerance:
        msgs.append(f"static deflection of the load point (node {load_node}) and the output point (node {output_node}) "
                    f"from these modes is within {err:.2g} of the full model's (tolerance {tolerance:g}): no static "
                    "correction")
        return BasisChoice(basis, tuple(msgs))
    W, lam = residual_vectors(structure.M, structure.K, basis.shapes, U)
    zeta = float(basis.damping_ratio[0]) if basis.n_flexible else float(np.atleast_1d(damping_ratio)[0])
    wr = np.sqrt(lam)
    corrected = dataclasses.replace(
        basis, shapes=np.hstack([basis.shapes, W]),
        frequencies_hz=np.concatenate([basis.frequencies_hz, wr / (2 * np.pi)]),
        stiffness=np.concatenate([basis.stiffness, lam]), damping=np.concatenate([basis.damping, 2 * zeta * wr]),
        damping_ratio=np.concatenate([basis.damping_ratio, np.full(lam.size, zeta)]), method=basis.method + "+static")
    err_after = static_error(corrected)
    msgs.append(f"static deflection of the load point (node {load_node}) or the output point (node {output_node}) "
                f"from these modes is {err:.2g} off the full "
                f"model's (> tolerance {tolerance:g}): added {lam.size} residual-flexibility vectors (static "
                f"correction; Rayleigh frequencies {', '.join(f'{f:.4g}' for f in wr / (2 * np.pi))} Hz); static "
                f"deflection error now {err_after:.1g}; {n_keep + lam.size} flexible coordinates")
    return BasisChoice(corrected, tuple(msgs))
