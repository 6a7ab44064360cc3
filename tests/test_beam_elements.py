"""Beam element types (flexfmu.ffr.elements): the Timoshenko element against the analytic Timoshenko beam and in
its Euler-Bernoulli limit, each element's matrices against its own interpolation, and the element registry."""
import json

import numpy as np
import pytest

from conftest import STEEL, straight_rod
from error_bounds import gamma
from flexfmu.errors import ParameterError
from flexfmu.ffr import elements
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.ffr.dynamics import BaseMotion, FFRBeamDynamics
from flexfmu.ffr.elements import EulerBernoulliElement, TimoshenkoElement, get_element, register
from flexfmu.ffr.elements.timoshenko import shear_coefficient, shear_parameters
from flexfmu.ffr.geometric_stiffness import inertial_geometric_stiffness
from flexfmu.ffr.kinematics import point_shape
from flexfmu.ffr.report import modal_analysis
from flexfmu.ffr.scene import load_scene, scene_from_dict
from flexfmu.linalg.modal import solve_modes

ELEMENT_NAMES = ("euler_bernoulli", "timoshenko")


def _section_material(scene):
    return scene.section, scene.material


def simply_supported_omega(scene, n_el: int, n_modes: int = 3) -> np.ndarray:
    """Lowest bending frequencies (rad/s) in the x-y plane of a straight rod along X, hinged at both ends.

    For a rod along X every element's axes are the body axes (Eq. 8 with cx = 1: C = I), and the x-y bending DOFs
    (v, theta_z) of the assembled free-free matrices couple to no other DOF; a hinge fixes v and leaves theta_z
    free."""
    model = build_beam_model(scene, "free", n_el)
    n = model.mesh.n_nodes
    dofs = np.array([6 * i + j for i in range(n) for j in (1, 5) if not (j == 1 and i in (0, n - 1))])
    K = model.K[dofs][:, dofs]
    M = model.M[dofs][:, dofs]
    return solve_modes(K, M, n_modes, method="dense").omega


def timoshenko_simply_supported_omega(scene, n: int) -> float:
    """Mode n of the hinged-hinged Timoshenko beam (bending about z).  Timoshenko's equations
        rho A v_tt = k G A (v'' - psi'),   rho I psi_tt = E I psi'' + k G A (v' - psi)
    (Timoshenko, Phil. Mag. 41 (1921) 744; Han, Benaroya & Wei, J. Sound Vib. 225 (1999) 935, hinged-hinged case)
    with v = V sin(a x), psi = Psi cos(a x), a = n pi / L, give the frequency equation
        rho A rho I w^4 - (k G A rho I a^2 + rho A E I a^2 + rho A k G A) w^2 + k G A E I a^4 = 0,
    whose smaller root is the bending mode."""
    sec, mat = _section_material(scene)
    kGA = shear_coefficient(sec, mat) * mat.G * sec.A
    EI, rhoA, rhoI = mat.E * sec.Iz, mat.rho * sec.A, mat.rho * sec.Iz
    a = n * np.pi / scene.total_length
    p, q, r = rhoA * rhoI, kGA * rhoI * a**2 + rhoA * EI * a**2 + rhoA * kGA, kGA * EI * a**4
    return float(np.sqrt(2 * r / (q + np.sqrt(q * q - 4 * p * r))))     # the smaller root, without cancellation


def euler_bernoulli_simply_supported_omega(scene, n: int) -> float:
    sec, mat = _section_material(scene)
    return float((n * np.pi / scene.total_length) ** 2 * np.sqrt(mat.E * sec.Iz / (mat.rho * sec.A)))


# ---------------------------------------------------------------- (a) the analytic Timoshenko beam
def test_timoshenko_simply_supported_frequencies_converge_to_the_analytic_ones_at_rate_two():
    scene = straight_rod(length=1.0, diameter=0.2, element="timoshenko")     # L/d = 5: shear matters (~4 %)
    exact = np.array([timoshenko_simply_supported_omega(scene, n) for n in (1, 2, 3)])
    eb = np.array([euler_bernoulli_simply_supported_omega(scene, n) for n in (1, 2, 3)])
    assert np.all(exact < 0.96 * eb)          # a case the Euler-Bernoulli frequencies would fail
    meshes = (8, 16, 32, 64)
    errors = np.array([simply_supported_omega(scene, n) / exact - 1 for n in meshes])
    # A conforming element with consistent mass is a Rayleigh-Ritz method: its frequencies bound the exact ones
    # from above (the errors here are >= 1e-6, far above the solver's round-off).
    assert np.all(errors > 0)
    # Asymptotic order 2, not the Euler-Bernoulli element's 4: the shear strain v' - psi of the element is
    # constant, while the shear force of a vibration mode varies along it, so the shear energy's error is O(h^2)
    # (the bending part, psi' linear, is O(h^4)).  The observed order approaches 2 as the mesh is refined.
    order = np.log2(errors[:-1] / errors[1:])
    assert np.all(np.abs(order[1] - 2) <= 0.1)            # 16 -> 32 elements
    assert np.all(np.abs(order[2] - 2) <= 0.05)           # 32 -> 64 elements
    assert np.all(np.abs(order[2] - 2) < np.abs(order[1] - 2))
    # The h^2 term is the whole asymptotic error: Richardson extrapolation with order 2 from 32 and 64 elements
    # leaves a remainder of higher order, well below the 64-element error.
    extrapolated = errors[3] - (errors[2] - errors[3]) / 3
    assert np.all(np.abs(extrapolated) <= np.abs(errors[3]) / 20)


def test_timoshenko_cantilever_static_deflection_is_exact_between_nodes():
    """The element's displacement functions are the exact static deflection under end loads, so a tip-loaded
    cantilever is exact at any point, not only at nodes: v(x) = P x^2 (3L - x) / (6 E I) + P x / (k G A) and the
    section rotation P (2 L x - x^2) / (2 E I) (shear does not turn the sections); likewise in the x-z plane."""
    L, P = 1.0, 1000.0
    scene = scene_from_dict({"points": [[0, 0, 0], [L, 0, 0]], "section": {"shape": "rectangle", "width": 0.1,
                             "height": 0.2}, "material": dict(STEEL), "element": "timoshenko"})
    sec, mat = _section_material(scene)
    kGA = shear_coefficient(sec, mat) * mat.G * sec.A
    model = build_beam_model(scene, "XFF", 3)
    F = point_shape(model.mesh, L).full_translation(model.n_dof).T @ np.array([0.0, P, P / 3])
    K = model.K_free.toarray()
    q = model.B2 @ np.linalg.solve(K, model.B2.T @ F)
    # LU with partial pivoting of the SPD K: relative error of q <= cond(K) gamma(3 n) [ASNA Thm 9.4, growth ~1];
    # the interpolation (<= 40 roundings on terms of the size of the result) and the formulas above add gamma(40).
    bound = np.linalg.cond(K) * gamma(3 * K.shape[0]) + gamma(40)
    for x in (0.13, 0.5, 0.77, 1.0):
        ps = point_shape(model.mesh, x)
        u, rot = ps.displacement_body(q), ps.rotation_body(q)
        for Py, I_bend, v, theta in ((P, sec.Iz, u[1], rot[2]), (P / 3, sec.Iy, u[2], -rot[1])):
            v_exact = Py * x**2 * (3 * L - x) / (6 * mat.E * I_bend) + Py * x / kGA
            assert v == pytest.approx(v_exact, rel=bound)
            assert theta == pytest.approx(Py * (2 * L * x - x**2) / (2 * mat.E * I_bend), rel=bound)


# ---------------------------------------------------------------- (b) the Euler-Bernoulli limit
def test_timoshenko_frequencies_approach_the_euler_bernoulli_ones_as_the_shear_parameter_vanishes():
    """With x = (n pi r / L)^2 (r^2 = I / A) and beta = E / (k G), the frequency equation above divided by the
    Euler-Bernoulli eigenvalue reads beta x^2 W^2 - (1 + x (1 + beta)) W + 1 = 0, W = (w / w_EB)^2; it is
    positive at W = 1 - x (1 + beta) and negative at W = 1, so 1 - x (1 + beta) < W < 1: the Timoshenko
    frequencies lie below the Euler-Bernoulli ones by at most x (1 + beta) = O((r / L)^2) = O(Phi)."""
    n_el, modes = 64, np.array([1, 2, 3])
    gaps = {}
    for slenderness in (10, 100, 1000):
        timo = straight_rod(length=1.0, diameter=1.0 / slenderness, element="timoshenko")
        euler = straight_rod(length=1.0, diameter=1.0 / slenderness)
        sec, mat = _section_material(timo)
        eb_exact = np.array([euler_bernoulli_simply_supported_omega(timo, n) for n in modes])
        e_timo = simply_supported_omega(timo, n_el) / eb_exact - 1
        e_euler = simply_supported_omega(euler, n_el) / eb_exact - 1     # > 0: Rayleigh-Ritz
        x = (modes * np.pi) ** 2 * sec.Iz / sec.A / timo.total_length**2
        beta = mat.E / (shear_coefficient(sec, mat) * mat.G)
        # Below: the Ritz bound (FE above the exact Timoshenko frequency) and 1 - x (1 + beta) < W.  Above: the
        # Euler-Bernoulli element on the same mesh; its own error (~(k h)^4 / 1440 <= 4e-7 here) -> 0 with h.
        assert np.all(-x * (1 + beta) < e_timo)
        assert np.all(e_timo < e_euler)
        gaps[slenderness] = e_timo
    # The gap vanishes as (r / L)^2: order 2 in the slenderness (mode 1; the next term is O((r / L)^4), and the
    # discretisation error, 4e-9 here, is 0.3 % of the gap at L / d = 1000).
    assert np.log10(gaps[100][0] / gaps[1000][0]) == pytest.approx(2.0, abs=0.02)


def test_timoshenko_element_matrices_tend_to_euler_bernoulli_ones_linearly_in_phi():
    """At Phi = 0 the Timoshenko stiffness is the Euler-Bernoulli one and its mass the Euler-Bernoulli mass with
    rotary inertia.  Stiffness entries differ by factors 1 / (1 + Phi), (4 + Phi) / (4 (1 + Phi)) and
    (2 - Phi) / (2 (1 + Phi)): at most 2 Phi relative.  Mass coefficients have Phi-derivatives at 0 of at most 7
    times their value (r12: 1/10 - Phi/2 over (1 + Phi)^2): within 8 Phi for Phi <= 1e-2."""
    euler, timo = EulerBernoulliElement(), TimoshenkoElement()
    L = np.array([0.3, 0.5])
    for diameter in (1e-2, 1e-3, 1e-4):
        scene = straight_rod(length=1.0, diameter=diameter)
        sec, mat = _section_material(scene)
        phi = max(float(np.max(p)) for p in shear_parameters(L, sec, mat))
        assert phi <= 1e-2
        K_e, K_t = euler.stiffness(L, sec, mat), timo.stiffness(L, sec, mat)
        assert np.all(np.abs(K_t - K_e) <= (2 * phi + gamma(20)) * np.abs(K_e))
        M_e, M_t = euler.mass(L, sec, mat, rotary_inertia=True), timo.mass(L, sec, mat)
        assert np.all(np.abs(M_t - M_e) <= (8 * phi + gamma(20)) * np.abs(M_e))


# ---------------------------------------------------------------- each element's matrices and interpolation
def _quadrature_matrices(element, L, sec, mat):
    """K and M in element axes from the element's interpolation: kinetic energy of the centre line and the section
    rotations, strain energy of extension, torsion, bending (section rotations) and shear (slope minus rotation).
    6 Gauss points integrate the degree <= 6 polynomials exactly; the rotation derivatives (quadratic rows) are
    exact central differences."""
    kGA = shear_coefficient(sec, mat) * mat.G * sec.A if isinstance(element, TimoshenkoElement) else 0.0
    K, M, delta = np.zeros((12, 12)), np.zeros((12, 12)), 1e-3
    for xg, wg in zip(*np.polynomial.legendre.leggauss(6)):
        xi, w = 0.5 * (xg + 1), 0.5 * wg * L
        S = element.shape_functions(xi, L, sec, mat)
        dS = (element.shape_functions(xi + delta, L, sec, mat) - element.shape_functions(xi - delta, L, sec, mat))
        dS /= 2 * delta * L
        dv, dw, _ = element.strain_gradients(xi, L, sec, mat)
        M += w * mat.rho * (sec.A * S[:3].T @ S[:3] + sec.Ip * np.outer(S[3], S[3]) + sec.Iy * np.outer(S[4], S[4])
                            + sec.Iz * np.outer(S[5], S[5]))
        K += w * (mat.E * sec.A * np.outer(dS[0], dS[0]) + mat.G * sec.J * np.outer(dS[3], dS[3])
                  + mat.E * sec.Iy * np.outer(dS[4], dS[4]) + mat.E * sec.Iz * np.outer(dS[5], dS[5]))
        if kGA:
            K += w * kGA * (np.outer(dv - S[5], dv - S[5]) + np.outer(dw + S[4], dw + S[4]))
    return K, M


@pytest.mark.parametrize("name", ELEMENT_NAMES)
def test_element_matrices_are_the_energies_of_its_interpolation(name):
    """The stiffness and mass an element gives are those of the interpolation that kinematics, loads and the
    inertia integrals use (Euler-Bernoulli: with rotary inertia).  1e-10 of each block's scale is far above the
    rounding (~1e-13 with the differences' 1e-3 step) and far below any wrong coefficient."""
    element = get_element(name)
    scene = scene_from_dict({"points": [[0, 0, 0], [1, 0, 0]], "material": dict(STEEL), "element": name,
                             "section": {"shape": "rectangle", "width": 0.05, "height": 0.12}})
    sec, mat = _section_material(scene)
    L = 0.37                                        # Phi ~ 0.3 and 0.04 in the two planes
    K_q, M_q = _quadrature_matrices(element, L, sec, mat)
    K = element.stiffness([L], sec, mat)[0]
    M = element.mass([L], sec, mat, rotary_inertia=True)[0]
    scale = np.array([1, 1, 1, 1, L, L] * 2)           # translations vs rotations
    for A, B in ((K, K_q), (M, M_q)):
        Ad, Bd = A * np.outer(scale, scale), B * np.outer(scale, scale)
        assert np.abs(Ad - Bd).max() <= 1e-10 * np.abs(Ad).max()


@pytest.mark.parametrize("name", ELEMENT_NAMES)
def test_strain_gradients_are_the_derivatives_of_the_interpolated_deflection(name):
    """dv/dx and dw/dx (what the geometric stiffness uses) against a 5-point difference of the cubic deflections
    (exact for polynomials up to degree 4; rounding ~ u |S| / delta ~ 1e-13)."""
    element = get_element(name)
    scene = straight_rod(length=1.0, diameter=0.1, element=name)
    sec, mat = _section_material(scene)
    L, d = 0.25, 1e-3
    for xi in (0.0, 0.3, 0.8, 1.0):
        S = [element.shape_functions(xi + k * d, L, sec, mat) for k in (-2, -1, 1, 2)]
        dS = (S[0] - 8 * S[1] + 8 * S[2] - S[3]) / (12 * d * L)
        G = element.strain_gradients(xi, L, sec, mat)
        np.testing.assert_allclose(G[0], dS[1], rtol=0, atol=1e-10 * np.abs(G[0]).max())
        np.testing.assert_allclose(G[1], dS[2], rtol=0, atol=1e-10 * np.abs(G[1]).max())
        np.testing.assert_allclose(G[2], dS[3], rtol=0, atol=1e-10 * np.abs(G[2]).max())


def test_cowper_shear_coefficients():
    """Cowper (1966): circle 6(1+nu)/(7+6nu), rectangle 10(1+nu)/(12+11nu), a tube between the circle
    (di -> 0) and the thin-walled tube 2(1+nu)/(4+3nu) (di -> do); a given coefficient overrides them."""
    def section(**s):
        return scene_from_dict({"points": [[0, 0, 0], [1, 0, 0]], "section": s, "material": dict(STEEL)}).section

    class Nu:
        nu = 0.3
    # the formulas against the values at nu = 0.3: <= 4 roundings on each side, all terms positive
    assert shear_coefficient(section(shape="circle", diameter=0.1), Nu) == pytest.approx(7.8 / 8.8, rel=gamma(8))
    assert shear_coefficient(section(shape="rectangle", width=0.1, height=0.3), Nu) == pytest.approx(13 / 15.3,
                                                                                                     rel=gamma(8))
    # the tube's di/do comes back from A and I: rounding of (16 I / A - 4 A / pi) cancels to ~1e-15 absolute
    assert shear_coefficient(section(shape="tube", outer_diameter=0.1, inner_diameter=0.0), Nu) == pytest.approx(
        7.8 / 8.8, abs=1e-13)
    thin = shear_coefficient(section(shape="tube", outer_diameter=0.1, inner_diameter=0.0999), Nu)
    assert thin == pytest.approx(2.6 / 4.9, abs=1e-5)           # 1 - m = 1e-3: O((1 - m)^2) from the limit
    assert shear_coefficient(section(shape="circle", diameter=0.1, shear_coefficient=0.5), Nu) == 0.5


def test_geometric_stiffness_and_dynamics_run_with_the_timoshenko_element():
    """A slender spinning cantilever: the axial prestress is the same for both elements (it is axial), and the
    Timoshenko geometric stiffness differs from the Euler-Bernoulli one through v' only, by O(Phi)."""
    n_el = 8
    mats = {}
    for name in ELEMENT_NAMES:
        model = build_beam_model(straight_rod(length=1.0, diameter=0.01, element=name), "XFF", n_el)
        mats[name] = inertial_geometric_stiffness(model)
    sec, mat = _section_material(straight_rod())
    phi = max(float(np.max(p)) for p in shear_parameters(np.array([1.0 / n_el]), sec, mat))
    e, t = mats["euler_bernoulli"], mats["timoshenko"]
    assert np.abs(t.axial_force - e.axial_force).max() <= 1e-9 * np.abs(e.axial_force).max()
    X = np.array([[-1.0, 0, 0], [0, 0, 0], [0, 0, -1.0]])      # omega = e_y: X = [w]x^2
    G_e, G_t = e.combine(X).toarray(), t.combine(X).toarray()
    # Each entry of the v', w' rows moves by at most Phi max|v'| (the Phi terms of (T1) over 1 + Phi), so each
    # product v'^T v' by at most (2 Phi + Phi^2) max|v'|^2; 4 Phi leaves a factor 2 for sums over elements.
    assert 0 < np.abs(G_t - G_e).max() <= 4 * phi * np.abs(G_e).max()


def test_moving_base_dynamics_with_the_timoshenko_element_settle_on_the_exact_static_deflection():
    """A Timoshenko cantilever whose base accelerates uniformly carries the d'Alembert load q = -rho A a0 per unit
    length; its tip deflects q L^4 / (8 E I) + q L^2 / (2 k G A).  The element's shape functions hold the exact
    homogeneous solutions, so with consistent loads (the inertia integrals) the nodal values are exact (Tong,
    AIAA J. 7 (1969) 178); with every mode retained, the modal static response is K^-1 f up to the eigen
    solver's error."""
    L, g = 1.0, 9.81
    scene = scene_from_dict({"points": [[0, 0, 0], [L, 0, 0]], "section": {"shape": "rectangle", "width": 0.1,
                             "height": 0.2}, "material": dict(STEEL), "element": "timoshenko"})
    sec, mat = _section_material(scene)
    model = build_beam_model(scene, "XFF", 4)
    modes = solve_modes(model.K_free, model.M_free, model.n_free)
    dynamics = FFRBeamDynamics(model, modes, 0.0, load_s=L, sensor_s=L)
    state = dynamics.static_response(np.zeros(3), np.zeros(3), BaseMotion(a0=np.array([0.0, g, 0.0])))
    q = -mat.rho * sec.A * g
    exact = q * L**4 / (8 * mat.E * sec.Iz) + q * L**2 / (2 * shear_coefficient(sec, mat) * mat.G * sec.A)
    assert dynamics.tip_displacement(state)[1] == pytest.approx(exact, rel=1e-8)
    # the shear part is 4 % of it here: the Euler-Bernoulli deflection alone would fail
    assert abs(exact - q * L**4 / (8 * mat.E * sec.Iz)) > 0.03 * abs(exact)


# ---------------------------------------------------------------- (c) the registry and the scene field
def test_the_default_element_is_euler_bernoulli():
    scene = load_scene("spatial_double_L")
    assert scene.element == "euler_bernoulli"
    assert isinstance(build_beam_model(scene, "XFF", 1).mesh.element, EulerBernoulliElement)
    assert elements.element_names()[:2] == ELEMENT_NAMES


@pytest.mark.parametrize("value", ["rayleigh", "Timoshenko", "", 3, None, ["timoshenko"]])
def test_an_unknown_element_is_a_parameter_error_naming_the_allowed_ones(value):
    with pytest.raises(ParameterError) as exc:
        straight_rod(element=value)
    assert exc.value.parameter == "element"
    assert all(name in exc.value.allowed for name in ELEMENT_NAMES)


def test_an_unknown_element_in_a_scene_file_names_the_field(tmp_path):
    path = tmp_path / "rod.json"
    path.write_text(json.dumps({"points": [[0, 0, 0], [1, 0, 0]], "section": {"shape": "circle", "diameter": 0.01},
                                "material": STEEL, "element": "timoshenko_beam"}), encoding="utf-8")
    with pytest.raises(ParameterError, match="element: unknown element 'timoshenko_beam'") as exc:
        load_scene(path)
    assert "euler_bernoulli | timoshenko" in exc.value.allowed


def test_shear_coefficient_rules():
    generic = {"A": 1e-4, "Iy": 1e-9, "Iz": 2e-9, "J": 3e-9}
    scene = scene_from_dict({"points": [[0, 0, 0], [1, 0, 0]], "section": generic, "material": dict(STEEL),
                             "element": "timoshenko"})
    with pytest.raises(ParameterError) as exc:                    # a generic section has no Cowper value
        build_beam_model(scene, "XFF", 2)
    assert exc.value.parameter == "section.shear_coefficient"
    for bad in (0, -0.5, 1.2, "0.8", None, float("nan")):          # k, not the form factor 1 / k
        with pytest.raises(ParameterError) as exc:
            scene_from_dict({"points": [[0, 0, 0], [1, 0, 0]], "material": dict(STEEL),
                             "section": {**generic, "shear_coefficient": bad}})
        assert exc.value.parameter == "section.shear_coefficient"
    given = scene_from_dict({"points": [[0, 0, 0], [1, 0, 0]], "material": dict(STEEL), "element": "timoshenko",
                             "section": {**generic, "shear_coefficient": 0.6}})
    assert given.section.shear_coefficient == 0.6
    build_beam_model(given, "XFF", 2)


# ---------------------------------------------------------------- (d) a new element is one register call
class _StifferByFour(EulerBernoulliElement):
    """A test element: four times the Euler-Bernoulli stiffness, so every frequency doubles."""

    name = "test_stiffer_by_four"

    def stiffness(self, L, section, material):
        return 4.0 * super().stiffness(L, section, material)


@pytest.fixture
def registry(monkeypatch):
    """The element registry, restored after the test."""
    monkeypatch.setattr(elements, "ELEMENTS", dict(elements.ELEMENTS))
    return elements


def test_registering_an_element_is_one_call_and_a_scene_then_selects_it(registry):
    assert register(_StifferByFour) is _StifferByFour
    scene = straight_rod(element="test_stiffer_by_four")
    ours = modal_analysis(scene, "XFF", n_modes=6, elements_per_segment=8).modes.frequencies_hz
    reference = modal_analysis(straight_rod(), "XFF", n_modes=6, elements_per_segment=8).modes.frequencies_hz
    # K times 4 (a power of two: exact) doubles every frequency; the dense solver keeps the low modes to ~1e-13
    np.testing.assert_allclose(ours, 2 * reference, rtol=1e-10)
    with pytest.raises(ParameterError) as exc:
        straight_rod(element="nope")
    assert "test_stiffer_by_four" in exc.value.allowed


def test_register_refuses_what_is_not_an_element(registry):
    with pytest.raises(TypeError):
        register(object)

    class Same(EulerBernoulliElement):
        name = "timoshenko"
    with pytest.raises(ValueError, match="already registered"):
        register(Same)

    class ThreeNodes(EulerBernoulliElement):
        name = "test_three_nodes"
        nodes_per_element = 3
    with pytest.raises(ValueError, match="2 nodes x 6 DOFs"):
        register(ThreeNodes)
    assert "test_three_nodes" not in registry.ELEMENTS


def test_the_automatic_mesh_extrapolates_with_the_elements_own_order():
    """The mesh choice estimates each mesh's error by Richardson extrapolation of two meshes, which needs the
    element's convergence order: 4 for Euler-Bernoulli, 2 for Timoshenko (measured above).  With the element's
    order the chosen mesh's frequencies below f_max are within the tolerance (a cantilever, L/d = 5)."""
    from flexfmu.ffr.mesh_choice import choose_elements_per_segment
    scene = straight_rod(length=1.0, diameter=0.2, element="timoshenko", clamps=[0.0])
    tolerance = 1e-3
    f_max = 3000.0
    choice = choose_elements_per_segment(scene, "scene", f_max, tolerance)
    assert choice.order == get_element("timoshenko").convergence_order == 2
    eb_choice = choose_elements_per_segment(straight_rod(length=1.0, diameter=0.2, clamps=[0.0]), "scene", f_max, tolerance)
    assert eb_choice.order == 4
    # the clamped rod's modes below f_max: the chosen mesh against one 16 x finer of the same element (error O(h^2):
    # the finer mesh keeps 1/256 of the chosen mesh's error, so the difference is the chosen mesh's error to 0.4 %)
    from flexfmu.ffr.mesh_choice import mesh_frequencies
    solve = mesh_frequencies(scene, "scene", ())
    chosen_hz, _ = solve(choice.elements_per_segment, 12)
    reference_hz, _ = solve(16 * choice.elements_per_segment, 12)
    k = int(np.count_nonzero(reference_hz < f_max))
    assert k >= 1
    true_errors = np.abs(chosen_hz[:k] - reference_hz[:k]) / reference_hz[:k]
    assert np.all(true_errors <= tolerance), (choice.elements_per_segment, true_errors)
