"""FFRBeam's strain gauges (flexfmu.ffr.gauges): the section forces and stresses at gauge_K_s.

The static checks put the spatial double L (XFF: clamped at s = 0) at rest under a held load, with the static
correction on, so that the section forces are those of the full finite-element model, and compare them with the
free-body sums of the part beyond the cut (the rod's polyline, not the mesh).  Rest: from rest, each exact step of
h leaves the transient times e^(-zeta omega_1 h) (modal damping zeta on every mode, omega_1 the lowest), asserted
below 1e-30: nothing of it is left in double precision.

Tolerance of the static checks: 1e-9 relative to the load's size, or the rounding bound of the end forces where that
is larger.  The section forces are the element's end forces D K_e q_e (+ the inertial terms), a cancellation of
terms of size |D| |K_e| |q_e| (up to 2e5 x the load here: a far element's axial stiffness EA / L_e times its mostly
rigid displacement); q = Phi eta + R z is within gamma_(m+18) (|Phi| |eta| + |R| |z|) of its value (eta within as
much of the static solution: exact steps, the transient gone) and the product adds gamma_12 of the same terms, so
|error| <= 2 gamma_(m+40) |D| (|K_e| (|Phi_e| |eta| + |R_e| |z|) + |S_bar_e| |a0|) (_rounding).  Any modelling
error (a missing inertial term, a wrong sign or frame, the static correction left out: 1e-3 .. 1 of the load) is far
above both.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from error_bounds import gamma, implementations_bound
from flexfmu.core.stress import evaluate_derived
from flexfmu.errors import ParameterError
from flexfmu.ffr.dynamics import BaseMotion
from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator, INPUT_NAMES, OUTPUT_NAMES
from flexfmu.core.vec3 import skew

pytestmark = pytest.mark.unit

POINTS = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.16], [0.14, 0.0, 0.16], [0.14, 0.15, 0.16]])   # the scene's
DIAMETER, RHO = 0.008, 7850.0
AREA = math.pi * DIAMETER ** 2 / 4
I_BEND = math.pi * DIAMETER ** 4 / 64
FORCES = ("N", "Vy", "Vz", "T", "My", "Mz")
STATIC_RTOL = 1e-9
ZETA, REST_STEP = 0.2, 10.0


def _at_rest(**kwargs) -> FFRBeamSimulator:
    gauges = {k: kwargs.pop(k) for k in list(kwargs) if k.startswith("gauge_")}
    sim = FFRBeamSimulator(FFRBeamConfig(scene="spatial_double_L", boundary="XFF", static_correction=1,
                                         damping_ratio=ZETA, **gauges))
    assert math.exp(-ZETA * 2 * math.pi * sim.frequencies_hz[0] * REST_STEP) < 1e-30
    sim.set_inputs(**kwargs)
    sim.step(REST_STEP)
    sim.step(REST_STEP)
    return sim


def _point(s: float) -> np.ndarray:
    """The rod's point at arc length s (the polyline)."""
    for a, b in zip(POINTS[:-1], POINTS[1:]):
        L = float(np.linalg.norm(b - a))
        if s <= L + 1e-15:
            return a + (b - a) * (s / L)
        s -= L
    raise AssertionError("beyond the rod")


def _beyond(s: float):
    """The pieces of the rod beyond arc length s: (length, centre) each."""
    pieces, start = [], 0.0
    for a, b in zip(POINTS[:-1], POINTS[1:]):
        L = float(np.linalg.norm(b - a))
        if start + L > s:
            p = _point(max(s, start))
            pieces.append((float(np.linalg.norm(b - p)), 0.5 * (p + b)))
        start += L
    return pieces


def _section_axes(sim, s: float) -> np.ndarray:
    """R (columns x, y, z, body frame) of the element after the node at s (the last one at the last point),
    checked: orthonormal, right-handed, x along the polyline's segment there."""
    mesh = sim.dynamics.model.mesh
    node = int(np.argmin(np.abs(mesh.node_s - s)))
    after = np.flatnonzero(mesh.elements[:, 0] == node)
    e = int(after[0]) if after.size else len(mesh.elements) - 1
    R = mesh.element_rotation[e]
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-14) and np.linalg.det(R) > 0
    direction = _point(min(s + 1e-3, 0.45)) - _point(min(s, 0.449))
    assert np.allclose(R[:, 0], direction / np.linalg.norm(direction), atol=1e-12)
    return R


def _rounding(sim, k: int) -> np.ndarray:
    """The rounding bound of gauge k's six section forces at rest (the module docstring)."""
    dyn, g = sim.dynamics, sim.dynamics.gauges.sections[k - 1]
    u = np.abs(np.array([sim.inputs[n] for n in INPUT_NAMES[:9]]))
    q = np.abs(dyn.Phi[g.dofs]) @ np.abs(sim.state.eta) + np.abs(sim.static_correction.residual[g.dofs, :9]) @ u
    return 2 * gamma(dyn.m + 40) * (np.abs(g.select) @ (np.abs(g.K) @ q + np.abs(g.S_bar_T) @ u[6:9]))


def _gauge(out: dict, k: int) -> np.ndarray:
    return np.array([out[f"gauge_{k}_{q}"] for q in FORCES])


def test_tip_force_at_rest_gives_the_free_body_section_forces():
    """Clamp (s = 0), first corner (s = 0.16: the element after it, along body x), mid segment 3, last point:
    [N, Vy, Vz] = R^T F and [T, My, Mz] = R^T ((r_tip - r_cut) x F)."""
    F = np.array([1.5, -2.0, 3.0])
    gauges = (0.0, 0.16, 0.375)
    sim = _at_rest(F_x=F[0], F_y=F[1], F_z=F[2], **{f"gauge_{k}_s": s for k, s in enumerate(gauges, start=1)})
    out = sim.outputs()
    r_tip = POINTS[-1]
    for k, s in enumerate(gauges, start=1):
        R = _section_axes(sim, s)
        want_F, want_M = R.T @ F, R.T @ np.cross(r_tip - _point(s), F)
        got, rounding = _gauge(out, k), _rounding(sim, k)
        assert np.all(np.abs(got[:3] - want_F) <= np.maximum(STATIC_RTOL * np.linalg.norm(F), rounding[:3])), (
            s, got[:3], want_F)
        assert np.all(np.abs(got[3:] - want_M) <= np.maximum(STATIC_RTOL * np.linalg.norm(F) * 0.45,
                                                             rounding[3:])), (s, got[3:], want_M)
    assert np.isclose(_gauge(out, 2)[0], F[0], rtol=0, atol=max(STATIC_RTOL * np.linalg.norm(F),
                                                                 _rounding(sim, 2)[0]))   # after the corner: F_x
    # the last point: the part beyond is the loaded point itself
    sim = _at_rest(F_x=F[0], F_y=F[1], F_z=F[2], gauge_3_s=0.45)
    got, R = _gauge(sim.outputs(), 3), _section_axes(sim, 0.45)
    assert np.all(np.abs(got - np.r_[R.T @ F, 0, 0, 0]) <= np.maximum(STATIC_RTOL * np.linalg.norm(F),
                                                                       _rounding(sim, 3)))


def test_tip_moment_at_rest():
    """A moment M at the last point: no force at any section, moment R^T M."""
    M = np.array([0.2, 0.05, -0.1])
    sim = _at_rest(M_x=M[0], M_y=M[1], M_z=M[2], gauge_1_s=0.0, gauge_2_s=0.3)
    out = sim.outputs()
    for k, s in ((1, 0.0), (2, 0.3)):
        R, got, rounding = _section_axes(sim, s), _gauge(out, k), _rounding(sim, k)
        assert np.all(np.abs(got[:3]) <= np.maximum(STATIC_RTOL * np.linalg.norm(M) / 0.45, rounding[:3]))
        assert np.all(np.abs(got[3:] - R.T @ M) <= np.maximum(STATIC_RTOL * np.linalg.norm(M), rounding[3:]))


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_base_acceleration_at_rest_is_the_inertial_load_beyond_the_cut(axis):
    """a0 along one axis, at rest: the part beyond the cut moves with a0, so the section carries its d'Alembert load:
    force -R^T (rho A L_beyond a0), moment -R^T sum (c_i - r_cut) x rho A L_i a0 (checks the inertial term)."""
    a0 = np.zeros(3)
    a0[axis] = 9.81
    gauges = (0.0, 0.16, 0.23)
    sim = _at_rest(**{f"base_a_{'xyz'[axis]}": a0[axis]}, **{f"gauge_{k}_s": s for k, s in enumerate(gauges, 1)})
    out = sim.outputs()
    size = RHO * AREA * 0.45 * 9.81
    for k, s in enumerate(gauges, start=1):
        pieces = _beyond(s)
        force = RHO * AREA * sum(L for L, _ in pieces) * a0
        moment = sum(np.cross(c - _point(s), RHO * AREA * L * a0) for L, c in pieces)
        R, got, rounding = _section_axes(sim, s), _gauge(out, k), _rounding(sim, k)
        assert np.all(np.abs(got[:3] + R.T @ force) <= np.maximum(STATIC_RTOL * size, rounding[:3])), (
            s, got[:3], -R.T @ force)
        assert np.all(np.abs(got[3:] + R.T @ moment) <= np.maximum(STATIC_RTOL * size * 0.45, rounding[3:])), (
            s, got[3:], -R.T @ moment)
        assert np.linalg.norm(force) > 1e-3 * size or s > 0.4       # a real load at each of these sections


def test_gauge_stresses_follow_the_circle_formulas():
    """sigma_max = |N| / A + hypot(My, Mz) c / I and von Mises sqrt(sigma^2 + 3 (T c / J)^2), c = d / 2, J = 2 I
    (outer fibre of a circle), from the gauge's own section forces; within a few roundings of them."""
    sim = _at_rest(F_x=40.0, F_y=-25.0, F_z=300.0, M_x=0.7, gauge_1_s=0.0, gauge_2_s=0.16, gauge_3_s=0.3)
    out = sim.outputs()
    c = DIAMETER / 2
    for k in (1, 2, 3):
        N, _, _, T, My, Mz = _gauge(out, k)
        sigma = abs(N) / AREA + math.hypot(My, Mz) * c / I_BEND
        tau = abs(T) * c / (2 * I_BEND)
        assert abs(out[f"gauge_{k}_sigma_max"] - sigma) <= gamma(16) * sigma
        assert abs(out[f"gauge_{k}_von_mises"] - math.sqrt(sigma ** 2 + 3 * tau ** 2)) <= gamma(24) * sigma * 2
        assert sigma > 1e6                               # loaded: the comparison is not of zeros
    names = {d.output for d in sim.derived_outputs}
    assert names == {f"gauge_{k}_{q}" for k in (1, 2, 3) for q in ("sigma_max", "von_mises")}
    # the per-step fill (all gauges at once) against flexfmu.core.stress.evaluate_derived, one by one: the same
    # elementwise operations (a few ulps allowed for a vectorised hypot or sqrt)
    y = sim.output_vector()
    one_by_one = y.copy()
    evaluate_derived(sim.derived_outputs, OUTPUT_NAMES, one_by_one)
    assert np.all(np.abs(y - one_by_one) <= 4 * np.finfo(float).eps * np.abs(one_by_one))


def test_absent_gauges_output_exact_zeros():
    """gauge_K_s = -1: all eight outputs exactly 0 under any load, base motion and state; none derived."""
    sim = FFRBeamSimulator(FFRBeamConfig(static_correction=1, gauge_2_s=0.2))
    rng = np.random.default_rng(3)
    for _ in range(3):
        sim.set_input_vector(rng.standard_normal(len(INPUT_NAMES)) * 5)
        sim.step(1e-3)
        out = sim.outputs()
        for k in (1, 3):
            assert all(out[f"gauge_{k}_{q}"] == 0.0 for q in FORCES + ("sigma_max", "von_mises"))
        assert out["gauge_2_sigma_max"] > 0
    assert {d.output for d in sim.derived_outputs} == {"gauge_2_sigma_max", "gauge_2_von_mises"}
    plain = FFRBeamSimulator(FFRBeamConfig())
    assert plain.derived_outputs == () and not np.any(plain.output_vector()[-24:])
    assert OUTPUT_NAMES[-24:] == tuple(f"gauge_{k}_{q}" for k in (1, 2, 3)
                                        for q in FORCES + ("sigma_max", "von_mises"))


@pytest.mark.parametrize("value", [0.46, -0.5, -1e-3, math.nan, math.inf, "0.1"])
def test_bad_gauge_arc_length_is_named(value):
    with pytest.raises(ParameterError) as err:
        FFRBeamSimulator(FFRBeamConfig(gauge_2_s=value))
    assert err.value.parameter == "gauge_2_s" and "-1" in str(err.value.allowed)


def test_gauge_on_a_generic_section_is_refused(tmp_path):
    scene = {"schema_version": 1, "name": "generic_rod", "points": [[0, 0, 0], [0, 0, 0.3]],
             "section": {"A": AREA, "Iy": I_BEND, "Iz": I_BEND, "J": 2 * I_BEND},
             "material": {"E": 200e9, "nu": 0.29, "rho": RHO}}
    path = tmp_path / "generic.json"
    path.write_text(json.dumps(scene))
    FFRBeamSimulator(FFRBeamConfig(scene=str(path), load_s=0.3))           # without a gauge: fine
    with pytest.raises(ParameterError) as err:
        FFRBeamSimulator(FFRBeamConfig(scene=str(path), load_s=0.3, gauge_3_s=0.1))
    assert err.value.parameter == "gauge_3_s"


def test_fast_maps_equal_term_by_term_formulas():
    """The gauges' rows of the output maps (with the static correction) against reference_outputs' element
    formulas (flexfmu.ffr.gauges.GaugeSection.nodal_forces) at random states, loads and base motion: each within
    2 gamma_ops of the size of the terms, |D| (|K_e| (|Phi_e| |eta| + |R_e| |z|) + |M_e| |Phi_e| (|eta_ddot terms| +
    2 zeta omega |eta_dot|) +
    |S_bar_e| |a0| + |X| (|P| + |M_ab| |Phi_e| |eta|) + 2 |W| |M_ab| |Phi_e| |eta_dot|); the stresses within the
    propagated difference (|dN| / A + |dM| c / I, + a few roundings)."""
    sim = FFRBeamSimulator(FFRBeamConfig(static_correction=1, gauge_1_s=0.0, gauge_2_s=0.16, gauge_3_s=0.45))
    dyn, corr = sim.dynamics, sim.static_correction
    rng = np.random.default_rng(11)
    scale = np.array([1, 1, 1, 0.1, 0.1, 0.1, 2, 2, 2, 3, 3, 3, 5, 5, 5], float)
    ops = 4 * (2 * dyn.m + 9) + 64
    for case in range(4):
        u = rng.standard_normal(len(INPUT_NAMES)) * scale
        if case == 0:
            u[9:] = 0.0
        sim.set_input_vector(u)
        sim.step(1e-3 * (case + 1))
        fast, ref = sim.outputs(), sim.reference_outputs()
        base = BaseMotion(a0=u[6:9], omega=u[9:12], alpha=u[12:15])
        W = skew(base.omega)
        absX = np.abs(skew(base.alpha)) + np.abs(W) @ np.abs(W)
        K_eff, C_eff = dyn._matrices(base)
        eta, eta_dot = np.abs(sim.state.eta), np.abs(sim.state.eta_dot)
        z = np.abs(np.concatenate([u[:9], (skew(base.alpha) + W @ W).ravel()]))
        accel = (np.abs(K_eff) @ eta + np.abs(C_eff) @ eta_dot + np.abs(dyn.load_force_map) @ np.abs(u[:3])
                 + np.abs(dyn.load_moment_map) @ np.abs(u[3:6]) + np.abs(dyn.F_a0) @ np.abs(u[6:9])
                 + np.einsum("ab,abk->k", absX, np.abs(dyn.P_hat)))
        for k, g in enumerate(dyn.gauges.sections, start=1):
            Phi_e, aD = np.abs(dyn.Phi[g.dofs]), np.abs(g.select)
            terms = (np.abs(g.K) @ (Phi_e @ eta + np.abs(corr.residual[g.dofs]) @ z)
                     + np.abs(g.M) @ Phi_e @ (accel + np.abs(dyn.damping) * eta_dot)
                     + np.abs(g.S_bar_T) @ np.abs(u[6:9])
                     + np.einsum("ab,abk->k", absX, np.abs(g.P))
                     + np.einsum("ab,abkl,l->k", absX, np.abs(g.M_ab), Phi_e @ eta)
                     + 2 * np.einsum("ab,abkl,l->k", np.abs(W), np.abs(g.M_ab), Phi_e @ eta_dot))
            bound = implementations_bound(aD @ terms, ops)
            diff = np.abs(_gauge(fast, k) - _gauge(ref, k))
            assert np.all(diff <= bound), (case, k, diff, bound)
            assert np.max(np.abs(_gauge(fast, k))) > 100 * np.max(bound)     # the bound is not the size itself
            dsigma = diff[0] / AREA + np.hypot(diff[4], diff[5]) * (DIAMETER / 2) / I_BEND
            for q in ("sigma_max", "von_mises"):
                assert abs(fast[f"gauge_{k}_{q}"] - ref[f"gauge_{k}_{q}"]) <= (
                    2 * dsigma + np.hypot(diff[3], 0) * 2 * (DIAMETER / 2) / (2 * I_BEND)
                    + gamma(32) * abs(ref[f"gauge_{k}_{q}"]))


def test_moving_base_polynomial_outputs_carry_the_gauges():
    """Base motion that changes every step (the series step, its output maps from the held-motion polynomials)
    against the same steps by the maps (one exponential and fast_maps per step): the gauges' outputs agree as the
    other outputs do (both exact zero-order holds of one system: within 1e-9 of the outputs' size)."""
    cfg = FFRBeamConfig(static_correction=1, gauge_1_s=0.0, gauge_2_s=0.3)
    series, maps = FFRBeamSimulator(cfg), FFRBeamSimulator(cfg)
    maps.moving_base_series = False
    for n in range(20):                   # platform-like motion: 1 Hz, 1 ms steps
        u = np.zeros(len(INPUT_NAMES))
        u[0:3] = [1.0, -0.5, 0.3]
        u[6:15] = 0.5 * np.sin(2 * np.pi * 1e-3 * n + np.arange(9))
        for sim in (series, maps):
            sim.set_input_vector(u)
            sim.step(1e-3)
        a, b = series.outputs(), maps.outputs()
        size = max(abs(b[f"gauge_{k}_{q}"]) for k in (1, 2) for q in FORCES)
        for k in (1, 2):
            assert np.max(np.abs(_gauge(a, k) - _gauge(b, k))) <= 1e-9 * size, n
    assert series._series_last                             # the last steps went by the series
