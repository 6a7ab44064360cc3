"""The schemes of the reframe integrator (:mod:`flexfmu.reframe.integrator`, whose docstring describes the
three built-in ones) behind one interface, and their one registry, :data:`SCHEMES`: :class:`ReframeIntegrator`
picks one object from the scheme's name once, in its constructor, and calls it for everything that depends on
the scheme; exported free bodies (flexfmu.body.free), the simulators' parameter checks, the CLI and the native
FMUs (flexfmu.fmi.native) read the class attributes of :class:`Scheme` instead of comparing names.  A new scheme
is a :class:`Scheme` subclass passed to :func:`register_scheme`.

The consistent and exponential schemes step with the compiled kernels (flexfmu.reframe.kernels) on the
integrator's packed model data and differ only in the per-dt coefficients they pass (none: classical
RK4; :func:`exponential_coefficients`: ETD-RK4).  The paper scheme (Section 3 as printed) is plain
numpy on the full modal matrices and keeps its own data here.
"""
from __future__ import annotations

import re
from types import MappingProxyType

import numpy as np

from flexfmu.core.checks import shown
from flexfmu.errors import FlexfmuError, ParameterError
from flexfmu.core.structure import N_RIGID
from flexfmu.core.angular_motion import angular_acceleration, angular_velocity
from flexfmu.core.rotation import reparametrize, rotvec_from_matrix
from flexfmu.core.rotation import rodrigues as _rodrigues
from flexfmu.core.rotation import rotvec_rate_unchecked as _rotvec_rate   # Eqs. (20)-(22), unchecked
from flexfmu.core.vec3 import cross as _cross
from flexfmu.core.vec3 import skew as _skew
from flexfmu.reframe.results import ReframeState

__all__ = ["Scheme", "ConsistentScheme", "ExponentialScheme", "PaperScheme", "SCHEMES", "register_scheme",
           "unregister_scheme", "scheme_names", "scheme_class", "make", "exponential_coefficients",
           "exponential_coefficients_scipy"]


def exponential_coefficients(stiffness, damping, dt: float) -> np.ndarray:
    """:func:`exponential_coefficients_scipy` computed by its C port (flexfmu.native.reframe, the one the native
    FMUs link) when the C kernels are in use (flexfmu.reframe.kernels.NATIVE; ``FLEXFMU_NATIVE_KERNELS=0``: the
    scipy reference).  Equal to ~1e-15 relative (tests/test_native_reframe_kernels.py)."""
    from flexfmu.reframe import kernels
    if kernels._use_native():
        from flexfmu.native import reframe as native
        return native.exponential_coefficients(stiffness, damping, dt)
    return exponential_coefficients_scipy(stiffness, damping, dt)


def exponential_coefficients_scipy(stiffness, damping, dt: float) -> np.ndarray:
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


class Scheme:
    """One scheme of a :class:`~flexfmu.reframe.integrator.ReframeIntegrator` (``integ``).

    What its users read, as class attributes (so without an integrator):

    stability_limited:    the step is limited by RK4 stability (dt * omega_max <= RK4_STABILITY_LIMIT): the
                          simulators' automatic internal step is 90 % of that limit; False: no limit, the
                          automatic internal step is chosen by the rotation per step (accuracy).
    kernel_coefficients:  None: the kernels step classical RK4; else a function (stiffness k_j, damping c_j, dt)
                          -> (nf, 6, 2, 2) per-mode coefficients the kernels take (the exponential scheme's ETD-RK4,
                          flexfmu.reframe.kernels).
    substeps:             kernel steps per step: a step of dt is ``substeps`` kernel steps of dt / substeps (the
                          stability limit is still checked on dt, which is conservative).
    geometric_stiffness:  the scheme takes a geometric-stiffness hook.
    kernel_outputs:       the outputs of a state come from the output kernel (ReframeIntegrator.output_vector);
                          else from :meth:`outputs`.
    for_bodies:           exported free bodies (flexfmu.body.free.FreeDynamics) can step with it: it is the kernels
                          with kernel_coefficients and substeps alone (no :meth:`advance` of its own).
    native_code:          the scheme's code in the native reframe kind (reframe.body[1] of csrc/native_reframe.c:
                          0 exponential, 1 consistent; C computes its coefficients itself), None: no native form.
    """

    name = ""
    stability_limited = True
    kernel_coefficients = None
    substeps = 1
    geometric_stiffness = True
    kernel_outputs = True
    for_bodies = False
    native_code: int | None = None

    def __init__(self, integ):
        self.integ = integ

    def setup(self) -> None:
        """Model data of the scheme, after the integrator's model, reference points and hooks are set."""
        self.integ._setup_consistent()

    def initial_rotvec(self, R0):
        """The ``rotvec`` of an initial state with body -> global rotation R0 (None: not used)."""
        return None

    def coefficients(self, dt: float):
        """Per-dt coefficients for the step kernel, flat (None: classical RK4), cached on the integrator."""
        return None if self.kernel_coefficients is None else self.integ._exponential(dt)

    def advance(self, state: ReframeState, dt: float, n: int, loads, coefficients_dt: float | None = None
                ) -> ReframeState:
        """n steps of dt from state (dt and n checked, loads prepared); the per-dt coefficients of
        coefficients_dt (default dt; within STEP_RTOL of it)."""
        k = self.substeps
        if k != 1:
            dt, n, coefficients_dt = dt / k, n * k, (dt if coefficients_dt is None else coefficients_dt) / k
        return self.integ._consistent_steps(state, dt, n, loads, coefficients_dt)


class ConsistentScheme(Scheme):
    name = "consistent"
    for_bodies = True
    native_code = 1


class ExponentialScheme(Scheme):
    name = "exponential"
    stability_limited = False
    kernel_coefficients = staticmethod(exponential_coefficients)
    for_bodies = True
    native_code = 0


class PaperScheme(Scheme):
    """Section 3 as printed (Eqs. 36-40), in modal space with the full modal matrices."""

    name = "paper"
    geometric_stiffness = False
    kernel_outputs = False

    @property
    def data(self):
        return self.integ.data

    @property
    def deformed_load_arm(self) -> bool:
        return self.integ.deformed_load_arm

    @property
    def _p_vec(self):
        return self.integ._p_vec

    @property
    def _q_vec(self):
        return self.integ._q_vec

    def _max_elastic_displacement(self, q) -> float:
        return self.integ._max_elastic_displacement(q)

    def initial_rotvec(self, R0):
        return reparametrize(rotvec_from_matrix(R0.T))

    def advance(self, state: ReframeState, dt: float, n: int, loads, coefficients_dt: float | None = None
                ) -> ReframeState:
        s = state                                      # no per-dt coefficients: coefficients_dt is not used
        for _ in range(n):
            s = self._paper_step(s, dt, loads.items)
            if not (np.all(np.isfinite(s.eta)) and np.all(np.isfinite(s.rotation))
                    and np.all(np.isfinite(s.position))):
                raise FlexfmuError(f"reframe: non-finite state at t = {s.t:.6g} s (scheme {self.name!r})")
        return s

    def setup(self):
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
        iR, iP, iQ = self.integ.reference_nodes
        tr = d.trans_rows
        self._relP = d.Psi[tr[iP], :N_RIGID] - d.Psi[tr[iR], :N_RIGID]    # rigid rel. velocity of P w.r.t. R
        self._relQ = d.Psi[tr[iQ], :N_RIGID] - d.Psi[tr[iR], :N_RIGID]
        # g of Eq. (9) is linear in (v_P/R, v_Q/R) for the fixed dummy-body vectors p, q: tabulate it
        # once with flexfmu.core.angular_motion.angular_velocity (columns = responses to unit inputs).  h of Eq.
        # (14) is the same map applied to (a_P/R - omega x v_P/R, a_Q/R - omega x v_Q/R).
        E = np.eye(6)
        self._gmap = np.column_stack([angular_velocity(self._p_vec, self._q_vec, E[k, :3], E[k, 3:])
                                      for k in range(6)])

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

    def outputs(self, s, loads, pts):
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



_REGISTRY: dict[str, type[Scheme]] = {}
#: name -> class of every registered scheme, in registration order (the order messages and the studies list
#: them); a read-only view that register_scheme and unregister_scheme keep current
SCHEMES = MappingProxyType(_REGISTRY)


def register_scheme(cls: type[Scheme]) -> type[Scheme]:
    """Add the scheme class ``cls`` to :data:`SCHEMES` under ``cls.name`` (a lower-case identifier); returns it, so
    it can decorate the class.  Refused (ValueError): a name already registered, or a native_code another scheme
    has (a subclass inherits its parent's, which the native runtime would then step in its place)."""
    if not (isinstance(cls, type) and issubclass(cls, Scheme)):
        raise TypeError(f"register_scheme: {cls!r} is not a subclass of flexfmu.reframe.schemes.Scheme")
    name = cls.name
    if not (isinstance(name, str) and re.fullmatch(r"[a-z][a-z0-9_]*", name)):
        raise ValueError(f"register_scheme: {cls.__name__}.name = {name!r}; a lower-case identifier is needed")
    if name in _REGISTRY:
        raise ValueError(f"register_scheme: a scheme {name!r} is registered already ({_REGISTRY[name].__name__})")
    if cls.native_code is not None:
        for other in _REGISTRY.values():
            if other.native_code == cls.native_code:
                raise ValueError(f"register_scheme: {name!r} has native_code {cls.native_code}, scheme "
                                 f"{other.name!r}'s; set native_code = None unless the native runtime steps it")
    _REGISTRY[name] = cls
    return cls


def unregister_scheme(name: str) -> type[Scheme]:
    """Remove the scheme ``name`` registered by :func:`register_scheme` (not a built-in one); returns its class."""
    if name in _BUILT_IN:
        raise ValueError(f"unregister_scheme: {name!r} is a built-in scheme")
    return _REGISTRY.pop(name)


def _passes(cls, where) -> bool:
    return where is None or (bool(getattr(cls, where)) if isinstance(where, str) else where(cls))


def scheme_names(where=None) -> tuple[str, ...]:
    """The names in :data:`SCHEMES` (registration order) whose class passes ``where``: None (all), the name of a
    class attribute that must be true (e.g. "for_bodies"), or a predicate on the class."""
    return tuple(name for name, cls in _REGISTRY.items() if _passes(cls, where))


def scheme_class(name, where=None, *, context: str = "", hint: str = "") -> type[Scheme]:
    """The class of the registered scheme ``name`` if it passes ``where`` (as in :func:`scheme_names`); else
    ParameterError naming ``scheme``, with ``context`` before the problem and, as allowed, the names that pass
    followed by ``hint``."""
    cls = _REGISTRY.get(name) if isinstance(name, str) else None
    if cls is None or not _passes(cls, where):
        raise ParameterError("scheme", f"{context}got {shown(name)}", " | ".join(scheme_names(where)) + hint)
    return cls


def make(name: str, integ) -> Scheme:
    """The scheme object of a name in SCHEMES for the integrator integ."""
    return scheme_class(name)(integ)


for _cls in (ConsistentScheme, PaperScheme, ExponentialScheme):
    register_scheme(_cls)
_BUILT_IN = frozenset(_REGISTRY)
