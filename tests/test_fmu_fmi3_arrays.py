"""FMI 3.0 array variables of the native FMUs (flexfmu.fmi.fmi3_arrays; csrc/flexfmu_fmi3.c serves them from the
runtime's table, BridgeApi.arrays): FFRBeam set up for the hammer record XFF (co-simulation and model exchange) and
ReframeBody (the reframe kind), each built with ``arrays=True``.

fmpy validates them and reads the arrays' dimensions and start values; during the hammer record every array reads
as its scalars bit for bit, and the record driven through the force array equals the record driven through the
three force scalars bit for bit; modal_coordinates and modal_rates are the continuous states, natural_frequencies the
FMU's f_1 .. f_6, n_retained_modes half the number of states; bad calls are refused with fmi3Error and one message
naming the variable; directional derivatives through arrays are those of their elements; fmusim runs the FMUs and
sets the structural parameter through Configuration Mode. A hexahedral bar with two gauges exported clamped and free:
its gauges' stress and strain tensors (G.sigma, G.eps) and its shape coordinates (q, sized by n_shape_coordinates)
read as their scalars bit for bit."""
from __future__ import annotations

import ctypes
import importlib.util
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

sys.path.insert(0, str(Path(__file__).parent))
from fmi3_helpers import Instance3  # noqa: E402

pytestmark = pytest.mark.fmu
ROOT = Path(__file__).resolve().parents[1]
BASE = 2**30                 # flexfmu.fmi.fmi3_arrays.ARRAY_VALUE_REFERENCE_BASE
TIME = 2**31 - 1             # flexfmu.fmi.description_fmi3.TIME_VALUE_REFERENCE
H = 1e-4
#: natural_frequencies (sqrt of the model's modal stiffness / 2 pi) against f_1 .. f_6 (the library's eigen-solve,
#: frequencies_hz): one value through a square and a square root, a few rounding errors of each
FREQUENCY_RTOL = 1e-12


def _hammer():
    spec = importlib.util.spec_from_file_location("hammer_test", ROOT / "examples" / "hammer_test.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HAMMER = _hammer()
LOAD_S, SENSOR_S = HAMMER.SETUPS["XFF"]


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    from flexfmu.fmi.native import registry_source
    from flexfmu.fmi.native_build import build_native_fmu

    out = tmp_path_factory.mktemp("arrays")
    beam = registry_source("FFRBeam", {"boundary": "XFF", "load_s": LOAD_S, "sensor_s": SENSOR_S})
    plate = registry_source("ReframeBody")
    return {"FFRBeam": build_native_fmu(beam, out / "beam" / "FFRBeam.fmu", fmi_version=3, interface="both",
                                        arrays=True),
            "ReframeBody": build_native_fmu(plate, out / "plate" / "ReframeBody.fmu", fmi_version=3, arrays=True),
            "sources": {"FFRBeam": beam, "ReframeBody": plate}}


def doubles(values) -> ctypes.Array:
    values = list(values)
    return (ctypes.c_double * len(values))(*values)


def refs(values) -> ctypes.Array:
    values = list(values)
    return (ctypes.c_uint32 * len(values))(*values)


def get(inst: Instance3, names, n: int) -> np.ndarray:
    """fmi3GetFloat64 of the variables ``names`` (scalars and arrays) with nValues = n."""
    values = (ctypes.c_double * n)()
    status = inst.raw("fmi3GetFloat64", refs(inst.vr[name] for name in names), len(names), values, n)
    assert status == 0, inst.errors()
    return np.array(values)


# ---------------------------------------------------------------------------------------------- modelDescription
@pytest.mark.parametrize("case", ["FFRBeam", "ReframeBody"])
def test_fmpy_validates_and_reads_the_arrays(fmus, case):
    from flexfmu.fmi.variables import table

    assert validate_fmu(str(fmus[case])) == []
    md = read_model_description(str(fmus[case]))
    source = fmus["sources"][case]
    rows = table(source.spec, source.values)
    by_reference = {v.valueReference: v for v in md.modelVariables}
    # the scalar view: the FMI 2.0 names at the FMI 2.0 value references
    assert [by_reference[k].name for k in range(len(rows))] == [v.name for v in rows]
    views = [v for v in md.modelVariables if v.valueReference >= BASE and v.name != "time"]
    assert views and all(BASE <= v.valueReference < TIME for v in views)
    viewed = {v.name for v in views}
    assert all(v.valueReference < BASE for v in md.modelVariables if v.name not in viewed and v.name != "time")
    size = next(v for v in views if v.name == "n_retained_modes")
    assert (size.type, size.causality, size.variability, size.shape) == ("UInt64", "structuralParameter", "fixed", ())
    n = int(size.start)
    assert n == source.values["n_modes" if case == "FFRBeam" else "n_flexible_modes"]
    shapes = {v.name: v.shape for v in views if v.name != "n_retained_modes"}
    modal = {"natural_frequencies", "modal_coordinates", "modal_rates"} if case == "FFRBeam" else {
        "natural_frequencies"}
    assert {name: shapes[name] for name in modal} == {name: (n,) for name in modal}
    assert all(shapes[name] == (3,) for name in set(shapes) - modal)
    for name in modal:
        array = next(v for v in views if v.name == name)
        assert [d.variable.name for d in array.dimensions] == ["n_retained_modes"]
    vectors = set(shapes) - modal
    assert {"F", "M"} <= vectors and (("tip_u" in vectors) if case == "FFRBeam" else ("com_pos" in vectors))
    force = next(v for v in views if v.name == "F")
    assert (force.causality, force.unit, [float(x) for x in force.start.split()]) == ("input", "N", [0.0] * 3)
    assert "(x, y, z)" in force.description
    frequencies = next(v for v in views if v.name == "natural_frequencies")
    starts = np.array([float(x) for x in frequencies.start.split()])
    assert frequencies.variability == "constant" and frequencies.unit == "Hz"
    assert len(starts) == n and np.all(np.diff(starts) > 0) and starts[0] > 0
    outputs = {u.variable.name for u in md.outputs}
    assert {v.name for v in views if v.causality == "output"} <= outputs
    if case == "FFRBeam":
        assert md.modelExchange is not None and len(md.derivatives) == 2 * n


# ---------------------------------------------------------------------------------------------- the hammer record
def test_the_hammer_record_through_arrays_equals_it_through_scalars(fmus):
    """The paper's hammer blow (2 s at 10 kS/s) through fmpy, the force given once as the array F and once as F_x, F_y,
    F_z: every scalar output equal bit for bit; in the first, every 3-vector output equal to its scalars and the modal
    arrays to the continuous states, bit for bit."""
    fmu = str(fmus["FFRBeam"])
    md = read_model_description(fmu)
    t = np.arange(0.0, 2.0 + H / 2, H)
    pulse = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    scale = (1.0, 0.7, 0.4)
    as_array = np.zeros(len(t), dtype=[("time", float), ("F", float, (3,))])
    as_scalars = np.zeros(len(t), dtype=[("time", float), ("F_x", float), ("F_y", float), ("F_z", float)])
    as_array["time"] = as_scalars["time"] = t
    for k, axis in enumerate("xyz"):
        as_array["F"][:, k] = as_scalars[f"F_{axis}"] = scale[k] * pulse
    scalars = [v.name for v in md.modelVariables if v.causality == "output" and not v.dimensions]
    arrays = [v.name for v in md.modelVariables if v.causality == "output" and v.dimensions]
    states = [v.name for v in md.modelVariables if v.name.startswith("eta_")]
    start = {"damping_ratio": 0.002}
    through_array = simulate_fmu(fmu, stop_time=2.0, step_size=H, output_interval=H, input=as_array,
                                 output=scalars + arrays + states, start_values=start)
    through_scalars = simulate_fmu(fmu, stop_time=2.0, step_size=H, output_interval=H, input=as_scalars,
                                   output=scalars, start_values=start)
    assert len(through_array) == len(t)
    for name in scalars:
        assert np.array_equal(through_array[name], through_scalars[name]), name
    vectors = [name for name in arrays if through_array[name].shape[1:] == (3,)]
    assert {"sensor_a", "tip_u", "reaction_F"} <= set(vectors)
    for name in vectors:
        for k, axis in enumerate("xyz"):
            assert np.array_equal(through_array[name][:, k], through_array[f"{name}_{axis}"]), (name, axis)
    n = len(states) // 2
    eta = np.column_stack([through_array[name] for name in states])
    assert np.array_equal(through_array["modal_coordinates"], eta[:, :n])
    assert np.array_equal(through_array["modal_rates"], eta[:, n:])
    assert np.max(np.abs(through_array["sensor_a_x"])) > 1.0 and np.max(np.abs(eta)) > 0.0


def test_modal_arrays_are_the_states_and_frequencies_the_fmus(fmus):
    """Co-simulation after a blow and model exchange at random states: modal_coordinates = x[:n], modal_rates = x[n:]
    bit for bit; natural_frequencies = f_1 .. f_6 (FREQUENCY_RTOL); n_retained_modes = number of states / 2."""
    from fmpy import extract
    from fmpy.fmi3 import FMU3Model

    inst = Instance3(fmus["FFRBeam"], "modes", damping_ratio=0.002)
    try:
        n = inst.fmu.getUInt64([inst.vr["n_retained_modes"]])[0]
        states = [f"eta_{k}" for k in range(1, n + 1)] + [f"eta_dot_{k}" for k in range(1, n + 1)]
        inst.fmu.exitInitializationMode()
        for k in range(20):
            inst.set(F_x=20.0 * math.sin(math.pi * k / 10) if k < 10 else 0.0)
            inst.fmu.doStep(k * H, H)
        viewed = get(inst, ["modal_coordinates", "modal_rates", *states], 4 * n)
        assert np.array_equal(viewed[:2 * n], viewed[2 * n:]) and np.all(viewed[:n] != 0.0)
        frequencies = get(inst, ["natural_frequencies"] + [f"f_{k}" for k in range(1, 7)], n + 6)
        first = min(n, 6)
        assert np.allclose(frequencies[:first], frequencies[n:n + first], rtol=FREQUENCY_RTOL, atol=0.0)
    finally:
        inst.free()
    md = read_model_description(str(fmus["FFRBeam"]))
    folder = extract(str(fmus["FFRBeam"]))
    model = FMU3Model(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.modelExchange.modelIdentifier,
                      instanceName="me")
    try:
        model.instantiate()
        model.enterInitializationMode(startTime=0.0)
        vr = {v.name: v.valueReference for v in md.modelVariables}
        assert model.getUInt64([vr["n_retained_modes"]]) == [n]
        model.exitInitializationMode()
        model.enterContinuousTimeMode()
        assert model.getNumberOfContinuousStates() == 2 * n
        rng = np.random.default_rng(7)
        for _ in range(3):
            x = rng.normal(size=2 * n) * 1e-4
            model.setContinuousStates(doubles(x), 2 * n)
            got = model.getFloat64([vr["modal_coordinates"], vr["modal_rates"]], nValues=2 * n)
            assert np.array_equal(got, x)
    finally:
        model.terminate()
        model.freeInstance()
        shutil.rmtree(folder, ignore_errors=True)


def test_the_reframe_kinds_frequencies_are_its_model_files(fmus):
    """ReframeBody: natural_frequencies = reframe.omega / (2 pi) of its model file, bit for bit as the model description
    prints them (the shortest repr), n_retained_modes = n_flexible_modes."""
    import zipfile

    from flexfmu.fmi.model_file import read_model_file

    with zipfile.ZipFile(fmus["ReframeBody"]) as archive:
        folder = Path(archive.extract("resources/flexfmu_model.bin", path=fmus["ReframeBody"].parent / "x"))
    omega = read_model_file(folder)["reframe.omega"]
    inst = Instance3(fmus["ReframeBody"], "plate")
    try:
        n = inst.fmu.getUInt64([inst.vr["n_retained_modes"]])[0]
        assert n == len(omega) == fmus["sources"]["ReframeBody"].values["n_flexible_modes"]
        assert np.array_equal(get(inst, ["natural_frequencies"], n), omega / (2.0 * math.pi))
    finally:
        inst.free()


# ---------------------------------------------------------------------------------------------- refusals
def _raw_get(i, names, n):
    return i.raw("fmi3GetFloat64", refs(i.vr[name] for name in names), len(names), (ctypes.c_double * n)(), n)


def _raw_set(i, names, values):
    return i.raw("fmi3SetFloat64", refs(i.vr[name] for name in names), len(names), doubles(values), len(values))


def _configure(i, value):
    assert i.raw("fmi3EnterConfigurationMode") == 0
    return i.fmu.setUInt64([i.vr["n_retained_modes"]], [value])


BAD_CALLS = {   # name: (state, call(inst) returning a status or raising, the start of its one message ({name}: a
                #        variable's value reference)
    "nValues too small": ("StepMode", lambda i: _raw_get(i, ["F"], 1),
                          "fmi3GetFloat64: nValues: got 1 for 1 value references (their variables hold 3 values"),
    "nValues too large": ("StepMode", lambda i: _raw_get(i, ["F", "F_x"], 5),
                          "fmi3GetFloat64: nValues: got 5 for 2 value references (their variables hold 4 values"),
    "output array set": ("StepMode", lambda i: _raw_set(i, ["tip_u"], [1.0, 2.0, 3.0]),
                         "fmi3SetFloat64: 'tip_u' (value reference {tip_u}) is an output; outputs cannot be set"),
    "constant array set": ("InitializationMode", lambda i: _raw_set(i, ["natural_frequencies"], [1.0] * 6),
                           "fmi3SetFloat64: 'natural_frequencies' (value reference {natural_frequencies}) is an "
                           "output"),
    "two views, two values": ("StepMode", lambda i: _raw_set(i, ["F", "F_y"], [1.0, 2.0, 3.0, 4.0]),
                              "fmi3SetFloat64: element 1 of 'F' (2) and value reference {F_y} (4) are one input"),
    "NaN through an array": ("StepMode", lambda i: _raw_set(i, ["F"], [0.0, float("nan"), 0.0]),
                             "fmi3SetFloat64: F_y: got nan (allowed: a finite number)"),
    "array through Int32": ("StepMode", lambda i: i.fmu.getInt32([i.vr["F"]], nValues=3),
                            "fmi3GetInt32: value reference {F} is 'F', a Float64 array; use fmi3GetFloat64"),
    "structural parameter through Float64": (
        "StepMode", lambda i: _raw_get(i, ["n_retained_modes"], 1),
        "fmi3GetFloat64: value reference {n_retained_modes} is 'n_retained_modes', a UInt64 structural parameter; use "
        "fmi3GetUInt64"),
    "a scalar through UInt64": ("StepMode", lambda i: i.fmu.getUInt64([i.vr["F_x"]]),
                                "fmi3GetUInt64: value reference {F_x} is not a UInt64 variable (this FMU's: "
                                "{n_retained_modes} 'n_retained_modes')"),
    "another structural parameter": (
        "Instantiated", lambda i: _configure(i, 5),
        "fmi3SetUInt64: n_retained_modes: got 5, but this FMU was built with n_retained_modes = 6, fixed at build"),
    "structural parameter outside Configuration Mode": (
        "Instantiated", lambda i: i.fmu.setUInt64([i.vr["n_retained_modes"]], [6]),
        "fmi3SetUInt64: illegal call sequence (state Instantiated)"),
}


def _status(call, inst) -> int | None:
    try:
        return call(inst)
    except Exception as exc:                # fmpy raises on fmi3Error
        return getattr(exc, "status", None)


@pytest.mark.parametrize("label", list(BAD_CALLS))
def test_a_bad_call_is_refused_naming_the_variable(fmus, label):
    """fmi3Error, one message naming the variable (FMI 3.0's names), Terminated; fmi3Reset brings the instance back for
    a run that works."""
    state, bad, message = BAD_CALLS[label]
    inst = Instance3(fmus["FFRBeam"], "bad", state=state)
    try:
        inst.log.clear()
        assert _status(bad, inst) == 3
        errors = inst.errors()
        assert len(errors) == 1 and errors[0].startswith(message.format_map(inst.vr)), errors
        assert "fmi2" not in errors[0]
        assert inst.fmi_state() == "Terminated"
        inst.fmu.reset()
        inst.fmu.enterInitializationMode(startTime=0.0)
        inst.fmu.exitInitializationMode()
        assert _raw_set(inst, ["F"], [0.0, 0.0, 1.0]) == 0
        inst.fmu.doStep(0.0, H)
        assert get(inst, ["tip_u"], 3)[2] != 0.0
    finally:
        inst.free()


def test_configuration_mode_takes_the_built_value(fmus):
    inst = Instance3(fmus["FFRBeam"], "configure", state="Instantiated")
    try:
        size = inst.vr["n_retained_modes"]
        _configure(inst, 6)
        assert inst.fmu.getUInt64([size]) == [6]
        assert inst.raw("fmi3ExitConfigurationMode") == 0
        inst.fmu.enterInitializationMode(startTime=0.0)
        inst.fmu.exitInitializationMode()
        inst.fmu.doStep(0.0, H)
        assert inst.fmu.getUInt64([size]) == [6] and not inst.errors()
    finally:
        inst.free()


# ---------------------------------------------------------------------------------------------- derivatives
def test_directional_derivatives_through_arrays_are_their_elements(fmus):
    """d [tip_u, modal_coordinates, modal_rates, natural_frequencies] / d [F, modal_coordinates] along a seed equals the
    call on the elements (the states' value references, F_x .. F_z) bit for bit; the constants' rows are 0 and the
    states' rows are the seed's states."""
    inst = Instance3(fmus["FFRBeam"], "dd", state="StepMode")
    try:
        n = inst.fmu.getUInt64([inst.vr["n_retained_modes"]])[0]
        eta = [f"eta_{k}" for k in range(1, n + 1)]
        rates = [f"eta_dot_{k}" for k in range(1, n + 1)]
        inst.set(F_x=3.0, base_a_z=2.0)
        seed = np.random.default_rng(3).normal(size=3 + n)

        def derivative(unknowns, knowns, n_unknown):
            out = (ctypes.c_double * n_unknown)()
            status = inst.raw("fmi3GetDirectionalDerivative", refs(inst.vr[u] for u in unknowns), len(unknowns),
                              refs(inst.vr[k] for k in knowns), len(knowns), doubles(seed), len(seed), out, n_unknown)
            assert status == 0, inst.errors()
            return np.array(out)

        viewed = derivative(["tip_u", "modal_coordinates", "modal_rates", "natural_frequencies"],
                            ["F", "modal_coordinates"], 3 + 3 * n)
        scalars = derivative(["tip_u_x", "tip_u_y", "tip_u_z", *eta, *rates], ["F_x", "F_y", "F_z", *eta], 3 + 2 * n)
        assert np.array_equal(viewed[:3 + 2 * n], scalars)
        assert np.array_equal(viewed[3:3 + n], seed[3:]) and np.all(viewed[3 + 2 * n:] == 0.0)
        assert np.any(viewed[:3] != 0.0)
    finally:
        inst.free()


# ---------------------------------------------------------------------------------------------- the plan
def test_the_vectors_and_the_frequencies_chosen(fmus):
    """flexfmu.fmi.fmi3_arrays on a made-up table: an interface's P_x.. are 'tip.F'; a name taken by a scalar gets
    '_xyz'; a quaternion's x, y, z, mixed causalities or units are no vector; the LTI kind's frequencies come from
    A(0) = [[0, I], [-diag(omega^2), 0]] and none from another form."""
    from flexfmu.fmi.fmi3_arrays import natural_frequencies, vectors
    from flexfmu.fmi.variables import Variable

    def rows(*spec):
        return [Variable(name, "Real", causality, 0.0, unit, f"thing {name}, body frame, {name[-1]}")
                for name, causality, unit in spec]

    table = rows(*[(f"tip.F_{a}", "input", "N") for a in "xyz"], ("P", "output", "m"),
                 *[(f"P_{a}", "output", "m") for a in "xyz"], *[(f"q_{a}", "output", "") for a in "wxyz"],
                 ("u_x", "output", "m"), ("u_y", "input", "m"), ("u_z", "output", "m"),
                 ("v_x", "output", "m"), ("v_y", "output", "m/s"), ("v_z", "output", "m"))
    found = {name: members for name, members, _ in vectors(table)}
    assert found == {"tip.F": [0, 1, 2], "P_xyz": [4, 5, 6]}
    omega = np.array([3.0, 5.0])
    A = np.zeros((1, 4, 4))
    A[0, :2, 2:] = np.eye(2)
    A[0, 2:, :2] = -np.diag(omega ** 2)
    assert np.allclose(natural_frequencies("lti", {"lti.A": A}), omega / (2 * math.pi), rtol=1e-15, atol=0)
    A[0, 2, 1] = 1.0
    assert natural_frequencies("lti", {"lti.A": A}) is None


def test_fmi2_refuses_arrays(fmus, tmp_path):
    from flexfmu.errors import ParameterError
    from flexfmu.fmi.native_build import build_native_fmu

    with pytest.raises(ParameterError, match="arrays.*FMI 2.0 has no array variables"):
        build_native_fmu(fmus["sources"]["FFRBeam"], tmp_path / "FFRBeam.fmu", fmi_version=2, arrays=True)
    assert not (tmp_path / "FFRBeam.fmu").exists()


# ---------------------------------------------------------------------------------------------- fmusim
def _fmusim() -> Path | None:
    import os
    for candidate in (os.environ.get("FMUSIM"), shutil.which("fmusim"), ROOT.parent / "fmusim-build" / "fmusim"):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    return None


def test_fmusim_runs_the_fmus_with_arrays(fmus, tmp_path):
    """fmusim (Reference-FMUs) records the arrays (space-separated elements) equal to their scalars in co-simulation and
    model exchange; n_retained_modes = 6 through Configuration Mode is taken, 5 refused naming it."""
    fmusim = _fmusim()
    if fmusim is None:
        pytest.skip("fmusim not built (benchmarks/build_fmusim.sh SOURCE_DIR BUILD_DIR; or set FMUSIM)")
    inputs = tmp_path / "blow.csv"
    t = np.arange(0.0, 0.0105, 1e-4)
    force = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    np.savetxt(inputs, np.column_stack([t, force, 0.4 * force]), delimiter=",", header="time,F_x,F_z", comments="",
               fmt="%.17g")

    def run(*options, fmu=fmus["FFRBeam"]):
        out = tmp_path / "out.csv"
        done = subprocess.run([str(fmusim), *options, "--stop-time", "0.01", "--output-interval", "1e-4",
                               "--input-file", str(inputs), "--output-file", str(out), str(fmu)],
                              capture_output=True, text=True, timeout=300)
        return done, out

    for interface in ("cs", "me"):
        done, out = run("--interface-type", interface, "--start-value", "n_retained_modes", "6")
        assert done.returncode == 0, done.stdout + done.stderr
        lines = out.read_text().splitlines()
        names = [name.strip('"') for name in lines[0].split(",")]
        rows = [line.split(",") for line in lines[1:]]
        assert len(rows) == 101
        for vector in ("sensor_a", "tip_u", "reaction_F"):
            for row in rows:
                assert row[names.index(vector)].split() == [row[names.index(f"{vector}_{a}")] for a in "xyz"]
        assert max(abs(float(row[names.index("tip_u_x")])) for row in rows) > 0.0
    done, _ = run("--interface-type", "cs", "--start-value", "n_retained_modes", "5")
    assert done.returncode != 0 and "n_retained_modes: got 5" in done.stdout + done.stderr
    done, out = run("--interface-type", "cs", fmu=fmus["ReframeBody"])
    assert done.returncode == 0, done.stdout + done.stderr


def test_cli_builds_arrays_on_request_only(tmp_path):
    import subprocess
    import sys

    def flexfmu(*args):
        return subprocess.run([sys.executable, "-m", "flexfmu", *map(str, args)], capture_output=True, text=True,
                              timeout=600)
    built = flexfmu("build", "--runtime", "native", "--fmi-version", "3", "--fmi3-arrays", "--set", "n_modes=4",
                    "--out", tmp_path)
    assert built.returncode == 0, built.stderr
    from fmpy import read_model_description
    arrays = {v.name for v in read_model_description(str(tmp_path / "FFRBeam.fmu")).modelVariables if v.dimensions}
    assert {"F", "reaction_F", "modal_coordinates", "natural_frequencies"} <= arrays
    for args in (("build", "--fmi3-arrays", "--out", tmp_path),
                 ("build", "--runtime", "native", "--fmi3-arrays", "--out", tmp_path)):
        run = flexfmu(*args)
        assert run.returncode == 2 and "fmi3-arrays: needs --runtime native --fmi-version 3" in run.stderr, run.stderr


# ---------------------------------------------------------------------------------------------- an exported body
@pytest.fixture(scope="module")
def bar_fmus(tmp_path_factory):
    """{"clamped", "free": (FMI 3.0 native FMU with arrays, its body)} of the bar (tests/hex_bar.py), clamped at its
    root or free, a tip interface, gauges at a point and over the root's node set; --f-max 2000: modes and
    static-correction vectors (clamped 11 + 16, free 15 + 6), so q has both kinds."""
    pytest.importorskip("meshio")
    from hex_bar import bar_model

    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.native import body_source
    from flexfmu.fmi.native_build import build_native_fmu
    from flexfmu.importers import load_structure

    folder = tmp_path_factory.mktemp("bar")
    structure = load_structure(bar_model(folder))
    out = {}
    for case, clamp in (("clamped", clamp_from_text(structure, "root")), ("free", None)):
        body = build_body(structure, interfaces=[interface_from_text("tip=tip")], clamp=clamp, f_max=2000.0,
                          gauges=["mid=0.2,0,0", "root=root"])
        assert body.n_coordinates > body.n_modes             # static-correction coordinates among the q
        name = f"Bar{case.title()}"
        out[case] = build_native_fmu(body_source(body, name), folder / case / f"{name}.fmu", fmi_version=3,
                                     arrays=True), body
    return out


@pytest.mark.parametrize("case", ["clamped", "free"])
def test_a_bodys_tensors_and_shape_coordinates_are_its_scalars(bar_fmus, case):
    """The gauges' G.sigma and G.eps (<Dimension start="6"/>, VOIGT order, the scalars' units) and q (sized by the
    structural parameter n_shape_coordinates = the body's number of coordinates) are validated by fmpy and, over 20 ms
    of a moving tip load (and base acceleration: clamped), read as their scalars bit for bit; the clamped body's q
    (the LTI kind's states x[0 .. n-1]) reads as modal_coordinates."""
    from flexfmu.core.stress import VOIGT

    fmu, body = bar_fmus[case]
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    views = {v.name: v for v in md.modelVariables if BASE <= v.valueReference < TIME}
    size = views["n_shape_coordinates"]
    assert (size.type, size.causality, size.variability, int(size.start)) == (
        "UInt64", "structuralParameter", "fixed", body.n_coordinates)
    assert views["q"].shape == (body.n_coordinates,)
    assert [d.variable.name for d in views["q"].dimensions] == ["n_shape_coordinates"]
    tensors = {f"{g}.{t}": [f"{g}.{t}_{c}" for c in VOIGT] for g in ("mid", "root") for t in ("sigma", "eps")}
    for name in tensors:
        assert views[name].shape == (6,) and views[name].causality == "output", name
        assert views[name].unit == ("Pa" if name.endswith("sigma") else None), name
        assert "(xx, yy, zz, xy, yz, xz)" in views[name].description
    scalars = {"q": [f"q_{k}" for k in range(1, body.n_coordinates + 1)], **tensors}
    t = np.arange(0.0, 0.02 + 5e-4, 1e-3)
    inputs = [("tip.F_x", 50.0 * np.sin(300.0 * t)), ("tip.F_z", 20.0 * np.cos(700.0 * t))]
    if case == "clamped":
        inputs.append(("base_a_y", 3.0 * np.sin(900.0 * t)))
    signal = np.zeros(len(t), dtype=[("time", float)] + [(name, float) for name, _ in inputs])
    signal["time"] = t
    for name, values in inputs:
        signal[name] = values
    modal = ["modal_coordinates"] if case == "clamped" else []
    result = simulate_fmu(str(fmu), stop_time=0.02, step_size=1e-3, output_interval=1e-3, input=signal,
                          output=[*scalars, *modal, *(n for names in scalars.values() for n in names)])
    for array, names in scalars.items():
        elements = np.column_stack([result[n] for n in names])
        assert np.array_equal(result[array], elements), array
        assert np.ptp(elements, axis=0).max() > 0, array       # (the root set's yz is 0 by the bar's symmetry)
    assert np.all(np.ptp(result["q"], axis=0) > 0)                  # every q moves
    if modal:
        assert np.array_equal(result["q"], result["modal_coordinates"])


def test_the_shape_coordinates_size_is_fixed_at_build(bar_fmus):
    """n_shape_coordinates = its built value through Configuration Mode is taken; another is refused naming it."""
    fmu, body = bar_fmus["clamped"]
    n = body.n_coordinates
    inst = Instance3(fmu, "configure", state="Instantiated")
    try:
        size = inst.vr["n_shape_coordinates"]
        assert inst.raw("fmi3EnterConfigurationMode") == 0
        inst.fmu.setUInt64([size], [n])
        assert inst.fmu.getUInt64([size]) == [n] and not inst.errors()
        assert _status(lambda i: i.fmu.setUInt64([size], [n + 1]), inst) == 3
        errors = inst.errors()
        assert len(errors) == 1 and errors[0].startswith(
            f"fmi3SetUInt64: n_shape_coordinates: got {n + 1}, but this FMU was built with n_shape_coordinates = "
            f"{n}, fixed at build: the number of shape coordinates"), errors
        assert "--modes N" in errors[0]
    finally:
        inst.free()


def test_the_tensors_chosen():
    """flexfmu.fmi.fmi3_arrays.tensors on a made-up table: six components of one prefix, causality and unit are a
    tensor in VOIGT order whatever the scalars' order; a full matrix (r_yx ...), a missing component, mixed units are
    none; a name taken by a scalar or a vector gets '_voigt'."""
    from flexfmu.fmi.fmi3_arrays import tensors
    from flexfmu.fmi.variables import Variable

    def rows(*spec):
        return [Variable(name, "Real", "output", 0.0, unit, f"thing {name}") for name, unit in spec]

    voigt = ("xx", "yy", "zz", "xy", "yz", "xz")
    table = rows(*[(f"g.sigma_{c}", "Pa") for c in reversed(voigt)], ("s", "m"), *[(f"s_{c}", "1") for c in voigt],
                 *[(f"r_{a}{b}", "1") for a in "xyz" for b in "xyz"], *[(f"e_{c}", "1") for c in voigt[:5]],
                 *[(f"u_{c}", "Pa") for c in voigt[:5]], ("u_xz", "1"), *[(f"v_{c}", "1") for c in voigt])
    position = {v.name: k for k, v in enumerate(table)}
    found = {name: members for name, members, _ in tensors(table, taken=["v"])}
    assert found == {name: [position[f"{prefix}_{c}"] for c in voigt]
                     for name, prefix in (("g.sigma", "g.sigma"), ("s_voigt", "s"), ("v_voigt", "v"))}
