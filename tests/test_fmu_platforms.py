"""Native FMUs on every platform they carry: binaries/win64/<id>.dll (MinGW-w64) run under Wine, and
binaries/aarch64-linux/<id>.so (gcc-aarch64-linux-gnu) run under qemu-aarch64, each in a small FMI 2.0 host built
for that platform from one source (tests/fmi2_platform_host.c), against the linux64 binary in the same host built
for Linux x86-64; and the source FMU rebuilt by fmpy (fmpy.build.build_platform_binary) against the shipped binary.

Why bit for bit, not a tolerance: the three binaries are compiled from the same C with the same IEEE flags (no
fast-math, no FMA contraction: flexfmu.native.compiler), and the hosts make the same FMI calls with the same
numbers (passed as binary64 bit patterns, never as decimal text).  The clamped kinds (FFRBeam, exported clamped
bodies) step by matrix products, sums and quotients alone, which IEEE-754 rounds identically on x86-64 and aarch64;
libm (glibc's on Linux, MinGW-w64's on Windows, which may differ in the last bit) enters only the choice of the
matrix exponential's scaling (pow, log2 under ceil), which a last-bit difference could change only at a threshold.
So any difference is a defect of the build (a flag lost, contraction on aarch64), not rounding.  The free kinds,
whose every step calls sin, cos and atan2, and FMI 3.0: tests/test_fmu_platforms_free.py.

The hosts, the records and how they run: tests/platform_hosts.py (Wine's prefix, what to install).
"""
from __future__ import annotations

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

from host_tools import extract_fmu
from platform_hosts import (ROOT, SETUPS, TOOLS, Records, build_hosts, hammer_case, host_environment,
                            relative_difference)

# ---------------------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def hosts(tmp_path_factory) -> dict:
    return build_hosts(tmp_path_factory.mktemp("platform_hosts"))


@pytest.fixture(scope="module")
def environment(tmp_path_factory) -> dict:
    return host_environment(tmp_path_factory.mktemp("platform_home"))


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


@pytest.fixture(scope="module")
def records(native, hosts, environment, tmp_path_factory) -> Records:
    return Records(native, hosts, environment, tmp_path_factory)


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
def test_each_platform_binary_gives_the_linux64_numbers_bit_for_bit(records, platform, name):
    """The hammer record (FFRBeam, each boundary: 20 001 rows x every output) and the bracket's base-motion record
    through the win64 DLL under Wine and the aarch64 library under qemu: the linux64 binary's numbers exactly
    (the module docstring says why exactly)."""
    reference = records(name, "linux64")
    ours = records(name, platform)
    assert ours.shape == reference.shape
    assert np.all(np.isfinite(reference)) and np.max(np.abs(reference)) > 0
    difference = relative_difference(ours, reference)
    print(f"\n{name} on {platform}: {reference.shape[0]} rows x {reference.shape[1]} outputs, largest relative "
          f"difference from linux64 {difference:.3g}")
    assert np.array_equal(ours, reference), f"not bit for bit: largest relative difference {difference:.3g}"


@pytest.mark.host
def test_the_linux64_host_gives_fmpys_numbers(native, records):
    """The reference above is the FMU's own: fmpy making the same calls on the same binary gets the same bits."""
    from fmpy.fmi2 import FMU2Slave

    from fmu_helpers import Instance
    case = hammer_case(native["XFF"], "XFF")
    reference = records("XFF", "linux64")
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
