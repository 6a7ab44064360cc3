"""Spin-up of a cantilever on a hub (Kane, Ryan & Banerjee 1987): where linear floating-frame models fail, and
how geometric (centrifugal) stiffening repairs them.

Problem (flexfmu/data/references/spinup/README.md): a straight beam, L = 10 m, EI = 1.4e4 N m^2, rho A = 1.2 kg/m,
EA = 2.8e7 N, no gravity, no damping, clamped at the origin to a hub that turns about z by

    theta(t) = (Omega_s / T_s) [t^2 / 2 + (T_s / 2 pi)^2 (cos(2 pi t / T_s) - 1)]   (t < T_s),
    theta(t) = Omega_s t - Omega_s T_s / 2                                            (t >= T_s),

Omega_s = 6 rad/s, T_s = 15 s.  The output is the tip deflection v in the rotating hub frame (m, along the
hub's y axis; negative = lagging the hub), compared with a geometrically exact Exudyn reference by

    max_t |v(t) - v_ref(t)| / max_t |v_ref(t)|   over 0 <= t <= 20 s   (peak |v_ref| = 0.5738 m).

Methods:
  * :func:`run_ffr` - the clamped FFR beam (flexfmu.ffr.dynamics) with the hub's rotation as the held base
    motion omega = theta' e_z, alpha = theta'' e_z (body frame), a0 = 0, sampled at mid-step.
  * :func:`run_reframe` - the free reframe body (flexfmu.reframe.integrator) of the beam plus a heavy hub (point mass and
    rotary inertia at the root) driven by a force and torque that make the hub follow theta(t) at the origin.

:func:`deviation` gives the metric, :func:`leaves_band` when a run first leaves a tolerance band.
:mod:`flexfmu.studies.spinup` is the study (``flexfmu bench spinup``, benchmarks/spinup.py): the table of every
method against the reference, convergence checks and the figure of docs/spinup.md.

Without stiffening the held stiffness K - Omega^2 M of the in-plane bending loses positive definiteness once
Omega passes the first non-rotating frequency 3.7977 rad/s (t = 8.512 s): the drivers report when that happens
(``unstable_from``) and when the deflection then exceeds ``divergence_limit`` (``failure_time``), and return
the history up to that point.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.errors import FlexfmuError, ParameterError, require
from flexfmu.ffr.dynamics import RK4_STABILITY_LIMIT, BaseMotion, FFRBeamDynamics
from flexfmu.linalg.modal import solve_modes
from flexfmu.ffr.scene import Scene, scene_from_dict
from flexfmu.studies.references import reference_path

# ---------------------------------------------------------------- the problem
LENGTH = 10.0             # m
EI = 1.4e4                # N m^2
RHO_A = 1.2               # kg/m
EA = 2.8e7                # N
OMEGA_S = 6.0             # rad/s, final hub rate
T_S = 15.0                # s, spin-up time
COMPARE_UNTIL = 20.0      # s, end of the comparison window
#: The geometrically exact Exudyn reference (package data; the README beside it gives its provenance).
REFERENCE = reference_path("spinup")
# An undamped held system is unstable when an eigenvalue's real part exceeds round-off (relative to |lambda|).
_GROWTH_TOL = 1e-9
#: An aluminium tube, about 63 mm x 2 mm, with exactly the problem's EI, rho A and EA: E = 70 GPa,
#: A = EA / E = 4e-4 m^2, I = EI / E = 2e-7 m^4 (both bending planes), rho = rho A / A = 3000 kg/m^3.
SECTION = {"A": EA / 7e10, "Iy": EI / 7e10, "Iz": EI / 7e10, "J": 2 * EI / 7e10}
MATERIAL = {"E": 7e10, "nu": 0.33, "rho": RHO_A / (EA / 7e10)}


def hub_angle(t):
    """theta(t) (rad), the hub's rotation about z."""
    t = np.asarray(t, float)
    spin = OMEGA_S / T_S * (t * t / 2 + (T_S / (2 * np.pi)) ** 2 * (np.cos(2 * np.pi * t / T_S) - 1))
    return np.where(t < T_S, spin, OMEGA_S * t - OMEGA_S * T_S / 2)


def hub_rate(t):
    """theta'(t) (rad/s)."""
    t = np.asarray(t, float)
    return np.where(t < T_S, OMEGA_S / T_S * (t - T_S / (2 * np.pi) * np.sin(2 * np.pi * t / T_S)), OMEGA_S)


def hub_acceleration(t):
    """theta''(t) (rad/s^2); largest 2 Omega_s / T_s = 0.8 at 7.5 s."""
    t = np.asarray(t, float)
    return np.where(t < T_S, OMEGA_S / T_S * (1 - np.cos(2 * np.pi * t / T_S)), 0.0)


def kane_scene() -> Scene:
    """The beam along body x from the origin, clamped there (the FFR model)."""
    return scene_from_dict({"name": "kane_spinup", "description": "Kane, Ryan & Banerjee (1987) spin-up beam",
                            "points": [[0.0, 0.0, 0.0], [LENGTH, 0.0, 0.0]], "section": dict(SECTION),
                            "material": dict(MATERIAL), "clamps": [0.0]})


def hub_scene(hub_mass: float, stub: float = 0.5) -> Scene:
    """The free beam of the reframe model: the same beam from the hub at the origin, the hub's point mass
    (kg) there, and a short stub of the same section along -z under the hub (length ``stub``, m).  The stub
    is there because the reframe integrator needs three non-colinear nodes; it lies on the spin axis (no
    centrifugal load), rides with the heavy hub in the retained modes (its own first mode is ~1500 rad/s
    at 0.5 m) and adds 0.6 kg to the hub."""
    return scene_from_dict({"name": "kane_spinup_hub", "description": "Kane spin-up beam on a free hub",
                            "points": [[0.0, 0.0, -stub], [0.0, 0.0, 0.0], [LENGTH, 0.0, 0.0]],
                            "section": dict(SECTION), "material": dict(MATERIAL), "clamps": [],
                            "point_masses": [{"s": stub, "mass": float(hub_mass)}]})


# ---------------------------------------------------------------- results
@dataclass
class SpinupResult:
    """One run.  t (s); v_tip, u_tip (m): tip deflection across and along the beam in the hub frame, up to
    the failure (if any).  unstable_from (s): when the linear model turns unstable (None: never) - FFR: the
    first base-motion sample at which the held system matrix has an eigenvalue with positive real part;
    reframe without stiffening: when the hub rate passes the first flexible frequency of the free model
    (a prediction, the linear centrifugal softening -omega^2 of that mode exceeding its stiffness).
    failure_time (s): first time |v_tip| > divergence_limit, or the integrator stopped (None: completed);
    info: method details (modes, step, hub tracking, ...)."""

    method: str
    geometric_stiffening: bool
    t: np.ndarray
    v_tip: np.ndarray
    u_tip: np.ndarray
    unstable_from: float | None = None
    failure_time: float | None = None
    failure_reason: str = ""
    info: dict = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        return self.failure_time is not None

    @property
    def label(self) -> str:
        return f"{self.method}, {'with' if self.geometric_stiffening else 'without'} geometric stiffening"


@dataclass
class Reference:
    """The geometrically exact reference (flexfmu/data/references/spinup/trajectory.csv): t (s), v_tip, u_tip (m)."""

    t: np.ndarray
    v_tip: np.ndarray
    u_tip: np.ndarray
    hub_angle: np.ndarray


def load_reference(path: str | Path | None = None) -> Reference:
    """Read the reference CSV (columns t, hub_angle, v_tip, u_tip; '#' lines are comments); default: the
    stored Exudyn reference, :data:`REFERENCE`."""
    path = REFERENCE if path is None else Path(path)
    require(path.is_file(), "path", f"no such file: {path}", f"the reference CSV, e.g. {REFERENCE}")
    lines = [ln for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    header = lines[0].split(",")
    require(set(header) >= {"t", "hub_angle", "v_tip", "u_tip"}, "path", f"columns {header}",
            "a CSV with the columns t, hub_angle, v_tip, u_tip")
    data = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    col = {name: data[:, k] for k, name in enumerate(header)}
    return Reference(t=col["t"], v_tip=col["v_tip"], u_tip=col["u_tip"], hub_angle=col["hub_angle"])


def deviation(result: SpinupResult, reference: Reference, t_end: float = COMPARE_UNTIL) -> float:
    """max |v - v_ref| / max |v_ref| over the reference samples 0 <= t <= t_end (the run's v interpolated
    linearly).  inf if the run failed or stopped before t_end."""
    if result.failed or result.t[-1] < t_end - 1e-9:
        return math.inf
    sel = reference.t <= t_end + 1e-9
    v = np.interp(reference.t[sel], result.t, result.v_tip)
    return float(np.max(np.abs(v - reference.v_tip[sel])) / np.max(np.abs(reference.v_tip[sel])))


def leaves_band(result: SpinupResult, reference: Reference, tolerance: float = 0.05,
                t_end: float = COMPARE_UNTIL) -> float | None:
    """First reference sample time (s) at which |v - v_ref| exceeds ``tolerance`` x max |v_ref| (0-t_end);
    the run's end if it stopped before t_end while still inside; None if it never leaves the band."""
    sel = (reference.t <= min(t_end, result.t[-1]) + 1e-9)
    v = np.interp(reference.t[sel], result.t, result.v_tip)
    peak = np.max(np.abs(reference.v_tip[reference.t <= t_end + 1e-9]))
    out = np.flatnonzero(np.abs(v - reference.v_tip[sel]) > tolerance * peak)
    if out.size:
        return float(reference.t[sel][out[0]])
    return float(result.t[-1]) if result.t[-1] < t_end - 1e-9 else None


# ---------------------------------------------------------------- FFR
def ffr_model(*, geometric_stiffening: bool, n_modes: int = 10, elements: int = 16,
              integrator: str = "exact") -> FFRBeamDynamics:
    """The clamped Kane beam as an FFR model with the lowest ``n_modes`` modes (undamped).

    The section is round (Iy = Iz), so the bending modes come in degenerate pairs (in-plane, out-of-plane):
    an even ``n_modes`` below the first torsion mode (n_modes <= 14) keeps whole pairs."""
    require(isinstance(n_modes, (int, np.integer)) and n_modes >= 1, "n_modes", f"got {n_modes!r}", ">= 1")
    model = build_beam_model(kane_scene(), "XFF", int(elements))
    require(n_modes <= model.n_free, "n_modes", f"got {n_modes}", f"1 .. {model.n_free}")
    modes = solve_modes(model.K_free, model.M_free, int(n_modes))
    return FFRBeamDynamics(model, modes, 0.0, LENGTH, LENGTH, integrator=integrator,
                           geometric_stiffening=geometric_stiffening)


def run_ffr(t_end: float = COMPARE_UNTIL, dt: float = 0.01, *, geometric_stiffening: bool, n_modes: int = 10,
            elements: int = 16, integrator: str = "exact", divergence_limit: float = LENGTH) -> SpinupResult:
    """The FFR beam through the spin-up: base rotation held over each step at its mid-step value (second
    order in dt), exact zero-order-hold step (or RK4).  Stops when |v_tip| > divergence_limit (m).
    With integrator="rk4", refuses (ParameterError naming dt) a step beyond the RK4 limit of the held system."""
    require(np.isfinite(t_end) and t_end > 0, "t_end", f"got {t_end!r}", "> 0 s")
    require(np.isfinite(dt) and 0 < dt <= t_end, "dt", f"got {dt!r}", f"0 < dt <= t_end = {t_end} s")
    require(np.isfinite(divergence_limit) and divergence_limit > 0, "divergence_limit",
            f"got {divergence_limit!r}", "> 0 m")
    dyn = ffr_model(geometric_stiffening=geometric_stiffening, n_modes=n_modes, elements=elements,
                    integrator=integrator)
    n_steps = int(round(t_end / dt))
    zero = np.zeros(3)
    state = dyn.initial_state()
    t, v, u = [0.0], [0.0], [0.0]
    unstable_from = failure_time = None
    reason = ""
    for k in range(n_steps):
        tm = (k + 0.5) * dt
        base = BaseMotion(omega=np.array([0.0, 0.0, float(hub_rate(tm))]),
                          alpha=np.array([0.0, 0.0, float(hub_acceleration(tm))]))
        if unstable_from is None or integrator == "rk4":
            lam = np.linalg.eigvals(dyn.system_matrix(base))
            if unstable_from is None and np.max(lam.real) > _GROWTH_TOL * np.max(np.abs(lam)):
                unstable_from = tm        # the time at which this step's base motion was sampled
            require(integrator != "rk4" or dt * np.max(np.abs(lam)) <= RK4_STABILITY_LIMIT, "dt",
                    f"dt * max|eig| = {dt:g} * {np.max(np.abs(lam)):.4g} > {RK4_STABILITY_LIMIT} at t = {tm:.3f} s: "
                    "RK4 would diverge on the highest retained mode",
                    f"dt <= {RK4_STABILITY_LIMIT / np.max(np.abs(lam)):.4g} s, integrator='exact' or fewer modes")
        state = dyn.step(state, dt, zero, zero, base)
        tip = dyn.tip_displacement(state)
        t.append(state.t)
        v.append(float(tip[1]))
        u.append(float(tip[0]))
        if not abs(v[-1]) <= divergence_limit:
            failure_time = state.t
            reason = (f"|v_tip| = {abs(v[-1]):.3g} m > {divergence_limit:g} m at t = {state.t:.3f} s "
                      f"(hub rate {float(hub_rate(state.t)):.4f} rad/s)")
            break
    return SpinupResult("FFR", bool(geometric_stiffening), np.array(t), np.array(v), np.array(u),
                        unstable_from, failure_time, reason,
                        {"n_modes": dyn.m, "elements": elements, "dt": dt, "integrator": integrator,
                         "frequencies_rad_s": dyn.omega_n.tolist()})


# ---------------------------------------------------------------- reframe
#: Hub of the free reframe body: a point mass and a rotary inertia (all three axes) at the root, heavy against
#: the beam (12 kg, 400 kg m^2 about the root) so that its tracking controller barely feels the beam.
HUB_MASS = 1.0e5          # kg
HUB_INERTIA = 1.0e6       # kg m^2
#: Hub tracking: feedforward of the rigid system plus a PD loop (held over each step) with this bandwidth and
#: damping ratio, on the hub's position (to the origin) and its angle (to theta(t)).
HUB_BANDWIDTH = 10.0      # rad/s
HUB_DAMPING = 1.0


def reframe_model(*, n_flexible: int = 8, elements: int = 16, hub_mass: float = HUB_MASS,
                  hub_inertia: float = HUB_INERTIA):
    """(structure, basis, geometric stiffness G (3, 3, nf, nf), beam model) of the free beam with its hub.

    The beam is :func:`hub_scene`.  The hub mass is a scene point mass at the root, so the inertia relief of
    the geometric stiffness sees it; its rotary inertia is added to the root node's rotational DOFs of M (the
    centrifugal patterns that the reframe model uses, X = [omega]x^2 with omega along a principal axis, have
    no moment about the centre of mass, so the relief does not need it).  Undamped modes."""
    from flexfmu.ffr.geometric_stiffness import inertial_geometric_stiffness
    from flexfmu.linalg.modal_basis import modal_basis

    require(np.isfinite(hub_mass) and hub_mass > 0, "hub_mass", f"got {hub_mass!r}", "> 0 kg")
    require(np.isfinite(hub_inertia) and hub_inertia > 0, "hub_inertia", f"got {hub_inertia!r}", "> 0 kg m^2")
    scene = hub_scene(hub_mass)
    model = build_beam_model(scene, "free", int(elements))
    structure = model.structure()
    root = model.mesh.node_at(scene.vertex_arc_lengths[1])
    hub = np.zeros(structure.n_dof)
    hub[6 * root + 3:6 * root + 6] = hub_inertia
    structure.M = (structure.M + sp.diags(hub)).tocsr()
    basis = modal_basis(structure, int(n_flexible), damping_ratio=0.0)
    G_X, _ = inertial_geometric_stiffness(model).modal(basis.shapes[:, 6:])
    return structure, basis, G_X, model


def run_reframe(t_end: float = COMPARE_UNTIL, dt: float = 0.01, *, geometric_stiffening: bool,
                n_flexible: int = 8, elements: int = 16, scheme: str = "consistent",
                divergence_limit: float = LENGTH, hub_mass: float = HUB_MASS,
                hub_inertia: float = HUB_INERTIA) -> SpinupResult:
    """The free reframe body (beam + hub) with the hub driven along theta(t) about the global z axis.

    The root node carries two loads (global components): a feedforward F_ff(t), M_ff(t) evaluated at the RK4
    stage times - the force that accelerates the rigid beam's centre of mass on its circle and the torque
    (J_hub + rho A L^3 / 3) theta'' of the rigid system - and a PD correction held over each step, computed
    from the hub's measured position, velocity, angle psi and rate (psi = frame angle + the root node's
    elastic rotation).  v_tip = -sin(psi) (x_tip - x_root) + cos(psi) (y_tip - y_root) (hub frame).
    info["hub_angle_error"] = max |psi - theta| (rad), info["hub_position_error"] = max |root position| (m)."""
    from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator

    require(np.isfinite(t_end) and t_end > 0, "t_end", f"got {t_end!r}", "> 0 s")
    require(np.isfinite(dt) and 0 < dt <= t_end, "dt", f"got {dt!r}", f"0 < dt <= t_end = {t_end} s")
    require(np.isfinite(divergence_limit) and divergence_limit > 0, "divergence_limit",
            f"got {divergence_limit!r}", "> 0 m")
    structure, basis, G_X, model = reframe_model(n_flexible=n_flexible, elements=elements, hub_mass=hub_mass,
                                                 hub_inertia=hub_inertia)
    integ = ReframeIntegrator(structure, basis, scheme=scheme,
                              geometric_stiffness=G_X if geometric_stiffening else None)
    root = model.mesh.node_at(model.mesh.scene.vertex_arc_lengths[1])
    tip = model.mesh.node_at(model.mesh.scene.total_length)
    m_beam = RHO_A * LENGTH
    J_rigid = hub_inertia + RHO_A * LENGTH**3 / 3.0

    def force_ff(t):
        th, w, al = float(hub_angle(t)), float(hub_rate(t)), float(hub_acceleration(t))
        e_x, e_y = np.array([math.cos(th), math.sin(th), 0.0]), np.array([-math.sin(th), math.cos(th), 0.0])
        return m_beam * 0.5 * LENGTH * (al * e_y - w * w * e_x)

    def moment_ff(t):
        return np.array([0.0, 0.0, J_rigid * float(hub_acceleration(t))])

    k_x, d_x = hub_mass * HUB_BANDWIDTH**2, 2 * HUB_DAMPING * hub_mass * HUB_BANDWIDTH
    k_th, d_th = hub_inertia * HUB_BANDWIDTH**2, 2 * HUB_DAMPING * hub_inertia * HUB_BANDWIDTH
    loads = integ.prepare_loads([PointLoad(root, force=force_ff, moment=moment_ff),
                                 PointLoad(root, force=np.zeros(3), moment=np.zeros(3))])
    state = integ.state
    n_steps = int(round(t_end / dt))
    t, v, u = [], [], []
    angle_err = pos_err = 0.0
    frame_turns = 0.0
    last_frame_angle = 0.0
    unstable_from = failure_time = None
    reason = ""
    for k in range(n_steps + 1):
        ns = integ.nodal_state(state)
        R = state.rotation
        raw = math.atan2(R[1, 0], R[0, 0])
        frame_turns += math.remainder(raw - last_frame_angle, 2 * math.pi)   # unwrap
        last_frame_angle = raw
        psi = frame_turns + float(ns.displacement[6 * root + 5])
        psi_rate = float(ns.velocity[6 * root + 5])
        r_root, v_root = ns.positions[root], ns.velocity[6 * root:6 * root + 3]
        d = ns.positions[tip] - r_root
        t.append(state.t)
        v.append(-math.sin(psi) * d[0] + math.cos(psi) * d[1])
        u.append(math.cos(psi) * d[0] + math.sin(psi) * d[1] - LENGTH)
        angle_err = max(angle_err, abs(psi - float(hub_angle(state.t))))
        pos_err = max(pos_err, float(np.linalg.norm(r_root)))
        if not abs(v[-1]) <= divergence_limit:
            failure_time = state.t
            reason = (f"|v_tip| = {abs(v[-1]):.3g} m > {divergence_limit:g} m at t = {state.t:.3f} s "
                      f"(hub rate {float(hub_rate(state.t)):.4f} rad/s)")
            break
        if k == n_steps:
            break
        if unstable_from is None and not geometric_stiffening and float(hub_rate(state.t)) > basis.omega[0]:
            unstable_from = state.t      # linear stiffness K - omega^2 M of the first mode < 0 from here on
        f_pd = -k_x * r_root - d_x * v_root
        m_pd = np.array([0.0, 0.0, k_th * (float(hub_angle(state.t)) - psi)
                         + d_th * (float(hub_rate(state.t)) - psi_rate)])
        loads.set_held(1, f_pd, m_pd)
        try:
            state = integ.advance(state, dt, loads)
        except ParameterError:
            raise                        # bad input (e.g. dt beyond the RK4 limit): not a divergence
        except FlexfmuError as exc:
            failure_time, reason = state.t + dt, f"integrator failed: {exc}"
            break
    integ.state = state
    return SpinupResult("reframe", bool(geometric_stiffening), np.array(t), np.array(v), np.array(u),
                        unstable_from, failure_time, reason,
                        {"n_flexible": basis.n_flexible, "elements": elements, "dt": dt, "scheme": scheme,
                         "hub_angle_error": angle_err, "hub_position_error": pos_err,
                         "frequencies_rad_s": basis.omega.tolist()})
