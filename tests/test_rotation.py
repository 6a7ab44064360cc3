"""Tests of flexfmu.core.rotation (paper Section 2, Eqs. 4-22).

References are exact rigid motions built here with numpy / scipy
(Rotation, expm); nothing is computed by the code under test.
"""
from __future__ import annotations

import numpy as np
import pytest
from error_bounds import U, gamma, mp_expm
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from flexfmu.errors import ParameterError
from flexfmu.core.rotation import (
    angular_acceleration,
    angular_acceleration_oblique,
    angular_velocity,
    angular_velocity_oblique,
    oblique_basis,
    paper_skew,
    reparametrize,
    rotation_matrix,
    rotvec_from_matrix,
    rotvec_rate,
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


def _assert_rel(actual, expected, rtol):
    err = np.linalg.norm(np.asarray(actual) - expected)
    assert err <= rtol * np.linalg.norm(expected), (err / np.linalg.norm(expected), actual, expected)


# ---------------------------------------------------------------- g and h
def test_g_and_h_recover_exact_rigid_motion():
    for c in _rigid_cases():
        w = angular_velocity(c["p"], c["q"], c["vP"], c["vQ"])
        _assert_rel(w, c["w"], 1e-12)
        al = angular_acceleration(c["p"], c["q"], c["vP"], c["vQ"], c["aP"], c["aQ"], c["w"])
        _assert_rel(al, c["al"], 1e-12)
        # chained as the integrator will use it (omega from g, not the exact one)
        al2 = angular_acceleration(c["p"], c["q"], c["vP"], c["vQ"], c["aP"], c["aQ"], w)
        _assert_rel(al2, c["al"], 1e-12)


def test_g_and_h_are_frame_agnostic():
    """Inputs in a rotated (e.g. body) frame give omega, alpha in that frame."""
    for c in _rigid_cases(10):
        R = c["R"]
        args = [R @ c[k] for k in ("p", "q", "vP", "vQ")]
        _assert_rel(angular_velocity(*args), R @ c["w"], 1e-12)
        al = angular_acceleration(*args, R @ c["aP"], R @ c["aQ"], R @ c["w"])
        _assert_rel(al, R @ c["al"], 1e-12)


def test_hat_components_are_contravariant_not_dual():
    """Eq. (8)/(13): omega = B^T omega_hat; the covariant reading B^-1 omega_hat is wrong."""
    for c in _rigid_cases(10):
        B, _, _, s = oblique_basis(c["p"], c["q"])
        assert s < 0.9999  # genuinely oblique
        w_hat = angular_velocity_oblique(c["p"], c["q"], c["vP"], c["vQ"])
        # expansion coefficients along e_i, solved independently
        contra = np.linalg.solve(B.T, c["w"])
        _assert_rel(w_hat, contra, 1e-12)
        # projections onto e_i (dual reading) differ for non-orthogonal p, q
        cov = B @ c["w"]
        assert np.linalg.norm(w_hat - cov) > 1e-3 * np.linalg.norm(cov)
        al_hat = angular_acceleration_oblique(c["p"], c["q"], c["vP"], c["vQ"],
                                              c["aP"], c["aQ"], c["w"])
        _assert_rel(al_hat, np.linalg.solve(B.T, c["al"]), 1e-12)


def test_oblique_basis_eq4():
    p = np.array([2.0, 0.0, 0.0])
    q = np.array([1.0, 1.0, 0.0])
    B, pn, qn, s = oblique_basis(p, q)
    np.testing.assert_allclose(B, [[1, 0, 0], [2 ** -0.5, 2 ** -0.5, 0], [0, 0, 1]], atol=1e-15)
    assert (pn, s) == (2.0, pytest.approx(2 ** -0.5, abs=1e-15))
    assert qn == pytest.approx(2 ** 0.5, abs=1e-15)


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
    np.testing.assert_allclose(skew(a) @ b, np.cross(a, b), rtol=0, atol=1e-15)
    np.testing.assert_allclose(paper_skew(a) @ b, np.cross(b, a), rtol=0, atol=1e-15)
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
        np.testing.assert_allclose(A, R_ref.T, rtol=0, atol=1e-14)
        # Eq. (18) against e^W in mpmath (W = th paper_skew(lam) has the entries fl(th lam_i) = phi: the same input).
        # Our Rodrigues I + sin(t) K + (1 - cos t) K^2 with |K_ij|, |K^2_ij| <= 1: evaluation <= gamma_8 (1 + |sin t|
        # + |1 - cos t|) per entry; t = ||phi|| to gamma_3 (dA/dt = K A, ||K A|| <= 1) and K = phi / t to gamma_5,
        # times the coefficients twice over (K^2) [ASNA 3.1]; u for rounding the 40-digit reference to doubles
        s_, c_ = abs(np.sin(th)), abs(1 - np.cos(th))
        bound = gamma(8) * (1 + s_ + c_) + gamma(3) * th + 2 * gamma(5) * (s_ + 2 * c_) + U
        ref = np.array(mp_expm(th * paper_skew(lam)).tolist(), dtype=float)
        assert np.abs(A - ref).max() <= bound, (th, np.abs(A - ref).max(), bound)
        # A maps global -> body: the body axes (columns of R_ref, global comps) map to unit vectors
        np.testing.assert_allclose(A @ R_ref, np.eye(3), rtol=0, atol=1e-14)
        np.testing.assert_allclose(A @ lam, lam, rtol=0, atol=1e-14)


def test_the_rodrigues_and_skew_implementations_agree():
    """The hot-path Rodrigues of the paper scheme (core.vec3, matrix products) and the reframe kernels'
    element-wise one (numpy and C) are the same formula: equal up to rounding, and equal to
    rotation_matrix(phi).T and scipy.  The unchecked skew, the checked one and wec.wave's are one."""
    from flexfmu.core import vec3
    from flexfmu.native import reframe as native
    from flexfmu.reframe import kernels, kernels_numpy
    from flexfmu.wec import wave

    rng = np.random.default_rng(5)
    for th in [0.0, 1e-12, 5e-5, 1e-4, 2e-4, 1e-3, 0.3, 1.0, 2.5, np.pi, 6.0]:
        lam = rng.normal(size=3)
        phi = th * lam / np.linalg.norm(lam)
        R_ref = Rotation.from_rotvec(phi).as_matrix()
        R_vec3 = vec3.rodrigues(phi)
        R_np = kernels_numpy._rodrigues(phi)
        compiled = [native.rodrigues(phi).reshape(3, 3)] if kernels.NATIVE else []      # the C kernels' own
        for R in (R_vec3, R_np, *compiled, rotation_matrix(phi).T):
            np.testing.assert_allclose(R, R_ref, rtol=0, atol=1e-14)
        np.testing.assert_allclose(R_np, R_vec3, rtol=0, atol=4e-16)
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
            if th < np.pi - 1e-3:
                np.testing.assert_allclose(got, phi, rtol=0, atol=2e-14)
            else:  # at/near pi, -phi' is equivalent; check the rotation and the angle
                assert np.linalg.norm(got) == pytest.approx(th, abs=1e-12)
                assert min(np.linalg.norm(got - phi), np.linalg.norm(got + phi)) < 1e-7
                np.testing.assert_allclose(Rotation.from_rotvec(got).as_matrix().T, A,
                                           rtol=0, atol=1e-14)
    for R in Rotation.random(20, random_state=4).as_matrix():
        got = rotvec_from_matrix(R.T)
        np.testing.assert_allclose(Rotation.from_rotvec(got).as_matrix(), R, rtol=0, atol=1e-14)
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
        np.testing.assert_allclose(Mdot, paper_skew(rotvec_rate(th * lam, w)), rtol=0, atol=1e-13)


def test_rotvec_rate_series_is_accurate_and_finite_at_zero():
    """c(theta) of Eq. (22) vs an extended-precision evaluation of
    (1 - (t/2) cot(t/2)) / t^2 on both sides of the series switch (theta = 0.1),
    and vs its Taylor limit 1/12 + t^2/720 where even long double cancels."""
    from flexfmu.core.rotation import rotvec_rate_coefficient

    w = np.array([0.0, 0.0, 1.5])
    lam = np.array([0.6, 0.8, 0.0])
    np.testing.assert_array_equal(rotvec_rate(np.zeros(3), w), w)
    assert np.all(np.isfinite(rotvec_rate(1e-300 * lam, w)))
    assert rotvec_rate_coefficient(0.0) == 1 / 12
    for th in [1e-9, 1e-5, 1e-3, 0.05, 0.0999, 0.1, 0.1001, 0.5, 3.0, 6.0]:
        if th < 1e-3:
            c_ref = 1 / 12 + th**2 / 720
        else:
            t = np.longdouble(th)
            h = t / 2
            c_ref = float((1 - h * np.cos(h) / np.sin(h)) / (t * t))
        # float64 cancellation in the closed form: ~ 12 eps / th^2 relative
        tol = 1e-15 if th < 0.1 else max(1e-15, 20 * np.finfo(float).eps / th**2)
        assert rotvec_rate_coefficient(th) == pytest.approx(c_ref, rel=tol), th
    # c enters rotvec_rate as phi x (phi x w) = -th^2 w for phi orthogonal to w
    th = 0.5
    got = rotvec_rate(th * lam, w)
    ref = w + 0.5 * np.cross(th * lam, w) - th**2 * rotvec_rate_coefficient(th) * w
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-15)


def test_reparametrize():
    rng = np.random.default_rng(7)
    for th in [0.0, 1.0, np.pi, np.pi + 1e-9, 4.0, 2 * np.pi - 1e-9, 2 * np.pi, 7.0, 3 * np.pi, 11.0]:
        lam = rng.normal(size=3)
        lam /= np.linalg.norm(lam)
        phi = th * lam
        out = reparametrize(phi)
        assert np.linalg.norm(out) <= np.pi + 1e-12
        np.testing.assert_allclose(Rotation.from_rotvec(out).as_matrix(),
                                   Rotation.from_rotvec(phi).as_matrix(), rtol=0, atol=1e-13)
        if th <= np.pi:
            np.testing.assert_array_equal(out, phi)
        else:  # lambda' = +-lambda
            assert abs(abs(out @ lam) - np.linalg.norm(out)) < 1e-12
    np.testing.assert_allclose(reparametrize(2 * np.pi * lam), 0.0, atol=1e-15)
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
