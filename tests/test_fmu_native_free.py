"""Native FMUs of exported free bodies (the reframe kind's free-body entries, csrc/native_reframe.c) against the
Python FMU of the same body: the paper's plate (coarse mesh) with two interfaces, forces and a moment at both, an
initial spin: every output (interface motion, body motion, the global frame vectors rot_*/omega_*/alpha_* computed
in C, the frequencies) equal to 1e-10 relative; no Python in the binary; bad parameters refused as the Python FMU
refuses them; a too-long communication step discarded alike."""
from __future__ import annotations

import math
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from error_bounds import implementations_bound

sys.path.insert(0, str(Path(__file__).parent))
from fmu_helpers import (Instance, discard_messages, error_messages, fmu_checker_findings,  # noqa: E402
                         refusal_messages)

PLATE_IF = [{"name": "A", "point": [-0.5, 0.0, 0.01]}, {"name": "B", "point": [0.5, 0.0, 0.0], "radius": 0.03}]
STEP = 1e-3


@pytest.fixture(scope="module")
def free_fmus(tmp_path_factory):
    """{"python", "native", "consistent" (native, scheme consistent fixed at build)}: FMUs of one free plate body."""
    from flexfmu.body.build import build_body
    from flexfmu.fmi.export import export_fmu
    from flexfmu.fmi.native import export_native
    from flexfmu.reframe.models import load_model

    out = tmp_path_factory.mktemp("native_free")
    body = build_body(load_model("paper_plate", divisions=(8, 2, 1)), interfaces=PLATE_IF, f_max=200.0,
                      tolerance=1e-3)
    assert body.kind == "free"
    return {"python": export_fmu(body, out / "Plate.fmu"),
            "native": export_fmu(body, out / "nat" / "Plate.fmu", runtime="native"),
            "consistent": export_native(body, out / "rk4" / "Plate.fmu", scheme="consistent")}


def record(fmu, t_end=0.3, step=STEP, **start):
    """Half-sine pulses (10 ms) of forces at A and B and a moment at B; all outputs."""
    md = read_model_description(str(fmu))
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    t = np.arange(0.0, t_end + step / 2, step)
    shape = np.where(t < 0.01, np.sin(np.pi * t / 0.01), 0.0)
    signals = np.zeros(len(t), dtype=[("time", float)] + [(name, float) for name in inputs])
    signals["time"] = t
    signals["A.F_x"], signals["A.F_z"], signals["B.F_y"] = 20.0 * shape, 50.0 * shape, -10.0 * shape
    if "B.M_y" in inputs:
        signals["B.M_y"] = 3.0 * shape
    return simulate_fmu(str(fmu), start_time=0.0, stop_time=t_end, step_size=step, output_interval=step,
                        input=signals, start_values=start, output=outputs)


def relative_difference(a, b) -> dict:
    out = {}
    for name in b.dtype.names[1:]:
        scale = float(np.max(np.abs(b[name])))
        out[name] = float(np.max(np.abs(a[name] - b[name]))) / (scale if scale > 0 else 1.0)
    return out


@pytest.mark.parametrize("start", [{}, {"omega0_1": 2.0, "omega0_3": 5.0, "v0_y": 0.3},
                                   {"damping_ratio": 0.05, "tolerance": 1e-6, "omega0_2": 1.5},
                                   {"internal_step": 2.5e-4, "omega0_1": -1.0}],
                         ids=["at-rest", "initial-spin", "damping-tolerance", "internal_step"])
def test_native_free_body_equals_the_python_fmu(free_fmus, start):
    native, python = record(free_fmus["native"], **start), record(free_fmus["python"], **start)
    assert np.array_equal(native["time"], python["time"])
    diff = relative_difference(native, python)
    worst = max(diff, key=diff.get)
    print(f"native vs python free plate {start}: worst {worst} {diff[worst]:.3g}")
    assert diff[worst] <= 1e-10, diff
    names = set(python.dtype.names)
    assert {"rot_x", "omega_x", "alpha_z", "A.acc_z", "B.pos_x", "f_1", "max_elastic_displacement"} <= names
    assert np.max(np.abs(python["A.acc_z"])) > 0 and np.max(np.abs(python["rot_y"])) > 0


def test_native_free_body_scheme_consistent_equals_the_python_fmu(free_fmus):
    start = {"omega0_1": 2.0, "v0_x": 0.1}
    native = record(free_fmus["consistent"], t_end=0.05, **start)
    python = record(free_fmus["python"], t_end=0.05, scheme="consistent", **start)
    diff = relative_difference(native, python)
    assert max(diff.values()) <= 1e-10, diff


@pytest.mark.parametrize("runtime", ["python", "native"])
def test_clock_host_steps_stay_within_the_stated_bound(free_fmus, runtime):
    """Steps h = t(k+1) - t(k) from t = 1000 s share the first step's exponential coefficients; the stages take the
    host's step.  Bound (flexfmu.core.step_size): the coefficients differ by <= jitter * omega_max dt relative per
    step, so after n steps the outputs differ normwise by <= n * (jitter * (1 + omega_max dt) + rounding)."""
    from fmu_helpers import clock_and_constant_step_runs
    from flexfmu.core.step_size import STEP_RTOL
    n = 150
    clock, constant, jitter = clock_and_constant_step_runs(free_fmus[runtime], {"A.F_x": 20.0, "B.F_y": -10.0},
                                                           STEP, n, t0=1e3)
    assert 0 < jitter < STEP_RTOL
    omega_max_dt = 2.0        # generous for the retained modes: f_max = 200 Hz gives omega dt = 1.3 at 1 ms
    bound = n * (jitter * (1 + omega_max_dt) + 16 * np.finfo(float).eps)
    worst = np.max(np.linalg.norm(clock - constant, axis=1) / np.linalg.norm(constant, axis=1))
    assert worst <= bound, (worst, bound)


def test_frame_global_matches_the_python_formula(free_fmus):
    """rot_*, omega_*, alpha_* of the native FMU recomputed from its own q, omega_k, alpha_k by _frame_global."""
    from flexfmu.body.simulator import _frame_global
    rec = record(free_fmus["native"], t_end=0.2, omega0_1=3.0, omega0_2=-2.0, omega0_3=7.0)
    body = np.stack([rec[n] for n in ("q_w", "q_x", "q_y", "q_z", "omega_1", "omega_2", "omega_3",
                                      "alpha_1", "alpha_2", "alpha_3")], axis=1)
    expected = np.array([_frame_global(row) for row in body])
    got = np.stack([rec[f"{q}_{a}"] for q in ("rot", "omega", "alpha") for a in "xyz"], axis=1)
    # C vs Python: each within gamma_32 of the exact value (the longest chain: |q| and the normalisation 6, atan2
    # and angle / s 4 (libm 1 ulp), Rodrigues' sin, cos and products 12, R x 5; 27 <= 32), of terms of size
    # <= pi max(1, |rot|, |omega|, |alpha|) (||dR|| <= ||d rot||, |rot| <= pi): implementations_bound
    bound = implementations_bound(math.pi * max(1.0, float(np.max(np.abs(expected)))), ops=32)
    assert np.max(np.abs(got - expected)) <= bound
    assert np.max(np.linalg.norm(got[:, :3], axis=1)) > 1.0        # rotated by more than a radian


def test_no_python_in_the_binary(free_fmus, tmp_path):
    if not shutil.which("ldd"):
        pytest.skip("no ldd")
    with zipfile.ZipFile(free_fmus["native"]) as zf:
        zf.extractall(tmp_path)
        assert "resources/flexfmu_model.bin" in zf.namelist()
    (so,) = (tmp_path / "binaries" / "linux64").glob("*.so")
    libs = subprocess.run(["ldd", str(so)], capture_output=True, text=True, check=True).stdout
    assert "python" not in libs.lower(), libs




def test_max_elastic_displacement_is_computed_only_when_read(free_fmus):
    """As for ReframeBody (tests/test_fmu_native_reframe.py): the exported free body's whole-mesh search runs only
    when max_elastic_displacement is read (and once at initialisation), with the values of a read of all outputs
    and of the Python FMU."""
    from test_fmu_native_reframe import check_deferred_reads
    check_deferred_reads(free_fmus["native"], free_fmus["python"], "A.pos_x", {"A.F_x": 20.0, "A.F_z": 50.0,
                                                                             "B.F_y": -10.0})


BAD = {
    "tolerance out of range": lambda i: (i.set(tolerance=2.0), i.initialize()),
    "damping_ratio out of range": lambda i: (i.set(damping_ratio=1.0), i.initialize()),
    "max_internal_steps out of range": lambda i: (i.set(max_internal_steps=0), i.initialize()),
    "NaN input": lambda i: i.fmu.setReal([i.vr["A.F_x"]], [float("nan")]),
}


@pytest.mark.parametrize("label", list(BAD))
def test_bad_parameters_are_refused_as_by_the_python_fmu(free_fmus, label):
    logs = refusal_messages((free_fmus["native"], free_fmus["python"]), BAD[label])
    assert len(logs[0]) == 1 and logs[0] == logs[1], logs


def test_the_scheme_is_fixed_at_build(free_fmus):
    inst = Instance(free_fmus["native"], "scheme")
    try:
        inst.set(scheme="exponential")                                  # its build value: fine
        inst.expect_failure(inst.set, scheme="consistent")
        (message,) = error_messages(inst)
        assert "scheme" in message and "exponential" in message
    finally:
        inst.free()


def test_a_too_long_step_is_discarded_as_by_the_python_fmu(free_fmus):
    logs = discard_messages((free_fmus["native"], free_fmus["python"]), 0.5, internal_step=1e-3, max_internal_steps=10)
    assert logs[0] == logs[1] and len(logs[0]) == 1, logs


def test_fmpy_validate_and_the_fmu_checker_find_no_problem(free_fmus):
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(free_fmus["native"])) == []
    assert fmu_checker_findings(free_fmus["native"]) == ""
