"""A minimal C host (examples/c_host/fmi2_host.c: dlopen + fmi2 calls) runs the FMUs the way a
non-Python FMI tool does and must give fmpy's numbers bit for bit.

Why bit for bit (identity, not a tolerance): the host and fmpy load the same FMU binary and make the same FMI
calls with the same values (start values and inputs passed as repr, which round-trips exactly; the host prints
%.17g, which round-trips exactly too), and the fmpy reference runs in a subprocess in the host's own environment
(same HOME, so the same flexfmu cache entries, and the same BLAS settings: the Python FMUs' set-up calls BLAS and
LAPACK, whose kernel OPENBLAS_CORETYPE and the like select).  An fmpy run in the test process would not be the
same computation: its environment and cache differ from the clean one (measured: 2e-12 apart with
OPENBLAS_CORETYPE=Prescott set for the tests), and no bound short of the eigen-solve's conditioning covers that.

The primary case runs the host in a clean environment (PATH=/usr/bin:/bin and HOME, nothing else):
what a user's tool has.  The other cases run in ``host_tools.host_environment`` (the same clean
environment unless switched there, for FMUs that need LD_PRELOAD, PYTHONHOME and PYTHONPATH).
A failing host shows its exit status and stderr (with the FMU's log messages) in the assertion
message.  The host returns from main after dlclose, so a crash while unloading or at exit fails the
test; the results are compared first so that such a failure also says whether the numbers were right.
"""
import numpy as np
import pytest

from host_tools import (clean_environment, compile_c_host, describe, extract_fmu, host_environment, run_host,
                        value_references)

H, N_STEPS = 1e-3, 20

# name: (start values, held inputs, outputs) as set through the C host
CASES = {
    "FFRBeam": ({"boundary": ("string", "XFX"), "damping_ratio": ("real", 0.02), "load_s": ("real", 0.3)},
                {"F_z": 1.5, "base_a_x": 0.5},
                ["sensor_u_z", "sensor_v_z", "sensor_a_x", "reaction_F_z", "reaction_M_y", "f_1"]),
    "ReframeBody": ({"model": ("string", "beam:spatial_double_L"), "n_flexible_modes": ("int", 4),
                     "omega0_3": ("real", 1.0),    # the load and output points on the rod (its first node)
                     **{f"{p}_point_{a}": ("real", 0.0) for p in ("load", "output") for a in "xyz"}},
                    {"F_x": 2.0, "M_z": 0.01},
                    ["omega_1", "omega_3", "com_vel_x", "out_acc_y", "q_w"]),
    # an FMU of flexfmu export (the fixture below): a straight steel rod, free, pushed at one end
    "Rod": ({"damping_ratio": ("real", 0.05)}, {"end.F_y": 0.5, "end.M_x": 0.01},
            ["com_vel_y", "omega_3", "end.pos_y", "end.acc_y", "f_1"]),
}


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """Rod.fmu written by ``flexfmu export`` from a beam scene (1 m steel rod, 4 modes, interface at x = 1 m)."""
    import json
    import subprocess
    import sys

    folder = tmp_path_factory.mktemp("exported")
    scene = {"name": "rod", "points": [[0, 0, 0], [1, 0, 0]], "section": {"shape": "circle", "diameter": 0.02},
             "material": {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}}
    (folder / "rod.json").write_text(json.dumps(scene))
    run = subprocess.run([sys.executable, "-m", "flexfmu", "export", f"beam:{folder / 'rod.json'}", "-o",
                          str(folder / "Rod.fmu"), "--modes", "4", "--interface", "end=1,0,0"],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    return folder / "Rod.fmu"


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    return compile_c_host(tmp_path_factory.mktemp("c_host"))


@pytest.fixture(scope="module")
def home(tmp_path_factory):
    """One HOME for the module's host runs: flexfmu's cache (compiled kernels) is filled once."""
    return tmp_path_factory.mktemp("host_home")


def fmu_arguments(fmu, unzipped, name):
    from fmpy import read_model_description
    start, inputs, outputs = CASES[name]
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


REFERENCE_DRIVER = """
import json, sys
sys.path.insert(0, sys.argv[1])
from fmu_helpers import Instance
fmu, start, inputs, outputs, h, n_steps = sys.argv[2], *map(json.loads, sys.argv[3:6]), float(sys.argv[6]), int(sys.argv[7])
inst = Instance(fmu, "fmpy", **start).initialize()
rows = []
for k in range(n_steps):
    inst.set(**inputs)
    inst.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
    rows.append([(k + 1) * h, *inst.get(*outputs)])
inst.free()
print("ROWS " + json.dumps([[repr(float(x)) for x in r] for r in rows]))
"""


def fmpy_reference(fmu, name, env, cwd) -> np.ndarray:
    """(N_STEPS, 1 + outputs): time, outputs after each step, the C host's calls through fmpy, in a subprocess with
    the host's environment ``env`` (see the module docstring: that makes it the same computation)."""
    import json
    import sys
    from pathlib import Path

    start, inputs, outputs = CASES[name]
    proc = run_host([sys.executable, "-c", REFERENCE_DRIVER, Path(__file__).resolve().parent, fmu,
                     json.dumps({k: v for k, (_, v) in start.items()}), json.dumps(inputs), json.dumps(outputs),
                     repr(H), N_STEPS], env, cwd, timeout=300)
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("ROWS ")]
    assert proc.returncode == 0 and line, "the fmpy reference failed" + describe(proc, env)
    return np.array([[float(x) for x in r] for r in json.loads(line[-1][5:])])


def host_rows(proc, env, run: int, index: int, n_columns: int) -> np.ndarray:
    """The host's CSV lines of one run and FMU: (time, outputs...)."""
    try:
        rows = [list(map(float, line.split(","))) for line in proc.stdout.splitlines() if line.strip()]
    except ValueError as exc:   # e.g. a line cut by a crash
        pytest.fail(f"unreadable host output ({exc})" + describe(proc, env))
    mine = [r[2:] for r in rows if int(r[0]) == run and int(r[1]) == index]
    return np.array(mine).reshape(-1, n_columns)


def assert_matches(proc, env, reference, run=0, index=0):
    got = host_rows(proc, env, run, index, reference.shape[1])
    assert got.shape == reference.shape, f"run {run}, FMU {index}: {got.shape} rows x columns" + describe(proc, env)
    assert np.array_equal(got[:, 0], reference[:, 0])
    assert np.all(np.abs(reference[:, 1:]).max(axis=0) > 0)
    # identity: the same FMU, calls and environment (module docstring); %.17g and repr round-trip exactly
    if not np.array_equal(got, reference):
        scale = np.abs(reference[:, 1:]).max(axis=0)
        worst = np.max(np.abs(got[:, 1:] - reference[:, 1:]) / scale)
        pytest.fail(f"run {run}, FMU {index}: not bit for bit, relative difference {worst:.3g}" + describe(proc, env))


def run_c_host(host, env, cwd, fmus, *options, timeout=120):
    """fmus: [(fmu path, name)]; each extracted fresh into cwd."""
    args = []
    for i, (fmu, name) in enumerate(fmus):
        unzipped = extract_fmu(fmu, cwd / f"{name}_{i}")
        args += fmu_arguments(fmu, unzipped, name)
    return run_host([host, *options, repr(H), N_STEPS, *args], env, cwd, timeout=timeout)


def check_run(proc, env, references, runs=1):
    """Results first (compared even if the process died at exit), then the exit status."""
    if proc.returncode == 4 or not proc.stdout.strip():   # 4: an FMI call failed (the FMU's log is in stderr)
        pytest.fail("the host failed" + describe(proc, env))
    for run in range(runs):
        for index, reference in enumerate(references):
            assert_matches(proc, env, reference, run, index)
    assert proc.returncode == 0, "the results match fmpy, but the host did not end normally" + describe(proc, env)


def test_c_host_in_a_clean_environment_matches_fmpy(fmus, host, tmp_path):
    """Nothing but PATH and HOME: the FMU must find libpython, its Python home and its packages."""
    env = clean_environment(tmp_path)
    proc = run_c_host(host, env, tmp_path, [(fmus["FFRBeam"], "FFRBeam")])
    check_run(proc, env, [fmpy_reference(fmus["FFRBeam"], "FFRBeam", env, tmp_path)])


@pytest.mark.parametrize("name", ["FFRBeam", "ReframeBody"])
def test_c_host_matches_fmpy(fmus, host, home, tmp_path, name):
    env = host_environment(home)
    proc = run_c_host(host, env, tmp_path, [(fmus[name], name)])
    check_run(proc, env, [fmpy_reference(fmus[name], name, env, tmp_path)])


@pytest.mark.parametrize("reload", [False, True], ids=["same-library", "dlclose-dlopen"])
def test_c_host_runs_the_same_fmu_twice_in_sequence(fmus, host, home, tmp_path, reload):
    """Instantiate, run, free; then a second instance in the same process (after dlclose/dlopen
    of the FMU's library with --reload): both runs must give fmpy's numbers."""
    env = host_environment(home)
    proc = run_c_host(host, env, tmp_path, [(fmus["FFRBeam"], "FFRBeam")], "--runs", 2,
                      *(["--reload"] if reload else []))
    check_run(proc, env, [fmpy_reference(fmus["FFRBeam"], "FFRBeam", env, tmp_path)], runs=2)


def test_c_host_loads_two_different_fmus(fmus, host, home, tmp_path):
    """FFRBeam and ReframeBody loaded and stepped side by side in one process (one interpreter)."""
    env = host_environment(home)
    proc = run_c_host(host, env, tmp_path, [(fmus["FFRBeam"], "FFRBeam"), (fmus["ReframeBody"], "ReframeBody")])
    check_run(proc, env, [fmpy_reference(fmus["FFRBeam"], "FFRBeam", env, tmp_path),
                          fmpy_reference(fmus["ReframeBody"], "ReframeBody", env, tmp_path)])


def test_c_host_runs_an_exported_fmu_beside_a_built_in_one_in_a_clean_environment(fmus, exported, host, tmp_path):
    """A user's exported body and FFRBeam in one bare C process: its model comes from its own resources."""
    env = clean_environment(tmp_path)
    proc = run_c_host(host, env, tmp_path, [(exported, "Rod"), (fmus["FFRBeam"], "FFRBeam")])
    check_run(proc, env, [fmpy_reference(exported, "Rod", env, tmp_path),
                          fmpy_reference(fmus["FFRBeam"], "FFRBeam", env, tmp_path)])


def test_c_host_with_clock_steps_gives_the_constant_step_numbers(fmus, host, home, tmp_path):
    """--clock-steps passes h = (k + 1) H - k H, as fmpy.simulate_fmu, libcosim and fmusim do: steps that differ
    from H in their last bits.  The FMU takes them as H (flexfmu.core.step_size), so its numbers are the
    constant-step run's, bit for bit (printed with 17 digits)."""
    steps = {(k + 1) * H - k * H for k in range(N_STEPS)}
    assert len(steps) > 1
    env = host_environment(home)
    runs = []
    for label, options in (("constant", ()), ("clock", ("--clock-steps",))):
        (tmp_path / label).mkdir()
        proc = run_c_host(host, env, tmp_path / label, [(fmus["FFRBeam"], "FFRBeam")], *options)
        assert proc.returncode == 0, describe(proc, env)
        runs.append(proc.stdout)
    assert runs[0] == runs[1]
