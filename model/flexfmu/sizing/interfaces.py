"""Model size of a flexible body with named interfaces (flexfmu.body): the modes for a band f_max and a tolerance
and the static correction, for loads at and outputs of several interface patches.

The same steps as ReframeBody's automatic basis (flexfmu.sizing.solid.auto_basis), generalised from one load node
and one output node to load patterns and output rows:

* modes: every mode up to f_max, then more until the estimated dynamic truncation error (Eq. (E) of
  flexfmu.sizing.model_size, the residual vectors' own dynamics included) of every interface's translation under
  every load group is within tolerance / SAFETY_FACTOR (:func:`flexfmu.sizing.solid.mode_search`);
* static correction: if the static translation of an interface under a load group from these modes is more than
  ``tolerance`` (relative, spectral norm) off the full model's, the residual-flexibility (Ritz) vectors of all the
  load patterns are added (:func:`flexfmu.sizing.solid.residual_vectors`): the static response to those loads is
  then exact, and the vectors respond dynamically at their Rayleigh frequencies.

Free body: the flexible modes of the free-free structure and the static responses with inertia relief.
Clamped body: the modes of the clamped structure (free DOFs) and K_ff^-1 of the load patterns, which include
the base's inertial loads (flexfmu.body.clamped Eq. (B1): base acceleration, angular acceleration, spin).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from flexfmu.errors import ParameterError
from flexfmu.linalg.modal import solve_modes
from flexfmu.core.structure import N_RIGID
from flexfmu.linalg.modal_basis import ModalBasis, modal_basis
from flexfmu.sizing.common import truncation_errors
from flexfmu.sizing.solid import (MAX_AUTO_MODES, _select, kept_message, mode_search, residual_vectors,
                                  static_responses)

#: the lowest natural frequencies a body reports (f_1 ... f_6)
N_REPORTED = 6


@dataclass(frozen=True)
class LoadCase:
    """The load groups and outputs of the size estimate: ``groups`` {name: (n_dof, k) load patterns} and
    ``outputs`` {name: (3, n_dof) translation rows}, on all DOFs of the structure."""

    groups: dict
    outputs: dict

    @property
    def patterns(self) -> np.ndarray:
        return np.hstack(list(self.groups.values()))

    def columns(self) -> dict:
        out, start = {}, 0
        for name, G in self.groups.items():
            out[name] = slice(start, start + G.shape[1])
            start += G.shape[1]
        return out


@dataclass(frozen=True)
class SizedModes:
    """What a body retains: ``basis`` (free: the ModalBasis, rigid modes first; clamped: None), ``shapes``
    (n_dof, m) the retained elastic coordinates on all DOFs (eigenmodes first, then residual vectors; zero on
    clamped DOFs), ``eigenvalues`` omega^2 (m,) (the vectors' Rayleigh quotients), ``n_modes`` eigenmodes among
    them, ``natural_hz`` the lowest (up to six) natural frequencies, and the ``messages`` to log."""

    basis: ModalBasis | None
    shapes: np.ndarray
    eigenvalues: np.ndarray
    n_modes: int
    natural_hz: np.ndarray
    messages: tuple


def _estimate(shapes, lam, freqs, U, case: LoadCase, f_max, zeta, complete):
    cols = case.columns()
    output_modal = {o: O @ shapes for o, O in case.outputs.items()}
    load_modal = {g: shapes.T @ G for g, G in case.groups.items()}
    static_full = {(o, g): O @ U[:, cols[g]] for o, O in case.outputs.items() for g in case.groups}
    return truncation_errors(output_modal, load_modal, lam, freqs, static_full, f_max, zeta, ritz_residual=True,
                             complete=complete)


def _static_error(shapes, lam, U, case: LoadCase) -> tuple[float, str]:
    """Worst relative static error (spectral norm) of an interface's translation under a load group."""
    cols = case.columns()
    worst, where = 0.0, ""
    for o, O in case.outputs.items():
        Oshapes = O @ shapes
        for g, G in case.groups.items():
            full = O @ U[:, cols[g]]
            scale = np.linalg.norm(full, 2)
            if not scale > 0:
                continue
            err = np.linalg.norm((Oshapes / lam) @ (shapes.T @ G) - full, 2) / scale
            if err > worst:
                worst, where = float(err), f"{o} under {g}"
    return worst, where


def _check_size(n_modes, f_max, tolerance, n_available: int):
    if n_modes is not None:
        if f_max is not None:
            raise ParameterError("n_modes", "given together with f_max", "n_modes, or f_max (and tolerance)")
        if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or not 1 <= n_modes <= n_available:
            raise ParameterError("n_modes", f"{n_modes!r}", f"an integer 1 .. {n_available} (elastic DOFs)")
        return int(n_modes), None, None
    if f_max is None:
        raise ParameterError("n_modes", "neither n_modes nor f_max given", "n_modes, or f_max (and tolerance)")
    if isinstance(f_max, bool) or not (isinstance(f_max, (int, float)) and np.isfinite(f_max) and f_max > 0):
        raise ParameterError("f_max", f"{f_max!r}", "a frequency > 0 Hz")
    tol = 1e-3 if tolerance is None else tolerance
    if isinstance(tol, bool) or not (isinstance(tol, (int, float)) and 1e-8 <= tol < 1):
        raise ParameterError("tolerance", f"{tolerance!r}", "1e-8 <= tolerance < 1 (relative)")
    return None, float(f_max), float(tol)


def _corrected(shapes, lam, U, case, M, K, tolerance, n_keep, noun):
    """The static check and, if needed, the residual vectors: (shapes, eigenvalues, messages)."""
    err, where = _static_error(shapes, lam, U, case)
    if err <= tolerance:
        return shapes, lam, [f"static translation of the interfaces from these {noun}s is within {err:.2g} of the "
                             f"full model's (tolerance {tolerance:g}): no static correction"]
    W, lam_w = residual_vectors(M, K, shapes, U)
    shapes2, lam2 = np.hstack([shapes, W]), np.concatenate([lam, lam_w])
    after, _ = _static_error(shapes2, lam2, U, case)
    fr = ", ".join(f"{f:.4g}" for f in np.sqrt(lam_w) / (2 * np.pi))
    return shapes2, lam2, [f"static translation of the interfaces from these {noun}s is {err:.2g} off the full model's "
                           f"(> tolerance {tolerance:g}; worst: {where}): added {lam_w.size} residual-flexibility "
                           f"vectors (static correction; Rayleigh frequencies {fr} Hz); static error now {after:.1g}; "
                           f"{n_keep + lam_w.size} elastic coordinates"]


def free_modes(structure, case: LoadCase, *, n_modes=None, f_max=None, tolerance=None,
               damping_ratio: float = 0.02) -> SizedModes:
    """The modal basis of a free body: ``n_modes`` flexible modes, or the modes for f_max and tolerance with
    the static correction (module docstring).  ``case`` on all DOFs of ``structure``."""
    n_avail = structure.n_dof - N_RIGID
    n_modes, f_max, tolerance = _check_size(n_modes, f_max, tolerance, n_avail)
    zeta = float(damping_ratio)
    if n_modes is not None:
        basis = modal_basis(structure, n_modes, zeta)
        natural = basis.frequencies_hz[:N_REPORTED]
        if natural.size < min(N_REPORTED, n_avail):
            natural = modal_basis(structure, min(N_REPORTED, n_avail), zeta).frequencies_hz
        return SizedModes(basis, basis.shapes[:, N_RIGID:], basis.stiffness[N_RIGID:].copy(), n_modes, natural,
                          (f"n_modes = {n_modes} given: {n_modes} flexible mode(s), no static correction",))
    G = case.patterns
    n_max = min(n_avail, MAX_AUTO_MODES)
    found = mode_search(n_max, lambda n: _free_solve(structure, n, zeta),
                        lambda full: static_responses(structure, full, G),
                        lambda full, U: _estimate(full.shapes[:, N_RIGID:], full.stiffness[N_RIGID:],
                                                  full.frequencies_hz, U, case, f_max, zeta,
                                                  full.n_flexible == n_avail),
                        f_max, tolerance)
    complete = found.n_try == n_avail
    if not complete and found.n_below >= found.n_try:
        raise ParameterError("f_max", f"{f_max:g} Hz: the model has more than {found.n_try} flexible modes up to "
                             f"f_max, the most an automatic size keeps (mode {found.n_try} is at "
                             f"{found.freqs[found.n_try - 1]:.6g} Hz)",
                             f"f_max < {found.freqs[found.n_try - 1]:.6g} Hz, or n_modes given (1 .. {n_avail})")
    n_keep = found.n_try if found.n_keep is None else found.n_keep
    basis = _select(found.full, n_keep)
    msgs = [kept_message("model size", "flexible mode(s)", "the interfaces' translation", found, n_keep, complete,
                         f_max, tolerance)]
    shapes, lam, more = _corrected(basis.shapes[:, N_RIGID:], basis.stiffness[N_RIGID:], found.U, case, structure.M,
                                   structure.K, tolerance, n_keep, "mode")
    msgs += more
    if shapes.shape[1] > n_keep:
        wr = np.sqrt(lam[n_keep:])
        basis = dataclasses.replace(
            basis, shapes=np.hstack([basis.shapes, shapes[:, n_keep:]]),
            frequencies_hz=np.concatenate([basis.frequencies_hz, wr / (2 * np.pi)]),
            stiffness=np.concatenate([basis.stiffness, lam[n_keep:]]),
            damping=np.concatenate([basis.damping, 2 * zeta * wr]),
            damping_ratio=np.concatenate([basis.damping_ratio, np.full(wr.size, zeta)]),
            method=basis.method + "+static")
    return SizedModes(basis, shapes, lam, n_keep, found.freqs[:N_REPORTED].copy(), tuple(msgs))


def _free_solve(structure, n, zeta):
    b = modal_basis(structure, n, zeta)
    return b, b.frequencies_hz


def clamped_modes(structure, free_dofs: np.ndarray, case: LoadCase, *, n_modes=None, f_max=None, tolerance=None,
                  damping_ratio: float = 0.02) -> SizedModes:
    """The retained coordinates of a clamped body (DOFs not in ``free_dofs`` fixed): ``n_modes`` modes of the
    clamped structure, or the modes for f_max and tolerance with the static correction (module docstring)."""
    f = np.asarray(free_dofs)
    M, K = structure.M.tocsr(), structure.K.tocsr()
    Mf, Kf = M[f][:, f].tocsr(), K[f][:, f].tocsr()
    n_avail = f.size
    n_modes, f_max, tolerance = _check_size(n_modes, f_max, tolerance, n_avail)
    zeta = float(damping_ratio)

    def full(shapes_f):
        out = np.zeros((structure.n_dof, shapes_f.shape[1]))
        out[f] = shapes_f
        return out

    if n_modes is not None:
        modes = solve_modes(Kf, Mf, max(n_modes, min(N_REPORTED, n_avail)))
        return SizedModes(None, full(modes.shapes[:, :n_modes]), modes.omega[:n_modes] ** 2, n_modes,
                          modes.frequencies_hz[:N_REPORTED].copy(),
                          (f"n_modes = {n_modes} given: {n_modes} mode(s) of the clamped structure, no static "
                           "correction",))
    case_f = LoadCase({g: G[f] for g, G in case.groups.items()}, {o: O[:, f] for o, O in case.outputs.items()})
    lu = spla.splu(Kf.tocsc())
    found = mode_search(min(n_avail, MAX_AUTO_MODES), lambda n: _clamped_solve(Kf, Mf, n),
                        lambda modes: lu.solve(case_f.patterns),
                        lambda modes, U: _estimate(modes.shapes, modes.omega ** 2, modes.frequencies_hz, U, case_f,
                                                   f_max, zeta, modes.shapes.shape[1] == n_avail),
                        f_max, tolerance)
    complete = found.n_try == n_avail
    if not complete and found.n_below >= found.n_try:
        raise ParameterError("f_max", f"{f_max:g} Hz: the clamped structure has more than {found.n_try} modes up to "
                             f"f_max, the most an automatic size keeps", "a lower f_max, or n_modes given")
    n_keep = found.n_try if found.n_keep is None else found.n_keep
    modes = found.full
    msgs = [kept_message("model size", "mode(s) of the clamped structure", "the interfaces' translation", found,
                         n_keep, complete, f_max, tolerance)]
    shapes, lam, more = _corrected(modes.shapes[:, :n_keep], modes.omega[:n_keep] ** 2, found.U, case_f, Mf, Kf,
                                   tolerance, n_keep, "mode")
    return SizedModes(None, full(shapes), lam, n_keep, found.freqs[:N_REPORTED].copy(), tuple(msgs + more))


def _clamped_solve(Kf, Mf, n):
    modes = solve_modes(Kf, Mf, n)
    return modes, modes.frequencies_hz
