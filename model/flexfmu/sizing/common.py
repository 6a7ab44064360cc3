"""Shared by both sides of the model size (flexfmu.sizing.model_size: the equations): the safety factor and the
mode-acceleration estimate of the dynamic truncation error, Eqs. (A) and (E)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SAFETY_FACTOR = 2.0                 # flexfmu.sizing.model_size docstring: conservative for observed orders >= 1


def dynamic_error_factor(frequencies_hz, f_max: float, damping_ratio: float = 0.0) -> np.ndarray:
    """A(f_max / f_j) of Eq. (A) per mode: the dynamic error, relative to its static contribution, of a mode
    represented only by its static (mode-acceleration) part; inf for modes at or below f_max (they must be
    retained)."""
    f = np.asarray(frequencies_hz, float)
    r = f_max / np.maximum(f, 1e-300)
    zeta = float(damping_ratio)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.abs(r**2 - 2j * zeta * r) / np.abs(1.0 - r**2 + 2j * zeta * r)
    return np.where(f > f_max, a, np.inf)


@dataclass(frozen=True)
class TruncationEstimate:
    """Estimated dynamic truncation error, Eq. (E), of keeping the first m of the computed modes.

    errors[m] (m = 0 .. n computed): worst over output points and load groups; worst[m]: which pair
    ("output under group"); static_residual[m]: the relative static share the first m modes miss (worst
    pair), which the static correction supplies."""

    errors: np.ndarray
    worst: tuple
    static_residual: np.ndarray

    def smallest(self, tolerance: float, at_least: int = 1) -> int | None:
        """Fewest modes (>= at_least) whose estimated error is <= tolerance; None if the computed modes
        do not reach it."""
        ok = np.nonzero(self.errors[at_least:] <= tolerance)[0]
        return int(ok[0]) + at_least if ok.size else None


def truncation_errors(output_modal, load_modal, eigenvalues, frequencies_hz, static_full, f_max: float,
                      damping_ratio: float = 0.0, ritz_residual: bool = False,
                      complete: bool = False) -> TruncationEstimate:
    """Eq. (E) for every number of retained modes m = 0 .. n (the n computed modes).

    output_modal: {output name: (3, n) displacement of the output point per mode}; load_modal: {group name:
    (n, k) modal loads phi_j^T g}; eigenvalues omega_j^2 (n,); static_full: {(output, group): (3, k) full
    static response o K^-1 g} (its part that the n modes miss is the tail, bounded with A at the highest
    computed frequency).  ritz_residual: the static correction is a set of Ritz vectors (ReframeBody) rather
    than mode acceleration: those respond dynamically at their Rayleigh frequency, which is at least the
    first omitted mode's, so the static residual share times A(f_max / f_{m+1}) is added.  complete: the n
    modes are all the model has, so nothing lies beyond them (no tail; keeping all n has no truncation error,
    even when the highest is below f_max)."""
    lam = np.asarray(eigenvalues, float)
    f = np.asarray(frequencies_hz, float)
    n = lam.size
    factor = dynamic_error_factor(f, f_max, damping_ratio)
    r = f_max / np.maximum(f, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        excess = 1.0 / (1.0 - r**2 + 2j * float(damping_ratio) * r) - 1.0     # H(r) - 1, Eq. (A)
    tail_factor = float(dynamic_error_factor([f[-1]], f_max, damping_ratio)[0]) if n else np.inf
    next_factor = np.append(factor, 0.0 if complete else tail_factor)   # A of the first omitted mode, m = 0 .. n
    errors = np.full(n + 1, -1.0)
    residual_worst = np.zeros(n + 1)
    worst = [""] * (n + 1)
    for out_name, a in output_modal.items():
        for group, b in load_modal.items():
            Y = np.asarray(static_full[(out_name, group)], float)
            scale = np.linalg.norm(Y, 2)
            contrib = (a / lam) @ b                        # all n modes' static response
            if not scale > 1e-14 * max(np.linalg.norm(contrib, 2), 1e-300):
                continue                                   # no static response of this output to this group
            tail = 0.0 if complete else np.linalg.norm(Y - contrib, 2) / scale * tail_factor
            # |sum_{j > m} c_j (H_j - 1)|: the omitted modes' error matrix at f = f_max, summed from the top
            e = np.zeros(n + 1)
            e[n] = tail
            error_matrix = np.zeros(Y.shape, complex)
            for j in range(n - 1, -1, -1):
                if not np.isfinite(factor[j]):
                    e[:j + 1] = np.inf
                    break
                error_matrix += np.outer(a[:, j] / lam[j], b[j]) * excess[j]
                e[j] = np.linalg.norm(error_matrix, 2) / scale + tail
            # static residual share after m modes: |Y - sum_{j <= m} c_j| / |Y| (exact matrices, no bound)
            partial = np.zeros_like(Y)
            res = [np.linalg.norm(Y, 2) / scale]
            for j in range(n):
                partial += np.outer(a[:, j] / lam[j], b[j])
                res.append(np.linalg.norm(Y - partial, 2) / scale)
            res = np.array(res)
            if ritz_residual:
                with np.errstate(invalid="ignore"):
                    e = np.where(np.isinf(e), np.inf, e + res * next_factor)
            for m in range(n + 1):
                if e[m] > errors[m] or (np.isinf(e[m]) and not worst[m]):
                    errors[m], worst[m] = e[m], f"{out_name} under {group}"
                residual_worst[m] = max(residual_worst[m], res[m])
    errors = np.where(errors < 0, 0.0, errors)
    return TruncationEstimate(errors=errors, worst=tuple(worst), static_residual=residual_worst)
