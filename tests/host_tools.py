"""Shared helpers for running the FMUs in hosts other than fmpy (the C host, ecos, libcosim).

The one switch: ``host_environment(tmp_path)`` is the process environment every non-Python host
test runs in: a clean environment (``PATH=/usr/bin:/bin`` and a fresh ``HOME``, nothing inherited
from the test process), plus ``python_environment()`` (``LD_PRELOAD`` of libpython, ``PYTHONHOME``,
``PYTHONPATH``) when ``FMUS_NEED_PYTHON_ENVIRONMENT`` is true or the tests run with
``FLEXFMU_HOST_ENV=python``; ``FLEXFMU_HOST_ENV=clean`` forces the clean one.
"""
from __future__ import annotations

import os
import shutil
import signal
import stat
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLEAN_PATH = "/usr/bin:/bin"

#: The flexfmu FMU runtime (flexfmu/fmi/csrc/, since 939bbe3) finds libpython, the Python home and
#: the build's site-packages itself; FMUs built before it (pythonfmu's binary) need python_environment().
FMUS_NEED_PYTHON_ENVIRONMENT = False


# ---------------------------------------------------------------- environments
def clean_environment(tmp_path: Path) -> dict:
    """Nothing but PATH and HOME: what a host started from a desktop, a service or CI may have."""
    home = Path(tmp_path) / "home"
    home.mkdir(parents=True, exist_ok=True)
    return {"PATH": CLEAN_PATH, "HOME": str(home)}


def libpython() -> Path:
    """The shared libpython of the interpreter running the tests (the one the FMUs were built with)."""
    path = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("LDLIBRARY")
    assert path.suffix.startswith(".so") or ".so." in path.name, f"no shared libpython: {path}"
    assert path.exists(), f"no shared libpython at {path}: a non-Python host cannot run these FMUs"
    return path


def python_environment() -> dict:
    """What FMUs with pythonfmu's binary (before the flexfmu runtime) need in a clean environment:
    all three, measured with examples/c_host and ecos.

    - LD_PRELOAD: pythonfmu's library is not linked against libpython ("undefined symbol:
      _Py_NoneStruct" from fmi2Instantiate without it).
    - PYTHONHOME: the embedded interpreter otherwise derives its prefix from the first python3 on
      PATH (/usr/bin/python3 in a clean PATH) and fails with "No module named 'math'".
    - PYTHONPATH: the build venv's site-packages (threadpoolctl, scikit-fem and the other dependencies
      are not in the base interpreter).
    """
    return {"LD_PRELOAD": str(libpython()), "PYTHONHOME": sys.base_prefix,
            "PYTHONPATH": sysconfig.get_paths()["purelib"]}


def host_environment(tmp_path: Path) -> dict:
    """The environment of every non-Python host test (see the module docstring)."""
    env = clean_environment(tmp_path)
    mode = os.environ.get("FLEXFMU_HOST_ENV", "")
    if mode == "python" or (FMUS_NEED_PYTHON_ENVIRONMENT and mode != "clean"):
        env.update(python_environment())
    return env


# ---------------------------------------------------------------- FMUs
def extract_fmu(fmu: Path, dest: Path) -> Path:
    """Unzip the FMU into dest (made fresh, never shared with another test or run)."""
    dest = Path(dest)
    if dest.exists():
        shutil.rmtree(dest)
    with zipfile.ZipFile(fmu) as zf:
        zf.extractall(dest)
    return dest


def fresh_fmu_copy(fmu: Path, dest_dir: Path) -> Path:
    """A copy of the .fmu under a new path, so that a host that caches by path unpacks it anew."""
    dest_dir = Path(dest_dir)
    dest_dir.mkdir(parents=True, exist_ok=True)
    return Path(shutil.copy2(fmu, dest_dir / Path(fmu).name))


def value_references(fmu: Path) -> dict:
    from fmpy import read_model_description
    return {v.name: v.valueReference for v in read_model_description(str(fmu)).modelVariables}


# ---------------------------------------------------------------- the C host
C_HOST_SOURCE = ROOT / "examples" / "c_host" / "fmi2_host.c"


def compile_c_host(out_dir: Path) -> Path:
    """Compile examples/c_host/fmi2_host.c against fmpy's FMI 2.0 headers; warnings are errors."""
    import fmpy
    exe = Path(out_dir) / "fmi2_host"
    headers = Path(fmpy.__file__).parent / "c-code"
    proc = subprocess.run(["gcc", "-std=c99", "-D_GNU_SOURCE", "-O2", "-Wall", "-Wextra", "-Werror",
                           f"-I{headers}", "-o", str(exe), str(C_HOST_SOURCE), "-ldl"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return exe


# ---------------------------------------------------------------- running hosts
def run_host(cmd, env: dict, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run a host process; its exit status, stdout and stderr go into ``describe`` on failure."""
    return subprocess.run([str(c) for c in cmd], env=env, cwd=str(cwd), capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)


def exit_description(returncode: int) -> str:
    if returncode < 0:
        try:
            return f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"killed by signal {-returncode}"
    if returncode > 128:   # a shell or wrapper reporting a signal as 128 + n
        try:
            return f"exit status {returncode} ({signal.Signals(returncode - 128).name}?)"
        except ValueError:
            pass
    return f"exit status {returncode}"


def describe(proc: subprocess.CompletedProcess, env: dict | None = None, extra: str = "",
             limit: int = 6000) -> str:
    """An assertion message: the command, its environment, how it ended, the tails of its output."""
    def tail(text):
        text = text or ""
        return text if len(text) <= limit else "...\n" + text[-limit:]
    shown_env = " ".join(f"{k}={v}" for k, v in (env or {}).items())
    return (f"\n$ {' '.join(map(str, proc.args))}\nenvironment: {shown_env or '(not given)'}\n"
            f"{exit_description(proc.returncode)}\n--- stderr:\n{tail(proc.stderr)}\n--- stdout:\n{tail(proc.stdout)}"
            + (f"\n{extra}" if extra else ""))


# ---------------------------------------------------------------- ecos (ecospy)
def ecos_binaries() -> tuple[Path, Path] | str:
    """(ecos, proxyfmu) from the ecospy package, made executable; or why they cannot run here."""
    import importlib.util
    try:
        spec = importlib.util.find_spec("ecospy")
    except (ImportError, ValueError):
        spec = None
    if spec is None or not spec.submodule_search_locations:
        return "ecospy is not installed (pip install ecospy, or the project's dev extra)"
    binaries = Path(list(spec.submodule_search_locations)[0]) / "binaries"
    found = []
    for name in ("ecos", "proxyfmu"):
        exe = binaries / name
        if not exe.is_file():
            return f"ecospy has no {exe}"
        found.append(exe)
    if not all(os.access(exe, os.X_OK) for exe in found):   # the wheel installs them without the x bit
        try:
            for exe in found:
                exe.chmod(exe.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
        except OSError:   # a read-only install: copies side by side (ecos looks for proxyfmu next to itself)
            import tempfile
            copies = Path(tempfile.mkdtemp(prefix="ecos_bin_"))
            found = [Path(shutil.copy2(exe, copies / exe.name)) for exe in found]
            for exe in found:
                exe.chmod(0o755)
    ecos = _with_pip_tbb(found[0])
    probe = subprocess.run([str(ecos), "--version"], capture_output=True, text=True, timeout=30)
    if probe.returncode != 0:   # e.g. libtbb.so.12 missing: the dev extra's tbb, or apt-get install libtbb12
        return f"{ecos} --version failed: {(probe.stderr or probe.stdout).strip()}"
    return ecos, found[1]


def _with_pip_tbb(ecos: Path) -> Path:
    """ecos links libtbb.so.12, which Debian's libtbb12 provides; the PyPI package tbb (dev extra) ships it
    in the environment's lib/.  A wrapper puts that folder on ecos's library path, so the tests need no
    system package; ecos still finds proxyfmu next to its real binary."""
    lib = Path(sys.prefix) / "lib"
    if not (lib / "libtbb.so.12").exists():
        return ecos
    import tempfile
    wrapper = Path(tempfile.mkdtemp(prefix="ecos_tbb_")) / "ecos"
    wrapper.write_text(f'#!/bin/sh\nLD_LIBRARY_PATH="{lib}${{LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}}" '
                       f'exec "{ecos}" "$@"\n')
    wrapper.chmod(0o755)
    return wrapper


# ---------------------------------------------------------------- fmpy references
def ecos_times(steps: int, h: float) -> list:
    """(t, h) of each step as ecos takes them: t accumulated, t += h."""
    out, t = [], 0.0
    for _ in range(steps):
        out.append((t, h))
        t += h
    return out


def libcosim_times(steps: int, step_ns: int) -> list:
    """(t, h) of each step as libcosim passes them to fmi2DoStep: time points in integer ns,
    to_double_time_point(t) = ns / 1e9 and h = to_double_time_point(t + dt) - to_double_time_point(t)."""
    return [(k * step_ns / 1e9, (k + 1) * step_ns / 1e9 - k * step_ns / 1e9) for k in range(steps)]


def jacobi_reference(components: dict, connections=(), outputs=(), times=(), inputs_at=None):
    """The fixed-step Jacobi co-simulation of libcosim and ecos, on fmpy (tests/fmu_helpers.Instance).

    components {instance: (fmu path, start values)}, connections [(src, output, dst, input)] of
    Reals, outputs [(instance, variable)], times [(t, h)] of each step (ecos_times, libcosim_times),
    inputs_at(t) -> {instance: {input: value}} applied before the step at t (a scenario).
    Start values are set in initialisation mode; after it every connection passes its output on;
    then every instance steps from t with the inputs of t, and the connections pass the new outputs.
    Returns rows of the outputs after initialisation (row 0) and after each step."""
    import numpy as np
    from fmu_helpers import Instance
    insts = {}
    try:
        for name, (fmu, start) in components.items():
            insts[name] = Instance(fmu, name, **start).initialize()

        def transfer():
            values = [(dst, inp, insts[src].get(out)[0]) for src, out, dst, inp in connections]
            for dst, inp, value in values:
                insts[dst].set(**{inp: value})

        def sample():
            return [insts[i].get(v)[0] for i, v in outputs]

        transfer()
        rows = [sample()]
        for t, h in times:
            for name, values in (inputs_at(t) if inputs_at else {}).items():
                insts[name].set(**values)
            for inst in insts.values():
                inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            transfer()
            rows.append(sample())
        return np.array(rows)
    finally:
        for inst in insts.values():
            inst.free()


# ---------------------------------------------------------------- the fmpy reference in a host's environment
JACOBI_DRIVER = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
from host_tools import jacobi_reference
components, connections, outputs, times = map(json.loads, sys.argv[2:6])
rows = jacobi_reference({k: tuple(v) for k, v in components.items()}, [tuple(c) for c in connections],
                        [tuple(o) for o in outputs], [tuple(t) for t in times])
print("ROWS " + json.dumps([[repr(float(x)) for x in r] for r in rows]))
"""


def jacobi_reference_in(components: dict, connections, outputs, times, env: dict, cwd: Path):
    """jacobi_reference in a subprocess with the environment ``env`` of the host it is compared with: the same FMU
    binaries, FMI calls, doubles, HOME (flexfmu cache entries) and BLAS settings, so the same computation, down to
    the sign of a zero.  components: {name: (FMU path, start values)}."""
    import json
    import sys

    import numpy as np
    components = {name: (str(fmu), start) for name, (fmu, start) in components.items()}
    proc = run_host([sys.executable, "-c", JACOBI_DRIVER, Path(__file__).resolve().parent, json.dumps(components),
                     json.dumps(list(connections)), json.dumps(list(outputs)), json.dumps(list(times))], env, cwd,
                    timeout=300)
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("ROWS ")]
    assert proc.returncode == 0 and line, "the fmpy reference failed" + describe(proc, env)
    return np.array([[float(x) for x in r] for r in json.loads(line[-1][5:])])
