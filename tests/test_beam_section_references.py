"""The gauges' independent references (tests/reference/beam_sections) against textbook results, on their own:
the 3D frame solver (beam_frame3d) against cantilever, torsion, L-frame and fixed-fixed closed forms and statics;
the base-excited cantilever's modal series (eb_base_excitation) against Blevins' roots, quadratures of its own mode
shapes and the undamped closed form by Krylov's functions."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

sys.path.insert(0, str(Path(__file__).resolve().parent / "reference" / "beam_sections"))
from beam_frame3d import Frame, FrameSection, PolylineFrame, section_axes, section_forces_at  # noqa: E402
from eb_base_excitation import (CASE, Cantilever, cantilever_roots, mode_curvature_shape,  # noqa: E402
                                mode_shear_shape, mode_sigma)

pytestmark = pytest.mark.unit

E, NU = 200e9, 0.29
G_SHEAR = E / (2 * (1 + NU))
#: a flat bar 20 mm x 5 mm (Iy != Iz: a wrong axis shows), J of any value: the frame solver takes it as given
FLAT = FrameSection(E=E, G=G_SHEAR, A=1e-4, Iy=2.0e-10, Iz=3.3e-9, J=7.0e-10)
ROUND = FrameSection(E=E, G=G_SHEAR, A=math.pi * 0.008**2 / 4, Iy=math.pi * 0.008**4 / 64,
                     Iz=math.pi * 0.008**4 / 64, J=math.pi * 0.008**4 / 32)
#: rounding of a solve with condition number ~ (L / r)^2 ~ 1e6: far below these
RTOL = 1e-9


# ----------------------------------------------------------------------------- frame solver
@pytest.mark.parametrize("direction, y_axis, z_axis", [
    ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    ((-1, 0, 0), (0, 1, 0), (0, 0, -1)),
    ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
    ((0, 1, 0), (-1, 0, 0), (0, 0, 1)),          # exactly parallel to Y: y = -c X, z = Z
    ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
])
def test_section_axes_follow_the_orientation_rule(direction, y_axis, z_axis):
    R = section_axes((0.0, 0.0, 0.0), direction)
    np.testing.assert_allclose(R, np.column_stack((direction, y_axis, z_axis)), atol=1e-15)


def test_section_axes_of_a_skew_element_are_right_handed_with_z_horizontal(rng):
    for _ in range(20):
        d = rng.normal(size=3)
        R = section_axes((0.0, 0.0, 0.0), d)
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-14)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
        np.testing.assert_allclose(R[:, 0], d / np.linalg.norm(d), atol=1e-15)
        assert abs(R[1, 2]) < 1e-15 and R[1, 1] >= 0.0        # z horizontal, y . Y >= 0


def cantilever(section, L=0.7, n_inner=3):
    """Along body X, clamped at x = 0, nodes also inside (results must not depend on them)."""
    model = PolylineFrame([[0, 0, 0], [L, 0, 0]], section, arc_lengths=np.linspace(0, L, n_inner + 2))
    model.clamp(0.0)
    return model


def test_cantilever_tip_deflections_rotations_twist_and_stretch():
    L, P, T = 0.7, 3.0, 0.4
    s = FLAT
    for force, moment, expect in [
        ((0, P, 0), (0, 0, 0), {1: P * L**3 / (3 * E * s.Iz), 5: P * L**2 / (2 * E * s.Iz)}),
        ((0, 0, P), (0, 0, 0), {2: P * L**3 / (3 * E * s.Iy), 4: -P * L**2 / (2 * E * s.Iy)}),
        ((P, 0, 0), (T, 0, 0), {0: P * L / (E * s.A), 3: T * L / (s.G * s.J)}),
        ((0, 0, 0), (0, 0, T), {1: T * L**2 / (2 * E * s.Iz), 5: T * L / (E * s.Iz)}),
    ]:
        model = cantilever(s, L)
        model.load(L, force, moment)
        tip = model.solve().displacement(model.node(L))
        want = np.zeros(6)
        for k, v in expect.items():
            want[k] = v
        np.testing.assert_allclose(tip, want, rtol=RTOL, atol=RTOL * np.max(np.abs(want)))


def test_l_frame_out_of_plane_tip_load_by_hand():
    """Clamp at 0, a along X, then b along Y (the exactly-vertical rule), force P along Z at the tip: bending of
    both legs and the twist of the first by the torque P b (Roark / any strength-of-materials text):
    w_tip = P b^3 / (3 EI) + P a^3 / (3 EI) + P b^2 a / (G J)."""
    a, b, P = 0.14, 0.15, 2.0
    s = ROUND
    model = PolylineFrame([[0, 0, 0], [a, 0, 0], [a, b, 0]], s)
    model.clamp(0.0)
    model.load(a + b, force=(0, 0, P))
    sol = model.solve()
    I = s.Iy
    w_tip = P * b**3 / (3 * E * I) + P * a**3 / (3 * E * I) + P * b**2 * a / (s.G * s.J)
    assert sol.displacement(model.node(a + b))[2] == pytest.approx(w_tip, rel=RTOL)
    # the first leg at its mid: the section forces are the statics of the part beyond the cut
    cut = section_forces_at(model, sol, a / 2)
    r_tip, r_cut = np.array([a, b, 0.0]), np.array([a / 2, 0.0, 0.0])
    R = section_axes((0, 0, 0), (1, 0, 0))
    F = np.array([0.0, 0.0, P])
    np.testing.assert_allclose(cut, np.concatenate([R.T @ F, R.T @ np.cross(r_tip - r_cut, F)]),
                               rtol=RTOL, atol=RTOL * P * (a + b))


def test_fixed_fixed_beam_with_a_central_load():
    """Statically indeterminate: end moments P L / 8 (hogging), mid-span P L / 8 (sagging), shear P / 2, mid
    deflection P L^3 / (192 EI) (Roark, Table 8.1 case 1c).  Along X, load -Y (down in y): section forces by (5)."""
    L, P = 0.6, 10.0
    s = FLAT
    model = PolylineFrame([[0, 0, 0], [L, 0, 0]], s, arc_lengths=[L / 4, L / 2])
    model.clamp(0.0)
    model.clamp(L)
    model.load(L / 2, force=(0, -P, 0))
    sol = model.solve()
    assert sol.displacement(model.node(L / 2))[1] == pytest.approx(-P * L**3 / (192 * E * s.Iz), rel=RTOL)
    # just after the left clamp, which holds the beam up with P / 2: the part beyond acts on the part before with
    # Vy = -P / 2; hogging there (v'' < 0, the top fibre y > 0 in tension: sigma = -Mz y / Iz > 0): Mz = -P L / 8
    root = section_forces_at(model, sol, 0.0)
    np.testing.assert_allclose(root, [0, -P / 2, 0, 0, 0, -P * L / 8], atol=RTOL * P * L)
    mid_before = sol.section_forces(model.element_at(L / 4)[0], L / 4)   # the end of the element before mid-span
    np.testing.assert_allclose(mid_before, [0, -P / 2, 0, 0, 0, P * L / 8], atol=RTOL * P * L)
    mid_after = section_forces_at(model, sol, L / 2)                       # the element after: the shear jumps
    np.testing.assert_allclose(mid_after, [0, P / 2, 0, 0, 0, P * L / 8], atol=RTOL * P * L)
    quarter = section_forces_at(model, sol, L / 4)                         # M linear: zero at L / 4
    np.testing.assert_allclose(quarter, [0, -P / 2, 0, 0, 0, 0], atol=RTOL * P * L)


def double_l(section=ROUND, cuts=()):
    pts = [[0, 0, 0], [0, 0, 0.16], [0.14, 0, 0.16], [0.14, 0.15, 0.16]]
    model = PolylineFrame(pts, section, arc_lengths=cuts)
    model.clamp(0.0)
    return model, np.array(pts, float)


@pytest.mark.parametrize("section", [ROUND, FLAT])
def test_double_l_section_forces_are_the_statics_of_the_part_beyond(section, rng):
    """The spec's check: [N, Vy, Vz] = R^T F, [T, My, Mz] = R^T ((r_tip - r_cut) x F), for any section."""
    cuts = [0.0, 0.08, 0.16, 0.23, 0.30, 0.375, 0.45]
    model, pts = double_l(section, cuts)
    F, M = rng.normal(size=3), rng.normal(size=3) * 0.1
    model.load(0.45, F, M)
    sol = model.solve()
    for s in cuts:
        R = model.section_axes_at(s)
        lever = pts[-1] - model.point_at(s)
        want = np.concatenate([R.T @ F, R.T @ (np.cross(lever, F) + M)])
        got = section_forces_at(model, sol, s)
        np.testing.assert_allclose(got, want, rtol=0, atol=RTOL * np.max(np.abs(want)))
    # and the reactions balance the load (force, moment about the origin)
    np.testing.assert_allclose(sol.reactions(), -np.concatenate([F, np.cross(pts[-1], F) + M]), atol=1e-9)


def test_cuts_on_a_segment_parallel_to_y_keep_its_axes():
    """A node interpolated on the double-L's last segment (along +Y) lies off the exact vertical by rounding; the
    section axes are still the rule's y = -X, z = Z (the segment's direction orients them)."""
    model, _ = double_l(ROUND, cuts=[0.3 + 0.15 * k / 7 for k in range(1, 7)])
    tilted = 0
    for s in model.node_s[model.node_s >= 0.3]:
        np.testing.assert_array_equal(model.section_axes_at(s), [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
        e = model.element_at(s)[0]
        i, j, _ = model.frame.elements[e]
        tilted += not np.array_equal(section_axes(model.frame.nodes[i], model.frame.nodes[j])[:, 1], [-1, 0, 0])
    assert tilted > 0          # the nodes' own direction would have turned some: the test can fail


def test_results_do_not_depend_on_extra_nodes():
    one, _ = double_l(ROUND, cuts=[0.45])
    many, _ = double_l(ROUND, cuts=np.linspace(0, 0.45, 31))
    for model in (one, many):
        model.clamp(0.0)
        model.load(0.45, (1.0, -2.0, 0.5), (0.01, 0.0, -0.02))
    a, b = one.solve(), many.solve()
    np.testing.assert_allclose(a.displacement(one.node(0.45)), b.displacement(many.node(0.45)), rtol=1e-9)


def test_frame_refuses_a_cut_without_a_node():
    model = cantilever(ROUND)
    with pytest.raises(ValueError, match="no node"):
        model.load(0.123, (1, 0, 0))


def test_generic_frame_api_matches_the_polyline_one():
    f = Frame(np.array([[0.0, 0, 0], [0.5, 0, 0]]))
    e = f.add_element(0, 1, FLAT)
    f.clamp(0)
    f.load(1, force=(0, 1.0, 0))
    sol = f.solve()
    np.testing.assert_allclose(sol.section_forces(e, 0.0), [0, 1.0, 0, 0, 0, 0.5], atol=1e-12)


# ----------------------------------------------------------------------------- base-excited cantilever
def test_cantilever_roots_and_sigmas_are_blevins():
    """Blevins, Table 8-1: beta_n L = 1.87510407, 4.69409113, 7.85475744, 10.99554073, 14.13716839;
    sigma_n = 0.734095514, 1.018467319, 0.999224497, 1.000033553, 0.999998550."""
    x = cantilever_roots(5)
    np.testing.assert_allclose(x, [1.87510407, 4.69409113, 7.85475744, 10.99554073, 14.13716839], atol=1e-8)
    np.testing.assert_allclose(mode_sigma(x), [0.734095514, 1.018467319, 0.999224497, 1.000033553, 0.999998550],
                               atol=2e-9)


@pytest.mark.parametrize("n", [1, 2, 3, 6])
def test_mode_shapes_are_mass_normalised_with_the_stated_participation_and_curvature(n):
    c = CASE
    phi = lambda x: float(c.mode_shape(n, x))                                        # noqa: E731
    mass = quad(lambda x: c.rho * c.A * phi(x) ** 2, 0, c.L, limit=200)[0]
    gamma = quad(lambda x: c.rho * c.A * phi(x), 0, c.L, limit=200)[0]
    x = cantilever_roots(n)[-1]
    assert mass == pytest.approx(1.0, rel=1e-9)
    assert gamma == pytest.approx(math.sqrt(c.rho * c.A * c.L) * 2 * mode_sigma(x) / x, rel=1e-8)
    h = 1e-4 * c.L                                   # phi''(0) by a one-sided 4th-order difference
    curvature = (2 * phi(0) - 5 * phi(h) + 4 * phi(2 * h) - phi(3 * h)) / h**2
    assert curvature == pytest.approx(2 * (x / c.L) ** 2 / math.sqrt(c.rho * c.A * c.L), rel=1e-5)
    # free end: no moment, no shear
    assert abs(float(c.mode_shape(n, c.L))) > 0


def test_static_series_sums_to_one():
    """sum s_n = 1: the root moment of the static inertia load; the tail after N ~ 8 / (2 pi^3 N^2)."""
    s = CASE.root_moment_shares(4000)
    assert math.fsum(s) == pytest.approx(1.0, abs=2 * 8 / (2 * math.pi**3 * 4000**2))


@pytest.mark.parametrize("ratio", [0.01, 0.3, 0.5, 0.9, 1.2, 2.0, 3.5, 6.0, 9.0, 12.0, 17.0, 30.0])
def test_undamped_modal_series_equals_the_krylov_closed_form(ratio):
    c = Cantilever(CASE.L, CASE.E, CASE.I, CASE.rho, CASE.A, zeta=0.0)
    w = ratio * c.natural_frequencies(1)[0]
    series = c.root_moment_transfer(w)[0]
    closed = c.undamped_root_moment_transfer(w)[0]
    assert series.imag == 0.0
    # the closed form's rounding: cosh z cos z cancels 1 near a pole; 1e-9 of the static moment covers both
    assert abs(series.real - closed) <= c.truncation_bound(w)[0] + 1e-9 * c.static_root_moment


def test_static_limit_and_sign():
    G = CASE.root_moment_transfer(1e-6)[0]
    assert G.real == pytest.approx(-CASE.static_root_moment, rel=1e-9)


@pytest.mark.parametrize("n_terms", [3, 5, 10, 40])
def test_truncation_bound_holds(n_terms):
    w = np.array([0.5, 1.0, 3.0]) * CASE.natural_frequencies(1)[0]
    full = CASE.root_moment_transfer(w, n_terms=3000)
    cut = CASE.root_moment_transfer(w, n_terms=n_terms)
    bound = CASE.truncation_bound(w, n_terms=n_terms)
    assert np.all(np.abs(full - cut) <= bound), (np.abs(full - cut), bound)


def test_damped_resonance_is_the_single_mode_peak():
    """At w = omega_n the n-th term dominates: G ~ -(rho A L^2 / 2) s_n / (2 i zeta) + the rest (small)."""
    omega = CASE.natural_frequencies(3)
    shares = CASE.root_moment_shares(3)
    for n in range(3):
        G = CASE.root_moment_transfer(omega[n])[0]
        peak = -CASE.static_root_moment * shares[n] / (2j * CASE.zeta)
        assert abs(G - peak) < 0.15 * abs(peak)


def test_case_csv_is_the_generator_output(tmp_path):
    from eb_base_excitation import CASE_CSV, write_case_csv
    fresh = tmp_path / "case.csv"
    write_case_csv(fresh)
    assert fresh.read_text() == CASE_CSV.read_text()


@pytest.mark.parametrize("n", [1, 2, 4])
def test_first_moment_of_each_mode_is_its_root_curvature_over_omega_squared(n):
    """int x rho A phi_n dx = EI phi_n''(0) / omega_n^2 = (rho A L^2 / 2) s_n / Gamma_n: the identity behind the
    reaction moment (10), by quadrature of the mode shape."""
    c = CASE
    first_moment = quad(lambda x: x * c.rho * c.A * float(c.mode_shape(n, x)), 0, c.L, limit=200)[0]
    x = cantilever_roots(n)[-1]
    gamma = math.sqrt(c.rho * c.A * c.L) * 2 * mode_sigma(x) / x
    assert first_moment == pytest.approx(c.static_root_moment * c.root_moment_shares(n)[-1] / gamma, rel=1e-8)


def test_reaction_equals_the_elastic_moment_without_damping_and_differs_by_the_damping_moment_with_it():
    w = np.array([0.5, 1.5, 8.0]) * CASE.natural_frequencies(1)[0]       # not on a pole of the undamped rod
    undamped = Cantilever(CASE.L, CASE.E, CASE.I, CASE.rho, CASE.A, zeta=0.0)
    np.testing.assert_allclose(undamped.root_reaction_transfer(w), undamped.root_moment_transfer(w), rtol=1e-12,
                               equal_nan=False)
    w = np.append(w, CASE.natural_frequencies(1)[0])                       # damped: the resonance too
    # with damping: the mode-n terms differ by the factor (1 + 2 i zeta w / omega_n), Eq. (10)
    omega = CASE.natural_frequencies()
    shares = CASE.root_moment_shares()
    H = 1.0 / (omega[None] ** 2 - w[:, None] ** 2 + 2j * CASE.zeta * omega[None] * w[:, None])
    damping_moment = -CASE.static_root_moment * np.sum(shares * omega**2 * H * 2j * CASE.zeta * w[:, None]
                                                       / omega, axis=1)
    np.testing.assert_allclose(CASE.root_reaction_transfer(w), CASE.root_moment_transfer(w) + damping_moment,
                               rtol=1e-12, equal_nan=False)


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_curvature_shape_is_the_mode_shapes_second_derivative(n):
    """psi_n(beta_n x) beta_n^2 / sqrt(rho A L) = phi_n''(x), by a central difference of mode_shape, along the rod;
    and its overflow-free form equals the direct one."""
    c = CASE
    z = cantilever_roots(n)[-1]
    b = z / c.L
    for x in (0.1, 0.25, 0.5, 0.8):
        h = 1e-4 * c.L
        fd = (float(c.mode_shape(n, x - h)) - 2 * float(c.mode_shape(n, x)) + float(c.mode_shape(n, x + h))) / h**2
        psi = float(mode_curvature_shape(np.array([z]), x / c.L)[0])
        assert psi * b**2 / math.sqrt(c.rho * c.A * c.L) == pytest.approx(fd, rel=1e-5, abs=1e-5 * b**2)
        s = mode_sigma(z)
        direct = math.cosh(b * x) + math.cos(b * x) - s * (math.sinh(b * x) + math.sin(b * x))
        assert psi == pytest.approx(direct, rel=1e-12, abs=1e-12 * math.cosh(b * x))


def test_curvature_shapes_stay_within_the_stated_bound():
    z = cantilever_roots(200)
    assert max(np.max(np.abs(mode_curvature_shape(z, xi))) for xi in np.linspace(0, 1, 501)) <= 4.43


@pytest.mark.parametrize("x", [0.0, 0.25, 0.5, 0.9, 1.0])
@pytest.mark.parametrize("ratio", [0.01, 0.5, 2.0, 3.5, 9.0, 12.0])
def test_undamped_moment_along_the_rod_equals_the_krylov_closed_form(x, ratio):
    c = Cantilever(CASE.L, CASE.E, CASE.I, CASE.rho, CASE.A, zeta=0.0)
    w = ratio * c.natural_frequencies(1)[0]
    series = c.moment_transfer(w, x)[0]
    closed = c.undamped_moment_transfer(w, x)[0]
    assert abs(series - closed) <= c.truncation_bound(w, x=x)[0] + 1e-9 * c.static_root_moment


def test_moment_along_the_rod_quasi_statically_and_at_the_ends():
    for x in (0.0, 0.3, 0.7, 1.0):
        G = CASE.moment_transfer(1e-3, x)[0]
        assert G.real == pytest.approx(-CASE.rho * CASE.A * (CASE.L - x) ** 2 / 2, rel=1e-7, abs=1e-12)
    w = np.array([0.5, 1.0, 6.0]) * CASE.natural_frequencies(1)[0]
    np.testing.assert_allclose(CASE.moment_transfer(w, 0.0), CASE.root_moment_transfer(w), rtol=1e-12)
    assert np.all(np.abs(CASE.moment_transfer(w, CASE.L)) < 1e-10 * CASE.static_root_moment)   # free end


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_shear_shape_is_the_curvature_shapes_derivative(n):
    """psi_n' = d psi_n / du by a central difference, and its overflow-free form equals the direct one."""
    z = cantilever_roots(n)[-1]
    s = mode_sigma(z)
    for xi in (0.0, 0.1, 0.5, 0.8, 1.0):
        u, h = z * xi, 1e-5
        fd = (float(mode_curvature_shape(np.array([z]), (u + h) / z)[0])
              - float(mode_curvature_shape(np.array([z]), (u - h) / z)[0])) / (2 * h)
        got = float(mode_shear_shape(np.array([z]), xi)[0])
        assert got == pytest.approx(fd, abs=1e-8 * math.cosh(u))
        direct = math.sinh(u) - math.sin(u) - s * (math.cosh(u) + math.cos(u))
        assert got == pytest.approx(direct, abs=1e-12 * math.cosh(u))
    roots = cantilever_roots(200)
    assert max(np.max(np.abs(mode_shear_shape(roots, xi))) for xi in np.linspace(0, 1, 501)) <= 4.43


@pytest.mark.parametrize("x", [0.0, 0.25, 0.5, 1.0])
@pytest.mark.parametrize("ratio", [0.01, 0.5, 2.0, 3.5, 9.0, 12.0])
def test_undamped_shear_along_the_rod_equals_the_krylov_closed_form(x, ratio):
    c = Cantilever(CASE.L, CASE.E, CASE.I, CASE.rho, CASE.A, zeta=0.0)
    w = ratio * c.natural_frequencies(1)[0]
    series = c.shear_transfer(w, x)[0]
    closed = c.undamped_shear_transfer(w, x)[0]
    assert abs(series - closed) <= c.shear_truncation_bound(w)[0] + 1e-9 * c.rho * c.A * c.L


def test_shear_is_minus_the_moments_slope_and_the_inertia_load_beyond_quasi_statically():
    """V = -dM/dx (Eq. 13) between the two independent series, damped; V -> -rho A (L - x) as w -> 0."""
    w = np.array([0.5, 1.0, 6.3]) * CASE.natural_frequencies(1)[0]
    for x in (0.2, 0.5):
        h = 1e-4
        slope = (CASE.moment_transfer(w, x + h, 2000) - CASE.moment_transfer(w, x - h, 2000)) / (2 * h)
        np.testing.assert_allclose(CASE.shear_transfer(w, x, 2000), -slope, rtol=1e-6)
        assert CASE.shear_transfer(1e-3, x)[0].real == pytest.approx(-CASE.rho * CASE.A * (CASE.L - x), rel=1e-7)
