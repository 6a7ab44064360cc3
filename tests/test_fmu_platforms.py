"""Native FMUs on every platform they carry: binaries/win64/<id>.dll (MinGW-w64) run under Wine, and
binaries/aarch64-linux/<id>.so (gcc-aarch64-linux-gnu) run under qemu-aarch64, each in a small FMI 2.0 host built
for that platform from one source (tests/fmi2_platform_host.c), against the linux64 binary in the same host built
for Linux x86-64; and the source FMU rebuilt by fmpy (fmpy.build.build_platform_binary) against the shipped binary.

Why bit for bit, not a tolerance: the three binaries are compiled from the same C with the same IEEE flags (no
fast-math, no FMA contraction: flexfmu.native.compiler), and the hosts make the same FMI calls with the same
numbers (passed as binary64 bit patterns, never as decimal text).  The clamped kinds (FFRBeam, exported clamped
bodies) step by matrix products, sums and quotients alone, which IEEE-754 rounds identically on x86-64 and aarch64;
libm (glibc's on Linux, MinGW-w64's and msvcrt's on Windows, which may differ in the last bit) enters only the
choice of the matrix exponential's scaling (pow, log2 under ceil), which a last-bit difference could change only
at a threshold.  So any difference is a defect of the build (a flag lost, contraction on aarch64), not rounding.

Wine starts its prefix (wineboot) on first use, which takes seconds to a minute: the prefix is kept in the system
temp folder between runs ($FLEXFMU_TEST_WINEPREFIX overrides).  tasks.py installs the cross compilers, Wine and
qemu-user on Debian/Ubuntu; without them these tests skip, naming what to install.
"""
from __future__ import annotations

import os
import shutil
import struct
import subprocess
import sys
import tempfile
import warnings
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
#: the paper's hammer record (examples/hammer_test.py): 10 kS/s, 2 s, a 1 ms half-sine of 20 N
SAMPLE_RATE, DURATION = 10_000, 2.0


def bits(value: float) -> str:
    """A double as the 16 hex digits of its IEEE-754 bits (what the host reads)."""
    return struct.pack(">d", float(value)).hex()


def _hammer_setups() -> dict:
    import importlib.util
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


# ---------------------------------------------------------------------------------------------- fixtures
def _why_not(platform: str) -> str | None:
    """Why ``platform``'s host cannot be built or run here (None: it can)."""
    compiler, _, runner, packages = TOOLS[platform]
    absent = [tool for tool in (compiler, runner) if tool and shutil.which(tool) is None]
    if platform == "aarch64-linux" and not (AARCH64_SYSROOT / "lib").is_dir():
        absent.append(f"the aarch64 C library in {AARCH64_SYSROOT}")
    if absent:
        return (f"{', '.join(absent)} not installed: apt-get install {packages} (python3 tasks.py installs them on "
                "Debian/Ubuntu as root)")
    return None


@pytest.fixture(scope="module")
def hosts(tmp_path_factory) -> dict:
    """{platform: the host's command prefix, or why there is none}."""
    import fmpy
    folder = tmp_path_factory.mktemp("platform_hosts")
    headers = Path(fmpy.__file__).parent / "c-code"
    out = {}
    for platform, (compiler, flags, runner, _) in TOOLS.items():
        why = _why_not(platform)
        if why:
            out[platform] = why
            continue
        exe = folder / f"fmi2_platform_host_{platform}{'.exe' if platform == 'win64' else ''}"
        proc = subprocess.run([compiler, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", f"-I{headers}", "-o",
                               str(exe), str(HOST_SOURCE), *flags], capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        out[platform] = {"linux64": [exe], "aarch64-linux": [runner, "-L", AARCH64_SYSROOT, exe],
                         "win64": [runner, exe]}[platform]
    return out


@pytest.fixture(scope="module")
def environment(tmp_path_factory) -> dict:
    """The hosts' environment: nothing but PATH and HOME, and Wine's prefix (kept between runs: wineboot is slow)
    with its debug output off."""
    env = clean_environment(tmp_path_factory.mktemp("platform_home"))
    user = getattr(os, "getuid", lambda: "user")()
    prefix = os.environ.get("FLEXFMU_TEST_WINEPREFIX") or str(Path(tempfile.gettempdir()) / f"flexfmu-wine-{user}")
    return {**env, "WINEPREFIX": prefix, "WINEDEBUG": "-all"}


@pytest.fixture(scope="module")
def native(tmp_path_factory) -> dict:
    """{"XFF" | "XFX" | "FXF": FFRBeam built with the hammer record's set-up, "bracket": examples/bracket exported
    clamped at its bolts (docs/export.md's command with --runtime native)}."""
    from flexfmu.cli import main as flexfmu
    from flexfmu.fmi.native import build_registry_fmu
    out = tmp_path_factory.mktemp("platform_fmus")
    fmus = {}
    for boundary, (load_s, sensor_s) in SETUPS.items():
        fmus[boundary] = build_registry_fmu("FFRBeam", {"boundary": boundary, "load_s": load_s, "sensor_s": sensor_s},
                                            target=out / boundary / "FFRBeam.fmu")
    status = flexfmu(["export", str(ROOT / "examples/bracket/bracket.json"), "-o", str(out / "Bracket.fmu"),
                      "--clamp", "bolt_1,bolt_2", "--interface", "tip=arm_top", "--f-max", "2000",
                      "--runtime", "native"])
    assert status == 0
    fmus["bracket"] = out / "Bracket.fmu"
    return fmus


def case_of(native: dict, name: str) -> dict:
    return bracket_case(native[name]) if name == "bracket" else hammer_case(native[name], name)


# ---------------------------------------------------------------------------------------------- running
def host_path(path: Path, platform: str) -> str:
    """``path`` as the host sees it: Wine maps the Unix root to drive Z:."""
    return "Z:" + str(path).replace("/", "\\") if platform == "win64" else str(path)


def run_case(case: dict, platform: str, hosts: dict, env: dict, folder: Path) -> np.ndarray:
    """(steps + 1, outputs): every output of ``case`` after initialisation and after each step, from the FMU's
    ``platform`` binary in that platform's host."""
    command = hosts[platform]
    if isinstance(command, str):
        pytest.skip(f"{platform}: {command}")
    fmu = Path(case["fmu"])
    md = read_model_description(str(fmu))
    if f"binaries/{platform}/" not in " ".join(zipfile.ZipFile(fmu).namelist()):
        pytest.skip(f"{fmu.name} has no {platform} binary (its cross compiler was missing at build)")
    variables = {v.name: v for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    inputs = list(case["signals"])
    n = len(case["signals"][inputs[0]])
    folder.mkdir(parents=True, exist_ok=True)
    unzipped = extract_fmu(fmu, folder / "fmu")
    np.column_stack([case["signals"][k] for k in inputs]).astype("<f8").tofile(folder / "inputs.bin")
    result = folder / "outputs.bin"
    result.unlink(missing_ok=True)
    args = [platform, host_path(unzipped, platform), md.coSimulation.modelIdentifier, md.guid, bits(case["step"]),
            str(n), host_path(folder / "inputs.bin", platform), host_path(result, platform)]
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


def relative_difference(ours: np.ndarray, reference: np.ndarray) -> float:
    """max over outputs of max |ours - reference| / max |reference| (per output)."""
    scale = np.abs(reference).max(axis=0)
    scale[scale == 0] = 1.0
    return float(np.max(np.abs(ours - reference) / scale))


_LINUX64: dict = {}


def linux64_run(native, name, hosts, env, tmp_path_factory) -> np.ndarray:
    """The linux64 binary's record of case ``name`` (once per module)."""
    if name not in _LINUX64:
        _LINUX64[name] = run_case(case_of(native, name), "linux64", hosts, env,
                                  tmp_path_factory.mktemp(f"linux64_{name}"))
    return _LINUX64[name]


# ---------------------------------------------------------------------------------------------- tests
@pytest.mark.host
def test_every_native_fmu_carries_windows_and_arm_binaries_that_need_only_the_system(native):
    """linux64, win64 and aarch64-linux, each the right machine; the DLL imports nothing beyond Windows' own DLLs
    (KERNEL32, msvcrt: -static-libgcc) and exports only the FMI functions; the FMU's documentation and build
    record name the platforms."""
    for platform in ("win64", "aarch64-linux"):
        compiler, _, _, packages = TOOLS[platform]
        if shutil.which(compiler) is None:
            pytest.skip(f"{platform}: {compiler} not installed (apt-get install {packages.split()[0]}): the FMUs have "
                        "no such binary")
    for name, fmu in native.items():
        stem = Path(fmu).stem
        with zipfile.ZipFile(fmu) as zf:
            members = set(zf.namelist())
            assert {f"binaries/linux64/{stem}.so", f"binaries/win64/{stem}.dll",
                    f"binaries/aarch64-linux/{stem}.so"} <= members, name
            elf_machine = lambda data: struct.unpack_from("<H", data, 18)[0]       # noqa: E731
            assert elf_machine(zf.read(f"binaries/linux64/{stem}.so")) == 62           # EM_X86_64
            assert elf_machine(zf.read(f"binaries/aarch64-linux/{stem}.so")) == 183    # EM_AARCH64
            dll = zf.read(f"binaries/win64/{stem}.dll")
            pe = struct.unpack_from("<I", dll, 0x3C)[0]
            assert dll[pe:pe + 4] == b"PE\0\0" and struct.unpack_from("<H", dll, pe + 4)[0] == 0x8664   # x86-64
            info = zf.read("resources/flexfmu_build.json").decode()
            documentation = zf.read("documentation/index.html").decode()
        assert '"platforms": [\n  "aarch64-linux",\n  "linux64",\n  "win64"\n ]' in info, info
        assert f"binaries/win64/{stem}.dll" in documentation and "copy the <code>aarch64-linux</code>" in documentation
    objdump = shutil.which("x86_64-w64-mingw32-objdump")
    if objdump is None:
        pytest.skip("x86_64-w64-mingw32-objdump not installed (binutils-mingw-w64-x86-64)")
    with tempfile.TemporaryDirectory() as tmp:
        dll = Path(tmp) / "FFRBeam.dll"
        dll.write_bytes(zipfile.ZipFile(native["XFF"]).read("binaries/win64/FFRBeam.dll"))
        table = subprocess.run([objdump, "-p", str(dll)], capture_output=True, text=True, check=True).stdout
    imported = {line.split(":", 1)[1].strip().lower() for line in table.splitlines() if "DLL Name:" in line}
    assert imported and imported <= {"kernel32.dll", "msvcrt.dll"}, imported
    exports = table.split("[Ordinal/Name Pointer] Table", 1)[1].split("\n\n", 1)[0]
    names = [line.split()[-1] for line in exports.splitlines() if line.strip().startswith("[")]
    assert len(names) > 30 and all(name.startswith(("fmi2", "fmi3")) for name in names), names


@pytest.mark.host
@pytest.mark.parametrize("platform", ["win64", "aarch64-linux"])
@pytest.mark.parametrize("name", ["XFF", "XFX", "FXF", "bracket"])
def test_each_platform_binary_gives_the_linux64_numbers_bit_for_bit(native, hosts, environment, tmp_path_factory,
                                                                   platform, name):
    """The hammer record (FFRBeam, each boundary: 20 001 rows x every output) and the bracket's base-motion record
    through the win64 DLL under Wine and the aarch64 library under qemu: the linux64 binary's numbers exactly
    (the module docstring says why exactly)."""
    if isinstance(hosts[platform], str):
        pytest.skip(f"{platform}: {hosts[platform]}")
    reference = linux64_run(native, name, hosts, environment, tmp_path_factory)
    ours = run_case(case_of(native, name), platform, hosts, environment, tmp_path_factory.mktemp(f"{platform}_{name}"))
    assert ours.shape == reference.shape
    assert np.all(np.isfinite(reference)) and np.max(np.abs(reference)) > 0
    difference = relative_difference(ours, reference)
    print(f"\n{name} on {platform}: {reference.shape[0]} rows x {reference.shape[1]} outputs, largest relative "
          f"difference from linux64 {difference:.3g}")
    assert np.array_equal(ours, reference), f"not bit for bit: largest relative difference {difference:.3g}"


@pytest.mark.host
def test_the_linux64_host_gives_fmpys_numbers(native, hosts, environment, tmp_path_factory):
    """The reference above is the FMU's own: fmpy making the same calls on the same binary gets the same bits."""
    from fmpy.fmi2 import FMU2Slave

    from fmu_helpers import Instance
    case = hammer_case(native["XFF"], "XFF")
    reference = linux64_run(native, "XFF", hosts, environment, tmp_path_factory)
    md = read_model_description(str(native["XFF"]))
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    inst = Instance(native["XFF"], "fmpy", **{k: v for k, (_, v) in case["start"].items()}).initialize()
    try:
        rows = [inst.get(*outputs)]
        vr_in = [inst.vr[k] for k in case["signals"]]
        vr_out = [inst.vr[k] for k in outputs]
        signals = np.column_stack(list(case["signals"].values()))
        fmu: FMU2Slave = inst.fmu
        for k in range(len(signals)):
            fmu.setReal(vr_in, list(signals[k]))
            fmu.doStep(currentCommunicationPoint=k * case["step"], communicationStepSize=case["step"])
            rows.append(fmu.getReal(vr_out))
    finally:
        inst.free()
    assert np.array_equal(np.array(rows), reference)


def _fmpy_hammer(fmu, folder=None):
    """The hammer record (XFF) through fmpy.simulate_fmu, from the FMU file or an unzipped folder."""
    from fmpy import simulate_fmu
    case = hammer_case(Path(fmu), "XFF")
    n = len(case["signals"]["F_x"])
    t = np.arange(n) * case["step"]
    inputs = [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "input"]
    signals = np.zeros(n, dtype=[("time", float)] + [(k, float) for k in inputs])     # the others held at 0
    signals["time"] = t
    for k, v in case["signals"].items():
        signals[k] = v
    return simulate_fmu(str(folder or fmu), stop_time=t[-1], step_size=case["step"], output_interval=case["step"],
                        input=signals, start_values={k: v for k, (_, v) in case["start"].items()})


@pytest.mark.host
def test_fmpy_rebuilds_the_source_fmu_and_it_gives_the_shipped_binarys_numbers(native, tmp_path):
    """fmpy's own build of an FMU's sources (fmpy.build.build_platform_binary: its CMake project over the
    SourceFiles listed in modelDescription.xml, default flags) makes a linux64 library that runs the hammer record
    with the shipped binary's numbers exactly (the same C, and x86-64 has no FMA instruction to contract into at
    fmpy's default flags)."""
    pytest.importorskip("fmpy.build")
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed")
    folder = extract_fmu(native["XFF"], tmp_path / "fmu")
    shutil.rmtree(folder / "binaries")
    (tmp_path / "build").mkdir()              # fmpy writes its CMake cache there before configuring
    proc = subprocess.run([sys.executable, "-c", "import sys; from fmpy.build import build_platform_binary; "
                           "build_platform_binary(sys.argv[1], build_dir=sys.argv[2])", str(folder),
                           str(tmp_path / "build")], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert sorted(p.relative_to(folder).as_posix() for p in (folder / "binaries").rglob("*")) == [
        "binaries/linux64", "binaries/linux64/FFRBeam.so"]
    ours = _fmpy_hammer(native["XFF"], folder)
    shipped = _fmpy_hammer(native["XFF"])
    assert len(ours) == len(shipped) == 20000
    assert max(np.max(np.abs(shipped[f"sensor_a_{a}"])) for a in "xyz") > 1e-2       # the blow shows
    assert all(np.array_equal(ours[k], shipped[k]) for k in shipped.dtype.names)


@pytest.mark.fmu
def test_without_the_cross_compilers_the_build_makes_linux64_and_says_what_to_install(tmp_path, monkeypatch):
    """Cross compilers missing (their names changed to ones not on PATH): the FMU has the binaries that could be
    built, one PlatformsMissingWarning names each missing platform with its apt-get line, and the FMU's
    documentation and build record say the same."""
    import dataclasses

    from flexfmu.fmi.native import build_registry_fmu
    from flexfmu.native import compiler
    absent = tuple(dataclasses.replace(p, compiler=f"{p.compiler}-absent") if p.compiler else p
                   for p in compiler.PLATFORMS)
    monkeypatch.setattr(compiler, "PLATFORMS", absent)
    assert set(compiler.missing_platforms()) == {"win64", "aarch64-linux"}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fmu = build_registry_fmu("FFRBeam", target=tmp_path / "FFRBeam.fmu")
    messages = [str(w.message) for w in caught if issubclass(w.category, compiler.PlatformsMissingWarning)]
    assert len(messages) == 1, [str(w.message) for w in caught]
    assert "win64 (apt-get install gcc-mingw-w64-x86-64" in messages[0]
    assert "aarch64-linux (apt-get install gcc-aarch64-linux-gnu" in messages[0]
    assert "the FMU runs on linux64" in messages[0]
    with zipfile.ZipFile(fmu) as zf:
        assert [n for n in zf.namelist() if n.startswith("binaries/")] == ["binaries/linux64/FFRBeam.so"]
        documentation = zf.read("documentation/index.html").decode()
        info = zf.read("resources/flexfmu_build.json").decode()
    assert "Not built, for want of the cross compiler" in documentation
    assert "apt-get install gcc-mingw-w64-x86-64" in documentation and "gcc-aarch64-linux-gnu" in info
