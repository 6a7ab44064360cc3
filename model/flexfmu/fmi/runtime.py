"""The flexfmu FMU runtime: compile it and install it into a pythonfmu-built FMU.

pythonfmu builds the modelDescription and the FMU's layout; its binary is replaced by ours
(the C sources in flexfmu/fmi/csrc/, shipped with the package): a front library with no Python symbols (the FMI entry
points, the call-sequence table, finding libpython; FMI 2.0: flexfmu_fmi2.c, FMI 3.0: flexfmu_fmi3.c beside it) and a
bridge library, the same for both FMI versions, compiled against this interpreter's headers:
the runtime every flexfmu FMU has (flexfmu_native.c: variables, checks, time, FMU states) over the Python kind
(native_python.c), which calls the simulator through flexfmu.fmi.plumbing.  The resources get what the binary needs to start Python and load the slave without any
set-up on the build machine, and what a user needs to move the FMU to another one:

* ``flexfmu_runtime.txt``: libpython, the interpreter's home, the environment's site-packages;
* ``flexfmu_build.json``: model, flexfmu version, build id (a digest of the bundled package), GUID;
* ``flexfmu_model.bin``: the variables and their checks, as every flexfmu FMU's runtime reads them
  (flexfmu.fmi.model_file; kind "python");
* ``flexfmu_loader.py``: flexfmu/fmi/loader.py, run by the binary on each new extraction;
* ``requirements.txt``: the exact versions of the packages the slave imports, built with.

Linux x86-64 only: pythonfmu's binaries for other platforms are removed, since they would run the
slave without this runtime; so is pythonfmu's copy of itself (the slave imports the installed one,
listed in requirements.txt).
"""
from __future__ import annotations

import json
import platform
import re
import shutil
import site
import subprocess
import sys
import sysconfig
import tempfile
from importlib import metadata
from pathlib import Path
from xml.etree import ElementTree as ET

from flexfmu.fmi import archive

HERE = Path(__file__).resolve().parent
RUNTIME = HERE / "csrc"
LOADER = HERE / "loader.py"


class RuntimeBuildError(RuntimeError):
    """The runtime cannot be built or installed here."""


def _fmi2_headers() -> Path:
    """The FMI 2.0 headers shipped with fmpy (fmi2Functions.h, ...)."""
    import fmpy
    headers = Path(fmpy.__file__).resolve().parent / "c-code"
    if not (headers / "fmi2Functions.h").is_file():
        raise RuntimeBuildError(f"FMI 2.0 headers not found in {headers} (fmpy installation incomplete?)")
    return headers


def _compiler() -> str:
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise RuntimeBuildError(f"the FMU runtime is built for linux64 only, not on {sys.platform}/{platform.machine()}")
    gcc = shutil.which("gcc") or shutil.which("cc")
    if gcc is None:
        raise RuntimeBuildError("no C compiler (gcc) on PATH: it is needed to build the FMU runtime; install it, "
                                "e.g. `apt-get install gcc`")
    return gcc


def _run(command: list[str]) -> None:
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeBuildError(f"compiling the FMU runtime failed:\n{' '.join(command)}\n{result.stderr}")


#: the front's C sources per FMI version.  FMI 3.0's front is flexfmu_fmi3.c beside flexfmu_fmi2.c, which holds the
#: code both fronts share (front_common.c, included there): the arrangement of the native library (native_build
#: _FRONT), without FLEXFMU_NATIVE, so it loads the Python bridge.  That front also answers FMI 2.0 calls; an FMI 2.0
#: FMU keeps the front of flexfmu_fmi2.c alone.
FRONT_SOURCES = {2: ("flexfmu_fmi2.c",), 3: ("flexfmu_fmi2.c", "flexfmu_fmi3.c")}
#: a symbol only an FMI 3.0 front exports (flexfmu.fmi.build checks that an FMI 3.0 FMU gets such a front)
FMI3_ENTRY = b"fmi3InstantiateCoSimulation"


def compile_runtime(folder: Path, fmi_version: int = 2) -> tuple[Path, Path]:
    """(front, bridge) shared libraries compiled into ``folder``: the front of FMI version ``fmi_version`` (2 or 3);
    the bridge (the runtime over the Python kind) is the same for both."""
    from flexfmu.errors import ParameterError

    if fmi_version not in FRONT_SOURCES:
        raise ParameterError("fmi_version", f"got {fmi_version!r}", "2 or 3")
    gcc = _compiler()
    common = ["-std=c11", "-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-Werror", "-Wno-format-truncation",
              "-fvisibility=hidden",  # messages may be cut to their buffers on purpose
              f"-I{_fmi2_headers()}", f"-I{RUNTIME}"]     # fmpy's c-code holds the FMI 3.0 headers too
    if fmi_version == 3 and not (_fmi2_headers() / "fmi3Functions.h").is_file():
        raise RuntimeBuildError(f"FMI 3.0 headers not found in {_fmi2_headers()} (fmpy installation incomplete?)")
    front = folder / ("front.so" if fmi_version == 2 else "front_fmi3.so")
    bridge = folder / "bridge.so"
    _run([gcc, *common, *(str(RUNTIME / name) for name in FRONT_SOURCES[fmi_version]), "-o", str(front), "-ldl",
          "-lpthread", "-lm"])
    include = sysconfig.get_paths()["include"]
    if not (Path(include) / "Python.h").is_file():
        raise RuntimeBuildError(f"Python.h not found in {include}: install this Python's headers (e.g. python3-dev)")
    # the bridge: the one runtime (flexfmu_native.c) over the Python kind.  No -lpython: the symbols come from the
    # libpython the front loads globally, or from a Python host
    _run([gcc, *common, f"-I{include}", str(RUNTIME / "flexfmu_native.c"), str(RUNTIME / "native_python.c"),
          "-o", str(bridge), "-lm"])
    return front, bridge


def libpython() -> Path:
    """This interpreter's shared libpython (a C host must load it)."""
    name = sysconfig.get_config_var("INSTSONAME") or sysconfig.get_config_var("LDLIBRARY")
    folder = Path(sysconfig.get_config_var("LIBDIR") or "")
    path = folder / name
    if not sysconfig.get_config_var("Py_ENABLE_SHARED") or not path.is_file():
        raise RuntimeBuildError(f"this Python ({sys.executable}) has no shared libpython ({path}): C hosts could not "
                                f"load the FMU; build with a Python configured with --enable-shared")
    return path


def runtime_settings() -> str:
    """resources/flexfmu_runtime.txt: where the embedded interpreter and the packages are on this machine."""
    sites = [p for p in site.getsitepackages() if Path(p).is_dir()]
    lines = ["# Written at build time; each line can be overridden by an environment variable (docs/fmu.md):",
             "# FLEXFMU_LIBPYTHON, FLEXFMU_PYTHONHOME, FLEXFMU_SITE_PACKAGES (':'-separated).",
             f"libpython={libpython()}", f"python_home={sys.base_prefix}",
             f"python_version={sys.version_info.major}.{sys.version_info.minor}"]
    lines += [f"site={p}" for p in sites]
    return "\n".join(lines) + "\n"


def _requirement_name(spec: str) -> str | None:
    """The distribution a requirement names, or None if it is only for an extra."""
    if "extra ==" in spec.replace("extra==", "extra =="):
        return None
    return re.split(r"[\s<>=!~;\[(]", spec.strip(), maxsplit=1)[0]


def requirements(root: str = "flexfmu") -> str:
    """resources/requirements.txt: the exact installed version of every package ``root`` needs at run
    time (recursively, extras left out)."""
    seen: dict[str, str] = {}
    todo = [_requirement_name(r) for r in (metadata.requires(root) or [])]
    while todo:
        name = todo.pop()
        if not name or name.lower() in seen:
            continue
        try:
            version = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue            # a platform-specific dependency not installed here
        seen[name.lower()] = f"{name}=={version}"
        todo += [_requirement_name(r) for r in (metadata.requires(name) or [])]
    return "# The Python packages this FMU was built with (python -m pip install -r requirements.txt)\n" + \
        "\n".join(sorted(seen.values(), key=str.lower)) + "\n"


def install(fmu: Path, front: Path, bridge: Path, build_info: dict, spec) -> None:
    """Put the runtime into the pythonfmu FMU at ``fmu`` (in place), with the model file of ``spec``."""
    from flexfmu.fmi import model_file

    members = archive.read_members(fmu)
    description = ET.fromstring(members["modelDescription.xml"])
    model_id = description.find("CoSimulation").get("modelIdentifier")
    info = {**build_info, "guid": description.get("guid"), "model": model_id}
    entries, *_ = model_file.entries(spec, kind="python", name=model_id, guid=description.get("guid"))
    kept = {name: data for name, data in members.items()
            if not name.startswith(("binaries/", "resources/pythonfmu/")) and name != "resources/slavemodule.txt"}
    kept[f"binaries/linux64/{model_id}.so"] = front.read_bytes()
    kept[f"binaries/linux64/{model_id}_python.so"] = bridge.read_bytes()
    kept["resources/flexfmu_loader.py"] = LOADER.read_bytes()
    with tempfile.TemporaryDirectory() as tmp:
        kept[f"resources/{model_file.MODEL_FILE}"] = model_file.write_model_file(Path(tmp) / "model.bin",
                                                                                 entries).read_bytes()
    kept["resources/flexfmu_build.json"] = json.dumps(info, indent=1).encode()
    kept["resources/flexfmu_runtime.txt"] = runtime_settings().encode()
    kept["resources/requirements.txt"] = requirements().encode()
    archive.write_members(fmu, kept)


def build_folder() -> Path:
    return Path(tempfile.mkdtemp(prefix="flexfmu-runtime-"))
