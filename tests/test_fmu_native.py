"""Native FMUs (flexfmu.fmi.native: the front and a C bridge in one library, no Python in the host) against the
Python FMUs of the same models, loaded the way users load them: fmpy.simulate_fmu on fresh extractions, many
times in one process and mixed with Python FMUs; the plain C host in an empty environment; the ecos CLI and
libcosim (those tests are marked host, the rest fmu).

The native FMUs are built once per session (the ``native`` fixture: FFRBeam at its defaults and with the hammer
record's set-ups for XFF, XFX and FXF; an exported clamped body beside its Python FMU)."""
from __future__ import annotations

import ctypes
import importlib.util
import math
import re
import shutil
import struct
import subprocess
import sys
import threading
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.validation import validate_fmu

from fmu_helpers import Instance, error_messages, fmu_checker_findings, refusal_messages, restamp_crc
from host_tools import (compile_c_host, describe, ecos_binaries, ecos_times, extract_fmu, fresh_fmu_copy,
                        host_environment, jacobi_reference, run_host, value_references)

ROOT = Path(__file__).resolve().parents[1]
H = 1e-3
#: relative equality of native and Python FMUs (per output, relative to its largest magnitude)
RTOL = 1e-10


def _hammer_module():
    spec = importlib.util.spec_from_file_location("hammer_test", ROOT / "examples" / "hammer_test.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HAMMER = _hammer_module()


# ---------------------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="session")
def native(tmp_path_factory):
    """{"FFRBeam": defaults, "XFF" | "XFX" | "FXF": the hammer record's set-up (boundary, load_s, sensor_s)}."""
    from flexfmu.fmi import native as build
    out = tmp_path_factory.mktemp("native")
    fmus = {"FFRBeam": build.build_registry_fmu("FFRBeam", target=out / "FFRBeam.fmu")}
    for boundary, (load_s, sensor_s) in HAMMER.SETUPS.items():
        fmus[boundary] = build.build_registry_fmu(
            "FFRBeam", {"boundary": boundary, "load_s": load_s, "sensor_s": sensor_s},
            target=out / boundary / "FFRBeam.fmu")
    return fmus


@pytest.fixture(scope="session")
def cantilever(tmp_path_factory):
    """A clamped steel bar (hexahedral mesh, clamped at x = 0, interface tip at x = 0.4 m, 8 modes) exported with
    both runtimes: {"python": path, "native": path}."""
    pytest.importorskip("meshio")
    sys.path.insert(0, str(Path(__file__).parent))
    from test_fmu_export import BOX, E, NU, RHO, box_mesh

    from flexfmu.body.build import build_body
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.export import export_fmu
    from flexfmu.importers import load_structure

    out = tmp_path_factory.mktemp("cantilever")
    box_mesh(out / "box.inp")
    structure = load_structure(out / "box.inp", material={"E": E, "nu": NU, "rho": RHO})
    body = build_body(structure, interfaces=[interface_from_text(f"tip={BOX[0]},0,0")], clamp="root", n_modes=8,
                      damping_ratio=0.02)
    return {"python": export_fmu(body, out / "python" / "Cantilever.fmu"),
            "native": export_fmu(body, out / "native" / "Cantilever.fmu", runtime="native")}


def relative_difference(a, b) -> dict:
    """{output: max |a - b| / max |b|} over the outputs of two simulate_fmu results."""
    out = {}
    for name in b.dtype.names[1:]:
        scale = float(np.max(np.abs(b[name])))
        out[name] = float(np.max(np.abs(a[name] - b[name]))) / (scale if scale > 0 else 1.0)
    return out


def _element(fmu, tag: str) -> bytes:
    """An element of the FMU's modelDescription.xml, serialised."""
    from xml.etree import ElementTree as ET
    with zipfile.ZipFile(fmu) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    return ET.tostring(root.find(tag))


def md_variables(fmu) -> list:
    md = read_model_description(str(fmu))
    return [(v.name, v.valueReference, v.type, v.causality, v.variability, v.initial, v.unit, v.description)
            for v in md.modelVariables]


# ---------------------------------------------------------------------------------------------- the FMU itself
def test_model_description_is_the_python_fmus(native, fmus):
    """Same variables (names, value references, types, causality, variability, units, descriptions), start
    values, unit definitions and DefaultExperiment as the Python FMU; no execution tool needed."""
    assert md_variables(native["FFRBeam"]) == md_variables(fmus["FFRBeam"])
    mine, theirs = read_model_description(str(native["FFRBeam"])), read_model_description(str(fmus["FFRBeam"]))
    assert [v.start for v in mine.modelVariables] == [v.start for v in theirs.modelVariables]
    for tag in ("UnitDefinitions", "DefaultExperiment", "LogCategories", "ModelStructure"):
        assert _element(native["FFRBeam"], tag) == _element(fmus["FFRBeam"], tag), tag
    assert mine.guid != theirs.guid and not mine.coSimulation.needsExecutionTool
    assert mine.coSimulation.canGetAndSetFMUstate and mine.coSimulation.canSerializeFMUstate
    # a set-up build: its fixed parameters start at the build values
    xfx = {v.name: v.start for v in read_model_description(str(native["XFX"])).modelVariables}
    assert (xfx["boundary"], float(xfx["load_s"]), float(xfx["sensor_s"])) == ("XFX", 0.30, 0.04)


def test_exported_model_description_is_the_python_fmus(cantilever):
    assert md_variables(cantilever["native"]) == md_variables(cantilever["python"])


@pytest.mark.parametrize("which", ["FFRBeam", "XFX", "exported"])
def test_fmpy_validate_reports_no_problems(native, cantilever, which):
    assert validate_fmu(str(cantilever["native"] if which == "exported" else native[which])) == []


@pytest.mark.parametrize("which", ["FFRBeam", "exported"])
def test_the_fmu_checker_finds_no_problem(native, cantilever, which):
    """fmu-manipulation-toolbox's checker (fmutool -check: XSD and semantic checks of the modelDescription), as
    for the Python FMUs (tests/test_fmu_hosts.py)."""
    assert fmu_checker_findings(cantilever["native"] if which == "exported" else native[which]) == ""


def test_the_binary_needs_no_python(native, cantilever):
    """ldd shows no libpython; no Python symbol is referenced; only the fmi2 and fmi3 functions are exported (the
    library holds the FMI 2.0 and FMI 3.0 fronts)."""
    for fmu in (native["FFRBeam"], cantilever["native"]):
        with zipfile.ZipFile(fmu) as zf:
            binaries = [n for n in zf.namelist() if n.startswith("binaries/")]
            linux64 = f"binaries/linux64/{Path(fmu).stem}.so"      # win64, aarch64-linux: test_fmu_platforms.py
            assert linux64 in binaries and all(n.startswith(("binaries/linux64/", "binaries/win64/",
                                                              "binaries/aarch64-linux/")) for n in binaries), binaries
            folder = Path(extract(str(fmu)))
        try:
            so = folder / linux64
            ldd = subprocess.run(["ldd", str(so)], capture_output=True, text=True, check=True).stdout
            assert "python" not in ldd.lower(), ldd
            libraries = {line.split()[0] for line in ldd.splitlines() if "=>" in line}
            assert libraries <= {"libm.so.6", "libc.so.6", "libpthread.so.0", "libdl.so.2"}, ldd
            symbols = subprocess.run(["nm", "-D", str(so)], capture_output=True, text=True, check=True).stdout
            assert not re.search(r"\bPy", symbols), "a Python symbol is referenced"
            exported = {line.split()[-1] for line in symbols.splitlines() if " T " in line}
            assert exported and all(name.startswith(("fmi2", "fmi3")) for name in exported), exported
            assert not (folder / "resources" / "flexfmu_runtime.txt").exists()
        finally:
            shutil.rmtree(folder, ignore_errors=True)


def test_sources_are_complete_and_rebuild_with_cmake(native, tmp_path):
    """sources/ holds every file the binary is made of: CMake rebuilds the library from them alone (as on Windows
    or macOS), and the rebuilt FMU gives the shipped one's numbers."""
    cmake = shutil.which("cmake")
    if cmake is None:
        pytest.skip("cmake is not installed")
    folder = extract_fmu(native["XFF"], tmp_path / "fmu")
    (folder / "binaries" / "linux64" / "FFRBeam.so").unlink()
    for step in (["-S", "sources", "-B", "build", "-DCMAKE_BUILD_TYPE=Release"], ["--build", "build"]):
        proc = subprocess.run([cmake, *step], cwd=folder, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout + proc.stderr
    rebuilt = folder / "binaries" / "linux64" / "FFRBeam.so"
    assert rebuilt.is_file()
    inputs = np.array([(0.0, 1.0, 0.5), (0.05, 1.0, 0.5)], dtype=[("time", float), ("F_z", float), ("base_w_z", float)])
    runs = []
    for source in (native["XFF"], folder):
        runs.append(simulate_fmu(str(source), stop_time=0.05, step_size=H, input=inputs,
                                 start_values={"damping_ratio": 0.02}))
    # identity: the same C sources built with IEEE flags (no fast-math, -ffp-contract=off in both builds), run on
    # the same inputs and steps: the same operations in the same order, the same libm
    assert all(np.array_equal(runs[0][name], runs[1][name]) for name in runs[0].dtype.names)


@pytest.mark.unit
def test_model_file_round_trip(tmp_path):
    from flexfmu.fmi.model_file import read_model_file, write_model_file
    entries = {"kind": "lti", "names": ["a", "béta", ""], "x": np.arange(6.0).reshape(2, 3), "i": np.int32(-4),
               "empty": np.zeros((0, 3)), "s": 2.5}
    back = read_model_file(write_model_file(tmp_path / "m.bin", entries))
    assert back["kind"] == "lti" and back["names"] == ["a", "béta", ""]
    assert np.array_equal(back["x"], entries["x"]) and back["x"].dtype == np.float64
    assert back["i"].shape == () and int(back["i"]) == -4 and back["i"].dtype == np.int32
    assert back["empty"].shape == (0, 3) and back["s"].shape == () and float(back["s"]) == 2.5


# ---------------------------------------------------------------------------------------------- equal numbers
def hammer_record(fmu, boundary, duration=2.0):
    """The paper's virtual experiment (examples/hammer_test.py): 1 ms half-sine blow on all three axes at load_s,
    10 kS/s, damping 0.002; every output."""
    from flexfmu.ffr.simulator import INPUT_NAMES
    load_s, sensor_s = HAMMER.SETUPS[boundary]
    dt = 1.0 / HAMMER.SAMPLE_RATE
    t = np.arange(0.0, duration + dt / 2, dt)
    pulse = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    signals = np.zeros(len(t), dtype=[("time", float)] + [(name, float) for name in INPUT_NAMES])
    signals["time"] = t
    signals["F_x"], signals["F_y"], signals["F_z"] = pulse, 0.7 * pulse, 0.4 * pulse
    return simulate_fmu(str(fmu), start_time=0.0, stop_time=duration, step_size=dt, output_interval=dt,
                        input=signals, start_values={"boundary": boundary, "damping_ratio": 0.002,
                                                     "load_s": load_s, "sensor_s": sensor_s})


@pytest.mark.parametrize("boundary", list(HAMMER.SETUPS))
def test_hammer_record_equals_the_python_fmu(native, fmus, boundary):
    """Every output over the 2 s hammer record, native and Python alternately in this process (each
    simulate_fmu on a fresh extraction): equal to 1e-10 relative."""
    ours = hammer_record(native[boundary], boundary)
    theirs = hammer_record(fmus["FFRBeam"], boundary)
    assert len(ours) == len(theirs) == 20001
    difference = relative_difference(ours, theirs)
    worst = max(difference, key=difference.get)
    print(f"\n{boundary}: worst relative difference {difference[worst]:.2e} ({worst})")
    assert difference[worst] <= RTOL, difference
    assert max(np.max(np.abs(ours[f"sensor_a_{a}"])) for a in "xyz") > 1e-2    # the blow shows


CONFIGURATIONS = {"geometric stiffening": {"geometric_stiffening": True},
                  "model size chosen, static correction": {"n_modes": -1, "elements_per_segment": 0}}


@pytest.mark.parametrize("label", list(CONFIGURATIONS))
def test_other_configurations_equal_the_python_fmu(fmus, tmp_path, label):
    """Geometric stiffening (the base acceleration enters the matrices too) and the automatic model size with its
    static correction (quartic terms of the base rotation in the strain energy; the damping ratio is then fixed):
    spun, shaken and loaded, every output equal to 1e-10."""
    from flexfmu.fmi.native import build_registry_fmu
    settings = CONFIGURATIONS[label]
    fmu = build_registry_fmu("FFRBeam", settings, target=tmp_path / "FFRBeam.fmu")
    t = np.arange(0.0, 0.2 + H / 2, H)
    signals = np.zeros(len(t), dtype=[("time", float)] + [(n, float) for n in ("F_y", "M_x", "base_w_z", "base_w_x",
                                                                              "base_a_x", "base_dw_y")])
    signals["time"] = t
    signals["F_y"], signals["M_x"] = np.sin(50 * t), 0.05
    signals["base_w_z"], signals["base_w_x"] = 3.0 + np.sin(5 * t), 0.5
    signals["base_a_x"], signals["base_dw_y"] = 2.0 * np.cos(9 * t), 0.3
    runs = [simulate_fmu(str(f), stop_time=0.2, step_size=H, input=signals, start_values=settings)
            for f in (fmu, fmus["FFRBeam"])]
    difference = relative_difference(*runs)
    worst = max(difference, key=difference.get)
    print(f"\n{label}: worst relative difference {difference[worst]:.2e} ({worst})")
    assert difference[worst] <= RTOL, difference
    if settings.get("n_modes") == -1:                       # the chosen modes depend on it: fixed at build
        inst = Instance(fmu, "zeta")
        try:
            inst.expect_failure(inst.set, damping_ratio=0.05)
            assert "built with damping_ratio = 0.01" in error_messages(inst)[0]
        finally:
            inst.free()


def base_motion_record(fmu, t_end=0.3, **start):
    """A clamped body shaken and spun through its base, its tip struck: every output."""
    md = read_model_description(str(fmu))
    names = [v.name for v in md.modelVariables if v.causality == "input"]
    t = np.arange(0.0, t_end + H / 2, H)
    signals = np.zeros(len(t), dtype=[("time", float)] + [(n, float) for n in names])
    signals["time"] = t
    signals["base_a_z"] = 9.81 * np.sin(40 * t)
    signals["base_a_x"] = 2.0
    signals["base_w_x"] = 0.5 * np.sin(7 * t)
    signals["base_dw_x"] = 3.5 * np.cos(7 * t)
    signals["base_w_z"] = 1.0
    signals["tip.F_y"] = np.where(t < 0.01, 5.0, 0.0)
    return simulate_fmu(str(fmu), stop_time=t_end, step_size=H, output_interval=H, input=signals, start_values=start)


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_exported_clamped_body_in_a_clock_host_equals_a_constant_step_host_bit_for_bit(cantilever, runtime):
    """Steps h = t(k+1) - t(k) from t = 1000 s, differing in their last bits, reuse the first step's maps
    (flexfmu.core.step_size): the same computation as a constant-step host, so the same bits."""
    from fmu_helpers import clock_and_constant_step_runs
    from flexfmu.core.step_size import STEP_RTOL
    inputs = {"tip.F_y": 5.0, "base_a_z": 9.81, "base_w_x": 0.5, "base_w_z": 1.0}
    clock, constant, jitter = clock_and_constant_step_runs(cantilever[runtime], inputs, H, 300, t0=1e3)
    assert 0 < jitter < STEP_RTOL
    assert np.array_equal(clock, constant)


@pytest.mark.parametrize("start", [{}, {"damping_ratio": 0.05}, {"internal_step": 2.5e-4}],
                         ids=["defaults", "damping", "internal-steps"])
def test_exported_clamped_body_under_base_motion_equals_the_python_fmu(cantilever, start):
    ours = base_motion_record(cantilever["native"], **start)
    theirs = base_motion_record(cantilever["python"], **start)
    difference = relative_difference(ours, theirs)
    worst = max(difference, key=difference.get)
    print(f"\nexported clamped body {start}: worst relative difference {difference[worst]:.2e} ({worst})")
    assert difference[worst] <= RTOL, difference
    assert np.max(np.abs(ours["reaction_F_z"])) > 1.0


def test_many_simulations_in_one_process_mixed_with_python_fmus(native, fmus):
    """simulate_fmu twelve times, native and Python FMUs of several models interleaved: identical results per
    FMU every time (fresh extraction each; fmpy deletes it after each run)."""
    inputs = np.array([(0.0, 1.0, 0.3), (0.02, 1.0, 0.3)], dtype=[("time", float), ("F_y", float), ("base_w_z", float)])
    runs = {}
    for k in range(3):
        for key, fmu in (("native", native["FFRBeam"]), ("python", fmus["FFRBeam"]), ("xfx", native["XFX"])):
            res = simulate_fmu(str(fmu), stop_time=0.02, step_size=H, input=inputs)
            runs.setdefault(key, []).append(res)
        simulate_fmu(str(fmus["PTO"]), stop_time=0.01, step_size=H)
    for key, results in runs.items():
        assert all(np.array_equal(np.array(r.tolist()), np.array(results[0].tolist())) for r in results), key
    assert max(relative_difference(runs["native"][0], runs["python"][0]).values()) <= RTOL


# ---------------------------------------------------------------------------------------------- behaviour
def _steps(inst, n, start_step=0, **inputs):
    rows = []
    for k in range(start_step, start_step + n):
        inst.set(**inputs)
        inst.fmu.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
        rows.append(inst.get("sensor_u_x", "sensor_a_z", "tip_u_y", "reaction_M_x", "elastic_energy"))
    return np.array(rows)


LOADS = {"F_y": 2.0, "base_w_z": 0.7, "base_dw_x": 1.5, "base_a_z": 3.0}


def test_fmu_state_get_set_serialise_round_trip(native):
    """Roll back with fmi2SetFMUstate, and continue from a serialised state in another instance (and extraction):
    bit-identical outputs; a state taken before initialisation brings back Instantiated with its parameters."""
    a = Instance(native["FFRBeam"], "a", damping_ratio=0.03).initialize()
    b = Instance(native["FFRBeam"], "b")
    try:
        _steps(a, 40, **LOADS)
        state = a.fmu.getFMUstate()
        data = a.fmu.serializeFMUstate(state)
        first = _steps(a, 25, 40, F_y=-1.0)
        a.fmu.setFMUstate(state)
        again = _steps(a, 25, 40, F_y=-1.0)
        assert np.array_equal(first, again)
        b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(data))       # b: its own extraction, other parameters
        assert np.array_equal(_steps(b, 25, 40, F_y=-1.0), first)
        assert b.fmu.getReal([b.vr["damping_ratio"]]) == [0.03]
        a.fmu.freeFMUstate(state)
        # before initialisation: the parameters restored, the instance back in initialisation mode
        c = Instance(native["FFRBeam"], "c", damping_ratio=0.2)
        before = c.fmu.getFMUstate()
        c.initialize()
        expected = _steps(c, 3, **LOADS)
        c.fmu.setFMUstate(before)
        assert c.fmu.getReal([c.vr["damping_ratio"]]) == [0.2]
        c.fmu.exitInitializationMode()                            # legal only in InitializationMode
        assert np.array_equal(_steps(c, 3, **LOADS), expected)
        c.free()
    finally:
        a.free()
        b.free()


def test_damaged_or_foreign_states_are_refused(native, fmus):
    inst = Instance(native["FFRBeam"], "s").initialize()
    python = Instance(fmus["FFRBeam"], "p").initialize()
    try:
        _steps(inst, 3, **LOADS)
        data = bytes(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
        foreign = bytes(python.fmu.serializeFMUstate(python.fmu.getFMUstate()))
        bad = {"truncated": data[:-8], "garbage payload": data[:-40] + b"\xff" * 40, "python FMU's": foreign,
               "other native build's": data.replace(read_model_description(str(native["FFRBeam"])).guid.encode(),
                                                    read_model_description(str(native["XFX"])).guid.encode())}
        for label, blob in bad.items():
            inst.log.clear()
            inst.expect_failure(inst.fmu.deSerializeFMUstate, blob)
            assert any(s == 3 and "fmi2DeSerializeFMUstate" in m for s, _, m in inst.log), (label, inst.log)
        nan_state = bytearray(data)                              # the state vector's last entry: before the u64
        nan_state[-16:-8] = struct.pack("<d", float("nan"))      # size of the kind's own state (0 here)
        inst.log.clear()                                         # a valid checksum: the bridge's own check refuses
        inst.expect_failure(inst.fmu.deSerializeFMUstate, restamp_crc(bytes(nan_state)))
        assert any("not finite" in m for _, _, m in inst.log), inst.log
        _steps(inst, 1, 3)                                       # the instance goes on
    finally:
        inst.free()
        python.free()




BAD_CALLS = {
    "unknown vr": lambda i: i.fmu.getReal([999]),
    "getReal of a String": lambda i: i.fmu.getReal([i.vr["boundary"]]),
    "setInteger of a Real": lambda i: i.fmu.setInteger([i.vr["F_x"]], [1]),
    "set an output": lambda i: i.fmu.setReal([i.vr["tip_u_x"]], [1.0]),
    "NaN input": lambda i: i.fmu.setReal([i.vr["F_x"]], [float("nan")]),
    "inf parameter": lambda i: i.fmu.setReal([i.vr["damping_ratio"]], [float("inf")]),
    "parameter after initialisation": lambda i: (i.initialize(), i.fmu.setReal([i.vr["damping_ratio"]], [0.1])),
    "wrong communication point": lambda i: (i.initialize(), i.fmu.doStep(currentCommunicationPoint=0.25,
                                                                         communicationStepSize=H)),
    "damping_ratio out of range": lambda i: (i.set(damping_ratio=1.5), i.initialize()),
    "max_internal_steps out of range": lambda i: (i.set(max_internal_steps=0), i.initialize()),
    "negative damping_ratio": lambda i: (i.set(damping_ratio=-0.1), i.initialize()),
}


@pytest.mark.parametrize("label", list(BAD_CALLS))
def test_refused_calls_give_the_python_fmus_status_and_message(native, fmus, label):
    """fmi2Error and the same one message as the Python FMU, word for word."""
    logs = refusal_messages((native["FFRBeam"], fmus["FFRBeam"]), BAD_CALLS[label])
    assert len(logs[0]) == 1 and logs[0] == logs[1], logs


FIXED = [("boundary", "XFX", "'XFF'"), ("scene", "c_section", "'spatial_double_L'"), ("n_modes", 7, "6"),
         ("load_s", 0.2, "-1.0"), ("geometric_stiffening", True, "false"), ("integrator", "rk4", "'exact'"),
         ("elements_per_segment", 4, "8")]


@pytest.mark.parametrize("name, value, built", FIXED, ids=[f[0] for f in FIXED])
def test_a_fixed_parameter_accepts_its_build_value_and_refuses_another(native, name, value, built):
    inst = Instance(native["FFRBeam"], "fixed")
    try:
        default = {v.name: v.start for v in inst.md.modelVariables}[name]
        inst.set(**{name: {"true": True, "false": False}.get(default, default)})      # its build value: fine
        inst.expect_failure(inst.set, **{name: value})
        (message,) = error_messages(inst)
        assert message.startswith(f"fmi2Set{inst.types[name]}: {name}: got ")
        assert f"built with {name} = {built}" in message
        assert f"flexfmu build --runtime native --fmu FFRBeam --set {name}=" in message
        inst.initialize()                                    # the refused value was not taken
        inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=H)
    finally:
        inst.free()


def test_the_rebuild_command_keeps_the_other_fixed_values(native):
    inst = Instance(native["XFX"], "fixed")
    try:
        inst.expect_failure(inst.set, sensor_s=0.1)
        (message,) = error_messages(inst)
        assert ("rebuild it: flexfmu build --runtime native --fmu FFRBeam --set boundary=XFX --set load_s=0.3 "
                "--set sensor_s=0.1 (or use" in message), message
        inst.log.clear()
        inst.expect_failure(inst.set, boundary="FXF")               # the changed one is not repeated
        (message,) = error_messages(inst)
        assert "rebuild it: flexfmu build --runtime native --fmu FFRBeam --set load_s=0.3 --set boundary=FXF (" \
            in message, message
        inst.log.clear()
        inst.expect_failure(inst.set, scene="my scene.json")       # a value the shell must see as one word
        assert "--set 'scene=my scene.json' (" in error_messages(inst)[0]
    finally:
        inst.free()


EXPORTED_BAD = [("damping_ratio", -0.5), ("internal_step", -1.0), ("internal_step", 1e-12),
                ("max_internal_steps", 0)]


@pytest.mark.parametrize("name, value", EXPORTED_BAD, ids=[f"{n}={v}" for n, v in EXPORTED_BAD])
def test_exported_body_refuses_bad_parameters_naming_them(cantilever, name, value):
    messages = []
    for fmu in (cantilever["native"], cantilever["python"]):
        inst = Instance(fmu, "bad", **{name: value})
        try:
            inst.expect_failure(inst.fmu.exitInitializationMode)
            (message,) = error_messages(inst)
            assert message.startswith(f"{name}: "), message
            messages.append(message)
        finally:
            inst.free()
    if name != "damping_ratio":               # the same words (damping: the same range, worded once per FMU)
        assert messages[0] == messages[1], messages


def test_a_step_above_max_internal_steps_is_discarded_as_by_the_python_fmu(cantilever):
    statuses, texts = [], []
    for fmu in (cantilever["native"], cantilever["python"]):
        inst = Instance(fmu, "cap", internal_step=1e-4, max_internal_steps=100).initialize()
        try:
            start = inst.fmu.getFMUstate()
            exc = inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=0.5,
                                      status=2)
            statuses.append(exc.status)
            texts.append([m for s, _, m in inst.log if s == 2])
            inst.fmu.setFMUstate(start)                          # roll back, then a smaller step does
            inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
        finally:
            inst.free()
    assert statuses == [2, 2] and texts[0] == texts[1], texts


def test_divergence_is_an_error_naming_what_the_python_fmu_names(native, fmus):
    """Spin far above the first bending frequency: fmi2Error before any output is NaN, at the same step and
    naming the same variable as the Python FMU."""
    found = []
    for fmu in (native["FFRBeam"], fmus["FFRBeam"]):
        inst = Instance(fmu, "spin").initialize()
        try:
            inst.set(base_w_z=2000.0, F_y=1.0)
            for k in range(200):
                try:
                    inst.fmu.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
                except Exception as exc:
                    assert getattr(exc, "status", None) == 3
                    break
                assert np.all(np.isfinite(inst.get("tip_u_x", "elastic_energy")))
            else:
                raise AssertionError("the spinning rod did not diverge")
            (message,) = error_messages(inst)
            assert "diverged" in message
            found.append((k, message.split(":")[0]))
        finally:
            inst.free()
    assert found[0] == found[1], found


def test_reset_gives_a_fresh_instance(native):
    fresh = Instance(native["FFRBeam"], "fresh").initialize()
    reused = Instance(native["FFRBeam"], "reused", damping_ratio=0.3).initialize()
    try:
        expected = _steps(fresh, 12, **LOADS)
        _steps(reused, 7, F_x=5.0)
        reused.fmu.reset()
        reused.fmu.setupExperiment(startTime=0.0)
        reused.fmu.enterInitializationMode()
        assert reused.fmu.getReal([reused.vr["damping_ratio"], reused.vr["F_x"]]) == [0.01, 0.0]
        reused.fmu.exitInitializationMode()
        assert np.array_equal(_steps(reused, 12, **LOADS), expected)
    finally:
        fresh.free()
        reused.free()


def test_outputs_read_after_new_inputs_are_those_of_the_last_step(native, fmus):
    """As the Python FMU: inputs set after a step act from the next fmi2DoStep on."""
    rows = []
    for fmu in (native["FFRBeam"], fmus["FFRBeam"]):
        inst = Instance(fmu, "late").initialize()
        try:
            _steps(inst, 5, **LOADS)
            before = inst.get("sensor_a_z", "reaction_F_y")
            inst.set(F_y=100.0, base_w_z=5.0)
            rows.append((before, inst.get("sensor_a_z", "reaction_F_y")))
        finally:
            inst.free()
    assert rows[0][0] == rows[0][1]
    np.testing.assert_allclose(rows[0][1], rows[1][1], rtol=RTOL)


def test_an_output_read_alone_equals_it_read_with_all_the_others(native):
    """Outputs are computed when read, each only if read: one instance reads every output at every step, the other
    one output at a time (another at each step, some steps none), the same inputs.  An output read alone goes
    through the same arithmetic as with the others (ffx_lti_output_rows: its row, in the same order), so the values
    are equal bit for bit; a state taken after reading one output holds all of them (read after a restore in a
    third instance, without a step)."""
    names = [v.name for v in read_model_description(str(native["FFRBeam"])).modelVariables if v.causality == "output"]
    whole = Instance(native["FFRBeam"], "whole", damping_ratio=0.02).initialize()
    alone = Instance(native["FFRBeam"], "alone", damping_ratio=0.02).initialize()
    restored = Instance(native["FFRBeam"], "restored")
    try:
        for k in range(3 * len(names)):
            for inst in (whole, alone):
                inst.set(**LOADS, F_z=math.sin(k))
                inst.fmu.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
            every = whole.get(*names)
            if k % 3 == 2:
                continue                                     # nothing read: nothing computed
            name = names[k % len(names)]
            assert alone.get(name) == [every[names.index(name)]], name
        state = alone.fmu.getFMUstate()                     # after one output read: the state holds all of them
        restored.fmu.setFMUstate(restored.fmu.deSerializeFMUstate(alone.fmu.serializeFMUstate(state)))
        assert restored.get(*names) == whole.get(*names)
        alone.fmu.freeFMUstate(state)
    finally:
        for inst in (whole, alone, restored):
            inst.free()


def test_two_instances_at_once_give_identical_results(native):
    """Interleaved in one thread, and four at once on four threads (fmpy's calls release the GIL)."""
    a, b = Instance(native["FFRBeam"], "a").initialize(), Instance(native["FFRBeam"], "b").initialize()
    try:
        rows_a, rows_b = [], []
        for k in range(30):
            rows_a.append(_steps(a, 1, k, **LOADS))
            rows_b.append(_steps(b, 1, k, **LOADS))
        assert np.array_equal(np.array(rows_a), np.array(rows_b))
        reference = np.concatenate(rows_a)
    finally:
        a.free()
        b.free()
    results, errors = {}, []

    def run(k):
        try:
            inst = Instance(native["FFRBeam"], f"thread{k}").initialize()
            try:
                results[k] = np.concatenate([_steps(inst, 1, j, **LOADS) for j in range(30)])
            finally:
                inst.free()
        except Exception as exc:            # noqa: BLE001 - reported below
            errors.append(repr(exc))

    threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    assert all(np.array_equal(r, reference) for r in results.values()) and len(results) == 4


def test_a_model_file_of_another_format_version_is_refused_naming_both(native, tmp_path):
    from flexfmu.fmi.model_file import MODEL_FILE
    folder = extract_fmu(native["FFRBeam"], tmp_path / "fmu")
    model = folder / "resources" / MODEL_FILE
    data = bytearray(model.read_bytes())
    data[16:20] = struct.pack("<I", 2)
    model.write_bytes(bytes(data))
    md = read_model_description(str(native["FFRBeam"]))
    log = []
    logger = fmi2CallbackLoggerTYPE(lambda c, name, status, category, message: log.append(message.decode()))
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = logger
    callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
    callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier="FFRBeam", instanceName="v2")
    with pytest.raises(Exception):
        fmu.instantiate(callbacks=callbacks)
    assert any("format version 2" in m and "reads version 1" in m for m in log), log
    fmu.freeLibrary()
    # and a host that read another modelDescription (another GUID)
    model.write_bytes(bytes(data[:16]) + struct.pack("<I", 1) + bytes(data[20:]))
    log.clear()
    fmu = FMU2Slave(guid="{not-this-one}", unzipDirectory=str(folder), modelIdentifier="FFRBeam", instanceName="g")
    with pytest.raises(Exception):
        fmu.instantiate(callbacks=callbacks)
    assert any("fmuGUID '{not-this-one}' is not this FMU's" in m for m in log), log
    fmu.freeLibrary()


# ---------------------------------------------------------------------------------------------- call sequence
def _sequence_module():
    sys.path.insert(0, str(Path(__file__).parent))
    import test_fmi_call_sequence as module
    return module


def native_instance_in(fmu, state: str) -> Instance:
    """The native clamped body (it can discard a step: internal_step and a low cap) in ``state``."""
    inst = Instance(fmu, "seq", internal_step=1e-4, max_internal_steps=100)
    if state == "Instantiated":
        inst.fmu.reset()
        return inst
    if state == "InitializationMode":
        return inst
    inst.initialize()
    if state == "StepFailed":
        inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=10.0, status=2)
    elif state == "Terminated":
        inst.fmu.terminate()
    elif state == "Error":
        inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=5.0, communicationStepSize=1e-3)
    inst.log.clear()
    return inst


def native_call(inst: Instance, function: str, donor):
    """test_fmi_call_sequence.call with this FMU's variables (no Boolean or String ones: empty lists)."""
    fmu, vr = inst.fmu, inst.vr
    out, load = vr["tip.pos_x"], vr["tip.F_x"]
    replaced = {
        "fmi2GetReal": lambda: fmu.getReal([out]),
        "fmi2GetInteger": lambda: fmu.getInteger([vr["max_internal_steps"]]),
        "fmi2GetBoolean": lambda: fmu.getBoolean([]),
        "fmi2GetString": lambda: fmu.getString([]),
        "fmi2SetReal": lambda: fmu.setReal([load], [1.0]),
        "fmi2SetInteger": lambda: fmu.setInteger([vr["max_internal_steps"]], [100]),
        "fmi2SetBoolean": lambda: fmu.setBoolean([], []),
        "fmi2SetString": lambda: fmu.setString([], []),
        "fmi2GetDirectionalDerivative": lambda: fmu.getDirectionalDerivative([out], [load], [1.0]),
        "fmi2SetRealInputDerivatives": lambda: fmu.setRealInputDerivatives([load], [1], [0.0]),
        "fmi2GetRealOutputDerivatives": lambda: fmu.getRealOutputDerivatives([out], [1]),
    }
    if function not in replaced:
        return _sequence_module().call(_Renamed(inst), function, donor)
    try:
        replaced[function]()
    except Exception as exc:
        return getattr(exc, "status", None)
    return 0


class _Renamed:
    """An Instance whose vr lookups the generic calls do not use (those calls take no variables)."""

    def __init__(self, inst):
        self.fmu, self.vr = inst.fmu, {}


@pytest.mark.parametrize("state", ["Instantiated", "InitializationMode", "StepComplete", "StepFailed", "Terminated",
                                   "Error"])
def test_call_sequence_table_holds_for_the_native_fmu(cantilever, state):
    """tests/test_fmi_call_sequence.py's check (the table in docs/fmu.md) on a native FMU."""
    seq = _sequence_module()
    fmu = cantilever["native"]
    donor_instance = Instance(fmu, "donor").initialize()
    donor = (donor_instance, donor_instance.fmu.getFMUstate())
    problems = []
    try:
        for function, legal in seq.TABLE.items():
            inst = native_instance_in(fmu, state)
            status = native_call(inst, function, donor)
            messages = [m for s, _, m in inst.log if s >= 3]
            illegal = [m for m in messages if "illegal call sequence" in m]
            if legal is None:
                if status != 3 or not any(m.startswith(f"{function}: not supported") for m in messages):
                    problems.append(f"{function} in {state}: expected 'not supported', got {status} {messages}")
            elif state in legal:
                if illegal:
                    problems.append(f"{function} in {state} is legal but was refused: {illegal}")
            else:
                wanted = f"{function}: illegal call sequence (state {state})"
                if status != 3 or messages != [wanted]:
                    problems.append(f"{function} in {state}: expected [{wanted!r}] and 3, got {status} {messages}")
                elif not seq.still_in(inst, state):
                    problems.append(f"{function} in {state} changed the state")
            if function == "fmi2FreeInstance":
                inst.fmu = None
            inst.free()
    finally:
        donor[0].free()
    assert not problems, "\n".join(problems)


# ---------------------------------------------------------------------------------------------- CLI
def flexfmu(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "flexfmu", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def test_cli_builds_a_native_fmu_and_refuses_what_has_no_native_form(tmp_path):
    run = flexfmu("build", "--runtime", "native", "--set", "boundary=FXF", "--set", "n_modes=4", "--out", tmp_path)
    assert run.returncode == 0, run.stderr
    starts = {v.name: v.start for v in read_model_description(str(tmp_path / "FFRBeam.fmu")).modelVariables}
    assert (starts["boundary"], starts["n_modes"]) == ("FXF", "4")
    for args, words in ((["--runtime", "native", "--fmu", "ReframeBody", "--set", "scheme=consistent"],
                         ["scheme", "exponential", "--runtime python"]),
                        (["--runtime", "native", "--set", "integrator=rk4"], ["integrator", "exact"]),
                        (["--runtime", "native", "--set", "nonsense=1"], ["nonsense"]),
                        (["--set", "boundary=XFX"], ["--runtime native"])):
        run = flexfmu("build", *args, "--out", tmp_path / "refused")
        assert run.returncode == 2 and all(w in run.stderr for w in words), run.stderr
    scene = tmp_path / "rod.json"
    scene.write_text('{"name": "rod", "points": [[0, 0, 0], [1, 0, 0]], "section": {"shape": "circle", '
                     '"diameter": 0.02}, "material": {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}}')
    run = flexfmu("export", f"beam:{scene}", "-o", tmp_path / "Rod.fmu", "--modes", 4, "--interface", "end=1,0,0",
                  "--runtime", "native")
    assert run.returncode == 0 and "native runtime" in run.stdout, run.stderr      # a free body: the reframe kind
    assert (tmp_path / "Rod.fmu").exists()
    pytest.importorskip("meshio")
    sys.path.insert(0, str(Path(__file__).parent))
    from test_fmu_export import BOX, E, NU, RHO, box_mesh
    box_mesh(tmp_path / "box.inp")
    run = flexfmu("export", tmp_path / "box.inp", "-o", tmp_path / "Bar.fmu", "--material", f"{E},{NU},{RHO}",
                  "--clamp", "root", "--modes", 4, "--interface", f"tip={BOX[0]},0,0", "--runtime", "native")
    assert run.returncode == 0 and "(native runtime)" in run.stdout, run.stderr
    res = simulate_fmu(str(tmp_path / "Bar.fmu"), stop_time=0.01, step_size=H, start_values={"base_a_z": 9.81})
    assert abs(res["reaction_F_z"][-1]) > 0 and validate_fmu(str(tmp_path / "Bar.fmu")) == []


# ---------------------------------------------------------------------------------------------- other hosts
C_CASE = ({"boundary": ("string", "XFX"), "damping_ratio": ("real", 0.02), "load_s": ("real", 0.3)},
          {"F_z": 1.5, "base_a_x": 0.5, "base_w_z": 0.4},
          ["sensor_u_z", "sensor_v_z", "sensor_a_x", "reaction_F_z", "reaction_M_y", "f_1", "elastic_energy"])
N_STEPS = 20


def _c_host_arguments(fmu, unzipped):
    start, inputs, outputs = C_CASE
    md = read_model_description(str(fmu))
    vr = value_references(fmu)
    args = ["--fmu", unzipped, md.coSimulation.modelIdentifier, md.guid]
    for key, (kind, value) in start.items():
        args += ["--set", kind, vr[key], repr(value) if kind == "real" else value]
    for key, value in inputs.items():
        args += ["--input", vr[key], repr(value)]
    for key in outputs:
        args += ["--output", vr[key]]
    return args


def _fmpy_rows(fmu):
    start, inputs, outputs = C_CASE
    inst = Instance(fmu, "fmpy", **{k: v for k, (_, v) in start.items()}).initialize()
    try:
        rows = []
        for k in range(N_STEPS):
            inst.set(**inputs)
            inst.fmu.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
            rows.append([(k + 1) * H, *inst.get(*outputs)])
        return np.array(rows)
    finally:
        inst.free()


def _host_rows(proc, run: int, n_columns: int) -> np.ndarray:
    rows = [list(map(float, line.split(","))) for line in proc.stdout.splitlines() if line.strip()]
    return np.array([r[2:] for r in rows if int(r[0]) == run]).reshape(-1, n_columns)


@pytest.mark.host
def test_c_host_runs_the_native_fmu_with_nothing_in_its_environment(native, fmus, tmp_path):
    """`env -i PATH=<a folder with no python>` (no HOME, no LD_PRELOAD, nothing else): two runs in one process with
    dlclose/dlopen between them; fmpy's numbers for the native FMU exactly, the Python FMU's to 1e-10.  A second
    run with the loader's trace (LD_DEBUG) shows that no libpython is ever loaded."""
    host = compile_c_host(tmp_path)
    empty = tmp_path / "no-python-here"
    empty.mkdir()
    assert shutil.which("python3", path=str(empty)) is None and shutil.which("python", path=str(empty)) is None
    unzipped = extract_fmu(native["XFX"], tmp_path / "fmu")
    args = _c_host_arguments(native["XFX"], unzipped)
    command = ["/usr/bin/env", "-i", f"PATH={empty}", host, "--runs", 2, "--reload", repr(H), N_STEPS, *args]
    proc = run_host(command, {}, tmp_path)
    message = describe(proc, {"PATH": str(empty)})
    assert proc.returncode == 0 and proc.stdout.strip(), message
    reference = _fmpy_rows(native["XFX"])
    python = _fmpy_rows(fmus["FFRBeam"])
    for run in (0, 1):
        got = _host_rows(proc, run, reference.shape[1])
        assert np.array_equal(got, reference), f"run {run}" + message
    scale = np.abs(python[:, 1:]).max(axis=0)
    assert np.max(np.abs(reference[:, 1:] - python[:, 1:]) / scale) <= RTOL
    traced = run_host(["/usr/bin/env", "-i", f"PATH={empty}", "LD_DEBUG=libs", host, repr(H), 2, *args], {}, tmp_path)
    assert traced.returncode == 0, describe(traced)
    loaded = [line for line in traced.stderr.splitlines() if "calling init:" in line]
    assert any("FFRBeam.so" in line for line in loaded), traced.stderr[-3000:]
    assert not any("python" in line.lower() for line in loaded), loaded


@pytest.fixture(scope="module")
def ecos():
    found = ecos_binaries()
    if isinstance(found, str):
        pytest.skip(f"ecos CLI not available: {found}")
    return found[0]


@pytest.mark.host
def test_ecos_cli_runs_the_native_fmu_in_process_and_through_proxyfmu(ecos, native, fmus, tmp_path):
    """`ecos simulate` on the native FMU itself (a scenario switching a load) and on an SSP folder running it in a
    proxyfmu process with start values (a fixed parameter at its build value, the runtime damping): the CSV equals
    fmpy's numbers printed the same way."""
    sys.path.insert(0, str(Path(__file__).parent))
    from test_fmu_ecos import (SCENARIO_OUTPUTS, assert_printed_equal, check_ecos_ran, read_ecos_csv, run_ecos,
                               scenario_run, write_csv_config, write_ssd)
    home = tmp_path / "home"
    home.mkdir()
    outputs = SCENARIO_OUTPUTS
    steps = 20
    _, texts, message, inputs_at, columns = scenario_run(ecos, native["FFRBeam"], tmp_path, home, steps)
    reference = jacobi_reference({"instance": (native["FFRBeam"], {})}, (), columns, ecos_times(steps, H), inputs_at)
    assert_printed_equal(texts, reference, columns, message)
    python = jacobi_reference({"instance": (fmus["FFRBeam"], {})}, (), columns, ecos_times(steps, H), inputs_at)
    assert np.max(np.abs(reference - python) / np.abs(python).max(axis=0)) <= RTOL

    start = {"boundary": "XFX", "damping_ratio": 0.02, "load_s": 0.3, "F_z": 150.0, "base_a_x": 0.5}
    folder = tmp_path / "system"
    fresh_fmu_copy(native["XFX"], folder)
    write_ssd(folder, {"body": ("FFRBeam.fmu", start)})
    columns = [("body", o) for o in outputs]
    config = write_csv_config(tmp_path / "csv2.xml", columns)
    work = tmp_path / "proxy"
    work.mkdir()
    proc, env, csv_path, message = run_ecos(ecos, folder, steps, work, home, "--parameterSet", "start",
                                            "--csvConfig", config)
    check_ecos_ran(proc, message)
    assert "[proxyfmu] Booting FMU instance 'body'" in proc.stdout + proc.stderr, message
    times, texts = read_ecos_csv(csv_path, columns, message)
    reference = jacobi_reference({"body": (native["XFX"], start)}, (), columns, ecos_times(steps, H))
    assert_printed_equal(texts, reference, columns, message)


LIBCOSIM_DRIVER = r"""
import json, sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave
spec = json.loads(sys.argv[1])
log_output_level(CosimLogLevel.ERROR)
execution = CosimExecution.from_step_size(step_size=spec["step_ns"])
index = {}
for s in spec["slaves"]:
    index[s["name"]] = execution.add_local_slave(CosimLocalSlave(fmu_path=s["fmu"], instance_name=s["name"]))
    for vr, kind, value in s["start"]:
        assert getattr(execution, kind + "_initial_value")(index[s["name"]], vr, value), (s["name"], vr)
observer = CosimObserver.create_last_value()
execution.add_observer(observer)
manipulator = CosimManipulator.create_override()
execution.add_manipulator(manipulator)
rows = []
for k in range(spec["steps"]):
    t = k * spec["step_ns"] / 1e9
    for name, vr, amplitude, omega in spec["sines"]:
        import math
        manipulator.slave_real_values(index[name], [vr], [amplitude * math.sin(omega * t)])
    assert execution.step(), f"step {k + 1} failed"
    rows.append([observer.last_real_values(index[n], [vr])[0] for n, vr in spec["outputs"]])
del observer, execution
print("RESULTS " + json.dumps([[repr(x) for x in r] for r in rows]))
"""


@pytest.mark.host
def test_libcosim_runs_native_and_python_fmus_side_by_side(native, fmus, tmp_path):
    """One libcosim execution (a fresh Python process) with the native FFRBeam (XFX set-up) and the Python FFRBeam,
    the same sinusoidal load on both: native equals fmpy given the same calls (identical), and native equals Python
    (1e-10)."""
    pytest.importorskip("libcosimpy", reason="libcosimpy (DNV's libcosim) is not installed")
    import json
    start = {"boundary": "XFX", "damping_ratio": 0.02, "load_s": 0.3}
    outputs = ["sensor_u_y", "sensor_a_x", "sensor_u_z", "reaction_F_z", "reaction_M_x"]
    steps, step_ns = 25, 1_000_000
    slaves, sines, columns = [], [], []
    for name, source in (("native", native["XFX"]), ("python", fmus["FFRBeam"])):
        fmu = fresh_fmu_copy(source, tmp_path / name)
        md = read_model_description(str(fmu))
        kinds = {v.name: v.type.lower() for v in md.modelVariables}
        vr = value_references(fmu)
        slaves.append({"name": name, "fmu": str(fmu), "start": [[vr[k], kinds[k], v] for k, v in start.items()]})
        sines.append([name, vr["F_z"], 1.5, 60.0])
        columns += [[name, vr[o]] for o in outputs]
    payload = json.dumps({"step_ns": step_ns, "steps": steps, "slaves": slaves, "sines": sines, "outputs": columns})
    env = host_environment(tmp_path)
    proc = run_host([sys.executable, "-c", LIBCOSIM_DRIVER, payload], env, tmp_path, timeout=300)
    message = describe(proc, env)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULTS ")]
    assert proc.returncode == 0 and lines, message
    got = np.array([[float(x) for x in row] for row in json.loads(lines[-1][8:])])
    n = len(outputs)
    ours, theirs = got[:, :n], got[:, n:]
    reference = []
    inst = Instance(native["XFX"], "fmpy", **start).initialize()
    try:
        for k in range(steps):
            # the same calls libcosim makes: the driver's math.sin of the same double t (numpy's sin may differ from
            # libm's in the last bit), t = ns / 1e9 and the step (t_{k+1} - t_k) as libcosim's to_double_duration
            t = k * step_ns / 1e9
            inst.set(F_z=1.5 * math.sin(60.0 * t))
            inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=(k + 1) * step_ns / 1e9 - t)
            reference.append(inst.get(*outputs))
    finally:
        inst.free()
    reference = np.array(reference)
    # identity: the same FMU binary on the same machine given bit-identical start values, inputs, times and steps
    # in the same order (libcosim's override manipulator sets F_z before each doStep, as here) does the same
    # operations and returns the same bits
    assert np.array_equal(ours, reference), (np.max(np.abs(ours - reference)), message)
    assert np.max(np.abs(ours - theirs) / np.abs(theirs).max(axis=0)) <= RTOL, message
