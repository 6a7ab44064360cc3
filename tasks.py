#!/usr/bin/env python3
"""Project tasks that work on a fresh clone with nothing but Python >= 3.11.

    python3 tasks.py main    # set up .venv, then the main job: modal report, build the FMUs into
                             # dist/, run both papers' scenarios through fmpy (dist/*.png), export
                             # the example bracket mesh as an FMU and run it in the wave converter,
                             # and the wave converter on a flexible barge (dist/barge_vs_rigid.png)
    python3 tasks.py test    # set up .venv, then run the whole test suite

Set-up creates ``.venv`` and installs the project with its ``dev`` extra into it.
It is skipped when ``pyproject.toml`` has not changed since the last install, so
running either command twice is safe and fast.
"""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
STAMP = VENV / ".flexfmu-install-stamp"


def _venv_python() -> Path:
    return VENV / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def _install_fingerprint() -> str:
    return hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()


def ensure_venv() -> Path:
    """Create .venv and install the project (editable, with dev extra) unless up to date."""
    if sys.version_info < (3, 11):
        sys.exit(f"flexfmu needs Python >= 3.11; this is {sys.version.split()[0]}")
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
                     # a user's mesh as an FMU, run in the wave-converter system (docs/export.md)
                     ["-m", "flexfmu", "export", "examples/bracket/bracket.json", "-o", "dist/Bracket.fmu",
                      "--clamp", "bolt_1,bolt_2", "--interface", "tip=arm_top", "--f-max", "2000"],
                     ["-m", "flexfmu", "cosim", "examples/bracket/OspSystemStructure.xml", "--t-end", "10",
                      "--out", "dist/bracket_system.csv"],
                     ["examples/bracket/plot_system.py", "dist/bracket_system.csv", "dist/bracket_system.png"],
                     # the wave converter on a flexible barge (docs/wave_converter.md)
                     ["examples/flexible_barge/make_barge.py", "--out", "dist"],
                     ["examples/flexible_barge/compare.py", "--t-end", "10", "--fmu-dir", "dist",
                      "--plot", "dist/barge_vs_rigid.png"]):
            status = run(argv)
            if status:
                return status
        return 0
    if task == "test":
        return run(["-m", "pytest", *extra])
    if task == "setup":
        ensure_venv()
        return 0
    print(__doc__)
    return 0 if task in ("help", "-h", "--help") else 2


if __name__ == "__main__":
    sys.exit(main())
