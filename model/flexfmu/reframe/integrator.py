"""Reframe flexible-body integrator (paper Section 3, Eqs. 23-40): large rigid motion plus vibration
from a conventional linear structural model (M, K, modal damping) by single RK4 steps in frames that
follow the rigid-body motion extracted from the rigid-body modes.

X. Liu, "A Novel Approach for Flexible Body Dynamics Computation via Synthesizing Incremental Motions
in Reconfigured Inertial Frames" (``shared/papers/reframe-flexible-body.txt``).  docs/reframe.md
explains both schemes, the defects of the printed one and the measured orders.

Three schemes (``scheme=``):

``"consistent"`` (default)
    Each step n is taken in the inertial frame that coincides with the dummy rigid body at t_n.  The
    step integrates, with one classical RK4 step (loads evaluated at the stage times), the motion of
    the next frame *relative to frame n* (rotation vector phi, starting at 0, Eq. 20 with Eq. 22 via
    :func:`flexfmu.core.rotation.rotvec_rate`; displacement of the frame point), the linear momentum
    (global components), the angular momentum (frame-n components) and the flexible modal
    coordinates and their conjugate momenta.  The equations are the Euler-Poincare (Kirchhoff)
    equations of the kinetic energy of the conventional model's mass matrix evaluated with the nodal
    velocities of the moving, deformed body (``flexfmu.reframe.kernels._rhs``), so the conventional M, K, modal basis
    are all that is used.  After the step the frame is re-configured onto the dummy body at t_{n+1}:
    the whole rigid part is absorbed into the frame pose (q_R = 0 always) and the momenta are
    expressed in the new frame.  In the dt -> 0 limit this is a modally reduced floating-frame model
    whose frame obeys the linearised mean-axis conditions (Psi_R^T M u = 0): the flexible modes are
    M-orthogonal to the rigid ones.

``"paper"``
    Section 3 as printed (Eqs. 36-40), ambiguities resolved as documented in :meth:`_paper_step`.

``"exponential"``
    The consistent scheme's equations and step-local state z = [phi, dpos, p_g, H, q_F, p_q]
    integrated by an exponential integrator that is exact for the flexible modes' linear part, so
    no RK4 stability limit applies (no ``check_stability``).  Split z' = L z + N(z, t) with L the
    block-diagonal linear oscillator of each flexible mode j on (q_j, p_j),
    L_j = [[0, 1], [-k_j, -c_j]] (k_j = omega_j^2, c_j = 2 zeta_j omega_j, Eq. 35's H for one mode;
    q' = p_q - D(q)^T omega and p_q' = dT/dq - K_q q - C_q qdot + Q), L = 0 on the 12 frame and
    momentum components, and N = z' - L z the rest: frame kinematics, gyroscopic / centrifugal /
    Coriolis coupling (-D^T omega, dT/dq + C_q D^T omega), the loads and the geometric stiffness.
    Variation of constants, z(t_n + h) = e^{hL} z_n + int_0^h e^{(h - s)L} N(z(t_n + s)) ds, with
    the integrand's N interpolated from four stage values gives the Cox & Matthews (2002) ETD-RK4
    step (phi_1(Z) = Z^{-1}(e^Z - I), phi_2(Z) = Z^{-1}(phi_1 - I), phi_3(Z) = Z^{-1}(phi_2 - I/2)):

        a = e^{hL/2} z_n + (h/2) phi_1(hL/2) N(z_n, t_n)
        b = e^{hL/2} z_n + (h/2) phi_1(hL/2) N(a, t_n + h/2)
        c = e^{hL/2} a + (h/2) phi_1(hL/2) (2 N(b, t_n + h/2) - N(z_n, t_n))
        z_{n+1} = e^{hL} z_n + h [(phi_1 - 3 phi_2 + 4 phi_3) N_n + (2 phi_2 - 4 phi_3)(N_a + N_b)
                                   + (4 phi_3 - phi_2) N_c],   phi_k = phi_k(hL).

    Classical order 4; on the L = 0 components it is classical RK4 itself (phi_k(0) = 1/k!), so the
    frame, momentum and the linear / angular momentum balance are integrated exactly as by the
    consistent scheme.  A constant N (e.g. the held modal load of the FMU on a body that does not
    rotate) is integrated exactly: the weights sum to phi_1(hL), the exact affine part.  The 2x2
    per-mode matrices are computed once per dt (:func:`exponential_coefficients`), so a step still
    costs O(nf^2).  Accuracy then depends on how fast N varies (the rigid motion, |omega| h, and the
    load history), not on omega_max h.

State (:class:`ReframeState`): time, the frame point (the dummy body's centre of mass, global), the
rotation (body -> global), and the modal state eta = [q_R, q_F, qdot_R, qdot_F] in the current frame
(Eq. 33; Psi mass-orthonormal so M_q = I).  The rigid modal velocities are ``A^{-1} [v; omega]`` with
``A = basis.rigid_transform``, v the velocity of the frame point and omega the angular velocity, both
in body components.  The paper scheme additionally carries its rotation vector M (Eq. 38).

Conventions: SI units; ``rotation`` maps body components to global components (it is ``A.T`` of
:mod:`flexfmu.core.rotation`); quaternions are scalar first (w, x, y, z), w >= 0; body-frame vectors
(omega, alpha) are in the dummy body's axes, which coincide with the mesh axes when undeformed.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import FlexfmuError, ParameterError
from flexfmu.linalg.modal_basis import N_RIGID, ModalBasis
from flexfmu.linalg.modal_basis import modal_basis as _modal_basis
from flexfmu.core.rotation import (
    rotvec_rate_coefficient,
    angular_acceleration,
    angular_velocity,
    oblique_basis,
    reparametrize,
    rotvec_from_matrix,
)
from flexfmu.core.structure import Structure
from flexfmu.core.vec3 import cross as _cross
from flexfmu.core.vec3 import skew as _skew

__all__ = [
    "SCHEMES",
    "RK4_STABILITY_LIMIT",
    "PointLoad",
    "half_sine_pulse",
    "constant_load",
    "ReframeState",
    "ReframeResult",
    "NodalState",
    "ReframeIntegrator",
    "FixedFrameBaseline",
    "BaselineResult",
    "quaternion_from_rotation",
    "Snapshot",
    "exponential_coefficients",
]

SCHEMES = ("consistent", "paper", "exponential")
#: RK4 is stable for an undamped oscillator while dt * omega <= 2*sqrt(2) = 2.83; refuse above 2.8.
RK4_STABILITY_LIMIT = 2.8
_ORTHO_RTOL = 1e-8       # Psi^T M Psi = I within this (relative to 1)
_RIGID_RTOL = 1e-8       # |K psi_rigid| / (|K| |psi_rigid|) allowed for the first six columns


# --------------------------------------------------------------------------- small helpers
def _kernels():
    """flexfmu.reframe.kernels, imported on first use (it imports numba when available)."""
    from flexfmu.reframe import kernels as _reframe_kernels

    return _reframe_kernels


def _rodrigues(phi):
    """exp(skew(phi)): body -> reference rotation (= scipy ``Rotation.from_rotvec(phi).as_matrix()``)."""
    th2 = float(phi @ phi)
    th = math.sqrt(th2)
    if th < 1e-4:
        a = 1.0 - th2 / 6.0 + th2 * th2 / 120.0
        b = 0.5 - th2 / 24.0 + th2 * th2 / 720.0
    else:
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / th2
    K = _skew(phi)
    return np.eye(3) + a * K + b * (K @ K)


def _rotvec_rate(phi, w):
    """Eqs. (20)-(22) as a vector (same as :func:`flexfmu.core.rotation.rotvec_rate`, without input checks)."""
    th = math.sqrt(float(phi @ phi))
    pxw = _cross(phi, w)
    return w + 0.5 * pxw + rotvec_rate_coefficient(th) * _cross(phi, pxw)


def quaternion_from_rotation(R) -> np.ndarray:
    """Unit quaternion (w, x, y, z), w >= 0, of the body -> global rotation matrix R."""
    phi = rotvec_from_matrix(np.asarray(R).T)          # rotvec_from_matrix takes global -> body
    th = float(np.linalg.norm(phi))
    w = math.cos(0.5 * th)
    s = 0.5 * np.sinc(th / (2.0 * np.pi))               # sin(th/2)/th
    return np.concatenate([[w], s * phi])


def _finite_vec3(x, name):
    try:
        v = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(name, f"{x!r} is not numeric", "finite 3-vector") from None
    if v.shape != (3,):
        raise ParameterError(name, f"shape {v.shape}", "finite 3-vector")
    if not np.all(np.isfinite(v)):
        raise ParameterError(name, f"{v} contains NaN or Inf", "finite 3-vector")
    return v


def _check_dt(dt):
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real) or not math.isfinite(dt) or dt <= 0.0:
        raise ParameterError("dt", f"{dt!r}", "finite time step > 0 (s)")
    return float(dt)


def exponential_coefficients(stiffness, damping, dt: float) -> np.ndarray:
    """Per-mode 2x2 matrices of the exponential scheme's ETD-RK4 step (module docstring), shape
    (nf, 6, 2, 2): E1 = e^{hL_j}, E2 = e^{hL_j/2}, A2 = (h/2) phi_1(hL_j/2), B1 = h (phi_1 - 3 phi_2 +
    4 phi_3), B2 = h (2 phi_2 - 4 phi_3), B4 = h (4 phi_3 - phi_2) (phi_k at hL_j) for
    L_j = [[0, 1], [-k_j, -c_j]] acting on (q_j, p_j).

    phi_k(Z) are the blocks of the exponential of the augmented matrix [[Z, I, 0, 0], [0, 0, I, 0],
    [0, 0, 0, I], [0, 0, 0, 0]] (Saad 1992; no cancellation for small hL), evaluated in the balanced
    coordinates (omega_j q_j, p_j) where Z is a scaled rotation-plus-damping and then scaled back.
    """
    from scipy.linalg import expm

    k = np.asarray(stiffness, dtype=float)
    c = np.asarray(damping, dtype=float)
    nf = k.size
    out = np.zeros((nf, 6, 2, 2))
    if nf == 0:
        return out
    w = np.sqrt(np.maximum(k, 0.0))
    s = np.where(w > 0.0, w, 1.0)                 # balancing scale omega_j (1 for a zero-stiffness mode)
    Lhat = np.zeros((nf, 2, 2))                   # T L T^-1 with T = diag(s, 1)
    Lhat[:, 0, 1] = s
    Lhat[:, 1, 0] = -k / s
    Lhat[:, 1, 1] = -c
    phis = {}
    for frac in (1.0, 0.5):
        W = np.zeros((nf, 8, 8))
        W[:, 0:2, 0:2] = frac * dt * Lhat
        for b in range(3):
            W[:, 2 * b:2 * b + 2, 2 * b + 2:2 * b + 4] = np.eye(2)
        X = expm(W)
        phis[frac] = [X[:, 0:2, 2 * b:2 * b + 2] for b in range(4)]     # e^Z, phi_1, phi_2, phi_3
    e1, p1, p2, p3 = phis[1.0]
    h = dt
    mats = [e1, phis[0.5][0], 0.5 * h * phis[0.5][1], h * (p1 - 3.0 * p2 + 4.0 * p3), h * (2.0 * p2 - 4.0 * p3),
            h * (4.0 * p3 - p2)]
    for m, X in enumerate(mats):                  # back to (q, p): T^-1 X T
        out[:, m, 0, 0] = X[:, 0, 0]
        out[:, m, 0, 1] = X[:, 0, 1] / s
        out[:, m, 1, 0] = X[:, 1, 0] * s
        out[:, m, 1, 1] = X[:, 1, 1]
    if not np.all(np.isfinite(out)):
        raise ParameterError("dt", f"{dt!r} s gives non-finite exponential propagators", "a finite time step > 0 (s)")
    return out


# --------------------------------------------------------------------------- loads
_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False


class _History:
    """A load history: callable f(t) -> (3,), a table (times, values) or a constant 3-vector."""

    def __init__(self, spec, name):
        self.name = name
        self.kind = None
        if spec is None:
            self.kind = "zero"
        elif callable(spec):
            self.kind = "callable"
            self.fn = spec
        elif isinstance(spec, tuple) and len(spec) == 2:
            times = np.asarray(spec[0], dtype=float)
            values = np.asarray(spec[1], dtype=float)
            if times.ndim != 1 or values.shape != (times.size, 3) or times.size < 1:
                raise ParameterError(name, f"table shapes {times.shape}, {values.shape}",
                                     "(times (k,), values (k, 3)) with k >= 1")
            if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
                raise ParameterError(name, "table contains NaN or Inf", "finite times and values")
            if np.any(np.diff(times) <= 0.0):
                raise ParameterError(name, "table times not strictly increasing", "strictly increasing times")
            self.kind = "table"
            self.times, self.values = times, values
        else:
            self.kind = "constant"
            self.value = _finite_vec3(spec, name)

    @classmethod
    def held(cls, value: np.ndarray, name: str) -> "_History":
        """A constant history of a finite float (3,) array that the caller has checked (the per-step input
        path of a co-simulation: no checks, no conversion)."""
        h = cls.__new__(cls)
        h.name, h.kind, h.value = name, "constant", value
        return h

    @property
    def constant(self) -> bool:
        """True for a zero or constant history (its value does not depend on t)."""
        return self.kind in ("zero", "constant")

    def raw(self, t):
        """The value at t without the checks of ``__call__`` (hot loop: the kernel checks finiteness, and
        on any problem the caller re-evaluates through ``__call__`` for the error message)."""
        kind = self.kind
        if kind == "callable":
            return self.fn(t)
        if kind == "constant":
            return self.value
        if kind == "zero":
            return _ZERO3
        return self(t)

    def __call__(self, t):
        if self.kind == "zero":
            return np.zeros(3)
        if self.kind == "constant":
            return self.value
        if self.kind == "table":
            return np.array([np.interp(t, self.times, self.values[:, k]) for k in range(3)])
        try:
            v = np.asarray(self.fn(t), dtype=float)
        except (TypeError, ValueError) as exc:
            raise ParameterError(self.name, f"f({t}) is not numeric ({exc})", "f(t) -> finite (3,)") from None
        if v.shape != (3,):
            raise ParameterError(self.name, f"f({t}) has shape {v.shape}", "f(t) -> finite (3,)")
        if not np.all(np.isfinite(v)):
            raise ParameterError(self.name, f"f({t}) = {v} contains NaN or Inf", "f(t) -> finite (3,)")
        return v


@dataclass
class PointLoad:
    """A force (and on 6-DOF nodes optionally a moment) at one node.

    point:     node index, or coordinates (m, undeformed body frame): the nearest node is loaded.
    force:     N; a callable ``f(t) -> (3,)``, a table ``(times (k,), values (k, 3))`` (linear
               interpolation, end values held outside), a constant 3-vector, or None.
    moment:    N m, same forms; only on models with 6 DOFs per node.
    follower:  False: components in the global frame (fixed direction); True: components in the body
               frame (the load turns with the dummy body).
    """

    point: object
    force: object = None
    moment: object = None
    follower: bool = False


def half_sine_pulse(vector, duration: float, start: float = 0.0):
    """Load history ``vector * sin(pi (t - start)/duration)`` on [start, start + duration], 0 elsewhere.

    Continuous (no jump), so RK4 stage evaluations at the pulse ends are unambiguous; its impulse is
    ``vector * 2 duration / pi``.
    """
    v = _finite_vec3(vector, "vector")
    if not (isinstance(duration, numbers.Real) and math.isfinite(duration) and duration > 0):
        raise ParameterError("duration", f"{duration!r}", "> 0 (s)")
    t0, T = float(start), float(duration)

    def f(t):
        s = (t - t0) / T
        return v * math.sin(math.pi * s) if 0.0 <= s <= 1.0 else np.zeros(3)

    return f


def constant_load(vector):
    """Load history: constant ``vector`` from t = 0 on (a step load switched on at t = 0)."""
    v = _finite_vec3(vector, "vector")
    return lambda t: v


@dataclass
class _ResolvedLoad:
    node: int
    force: _History
    moment: _History
    follower: bool


# --------------------------------------------------------------------------- state / results
@dataclass
class ReframeState:
    """Explicit state of the reframe integrator.

    t:         s.
    position:  (3,) global position of the frame point = centre of mass of the dummy rigid body, m.
    rotation:  (3, 3) body -> global rotation of the dummy body (its frame is the current frame).
    eta:       (2 n_modes,) modal state in the current frame, Eq. (33): [q_R, q_F, qdot_R, qdot_F].
    rotvec:    (3,) scheme="paper" only: the integrated rotation vector M of Eq. (38), |M| <= pi,
               with ``rotation_matrix(rotvec) == rotation.T``.
    """

    t: float
    position: np.ndarray
    rotation: np.ndarray
    eta: np.ndarray
    rotvec: np.ndarray | None = None


def _state_vector(s: ReframeState) -> np.ndarray:
    """[position, rotation (row-major), eta] of a state as one float array for the kernels.  A state made by
    the kernels holds views into one such array (``_flat``): reused while all three fields are still views
    of it (assigning a new array to a field makes a copy here instead); the kernels never write into y0."""
    flat = s.__dict__.get("_flat")
    if flat is not None and s.position.base is flat and s.rotation.base is flat and s.eta.base is flat:
        return flat
    return np.concatenate((s.position, np.ravel(s.rotation), s.eta)).astype(float, copy=False)


def _state_from_vector(t: float, y: np.ndarray) -> ReframeState:
    s = ReframeState(t=t, position=y[0:3], rotation=y[3:12].reshape(3, 3), eta=y[12:])
    s.__dict__["_flat"] = y
    return s


@dataclass
class NodalState:
    """All nodal quantities of a state.

    positions:      (N, 3) global node positions, m.
    displacement:   (n_dof,) elastic displacement x in the current frame (body components).
    velocity_body:  (n_dof,) nodal velocities (translations: m/s; rotational DOFs: angular
                    velocity of the node, rad/s), body components, in the inertial frame.
    velocity:       (n_dof,) the same in global components.
    """

    positions: np.ndarray
    displacement: np.ndarray
    velocity_body: np.ndarray
    velocity: np.ndarray


@dataclass
class ReframeResult:
    """Time histories from :meth:`ReframeIntegrator.run` (first axis: the n_t output times).

    t (n_t,); frame_origin (n_t, 3): global position of the body frame origin (mesh origin of the
    dummy body); frame_origin_velocity (n_t, 3) its time derivative, global; rotation (n_t, 3, 3) body -> global; quaternion (n_t, 4) (w, x, y, z);
    omega, alpha (n_t, 3) body frame, rad/s, rad/s^2; com_position, com_velocity (n_t, 3) global;
    q, qd (n_t, n_flexible) flexible modal coordinates / velocities; max_elastic_displacement (n_t,)
    max over nodes of |elastic translation|, m; points (n_p,) node indices; point_position,
    point_velocity, point_acceleration (n_t, n_p, 3) global, full motion; point_position_rigid,
    point_velocity_rigid, point_acceleration_rigid the embedded rigid part
    (a_o + alpha x r + omega x (omega x r)); final_state: the last :class:`ReframeState`.
    """

    t: np.ndarray
    frame_origin: np.ndarray
    frame_origin_velocity: np.ndarray
    rotation: np.ndarray
    quaternion: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    com_position: np.ndarray
    com_velocity: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    max_elastic_displacement: np.ndarray
    points: np.ndarray
    point_position: np.ndarray
    point_velocity: np.ndarray
    point_acceleration: np.ndarray
    point_position_rigid: np.ndarray
    point_velocity_rigid: np.ndarray
    point_acceleration_rigid: np.ndarray
    final_state: ReframeState = None


# --------------------------------------------------------------------------- common model data
class _ModelData:
    """Validated structure + modal basis, index arrays and load handling shared by both integrators."""

    def __init__(self, structure: Structure, basis):
        if not isinstance(structure, Structure):
            raise ParameterError("structure", f"{type(structure).__name__}", "a flexfmu Structure")
        if isinstance(basis, numbers.Integral) and not isinstance(basis, bool):
            basis = _modal_basis(structure, int(basis))
        if not isinstance(basis, ModalBasis):
            raise ParameterError("basis", f"{type(basis).__name__}", "a ModalBasis or the number of flexible modes")
        self.structure = structure
        self.basis = basis
        nodes = np.asarray(structure.nodes, dtype=float)
        dpn = int(structure.dofs_per_node)
        n_dof = nodes.shape[0] * dpn
        M, K = structure.M.tocsr(), structure.K.tocsr()
        if M.shape != (n_dof, n_dof) or K.shape != (n_dof, n_dof):
            raise ParameterError("structure.M", f"M {M.shape}, K {K.shape} for {n_dof} DOFs",
                                 "square matrices of size N * dofs_per_node")
        Psi = np.asarray(basis.shapes, dtype=float)
        if Psi.ndim != 2 or Psi.shape[0] != n_dof:
            raise ParameterError("basis.shapes", f"shape {Psi.shape}", f"({n_dof}, 6 + n_flexible)")
        if Psi.shape[1] < N_RIGID:
            raise ParameterError("basis.shapes", f"only {Psi.shape[1]} modes: fewer than 6 rigid-body modes",
                                 "6 rigid-body modes first, then the flexible ones")
        # The first six columns must be rigid-body modes (no strain energy) and span six motions.
        PR = Psi[:, :N_RIGID]
        res = np.max(np.abs(K @ PR), axis=0) / np.maximum(np.max(abs(K) @ np.abs(PR), axis=0), 1e-300)
        G = Psi.T @ (M @ Psi)
        ortho = float(np.max(np.abs(G - np.eye(Psi.shape[1]))))
        if np.max(res) > _RIGID_RTOL or np.any(np.abs(basis.stiffness[:N_RIGID]) > 0) or \
                np.linalg.matrix_rank(PR.T @ (M @ PR), tol=1e-8) < N_RIGID:
            raise ParameterError("basis.shapes", "fewer than 6 rigid-body modes in the first six columns "
                                 f"(max |K psi| / (|K| |psi|) = {np.max(res):.3g})",
                                 "columns 0-5: six independent rigid-body modes")
        if ortho > _ORTHO_RTOL:
            raise ParameterError("basis.shapes", f"not mass-orthonormal (|Psi^T M Psi - I| = {ortho:.3g})",
                                 f"Psi^T M Psi = I within {_ORTHO_RTOL:g}")
        self.nodes = nodes
        self.dpn = dpn
        self.n_nodes = nodes.shape[0]
        self.n_dof = n_dof
        self.M, self.K = M, K
        self.Psi = Psi
        self.n_modes = Psi.shape[1]
        self.nf = self.n_modes - N_RIGID
        self.Phi = Psi[:, N_RIGID:]
        self.kq = np.asarray(basis.stiffness, dtype=float)
        self.cq = np.asarray(basis.damping, dtype=float)
        self.A6 = np.asarray(basis.rigid_transform, dtype=float)
        self.A6inv = np.linalg.inv(self.A6)
        self.mass = float(basis.mass)
        self.com = np.asarray(basis.center_of_mass, dtype=float)
        self.Xc = nodes - self.com
        self.trans_rows = (np.arange(self.n_nodes)[:, None] * dpn + np.arange(3)).astype(np.int64)
        self.rot_rows = (self.trans_rows + 3) if dpn == 6 else None
        self.omega_max = float(np.sqrt(np.max(self.kq))) if self.nf else 0.0

    # ---- nodes and loads
    def node_index(self, point, name):
        if isinstance(point, numbers.Integral) and not isinstance(point, bool):
            i = int(point)
            if not 0 <= i < self.n_nodes:
                raise ParameterError(name, f"node {i} out of range", f"0 ... {self.n_nodes - 1}")
            return i
        x = _finite_vec3(point, name)
        return int(np.argmin(np.linalg.norm(self.nodes - x, axis=1)))

    def resolve_loads(self, load):
        if load is None:
            return []
        loads = [load] if isinstance(load, PointLoad) else list(load)
        out = []
        for k, ld in enumerate(loads):
            if not isinstance(ld, PointLoad):
                raise ParameterError(f"load[{k}]", f"{type(ld).__name__}", "PointLoad")
            node = self.node_index(ld.point, f"load[{k}].point")
            if ld.moment is not None and self.dpn != 6:
                raise ParameterError(f"load[{k}].moment", "moments need rotational DOFs",
                                     "None on models with 3 DOFs per node")
            out.append(_ResolvedLoad(node, _History(ld.force, "load.force"),
                                     _History(ld.moment, "load.moment"), bool(ld.follower)))
        return out

    def check_stability(self, dt):
        if self.omega_max * dt > RK4_STABILITY_LIMIT:
            raise ParameterError(
                "dt", f"dt * omega_max = {dt:g} * {self.omega_max:.6g} = {dt * self.omega_max:.3g} > "
                      f"{RK4_STABILITY_LIMIT}: RK4 would diverge on the highest flexible mode "
                      f"({self.omega_max / (2 * np.pi):.6g} Hz)",
                f"dt <= {RK4_STABILITY_LIMIT / self.omega_max:.4g} s, or fewer flexible modes")


def _check_initial(data: _ModelData, v0, omega0, q0, qd0, rotation0, position0):
    v0 = _finite_vec3(v0, "v0")
    omega0 = _finite_vec3(omega0, "omega0")
    nf = data.nf

    def modal(x, name):
        if x is None:
            return np.zeros(nf)
        a = np.asarray(x, dtype=float)
        if a.shape != (nf,) or not np.all(np.isfinite(a)):
            raise ParameterError(name, f"shape {a.shape} or non-finite", f"finite ({nf},) flexible modal values")
        return a

    q0, qd0 = modal(q0, "q0"), modal(qd0, "qd0")
    if rotation0 is None:
        R0 = np.eye(3)
    else:
        R0 = np.asarray(rotation0, dtype=float)
        if R0.shape != (3, 3) or not np.all(np.isfinite(R0)) or \
                np.max(np.abs(R0.T @ R0 - np.eye(3))) > 1e-9 or np.linalg.det(R0) <= 0:
            raise ParameterError("rotation0", "not a proper rotation matrix", "orthonormal 3x3, det +1")
    pos = data.com.copy() if position0 is None else _finite_vec3(position0, "position0")
    return v0, omega0, q0, qd0, R0, pos


# --------------------------------------------------------------------------- the integrator
class ReframeIntegrator:
    """Reframe flexible-body integrator (see the module docstring).

    structure:          conventional model (:class:`~flexfmu.core.structure.Structure`), free-free.
    basis:              :class:`~flexfmu.linalg.modal_basis.ModalBasis` (6 rigid + n flexible modes,
                        mass-orthonormal), or an int n: ``modal_basis(structure, n)`` (5% damping).
    reference_points:   (R, P, Q): node indices or coordinates (nearest node).  Default: the
                        structure's ``meta["points"]`` R, P, Q if present (the plate: P1, P2, P3),
                        else R = the node nearest the centre of mass, P = the node farthest from R,
                        Q = the node farthest from the line RP.  Used by Eqs. (36)-(37) of the paper
                        scheme; checked (non-colinear) for both schemes.
    scheme:             "consistent" (default), "exponential" (the consistent equations, exact in
                        the flexible modes' linear part: no RK4 stability limit) or "paper".
    deformed_load_arm:  True: the moment of a load on the rigid-body motion uses the deformed position
                        of its point (adds u_F x f).  False: the undeformed lever arm (paper's
                        linear model).
    geometric_stiffness: None, or G of shape (3, 3, nf, nf) (body frame, flexible modal coordinates,
                        N m / rad^2 per unit modal coordinate, i.e. kg-normalised like the modes):
                        the flexible momentum rate gets -(sum_ab X_ab G[a, b]) q_F with
                        X = skew(omega) @ skew(omega) at every stage (e.g. centrifugal stiffening).
                        Not with scheme="paper".
    """

    def __init__(self, structure: Structure, basis, *, reference_points=None, scheme: str = "consistent",
                 deformed_load_arm: bool = True, geometric_stiffness=None):
        if scheme not in SCHEMES:
            raise ParameterError("scheme", repr(scheme), " | ".join(f'"{x}"' for x in SCHEMES))
        self.scheme = scheme
        self.deformed_load_arm = bool(deformed_load_arm)
        self.data = _ModelData(structure, basis)
        self._setup_geometric_stiffness(geometric_stiffness)
        self._setup_reference_points(reference_points)
        self._setup_consistent() if scheme != "paper" else self._setup_paper()
        self._setup_max_displacement()
        self._ex_cache = {}
        self.state = self.initial_state()

    @property
    def stability_limited(self) -> bool:
        """True if the step is limited by RK4 stability (dt * omega_max <= RK4_STABILITY_LIMIT)."""
        return self.scheme != "exponential"

    # ---------------------------------------------------------------- setup
    def _setup_geometric_stiffness(self, G):
        nf = self.data.nf
        self.geometric_stiffness = None
        self._Gk = np.zeros(0)
        if G is None:
            return
        if self.scheme == "paper":
            raise ParameterError("geometric_stiffness", "not supported by scheme 'paper'",
                                 'None, or scheme "consistent" / "exponential"')
        try:
            Ga = np.array(G, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError("geometric_stiffness", f"{type(G).__name__} is not numeric",
                                 f"finite array of shape (3, 3, {nf}, {nf})") from None
        if Ga.shape != (3, 3, nf, nf):
            raise ParameterError("geometric_stiffness", f"shape {Ga.shape}",
                                 f"finite array of shape (3, 3, {nf}, {nf}) (body frame, flexible modes)")
        if not np.all(np.isfinite(Ga)):
            raise ParameterError("geometric_stiffness", "contains NaN or Inf",
                                 f"finite array of shape (3, 3, {nf}, {nf})")
        self.geometric_stiffness = Ga
        self._Gk = np.ascontiguousarray(Ga.reshape(-1))

    def _exponential(self, dt: float) -> np.ndarray:
        """Flat exponential-scheme coefficients for dt (cached: the FMU steps with one dt)."""
        EX = self._ex_cache.get(dt)
        if EX is None:
            EX = np.ascontiguousarray(exponential_coefficients(self._kF, self._cF, dt).reshape(-1))
            if len(self._ex_cache) >= 8:
                self._ex_cache.clear()
            self._ex_cache[dt] = EX
        return EX

    def _setup_reference_points(self, reference_points):
        d = self.data
        if reference_points is None:
            pts = d.structure.meta.get("points", {}) if isinstance(d.structure.meta, dict) else {}
            if all(k in pts for k in ("R", "P", "Q")):
                idx = [int(pts["R"]), int(pts["P"]), int(pts["Q"])]
            else:
                iR = int(np.argmin(np.linalg.norm(d.Xc, axis=1)))
                dist = np.linalg.norm(d.nodes - d.nodes[iR], axis=1)
                iP = int(np.argmax(dist))
                e = (d.nodes[iP] - d.nodes[iR]) / max(dist[iP], 1e-300)
                rel = d.nodes - d.nodes[iR]
                iQ = int(np.argmax(np.linalg.norm(rel - np.outer(rel @ e, e), axis=1)))
                idx = [iR, iP, iQ]
        else:
            try:
                seq = list(reference_points)
            except TypeError:
                raise ParameterError("reference_points", f"{reference_points!r}", "(R, P, Q)") from None
            if len(seq) != 3:
                raise ParameterError("reference_points", f"{len(seq)} entries", "(R, P, Q)")
            idx = [d.node_index(p, f"reference_points[{k}]") for k, p in enumerate(seq)]
        iR, iP, iQ = idx
        p_vec = d.nodes[iP] - d.nodes[iR]
        q_vec = d.nodes[iQ] - d.nodes[iR]
        try:
            oblique_basis(p_vec, q_vec, min_sine=1e-3)
        except ParameterError as exc:
            raise ParameterError("reference_points",
                                 f"R, P, Q = nodes {idx} at {d.nodes[idx].tolist()} are coincident or colinear "
                                 f"({exc})", "three non-colinear points, |e1 x e2| >= 1e-3") from None
        self.reference_nodes = tuple(idx)
        self._p_vec, self._q_vec = p_vec, q_vec

    def _setup_consistent(self):
        """Inertia invariants of the kinetic energy T = 1/2 w^T M w (body components).

        Nodal velocity w = T v + S(y) omega + Phi qdot with y = X - c + u, u = Phi q: S(y) is the
        rotation field (omega x y on translational DOFs, omega on rotational DOFs), split as
        S(y) = S0 + sum_j q_j S_j (S_j: omega x phi_j on translational DOFs).  Then the generalised
        mass matrix of (v, omega, qdot) is

            [[m I,  A(q),   0   ],
             [A^T,  J(q),   D(q)],
             [0,    D^T,    I   ]]

        with A(q) = sum q_j T^T M S_j (0 for an isotropic mass matrix), J(q) = S(y)^T M S(y),
        D(q) = sum q_j S_j^T M Phi (T^T M Phi = S0^T M Phi = 0: Phi is M-orthogonal to the rigid modes).
        The invariants come from a few sparse-times-dense and dense products (BLAS), O(nnz(M) nf +
        n_dof nf^2); the step kernel (flexfmu.reframe.kernels) then costs O(nf^2) whatever the mesh.
        """
        d = self.data
        nd, nf, N = d.n_dof, d.nf, d.n_nodes
        tr = d.trans_rows
        T = np.zeros((nd, 3))
        S0 = np.zeros((nd, 3))
        for k in range(3):
            T[tr[:, k], k] = 1.0
            S0[tr, k] = np.cross(np.eye(3)[k], d.Xc)
            if d.rot_rows is not None:
                S0[d.rot_rows[:, k], k] = 1.0
        J0 = S0.T @ (d.M @ S0)
        self._J0 = 0.5 * (J0 + J0.T)
        self._m = float(np.mean(np.diag(T.T @ (d.M @ T))))
        # SJ[:, 3 j + k] = S_j e_k = e_k x phi_j on the translational rows.
        U = d.Phi[tr]                                             # (N, 3, nf) translational mode shapes
        SJ = np.zeros((nd, nf, 3))
        for k in range(3):
            SJ[tr, :, k] = np.cross(np.eye(3)[k][None, :, None], U, axisa=1, axisb=1, axisc=1)
        SJ = SJ.reshape(nd, 3 * nf)
        MSJ = np.asarray(d.M @ SJ)
        self._Aj = (T.T @ MSJ).reshape(3, nf, 3).transpose(1, 0, 2).copy()         # T^T M S_j
        Bj = (S0.T @ MSJ).reshape(3, nf, 3).transpose(1, 0, 2)                   # S0^T M S_j
        self._Bsym = Bj + np.transpose(Bj, (0, 2, 1))
        C = SJ.T @ MSJ
        C = 0.5 * (C + C.T)                                 # exactly C_kj = C_jk^T (the kernels rely on it)
        self._Cjk = C.reshape(nf, 3, nf, 3).transpose(0, 2, 1, 3).copy()  # S_j^T M S_k
        self._Dj = (MSJ.T @ d.Phi).reshape(nf, 3, nf)                          # S_j^T M Phi
        self._kF = d.kq[N_RIGID:]
        self._cF = d.cq[N_RIGID:]
        del SJ, MSJ
        kern = _kernels()
        P = np.concatenate([[self._m], self._J0.ravel(), self._Aj.ravel(), self._Bsym.ravel(), self._Cjk.ravel(),
                            self._Dj.ravel(), self._kF, self._cF, d.A6.ravel(), d.A6inv.ravel(), d.com])
        assert P.size == kern.param_size(nf)
        self._P = np.ascontiguousarray(P, dtype=float)
        self._points_cache = {}
        del N

    def _setup_max_displacement(self):
        """Node blocks for the exact max elastic displacement (_reframe_kernels.max_node_norm): nodes in
        Morton (Z-curve) order of their coordinates; per block and superblock the mean of the nodes'
        translational mode-shape rows and the largest distance of a node's rows from it."""
        d = self.data
        kern = _kernels()
        B = kern.BLOCK
        span = max(float(np.max(np.ptp(d.nodes, axis=0))), 1e-300)          # one scale: compact blocks
        cell = np.minimum(((d.nodes - d.nodes.min(axis=0)) / span * 1023.0).astype(np.int64), 1023)
        code = np.zeros(d.n_nodes, dtype=np.int64)
        for bit in range(10):
            for axis in range(3):
                code |= ((cell[:, axis] >> bit) & 1) << (3 * bit + axis)
        order = np.argsort(code, kind="stable")
        U = d.Psi[d.trans_rows[order], N_RIGID:].reshape(d.n_nodes, 3 * d.nf)    # Phi_i rows, curve order

        def groups(X, starts, size):
            C = np.add.reduceat(X, starts, axis=0) / np.diff(np.append(starts, size))[:, None]
            return C

        starts = np.arange(0, d.n_nodes, B)
        bc = groups(U, starts, d.n_nodes)
        dist = np.sqrt(np.einsum("nk,nk->n", U - np.repeat(bc, np.diff(np.append(starts, d.n_nodes)), axis=0),
                                 U - np.repeat(bc, np.diff(np.append(starts, d.n_nodes)), axis=0)))
        br = np.maximum.reduceat(dist, starts)
        sstarts = np.arange(0, bc.shape[0], B)                       # superblocks: B blocks
        node_starts = starts[sstarts]
        sc = groups(U, node_starts, d.n_nodes)
        counts = np.diff(np.append(node_starts, d.n_nodes))
        sdist = np.sqrt(np.einsum("nk,nk->n", U - np.repeat(sc, counts, axis=0), U - np.repeat(sc, counts, axis=0)))
        sr = np.maximum.reduceat(sdist, node_starts)
        self._umax = (np.ascontiguousarray(order, dtype=np.int64), np.ascontiguousarray(bc), np.ascontiguousarray(br),
                      np.ascontiguousarray(sc), np.ascontiguousarray(sr))
        # the same arguments with an empty node order: the output kernel skips the search
        self._umax_skip = (np.zeros(0, dtype=np.int64),) + self._umax[1:]
        self._Psi_c = np.ascontiguousarray(d.Psi)

    def _max_elastic_displacement(self, q) -> float:
        return float(_kernels().max_node_norm(self._Psi_c, N_RIGID, self.data.dpn, *self._umax,
                                              np.ascontiguousarray(q, dtype=float)))

    def max_elastic_displacement(self, state: ReframeState) -> float:
        """Largest elastic nodal displacement |Phi_i q| over all nodes of ``state``, m (body frame norm): the
        value :meth:`output_vector` leaves out with ``max_elastic=False``."""
        nm = self.data.n_modes
        return self._max_elastic_displacement(state.eta[N_RIGID:nm])

    def _setup_paper(self):
        """G_ab = Psi^T M E_ab Psi for the coordinate transformation T_{m/n} (Eqs. 36-40).

        T_{m/n} applies the 3x3 matrix R_{m/n} to every translational and rotational triplet of x and
        xdot; followed by the inverse modal expansion (Eqs. 30-31, M_q = I) it is the modal matrix
        sum_ab R_ab G_ab (exact, no physical-space vectors needed).
        """
        d = self.data
        G = np.zeros((3, 3, d.n_modes, d.n_modes))
        MPsi = d.M @ d.Psi
        for a in range(3):
            for b in range(3):
                Y = np.zeros_like(d.Psi)
                Y[a::3, :] = d.Psi[b::3, :]
                G[a, b] = MPsi.T @ Y
        self._G = G.reshape(9, d.n_modes * d.n_modes)
        iR, iP, iQ = self.reference_nodes
        tr = d.trans_rows
        self._relP = d.Psi[tr[iP], :N_RIGID] - d.Psi[tr[iR], :N_RIGID]    # rigid rel. velocity of P w.r.t. R
        self._relQ = d.Psi[tr[iQ], :N_RIGID] - d.Psi[tr[iR], :N_RIGID]
        # g of Eq. (9) is linear in (v_P/R, v_Q/R) for the fixed dummy-body vectors p, q: tabulate it
        # once with flexfmu.core.rotation.angular_velocity (columns = responses to unit inputs).  h of Eq.
        # (14) is the same map applied to (a_P/R - omega x v_P/R, a_Q/R - omega x v_Q/R).
        E = np.eye(6)
        self._gmap = np.column_stack([angular_velocity(self._p_vec, self._q_vec, E[k, :3], E[k, 3:])
                                      for k in range(6)])

    # ---------------------------------------------------------------- initial conditions
    def initial_state(self, v0=(0.0, 0.0, 0.0), omega0=(0.0, 0.0, 0.0), q0=None, qd0=None, *,
                      rotation0=None, position0=None, t0: float = 0.0) -> ReframeState:
        """State from initial conditions (item 7).

        v0:         (3,) initial velocity of the centre of mass, global components, m/s.
        omega0:     (3,) initial angular velocity of the dummy body, body components, rad/s.
        q0, qd0:    (n_flexible,) initial flexible modal coordinates / velocities (elastic state).
        rotation0:  initial body -> global rotation (default identity: body frame = mesh frame).
        position0:  initial global position of the centre of mass (default: its mesh position).
        """
        d = self.data
        v0, omega0, q0, qd0, R0, pos = _check_initial(d, v0, omega0, q0, qd0, rotation0, position0)
        qdR = d.A6inv @ np.concatenate([R0.T @ v0, omega0])
        eta = np.concatenate([np.zeros(N_RIGID), q0, qdR, qd0])
        rv = reparametrize(rotvec_from_matrix(R0.T)) if self.scheme == "paper" else None
        return ReframeState(t=float(t0), position=pos, rotation=R0.copy(), eta=eta, rotvec=rv)

    def set_initial(self, *args, **kwargs) -> ReframeState:
        """Set ``self.state`` from initial conditions (arguments of :meth:`initial_state`)."""
        self.state = self.initial_state(*args, **kwargs)
        return self.state

    # ---------------------------------------------------------------- stepping
    def step(self, dt: float, load=None) -> ReframeState:
        """Advance ``self.state`` by one step dt (s) under ``load`` (PointLoad or list); return it."""
        self.state = self.advance(self.state, dt, load)
        return self.state

    def advance(self, state: ReframeState, dt: float, load=None) -> ReframeState:
        """One step from ``state`` (not modified); returns the new state."""
        return self.advance_steps(state, dt, 1, load)

    def advance_steps(self, state: ReframeState, dt: float, n_steps: int, load=None) -> ReframeState:
        """``n_steps`` steps of dt from ``state`` (not modified): the same as as many :meth:`advance` calls
        (same numbers), in one call of the step kernel for the consistent and exponential schemes."""
        dt = _check_dt(dt)
        if isinstance(n_steps, bool) or not isinstance(n_steps, numbers.Integral) or n_steps < 1:
            raise ParameterError("n_steps", f"{n_steps!r}", "integer >= 1")
        if self.stability_limited:
            self.data.check_stability(dt)
        loads = load if isinstance(load, _Prepared) else _Prepared(self.data.resolve_loads(load))
        if self.scheme != "paper":
            return self._consistent_steps(state, dt, int(n_steps), loads)
        s = state
        for _ in range(int(n_steps)):
            s = self._paper_step(s, dt, loads.items)
            if not (np.all(np.isfinite(s.eta)) and np.all(np.isfinite(s.rotation))
                    and np.all(np.isfinite(s.position))):
                raise FlexfmuError(f"reframe: non-finite state at t = {s.t:.6g} s (scheme {self.scheme!r})")
        return s

    # ---------------------------------------------------------------- consistent scheme
    def _kernel_loads(self, loads: "_Prepared") -> np.ndarray:
        """Node data of the loads for the step kernel: per load [follower, rotational DOFs, arm (3),
        translational rows of Phi (3 nf), rotational rows (3 nf)]; cached on ``loads``."""
        cached = loads._kernel
        if cached is not None and cached[0] is self:
            return cached[1]
        d = self.data
        nf = d.nf
        blocks = []
        for ld in loads.items:
            rot = d.Phi[d.rot_rows[ld.node]] if d.rot_rows is not None else np.zeros((3, nf))
            blocks.append(np.concatenate([[float(ld.follower), float(d.rot_rows is not None)], d.Xc[ld.node],
                                          d.Phi[d.trans_rows[ld.node]].ravel(), rot.ravel()]))
        LP = np.ascontiguousarray(np.concatenate(blocks) if blocks else np.zeros(0), dtype=float)
        loads._kernel = (self, LP)
        return LP

    def _consistent_steps(self, s: ReframeState, dt: float, n: int, loads: "_Prepared") -> ReframeState:
        kern = _kernels()
        LP = self._kernel_loads(loads)
        SV, held = loads.stage_values(s.t, dt, n)
        y0 = _state_vector(s)
        if self.scheme == "consistent" and self._Gk.size == 0:
            y, t, done, status = kern.consistent_steps(self._P, LP, self.data.nf, self.deformed_load_arm, SV, held,
                                                       float(s.t), dt, n, y0)
        else:
            EX = self._exponential(dt) if self.scheme == "exponential" else np.zeros(0)
            y, t, done, status = kern.reframe_steps(self._P, LP, self._Gk, EX, self.data.nf, self.deformed_load_arm,
                                                    SV, held, float(s.t), dt, n, y0)
        if status == 1:
            loads.check((t, t + 0.5 * dt, t + dt))         # raises the history's ParameterError
        if status:
            raise FlexfmuError(f"reframe: non-finite state at t = {t:.6g} s (scheme {self.scheme!r})")
        return _state_from_vector(t, y)

    def _velocities(self, state):
        d = self.data
        nm = d.n_modes
        vw = d.A6 @ state.eta[nm:nm + N_RIGID]
        return vw[:3], vw[3:], state.eta[N_RIGID:nm].copy(), state.eta[nm + N_RIGID:].copy()

    def _point_data(self, points: np.ndarray) -> np.ndarray:
        """Output points for the kernel: rows [X - c (3), translational rows of Phi (3 nf)]; cached."""
        key = points.tobytes()
        PP = self._points_cache.get(key)
        if PP is None:
            d = self.data
            PP = np.ascontiguousarray(np.hstack([d.Xc[points], d.Phi[d.trans_rows[points]].reshape(len(points), -1)])
                                      if len(points) else np.zeros((0, 3 + 3 * d.nf)), dtype=float)
            if len(self._points_cache) > 16:
                self._points_cache.clear()
            self._points_cache[key] = PP
        return PP

    def output_vector(self, state: ReframeState, loads: "_Prepared", points: np.ndarray,
                      max_elastic: bool = True) -> np.ndarray:
        """All outputs of one state as one flat array (consistent scheme): frame origin (3), its velocity (3),
        quaternion (4), omega (3), alpha (3), com position (3), com velocity (3), q (nf), qdot (nf),
        max elastic displacement (1), then per point position, velocity, acceleration, and their rigid
        parts (6 x 3).  :meth:`snapshot` wraps it; the ReframeBody FMU reads it directly.

        max_elastic=False skips the search over the mesh for the max elastic displacement, the one output
        whose cost grows with the mesh, and puts -1 in its place (:meth:`max_elastic_displacement` gives
        it alone; the paper scheme computes it always); everything else is O(modes^2)."""
        if self.scheme == "paper":
            snap = self.snapshot(state, loads, points)
            return np.concatenate([snap.frame_origin, snap.frame_origin_velocity, snap.quaternion, snap.omega,
                                   snap.alpha, snap.com_position, snap.com_velocity, snap.q, snap.qd,
                                   [snap.max_elastic_displacement],
                                   np.stack([snap.point_position, snap.point_velocity, snap.point_acceleration,
                                             snap.point_position_rigid, snap.point_velocity_rigid,
                                             snap.point_acceleration_rigid], axis=1).ravel()])
        d = self.data
        SV, held = loads.stage_values(state.t, 0.0, 1)
        if not held and not np.all(np.isfinite(SV)):
            loads.check((state.t,))
        y = _state_vector(state)
        kern = _kernels()
        umax = self._umax if max_elastic else self._umax_skip
        if self._Gk.size:
            return kern.reframe_outputs(self._P, self._kernel_loads(loads), self._Gk, d.nf, self.deformed_load_arm,
                                        SV[0, 0], y, self._point_data(points), self._Psi_c, d.dpn, *umax)
        return kern.consistent_outputs(self._P, self._kernel_loads(loads), d.nf, self.deformed_load_arm,
                                       SV[0, 0], y, self._point_data(points), self._Psi_c, d.dpn, *umax)

    # ---------------------------------------------------------------- paper scheme
    def _paper_fq(self, t, A, q, loads):
        """f_q = Psi^T f_x (Eq. 32) with f_x in the components of the frame whose global->body matrix is A.

        With deformed_load_arm the rigid-rotation part gets the extra moment u_F x f (u_F = elastic
        displacement Phi q_F at the loaded node): A6^T [0; u_F x f].
        """
        d = self.data
        fq = np.zeros(d.n_modes)
        for ld in loads:
            f = ld.force(t)
            m = ld.moment(t)
            f_b = f if ld.follower else A @ f
            m_b = m if ld.follower else A @ m
            rows = d.trans_rows[ld.node]
            fq += d.Psi[rows].T @ f_b
            if d.rot_rows is not None:
                fq += d.Psi[d.rot_rows[ld.node]].T @ m_b
            if self.deformed_load_arm and d.nf:
                u = d.Phi[rows] @ q[N_RIGID:]
                fq[:N_RIGID] += d.A6.T @ np.concatenate([np.zeros(3), _cross(u, f_b)])
        return fq

    def _paper_etadot(self, eta, fq):
        """Eq. (35) with M_q = I: eta_dot = H eta + [0; f_q]."""
        nm = self.data.n_modes
        q, qd = eta[:nm], eta[nm:]
        return np.concatenate([qd, -self.data.kq * q - self.data.cq * qd + fq])

    def _paper_transform(self, eta, incr, Rmn):
        """Eqs. (36)-(40) bracket: T_{m/n}({x_n; xdot_n} + Psi incr - {Psi_R incr_R; 0}), then Eqs. (30)-(31)."""
        nm = self.data.n_modes
        qt = eta[:nm] + incr[:nm]
        qt[:N_RIGID] = eta[:N_RIGID]                  # the rigid displacement increment is removed
        qdt = eta[nm:] + incr[nm:]
        G = (Rmn.ravel() @ self._G).reshape(nm, nm)
        return np.concatenate([G @ qt, G @ qdt])

    def _paper_rel(self, x6):
        """Rigid-mode relative velocities (or accelerations) of P and Q w.r.t. R from rigid modal rates."""
        return self._relP @ x6, self._relQ @ x6

    def _g(self, vP, vQ):
        """Eq. (9) (tabulated, see _setup_paper)."""
        return self._gmap[:, :3] @ vP + self._gmap[:, 3:] @ vQ

    def _paper_omega(self, eta):
        """Eq. (36): omega_n = g(v_P/R, v_Q/R) from the rigid-mode part of eta (body components)."""
        nm = self.data.n_modes
        vP, vQ = self._paper_rel(eta[nm:nm + N_RIGID])
        return self._g(vP, vQ), vP, vQ

    def _paper_step(self, s, dt, loads):
        """One step of Section 3 as printed (Eqs. 36-40).

        Resolved ambiguities (equation numbers of the paper):

        * Eqs. (36)-(37), stages: v_P/R, a_P/R are the relative velocities / accelerations of the
          *embedded rigid motion* (rigid-mode part Psi_R qdot_R, Psi_R qddot_R of eta, eta_dot) at the
          undeformed positions p = RP, q = RQ of the dummy body, in the current (stage) frame's
          components; omega = g(...) of Eq. (9), alpha = h(...) of Eq. (14) (both body components).
        * Step k1 (text garbled): Delta_k1 eta = dt (H eta_n + [0; f_q,n]),
          Delta_k1 v = dt (a_n - omega_n x v_n) (Eq. 15 with the k1 data),
          Delta_k1 M = dt f^{-1}(theta_n, M_hat_n) Omega_n (Eq. 20).
        * T_{m/n}: every translational and rotational triplet of x and xdot is multiplied by
          R_{m/n} = A(M_m) A(M_n)^T (A of Eq. 18, global -> body), i.e. components in frame n are
          expressed in frame m; then the inverse modal expansion (Eqs. 30-31).
        * f_q,n and f_q,n+1: the loads at t_n and t_{n+1}, both with frame-n components (the frame at
          t_{n+1} is not yet known) and the elastic displacement of x_n for the deformed arm; stages
          2 and 3 use their mean, as printed.
        * Eq. (38): M is the rotation vector of the dummy body relative to the *global* frame,
          integrated additively; re-parametrised to |M| <= pi after each step (Eq. 22 is singular at
          2 pi).  Eq. (39)-(40) as printed: the RK4 combination of increments computed in the four
          stage frames, rigid displacement increment removed, transformed with R_{n+1/n}.
        * Position of the dummy body: its centre of mass moves by the translation part of
          Psi_R Delta_n q_R (the rigid modes rotate about the centre of mass), expressed in frame n.
        """
        d = self.data
        nm = d.n_modes
        phi_n = s.rotvec
        A_n = _rodrigues(phi_n).T                  # Eq. (18)-(19), = flexfmu.core.rotation.rotation_matrix
        eta_n = s.eta
        fq_n = self._paper_fq(s.t, A_n, eta_n[:nm], loads)
        fq_1 = self._paper_fq(s.t + dt, A_n, eta_n[:nm], loads)
        w_n, vP_n, vQ_n = self._paper_omega(eta_n)
        # k1
        D1 = dt * self._paper_etadot(eta_n, fq_n)
        aP, aQ = self._paper_rel(D1[nm:nm + N_RIGID] / dt)
        dvP = dt * (aP - _cross(w_n, vP_n))
        dvQ = dt * (aQ - _cross(w_n, vQ_n))
        DM1 = dt * _rotvec_rate(phi_n, w_n)         # Eqs. (20)-(22)
        incs_eta, incs_M = [D1], [DM1]
        f_stage = (0.5 * (fq_n + fq_1), 0.5 * (fq_n + fq_1), fq_1)
        frac = (0.5, 0.5, 1.0)
        for k in range(3):                          # stages k2, k3, k4
            c = frac[k]
            vP = vP_n + c * dvP
            vQ = vQ_n + c * dvQ
            w_k = self._g(vP, vQ)
            phi_k = phi_n + c * incs_M[-1]
            R_kn = _rodrigues(phi_k).T @ A_n.T
            eta_k = self._paper_transform(eta_n, c * incs_eta[-1], R_kn)
            Dk = dt * self._paper_etadot(eta_k, f_stage[k])
            if k < 2:
                aP, aQ = self._paper_rel(Dk[nm:nm + N_RIGID] / dt)
                dvP = dt * (aP - _cross(w_k, vP))
                dvQ = dt * (aQ - _cross(w_k, vQ))
            incs_eta.append(Dk)
            incs_M.append(dt * _rotvec_rate(phi_k, w_k))
        phi_1 = phi_n + (incs_M[0] + 2 * incs_M[1] + 2 * incs_M[2] + incs_M[3]) / 6.0   # Eq. (38)
        D_eta = (incs_eta[0] + 2 * incs_eta[1] + 2 * incs_eta[2] + incs_eta[3]) / 6.0           # Eq. (39)
        A_1 = _rodrigues(phi_1).T
        eta_1 = self._paper_transform(eta_n, D_eta, A_1 @ A_n.T)                               # Eq. (40)
        dcom = (d.A6 @ D_eta[:N_RIGID])[:3]
        position = s.position + A_n.T @ dcom
        return ReframeState(t=s.t + dt, position=position, rotation=A_1.T.copy(), eta=eta_1,
                            rotvec=reparametrize(phi_1))

    def _paper_kinematics(self, s, loads):
        """omega (Eq. 36), alpha (Eq. 37), a_o (COM), qddot at a state, body components."""
        d = self.data
        nm = d.n_modes
        fq = self._paper_fq(s.t, s.rotation.T, s.eta[:nm], loads)
        etadot = self._paper_etadot(s.eta, fq)
        w, vP, vQ = self._paper_omega(s.eta)
        aP, aQ = self._paper_rel(etadot[nm:nm + N_RIGID])
        alpha = angular_acceleration(self._p_vec, self._q_vec, vP, vQ, aP, aQ, w)
        vw = d.A6 @ s.eta[nm:nm + N_RIGID]
        a_c = (d.A6 @ etadot[nm:nm + N_RIGID])[:3]
        return vw[:3], w, a_c, alpha, etadot[nm:]

    # ---------------------------------------------------------------- outputs
    def nodal_state(self, state: ReframeState | None = None) -> NodalState:
        """Nodal positions (global), elastic displacement and nodal velocities of a state."""
        s = self.state if state is None else state
        d = self.data
        nm = d.n_modes
        R = s.rotation
        if self.scheme != "paper":
            v, w, q, qd = self._velocities(s)
            u = d.Phi @ q
            wb = d.Phi @ qd
            # T v + S(X - c + u) omega: v + omega x y on translational DOFs, omega on rotational DOFs
            wb[d.trans_rows] += v + np.cross(w, d.Xc + u[d.trans_rows])
            if d.rot_rows is not None:
                wb[d.rot_rows] += w
        else:
            u = d.Psi @ s.eta[:nm]
            wb = d.Psi @ s.eta[nm:]
        pos = s.position + (d.Xc + u[d.trans_rows]) @ R.T
        wg = (wb.reshape(-1, 3) @ R.T).ravel()
        return NodalState(positions=pos, displacement=u, velocity_body=wb, velocity=wg)

    def _outputs(self, s, loads, pts):
        """omega, alpha, com velocity, and point kinematics (full, rigid) of one state (paper scheme; the
        consistent scheme's are computed by the output kernel, :meth:`output_vector`).  Only the output
        points' rows of Psi are used, so the cost does not depend on the mesh."""
        d = self.data
        nm = d.n_modes
        R = s.rotation
        v, w, a_o, alpha, qdd_all = self._paper_kinematics(s, loads)
        tr = d.trans_rows[pts]
        Psi_p = d.Psi[tr]                                          # (n_p, 3, nm)
        u = Psi_p @ s.eta[:nm]
        ud = Psi_p[..., N_RIGID:] @ s.eta[nm + N_RIGID:]
        udd = Psi_p[..., N_RIGID:] @ qdd_all[N_RIGID:]
        vcom = R @ v
        X = d.Xc[pts]                                              # (n_p, 3) rigid arms
        Wt = _skew(w).T
        wx = lambda r: r @ Wt                                      # noqa: E731  (omega x r, row-wise)
        pos_r = s.position + X @ R.T
        vel_r = (v + wx(X)) @ R.T
        acc_r = (a_o + X @ _skew(alpha).T + wx(wx(X))) @ R.T
        pos_f = s.position + (X + u) @ R.T
        # paper: x, xdot are the linear model's displacement / full velocity in the frame; full
        # acceleration = embedded rigid acceleration + elastic acceleration Phi qddot_F.
        vel_f = (Psi_p @ s.eta[nm:]) @ R.T
        acc_f = acc_r + udd @ R.T
        del ud
        umax = self._max_elastic_displacement(s.eta[N_RIGID:nm])
        v_origin = R @ (v + _cross(w, -d.com))          # d/dt of the frame origin, rigid with the dummy body
        return w, alpha, vcom, umax, v_origin, (pos_f, vel_f, acc_f, pos_r, vel_r, acc_r)

    def run(self, t_end: float, dt: float, load=None, points=(), *, state: ReframeState | None = None,
            every: int = 1) -> ReframeResult:
        """Integrate from ``state`` (default ``self.state``) to ``t_end`` (s) with steps dt; store every
        ``every``-th step (and the first).  ``points``: node indices or coordinates (nearest node) whose
        global position / velocity / acceleration (full and rigid part) are recorded.
        ``self.state`` is set to the final state.
        """
        dt = _check_dt(dt)
        s = self.state if state is None else state
        if not (isinstance(t_end, numbers.Real) and math.isfinite(t_end) and t_end > s.t):
            raise ParameterError("t_end", f"{t_end!r}", f"finite, > start time {s.t}")
        if not (isinstance(every, numbers.Integral) and every >= 1):
            raise ParameterError("every", f"{every!r}", "integer >= 1")
        if self.stability_limited:
            self.data.check_stability(dt)
        loads = self.prepare_loads(load)
        pts = self.point_indices(points)
        n_steps = int(round((t_end - s.t) / dt))
        if abs(n_steps * dt - (t_end - s.t)) > 1e-9 * max(1.0, t_end):
            n_steps = int(math.ceil((t_end - s.t) / dt))
        rec = [self.snapshot(s, loads, pts)]
        done = 0
        while done < n_steps:                 # records after every ``every``-th step and the last
            k = min(every - done % every, n_steps - done)
            s = self.advance_steps(s, dt, k, loads)
            done += k
            rec.append(self.snapshot(s, loads, pts))
        self.state = s
        stacked = {name: np.array([getattr(r, name) for r in rec]) for name in Snapshot.__dataclass_fields__}
        return ReframeResult(points=pts, final_state=s, **stacked)

    # ---------------------------------------------------------------- single-state outputs (FMU, CLI)
    def prepare_loads(self, load) -> "_Prepared":
        """Resolve loads once (node lookup, history checks) for many steps."""
        return load if isinstance(load, _Prepared) else _Prepared(self.data.resolve_loads(load))

    def point_indices(self, points) -> np.ndarray:
        """Node indices of output points given as node indices or coordinates (nearest node)."""
        return np.array([self.data.node_index(p, f"points[{k}]") for k, p in enumerate(points)], dtype=np.int64)

    def snapshot(self, state: ReframeState, loads: "_Prepared", points: np.ndarray) -> "Snapshot":
        """All outputs of one state (the loads enter the accelerations)."""
        if self.scheme != "paper":
            vec = self.output_vector(state, loads, points)
            nf = self.data.nf
            kin = vec[23 + 2 * nf:].reshape(len(points), 6, 3)
            return Snapshot(t=state.t, frame_origin=vec[0:3], frame_origin_velocity=vec[3:6],
                            rotation=np.array(state.rotation), quaternion=vec[6:10], omega=vec[10:13],
                            alpha=vec[13:16], com_position=vec[16:19], com_velocity=vec[19:22], q=vec[22:22 + nf],
                            qd=vec[22 + nf:22 + 2 * nf], max_elastic_displacement=float(vec[22 + 2 * nf]),
                            point_position=kin[:, 0], point_velocity=kin[:, 1], point_acceleration=kin[:, 2],
                            point_position_rigid=kin[:, 3], point_velocity_rigid=kin[:, 4],
                            point_acceleration_rigid=kin[:, 5])
        w, alpha, vcom, umax, v_origin, kin = self._outputs(state, loads.items, points)
        nm = self.data.n_modes
        return Snapshot(t=state.t, frame_origin=state.position - state.rotation @ self.data.com,
                        frame_origin_velocity=v_origin, rotation=state.rotation.copy(),
                        quaternion=quaternion_from_rotation(state.rotation), omega=w, alpha=alpha,
                        com_position=state.position.copy(), com_velocity=vcom, q=state.eta[N_RIGID:nm].copy(),
                        qd=state.eta[nm + N_RIGID:].copy(), max_elastic_displacement=umax,
                        point_position=kin[0], point_velocity=kin[1], point_acceleration=kin[2],
                        point_position_rigid=kin[3], point_velocity_rigid=kin[4], point_acceleration_rigid=kin[5])


@dataclass
class Snapshot:
    """Outputs of one state: the fields of :class:`ReframeResult` without the time axis (point fields
    (n_p, 3))."""

    t: float
    frame_origin: np.ndarray
    frame_origin_velocity: np.ndarray
    rotation: np.ndarray
    quaternion: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    com_position: np.ndarray
    com_velocity: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    max_elastic_displacement: float
    point_position: np.ndarray
    point_velocity: np.ndarray
    point_acceleration: np.ndarray
    point_position_rigid: np.ndarray
    point_velocity_rigid: np.ndarray
    point_acceleration_rigid: np.ndarray


class _Prepared:
    """Loads resolved once (node lookup, history checks) for a whole run; gathers their values at the RK4
    stage times into one array for the step kernel."""

    def __init__(self, items):
        self.items = items
        self._held = None        # (1, 3, n_loads, 6) values when every history is constant
        self._kernel = None      # (integrator, packed node data) for the consistent-scheme kernel

    @property
    def constant(self) -> bool:
        return all(ld.force.constant and ld.moment.constant for ld in self.items)

    def set_held(self, index: int, force, moment=None, *, checked: bool = False) -> None:
        """Make load ``index`` constant (checked like a PointLoad's constant force / moment): the input held
        over a co-simulation step.  checked=True: force and moment are finite float (3,) arrays already
        (the caller checked them), taken as they are."""
        ld = self.items[index]
        make = _History.held if checked else _History
        ld.force = make(force, "load.force")
        if moment is not None:
            ld.moment = make(moment, "load.moment")
        if self._held is not None:        # every load was constant and still is: update its row in place
            self._held[0, :, index, 0:3] = ld.force.raw(0.0)
            self._held[0, :, index, 3:6] = ld.moment.raw(0.0)

    def stage_values(self, t: float, dt: float, n: int):
        """Force and moment of every load at t_k, t_k + dt/2, t_k + dt (t_0 = t, t_{k+1} = t_k + dt) for
        k < n: ``(values (n, 3, n_loads, 6), False)``; ``(values (1, 3, n_loads, 6), True)`` if constant."""
        if self._held is None and self.constant:
            self._held = self._values([(0.0, 0.0, 0.0)])
        if self._held is not None:
            return self._held, True
        times = []
        for _ in range(n):
            times.append((t, t + 0.5 * dt, t + dt))
            t = t + dt
        return self._values(times), False

    def _values(self, times):
        items = self.items
        if not items:
            return np.zeros((len(times), 3, 0, 6))
        raw = []
        for stage_times in times:
            for ts in stage_times:
                for ld in items:
                    raw.append(ld.force.raw(ts))
                    raw.append(ld.moment.raw(ts))
        try:
            values = np.array(raw, dtype=float)
        except (TypeError, ValueError):
            values = None
        if values is None or values.shape != (len(raw), 3):
            for stage_times in times:
                self.check(stage_times)
            raise ParameterError("load", "load history values of inconsistent shape", "f(t) -> finite (3,)")
        return values.reshape(len(times), 3, len(items), 6)

    def check(self, stage_times) -> None:
        """Evaluate every history at the given times with the full checks (raises ParameterError)."""
        for ts in stage_times:
            for ld in self.items:
                ld.force(ts)
                ld.moment(ts)


# --------------------------------------------------------------------------- fixed-frame baseline
@dataclass
class BaselineResult:
    """Fixed-frame linear baseline: t (n_t,), eta (n_t, 2 n_modes) modal state in the global frame,
    com_position / com_velocity (n_t, 3), points (n_p,), point_position / point_velocity (n_t, n_p, 3)."""

    t: np.ndarray
    eta: np.ndarray
    com_position: np.ndarray
    com_velocity: np.ndarray
    points: np.ndarray
    point_position: np.ndarray
    point_velocity: np.ndarray


class FixedFrameBaseline:
    """The same model integrated conventionally in the fixed global frame (item 9): Eq. (35) with RK4,
    x = Psi q the displacement from the initial (mesh) configuration, loads with undeformed arms and
    global components (follower loads use the initial orientation).  Valid only for small rotations:
    the comparison shows what the reframing buys."""

    def __init__(self, structure: Structure, basis):
        self.data = _ModelData(structure, basis)

    def run(self, t_end, dt, load=None, points=(), *, v0=(0, 0, 0), omega0=(0, 0, 0), q0=None, qd0=None,
            every: int = 1) -> BaselineResult:
        d = self.data
        dt = _check_dt(dt)
        d.check_stability(dt)
        if not (isinstance(t_end, numbers.Real) and math.isfinite(t_end) and t_end > 0):
            raise ParameterError("t_end", f"{t_end!r}", "finite, > 0")
        v0, omega0, q0, qd0, _, _ = _check_initial(d, v0, omega0, q0, qd0, None, None)
        loads = d.resolve_loads(load)
        pts = np.array([d.node_index(p, f"points[{k}]") for k, p in enumerate(points)], dtype=np.int64)
        nm = d.n_modes
        eta = np.concatenate([np.zeros(N_RIGID), q0, d.A6inv @ np.concatenate([v0, omega0]), qd0])

        def fq(t):
            out = np.zeros(nm)
            for ld in loads:
                out += d.Psi[d.trans_rows[ld.node]].T @ ld.force(t)
                if d.rot_rows is not None:
                    out += d.Psi[d.rot_rows[ld.node]].T @ ld.moment(t)
            return out

        def rhs(t, e):
            return np.concatenate([e[nm:], -d.kq * e[:nm] - d.cq * e[nm:] + fq(t)])

        n_steps = int(math.ceil((t_end - 1e-12 * t_end) / dt))
        rec = []
        tr = d.trans_rows[pts]

        def record(t, e):
            x = d.Psi @ e[:nm]
            xd = d.Psi @ e[nm:]
            tc = (d.A6 @ e[:N_RIGID])[:3]
            vc = (d.A6 @ e[nm:nm + N_RIGID])[:3]
            rec.append((t, e.copy(), d.com + tc, vc, d.nodes[pts] + x[tr], xd[tr]))

        t = 0.0
        record(t, eta)
        for n in range(n_steps):
            k1 = rhs(t, eta)
            k2 = rhs(t + 0.5 * dt, eta + 0.5 * dt * k1)
            k3 = rhs(t + 0.5 * dt, eta + 0.5 * dt * k2)
            k4 = rhs(t + dt, eta + dt * k3)
            eta = eta + (dt / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
            t = (n + 1) * dt
            if (n + 1) % every == 0 or n + 1 == n_steps:
                record(t, eta)
        cols = list(zip(*rec))
        return BaselineResult(t=np.array(cols[0]), eta=np.array(cols[1]), com_position=np.array(cols[2]),
                              com_velocity=np.array(cols[3]), points=pts, point_position=np.array(cols[4]),
                              point_velocity=np.array(cols[5]))
