"""Exponential reframe scheme (scheme="exponential") and the geometric-stiffness hook.

References never come from the code under test: the analytic damped oscillator, the consistent scheme at
a small step (its dt -> 0 limit; it is itself checked against rigid Newton-Euler, Exudyn and a
physical-space step elsewhere), momenta from M and the nodal state (tests/test_reframe.invariants), and
the hand-calculated frequency of a spinning mode with a given geometric stiffness.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from flexfmu.reframe import kernels as K
from flexfmu.errors import ParameterError
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.models import load_model
from flexfmu.reframe.plate import paper_plate
from flexfmu.reframe.integrator import SCHEMES, PointLoad, ReframeIntegrator, exponential_coefficients, half_sine_pulse
from error_bounds import U, expm_error_bound, gamma, implementations_bound
from reframe_bounds import mass_matrix, outputs_bound, steps_bound
from test_reframe import invariants, mass_properties

OMEGA0 = np.array([5.0, 2.0, 8.0])
DIR = np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)
LOAD_NODE = 12                                      # free end of the bent rod


@pytest.fixture(scope="module")
def beam():
    """Free-free bent rod, 13 nodes, 6 DOF/node; flexible modes 148, 266, 280, 980, 992, 1316 Hz."""
    return load_model("beam:spatial_double_L", elements_per_segment=4)


@pytest.fixture(scope="module")
def plate():
    return paper_plate((20, 2, 1))


def _single_mode(basis, j):
    """The six rigid modes and flexible mode j only (still mass-orthonormal and K-diagonal)."""
    sel = [0, 1, 2, 3, 4, 5, 6 + j]
    return dataclasses.replace(basis, shapes=basis.shapes[:, sel], frequencies_hz=basis.frequencies_hz[[j]],
                               stiffness=basis.stiffness[sel], damping=basis.damping[sel],
                               damping_ratio=basis.damping_ratio[[j]])


def _balanced_phi_matrix(k, c, h):
    """The 8x8 matrix whose exponential schemes.exponential_coefficients_scipy (and its C port) take for one mode:
    [[h L^, I, 0, 0], [0, 0, I, 0], [0, 0, 0, I], 0] with L^ = [[0, omega], [-k / omega, -c]] (omega = sqrt(k))."""
    s = math.sqrt(k) if k > 0 else 1.0
    W = np.zeros((8, 8))
    W[0:2, 0:2] = h * np.array([[0.0, s], [-k / s, -c]])
    for blk in range(3):
        W[2 * blk:2 * blk + 2, 2 * blk + 2:2 * blk + 4] = np.eye(2)
    return W


def test_exponential_is_a_scheme():
    assert "exponential" in SCHEMES


# --------------------------------------------------------------------------- (b) analytic oscillator
def test_single_free_mode_matches_the_analytic_damped_oscillator(plate):
    """No rigid motion: a self-equilibrated force pair (equal, opposite, along the line joining its two
    nodes: zero force and moment) on one flexible mode of the plate, 2 % damping, q0 and qd0 given.
    Then q'' + 2 zeta omega q' + omega^2 q = Q exactly, Q = phi^T f (from the mode shape here), and the
    exponential step is exact for it (held load) whatever dt: round-off at dt omega = 0.5, 5 and 20."""
    mb = modal_basis(plate, 8, 0.02)
    pts = plate.points
    a, b = pts["P1"], pts["P7"]                                # opposite corners of the plate
    e = plate.nodes[b] - plate.nodes[a]
    e /= np.linalg.norm(e)
    F = 50.0
    Qs = [F * e @ (mb.flexible[3 * b:3 * b + 3, j] - mb.flexible[3 * a:3 * a + 3, j]) for j in range(8)]
    j = int(np.argmax(np.abs(Qs)))                             # the mode this pair drives most
    one = _single_mode(mb, j)
    w, zeta, Q = 2 * np.pi * one.frequencies_hz[0], one.damping_ratio[0], Qs[j]
    q0, v0 = 1e-5, -3e-3
    qs = Q / w**2
    wd = w * math.sqrt(1 - zeta**2)

    def analytic(t):
        x0 = q0 - qs
        return qs + np.exp(-zeta * w * t) * (x0 * np.cos(wd * t) + (v0 + zeta * w * x0) / wd * np.sin(wd * t))

    assert abs(qs) > 0.1 * abs(q0)                             # the load matters
    k, c = float(one.stiffness[6]), float(one.damping[6])
    amp = abs(q0 - qs) + abs((v0 + zeta * w * (q0 - qs)) / wd)
    # balanced coordinates (omega q, p): the damped mode's map has log-norm <= 0 (||e^{hL^}||_2 <= 1), so the
    # state stays within |z0 - z_s| of the static z_s = (omega qs, 0)
    z_max = w * abs(qs) + math.hypot(w * (q0 - qs), v0)
    for dtw in (0.5, 5.0, 20.0):
        dt = dtw / w
        integ = ReframeIntegrator(plate, one, scheme="exponential", deformed_load_arm=False)
        integ.set_initial(q0=[q0], qd0=[v0])
        n = int(round(0.2 / dt))
        every = max(1, n // 50)
        loads = [PointLoad(b, F * e), PointLoad(a, -F * e)]
        r = integ.run(n * dt, dt, loads, every=every)
        # the state of record i is after min(i every, n) steps of dt: its exact time is steps * dt (one rounding),
        # not the integrator's t accumulated by n additions (up to n u t_end off, omega n u t_end in the phase)
        t_exact = np.minimum(np.arange(len(r.t)) * every, n) * dt
        ref = analytic(t_exact)
        err = np.max(np.abs(r.q[:, 0] - ref))
        t_end = n * dt
        ka = integ.kernel_arguments(integ.prepare_loads(loads), dt, np.array([], dtype=np.int64))
        LP = ka.LP.reshape(2, -1)
        arms = np.linalg.norm(LP[:, 2:5], axis=1)
        phis = np.abs(LP[:, 5:8]).sum(axis=1)
        # (i) the exponential coefficients: per step the balanced augmented expm (schemes.exponential_coefficients,
        # frac 1 and 1/2) errs by <= eb in the 2-norm; E1 carries it on |z| <= z_max, B1, B2 (twice), B4 =
        # h (phi1 - 3 phi2 + 4 phi3), h (2 phi2 - 4 phi3), h (4 phi3 - phi2) on Q: <= (8 + 12 + 5) h eb |Q|
        eb = max(expm_error_bound(_balanced_phi_matrix(k, c, frac * dt)) for frac in (1.0, 0.5))
        coef = n * eb * (z_max + 25 * dt * abs(Q))
        # (ii) the step's rounding: <= 32 roundings (Q from two loads 6, the phi combinations 5, the 2x2 products
        # 2, four maps summed 3, the scaling back 1, the mass solve for qd 2, ...) on terms <= 2 z_max (|E1| <= 1
        # entrywise x 2) + 25 h |Q|; growth 1 (damped mode in its energy norm), n steps
        rnd = implementations_bound(2 * z_max + 25 * dt * abs(Q), 32, 1.0, n)
        # (iii) Q: the kernel's PhiT^T f per load vs the test's F e . (phi_b - phi_a), each within gamma_8 of the terms
        # sum |Phi| |f|: a held-force difference moves q by <= 2 dQ / omega^2 (the step response's overshoot < 2)
        dQ = 2 * gamma(8) * F * float(phis.sum())
        # (iv) the reference: the phase and decay arguments (omega_d t, zeta omega t <= 2 omega t_end) carry <= 16
        # roundings (omega from lam 3, omega_d 4, t 2, products 2, exp/sin/cos <= 4 ulp each [libm, SVML]);
        # relative to the amplitude; qs = Q / w^2 and the sum: gamma_4 |qs|
        ref_err = amp * gamma(16) * (1 + 2 * w * t_end) + gamma(4) * abs(qs)
        bound = (coef + rnd) / w + 2 * dQ / w**2 + ref_err
        # omega: no force (the pair sums to exactly 0); the moment of the computed pair is <= F (|d| gamma_6 +
        # gamma_2 (|arm_a| + |arm_b|)) (e is d / |d| to rounding, the arms node - com rounded), its evaluation
        # <= 2 gamma_8 F sum |arm|, accumulated over t_end into h; rigid velocities = M^-1 [p, h, p_q]: the
        # coupling block M^-1[3:6, 6:] on |p_q| <= z_max and its inverse's error kappa gamma_7 ||M^-1||
        M = mass_matrix(ka.P, 1, np.zeros(1))
        Minv = np.linalg.inv(M)
        dist = float(np.linalg.norm(plate.nodes[b] - plate.nodes[a]))
        h_max = t_end * F * (dist * gamma(6) + gamma(2) * arms.sum() + 2 * gamma(8) * arms.sum())
        w_bound = 2 * (np.linalg.norm(Minv, 2) * h_max + (np.linalg.norm(Minv[3:6, 6:], 2)
                       + np.linalg.cond(M) * gamma(7) * np.linalg.norm(Minv, 2)) * z_max)
        print(f"\nsingle mode {one.frequencies_hz[0]:.1f} Hz, dt omega = {dtw}: max |q - q_analytic| = {err:.2g} "
              f"(bound {bound:.2g}, max |q| {np.max(np.abs(ref)):.2g}), max |omega| = {np.max(np.abs(r.omega)):.1g} "
              f"rad/s (bound {w_bound:.2g})")
        assert err <= bound
        assert np.max(np.abs(r.omega)) <= w_bound


# --------------------------------------------------------------------------- (a) no RK4 limit
def _tumble_run(beam, mb, scheme, dt, t_end=0.2):
    integ = ReframeIntegrator(beam, mb, scheme=scheme)
    integ.set_initial(omega0=OMEGA0)
    r = integ.run(t_end, dt, PointLoad(LOAD_NODE, half_sine_pulse(2.0 * DIR, 0.02)), points=[LOAD_NODE],
                  every=10**6)
    return r, integ


def test_no_rk4_stability_limit(beam):
    """Six flexible modes (up to 1316 Hz), tumbling (omega0 = (5, 2, 8) rad/s) under a 0.02 s pulse: at
    dt omega_max = 20.7 the consistent scheme is refused, its RK4 kernel (run without the check)
    diverges, and the exponential scheme stays within 1e-5 of the consistent scheme at dt = 2.5e-5 s."""
    mb = modal_basis(beam, 6)
    dt = 2.5e-3
    ref, integ = _tumble_run(beam, mb, "consistent", 2.5e-5)
    assert dt * integ.data.omega_max >= 20.0
    with pytest.raises(ParameterError) as e:
        _tumble_run(beam, mb, "consistent", dt)
    assert e.value.parameter == "dt"
    s = integ.initial_state(omega0=OMEGA0)
    loads = integ.prepare_loads(PointLoad(LOAD_NODE, half_sine_pulse(2.0 * DIR, 0.02)))
    SV, held = loads.stage_values(0.0, dt, 80)
    y0 = np.concatenate((s.position, s.rotation.ravel(), s.eta))
    ka = integ.kernel_arguments(loads, dt)
    _, _, done, status = K.consistent_steps(ka.P, ka.LP, ka.nf, True, SV, held, 0.0, dt, 80, y0)
    assert status == 2 and done < 80                          # RK4 blew up to non-finite values
    r, _ = _tumble_run(beam, mb, "exponential", dt)
    err_w = np.linalg.norm(r.omega[-1] - ref.omega[-1]) / np.linalg.norm(ref.omega[-1])
    err_q = np.linalg.norm(r.q[-1] - ref.q[-1]) / np.linalg.norm(ref.q[-1])
    err_x = np.linalg.norm(r.point_position[-1, 0] - ref.point_position[-1, 0])
    print(f"\ndt omega_max = {dt * integ.data.omega_max:.1f}: consistent RK4 non-finite after {done + 1} steps; "
          f"exponential: omega error {err_w:.2g}, q error {err_q:.2g} (relative), tip position {err_x:.2g} m")
    assert err_w <= 1e-5 and err_q <= 1e-5 and err_x <= 1e-5


# --------------------------------------------------------------------------- (c) convergence order
def test_converges_to_the_consistent_limit_with_order_4(beam):
    """Three flexible modes, omega0 = (5, 2, 8) rad/s, 0.1 s half-sine pulse, 0.2 s: omega, attitude and
    the tip position against the consistent scheme at dt = 5e-5 s (whose own error is ~1e-11 here)."""
    mb = modal_basis(beam, 3)
    force = half_sine_pulse(2.0 * DIR, 0.1)

    def final(scheme, dt):
        integ = ReframeIntegrator(beam, mb, scheme=scheme)
        integ.set_initial(omega0=OMEGA0)
        r = integ.run(0.2, dt, PointLoad(LOAD_NODE, force), points=[LOAD_NODE], every=10**6)
        return np.concatenate([r.omega[-1], r.rotation[-1].ravel(), r.point_position[-1, 0]]), integ

    ref, _ = final("consistent", 5e-5)
    dts = (2e-3, 1e-3, 5e-4, 2.5e-4)              # each divides the pulse length and t_end
    errs = []
    for dt in dts:
        y, integ = final("exponential", dt)
        errs.append(np.linalg.norm(y - ref))
    errs = np.array(errs)
    orders = np.log2(errs[:-1] / errs[1:])
    print(f"\nexponential vs consistent(5e-5): dt {dts} (dt omega_max {np.array(dts) * integ.data.omega_max}), "
          f"errors {errs}, orders {orders}")
    assert errs[-1] <= 1e-9
    assert np.all(3.5 <= orders[-2:]) and np.all(orders[-2:] <= 5.0)


# --------------------------------------------------------------------------- (d) momenta
def test_linear_momentum_exact(beam):
    """v0 != 0, tumbling, constant global loads at two nodes, at dt omega_max = 0.18 and 21:
    m v_com = m v0 + F t from M and the nodal velocities."""
    mb = modal_basis(beam, 3)
    m, _, _ = mass_properties(beam)
    v0 = np.array([0.3, -0.2, 0.1])
    f1, f2 = 3.0 * DIR, np.array([0.0, 0.5, -0.25])
    for dt in (1e-4, 1.2e-2):
        integ = ReframeIntegrator(beam, mb, scheme="exponential")
        integ.set_initial(v0=v0, omega0=OMEGA0)
        integ.run(0.12, dt, [PointLoad(LOAD_NODE, f1), PointLoad(5, f2)], every=10**6)
        p, _, _, _ = invariants(integ, beam, integ.state)
        expected = m * v0 + (f1 + f2) * integ.state.t
        err = np.linalg.norm(p - expected) / np.linalg.norm(expected)
        print(f"\nexponential, dt omega_max = {dt * integ.data.omega_max:.2f}: linear momentum error {err:.2g}")
        assert err <= 1e-9


def test_angular_momentum_free_tumbling(beam):
    """No load, undamped, omega0 = (5, 2, 8) rad/s, 2 s, six flexible modes: angular momentum about the
    global origin from M and the nodal state, at dt omega_max = 1.7 and 20.7."""
    mb = modal_basis(beam, 6, damping_ratio=0.0)
    for dt in (2e-4, 2.5e-3):
        integ = ReframeIntegrator(beam, mb, scheme="exponential")
        s0 = integ.set_initial(omega0=OMEGA0)
        _, L0, T0, V0 = invariants(integ, beam, s0)
        integ.run(2.0, dt, None, every=10**6)
        _, L1, T1, V1 = invariants(integ, beam, integ.state)
        dL = np.linalg.norm(L1 - L0) / np.linalg.norm(L0)
        dE = abs(T1 + V1 - T0 - V0) / T0
        print(f"\nexponential, free tumbling 2 s, dt omega_max = {dt * integ.data.omega_max:.1f}: |dL|/|L| = {dL:.2g}, "
              f"|d(T+V)|/T = {dE:.2g}")
        assert dL <= 1e-10
        assert dE <= 1e-4


# --------------------------------------------------------------------------- (e) C = numpy
def _random_G(nf, rng, scale):
    G = scale * rng.standard_normal((3, 3, nf, nf))
    return 0.5 * (G + G.transpose(1, 0, 2, 3))


@pytest.mark.skipif(not K.NATIVE, reason="C kernels not available: the numpy versions are the only ones")
@pytest.mark.parametrize("scheme", ["exponential", "consistent"])
def test_c_kernels_equal_numpy_versions(beam, scheme):
    """reframe_steps / reframe_outputs with geometric stiffness, and the exponential coefficients."""
    mb = modal_basis(beam, 3)
    rng = np.random.default_rng(51)
    integ = ReframeIntegrator(beam, mb, scheme=scheme, geometric_stiffness=_random_G(3, rng, 1e3))
    s = integ.initial_state(omega0=OMEGA0, qd0=(1e-3, -2e-3, 1e-3))
    loads = integ.prepare_loads(PointLoad(LOAD_NODE, half_sine_pulse([1.0, 0.0, 1.0], 0.005), moment=[0.0, 0.01, 0.0]))
    dt, n = (1e-3, 40) if scheme == "exponential" else (5e-5, 200)
    SV, held = loads.stage_values(s.t, dt, n)
    pts = np.array([0, 7], dtype=np.int64)
    ka = integ.kernel_arguments(loads, dt, pts)                # EX: empty for the consistent scheme (RK4)
    y0 = np.concatenate((s.position, s.rotation.ravel(), s.eta))
    args = (ka.P, ka.LP, ka.G, ka.EX, ka.nf, True, SV, held, 0.0, dt, n, y0)
    y_c, t_c, k_c, st_c = K.reframe_steps(*args)
    y_np, t_np, k_np, st_np = K.reframe_steps_numpy(*args)
    assert (k_c, st_c) == (k_np, st_np) == (n, 0) and t_c == t_np
    # C vs numpy, two double implementations: the a-priori bound of tests/reframe_bounds.py (gamma of the longest
    # rounding chain x the terms' size, carried n steps by the computed flexible-map growth and the rigid Lipschitz)
    assert np.max(np.abs(y_c - y_np)) <= steps_bound(ka.P, ka.LP, ka.G, ka.EX, ka.nf, SV, dt, n, y0, y_np)
    assert np.max(np.abs(y_np - y0)) > 1e-6                   # it moved
    out_args = (ka.P, ka.LP, ka.G, ka.nf, True, SV[-1, 2], y_c, ka.PP, ka.Psi, ka.dpn, *ka.umax)
    o_c, o_np = K.reframe_outputs(*out_args), K.reframe_outputs_numpy(*out_args)
    # the same state y_c into both: the outputs' bound of tests/reframe_bounds.py (solve, point accelerations)
    assert np.max(np.abs(o_c - o_np)) <= outputs_bound(ka.P, ka.LP, ka.G, ka.nf, SV[-1, 2], y_c, ka.PP, ka.Psi,
                                                       ka.dpn, o_np)


def test_exponential_coefficients_against_eigen_decomposition():
    """The six 2x2 matrices against L = V diag(lambda) V^-1 with the scalar phi_k(z) = (e^z - sum_{i<k}
    z^i / i!) / z^k (direct formula: |h lambda| >= 0.5 here), for a damped and an undamped mode at
    h omega = 0.5, 5 and 20; and the nilpotent limit k = c = 0 (L = [[0, 1], [0, 0]]: phi_k(hL) =
    I/k! + hL/(k+1)!, the RK4 weights on q plus the exact drift)."""
    import mpmath
    from test_native_reframe_kernels import _exponential_coefficients_mp

    def phi(k, z):
        return (mpmath.exp(z) - sum(z**i / mpmath.factorial(i) for i in range(k))) / z**k

    for zeta in (0.0, 0.05):
        w = 2.0e3
        kk, cc = w**2, 2 * zeta * w
        for hw in (0.5, 5.0, 20.0):
            h = hw / w
            with mpmath.workdps(40):       # the eigen-decomposition reference at 40 digits: its error is negligible
                lam = [(-cc + r) / 2 for r in (mpmath.sqrt(mpmath.mpc(cc * cc - 4 * kk)),
                                                -mpmath.sqrt(mpmath.mpc(cc * cc - 4 * kk)))]
                V = mpmath.matrix([[1, 1], lam])
                Vi = mpmath.inverse(V)

                def f(g, x):
                    return V * mpmath.diag([g(x * lam[0]), g(x * lam[1])]) * Vi

                p1, p2, p3 = (f(lambda z, k=k: phi(k, z), h) for k in (1, 2, 3))
                want = [f(mpmath.exp, h), f(mpmath.exp, h / 2), h / 2 * f(lambda z: phi(1, z), h / 2),
                        h * (p1 - 3 * p2 + 4 * p3), h * (2 * p2 - 4 * p3), h * (4 * p3 - p2)]
                want = [np.array([[float(mpmath.re(M[i, j])) for j in range(2)] for i in range(2)]) for M in want]
            got = exponential_coefficients([kk], [cc], h)[0]
            # the double port's error, per entry in the balanced coordinates (omega q, p): expm_error_bound of the
            # two augmented 8x8 exponentials carried through the combinations, + the scalings and the reference's
            # and the combination's few roundings (tests/test_native_reframe_kernels._exponential_coefficients_mp)
            _, _, bound = _exponential_coefficients_mp(np.array([kk]), np.array([cc]), h)
            unbalance = np.array([[1.0, 1.0 / w], [w, 1.0]])     # (omega q, p) -> (q, p): T^-1 X T, T = diag(w, 1)
            for m in range(6):
                # + the 40-digit reference rounded to double: u |want|
                allowed = bound[0, m] * unbalance + U * np.abs(want[m])
                assert np.all(np.abs(got[m] - want[m]) <= allowed), (zeta, hw, m)
    h = 1e-3
    N = np.array([[0.0, 1.0], [0.0, 0.0]])
    X = exponential_coefficients([0.0], [0.0], h)[0]
    I2 = np.eye(2)
    expect = [I2 + h * N, I2 + h / 2 * N, h / 2 * (I2 + h / 4 * N), h / 6 * I2 + h * h * (1 / 2 - 3 / 6 + 4 / 24) * N,
              h / 3 * I2 + h * h * (2 / 6 - 4 / 24) * N, h / 6 * I2 + h * h * (4 / 24 - 1 / 6) * N]
    # the port's bound at k = c = 0 (_exponential_coefficients_mp, unbalanced with s = 1) + the few roundings of
    # ``expect`` (<= 4 terms: gamma_4 of their sizes, each <= |h| <= 2 max |expect|)
    _, _, bound = _exponential_coefficients_mp(np.zeros(1), np.zeros(1), h)
    for m in range(6):
        assert np.all(np.abs(X[m] - expect[m]) <= bound[0, m] + gamma(4) * 2 * np.max(np.abs(expect[m]))), m


# --------------------------------------------------------------------------- geometric stiffness hook
def test_geometric_stiffness_shifts_the_spinning_frequency(plate):
    """Plate spinning at Omega = 2 rad/s about its normal z (a principal axis) with one flexible mode
    (397 Hz) and G[x, x] = G[y, y] = g, G[z, z], G[x, z] = G[z, x] arbitrary.  X = skew(w)^2 =
    diag(-Omega^2, -Omega^2, 0), so the hook adds 2 g Omega^2 q: omega^2 = k - 2 g Omega^2 (the model's own
    rotating-frame terms are O((Omega/omega)^2) = 6e-7).  g is chosen for +20 % frequency; the
    frequency is measured from zero crossings of q over ~30 periods."""
    mb = modal_basis(plate, 8, 0.0)
    one = _single_mode(mb, 6)
    k = one.stiffness[6]
    Om = 2.0
    g = -(1.2**2 - 1.0) * k / (2 * Om**2)
    G = np.zeros((3, 3, 1, 1))
    G[0, 0] = G[1, 1] = g
    G[2, 2] = 7.0 * g
    G[0, 2] = G[2, 0] = 3.0 * g
    expected = math.sqrt(k - 2 * g * Om**2)
    base = math.sqrt(k)
    for scheme in ("consistent", "exponential"):
        integ = ReframeIntegrator(plate, one, scheme=scheme, geometric_stiffness=G)
        integ.set_initial(omega0=(0.0, 0.0, Om), q0=[1e-4])
        dt = 0.05 / expected
        n = int(30 * 2 * math.pi / expected / dt)
        r = integ.run(n * dt, dt, None)
        q = r.q[:, 0] - np.mean(r.q[:, 0])
        i = np.nonzero(np.sign(q[:-1]) != np.sign(q[1:]))[0]
        tc = r.t[i] - q[i] * (r.t[i + 1] - r.t[i]) / (q[i + 1] - q[i])
        measured = math.pi * (len(tc) - 1) / (tc[-1] - tc[0])
        print(f"\n{scheme}: spinning mode with G: {measured / (2 * math.pi):.6f} Hz, hand calculation "
              f"{expected / (2 * math.pi):.6f} Hz (without G {base / (2 * math.pi):.4f} Hz)")
        assert abs(measured / expected - 1) <= 1e-4
    # G = 0 is the same as no G (same numbers); the paper scheme refuses G
    s0 = ReframeIntegrator(plate, one).initial_state(omega0=(1.0, 2.0, Om), q0=[1e-4])
    s_none = ReframeIntegrator(plate, one, scheme="exponential").advance_steps(s0, 1e-3, 20)
    zero_G = ReframeIntegrator(plate, one, scheme="exponential", geometric_stiffness=np.zeros((3, 3, 1, 1)))
    s_zero = zero_G.advance_steps(s0, 1e-3, 20)
    # identity: with G = 0 the geometric terms add +-0.0 to each sum, which changes no bit; the rest is the same
    # operations in the same order
    assert np.array_equal(s_none.eta, s_zero.eta)


@pytest.mark.parametrize("G, scheme, fragment", [
    (np.zeros((3, 3, 2)), "consistent", "shape"),
    (np.zeros((3, 3, 1, 1)), "consistent", "shape"),
    (np.full((3, 3, 2, 2), np.nan), "exponential", "NaN"),
    ("abc", "consistent", "not numeric"),
    (np.zeros((3, 3, 2, 2)), "paper", "paper"),
])
def test_geometric_stiffness_bad_input(beam, G, scheme, fragment):
    with pytest.raises(ParameterError) as e:
        ReframeIntegrator(beam, modal_basis(beam, 2), scheme=scheme, geometric_stiffness=G)
    assert e.value.parameter == "geometric_stiffness" and fragment in str(e.value)


_FALLBACK_SCRIPT = """
import json, numpy as np
from flexfmu.reframe import kernels as K
from flexfmu.reframe.models import load_model
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.integrator import ReframeIntegrator, PointLoad, half_sine_pulse
from flexfmu.reframe.results import _state_vector
beam = load_model("beam:spatial_double_L", elements_per_segment=4)
G = 1e3 * np.random.default_rng(5).standard_normal((3, 3, 3, 3))
integ = ReframeIntegrator(beam, modal_basis(beam, 3), scheme="exponential", geometric_stiffness=G)
s = integ.initial_state(omega0=(5.0, 2.0, 8.0), qd0=(1e-3, -2e-3, 1e-3))
loads = integ.prepare_loads(PointLoad(12, half_sine_pulse([1.0, 0.0, 1.0], 0.005), moment=[0.0, 0.01, 0.0]))
pts = np.array([0, 7], dtype=np.int64)
t, y, o = [], [], []
for k in range(21):
    if k:
        s = integ.advance_steps(s, 1e-3, 1, loads)
    t.append(s.t)
    y.append(_state_vector(s).tolist())
    o.append(integ.output_vector(s, loads, pts).tolist())
print(json.dumps({"native": K.NATIVE, "t": t, "y": y, "o": o}))
"""


def _fallback_case():
    """The case of _FALLBACK_SCRIPT in this process: (integrator, initial state, prepared loads)."""
    beam = load_model("beam:spatial_double_L", elements_per_segment=4)
    G = 1e3 * np.random.default_rng(5).standard_normal((3, 3, 3, 3))
    integ = ReframeIntegrator(beam, modal_basis(beam, 3), scheme="exponential", geometric_stiffness=G)
    s0 = integ.initial_state(omega0=(5.0, 2.0, 8.0), qd0=(1e-3, -2e-3, 1e-3))
    loads = integ.prepare_loads(PointLoad(12, half_sine_pulse([1.0, 0.0, 1.0], 0.005), moment=[0.0, 0.01, 0.0]))
    return integ, s0, loads


def _carried(ka, sv_max, dt, n, y0, y_ref):
    """The factor by which tests/reframe_bounds.steps_bound carries a step's error into the later steps: the
    flexible modes' linear step map (max_k <= n ||M^k||_2) times exp(n dt Lambda), Lambda = (1 + kappa(S)) |omega|
    (the rigid gyroscopic coupling), at y0 and y_ref (as steps_bound takes them)."""
    from reframe_bounds import _flexible_growth, _force_terms, _split
    ws = [_split(ka.P, ka.nf, y)[1] for y in (y0, y_ref)]
    kappa_S = max(_force_terms(ka.P, ka.LP, ka.G, ka.nf, y, sv_max)[3] for y in (y0, y_ref))
    lam = (1 + kappa_S) * max(float(np.linalg.norm(w)) for w in ws)
    return _flexible_growth(ka.P, ka.EX, ka.G, ka.nf, dt, n, ws) * math.exp(n * dt * lam)


def test_numpy_fallback_gives_the_same_numbers():
    """FLEXFMU_NATIVE_KERNELS=0 (as without a C compiler): the exponential scheme with geometric stiffness gives
    the same results as the C kernels within the a-priori bounds of tests/reframe_bounds.py (20 steps, the states
    after every step and the output vectors at them), widened by the two runs' different exponential coefficients
    (scipy's expm and its C port)."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path
    from flexfmu.reframe.integrator import ReframeState
    from reframe_bounds import _force_terms, _split

    runs = {}
    for flag in ("0", "1"):
        out = subprocess.run([sys.executable, "-c", _FALLBACK_SCRIPT], env=dict(os.environ, FLEXFMU_NATIVE_KERNELS=flag),
                             capture_output=True, text=True, check=True, cwd=Path(__file__).resolve().parents[1])
        runs[flag] = json.loads(out.stdout.strip().splitlines()[-1])
    assert runs["0"]["native"] is False and runs["0"]["t"] == runs["1"]["t"]
    integ, s0, loads = _fallback_case()
    dt, pts = 1e-3, np.array([0, 7], dtype=np.int64)
    ka = integ.kernel_arguments(loads, dt, pts)
    y_np, y_run = np.array(runs["0"]["y"]), np.array(runs["1"]["y"])
    # the coefficients: each run's within (error bound of a double Pade-13 expm of the balanced augmented matrix,
    # _balanced_phi_matrix, frac 1 and 1/2) + (their combinations' and scaling's few roundings, gamma_8) of the exact
    # ones in the balanced coordinates (omega q, p); per step E1 carries the difference on |z| (the balanced mode
    # state, max over both runs' states), the B matrices on the step's forcing, over-counted as 25 h N with N the
    # rates' size (1 + kappa) ||M^-1|| T_b (tests/reframe_bounds.py); back in (q, p): / min(omega, 1)
    k, c = integ._kF, integ._cF
    omega = np.sqrt(k)
    eb = np.array([max(expm_error_bound(_balanced_phi_matrix(kj, cj, f * dt)) for f in (1.0, 0.5))
                   for kj, cj in zip(k, c)]) + gamma(8)
    sv_max = float(np.max(np.abs(loads.stage_values(s0.t, dt, 20)[0])))
    z_max, N = np.zeros(ka.nf), 0.0
    for y in np.vstack([y_np, y_run]):
        _, _, q, qd = _split(ka.P, ka.nf, y)
        z_max = np.maximum(z_max, np.hypot(omega * q, qd))
        T, kappa, minv, _ = _force_terms(ka.P, ka.LP, ka.G, ka.nf, y, sv_max)
        N = max(N, (1 + kappa) * minv * T)
    coefficients = float(np.max(2 * eb * (z_max + 25 * dt * N) / np.minimum(omega, 1.0)))
    y0 = y_np[0]
    worst = worst_o = 0.0
    for n in range(21):
        SV, _ = loads.stage_values(s0.t, dt, max(n, 1))
        # identical at n = 0 (the same initial state); then steps_bound, plus n steps' coefficient differences
        # carried as steps_bound carries its own per-step error (the flexible growth, the rigid coupling)
        bound = (steps_bound(ka.P, ka.LP, ka.G, ka.EX, ka.nf, SV, dt, n, y0, y_run[n])
                 + n * coefficients * _carried(ka, sv_max, dt, n, y0, y_run[n])) if n else 0.0
        err = float(np.max(np.abs(y_np[n] - y_run[n])))
        assert err <= bound, n
        worst = max(worst, err / bound if bound else 0.0)
        # the outputs, each at its run's own state (as tests/test_performance_equivalence.py): this process's
        # output_vector at the numpy run's state against the numpy run's, within outputs_bound; at the other
        # run's state the same code on the same numbers: identical (when this process has the C kernels, as that
        # run did)
        here = [integ.output_vector(ReframeState(t=runs["0"]["t"][n], position=y[:3], rotation=y[3:12].reshape(3, 3),
                                                 eta=y[12:]), loads, pts) for y in (y_np[n], y_run[n])]
        o_np, o_run = np.array(runs["0"]["o"][n]), np.array(runs["1"]["o"][n])
        o_bound = outputs_bound(ka.P, ka.LP, ka.G, ka.nf, sv_max, y_np[n], ka.PP, ka.Psi, ka.dpn, o_np)
        assert np.max(np.abs(here[0] - o_np)) <= o_bound, n
        worst_o = max(worst_o, float(np.max(np.abs(here[0] - o_np))) / o_bound)
        if K.NATIVE == runs["1"]["native"]:
            assert np.array_equal(here[1], o_run), n
    print(f"\nnumpy vs C kernels, 20 exponential steps: max state difference / bound {worst:.2g}, outputs "
          f"{worst_o:.2g} (steps_bound's scalar ||M^-1|| and mixed units: no bite here)")
