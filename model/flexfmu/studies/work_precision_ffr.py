"""The FFR-beam cases of the work-precision study (flexfmu.studies.work_precision): a hammer blow and a moving
base on the spatial double-L, their independent references (closed form, DOP853), the runs through
FFRBeamSimulator and the sweeps over time step, modes and mesh."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import FlexfmuError
from flexfmu.studies.work_precision_measure import (Case, Point, best_cpu, config_fields, ffr_auto_available,
                                                    ffr_integrators, refused, relative_max_error)


HAMMER_FORCE = 20.0 * np.array([1.0, 0.7, 0.4])     # N peak, body frame, a 1 ms half-sine blow at the tip
HAMMER_PULSE = 1e-3


def hammer_input(t: float) -> np.ndarray:
    """FFRBeam input vector (INPUT_NAMES order) of the hammer case at time t."""
    u = np.zeros(15)
    if 0.0 <= t <= HAMMER_PULSE:
        u[0:3] = HAMMER_FORCE * math.sin(math.pi * t / HAMMER_PULSE)
    return u


BASE_SPIN, BASE_RAMP, BASE_ACC, BASE_FREQ = 3.0, 0.05, 5.0, 20.0


def base_input(t: float) -> np.ndarray:
    """Moving base: spin-up about body z to 3 rad/s over 0.05 s (smooth 1 - cos ramp), and a 20 Hz, 5 m/s^2
    sinusoidal acceleration of the base along body x and (half of it) y."""
    u = np.zeros(15)
    if t < BASE_RAMP:
        u[11] = 0.5 * BASE_SPIN * (1.0 - math.cos(math.pi * t / BASE_RAMP))
        u[14] = 0.5 * BASE_SPIN * math.pi / BASE_RAMP * math.sin(math.pi * t / BASE_RAMP)
    else:
        u[11] = BASE_SPIN
    a = BASE_ACC * math.sin(2.0 * math.pi * BASE_FREQ * t)
    u[6], u[7] = a, 0.5 * a
    return u


@dataclass
class FFRCase:
    case: Case
    inputs: object
    breakpoints: tuple         # times where the input has a kink (the reference integrates piecewise)
    t_end: float
    out_period: float
    base_eps: int
    base_modes: int
    dts: tuple
    modes: tuple
    ref_modes: int
    modes_dt: float
    meshes: tuple
    ref_eps: int
    mesh_dt: float
    f_max: float
    tolerance: float
    analytic: bool = False     # hammer: closed-form reference (hammer_analytic), every mode; else DOP853


def _ffr_config(eps, n_modes, integrator="exact", **extra):
    from flexfmu.ffr.simulator import FFRBeamConfig
    kw = dict(boundary="XFF", elements_per_segment=eps, n_modes=n_modes, damping_ratio=0.01)
    if "integrator" in config_fields(FFRBeamConfig):
        kw["integrator"] = integrator
    kw.update(extra)
    return FFRBeamConfig(**kw)


def run_ffr(config, dt, t_end, inputs, out_period) -> np.ndarray:
    """Tip elastic displacement (body frame, m) every out_period s through FFRBeamSimulator, the inputs held
    over each step at their mid-step value (second order for smooth inputs)."""
    from flexfmu.ffr.simulator import FFRBeamSimulator
    sim = FFRBeamSimulator(config)
    every = int(round(out_period / dt))
    n = int(round(t_end / dt))
    sim.set_input_vector(inputs(0.0))
    out = [sim.output_vector()[9:12]]
    for k in range(n):
        sim.set_input_vector(inputs((k + 0.5) * dt))
        sim.step(dt)
        if (k + 1) % every == 0:
            out.append(sim.output_vector()[9:12])
    return np.array(out)


def ffr_reference(config, t_end, inputs, out_period, breakpoints, rtol=1e-11) -> np.ndarray:
    """The same model's equations of motion (ffr_dynamics Eq. (*), FFRBeamDynamics.acceleration) with the
    continuous input, integrated by scipy's DOP853 (rtol 1e-11), piecewise between the input's kinks: a time
    integration independent of the FFR step (matrix exponential / RK4 with held inputs)."""
    from scipy.integrate import solve_ivp

    from flexfmu.ffr.simulator import FFRBeamSimulator
    from flexfmu.ffr.dynamics import BaseMotion, ModalState
    dyn = FFRBeamSimulator(config).dynamics
    m = dyn.m
    zero = np.zeros(m)

    def parts(t):
        u = inputs(t)
        return u, BaseMotion(a0=u[6:9], omega=u[9:12], alpha=u[12:15])

    def system(t):
        """(A, b) of x' = A x + b at time t: the equations are affine in x = [eta; eta_dot]."""
        u, base = parts(t)
        f0 = dyn.acceleration(ModalState(zero, zero, t), u[0:3], u[3:6], base)
        if hasattr(dyn, "system_matrix"):
            A = dyn.system_matrix(base)
        else:                               # unit states give the affine map's columns exactly
            A = np.zeros((2 * m, 2 * m))
            A[:m, m:] = np.eye(m)
            for k in range(m):
                e = np.zeros(m)
                e[k] = 1.0
                A[m:, k] = dyn.acceleration(ModalState(e, zero, t), u[0:3], u[3:6], base) - f0
                A[m:, m + k] = dyn.acceleration(ModalState(zero, e, t), u[0:3], u[3:6], base) - f0
        return A, np.concatenate([zero, f0])

    def rhs(t, x):
        A, b = system(t)
        return A @ x + b

    n_out = int(round(t_end / out_period))
    grid = np.arange(n_out + 1) * out_period
    edges = [0.0] + [b for b in breakpoints if 0.0 < b < t_end] + [t_end]
    x = np.zeros(2 * m)
    eta = np.zeros((grid.size, m))
    for a, b in zip(edges[:-1], edges[1:]):
        sel = np.nonzero((grid >= a - 1e-12) & (grid <= b + 1e-12))[0]
        t_eval = np.union1d(grid[sel], [b])
        sol = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=rtol, atol=1e-16, t_eval=t_eval)
        if not sol.success:
            raise FlexfmuError(f"reference integration failed: {sol.message}")
        eta[sel] = sol.y[:m, np.searchsorted(t_eval, grid[sel])].T
        x = sol.y[:, -1]
    return eta @ dyn.tip_map.T


def hammer_analytic(config, t_end, out_period) -> np.ndarray:
    """Closed-form tip displacement (body frame, m) of the hammer case: with the base at rest the modal
    equations decouple, eta_i'' + 2 zeta w_i eta_i' + w_i^2 eta_i = g_i sin(pi t / T) on [0, T] (g = modal
    load of HAMMER_FORCE at load_s), free vibration after.  Solution: the steady sinusoidal particular part
    Im(g e^{i W t} / (w^2 - W^2 + 2 i zeta w W)) plus the damped free response that makes eta(0) = eta'(0) = 0;
    from T on, the free response of the state at T.  Every mode of the model can be kept (no time step)."""
    from flexfmu.ffr.simulator import FFRBeamSimulator
    dyn = FFRBeamSimulator(config).dynamics
    w = np.sqrt(dyn.stiffness)
    zeta = dyn.damping / (2.0 * w)
    wd = w * np.sqrt(1.0 - zeta**2)
    g = dyn.load_force_map @ HAMMER_FORCE
    W = math.pi / HAMMER_PULSE
    amp = g / (w**2 - W**2 + 2j * zeta * w * W)

    def free(t, e0, v0):
        """Damped free response (eta, eta_dot) after time t from (e0, v0), per mode."""
        a, b = e0, (v0 + zeta * w * e0) / wd
        decay = np.exp(-zeta * w * t)
        c, s = np.cos(wd * t), np.sin(wd * t)
        eta = decay * (a * c + b * s)
        eta_dot = decay * ((-zeta * w) * (a * c + b * s) + wd * (-a * s + b * c))
        return eta, eta_dot

    def forced(t):
        z = amp * np.exp(1j * W * t)
        e_h, v_h = free(t, -amp.imag, -(1j * W * amp).imag)         # cancels the particular part at t = 0
        return z.imag + e_h, (1j * W * z).imag + v_h

    e_T, v_T = forced(HAMMER_PULSE)
    grid = np.arange(int(round(t_end / out_period)) + 1) * out_period
    eta = np.array([forced(t)[0] if t <= HAMMER_PULSE else free(t - HAMMER_PULSE, e_T, v_T)[0] for t in grid])
    return eta @ dyn.tip_map.T


def _ffr_point(fc: FFRCase, panel, method, value, label, config, dt, u_ref, repeat, automatic=False, note="",
               setup=None):
    from flexfmu.ffr.simulator import FFRBeamSimulator
    try:
        if setup is None:
            t0 = time.process_time()
            FFRBeamSimulator(config)               # first construction of this configuration: the set-up
            setup = time.process_time() - t0
        cpu, u = best_cpu(lambda: run_ffr(config, dt, fc.t_end, fc.inputs, fc.out_period), repeat)
    except FlexfmuError as exc:
        refused(fc.case, panel, method, value, label, exc)
        return
    fc.case.add(Point(panel, method, value, label, setup, cpu, relative_max_error(u, u_ref), note=note,
                      automatic=automatic))


def ffr_free_dofs(eps: int) -> int:
    from flexfmu.ffr.simulator import FFRBeamSimulator
    return FFRBeamSimulator(_ffr_config(eps, 1)).dynamics.model.n_free


def _ffr_ref(fc: FFRCase, eps: int, n_modes) -> np.ndarray:
    """u_ref of a sweep; n_modes None: every mode of the model."""
    config = _ffr_config(eps, ffr_free_dofs(eps) if n_modes is None else n_modes)
    if fc.analytic:
        return hammer_analytic(config, fc.t_end, fc.out_period)
    return ffr_reference(config, fc.t_end, fc.inputs, fc.out_period, fc.breakpoints)


def sweep_ffr(fc: FFRCase, repeat: int) -> Case:
    from flexfmu.ffr.simulator import FFRBeamConfig
    integrators = ffr_integrators()
    name = {"exact": "FFR modal, exact (expm)", "rk4": "FFR modal, RK4"}
    # ---- time step
    u_ref = _ffr_ref(fc, fc.base_eps, fc.base_modes)
    for integ in integrators:
        for dt in fc.dts:
            _ffr_point(fc, "dt", name.get(integ, integ), dt, f"{dt:.3g} s",
                       _ffr_config(fc.base_eps, fc.base_modes, integ), dt, u_ref, repeat)
    # ---- modes
    u_ref = _ffr_ref(fc, fc.base_eps, fc.ref_modes)
    for integ in integrators:
        for n in fc.modes:
            _ffr_point(fc, "modes", name.get(integ, integ), n, str(n), _ffr_config(fc.base_eps, n, integ),
                       fc.modes_dt, u_ref, repeat)
    if "static_correction" in config_fields(FFRBeamConfig):
        for n in fc.modes:
            _ffr_point(fc, "modes", "FFR modal, exact + static correction", n, str(n),
                       _ffr_config(fc.base_eps, n, "exact", static_correction=1), fc.modes_dt, u_ref, repeat)
    if ffr_auto_available():
        from flexfmu.ffr.simulator import FFRBeamSimulator
        for integ in integrators:
            config = _ffr_config(0, -1, integ, f_max=fc.f_max, tolerance=fc.tolerance)
            try:
                t0 = time.process_time()
                sim = FFRBeamSimulator(config)         # the set-up, incl. the choice (mesh study, modes)
                setup = time.process_time() - t0
                n = sim.dynamics.m
                mesh_choice = getattr(getattr(sim, "model_choice", None), "mesh", None)
                eps = getattr(mesh_choice, "elements_per_segment", None)
            except FlexfmuError as exc:
                refused(fc.case, "modes", name.get(integ, integ), 0, "automatic", exc)
                continue
            _ffr_point(fc, "modes", name.get(integ, integ), n, f"auto: {n}", config, fc.modes_dt, u_ref, repeat,
                       automatic=True, setup=setup, note=f"automatic choice ({n} modes"
                       + (f", {eps} el/seg" if eps else "") + f"), f_max = {fc.f_max:g} Hz, tolerance {fc.tolerance:g}")
    # ---- mesh
    u_ref = _ffr_ref(fc, fc.ref_eps, fc.base_modes)
    for integ in integrators:
        for eps in fc.meshes:
            _ffr_point(fc, "mesh", name.get(integ, integ), eps, f"{eps} el/seg", _ffr_config(eps, fc.base_modes, integ),
                       fc.mesh_dt, u_ref, repeat)
    return fc.case


def hammer_case(quick: bool) -> FFRCase:
    t_end = 0.05 if quick else 0.1
    case = Case("ffr_hammer", "FFR beam: hammer impulse",
                "spatial double-L clamped at its first point (XFF), 1 % modal damping; a 1 ms half-sine blow at the "
                f"tip, peak 20 N × (1, 0.7, 0.4) (body frame), base at rest; {t_end:g} s",
                "tip elastic displacement, body frame")
    return FFRCase(case, hammer_input, (HAMMER_PULSE,), t_end, 5e-4, base_eps=8, base_modes=6,
                   dts=(5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5) + (() if quick else (1.5625e-5,)),
                   modes=(1, 2, 4, 6, 10, 24) if quick else (1, 2, 3, 4, 6, 8, 10, 16, 24, 40),
                   ref_modes=None, modes_dt=1e-5,
                   meshes=(1, 2, 4) if quick else (1, 2, 4, 8), ref_eps=16 if quick else 32, mesh_dt=1e-5,
                   f_max=1.5 / HAMMER_PULSE, tolerance=1e-3, analytic=True)


def base_case(quick: bool) -> FFRCase:
    t_end = 0.1
    case = Case("ffr_base", "FFR beam: moving base",
                "spatial double-L, XFF, 1 % modal damping; the base spins up about body z to 3 rad/s over 0.05 s "
                "(1 − cos ramp) and accelerates sinusoidally (20 Hz, 5 m/s² along x, 2.5 m/s² along y); no force; "
                f"{t_end:g} s",
                "tip elastic displacement, body frame")
    return FFRCase(case, base_input, (BASE_RAMP,), t_end, 5e-4, base_eps=8, base_modes=6,
                   dts=(5e-4, 2.5e-4, 1.25e-4) + (() if quick else (6.25e-5,)),
                   modes=(1, 2, 4, 6) if quick else (1, 2, 3, 4, 6, 8, 12), ref_modes=12 if quick else 16,
                   modes_dt=1.25e-4 if quick else 6.25e-5, meshes=(1, 2) if quick else (1, 2, 4),
                   ref_eps=4 if quick else 8, mesh_dt=1.25e-4 if quick else 6.25e-5, f_max=300.0, tolerance=1e-3)
