"""FFR modal step: the exact zero-order-hold update (matrix exponential) and the RK4 option.

* the exact update reproduces the closed-form response of a damped single-mode oscillator to a step force,
  for steps of any length (no step-size limit);
* RK4 converges to the exact update at order 4 (both advance the same held-input system);
* ``rk4_step_limit`` is 2.8 / max |eig A| = 2.8 / omega_max for an undamped model at rest (independent:
  the highest retained natural frequency), RK4 stays bounded just below the true limit 2 sqrt(2) / omega_max
  and grows without bound just above it, while the exact update stays bounded at the same step.
"""
from __future__ import annotations

import numpy as np
import pytest

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.errors import ParameterError
from flexfmu.ffr.dynamics import RK4_STABILITY_LIMIT, BaseMotion, FFRBeamDynamics
from flexfmu.linalg.modal import solve_modes
from flexfmu.ffr.scene import load_scene

ZERO = np.zeros(3)
SPIN = BaseMotion(a0=np.array([0.3, -0.2, 1.0]), omega=np.array([1.5, -0.7, 2.0]), alpha=np.array([3.0, 1.0, -2.0]))


def _dynamics(n_modes, damping_ratio, integrator="exact", elements=4):
    model = build_beam_model(load_scene("spatial_double_L"), "XFF", elements)
    modes = solve_modes(model.K_free, model.M_free, n_modes)
    return FFRBeamDynamics(model, modes, damping_ratio, 0.45, 0.04, integrator=integrator)


def test_exact_update_matches_single_mode_step_response():
    zeta = 0.02
    dyn = _dynamics(1, zeta)
    w = float(dyn.omega_n[0])
    force = np.array([0.0, 3.0, -2.0])                       # N at the tip, body frame, held
    f = float((dyn.load_force_map @ force)[0])               # modal force of that load
    wd = w * np.sqrt(1 - zeta**2)

    def analytic(t):     # eta'' + 2 zeta w eta' + w^2 eta = f from rest
        decay = np.exp(-zeta * w * t)
        eta = f / w**2 * (1 - decay * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t)))
        return eta, f / wd * decay * np.sin(wd * t)

    period = 2 * np.pi / w
    for h in (0.013 * period, 0.37 * period, 3.3 * period):   # far beyond any explicit limit too
        state = dyn.initial_state()
        for _ in range(7):
            state = dyn.step(state, h, force, ZERO, BaseMotion())
        eta, eta_dot = analytic(state.t)
        # against the analytic response (an independent reference, relative tolerances >= 1e-10); no absolute
        # floor: at these 7 h the response is away from its zeros (|eta| >= 0.15 f / w^2, |eta'| >= 0.03 f / w)
        assert state.eta[0] == pytest.approx(eta, rel=1e-10, abs=0)
        assert state.eta_dot[0] == pytest.approx(eta_dot, rel=1e-9, abs=0)


def test_rk4_converges_at_fourth_order_to_the_exact_update():
    exact, rk4 = _dynamics(4, 0.01), _dynamics(4, 0.01, "rk4")
    force, moment = np.array([1.0, -2.0, 0.5]), np.array([0.0, 0.01, 0.0])
    h0 = rk4.rk4_step_limit(SPIN) / 4
    T = 32 * h0
    errors = []
    for k in (1, 2, 4, 8):
        h = h0 / k
        s_ex, s_rk = exact.initial_state(), rk4.initial_state()
        for _ in range(32 * k):
            s_ex = exact.step(s_ex, h, force, moment, SPIN)
            s_rk = rk4.step(s_rk, h, force, moment, SPIN)
        assert s_ex.t == pytest.approx(T)
        errors.append(np.linalg.norm(np.concatenate([s_rk.eta - s_ex.eta, s_rk.eta_dot - s_ex.eta_dot]))
                      / np.linalg.norm(np.concatenate([s_ex.eta, s_ex.eta_dot])))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    print("RK4 relative errors", errors, "observed orders", orders)
    assert errors[0] < 1e-2
    assert np.all(np.abs(orders - 4.0) < 0.3)


def test_rk4_step_limit_and_failure_beyond_it():
    rk4, exact = _dynamics(6, 0.0, "rk4"), _dynamics(6, 0.0)
    w_max = float(rk4.omega_n[-1])
    rest = BaseMotion()
    # At rest and undamped, the eigenvalues of A are +-i omega_k: the limit is 2.8 / omega_max.
    assert rk4.rk4_step_limit(rest) == pytest.approx(RK4_STABILITY_LIMIT / w_max, rel=1e-9)
    true_limit = 2 * np.sqrt(2) / w_max          # RK4's stability boundary on the imaginary axis
    force = np.array([0.0, 0.0, 1.0])
    static = exact.static_response(force, ZERO, rest)
    scale = np.linalg.norm(static.eta)

    def run(dyn, h, n=400):
        s = dyn.initial_state()
        peak = 0.0
        for _ in range(n):
            s = dyn.step(s, h, force, ZERO, rest)
            peak = max(peak, float(np.linalg.norm(s.eta)))
        return peak / scale

    assert rk4.rk4_step_limit(rest) < true_limit
    assert run(rk4, rk4.rk4_step_limit(rest)) < 10.0            # bounded at the documented limit
    h_bad = 1.05 * true_limit
    assert h_bad > rk4.rk4_step_limit(rest)                      # detected up front ...
    assert run(rk4, h_bad) > 1e6                                 # ... and it does fail
    assert run(exact, h_bad) < 3.0                               # the exact update has no limit
    # the spectral radius of the RK4 transition matrix says the same
    Ad, _ = rk4._transition(h_bad, rest)
    assert np.max(np.abs(np.linalg.eigvals(Ad))) > 1.0


def test_rk4_step_limit_follows_the_base_motion():
    rk4 = _dynamics(4, 0.01, "rk4")
    A = rk4.system_matrix(SPIN)
    assert rk4.rk4_step_limit(SPIN) == pytest.approx(RK4_STABILITY_LIMIT / np.max(np.abs(np.linalg.eigvals(A))))
    assert rk4.rk4_step_limit(SPIN) != pytest.approx(rk4.rk4_step_limit(BaseMotion()), rel=1e-6)


def test_default_is_exact_and_bad_options_are_refused():
    model = build_beam_model(load_scene("spatial_double_L"), "XFF", 2)
    modes = solve_modes(model.K_free, model.M_free, 2)
    assert FFRBeamDynamics(model, modes, 0.01, 0.45, 0.04).integrator == "exact"
    with pytest.raises(ParameterError, match="integrator"):
        FFRBeamDynamics(model, modes, 0.01, 0.45, 0.04, integrator="euler")
    with pytest.raises(ParameterError, match="geometric_stiffening"):
        FFRBeamDynamics(model, modes, 0.01, 0.45, 0.04, geometric_stiffening="yes")


def test_spinup_driver_refuses_an_rk4_step_beyond_the_limit():
    from flexfmu.studies import spinup_models as spinup

    with pytest.raises(ParameterError, match="dt"):
        spinup.run_ffr(t_end=0.5, dt=0.05, geometric_stiffening=True, integrator="rk4")   # limit ~0.013 s
    ok = spinup.run_ffr(t_end=0.5, dt=0.01, geometric_stiffening=True, integrator="rk4")
    exact = spinup.run_ffr(t_end=0.5, dt=0.01, geometric_stiffening=True)
    np.testing.assert_allclose(ok.v_tip, exact.v_tip, atol=1e-6 * np.max(np.abs(exact.v_tip)))
