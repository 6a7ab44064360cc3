"""FMI 3.0 co-simulation FMUs of the Python runtime: the front compiled from csrc/flexfmu_fmi3.c (beside
flexfmu_fmi2.c, which holds front_common.c) loads the same Python-kind runtime library as the FMI 2.0 front
(flexfmu.fmi.runtime.compile_runtime(folder, 3)); the modelDescription is flexfmu.fmi.description_fmi3's over the
same variable table; the layout FMI 3.0's (flexfmu.fmi.build.build_one(..., fmi_version=3)).

Shown here: every FMU of the registry built by `flexfmu build --fmi-version 3` passes fmpy's validation, declares the
variables of flexfmu.fmi.variables.table, and steps; the FMI 3.0 FMU's records equal the FMI 2.0 FMU's of the same
spec (FFRBeam on the hammer record XFF, ReframeBody's plate, examples/bracket exported clamped and free); two FMI 3.0
Python FMUs share one process; FMU states round-trip; a C host (fmusim, when built) prints the same numbers for
both versions; `flexfmu export --fmi-version 3` of a free rod obeys Newton's second law.  The comparisons reuse
tests/test_fmu_fmi3.py's cases and recorder (those of the native FMUs)."""
from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

sys.path.insert(0, str(Path(__file__).parent))
from fmi3_helpers import STATE_BITS, STATE_PREFIX, Instance3  # noqa: E402
from test_fmu_fmi3 import CASES, RTOL, _fmusim, pulse, record, relative_difference  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
H = 1e-3
#: the runtime field of a serialised FMU state's header (csrc/front_common.c RUNTIME_ID): 1 for the Python runtime
PYTHON_RUNTIME_ID = 1


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """{"registry": {name: FMI 3.0 FMU of `flexfmu build --fmi-version 3`}, "twins": {case: {2: FMU, 3: FMU}}}: each
    pair of one spec, built in one go (an FMU refuses to load beside a flexfmu of another build in one process):
    FFRBeam (case XFF) and ReframeBody, the bracket exported clamped at its bolts and free (6 modes)."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.cli import main
    from flexfmu.fmi import registry, runtime
    from flexfmu.fmi.build import build_one
    from flexfmu.fmi.export import export_fmu
    from flexfmu.importers import load_structure

    out = tmp_path_factory.mktemp("fmi3_python")
    structure = load_structure(ROOT / "examples" / "bracket" / "bracket.json")
    tip = interface_from_text("tip=arm_top")
    clamped = build_body(structure, interfaces=[tip], clamp=clamp_from_text(structure, "bolt_1,bolt_2"), n_modes=6)
    free = build_body(structure, interfaces=[tip, interface_from_text("bolt=bolt_1")], n_modes=6)

    assert main(["build", "--fmi-version", "3", "--out", str(out / "fmi3")]) == 0
    fmi3 = {spec.name: out / "fmi3" / f"{spec.name}.fmu" for spec in registry.FMUS}
    runtime_files = runtime.compile_runtime(runtime.build_folder())
    specs = {spec.name: spec for spec in registry.FMUS}
    twins = {case: {2: build_one(specs[name], out / "fmi2" / f"{name}.fmu", runtime_files), 3: fmi3[name]}
             for case, name in (("XFF", "FFRBeam"), ("ReframeBody", "ReframeBody"))}
    for case, body, name in (("clamped", clamped, "BracketClamped"), ("free", free, "BracketFree")):
        twins[case] = {v: export_fmu(body, out / f"fmi{v}" / f"{name}.fmu", fmi_version=v) for v in (2, 3)}
    return {"registry": fmi3, "twins": twins}


def registry_names() -> list[str]:
    from flexfmu.fmi import registry
    return [spec.name for spec in registry.FMUS]


@pytest.mark.parametrize("name", registry_names())
def test_every_registry_fmu_validates_declares_the_variable_table_and_steps(built, name):
    from flexfmu.fmi import registry
    from flexfmu.fmi.description_fmi3 import TIME_VALUE_REFERENCE
    from flexfmu.fmi.variables import table

    fmu = built["registry"][name]
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.fmiVersion == "3.0" and md.coSimulation.modelIdentifier == name
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert md.coSimulation.needsExecutionTool        # a Python installation, as the FMI 2.0 FMU declares
    assert "Python runtime" in md.generationTool
    spec = next(s for s in registry.FMUS if s.name == name)
    declared = [(v.name, v.valueReference, v.causality, v.unit or "") for v in md.modelVariables if v.name != "time"]
    rows = table(spec)
    assert declared == [(v.name, k, v.causality, v.unit if v.type == "Real" else "") for k, v in enumerate(rows)]
    assert [(v.valueReference, v.causality) for v in md.modelVariables if v.name == "time"] == \
        [(TIME_VALUE_REFERENCE, "independent")]
    import zipfile
    with zipfile.ZipFile(fmu) as archive:
        binaries = sorted(n for n in archive.namelist() if n.startswith("binaries/"))
    assert binaries == [f"binaries/x86_64-linux/{name}.so", f"binaries/x86_64-linux/{name}_python.so"]
    # it loads (Python runtime, model file, GUID as instantiationToken) and steps from its default experiment
    inst = Instance3(fmu, state="StepMode")
    try:
        step = float(md.defaultExperiment.stepSize or H)
        inst.fmu.doStep(0.0, step)
        outputs = [v.name for v in md.modelVariables if v.causality == "output"]
        values = inst.get(*outputs)
        assert all(np.isfinite(values)) and inst.errors() == []
        assert inst.fmu.getFloat64([TIME_VALUE_REFERENCE]) == [step]
    finally:
        inst.free()


@pytest.mark.parametrize("case", ["XFF", "ReframeBody", "clamped", "free"])
def test_fmi3_records_equal_the_fmi2_records(built, case):
    """The same front code under both versions' entry points, the same bridge, model file and Python: equal bit for
    bit (RTOL allows only for a host passing numbers differently rounded)."""
    pair = built["twins"][case]
    assert validate_fmu(str(pair[3])) == []
    t_end, step, forces, start = CASES[case]
    fmi3, fmi2 = (record(pair[v], t_end, step, forces, **start) for v in (3, 2))
    assert len(fmi3) == len(fmi2) == int(round(t_end / step)) + 1 and np.array_equal(fmi3["time"], fmi2["time"])
    assert fmi3.dtype.names == fmi2.dtype.names
    difference = relative_difference(fmi3, fmi2)
    worst = max(difference, key=difference.get)
    identical = all(np.array_equal(fmi3[n], fmi2[n]) for n in fmi2.dtype.names)
    print(f"\n{case} (Python runtime): FMI 3.0 vs FMI 2.0, {len(fmi2)} samples of {len(difference)} outputs: worst "
          f"relative difference {difference[worst]:.2e} ({worst}); bit for bit: {identical}")
    assert difference[worst] <= RTOL, difference
    # the record moves: the comparison is not of zeros
    assert max(np.max(np.abs(fmi2[n])) for n in fmi2.dtype.names[1:] if "acc" in n or "_a_" in n) > 1e-3


def _drive(instances: list, steps: int) -> list[np.ndarray]:
    """Step the (Instance3, input name, outputs) in turns, step H, the input a half-sine pulse; each one's outputs."""
    force = pulse(10.0, 20 * H)
    records = [[] for _ in instances]
    for k in range(steps):
        for inst, name, outputs in instances:
            inst.set(**{name: float(force(k * H))})
            inst.fmu.doStep(k * H, H)
        for rows, (inst, _, outputs) in zip(records, instances):
            rows.append(inst.get(*outputs))
    return [np.array(r) for r in records]


def test_two_fmi3_python_fmus_in_one_process(built):
    """FFRBeam and the exported clamped bracket (its model from its own resources/), one instance of each stepped in
    turns in this process: each one's outputs equal, bit for bit, those of the same FMU stepped alone."""
    fmus = {"FFRBeam": (built["registry"]["FFRBeam"], "F_y"), "bracket": (built["twins"]["clamped"][3], "tip.F_y")}

    def make(key, name):
        fmu, force = fmus[key]
        inst = Instance3(fmu, name, state="StepMode")
        outputs = [v.name for v in inst.md.modelVariables if v.causality == "output"]
        return inst, force, outputs

    steps = 100
    alone = {}
    for key in fmus:
        inst = make(key, f"{key}-alone")
        try:
            alone[key] = _drive([inst], steps)[0]
        finally:
            inst[0].free()
    both = [make(key, f"{key}-together") for key in fmus]
    try:
        together = dict(zip(fmus, _drive(both, steps)))
        assert all(inst.errors() == [] for inst, _, _ in both)
    finally:
        for inst, _, _ in both:
            inst.free()
    for key in fmus:
        assert np.max(np.abs(alone[key])) > 0
        np.testing.assert_array_equal(together[key], alone[key])


@pytest.mark.parametrize("case", ["XFF", "free"])
def test_fmu_states_round_trip(built, case):
    """A state taken in Step Mode after 30 steps: setting it, its serialised bytes deserialised in the same instance,
    and in a second instance, each continue exactly as the first continuation; the header says Python runtime and
    Step Mode, and the instance's time is the state's."""
    from flexfmu.fmi.description_fmi3 import TIME_VALUE_REFERENCE

    fmu = built["twins"][case][3]
    force_name = {"XFF": "F_y", "free": "tip.F_y"}[case]
    inst = Instance3(fmu, state="StepMode")
    other = Instance3(fmu, "other", state="StepMode")
    outputs = [v.name for v in inst.md.modelVariables if v.causality == "output"]
    force = pulse(10.0, 50 * H)

    def run(instance, first, n):
        rows = []
        for k in range(first, first + n):
            instance.set(**{force_name: float(force(k * H))})
            instance.fmu.doStep(k * H, H)
            rows.append(instance.get(*outputs))
        return np.array(rows)

    states = []
    try:
        run(inst, 0, 30)
        state = inst.fmu.getFMUState()
        states.append((inst, state))
        blob = inst.fmu.serializeFMUState(state)
        assert blob.startswith(STATE_PREFIX)
        runtime_id, fmi_state = struct.unpack_from("<II", blob, len(STATE_PREFIX) + 4)
        assert (runtime_id, fmi_state) == (PYTHON_RUNTIME_ID, STATE_BITS["StepMode"])
        first = run(inst, 30, 30)
        assert np.max(np.abs(first)) > 0
        inst.fmu.setFMUState(state)
        assert inst.fmu.getFloat64([TIME_VALUE_REFERENCE]) == [pytest.approx(30 * H, rel=1e-12)]
        np.testing.assert_array_equal(run(inst, 30, 30), first)
        restored = inst.fmu.deserializeFMUState(blob)
        states.append((inst, restored))
        inst.fmu.setFMUState(restored)
        np.testing.assert_array_equal(run(inst, 30, 30), first)
        in_other = other.fmu.deserializeFMUState(blob)
        states.append((other, in_other))
        other.fmu.setFMUState(in_other)
        np.testing.assert_array_equal(run(other, 30, 30), first)
        assert inst.errors() == [] and other.errors() == []
    finally:
        for owner, s in states:
            owner.fmu.freeFMUState(s)
        inst.free()
        other.free()


def test_fmusim_runs_the_fmi3_python_fmu_as_the_fmi2_one(built, tmp_path):
    """A C host (no Python in the process until the front loads libpython): the same numbers for both versions."""
    fmusim = _fmusim()
    if fmusim is None:
        pytest.skip("fmusim not built (benchmarks/build_fmusim.sh SOURCE_DIR BUILD_DIR; or set FMUSIM)")
    inputs = tmp_path / "hammer.csv"
    t = np.arange(0.0, 0.0205, 1e-4)
    force = pulse(20.0, 1e-3)(t)
    np.savetxt(inputs, np.column_stack([t, force, 0.4 * force]), delimiter=",", header="time,F_x,F_z",
               comments="", fmt="%.17g")
    outputs = {}
    for version in (2, 3):
        out = tmp_path / f"out{version}.csv"
        run = subprocess.run([str(fmusim), "--interface-type", "cs", "--stop-time", "0.02", "--output-interval", "1e-4",
                              "--start-value", "damping_ratio", "0.002", "--input-file", str(inputs),
                              "--output-file", str(out), str(built["twins"]["XFF"][version])],
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stdout + run.stderr
        lines = out.read_text().splitlines()
        outputs[version] = ([name.strip('"') for name in lines[0].split(",")], lines[1:])
    (names, rows), (names2, rows2) = outputs[3], outputs[2]
    assert names == names2 and len(rows) == 201 and rows == rows2     # the same numbers, printed alike
    accelerometer = np.array([float(row.split(",")[names.index("sensor_a_z")]) for row in rows])
    assert np.max(np.abs(accelerometer)) > 1e-3


def test_cli_exports_an_fmi3_python_fmu_of_a_free_rod(tmp_path, capsys):
    """`flexfmu export --fmi-version 3` (Python runtime) of a free steel rod: a force F_y at one end for t gives its
    centre of mass the velocity F t / m (Newton's second law; the modal part has no net momentum)."""
    from flexfmu.cli import main

    E, NU, RHO, L, d = 2.1e11, 0.3, 7850.0, 1.0, 0.02
    scene = tmp_path / "rod.json"
    scene.write_text('{"name": "rod", "points": [[0, 0, 0], [1, 0, 0]], "section": {"shape": "circle", '
                     f'"diameter": {d}}}, "material": {{"E": {E}, "nu": {NU}, "rho": {RHO}}}}}')
    out = tmp_path / "Rod.fmu"
    assert main(["export", f"beam:{scene}", "-o", str(out), "--modes", "4", "--interface", f"end={L},0,0",
                 "--fmi-version", "3"]) == 0
    assert "(FMI 3.0)" in capsys.readouterr().out
    assert validate_fmu(str(out)) == [] and read_model_description(str(out)).fmiVersion == "3.0"
    F = 0.5
    result = simulate_fmu(str(out), stop_time=0.002, step_size=1e-5, output_interval=1e-5,
                          start_values={"end.F_y": F}, output=["com_vel_y"])
    mass = RHO * np.pi * d ** 2 / 4 * L
    # the bound tests/test_fmu_export.py puts on the FMI 2.0 FMU of this rod (measured here: 1e-14, rounding)
    assert result["com_vel_y"][-1] == pytest.approx(F * result["time"][-1] / mass, rel=1e-6)
