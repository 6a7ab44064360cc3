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
# The implementation is split by side; this module keeps the equations above and every name: common (shared
# estimates), mesh and beam (FFRBeam: mesh, modes, static correction), solid (ReframeBody's basis).  The FFR beam's
# mesh choice on its own model is flexfmu.ffr.mesh_choice.choose_elements_per_segment (sizing sits below ffr).
from flexfmu.sizing.beam import (FFR_LOAD_GROUPS, LOAD_PATTERN_NAMES, ModelChoice, StaticCorrection,
                                 TruncationChoice, ffr_load_patterns, ffr_static_correction, ffr_truncation_errors,
                                 residual_flexibility)
from flexfmu.sizing.common import SAFETY_FACTOR, TruncationEstimate, dynamic_error_factor, truncation_errors
from flexfmu.sizing.mesh import (A_PRIORI_MARGIN, CONVERGENCE_ORDER, MAX_BAND_MODES, MAX_ELEMENTS_PER_SEGMENT,
                                 ROUNDOFF_CEILING, TOLERANCE_RANGE, MeshChoice, MeshFrequencies, check_band,
                                 check_resolvable, choose_n_modes, converge_elements_per_segment,
                                 estimated_mode_count, resolved_band, richardson, wave_errors)
from flexfmu.sizing.mesh import _FIRST_MODES_SOLVED, _frequency_of_mode, _unreachable, _wave_numbers  # noqa: F401
from flexfmu.sizing.solid import (MAX_AUTO_MODES, BasisChoice, ModeSearch, auto_basis, kept_message, load_point_rows,
                                  modal_compliance, mode_search, reframe_truncation_errors, residual_vectors,
                                  static_deflections, static_responses)
from flexfmu.sizing.solid import _SHIFT, _select, _static_error, _with_frequencies  # noqa: F401

__all__ = ["A_PRIORI_MARGIN", "CONVERGENCE_ORDER", "FFR_LOAD_GROUPS", "LOAD_PATTERN_NAMES", "MAX_AUTO_MODES",
           "MAX_BAND_MODES", "MAX_ELEMENTS_PER_SEGMENT", "ROUNDOFF_CEILING", "SAFETY_FACTOR", "TOLERANCE_RANGE",
           "BasisChoice", "MeshChoice", "MeshFrequencies", "ModeSearch", "ModelChoice", "StaticCorrection",
           "TruncationChoice", "TruncationEstimate",
           "auto_basis", "check_band", "check_resolvable", "choose_n_modes", "converge_elements_per_segment",
           "dynamic_error_factor", "estimated_mode_count", "ffr_load_patterns", "ffr_static_correction",
           "ffr_truncation_errors", "kept_message", "load_point_rows", "modal_compliance", "mode_search",
           "reframe_truncation_errors", "residual_flexibility", "residual_vectors", "resolved_band", "richardson",
           "static_deflections", "static_responses", "truncation_errors", "wave_errors"]
