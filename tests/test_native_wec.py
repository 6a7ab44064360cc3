"""The native point-absorber FMUs (the wec kind, csrc/native_wec.c): AbsorberWave, AbsorberFloat, AbsorberHydro and
HeavePTO against a numpy transcription of the specification (tests/wec_reference.py) on random inputs and parameters,
FMU states, refusals naming the parameter or input, fmpy's validation.

The hull is a stand-in of random but valid data (wec_reference.stand_in_hull: full 6x6 couplings, a stable
radiation model), so the FMUs build in seconds without the BEM database.

Tolerance: 1e-12 of each output's largest magnitude over the run.  Both sides evaluate the same formulas in IEEE
double; they differ in summation order, libm versus numpy's cos/exp, the matrix exponential (scipy's LAPACK solve
versus the kernels' LU) and the wave's phasor recurrence (csrc/native_wec.c: <= 64 complex products between exact
anchors, < 3.6e-14 of each component).  Each of those is a few eps per operation on terms no larger than the
output's scale times the sum's length: <= 500 components x ~4 eps = 4.4e-13 for the wave's sums, ~1e-14 for the 6x6
and n_r-state products; the float's double integration adds a rounding per step to a state whose scale grows with
it, so its relative error stays a few eps x the number of steps (<= 400 here: ~1e-13).  The wave's phases also
carry the rounding of w t: eps w t <= 2.2e-16 x 5 rad/s x 60 s = 7e-14 over the runs here.  1e-12 is above all
of these and far below any error of the equations (a wrong sign, factor or index is > 1e-3)."""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import wec_reference as R  # noqa: E402
from fmu_helpers import Instance, error_messages  # noqa: E402

RTOL = 1e-12
#: the Python simulators' bounds on |xi|, |xi_dot| (m, rad, m/s, rad/s) and on the radiation memory states
DIVERGENCE_LIMITS = {"AbsorberFloat": 1e3, "AbsorberHydro": 1e12}


@pytest.fixture(scope="module")
def hull():
    return R.stand_in_hull()


@pytest.fixture(scope="module")
def fmus(hull, tmp_path_factory) -> dict:
    """The four native FMUs of the stand-in hull and specs, at the specs' defaults."""
    from flexfmu.fmi import native
    from flexfmu.fmi.native_build import build_native_fmu

    out = tmp_path_factory.mktemp("native_wec")
    built = {}
    for name, component in native.WEC_COMPONENTS.items():
        spec = R.SPECS[name]
        source = native.wec_source(spec, component, dataclasses.asdict(spec.config_class()), hull, name,
                                   divergence_limit=DIVERGENCE_LIMITS.get(name, np.inf))
        built[name] = build_native_fmu(source, out / f"{name}.fmu")
    return built


def relative(native: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per output: max |native - reference| over the run / max |reference| (1 where the reference is 0)."""
    scale = np.max(np.abs(reference), axis=0)
    return np.max(np.abs(native - reference), axis=0) / np.where(scale > 0, scale, 1.0)


def run(fmu, outputs, steps, inputs=None, input_names=(), **start) -> np.ndarray:
    """The outputs after each step of ``steps`` (step sizes) with ``inputs[k]`` set before step k."""
    inst = Instance(fmu, **start).initialize()
    try:
        vr_in = [inst.vr[n] for n in input_names]
        vr_out = [inst.vr[n] for n in outputs]
        t, rows = 0.0, []
        for k, h in enumerate(steps):
            if input_names:
                inst.fmu.setReal(vr_in, list(inputs[k]))
            inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            t += h
            rows.append(inst.fmu.getReal(vr_out))
        return np.array(rows)
    finally:
        inst.free()


# ---------------------------------------------------------------------------------------------- wave
WAVES = {
    "regular": {"sea_state": "regular", "wave_height": 3.1, "wave_period": 6.3, "ramp_time": 7.0},
    "jonswap-seed3-automatic": {"sea_state": "jonswap", "seed": 3, "n_components": 0},
    "jonswap-random": {"sea_state": "jonswap", "wave_height": 4.2, "wave_period": 9.7, "gamma": 1.7, "seed": 12345,
                       "n_components": 500, "record_length": 600.0, "ramp_time": 0.0},
}


@pytest.mark.parametrize("case", list(WAVES))
def test_wave_equals_the_specification(fmus, hull, case):
    """60 s in steps of 0.02 s, then steps that change size (the phasors' rotations recomputed, re-anchored)."""
    p = {**R.WAVE_DEFAULTS, **WAVES[case]}
    rng = np.random.default_rng(5)
    steps = np.concatenate([np.full(3000, 0.02), rng.uniform(0.001, 0.05, 200), np.full(100, 0.01)])
    got = run(fmus["AbsorberWave"], R.WAVE_OUTPUTS, steps, **WAVES[case])
    components = R.wave_components(p, hull)
    times = np.cumsum(steps)
    expected = np.array([R.wave_outputs(p, hull, t, components) for t in times])
    if case.startswith("jonswap-seed3"):
        assert components[0].size == 375            # ceil(2.5 x 1200 s / 8 s)
    diff = relative(got, expected)
    print(f"wave {case}: native vs specification {np.max(diff):.2g}")
    assert np.max(diff) <= RTOL, dict(zip(R.WAVE_OUTPUTS, diff))
    assert np.max(np.abs(expected[:, 0])) > 0.3 * p["wave_height"]


def test_wave_with_a_host_clock_whose_steps_differ_in_the_last_bits(fmus, hull):
    """h = t(k+1) - t(k) from t0 = 1000 s (steps differing by ~1e-13 relative): the phasors stay on the
    recurrence (the drift is taken to first order) and equal the exact sum."""
    from fmu_helpers import clock_and_constant_step_runs
    p = {**R.WAVE_DEFAULTS, "sea_state": "jonswap", "n_components": 200, "ramp_time": 0.0}
    start = {k: p[k] for k in ("sea_state", "n_components", "ramp_time")}
    clock, constant, jitter = clock_and_constant_step_runs(fmus["AbsorberWave"], {}, 0.01, 500, t0=1000.0, **start)
    assert jitter > 0
    components = R.wave_components(p, hull)
    for rows, steps in ((clock, [(1000.0 + (k + 1) * 0.01) - (1000.0 + k * 0.01) for k in range(500)]),
                        (constant, [(1000.0 + 0.01) - 1000.0] * 500)):
        times = np.cumsum(steps)
        expected = np.array([R.wave_outputs(p, hull, t, components) for t in times])
        assert np.max(relative(rows, expected)) <= RTOL


# ---------------------------------------------------------------------------------------------- float, hydro, PTO
@pytest.mark.parametrize("heave_only", [False, True])
def test_float_equals_the_specification(fmus, hull, heave_only):
    rng = np.random.default_rng(11)
    n = 400
    steps = rng.uniform(0.005, 0.02, n)
    loads = rng.normal(size=(n, 24)) * np.tile([1e5, 1e5, 1e5, 3e5, 3e5, 3e5], 4)
    got = run(fmus["AbsorberFloat"], R.FLOAT_OUTPUTS, steps, loads, R.FLOAT_INPUTS, heave_only=heave_only)
    ref = R.FloatReference({"heave_only": heave_only}, hull)
    expected = []
    for u, h in zip(loads, steps):
        ref.step(u, h)
        expected.append(ref.outputs(u))
    diff = relative(got, np.array(expected))
    print(f"float heave_only={heave_only}: native vs specification {np.max(diff):.2g}")
    assert np.max(diff) <= RTOL, dict(zip(R.FLOAT_OUTPUTS, diff))
    if heave_only:
        assert np.all(got[:, [0, 1, 3, 4, 5, 6, 7, 9, 10, 11]] == 0.0)


@pytest.mark.parametrize("drag", [True, False])
def test_hydro_equals_the_specification(fmus, hull, drag):
    rng = np.random.default_rng(13)
    n = 400
    params = {"drag": drag, **{f"drag_coefficient_{d}": rng.uniform(0, 2) for d in R.DOFS},
              **{f"drag_area_{d}": rng.uniform(0, 80) for d in R.DOFS}}
    motion = rng.normal(size=(n, 12)) * np.array([1, 1, 1, 0.1, 0.1, 0.1, 2, 2, 2, 0.3, 0.3, 0.3])
    steps = np.concatenate([np.full(n // 2, 0.01), rng.uniform(0.002, 0.05, n - n // 2)])
    got = run(fmus["AbsorberHydro"], R.HYDRO_OUTPUTS, steps, motion, R.MOTION, **params)
    ref = R.HydroReference({**R.HYDRO_DEFAULTS, **params}, hull)
    expected = []
    for u, h in zip(motion, steps):
        ref.step(u, h)
        expected.append(ref.outputs(u))
    expected = np.array(expected)
    diff = relative(got, expected)
    print(f"hydro drag={drag}: native vs specification {np.max(diff):.2g}")
    assert np.max(diff) <= RTOL, dict(zip(R.HYDRO_OUTPUTS, diff))
    assert (np.max(expected[:, 6]) > 0) == drag and np.min(expected[:, 6]) >= 0


@pytest.mark.parametrize("limit", [0.0, 1.5e5])
def test_pto_equals_the_specification(fmus, limit):
    rng = np.random.default_rng(17)
    n = 300
    params = {"damping": rng.uniform(0, 5e5), "stiffness": rng.uniform(-1e5, 1e5), "force_limit": limit}
    motion = rng.normal(size=(n, 2)) * [1.0, 1.5]
    got = run(fmus["HeavePTO"], ("F_z", "power"), np.full(n, 0.01), motion, ("pos_z", "vel_z"), **params)
    expected = np.array([R.pto_outputs(params, u) for u in motion])
    assert np.max(relative(got, expected)) <= RTOL
    if limit:
        assert np.max(np.abs(got[:, 0])) == limit        # the limit is active on some steps


# ---------------------------------------------------------------------------------------------- Python simulators
@pytest.fixture(scope="module")
def registry_fmus(tmp_path_factory) -> dict:
    """The four registry FMUs built by flexfmu.fmi.native (the real hull: flexfmu.wec.absorber.hull, cached)."""
    from flexfmu.fmi.native import WEC_COMPONENTS, build_registry_fmu
    out = tmp_path_factory.mktemp("registry_wec")
    return {name: build_registry_fmu(name, target=out / f"{name}.fmu") for name in WEC_COMPONENTS}


def python_run(simulator, steps, inputs=None, input_names=()) -> np.ndarray:
    """What ``run`` records, from a flexfmu.wec.absorber simulator."""
    rows = []
    for k, h in enumerate(steps):
        if input_names:
            simulator.set_inputs(**dict(zip(input_names, map(float, inputs[k]))))
        simulator.step(float(h))
        rows.append(list(simulator.outputs().values()))
    return np.array(rows)


@pytest.mark.parametrize("case", [{"sea_state": "regular", "wave_height": 1.3, "wave_period": 5.1, "ramp_time": 3.0},
                                  {"sea_state": "jonswap", "seed": 3, "n_components": 0},
                                  {"sea_state": "jonswap", "wave_period": 9.0, "record_length": 1800.0},
                                  {"sea_state": "jonswap", "wave_height": 3.3, "wave_period": 11.0, "gamma": 2.2,
                                   "seed": 777, "n_components": 512, "ramp_time": -1.0}],
                         ids=["regular", "jonswap-seed3-automatic", "jonswap-whole-count", "jonswap-random"])
def test_wave_equals_the_python_simulator(registry_fmus, case):
    from flexfmu.wec.absorber import wave
    if case.get("record_length") == 1800.0:     # 2.5 L / Tp = 500 exactly: through w_p it would round up to 501
        assert wave.component_count(wave.AbsorberWaveConfig(**case)) == 500
    steps = np.concatenate([np.full(2000, 0.01), np.random.default_rng(3).uniform(0.001, 0.1, 300)])
    got = run(registry_fmus["AbsorberWave"], wave.OUTPUT_NAMES, steps, **case)
    expected = python_run(wave.AbsorberWaveSimulator(wave.AbsorberWaveConfig(**case)), steps)
    diff = relative(got, expected)
    print(f"wave {case}: native vs Python {np.max(diff):.2g}")
    assert np.max(diff) <= RTOL, dict(zip(wave.OUTPUT_NAMES, diff))


@pytest.mark.parametrize("heave_only", [False, True])
def test_float_equals_the_python_simulator(registry_fmus, heave_only):
    from flexfmu.wec.absorber import float_body as fb
    rng = np.random.default_rng(23)
    steps = rng.uniform(0.005, 0.02, 400)
    loads = rng.normal(size=(400, 24)) * np.tile([2e4, 2e4, 2e4, 6e4, 6e4, 6e4], 4)
    got = run(registry_fmus["AbsorberFloat"], fb.OUTPUT_NAMES, steps, loads, fb.INPUT_NAMES, heave_only=heave_only)
    expected = python_run(fb.AbsorberFloatSimulator(fb.AbsorberFloatConfig(heave_only)), steps, loads, fb.INPUT_NAMES)
    diff = relative(got, expected)
    print(f"float heave_only={heave_only}: native vs Python {np.max(diff):.2g}")
    assert np.max(diff) <= RTOL, dict(zip(fb.OUTPUT_NAMES, diff))


@pytest.mark.parametrize("drag", [True, False])
def test_hydro_equals_the_python_simulator(registry_fmus, drag):
    from flexfmu.wec.absorber import hydro
    rng = np.random.default_rng(29)
    params = {"drag": drag, **{n: rng.uniform(0, 2) for n in hydro.CD_NAMES},
              **{n: rng.uniform(0, 60) for n in hydro.AREA_NAMES}}
    motion = rng.normal(size=(400, 12)) * np.array([0.5, 0.5, 1, 0.05, 0.05, 0.05, 1, 1, 2, 0.1, 0.1, 0.1])
    steps = np.concatenate([np.full(200, 0.01), rng.uniform(0.002, 0.05, 200)])
    got = run(registry_fmus["AbsorberHydro"], hydro.OUTPUT_NAMES, steps, motion, hydro.INPUT_NAMES, **params)
    expected = python_run(hydro.AbsorberHydroSimulator(hydro.AbsorberHydroConfig(**params)), steps, motion,
                          hydro.INPUT_NAMES)
    diff = relative(got, expected)
    print(f"hydro drag={drag}: native vs Python {np.max(diff):.2g}")
    assert np.max(diff) <= RTOL, dict(zip(hydro.OUTPUT_NAMES, diff))


def test_pto_equals_the_python_simulator(registry_fmus):
    from flexfmu.wec.absorber import pto
    rng = np.random.default_rng(31)
    params = {"damping": 4.2e5, "stiffness": -3.0e4, "force_limit": 2.5e5}
    motion = rng.normal(size=(300, 2)) * [1.0, 1.0]
    steps = np.full(300, 0.01)
    got = run(registry_fmus["HeavePTO"], pto.OUTPUT_NAMES, steps, motion, pto.INPUT_NAMES, **params)
    expected = python_run(pto.HeavePTOSimulator(pto.HeavePTOConfig(**params)), steps, motion, pto.INPUT_NAMES)
    assert np.array_equal(got, expected)                 # the same few operations in the same order
    assert np.max(np.abs(got[:, 0])) == params["force_limit"]


@pytest.mark.parametrize("fmu, start", [
    ("AbsorberWave", {"wave_period": 0.9}), ("AbsorberWave", {"sea_state": "jonswap", "wave_period": 70.0}),
    ("AbsorberWave", {"sea_state": "jonswap", "record_length": 4e4}), ("AbsorberWave", {"sea_state": "swell"}),
    ("AbsorberWave", {"seed": -1}), ("AbsorberHydro", {"drag_area_rx": -2.0}),
    ("AbsorberHydro", {"drag_coefficient_x": 1e300, "drag_area_x": 1e300}), ("HeavePTO", {"damping": -1.0}),
], ids=["period-regular", "period-jonswap", "record_length", "sea_state", "seed", "area", "drag-rate", "damping"])
def test_a_bad_parameter_gives_the_python_simulators_message(registry_fmus, fmu, start):
    """fmi2Error at fmi2ExitInitializationMode with the message the Python simulator's ParameterError has."""
    from flexfmu.errors import ParameterError
    from flexfmu.fmi import registry
    spec = registry.BY_NAME[fmu]
    with pytest.raises(ParameterError) as python:
        spec.make_simulator(spec.config_class(**start))
    inst = Instance(registry_fmus[fmu], **start)
    try:
        inst.expect_failure(inst.fmu.exitInitializationMode)
        assert error_messages(inst)[-1] == str(python.value)
    finally:
        inst.free()


# ---------------------------------------------------------------------------------------------- FMU states
STATE_CASES = {"AbsorberWave": ({"sea_state": "jonswap", "n_components": 300}, ()),
               "AbsorberFloat": ({}, R.FLOAT_INPUTS), "AbsorberHydro": ({}, R.MOTION),
               "HeavePTO": ({"force_limit": 1e5}, ("pos_z", "vel_z"))}


@pytest.mark.parametrize("name", list(STATE_CASES))
def test_fmu_state_round_trip_gives_the_same_numbers_bit_for_bit(fmus, name):
    """Steps, a serialised FMU state, more steps; the state restored (deserialised into a new instance too) and
    the same steps again: the same outputs bit for bit (the wave's phasors are rebuilt by the same products)."""
    start, input_names = STATE_CASES[name]
    rng = np.random.default_rng(19)
    inst = Instance(fmus[name], **start).initialize()
    other = Instance(fmus[name], "other", **start).initialize()
    try:
        outputs = [v.name for v in inst.md.modelVariables if v.causality == "output"]
        inputs = rng.normal(size=(200, len(input_names))) * 1e4

        def steps(instance, t, rows):
            for k in range(rows.start, rows.stop):
                if input_names:
                    instance.set(**dict(zip(input_names, inputs[k])))
                instance.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
                t += 0.01
                yield instance.get(*outputs)

        list(steps(inst, 0.0, range(0, 90)))        # past an anchor of the wave (64 steps) on purpose
        t = 0.9
        state = inst.fmu.getFMUstate()
        blob = inst.fmu.serializeFMUstate(state)
        first = np.array(list(steps(inst, t, range(90, 200))))
        inst.fmu.setFMUstate(state)
        again = np.array(list(steps(inst, t, range(90, 200))))
        other.fmu.setFMUstate(other.fmu.deSerializeFMUstate(blob))
        elsewhere = np.array(list(steps(other, t, range(90, 200))))
        assert np.array_equal(first, again) and np.array_equal(first, elsewhere)
        assert np.any(first != 0.0)
    finally:
        inst.free()
        other.free()


# ---------------------------------------------------------------------------------------------- refusals
@pytest.mark.parametrize("start, name, text", [
    ({"wave_period": 200.0}, "wave_period", "wave frequencies 0.0314159 .. 0.0314159 rad/s lie outside the BEM "
     "database's (allowed: wave frequencies within 0.05 .. 5 rad/s: a regular period 1.25664 .. 125.664 s; a "
     "JONSWAP Tp whose band 0.5 .. 3 w_p lies within it, about 3.77 .. 62.83 s)"),
    ({"sea_state": "jonswap", "wave_period": 3.0, "n_components": 10}, "wave_period", "wave frequencies 1.309 .. "
     "6.02139 rad/s lie outside"),
    ({"sea_state": "choppy"}, "sea_state", "allowed: regular | jonswap"),
    ({"sea_state": "jonswap", "n_components": 6000}, "n_components", "0 (automatic) or 1 .. 5000"),
    ({"sea_state": "jonswap", "record_length": 1e5}, "record_length", "100000.0 s needs 31250 components at Tp = 8.0 "
     "s (allowed: <= 5000 components: record_length <= 16000 s (or set n_components))"),
    ({"gamma": 0.5}, "gamma", ">= 1"),
], ids=["period-regular", "period-jonswap", "sea_state", "n_components", "record_length", "gamma"])
def test_a_bad_wave_parameter_is_refused_naming_it(fmus, start, name, text):
    inst = Instance(fmus["AbsorberWave"], **start)
    try:
        inst.expect_failure(inst.fmu.exitInitializationMode)
        message = error_messages(inst)[-1]
        assert message.startswith(f"{name}: ") and text in message, message
    finally:
        inst.free()


@pytest.mark.parametrize("fmu, start", [("AbsorberHydro", {"drag_coefficient_z": -1.0}),
                                        ("HeavePTO", {"damping": -5.0}), ("HeavePTO", {"force_limit": -1.0})])
def test_a_negative_coefficient_is_refused_naming_it(fmus, fmu, start):
    inst = Instance(fmus[fmu], **start)
    try:
        inst.expect_failure(inst.fmu.exitInitializationMode)
        assert error_messages(inst)[-1].startswith(f"{next(iter(start))}: got -")
    finally:
        inst.free()


def test_a_state_that_overflows_is_refused_naming_the_input(fmus):
    """A load too large for the float overflows xi_dot (h acc = 10 s x 1e308 N / ~3e5 kg): fmi2Error naming the
    input behind it (the bridge's message, from the kind's culprit)."""
    inst = Instance(fmus["AbsorberFloat"]).initialize()
    try:
        inst.set(pto_F_z=1e308, wave_F_x=1.0)
        for k in range(3):
            try:
                inst.fmu.doStep(currentCommunicationPoint=k * 10.0, communicationStepSize=10.0)
            except Exception as exc:     # fmpy's FMICallException
                assert getattr(exc, "status", None) == 3
                break
        else:
            pytest.fail("the overflow was not refused")
        message = error_messages(inst)[-1]
        assert message.startswith("pto_F_z: 1e+308 makes the state overflow"), message
    finally:
        inst.free()


@pytest.mark.parametrize("fmu, inputs, text", [
    ("AbsorberFloat", {"wave_F_z": 1e9}, "state: diverged at t = 10 s (|xi|, |xi_dot| up to "),
    ("AbsorberHydro", {"vel_z": 1e14}, "state: the radiation memory diverged at t = 10 s (allowed: a communication "
     "step inside the coupling-stability limit (examples/point_absorber/README.md))"),
])
def test_a_diverging_state_is_refused_as_the_python_simulator_refuses_it(fmus, fmu, inputs, text):
    """Beyond the simulators' divergence limits (|xi|, |xi_dot| > 1e3; memory states > 1e12): fmi2Error with their
    message, the state left at the step's start (the step may be retried after a rollback)."""
    inst = Instance(fmus[fmu]).initialize()
    try:
        inst.set(**inputs)
        inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=10.0)
        assert text in error_messages(inst)[-1], error_messages(inst)[-1]
    finally:
        inst.free()


def test_outputs_that_overflow_are_refused_naming_the_input(fmus):
    """A displacement whose hydrostatic force overflows (1e305 m x ~1e6 N/m): reading the hydro's outputs is
    refused naming it (the step, which reads the velocities only, succeeds)."""
    inst = Instance(fmus["AbsorberHydro"]).initialize()
    try:
        inst.set(pos_x=1e305, vel_y=2.0)
        inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
        inst.expect_failure(inst.get, "F_y")
        message = error_messages(inst)[-1]
        assert message.startswith("outputs: pos_x: 1e+305 makes F_x, ") and "overflow" in message, message
    finally:
        inst.free()


def test_the_fmi3_wave_gives_the_fmi2_numbers(fmus, hull, tmp_path):
    """The FMI 3.0 FMU (the same binary and model file) with its String and Int32 parameters set: bit for bit."""
    from fmpy import simulate_fmu

    from flexfmu.fmi import native
    from flexfmu.fmi.native_build import build_native_fmu
    spec = R.SPECS["AbsorberWave"]
    source = native.wec_source(spec, "wave", dataclasses.asdict(spec.config_class()), hull, "AbsorberWave")
    fmi3 = build_native_fmu(source, tmp_path / "AbsorberWave.fmu", fmi_version=3)
    start = {"sea_state": "jonswap", "seed": 3, "n_components": 120, "ramp_time": 1.0}
    runs = [simulate_fmu(str(f), stop_time=5.0, step_size=0.01, output_interval=0.01, start_values=start)
            for f in (fmus["AbsorberWave"], fmi3)]
    assert all(np.array_equal(runs[0][n], runs[1][n]) for n in R.WAVE_OUTPUTS)
    assert np.max(np.abs(runs[0]["elevation"])) > 0.1


def test_fmpy_validates_every_wec_fmu(fmus):
    from fmpy.validation import validate_fmu
    for name, fmu in fmus.items():
        assert validate_fmu(str(fmu)) == [], name
