"""FFRBeam's step and output maps as polynomials in the held base motion, for the moving-base step
(flexfmu.native.lti_taylor: the exact zero-order hold by the series of the step's exponential on the step's vector).

With the rotation (omega, alpha) held (and a0, with geometric stiffening), FFRBeamDynamics' system x' = A x + g,
x = [eta; eta_dot], has

    A = [[0, I], [-K_eff, -C_eff]],  g = [0; Fm u - sum_ab X_ab P_hat_ab],  u = [F, M, a0] (body frame),

K_eff = Lambda + sum_ab X_ab H_ab (+ the geometric stiffness, linear in X and a0), C_eff = Z + 2 sum_ab W_ab H_ab,
W = [omega]x, X = [alpha]x + W^2: every entry a polynomial of degree <= 2 in p = (omega, alpha) (a0 first with
geometric stiffening).  So are the output maps of FFRBeamDynamics.fast_maps (C, y0: linear in W, X and in
J0 alpha + omega x J0 omega; the static correction adds terms linear in X).  Both are taken from the library's own
maps (system_matrix, modal_force; the simulator's maps of fast_maps, ``output_values``) by
flexfmu.native.lti_taylor.HeldPolynomial: at p = 0 exactly, the rest fitted on the dynamics without its modal
stiffness and damping (FFRBeamDynamics.without_modal_terms: nothing of size omega^2 is differenced), so a step
with new base motion is one product over the monomials in use, not a new exponential and a new fast_maps.
"""
from __future__ import annotations

import numpy as np

from flexfmu.ffr.dynamics import BaseMotion
from flexfmu.native import lti_taylor


class FFRBeamMovingBase:
    """The polynomials of one FFRBeamDynamics (built once per simulator, when the base motion first moves)."""

    def __init__(self, dynamics, output_values):
        """``output_values(dynamics, base)``: the output maps of the held ``base`` as one vector (the simulator's
        assembly of fast_maps), a polynomial of degree <= 2 in p."""
        dyn = dynamics
        self.geometric_stiffening = dyn.geometric_stiffening
        self.m = dyn.m
        self.n_p = 9 if self.geometric_stiffening else 6
        zero = dyn.without_modal_terms()
        rest = np.zeros(self.n_p)
        self.step = lti_taylor.HeldPolynomial.from_samples(lambda p: self._step_values(zero, p), self.n_p,
                                                           self._step_values(dyn, rest))
        self.outputs = lti_taylor.HeldPolynomial.from_samples(lambda p: output_values(zero, self.base(p)), self.n_p,
                                                              output_values(dyn, self.base(rest)))
        #: x' = A x + g with g = [0; Fm [F, M, a0] + f(p)] (flexfmu.native.lti_taylor.HeldSystem: the rule)
        self.system = lti_taylor.HeldSystem(self.step, np.hstack([dyn.load_force_map, dyn.load_moment_map,
                                                                  -dyn.F_a0]))

    def base(self, p) -> BaseMotion:
        """The BaseMotion of the held p (omega, alpha; a0 first with geometric stiffening, else zero)."""
        p = np.asarray(p, dtype=float)
        a0 = p[:3].copy() if self.geometric_stiffening else np.zeros(3)
        return BaseMotion(a0=a0, omega=p[-6:-3].copy(), alpha=p[-3:].copy())

    def _step_values(self, dyn, p) -> np.ndarray:
        base = self.base(p)
        rotation_only = BaseMotion(a0=np.zeros(3), omega=base.omega, alpha=base.alpha)   # a0 is an input (Fm)
        zero = np.zeros(3)
        return np.concatenate([dyn.system_matrix(base).ravel(), dyn.modal_force(zero, zero, rotation_only)])
