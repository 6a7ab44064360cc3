"""Directional derivatives of the native LTI-kind FMUs (FFRBeam, exported clamped bodies): exact derivatives of the
outputs and the state derivatives with respect to the inputs and the states (csrc/native_lti.c `directional`).

- Against central differences of the FMU itself (a model-exchange instance, where the outputs and derivatives follow
  the inputs and states as set), at a random state and random inputs including the base motion (the geometric
  stiffening and the static correction on: every kind of term).  The outputs are polynomials of degree <= 2 in each
  single input or state but for the static correction's strain energy (degree 4 in the base motion), so the
  differences err by rounding, eps |y| / delta, and by delta^2 |y'''| / 6 for those terms; each error is scaled by
  the output's largest sensitivity (over the knowns, each at its own scale).  Bound 1e-6; measured 3e-13.
- d reaction_F / d base_a = -(m I - L^T L), the mass the retained modes do not carry, against a closed form computed
  here: a straight clamped rod (Euler-Bernoulli), whose modes' effective masses are m (2 sigma_k / beta_k L)^2 with
  cos(beta L) cosh(beta L) = -1, sigma_k = (cosh + cos) / (sinh + sin) of beta_k L (Blevins, Formulas for natural
  frequency and mode shape, table 8-1); with the first six modes (three bending pairs) retained, the transverse
  diagonal is -m (1 - sum_k eff_k), the axial one -m.  The finite-element model converges to it as h^4 or faster.
"""
from __future__ import annotations

import ctypes
import json

import numpy as np
import pytest
from me_helpers import HAMMER_SETTINGS, ROOT, MeInstance
from scipy.optimize import brentq

pytestmark = pytest.mark.fmu
BOUND = 1e-6
ROD = {"length": 0.5, "diameter": 0.008, "E": 200e9, "rho": 7850.0}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.native import build_registry_fmu, export_native
    from flexfmu.importers import load_structure

    out = tmp_path_factory.mktemp("dd")
    settings = dict(HAMMER_SETTINGS["XFF"], geometric_stiffening=True, static_correction=1)
    built = {"FFRBeam": build_registry_fmu("FFRBeam", settings, target=out / "2" / "FFRBeam.fmu", interface="both"),
             "FFRBeam3": build_registry_fmu("FFRBeam", settings, target=out / "3" / "FFRBeam.fmu", fmi_version=3,
                                            interface="both"),
             "ReframeBody": build_registry_fmu("ReframeBody", target=out / "free" / "ReframeBody.fmu")}
    structure = load_structure(ROOT / "examples" / "bracket" / "bracket.json")
    clamped = build_body(structure, interfaces=[interface_from_text("tip=arm_top")],
                         clamp=clamp_from_text(structure, "bolt_1,bolt_2"), n_modes=8)
    built["bracket"] = export_native(clamped, out / "bracket" / "BracketClamped.fmu", interface="both")
    rod = out / "rod.json"
    rod.write_text(json.dumps({"schema_version": 1, "name": "rod", "points": [[0, 0, 0], [0, 0, ROD["length"]]],
                               "section": {"shape": "circle", "diameter": ROD["diameter"]},
                               "material": {"E": ROD["E"], "nu": 0.3, "rho": ROD["rho"]}, "clamps": [0.0]}))
    for n in (16, 64):
        built[f"rod{n}"] = build_registry_fmu(
            "FFRBeam", {"scene": str(rod), "boundary": "scene", "n_modes": 6, "elements_per_segment": n,
                        "static_correction": 0}, target=out / f"rod{n}" / "FFRBeam.fmu")
    return built


def doubles(values) -> ctypes.Array:
    values = list(values)
    return (ctypes.c_double * len(values))(*values)


#: typical sizes of the inputs by name prefix (N, N m, m/s^2, rad/s, rad/s^2): the random point and the steps
INPUT_SCALE = {"F": 10.0, "M": 1.0, "base_a": 5.0, "base_w": 2.0, "base_dw": 10.0}


def _scale(name: str) -> float:
    return INPUT_SCALE[name.split(".")[-1].rsplit("_", 1)[0]]


def random_point(inst: MeInstance, seed: int):
    """Set a random state (10 nominals each) and random inputs (their typical sizes); returns (x, inputs)."""
    rng = np.random.default_rng(seed)
    nominals = np.array([float(d.variable.derivative.nominal) for d in inst.md.derivatives])
    x = rng.normal(size=len(nominals)) * 10 * nominals
    inst.fmu.setContinuousStates(doubles(x), len(x))
    inputs = {v.name: rng.normal() * _scale(v.name) for v in inst.md.modelVariables if v.causality == "input"}
    inst.set(**inputs)
    return x, inputs


def jacobians(inst: MeInstance, x, inputs, step: float = 1e-3):
    """(directional derivatives, central differences, the knowns' scales) of [outputs; state derivatives] with
    respect to [inputs; states], the differences at step x scale."""
    outputs = [v.valueReference for v in inst.md.modelVariables if v.causality == "output"]
    unknowns = outputs + inst.derivatives
    nominals = np.array([float(d.variable.derivative.nominal) for d in inst.md.derivatives])
    knowns = [(inst.vr[name], _scale(name), name) for name in inputs] + [
        (vr, 10 * nominals[i], i) for i, vr in enumerate(inst.states)]
    exact = np.zeros((len(unknowns), len(knowns)))
    central = np.zeros_like(exact)
    n = len(x)
    for j, (vr, scale, key) in enumerate(knowns):
        exact[:, j] = inst.fmu.getDirectionalDerivative(unknowns, [vr], [1.0])
        delta, values = step * scale, []
        for sign in (1.0, -1.0):
            if isinstance(key, str):
                inst.set(**{key: inputs[key] + sign * delta})
            else:
                moved = np.array(x)
                moved[key] += sign * delta
                inst.fmu.setContinuousStates(doubles(moved), n)
            values.append(np.array(inst.fmu.getReal(unknowns)))
        inst.set(**{key: inputs[key]}) if isinstance(key, str) else inst.fmu.setContinuousStates(doubles(x), n)
        central[:, j] = (values[0] - values[1]) / (2 * delta)
    return exact, central, np.array([k[1] for k in knowns])


@pytest.mark.parametrize("case", ["FFRBeam", "bracket"])
def test_directional_derivatives_equal_central_differences_of_the_fmu(fmus, case):
    inst = MeInstance(fmus[case], "me")
    try:
        x, inputs = random_point(inst, seed=7)
        exact, central, scales = jacobians(inst, x, inputs)
    finally:
        inst.free()
    sensitivity = np.max(np.abs(exact) * scales, axis=1)          # per output: its largest change at scale
    constant = sensitivity == 0                                     # the natural frequencies f_k
    assert np.all(central[constant] == 0) and 0 < constant.sum() < len(constant)
    error = np.abs(exact - central)[~constant] * scales / sensitivity[~constant, None]
    assert error.max() < BOUND, np.unravel_index(error.argmax(), error.shape)
    assert np.any(exact[:, :len(inputs)] != 0)                       # the inputs act, not only the states


def test_co_simulation_and_fmi3_give_the_same_derivatives_as_model_exchange(fmus):
    """The same function at the same point: the co-simulation instance after some steps (its state read through the
    states' value references), a model-exchange instance set to that state and those inputs, and FMI 3.0's."""
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Model

    cs = MeInstance(fmus["FFRBeam"], "cs")
    me = MeInstance(fmus["FFRBeam"], "me")
    try:
        inputs = {"F_x": 3.0, "F_z": -2.0, "base_a_y": 1.5, "base_w_z": 0.7, "base_dw_x": 4.0}
        cs.set(**inputs)
        for k in range(50):
            cs.fmu.doStep(k * 1e-4, 1e-4)
        x = cs.fmu.getReal(cs.states)
        me.fmu.setContinuousStates(doubles(x), len(x))
        me.set(**inputs)
        unknowns = [v.valueReference for v in cs.md.modelVariables if v.causality == "output"]
        knowns = [cs.vr[n] for n in inputs] + cs.states[:3]
        for vr in knowns:
            assert cs.fmu.getDirectionalDerivative(unknowns, [vr], [1.0]) == \
                me.fmu.getDirectionalDerivative(unknowns, [vr], [1.0])
        md3 = read_model_description(str(fmus["FFRBeam3"]))
        fmu3 = FMU3Model(guid=md3.guid, unzipDirectory=extract(str(fmus["FFRBeam3"])),
                         modelIdentifier=md3.modelExchange.modelIdentifier, instanceName="three")
        fmu3.instantiate()
        fmu3.enterInitializationMode(startTime=0.0)
        fmu3.exitInitializationMode()
        fmu3.enterContinuousTimeMode()
        fmu3.setContinuousStates(doubles(x), len(x))
        fmu3.setFloat64([cs.vr[n] for n in inputs], list(inputs.values()))
        for vr in knowns:
            assert fmu3.getDirectionalDerivative(unknowns, [vr], [1.0]) == \
                me.fmu.getDirectionalDerivative(unknowns, [vr], [1.0])
        fmu3.freeInstance()
    finally:
        cs.free()
        me.free()


def residual_mass_closed_form() -> np.ndarray:
    """-(m I - L^T L) of the straight clamped rod along z with its first six modes (bending pairs 1..3), from the
    Euler-Bernoulli cantilever's effective masses."""
    m = ROD["rho"] * np.pi * ROD["diameter"] ** 2 / 4 * ROD["length"]
    effective = 0.0
    for lower in (1.5, 4.5, 7.5):                       # beta_k L: the roots of cos b cosh b = -1 in these brackets
        b = brentq(lambda b: np.cos(b) * np.cosh(b) + 1.0, lower, lower + 1.5)
        sigma = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))
        effective += (2 * sigma / b) ** 2
    return -np.diag([m * (1 - effective), m * (1 - effective), m])


def reaction_by_base_acceleration(fmu) -> np.ndarray:
    inst = MeInstance(fmu, "cs")
    try:
        reactions = [inst.vr[f"reaction_F_{a}"] for a in "xyz"]
        return np.array([inst.fmu.getDirectionalDerivative(reactions, [inst.vr[f"base_a_{a}"]], [1.0])
                         for a in "xyz"]).T
    finally:
        inst.free()


def test_reaction_by_base_acceleration_is_the_mass_the_retained_modes_do_not_carry(fmus):
    closed = residual_mass_closed_form()
    m = -closed[2, 2]
    errors = {n: np.max(np.abs(reaction_by_base_acceleration(fmus[f"rod{n}"]) - closed)) / m for n in (16, 64)}
    assert errors[64] < BOUND, errors                       # measured 3.7e-10 (16 elements: 6.7e-7)
    assert np.log(errors[16] / errors[64]) / np.log(4) > 3.5, errors     # converges as h^4 or faster (5.4)


def test_directional_derivative_calls_refused_with_a_message(fmus):
    inst = MeInstance(fmus["FFRBeam"], "me")
    try:
        output, inp = inst.vr["tip_u_x"], inst.vr["F_x"]
        for unknowns, knowns, expected in [([inp], [inp], "is not an output or a state derivative"),
                                           ([output], [output], "is not an input or a continuous state"),
                                           ([output], [10**6], "is not an input or a continuous state"),
                                           ([output], [inp, inst.vr["n_modes"]], "'n_modes') is not an input")]:
            inst.log.clear()
            with pytest.raises(Exception):
                inst.fmu.getDirectionalDerivative(unknowns, knowns, [1.0] * len(knowns))
            assert any(expected in m for m in inst.log), (expected, inst.log)
    finally:
        inst.free()
    free = MeInstance(fmus["ReframeBody"], "cs")
    try:
        with pytest.raises(Exception):
            free.fmu.getDirectionalDerivative([free.vr["omega_1"]], [free.vr["F_x"]], [1.0])
        assert any("provides no directional derivatives" in m for m in free.log), free.log
    finally:
        free.free()
