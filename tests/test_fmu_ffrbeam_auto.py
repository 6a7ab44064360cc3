"""FFRBeam.fmu with the automatic model size and the RK4 integrator: what it chose and why is logged (status
OK) with its numbers, and its outputs are the library's."""
import numpy as np
import pytest

from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
from flexfmu.ffr.dynamics import BaseMotion

OUTPUTS = ("tip_u_x", "tip_u_y", "tip_u_z", "sensor_u_x", "sensor_u_z", "sensor_a_x", "reaction_M_y",
           "elastic_energy")


@pytest.fixture
def ffr(fmu_instance):
    return lambda name="ffr", **start: fmu_instance("FFRBeam", name, **start)


def inputs_at(t: float) -> dict:
    """A force that switches off (an impulse-like start), a sine force and a base acceleration."""
    return {"F_y": 1.0 if t < 0.02 else 0.0, "F_z": float(np.sin(37.0 * t)), "base_a_x": float(0.3 * np.cos(11.0 * t))}


def run_fmu(inst, h: float, steps: int) -> np.ndarray:
    out = []
    for k in range(steps):
        inst.set(**inputs_at(k * h))
        inst.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        out.append(inst.get(*OUTPUTS))
    return np.array(out)


def run_library(config: FFRBeamConfig, h: float, steps: int) -> tuple[np.ndarray, FFRBeamSimulator]:
    sim = FFRBeamSimulator(config)
    out = []
    for k in range(steps):
        sim.set_inputs(**inputs_at(k * h))
        sim.step(h)
        values = sim.outputs()
        out.append([values[name] for name in OUTPUTS])
    return np.array(out), sim


def assert_same_run(fmu_out: np.ndarray, lib_out: np.ndarray) -> None:
    """Equal to round-off, each column relative to its largest value over the run."""
    scale = np.abs(lib_out).max(axis=0)
    assert np.all(scale > 0)
    assert np.all(np.abs(fmu_out - lib_out) <= 1e-10 * scale), np.abs(fmu_out - lib_out).max(axis=0) / scale


def ok_messages(inst) -> list[str]:
    return [message for status, _, message in inst.log if status == 0]


def test_automatic_model_is_logged_and_matches_the_library(ffr):
    start = {"n_modes": -1, "elements_per_segment": 0, "f_max": 300.0, "tolerance": 1e-3}
    inst = ffr(**start).initialize()
    fmu_out = run_fmu(inst, 1e-3, 40)
    lib_out, sim = run_library(FFRBeamConfig(**start), 1e-3, 40)
    choice = sim.model_choice
    (message,) = [m for m in ok_messages(inst) if m.startswith("model size")]
    # the choice and the numbers that justify it
    n_el, n = choice.elements_per_segment, choice.n_modes
    for text in (f"elements_per_segment = {n_el} (chosen", f"{choice.mesh.worst_error:.2e}", "<= 0.001",
                 f"{n_el - 1} elements per segment: error", "retained frequencies",
                 f"n_modes = {n} of {choice.n_free} (chosen: the 5 modes below f_max and {n - 5} above",
                 "dynamic truncation error of tip_u and sensor_u", f"{choice.truncation.error:.2e}, x2 safety",
                 f"worst: {choice.truncation.worst}", "219.155", f"first omitted {choice.frequencies_hz[n]:.6g} Hz",
                 "static correction on"):
        assert text in message, (text, message)
    assert message == sim.messages[0]             # the library's own message, word for word
    assert_same_run(fmu_out, lib_out)
    assert np.abs(fmu_out[:, 0:3]).max() > 0       # the run did deflect the rod


def test_rk4_beyond_its_limit_is_substepped_logged_and_close_to_exact(ffr):
    """Default model (8 elements, 6 modes, omega_max = 2023 rad/s): RK4's stable step is 2.8 / omega_max =
    1.38 ms.  A 5 ms communication step is split into ceil(5 / (0.9 * 1.38)) = 5 sub-steps of 1 ms and logged;
    when the step changes to 1 ms (a single RK4 step) that is logged too."""
    h, steps = 5e-3, 100
    inst = ffr(integrator="rk4").initialize()
    fmu_out = run_fmu(inst, h, steps)
    lib_out, sim = run_library(FFRBeamConfig(integrator="rk4"), h, steps)
    exact_out, _ = run_library(FFRBeamConfig(), h, steps)
    limit = sim.dynamics.rk4_step_limit(BaseMotion())      # the inputs hold no base rotation
    assert h > limit
    (message,) = [m for m in ok_messages(inst) if m.startswith("integrator rk4")]
    for text in (f"stable step limit {limit:.4g} s", f"omega_max = {2.8 / limit:.6g} rad/s",
                 "5 equal RK4 sub-steps of 0.001 s"):
        assert text in message, (text, message)
    assert_same_run(fmu_out, lib_out)
    # bounded, and the tip displacement within 2 % of the exact integrator's (measured 0.9 %: RK4's phase error
    # at omega h = 0.25 per sub-step for mode 1 over 500 sub-steps)
    assert np.all(np.isfinite(fmu_out))
    scale = np.abs(exact_out[:, 0:3]).max(axis=0)
    assert np.all(np.abs(fmu_out[:, 0:3] - exact_out[:, 0:3]).max(axis=0) <= 0.02 * scale)
    # a change of the communication step changes n_sub: logged again
    t = steps * h
    inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=1e-3)
    assert any("1 RK4 step, no sub-steps" in m for m in ok_messages(inst))


def test_bad_tolerance_fails_initialisation_naming_it(ffr):
    inst = ffr(n_modes=-1, elements_per_segment=0, tolerance=0.5)
    inst.expect_failure(inst.fmu.exitInitializationMode)
    assert any(status >= 3 and "tolerance" in message and "1e-06 .. 0.1" in message
               for status, _, message in inst.log), inst.log
