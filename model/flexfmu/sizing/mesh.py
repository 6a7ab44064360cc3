"""Elements per segment of an FFR beam for a frequency band and a tolerance: the convergence of the frequencies
(Richardson, Eq. (R) of flexfmu.sizing.model_size) and the a-priori refusal of bands the finest mesh cannot resolve.

This module knows the estimates, not the beam model: a ``scene`` is read for its section, material and segment
lengths (a flexfmu.ffr.scene.Scene), and the meshes' frequencies come from the caller
(:func:`converge_elements_per_segment`'s ``mesh_frequencies``); flexfmu.ffr.mesh_choice supplies them for the FFR
beam model (sizing sits below ffr: docs/architecture.md, "Layers")."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from flexfmu.core.checks import finite
from flexfmu.errors import FlexfmuError, ParameterError, require
from flexfmu.sizing.common import SAFETY_FACTOR

CONVERGENCE_ORDER = 4               # h^4: Euler-Bernoulli Hermite cubics, frequency (eigenvalue) error
MAX_ELEMENTS_PER_SEGMENT = 512
# Below ~1e-6 the eigen solver's round-off on fine meshes (~1e-7 relative, docs/model_size.md) is no
# longer small against the tolerance; above 0.1 the h^4 asymptotics the estimate relies on do not hold.
TOLERANCE_RANGE = (1e-6, 0.1)
_FIRST_MODES_SOLVED = 8             # modes per eigen solve to begin with (doubled while all are below f_max)


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


def _wave_numbers(scene, f_hz: float) -> dict:
    """Wave numbers (1/m) of the rod's axial, torsional and bending waves at f_hz (Euler-Bernoulli)."""
    sec, mat = scene.section, scene.material
    w = 2.0 * math.pi * f_hz
    return {"axial": w * math.sqrt(mat.rho / mat.E),
            "torsional": w * math.sqrt(mat.rho * sec.Ip / (mat.G * sec.J)),
            "bending": math.sqrt(w) * (mat.rho * sec.A / (mat.E * min(sec.Iy, sec.Iz))) ** 0.25}


def wave_errors(scene, f_hz: float, h: float) -> dict:
    """Relative frequency error of each wave type at f_hz on elements of length h: (kh)^2 / 24 for the linear
    axial and torsional elements, (kh)^4 / 1440 for the Hermite bending element (consistent mass; both within a
    few % of the measured errors of a straight cantilever's modes up to kh ~ 1)."""
    k = _wave_numbers(scene, f_hz)
    return {"axial": (k["axial"] * h) ** 2 / 24.0, "torsional": (k["torsional"] * h) ** 2 / 24.0,
            "bending": (k["bending"] * h) ** 4 / 1440.0}


def estimated_mode_count(scene, f_hz: float) -> float:
    """Modes below f_hz, Weyl's estimate L k / pi per wave type (bending in two planes), L the rod's length
    (118 against 118 computed for the spatial double-L at 100 kHz)."""
    k = _wave_numbers(scene, f_hz)
    return scene.total_length / math.pi * (k["axial"] + k["torsional"] + 2.0 * k["bending"])


def _frequency_of_mode(scene, n: int) -> float:
    """Estimated frequency (Hz) of mode n (the inverse of estimated_mode_count; bisection in log f)."""
    lo, hi = 1e-6, 1e12
    for _ in range(100):                                  # fixed count: 1e-6 .. 1e12 to ~1e-10 relative
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if estimated_mode_count(scene, mid) < n else (lo, mid)
    return hi


def resolved_band(scene, tolerance: float, elements_per_segment: int,
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


def check_resolvable(scene, f_max: float, tolerance: float, min_modes: int = 1,
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


#: mesh_frequencies(elements_per_segment, n_modes) -> (the mesh's lowest min(n_modes, n_free) natural frequencies
#: in Hz, ascending; n_free, the mesh's number of free DOFs)
MeshFrequencies = Callable[[int, int], "tuple[np.ndarray, int]"]


def converge_elements_per_segment(scene, mesh_frequencies: MeshFrequencies, f_max: float, tolerance: float, *,
                                  min_modes: int = 1, max_elements_per_segment: int = MAX_ELEMENTS_PER_SEGMENT,
                                  safety_factor: float = SAFETY_FACTOR,
                                  min_modes_parameter: str = "min_modes",
                                  order: int = CONVERGENCE_ORDER) -> MeshChoice:
    """Smallest elements per segment whose frequencies below f_max (and the first ``min_modes``,
    whatever their frequency) are within ``tolerance`` (relative) of the converged ones, estimated
    as in flexfmu.sizing.model_size's docstring.  ``mesh_frequencies`` solves the meshes (:data:`MeshFrequencies`;
    for the FFR beam flexfmu.ffr.mesh_choice.choose_elements_per_segment passes the model's own, same boundary and
    extra nodes).  A band far beyond what ``max_elements_per_segment`` can resolve is refused up front
    (:func:`check_resolvable` on ``scene``, naming f_max or ``min_modes_parameter``).  ``order``: the frequency
    error's order in the element size (the beam element's ``convergence_order``), which the extrapolation assumes."""
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
            solved[n], n_free = mesh_frequencies(int(n), n_wanted)
            if n_wanted >= n_free:                    # every mode of the mesh solved
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
        extrapolated, errors = richardson(coarse[:common], fine[:common], order)
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
                      rejected=rejected, meshes_solved=tuple(sorted(solved)), safety_factor=float(safety_factor),
                      order=int(order))


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

