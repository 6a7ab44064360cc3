#!/usr/bin/env python3
"""Project tasks that work on a fresh clone with nothing but Python >= 3.11.

    python3 tasks.py main    # set up .venv, then the main job: modal report, build the FMUs into
                             # dist/, run both papers' scenarios through fmpy (dist/*.png), export
                             # the example bracket mesh as an FMU and run it in the wave converter
                             # (its deformed shape: dist/bracket_animation.gif, dist/bracket_vtk/; the
                             # fatigue of its arm root's gauge: dist/bracket_fatigue.png),
                             # and the wave converter on a flexible barge (dist/barge_vs_rigid.png)
    python3 tasks.py test    # set up .venv, then run the whole test suite (a pytest-xdist worker per core)
    python3 tasks.py verify  # the suite under each OpenBLAS kernel type this CPU can run, in random order
                             # (3 seeds), and from a wheel installed outside the checkout (slow: ~1 h)

Set-up creates ``.venv`` and installs the project with its ``dev`` extra into it.
It is skipped when ``pyproject.toml`` has not changed since the last install, so
running either command twice is safe and fast.  On Debian/Ubuntu it also installs the
SYSTEM_PACKAGES that are missing (with apt-get, when run as root; otherwise it names them).
"""
from __future__ import annotations

import hashlib
import os
import re
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
STAMP = VENV / ".flexfmu-install-stamp"


#: Debian packages beyond Python: the cross compilers of the native FMUs' win64 and aarch64-linux binaries
#: (flexfmu.native.compiler.PLATFORMS; without them a native FMU is built for linux64 only) and what runs those
#: binaries here (tests/test_fmu_platforms.py: Wine, qemu-user)
SYSTEM_PACKAGES = ("gcc-mingw-w64-x86-64", "gcc-aarch64-linux-gnu", "wine", "wine64", "qemu-user")


def ensure_system_packages() -> None:
    """Install the SYSTEM_PACKAGES that are missing, with apt-get as root on Debian/Ubuntu; say which are missing
    otherwise.  A failed install is reported, not fatal: the build and the tests then do without them."""
    import shutil
    if shutil.which("dpkg-query") is None:
        return
    missing = [p for p in SYSTEM_PACKAGES
               if "install ok installed" not in subprocess.run(["dpkg-query", "-W", "-f=${Status}", p],
                                                               capture_output=True, text=True).stdout]
    if not missing:
        return
    if getattr(os, "geteuid", lambda: -1)() != 0 or shutil.which("apt-get") is None:
        print(f"[tasks] not installed: {' '.join(missing)} (native FMUs get linux64 binaries only and their "
              f"platform tests skip); as root: apt-get install {' '.join(missing)}", flush=True)
        return
    print(f"[tasks] apt-get install {' '.join(missing)}", flush=True)
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    status = subprocess.call(["apt-get", "update", "-qq"], env=env) or subprocess.call(
        ["apt-get", "install", "-y", "-qq", "--no-install-recommends", *missing], env=env)
    if status:
        print(f"[tasks] apt-get failed (exit {status}); going on without {' '.join(missing)}", flush=True)


def _venv_python() -> Path:
    return VENV / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def _install_fingerprint() -> str:
    return hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()


def ensure_venv() -> Path:
    """Create .venv and install the project (editable, with dev extra) unless up to date."""
    if sys.version_info < (3, 11):
        sys.exit(f"flexfmu needs Python >= 3.11; this is {sys.version.split()[0]}")
    ensure_system_packages()
    python = _venv_python()
    if not python.exists():
        print(f"[tasks] creating {VENV}", flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    fingerprint = _install_fingerprint()
    if not STAMP.exists() or STAMP.read_text() != fingerprint:
        print("[tasks] installing flexfmu[dev] into .venv", flush=True)
        subprocess.check_call([str(python), "-m", "pip", "install", "--quiet", "--upgrade", "pip"])
        subprocess.check_call([str(python), "-m", "pip", "install", "--quiet", "-e", f"{ROOT}[dev]"])
        # Nastran decks (flexfmu.importers.nastran): pyNastran 1.4.1's metadata pins numpy<2, which would
        # downgrade flexfmu's numpy; it runs on numpy 2 (flexfmu aliases the one removed function it calls),
        # so it goes in without its dependencies, and with the ones it really needs.
        subprocess.check_call([str(python), "-m", "pip", "install", "--quiet", "--no-deps", "pyNastran==1.4.1",
                               "cpylog>=1.4", "docopt-ng>=0.9", "colorama"])
        STAMP.write_text(fingerprint)
    return python


def run(argv: list[str]) -> int:
    python = ensure_venv()
    return subprocess.call([str(python), *argv], cwd=ROOT)


# OpenBLAS kernel types from the oldest x86-64 to the newest; the CPU must support a type's instructions
CORETYPES = ("Prescott", "Nehalem", "Sandybridge", "Haswell", "SkylakeX", "Zen")
CORETYPE_FLAGS = {"Sandybridge": "avx", "Haswell": "avx2", "SkylakeX": "avx512f"}


def _cpu_flags() -> set[str]:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return set()
    return set(next((line.split(":", 1)[1].split() for line in text.splitlines() if line.startswith("flags")), []))


def verify(extra: list[str]) -> int:
    """The whole suite in the conditions of a machine unlike this one: each OpenBLAS kernel type the CPU can run
    (OPENBLAS_CORETYPE; threadpoolctl reports the one in use), random test order with pytest-randomly (3 seeds),
    and a wheel installed into a fresh venv outside the checkout.  Prints one line per run; exit 1 if any failed."""
    import tempfile

    python = ensure_venv()
    # the verify extra's pytest-randomly, into .venv alone: installed, it would shuffle every plain run too,
    # so each run below says whether it wants it
    subprocess.check_call([str(python), "-m", "pip", "install", "--quiet", "pytest-randomly>=3.15,<6"])
    flags, amd = _cpu_flags(), "AuthenticAMD" in Path("/proc/cpuinfo").read_text(errors="ignore")
    runs = []
    for core in CORETYPES:
        if core == "Zen" and not amd or core in CORETYPE_FLAGS and CORETYPE_FLAGS[core] not in flags:
            continue
        runs.append((f"OPENBLAS_CORETYPE={core}", {"OPENBLAS_CORETYPE": core}, ["-p", "no:randomly"]))
    for seed in (1, 2, 3):
        runs.append((f"random order, seed {seed}", {}, [f"-p", "randomly", f"--randomly-seed={seed}"]))
    results = []
    try:
        for label, env_extra, options in runs:
            env = {**os.environ, **env_extra}
            print(f"[verify] {label}", flush=True)
            status = subprocess.call([str(python), "-m", "pytest", "-q", "-p", "no:cacheprovider", *options, *extra],
                                     cwd=ROOT, env=env)
            results.append((label, status))
        with tempfile.TemporaryDirectory() as tmp:
            # a wheel in a venv of its own: the suite imports flexfmu from that venv's site-packages, not model/
            wheel_dir, env_dir = Path(tmp) / "wheel", Path(tmp) / "venv"
            subprocess.check_call([str(python), "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(wheel_dir),
                                   str(ROOT)])
            venv.EnvBuilder(with_pip=True).create(env_dir)
            wheel_python = env_dir / "bin" / "python"
            wheel = next(wheel_dir.glob("flexfmu-*.whl"))
            subprocess.check_call([str(wheel_python), "-m", "pip", "install", "--quiet", f"{wheel}[dev]"])
            subprocess.check_call([str(wheel_python), "-m", "pip", "install", "--quiet", "--no-deps",
                                   "pyNastran==1.4.1", "cpylog>=1.4", "docopt-ng>=0.9", "colorama"])
            print("[verify] from a wheel installed outside the checkout", flush=True)
            status = subprocess.call([str(wheel_python), "-c", "import flexfmu, sys; "
                                      "sys.exit(0 if 'site-packages' in flexfmu.__file__ else 1)"])
            if status == 0:
                status = subprocess.call([str(wheel_python), "-m", "pytest", "-q", "-p", "no:cacheprovider",
                                          *extra], cwd=ROOT)
            else:
                print("[verify] the wheel's venv does not import flexfmu from its site-packages", flush=True)
            results.append(("wheel outside the checkout", status))
    finally:
        for label, status in results:
            print(f"[verify] {label}: {'passed' if status == 0 else f'FAILED (exit {status})'}", flush=True)
    return 0 if results and all(status == 0 for _, status in results) else 1


#: the point absorber's native FMUs and what each fixes at build that examples/point_absorber's system file sets
POINT_ABSORBER_NATIVE = (("AbsorberWave", []), ("AbsorberFloat", []), ("AbsorberHydro", []), ("HeavePTO", []),
                         ("Mooring", ["--set", "internal_time_step=0.0020833333333333333"]))


def main() -> int:
    task = sys.argv[1] if len(sys.argv) > 1 else "help"
    extra = sys.argv[2:]
    if task == "main":
        if extra:
            print(f"tasks.py main takes no arguments (got {' '.join(extra)}); see README.md", file=sys.stderr)
            return 2
        # The modal report, the FMUs, then both papers' scenarios through fmpy.
        for argv in (["-m", "flexfmu", "main"], ["build_scripts/build_fmus.py", "--out", "dist"],
                     ["examples/hammer_test.py", "--fmu", "dist/FFRBeam.fmu", "--plot", "dist/hammer_fft.png"],
                     ["examples/reframe_plate.py", "--fmu", "dist/ReframeBody.fmu", "--plot", "dist/reframe_plate.png"],
                     # the native FFRBeam (no Python) for every FMI tool: FMI 2.0 and 3.0, co-simulation and model
                     # exchange, linux64/win64/aarch64 binaries (docs/fmu.md), and the FMI cross-check packages
                     ["-m", "flexfmu", "build", "--runtime", "native", "--interface", "both", "--out", "dist/native"],
                     ["-m", "flexfmu", "build", "--runtime", "native", "--interface", "both", "--fmi-version", "3",
                      "--fmi3-arrays", "--out", "dist/native/fmi3"],
                     ["-m", "flexfmu", "cross-check", "dist/cross-check", "--interface", "cs", "me"],
                     # a user's mesh as an FMU, run in the wave-converter system (docs/export.md)
                     ["-m", "flexfmu", "export", "examples/bracket/bracket.json", "-o", "dist/Bracket.fmu",
                      "--clamp", "bolt_1,bolt_2", "--interface", "tip=arm_top", "--f-max", "2000",
                      "--gauge", "root=0.0005,0.02,0.008", "--gauge", "hole=bolt_1"],
                     ["-m", "flexfmu", "cosim", "examples/bracket/OspSystemStructure.xml", "--t-end", "10",
                      "--out", "dist/bracket_system.csv"],
                     ["examples/bracket/plot_system.py", "dist/bracket_system.csv", "dist/bracket_system.png"],
                     # its deformed shape over the run: the FMU's outputs q_1 .. q_n and its resources/shape.npz
                     # (docs/animation.md)
                     ["-m", "flexfmu", "animate", "dist/bracket_system.csv", "--fmu", "dist/Bracket.fmu",
                      "--out", "dist/bracket_animation.gif", "--vtk", "dist/bracket_vtk"],
                     # the fatigue of its arm root: the critical plane of the gauge's stress (docs/fatigue.md)
                     ["-m", "flexfmu", "fatigue", "dist/bracket_system.csv", "--tensor-gauge", "bracket.root",
                      "--curve", "DNV-B1", "--out", "dist/bracket_fatigue.csv", "--plot", "dist/bracket_fatigue.png"],
                     # the wave converter on a flexible barge (docs/wave_converter.md)
                     ["examples/flexible_barge/make_barge.py", "--out", "dist"],
                     ["examples/flexible_barge/compare.py", "--t-end", "10", "--fmu-dir", "dist",
                      "--plot", "dist/barge_vs_rigid.png"],
                     # the point absorber without Python in the host: its five native FMUs (the lines' MoorDyn step
                     # as the system file sets it), a 20-minute JONSWAP sea state in libcosim (docs/wave_converter.md)
                     *(["-m", "flexfmu", "build", "--runtime", "native", "--fmu", name, "--out",
                        "dist/native/point_absorber"] + settings for name, settings in POINT_ABSORBER_NATIVE),
                     ["-m", "flexfmu", "cosim", "examples/point_absorber/OspSystemStructure.xml", "--master", "libcosim",
                      "--fmu-dir", "dist/native/point_absorber", "--t-end", "1200", "--every", "16",
                      "--set", "wave.sea_state=jonswap", "--set", "wave.wave_height=2", "--set", "wave.wave_period=8",
                      "--out", "dist/point_absorber_jonswap.csv", "--plot", "dist/point_absorber_jonswap.png"]):
            status = run(argv)
            if status:
                return status
        return 0
    if task == "test":
        # one pytest-xdist worker per core, each test file on one worker (its module fixtures, the FMUs it builds,
        # built once); "-n 0" among the arguments runs in this process instead (a debugger, -x on the first failure)
        workers = [] if any(a == "-n" or a.startswith(("-n=", "--numprocesses")) or re.fullmatch(r"-n\d+", a)
                            for a in extra) else ["-n", "auto", "--dist", "loadfile"]
        return run(["-m", "pytest", *workers, *extra])
    if task == "verify":
        return verify(extra)
    if task == "setup":
        ensure_venv()
        return 0
    print(__doc__)
    return 0 if task in ("help", "-h", "--help") else 2


if __name__ == "__main__":
    sys.exit(main())
