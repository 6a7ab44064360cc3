"""FMUs loaded the way users load them: fmpy.simulate_fmu many times in one process (each call on a
fresh extraction that fmpy deletes afterwards), several FMU types mixed, in a fresh interpreter and in
one that has imported flexfmu already; two flexfmu builds in one process; a Python that lacks the
FMU's packages; many instantiate/free cycles; processes that must always exit cleanly."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from fmpy import simulate_fmu

from flexfmu.fmi.diagnostics import cycles, exit_stress
from flexfmu.fmi.loader import package_build_id

SMALL_REFRAME = {"model": "beam:spatial_double_L", "n_flexible_modes": 4, "load_point_x": 0.14,
                 "load_point_y": 0.15, "load_point_z": 0.16,
                 "output_point_x": 0.0, "output_point_y": 0.0, "output_point_z": 0.0, "omega0_3": 1.0}
#: (FMU, start values, outputs): small runs whose final outputs are compared
RUNS = {
    "ffr_damped": ("FFRBeam", {"damping_ratio": 0.02, "base_w_z": 0.0}, ["tip_u_z", "sensor_a_x", "reaction_F_z"]),
    "ffr_xfx": ("FFRBeam", {"boundary": "XFX", "load_s": 0.3}, ["tip_u_z", "sensor_a_x", "reaction_F_z"]),
    "reframe": ("ReframeBody", SMALL_REFRAME, ["omega_3", "com_vel_x", "out_acc_y"]),
    "wave": ("WaveExcitation", {}, ["F_x", "F_z", "M_y"]),
}
SEQUENCES = [["ffr_damped", "ffr_xfx", "ffr_damped"], ["reframe", "ffr_damped"], ["wave", "reframe", "wave"]]

RUNNER = r"""
import json, sys
from fmpy import simulate_fmu
runs = json.loads(sys.argv[1])
results = []
for path, start, outputs in runs:
    r = simulate_fmu(path, start_values=start, stop_time=0.02, step_size=1e-3, output_interval=1e-3, output=outputs)
    results.append([float(r[name][-1]) for name in outputs])
print(json.dumps(results))
"""


def _spec(fmus, key):
    name, start, outputs = RUNS[key]
    return [str(fmus[name]), start, outputs]


def _run_fresh_process(specs, env=None, timeout=300):
    out = subprocess.run([sys.executable, "-c", RUNNER, json.dumps(specs)], capture_output=True, text=True,
                         timeout=timeout, env=env)
    return out


def _final_outputs_in_this_process(spec):
    path, start, outputs = spec
    r = simulate_fmu(path, start_values=start, stop_time=0.02, step_size=1e-3, output_interval=1e-3, output=outputs)
    return [float(r[name][-1]) for name in outputs]


@pytest.fixture(scope="module")
def single_runs(fmus):
    """Each run alone, each in its own fresh process: the reference for the sequences."""
    results = {}
    for key in RUNS:
        out = _run_fresh_process([_spec(fmus, key)])
        assert out.returncode == 0, out.stderr[-3000:]
        results[key] = json.loads(out.stdout.splitlines()[-1])[0]
    return results


@pytest.mark.parametrize("sequence", SEQUENCES, ids=["-".join(s) for s in SEQUENCES])
def test_sequence_in_a_fresh_process_equals_single_runs(fmus, single_runs, sequence):
    out = _run_fresh_process([_spec(fmus, key) for key in sequence])
    assert out.returncode == 0, out.stderr[-3000:]
    results = json.loads(out.stdout.splitlines()[-1])
    for key, values in zip(sequence, results):
        assert values == single_runs[key], key            # bit-identical: nothing leaks between loads


def test_sequence_in_a_process_that_imported_flexfmu(fmus, single_runs):
    """pytest's own process has flexfmu imported from the source tree: the FMUs share it (same build)."""
    for key in ["ffr_damped", "reframe", "ffr_xfx", "wave", "ffr_damped"]:
        assert _final_outputs_in_this_process(_spec(fmus, key)) == single_runs[key], key


def _other_build(fmu: Path, target: Path) -> Path:
    """A copy of ``fmu`` whose bundled flexfmu differs (as another flexfmu build would)."""
    with zipfile.ZipFile(fmu) as zf:
        members = {info.filename: zf.read(info) for info in zf.infolist()}
    members["resources/flexfmu/__init__.py"] += b"\n# another build\n"
    unpacked = target.with_suffix(".d")
    for name, data in members.items():
        (unpacked / name).parent.mkdir(parents=True, exist_ok=True)
        (unpacked / name).write_bytes(data)
    info = json.loads(members["resources/flexfmu_build.json"])
    info["build_id"] = package_build_id(str(unpacked / "resources" / "flexfmu"))
    members["resources/flexfmu_build.json"] = json.dumps(info).encode()
    with zipfile.ZipFile(target, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return target


def test_two_builds_in_one_process_second_fails_naming_both(fmus, tmp_path):
    other = _other_build(fmus["FFRBeam"], tmp_path / "FFRBeam_other.fmu")
    script = r"""
import sys
from fmpy import simulate_fmu
messages = []
def logger(component, instance, status, category, message):
    messages.append((status, message.decode()))
simulate_fmu(sys.argv[1], stop_time=1e-3, output_interval=1e-3)
try:
    simulate_fmu(sys.argv[2], stop_time=1e-3, output_interval=1e-3, logger=logger)
except Exception as exc:
    print("FAILED:", exc)
for status, message in messages:
    print("LOG", status, message)
"""
    env = {**os.environ, "FLEXFMU_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([sys.executable, "-c", script, str(fmus["FFRBeam"]), str(other)], capture_output=True,
                         text=True, timeout=300, env=env)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "FAILED:" in out.stdout and "instantiate" in out.stdout.lower(), out.stdout
    errors = [line for line in out.stdout.splitlines() if line.startswith("LOG 3 ")]
    assert len(errors) == 1, out.stdout                    # one message per error
    first = json.loads(zipfile.ZipFile(fmus["FFRBeam"]).read("resources/flexfmu_build.json"))["build_id"]
    second = json.loads(zipfile.ZipFile(other).read("resources/flexfmu_build.json"))["build_id"]
    assert first in errors[0] and second in errors[0], errors[0]


def test_extraction_deleted_while_loaded_and_runtime_copy_reused(fmus, tmp_path):
    """A runtime copy survives the extraction; a second process reuses it instead of copying again."""
    env = {**os.environ, "FLEXFMU_CACHE_DIR": str(tmp_path / "cache")}
    for _ in range(2):
        out = _run_fresh_process([_spec(fmus, "ffr_damped"), _spec(fmus, "ffr_xfx")], env=env)
        assert out.returncode == 0, out.stderr[-3000:]
    copies = list((tmp_path / "cache" / "fmu-runtime").iterdir())
    assert len(copies) == 1 and (copies[0] / "complete").is_file(), copies


@pytest.fixture(scope="module")
def c_host(tmp_path_factory):
    """examples/c_host/fmi2_host.c compiled; run(unzipped FMU, extra arguments, env) takes one step."""
    from fmpy import read_model_description
    from host_tools import compile_c_host
    exe = compile_c_host(tmp_path_factory.mktemp("c_host"))

    class Host:
        @staticmethod
        def run(unzipped, extra, env):
            md = read_model_description(str(unzipped))
            return subprocess.run([str(exe), "1e-3", "1", "--fmu", str(unzipped), md.coSimulation.modelIdentifier,
                                   md.guid, *extra], capture_output=True, text=True, timeout=120, env=env)
    return Host


def test_missing_packages_are_named_with_the_pip_command(fmus, tmp_path, c_host):
    """A Python without the FMU's packages: one Error naming what is missing and how to install it."""
    unzipped = tmp_path / "FFRBeam"
    with zipfile.ZipFile(fmus["FFRBeam"]) as zf:
        zf.extractall(unzipped)
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "FLEXFMU_SITE_PACKAGES": str(tmp_path / "empty")}
    out = c_host.run(unzipped, [], env=env)
    assert out.returncode != 0
    text = out.stdout + out.stderr
    assert "missing packages" in text and "pythonfmu==" in text, text
    assert "pip install -r" in text and "requirements.txt" in text, text
    assert "Segmentation" not in text and "core dumped" not in text


def test_instantiate_free_cycles_keep_memory_flat(fmus):
    """1000 cycles of load, instantiate, initialise, step, free (fmpy unloads the library each time):
    resident memory between the middle and the end grows by less than 100 KiB (pythonfmu's binary leaked
    ~8 KiB per cycle, 4 MiB over these 500)."""
    half, end = cycles(fmus["Hydrostatics"], 1000)
    assert end - half < 100, f"RSS grew {end - half} KiB over 500 cycles"


def test_processes_exit_cleanly_under_load(fmus):
    """Many short host processes, with and without refused calls and unfreed instances, while another
    process loads the CPU: every one exits 0 with no heap-corruption or crash message."""
    codes = exit_stress([fmus[n] for n in ("FFRBeam", "Hydrostatics", "WaveExcitation", "PTO")], runs=12)
    assert codes == {"exit 0, clean": 12}, codes


@pytest.mark.parametrize("form", ["file:///", "file:/", "file://localhost/", "root folder", "none", "spaces"])
def test_resource_locations_hosts_pass(fmus, tmp_path, form):
    """Hosts spell fmuResourceLocation differently (or point at the FMU's root, or pass NULL): the FMU
    finds its resources in each case, also in a folder whose name needs percent-encoding."""
    import ctypes
    from urllib.parse import quote
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2CoSimulation, fmi2False
    folder = tmp_path / ("with space %" if form == "spaces" else "plain") / "Hydrostatics"
    with zipfile.ZipFile(fmus["Hydrostatics"]) as zf:
        zf.extractall(folder)
    resources = folder / "resources"
    location = {"file:///": resources.as_uri(), "spaces": resources.as_uri(),
                "file:/": "file:" + quote(str(resources)), "file://localhost/": "file://localhost" + quote(str(resources)),
                "root folder": folder.as_uri(), "none": None}[form]
    md = read_model_description(str(fmus["Hydrostatics"]))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="r")
    log = []
    logger = fmi2CallbackLoggerTYPE(lambda c, n, status, cat, message: log.append(message))
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = logger
    component = fmu.fmi2Instantiate(b"r", fmi2CoSimulation, md.guid.encode(),
                                    location.encode() if location else None, ctypes.byref(callbacks),
                                    fmi2False, fmi2False)
    assert component, log
    fmu.component = component
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    fmu.freeInstance()
