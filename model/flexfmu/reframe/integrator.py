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
    velocities of the moving, deformed body (``flexfmu.reframe.kernels_numpy._rhs``), so the conventional M, K, modal basis
    are all that is used.  After the step the frame is re-configured onto the dummy body at t_{n+1}:
    the whole rigid part is absorbed into the frame pose (q_R = 0 always) and the momenta are
    expressed in the new frame.  In the dt -> 0 limit this is a modally reduced floating-frame model
    whose frame obeys the linearised mean-axis conditions (Psi_R^T M u = 0): the flexible modes are
    M-orthogonal to the rigid ones.

``"paper"``
    Section 3 as printed (Eqs. 36-40), ambiguities resolved as documented in
    :meth:`flexfmu.reframe.schemes.PaperScheme._paper_step`.

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

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.core.angular_motion import oblique_basis
from flexfmu.core.rotation import quaternion_from_rotation
from flexfmu.core.structure import N_RIGID, Structure
from flexfmu.core.step_size import same_step
# Loads, states / results, the model checks, the baseline and the kernel calls live in their own modules; their
# public names are re-exported here, where the rest of flexfmu and its users import them from.
from flexfmu.reframe import schemes as _schemes
from flexfmu.reframe.baseline import BaselineResult, FixedFrameBaseline
from flexfmu.reframe.kernel_calls import KernelArguments, KernelCalls
from flexfmu.reframe.layout import output_layout
from flexfmu.reframe.loads import PointLoad, _Prepared, constant_load, half_sine_pulse
from flexfmu.reframe.modeldata import RK4_STABILITY_LIMIT, _check_dt, _check_initial, _ModelData
from flexfmu.reframe.schemes import SCHEMES, exponential_coefficients
from flexfmu.reframe.results import NodalState, ReframeResult, ReframeState, Snapshot

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
    "KernelArguments",
]


# --------------------------------------------------------------------------- the integrator
class ReframeIntegrator(KernelCalls):
    """Reframe flexible-body integrator (see the module docstring).

    structure:          conventional model (:class:`~flexfmu.core.structure.Structure`), free-free.
    basis:              :class:`~flexfmu.linalg.modal_basis.ModalBasis` (6 rigid + n flexible modes,
                        mass-orthonormal), or an int n: ``modal_basis(structure, n)`` (5% damping).
    reference_points:   (R, P, Q): node indices or coordinates (nearest node).  Default: the
                        structure's ``points`` R, P, Q if present (the plate: P1, P2, P3),
                        else R = the node nearest the centre of mass, P = the node farthest from R,
                        Q = the node farthest from the line RP.  Used only by Eqs. (36)-(37) of the
                        paper scheme: required non-colinear there, and whenever given explicitly (any
                        scheme); the consistent and exponential schemes take any structure with the
                        default points (a straight rod: colinear nodes).
    scheme:             "consistent" (default), "exponential" (the consistent equations, exact in
                        the flexible modes' linear part: no RK4 stability limit), "paper", or another
                        name in SCHEMES (flexfmu.reframe.schemes.register_scheme).
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
        self.scheme = scheme
        #: the scheme's object (flexfmu.reframe.schemes), chosen here once: every scheme-dependent step
        #: and output goes through it
        self.stepper = _schemes.make(scheme, self)
        self.deformed_load_arm = bool(deformed_load_arm)
        self.data = _ModelData(structure, basis)
        self._setup_geometric_stiffness(geometric_stiffness)
        self._setup_reference_points(reference_points)
        self.stepper.setup()
        self._setup_max_displacement()
        self._ex_cache = {}
        self.state = self.initial_state()

    @property
    def stability_limited(self) -> bool:
        """True if the step is limited by RK4 stability (dt * omega_max <= RK4_STABILITY_LIMIT)."""
        return self.stepper.stability_limited

    # ---------------------------------------------------------------- setup
    def _setup_geometric_stiffness(self, G):
        nf = self.data.nf
        self.geometric_stiffness = None
        self._Gk = np.zeros(0)
        if G is None:
            return
        if not self.stepper.geometric_stiffness:
            raise ParameterError("geometric_stiffness", f"not supported by scheme {self.scheme!r}", "None, or scheme "
                                 + " / ".join(f'"{x}"' for x in _schemes.scheme_names("geometric_stiffness")))
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

    def _setup_reference_points(self, reference_points):
        d = self.data
        if reference_points is None:
            pts = getattr(d.structure, "points", None) or {}
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
        # only the paper scheme's Eqs. (36)-(37) use R, P, Q; points given explicitly are checked for any scheme
        checked = isinstance(self.stepper, _schemes.PaperScheme) or reference_points is not None
        try:
            if checked:
                oblique_basis(p_vec, q_vec, min_sine=1e-3)
        except ParameterError as exc:
            raise ParameterError("reference_points",
                                 f"R, P, Q = nodes {idx} at {d.nodes[idx].tolist()} are coincident or colinear "
                                 f"({exc})", "three non-colinear points, |e1 x e2| >= 1e-3") from None
        self.reference_nodes = tuple(idx)
        self._p_vec, self._q_vec = p_vec, q_vec

    # ---------------------------------------------------------------- initial conditions
    def initial_state(self, v0=(0.0, 0.0, 0.0), omega0=(0.0, 0.0, 0.0), q0=None, qd0=None, *,
                      rotation0=None, position0=None, t0: float = 0.0) -> ReframeState:
        """State from initial conditions.

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
        return ReframeState(t=float(t0), position=pos, rotation=R0.copy(), eta=eta, rotvec=self.stepper.initial_rotvec(R0))

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

    def advance_steps(self, state: ReframeState, dt: float, n_steps: int, load=None, *,
                      check_stability: bool = True, coefficients_dt: float | None = None) -> ReframeState:
        """``n_steps`` steps of dt from ``state`` (not modified): the same as as many :meth:`advance` calls
        (same numbers), in one call of the step kernel for the consistent and exponential schemes.
        ``check_stability=False`` lets dt exceed the RK4 stability limit, for studies that measure the
        growth there; otherwise such a dt raises ParameterError.  ``coefficients_dt``: the exponential scheme's
        coefficients are those of this step, within STEP_RTOL of dt (an FMU's cached step for a host's last-bit
        variant of it: flexfmu.core.step_size states the error bound); the stages still take dt."""
        dt = _check_dt(dt)
        if isinstance(n_steps, bool) or not isinstance(n_steps, numbers.Integral) or n_steps < 1:
            raise ParameterError("n_steps", f"{n_steps!r}", "integer >= 1")
        if self.stability_limited and check_stability:
            self.data.check_stability(dt)
        loads = load if isinstance(load, _Prepared) else _Prepared(self.data.resolve_loads(load))
        if coefficients_dt is None:
            coefficients_dt = dt
        elif not same_step(coefficients_dt, dt):
            raise ParameterError("coefficients_dt", f"got {coefficients_dt!r} for dt = {dt!r}",
                                 "a step within STEP_RTOL of dt (flexfmu.core.step_size)")
        # an argument, not an attribute: the integrator is shared by FMU instances that may step in other threads
        return self.stepper.advance(state, dt, int(n_steps), loads, coefficients_dt)

    def _velocities(self, state):
        d = self.data
        nm = d.n_modes
        vw = d.A6 @ state.eta[nm:nm + N_RIGID]
        return vw[:3], vw[3:], state.eta[N_RIGID:nm].copy(), state.eta[nm + N_RIGID:].copy()

    # ---------------------------------------------------------------- outputs
    def nodal_state(self, state: ReframeState | None = None) -> NodalState:
        """Nodal positions (global), elastic displacement and nodal velocities of a state."""
        s = self.state if state is None else state
        d = self.data
        nm = d.n_modes
        R = s.rotation
        if self.stepper.kernel_outputs:
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
        if self.stepper.kernel_outputs:
            vec = self.output_vector(state, loads, points)
            L = output_layout(self.data.nf, len(points))
            kin = vec[L.points].reshape(len(points), 6, 3)
            return Snapshot(t=state.t, frame_origin=vec[L.frame_origin], frame_origin_velocity=vec[L.frame_origin_velocity],
                            rotation=np.array(state.rotation), quaternion=vec[L.quaternion], omega=vec[L.omega],
                            alpha=vec[L.alpha], com_position=vec[L.com_position], com_velocity=vec[L.com_velocity],
                            q=vec[L.q], qd=vec[L.qd], max_elastic_displacement=float(vec[L.max_elastic_displacement]),
                            point_position=kin[:, 0], point_velocity=kin[:, 1], point_acceleration=kin[:, 2],
                            point_position_rigid=kin[:, 3], point_velocity_rigid=kin[:, 4],
                            point_acceleration_rigid=kin[:, 5])
        w, alpha, vcom, umax, v_origin, kin = self.stepper.outputs(state, loads.items, points)
        nm = self.data.n_modes
        return Snapshot(t=state.t, frame_origin=state.position - state.rotation @ self.data.com,
                        frame_origin_velocity=v_origin, rotation=state.rotation.copy(),
                        quaternion=quaternion_from_rotation(state.rotation), omega=w, alpha=alpha,
                        com_position=state.position.copy(), com_velocity=vcom, q=state.eta[N_RIGID:nm].copy(),
                        qd=state.eta[nm + N_RIGID:].copy(), max_elastic_displacement=umax,
                        point_position=kin[0], point_velocity=kin[1], point_acceleration=kin[2],
                        point_position_rigid=kin[3], point_velocity_rigid=kin[4], point_acceleration_rigid=kin[5])


