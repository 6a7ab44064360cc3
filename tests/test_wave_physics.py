"""The wave-energy converter's component models (library façades): Airy/JONSWAP waves, Froude-Krylov
loads on a box against closed forms, the minimal Cummins coefficients, the platform's exact step and
work bookkeeping, the PTO."""
import math

import numpy as np
import pytest

from error_bounds import gamma, implementations_bound
from flexfmu.errors import ParameterError
from flexfmu.wec.hydrostatics import HydrostaticsConfig, HydrostaticsSimulator
from flexfmu.wec.platform import PlatformConfig, PlatformSimulator
from flexfmu.wec.pto import PTOConfig, PTOSimulator
from flexfmu.wec.wave import (FloatingBox, froude_krylov_transfer, jonswap_sea, jonswap_spectrum, ramp, regular_wave,
                          wave_number)
from flexfmu.wec.wave_excitation import WaveExcitationConfig, WaveExcitationSimulator


def test_dispersion_deep_and_finite_depth():
    w = np.array([0.5, 2.0, 6.0])
    # identity: deep water is the same expression omega**2 / G, G = 9.81
    np.testing.assert_array_equal(wave_number(w), w**2 / 9.81)
    for d in (0.5, 3.0, 50.0):
        k = wave_number(w, d)
        # Newton stops at |step| <= 1e-14 k: residual <= f'(k) 1e-14 k; plus rounding of f here and in the last
        # step (g k tanh(kd) and w^2, <= 4 roundings, tanh within 2 ulp): generously gamma(8) 4 w^2
        th = np.tanh(k * d)
        df = 9.81 * th + 9.81 * k * d * (1.0 - th**2)
        assert np.all(np.abs(9.81 * k * th - w**2) <= df * 1e-14 * k + gamma(8) * 4 * w**2)
    # shallow water: k -> w / sqrt(g d)
    assert wave_number(np.array([0.01]), 1.0)[0] == pytest.approx(0.01 / math.sqrt(9.81), rel=1e-4)


def test_jonswap_significant_height_and_peak():
    hs, tp = 0.3, 2.0
    w = np.linspace(0.05, 40, 200001)
    S = jonswap_spectrum(w, hs, tp)
    assert 4 * math.sqrt(np.trapezoid(S, w)) == pytest.approx(hs, rel=1e-3)
    assert w[np.argmax(S)] == pytest.approx(2 * math.pi / tp, rel=1e-3)
    sea = jonswap_sea(hs, tp, n_components=400, seed=3)
    m0 = np.sum(sea.amplitude**2) / 2
    assert 4 * math.sqrt(m0) == pytest.approx(hs, rel=0.02)      # 0.5 .. 3 wp holds ~all the energy
    again = jonswap_sea(hs, tp, n_components=400, seed=3)
    assert np.array_equal(sea.phase, again.phase)
    assert not np.array_equal(sea.phase, jonswap_sea(hs, tp, n_components=400, seed=4).phase)


@pytest.mark.parametrize("period", [0.7, 1.4, 4.0])
def test_froude_krylov_box_head_seas_closed_form(period):
    """Heading 0, deep water: F_z = rho g W L e^{-kT} sinc(kL/2), F_x = -2i rho g W sin(kL/2) (1 - e^{-kT}) / k,
    M_y = -int p x dS over the bottom, and no sway, roll or yaw."""
    box = FloatingBox(length=1.2, beam=0.5, draft=0.3)
    waves = regular_wave(0.1, period)
    X = froude_krylov_transfer(box, waves)[:, 0]
    k, L, W, T, rg = waves.k[0], box.length, box.beam, box.draft, box.rho * box.g
    h = k * L / 2
    Fz = rg * W * L * math.exp(-k * T) * math.sin(h) / h
    Fx = -2j * rg * W * math.sin(h) * (1 - math.exp(-k * T)) / k
    # pitch: bottom term -rho g W e^{-kT} int x e^{ikx} dx plus the x-faces' -int z p n_x dS term
    bottom = -rg * W * math.exp(-k * T) * 2j * (math.sin(h) / k**2 - L / 2 * math.cos(h) / k)
    int_z = (T * math.exp(-k * T) / k) - (1 - math.exp(-k * T)) / k**2     # int_{-T}^0 z e^{kz} dz
    faces = -2j * rg * W * math.sin(h) * int_z
    assert X[2] == pytest.approx(Fz, rel=1e-10)
    assert X[0] == pytest.approx(Fx, rel=1e-10)
    assert X[4] == pytest.approx(bottom + faces, rel=1e-9)
    assert np.abs(X[[1, 3, 5]]).max() < 1e-9 * abs(Fz)


def test_froude_krylov_long_wave_is_hydrostatic_and_heading_rotates_it():
    box = FloatingBox()
    X = froude_krylov_transfer(box, regular_wave(0.1, 200.0))[:, 0]
    assert X[2].real == pytest.approx(box.rho * box.g * box.length * box.beam, rel=1e-3)
    # a 90 deg heading turns surge into sway (box symmetric in x and y apart from its size)
    sq = FloatingBox(length=0.8, beam=0.8, draft=0.2)
    X0 = froude_krylov_transfer(sq, regular_wave(0.1, 1.2, heading=0.0))[:, 0]
    X90 = froude_krylov_transfer(sq, regular_wave(0.1, 1.2, heading=math.pi / 2))[:, 0]
    assert X90[1] == pytest.approx(X0[0], rel=1e-10)
    assert X90[3] == pytest.approx(-X0[4], rel=1e-10)
    assert X90[2] == pytest.approx(X0[2], rel=1e-10)


def test_wave_excitation_ramp_and_output_match_the_transfer_function():
    cfg = WaveExcitationConfig(heading=30.0, ramp_time=2.0)
    sim = WaveExcitationSimulator(cfg)
    assert all(v == 0.0 for v in sim.outputs().values())          # ramped: zero at t = 0
    X = froude_krylov_transfer(FloatingBox(), regular_wave(cfg.wave_height, cfg.wave_period, math.radians(30)))
    for _ in range(2500):
        sim.step(1e-3)
    out = sim.outputs()
    w = 2 * math.pi / cfg.wave_period
    expected = (X[:, 0] * cfg.wave_height / 2 * np.exp(-1j * w * sim.time)).real
    # X: the same function of the same box and wave (same bits); the angle fl(w t), w = 2 pi / T, the same bits on
    # both sides; each side within gamma(7) of Re(X a e^{-i w t}) at that angle: a X (1 rounding), the complex
    # product (2), cos/sin within 4 ulp (libm or numpy SIMD, generously); terms (|Re X| + |Im X|) a (ramp(2.5, 2) = 1)
    got = np.array([out[n] for n in ("F_x", "F_y", "F_z", "M_x", "M_y", "M_z")])
    scale = (np.abs(X[:, 0].real) + np.abs(X[:, 0].imag)) * cfg.wave_height / 2
    assert np.all(np.abs(got - expected) <= implementations_bound(scale, 7))
    # eta: a cos(fl(w t)) both sides (same angle bits): the product (1 rounding) and cos (4 ulp): gamma(5) a each
    eta = cfg.wave_height / 2 * math.cos(w * sim.time)
    assert abs(out["eta"] - eta) <= implementations_bound(cfg.wave_height / 2, 5)
    assert ramp(1.0, 2.0) == pytest.approx(0.5)
    with pytest.raises(ParameterError, match="sea_state"):
        WaveExcitationSimulator(WaveExcitationConfig(sea_state="storm"))


def test_hydrostatic_coefficients_and_stability_check():
    box = FloatingBox().check()
    C = box.hydrostatic_stiffness()
    assert C[2, 2] == pytest.approx(box.rho * box.g * box.length * box.beam)
    # GM_T = I_wp / V + z_B - z_G: C44 = rho g V GM_T
    gm = box.length * box.beam**3 / 12 / box.volume - box.draft / 2 - box.z_G
    assert C[3, 3] == pytest.approx(box.rho * box.g * box.volume * gm)
    with pytest.raises(ParameterError, match="z_G.*roll"):
        FloatingBox(z_G=0.2).check()
    M = box.rigid_mass_matrix()
    assert np.allclose(M, M.T) and np.all(np.linalg.eigvalsh(M) > 0)
    B = box.radiation_damping([0.1, 0.1, 0.15, 0.05, 0.1, 0.1])
    MA = np.diag(M + box.added_mass())
    assert B[2, 2] == pytest.approx(2 * 0.15 * math.sqrt(C[2, 2] * MA[2]))


def test_hydrostatics_force_and_energy_outputs():
    sim = HydrostaticsSimulator(HydrostaticsConfig())
    sim.set_inputs(pos_z=0.01, rot_y=0.02, vel_z=0.1, omega_x=0.05)
    out = sim.outputs()
    C, B = sim.C, sim.B
    assert out["F_z"] == pytest.approx(-C[2, 2] * 0.01 - B[2, 2] * 0.1)
    assert out["M_y"] == pytest.approx(-C[4, 4] * 0.02)
    assert out["M_x"] == pytest.approx(-B[3, 3] * 0.05)
    assert out["potential_energy"] == pytest.approx(0.5 * (C[2, 2] * 1e-4 + C[4, 4] * 4e-4))
    assert out["radiation_power"] == pytest.approx(B[2, 2] * 0.01 + B[3, 3] * 0.0025)


def test_platform_exact_step_work_bookkeeping_and_mount_loads():
    cfg = PlatformConfig(mount_x=0.1, mount_z=0.2)
    sim = PlatformSimulator(cfg)
    rng = np.random.default_rng(5)
    ke0 = 0.0
    M, absM, absMi = sim.M, np.abs(sim.M), np.abs(sim.M_inv)
    # the inverse's residual |M M_inv - I|, computed (6 terms and the subtraction: + gamma(7) |M||M_inv|)
    residual = np.abs(M @ sim.M_inv - np.eye(6)) + gamma(7) * absM @ absMi
    bound = 0.0
    for _ in range(50):                                   # random held loads, variable steps
        sim.set_inputs(**{n: float(rng.normal()) for n in sim.inputs})
        h = float(rng.uniform(1e-4, 5e-3))
        v0, Q, acc = np.abs(sim.xi_dot), np.abs(sim.group_loads()), np.abs(sim.acceleration())
        sim.step(h)
        d = h * v0 + 0.5 * h * h * acc                    # |d_xi|'s terms
        w = v0 + np.abs(sim.xi_dot) + h * acc
        # exact: KE(v + h a) - KE(v) = (M a) . d_xi; per step (M a - Q) . d_xi with a = fl(M_inv Q), |M a - Q| <=
        # (residual + gamma(9) |M||M_inv|) |Q| (6-term matvec, 4-group sum), the rounding of d_xi (gamma(4)
        # |M||a| . d), of Q . d_xi and the work's running sums over 50 steps and 4 groups (gamma(6 + 50 + 3)), and
        # of v + h a (gamma(2) |v|+h|a| against M (v_k + v_k+1) / 2: gamma(2) w^T |M| w)
        bound += ((residual + gamma(9) * absM @ absMi) @ Q.sum(axis=0)) @ d + gamma(4) * (absM @ acc) @ d
        bound += gamma(59) * (Q @ d).sum() + gamma(2) * w @ absM @ w
    out = sim.outputs()
    v = np.abs(sim.xi_dot)
    bound += gamma(7) * v @ absM @ v                      # the final 0.5 v^T M v (ke0 = 0 exactly)
    work = sum(out[f"work_{g}"] for g in ("wave", "hydro", "payload", "pto"))
    assert abs(out["kinetic_energy"] - ke0 - work) <= bound
    # constant force from rest: x = F t^2 / 2 (M^-1 F), exactly, in one or many steps
    a = PlatformSimulator(cfg)
    b = PlatformSimulator(cfg)
    for s in (a, b):
        s.set_inputs(wave_F_z=3.0, payload_F_x=1.0)
    a.step(0.4)
    for _ in range(8):
        b.step(0.05)
    rhs = np.array([1.0, 0, 3.0, 0, 1.0 * 0.2, 0])
    acc = np.linalg.solve(a.M, rhs)   # payload F_x at the mount: M_y = z_m F_x
    acc_sim = a.acceleration()        # fl(M_inv Q), Q = rhs exactly (the cross product r_m x F of 0.2 and 0s)

    def solve_error(x):
        # |x - M^-1 b| <= |M^-1| |M x - b|, the residual computed within gamma(7) (|M||x| + |b|) (first order in u)
        return np.abs(a.M_inv) @ (np.abs(a.M @ x - rhs) + gamma(7) * (np.abs(a.M) @ np.abs(x) + np.abs(rhs)))
    # a.xi = fl(0.5 fl(h h) acc_sim), h = fl(0.4); 0.5 acc fl(0.16): each within gamma(4) of 0.08 x (0.4, 0.16 decimal)
    err = solve_error(acc) + solve_error(acc_sim)
    assert np.all(np.abs(a.xi - 0.5 * acc * 0.16) <= 0.08 * (err + gamma(4) * (np.abs(acc) + np.abs(acc_sim))))
    # the same acc_sim bits in a and b (same M, same inv); fl(0.05) = fl(0.4) / 8 exactly, so equal in exact
    # arithmetic.  Per step 5 roundings (h v, h h, . acc, two sums; v + h acc) on terms <= |xi| + h |v| at the end
    # (all of one sign from rest), carried by the step map in (xi, h v): [[1, 1], [0, 1]], 1-norm 2, over 8 steps
    scale = np.abs(b.xi) + 0.05 * np.abs(b.xi_dot)
    assert np.all(np.abs(b.xi - a.xi) <= implementations_bound(scale, 5, growth=2.0, n_steps=8))
    out = a.outputs()
    alpha = np.array([out["alpha_x"], out["alpha_y"], out["alpha_z"]])
    mount_a = np.array([out[f"mount_a_{c}"] for c in "xyz"])
    # acc vs acc_sim as above; each side's cross product and sum (3 roundings) of terms <= |acc| + sum|alpha| sum|r|
    terms = np.abs(acc_sim[:3]) + np.abs(alpha).sum() * np.abs(cfg.mount).sum()
    bound = (solve_error(acc) + solve_error(acc_sim))[:3] + implementations_bound(terms, 3)
    assert np.all(np.abs(mount_a - (acc[:3] + np.cross(alpha, cfg.mount))) <= bound)
    with pytest.raises(ParameterError, match="diverged"):
        a.set_inputs(wave_F_z=1e9)
        a.step(1.0)


def test_pto_damper_stator_and_power():
    sim = PTOSimulator(PTOConfig(damping=3.0))
    sim.set_inputs(v_x=0.1, v_y=-0.2, v_z=0.05)
    out = sim.outputs()
    F = np.array([out["F_x"], out["F_y"], out["F_z"]])
    assert np.allclose(F, -3.0 * np.array([0.1, -0.2, 0.05]))
    assert out["power"] == pytest.approx(3.0 * (0.01 + 0.04 + 0.0025))
    r = np.array([0.14, 0.15, 0.16])
    assert np.allclose([out[f"stator_M_{c}"] for c in "xyz"], np.cross(r, -F))
    axial = PTOSimulator(PTOConfig(damping=3.0, axis_z=2.0))
    axial.set_inputs(v_x=0.1, v_y=-0.2, v_z=0.05)
    o = axial.outputs()
    assert (o["F_x"], o["F_y"], o["F_z"]) == (0.0, 0.0, pytest.approx(-0.15))
    assert o["power"] == pytest.approx(3.0 * 0.05**2)
