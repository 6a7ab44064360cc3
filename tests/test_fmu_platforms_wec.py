"""The native point-absorber FMUs (the wec kind, csrc/native_wec.c) on every platform they carry, in the host of
tests/platform_hosts.py (tests/fmi2_platform_host.c: linux64 natively, win64 under Wine, aarch64-linux under
qemu-aarch64), against the linux64 binary.  The kinds' records are not among tests/test_fmu_platforms*.py's cases
(their hosts feed inputs; the wave has none), so they are run here.

The float and the PTO use +, -, * and / only: bit for bit everywhere.  The hydro's step maps come from the matrix
exponential, where libm enters only the choice of the scaling 2^-s (pow, log2 and ceil of norms: a last-bit
difference changes s only at a threshold, as tests/test_fmu_platforms_free.py says of the x87's pow), and its step
and outputs are + and *: bit for bit too.  The wave evaluates cos and sin
at its anchors and rotations (csrc/native_wec.c): aarch64-linux calls glibc's, as linux64 does (bit for bit); the
win64 DLL MinGW-w64's x87 functions, which differ from glibc's by a few ulp on ~1 argument in 1000
(tests/test_fmu_platforms_free.py).  Such a difference enters a component's phasor (amplitude <= 1), is carried by
at most 63 rotations (each adding ~2.5 eps) until the next exact anchor, and is summed over 500 components whose
largest output is of the order of their amplitudes' sum: a bound of 500 x 64 x 5 ulp = 3.5e-11 of the largest
output if every component differed at once; in fact ~1 in 1000 does, so WAVE_RTOL = 1e-12 holds with margin and
still catches any error of the arithmetic (a phase or factor wrong on one platform is > 1e-6)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

sys.path.insert(0, str(Path(__file__).parent))
from host_tools import extract_fmu  # noqa: E402
from platform_hosts import bits, build_hosts, host_environment, host_path  # noqa: E402

WAVE_RTOL = 1e-12
N_STEPS = 1500
PLATFORMS = ("linux64", "aarch64-linux", "win64")


@pytest.fixture(scope="module")
def setup(tmp_path_factory) -> dict:
    from flexfmu.fmi.native import WEC_COMPONENTS, build_registry_fmu
    folder = tmp_path_factory.mktemp("wec_platforms")
    (folder / "hosts").mkdir()
    return {"fmus": {name: build_registry_fmu(name, target=folder / f"{name}.fmu") for name in WEC_COMPONENTS},
            "hosts": build_hosts(folder / "hosts"), "env": host_environment(folder / "home"), "folder": folder}


def _cases() -> dict:
    """Per FMU: (step, start values {name: (host kind, value)}, inputs {name: signal}): random inputs of the
    float's and hydro's size, a JONSWAP sea of 500 components."""
    rng = np.random.default_rng(41)
    axes = ("x", "y", "z")
    motion = [f"{q}_{a}" for q in ("pos", "rot", "vel", "omega") for a in axes]
    loads = [f"{g}_{k}_{a}" for g in ("wave", "hydro", "pto", "mooring") for k in "FM" for a in axes]
    return {
        "AbsorberWave": (0.05, {"sea_state": ("s", "jonswap"), "n_components": ("i", "500"), "seed": ("i", "3")}, {}),
        "AbsorberFloat": (0.01, {}, {n: 1e4 * rng.normal(size=N_STEPS) for n in loads}),
        "AbsorberHydro": (0.01, {"drag_area_x": ("r", bits(12.0))}, {n: rng.normal(size=N_STEPS) for n in motion}),
        "HeavePTO": (0.01, {"force_limit": ("r", bits(1.5e5))},
                     {n: rng.normal(size=N_STEPS) for n in ("pos_z", "vel_z")}),
    }


CASES = _cases()
RECORDS: dict = {}


def record(setup, name: str, platform: str) -> np.ndarray:
    """(N_STEPS + 1, outputs) from ``platform``'s binary (once per module)."""
    if (name, platform) in RECORDS:
        return RECORDS[name, platform]
    command = setup["hosts"][platform, 2]
    if isinstance(command, str):
        pytest.skip(f"{platform}: {command}")
    step, start, signals = CASES[name]
    fmu = setup["fmus"][name]
    md = read_model_description(str(fmu))
    variables = {v.name: v for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    folder = setup["folder"] / f"{name}_{platform}"
    folder.mkdir()
    unzipped = extract_fmu(fmu, folder / "fmu")
    inputs = np.column_stack([signals[k] for k in signals]) if signals else np.zeros((N_STEPS, 0))
    inputs.astype("<f8").tofile(folder / "inputs.bin")
    result = folder / "outputs.bin"
    args = [platform, host_path(unzipped, platform), md.coSimulation.modelIdentifier, md.guid, bits(step),
            str(N_STEPS), host_path(folder / "inputs.bin", platform), host_path(result, platform)]
    for key, (kind, value) in start.items():
        args += ["--set", kind, str(variables[key].valueReference), value]
    for key in signals:
        args += ["--input", str(variables[key].valueReference)]
    for key in outputs:
        args += ["--output", str(variables[key].valueReference)]
    proc = subprocess.run([str(c) for c in (*command, *args)], env=setup["env"], cwd=folder, capture_output=True,
                          text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0 and result.is_file(), proc.stderr[-2000:]
    RECORDS[name, platform] = np.fromfile(result, "<f8").reshape(N_STEPS + 1, len(outputs))
    return RECORDS[name, platform]


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("platform", ["aarch64-linux", "win64"])
def test_each_platform_gives_the_linux64_numbers(setup, name, platform):
    linux = record(setup, name, "linux64")
    other = record(setup, name, platform)
    assert np.all(np.isfinite(linux)) and np.max(np.abs(linux)) > 0
    if platform == "win64" and name == "AbsorberWave":
        scale = np.max(np.abs(linux), axis=0)
        difference = np.max(np.abs(other - linux) / np.where(scale > 0, scale, 1.0))
        print(f"{name} win64 vs linux64: {difference:.2g} relative")
        assert difference <= WAVE_RTOL
    else:
        assert np.array_equal(other, linux), f"{name} on {platform} differs from linux64"
