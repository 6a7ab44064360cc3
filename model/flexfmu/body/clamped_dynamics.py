"""Time integration and outputs of a clamped body on a moving base (flexfmu.body.clamped, Eqs. (B2), (B4)-(B6)),
from the reduced model alone (flexfmu.body.model.FlexBody).

With the base motion (a0, w, alpha) and the interface loads held over a step, (B2) is a linear system with
constant matrices, x' = A x + [0; r], x = [eta; eta_d]: advanced exactly by the augmented matrix exponential
(zero-order hold, as flexfmu.ffr.dynamics), cached per step size and held base rotation.  For a held base rotation
the modal force and the outputs are affine in the state and the loads too (bar two bilinear moment terms):
:meth:`ClampedDynamics.held_maps` multiplies them out once per rotation, for the per-step path.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from flexfmu.core.blas import single_thread
from flexfmu.core.cache import BoundedCache
from flexfmu.core.step_size import StepSizes
from flexfmu.core.vec3 import cross, skew
from flexfmu.native import lti_taylor

#: step maps memoised per instance (key: step size, w, alpha); starts afresh when full (inputs varying every step)
MAP_MEMO_SIZE = 65


class ClampedDynamics:
    """(B2) and its outputs for the arrays of :func:`flexfmu.body.clamped.clamped_invariants` (``inv``), the
    retained coordinates' eigenvalues omega^2 (m,), the damping ratio and the interfaces: ``rows`` a list of
    (6, m) maps D Phi_patch (translation, rotation of the point per coordinate), ``points`` (n_if, 3) and
    ``moments`` (n_if,) bools."""

    def __init__(self, inv: dict, eigenvalues: np.ndarray, damping_ratio: float, rows, points, moments):
        self.inv = inv
        self.lam = np.asarray(eigenvalues, dtype=float)
        self.m = self.lam.size
        self.zeta = float(damping_ratio)
        self.damping = 2.0 * self.zeta * np.sqrt(np.maximum(self.lam, 0.0))
        self.rows = [np.asarray(r, dtype=float) for r in rows]
        self.points = np.asarray(points, dtype=float).reshape(-1, 3)
        self.moments = [bool(x) for x in moments]
        self.mass = float(inv["mass"])
        self.mc = inv["first_moment"]
        self.J0 = inv["J0"]
        self._maps = BoundedCache(MAP_MEMO_SIZE)
        self._steps = StepSizes()              # the step sizes of the maps' keys (flexfmu.core.step_size)

    def without_modal_terms(self) -> "ClampedDynamics":
        """This model with the eigenvalues and the damping set to zero (a shallow copy with its own caches): what
        the base rotation adds to (B2) and to the held maps, without the large omega^2 they would be differenced
        against (MovingBase fits the maps' polynomial in the rotation on it)."""
        other = copy.copy(self)
        other.lam = np.zeros(self.m)
        other.damping = np.zeros(self.m)
        other._maps = BoundedCache(MAP_MEMO_SIZE)
        other._steps = StepSizes()
        return other

    # ---------------------------------------------------------------- (B2)
    def matrices(self, w, alpha):
        """K_eff = Lambda + H and C_eff = Z + G of (B2) for the held base rotation."""
        B, N = self.inv["B"], self.inv["N"]
        K = np.diag(self.lam) + np.einsum("k,kij->ij", alpha, B) - np.einsum("k,l,klij->ij", w, w, N)
        C = np.diag(self.damping) + np.einsum("k,kij->ij", w, B - B.transpose(0, 2, 1))
        return K, C

    def system_matrix(self, w, alpha) -> np.ndarray:
        """A of x' = A x + [0; r], x = [eta; eta_d], for the held base rotation (2m, 2m): what :meth:`transition`
        advances exactly."""
        m = self.m
        K, C = self.matrices(w, alpha)
        A = np.zeros((2 * m, 2 * m))
        A[:m, m:] = np.eye(m)
        A[m:, :m] = -K
        A[m:, m:] = -C
        return A

    def modal_force(self, loads, a0, w, alpha) -> np.ndarray:
        """Right side of (B2): loads (n_if, 6) [F, M] per interface, body frame."""
        r = -self.inv["Sa"] @ a0 - self.inv["Sw"] @ alpha + np.einsum("k,l,klj->j", w, w, self.inv["R"])
        for D, ld, mom in zip(self.rows, loads, self.moments):
            r += D[:3].T @ ld[:3]
            if mom:
                r += D[3:].T @ ld[3:]
        return r

    def transition(self, h: float, w, alpha):
        """(Ad, Bd): x(t + h) = Ad x(t) + Bd r for r held (exact), cached per (h, w, alpha); a step within
        STEP_RTOL of one already seen uses that step's maps (flexfmu.core.step_size, with the error bound)."""
        h = self._steps.canonical(h)
        key = (h,) + tuple(w) + tuple(alpha)
        hit = self._maps.get(key)
        if hit is not None:
            return hit
        m = self.m
        K, C = self.matrices(w, alpha)
        A = np.zeros((3 * m, 3 * m))          # [[A, B], [0, 0]] with B = [0; I]: e^{Ah} and int e^{As} ds B
        A[:m, m:2 * m] = np.eye(m)
        A[m:2 * m, :m] = -K
        A[m:2 * m, m:2 * m] = -C
        A[m:2 * m, 2 * m:] = np.eye(m)
        with single_thread():
            E = sla.expm(A * h)
        hit = self._maps[key] = (E[:2 * m, :2 * m].copy(), E[:2 * m, 2 * m:].copy())
        return hit

    def step(self, x: np.ndarray, h: float, loads, a0, w, alpha) -> np.ndarray:
        """x = [eta; eta_d] after h (s) with everything held."""
        Ad, Bd = self.transition(float(h), tuple(np.asarray(w, float).tolist()),
                                 tuple(np.asarray(alpha, float).tolist()))
        return Ad @ x + Bd @ self.modal_force(loads, a0, w, alpha)

    def acceleration(self, x, loads, a0, w, alpha) -> np.ndarray:
        K, C = self.matrices(w, alpha)
        m = self.m
        return self.modal_force(loads, a0, w, alpha) - C @ x[m:] - K @ x[:m]

    def static(self, loads, a0, w, alpha) -> np.ndarray:
        """Equilibrium x = [eta; 0] of (B2) for held inputs (K_eff eta = r)."""
        K, _ = self.matrices(w, alpha)
        return np.concatenate([np.linalg.solve(K, self.modal_force(loads, a0, w, alpha)), np.zeros(self.m)])

    # ---------------------------------------------------------------- outputs
    def interface_motion(self, x, eta_dd, a0, w, alpha):
        """Per interface: position x_I + u_I, elastic velocity u_I_d (relative to the base) and absolute
        acceleration (accelerometer) in body components, shape (n_if, 3, 3)."""
        m = self.m
        out = np.empty((len(self.rows), 3, 3))
        for i, D in enumerate(self.rows):
            y = self.points[i] + D[:3] @ x[:m]
            v = D[:3] @ x[m:]
            out[i, 0] = y
            out[i, 1] = v
            out[i, 2] = (a0 + cross(alpha, y) + cross(w, cross(w, y)) + 2.0 * cross(w, v) + D[:3] @ eta_dd)
        return out

    def _field(self, f: int, eta, eta_d, eta_dd, w, alpha) -> np.ndarray:
        """V^T f1 of (B6) for the test field f (0: T, 1: S0)."""
        inv = self.inv
        Va, Vq, Vr = inv["Va"][f], inv["Vq"][f], inv["Vr"][f]
        return (inv["Vp"][f] @ eta_dd + np.einsum("k,kcj,j->c", alpha, Va, eta) + np.einsum("k,kcj,j->c", w, Va, eta_d)
                - np.einsum("k,l,klcj,j->c", w, w, Vq, eta) - np.einsum("k,kcj,j->c", w, Vr, eta_d))

    def reactions(self, x, eta_dd, loads, a0, w, alpha):
        """Force and moment (about the body origin O) the structure exerts on its clamps, body frame: (B4)-(B6)."""
        m = self.m
        eta, eta_d = x[:m], x[m:]
        mc, J0 = self.mc, self.J0
        F_in = self.mass * a0 + cross(alpha, mc) + cross(w, cross(w, mc)) + self._field(0, eta, eta_d, eta_dd, w, alpha)
        c = np.concatenate([a0, alpha, np.outer(w, w).ravel()])       # weights of the 15 base patterns
        M_in = (cross(mc, a0) + J0 @ alpha + cross(w, J0 @ w) + self._field(1, eta, eta_d, eta_dd, w, alpha)
                + np.einsum("p,pcj,j->c", c, self.inv["arm"], eta))
        F_ext, M_ext = np.zeros(3), np.zeros(3)
        for i, (D, ld) in enumerate(zip(self.rows, loads)):
            F_ext += ld[:3]
            M_ext += cross(self.points[i] + D[:3] @ eta, ld[:3])
            if self.moments[i]:
                M_ext += ld[3:]
        return F_ext - F_in, M_ext - M_in

    # ---------------------------------------------------------------- affine maps of a held base rotation
    def n_loads(self) -> int:
        """Length of the load vector ul = [F_1, M_1, F_2, M_2, ..., a0]: each interface's force (N) and, where it
        carries one, its moment (N.m), then the base acceleration a0 (m/s^2), body frame."""
        return sum(6 if mom else 3 for mom in self.moments) + 3

    def held_maps(self, w, alpha) -> "HeldMaps":
        """(B2) and the outputs of :meth:`interface_motion` and :meth:`reactions` as maps of the state
        x = [eta; eta_d] and the load vector ul (:meth:`n_loads`) for the held base rotation w (rad/s), alpha
        (rad/s^2), body frame: what depends on the model and the rotation alone is multiplied out here once, so
        that a step and its outputs are a few matrix-vector products.  The same formulas as those methods,
        regrouped: the results differ from theirs in rounding only."""
        w = np.asarray(w, dtype=float)
        alpha = np.asarray(alpha, dtype=float)
        inv, m, n_if = self.inv, self.m, len(self.rows)
        nl = self.n_loads()
        a0_cols = slice(nl - 3, nl)
        eye3 = np.eye(3)
        K, C = self.matrices(w, alpha)

        # right side of (B2): r = force ul + force0 (modal_force)
        force = np.zeros((self.m, nl))
        force_cols, moment_cols, k = [], [], 0
        for D, mom in zip(self.rows, self.moments):
            force[:, k:k + 3] = D[:3].T
            force_cols.append(slice(k, k + 3))
            k += 3
            moment_cols.append(slice(k, k + 3) if mom else None)
            if mom:
                force[:, k:k + 3] = D[3:].T
                k += 3
        force[:, a0_cols] = -inv["Sa"]
        force0 = -inv["Sw"] @ alpha + np.einsum("k,l,klj->j", w, w, inv["R"])
        # eta_dd = acc_x x + force ul + force0 (acceleration)
        acc_x = np.hstack([-K, -C])

        ny = 9 * n_if + 6
        Cx, Cu, y0 = np.zeros((ny, 2 * m)), np.zeros((ny, nl)), np.zeros(ny)
        W = skew(w)
        rotation = skew(alpha) + W @ W                # y -> alpha x y + w x (w x y)
        for i, D in enumerate(self.rows):             # interface_motion: position, velocity, acceleration
            T, point, row = D[:3], self.points[i], 9 * i
            Cx[row:row + 3, :m] = T
            y0[row:row + 3] = point
            Cx[row + 3:row + 6, m:] = T
            acc = slice(row + 6, row + 9)
            Cx[acc] = T @ acc_x
            Cx[acc, :m] += rotation @ T
            Cx[acc, m:] += 2.0 * W @ T
            Cu[acc] = T @ force
            Cu[acc, a0_cols] += eye3
            y0[acc] = rotation @ point + T @ force0

        # reactions: F = F_ext - F_in, M = M_ext - M_in, each V^T f1 field (_field) affine in x through eta_dd
        fields = []
        for f in (0, 1):
            Va, Vq, Vr, Vp = inv["Va"][f], inv["Vq"][f], inv["Vr"][f], inv["Vp"][f]
            direct = np.hstack([np.einsum("k,kcj->cj", alpha, Va) - np.einsum("k,l,klcj->cj", w, w, Vq),
                                np.einsum("k,kcj->cj", w, Va) - np.einsum("k,kcj->cj", w, Vr)])
            fields.append((direct + Vp @ acc_x, Vp @ force, Vp @ force0))
        mc, J0 = self.mc, self.J0
        F, M = slice(9 * n_if, 9 * n_if + 3), slice(9 * n_if + 3, 9 * n_if + 6)
        field_x, field_u, field_0 = fields[0]
        Cx[F] = -field_x
        Cu[F] = -field_u
        Cu[F, a0_cols] -= self.mass * eye3
        y0[F] = -(cross(alpha, mc) + cross(w, cross(w, mc))) - field_0
        field_x, field_u, field_0 = fields[1]
        arm = inv["arm"]                              # base patterns [a0, alpha, w w^T (row-major)]
        held_arm = np.einsum("p,pcj->cj", np.concatenate([alpha, np.outer(w, w).ravel()]), arm[3:])
        Cx[M] = -field_x
        Cx[M, :m] -= held_arm
        Cu[M] = -field_u
        Cu[M, a0_cols] -= skew(mc)                    # mc x a0
        y0[M] = -(J0 @ alpha + cross(w, J0 @ w)) - field_0

        # F_ext = sum F_I; M_ext = sum (x_I + u_I) x F_I + M_I: x_I x F_I is linear in ul, u_I x F_I (u_I = T eta)
        # and the a0 arm patterns' moment are bilinear in eta and ul: M += ul @ (moment_arm @ eta).reshape(nl, 3)
        moment_arm = np.zeros((nl, 3, m))
        for i, D in enumerate(self.rows):
            Cu[F, force_cols[i]] += eye3
            Cu[M, force_cols[i]] += skew(self.points[i])
            if moment_cols[i] is not None:
                Cu[M, moment_cols[i]] += eye3
            for a in range(3):                        # (T eta) x e_a = -e_a x (T eta)
                moment_arm[force_cols[i].start + a] = -skew(eye3[a]) @ D[:3]
        moment_arm[a0_cols] = -arm[:3]
        return HeldMaps(force, force0, np.ascontiguousarray(Cx), np.ascontiguousarray(Cu), y0,
                        moment_arm.reshape(nl * 3, m), M)


@dataclass(frozen=True, slots=True)
class HeldMaps:
    """ClampedDynamics.held_maps: for x = [eta; eta_d] and the load vector ul (ClampedDynamics.n_loads), body frame,

        r = force @ ul + force0                  (the right side of (B2), N per modal coordinate)
        y = Cx @ x + Cu @ ul + y0,  y[moment] += ul @ (moment_arm @ eta).reshape(-1, 3)

    y: per interface its position (m), elastic velocity (m/s), absolute acceleration (m/s^2), then the reaction
    force (N) and moment about the body origin (N.m), as ClampedDynamics.interface_motion and reactions."""

    force: np.ndarray
    force0: np.ndarray
    Cx: np.ndarray
    Cu: np.ndarray
    y0: np.ndarray
    moment_arm: np.ndarray
    moment: slice


class MovingBase:
    """(B2) and the held maps as polynomials of degree <= 2 in the held base rotation p = (w, alpha) (rad/s,
    rad/s^2, body frame), for the moving-base step (flexfmu.native.lti_taylor): K and C are linear in alpha, w and
    w w^T, the modal force's force0 and every held map (ClampedDynamics.held_maps) too.  At p = 0 they are the
    model's own; the rest is fitted (flexfmu.native.lti_taylor.HeldPolynomial) on the model without its eigenvalues
    and damping (ClampedDynamics.without_modal_terms), so nothing of size omega^2 is differenced.  ``output_values
    (dynamics, w, alpha)``: the engine's output maps of the held rotation as one vector."""

    N_P = 6

    def __init__(self, dynamics: ClampedDynamics, output_values):
        dyn = dynamics
        self.m = dyn.m
        zero = dyn.without_modal_terms()
        rest = np.zeros(self.N_P)
        self.step = lti_taylor.HeldPolynomial.from_samples(lambda p: self._step_values(zero, p), self.N_P,
                                                           self._step_values(dyn, rest))
        self.outputs = lti_taylor.HeldPolynomial.from_samples(lambda p: output_values(zero, p[:3], p[3:]),
                                                              self.N_P, output_values(dyn, rest[:3], rest[3:]))
        at_rest = dyn.held_maps(rest[:3], rest[3:])
        #: the parts of the held maps that do not depend on the rotation
        self.force, self.moment_arm, self.moment = at_rest.force, at_rest.moment_arm, at_rest.moment
        #: x' = A x + g, g = [0; force ul + force0(p)] (flexfmu.native.lti_taylor.HeldSystem: the rule)
        self.system = lti_taylor.HeldSystem(self.step, self.force)

    @staticmethod
    def _step_values(dyn, p) -> np.ndarray:
        w, alpha = p[:3], p[3:]
        force0 = dyn.modal_force(np.zeros((len(dyn.rows), 6)), np.zeros(3), w, alpha)
        return np.concatenate([dyn.system_matrix(w, alpha).ravel(), force0])
