"""Flexible bodies clamped to a moving base (flexfmu.body: build_body with a clamp, FlexBodySimulator).

References: the analytic cantilever under a uniform load and the analytic spinning bar (Euler-Bernoulli and bar
theory), Newton-Euler for the reactions, and the FFR beam code (flexfmu.ffr.dynamics: centre-line quadrature of
the inertia integrals) as another implementation of the same equations."""
import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from conftest import STEEL, straight_rod
from error_bounds import U, gamma, implementations_bound
from flexfmu.body.build import build_body
from flexfmu.body.simulator import FlexBodyConfig, FlexBodySimulator, input_names, output_names, variable_info
from flexfmu.errors import ParameterError
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.ffr.dynamics import BaseMotion, FFRBeamDynamics
from flexfmu.ffr.scene import load_scene
from flexfmu.linalg.modal import solve_modes
from flexfmu.reframe.models import load_model


def _rod(L, d, n_el):
    s = build_beam_model(straight_rod(L, d), "free", n_el).structure()
    return dataclasses.replace(s, node_sets={"root": np.array([0]), "tip": np.array([s.nodes.shape[0] - 1])})


def _settle(body, inputs, zeta=0.7, step=0.05, n=200):
    sim = FlexBodySimulator(body, FlexBodyConfig(damping_ratio=zeta))
    sim.set_inputs(**inputs)
    for _ in range(n):
        sim.step(step)
    return sim.outputs()


def test_base_acceleration_bends_a_cantilever_as_a_uniform_load():
    """Base accelerating at +a along y: the inertial load -rho A a gives w_tip = -q L^4 / (8 E I); the rod pushes
    the base with -m a (what the structure exerts on its clamps) and the moment -q L^2 / 2 about z."""
    L, d, a = 1.0, 0.01, 9.81
    rod = _rod(L, d, 6)
    body_nodes = rod.nodes.shape[0]
    body = build_body(rod, interfaces=[{"name": "tip", "point": [L, 0, 0]}], clamp="root", f_max=100.0,
                      tolerance=1e-6)
    o = _settle(body, {"base_a_y": a})
    EI = STEEL["E"] * np.pi * d**4 / 64
    q = STEEL["rho"] * np.pi * d**2 / 4 * a
    print(f"\ntip {o['tip.pos_y']:.12g} vs {-q * L**4 / (8 * EI):.12g}; reaction F_y {o['reaction_F_y']:.12g} vs "
          f"{-body.mass * a:.12g}; M_z {o['reaction_M_z']:.12g} vs {-q * L**2 / 2:.12g}")
    w_tip = -q * L**4 / (8 * EI)
    assert o["tip.pos_y"] == pytest.approx(w_tip, rel=1e-9)
    # the axial displacement is zero analytically (a transverse load): held to the deflection's own analytic
    # tolerance, 1e-9 of |w_tip| (no quick rounding bound: it passes through the modal truncation and the solve)
    assert abs(o["tip.pos_x"] - L) <= 1e-9 * abs(w_tip)
    # settled (e^{-zeta omega_1 t} ~ e^-300): the reaction is the total inertial load -m a exactly, so only
    # rounding separates them: sums over the n_dof nodal/modal terms of size <= m |a| and the formulas' few
    # operations, generously gamma(n_dof + 64) m |a|; F_x, F_z are zero in exact arithmetic, the same bound
    n_dof = 6 * body_nodes
    assert abs(o["reaction_F_y"] + body.mass * a) <= gamma(n_dof + 64) * body.mass * a
    assert o["reaction_M_z"] == pytest.approx(-q * L**2 / 2, rel=1e-9)
    assert abs(o["tip.acc_y"] - a) <= 1e-9 * a          # at rest on the base: the base's acceleration
    assert abs(o["reaction_F_x"]) + abs(o["reaction_F_z"]) <= 2 * gamma(n_dof + 64) * body.mass * a


def test_spinning_bar_stretches_and_pulls_its_hub():
    """Bar along x clamped at the hub spinning about z (below its first bending frequency): E A u'' + rho A w^2
    (x + u) = 0, u(0) = 0, u'(L) = 0: u(L) = tan(kL)/k - L, k = w sqrt(rho/E); the hub is pulled outward with
    rho A w^2 int (x + u) dx = rho A w^2 (1 - cos kL) / (k^2 cos kL)."""
    L, d, w = 1.0, 0.02, 30.0
    body = build_body(_rod(L, d, 16), interfaces=[{"name": "tip", "point": [L, 0, 0]}], clamp="root",
                      n_modes=16 * 6)                      # every mode: the axial ones are far above the bending ones
    o = _settle(body, {"base_w_z": w}, step=0.01, n=1500)
    k = w * np.sqrt(STEEL["rho"] / STEEL["E"])
    rhoA = STEEL["rho"] * np.pi * d**2 / 4
    u_tip = np.tan(k * L) / k - L
    pull = rhoA * w**2 * (1 - np.cos(k * L)) / (k**2 * np.cos(k * L))
    # the consistent axial mass integrates the linear interpolant of u between the 17 nodes (trapezoid rule)
    x = np.linspace(0.0, L, 17)
    u = np.sin(k * x) / (k * np.cos(k * L)) - x
    pull_fe = rhoA * w**2 * (L**2 / 2 + np.sum(0.5 * (u[1:] + u[:-1]) * np.diff(x)))
    print(f"\nstretch {o['tip.pos_x'] - L:.12g} vs {u_tip:.12g}; reaction F_x {o['reaction_F_x']:.12g} vs {pull:.12g} "
          f"(continuum), {pull_fe:.12g} (the interpolant of the exact u)")
    assert o["tip.pos_x"] - L == pytest.approx(u_tip, rel=1e-8)
    # the rigid part rho A w^2 L^2 / 2 of the pull is a sum of positive terms (rounding gamma(n_dof + 64) of it,
    # as above); the part carried by the stretch u, rho A w^2 int u, is held to the stretch's own analytic
    # tolerance (1e-8 relative, the assertion above; no quick rounding bound through the modal solve)
    n_dof = 6 * 17
    pull_u = rhoA * w**2 * abs(np.sum(0.5 * (u[1:] + u[:-1]) * np.diff(x)))
    assert abs(o["reaction_F_x"] - pull_fe) <= gamma(n_dof + 64) * abs(pull_fe) + 1e-8 * pull_u
    assert o["reaction_F_x"] == pytest.approx(pull, rel=(L / 16) ** 2 * k**2 / 6)   # twice the h^2 k^2 / 12 gap
    assert abs(o["tip.acc_x"] + w**2 * o["tip.pos_x"]) <= 1e-9 * w**2 * L      # centripetal, at rest in the frame


def _ffr_pair(n_el):
    scene = load_scene("spatial_double_L")
    L = scene.total_length
    model = build_beam_model(scene, "XFF", n_el, extra_arc_lengths=(L, 0.04))
    modes = solve_modes(model.K_free, model.M_free, 6)
    dyn = FFRBeamDynamics(model, modes, 0.02, L, 0.04)
    fixed = np.flatnonzero(np.diff(model.B2.indptr) == 0)               # the clamped DOFs: rows B2 drops
    s = dataclasses.replace(model.structure(), constrained_dofs=fixed)
    body = build_body(s, interfaces=[{"name": "tip", "point": scene.points[-1].tolist()},
                                     {"name": "sensor", "point": dyn.sensor.undeformed_body.tolist()}],
                      clamp="file", n_modes=6)
    return scene, dyn, body, modes


def _compare(scene, dyn, body, inputs, base, h=5e-4, n=400):
    """Max relative differences of tip_u, sensor_a, reaction F, M along a run of both codes."""
    sim = FlexBodySimulator(body, FlexBodyConfig())
    sim.set_inputs(**inputs)
    F = np.array([inputs.get(f"tip.F_{a}", 0.0) for a in "xyz"])
    M = np.array([inputs.get(f"tip.M_{a}", 0.0) for a in "xyz"])
    state = dyn.initial_state()
    mine, ref = [], []
    for _ in range(n):
        sim.step(h)
        state = dyn.step(state, h, F, M, base)
        o = sim.outputs()
        acc = dyn.acceleration(state, F, M, base)
        _, _, a = dyn.sensor_motion(state, acc, base)
        Fr, Mr = dyn.reactions(state, acc, F, M, base)
        ref.append(np.concatenate([dyn.tip_displacement(state), a, Fr, Mr]))
        mine.append(np.concatenate([[o[f"tip.pos_{x}"] - p for x, p in zip("xyz", scene.points[-1])],
                                    [o[f"sensor.acc_{x}"] for x in "xyz"], [o[f"reaction_F_{x}"] for x in "xyz"],
                                    [o[f"reaction_M_{x}"] for x in "xyz"]]))
    mine, ref = np.array(mine), np.array(ref)
    return {name: float(np.abs(mine[:, sl] - ref[:, sl]).max() / np.abs(ref[:, sl]).max())
            for name, sl in (("tip_u", slice(0, 3)), ("sensor_a", slice(3, 6)), ("F", slice(6, 9)),
                             ("M", slice(9, 12)))}


def test_matches_the_ffr_beam_code():
    """Same M, K, modes: the same frequencies, and the same response to base acceleration and interface loads (the
    reaction moment then differs by the cross-sections' torsional inertia, which M holds and the centre-line
    integrals leave out: relative size d^2 / (8 L^2) of the shortest segment).  Base rotation: M's nodal couplings
    (flexfmu.body.clamped Eq. (B3)) approach the centre line's as h^2; already at 8 elements/segment the
    difference is within that same size."""
    rotary = 0.008**2 / (8 * 0.14**2)                     # d^2 / (8 L^2), the shortest segment of the double L
    scene, dyn, body, modes = _ffr_pair(8)
    # two eigen-solves of the same pencil (K, M), each backward stable (scaled to unit diag M as solve_modes does:
    # (K + dK, M + dM), ||dK|| <= gamma(10 n) ||K||, ||dM|| <= gamma(10 n) ||M||, 10 n over-counting the
    # Cholesky, reduction and tridiagonal QR): Weyl for the definite pencil |dlambda| <= (||dK|| + lambda ||dM||)
    # / lambda_min(M), twice (two solves), halved for f ~ sqrt(lambda), plus a few roundings of sqrt and 2 pi;
    # ||.||_2 <= the 1-norm of these symmetric matrices
    dm = 1.0 / np.sqrt(dyn.model.M_free.diagonal())
    Ks, Ms = (sp.diags(dm) @ dyn.model.K_free @ sp.diags(dm)), (sp.diags(dm) @ dyn.model.M_free @ sp.diags(dm))
    n = Ks.shape[0]
    lam = (2 * np.pi * modes.frequencies_hz[:6]) ** 2
    m_min = float(np.linalg.eigvalsh(Ms.toarray())[0])
    rel = gamma(10 * n) * (spla.norm(Ks, 1) + lam * spla.norm(Ms, 1)) / (m_min * lam) + 8 * U
    assert np.all(np.abs(body.natural_frequencies_hz - modes.frequencies_hz[:6]) <= rel * modes.frequencies_hz[:6])
    a0 = np.array([1.0, -2.0, 3.0])
    d = _compare(scene, dyn, body, {"base_a_x": 1.0, "base_a_y": -2.0, "base_a_z": 3.0, "tip.F_x": 0.5,
                                    "tip.M_y": 0.01}, BaseMotion(a0=a0))
    print(f"\nbase acceleration and tip load, 8 elements/segment: {d}")
    # two codes with the same M, K, modes over n = 400 steps: per step each within gamma(ops) of the terms, ops
    # generously 4 (2 m + 15 inputs) + 64 (as the held-map test in test_performance_equivalence); the damped
    # modal step map is a contraction in the energy norm (growth 1); converting the group's units to the energy
    # norm and back costs omega_max / omega_min each way, which also over-counts the terms' size relative to
    # the result (the modes' static responses scale as 1 / omega^2): relative (omega_max / omega_min)^2
    w_ratio = float(modes.frequencies_hz[5] / modes.frequencies_hz[0])
    bound = implementations_bound(w_ratio**2, 4 * (2 * 6 + 15) + 64, 1.0, 400)
    print(f"rounding bound (relative) {bound:.1e}")
    assert d["tip_u"] <= bound and d["sensor_a"] <= bound and d["F"] <= bound
    assert d["M"] < rotary
    spin = {"base_w_z": 30.0, "base_dw_x": 50.0, "base_dw_z": 100.0}
    base = BaseMotion(omega=np.array([0.0, 0.0, 30.0]), alpha=np.array([50.0, 0.0, 100.0]))
    coarse = _compare(scene, dyn, body, spin, base)
    scene, dyn, body, _ = _ffr_pair(32)
    fine = _compare(scene, dyn, body, spin, base)
    print(f"base rotation: 8 elements/segment {coarse}; 32: {fine}; d^2 / (8 L^2) = {rotary:.2e}")
    assert all(coarse[k] < rotary and fine[k] < rotary for k in fine)


def test_file_clamp_equals_node_set_clamp_and_inputs():
    s = _rod(1.0, 0.01, 6)
    s = dataclasses.replace(s, constrained_dofs=np.arange(6))
    a = build_body(s, interfaces=[{"name": "tip", "point": [1.0, 0, 0]}], clamp="root", n_modes=4)
    b = build_body(s, interfaces=[{"name": "tip", "point": [1.0, 0, 0]}], clamp="file", n_modes=4)
    # identity: both clamps give the same DOF array (0..5, sorted int64: flexfmu.body.build.clamped_dofs), so the
    # same reduction and eigensolve run on the same numbers in the same order: the same bits
    np.testing.assert_array_equal(a.natural_frequencies_hz, b.natural_frequencies_hz)
    assert input_names(a) == ("tip.F_x", "tip.F_y", "tip.F_z", "tip.M_x", "tip.M_y", "tip.M_z", "base_a_x",
                              "base_a_y", "base_a_z", "base_w_x", "base_w_y", "base_w_z", "base_dw_x", "base_dw_y",
                              "base_dw_z")
    info = variable_info(a)
    assert all("body frame" in info[n][1] for n in input_names(a))
    assert set(output_names(a)) <= set(info) and "reaction_M_z" in output_names(a)
    with pytest.raises(ParameterError) as err:
        FlexBodySimulator(a, FlexBodyConfig(v0_x=1.0))
    assert err.value.parameter == "v0_x"


@pytest.mark.parametrize("clamp, words", [("nope", "unknown node set"), ("file", "constrains no DOF"),
                                          ("one", "free to move"), (3, "node-set name")])
def test_clamp_errors(clamp, words):
    s = load_model("paper_plate", divisions=(4, 1, 1))
    s = dataclasses.replace(s, node_sets={"one": np.array([0])})       # one 3-DOF node: the body can turn about it
    with pytest.raises(ParameterError) as err:
        build_body(s, interfaces=[{"name": "A", "point": [0.5, 0.0, 0.0]}], clamp=clamp, n_modes=2)
    print(f"\n{clamp!r}: {err.value}")
    assert err.value.parameter == "clamp" and words in str(err.value)
