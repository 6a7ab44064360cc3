"""FFRBeam's strain gauges (gauge_K_s; gauge_K_N .. _Mz, _sigma_max, _von_mises) against independent references,
tests/reference/beam_sections (no flexfmu code in them; their own checks: tests/test_beam_section_references.py).

a) Static: spatial double-L (and the flat-bar inclined beam), a constant load at rest, gauges mid-segment, at and
   near the corners, at the root and the tip, clamped at one end (statically determinate) and at both (indeterminate:
   the section forces then depend on the stiffnesses), against the 3D frame solver beam_frame3d: 1e-6 relative to
   the largest component of the compared force or moment triple; the stresses against N/A + M c/I and T c/J.
b) Dynamic: a straight 1 m cantilever shaken sideways at its clamp, a0 sin(w t) through base_a_y (and base_a_z), run
   to steady state with the exact integrator; the bending moment of gauges at the root, a quarter and mid-span
   (amplitude and phase, fitted over the last whole periods) against the closed-form Euler-Bernoulli moment with the
   same modal damping (eb_base_excitation), within 1 % at w / w1 = 0.5 .. 17.5: below, at and between the first three
   resonances; the shear force at the root likewise.  The shear at the interior gauges misses the damping load of
   the element after the cut (O(h), up to 3 % here): test_interior_gauge_shear_matches_the_closed_form, an
   expected failure until the gauges include it.  The same runs check reaction_M against the clamp's d'Alembert
   reaction (eb_base_excitation Eq. 10), which also balances the damping forces.
"""
import json
import math
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent / "reference" / "beam_sections"))
from beam_frame3d import FrameSection, PolylineFrame, section_forces_at  # noqa: E402
from eb_base_excitation import (CASE, DEFAULT_TERMS, cantilever_roots, mode_curvature_shape,  # noqa: E402
                                mode_shear_shape, mode_sigma)

from flexfmu.ffr.simulator import OUTPUT_NAMES, FFRBeamConfig, FFRBeamSimulator  # noqa: E402

GAUGES_LANDED = "gauge_1_s" in FFRBeamConfig.__dataclass_fields__ and "gauge_1_Mz" in OUTPUT_NAMES
needs_gauges = pytest.mark.skipif(not GAUGES_LANDED, reason="FFRBeam has no gauges yet (parameters gauge_K_s, "
                                                            "outputs gauge_K_N .. gauge_K_von_mises)")
FORCES = ("N", "Vy", "Vz", "T", "My", "Mz")
E, NU, RHO = 200e9, 0.29, 7850.0
G_SHEAR = E / (2 * (1 + NU))


# ============================================================================= a) static, frame solver
def circle(d):
    I = math.pi * d**4 / 64
    return FrameSection(E=E, G=G_SHEAR, A=math.pi * d**2 / 4, Iy=I, Iz=I, J=2 * I)


def rectangle(b, h):
    """width b along z, height h along y; J by Roark's formula (docs/scene_format.md)."""
    a, t = max(b, h), min(b, h)
    r = t / a
    J = a * t**3 * (1 / 3 - 0.21 * r * (1 - r**4 / 12))
    return FrameSection(E=E, G=G_SHEAR, A=b * h, Iy=h * b**3 / 12, Iz=b * h**3 / 12, J=J)


DOUBLE_L = [[0, 0, 0], [0, 0, 0.16], [0.14, 0, 0.16], [0.14, 0.15, 0.16]]
INCLINED = [[0, 0, 0], [0.15, 0, 0], [0.25, 0, 0.1], [0.40, 0, 0.1]]
S_INCLINE_END = 0.15 + math.hypot(0.1, 0.1)
#: name: (scene, points, section, boundary, load_s, gauge arc lengths)
STATIC_CASES = {
    "double_L XFF mid-segments": ("spatial_double_L", DOUBLE_L, circle(0.008), "XFF", 0.45, (0.08, 0.23, 0.375)),
    "double_L XFF root and corners": ("spatial_double_L", DOUBLE_L, circle(0.008), "XFF", 0.45, (0.0, 0.16, 0.30)),
    "double_L XFF near a corner, tip": ("spatial_double_L", DOUBLE_L, circle(0.008), "XFF", 0.45,
                                        (0.159, 0.161, 0.45)),
    "double_L XFX (indeterminate)": ("spatial_double_L", DOUBLE_L, circle(0.008), "XFX", 0.23, (0.08, 0.23, 0.375)),
    "inclined flat bar XFX": ("inclined_beam", INCLINED, rectangle(0.020, 0.005), "XFX", 0.22,
                              (0.075, 0.22, S_INCLINE_END)),
}
LOAD_F = np.array([0.4, -1.2, 2.0])         # N, body frame
LOAD_M = np.array([0.05, 0.02, -0.03])      # N m, body frame
#: FFRBeam vs the frame solver, relative to the largest component of the compared triple: both are exact for a
#: nodal load on an Euler-Bernoulli frame (rounding ~ cond(K) eps ~ 1e-10); the residual transient is bounded
#: below (e^-40 of the response)
STATIC_RTOL = 1e-6


def frame_reference(points, section, boundary, load_s, gauges):
    model = PolylineFrame(points, section, arc_lengths=[load_s, *gauges])
    model.clamp(0.0)
    if boundary == "XFX":
        model.clamp(model.vertex_s[-1])
    model.load(load_s, LOAD_F, LOAD_M)
    return model, model.solve()


@lru_cache(maxsize=None)
def settled(case: str):
    """FFRBeam at rest under the load: one exact step of 40 / (zeta omega_1): the modes' transient is e^-40 of
    their static response (the exact step is exact for held input at any length)."""
    scene, _, _, boundary, load_s, gauges = STATIC_CASES[case]
    zeta = 0.5
    kw = {f"gauge_{k}_s": s for k, s in enumerate(gauges, start=1)} if GAUGES_LANDED else {}
    sim = FFRBeamSimulator(FFRBeamConfig(scene=scene, boundary=boundary, elements_per_segment=4, n_modes=6,
                                         damping_ratio=zeta, static_correction=1, load_s=load_s, sensor_s=load_s,
                                         **kw))
    sim.set_inputs(**{f"F_{a}": v for a, v in zip("xyz", LOAD_F)}, **{f"M_{a}": v for a, v in zip("xyz", LOAD_M)})
    omega_1 = 2 * math.pi * sim.frequencies_hz[0]
    sim.step(40.0 / (zeta * omega_1))
    return sim.outputs()


def assert_triple(got, want, what):
    scale = np.max(np.abs(want))
    assert np.max(np.abs(got - want)) <= STATIC_RTOL * scale, f"{what}: FFRBeam {got}, reference {want}"


@pytest.mark.unit
@pytest.mark.parametrize("case", list(STATIC_CASES))
def test_static_load_point_displacement_matches_the_frame_solver(case):
    """No gauge needed: the set-up (scene, clamps, load, at rest) is the same in both; sensor_u at the load point."""
    _, points, section, boundary, load_s, gauges = STATIC_CASES[case]
    model, solution = frame_reference(points, section, boundary, load_s, gauges)
    out = settled(case)
    got = np.array([out[f"sensor_u_{a}"] for a in "xyz"])
    assert_triple(got, solution.displacement(model.node(load_s))[:3], f"{case}: sensor_u")


@pytest.mark.unit
@needs_gauges
@pytest.mark.parametrize("case", list(STATIC_CASES))
def test_static_section_forces_match_the_frame_solver(case):
    _, points, section, boundary, load_s, gauges = STATIC_CASES[case]
    model, solution = frame_reference(points, section, boundary, load_s, gauges)
    out = settled(case)
    for k, s in enumerate(gauges, start=1):
        want = section_forces_at(model, solution, s)
        got = np.array([out[f"gauge_{k}_{q}"] for q in FORCES])
        assert_triple(got[:3], want[:3], f"{case}: gauge {k} at s = {s} m, N Vy Vz")
        assert_triple(got[3:], want[3:], f"{case}: gauge {k} at s = {s} m, T My Mz")


@pytest.mark.unit
@needs_gauges
@pytest.mark.parametrize("case", list(STATIC_CASES))
def test_static_stresses_are_n_over_a_plus_m_c_over_i(case):
    """Outer fibre of a circle: sigma = |N|/A + |M| c/I, tau = T c/J; a rectangle's corner: |N|/A + |My| b/(2 Iy)
    + |Mz| h/(2 Iz), tau = T t/J (thin strip, t the short side); von Mises sqrt(sigma^2 + 3 tau^2) (the spec)."""
    _, points, section, boundary, load_s, gauges = STATIC_CASES[case]
    model, solution = frame_reference(points, section, boundary, load_s, gauges)
    out = settled(case)
    sec = section
    for k, s in enumerate(gauges, start=1):
        N, _, _, T, My, Mz = section_forces_at(model, solution, s)
        if sec.Iy == sec.Iz:                                       # circle: c from I = pi d^4 / 64, A = pi d^2 / 4
            c = math.sqrt(4 * sec.Iy / sec.A)
            sigma, tau = abs(N) / sec.A + math.hypot(My, Mz) * c / sec.Iy, abs(T) * c / sec.J
        else:
            b, h = math.sqrt(12 * sec.Iy / sec.A), math.sqrt(12 * sec.Iz / sec.A)
            sigma = abs(N) / sec.A + abs(My) * b / (2 * sec.Iy) + abs(Mz) * h / (2 * sec.Iz)
            tau = abs(T) * min(b, h) / sec.J
        assert out[f"gauge_{k}_sigma_max"] == pytest.approx(sigma, rel=STATIC_RTOL)
        assert out[f"gauge_{k}_von_mises"] == pytest.approx(math.sqrt(sigma**2 + 3 * tau**2), rel=STATIC_RTOL)


# ============================================================================= b) dynamic, closed form
#: The shaken cantilever: CASE of eb_base_excitation (steel, 1 m, 10 mm diameter, zeta 0.03; its CSV tabulates it).
CANTILEVER = {"name": "shaken_cantilever", "points": [[0, 0, 0], [CASE.L, 0, 0]],
              "section": {"shape": "circle", "diameter": 0.01}, "material": {"E": CASE.E, "nu": NU, "rho": CASE.rho}}
#: Error budget of the fitted moments (root, quarter and mid-span gauges) against the closed form, relative to |G|,
#: which the tolerance (1 %) holds with a margin (the measured deviations are printed with -s):
#: - FE discretisation, 32 elements: the bending frequencies within 1e-5 of Euler-Bernoulli's (asserted below,
#:   from f_1..f_6; measured 2.5e-6 at the third); at a resonance |dG| / |G| ~ (d omega / omega) / zeta <= 3.3e-4,
#:   elsewhere less;
#: - modal truncation: 12 modes = the six lowest bending pairs (to 600 Hz = 85 omega_1) plus the static correction,
#:   so only the omitted modes' dynamic part is missing: sum_{n > 6} s_n |omega_n^2 H_n - 1| (Eq. 7), computed
#:   below from the closed form and asserted < 1e-3 |G|;
#: - the zero-order hold: inputs a0 sin(w (t_k + h/2)) held on [t_k, t_k + h) and outputs read with the mean of the
#:   inputs either side of t_k (the held signal's Fourier series at its jumps): the fundamental is exactly
#:   sinc(w h / 2) a0 sin(w t), divided out; the images at w + 2 pi m / h (h <= 0.5 ms: >= 1876 Hz, 3 x the highest
#:   retained mode) alias onto w with weights <= sin(w h/2) / (pi - w h/2) and meet only the retained modes' tails
#:   and the static correction's constant (whose +-m images cancel to O((w h)^2)): < 3e-5 of rho A L^2 / 2;
#: - the residual transient from rest: bounded by transient_bound (below) at the fit window's start, asserted
#:   < 0.25 % |G|;
#: - the closed form's series: truncation_bound < 3e-11 of rho A L^2 / 2 up to 20 omega_1.
DYN_ELEMENTS, DYN_MODES, MAX_STEP = 32, 12, 0.5e-3
DYN_GAUGES = (0.0, 0.25, 0.5)               # m from the clamp: the root, a quarter and mid-span
RUN_DECAYS, WINDOW_S = 9.0, 0.5             # run 9 / (zeta omega_1) s; fit over the last >= 0.5 s of whole periods
DYN_RTOL = 0.01
OMEGA = CASE.natural_frequencies(3)
RATIOS = {"below 1st": 0.5, "at 1st": 1.0, "between 1st and 2nd": 1.5, "between 1st and 2nd, low": 4.0,
          "at 2nd": OMEGA[1] / OMEGA[0], "between 2nd and 3rd": 8.0, "at 3rd": OMEGA[2] / OMEGA[0]}


def modal_terms(x: float, quantity: str = "M") -> np.ndarray:
    """Mode n's part of the static moment (quantity "M", N m per m/s^2) or shear force ("V", N per m/s^2) at x,
    n = 1 .. 200: t_n(x) = EI phi_n''(x) Gamma_n / omega_n^2 (eb_base_excitation Eq. 11) or
    v_n(x) = EI phi_n^(3)(x) Gamma_n / omega_n^2 (Eq. 13)."""
    z = cantilever_roots(DEFAULT_TERMS)
    if quantity == "M":
        return CASE.rho * CASE.A * CASE.L**2 * 2 * mode_sigma(z) * mode_curvature_shape(z, x / CASE.L) / z**3
    return CASE.rho * CASE.A * CASE.L * 2 * mode_sigma(z) * mode_shear_shape(z, x / CASE.L) / z**2


def transient_bound(w: float, t: float, x: float, quantity: str = "M") -> float:
    """Largest |moment| (or |shear|) at x per unit a0 of the free vibration left at time t from a start at rest:
    mode n starts with minus its steady state (|q| <= Gamma_n |H_n|, |q'| <= w Gamma_n |H_n|, Eq. 3), and a damped
    free vibration (q0, v0) stays below e^{-zeta omega_n t} sqrt(q0^2 + ((v0 + zeta omega_n q0) / omega_d)^2); its
    moment at x is EI phi_n''(x) q = t_n(x) omega_n^2 q / Gamma_n (Eq. 11; the shear likewise with v_n, Eq. 13)."""
    omega, z = CASE.natural_frequencies(), CASE.zeta
    H = np.abs(1.0 / (omega**2 - w**2 + 2j * z * omega * w))
    growth = np.sqrt(1 + ((w + z * omega) / (omega * math.sqrt(1 - z * z))) ** 2)
    return float(np.sum(np.abs(modal_terms(x, quantity)) * omega**2 * H * growth * np.exp(-z * omega * t)))


def omitted_modes_part(w: float, x: float, quantity: str = "M", n_kept: int = DYN_MODES // 2) -> float:
    """|sum_{n > n_kept} t_n(x) (omega_n^2 H_n - 1)| (or v_n): what a static correction leaves out (Eqs. 7, 11, 13)."""
    omega, z = CASE.natural_frequencies(), CASE.zeta
    damping = 2j * z * omega * w
    tail = (modal_terms(x, quantity) * (w**2 - damping) / (omega**2 - w**2 + damping))[n_kept:]
    return float(abs(np.sum(tail)))


@pytest.fixture(scope="module")
def shaken_sim(tmp_path_factory) -> FFRBeamSimulator:
    """FFRBeam on the cantilever scene (a JSON in a temporary folder), gauges at DYN_GAUGES."""
    path = tmp_path_factory.mktemp("shaken") / "shaken_cantilever.json"
    path.write_text(json.dumps(CANTILEVER))
    kw = {f"gauge_{k}_s": s for k, s in enumerate(DYN_GAUGES, start=1)} if GAUGES_LANDED else {}
    return FFRBeamSimulator(FFRBeamConfig(scene=str(path), boundary="XFF", elements_per_segment=DYN_ELEMENTS,
                                          n_modes=DYN_MODES, damping_ratio=CASE.zeta, static_correction=1, **kw))


@lru_cache(maxsize=None)
def shaken(sim: FFRBeamSimulator, axis: str, ratio: float):
    """Fitted complex amplitudes per unit a0 of the moment outputs under base_a_<axis> = sin(w t), w = ratio
    omega_1: ({output: G_fit}, the fit window's first time (s), w)."""
    sim.state = sim.dynamics.initial_state()                # at rest
    sim.set_inputs(**{f"base_a_{a}": 0.0 for a in "xyz"})
    w = ratio * OMEGA[0]
    period = 2 * math.pi / w
    per_period = math.ceil(period / MAX_STEP)
    h = period / per_period
    n_periods = math.ceil(RUN_DECAYS / (CASE.zeta * OMEGA[0]) / period)
    n_window = math.ceil(WINDOW_S / period) * per_period
    n_steps = n_periods * per_period
    outputs = ["reaction_M_y", "reaction_M_z"] + ([f"gauge_{k}_{q}{a}" for k in (1, 2, 3) for q in "MV" for a in "yz"]
                                                  if GAUGES_LANDED else [])
    rows = [OUTPUT_NAMES.index(name) for name in outputs]
    held = np.sin(w * (np.arange(n_steps + 1) + 0.5) * h)
    name = f"base_a_{axis}"
    y = np.empty((n_window, len(rows)))
    for k in range(n_steps):
        sim.set_inputs(**{name: held[k]})
        sim.step(h)
        if k >= n_steps - n_window:
            sim.set_inputs(**{name: 0.5 * (held[k] + held[k + 1])})
            y[k - (n_steps - n_window)] = sim.output_vector()[rows]
    t = (np.arange(n_steps - n_window, n_steps) + 1) * h
    # y = Im(G e^{i w t}) over whole periods: G = (2 i / n) sum y e^{-i w t}; / sinc: the hold's fundamental
    G = 2j / n_window * (np.exp(-1j * w * t) @ y) / np.sinc(w * h / (2 * math.pi))
    return dict(zip(outputs, G)), t[0] - h, w


def root_moment_component(axis: str, G: dict, prefix: str) -> complex:
    """The section moment along e_x cross e_a (the closed form's component) of outputs prefix + y / z: Mz for y, -My
    for z (rod along X, section axes = body axes by the orientation rule)."""
    return G[f"{prefix}z"] if axis == "y" else -G[f"{prefix}y"]


def shear_component(axis: str, G: dict, prefix: str) -> complex:
    """The section's shear force along e_a (the closed form's component, Eq. 13): Vy for y, Vz for z."""
    return G[f"{prefix}{axis}"]


@pytest.mark.unit
def test_shaken_cantilever_model_is_the_closed_forms(shaken_sim):
    """The FE frequencies (each bending frequency twice: a circle) within 1e-5 of Euler-Bernoulli's, the budget's
    discretisation line; the scene's constants those of CASE."""
    sim = shaken_sim
    exact = np.repeat(OMEGA / (2 * math.pi), 2)
    np.testing.assert_allclose(sim.frequencies_hz, exact, rtol=1e-5)
    assert CASE.I == pytest.approx(math.pi * CANTILEVER["section"]["diameter"] ** 4 / 64, rel=1e-15)


dynamic_cases = pytest.mark.parametrize("axis, ratio", [("y", r) for r in RATIOS.values()]
                                        + [("z", RATIOS["between 1st and 2nd"]), ("z", RATIOS["at 2nd"])],
                                        ids=[f"y {k}" for k in RATIOS] + ["z between 1st and 2nd", "z at 2nd"])


@pytest.mark.study
@dynamic_cases
def test_reaction_moment_is_the_dalembert_reaction(shaken_sim, axis, ratio):
    """reaction_M: the moment the rod exerts on its clamp = the section at s = 0 with the damping forces' moment
    (eb_base_excitation Eq. 10): the harness (hold, fit, run length) checked without the gauges."""
    G_fit, window_start, w = shaken(shaken_sim, axis, ratio)
    want = CASE.root_reaction_transfer(w)[0]
    transient = 2 * transient_bound(w, window_start, 0.0)     # the fit: |(2 / n) sum e^{-i w t} y| <= 2 max |y|
    # (the reaction's free vibration also carries the damping forces' moment, at most 2 zeta = 6 % more: in margin)
    got = root_moment_component(axis, G_fit, "reaction_M_")
    print(f"reaction {axis} w/w1 = {ratio:.4f}: {got:.6f} vs {want:.6f}, rel {abs(got - want) / abs(want):.2e}")
    assert transient < 0.0025 * abs(want)
    assert abs(got - want) <= DYN_RTOL * abs(want)


def compare_dynamic(G_fit, window_start, w, axis, k, x, quantity):
    """(relative deviation, bounded errors, text) of gauge k's moment or shear against Eqs. (7), (11), (13)."""
    if quantity == "M":
        want, got = CASE.moment_transfer(w, x)[0], root_moment_component(axis, G_fit, f"gauge_{k}_M")
        series = CASE.truncation_bound(w, x=x)[0]
    else:
        want, got = CASE.shear_transfer(w, x)[0], shear_component(axis, G_fit, f"gauge_{k}_V")
        series = CASE.shear_truncation_bound(w)[0]
    rel = abs(got - want) / abs(want)
    what = f"gauge {k} (x = {x} m) {quantity} {axis} w/w1 = {w / OMEGA[0]:.4f}"
    print(f"{what}: |G| {abs(got):.6g} vs {abs(want):.6g}, phase {np.angle(got):.5f} vs {np.angle(want):.5f} rad, "
          f"rel {rel:.2e}")
    # the bounded parts of the budget (the run long enough, the retained modes enough), relative to |G|
    bounded = 2 * transient_bound(w, window_start, x, quantity) + omitted_modes_part(w, x, quantity) + series
    return rel, bounded / abs(want), what


@pytest.mark.study
@needs_gauges
@dynamic_cases
def test_gauge_moments_and_root_shear_match_the_closed_form(shaken_sim, axis, ratio):
    """The bending moment of the gauges at the root, a quarter and mid-span (Eqs. 7, 11) and the shear force at the
    root (Eq. 13): each within 1 % of its closed form's amplitude, phase included (the complex difference)."""
    G_fit, window_start, w = shaken(shaken_sim, axis, ratio)
    for k, x, quantity in [(k, x, "M") for k, x in enumerate(DYN_GAUGES, start=1)] + [(1, 0.0, "V")]:
        rel, bounded, what = compare_dynamic(G_fit, window_start, w, axis, k, x, quantity)
        # the bounded parts within half the tolerance; the rest (FE discretisation <= 3.3e-4, hold < 3e-5 of the
        # static value) in the other half
        assert bounded < 0.5 * DYN_RTOL, f"{what}: bounded errors {bounded:.3g}"
        assert rel <= DYN_RTOL, what


@pytest.mark.study
@needs_gauges
def test_interior_gauge_shear_matches_the_closed_form(shaken_sim):
    """The shear force at a quarter and mid-span (Eq. 13) within 1 % at every frequency of RATIOS (shaken along y)."""
    worst = (0.0, "")
    for ratio in RATIOS.values():
        G_fit, window_start, w = shaken(shaken_sim, "y", ratio)
        for k, x in list(enumerate(DYN_GAUGES, start=1))[1:]:
            rel, bounded, what = compare_dynamic(G_fit, window_start, w, "y", k, x, "V")
            assert bounded < 0.5 * DYN_RTOL, f"{what}: bounded errors {bounded:.3g}"
            worst = max(worst, (rel, what))
    assert worst[0] <= DYN_RTOL, f"{worst[1]}: {worst[0]:.2e}"
