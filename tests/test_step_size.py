"""Caches keyed by a step size accept the step a host really passes (flexfmu.core.step_size).

A host that computes each step as h = t(k+1) - t(k) (fmpy.simulate_fmu, libcosim, fmusim) passes steps that differ
in their last bits.  Every cache keyed by a step size, in Python and in C, takes a step within STEP_RTOL of a cached
one as that step.  Where the cached entry is the whole step map (the exact zero-order hold of the clamped kinds),
such a run is the same computation as a constant-step run, so the two are compared bit for bit: a cache that
recomputed its maps for each last-bit variant would round differently.  Where only coefficients are shared (the
reframe exponential scheme, whose stages take the host's own step), the two runs differ within the bound stated
in flexfmu.core.step_size."""
from __future__ import annotations

import ctypes

import numpy as np
import pytest

from fmu_helpers import clock_and_constant_step_runs
from flexfmu.core.step_size import STEP_RTOL, StepSizes, same_step

EPS = np.finfo(float).eps
T0, STEP = 1e3, 1e-4            # a late start makes the clock steps differ from each other by ~1e-9 relative


def clock_steps(n, t0=T0, step=STEP):
    return [(t0 + (k + 1) * step) - (t0 + k * step) for k in range(n)]


# ---------------------------------------------------------------------------------------------- the policy
@pytest.mark.unit
def test_same_step_within_the_tolerance_only():
    assert same_step(1e-3, 1e-3 * (1 + 0.5 * STEP_RTOL))
    assert not same_step(1e-3, 1e-3 * (1 + 2 * STEP_RTOL))
    steps = StepSizes()
    first = steps.canonical(1e-4)
    assert all(steps.canonical(h) == first for h in clock_steps(2000))
    assert steps.canonical(2e-4) == 2e-4 and steps.canonical(1e-4 * (1 + 1e-9)) == first


@pytest.mark.unit
def test_python_and_c_share_one_tolerance():
    from flexfmu.native.lti import library
    rtol = library().ffx_step_rtol
    rtol.restype = ctypes.c_double
    assert rtol() == STEP_RTOL


@pytest.mark.unit
def test_host_clock_steps_differ_in_their_last_bits_within_the_tolerance():
    steps = clock_steps(10000)
    assert len(set(steps)) > 1                                      # what a host really passes
    assert max(abs(h - STEP) for h in steps) / STEP < STEP_RTOL     # ... and what the caches take as one step


# ---------------------------------------------------------------------------------------------- library caches
@pytest.fixture(scope="module")
def ffr_simulator():
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    return lambda: FFRBeamSimulator(FFRBeamConfig(boundary="XFF", n_modes=6))


@pytest.mark.unit
def test_ffr_simulator_keeps_one_map_for_the_clock_steps(ffr_simulator):
    runs = []
    for steps in (clock_steps(500), [clock_steps(1)[0]] * 500):
        sim = ffr_simulator()
        sim.set_input_vector(_ffr_inputs(sim))
        for h in steps:
            sim.step(h)
        assert len(sim._map_cache) == 1
        runs.append(np.concatenate([sim.state.eta, sim.state.eta_dot]))
    assert np.array_equal(runs[0], runs[1])        # one map: the same operations in the same order


def _ffr_inputs(sim):
    from flexfmu.ffr.simulator import INPUT_NAMES
    values = dict.fromkeys(INPUT_NAMES, 0.0)
    values.update(F_x=1.0, F_y=-2.0, F_z=0.5, base_w_z=0.3)       # a spinning base: maps depend on it too
    return [values[n] for n in INPUT_NAMES]


@pytest.mark.unit
def test_lti_kernel_updates_its_maps_once_for_the_clock_steps(ffr_simulator):
    from flexfmu.native.lti import LtiModel
    model = LtiModel.from_ffrbeam(ffr_simulator())
    kernel = model.kernel()
    rng = np.random.default_rng(7)
    x0, u, p = rng.normal(size=model.nx), rng.normal(size=model.nu), 0.1 * rng.normal(size=model.np)
    finals = []
    for steps in (clock_steps(300), [clock_steps(1)[0]] * 300):
        x = x0
        before = kernel._maps.n_step_updates
        for h in steps:
            x = kernel.step(x, u, p, h)
        assert kernel._maps.n_step_updates - before <= 1
        finals.append(x)
    assert np.array_equal(finals[0], finals[1])
    before = kernel._maps.n_step_updates
    kernel.step(x0, u, p, STEP * (1 + 10 * STEP_RTOL))             # another step: new maps
    assert kernel._maps.n_step_updates == before + 1


@pytest.mark.unit
def test_exponential_scheme_keeps_one_coefficient_set_for_the_clock_steps():
    """The ReframeBody simulator asks its (shared) integrator for the coefficients of its own first step only."""
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
    origin = dict(load_point_x=0.0, load_point_y=0.0, load_point_z=0.0, output_point_x=0.0, output_point_y=0.0,
                  output_point_z=0.0)                         # the rod's first node (points must lie on the body)
    sim = ReframeBodySimulator(ReframeBodyConfig(model="beam:spatial_double_L", n_flexible_modes=4, **origin))
    cache = sim.integrator._ex_cache
    before = set(cache)
    for h in clock_steps(50, step=1e-3):
        sim.step(h)
    assert len(set(cache) - before) <= 1
    from flexfmu.errors import ParameterError
    with pytest.raises(ParameterError, match="coefficients_dt"):          # only a step's last-bit variants
        sim.integrator.advance_steps(sim.state, 1e-3, 1, coefficients_dt=2e-3)


@pytest.mark.unit
def test_instances_do_not_share_their_step_history():
    """Two simulators of one model (one shared dynamics and integrator): each takes its own first step as the
    canonical one, so a run does not depend on what another instance stepped with before."""
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    config = FFRBeamConfig(boundary="XFF", n_modes=6)
    first = FFRBeamSimulator(config)
    first.set_input_vector(_ffr_inputs(first))
    first.step(STEP * (1 + 0.5 * STEP_RTOL))              # a step the next instance must not inherit
    runs = []
    for _ in range(2):
        sim = FFRBeamSimulator(config)
        sim.set_input_vector(_ffr_inputs(sim))
        for _ in range(100):
            sim.step(STEP)
        runs.append(np.concatenate([sim.state.eta, sim.state.eta_dot]))
    assert np.array_equal(runs[0], runs[1])
    assert FFRBeamSimulator(config).dynamics is first.dynamics   # shared: the case this test is about


# ---------------------------------------------------------------------------------------------- through FMUs
@pytest.fixture(scope="module")
def native_ffrbeam(tmp_path_factory):
    from flexfmu.fmi import native as build
    return build.build_registry_fmu("FFRBeam", target=tmp_path_factory.mktemp("clock") / "FFRBeam.fmu")


FFR_INPUTS = {"F_x": 1.0, "F_y": -2.0, "F_z": 0.5, "base_w_z": 0.3}


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_ffrbeam_in_a_clock_host_equals_a_constant_step_host_bit_for_bit(runtime, fmus, native_ffrbeam):
    fmu = fmus["FFRBeam"] if runtime == "python" else native_ffrbeam
    clock, constant, jitter = clock_and_constant_step_runs(fmu, FFR_INPUTS, STEP, 400, t0=T0)
    assert 0 < jitter < STEP_RTOL
    assert np.array_equal(clock, constant)


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_fmpy_simulate_fmu_equals_a_constant_step_loop(runtime, fmus, native_ffrbeam):
    """fmpy.simulate_fmu steps from t = k dt as (k + 1) dt - k dt: the same numbers as FMU2Slave with a constant dt."""
    from fmpy import simulate_fmu
    fmu = fmus["FFRBeam"] if runtime == "python" else native_ffrbeam
    n, dt = 3000, 1e-4
    result = simulate_fmu(str(fmu), start_time=0.0, stop_time=n * dt, step_size=dt, output_interval=dt,
                          start_values=FFR_INPUTS, output=["sensor_a_y", "reaction_M_z"])
    _, constant, _ = clock_and_constant_step_runs(fmu, FFR_INPUTS, dt, n, t0=0.0)
    steps = np.diff(result["time"])
    assert len(set(steps.tolist())) > 1                              # simulate_fmu's steps do vary
    from fmpy import read_model_description
    names = [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output"]
    for name in ("sensor_a_y", "reaction_M_z"):
        assert np.array_equal(result[name][1:], constant[:, names.index(name)])


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_reframebody_in_a_clock_host_is_within_the_stated_bound(runtime, fmus, tmp_path):
    """The exponential scheme shares its coefficients for a step's last-bit variants; its stages take the host's
    step.  Bound (flexfmu.core.step_size): per step the coefficients differ by <= jitter * omega_max dt relative,
    so after n steps the outputs differ by <= n * jitter * (1 + omega_max dt) relative to their size, plus the
    rounding of the stages (a few eps per step)."""
    from flexfmu.fmi import native as build
    fmu = fmus["ReframeBody"] if runtime == "python" else build.build_registry_fmu(
        "ReframeBody", target=tmp_path / "ReframeBody.fmu")
    n, step = 200, 1e-3
    clock, constant, jitter = clock_and_constant_step_runs(fmu, {"F_x": 30.0, "F_z": 30.0}, step, n, t0=T0)
    assert 0 < jitter < STEP_RTOL
    omega_max_dt = 2 * np.pi * 2000.0 * step        # above the FMU's default band (modes up to f_max)
    bound = n * (jitter * (1 + omega_max_dt) + 16 * EPS)
    # normwise over the outputs of each step: outputs that are zero in exact arithmetic (1e-21) have no scale of
    # their own; their rounding follows the body's motion, which the norm carries
    worst = np.max(np.linalg.norm(clock - constant, axis=1) / np.linalg.norm(constant, axis=1))
    assert worst <= bound, (worst, bound)
