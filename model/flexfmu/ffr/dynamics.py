"""Elastic vibration of a clamped FFR beam structure on a moving base (floating frame).

Derivation (linear FFR, Shabana's inertia shape integrals; all vectors in body components).
A point of the rod is at u = u0 + S q from the frame origin.  Its absolute acceleration is

    a = a0 + alpha x u + omega x (omega x u) + 2 omega x S q_dot + S q_ddot,

with a0 the frame origin's acceleration and omega, alpha the frame's angular velocity and
acceleration.  Virtual work  int rho dq^T S^T a dV + dq^T (K q + C q_dot) = dq^T Q  gives

    M q_ddot + (C + 2 sum_ab W_ab M_ab) q_dot + (K + sum_ab X_ab M_ab) q
        = Q - S_bar^T a0 - sum_ab X_ab P_ab,                                  (*)

with W = [omega]x, X = [alpha]x + [omega]x^2 and the inertia shape integrals

    S_bar = int rho S dV (3, n),  P_ab = int rho S_a^T u0_b dV (n,),  M_ab = int rho S_a^T S_b dV (n, n)

(S_a = row a of S).  The centre-line mass carries these couplings; the small rotary
inertia of the cross-sections (rho*Ip, in M) is left out of them (relative size
d^2 / (8 L^2) ~ 1e-4 for the specimen).  In modal coordinates q = Phi eta (mass-normalised
modes of the clamped structure) (*) becomes an m x m system with constant matrices while
(a0, omega, alpha) are held, which is what a co-simulation step does (zero-order hold):
it is advanced exactly with the matrix exponential (no step-size limit).  ``integrator="rk4"``
advances the same held-input system x' = A x + B u, x = [eta; eta_dot], by one classical RK4 step
instead, as matrices (stable only for h <= :meth:`FFRBeamDynamics.rk4_step_limit`):

    x+ = Ad x + Bd u,   Ad = I + hA + (hA)^2/2 + (hA)^3/6 + (hA)^4/24,
                        Bd = h (I + hA/2 + (hA)^2/6 + (hA)^3/24) B.

Geometric stiffening (``geometric_stiffening=True``): (*) is linear about the *unstressed* rod, so it
keeps the centrifugal softening X_ab M_ab but not the stiffening by the stress that the same inertial load
induces; a cantilever spun past its first bending frequency then diverges.  The option adds the geometric
stiffness of the quasi-static prestress of the held inertial load -rho (a0 + X u0)
(flexfmu.ffr.geometric_stiffness, Eqs. (1)-(4) there), in modal coordinates:

    K_eff = Lambda + sum_ab X_ab M_ab_hat + sum_ab X_ab G_ab_hat + sum_a a0_a G_a_hat,     G_hat = Phi^T G Phi.

K_eff then depends on a0 as well: the step maps are cached per (h, omega, alpha, a0).

Reactions: Newton-Euler for the whole rod gives what the structure exerts on its clamps
(body frame, about the frame origin):

    F_on_base = F_ext - int rho a dV,   M_on_base = M_ext + r_F x F_ext - int rho u x a dV,

evaluated to first order in q (the elastic motion is small by assumption).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from flexfmu.core.blas import single_thread
from flexfmu.core.cache import BoundedCache
from flexfmu.ffr.assembly import BeamModel
from flexfmu.errors import require
from flexfmu.ffr.ffrbeam_config import GAUGE_SLOTS
from flexfmu.ffr.gauges import GaugeSections
from flexfmu.ffr.geometric_stiffness import inertial_geometric_stiffness
from flexfmu.ffr.kinematics import point_shape
from flexfmu.linalg.modal import Modes
from flexfmu.core.vec3 import cross as _cross
from flexfmu.core.vec3 import skew as _skew

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)   # exact for the degree-6 products of cubic translations
INTEGRATORS = ("exact", "rk4")
#: Classical RK4 is stable for h |lambda| up to 2 sqrt(2) = 2.83 on the imaginary axis (undamped modes) and
#: 2.79 on the negative real axis; 2.8 is the limit used for lightly damped modes (as flexfmu.reframe.integrator's).
RK4_STABILITY_LIMIT = 2.8
#: Step and output maps memoised per instance (keys: step size and held base motion): inputs that vary every
#: step would grow the memo without bound, so it starts afresh when it holds this many.
MAP_MEMO_SIZE = 65


@dataclass
class InertiaIntegrals:
    """Inertia shape integrals of the rod's centre line (unconstrained DOFs, body frame).

    mass (kg); first_moment = int rho u0 dV (kg m); J0 = int rho (|u0|^2 I - u0 u0^T) dV (kg m^2);
    S_bar (3, n); P (3, 3, n) with P[a, b] = int rho S_a^T u0_b; M_ab[a][b] sparse (n, n).
    """

    mass: float
    first_moment: np.ndarray
    J0: np.ndarray
    S_bar: np.ndarray
    P: np.ndarray
    M_ab: list


def inertia_integrals(model: BeamModel) -> InertiaIntegrals:
    """Gauss quadrature (4 points per element) of the integrals above, plus point masses."""
    mesh, sec, mat = model.mesh, model.mesh.scene.section, model.mesh.scene.material
    shape_functions = mesh.element.shape_functions
    n = model.n_dof
    n_el = len(mesh.elements)
    rhoA = mat.rho * sec.A
    # Body-frame translational shape rows at every Gauss point: (n_el, n_gp, 3, 12)
    S_gp = np.empty((n_el, len(_GAUSS_X), 3, 12))
    x0_gp = np.empty((n_el, len(_GAUSS_X), 3))
    w_gp = np.empty((n_el, len(_GAUSS_X)))
    for g, (xg, wg) in enumerate(zip(_GAUSS_X, _GAUSS_W)):
        xi = 0.5 * (xg + 1.0)
        for e in range(n_el):
            L = mesh.element_length[e]
            C = mesh.element_rotation[e]
            S_gp[e, g] = C @ shape_functions(xi, L, sec, mat)[:3] @ np.kron(np.eye(4), C.T)
        n1, n2 = mesh.elements[:, 0], mesh.elements[:, 1]
        x0_gp[:, g] = (1 - xi) * mesh.nodes[n1] + xi * mesh.nodes[n2]
        w_gp[:, g] = rhoA * 0.5 * wg * mesh.element_length
    dofs = (6 * mesh.elements[:, :, None] + np.arange(6)).reshape(-1, 12)

    S_bar = np.zeros((3, n))
    np.add.at(S_bar.T, dofs, np.einsum("eg,egak->eka", w_gp, S_gp))
    P = np.zeros((3, 3, n))
    contrib = np.einsum("eg,egak,egb->eabk", w_gp, S_gp, x0_gp)     # (n_el, 3, 3, 12)
    for a in range(3):
        for b in range(3):
            np.add.at(P[a, b], dofs, contrib[:, a, b])
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    M_ab = [[sp.csr_matrix((np.einsum("eg,egk,egl->ekl", w_gp, S_gp[:, :, a], S_gp[:, :, b]).ravel(),
                            (rows, cols)), shape=(n, n)) for b in range(3)] for a in range(3)]
    mass = float(w_gp.sum())
    first = np.einsum("eg,egb->b", w_gp, x0_gp)
    J0 = np.einsum("eg,egk,egk->", w_gp, x0_gp, x0_gp) * np.eye(3) - np.einsum("eg,ega,egb->ab", w_gp, x0_gp, x0_gp)
    for pm in mesh.scene.point_masses:
        node = mesh.node_at(pm.s, "point_masses.s")
        r = mesh.nodes[node]
        mass += pm.mass
        first = first + pm.mass * r
        J0 = J0 + pm.mass * (r @ r * np.eye(3) - np.outer(r, r))
        for a in range(3):
            S_bar[a, 6 * node + a] += pm.mass
            for b in range(3):
                P[a, b, 6 * node + a] += pm.mass * r[b]
                M_ab[a][b] = M_ab[a][b] + sp.csr_matrix(([pm.mass], ([6 * node + a], [6 * node + b])), shape=(n, n))
    return InertiaIntegrals(mass, first, J0, S_bar, P, M_ab)


@dataclass
class BaseMotion:
    """Floating-frame (base) motion held over a step, body frame: a0 (m/s^2), omega (rad/s), alpha (rad/s^2)."""

    a0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    omega: np.ndarray = field(default_factory=lambda: np.zeros(3))
    alpha: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def key(self) -> tuple:
        return tuple(np.concatenate([self.omega, self.alpha]).tolist())


@dataclass
class ModalState:
    """Explicit state: modal coordinates eta, their rates eta_dot, and time t (s)."""

    eta: np.ndarray
    eta_dot: np.ndarray
    t: float = 0.0

    def copy(self) -> "ModalState":
        return ModalState(self.eta.copy(), self.eta_dot.copy(), self.t)


class FFRBeamDynamics:
    """Modal time integration of a clamped beam structure on a moving base.

    model: the constrained BeamModel; modes: its retained modes (shapes on the free DOFs);
    damping_ratio: modal damping zeta (each mode gets 2 zeta omega_i);
    load_s / sensor_s: arc lengths (m) of the load point and of the sensor.
    integrator: "exact" (zero-order-hold matrix exponential, default) or "rk4" (one classical RK4 step
    of the same held-input system, see the module docstring).
    geometric_stiffening: add the geometric stiffness of the prestress of the held inertial load.
    gauge_s: the strain gauges' arc lengths (m; None = no gauge), mesh nodes (flexfmu.ffr.gauges).
    """

    def __init__(self, model: BeamModel, modes: Modes, damping_ratio: float, load_s: float, sensor_s: float,
                 tip_s: float | None = None, *, integrator: str = "exact", geometric_stiffening: bool = False,
                 gauge_s: tuple = (None,) * GAUGE_SLOTS):
        require(np.isfinite(damping_ratio) and 0.0 <= damping_ratio < 1.0, "damping_ratio",
                f"got {damping_ratio!r}", "0 <= damping_ratio < 1")
        require(integrator in INTEGRATORS, "integrator", f"got {integrator!r}", " | ".join(INTEGRATORS))
        require(isinstance(geometric_stiffening, (bool, np.bool_)), "geometric_stiffening",
                f"got {geometric_stiffening!r}", "True | False")
        self.integrator = integrator
        self.geometric_stiffening = bool(geometric_stiffening)
        require(model.clamped_nodes.size > 0, "boundary", "the structure has no clamp",
                "a boundary that clamps at least one point (XFF | XFX | FXF | FXF_mid or scene clamps)")
        self.model, self.modes, self.damping_ratio = model, modes, float(damping_ratio)
        scene = model.mesh.scene
        Phi = model.B2 @ modes.shapes                          # (n_dof, m) on all DOFs, zeros at clamps
        self.Phi = Phi
        self.m = Phi.shape[1]
        self.omega_n = modes.omega
        self.stiffness = self.omega_n**2                       # Lambda (mass-normalised)
        self.damping = 2.0 * self.damping_ratio * self.omega_n
        ints = inertia_integrals(model)
        self.integrals = ints
        self.F_a0 = Phi.T @ ints.S_bar.T                        # (m, 3): Phi^T S_bar^T
        self.P_hat = np.einsum("abn,nk->abk", ints.P, Phi)     # (3, 3, m)
        self.H_hat = np.array([[Phi.T @ (ints.M_ab[a][b] @ Phi) for b in range(3)] for a in range(3)])
        self.S_bar_hat = ints.S_bar @ Phi                       # (3, m): int rho S Phi
        self.load = point_shape(model.mesh, load_s, "load_s")
        self.sensor = point_shape(model.mesh, sensor_s, "sensor_s")
        self.tip = point_shape(model.mesh, scene.total_length if tip_s is None else tip_s, "tip_s")
        n = model.n_dof
        self.load_force_map = Phi.T @ self.load.full_translation(n).T   # (m, 3)
        self.load_moment_map = Phi.T @ self.load.full_rotation(n).T     # (m, 3)
        self.sensor_map = self.sensor.full_translation(n) @ Phi          # (3, m)
        self.tip_map = self.tip.full_translation(n) @ Phi
        self.load_disp_map = self.load.full_translation(n) @ Phi         # (3, m)
        # Reaction integrals in modal coordinates: int rho S q = S_bar_hat eta; the cross integrals
        # int rho u0 x (S q) etc. go through P_hat (3, 3, m).
        self.gauges = GaugeSections(model, Phi, tuple(gauge_s))     # the section forces' rows of fast_maps
        if self.geometric_stiffening:
            # G_X_hat (3, 3, m, m) per unit X_ab, G_a0_hat (3, m, m) per unit a0_a (kg, kg/m)
            self.G_X_hat, self.G_a0_hat = inertial_geometric_stiffness(model).modal(Phi)
        self._cache = BoundedCache(MAP_MEMO_SIZE)
        self._fast_cache = BoundedCache(MAP_MEMO_SIZE)

    def with_damping(self, damping_ratio: float) -> "FFRBeamDynamics":
        """This model with another modal damping ratio: a shallow copy sharing the model data, with its own map
        caches.  Any finite value (flexfmu.native.lti samples the maps' dependence on it around 0)."""
        require(np.isfinite(damping_ratio), "damping_ratio", f"got {damping_ratio!r}", "a finite number")
        other = copy.copy(self)
        other.damping_ratio = float(damping_ratio)
        other.damping = 2.0 * other.damping_ratio * self.omega_n
        other._cache = BoundedCache(MAP_MEMO_SIZE)
        other._fast_cache = BoundedCache(MAP_MEMO_SIZE)
        return other

    def without_modal_terms(self) -> "FFRBeamDynamics":
        """This model with the modal stiffness and damping set to zero (a shallow copy with its own map caches):
        what the base motion adds to the maps, and the terms that do not depend on the modes' frequencies, without
        the large Lambda (~omega^2) they would be differenced against (flexfmu.ffr.moving_base fits the maps'
        polynomial in the held base motion on it)."""
        other = copy.copy(self)
        other.stiffness = np.zeros(self.m)
        other.damping = np.zeros(self.m)
        other._cache = BoundedCache(MAP_MEMO_SIZE)
        other._fast_cache = BoundedCache(MAP_MEMO_SIZE)
        return other

    # ------------------------------------------------------------ equations of motion
    def _matrices(self, base: BaseMotion) -> tuple[np.ndarray, np.ndarray]:
        """Modal stiffness and damping of (*) for the held base rotation."""
        W = _skew(base.omega)
        X = _skew(base.alpha) + W @ W
        K_eff = np.diag(self.stiffness) + np.einsum("ab,abij->ij", X, self.H_hat)
        if self.geometric_stiffening:
            K_eff = (K_eff + np.einsum("ab,abij->ij", X, self.G_X_hat)
                     + np.einsum("a,aij->ij", np.asarray(base.a0, float), self.G_a0_hat))
        C_eff = np.diag(self.damping) + 2.0 * np.einsum("ab,abij->ij", W, self.H_hat)
        return K_eff, C_eff

    def _base_key(self, base: BaseMotion) -> tuple:
        """Cache key of the held base motion: what K_eff and C_eff depend on."""
        if self.geometric_stiffening:
            return base.key() + tuple(np.asarray(base.a0, float).tolist())
        return base.key()

    def system_matrix(self, base: BaseMotion) -> np.ndarray:
        """A of x' = A x + B u, x = [eta; eta_dot], for the held base motion (2m, 2m)."""
        m = self.m
        K_eff, C_eff = self._matrices(base)
        A = np.zeros((2 * m, 2 * m))
        A[:m, m:] = np.eye(m)
        A[m:, :m] = -K_eff
        A[m:, m:] = -C_eff
        return A

    def rk4_step_limit(self, base: BaseMotion) -> float:
        """Largest step (s) for which RK4 is stable on the held system: RK4_STABILITY_LIMIT / max |eig(A)|
        (inf without modes).  Beyond it the highest mode grows every step."""
        if self.m == 0:
            return float("inf")
        return RK4_STABILITY_LIMIT / float(np.max(np.abs(np.linalg.eigvals(self.system_matrix(base)))))

    def modal_force(self, force_body, moment_body, base: BaseMotion) -> np.ndarray:
        """Right-hand side of (*) in modal coordinates."""
        X = _skew(base.alpha) + _skew(base.omega) @ _skew(base.omega)
        return (self.load_force_map @ force_body + self.load_moment_map @ moment_body
                - self.F_a0 @ base.a0 - np.einsum("ab,abk->k", X, self.P_hat))

    def acceleration(self, state: ModalState, force_body, moment_body, base: BaseMotion) -> np.ndarray:
        K_eff, C_eff = self._matrices(base)
        return self.modal_force(force_body, moment_body, base) - C_eff @ state.eta_dot - K_eff @ state.eta

    # ------------------------------------------------------------ exact zero-order-hold step
    def _transition(self, h: float, base: BaseMotion) -> tuple[np.ndarray, np.ndarray]:
        key = (h, self._base_key(base))
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        m = self.m
        if self.integrator == "rk4":
            hA = h * self.system_matrix(base)
            I = np.eye(2 * m)
            P = I + hA @ (I / 2 + hA @ (I / 6 + hA / 24))     # I + hA/2 + (hA)^2/6 + (hA)^3/24
            Ad = I + hA @ P
            Bd = h * P[:, m:]                                 # h P B with B = [0; I]
            self._cache[key] = (Ad, Bd)
            return Ad, Bd
        K_eff, C_eff = self._matrices(base)
        A = np.zeros((2 * m + 1 + m, 2 * m + 1 + m))
        # Augmented exponential [[A, B], [0, 0]] gives e^{Ah} and int_0^h e^{As} ds B for B = [0; I].
        A[:m, m:2 * m] = np.eye(m)
        A[m:2 * m, :m] = -K_eff
        A[m:2 * m, m:2 * m] = -C_eff
        A[m:2 * m, 2 * m + 1:] = np.eye(m)
        with single_thread():        # a small matrix: BLAS threads only slow it down (flexfmu.core.blas)
            E = sla.expm(A[:, :] * h)
        Ad = E[:2 * m, :2 * m]
        Bd = E[:2 * m, 2 * m + 1:]
        self._cache[key] = (Ad, Bd)
        return Ad, Bd

    def step(self, state: ModalState, h: float, force_body, moment_body, base: BaseMotion) -> ModalState:
        """Advance by h (s) with force, moment and base motion held constant (exact for that input; one
        RK4 step with integrator="rk4")."""
        require(np.isfinite(h) and h > 0, "step size", f"got {h!r}", "> 0 s")
        Ad, Bd = self._transition(float(h), base)
        x = Ad @ np.concatenate([state.eta, state.eta_dot]) + Bd @ self.modal_force(force_body, moment_body, base)
        return ModalState(x[:self.m], x[self.m:], state.t + h)

    def static_response(self, force_body, moment_body, base: BaseMotion) -> ModalState:
        """Equilibrium of (*) for constant inputs: K_eff eta = rhs (eta_dot = 0)."""
        K_eff, _ = self._matrices(base)
        eta = np.linalg.solve(K_eff, self.modal_force(force_body, moment_body, base))
        return ModalState(eta, np.zeros(self.m), 0.0)

    # ------------------------------------------------------------ outputs
    def initial_state(self) -> ModalState:
        return ModalState(np.zeros(self.m), np.zeros(self.m), 0.0)

    def sensor_motion(self, state: ModalState, eta_ddot: np.ndarray, base: BaseMotion) -> tuple:
        """Sensor elastic displacement and velocity, and total (accelerometer) acceleration, body frame."""
        u_el = self.sensor_map @ state.eta
        v_el = self.sensor_map @ state.eta_dot
        a_el = self.sensor_map @ eta_ddot
        u = self.sensor.undeformed_body + u_el
        w, al = base.omega, base.alpha
        a = base.a0 + _cross(al, u) + _cross(w, _cross(w, u)) + 2 * _cross(w, v_el) + a_el
        return u_el, v_el, a

    def reactions(self, state: ModalState, eta_ddot: np.ndarray, force_body, moment_body,
                  base: BaseMotion) -> tuple[np.ndarray, np.ndarray]:
        """Force and moment (about the frame origin) the structure exerts on its clamps, body frame."""
        ints = self.integrals
        w, al = base.omega, base.alpha
        q = self.Phi @ state.eta
        q_dot = self.Phi @ state.eta_dot
        q_ddot = self.Phi @ eta_ddot
        s_u = ints.first_moment + ints.S_bar @ q                  # int rho u
        s_v = ints.S_bar @ q_dot
        s_a = ints.S_bar @ q_ddot
        momentum_rate = (ints.mass * base.a0 + _cross(al, s_u) + _cross(w, _cross(w, s_u))
                         + 2 * _cross(w, s_v) + s_a)
        force_on_base = np.asarray(force_body, float) - momentum_rate
        # int rho u x a to first order in q.  T[b, c] = int rho x_b y_c turns into int rho x cross y
        # by _cross_integral; Pq[a, b] = int rho (S q)_a u0_b.
        Pq, Pqd, Pqdd = (np.einsum("abn,n->ab", ints.P, v) for v in (q, q_dot, q_ddot))
        W = _skew(w)
        X = _skew(al) + W @ W
        moment_rate = (ints.J0 @ al + _cross(w, ints.J0 @ w)   # int rho u0 x (X u0)
                       + _cross_integral(Pq @ X.T)               # int rho (S q) x (X u0)
                       + _cross_integral((X @ Pq).T)             # int rho u0 x (X S q)
                       + _cross_integral((2 * W @ Pqd).T)        # int rho u0 x (2 W S q_dot)
                       + _cross_integral(Pqdd.T)                 # int rho u0 x S q_ddot
                       + _cross(s_u, base.a0))                 # int rho u x a0
        r_F = self.load.undeformed_body + self.load.displacement_body(q)
        moment_on_base = np.asarray(moment_body, float) + _cross(r_F, force_body) - moment_rate
        return force_on_base, moment_on_base

    # ------------------------------------------------------------ the same, as cached affine maps (FMU hot path)
    def fast_maps(self, h: float, base: BaseMotion):
        """Step and output maps for step h with the base rotation (omega, alpha) of ``base`` held, in
        the modal state x = [eta; eta_dot] and the input u = [F, M, a0] (body frame):

            x+ = Ad x + Bu u + b0
            y  = Cx x + Du u + y0 + [0 (18); cross(L eta, F) - cross(S_bar_hat eta, a0)]

        with y = [sensor u, sensor v, sensor a, tip u, reaction F, reaction M] (18 values): the same
        quantities as :meth:`step`, :meth:`sensor_motion`, :meth:`tip_displacement` and
        :meth:`reactions` (tests/test_performance_equivalence.py), at O(m^2) per step; then the gauges' section
        forces (6 per gauge slot, zero rows for none: flexfmu.ffr.gauges, without the static correction).  Cached per
        (h, omega, alpha) (and a0 with geometric stiffening); ``h = None`` gives the output maps only."""
        key = (h, self._base_key(base))
        hit = self._fast_cache.get(key)
        if hit is not None:
            return hit
        m = self.m
        ints = self.integrals
        w, al = np.asarray(base.omega, float), np.asarray(base.alpha, float)
        W = _skew(w)
        X = _skew(al) + W @ W
        K_eff, C_eff = self._matrices(base)
        Fm = np.hstack([self.load_force_map, self.load_moment_map, -self.F_a0])      # (m, 9)
        p = np.einsum("ab,abk->k", X, self.P_hat)
        Ax = np.hstack([-K_eff, -C_eff])                                            # eta_ddot = Ax x + Fm u - p
        Z3m, I3, Z3 = np.zeros((3, m)), np.eye(3), np.zeros((3, 3))
        Sm, Sb = self.sensor_map, self.S_bar_hat
        u0 = self.sensor.undeformed_body

        def ci_cols(f):
            return np.column_stack([_cross_integral(f(self.P_hat[:, :, k])) for k in range(m)]) if m else Z3m

        L_eta = ci_cols(lambda Pk: Pk @ X.T) + ci_cols(lambda Pk: (X @ Pk).T)
        L_v = ci_cols(lambda Pk: (2 * W @ Pk).T)
        L_a = ci_cols(lambda Pk: Pk.T)
        rows_x = [np.hstack([Sm, Z3m]), np.hstack([Z3m, Sm]), np.hstack([X @ Sm, 2 * W @ Sm]) + Sm @ Ax,
                  np.hstack([self.tip_map, Z3m]), -(np.hstack([X @ Sb, 2 * W @ Sb]) + Sb @ Ax),
                  -(np.hstack([L_eta, L_v]) + L_a @ Ax)]
        rows_u = [np.zeros((3, 9)), np.zeros((3, 9)), np.hstack([Z3, Z3, I3]) + Sm @ Fm, np.zeros((3, 9)),
                  np.hstack([I3, Z3, -ints.mass * I3]) - Sb @ Fm,
                  np.hstack([_skew(self.load.undeformed_body), I3, -_skew(ints.first_moment)]) - L_a @ Fm]
        y0 = np.concatenate([np.zeros(6), X @ u0 - Sm @ p, np.zeros(3), -(X @ ints.first_moment - Sb @ p),
                             -(ints.J0 @ al + _cross(w, ints.J0 @ w) - L_a @ p)])
        gauge_x, gauge_u, gauge_y0 = self.gauges.output_rows(Ax, Fm, p, W, X, self.damping)
        C = np.ascontiguousarray(np.hstack([np.vstack(rows_x + [gauge_x]), np.vstack(rows_u + [gauge_u])]))
        y0 = np.concatenate([y0, gauge_y0])                                             # C: (36, 2m + 9)
        if h is None:
            Ad = Bu = b0 = None
        else:
            Ad, Bd = self._transition(float(h), base)
            Bu, b0 = Bd @ Fm, -(Bd @ p)
        hit = self._fast_cache[key] = (Ad, Bu, b0, C, y0)
        return hit

    def tip_displacement(self, state: ModalState) -> np.ndarray:
        return self.tip_map @ state.eta

    def elastic_energy(self, state: ModalState) -> float:
        """Strain energy 1/2 q^T K q = 1/2 sum omega_i^2 eta_i^2 (J)."""
        return 0.5 * float(self.stiffness @ state.eta**2)


def _cross_integral(T: np.ndarray) -> np.ndarray:
    """int rho x cross y from T[b, c] = int rho x_b y_c: components eps_ibc T[b, c]."""
    return np.array([T[1, 2] - T[2, 1], T[2, 0] - T[0, 2], T[0, 1] - T[1, 0]])
