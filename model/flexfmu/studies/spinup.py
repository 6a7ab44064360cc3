# Over 500 lines on purpose: the spin-up models (shared by tests and the bench) and the study that compares them.
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
:func:`main` is the study itself (``flexfmu bench spinup``, benchmarks/spinup.py): the table of every method
against the reference, convergence checks and the figure of docs/spinup.md.

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
from flexfmu.studies import common
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


# ---------------------------------------------------------------- the study (flexfmu bench spinup)
STUDY = """Spin-up study (Kane, Ryan & Banerjee 1987): FFR and reframe models with and without geometric stiffening
against the geometrically exact Exudyn reference (flexfmu/data/references/spinup/trajectory.csv).

    flexfmu bench spinup [--quick] [--out REPORT.md]   # ~20 s: table on stdout, figures/spinup_tip_deflection.png
    .venv/bin/python benchmarks/spinup.py --no-figure  # table only

Metric: max_t |v - v_ref| / max_t |v_ref| over 0-20 s (peak |v_ref| = 0.5738 m).  Each method is also run at
half the step (dt / 2) and with more modes, to show that the numbers quoted are converged.  Times are CPU
seconds of one run on this machine (indicative only; the study is about accuracy and failure, not speed).
"""
DT = 0.01

# (label, runner, keyword arguments): the four comparisons of the figure, then the convergence checks.
RUNS = [
    ("FFR", run_ffr, {"geometric_stiffening": False}),
    ("FFR", run_ffr, {"geometric_stiffening": True}),
    ("reframe", run_reframe, {"geometric_stiffening": False}),
    ("reframe", run_reframe, {"geometric_stiffening": True}),
]
CHECKS = [
    ("FFR, dt/2", run_ffr, {"geometric_stiffening": True, "dt": DT / 2}),
    ("FFR, 14 modes, 32 elements", run_ffr, {"geometric_stiffening": True, "n_modes": 14, "elements": 32}),
    ("FFR, RK4 integrator", run_ffr, {"geometric_stiffening": True, "integrator": "rk4"}),
    ("reframe, dt/2", run_reframe, {"geometric_stiffening": True, "dt": DT / 2}),
    ("reframe, 12 flexible modes, 32 elements", run_reframe,
     {"geometric_stiffening": True, "n_flexible": 12, "elements": 32, "dt": DT / 2}),
    ("reframe, hub 10x lighter", run_reframe,
     {"geometric_stiffening": True, "hub_mass": HUB_MASS / 10, "hub_inertia": HUB_INERTIA / 10}),
    ("reframe, exponential scheme, dt = 0.05 s", run_reframe,
     {"geometric_stiffening": True, "scheme": "exponential", "dt": 0.05}),
]


def run_all(rows):
    """[(label, keyword arguments, SpinupResult, CPU s)] of the rows (label, runner, keyword arguments)."""
    import time

    out = []
    for label, runner, kwargs in rows:
        kw = {"dt": DT, **kwargs}
        t0 = time.process_time()
        result = runner(**kw)
        cpu = time.process_time() - t0
        out.append((label, kw, result, cpu))
    return out


def table(results, reference) -> str:
    lines = ["| method | stiffening | dt (s) | unstable from (s) | fails at (s) | max \\|v - v_ref\\| / peak, 0-20 s "
             "| leaves the 5 % band at (s) | peak v (m) at t (s) | hub angle / position error | CPU (s) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for label, kw, r, cpu in results:
        dev = deviation(r, reference)
        k = int(np.argmin(r.v_tip[r.t <= COMPARE_UNTIL])) if not r.failed else None
        hub = (f"{r.info['hub_angle_error']:.1e} rad / {r.info['hub_position_error']:.1e} m"
               if "hub_angle_error" in r.info else "clamped")
        lines.append("| " + " | ".join([
            label, "yes" if r.geometric_stiffening else "no", f"{kw['dt']:g}",
            "-" if r.unstable_from is None else f"{r.unstable_from:.2f}",
            "-" if r.failure_time is None else f"{r.failure_time:.2f}",
            "diverged" if not np.isfinite(dev) else f"{100 * dev:.3f} %",
            "-" if (t5 := leaves_band(r, reference)) is None else f"{t5:.2f}",
            "-" if k is None else f"{r.v_tip[k]:.4f} at {r.t[k]:.2f}",
            hub, f"{cpu:.1f}"]) + " |")
    ref_peak = int(np.argmin(reference.v_tip))
    lines.append(f"| reference (Exudyn ANCF) | exact | 6.25e-4 | - | - | 0 | - | {reference.v_tip[ref_peak]:.4f} at "
                 f"{reference.t[ref_peak]:.2f} | prescribed | - |")
    return "\n".join(lines)


def figure(results, reference, path: Path, plt) -> None:
    """The tip deflection of the four runs against the reference and their errors (``plt``: matplotlib.pyplot)."""
    # (colour, line style, width, alpha): the two unstiffened runs coincide, so the reframe one is drawn wide
    # and pale under the FFR one
    styles = {("FFR", False): ("tab:red", "--", 1.6, 1.0), ("FFR", True): ("tab:blue", "-", 1.6, 1.0),
              ("reframe", False): ("tab:orange", "-", 5.0, 0.45), ("reframe", True): ("tab:green", "-.", 1.6, 1.0)}
    fig, (ax, ax_err) = plt.subplots(2, 1, figsize=(9, 7.5), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    sel = reference.t <= COMPARE_UNTIL
    ax.plot(reference.t[sel], reference.v_tip[sel], color="black", lw=3.0, alpha=0.35,
            label="reference: Exudyn geometrically exact (ANCF)")
    for label, _, r, _ in results:
        color, ls, lw, alpha = styles[(label, r.geometric_stiffening)]
        text = f"{label}, {'with' if r.geometric_stiffening else 'without'} stiffening"
        if r.failed:
            text += f" (unstable from {r.unstable_from:.2f} s, |v| > {LENGTH:g} m at {r.failure_time:.2f} s)"
        else:
            text += f" ({100 * deviation(r, reference):.2f} % of peak)"
        ax.plot(r.t, r.v_tip, color=color, ls=ls, lw=lw, alpha=alpha, label=text)
        if not r.failed:     # the error at the reference's own sample times (every 0.05 s, on the run's grid)
            v = np.interp(reference.t[sel], r.t, r.v_tip)
            ax_err.plot(reference.t[sel], 1e3 * (v - reference.v_tip[sel]), color=color, ls=ls, lw=1.4,
                        label=f"{label} with stiffening - reference")
    onset = next(r.unstable_from for label, _, r, _ in results if label == "FFR" and r.failed)
    ax.axvline(onset, color="gray", lw=0.8, ls="--")
    ax.text(onset + 0.15, 0.22, f"hub rate = first bending\nfrequency 3.80 rad/s ({onset:.2f} s)", fontsize=8,
            color="gray")
    ax.set_ylim(-1.5, 0.45)
    fail = max(r.failure_time for _, _, r, _ in results if r.failed)
    ax.text(0.3, -1.42, f"without stiffening: off the chart, |v| > {LENGTH:g} m by {fail:.2f} s",
            fontsize=8, color="tab:red")
    ax.set_ylabel("tip deflection v in the hub frame (m)")
    ax.set_title("Spin-up of a cantilever (Kane, Ryan & Banerjee 1987): linear models vs geometrically exact")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    ax_err.axhline(0.0, color="black", lw=0.6)
    ax_err.set_xlabel("time t (s)")
    ax_err.set_ylabel("v - v_ref (mm)")
    ax_err.set_xlim(0, COMPARE_UNTIL)
    ax_err.legend(fontsize=8, loc="lower right")
    ax_err.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    """The spin-up study: tables on stdout, the figure, and with --out a Markdown report of both."""
    import argparse

    ap = argparse.ArgumentParser(description=STUDY,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-figure", action="store_true", help="print the table only")
    ap.add_argument("--quick", action="store_true", help="skip the convergence and sensitivity runs")
    ap.add_argument("--out", type=Path, default=None, metavar="REPORT.md",
                    help="also write the printed tables and the figure's link as a Markdown report; the figure "
                         "then goes to figures/ beside it (default: no report)")
    ap.add_argument("--figures", type=Path, default=None, metavar="DIR",
                    help="folder for the figure (default: figures/ beside --out; without --out docs/figures of "
                         "a source checkout, else ./figures)")
    args = ap.parse_args(argv)
    chart = None
    with common.recording() as printed:
        reference = load_reference()
        results = run_all(RUNS)
        print(table(results, reference))
        if not args.quick:
            checks = run_all(CHECKS)
            print()
            print("Convergence and sensitivity (all with stiffening):")
            print(table(checks, reference))
        for label, _, r, _ in results:
            if r.failed:
                print(f"{label} without stiffening: {r.failure_reason}")
        if not args.no_figure:
            plt = common.pyplot()
            if plt is None:
                print(common.skipped("figure spinup_tip_deflection.png", "matplotlib"))
            else:
                folder = args.figures or common.figures_dir(args.out)
                folder.mkdir(parents=True, exist_ok=True)
                chart = folder / "spinup_tip_deflection.png"
                figure(results, reference, chart, plt)
                print(f"wrote {chart}")
    if args.out is not None and str(args.out) != "-":
        path = common.write_text_report(
            args.out, "Spin-up study" + (" (--quick)" if args.quick else ""),
            "Written by `flexfmu bench spinup` (flexfmu.studies.spinup); docs/spinup.md explains the study. "
            "Reference: flexfmu/data/references/spinup (Exudyn ANCF, see its README).", printed.getvalue(), [chart])
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
