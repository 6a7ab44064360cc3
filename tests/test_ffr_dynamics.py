"""FFR beam on a moving base: inertia shape integrals, exact ZOH stepping, reactions.

References are analytic (uniform-load cantilever, spinning bar, damped oscillator, rigid-body
Newton-Euler) or a full static FE solve K^-1 F; none come from the time integration under test.
"""
import numpy as np
import pytest
import scipy.sparse.linalg as spla

from conftest import STEEL, straight_rod
from error_bounds import gamma
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.errors import ParameterError
from flexfmu.ffr.dynamics import BaseMotion, FFRBeamDynamics, inertia_integrals
from flexfmu.linalg.modal import solve_modes
from flexfmu.ffr.scene import load_scene, scene_from_dict

ZERO = np.zeros(3)


def _dynamics(scene, boundary="XFF", n_el=8, n_modes=None, zeta=0.01, load_s=None, sensor_s=0.0):
    model = build_beam_model(scene, boundary, n_el)
    modes = solve_modes(model.K_free, model.M_free, n_modes or model.n_free)
    return FFRBeamDynamics(model, modes, zeta, scene.total_length if load_s is None else load_s, sensor_s)


def test_inertia_integrals_reproduce_rigid_translation(rng):
    scene = scene_from_dict({**_double_l(), "point_masses": [{"s": 0.3, "mass": 0.05}]})
    model = build_beam_model(scene, "free", 3)
    ints = inertia_integrals(model)
    n_el, X = len(model.mesh.elements), float(np.abs(model.mesh.nodes).max())
    rhoA = scene.material.rho * scene.section.A
    # mass = sum of 4 n_el positive Gauss weights rhoA/2 w_g L_e (+ point masses): gamma(4 n_el + 5) mass; the exact
    # element lengths sum to the exact segment lengths, each rounded L_e or segment length within gamma(8) 2 X (node
    # coordinates <= 2 roundings of terms <= X, a difference, the norm's 5), for the n_el + n_segments of them
    bound = gamma(4 * n_el + 5) * ints.mass + rhoA * (n_el + len(scene.points) - 1) * gamma(8) * 2 * X
    assert abs(ints.mass - scene.total_mass) <= bound
    t = rng.normal(size=3)
    q = np.zeros(model.n_dof)
    for i in range(model.mesh.n_nodes):
        q[6 * i:6 * i + 3] = t
    # S q = C N C^T t = t exactly at every Gauss point (partition of unity, C orthogonal).  Rounding: C within
    # gamma(19) (test_beam_element's DELTA), the products C N (12) C^T (3 terms) and the Gauss sum (4 n_el terms,
    # weights 5): generously gamma(4 n_el + 60), of terms |C||N||C^T||t| <= 3 * 3 * 2 sum|t| (|C_ij|, |N| <= 1, 2 nodes)
    St = 18 * np.abs(t).sum()
    g = gamma(4 * n_el + 60)
    assert np.all(np.abs(ints.S_bar @ q - ints.mass * t) <= g * ints.mass * St)
    # P q = sum w (S q) x0^T: the same with the extra factor |x0| <= X (first moment: gamma(4 n_el + 5) mass X)
    Pq = np.einsum("abn,n->ab", ints.P, q)
    assert np.all(np.abs(Pq - np.outer(t, ints.first_moment)) <= 2 * g * ints.mass * St * X)
    # q^T M_ab q = sum w (S_a q)(S_b q): terms <= w St^2, plus the sparse product and dot (2 n_dof terms)
    g2 = gamma(4 * n_el + 60 + 2 * model.n_dof)
    for a in range(3):
        for b in range(3):
            assert abs(q @ (ints.M_ab[a][b] @ q) - ints.mass * t[a] * t[b]) <= 2 * g2 * ints.mass * St**2
    # centre-line translational mass equals the consistent M for translations: same element lengths and rhoA; M's
    # entries C_bar M_loc C_bar^T (closed-form local entries, 12 + 12 terms, rotation within gamma(19)) and the
    # form (2 n_dof terms): generously gamma(2 n_dof + 80) |q|^T |M| |q|; ints.mass t.t as above (4 n_el + 5 + 3)
    qMq_scale = np.abs(q) @ (abs(model.M) @ np.abs(q))
    bound = gamma(2 * model.n_dof + 80) * qMq_scale + gamma(4 * n_el + 8) * ints.mass * (t @ t)
    assert abs(q @ model.M @ q - ints.mass * t @ t) <= bound


def _double_l():
    return {"name": "L2", "points": load_scene("spatial_double_L").points.tolist(),
            "section": {"shape": "circle", "diameter": 0.008}, "material": dict(STEEL)}


def test_base_acceleration_equals_uniform_load_on_cantilever():
    """Base accelerating at +a along body y = gravity -a: tip deflection -rhoA a L^4 / (8 EI)."""
    L, d, a = 1.0, 0.01, 9.81
    dyn = _dynamics(straight_rod(L, d), n_el=6)
    eq = dyn.static_response(ZERO, ZERO, BaseMotion(a0=np.array([0.0, a, 0.0])))
    EI = STEEL["E"] * np.pi * d**4 / 64
    rhoA = STEEL["rho"] * np.pi * d**2 / 4
    # analytic reference: x and z are exactly 0 there; they are held to the same 1e-9 of the deflection as y
    w_tip = rhoA * a * L**4 / (8 * EI)
    np.testing.assert_allclose(dyn.tip_displacement(eq), [0.0, -w_tip, 0.0], rtol=1e-9, atol=1e-9 * w_tip)


def test_constant_spin_gives_centrifugal_stretch_of_a_bar():
    """Bar along x clamped at the hub spinning about z: E A u'' + rho A w^2 (x + u) = 0,
    u(0) = 0, u'(L) = 0  ->  u(L) = tan(kL)/k - L, k = w sqrt(rho/E)."""
    L, d, w = 1.0, 0.02, 30.0            # below the first bending frequency: no spin softening instability
    dyn = _dynamics(straight_rod(L, d), n_el=16)
    base = BaseMotion(omega=np.array([0.0, 0.0, w]))
    eq = dyn.static_response(ZERO, ZERO, base)
    k = w * np.sqrt(STEEL["rho"] / STEEL["E"])
    u_exact = np.tan(k * L) / k - L
    tip = dyn.tip_displacement(eq)
    assert tip[0] == pytest.approx(u_exact, rel=1e-6)
    assert abs(tip[1]) < 1e-9 * u_exact and abs(tip[2]) < 1e-9 * u_exact
    # and the damped time response settles there (exact ZOH steps, 1 ms)
    dyn_damped = _dynamics(straight_rod(L, d), n_el=16, zeta=0.3)
    state = dyn_damped.initial_state()
    for _ in range(3000):
        state = dyn_damped.step(state, 1e-3, ZERO, ZERO, base)
    np.testing.assert_allclose(dyn_damped.tip_displacement(state), tip, rtol=1e-6, atol=1e-9 * u_exact)


def test_modal_static_tip_deflection_equals_full_fe_solve():
    """All modes retained: the modal equilibrium under a tip force equals K^-1 F of the full model."""
    scene = load_scene("spatial_double_L")
    dyn = _dynamics(scene, "XFF", n_el=4)
    F = np.array([0.3, -1.0, 2.0])
    eq = dyn.static_response(F, ZERO, BaseMotion())
    model = dyn.model
    f_full = dyn.load.full_translation(model.n_dof).T @ F
    q = model.B2 @ spla.spsolve(model.K_free.tocsc(), model.B2.T @ f_full)
    np.testing.assert_allclose(dyn.tip_displacement(eq), dyn.tip.displacement_body(q), rtol=1e-9)
    assert dyn.elastic_energy(eq) == pytest.approx(0.5 * q @ model.K @ q, rel=1e-9)


def test_zero_order_hold_step_is_exact():
    """Free decay of each mode: eta = e^{-z w t} cos(w_d t) eta0 (+ analytic velocity term); h and 2 x h/2 agree."""
    dyn = _dynamics(load_scene("spatial_double_L"), n_el=4, n_modes=6, zeta=0.05)
    state = dyn.initial_state()
    state.eta[:] = 1e-4
    w, z = dyn.omega_n, 0.05
    wd = w * np.sqrt(1 - z**2)
    t = 0.0123
    one = dyn.step(state, t, ZERO, ZERO, BaseMotion())
    two = dyn.step(dyn.step(state, t / 2, ZERO, ZERO, BaseMotion()), t / 2, ZERO, ZERO, BaseMotion())
    exact = 1e-4 * np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))
    # at this t every mode is away from its zeros: the relative tolerances alone, without absolute floors
    assert np.min(np.abs(exact)) >= 0.1 * np.max(np.abs(exact))
    np.testing.assert_allclose(one.eta, exact, rtol=1e-9, atol=0)
    np.testing.assert_allclose(two.eta, one.eta, rtol=1e-10, atol=0)


def test_stiff_rod_reactions_equal_rigid_body_newton_euler():
    """A very stiff rod under ramped base acceleration and angular acceleration reacts like a
    rigid body: F_on_base = -m a0, M_on_base = -(J0 alpha + m r_c x a0) about the frame origin."""
    stiff = {**_double_l(), "material": {**STEEL, "E": STEEL["E"] * 1e6}}
    scene = scene_from_dict(stiff)
    dyn = _dynamics(scene, "XFF", n_el=4, n_modes=12, zeta=0.05)
    ints = dyn.integrals
    state = dyn.initial_state()
    h = 1e-4
    a_dir, al_dir = np.array([0.3, -0.5, 1.0]), np.array([0.2, 1.0, -0.4])
    for i in range(1, 551):   # ramp over 50 ms, then hold 5 ms: each held step's jump rings down
        ramp = min(i, 500) / 500
        base = BaseMotion(a0=5.0 * ramp * a_dir, alpha=20.0 * ramp * al_dir)
        state = dyn.step(state, h, ZERO, ZERO, base)
    acc = dyn.acceleration(state, ZERO, ZERO, base)
    F, M = dyn.reactions(state, acc, ZERO, ZERO, base)
    r_c = ints.first_moment / ints.mass
    F_rigid = -(ints.mass * base.a0 + ints.mass * np.cross(base.alpha, r_c))
    M_rigid = -(ints.J0 @ base.alpha + ints.mass * np.cross(r_c, base.a0))
    np.testing.assert_allclose(F, F_rigid, rtol=1e-4, atol=1e-4 * np.abs(F_rigid).max())
    np.testing.assert_allclose(M, M_rigid, rtol=1e-4, atol=1e-4 * np.abs(M_rigid).max())


def test_tip_force_reaction_balances_after_vibration_decays():
    """Fixed base, constant tip force: at equilibrium the clamp carries the force and its moment."""
    scene = load_scene("spatial_double_L")
    dyn = _dynamics(scene, "XFF", n_el=4, n_modes=6)
    F = np.array([0.0, 0.0, 1.5])
    eq = dyn.static_response(F, ZERO, BaseMotion())
    Fr, Mr = dyn.reactions(eq, np.zeros(dyn.m), F, ZERO, BaseMotion())
    # identity: fixed base (a0 = omega = alpha = 0) and eta_dot = eta_ddot = 0 make every inertial term an exact
    # zero, so reactions returns F - 0 and 0 + r_F x F - 0 with r_F by the same expression and the cross product
    # by the same products and differences as np.cross: the same bits
    np.testing.assert_array_equal(Fr, F)
    np.testing.assert_array_equal(Mr, np.cross(dyn.load.undeformed_body + dyn.load.displacement_body(dyn.Phi @ eq.eta),
                                               F))


def test_bad_parameters_are_named():
    scene = load_scene("spatial_double_L")
    model = build_beam_model(scene, "XFF", 2)
    modes = solve_modes(model.K_free, model.M_free, 4)
    with pytest.raises(ParameterError, match="damping_ratio"):
        FFRBeamDynamics(model, modes, 1.5, 0.45, 0.04)
    with pytest.raises(ParameterError, match="sensor_s"):
        FFRBeamDynamics(model, modes, 0.01, 0.45, 0.5)
    free = build_beam_model(scene, "free", 2)
    with pytest.raises(ParameterError, match="boundary"):
        FFRBeamDynamics(free, solve_modes(free.K_free, free.M_free, 8), 0.01, 0.45, 0.04)
    dyn = FFRBeamDynamics(model, modes, 0.01, 0.45, 0.04)
    with pytest.raises(ParameterError, match="step size"):
        dyn.step(dyn.initial_state(), 0.0, ZERO, ZERO, BaseMotion())


def test_step_map_memo_is_bounded():
    """Inputs that vary every step: the memo of step maps holds MAP_MEMO_SIZE entries, then starts afresh."""
    from flexfmu.ffr.dynamics import MAP_MEMO_SIZE
    dyn = _dynamics(load_scene("spatial_double_L"), n_el=2, n_modes=3)
    for i in range(MAP_MEMO_SIZE):
        dyn.fast_maps(1e-3 * (i + 1), BaseMotion())
    assert len(dyn._fast_cache) == MAP_MEMO_SIZE
    dyn.fast_maps(1e-3, BaseMotion())                      # a hit keeps every entry
    assert len(dyn._fast_cache) == MAP_MEMO_SIZE
    dyn.fast_maps(1.0, BaseMotion())                       # a new key when full: cleared, then stored
    assert len(dyn._fast_cache) == 1
