"""The free kinds (ReframeBody, exported free bodies: the native "reframe" kind) and FMI 3.0 on every platform a
native FMU carries, in the host of tests/platform_hosts.py (tests/fmi2_platform_host.c built for linux64, for win64
run under Wine and for aarch64-linux run under qemu-aarch64; built with -DFMI_VERSION=3 for FMI 3.0), against the
linux64 binary: ReframeBody's plate and the bracket of examples/bracket exported free, each spinning and struck.

The clamped kinds give the linux64 numbers bit for bit everywhere (tests/test_fmu_platforms.py says why).  The free
kinds turn their frame at every internal step with sin, cos and atan2, so the C library's versions enter every
step.  aarch64-linux calls glibc's, as linux64 does, and gives the linux64 numbers bit for bit (the same glibc
code; also measured on 2^20 arguments of each function: no bit differs).  The win64 DLL carries MinGW-w64's own,
linked statically from libmingwex (not msvcrt's, so not Wine's either: what runs under Wine is what runs on
Windows on the same processor): fsin, fcos, fsincos and fpatan in the x87 unit, rounded to double.  They differ
from glibc's in the last bits of about 1 argument in 1000 (measured on 2^20 arguments in [-4, 4]: sin 1486, cos
1169, atan2 865; up to 5 ulp for cos, more ulps for sin near multiples of pi, where the x87's 66-bit pi limits it
and the result is near zero).  So on win64 the free kinds are held to the linux64 numbers within FREE_RTOL, and
the linux64 binary with those x87 functions preloaded in place of glibc's (tests/mingw_x87_libm.c) must give the
win64 numbers bit for bit: the difference is those functions' and nothing else.

The x87 rounds to its control word's precision: a MinGW program (our host under Wine) starts at 64-bit precision
(0x37f), a Windows x64 process built with Microsoft's compiler at the ABI's 53-bit (0x27f).  At 53 bits MinGW's
pow differs in the last bit on about 1 argument in 10 (sin, cos, atan2, log2 on none of the 2^20); pow and log2
enter only thresholds (the matrix exponential's scaling, the free kinds' rotation bound per internal step).  The
host's --x87-control runs the DLL at the Windows default too.
"""
from __future__ import annotations

import platform as platform_module
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from platform_hosts import (HOST_SOURCE, ROOT, Records, build_hosts, case_of, host_environment, output_names,
                            run_case, vector_relative_difference)

#: win64 against linux64 for the free kinds, relative to each vector's largest component over the record (a
#: component that is zero but for rounding, as com_vel_y of a body pushed in x-z, has no scale of its own).  The two
#: libms' sin, cos and atan2 differ by a few ulp (1.1e-16 relative each) where they differ; the results enter the
#: state with O(1) coefficients, so a step adds at most some 10 ulp; over records this short a difference is
#: carried, not amplified (the rigid rotation is neutral, the elastic modes damped), so N <= 1000 steps stay below
#: N x 10 x 1.1e-16 ~ 1e-12 even if every step differed
FREE_RTOL = 1e-12
#: the x87 control word a Windows x64 process starts with (Microsoft's x64 ABI: all exceptions masked, round to
#: nearest, 53-bit precision); a MinGW program starts at 0x37f (64-bit precision)
WINDOWS_X87_CONTROL = "27f"
FREE = ("ReframeBody", "free")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict:
    """{"ReframeBody" | "bracket" | "free": {FMI version: FMU}}, each from one NativeSource (as
    tests/test_fmu_fmi3.py's): the reframe plate at its defaults and examples/bracket exported clamped at its bolts,
    as FMI 2.0 and 3.0; the bracket exported free with interfaces at its tip and one bolt hole, as FMI 2.0."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.native import body_source, registry_source
    from flexfmu.fmi.native_build import build_native_fmu
    from flexfmu.importers import load_structure
    out = tmp_path_factory.mktemp("platform_free")
    structure = load_structure(ROOT / "examples" / "bracket" / "bracket.json")
    tip = interface_from_text("tip=arm_top")
    clamped = build_body(structure, interfaces=[tip], clamp=clamp_from_text(structure, "bolt_1,bolt_2"), f_max=2000.0)
    free = build_body(structure, interfaces=[tip, interface_from_text("bolt=bolt_1")], f_max=2000.0)
    sources = {"ReframeBody": (registry_source("ReframeBody"), (2, 3)),
               "bracket": (body_source(clamped, "Bracket"), (2, 3)), "free": (body_source(free, "BracketFree"), (2,))}
    return {name: {v: build_native_fmu(source, out / f"fmi{v}" / f"{source.name}.fmu", fmi_version=v)
                   for v in versions} for name, (source, versions) in sources.items()}


@pytest.fixture(scope="module")
def hosts(tmp_path_factory) -> dict:
    return build_hosts(tmp_path_factory.mktemp("platform_hosts"))


@pytest.fixture(scope="module")
def environment(tmp_path_factory) -> dict:
    return host_environment(tmp_path_factory.mktemp("platform_home"))


@pytest.fixture(scope="module")
def records(fmus, hosts, environment, tmp_path_factory) -> Records:
    """The FMI 2.0 FMUs' records."""
    return Records({name: pair[2] for name, pair in fmus.items()}, hosts, environment, tmp_path_factory)


@pytest.fixture(scope="module")
def mingw_x87_libm(tmp_path_factory) -> Path:
    """tests/mingw_x87_libm.c built for LD_PRELOAD (x86-64 Linux only)."""
    if platform_module.machine() not in ("x86_64", "AMD64") or not sys.platform.startswith("linux"):
        pytest.skip("the x87 sin, cos and atan2 preload needs x86-64 Linux")
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed")
    library = tmp_path_factory.mktemp("x87_libm") / "mingw_x87_libm.so"
    proc = subprocess.run(["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-o",
                           str(library), str(HOST_SOURCE.with_name("mingw_x87_libm.c"))], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return library


# ---------------------------------------------------------------------------------------------- tests
@pytest.mark.host
@pytest.mark.parametrize("name", FREE)
def test_the_free_kinds_on_aarch64_give_the_linux64_numbers_bit_for_bit(records, name):
    """ReframeBody's plate (501 rows x 35 outputs) and the free bracket (1001 x 56), spinning and struck, through
    the aarch64 library under qemu: the linux64 binary's numbers exactly (glibc's sin, cos and atan2 on both)."""
    reference, ours = records(name, "linux64"), records(name, "aarch64-linux")
    assert ours.shape == reference.shape
    assert np.all(np.isfinite(reference)) and np.max(np.abs(reference)) > 0
    difference, where = vector_relative_difference(ours, reference, output_names(records.fmus[name]))
    print(f"\n{name} on aarch64-linux: {reference.shape[0]} rows x {reference.shape[1]} outputs, largest difference "
          f"from linux64 relative to its vector {difference:.3g} ({where})")
    assert np.array_equal(ours, reference), f"not bit for bit: {where} {difference:.3g}"


@pytest.mark.host
@pytest.mark.parametrize("name", FREE)
def test_the_free_kinds_on_win64_differ_from_linux64_by_mingws_sin_cos_and_atan2_alone(records, mingw_x87_libm,
                                                                                       name):
    """The same records through the win64 DLL under Wine: within FREE_RTOL of the linux64 binary's (per vector);
    and the linux64 binary with MinGW-w64's x87 sin, cos, sincos and atan2 preloaded in place of glibc's gives the
    win64 numbers bit for bit, so the difference is those functions' and nothing else."""
    reference, ours = records(name, "linux64"), records(name, "win64")
    assert ours.shape == reference.shape and np.all(np.isfinite(ours))
    difference, where = vector_relative_difference(ours, reference, output_names(records.fmus[name]))
    rows = np.flatnonzero((ours != reference).any(axis=1))
    print(f"\n{name} on win64: {reference.shape[0]} rows x {reference.shape[1]} outputs; bit for bit: "
          f"{rows.size == 0}; rows differing: {rows.size} (the first: {rows[0] if rows.size else '-'}); largest "
          f"difference relative to its vector {difference:.3g} ({where})")
    assert difference <= FREE_RTOL, f"{where}: {difference:.3g} > {FREE_RTOL:g}"
    with_x87 = run_case(case_of(records.fmus, name), "linux64", records.hosts,
                        {**records.env, "LD_PRELOAD": str(mingw_x87_libm)}, records.tmp.mktemp(f"linux64_x87_{name}"))
    assert np.array_equal(with_x87, ours), (
        f"the linux64 binary with MinGW's x87 sin, cos and atan2 differs from win64 in {int(np.sum(with_x87 != ours))}"
        " values: something besides those functions differs")


@pytest.mark.host
@pytest.mark.parametrize("name", ["bracket", *FREE])
def test_win64_at_the_windows_x87_precision_gives_the_same_numbers(records, name):
    """The win64 records of the clamped bracket under base motion and of the free kinds with the host's x87 control
    word set to Windows' default, 0x27f (53-bit precision, as in a host built with Microsoft's compiler), equal
    those at MinGW's 0x37f (64-bit) bit for bit."""
    default = records(name, "win64")
    windows = records(name, "win64", ("--x87-control", WINDOWS_X87_CONTROL))
    print(f"\n{name} on win64 at x87 control 0x{WINDOWS_X87_CONTROL}: bit for bit with 0x37f: "
          f"{np.array_equal(windows, default)}")
    assert np.array_equal(windows, default)


@pytest.mark.host
@pytest.mark.parametrize("platform", ["linux64", "win64", "aarch64-linux"])
@pytest.mark.parametrize("name", ["bracket", "ReframeBody"])
def test_fmi3_fmus_give_the_fmi2_numbers_on_each_platform(fmus, records, platform, name):
    """One clamped and one free kind built as FMI 2.0 and FMI 3.0 from one source: the FMI 3.0 FMU's binary for
    each platform (x86_64-linux, x86_64-windows under Wine, aarch64-linux under qemu), in the host built for FMI
    3.0 (the same calls in FMI 3.0's names: fmi3InstantiateCoSimulation, fmi3SetFloat64, fmi3DoStep, ...), gives the
    FMI 2.0 FMU's numbers on that platform bit for bit."""
    fmi2 = records(name, platform)
    fmi3 = run_case(case_of({name: fmus[name][3]}, name), platform, records.hosts, records.env,
                    records.tmp.mktemp(f"fmi3_{platform}_{name}"))
    assert np.all(np.isfinite(fmi2)) and np.max(np.abs(fmi2)) > 0
    print(f"\n{name} on {platform}, FMI 3.0 vs FMI 2.0: {fmi2.shape[0]} rows x {fmi2.shape[1]} outputs, bit for bit: "
          f"{np.array_equal(fmi3, fmi2)}")
    assert np.array_equal(fmi3, fmi2)
