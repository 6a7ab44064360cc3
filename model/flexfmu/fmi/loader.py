"""Load a flexfmu FMU's slave into the host's Python.

The build copies this file into every FMU as ``resources/flexfmu_loader.py``; the FMU's binary
(its Python kind, csrc/native_python.c) runs it in a fresh namespace for each new extraction and calls :func:`load`.  It
imports nothing from flexfmu at module level, because deciding which flexfmu to import is its job:

* All FMUs in a process share one interpreter, so ``flexfmu`` can be imported once.  It is imported
  from a per-user runtime copy keyed by the package's content (``<cache root>/fmu-runtime/<build
  id>``), never from an extraction folder: hosts delete those (fmpy after every ``simulate_fmu``)
  while the module, its lazy imports and its data files stay in use.
* A ``flexfmu`` already imported (by another FMU, or the user's own) is reused when its content is
  the same build; another build is refused, naming both, since one process cannot hold two.
* A missing package is reported with the list from ``resources/requirements.txt`` and the pip command.
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
import sys
import tempfile

PACKAGE = "flexfmu"
BUILD_INFO = "flexfmu_build.json"


class FmuLoadError(Exception):
    """Why the model cannot be loaded; the FMU's binary logs it and fmi2Instantiate returns NULL."""

    fmi_status = 3      # fmi2Error


def package_build_id(package_dir: str) -> str:
    """A digest of every file of the package (not caches): equal for a package and its bundled copy."""
    digest = hashlib.sha256()
    for folder, subfolders, files in os.walk(package_dir):
        subfolders[:] = sorted(d for d in subfolders if d != "__pycache__")
        for name in sorted(files):
            if name.endswith((".pyc", ".pyo")):
                continue
            path = os.path.join(folder, name)
            digest.update(os.path.relpath(path, package_dir).replace(os.sep, "/").encode() + b"\0")
            with open(path, "rb") as file:
                digest.update(file.read())
            digest.update(b"\0")
    return digest.hexdigest()[:16]


def cache_root() -> str:
    """As flexfmu.core.cache.cache_root (this file cannot import flexfmu)."""
    explicit = os.environ.get("FLEXFMU_CACHE_DIR")
    if explicit:
        return explicit
    xdg = os.environ.get("XDG_CACHE_HOME")
    return os.path.join(xdg or os.path.join(os.path.expanduser("~"), ".cache"), PACKAGE)


def _runtime_copy(bundled: str, build_id: str) -> str:
    """A folder holding a copy of the bundled package that outlives the extraction (atomic; shared by
    processes).  Falls back to the system temp folder, then to the extraction itself."""
    for root in (cache_root(), os.path.join(tempfile.gettempdir(), f"flexfmu-{os.getuid()}")):
        target = os.path.join(root, "fmu-runtime", build_id)
        marker = os.path.join(target, "complete")
        if os.path.isfile(marker):
            return target
        try:
            os.makedirs(os.path.dirname(target), exist_ok=True)
            scratch = tempfile.mkdtemp(prefix=f".{build_id}-", dir=os.path.dirname(target))
            shutil.copytree(bundled, os.path.join(scratch, PACKAGE))
            with open(os.path.join(scratch, "complete"), "w") as file:
                file.write(build_id)
            # a target with its marker is another process's complete copy, renamed into place while we copied
            # (it may already be importing from it): never removed; one without is left incomplete by someone
            if os.path.isdir(target) and not os.path.isfile(marker):
                shutil.rmtree(target, ignore_errors=True)
            try:
                os.rename(scratch, target)
            except OSError:                    # another process won the race: use its copy
                shutil.rmtree(scratch, ignore_errors=True)
            if os.path.isfile(marker):
                return target
        except OSError:
            continue
    return os.path.dirname(bundled)


def _loaded_build(module) -> tuple[str, str]:
    """(build id, folder) of an imported flexfmu."""
    folder = os.path.dirname(os.path.abspath(module.__file__))
    build_id = getattr(module, "__build_id__", None)
    if build_id is None:
        build_id = package_build_id(folder) if os.path.isdir(folder) else "unknown (its folder is gone)"
        module.__build_id__ = build_id
    return build_id, folder


def _import_flexfmu(resources: str, info: dict):
    loaded = sys.modules.get(PACKAGE)
    if loaded is not None:
        build_id, folder = _loaded_build(loaded)
        if build_id != info["build_id"]:
            raise FmuLoadError(
                f"this FMU ({info['model']}) was built with flexfmu {info['version']} (build {info['build_id']}), "
                f"but flexfmu {getattr(loaded, '__version__', '?')} (build {build_id}) is already imported in this "
                f"process from {folder}; one Python process holds one flexfmu: rebuild the FMUs with the same "
                f"flexfmu, or run this FMU in its own process (e.g. a host's out-of-process proxy)")
        return loaded
    root = _runtime_copy(os.path.join(resources, PACKAGE), info["build_id"])
    init = os.path.join(root, PACKAGE, "__init__.py")
    spec = importlib.util.spec_from_file_location(PACKAGE, init, submodule_search_locations=[os.path.dirname(init)])
    module = importlib.util.module_from_spec(spec)
    sys.modules[PACKAGE] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(PACKAGE, None)
        raise
    module.__build_id__ = info["build_id"]
    return module


def _requirements_message(resources: str, error: BaseException) -> str:
    """Which of the FMU's requirements this Python lacks, and how to install them."""
    from importlib import metadata
    path = os.path.join(resources, "requirements.txt")
    missing, other = [], []
    try:
        with open(path) as file:
            lines = [line.strip() for line in file if line.strip() and not line.startswith("#")]
    except OSError:
        lines = []
    for line in lines:
        name, _, version = line.partition("==")
        try:
            installed = metadata.version(name)
        except metadata.PackageNotFoundError:
            missing.append(line)
            continue
        if version and installed != version:
            other.append(f"{name} {installed} (built with {version})")
    text = (f"this FMU cannot import its Python code ({type(error).__name__}: {error}) in the Python at "
            f"{sys.prefix} (Python {sys.version.split()[0]})")
    if missing:
        text += f"; missing packages: {', '.join(missing)}"
    if other:
        text += f"; other versions: {', '.join(other)}"
    return text + f"; install what it needs with: python -m pip install -r {path}"


def load(resources: str):
    """The model of the FMU extracted at ``resources/..`` (flexfmu.fmi.plumbing.PythonModel of the spec its slave
    script's ``fmu_spec`` gives), which the runtime's Python kind makes its instances from."""
    try:
        with open(os.path.join(resources, BUILD_INFO)) as file:
            info = json.load(file)
    except (OSError, ValueError) as exc:
        raise FmuLoadError(f"the FMU's {BUILD_INFO} is missing or damaged ({exc})") from None
    try:
        _import_flexfmu(resources, info)
        name = f"flexfmu_fmu_slave_{info['model']}_{info['build_id']}"
        spec = importlib.util.spec_from_file_location(name, os.path.join(resources, info["slave_script"]))
        script = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(script)
        from flexfmu.fmi.plumbing import PythonModel
    except ImportError as exc:
        raise FmuLoadError(_requirements_message(resources, exc)) from None
    return PythonModel(script.fmu_spec(resources))
