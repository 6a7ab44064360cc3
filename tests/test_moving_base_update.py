"""The moving-base step: base motion that changes at every step (a floating platform's) stepped by the Taylor series
of the step's exponential on the step's vector instead of new maps (flexfmu.native.lti_taylor in numpy; csrc/
lti_kernels.c's ffx_lti_taylor_* in C, the same rule).

* The rule is one: the C plan (sub-steps, terms), tail bound and balance equal numpy's.
* The bound holds: one sub-step of the series (numpy and C) against an extended-precision exponential, for the wave
  converter's harvester under base motion from 1e-3 to 10 rad/s (rad/s^2) and steps of 0.1 to 4 ms; the truncation
  bound is below u = 2^-53 (relative to ||w_1||) whenever the rule takes the series.
* A platform-like base motion (2 s at 1 ms): the series run within its propagated bound of a long-double run of the
  same held systems, equal to the exponential (maps) run and to the C kernel within the native tests' RTOL; the
  polynomials equal the library's own maps; jumps go by the maps, motion by the series, in numpy and C alike; a
  restored FFRBeam state continues bit for bit.  The same for an exported clamped body.
"""
import dataclasses
import math

import numpy as np
import pytest

from conftest import straight_rod
from error_bounds import U, gamma
from flexfmu.native import lti, lti_taylor
from flexfmu.native.compiler import CompilerError

try:
    lti.library()
except CompilerError as exc:                     # pragma: no cover - no C compiler on this machine
    pytest.skip(f"no C compiler: {exc}", allow_module_level=True)

#: two exact implementations of the zero-order hold, per output relative to its largest value over the record: the
#: tolerance tests/test_native_lti.py and tests/test_fmu_native.py demand of the native kernel against Python
RTOL = 1e-10
#: examples/wave_converter/OspSystemStructure.xml's harvester
HARVESTER = dict(scene="spatial_double_L", boundary="XFF", elements_per_segment=8, n_modes=6, damping_ratio=0.01,
                 load_s=0.45, sensor_s=0.45)
H = 1e-3
EPS_LD = float(np.finfo(np.longdouble).eps)


# ---------------------------------------------------------------------------------------------- fixtures, helpers
@pytest.fixture(scope="module")
def harvester():
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    return FFRBeamSimulator(FFRBeamConfig(**HARVESTER))


@pytest.fixture(scope="module")
def harvester_model(harvester):
    return lti.LtiModel.from_ffrbeam(harvester)


def platform_motion(n: int, h: float, seed: int = 5) -> np.ndarray:
    """(n, 9): base a0 (m/s^2), w (rad/s), dw (rad/s^2) of a floating platform, body frame: per axis three sines of
    the wave converter's periods (1 .. 2.5 s), amplitudes as its run (w_y up to 0.3 rad/s, a0 up to 0.7 m/s^2), dw
    the derivative of w."""
    rng = np.random.default_rng(seed)
    t = h * np.arange(n)[:, None]
    out = np.zeros((n, 9))
    for axis, (a_amp, w_amp) in enumerate(((0.35, 0.08), (0.15, 0.3), (0.7, 0.02))):
        for _ in range(3):
            omega = 2.0 * np.pi / rng.uniform(1.0, 2.5)
            phase = rng.uniform(0.0, 2.0 * np.pi)
            out[:, axis] += a_amp / 3 * np.sin(omega * t[:, 0] + phase)
            out[:, 3 + axis] += w_amp / 3 * np.sin(omega * t[:, 0] + 1.3 * phase)
            out[:, 6 + axis] += w_amp / 3 * omega * np.cos(omega * t[:, 0] + 1.3 * phase)
    return out


def expm_ld(M: np.ndarray) -> np.ndarray:
    """exp(M) in long double: a degree-30 Taylor series of M / 2^s (||M / 2^s||_1 <= 1/4), squared s times.  Its
    error (truncation 0.25^31 / 31!, ~1e-53; the roundings, ~(30 + s) n eps_ld of the terms' sizes) is far below
    the double-precision bounds it is compared against; REFERENCE_SLACK covers it."""
    A = M.astype(np.longdouble)
    norm = float(np.abs(M).sum(axis=0).max())
    s = max(0, math.ceil(math.log2(norm / 0.25))) if norm > 0 else 0
    A = A / np.longdouble(2.0) ** s
    E = T = np.eye(M.shape[0], dtype=np.longdouble)
    for k in range(1, 31):
        T = T @ A / k
        E = E + T
    for _ in range(s):
        E = E @ E
    return E


def reference_step(A, g, x, h) -> tuple[np.ndarray, np.ndarray]:
    """x+ = e^{hA} x + h phi_1(hA) g in long double, and e^{hA} (the top rows of expm([[hA, hg], [0, 0]]))."""
    nx = A.shape[0]
    M = np.zeros((nx + 1, nx + 1))
    M[:nx, :nx], M[:nx, nx] = h * A, h * g
    E = expm_ld(M)
    z = np.concatenate([np.asarray(x, np.longdouble), [np.longdouble(1)]])
    return (E[:nx] @ z), E[:nx, :nx]


def norm_d(v, d) -> float:
    return float(np.max(np.abs(np.asarray(v, float)) / d))


def series_bound(A, g, x, h, plan, d) -> float:
    """What may separate one sub-step of the series (plan (1, K), either evaluation) from e^{hA} x + h phi_1(hA) g
    in ||.||_D (lti_taylor's docstring): the truncation tail(theta, K) ||w_1||_D, plus the roundings.  With m_1 =
    h (|A||x| + |g|) (componentwise, so the bound holds in the scaled coordinates too) the terms are within
    theta^(k-1)/k! ||m_1||_D, and each computed term carries at most ((1 + gamma_c)^L - 1) of its size for a chain of
    L rounded products and sums of c terms [ASNA 3.5]: the C recursion L = K (c = nx + 2), numpy's Paterson-
    Stockmeyer L <= 3K (c = nx + q + 2); the increments' sum and the final addition one u each [ASNA 4.2].  So
        rounding <= ((1 + gamma_c)^(3K + 2) - 1) (e^theta - 1) / theta ||m_1||_D + u ||x||_D."""
    s, K = plan
    assert s == 1
    theta = h * lti_taylor.scaled_norm(np.asarray(A), d)
    w1 = h * (A @ x + g)
    m1 = h * (np.abs(A) @ np.abs(x) + np.abs(g))
    c = A.shape[0] + math.ceil(math.sqrt(K)) + 2
    grow = (math.expm1(theta) / theta) if theta > 0 else 1.0
    rounding = ((1.0 + gamma(c)) ** (3 * K + 2) - 1.0) * grow * norm_d(m1, d) + U * norm_d(x, d)
    return lti_taylor.tail_bound(theta, K) * norm_d(w1, d) + rounding


def reference_slack(x_ref, d) -> float:
    """The long-double reference's own error and its rounding to double: u ||x_ref||_D + 1e3 eps_ld (terms)."""
    return (U + 1e3 * EPS_LD) * norm_d(np.asarray(x_ref, float), d)


def output_rows_within(poly, exact, terms, d, nu: int) -> bool:
    """The output maps [Cx (ny, nx), Cu (ny, nu), y0 (ny)] flat: per output row, the error they make for a state with
    ||x||_D <= 1 and inputs |u_j| <= 1, sum_j |dCx_ij| d_j + sum_j |dCu_ij| + |dy0_i|, within gamma_64 of the same
    sums of the entries' sizes (|exact| + ``terms``, the monomials' |coefficients| |mono_k|): the entries are sums
    and products a few operations deep of numbers of those sizes, some cancelling (I - S_bar Fm)."""
    nx = d.size
    ny = poly.size // (nx + nu + 1)

    def rows(v):
        v = np.abs(v)
        return ((v[:ny * nx].reshape(ny, nx) @ d) + v[ny * nx:ny * (nx + nu)].reshape(ny, nu).sum(axis=1)
                + v[ny * (nx + nu):])
    return bool(np.all(rows(poly - exact) <= gamma(64) * rows(np.abs(exact) + terms)))


def relative_per_output(a, b) -> np.ndarray:
    """max over the record of |a - b| / max |b|, per output (an output zero all along: against 1)."""
    a, b = np.asarray(a), np.asarray(b)
    scale = np.abs(b).max(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    return np.abs(a - b).max(axis=0) / scale


# ---------------------------------------------------------------------------------------------- one rule
def test_plan_tail_and_balance_are_the_same_in_c_and_numpy():
    import ctypes
    lib = lti.library()
    rng = np.random.default_rng(3)
    thetas = np.concatenate([[0.0, 1e-300, 1e-12, 2.5, 2.5000000001, 5.0, 7.5, 1e3], rng.uniform(0, 12, 300),
                             10.0 ** rng.uniform(-10, 1, 100)])
    s, K = ctypes.c_int(), ctypes.c_int()
    for theta in thetas:
        plan = lti_taylor.taylor_plan(float(theta))
        assert lib.ffx_lti_taylor_plan(float(theta), ctypes.addressof(s), ctypes.addressof(K)) == 1
        assert (s.value, K.value) == plan, theta
        t = theta / plan[0]
        assert t <= lti_taylor.THETA_SUBSTEP
        # the least K: the truncation below u with K terms, not with K - 1
        assert lti_taylor.tail_bound(t, plan[1]) <= U
        assert plan[1] == 1 or lti_taylor.tail_bound(t, plan[1] - 1) > U
        assert lib.ffx_lti_taylor_tail(float(t), plan[1]) == lti_taylor.tail_bound(t, plan[1])
    for bad in (math.nan, math.inf, -1.0):
        assert lti_taylor.taylor_plan(bad) is None
        assert lib.ffx_lti_taylor_plan(bad, ctypes.addressof(s), ctypes.addressof(K)) == 0
    # the tail bound bounds the tail: against the sum itself (exact rationals are not needed: terms fall fast)
    for theta in (0.3, 1.0, 2.06, 2.5):
        for K in (5, 12, 25):
            tail = sum(theta ** (k - 1) / math.factorial(k) for k in range(K + 1, K + 60))
            assert tail <= lti_taylor.tail_bound(theta, K) * (1 + 1e-12)
    # balance: the same operations in the same order in both (identity)
    for n in (1, 4, 12):
        A = rng.standard_normal((n, n)) * 10.0 ** rng.uniform(-3, 4, (n, n))
        A[rng.random((n, n)) < 0.3] = 0.0
        d = np.zeros(n)
        lib.ffx_lti_balance(n, A.ctypes.data, d.ctypes.data)
        assert np.array_equal(d, lti_taylor.balance(A))


# ---------------------------------------------------------------------------------------------- the bound
@pytest.mark.parametrize("h", [1e-4, 1e-3, 4e-3])
def test_one_series_step_is_within_its_bound_of_the_exponential(harvester, harvester_model, h):
    """The harvester's A(p), g under random base motion of sizes 1e-3 .. 10 (rad/s, rad/s^2, m/s^2) and a random
    state of realistic proportions: one sub-step of the series (numpy with numpy's A(p), C with the kernel's) within
    series_bound of the long-double exponential of the same system; the truncation bound <= u ||w_1||_D."""
    held = harvester._moving_model().system
    d = held.weights
    kernel = harvester_model.kernel()
    rng = np.random.default_rng(int(h * 1e5))
    worst, c_checked = 0.0, 0
    for size in (1e-3, 1e-2, 0.1, 1.0, 10.0):
        for _ in range(3):
            p = rng.standard_normal(6) * size
            loads = rng.standard_normal(9) * np.r_[np.ones(3), 0.1 * np.ones(3), size * np.ones(3)]
            x = rng.standard_normal(held.nx) * d * 1e-3          # eta ~ eta_dot / omega
            A = np.asarray(held.step(p)[:held.nx ** 2]).reshape(held.nx, held.nx)
            g = np.zeros(held.nx)
            g[held.m:] = held.force_map @ loads + held.step(p)[held.nx ** 2:]
            theta = h * lti_taylor.scaled_norm(A, d)
            s, K = lti_taylor.taylor_plan(theta)
            hs = h / s                                             # one sub-step
            plan = (1, K)
            assert lti_taylor.taylor_plan(hs * lti_taylor.scaled_norm(A, d)) == plan
            assert lti_taylor.tail_bound(hs * lti_taylor.scaled_norm(A, d), K) <= U
            ref, _ = reference_step(A, g, x, hs)
            got = lti_taylor.taylor_steps(A, g, x, hs, plan)
            bound = series_bound(A, g, x, hs, plan, d) + reference_slack(ref, d)
            err = norm_d(got - ref.astype(float), d)
            assert err <= bound, (size, h, err, bound)
            worst = max(worst, err / bound)
            # the C kernel: its own A(p), g (the extraction's), prepared by the rule's arithmetic, one sub-step
            u = loads
            pk = np.r_[HARVESTER["damping_ratio"], p]
            before = pk.copy()
            before[1:] -= 1e-9                                     # a tiny motion: the series (if not too costly)
            xc = kernel.steps_held(x, u, before, pk, hs, 1) if _prepared(kernel, before, pk, hs, u) else None
            if xc is not None:
                Ac, gc = _held_system(kernel)
                plan_c = (kernel._maps.taylor_substeps, kernel._maps.taylor_terms)
                assert plan_c[0] == 1
                refc, _ = reference_step(Ac, gc, x, hs)
                boundc = series_bound(Ac, gc, x, hs, plan_c, kernel.weights()) + reference_slack(refc, d)
                assert norm_d(xc - refc.astype(float), kernel.weights()) <= boundc
                c_checked += 1
                # the kernel's sub-steps are its single sub-steps in sequence, bit for bit
                if s > 1:
                    one = x
                    for _ in range(s):
                        assert _prepared(kernel, before, pk, hs, u)
                        one = kernel.steps_held(one, u, before, pk, hs, 1)
                    assert _prepared(kernel, before, pk, h, u)
                    assert np.array_equal(kernel.steps_held(x, u, before, pk, h, 1), one)
    assert c_checked == 15                                         # the rule took the series every time
    print(f"\nh = {h:g}: worst error / bound {worst:.2e}")


def _prepared(kernel, p_before, p, h, u) -> bool:
    lib = kernel.lib
    kernel._load(None, u, p)
    kernel._load_before(p_before)
    return lib.ffx_lti_taylor_prepare(kernel._maps_addr, kernel._apb, kernel._ap, h, 1, kernel._au) == 1


def _held_system(kernel):
    nx = kernel.model.nx
    mp = kernel._maps
    A = np.ctypeslib.as_array(mp.A_held, shape=(nx * nx,)).reshape(nx, nx).copy()
    return A, np.ctypeslib.as_array(mp.g_held, shape=(nx,)).copy()


# ---------------------------------------------------------------------------------------------- a record
def _run(sim, motion, series: bool, forces=True):
    from flexfmu.ffr.simulator import INPUT_NAMES
    sim.moving_base_series = series
    states, outputs, took = [], [], []
    u = np.zeros(len(INPUT_NAMES))
    for k, p in enumerate(motion):
        u[:3] = (np.sin(40.0 * k * H), 0.5 * np.cos(25.0 * k * H), 0.2) if forces else 0.0
        u[6:15] = p
        sim.set_input_vector(u)
        sim.step(H)
        took.append(sim._series_last)
        states.append(np.concatenate([sim.state.eta, sim.state.eta_dot]))
        outputs.append(sim.output_vector())
    return np.array(states), np.array(outputs), np.array(took)


def _fresh_harvester():
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    return FFRBeamSimulator(FFRBeamConfig(**HARVESTER))


def test_platform_record_series_within_bound_and_equal_to_maps_and_native(harvester_model):
    """2 s of platform motion at 1 ms through the harvester: (a) the series run within its propagated bound of a
    long-double run of the same held systems, in the weighted 2-norm ||D^-1 v||_2 where the modes' steps are
    rotations (||D^-1 e^{hA} D||_2 = 1 + O(base motion), while the max norm's grows to sqrt(2) a step):
    B_{k+1} = G_k B_k + sqrt(nx) b_k, G_k = ||D^-1 e^{hA_k} D||_2 of the reference, b_k series_bound of step k
    (a max norm: sqrt(nx) bounds the 2-norm by it); (b) every output equal to the maps run's (one exponential per step:
    the old path) and to the C kernel's (LtiSimulator: ffx_lti_steps_held, the native FMU's step) within RTOL;
    (c) all steps but the first by the series in numpy, and the same steps in C."""
    n = 2000
    motion = platform_motion(n, H)
    sim = _fresh_harvester()
    states, outputs, took = _run(sim, motion, series=True)
    assert took[0] == False and took[1:].all()                     # noqa: E712  first step: no step before it
    held = sim._moving_model().system
    d = held.weights
    # (a) the same systems in long double, from the same start; the bound propagated
    x_ref = np.zeros(held.nx)
    x = np.zeros(held.nx)
    B, worst, loads = 0.0, 0.0, np.zeros(9)
    for k in range(n):
        loads[:3] = (np.sin(40.0 * k * H), 0.5 * np.cos(25.0 * k * H), 0.2)
        loads[6:9] = motion[k, :3]
        A = held.step(motion[k, 3:])[:held.nx ** 2].reshape(held.nx, held.nx)
        g = np.zeros(held.nx)
        g[held.m:] = held.force_map @ loads + held.step(motion[k, 3:])[held.nx ** 2:]
        ref, E = reference_step(A, g, x_ref, H)
        if k > 0:                                                  # the first step went by the maps
            plan = lti_taylor.taylor_plan(H * lti_taylor.scaled_norm(A, d))
            assert plan[0] == 1
            G = float(np.linalg.norm(E.astype(float) * d[None, :] / d[:, None], 2)) * (1 + 1e-12)
            B = G * B + math.sqrt(held.nx) * (series_bound(A, g, x, H, plan, d) + reference_slack(ref, d))
            err = float(np.linalg.norm((states[k] - ref.astype(float)) / d))
            assert err <= B, (k, err, B)
            worst = max(worst, err / B)
        else:
            ref = states[0].astype(np.longdouble)                 # start the reference where the maps' step ended
        x_ref, x = ref, states[k]
    size = max(float(np.linalg.norm(s / d)) for s in states)
    print(f"\nseries vs long double: worst error / propagated bound {worst:.2e}; bound at the end {B / size:.2e} of "
          f"max ||D^-1 x||_2, error {err / size:.2e}")
    # (b) the maps run and the C kernel
    maps_states, maps_outputs, maps_took = _run(_fresh_harvester(), motion, series=False)
    assert not maps_took.any()
    from flexfmu.native.lti import LtiSimulator
    native = LtiSimulator(harvester_model)
    c_out = []
    from flexfmu.ffr.simulator import INPUT_NAMES
    u = np.zeros(len(INPUT_NAMES))
    for k, p in enumerate(motion):
        u[:3] = (np.sin(40.0 * k * H), 0.5 * np.cos(25.0 * k * H), 0.2)
        u[6:15] = p
        native.set_input_vector(u)
        native.step(H)
        c_out.append(native.output_vector())
    vs_maps, vs_c = relative_per_output(outputs, maps_outputs), relative_per_output(c_out, outputs)
    print(f"per output, max relative difference: series vs maps {vs_maps.max():.2e}, C vs numpy {vs_c.max():.2e}; "
          f"C steps by the series {native.kernel.series_steps} of {n}, maps {native.kernel.counters[0]}")
    assert vs_maps.max() <= RTOL and vs_c.max() <= RTOL
    # (c) C takes the series where numpy does (its first step follows the inputs at construction, zero: the
    # platform's first motion is a change as small as a step's, so C may take it by the series too)
    assert native.kernel.series_steps in (n - 1, n)


def test_polynomials_equal_the_library_maps(harvester):
    """A(p), g and the output maps of FFRBeam's polynomials against the library's system_matrix, modal_force and
    fast_maps at random base motion: within gamma_64 of the terms (the fit differences values of the model without
    its modal stiffness: rounding of O(1) numbers, a few products deep), in the balanced norm for A."""
    from flexfmu.ffr.dynamics import BaseMotion
    mb = harvester._moving_model()
    dyn = harvester.dynamics
    d = mb.system.weights
    rng = np.random.default_rng(11)
    for size in (0.01, 0.3, 3.0):
        p = rng.standard_normal(6) * size
        base = mb.base(p)
        A_lib = dyn.system_matrix(base)
        A_poly = mb.system.step(p)[:mb.system.nx ** 2].reshape(A_lib.shape)
        mono = np.abs(mb.system.step.monomials(p))
        terms = sum(mono[j] * np.abs(mb.system.step.coefficient(j)[:A_lib.size].reshape(A_lib.shape))
                    for j in range(mono.size))
        scaled = lambda M: (M * d[None, :]) / d[:, None]          # noqa: E731
        assert np.all(np.abs(scaled(A_poly - A_lib)) <= gamma(64) * (scaled(terms) + np.abs(scaled(A_lib))))
        f_lib = dyn.modal_force(np.zeros(3), np.zeros(3), BaseMotion(np.zeros(3), base.omega, base.alpha))
        f_poly = mb.system.step(p)[A_lib.size:]
        assert np.all(np.abs(f_poly - f_lib) <= gamma(64) * (np.abs(f_lib) + mono.sum() * np.abs(f_lib).max()))
        values = harvester._output_values(dyn, base)
        poly = mb.outputs(p)
        o_terms = sum(mono_j * np.abs(mb.outputs.coefficient(j)).ravel()
                      for j, mono_j in enumerate(np.abs(mb.outputs.monomials(p))))
        assert output_rows_within(poly, values, o_terms, d, 9)


def test_jumps_go_by_the_maps_motion_by_the_series_in_numpy_and_c(harvester_model):
    """Inputs constant by segments (jumps of 0.3 rad/s, 2 rad/s^2) at 1 ms: the maps, one exponential per segment,
    in numpy and C; smooth motion: the series; a fixed base: the maps once."""
    from flexfmu.ffr.simulator import INPUT_NAMES
    from flexfmu.native.lti import LtiSimulator
    sim = _fresh_harvester()
    native = LtiSimulator(harvester_model)
    u = np.zeros(len(INPUT_NAMES))
    took = []
    segments = [(0.3, 0.0), (0.0, 2.0), (-0.3, 2.0), (0.6, -1.0)]
    for w, dw in segments:
        u[10], u[14] = w, dw
        for _ in range(5):
            sim.set_input_vector(u)
            native.set_input_vector(u)
            sim.step(H)
            native.step(H)
            took.append(sim._series_last)
    assert not any(took) and native.kernel.series_steps == 0
    assert native.kernel.counters[0] == len(segments)
    smooth = platform_motion(50, H)
    for p in smooth:
        u[6:15] = p
        sim.set_input_vector(u)
        native.set_input_vector(u)
        sim.step(H)
        native.step(H)
        took.append(sim._series_last)
    # the first smooth step jumps from the last segment: the maps; then the series
    assert took[-50] == False and all(took[-49:])                 # noqa: E712
    assert native.kernel.series_steps == 49


def test_ffrbeam_state_round_trip_continues_bit_for_bit_under_moving_base():
    """get_state mid-record (moving base), 50 steps, set_state, the same 50 steps: the same bits (the state holds
    the base motion the next step compares with, and how the last step went)."""
    from flexfmu.ffr.simulator import INPUT_NAMES
    motion = platform_motion(150, H, seed=8)
    sim = _fresh_harvester()
    u = np.zeros(len(INPUT_NAMES))

    def steps(rows):
        out = []
        for p in rows:
            u[6:15] = p
            sim.set_input_vector(u)
            sim.step(H)
            out.append(sim.output_vector())
        return np.array(out)

    steps(motion[:100])
    state = sim.get_state()
    assert state["series_last"] is True and state["held_before"] == motion[99, 3:9].tolist()
    first = steps(motion[100:])
    sim.set_state(state)
    assert np.array_equal(steps(motion[100:]), first)


# ---------------------------------------------------------------------------------------------- a clamped body
def test_clamped_body_series_equals_maps_and_native():
    """An exported clamped body (a rod, two interfaces, 6 modes) under 1.5 s of platform rotation at 1 ms: the
    series run equal to the maps run and to the C kernel (LtiModel.from_clamped_body, LtiSimulator) within RTOL;
    the held maps' polynomial equal to held_maps at a random rotation; a state round trip bit for bit."""
    from flexfmu.body.build import build_body
    from flexfmu.body.simulator import FlexBodyConfig, FlexBodySimulator
    from flexfmu.ffr.assembly import build_beam_model
    s = build_beam_model(straight_rod(0.5, 0.01, direction=(1.0, 0.3, -0.2)), "free", 8).structure()
    s = dataclasses.replace(s, node_sets={"root": np.array([0])})
    body = build_body(s, interfaces=[{"name": "tip", "point": s.nodes[-1].tolist()},
                                     {"name": "mid", "point": s.nodes[4].tolist(), "moments": False}],
                      clamp="root", n_modes=6)
    n = 1500
    motion = platform_motion(n, H, seed=2)
    runs = {}
    for series in (True, False):
        sim = FlexBodySimulator(body, FlexBodyConfig(damping_ratio=0.02))
        sim.engine.moving_base_series = series
        rows, took = [], []
        for k in range(n):
            u = np.zeros(len(sim.input_names))
            u[0], u[7] = np.sin(30 * k * H), 0.3
            u[-9:] = motion[k]
            sim.set_input_vector(u.tolist())
            sim.step(H)
            rows.append(sim.output_vector())
            took.append(sim.engine._series_last)
            if series and k == 1000:
                state = sim.get_state()
        runs[series] = (np.array(rows), np.array(took), sim)
    assert runs[True][1][1:].all() and not runs[False][1].any()
    model = lti.LtiModel.from_clamped_body(runs[False][2])
    native = lti.LtiSimulator(model)
    c_out = []
    for k in range(n):
        u = np.zeros(len(native.model.input_names))
        u[0], u[7] = np.sin(30 * k * H), 0.3
        u[-9:] = motion[k]
        native.set_input_vector(u)
        native.step(H)
        c_out.append(native.output_vector())
    vs_maps = relative_per_output(runs[True][0], runs[False][0])
    vs_c = relative_per_output(c_out, runs[True][0])
    print(f"\nclamped body: series vs maps {vs_maps.max():.2e}, C vs numpy {vs_c.max():.2e}; C series steps "
          f"{native.kernel.series_steps} of {n}")
    assert vs_maps.max() <= RTOL and vs_c.max() <= RTOL
    assert native.kernel.series_steps >= n - 1
    # the polynomial of the held maps
    engine = runs[True][2].engine
    mb = engine._moving_model()
    p = np.random.default_rng(4).standard_normal(6)
    exact = engine._output_values(engine.dyn, p[:3], p[3:])
    poly = mb.outputs(p)
    terms = sum(m_j * np.abs(mb.outputs.coefficient(j)).ravel()
                for j, m_j in enumerate(np.abs(mb.outputs.monomials(p))))
    assert output_rows_within(poly, exact, terms, mb.system.weights, engine.n_loads)
    # a restored state continues bit for bit
    sim = runs[True][2]
    sim.set_state(state)
    again = []
    for k in range(1001, n):
        u = np.zeros(len(sim.input_names))
        u[0], u[7] = np.sin(30 * k * H), 0.3
        u[-9:] = motion[k]
        sim.set_input_vector(u.tolist())
        sim.step(H)
        again.append(sim.output_vector())
    assert np.array_equal(np.array(again), runs[True][0][1001:])
