"""Straight rods against analytic Euler-Bernoulli frequencies; h^4 convergence; invariance."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import STEEL, straight_rod
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.linalg.modal import solve_modes
from flexfmu.ffr.scene import load_scene, scene_from_dict

# beta_n L of the first three bending modes (Blevins, Formulas for Natural Frequency, Table 8-1)
BETA_L = {
    "cantilever": [1.875104069, 4.694091133, 7.854757438],
    "free-free": [4.730040745, 7.853204624, 10.99560784],
    "clamped-clamped": [4.730040745, 7.853204624, 10.99560784],
}
BOUNDARY = {"cantilever": "XFF", "free-free": "free", "clamped-clamped": "XFX"}


def analytic_bending_hz(case, length=1.0, diameter=0.01):
    A = np.pi * diameter**2 / 4
    I = np.pi * diameter**4 / 64
    c = np.sqrt(STEEL["E"] * I / (STEEL["rho"] * A)) / length**2
    return np.array(BETA_L[case]) ** 2 * c / (2 * np.pi)


def bending_frequencies(case, n_el, direction=(1.0, 0.0, 0.0)):
    """Computed frequencies closest to the three analytic bending ones (each appears twice for a circle)."""
    model = build_beam_model(straight_rod(direction=direction), BOUNDARY[case], n_el)
    f = solve_modes(model.K_free, model.M_free, min(20, model.n_free)).frequencies_hz
    exact = analytic_bending_hz(case)
    return np.array([f[np.argmin(np.abs(f - fe))] for fe in exact]), exact, f


@pytest.mark.parametrize("case", list(BETA_L))
def test_first_three_bending_frequencies_within_0p1_percent_at_16_elements(case):
    ours, exact, all_f = bending_frequencies(case, 16)
    np.testing.assert_allclose(ours, exact, rtol=1e-3)
    # a circular rod bends alike in both planes: every bending frequency appears twice
    for fe in ours:
        assert np.sum(np.abs(all_f - fe) < 1e-6 * fe) == 2


@pytest.mark.parametrize("case", list(BETA_L))
def test_frequency_error_falls_like_h4(case):
    meshes = [8, 16, 32]
    errors = []
    for n in meshes:
        ours, exact, _ = bending_frequencies(case, n)
        errors.append(abs(ours[2] - exact[2]) / exact[2])   # third mode: far from round-off
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    print(f"{case}: errors {errors}, rates {rates}")
    assert np.all((rates > 3.5) & (rates < 4.5)), rates


def _transform(points, rotation, shift):
    return (rotation.apply(np.asarray(points)) + shift).tolist()


@pytest.mark.parametrize("boundary", ["XFF", "FXF", "free"])
def test_rotated_and_translated_structure_has_same_frequencies(boundary, rng):
    base = load_scene("spatial_double_L")
    raw = {"name": "moved", "section": {"shape": "circle", "diameter": 0.008}, "material": dict(STEEL)}
    f_ref = None
    for k in range(4):
        rot = Rotation.random(random_state=int(rng.integers(1 << 30))) if k else Rotation.identity()
        shift = rng.normal(size=3) * 10 if k else np.zeros(3)
        scene = scene_from_dict({**raw, "points": _transform(base.points, rot, shift)})
        model = build_beam_model(scene, boundary, 4)
        f = solve_modes(model.K_free, model.M_free, 12).frequencies_hz
        elastic = f[6:] if boundary == "free" else f
        if f_ref is None:
            f_ref = elastic
        else:
            np.testing.assert_allclose(elastic, f_ref, rtol=1e-9)


def test_rectangular_section_invariant_under_rotation_about_body_y(rng):
    """The section-axis rule references body Y, so rotations about Y (and translations) keep frequencies."""
    base = load_scene("inclined_beam")
    raw = {"name": "moved", "section": {"shape": "rectangle", "width": 0.02, "height": 0.005},
           "material": dict(STEEL)}
    freqs = []
    for angle in [0.0, 0.7, 2.9, -1.3]:
        rot = Rotation.from_rotvec([0.0, angle, 0.0])
        scene = scene_from_dict({**raw, "points": _transform(base.points, rot, rng.normal(size=3))})
        model = build_beam_model(scene, "XFF", 4)
        freqs.append(solve_modes(model.K_free, model.M_free, 8).frequencies_hz)
    for f in freqs[1:]:
        np.testing.assert_allclose(f, freqs[0], rtol=1e-9)


def test_rectangle_bends_about_its_weak_axis_first():
    """Horizontal cantilever 20 mm wide x 5 mm high: first mode vertical (weak axis), ratio = width/height."""
    scene = scene_from_dict({"name": "bar", "points": [[0, 0, 0], [1.0, 0, 0]],
                             "section": {"shape": "rectangle", "width": 0.02, "height": 0.005},
                             "material": dict(STEEL)})
    model = build_beam_model(scene, "XFF", 16)
    modes = solve_modes(model.K_free, model.M_free, 2)
    f = modes.frequencies_hz
    A, I_weak = 0.02 * 0.005, 0.02 * 0.005**3 / 12
    f_exact = 1.875104069**2 * np.sqrt(STEEL["E"] * I_weak / (STEEL["rho"] * A)) / (2 * np.pi)
    assert f[0] == pytest.approx(f_exact, rel=1e-4)
    assert f[1] / f[0] == pytest.approx(0.02 / 0.005, rel=1e-4)
    tip_dofs = model.B2[6 * (model.mesh.n_nodes - 1):6 * model.mesh.n_nodes, :] @ modes.shapes[:, 0]
    assert abs(tip_dofs[1]) > 1e3 * max(abs(tip_dofs[0]), abs(tip_dofs[2]))   # moves along body Y


def test_dense_and_sparse_solvers_agree():
    model = build_beam_model(load_scene("spatial_double_L"), "free", 12)
    dense = solve_modes(model.K_free, model.M_free, 14, method="dense")
    sparse = solve_modes(model.K_free, model.M_free, 14, method="sparse")
    assert dense.method == "dense" and sparse.method == "sparse"
    np.testing.assert_allclose(sparse.frequencies_hz[6:], dense.frequencies_hz[6:], rtol=1e-9)
    M = model.M_free.toarray()
    for modes in (dense, sparse):
        np.testing.assert_allclose(modes.shapes.T @ M @ modes.shapes, np.eye(14), atol=1e-9)


def test_free_structure_has_six_rigid_body_modes_at_zero():
    model = build_beam_model(load_scene("spatial_double_L"), "scene", 8)   # the scene has no clamps
    f = solve_modes(model.K_free, model.M_free, 8).frequencies_hz
    assert np.all(f[:6] < 1e-4 * f[6])
    assert f[6] > 100.0


@pytest.mark.parametrize("n_modes", [1, 3, 6])
def test_free_structure_asked_only_for_rigid_modes(n_modes):
    """A free-free structure asked for at most its 6 rigid-body modes: 0 Hz (round-off), converged at once
    (the shift of the inverted eigenproblem is scaled by the first elastic mode, not by round-off)."""
    from flexfmu.ffr.report import modal_analysis
    from flexfmu.ffr.scene import load_scene
    result = modal_analysis(load_scene("spatial_double_L"), "free", n_modes=n_modes)
    assert result.converged and result.modes.frequencies_hz.shape == (n_modes,)
    assert np.all(result.modes.frequencies_hz < 1e-2), result.modes.frequencies_hz   # the first elastic: 148 Hz
