"""The C kernel of a clamped flexible body on a moving base (flexfmu.native: csrc/lti_kernels.c through lti.py)
against the library's Python simulators, whose maps its coefficients are taken from: FFRBeam (the paper's hammer
record, random held base motion with and without geometric stiffening and static correction, the damping ratio
changed at run time) and exported clamped bodies (flexfmu.body).  The C matrix exponential against scipy.linalg.expm
and an extended-precision Taylor series."""
import ctypes
import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg as sla

from conftest import straight_rod
from error_bounds import U, expm_error_bound, gamma
from flexfmu.errors import NonFiniteError, ParameterError
from flexfmu.native import lti
from flexfmu.native.lti_kernel import _Maps, _ip, _ptr
from flexfmu.native.compiler import CompilerError

try:
    lti.library()
except CompilerError as exc:                     # pragma: no cover - no C compiler on this machine
    pytest.skip(f"no C compiler: {exc}", allow_module_level=True)

RTOL = 1e-10                                      # C kernel against the Python simulators, per output
#: the paper's hammer set-ups (examples/hammer_test.py): boundary -> (load_s, sensor_s)
HAMMER = {"XFF": (0.45, 0.04), "FXF": (0.45, 0.30), "XFX": (0.30, 0.04)}


def _relative_errors(mine, ref, groups=None):
    """Per output: max over the record of |mine - ref| / max |ref|; an output that is zero all along is measured
    against its vector's (``groups``: output -> group index) largest value."""
    mine, ref = np.asarray(mine), np.asarray(ref)
    scale = np.abs(ref).max(axis=0)
    if groups is not None:
        for g in set(groups):
            members = [k for k, gk in enumerate(groups) if gk == g]
            scale[members] = np.where(scale[members] > 0, scale[members], scale[members].max())
    scale = np.where(scale > 0, scale, 1.0)
    return np.abs(mine - ref).max(axis=0) / scale


def _ffr_groups():
    from flexfmu.ffr.simulator import OUTPUT_NAMES
    return [k // 3 if k < 18 else 100 + k for k in range(len(OUTPUT_NAMES))]


# ---------------------------------------------------------------------------------------------- expm
def _expm_reference(M):
    """exp(M) by a degree-40 Taylor series of M / 2^s (|M / 2^s|_1 <= 1/4) squared s times, in long double."""
    A = M.astype(np.longdouble)
    norm = float(np.abs(M).sum(axis=0).max())
    s = max(0, int(np.ceil(np.log2(norm / 0.25)))) if norm > 0 else 0
    A = A / np.longdouble(2.0) ** s
    E = T = np.eye(M.shape[0], dtype=np.longdouble)
    for k in range(1, 41):
        T = T @ A / k
        E = E + T
    for _ in range(s):
        E = E @ E
    return E.astype(float)


def _rel(a, b):
    return float(np.abs(a - b).max() / np.abs(b).max())


def _expm_bound(M):
    """What may separate lti.expm(M) from _expm_reference(M), entrywise: the a-priori bound of a double Pade-13
    scaling and squaring (error_bounds.expm_error_bound), the long-double reference's own bound
    (error_bounds.taylor_reference_error_bound with u = 2^-64: ~2^-11 of the first), and the reference's rounding
    to double (u |X|, here u max |X|)."""
    from error_bounds import U, expm_error_bound, taylor_reference_error_bound
    u_ref = float(np.finfo(np.longdouble).eps) / 2
    return expm_error_bound(M) + taylor_reference_error_bound(M, u_ref), U


def _within_bound(E, X, M):
    absolute, u = _expm_bound(M)
    err = float(np.abs(E - X).max())
    return err <= absolute + u * float(np.abs(X).max()), err / (absolute + u * float(np.abs(X).max()))


def test_expm_is_within_its_error_bound_of_an_extended_precision_reference(rng):
    """Random dense, skew-symmetric (oscillatory) and damped-oscillatory matrices, 1-norms from 1e-3 to ~1e3, and
    the kernels' augmented sizes 8, 22, 40: lti.expm within the a-priori error bound of its algorithm
    (_expm_bound) of the long-double reference.  (Formerly 1e-13 relative to the largest entry, and C against
    scipy.linalg.expm to 1e-13: read off one machine; scipy's own error depends on the BLAS.)  scipy's distance
    to the reference, in units of the same bound, is printed for comparison."""
    assert np.finfo(np.longdouble).eps < 1e-18, "the reference needs an extended long double"
    worst = {"C vs reference / bound": 0.0, "scipy vs reference / bound": 0.0, "C vs reference, relative": 0.0}
    matrices = []
    for kind in ("dense", "skew", "damped"):
        for n in (2, 3, 8, 22, 40):
            for scale in (1e-3, 0.3, 1.0, 30.0, 1e2, 1e3):
                if kind == "dense" and scale > 30:       # e^{|lambda|}: ill-conditioned, entries beyond 1e40
                    continue
                G = rng.standard_normal((n, n)) / np.sqrt(n)
                matrices.append((kind, n, scale, {"dense": G * scale, "skew": 0.5 * (G - G.T) * scale,
                                 "damped": 0.5 * (G - G.T) * scale - 0.05 * scale * np.eye(n) + 0.01 * scale * G}[kind]))
    for n in (8, 22, 40):                                # the kernels' augmented sizes, norms up to 30
        for scale in (1e-3, 1.0, 30.0):
            matrices.append(("augmented size", n, scale, rng.standard_normal((n, n)) / np.sqrt(n) * scale))
    for kind, n, scale, M in matrices:
        E, S, X = lti.expm(M), sla.expm(M), _expm_reference(M)
        ok, ratio = _within_bound(E, X, M)
        assert ok, (kind, n, scale, ratio)
        worst["C vs reference / bound"] = max(worst["C vs reference / bound"], ratio)
        worst["scipy vs reference / bound"] = max(worst["scipy vs reference / bound"], _within_bound(S, X, M)[1])
        worst["C vs reference, relative"] = max(worst["C vs reference, relative"], _rel(E, X))
    print(f"\nexpm, worst: {worst}")


def test_expm_of_zero_and_of_zero_rows_is_exact():
    assert np.array_equal(lti.expm(np.zeros((4, 4))), np.eye(4))
    M = np.zeros((5, 5))
    M[:3] = np.random.default_rng(1).standard_normal((3, 5)) * 50     # many squarings
    E = lti.expm(M)
    assert np.array_equal(E[3:], np.eye(5)[3:])       # the augmented matrix's last rows: exactly those of I
    ok, ratio = _within_bound(E, _expm_reference(M), M)
    assert ok, ratio


def test_expm_reports_non_finite():
    with pytest.raises(NonFiniteError):
        lti.expm(np.array([[np.nan, 0.0], [0.0, 1.0]]))
    with pytest.raises(NonFiniteError):
        lti.expm(np.array([[1e3, 1.0], [0.0, 1.0]]))      # e^1000 overflows


def test_monomials_in_the_header_order():
    lib = lti.library()
    p = np.array([2.0, -3.0, 5.0])
    out = np.zeros(lti.n_monomials(3))
    lib.ffx_lti_monomials(3, _ptr(p), _ptr(out))
    assert out.tolist() == [1, 2, -3, 5, 4, -6, 10, 9, -15, 25] == lti.monomials(p).tolist()
    assert lti.monomial_names(("a", "b")) == ("1", "a", "b", "a*a", "a*b", "b*b")


# ---------------------------------------------------------------------------------------------- FFRBeam
def _ffrbeam(**config):
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    return FFRBeamSimulator(FFRBeamConfig(**config))


@pytest.mark.parametrize("boundary", sorted(HAMMER))
def test_ffrbeam_hammer_record_matches_the_simulator(boundary):
    """The paper's virtual experiment (examples/hammer_test.py): a 1 ms half-sine hammer blow at load_s, 10 kS/s,
    2 s; all 25 outputs of the C kernel against FFRBeamSimulator, step by step."""
    from flexfmu.ffr.simulator import INPUT_NAMES, OUTPUT_NAMES
    load_s, sensor_s = HAMMER[boundary]
    sim = _ffrbeam(boundary=boundary, damping_ratio=0.002, load_s=load_s, sensor_s=sensor_s)
    model = lti.LtiModel.from_ffrbeam(sim)
    kernel = model.kernel()
    dt, n = 1e-4, 20000
    x = np.zeros(model.nx)
    mine, ref = [], []
    v = np.zeros(len(INPUT_NAMES))
    for k in range(n):
        t = k * dt
        f = 20.0 * np.sin(np.pi * t / 1e-3) if t < 1e-3 else 0.0
        v[:3] = (f, 0.7 * f, 0.4 * f)
        sim.set_input_vector(v)
        u, p = model.split_inputs(v)
        sim.step(dt)
        x = kernel.step(x, u, p, dt)
        mine.append(kernel.outputs(x, u, p))
        ref.append(sim.output_vector())
    err = _relative_errors(mine, ref, _ffr_groups())
    worst = int(np.argmax(err))
    print(f"\n{boundary}: {n} steps, worst relative difference {err[worst]:.2e} ({OUTPUT_NAMES[worst]}); "
          f"maps recomputed {kernel.counters}; extraction {model.fit_error}")
    assert err.max() <= RTOL
    assert kernel.counters == (1, 1)                  # one p and one h all along: the maps once
    assert np.max(np.abs(np.array(ref)[:, 6:9])) > 1.0           # the accelerometer saw the blow


def _random_run(sim, model, rng, n_segments=24, damping=(0.0, 0.3)):
    """Held inputs (loads, base_a, base_w, base_dw) drawn per segment of 5..40 steps of 2e-4..5e-3 s; the damping
    ratio changed twice at run time (Python: with_damping / a new instance, C: the parameter p[0]).  Returns the
    C and Python outputs after every step."""
    from flexfmu.native.lti import LtiSimulator
    native = LtiSimulator(model)
    names = model.input_names
    mine, ref = [], []
    for seg in range(n_segments):
        v = np.zeros(len(names))
        for k, name in enumerate(names):
            v[k] = rng.standard_normal() * (3.0 if name.startswith("base_w") else 10.0 if name.startswith("base_")
                                            else 1.0)
        if seg == n_segments // 3:
            sim = _redamped(sim, damping[0])
            native.set_parameter("damping_ratio", damping[0])
        if seg == 2 * n_segments // 3:
            sim = _redamped(sim, damping[1])
            native.set_parameter("damping_ratio", damping[1])
        sim.set_input_vector(v)
        native.set_input_vector(v)
        h = float(rng.choice([2e-4, 1e-3, 5e-3]))
        for _ in range(int(rng.integers(5, 40))):
            sim.step(h)
            native.step(h)
            mine.append(native.output_vector())
            ref.append(sim.output_vector())
    return np.array(mine), np.array(ref), native


def _redamped(sim, zeta):
    if hasattr(sim, "with_damping"):                  # FFRBeam
        return sim.with_damping(zeta)
    from flexfmu.body.simulator import FlexBodySimulator
    other = FlexBodySimulator(sim.body, dataclasses.replace(sim.config, damping_ratio=zeta))
    state = sim.get_state()
    state["config"] = dataclasses.asdict(other.config)
    other.set_state(state)
    return other


@pytest.mark.parametrize("stiffening", [False, True], ids=["plain", "geometric_stiffening"])
@pytest.mark.parametrize("correction", ["off", "on"])
def test_ffrbeam_random_held_base_motion_matches_the_simulator(stiffening, correction, rng):
    """Random held loads and base motion (w up to ~10 rad/s, alpha and a0 up to ~30), steps of 0.2 .. 5 ms, the
    damping ratio changed at run time: all 25 outputs within 1e-10; with the static correction (n_modes = -1) the
    energy's degree-4 term in the base rotation travels as monomial products."""
    from flexfmu.ffr.simulator import OUTPUT_NAMES
    config = {"geometric_stiffening": stiffening}
    config.update({"n_modes": -1} if correction == "on" else {"n_modes": 6, "static_correction": 0})
    sim = _ffrbeam(**config)
    assert (sim.static_correction is not None) == (correction == "on")
    model = lti.LtiModel.from_ffrbeam(sim)
    assert model.np == (10 if stiffening else 7)
    # the extraction's own acceptance (lti.FIT_TOLERANCE, the library's contract); what the model gives is checked
    # end to end below
    assert all(v <= lti.FIT_TOLERANCE for v in model.fit_error.values()), model.fit_error
    mine, ref, native = _random_run(sim, model, rng)
    err = _relative_errors(mine, ref, _ffr_groups())
    worst = int(np.argmax(err))
    print(f"\nFFRBeam {config}: nx {model.nx}, np {model.np}, {model.nquad} quadratic terms; {len(ref)} steps, "
          f"worst {err[worst]:.2e} ({OUTPUT_NAMES[worst]}); extraction {model.fit_error}; "
          f"maps {native.kernel.counters}")
    assert err.max() <= RTOL
    energy = OUTPUT_NAMES.index("elastic_energy")
    assert np.all(ref[:, energy] > 0)


def _ffr_growth(W: np.ndarray, d, m: int) -> float:
    """A bound on sup_{0 <= t <= 1} ||D^-1 e^{tW} D||_2 for an augmented W = h [[A, B], [0, 0]], A = [[0, I], [-K, -C]]
    (m modes), D = diag(d): in the energy norm ||x||_P^2 = |eta_dot|^2 + eta^T K_s eta of the scaled state (K_s the
    symmetric part of K, positive definite), ||e^{t h A'}||_P <= e^{t mu_P} with mu_P the logarithmic 2-norm of
    L^T h A' L^-T (P = L L^T; computed here, raised by n u its Frobenius norm for that computation's rounding), so
    ||e^{t h A'}||_2 <= kappa(L) e^{max(mu_P, 0)} =: G_A; e^{tW'} = [[e^{t h A'}, int_0^t e^{s h A'} ds h B'], [0, I]]
    = [[e^{t h A'}, 0], [0, I]] + [[0, ..], [0, 0]]: <= max(G_A, 1) + G_A ||h B'||_2."""
    d = np.asarray(d, float)
    Wp = W / d[:, None] * d[None, :]
    nx = 2 * m
    h = W[0, m]                                                  # the h I block
    K = -W[m:nx, :m] / h
    Ks = 0.5 * (K + K.T) * d[:m, None] * d[None, :m]
    L = np.linalg.cholesky(np.block([[Ks, np.zeros((m, m))], [np.zeros((m, m)), np.eye(m)]]))
    AP = np.linalg.solve(L, (L.T @ Wp[:nx, :nx]).T).T            # L^T A' L^-T
    mu = float(np.linalg.eigvalsh(0.5 * (AP + AP.T)).max()) + nx * U * float(np.linalg.norm(AP))
    G_A = float(np.linalg.cond(L)) * (1 + 1e-6) * math.exp(max(mu, 0.0))
    return max(G_A, 1.0) + G_A * (1 + 1e-6) * float(np.linalg.norm(Wp[:nx, nx:], 2))


def _pow2(x):
    return 2.0 ** np.round(np.log2(x))


def test_ffrbeam_step_maps_equal_the_python_exponential():
    """Ad, Bd, bd of the kernel and FFRBeamDynamics.fast_maps (scipy's expm of the same system) for steps from 0.1 ms
    to 1 s and a spinning, accelerating base, each against the exact exponential of its own augmented matrix (mpmath,
    40 digits) within the a-priori bound of its algorithm.  The matrices are far from balanced (omega^2 h against h),
    so the bound is taken in the balanced coordinates (omega_j eta_j, eta_dot) by powers of two, in which the rounding
    of either algorithm is the same (error_bounds.expm_error_bound_scaled); scipy's Pade degree and squarings are
    its own pick_pade_structure's, the kernel's replicated (error_bounds.ffx_squarings).  The kernel's matrix is the
    extraction's polynomial at p, the library's its own: they differ by the fit (printed)."""
    import mpmath
    from scipy.linalg._matfuncs_expm import pick_pade_structure
    from error_bounds import expm_error_bound_scaled, ffx_squarings, lu_growth_scaled
    from flexfmu.ffr.dynamics import BaseMotion, _skew
    sim = _ffrbeam(geometric_stiffening=True)
    model = lti.LtiModel.from_ffrbeam(sim)
    kernel = model.kernel()
    dyn = sim.dynamics
    m, nx, nu = dyn.m, model.nx, model.nu
    base = BaseMotion(a0=np.array([1.0, -4.0, 9.81]), omega=np.array([2.0, -1.0, 5.0]),
                      alpha=np.array([10.0, 3.0, -7.0]))
    p = np.r_[dyn.damping_ratio, base.omega, base.alpha, base.a0]
    K_eff, C_eff = dyn._matrices(base)
    mono = lti.monomials(p)
    with mpmath.workdps(40):
        mono_mp = [mpmath.mpf(1)] + [mpmath.mpf(float(v)) for v in p]
        mono_mp += [mono_mp[1 + i] * mono_mp[1 + j] for i in range(len(p)) for j in range(i, len(p))]
        coef = np.concatenate([model.A, model.B, model.b[:, :, None]], axis=2)         # (nmono, nx, nx + nu + 1)
        fit = [[mpmath.fsum(mono_mp[k] * mpmath.mpf(float(coef[k, i, j])) for k in range(model.nmono))
                for j in range(coef.shape[2])] for i in range(nx)]
    d_eta = 1.0 / _pow2(np.sqrt(np.diag(K_eff)))
    worst = {"kernel": 0.0, "scipy": 0.0}
    for h in (1e-4, 1e-3, 1e-2, 0.1, 1.0):
        Ad, Bu, b0, _, _ = dyn.fast_maps(h, base)
        _, Bd = dyn._transition(h, base)                          # the cached pair fast_maps used
        mAd, mBd, mbd = kernel.step_maps(p, h)

        # the kernel's W_C = fl(h fl(sum_k mono_k coef_k)) (here the same sum, to rounding: for its size, the squarings
        # and the pivots) against W = h sum_k mono_k coef_k exactly: the monomial, the product and nmono - 1
        # additions, then h: <= gamma_{nmono + 3} h sum |mono_k| |coef_k| + u |W_C|
        n = nx + nu + 1
        W_C = np.zeros((n, n))
        W_C[:nx] = np.tensordot(mono, coef, axes=1) * h
        dW = gamma(model.nmono + 3) * h * np.tensordot(np.abs(mono), np.abs(coef), axes=1) + U * np.abs(W_C[:nx])
        # the input columns scaled to ||h B'||_2 ~ 1/4 (the growth bound) by one power of two
        d_in = np.full(nu + 1, 0.25 / _pow2(float(np.linalg.norm(W_C[:nx, nx:], 2))))
        d = np.r_[d_eta, np.ones(m), d_in]
        G = _ffr_growth(W_C, d, m)
        choices = [(13, s) for s in ffx_squarings(W_C)]
        lu = max(lu_growth_scaled(W_C, d, 13, s) for _, s in choices)
        bound_C = expm_error_bound_scaled(W_C, d, G, choices, lu)
        # the exact exponential of the exact W (balanced: D^-1 W D, exact by powers of two) and W_C's distance from it:
        # ||D^-1 (e^{W_C} - e^W) D||_2 <= G^2 ||D^-1 (W_C - W) D||_F
        pert = G ** 2 * float(np.linalg.norm(dW / d[:nx, None] * d[None, :]))
        with mpmath.workdps(40):
            Wb = mpmath.zeros(n, n)
            for i in range(nx):
                for j in range(n):
                    Wb[i, j] = fit[i][j] * h * d[j] / d[i]
            ref = np.array(mpmath.expm(Wb).tolist(), dtype=float)[:nx]
        got = np.hstack([mAd, mBd, mbd[:, None]]) / d[:nx, None] * d[None, :]
        err = np.abs(got - ref)
        lim = bound_C + pert + U * np.abs(ref)
        assert np.isfinite(bound_C) and np.all(err <= lim), (h, float(np.max(err / lim)))
        ratio_C = float(np.max(err / lim))
        worst["kernel"] = max(worst["kernel"], ratio_C)

        # scipy on W_py = fl(A_aug h) (the same elementwise product as FFRBeamDynamics._transition: the same bits)
        n = 3 * m + 1
        A = np.zeros((n, n))
        A[:m, m:2 * m] = np.eye(m)
        A[m:2 * m, :m] = -K_eff
        A[m:2 * m, m:2 * m] = -C_eff
        A[m:2 * m, 2 * m + 1:] = np.eye(m)
        W_py = A * h
        d = np.r_[d_eta, np.ones(m), 1.0, np.full(m, 0.25 / _pow2(h))]
        G = _ffr_growth(W_py, d, m)
        work = np.empty((5, n, n))
        work[0] = W_py
        choice = pick_pade_structure(work)                       # scipy's own choice for W_py
        bound_py = expm_error_bound_scaled(W_py, d, G, [choice], lu_growth_scaled(W_py, d, *choice))
        with mpmath.workdps(40):
            Wb = mpmath.matrix([[mpmath.mpf(float(W_py[i, j] / d[i] * d[j])) for j in range(n)] for i in range(n)])
            ref = np.array(mpmath.expm(Wb).tolist(), dtype=float)[:2 * m]
        got = np.hstack([Ad, np.zeros((2 * m, 1)), Bd]) / d[:2 * m, None] * d[None, :]
        err = np.abs(got - ref)
        lim = bound_py + U * np.abs(ref)
        assert np.isfinite(bound_py) and np.all(err <= lim), (h, float(np.max(err / lim)))
        ratio_py = float(np.max(err / lim))
        worst["scipy"] = max(worst["scipy"], ratio_py)
        # Bu = fl(Bd Fm), b0 = -fl(Bd p_X): Bd within dBd = bound_py d_i / d_j + u |ref| of the exact one (entrywise
        # from the balanced 2-norm), the products gamma_m |Bd| |rhs|; against the reference's block Bd_ref times rhs
        # in mpmath (Bd_ref within u of exact: u |Bd_ref| |rhs|; the product rounded to double: u)
        Fm = np.hstack([dyn.load_force_map, dyn.load_moment_map, -dyn.F_a0])
        pv = np.einsum("ab,abk->k", _skew(base.alpha) + _skew(base.omega) @ _skew(base.omega), dyn.P_hat)
        scale = d[:2 * m, None] / d[None, 2 * m + 1:]
        Bd_ref = ref[:, 2 * m + 1:] * scale
        dBd = (bound_py + U * np.abs(ref[:, 2 * m + 1:])) * scale
        for got, rhs in ((Bu, Fm), (-b0[:, None], pv[:, None])):
            with mpmath.workdps(40):
                exact = np.array((mpmath.matrix(Bd_ref.tolist()) * mpmath.matrix(rhs.tolist())).tolist(), dtype=float)
            lim = (gamma(m) * np.abs(Bd) + dBd + U * np.abs(Bd_ref)) @ np.abs(rhs) + U * np.abs(exact)
            assert np.all(np.abs(got - exact) <= lim), h
        print(f"h = {h:g} s: kernel vs python Ad {_rel(mAd, Ad):.1e}, Bd {_rel(mBd, Bu):.1e}, bd {_rel(mbd, b0):.1e}; "
              f"bounds (balanced) kernel {bound_C:.1e} + fit rounding {pert:.1e}, scipy {bound_py:.1e}; error / bound "
              f"kernel {ratio_C:.1e}, scipy {ratio_py:.1e}")
    print(f"worst error / bound: {worst}")


def test_ffrbeam_rk4_is_refused():
    with pytest.raises(ParameterError) as err:
        lti.LtiModel.from_ffrbeam(_ffrbeam(integrator="rk4"))
    assert err.value.parameter == "integrator"


# ---------------------------------------------------------------------------------------------- clamped bodies
def _clamped_rod():
    from flexfmu.body.build import build_body
    from flexfmu.ffr.assembly import build_beam_model
    s = build_beam_model(straight_rod(0.8, 0.01), "free", 8).structure()
    s = dataclasses.replace(s, node_sets={"root": np.array([0])})
    return build_body(s, interfaces=[{"name": "tip", "point": [0.8, 0, 0]}, {"name": "mid", "point": [0.4, 0, 0]}],
                      clamp="root", n_modes=5, damping_ratio=0.03)


def _clamped_plate():
    """A small solid (the reframe paper's plate, coarse tetra10 mesh) clamped along its x = min edge."""
    from flexfmu.body.build import build_body
    from flexfmu.reframe.models import load_model
    s = load_model("paper_plate", divisions=(6, 2, 1))
    x = s.nodes[:, 0]
    s = dataclasses.replace(s, node_sets={"root": np.flatnonzero(np.isclose(x, x.min()))})
    return build_body(s, interfaces=[{"name": "A", "point": [float(x.max()), 0.0, 0.0]}], clamp="root", n_modes=6)


@pytest.mark.parametrize("make", [_clamped_rod, _clamped_plate], ids=["beam_rod", "solid_plate"])
def test_clamped_body_matches_its_simulator(make, rng):
    """An exported clamped body (flexfmu.body, as `flexfmu export --clamp` builds it): random held interface loads
    and base motion, the damping ratio changed at run time; every output within 1e-10."""
    from flexfmu.body.simulator import FlexBodySimulator
    body = make()
    sim = FlexBodySimulator(body)
    model = lti.LtiModel.from_clamped_body(sim)
    assert model.param_names[0] == "damping_ratio" and model.p_start[0] == pytest.approx(body.damping_ratio)
    # the extraction's own acceptance (lti.FIT_TOLERANCE, the library's contract); what the model gives is checked
    # end to end below
    assert all(v <= lti.FIT_TOLERANCE for v in model.fit_error.values()), model.fit_error
    mine, ref, native = _random_run(sim, model, rng, damping=(0.1, 0.0))
    groups = [k // 3 for k in range(model.ny)]
    err = _relative_errors(mine, ref, groups)
    worst = int(np.argmax(err))
    print(f"\n{make.__name__}: nx {model.nx}, nu {model.nu}, ny {model.ny}, {model.nquad} quadratic terms; "
          f"{len(ref)} steps, worst {err[worst]:.2e} ({model.output_names[worst]}); extraction {model.fit_error}")
    assert err.max() <= RTOL


def test_free_body_is_refused():
    from flexfmu.body.build import build_body
    from flexfmu.body.simulator import FlexBodySimulator
    from flexfmu.ffr.assembly import build_beam_model
    s = build_beam_model(straight_rod(0.5, 0.01), "free", 4).structure()
    body = build_body(s, interfaces=[{"name": "tip", "point": [0.5, 0, 0]}], n_modes=2)
    with pytest.raises(ParameterError) as err:
        lti.LtiModel.from_clamped_body(FlexBodySimulator(body))
    assert err.value.parameter == "body"


# ---------------------------------------------------------------------------------------------- the kernel's contract
@pytest.fixture(scope="module")
def ffr_model():
    return lti.LtiModel.from_ffrbeam(_ffrbeam())


def test_maps_are_recomputed_only_when_p_or_h_change(ffr_model):
    kernel = ffr_model.kernel()
    x, u = np.zeros(ffr_model.nx), np.ones(ffr_model.nu)
    p = ffr_model.p_start.copy()
    for _ in range(5):
        x = kernel.step(x, u, p, 1e-3)
        kernel.outputs(x, u * 2, p)                  # inputs u change nothing
    assert kernel.counters == (1, 1)
    x = kernel.step(x, u, p, 2e-3)                     # h: the step maps only
    assert kernel.counters == (2, 1)
    p[2] = 0.5
    x = kernel.step(x, u, p, 2e-3)
    kernel.outputs(x, u, p)
    assert kernel.counters == (3, 2)
    kernel.invalidate()
    kernel.step(x, u, p, 2e-3)
    assert kernel.counters == (4, 2)


def test_steps_equal_repeated_steps(ffr_model):
    kernel = ffr_model.kernel()
    rng = np.random.default_rng(5)
    x0, u = rng.standard_normal(ffr_model.nx) * 1e-4, rng.standard_normal(ffr_model.nu)
    p = np.r_[0.02, rng.standard_normal(6)]
    x = x0
    for _ in range(7):
        x = kernel.step(x, u, p, 1e-3)
    assert np.array_equal(kernel.steps(x0, u, p, 1e-3, 7), x)
    assert np.array_equal(kernel.steps(x0, u, p, 1e-3, 0), x0)


def test_output_rows_alone_equal_the_whole_outputs_bit_for_bit(ffr_model):
    """ffx_lti_output_rows (what a native FMU computes for the outputs a host reads) gives each row asked for with
    the arithmetic of ffx_lti_outputs, in the same order: equal bit for bit, with the quadratic terms visited per
    row (quad_start) or by the general loop; rows not asked for are not written."""
    lib = lti.library()
    kernel = ffr_model.kernel()
    rng = np.random.default_rng(11)
    x, u = rng.standard_normal(ffr_model.nx) * 1e-3, rng.standard_normal(ffr_model.nu)
    p = np.r_[0.02, rng.standard_normal(ffr_model.np - 1)]
    whole = kernel.outputs(x, u, p)
    starts = np.zeros(ffr_model.ny + 1, dtype=np.int32)
    assert ffr_model.nquad > 0
    assert lib.ffx_lti_quad_starts(ctypes.addressof(kernel._model), _ptr(starts, _ip)) == 1
    assert np.array_equal(np.diff(starts), np.bincount(ffr_model.quad_row, minlength=ffr_model.ny))
    subsets = [[], [0], [ffr_model.ny - 1], sorted(set(ffr_model.quad_row.tolist())),
               rng.permutation(ffr_model.ny)[:5].tolist(), list(range(ffr_model.ny))]
    for quad_start in (None, _ptr(starts, _ip)):
        kernel._model.quad_start = quad_start
        assert lib.ffx_lti_check_model(ctypes.addressof(kernel._model)) == lti.OK
        for rows in subsets:
            y = np.full(ffr_model.ny, -7.0)
            wanted = np.array(rows, dtype=np.int32)
            status = lib.ffx_lti_output_rows(ctypes.byref(kernel._maps), _ptr(p), _ptr(x), _ptr(u),
                                             _ptr(wanted, _ip), len(rows), _ptr(y))
            assert status == lti.OK
            assert np.array_equal(y[rows], whole[rows]), rows
            assert np.all(np.delete(y, rows) == -7.0)
    starts[1] += 1                                      # row starts that do not match the rows: refused
    kernel._model.quad_start = _ptr(starts, _ip)
    assert lib.ffx_lti_check_model(ctypes.addressof(kernel._model)) == lti.BAD_ARGUMENT
    kernel._model.quad_start = None
    unordered = dataclasses.replace(ffr_model, quad_row=ffr_model.quad_row[::-1].copy())
    unordered_kernel = unordered.kernel()
    assert lib.ffx_lti_quad_starts(ctypes.addressof(unordered_kernel._model), _ptr(starts, _ip)) == 0


def test_non_finite_results_are_reported_and_leave_the_state(ffr_model):
    lib = lti.library()
    kernel = ffr_model.kernel()
    x = np.full(ffr_model.nx, 1e-3)
    u = np.zeros(ffr_model.nu)
    p = ffr_model.p_start.copy()
    p[1] = 1e200                                        # base_w_x: the maps overflow
    before = x.copy()
    status = lib.ffx_lti_step(ctypes.byref(kernel._maps), _ptr(p), 1e-3, _ptr(x), _ptr(u), _ptr(x))
    assert status == lti.NONFINITE and np.array_equal(x, before)      # in place: x untouched
    with pytest.raises(NonFiniteError):
        kernel.step(x, u, p, 1e-3)
    with pytest.raises(NonFiniteError):
        kernel.outputs(x, u, p)
    p = ffr_model.p_start.copy()
    y = np.zeros(ffr_model.ny)
    status = lib.ffx_lti_outputs(ctypes.byref(kernel._maps), _ptr(p), _ptr(np.full(ffr_model.nx, 1e300)),
                                 _ptr(u), _ptr(y))
    assert status == lti.NONFINITE
    for h in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ParameterError):
            kernel.step(x, u, p, h)
    assert lib.ffx_lti_status_string(lti.NONFINITE).decode().startswith("a result is not finite")


def _integrator_model():
    """x' = u, y = x + x^2 (nx = nu = ny = 1, no parameters): by hand."""
    one = np.ones((1, 1, 1))
    return lti.LtiModel(A=0 * one, B=one, b=np.zeros((1, 1)), Cx=one, Cu=0 * one, y0=np.zeros((1, 1)),
                        quad_row=[0], quad_i=[0], quad_j=[0], quad_value=[1.0], input_names=("u",), param_names=(),
                        output_names=("y",), u_from_input=[0], p_from_input=np.zeros(0), p_start=np.zeros(0))


def test_state_overflow_is_reported_and_leaves_the_state():
    model = _integrator_model()
    kernel = model.kernel()
    lib = lti.library()
    p = np.zeros(1)                                     # np = 0: never read
    x, u = np.array([1e308]), np.array([1e308])
    status = lib.ffx_lti_step(ctypes.byref(kernel._maps), _ptr(p), 1.0, _ptr(x), _ptr(u), _ptr(x))
    assert status == lti.NONFINITE and x[0] == 1e308
    status = lib.ffx_lti_steps(ctypes.byref(kernel._maps), _ptr(p), 0.3, 3, _ptr(x), _ptr(u),
                               _ptr(x))
    assert status == lti.NONFINITE and x[0] == 1e308  # the third step overflows: none is kept
    # 1 + 0.25 * 2 by the exact ZOH: expm of W = 0.25 [[0, 1], [0, 0]] within expm_error_bound(W) (2-norm) times
    # |x| + |u| = 3, then Ad x + Bd u: gamma_2 of its terms (<= 1.5)
    W = 0.25 * np.array([[0.0, 1.0], [0.0, 0.0]])
    x1 = kernel.step(np.array([1.0]), np.array([2.0]), np.zeros(0), 0.25)[0]
    assert abs(x1 - 1.5) <= 3 * expm_error_bound(W) + gamma(2) * 1.5
    assert kernel.outputs(np.array([3.0]), np.array([0.0]), np.zeros(0)).tolist() == [12.0]
    with pytest.raises(NonFiniteError):
        kernel.outputs(np.array([1e200]), np.array([0.0]), np.zeros(0))


def test_arrays_round_trip_and_the_model_check(ffr_model):
    arrays, names = ffr_model.arrays(), ffr_model.names()
    assert {a.dtype for a in arrays.values()} <= {np.dtype(np.float64), np.dtype(np.int32)}
    assert int(arrays["nmono"]) == lti.n_monomials(int(arrays["np"])) == ffr_model.A.shape[0]
    again = lti.LtiModel.from_arrays(arrays, names)
    for key, value in arrays.items():
        assert np.array_equal(getattr(again, key), value)
    assert again.param_names == ("damping_ratio", "base_w_x", "base_w_y", "base_w_z", "base_dw_x", "base_dw_y",
                                 "base_dw_z")
    assert again.u_names == ("F_x", "F_y", "F_z", "M_x", "M_y", "M_z", "base_a_x", "base_a_y", "base_a_z")
    bad = dict(arrays, quad_i=arrays["quad_i"].copy())
    bad["quad_i"][0] = ffr_model.nx + ffr_model.nu + ffr_model.nmono
    with pytest.raises(ParameterError):
        lti.LtiModel.from_arrays(bad, names)
    lib = lti.library()
    kernel = ffr_model.kernel()
    assert lib.ffx_lti_check_model(ctypes.byref(kernel._model)) == lti.OK
    kernel._model.nmono -= 1
    assert lib.ffx_lti_check_model(ctypes.byref(kernel._model)) == lti.BAD_ARGUMENT
    maps, work = _Maps(), np.zeros(4)
    kernel._model.nmono += 1
    assert lib.ffx_lti_maps_init(ctypes.byref(maps), ctypes.byref(kernel._model), _ptr(work), 4) == \
        lti.BAD_ARGUMENT                                # too little workspace


def test_numpy_evaluation_equals_the_kernel(ffr_model):
    """LtiModel's numpy outputs (the extraction's check) and the C outputs: the same sums."""
    rng = np.random.default_rng(9)
    kernel = ffr_model.kernel()
    for _ in range(3):
        x, u = rng.standard_normal(ffr_model.nx) * 1e-3, rng.standard_normal(ffr_model.nu)
        p = np.r_[0.05, rng.standard_normal(6) * 3]
        # C vs numpy, per output: each within gamma_ops of the sum of its terms' sizes (the maps' monomial sums of
        # nmono terms, then the inner products over x and u, y0, the quadratic terms: ops = nmono + nx + nu +
        # nquad + 3 rounds the longest chain) [ASNA 3.5]
        m = ffr_model
        mono = np.abs(lti.monomials(p))
        quad = np.zeros(m.ny)
        z = np.abs(np.concatenate([x, u, lti.monomials(p)]))
        np.add.at(quad, m.quad_row, np.abs(m.quad_value) * z[m.quad_i] * z[m.quad_j])
        terms = (np.tensordot(mono, np.abs(m.Cx), axes=1) @ np.abs(x) + np.tensordot(mono, np.abs(m.Cu), axes=1)
                 @ np.abs(u) + np.tensordot(mono, np.abs(m.y0), axes=1) + quad)
        bound = 2 * gamma(m.nmono + m.nx + m.nu + len(m.quad_value) + 3) * terms
        assert np.all(np.abs(kernel.outputs(x, u, p) - m.outputs(x, u, p)) <= bound)
