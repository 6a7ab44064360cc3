"""Stability where methods fail: each failure mode is shown, and detected or refused.

References never come from the code under test: the RK4 amplification polynomial, omega_max from a dense
generalised eigenproblem of (K, M), principal axes and rigid lengths from M and the nodes, the fixed-frame
model's stretch from geometry (a point moved along the tangent), the rigid added-mass loop of the
co-simulation from the bodies' 6x6 inertias, momentum and energy from M, K and the nodal state.
flexfmu.studies.stability (`flexfmu bench stability`) runs the full studies and draws the charts of
docs/stability.md.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg

from flexfmu.errors import FlexfmuError, ParameterError
from flexfmu.linalg.modal_basis import mass_properties, modal_basis
from flexfmu.reframe.models import load_model
from flexfmu.reframe.integrator import RK4_STABILITY_LIMIT, FixedFrameBaseline, ReframeIntegrator

from error_bounds import gamma, implementations_bound

AXES = "xyz"


# --------------------------------------------------------------------------- independent helpers
@pytest.fixture(scope="module")
def rod():
    """Free-free bent rod spatial_double_L, 4 elements per segment (13 nodes, 6 DOF per node)."""
    return load_model("beam:spatial_double_L", elements_per_segment=4)


def rk4_amplification(y):
    """|R(i y)| of classical RK4 for an undamped mode, R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24."""
    z = 1j * y
    return abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)


def natural_frequencies(structure):
    """All natural frequencies (rad/s, ascending, six rigid ~0 first): dense eigh of (K, M)."""
    lam = scipy.linalg.eigh(structure.K.toarray(), structure.M.toarray(), eigvals_only=True)
    return np.sqrt(np.clip(lam, 0.0, None))


def principal_axes(structure):
    """Principal moments (ascending) and axes (columns) about the centre of mass (flexfmu.linalg.modal_basis.
    mass_properties, checked against an independent computation in tests/test_reframe.py)."""
    props = mass_properties(structure)
    return props.principal_moments, props.principal_axes


def spurious_stretch(point_position, rigid_length):
    """Detection of stretching: max over time of |distance between two material points / rigid distance - 1|
    (point_position: (n_t, 2, 3) global)."""
    d = np.linalg.norm(point_position[:, 1] - point_position[:, 0], axis=1)
    return float(np.max(np.abs(d / rigid_length - 1.0)))


# --------------------------------------------------------------------------- 1. RK4 limit
def test_rk4_limit_growth_above_two_sqrt_two_and_refusal(rod):
    """The highest undamped mode grows per step by |R(i dt omega_max)|: just below 2 sqrt(2) it decays,
    just above it grows.  The guard sits in advance_steps / run; advance_steps(check_stability=False)
    steps past it.  Through the public API dt above the limit is
    refused naming dt and the allowed range."""
    basis = modal_basis(rod, 3, damping_ratio=0.0)
    integ = ReframeIntegrator(rod, basis, scheme="consistent")
    w_max = natural_frequencies(rod)[6 + 2]
    assert integ.data.omega_max == pytest.approx(w_max, rel=1e-8)
    nm = 6 + 3
    growth = {}
    for y in (2.75, 2.80, 2.85, 2.90):
        q0 = np.array([0.0, 0.0, 1e-7])
        s0 = integ.initial_state(q0=q0)
        s = integ.advance_steps(s0, y / w_max, 20, check_stability=False)
        amp = lambda st: math.hypot(st.eta[nm - 1], st.eta[-1] / w_max)  # noqa: E731
        growth[y] = (amp(s) / amp(s0)) ** (1 / 20)
        assert growth[y] == pytest.approx(rk4_amplification(y), rel=1e-4)
    print("\ngrowth per step at dt*omega_max = 2.75, 2.80, 2.85, 2.90: "
          + ", ".join(f"{g:.5f}" for g in growth.values()))
    assert growth[2.80] < 1.0 < growth[2.85]                 # crosses 1 at 2 sqrt(2) = 2.828
    assert growth[2.90] ** 20 > 30                           # 20 steps: the mode has grown 34-fold

    limit = RK4_STABILITY_LIMIT / w_max
    for run in (lambda dt: integ.run(0.01, dt), lambda dt: FixedFrameBaseline(rod, basis).run(0.01, dt)):
        with pytest.raises(ParameterError) as err:
            run(1.01 * limit)
        assert err.value.parameter == "dt"
        assert f"dt <= {limit:.4g} s" in err.value.allowed
    integ.run(20 * 0.99 * limit, 0.99 * limit)                 # just inside: accepted, stays finite
    assert np.all(np.isfinite(integ.state.eta))


def test_reframe_body_sub_steps_automatically_or_refuses_internal_step():
    """ReframeBody (the façade the FMU wraps) with an RK4 scheme: internal_step = 0 splits a communication
    step 10x the RK4 limit into 12 internal steps inside it (90 % of the limit) and logs why; an explicit
    internal_step above the limit is refused naming internal_step."""
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

    cfg = ReframeBodyConfig(model="beam:spatial_double_L", scheme="consistent", n_flexible_modes=3,
                            load_point_x=0.0, load_point_y=0.0, load_point_z=0.0,    # on the rod (its first node)
                            output_point_x=0.14, output_point_y=0.15, output_point_z=0.16)
    w_max = natural_frequencies(load_model("beam:spatial_double_L"))[6 + 2]
    limit = RK4_STABILITY_LIMIT / w_max
    with pytest.raises(ParameterError) as err:
        ReframeBodySimulator(dataclasses.replace(cfg, internal_step=1.05 * limit))
    assert err.value.parameter == "internal_step"
    sim = ReframeBodySimulator(cfg)
    h = 10 * limit
    assert sim.internal_steps(h) == 12                         # ceil(10 / 0.9)
    sim.set_inputs(F_z=1.0)
    for _ in range(20):
        sim.step(h)
    out = sim.output_vector()
    assert np.all(np.isfinite(out))
    assert out[-1] < 1e-3                                      # elastic displacement of a 1 N load: um, not exploding
    assert any("12 internal" in m and "RK4" in m for m in sim.messages)


# --------------------------------------------------------------------------- 2. large rotation
def test_large_rotation_fixed_frame_model_stretches_reframe_holds(rod):
    """Free spin at 1 rev/s about the major principal axis through 30 degrees: the fixed-frame linear
    model moves the rod's ends along tangents, stretching it by sqrt(1 + theta^2 sin^2 beta) - 1 (12 % —
    far beyond any elastic strain); reframe keeps the end-to-end distance within the physical
    centrifugal stretch (Omega / omega_1)^2."""
    basis = modal_basis(rod, 3)
    _, axes = principal_axes(rod)
    k = axes[:, 2]
    spin = 2 * math.pi
    theta = math.radians(30.0)
    t_end = theta / spin
    dt = t_end / 400
    ends = [0, rod.nodes.shape[0] - 1]
    d = rod.nodes[ends[1]] - rod.nodes[ends[0]]
    d0 = float(np.linalg.norm(d))
    base = FixedFrameBaseline(rod, basis).run(t_end, dt, None, ends, omega0=spin * k)
    integ = ReframeIntegrator(rod, basis, scheme="consistent")
    integ.set_initial(omega0=spin * k)
    r = integ.run(t_end, dt, None, ends)
    stretch_base = spurious_stretch(base.point_position, d0)
    stretch_reframe = spurious_stretch(r.point_position, d0)
    sin2beta = float(np.linalg.norm(np.cross(k, d / d0)) ** 2)
    analytic = math.sqrt(1 + theta**2 * sin2beta) - 1
    centrifugal = (spin / natural_frequencies(rod)[6]) ** 2
    print(f"\n30 deg at 1 rev/s: stretch baseline {stretch_base:.4g} (analytic {analytic:.4g}), "
          f"reframe {stretch_reframe:.3g}, (Omega/omega_1)^2 = {centrifugal:.3g}")
    assert stretch_base == pytest.approx(analytic, rel=1e-9)
    assert stretch_base > 0.05                                 # 5 % strain: 25x the yield strain of steel
    assert stretch_reframe < 2.0 * centrifugal                 # static stretch, overshoot from rest <= 2x
    assert stretch_reframe < 1e-3 * stretch_base


# --------------------------------------------------------------------------- 3. co-simulation coupling
def _study():
    """flexfmu.studies.stability, which draws the charts from the same system and predictions."""
    from flexfmu.studies import stability_cosim as stability
    return stability


def platform_beam_system(mass_ratio: float):
    """The study's FFRBeam-on-a-rigid-Platform system (platform density from the mass ratio), with the beam's
    inertia integrals and the platform's config."""
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    from flexfmu.wec.platform import PlatformConfig

    system = _study().platform_beam_system(mass_ratio)
    rho = next(spec for spec in system.simulators if spec.name == "platform").initial_values["rho"]
    return system, FFRBeamSimulator(FFRBeamConfig()).dynamics.integrals, PlatformConfig(rho=rho)


def kicked_run(system, h, scheme, n_steps):
    """A 1 N kick on the beam tip for one step, then free; peak |payload force| in the first and last
    fifth, or the divergence a component reported."""
    from flexfmu.cosim.masters import Master

    master = Master(system, "library")
    master.initialize()
    master.slaves["beam"].set(["F_z"], [1.0])
    peaks = []
    for k in range(n_steps):
        master.step(k * h, h, scheme)
        master.slaves["beam"].set(["F_z"], [0.0])
        peaks.append(np.linalg.norm([master.slaves["platform"].values[f"payload_F_{a}"] for a in AXES]))
    m = n_steps // 5
    return max(peaks[:m]), max(peaks[-m:])


def residual_inertia():
    """The beam's rigid inertia not carried by its retained modes, from the FE matrices (the study's)."""
    return _study().residual_inertia()


def test_cosim_coupling_instability_detected_and_stable_point_stable():
    """Explicit force/motion coupling: the beam's clamp reaction, held over a step, acts on the platform as
    an added mass computed one exchange late: the accelerations are multiplied by -T Mp^-1 T^T B_res per
    exchange (B_res: residual inertia of the beam about the mount, Mp: the platform's inertia about O,
    T: O -> mount) at any small step.  For a heavy beam (mass ratio 10) |lambda| > 1: ``stability_check``
    reports it and a run diverges (the Platform raises).  A light beam (mass ratio 1e-3) at 0.1 ms is
    stable and its run decays; a beam as heavy as the platform is stable at 0.1 ms but not at 2.5 ms,
    where the step approaches its modes' periods (40-322 Hz)."""
    from flexfmu.cosim.masters import STABILITY_TOLERANCE, spectral_radius, stability_check, step_map
    from flexfmu.wec.platform import mass_matrix
    from flexfmu.core.vec3 import skew

    system, ints, pcfg = platform_beam_system(10.0)
    Mp = mass_matrix(pcfg)
    T = np.block([[np.eye(3), -skew(pcfg.mount)], [np.zeros((3, 3)), np.eye(3)]])
    loop = float(np.max(np.abs(np.linalg.eigvals(T @ np.linalg.solve(Mp, T.T @ residual_inertia())))))
    h = 1e-5                                   # far below the beam's periods: the instantaneous loop dominates
    rho_gs = float(np.max(np.abs(np.linalg.eigvals(step_map(system, h, "gauss-seidel")))))
    print(f"\nmass ratio 10: residual-inertia loop {loop:.4f}, spectral radius Gauss-Seidel at 1e-5 s {rho_gs:.4f}")
    assert loop > 2.0
    assert rho_gs == pytest.approx(loop, rel=1e-3)
    check = stability_check(system, h, "gauss-seidel", n_grid=2)
    assert not check["stable"] and check["spectral_radius"] > 1 + STABILITY_TOLERANCE
    with pytest.raises(FlexfmuError, match="diverged"):
        kicked_run(system, h, "gauss-seidel", 200)

    light, _, _ = platform_beam_system(1e-3)
    check = stability_check(light, 1e-4, "jacobi", n_grid=2)
    assert check["stable"] and check["first_unstable"] is None
    first, last = kicked_run(light, 1e-4, "jacobi", 200)
    assert last < first
    equal, _, _ = platform_beam_system(1.0)
    assert spectral_radius(equal, 1e-4, "gauss-seidel") <= 1 + STABILITY_TOLERANCE
    assert spectral_radius(equal, 2.5e-3, "gauss-seidel") > 1.1


# --------------------------------------------------------------------------- 4. 3D tumbling
def momentum_and_energy(integ, structure, state):
    """Global angular momentum about the origin and T + V, from M, K and the nodal state."""
    ns = integ.nodal_state(state)
    R = state.rotation
    Mw = structure.M @ ns.velocity_body
    Mw_g = (Mw.reshape(-1, 3) @ R.T).reshape(structure.nodes.shape[0], -1)
    L = np.cross(ns.positions, Mw_g[:, :3]).sum(axis=0) + Mw_g[:, 3:].sum(axis=0)
    return L, 0.5 * ns.velocity_body @ Mw + 0.5 * ns.displacement @ (structure.K @ ns.displacement)


def momentum_term_size(integ, structure, state):
    """sum over nodes of |x| (|M| |v|) + |M| |v| (rotational DOFs): the size of the terms summed into L."""
    ns = integ.nodal_state(state)
    aMv = (abs(structure.M) @ np.abs(ns.velocity_body)).reshape(structure.nodes.shape[0], -1)
    return float(np.linalg.norm(ns.positions, axis=1) @ np.linalg.norm(aMv[:, :3], axis=1)
                 + np.linalg.norm(aMv[:, 3:], axis=1).sum())


def tumbling_drift(rod, scheme, dt, t_end=1.0, records=10):
    basis = modal_basis(rod, 3, damping_ratio=0.0)
    _, axes = principal_axes(rod)
    integ = ReframeIntegrator(rod, basis, scheme=scheme)
    s = integ.initial_state(omega0=8.0 * (axes[:, 1] + 0.1 * axes[:, 2]))
    L0, E0 = momentum_and_energy(integ, rod, s)
    n = int(round(t_end / dt))
    dL = dE = flip = 0.0
    size = momentum_term_size(integ, rod, s)
    for _ in range(records):
        s = integ.advance_steps(s, dt, n // records)
        L, E = momentum_and_energy(integ, rod, s)
        size = max(size, momentum_term_size(integ, rod, s))
        dL = max(dL, float(np.linalg.norm(L - L0) / np.linalg.norm(L0)))
        dE = max(dE, abs(E - E0) / E0)
        flip = max(flip, math.degrees(math.acos(np.clip((s.rotation @ axes[:, 1]) @ axes[:, 1], -1, 1))))
    # L is the consistent scheme's state, conserved exactly by its step map (a rotation of it: growth 1): per
    # step 4 RK4 stages of a 9 x 9 mass solve (~27 roundings), the right-hand side (~24) and the stage sum (4),
    # plus the reframing and the frame update (~20): ~240, over-counted as 256, on |L|; measuring L (sparse
    # M v, <= 24 terms a row, rotation, cross, 13-node sum: < 48 roundings) on the terms' size, L0 and L
    bound = (implementations_bound(np.linalg.norm(L0), 256, 1.0, n) + 2.0 * gamma(48) * size) / np.linalg.norm(L0)
    return dL, dE, flip, bound


def test_tumbling_paper_scheme_drifts_consistent_conserves(rod):
    """Spin about the intermediate principal axis (+10 % about the major one): the rod flips.  The paper
    scheme loses angular momentum at 1e-2 level; the consistent scheme conserves it to rounding (it is
    its state), and its energy error falls at RK4's order."""
    dts = (3.75e-4, 1.875e-4, 9.375e-5)
    paper = tumbling_drift(rod, "paper", 7.5e-4)
    cons = [tumbling_drift(rod, "consistent", dt) for dt in (7.5e-4, *dts)]
    orders = [math.log2(cons[k][1] / cons[k + 1][1]) for k in (1, 2)]
    print(f"\ntumbling 1 s, dt 7.5e-4: |dL|/|L| paper {paper[0]:.3g}, consistent {cons[0][0]:.3g}; "
          f"flip {cons[0][2]:.0f} deg; consistent energy drift {[f'{c[1]:.3g}' for c in cons]}, orders {orders}")
    assert cons[0][2] > 90.0                                   # it does tumble
    assert paper[0] > 1e-3
    assert all(c[0] <= c[3] for c in cons)                      # conserved to a derived rounding bound
    assert paper[0] > 1e8 * cons[0][0]
    assert min(orders) > 3.5
