"""Tests of flexfmu.core.rotation and flexfmu.core.angular_motion (paper Section 2, Eqs. 4-22).

References are exact rigid motions built here with numpy / scipy
(Rotation, expm); nothing is computed by the code under test.
"""
from __future__ import annotations

import numpy as np
import pytest
from error_bounds import U, gamma, implementations_bound, mp_expm
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from flexfmu.errors import ParameterError
from flexfmu.core.angular_motion import (
    angular_acceleration,
    angular_acceleration_oblique,
    angular_velocity,
    angular_velocity_oblique,
    oblique_basis,
)
from flexfmu.core.rotation import (
    paper_skew,
    reparametrize,
    rotation_matrix,
    rotvec_from_matrix,
    rotvec_rate,
    rotvec_rate_coefficient,
    rotvec_rate_matrix,
    skew,
)

RNG_SEED = 20240531


def _cross_mat(v):
    """Independent cross-product matrix for the references."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _oblique_pair(rng, angle_deg):
    """Random p, q (m) of random lengths at the given angle (not orthogonal)."""
    p = rng.normal(size=3)
    p *= rng.uniform(0.05, 2.0) / np.linalg.norm(p)
    u = rng.normal(size=3)
    u -= (u @ p) / (p @ p) * p
    u /= np.linalg.norm(u)
    a = np.radians(angle_deg)
    q = rng.uniform(0.05, 2.0) * (np.cos(a) * p / np.linalg.norm(p) + np.sin(a) * u)
    return p, q


def _rigid_cases(n=40):
    rng = np.random.default_rng(RNG_SEED)
    angles = np.concatenate([[3.0, 20.0, 60.0, 120.0, 170.0, 177.0],
                             rng.uniform(10.0, 170.0, n - 6)])
    for ang in angles:
        p, q = _oblique_pair(rng, ang)
        w = rng.normal(scale=5.0, size=3)
        al = rng.normal(scale=50.0, size=3)
        vP, vQ = np.cross(w, p), np.cross(w, q)
        aP = np.cross(al, p) + np.cross(w, np.cross(w, p))
        aQ = np.cross(al, q) + np.cross(w, np.cross(w, q))
        R = Rotation.random(random_state=rng).as_matrix()
        yield dict(p=p, q=q, w=w, al=al, vP=vP, vQ=vQ, aP=aP, aQ=aQ, R=R)


def _assert_within(actual, expected, bound):
    err = np.linalg.norm(np.asarray(actual) - expected)
    assert err <= bound, (err, bound, actual, expected)


def _sine(p, q):
    """|sin angle(p, q)|: the recovery of a rotation from two vectors has conditioning ~ 1 / s."""
    return np.linalg.norm(np.cross(p, q)) / (np.linalg.norm(p) * np.linalg.norm(q))


def _recovery_bounds(c, s, inputs_rotated=False):
    """Bounds on |g - omega|, |h - alpha| (2-norm) for the data of a _rigid_cases case at sine s.

    g: e1, e2 (a normalisation each), n = e1 x e2 and e3 = n / s (absolute error ~ u, so a direction error
    ~ u / s), x_i = w . e_j / (p s) (3-term dot products, two divisions) and B^T x (3 terms): every rounding
    enters relative to |omega| and is divided by s at most twice (the direction of e3, the division by s):
    generously gamma(64) |omega| / s^2 [ASNA 3.1], the inputs v = fl(w x p) (gamma(2) |w| |p| each; with the
    rotated inputs R v another gamma(3)) included in the 64.  h: the same with w_P = a_P - omega x v_P, whose
    terms are |alpha| |p| and |omega|^2 |p| (a_P holds omega x (omega x p)), so |alpha| + 2 |omega|^2 stands
    for |alpha|; chained (h with omega from g): the error d of g enters as d x v_P / (p s) per component,
    3 |omega| d / s after B^T."""
    w, al = np.linalg.norm(c["w"]), np.linalg.norm(c["al"])
    bw = gamma(64) * w / s**2
    ba = gamma(64) * (al + 2 * w**2) / s**2
    return bw, ba, ba + 3 * w * bw / s


def _rot_bound(th):
    """Per-entry bound on |fl(R(phi)) - R(phi)| for any double evaluation of the rotation matrix of phi,
    th = |phi|: by Rodrigues I + a K + b K^2 (|a K_ij| <= 1, |b (K^2)_ij| <= 2) or from the unit quaternion
    (sin(th/2) phi/th, cos(th/2)) (scipy: entries of <= 3 products of components, <= 1): generously 16 roundings
    of terms <= 3 (sin, cos within a few ulps included); th = fl(||phi||) within gamma(3) relative moves the
    entries by <= (2 th + 5) gamma(4) [|d(sin t, 1 - cos t)/dt| t and the division by t, t^2]; the series
    below 1e-4 rad (a to th^4, b to th^4) truncated at th^6 / 5040 (times |K_ij| <= th)."""
    return 3 * gamma(16) + (2 * th + 5) * gamma(4) + (th**7 if th < 1e-4 else 0.0)


def _log_bound(th):
    """Bound on |rotvec_from_matrix(A) - phi| (and on the angle, and the roundtrip's per-entry |R(got) - A|)
    for A = fl(R(phi)) within _rot_bound(th): the quaternion extraction divides by 4 max(|w|, |x|, |y|, |z|)
    >= 2 and 2 atan2(|q_v|, w) q_v / |q_v| has conditioning <= pi / 2 on |phi| <= pi, R(q) is 4-Lipschitz in
    q per entry: generously 16 (the entry error of A plus 16 roundings of its own)."""
    return 16 * (_rot_bound(th) + gamma(16))


# ---------------------------------------------------------------- g and h
def test_g_and_h_recover_exact_rigid_motion():
    for c in _rigid_cases():
        bw, ba, ba_chained = _recovery_bounds(c, _sine(c["p"], c["q"]))     # conditioning 1 / s: see there
        w = angular_velocity(c["p"], c["q"], c["vP"], c["vQ"])
        _assert_within(w, c["w"], bw)
        al = angular_acceleration(c["p"], c["q"], c["vP"], c["vQ"], c["aP"], c["aQ"], c["w"])
        _assert_within(al, c["al"], ba)
        # chained as the integrator will use it (omega from g, not the exact one)
        al2 = angular_acceleration(c["p"], c["q"], c["vP"], c["vQ"], c["aP"], c["aQ"], w)
        _assert_within(al2, c["al"], ba_chained)


def test_g_and_h_are_frame_agnostic():
    """Inputs in a rotated (e.g. body) frame give omega, alpha in that frame."""
    for c in _rigid_cases(10):
        R = c["R"]
        args = [R @ c[k] for k in ("p", "q", "vP", "vQ")]
        # the rotated inputs' roundings (gamma(3) each) are within _recovery_bounds' count; the references
        # R w, R alpha add gamma(3) |w|, gamma(3) |alpha|, and R orthogonal only to ~4 u (scipy): gamma(8) in all
        bw, ba, _ = _recovery_bounds(c, _sine(c["p"], c["q"]))
        _assert_within(angular_velocity(*args), R @ c["w"], bw + gamma(8) * np.linalg.norm(c["w"]))
        al = angular_acceleration(*args, R @ c["aP"], R @ c["aQ"], R @ c["w"])
        _assert_within(al, R @ c["al"], ba + gamma(8) * np.linalg.norm(c["al"]))


def test_hat_components_are_contravariant_not_dual():
    """Eq. (8)/(13): omega = B^T omega_hat; the covariant reading B^-1 omega_hat is wrong."""
    for c in _rigid_cases(10):
        B, _, _, s = oblique_basis(c["p"], c["q"])
        assert s < 0.9999  # genuinely oblique
        w_hat = angular_velocity_oblique(c["p"], c["q"], c["vP"], c["vQ"])
        # expansion coefficients along e_i, solved independently
        contra = np.linalg.solve(B.T, c["w"])
        # the hat components are |omega| / s in size: _recovery_bounds before B^T (its 1 / s^2 covers them);
        # the reference's own error: LU with partial pivoting, backward error gamma(9) ||B|| [ASNA 9.4], times
        # kappa(B) ~ 2 / s, relative to ||contra||
        bw, ba, _ = _recovery_bounds(c, s)
        kappa = np.linalg.cond(B)
        _assert_within(w_hat, contra, bw + kappa * gamma(9) * np.linalg.norm(contra))
        # projections onto e_i (dual reading) differ for non-orthogonal p, q
        cov = B @ c["w"]
        assert np.linalg.norm(w_hat - cov) > 1e-3 * np.linalg.norm(cov)
        al_hat = angular_acceleration_oblique(c["p"], c["q"], c["vP"], c["vQ"],
                                              c["aP"], c["aQ"], c["w"])
        al_ref = np.linalg.solve(B.T, c["al"])
        _assert_within(al_hat, al_ref, ba + kappa * gamma(9) * np.linalg.norm(al_ref))


def test_oblique_basis_eq4():
    p = np.array([2.0, 0.0, 0.0])
    q = np.array([1.0, 1.0, 0.0])
    B, pn, qn, s = oblique_basis(p, q)
    # e1 = p / 2 and pn = sqrt(4) are exact; e2 = q / fl(sqrt 2), s = ||e1 x e2|| (sqrt of a square) and
    # e3 = n / s: each a correctly rounded sqrt and division or two, generously within gamma(4) of the value
    np.testing.assert_allclose(B, [[1, 0, 0], [2 ** -0.5, 2 ** -0.5, 0], [0, 0, 1]], rtol=0, atol=gamma(4))
    assert (pn, s) == (2.0, pytest.approx(2 ** -0.5, rel=0, abs=gamma(4)))
    assert qn == pytest.approx(2 ** 0.5, rel=0, abs=gamma(4) * 2 ** 0.5)


@pytest.mark.parametrize(
    "p, q, name",
    [
        ([1.0, 2.0, 3.0], [2.0, 4.0, 6.0], "p_vec, q_vec"),           # colinear
        ([1.0, 2.0, 3.0], [-1.0, -2.0, -3.0 + 1e-9], "p_vec, q_vec"),  # nearly colinear
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], "p_vec"),
        ([1.0, 0.0, 0.0], [0.0, 0.0, 0.0], "q_vec"),
        ([np.nan, 0.0, 0.0], [0.0, 1.0, 0.0], "p_vec"),
        ([1.0, 0.0], [0.0, 1.0, 0.0], "p_vec"),
    ],
)
def test_g_h_bad_geometry_raise(p, q, name):
    v = np.zeros(3)
    with pytest.raises(ParameterError) as ei:
        angular_velocity(p, q, v, v)
    assert ei.value.parameter == name
    with pytest.raises(ParameterError) as ei:
        angular_acceleration(p, q, v, v, v, v, v)
    assert ei.value.parameter == name


def test_g_h_bad_motion_inputs_raise():
    p, q, v = [1.0, 0, 0], [0, 1.0, 0], np.zeros(3)
    with pytest.raises(ParameterError) as ei:
        angular_velocity(p, q, [np.inf, 0, 0], v)
    assert ei.value.parameter == "v_PR"
    with pytest.raises(ParameterError) as ei:
        angular_acceleration(p, q, v, v, v, [0, np.nan, 0], v)
    assert ei.value.parameter == "a_QR"
    with pytest.raises(ParameterError) as ei:
        angular_acceleration(p, q, v, v, v, v, [1.0, 2.0])
    assert ei.value.parameter == "omega"


# ------------------------------------------------------ skew and Rodrigues
def test_skew_conventions():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=3), rng.normal(size=3)
    # the same two products a_i b_j per component, summed in another order (3 terms, one zero): each within
    # gamma(3) of the terms |skew(a)| |b|
    terms = np.abs(skew(a)) @ np.abs(b)
    assert np.all(np.abs(skew(a) @ b - np.cross(a, b)) <= implementations_bound(terms, 3))
    assert np.all(np.abs(paper_skew(a) @ b - np.cross(b, a)) <= implementations_bound(terms, 3))
    # Eq. (17) written out
    lam = a / np.linalg.norm(a)
    eq17 = np.array([[0, lam[2], -lam[1]], [-lam[2], 0, lam[0]], [lam[1], -lam[0], 0]])
    np.testing.assert_array_equal(paper_skew(lam), eq17)


def test_rodrigues_matches_scipy_and_expm():
    rng = np.random.default_rng(2)
    thetas = [0.0, 1e-12, 1e-7, 1e-3, 0.3, 1.0, 2.5, np.pi - 1e-9, np.pi, 3.5, 6.0, 2 * np.pi, 9.0]
    for th in thetas:
        lam = rng.normal(size=3)
        lam /= np.linalg.norm(lam)
        phi = th * lam
        A = rotation_matrix(phi)
        R_ref = Rotation.from_rotvec(phi).as_matrix()     # body -> global
        # both within _rot_bound(th) of the exact rotation of phi (scipy: an inexact double reference)
        np.testing.assert_allclose(A, R_ref.T, rtol=0, atol=2 * _rot_bound(th))
        # Eq. (18) against e^W in mpmath (W = th paper_skew(lam) has the entries fl(th lam_i) = phi: the same input).
        # Our Rodrigues I + sin(t) K + (1 - cos t) K^2 with |K_ij|, |K^2_ij| <= 1: evaluation <= gamma_8 (1 + |sin t|
        # + |1 - cos t|) per entry; t = ||phi|| to gamma_3 (dA/dt = K A, ||K A|| <= 1) and K = phi / t to gamma_5,
        # times the coefficients twice over (K^2) [ASNA 3.1]; u for rounding the 40-digit reference to doubles
        s_, c_ = abs(np.sin(th)), abs(1 - np.cos(th))
        bound = gamma(8) * (1 + s_ + c_) + gamma(3) * th + 2 * gamma(5) * (s_ + 2 * c_) + U
        ref = np.array(mp_expm(th * paper_skew(lam)).tolist(), dtype=float)
        assert np.abs(A - ref).max() <= bound, (th, np.abs(A - ref).max(), bound)
        # A maps global -> body: the body axes (columns of R_ref, global comps) map to unit vectors.  (A + E)(R + F)
        # - I = E R + A F + E F: 3-term rows of entries <= 1 times the two per-entry errors, the product's
        # rounding gamma(3) 3; lam vs phi / th (one rounding each of th lam and of th, moved by ||A - I|| <= 2)
        err = 3 * 2 * _rot_bound(th) + 3 * gamma(3)
        np.testing.assert_allclose(A @ R_ref, np.eye(3), rtol=0, atol=err)
        np.testing.assert_allclose(A @ lam, lam, rtol=0, atol=3 * _rot_bound(th) + 3 * gamma(3) + 2 * gamma(4))


def test_the_rodrigues_and_skew_implementations_agree():
    """Rodrigues is written once in Python (core.rotation): its hot-path forms (rodrigues, rodrigues_into: the paper
    scheme and the numpy reframe kernels) and the checked rotation_matrix (the transpose) are equal bit for bit;
    the C kernels' twin (ffx_reframe_rodrigues, the same expressions) and scipy are within the rounding bound of
    the exact rotation.  The unchecked skew, the checked one and wec.wave's are one."""
    from flexfmu.core import rotation, vec3
    from flexfmu.native import reframe as native
    from flexfmu.reframe import kernels
    from flexfmu.wec import wave

    rng = np.random.default_rng(5)
    for th in [0.0, 1e-12, 5e-5, 1e-4, 2e-4, 1e-3, 0.3, 1.0, 2.5, np.pi, 6.0]:
        lam = rng.normal(size=3)
        phi = th * lam / np.linalg.norm(lam)
        R_ref = Rotation.from_rotvec(phi).as_matrix()
        R = rotation.rodrigues(phi)
        assert np.array_equal(rotation.rodrigues_into(phi, np.empty(9)).reshape(3, 3), R)
        assert np.array_equal(rotation_matrix(phi).T, R)
        compiled = [native.rodrigues(phi).reshape(3, 3)] if kernels.NATIVE else []      # the C kernels' own
        # each (and scipy) within _rot_bound(th) of the exact rotation: two evaluations differ by twice it
        for R_other in (R, *compiled):
            np.testing.assert_allclose(R_other, R_ref, rtol=0, atol=2 * _rot_bound(th))
        assert np.array_equal(skew(phi), vec3.skew(phi)) and wave._skew is vec3.skew


def test_rotvec_from_matrix_roundtrip_incl_near_pi():
    rng = np.random.default_rng(3)
    thetas = [0.0, 1e-15, 1e-9, 1e-4, 1.0, 3.0, np.pi - 1e-6, np.pi - 1e-10, np.pi]
    for th in thetas:
        for _ in range(5):
            lam = rng.normal(size=3)
            lam /= np.linalg.norm(lam)
            phi = th * lam
            A = Rotation.from_rotvec(phi).as_matrix().T
            got = rotvec_from_matrix(A)
            if th < np.pi - 1e-3:        # A is scipy's (inexact) matrix of phi: _log_bound includes its error
                np.testing.assert_allclose(got, phi, rtol=0, atol=_log_bound(th))
            else:  # at/near pi, -phi' is equivalent; check the rotation and the angle
                assert np.linalg.norm(got) == pytest.approx(th, rel=0, abs=_log_bound(th) + gamma(3) * th)
                assert min(np.linalg.norm(got - phi), np.linalg.norm(got + phi)) < 1e-7
                np.testing.assert_allclose(Rotation.from_rotvec(got).as_matrix().T, A,
                                           rtol=0, atol=_log_bound(th) + _rot_bound(np.pi))
    for R in Rotation.random(20, random_state=4).as_matrix():
        got = rotvec_from_matrix(R.T)
        np.testing.assert_allclose(Rotation.from_rotvec(got).as_matrix(), R, rtol=0,
                                   atol=_log_bound(np.pi) + _rot_bound(np.pi))
        assert np.linalg.norm(got) <= np.pi


@pytest.mark.parametrize("A", [np.eye(2), np.diag([1.0, 1.0, -1.0]), 1.01 * np.eye(3),
                               np.full((3, 3), np.nan)])
def test_rotvec_from_matrix_bad_input(A):
    with pytest.raises(ParameterError) as ei:
        rotvec_from_matrix(A)
    assert ei.value.parameter == "A"


# --------------------------------------------------- rotation-vector rate
def _exact_rotvec(phi0, w_body, t):
    """phi(t) for constant body-frame omega: R(t) = R0 expm(t [w]x), A = R^T."""
    R = Rotation.from_rotvec(phi0).as_matrix() @ expm(t * _cross_mat(w_body))
    return Rotation.from_matrix(R).as_rotvec()


@pytest.mark.parametrize("theta0", [0.0, 1e-6, 0.05, 0.0999, 0.1001, 0.7, 2.0, 3.0])
def test_rotvec_rate_vs_finite_difference(theta0):
    rng = np.random.default_rng(int(theta0 * 1e4) + 5)
    lam = rng.normal(size=3)
    lam /= np.linalg.norm(lam)
    phi0 = theta0 * lam
    w = rng.normal(scale=3.0, size=3)
    h = 1e-5
    fd = (_exact_rotvec(phi0, w, h) - _exact_rotvec(phi0, w, -h)) / (2 * h)
    got = rotvec_rate(phi0, w)
    np.testing.assert_allclose(got, fd, rtol=0, atol=1e-7 * np.linalg.norm(w))
    # the same omega given in global components is the wrong input: the test discriminates
    if theta0 > 0.5:
        w_glob = Rotation.from_rotvec(phi0).as_matrix() @ w
        assert np.linalg.norm(rotvec_rate(phi0, w_glob) - fd) > 1e-2 * np.linalg.norm(w)


def test_rotvec_rate_equals_literal_eq22():
    rng = np.random.default_rng(6)
    for th in [0.0, 1e-8, 0.05, 0.5, 2.0, 3.1, 4.0]:
        lam = rng.normal(size=3)
        lam /= np.linalg.norm(lam)
        w = rng.normal(size=3)
        Mdot = rotvec_rate_matrix(paper_skew(lam), th, paper_skew(w))
        # two groupings of w + th/2 lam x w + th^2 c lam x (lam x w), terms <= |w| (1 + th + c th^2): <= 16
        # roundings generously (matrix products of 3 terms, twice; the cross products; c's own cancellation,
        # 12 eps / th^2 relative, times th^2); c at th and at fl(||th lam||) (gamma(3) th apart, |c'| th <= 0.13
        # on th <= 4): within the 32 counted
        c = rotvec_rate_coefficient(th)
        scale = np.linalg.norm(w) * (1 + th + (abs(c) + 1) * th**2)
        np.testing.assert_allclose(Mdot, paper_skew(rotvec_rate(th * lam, w)), rtol=0,
                                   atol=implementations_bound(scale, 32))


def test_rotvec_rate_series_is_accurate_and_finite_at_zero():
    """c(theta) of Eq. (22) vs an mpmath (50 digits) evaluation of (1 - (t/2) cot(t/2)) / t^2 on both sides
    of the series switch (theta = 0.1)."""
    import mpmath

    w = np.array([0.0, 0.0, 1.5])
    lam = np.array([0.6, 0.8, 0.0])
    np.testing.assert_array_equal(rotvec_rate(np.zeros(3), w), w)
    assert np.all(np.isfinite(rotvec_rate(1e-300 * lam, w)))
    assert rotvec_rate_coefficient(0.0) == 1 / 12
    for th in [1e-9, 1e-5, 1e-3, 0.05, 0.0999, 0.1, 0.1001, 0.5, 3.0, 6.0]:
        with mpmath.workdps(50):                      # 50 digits: the cancellation at 1e-9 costs 18 of them
            t = mpmath.mpf(th)
            h_cot = t / 2 * mpmath.cot(t / 2)
            c_ref = (1 - h_cot) / (t * t)
            c_ref, h_cot = float(c_ref), float(h_cot)
        if th < 0.1:
            # series to t^6 (Horner: 7 roundings of terms <= c): the tail sum_{k>=4} is positive, geometric of
            # ratio <= t^2 / (2 pi)^2, its first term t^8 / 47900160: <= 1.01 of it
            bound = 1.01 * th**8 / 47900160 + gamma(8) * c_ref
        else:
            # closed form: h = th / 2 exact, h cos h / sin h within gamma(10) (cos, sin generously 4 ulps each, a
            # product, a division) of |h cot h|; 1 - it one rounding; the division by fl(th th) gamma(2) of c
            bound = (gamma(10) * abs(h_cot) + gamma(1) * abs(1 - h_cot)) / th**2 + gamma(2) * c_ref
        bound += U * c_ref                            # the reference rounded to a double
        assert abs(rotvec_rate_coefficient(th) - c_ref) <= bound, (th, rotvec_rate_coefficient(th) - c_ref, bound)
    # c enters rotvec_rate as phi x (phi x w) = -th^2 w for phi orthogonal to w
    th = 0.5
    got = rotvec_rate(th * lam, w)
    ref = w + 0.5 * np.cross(th * lam, w) - th**2 * rotvec_rate_coefficient(th) * w
    # two groupings of the terms |w| (1 + th + c th^2) (phi x (phi x w) vs -th^2 w: |lam| = 1 within gamma(2),
    # c at th vs fl(||th lam||), |c'| th < 1e-3 here): generously 16 roundings
    c = rotvec_rate_coefficient(th)
    np.testing.assert_allclose(got, ref, rtol=0,
                               atol=implementations_bound(np.linalg.norm(w) * (1 + th + c * th**2), 16))


def test_reparametrize():
    rng = np.random.default_rng(7)
    for th in [0.0, 1.0, np.pi, np.pi + 1e-9, 4.0, 2 * np.pi - 1e-9, 2 * np.pi, 7.0, 3 * np.pi, 11.0]:
        lam = rng.normal(size=3)
        lam /= np.linalg.norm(lam)
        phi = th * lam
        out = reparametrize(phi)
        # the new angle th - 2 pi k (fl(2 pi), th = fl(||phi||), the subtraction, the scaling of phi, its norm):
        # generously within gamma(8) (th + 2 pi) of the exact one
        angle_err = gamma(8) * (th + 2 * np.pi)
        assert np.linalg.norm(out) <= np.pi + angle_err
        # the same rotation up to that angle error (entries move by <= it), each scipy matrix within _rot_bound
        np.testing.assert_allclose(Rotation.from_rotvec(out).as_matrix(), Rotation.from_rotvec(phi).as_matrix(),
                                   rtol=0, atol=_rot_bound(th) + _rot_bound(np.linalg.norm(out)) + angle_err)
        if th <= np.pi:
            np.testing.assert_array_equal(out, phi)
        else:  # lambda' = +-lambda: out . lam = +-|out| |lam|^2, |lam| = 1 within gamma(3); 3-term dot, norm
            assert abs(abs(out @ lam) - np.linalg.norm(out)) <= gamma(16) * np.linalg.norm(out)
    np.testing.assert_allclose(reparametrize(2 * np.pi * lam), 0.0, rtol=0, atol=gamma(8) * 2 * np.pi)
    with pytest.raises(ParameterError):
        reparametrize([1.0, np.nan, 0.0])


def test_eq22_singular_near_two_pi_without_reparametrization():
    w = np.array([0.0, 1.0, 0.0])
    phi = (2 * np.pi - 1e-6) * np.array([1.0, 0.0, 0.0])
    assert np.linalg.norm(rotvec_rate(phi, w)) > 1e5
    assert np.linalg.norm(rotvec_rate(reparametrize(phi), w)) < 10


def test_rk4_through_pi_and_two_pi_with_reparametrize():
    """Constant body omega, 1.6 turns: RK4 + reparametrize after each step vs exact expm."""
    w = np.array([1.1, -2.3, 1.9])          # |w| = 3.18 rad/s
    phi0 = np.array([0.4, 0.9, -0.3])
    dt, n = 2e-3, 1600                      # T = 3.2 s, rotation angle 10.2 rad > 3 pi
    R0 = Rotation.from_rotvec(phi0).as_matrix()
    phi = phi0.copy()
    thetas, reparams, raw_rotation = [], 0, 0.0
    for k in range(1, n + 1):
        k1 = rotvec_rate(phi, w)
        k2 = rotvec_rate(phi + 0.5 * dt * k1, w)
        k3 = rotvec_rate(phi + 0.5 * dt * k2, w)
        k4 = rotvec_rate(phi + dt * k3, w)
        phi = phi + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        thetas.append(np.linalg.norm(phi))
        new = reparametrize(phi)
        reparams += not np.array_equal(new, phi)
        phi = new
        if k % 400 == 0 or k == n:
            A_exact = (R0 @ expm(k * dt * _cross_mat(w))).T
            np.testing.assert_allclose(rotation_matrix(phi), A_exact, rtol=0, atol=1e-10)
    raw_rotation = n * dt * np.linalg.norm(w)
    assert raw_rotation > 3 * np.pi             # the body turned past 2 pi (and 3 pi)
    assert max(thetas) > np.pi                  # theta went past pi ...
    assert max(thetas) < np.pi + 0.1            # ... but never near the 2 pi singularity
    assert reparams >= 1
    assert np.all(np.isfinite(phi))
