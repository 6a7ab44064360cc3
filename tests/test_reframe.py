"""Reframe integrator: references never come from flexfmu.reframe.integrator.

* rigid references: Newton + Euler equations with quaternions, scipy solve_ivp (DOP853, rtol 1e-12),
  mass / centre of mass / inertia computed here from M and the node positions;
* momentum and energy: computed here from M, K and the nodal positions / velocities of a state.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.errors import ParameterError
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.integrator import FixedFrameBaseline, PointLoad, ReframeIntegrator, half_sine_pulse
from flexfmu.ffr.scene import load_scene

from error_bounds import gamma, implementations_bound

OMEGA0 = np.array([5.0, 2.0, 8.0])
DIR = np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)      # the paper's load direction, global


# --------------------------------------------------------------------------- models
@pytest.fixture(scope="module")
def beam():
    """Free-free bent rod (13 nodes, 6 DOF/node, first flexible mode 148 Hz)."""
    return build_beam_model(load_scene("spatial_double_L"), "free", 4).structure()


@pytest.fixture(scope="module")
def plate():
    """The paper's plate on a coarse mesh (1845 DOFs; first four flexible modes within 1% of Table 1)."""
    from flexfmu.reframe.plate import paper_plate
    return paper_plate((20, 2, 1))


BEAM_LOAD_NODE = 12                                      # free end of the rod, (0.14, 0.15, 0.16) m


# --------------------------------------------------------------------------- independent references
def mass_properties(structure):
    """Mass, centre of mass, inertia about it, from M and the nodes (rigid fields, any DOFs/node)."""
    nodes = structure.nodes
    dpn = structure.dofs_per_node
    n = nodes.shape[0] * dpn
    M = structure.M

    def fields(origin):
        T = np.zeros((n, 3))
        S = np.zeros((n, 3))
        for k in range(3):
            T[k::dpn, k] = 1.0
            rot = np.cross(np.eye(3)[k], nodes - origin)
            for j in range(3):
                S[j::dpn, k] = rot[:, j]
            if dpn == 6:
                S[3 + k::dpn, k] = 1.0
        return T, S

    T, S = fields(np.zeros(3))
    m = float(np.trace(T.T @ (M @ T))) / 3.0
    C = T.T @ (M @ S)                                   # C_ik = m (e_k x c)_i
    c = np.array([C[1, 2] - C[2, 1], C[2, 0] - C[0, 2], C[0, 1] - C[1, 0]]) / (2.0 * m)
    _, S = fields(c)
    return m, c, S.T @ (M @ S)


def rigid_reference(structure, node, force, omega0, t_eval, breaks=()):
    """Rigid body: m x'' = F, J w' = N - w x J w (body), q' = q (x) (0, w)/2; returns (t, omega_body, R)."""
    m, c, J = mass_properties(structure)
    arm = structure.nodes[node] - c

    def rhs(t, y):
        R = Rotation.from_quat(y[6:10]).as_matrix()
        w = y[10:13]
        f = force(t)
        wd = np.linalg.solve(J, np.cross(arm, R.T @ f) - np.cross(w, J @ w))
        x, yq, z, s = y[6:10]
        qd = 0.5 * np.array([s * w[0] - z * w[1] + yq * w[2], z * w[0] + s * w[1] - x * w[2],
                             -yq * w[0] + x * w[1] + s * w[2], -x * w[0] - yq * w[1] - z * w[2]])
        return np.concatenate([y[3:6], f / m, qd, wd])

    y = np.concatenate([c, np.zeros(3), [0.0, 0.0, 0.0, 1.0], omega0])
    edges = [0.0, *[b for b in breaks if 0 < b < t_eval[-1]], t_eval[-1]]
    ts, ws, Rs = [], [], []
    for a, b in zip(edges[:-1], edges[1:]):
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
        assert sol.success
        for t in t_eval:
            if a <= t <= b and (t < b or b == edges[-1]):
                yt = sol.sol(t)
                ts.append(t)
                ws.append(yt[10:13])
                Rs.append(Rotation.from_quat(yt[6:10]).as_matrix())
        y = sol.y[:, -1]
    return np.array(ts), np.array(ws), np.array(Rs)


def invariants(integ, structure, state):
    """(linear momentum, angular momentum about the global origin, kinetic, strain energy) from M, K."""
    ns = integ.nodal_state(state)
    R = state.rotation
    Mw = structure.M @ ns.velocity_body
    Mw_g = (Mw.reshape(-1, 3) @ R.T).reshape(structure.n_nodes, -1)
    p = Mw_g[:, :3].sum(axis=0)
    L = np.cross(ns.positions, Mw_g[:, :3]).sum(axis=0)
    if structure.dofs_per_node == 6:
        L = L + Mw_g[:, 3:].sum(axis=0)
    T = 0.5 * ns.velocity_body @ Mw
    V = 0.5 * ns.displacement @ (structure.K @ ns.displacement)
    return p, L, T, V


# --------------------------------------------------------------------------- rigid limit
def test_rigid_limit_plate_paper_load(plate):
    """Paper's load: 50 N along global [1,0,1]/sqrt2 at (-0.5, 0, 0.01) m, a 0.01 s half-sine pulse;
    plate with four flexible modes: dummy-body omega vs the rigid plate over 1 s."""
    from flexfmu.reframe.plate import LOAD_POINT
    F = 50.0 * DIR
    force = half_sine_pulse(F, 0.01)
    mb = modal_basis(plate, 4)
    res = {}
    for scheme in ("consistent", "paper"):
        integ = ReframeIntegrator(plate, mb, scheme=scheme)
        assert integ.reference_nodes == tuple(plate.points[k] for k in ("P1", "P2", "P3"))
        res[scheme] = integ.run(1.0, 2e-4, PointLoad(LOAD_POINT, force), every=250)
    node = int(np.argmin(np.linalg.norm(plate.nodes - LOAD_POINT, axis=1)))
    t_ref, w_ref, _ = rigid_reference(plate, node, force, np.zeros(3), res["consistent"].t, breaks=(0.01,))
    scale = np.max(np.linalg.norm(w_ref, axis=1))
    for scheme, r in res.items():
        np.testing.assert_allclose(r.t, t_ref)
        err = np.max(np.linalg.norm(r.omega - w_ref, axis=1)) / scale
        print(f"\nplate, paper load, {scheme}: max |omega - omega_rigid| / max|omega_rigid| = {err:.3g} "
              f"(omega_y(1 s) = {r.omega[-1, 1]:.9g}, rigid {w_ref[-1, 1]:.9g} rad/s)")
        if scheme == "consistent":
            assert err <= 1e-4


def _beam_loads():
    return {"step": (lambda t: 1.0 * DIR, ()),                     # constant 1 N from t = 0
            "pulse": (half_sine_pulse(2.0 * DIR, 0.1), (0.1,))}     # 0.1 s half-sine, 2 N peak


@pytest.mark.parametrize("spin", [True, False], ids=["omega0", "at_rest"])
@pytest.mark.parametrize("kind", ["step", "pulse"])
def test_rigid_convergence_order(beam, kind, spin):
    """0 flexible modes, omega0 = (5, 2, 8) rad/s or at rest, 1 s: omega and attitude error vs the
    rigid reference (max of |omega - omega_ref| / |omega_ref| and |R - R_ref|)."""
    force, breaks = _beam_loads()[kind]
    w0 = OMEGA0 if spin else np.zeros(3)
    mb = modal_basis(beam, 0)
    t_ref, w_ref, R_ref = rigid_reference(beam, BEAM_LOAD_NODE, force, w0, [1.0], breaks=breaks)
    dts = (0.01, 0.005, 0.0025)
    for scheme in ("consistent", "paper"):
        errs = []
        for dt in dts:
            integ = ReframeIntegrator(beam, mb, scheme=scheme)
            integ.set_initial(omega0=w0)
            r = integ.run(1.0, dt, PointLoad(BEAM_LOAD_NODE, force), every=10 ** 6)
            errs.append(max(np.linalg.norm(r.omega[-1] - w_ref[-1]) / np.linalg.norm(w_ref[-1]),
                            np.linalg.norm(r.rotation[-1] - R_ref[-1])))
        errs = np.array(errs)
        orders = np.log2(errs[:-1] / errs[1:])
        print(f"\nrigid beam, {kind} load, spin={spin}, {scheme}: errors {errs} at dt {dts}, orders {orders}")
        if scheme == "consistent":
            assert errs[-1] <= 1e-4
            assert 3.5 <= orders[-1] <= 4.5


@pytest.mark.parametrize("kind", ["step", "pulse"])
def test_flexible_convergence_order(beam, kind):
    """Three flexible modes, omega0 = (5, 2, 8) rad/s, 0.2 s: self-convergence (differences of
    successive halvings) and the difference from consistent at dt/8 (printed for both schemes)."""
    force, _ = _beam_loads()[kind]
    mb = modal_basis(beam, 3)
    dts = (4e-4, 2e-4, 1e-4, 5e-5)

    def final(scheme, dt):
        integ = ReframeIntegrator(beam, mb, scheme=scheme)
        integ.set_initial(omega0=OMEGA0)
        r = integ.run(0.2, dt, PointLoad(BEAM_LOAD_NODE, force), points=[BEAM_LOAD_NODE], every=10 ** 6)
        return np.concatenate([r.omega[-1], r.rotation[-1].ravel(), r.point_position[-1, 0]])

    ref = final("consistent", dts[-1] / 2)
    for scheme in ("consistent", "paper"):
        ys = [final(scheme, dt) for dt in dts]
        diffs = np.array([np.linalg.norm(a - b) for a, b in zip(ys[:-1], ys[1:])])
        errs = np.array([np.linalg.norm(y - ref) for y in ys])
        print(f"\nflexible beam, {kind} load, {scheme}: self-convergence orders "
              f"{np.log2(diffs[:-1] / diffs[1:])}, |y - y_consistent(dt/8)| = {errs}")
        if scheme == "consistent":        # the coarsest pair (dt omega_max = 0.7) is pre-asymptotic
            assert 3.5 <= math.log2(diffs[-2] / diffs[-1]) <= 4.5


# --------------------------------------------------------------------------- conservation
def test_linear_momentum(beam):
    """Tumbling flexible beam under a triangular force pulse (table) plus a step: m v_com = m v0 + int F dt."""
    mb = modal_basis(beam, 3)
    m, _, _ = mass_properties(beam)
    v0 = np.array([0.3, -0.2, 0.1])
    table = (np.array([0.0, 0.01, 0.02, 0.05]), np.array([[0, 0, 0], 3.0 * DIR, [0, 0, 0], [0, 0, 0]]))
    step = np.array([0.0, 0.5, -0.25])
    loads = [PointLoad(BEAM_LOAD_NODE, table), PointLoad(5, step)]
    impulse = 3.0 * DIR * 0.01 + step * 0.1               # triangle area + step * t_end
    integ = ReframeIntegrator(beam, mb)
    integ.set_initial(v0=v0, omega0=OMEGA0)
    r = integ.run(0.1, 1e-4, loads, every=100)
    p, _, _, _ = invariants(integ, beam, integ.state)
    expected = m * v0 + impulse
    err_nodal = np.linalg.norm(p - expected) / np.linalg.norm(expected)
    err_out = np.linalg.norm(m * r.com_velocity[-1] - expected) / np.linalg.norm(expected)
    print(f"\nlinear momentum (consistent): relative error {err_nodal:.3g} (from M and nodal velocities), "
          f"{err_out:.3g} (com_velocity output)")
    assert err_nodal <= 1e-9
    assert err_out <= 1e-9


def _tumble(structure, n_flexible, dt, t_end=2.0):
    mb = modal_basis(structure, n_flexible, damping_ratio=0.0)
    out = {}
    for scheme in ("consistent", "paper"):
        integ = ReframeIntegrator(structure, mb, scheme=scheme)
        s0 = integ.set_initial(omega0=OMEGA0)
        p0, L0, T0, V0 = invariants(integ, structure, s0)
        integ.run(t_end, dt, None, every=10 ** 6)
        p1, L1, T1, V1 = invariants(integ, structure, integ.state)
        out[scheme] = (np.linalg.norm(L1 - L0) / np.linalg.norm(L0), abs(T1 - T0) / T0,
                       abs(T1 + V1 - T0 - V0) / T0, np.linalg.norm(p1 - p0))
        print(f"\n{structure.name}, free tumbling {t_end} s, {n_flexible} undamped flexible modes, dt {dt}, "
              f"{scheme}: |dL|/|L| = {out[scheme][0]:.3g}, |dT|/T = {out[scheme][1]:.3g}, "
              f"|d(T+V)|/T = {out[scheme][2]:.3g}, |dp| = {out[scheme][3]:.3g}")
    return out


def test_free_tumbling_beam(beam):
    """No load, omega0 = (5, 2, 8) rad/s, 2 s.  Undamped: with modal damping the elastic energy the
    centrifugal load puts into the modes (~(Omega/omega_1)^2 T ~ 1e-5 T here) is dissipated, so kinetic
    energy would not be conserved physically."""
    out = _tumble(beam, 3, 2e-4)
    dL, dT, dE, _ = out["consistent"]
    assert dL <= 1e-6
    assert dT <= 1e-5
    assert dE <= 1e-5


def test_free_tumbling_plate(plate):
    """Plate (coarse mesh), four undamped flexible modes, as for the beam."""
    out = _tumble(plate, 4, 2e-4)
    dL, dT, dE, _ = out["consistent"]
    assert dL <= 1e-6
    assert dT <= 1e-5
    assert dE <= 1e-5


# --------------------------------------------------------------------------- outputs, baseline
def test_rigid_outputs_consistent(beam):
    """0 modes: point velocity / acceleration outputs agree with differentiated positions; quaternion."""
    mb = modal_basis(beam, 0)
    integ = ReframeIntegrator(beam, mb)
    integ.set_initial(v0=(0.1, 0.0, 0.2), omega0=OMEGA0)
    dt = 1e-3
    r = integ.run(0.2, dt, PointLoad(BEAM_LOAD_NODE, lambda t: DIR), points=[0, BEAM_LOAD_NODE])
    pos, vel, acc = r.point_position, r.point_velocity, r.point_acceleration

    def d5(x):                                       # five-point derivative, error ~ dt^4 / 30
        return (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * dt)

    assert np.max(np.abs(d5(pos) - vel[2:-2])) <= 1e-6 * np.max(np.abs(vel))
    assert np.max(np.abs(d5(vel) - acc[2:-2])) <= 1e-6 * np.max(np.abs(acc))
    # 0 modes: full and rigid acceleration are both R (a_o + alpha x X + w x (w x X)) (elastic terms exactly 0),
    # possibly contracted differently: <= 12 roundings each (two crosses, 2 adds, R @), terms sized by
    # |a_o| + |alpha||X| + |w|^2|X| with |a_o| <= |acc| + |alpha||X| + |w|^2|X|, x3 for the R row sum
    X = np.linalg.norm(r.point_position - r.com_position[:, None, :], axis=2)[..., None]
    rot = (np.linalg.norm(r.alpha, axis=1) + np.linalg.norm(r.omega, axis=1) ** 2)[:, None, None] * X
    scale = 3.0 * (np.linalg.norm(acc, axis=2)[..., None] + 2.0 * rot)
    assert np.all(np.abs(r.point_acceleration_rigid - acc) <= implementations_bound(scale, 12))
    R_q = Rotation.from_quat(np.column_stack([r.quaternion[:, 1:], r.quaternion[:, 0]])).as_matrix()
    # R -> quaternion (Shepperd, pivot >= 1/2; atan2/sin/cos, ~30 u on O(1) components) -> matrix (x8 + 10 u):
    # ~250 roundings, over-counted as 512; plus the integrated R's own orthogonality defect d = ||R^T R - I||_2,
    # which the extraction projects away (R - Q <= d, quaternion gradient <= 3/2 per entry, x8 rebuilt): 50 d
    defect = np.linalg.norm(np.einsum("kji,kjl->kil", r.rotation, r.rotation) - np.eye(3), ord=2, axis=(1, 2))
    assert np.all(np.abs(R_q - r.rotation) <= gamma(512) + 50.0 * defect[:, None, None])


def test_fixed_frame_baseline_stretches(beam):
    """Free spin about the major principal axis, 1 s: the fixed-frame linear model stretches the body,
    reframe keeps the distance between the rod's ends within the centrifugal static stretch."""
    m, c, J = mass_properties(beam)
    lam, V = np.linalg.eigh(J)
    w0 = 8.0 * V[:, 2]
    mb = modal_basis(beam, 3)
    ends = [0, BEAM_LOAD_NODE]
    d0 = np.linalg.norm(beam.nodes[ends[1]] - beam.nodes[ends[0]])
    base = FixedFrameBaseline(beam, mb).run(1.0, 2e-4, None, ends, omega0=w0, every=50)
    integ = ReframeIntegrator(beam, mb)
    integ.set_initial(omega0=w0)
    r = integ.run(1.0, 2e-4, None, ends, every=50)
    stretch_base = np.max(np.abs(np.linalg.norm(np.diff(base.point_position, axis=1)[:, 0], axis=1) / d0 - 1))
    stretch_ref = np.max(np.abs(np.linalg.norm(np.diff(r.point_position, axis=1)[:, 0], axis=1) / d0 - 1))
    static = (8.0 / (2 * np.pi * mb.frequencies_hz[0])) ** 2
    print(f"\nspin 8 rad/s about the major axis, 1 s: end-to-end stretch baseline {stretch_base:.3g}, "
          f"reframe {stretch_ref:.3g}, (Omega/omega_1)^2 = {static:.3g}")
    assert stretch_base > 1.0
    assert stretch_ref <= 2.0 * static


# --------------------------------------------------------------------------- bad input
def test_bad_input(beam):
    mb = modal_basis(beam, 2)
    integ = ReframeIntegrator(beam, mb)
    for dt in (0.0, -1e-3, float("nan")):
        with pytest.raises(ParameterError) as e:
            integ.step(dt)
        assert e.value.parameter == "dt"
    with pytest.raises(ParameterError) as e:
        integ.step(1e-4, PointLoad(BEAM_LOAD_NODE, lambda t: np.array([1.0, np.nan, 0.0])))
    assert e.value.parameter == "load.force"
    with pytest.raises(ParameterError) as e:
        integ.step(1e-4, PointLoad(BEAM_LOAD_NODE, (np.nan, 0.0, 0.0)))
    assert "force" in e.value.parameter
    with pytest.raises(ParameterError) as e:           # nodes 0, 1, 2 lie on the first segment (z axis)
        ReframeIntegrator(beam, mb, reference_points=(0, 1, 2))
    assert e.value.parameter == "reference_points"
    with pytest.raises(ParameterError) as e:
        ReframeIntegrator(beam, mb, reference_points=(0, 0, 5))
    assert e.value.parameter == "reference_points"
    few = dataclasses.replace(mb, shapes=mb.shapes[:, :5], stiffness=mb.stiffness[:5], damping=mb.damping[:5])
    with pytest.raises(ParameterError) as e:
        ReframeIntegrator(beam, few)
    assert e.value.parameter == "basis.shapes"
    swapped = dataclasses.replace(mb, shapes=mb.shapes[:, [6, 1, 2, 3, 4, 5, 0, 7]])
    with pytest.raises(ParameterError) as e:
        ReframeIntegrator(beam, swapped)
    assert e.value.parameter == "basis.shapes"
    with pytest.raises(ParameterError) as e:           # dt * omega_max > 2.8 is refused, not run
        integ.step(1e-2)
    assert e.value.parameter == "dt"
    with pytest.raises(ParameterError) as e:
        ReframeIntegrator(beam, mb, scheme="exact")
    assert e.value.parameter == "scheme"
