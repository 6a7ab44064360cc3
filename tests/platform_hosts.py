"""Running a native FMU's binary for each platform it carries in the small host tests/fmi2_platform_host.c built for
that platform (linux64 natively, win64 under Wine, aarch64-linux under qemu-aarch64; FMI 2.0, or FMI 3.0 built with
-DFMI_VERSION=3), on the records tests/test_fmu_platforms.py and tests/test_fmu_platforms_free.py compare: what the
two modules share.

Wine starts its prefix (wineboot) on first use, which takes seconds to a minute: the prefix is kept in the system
temp folder between runs ($FLEXFMU_TEST_WINEPREFIX overrides).  tasks.py installs the cross compilers, Wine and
qemu-user on Debian/Ubuntu; without them the tests skip, naming what to install.
"""
from __future__ import annotations

import importlib.util
import itertools
import os
import re
import shutil
import struct
import subprocess
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from host_tools import clean_environment, describe, extract_fmu

ROOT = Path(__file__).resolve().parents[1]
HOST_SOURCE = Path(__file__).resolve().parent / "fmi2_platform_host.c"
AARCH64_SYSROOT = Path("/usr/aarch64-linux-gnu")
#: platform: (compiler, extra flags, runner, Debian packages)
TOOLS = {
    "linux64": ("gcc", ("-ldl",), None, "gcc"),
    "win64": ("x86_64-w64-mingw32-gcc", ("-D__USE_MINGW_ANSI_STDIO=1", "-static-libgcc"), "wine",
              "gcc-mingw-w64-x86-64 wine"),
    "aarch64-linux": ("aarch64-linux-gnu-gcc", ("-ldl",), "qemu-aarch64", "gcc-aarch64-linux-gnu qemu-user"),
}
#: FMI 3.0's names of the same platforms' binary folders
FMI3_FOLDERS = {"linux64": "x86_64-linux", "win64": "x86_64-windows", "aarch64-linux": "aarch64-linux"}
#: the paper's hammer record (examples/hammer_test.py): 10 kS/s, 2 s, a 1 ms half-sine of 20 N
SAMPLE_RATE, DURATION = 10_000, 2.0


def bits(value: float) -> str:
    """A double as the 16 hex digits of its IEEE-754 bits (what the host reads)."""
    return struct.pack(">d", float(value)).hex()


def _hammer_setups() -> dict:
    spec = importlib.util.spec_from_file_location("hammer_test", ROOT / "examples" / "hammer_test.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.SAMPLE_RATE == SAMPLE_RATE
    return module.SETUPS


SETUPS = _hammer_setups()


# ---------------------------------------------------------------------------------------------- the records
def half_sine(t: np.ndarray, amplitude: float, width: float = 1e-3) -> np.ndarray:
    return np.where(t < width, amplitude * np.sin(np.pi * t / width), 0.0)


def hammer_case(fmu: Path, boundary: str) -> dict:
    """tests/test_fmu_native.py's hammer_record through the host: the blow on all three axes at load_s, damping
    0.002, every output."""
    load_s, sensor_s = SETUPS[boundary]
    dt, n = 1.0 / SAMPLE_RATE, int(round(DURATION * SAMPLE_RATE))
    t = np.arange(n) * dt
    pulse = half_sine(t, 20.0)
    return {"fmu": fmu, "step": dt, "signals": {"F_x": pulse, "F_y": 0.7 * pulse, "F_z": 0.4 * pulse},
            "start": {"boundary": ("s", boundary), "damping_ratio": ("r", 0.002), "load_s": ("r", load_s),
                      "sensor_s": ("r", sensor_s)}}


def bracket_case(fmu: Path) -> dict:
    """The exported bracket shaken and spun through its base (test_fmu_native's base_motion_record) and struck at
    its tip: 0.05 s at 10 kS/s.  The base's spin changes at every step, so every step computes new exponential maps
    (the matrix exponential with its pow and log2): about 1 ms of CPU a step natively, 30 times that under qemu."""
    dt, n = 1e-4, 500
    t = np.arange(n) * dt
    return {"fmu": fmu, "step": dt, "start": {"damping_ratio": ("r", 0.02)},
            "signals": {"base_a_z": 9.81 * np.sin(40 * t), "base_a_x": np.full(n, 2.0),
                        "base_w_x": 0.5 * np.sin(7 * t), "base_dw_x": 3.5 * np.cos(7 * t), "base_w_z": np.ones(n),
                        "tip.F_y": np.where(t < 0.01, 5.0, 0.0), "tip.F_z": half_sine(t, 20.0)}}


def reframe_case(fmu: Path) -> dict:
    """ReframeBody's plate (examples/reframe_plate.py's load: 50 N along [1 0 1]/sqrt(2), global, a 10 ms
    half-sine), spinning at 1 rad/s about its second body axis from the start: 0.5 s at 1 ms.  The free kind turns
    its frame every internal step (Rodrigues: sin, cos; the quaternion's atan2), so libm runs at every step."""
    dt, n = 1e-3, 500
    t = np.arange(n) * dt
    force = half_sine(t, 50.0, 0.01) / np.sqrt(2.0)
    return {"fmu": fmu, "step": dt, "start": {"omega0_2": ("r", 1.0)}, "signals": {"F_x": force, "F_z": force}}


def free_bracket_case(fmu: Path) -> dict:
    """The bracket exported free (interfaces tip and bolt), spun at 2 rad/s about x and struck at the tip and the
    bolt (tests/test_fmu_fmi3.py's blows), then left spinning: 1 s at 1 ms."""
    dt, n = 1e-3, 1000
    t = np.arange(n) * dt
    return {"fmu": fmu, "step": dt, "start": {"omega0_1": ("r", 2.0)},
            "signals": {"tip.F_x": half_sine(t, 20.0, 0.01), "tip.F_z": half_sine(t, 50.0, 0.01),
                        "bolt.F_y": half_sine(t, -10.0, 0.01)}}


#: case name: its record (the hammer set-ups XFF, XFX, FXF take hammer_case)
RECORDS = {"bracket": bracket_case, "ReframeBody": reframe_case, "free": free_bracket_case}


def case_of(fmus: dict, name: str) -> dict:
    """The record of case ``name`` on its FMU ``fmus[name]``."""
    return RECORDS[name](fmus[name]) if name in RECORDS else hammer_case(fmus[name], name)


# ---------------------------------------------------------------------------------------------- the hosts
def why_not(platform: str) -> str | None:
    """Why ``platform``'s host cannot be built or run here (None: it can)."""
    compiler, _, runner, packages = TOOLS[platform]
    absent = [tool for tool in (compiler, runner) if tool and shutil.which(tool) is None]
    if platform == "aarch64-linux" and not (AARCH64_SYSROOT / "lib").is_dir():
        absent.append(f"the aarch64 C library in {AARCH64_SYSROOT}")
    if absent:
        return (f"{', '.join(absent)} not installed: apt-get install {packages} (python3 tasks.py installs them on "
                "Debian/Ubuntu as root)")
    return None


def build_hosts(folder: Path) -> dict:
    """{(platform, FMI version 2 | 3): the host's command prefix, or why there is none}."""
    import fmpy
    headers = Path(fmpy.__file__).parent / "c-code"
    out = {}
    for (platform, (compiler, flags, runner, _)), version in itertools.product(TOOLS.items(), (2, 3)):
        why = why_not(platform)
        if why:
            out[platform, version] = why
            continue
        exe = folder / f"fmi{version}_platform_host_{platform}{'.exe' if platform == 'win64' else ''}"
        proc = subprocess.run([compiler, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", f"-I{headers}",
                               f"-DFMI_VERSION={version}", "-o", str(exe), str(HOST_SOURCE), *flags],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        out[platform, version] = {"linux64": [exe], "aarch64-linux": [runner, "-L", AARCH64_SYSROOT, exe],
                                  "win64": [runner, exe]}[platform]
    return out


def host_environment(home: Path) -> dict:
    """The hosts' environment: nothing but PATH and HOME, and Wine's prefix (kept between runs: wineboot is slow)
    with its debug output off."""
    env = clean_environment(home)
    user = getattr(os, "getuid", lambda: "user")()
    prefix = os.environ.get("FLEXFMU_TEST_WINEPREFIX") or str(Path(tempfile.gettempdir()) / f"flexfmu-wine-{user}")
    return {**env, "WINEPREFIX": prefix, "WINEDEBUG": "-all"}


def host_path(path: Path, platform: str) -> str:
    """``path`` as the host sees it: Wine maps the Unix root to drive Z:."""
    return "Z:" + str(path).replace("/", "\\") if platform == "win64" else str(path)


def run_case(case: dict, platform: str, hosts: dict, env: dict, folder: Path, options: tuple = ()) -> np.ndarray:
    """(steps + 1, outputs): every output of ``case`` after initialisation and after each step, from the FMU's
    ``platform`` binary in that platform's host for the FMU's FMI version (``options``: the host's further ones)."""
    fmu = Path(case["fmu"])
    md = read_model_description(str(fmu))
    version = int(md.fmiVersion[0])
    command = hosts[platform, version]
    if isinstance(command, str):
        pytest.skip(f"{platform}: {command}")
    folder_name = FMI3_FOLDERS[platform] if version == 3 else platform
    if f"binaries/{folder_name}/" not in " ".join(zipfile.ZipFile(fmu).namelist()):
        pytest.skip(f"{fmu.name} has no {folder_name} binary (its cross compiler was missing at build)")
    variables = {v.name: v for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    inputs = list(case["signals"])
    n = len(case["signals"][inputs[0]])
    folder.mkdir(parents=True, exist_ok=True)
    unzipped = extract_fmu(fmu, folder / "fmu")
    np.column_stack([case["signals"][k] for k in inputs]).astype("<f8").tofile(folder / "inputs.bin")
    result = folder / "outputs.bin"
    result.unlink(missing_ok=True)
    args = [folder_name, host_path(unzipped, platform), md.coSimulation.modelIdentifier, md.guid,
            bits(case["step"]), str(n), host_path(folder / "inputs.bin", platform), host_path(result, platform),
            *options]
    for name, (kind, value) in case["start"].items():
        args += ["--set", kind, str(variables[name].valueReference), bits(value) if kind == "r" else value]
    for name in inputs:
        args += ["--input", str(variables[name].valueReference)]
    for name in outputs:
        args += ["--output", str(variables[name].valueReference)]
    proc = subprocess.run([str(c) for c in (*command, *args)], env=env, cwd=folder, capture_output=True, text=True,
                          timeout=900, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0 and result.is_file(), describe(proc, env)
    return np.fromfile(result, "<f8").reshape(n + 1, len(outputs))


class Records:
    """Each (case, platform, host options) record run once (the modules keep one)."""

    def __init__(self, fmus: dict, hosts: dict, env: dict, tmp_path_factory):
        self.fmus, self.hosts, self.env, self.tmp = fmus, hosts, env, tmp_path_factory
        self.done: dict = {}

    def __call__(self, name: str, platform: str, options: tuple = ()) -> np.ndarray:
        key = (name, platform, options)
        if key not in self.done:
            tag = "_".join((platform, name, *options)).replace("-", "")
            self.done[key] = run_case(case_of(self.fmus, name), platform, self.hosts, self.env, self.tmp.mktemp(tag),
                                      options)
        return self.done[key]


# ---------------------------------------------------------------------------------------------- comparing
def relative_difference(ours: np.ndarray, reference: np.ndarray) -> float:
    """max over outputs of max |ours - reference| / max |reference| (per output)."""
    scale = np.abs(reference).max(axis=0)
    scale[scale == 0] = 1.0
    return float(np.max(np.abs(ours - reference) / scale))


def vector_relative_difference(ours: np.ndarray, reference: np.ndarray, outputs: list[str]) -> tuple[float, str]:
    """The largest |ours - reference| over the record relative to the largest component of its vector (the outputs
    NAME_x, _y, _z (and q's _w) or NAME_1, _2, _3 together; any other output alone), and that output's name."""
    groups: dict = {}
    for j, name in enumerate(outputs):
        match = re.fullmatch(r"(.+)_(?:([xyzw])|([123]))", name)
        key = (match[1], "xyz" if match[2] else "123") if match else (name, "")
        groups.setdefault(key, []).append(j)
    worst, where = 0.0, ""
    for columns in groups.values():
        scale = float(np.abs(reference[:, columns]).max()) or 1.0
        for j in columns:
            difference = float(np.abs(ours[:, j] - reference[:, j]).max()) / scale
            if difference >= worst:
                worst, where = difference, outputs[j]
    return worst, where


def output_names(fmu: Path) -> list[str]:
    return [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output"]
