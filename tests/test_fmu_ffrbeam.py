"""FFRBeam.fmu driven through fmpy: validation, the paper's hammer test, a static FE reference,
rollback, independent instances and the error paths."""
import numpy as np
import pytest
import scipy.sparse.linalg as spla
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu
from scipy.signal import find_peaks

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.ffr.kinematics import point_shape
from flexfmu.ffr.scene import load_scene


@pytest.fixture
def ffr(fmu_instance):
    return lambda name="ffr", **start: fmu_instance("FFRBeam", name, **start)


def test_fmpy_validate_reports_no_problems(fmus):
    assert validate_fmu(str(fmus["FFRBeam"])) == []


def hammer_spectrum(fmu, boundary, load_s, sensor_s, duration=2.0, dt=1e-4):
    """Half-sine 1 ms hammer blow (all three axes) at load_s, accelerometer at sensor_s, 10 kS/s."""
    t = np.arange(0.0, duration + dt / 2, dt)
    pulse = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    signals = np.zeros(len(t), dtype=[("time", float), ("F_x", float), ("F_y", float), ("F_z", float)])
    signals["time"] = t
    for name, w in (("F_x", 1.0), ("F_y", 0.7), ("F_z", 0.4)):
        signals[name] = w * pulse
    res = simulate_fmu(str(fmu), start_time=0.0, stop_time=duration, step_size=dt, output_interval=dt,
                       input=signals, start_values={"boundary": boundary, "damping_ratio": 0.002,
                                                     "load_s": load_s, "sensor_s": sensor_s},
                       output=["sensor_a_x", "sensor_a_y", "sensor_a_z"] + [f"f_{i}" for i in range(1, 7)])
    spectrum = sum(np.abs(np.fft.rfft(res[c] * np.hanning(len(res))))
                   for c in ("sensor_a_x", "sensor_a_y", "sensor_a_z"))
    freqs = np.fft.rfftfreq(len(res), dt)
    return freqs, spectrum, np.array([res[f"f_{i}"][-1] for i in range(1, 7)])


# A perfect clamp isolates the parts on either side of it, so the hammer and the accelerometer
# must be on the same side: XFX's tip is clamped (hit the second corner); FXF's clamp at the first
# corner separates segment 1 from the L-arm that carries modes 1 and 2 (measure on the arm).
HAMMER_SETUPS = {"XFF": (0.45, 0.04), "XFX": (0.30, 0.04), "FXF": (0.45, 0.30)}


@pytest.mark.parametrize("boundary", list(HAMMER_SETUPS))
def test_hammer_fft_peaks_equal_natural_frequencies(fmus, boundary):
    freqs, spectrum, f_model = hammer_spectrum(fmus["FFRBeam"], boundary, *HAMMER_SETUPS[boundary])
    bin_hz = freqs[1] - freqs[0]
    # peaks standing a decade above their surroundings in the log spectrum
    peaks, _ = find_peaks(np.log10(spectrum + 1e-30 * spectrum.max()), prominence=1.0)
    found = freqs[peaks]
    print(boundary, "peaks", np.round(found, 2), "model", np.round(f_model, 2))
    assert len(found) >= 2
    for f in found:   # every clear peak is a natural frequency of the model
        assert np.min(np.abs(f_model - f)) <= bin_hz, (f, f_model)
    for f in f_model[:2]:   # and the first two modes show up
        assert np.min(np.abs(found - f)) <= bin_hz, (f, found)


def test_static_tip_load_equals_fe_solve(ffr):
    """All modes retained, a constant tip force, one long exact step: the tip deflection equals K^-1 F."""
    scene = load_scene("spatial_double_L")
    model = build_beam_model(scene, "XFF", 2, extra_arc_lengths=(0.45, 0.04))
    inst = ffr(elements_per_segment=2, n_modes=model.n_free, damping_ratio=0.9).initialize()
    F = np.array([0.4, -1.2, 2.0])
    inst.set(F_x=F[0], F_y=F[1], F_z=F[2])
    inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=5.0)
    tip = point_shape(model.mesh, 0.45)
    q = model.B2 @ spla.spsolve(model.K_free.tocsc(), model.B2.T @ (tip.full_translation(model.n_dof).T @ F))
    expected = tip.displacement_body(q)
    np.testing.assert_allclose(inst.get("tip_u_x", "tip_u_y", "tip_u_z"), expected, rtol=1e-6)
    np.testing.assert_allclose(inst.get("reaction_F_x", "reaction_F_y", "reaction_F_z"), F, rtol=1e-9)


def _run(inst, steps, h=1e-3, t0=0.0):
    out = []
    for k in range(steps):
        inst.set(F_z=np.sin(37.0 * (t0 + k * h)), base_a_x=0.3 * np.cos(11.0 * (t0 + k * h)))
        inst.fmu.doStep(currentCommunicationPoint=t0 + k * h, communicationStepSize=h)
        out.append(inst.get("sensor_a_x", "sensor_a_y", "tip_u_z", "reaction_M_y", "elastic_energy"))
    return np.array(out)


def test_rollback_with_fmu_state_is_bit_identical(ffr):
    inst = ffr().initialize()
    _run(inst, 20)
    state = inst.fmu.getFMUState()
    first = _run(inst, 15, t0=0.02)
    inst.fmu.setFMUState(state)
    again = _run(inst, 15, t0=0.02)
    assert np.array_equal(first, again)
    serialized = inst.fmu.serializeFMUState(state)
    inst.fmu.setFMUState(inst.fmu.deserializeFMUState(serialized))
    assert np.array_equal(_run(inst, 15, t0=0.02), first)


def test_instances_are_independent(ffr):
    alone = _run(ffr("alone", boundary="XFX").initialize(), 10)
    a = ffr("a", boundary="XFX").initialize()
    b = ffr("b", boundary="XFF").initialize()
    mixed = []
    for k in range(10):
        _run(b, 1, t0=k * 1e-3)
        mixed.append(_run(a, 1, t0=k * 1e-3)[0])
    assert np.array_equal(np.array(mixed), alone)


def test_variable_communication_steps_match_fixed_steps(ffr):
    """Inputs held constant: one step of 4 ms equals four of 1 ms (the ZOH step is exact)."""
    a, b = ffr("a").initialize(), ffr("b").initialize()
    for inst in (a, b):
        inst.set(F_y=1.0, base_w_z=2.0)
    a.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=4e-3)
    for k in range(4):
        b.fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
    np.testing.assert_allclose(a.get("tip_u_x", "tip_u_y", "tip_u_z"), b.get("tip_u_x", "tip_u_y", "tip_u_z"),
                               rtol=1e-9)


ERROR_CASES = [
    ("damping_ratio out of range", {"damping_ratio": 1.5}, "damping_ratio"),
    ("unknown scene", {"scene": "no_such_scene"}, "scene"),
    ("unknown boundary", {"boundary": "XYZ"}, "boundary"),
    ("sensor outside the rod", {"sensor_s": 2.0}, "sensor_s"),
    ("too many modes", {"elements_per_segment": 1, "n_modes": 500}, "n_modes"),
]


@pytest.mark.parametrize("label, start, name", ERROR_CASES, ids=[c[0] for c in ERROR_CASES])
def test_bad_parameter_fails_initialisation_naming_it(ffr, label, start, name):
    inst = ffr(**start)
    exc = inst.expect_failure(inst.fmu.exitInitializationMode)
    assert "fmi2ExitInitializationMode failed" in str(exc)
    assert any(status >= 3 and name in message for status, _, message in inst.log), inst.log


STEP_ERRORS = [
    ("wrong communication point", {}, 0.5, 1e-3, "currentCommunicationPoint"),
    ("zero step", {}, 0.0, 0.0, "communicationStepSize"),
    ("negative step", {}, 0.0, -1e-3, "communicationStepSize"),
    ("NaN time", {}, float("nan"), 1e-3, "currentCommunicationPoint"),
]


@pytest.mark.parametrize("label, inputs, t, h, name", STEP_ERRORS, ids=[c[0] for c in STEP_ERRORS])
def test_step_errors_are_logged_with_the_variable(ffr, label, inputs, t, h, name):
    inst = ffr().initialize()
    inst.set(**inputs)
    exc = inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)
    assert "fmi2DoStep failed" in str(exc)
    assert any(status >= 3 and name in message for status, _, message in inst.log), inst.log


@pytest.mark.parametrize("name, value", [("F_x", float("nan")), ("base_w_z", float("inf")), ("damping_ratio", float("-inf"))])
def test_non_finite_values_are_refused_when_set(ffr, name, value):
    inst = ffr()
    inst.expect_failure(inst.set, **{name: value})
    assert any(status == 3 and name in message and "finite" in message for status, _, message in inst.log), inst.log
    inst.initialize()                      # the refused value was not taken: the instance still works
    inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)


def test_fixed_parameter_cannot_change_after_initialisation(ffr):
    inst = ffr().initialize()
    inst.expect_failure(inst.set, damping_ratio=0.3)
    assert any("damping_ratio" in message and "only before fmi2ExitInitializationMode" in message for _, _, message in inst.log)


def test_reset_gives_a_fresh_instance(ffr):
    """fmi2Reset, then the same experiment again: the outputs equal a fresh instance's."""
    fresh = _run(ffr("fresh").initialize(), 12)
    inst = ffr("reused").initialize()
    _run(inst, 7)
    inst.fmu.reset()
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    inst.fmu.exitInitializationMode()
    assert np.array_equal(_run(inst, 12), fresh)


def test_divergence_is_an_error_not_nan(ffr):
    """Spin far above the first bending frequency (no geometric stiffening in a linear FFR model):
    the elastic state grows exponentially; the FMU stops with fmi2Error before any output is NaN."""
    inst = ffr().initialize()
    inst.set(base_w_z=2000.0, F_y=1.0)
    h, last = 1e-3, None
    for k in range(200):
        try:
            inst.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        except Exception as exc:
            assert getattr(exc, "status", None) == 3
            break
        last = inst.get("tip_u_x", "tip_u_y", "tip_u_z", "elastic_energy")
        assert np.all(np.isfinite(last))
    else:
        raise AssertionError("the spinning rod did not diverge")
    assert any("diverged" in message for _, _, message in inst.log), inst.log
