"""Install the FMI 2.0 shim (fmi2_shim.c) into a pythonfmu-built FMU.

pythonfmu 0.7's binary turns every Python exception into fmi2Fatal.  The shim returns fmi2Error
when the slave logged an fmi2Error message before raising (a bad parameter, call or input).  It
also keeps the instance safe to reset, roll back and free afterwards.  See the comment at the
top of fmi2_shim.c.

    apply_shim(fmu_path)

renames binaries/linux64/<modelIdentifier>.so to <modelIdentifier>_pythonfmu.so, compiles the
shim with gcc into binaries/linux64/<modelIdentifier>.so and rewrites the .fmu in place.  It can
be applied again (it recompiles the shim and keeps the renamed pythonfmu library).

Linux (x86-64) only for now: the win64 binary is left as pythonfmu built it, so on Windows the
FMU still answers fmi2Fatal for these errors.
"""
from __future__ import annotations

import platform
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

SHIM_SOURCE = Path(__file__).resolve().with_name("fmi2_shim.c")


class ShimError(RuntimeError):
    """The shim cannot be built or installed."""


def _fmi2_headers() -> Path:
    """The FMI 2.0 headers shipped with fmpy (fmi2Functions.h, fmi2FunctionTypes.h, ...)."""
    import fmpy
    headers = Path(fmpy.__file__).resolve().parent / "c-code"
    if not (headers / "fmi2Functions.h").is_file():
        raise ShimError(f"FMI 2.0 headers not found in {headers} (fmpy installation incomplete?)")
    return headers


def compile_shim(output: Path) -> None:
    """Compile fmi2_shim.c into the shared library `output` (Linux x86-64 only)."""
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise ShimError(f"the FMI shim is built for linux64 only, not on {sys.platform}/{platform.machine()}")
    gcc = shutil.which("gcc")
    if gcc is None:
        raise ShimError("gcc not found on PATH: it is needed to compile the FMI shim "
                        "(build_scripts/fmi2_shim.c); install it, e.g. `apt-get install gcc`")
    command = [gcc, "-std=c99", "-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-fvisibility=hidden",
               f"-I{_fmi2_headers()}", str(SHIM_SOURCE), "-o", str(output), "-ldl"]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise ShimError(f"compiling the FMI shim failed:\n{' '.join(command)}\n{result.stderr}")


def _model_identifier(model_description: bytes) -> str:
    cosim = ET.fromstring(model_description).find("CoSimulation")
    if cosim is None or not cosim.get("modelIdentifier"):
        raise ShimError("modelDescription.xml has no CoSimulation modelIdentifier")
    return cosim.get("modelIdentifier")


def apply_shim(fmu_path: Path) -> None:
    """Install the FMI shim into the linux64 binary of the pythonfmu FMU at `fmu_path` (in place)."""
    fmu_path = Path(fmu_path)
    with zipfile.ZipFile(fmu_path) as zf:
        members = [(info, zf.read(info)) for info in zf.infolist()]
    data = {info.filename: content for info, content in members}
    if "modelDescription.xml" not in data:
        raise ShimError(f"{fmu_path}: not an FMU (no modelDescription.xml)")
    model_id = _model_identifier(data["modelDescription.xml"])
    binary = f"binaries/linux64/{model_id}.so"
    inner = f"binaries/linux64/{model_id}_pythonfmu.so"
    if binary not in data:
        raise ShimError(f"{fmu_path}: no {binary} to wrap")

    with tempfile.TemporaryDirectory() as tmp:
        shim_so = Path(tmp) / f"{model_id}.so"
        compile_shim(shim_so)
        shim_bytes = shim_so.read_bytes()

    already_shimmed = inner in data
    rewritten = []
    for info, content in members:
        if info.filename == binary:
            if not already_shimmed:   # pythonfmu's library moves to <id>_pythonfmu.so, same attributes
                rewritten.append((_renamed(info, inner), content))
            rewritten.append((_renamed(info, binary), shim_bytes))
        else:
            rewritten.append((info, content))

    tmp_fmu = fmu_path.with_name(fmu_path.name + ".shim.tmp")
    with zipfile.ZipFile(tmp_fmu, "w", zipfile.ZIP_DEFLATED) as zf:
        for info, content in rewritten:
            zf.writestr(info, content)
    tmp_fmu.replace(fmu_path)


def _renamed(info: zipfile.ZipInfo, name: str) -> zipfile.ZipInfo:
    copy = zipfile.ZipInfo(name, date_time=info.date_time)
    copy.compress_type = zipfile.ZIP_DEFLATED
    copy.external_attr = info.external_attr
    return copy


if __name__ == "__main__":
    for argument in sys.argv[1:]:
        apply_shim(Path(argument))
        print(f"FMI shim installed in {argument}")
