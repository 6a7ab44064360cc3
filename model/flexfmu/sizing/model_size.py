"""A model no larger than the scene needs: mesh, number of modes and static correction.

Given a frequency band of interest (0 .. f_max) and a relative tolerance:

* **Elements per segment** from the convergence of the frequencies below f_max.  The beam element
  (Hermite cubics for bending, linear axial and torsion, consistent mass) is a conforming
  Rayleigh-Ritz discretisation, so its frequencies converge monotonically from above: as h^4 for
  bending-dominated modes (error ratios 12-16 per halving on the spatial double-L,
  docs/model_size.md), as h^2 for modes dominated by axial or torsional deformation.  For a pair of
  meshes (n, 2n) Richardson's estimate of the coarse mesh's relative error is

      f_inf = f_2n - (f_n - f_2n) / (2^p - 1),   e_n = |f_n - f_2n| / f_inf * 2^p / (2^p - 1),   p = 4,   (R)

  with f_inf the extrapolated ("converged") frequency.
  A mesh is accepted when SAFETY_FACTOR * e <= tolerance for every frequency below f_max.  With
  SAFETY_FACTOR = 2 the test stays conservative for any observed order p >= 1 (the true error of
  the coarse mesh is d 2^p / (2^p - 1) <= 2 d, d = |f_n - f_2n| / f_inf, for a power law from
  above), so also for the h^2 modes.  Meshes are doubled from 1 element per segment until a
  pair passes; the smallest passing n between the last failing and the first passing doubling is
  then found by bisection, its errors measured against f_inf of the passing pair.  Fine meshes of
  slender rods are ill-conditioned (element length below the diameter at ~64 elements per segment
  of the double-L): where the estimated error stops halving per doubling the tolerance is declared
  unreachable (round-off), as it is when it would take more than max_elements_per_segment.

* **Number of modes** (mode-acceleration truncation estimate): every mode below f_max, and then
  more, until the estimated *dynamic* truncation error of the displacement outputs is at most
  `tolerance`.  With the static correction an omitted mode j keeps its quasi-static share exactly;
  what is lost is its dynamic amplification.  For a harmonic input at f <= f_max the omitted mode
  responds with H(r) = 1 / (1 - r^2 + 2 i zeta r), r = f / f_j, times its static contribution, the
  correction supplies 1, so the error is

      A(r) = |H(r) - 1| = |r^2 - 2 i zeta r| / |1 - r^2 + 2 i zeta r|   (~ r^2 / (1 - r^2)),   (A)

  largest at f = f_max (mode-acceleration method: R. R. Craig Jr. & A. J. Kurdila, Fundamentals of
  Structural Dynamics, 2nd ed., Wiley 2006, the mode-superposition chapter: mode-displacement vs
  mode-acceleration solutions).  For an output point o and a group of load patterns g (force,
  moment, ...) the static contribution of mode j is the rank-one matrix
  c_j = (o phi_j)(phi_j^T g) / omega_j^2; relative to the full static response Y = o K^-1 g
  (spectral norms) the estimated error of keeping the first m modes is

      e(m) = max_{o, g} | sum_{j > m} c_j (H(f_max / f_j) - 1) | / |Y|                   (E)

  the exact steady-state error of the mode-acceleration model for a harmonic load at f_max.
  Modes beyond those computed are bounded together by the norm of the static residual that the
  computed modes leave, times A at the highest computed frequency.  n_modes is the fewest with
  SAFETY_FACTOR * e(m) <= tolerance (pulses are not band-limited and leave the omitted modes
  ringing, which the steady-state (E) does not contain).  The mesh then resolves every retained
  frequency to the tolerance (docs/model_size.md: why not a looser one above f_max).
  See :func:`truncation_errors`.

* **Static correction** (mode-acceleration method / residual flexibility): the free-DOF
  displacement is q = Phi eta + R f with the residual flexibility

      R = K^-1 - Phi Lambda^-1 Phi^T                                                (RF)

  (mass-normalised Phi, Lambda = diag(omega_i^2)) applied to the load f(t) acting at that
  instant.  At equilibrium eta = Lambda^-1 Phi^T f, so q = K^-1 f: the truncated model's static
  deflection equals the full model's exactly.  Phi^T K R = 0 and R K R = R, so the strain energy
  is 1/2 eta^T Lambda eta + 1/2 f^T R f.  For the FFR beam the load patterns are those of
  flexfmu.ffr.dynamics Eq. (*): load-point force and moment, base acceleration (-S_bar^T a0) and
  the nine base-rotation patterns (-P_ab, multiplied by X_ab); see :func:`ffr_load_patterns`.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.core.checks import finite
from flexfmu.errors import FlexfmuError, ParameterError, require
from flexfmu.linalg.modal import solve_modes
from flexfmu.linalg.modal_basis import N_RIGID, ModalBasis, modal_basis
from flexfmu.ffr.scene import Scene

CONVERGENCE_ORDER = 4               # h^4: Euler-Bernoulli Hermite cubics, frequency (eigenvalue) error
SAFETY_FACTOR = 2.0                 # see the module docstring: conservative for observed orders >= 1
MAX_ELEMENTS_PER_SEGMENT = 512
# Below ~1e-6 the eigen solver's round-off on fine meshes (~1e-7 relative, docs/model_size.md) is no
# longer small against the tolerance; above 0.1 the h^4 asymptotics the estimate relies on do not hold.
TOLERANCE_RANGE = (1e-6, 0.1)
_FIRST_MODES_SOLVED = 8             # modes per eigen solve to begin with (doubled while all are below f_max)
# Free DOFs up to which the meshes are solved densely; beyond, shift-invert on the banded matrices is ~30x
# cheaper (0.1 s against 2-6 s CPU at 576-1152 DOFs) and within ~2e-8 of the dense frequencies.
_DENSE_UP_TO = 200


@dataclass(frozen=True)
class MeshChoice:
    """The chosen elements per segment and why.

    converged_hz: extrapolated frequencies (R) of the modes of interest (Hz); chosen_hz: the chosen
    mesh's; relative_errors: its estimated relative errors, per mode of interest; rejected: the
    next smaller mesh tried and its worst estimated error (None if 1 element already passes);
    reference_meshes: the pair (n, 2n) the extrapolation came from; n_below_f_max: modes whose
    converged frequency is below f_max; meshes_solved: every elements_per_segment solved.
    """

    elements_per_segment: int
    f_max: float
    tolerance: float
    converged_hz: np.ndarray
    chosen_hz: np.ndarray
    relative_errors: np.ndarray
    n_below_f_max: int
    reference_meshes: tuple[int, int]
    rejected: tuple[int, float] | None
    meshes_solved: tuple[int, ...]
    safety_factor: float = SAFETY_FACTOR
    order: int = CONVERGENCE_ORDER

    @property
    def worst_error(self) -> float:
        return float(np.max(self.relative_errors))

    @property
    def worst_mode(self) -> int:
        """1-based index of the mode with the largest estimated error."""
        return int(np.argmax(self.relative_errors)) + 1


def check_band(f_max: float, tolerance: float) -> None:
    """ParameterError unless f_max > 0 (Hz, finite) and tolerance lies in TOLERANCE_RANGE."""
    require(finite(f_max) and f_max > 0, "f_max", f"got {f_max!r}", "a finite frequency > 0 Hz")
    lo, hi = TOLERANCE_RANGE
    require(finite(tolerance) and lo <= tolerance <= hi, "tolerance", f"got {tolerance!r}",
            f"{lo:g} .. {hi:g} (relative)")


def richardson(coarse_hz: np.ndarray, fine_hz: np.ndarray, order: int = CONVERGENCE_ORDER):
    """(extrapolated frequencies, estimated relative errors of the coarse mesh), Eq. (R)."""
    gain = 2.0 ** order
    diff = np.asarray(coarse_hz, float) - np.asarray(fine_hz, float)
    extrapolated = np.asarray(fine_hz, float) - diff / (gain - 1.0)
    return extrapolated, np.abs(diff) * gain / (gain - 1.0) / np.maximum(np.abs(extrapolated), 1e-300)


def choose_n_modes(frequencies_hz, f_max: float) -> int:
    """Number of modes to retain: all below f_max (Hz), at least one."""
    return max(1, int(np.count_nonzero(np.asarray(frequencies_hz) < f_max)))


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


# ------------------------------------------------------------------ a priori: what the finest mesh can resolve
#: The a-priori check refuses a band only when its estimated error on the finest allowed mesh is this many
#: times what the tolerance allows: the estimate is of single waves (below), the modes of a bent rod mix them.
A_PRIORI_MARGIN = 2.0
#: Estimated errors stalling above this are a band not yet resolved (pre-asymptotic: errors ~0.1 .. 1 whose modes
#: pair up differently on the next mesh), not the eigen solver's round-off (~1e-7 on fine meshes, growing with
#: them; the largest stall docs/model_size.md reports is 2.6e-4 at 256 elements per segment).
ROUNDOFF_CEILING = 1e-3
#: Most modes of interest (below f_max, or min_modes) the automatic mesh choice resolves: their meshes (up to
#: 1024 elements per segment, ~18 000 DOFs for three segments) take ~1 min to solve for 200 modes (measured: 134
#: modes of the spatial double-L, 48 s); the same cap as ReframeBody's n_flexible_modes = -1 (MAX_AUTO_MODES).
MAX_BAND_MODES = 200


def _wave_numbers(scene: Scene, f_hz: float) -> dict:
    """Wave numbers (1/m) of the rod's axial, torsional and bending waves at f_hz (Euler-Bernoulli)."""
    sec, mat = scene.section, scene.material
    w = 2.0 * math.pi * f_hz
    return {"axial": w * math.sqrt(mat.rho / mat.E),
            "torsional": w * math.sqrt(mat.rho * sec.Ip / (mat.G * sec.J)),
            "bending": math.sqrt(w) * (mat.rho * sec.A / (mat.E * min(sec.Iy, sec.Iz))) ** 0.25}


def wave_errors(scene: Scene, f_hz: float, h: float) -> dict:
    """Relative frequency error of each wave type at f_hz on elements of length h: (kh)^2 / 24 for the linear
    axial and torsional elements, (kh)^4 / 1440 for the Hermite bending element (consistent mass; both within a
    few % of the measured errors of a straight cantilever's modes up to kh ~ 1)."""
    k = _wave_numbers(scene, f_hz)
    return {"axial": (k["axial"] * h) ** 2 / 24.0, "torsional": (k["torsional"] * h) ** 2 / 24.0,
            "bending": (k["bending"] * h) ** 4 / 1440.0}


def estimated_mode_count(scene: Scene, f_hz: float) -> float:
    """Modes below f_hz, Weyl's estimate L k / pi per wave type (bending in two planes), L the rod's length
    (118 against 118 computed for the spatial double-L at 100 kHz)."""
    k = _wave_numbers(scene, f_hz)
    return scene.total_length / math.pi * (k["axial"] + k["torsional"] + 2.0 * k["bending"])


def _frequency_of_mode(scene: Scene, n: int) -> float:
    """Estimated frequency (Hz) of mode n (the inverse of estimated_mode_count; bisection in log f)."""
    lo, hi = 1e-6, 1e12
    for _ in range(100):                                  # fixed count: 1e-6 .. 1e12 to ~1e-10 relative
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if estimated_mode_count(scene, mid) < n else (lo, mid)
    return hi


def resolved_band(scene: Scene, tolerance: float, elements_per_segment: int,
                  safety_factor: float = SAFETY_FACTOR) -> float:
    """Estimated highest frequency (Hz) that ``elements_per_segment`` resolve to ``tolerance``: where the worst
    wave's error (:func:`wave_errors` on the longest segment's elements) times safety_factor reaches it."""
    h = float(np.max(scene.segment_lengths)) / elements_per_segment
    lo, hi = 1e-6, 1e12
    for _ in range(100):
        mid = math.sqrt(lo * hi)
        ok = safety_factor * max(wave_errors(scene, mid, h).values()) <= tolerance
        lo, hi = (mid, hi) if ok else (lo, mid)
    return lo


def check_resolvable(scene: Scene, f_max: float, tolerance: float, min_modes: int = 1,
                     max_elements_per_segment: int = MAX_ELEMENTS_PER_SEGMENT, safety_factor: float = SAFETY_FACTOR,
                     min_modes_parameter: str = "min_modes") -> None:
    """Fast refusal (ParameterError) of a band that the mesh sequence could not resolve, or only after minutes:

    * more than MAX_BAND_MODES modes below f_max (or min_modes > MAX_BAND_MODES), from Weyl's estimate
      (:func:`estimated_mode_count`): names f_max (or ``min_modes_parameter``);
    * the finest allowed mesh resolving the band's top to the tolerance by a wide margin: the error of the
      highest mode of each wave type is estimated from :func:`wave_errors` one mode spacing below the top
      (c / 2L: lenient) and refused only beyond A_PRIORI_MARGIN times tolerance / safety_factor; names the
      tolerance when one in TOLERANCE_RANGE would do, else f_max (or ``min_modes_parameter``).

    Borderline bands go to the mesh sequence, which measures."""
    by_modes = min_modes > 1 and _frequency_of_mode(scene, min_modes) > f_max
    f_top = _frequency_of_mode(scene, min_modes) if by_modes else f_max
    band_name = min_modes_parameter if by_modes else "f_max"
    count = estimated_mode_count(scene, f_max)
    if max(count, min_modes) > MAX_BAND_MODES:
        f_cap = _frequency_of_mode(scene, MAX_BAND_MODES)
        what = (f"{min_modes} modes" if by_modes else
                f"{f_max:g} Hz: the band up to f_max holds about {count:.0f} modes (estimated)")
        f_ok = min(f_cap, resolved_band(scene, tolerance, max_elements_per_segment, safety_factor))
        raise ParameterError(band_name, f"{what}, more than the {MAX_BAND_MODES} whose convergence the automatic mesh "
                             f"choice resolves (their meshes would take minutes to solve); mode {MAX_BAND_MODES} is at "
                             f"about {f_cap:.3g} Hz",
                             f"at most {MAX_BAND_MODES} modes" if by_modes else
                             f"f_max <= about {f_ok:.3g} Hz at tolerance {tolerance:g}, or elements_per_segment given")
    L = scene.total_length
    h = float(np.max(scene.segment_lengths)) / max_elements_per_segment
    sec, mat = scene.section, scene.material
    speeds = {"axial": math.sqrt(mat.E / mat.rho), "torsional": math.sqrt(mat.G * sec.J / (mat.rho * sec.Ip))}
    worst, kind = 0.0, ""
    for name, error in wave_errors(scene, f_top, h).items():
        if name in speeds:                                # the highest such mode may lie one spacing lower
            error = wave_errors(scene, max(f_top - speeds[name] / (2.0 * L), 0.0), h)[name]
        if error > worst:
            worst, kind = error, name
    if not safety_factor * worst > A_PRIORI_MARGIN * tolerance:
        return
    limit = resolved_band(scene, tolerance, max_elements_per_segment, safety_factor)
    lo, hi = TOLERANCE_RANGE
    looser = safety_factor * worst / A_PRIORI_MARGIN            # a tolerance the estimate would let through
    name = "tolerance" if looser <= hi else band_name
    what = (f"{min_modes} modes, reaching about {f_top:.4g} Hz (estimated), beyond f_max = {f_max:g} Hz"
            if by_modes else f"f_max = {f_max:g} Hz")
    options = [f"a tolerance >= about {looser:.2g} (of {lo:g} .. {hi:g})"] if looser <= hi else []
    options.append(f"at most about {max(1, int(estimated_mode_count(scene, limit)))} modes" if by_modes
                   else f"f_max <= about {limit:.3g} Hz at tolerance {tolerance:g}")
    if max_elements_per_segment < MAX_ELEMENTS_PER_SEGMENT:
        options.append("more elements allowed")
    head = (f"{tolerance:g} is not reachable for {what}" if name == "tolerance"
            else f"{what} is not resolvable to tolerance {tolerance:g}")
    raise ParameterError(name, f"{head}: the finest allowed mesh ({max_elements_per_segment} elements per segment, "
                         f"{h:.3g} m) leaves its {kind} waves there an estimated {worst:.2g} off (x{safety_factor:g} "
                         f"safety); it resolves up to about {limit:.3g} Hz", ", or ".join(options))


def choose_elements_per_segment(scene: Scene, boundary: str, f_max: float, tolerance: float, *,
                                extra_arc_lengths=(), min_modes: int = 1,
                                max_elements_per_segment: int = MAX_ELEMENTS_PER_SEGMENT,
                                safety_factor: float = SAFETY_FACTOR,
                                min_modes_parameter: str = "min_modes") -> MeshChoice:
    """Smallest elements per segment whose frequencies below f_max (and the first ``min_modes``,
    whatever their frequency) are within ``tolerance`` (relative) of the converged ones, estimated
    as in the module docstring.  The meshes are built as flexfmu.ffr.assembly.build_beam_model does
    for the model itself (same boundary and extra nodes).  A band far beyond what
    ``max_elements_per_segment`` can resolve is refused up front (:func:`check_resolvable`, naming f_max or
    ``min_modes_parameter``)."""
    check_band(f_max, tolerance)
    require(isinstance(min_modes, (int, np.integer)) and min_modes >= 1, "min_modes", f"got {min_modes!r}",
            "an integer >= 1")
    require(isinstance(max_elements_per_segment, (int, np.integer)) and max_elements_per_segment >= 1,
            "max_elements_per_segment", f"got {max_elements_per_segment!r}", "an integer >= 1")
    check_resolvable(scene, f_max, tolerance, min_modes, max_elements_per_segment, safety_factor, min_modes_parameter)
    solved: dict[int, np.ndarray] = {}
    complete: set[int] = set()            # meshes whose every mode is solved (fewer free DOFs than asked)
    n_wanted = max(_FIRST_MODES_SOLVED, min_modes + 1)

    def frequencies(n: int) -> np.ndarray:
        """Lowest n_wanted frequencies of the mesh (all of them if it has fewer free DOFs)."""
        if n not in solved or (len(solved[n]) < n_wanted and n not in complete):
            model = build_beam_model(scene, boundary, int(n), extra_arc_lengths=tuple(extra_arc_lengths))
            k = min(n_wanted, model.n_free)
            method = "dense" if model.n_free <= _DENSE_UP_TO or k >= model.n_free - 1 else "sparse"
            solved[n] = solve_modes(model.K_free, model.M_free, k, method=method).frequencies_hz
            if k == model.n_free:
                complete.add(n)
        return solved[n]

    def modes_of_interest(reference_hz: np.ndarray) -> int:
        return max(min_modes, int(np.count_nonzero(reference_hz < f_max)))

    def worst(coarse: np.ndarray, reference: np.ndarray, k: int) -> np.ndarray:
        """Relative errors of the first k modes of ``coarse`` against ``reference`` (inf if absent)."""
        if len(coarse) < k:
            return np.full(k, np.inf)
        return np.abs(coarse[:k] - reference[:k]) / reference[:k]

    n, previous = 1, None                 # previous: (number of modes of interest, their worst error)
    # n doubles until 2 n > max_elements_per_segment (raises); the other rounds double n_wanted until the mesh's
    # every mode is solved: at most ~log2(max_elements_per_segment) * log2(DOFs) rounds, guarded all the same.
    for _ in range(64 * 64):
        fine = frequencies(2 * n)
        # Every mode below f_max must be among those solved (frequencies converge from above, so the
        # finer mesh's count is the one to trust).
        while 2 * n not in complete and fine[-1] < f_max:
            n_wanted *= 2
            fine = frequencies(2 * n)
        coarse = frequencies(n)
        common = min(len(coarse), len(fine))
        extrapolated, errors = richardson(coarse[:common], fine[:common])
        # below f_max after extrapolation (lower than the fine mesh's) or on the fine mesh
        k = modes_of_interest(np.minimum(extrapolated, fine[:common]))
        if k >= len(fine) and 2 * n not in complete:      # the band may reach beyond the modes solved
            n_wanted = 2 * max(n_wanted, k)
            continue
        if k <= common:
            extrapolated, errors = extrapolated[:k], errors[:k]
        else:                                             # a mesh with fewer modes than needed
            extrapolated, errors = np.asarray(fine[:k], float), np.full(k, np.inf)
        worst_now = float(np.max(errors))
        if safety_factor * worst_now <= tolerance:
            break
        if 2 * n > max_elements_per_segment:
            raise _unreachable(f"{tolerance:g} is not reachable for f_max = {f_max:g} Hz with at most "
                               f"{max_elements_per_segment} elements per segment", errors, extrapolated, n, f_max,
                               tolerance, safety_factor, "or more elements allowed")
        # round-off: the errors of the same modes (the band may have grown) stop halving at a small level
        if n >= 8 and previous is not None:
            same = float(np.max(errors[:previous[0]]))
            if same <= ROUNDOFF_CEILING and math.isfinite(previous[1]) and not same < 0.5 * previous[1]:
                raise _unreachable(f"{tolerance:g} is not reachable: the frequencies stop converging at an estimated "
                                   f"error {same:.2g} ({n} elements per segment; round-off of the eigen solver)",
                                   errors, extrapolated, n, f_max, tolerance, safety_factor)
        previous = (k, worst_now)
        n *= 2
    else:
        raise FlexfmuError(f"the mesh choice did not settle (f_max = {f_max:g} Hz, tolerance {tolerance:g})")
    n_hi = n
    chosen, rejected = n_hi, None
    errors_at = {n_hi: errors}
    if n_hi > 1:
        # The smallest passing mesh lies in (n_hi / 2, n_hi]: bisection, with the errors now measured
        # against the extrapolated frequencies (the error falls monotonically with n in the
        # asymptotic range; the prediction e(n) = e(n / 2) / 16 would misplace the h^2 modes).
        lo, hi = n_hi // 2, n_hi

        def passes(candidate: int) -> bool:
            if candidate not in errors_at:
                errors_at[candidate] = worst(frequencies(candidate), extrapolated, k)
            return safety_factor * float(np.max(errors_at[candidate])) <= tolerance

        passes(lo)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (lo, mid) if passes(mid) else (mid, hi)
        chosen, rejected = hi, (lo, float(np.max(errors_at[lo])))
    chosen_errors = errors_at[chosen]
    return MeshChoice(elements_per_segment=int(chosen), f_max=float(f_max), tolerance=float(tolerance),
                      converged_hz=np.asarray(extrapolated, float),
                      chosen_hz=np.asarray(frequencies(chosen)[:k], float),
                      relative_errors=np.asarray(chosen_errors, float),
                      n_below_f_max=int(np.count_nonzero(extrapolated < f_max)), reference_meshes=(n_hi, 2 * n_hi),
                      rejected=rejected, meshes_solved=tuple(sorted(solved)), safety_factor=float(safety_factor))


def _unreachable(text: str, errors, extrapolated, n: int, f_max: float, tolerance: float, safety_factor: float,
                 more: str = "") -> ParameterError:
    """ParameterError naming the tolerance when the mesh sequence stops short of it: what was reached, the
    band that n elements per segment do resolve to the tolerance, and what would be allowed."""
    errors = np.asarray(errors, float)
    bad = np.nonzero(~(safety_factor * errors <= tolerance))[0]
    j = int(np.argmax(np.where(np.isfinite(errors), errors, np.inf)))
    text += f" (estimated error {errors[j]:.2g} at {n}, mode {j + 1} at {extrapolated[j]:.6g} Hz"
    resolved = float(extrapolated[bad[0] - 1]) if bad.size and bad[0] > 0 else None
    if resolved is not None:
        text += f"; {n} elements per segment resolve the modes up to {resolved:.6g} Hz to it"
    text += ")"
    lo, hi = TOLERANCE_RANGE
    needed = safety_factor * float(errors[j]) if math.isfinite(errors[j]) else math.inf
    options = []
    if needed <= hi:
        options.append(f"a tolerance >= {needed:.2g} (of {lo:g} .. {hi:g})")
    if resolved is not None and resolved < f_max:
        options.append(f"f_max < {resolved:.6g} Hz at this tolerance")
    if more:
        options.append(more)
    if not options:
        options.append(f"a lower f_max: no tolerance in {lo:g} .. {hi:g} reaches {f_max:g} Hz")
    return ParameterError("tolerance", text, ", or ".join(options))


# ---------------------------------------------------------------------------------------------- static correction
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


# --------------------------------------------------------------------------- free bodies (ReframeBody)
MAX_AUTO_MODES = 200        # n_flexible_modes = -1 computes at most this many modes
_SHIFT = 1e-8               # K + shift * omega_1^2 M for the static solve (relative error ~ shift)


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
    DOF row, with inertia relief (the load minus the inertia forces of the rigid acceleration it causes),
    M-orthogonal to the rigid modes: one sparse factorisation of K + s M (s = 1e-8 omega_1^2; relative
    error ~1e-8 of the first mode's share) and one refinement step."""
    M, K = structure.M.tocsc(), structure.K.tocsc()
    PR = basis.shapes[:, :N_RIGID]
    lam1 = float(basis.stiffness[N_RIGID]) if basis.n_flexible else float(np.max(K.diagonal() / M.diagonal()))
    lu = spla.splu((K + _SHIFT * lam1 * M).tocsc())
    F = np.zeros((structure.n_dof, len(rows)))
    F[np.asarray(rows), np.arange(len(rows))] = 1.0
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


def auto_basis(structure, f_max: float, tolerance: float, damping_ratio: float, load_node: int,
               output_node: int | None = None):
    """(basis, messages) for ``n_flexible_modes = -1``: the flexible modes up to f_max (Hz), then more until the
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
    n_try, U = min(8, n_max), None
    for _ in range(2 + n_max.bit_length()):              # n_try doubles up to n_max, where the loop ends
        full = modal_basis(structure, n_try, damping_ratio)
        freqs = full.frequencies_hz
        if U is None and n_try:
            U = static_deflections(structure, full, rows)
        n_below = int(np.count_nonzero(freqs <= f_max))
        estimate, n_keep = None, None
        if n_try and (n_below < n_try or n_try >= n_max):
            estimate = reframe_truncation_errors(structure, full, U, rows, out_rows, f_max, zeta)
            n_keep = estimate.smallest(tolerance / SAFETY_FACTOR, at_least=n_below)
        settled = estimate is not None and estimate.errors[-1] <= 0.1 * tolerance   # uncomputed modes' bound
        if n_try >= n_max or (n_keep is not None and n_keep < n_try and settled):
            break
        n_try = min(2 * n_try, n_max)
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
    kept = freqs[:n_keep]
    shown = ", ".join(f"{f:.4g}" for f in kept[:6]) + (f", ..., {kept[-1]:.4g}" if n_keep > 6 else "")
    if estimate is not None and complete and n_keep == n_try:
        why = (f"every flexible mode of the model, the complete modal basis, so there is no truncation error; "
               f"{n_below} of them up to f_max = {f_max:g} Hz")
    elif estimate is not None:
        met = SAFETY_FACTOR * estimate.errors[n_keep] <= tolerance
        why = (f"the {n_below} up to f_max = {f_max:g} Hz and {n_keep - n_below} above, "
               + ("until" if met else "all computed (limit); NOT within tolerance:")
               + " the estimated dynamic truncation error of the load and output points' deflection (mode "
               f"acceleration, omitted modes and residual vectors amplified as at f_max) is {estimate.errors[n_keep]:.2g}"
               f", x{SAFETY_FACTOR:g} safety {'<=' if met else '>'} {tolerance:g}, worst: {estimate.worst[n_keep]}")
    else:
        why = f"every mode up to f_max = {f_max:g} Hz"
    msgs = [f"n_flexible_modes = -1: kept {n_keep} flexible mode(s) ({why})" + (f": {shown} Hz" if n_keep else "")
            + (f"; the next is at {freqs[n_keep]:.4g} Hz" if n_keep < freqs.size else
               f"; limit of {MAX_AUTO_MODES} modes reached" if n_keep == MAX_AUTO_MODES else "")]
    if U is None:
        return basis, msgs
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
        return basis, msgs
    M, K = structure.M, structure.K
    Phi = basis.shapes
    R = U.copy()
    for _ in range(2):                                   # M-orthogonal to every retained mode ("twice is enough")
        R -= Phi @ (Phi.T @ (M @ R))
    Mr = R.T @ (M @ R)
    mu, V = np.linalg.eigh(0.5 * (Mr + Mr.T))
    keep = mu > 1e-12 * mu.max()
    W = R @ (V[:, keep] / np.sqrt(mu[keep]))             # M-orthonormal residual vectors
    Kw = W.T @ (K @ W)
    lam, Y = sla.eigh(0.5 * (Kw + Kw.T))
    W = W @ Y
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
    return corrected, msgs
