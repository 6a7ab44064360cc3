"""Third-party checks of the FMUs flexfmu makes, each run in a bare environment (nothing but PATH=/usr/bin:/bin
and a fresh HOME, as a host started from a desktop, a service or CI has):

- fmu-manipulation-toolbox's checker, ``fmutool -input X.fmu -check`` (pyproject.toml's dev extra): the
  modelDescription against the FMI standard's XSD, then its semantic rules (unique names and value references,
  causality / variability / initial combinations, start values, the model structure).  On the native FMUs, FMI 2.0
  and FMI 3.0 co-simulation: FFRBeam (the hammer record's XFF set-up), ReframeBody, examples/bracket exported
  clamped at its bolts and free; FFRBeam built with model exchange too; and the Python runtime's FFRBeam (FMI 2.0
  and 3.0, as ``flexfmu build`` makes dist/).
- Reference-FMUs' fmusim (benchmarks/build_fmusim.sh; skipped when not built) on the native FMI 3.0 FMUs: each
  runs and prints the FMI 2.0 FMU's numbers.

Each checker is first fed what it must refuse (a modelDescription broken against the XSD and against a semantic
rule; a parameter out of its range), so a check that passes is one that could have failed.  What fmutool prints:
one line per finding, "LEVEL | message"; a compliant FMU gives INFO lines only, among them "This FMU seems to be
compliant with FMI-<version>." and "No semantic error against the FMI-<major> standard.", and exit status 0; a
problem gives ERROR lines ("This FMU does not validate with FMI standard.", "<n> semantic error(s) against the
FMI-<major> standard.", "-check: <n> error(s) found.") and exit status 7 (fmu-manipulation-toolbox 2.0).
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from host_tools import clean_environment, describe
from platform_hosts import SETUPS

ROOT = Path(__file__).resolve().parents[1]
FMUTOOL = Path(sys.executable).with_name("fmutool")
#: one line of fmutool's log
LOG_LINE = re.compile(r"(DEBUG|INFO|WARNING|ERROR|CRITICAL)\s*\| ?(.*)")
#: the hammer record's XFF set-up (examples/hammer_test.py)
XFF = {"boundary": "XFF", "load_s": SETUPS["XFF"][0], "sensor_s": SETUPS["XFF"][1]}
NATIVE = ("FFRBeam", "ReframeBody", "clamped", "free")


@pytest.fixture(scope="module")
def native(tmp_path_factory) -> dict:
    """{"FFRBeam" | "ReframeBody" | "clamped" | "free": {2: FMI 2.0 FMU, 3: FMI 3.0 FMU}} (native runtime,
    co-simulation), each pair from one NativeSource; "FFRBeam me": {2, 3: FFRBeam with co-simulation and model
    exchange}."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.native import body_source, registry_source
    from flexfmu.fmi.native_build import build_native_fmu
    from flexfmu.importers import load_structure
    out = tmp_path_factory.mktemp("checked")
    structure = load_structure(ROOT / "examples" / "bracket" / "bracket.json")
    tip = interface_from_text("tip=arm_top")
    clamped = build_body(structure, interfaces=[tip], clamp=clamp_from_text(structure, "bolt_1,bolt_2"), f_max=2000.0)
    free = build_body(structure, interfaces=[tip, interface_from_text("bolt=bolt_1")], f_max=2000.0)
    sources = {"FFRBeam": registry_source("FFRBeam", XFF), "ReframeBody": registry_source("ReframeBody"),
               "clamped": body_source(clamped, "BracketClamped"), "free": body_source(free, "BracketFree")}
    fmus = {name: {v: build_native_fmu(source, out / name / f"fmi{v}" / f"{source.name}.fmu", fmi_version=v)
                   for v in (2, 3)} for name, source in sources.items()}
    fmus["FFRBeam me"] = {v: build_native_fmu(sources["FFRBeam"], out / "me" / f"fmi{v}" / "FFRBeam.fmu",
                                              fmi_version=v, interface="both") for v in (2, 3)}
    return fmus


@pytest.fixture(scope="module")
def python_fmus(tmp_path_factory) -> dict:
    """{2 | 3: the Python runtime's FFRBeam}, built by ``flexfmu build [--fmi-version 3]`` as dist/ is."""
    out = tmp_path_factory.mktemp("python_fmus")
    fmus = {}
    for version in (2, 3):
        folder = out / f"fmi{version}"
        proc = subprocess.run([sys.executable, "-m", "flexfmu", "build", "--out", str(folder), "--fmi-version",
                               str(version)], capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
        fmus[version] = folder / "FFRBeam.fmu"
    return fmus


@pytest.fixture
def bare(tmp_path) -> dict:
    return clean_environment(tmp_path)


# ---------------------------------------------------------------------------------------------- fmutool
def fmutool_check(fmu: Path, env: dict, cwd: Path) -> subprocess.CompletedProcess:
    assert FMUTOOL.exists(), "fmu-manipulation-toolbox missing: install the project with its dev extra"
    return subprocess.run([str(FMUTOOL), "-input", str(fmu), "-check"], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=300, stdin=subprocess.DEVNULL)


def fmutool_problems(proc: subprocess.CompletedProcess, fmi_version: str) -> list[str]:
    """Everything in ``fmutool -check``'s run that is not a clean pass for an FMU of ``fmi_version`` ("2.0",
    "3.0"): a line above INFO or not fmutool's, a missing compliance or semantic line, a non-zero exit status."""
    problems, messages = [], []
    for line in (proc.stdout + proc.stderr).splitlines():
        match = LOG_LINE.fullmatch(line.rstrip())
        if match is None:
            if line.strip():
                problems.append(f"unexpected output: {line}")
        elif match[1] != "INFO":
            problems.append(f"{match[1]}: {match[2]}")
        else:
            messages.append(match[2].strip())
    for expected in (f"This FMU seems to be compliant with FMI-{fmi_version}.",
                     f"No semantic error against the FMI-{fmi_version[0]} standard."):
        if expected not in messages:
            problems.append(f"missing: {expected}")
    if proc.returncode != 0:
        problems.append(f"exit status {proc.returncode}")
    return problems


def with_model_description(fmu: Path, target: Path, edit) -> Path:
    """A copy of ``fmu`` at ``target`` whose modelDescription.xml is edit(text)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as copy:
        for name in source.namelist():
            data = source.read(name)
            if name == "modelDescription.xml":
                changed = edit(data.decode("utf-8"))
                assert changed != data.decode("utf-8"), "the edit changed nothing"
                data = changed.encode("utf-8")
            copy.writestr(name, data)
    return target


def drop_first_output_entry(text: str) -> str:
    """The model structure without its first output's entry (FMI 2.0: <Outputs><Unknown .../>; FMI 3.0: <Output
    .../>): an output not listed there breaks FMI 2.0 section 2.2.8 / FMI 3.0 section 2.4.8, which no XSD can
    express."""
    start = text.index("<Unknown", text.index("<Outputs>")) if "<Outputs>" in text else text.index("<Output ")
    return text[:start] + text[text.index("/>", start) + 2:]


def bad_causality(text: str) -> str:
    return text.replace('causality="input"', 'causality="sideways"', 1)


@pytest.mark.host
@pytest.mark.parametrize("version", [2, 3])
def test_fmutool_reports_a_broken_model_description(native, bare, tmp_path, version):
    """ReframeBody's modelDescription with an output missing from the model structure (semantic), and with an
    input's causality not one of the standard's (XSD): each reported, exit status non-zero."""
    fmu = native["ReframeBody"][version]
    first_output = next(v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output")
    listed = "<Outputs>" if version == 2 else "<Output>"
    semantic = fmutool_check(with_model_description(fmu, tmp_path / "semantic" / fmu.name, drop_first_output_entry),
                             bare, tmp_path)
    problems = fmutool_problems(semantic, f"{version}.0")
    section = "FMI-2 §2.2.8" if version == 2 else "FMI-3 §2.4.8"
    assert f"ERROR: Output '{first_output}' is not listed in {listed} ({section})." in problems, describe(semantic, bare)
    assert f"missing: No semantic error against the FMI-{version} standard." in problems
    assert semantic.returncode != 0
    schema = fmutool_check(with_model_description(fmu, tmp_path / "schema" / fmu.name, bad_causality), bare, tmp_path)
    problems = fmutool_problems(schema, f"{version}.0")
    assert "ERROR: This FMU does not validate with FMI standard." in problems, describe(schema, bare)
    assert any(p.startswith("ERROR: attribute causality='sideways'") for p in problems), problems
    assert schema.returncode != 0


@pytest.mark.host
@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("name", [*NATIVE, "FFRBeam me"])
def test_fmutool_finds_no_problem_in_the_native_fmus(native, bare, tmp_path, name, version):
    fmu = native[name][version]
    proc = fmutool_check(fmu, bare, tmp_path)
    assert read_model_description(str(fmu)).fmiVersion == f"{version}.0"
    assert fmutool_problems(proc, f"{version}.0") == [], describe(proc, bare)


@pytest.mark.host
@pytest.mark.parametrize("version", [2, 3])
def test_fmutool_finds_no_problem_in_the_python_runtimes_fmu(python_fmus, bare, tmp_path, version):
    proc = fmutool_check(python_fmus[version], bare, tmp_path)
    assert fmutool_problems(proc, f"{version}.0") == [], describe(proc, bare)


# ---------------------------------------------------------------------------------------------- fmusim
def fmusim_path() -> Path | None:
    """fmusim (Reference-FMUs, built by benchmarks/build_fmusim.sh): $FMUSIM, on PATH, or the benchmarks' build folder
    beside this checkout."""
    for candidate in (os.environ.get("FMUSIM"), shutil.which("fmusim"), ROOT.parent / "fmusim-build" / "fmusim"):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    return None


@pytest.fixture(scope="module")
def fmusim() -> Path:
    found = fmusim_path()
    if found is None:
        pytest.skip("fmusim not built (benchmarks/build_fmusim.sh SOURCE_DIR BUILD_DIR; or set FMUSIM)")
    return found


def pulse(amplitude: float, width: float):
    return lambda t: np.where(t < width, amplitude * np.sin(np.pi * t / width), 0.0)


#: case: (stop time, output interval = step (s), inputs {name: f(t)}, start values, an output the inputs move)
FMUSIM_CASES = {
    "FFRBeam": (0.05, 1e-4, {"F_x": pulse(20.0, 1e-3), "F_z": pulse(8.0, 1e-3)}, {"damping_ratio": 0.002},
                "sensor_a_z"),
    "ReframeBody": (0.05, 1e-3, {"F_x": pulse(35.0, 0.01), "F_z": pulse(35.0, 0.01)}, {"omega0_2": 1.0},
                    "com_vel_x"),
    "clamped": (0.05, 1e-4, {"base_a_z": lambda t: 9.81 * np.sin(40 * t), "tip.F_y": pulse(5.0, 0.01)}, {},
                "tip.acc_z"),
    "free": (0.05, 1e-3, {"tip.F_x": pulse(20.0, 0.01), "bolt.F_y": pulse(-10.0, 0.01)}, {"omega0_1": 2.0},
             "com_vel_x"),
}


def run_fmusim(fmusim: Path, fmu: Path, case: str, env: dict, folder: Path, extra=()) -> subprocess.CompletedProcess:
    """fmusim on ``fmu`` with FMUSIM_CASES[case]'s inputs (a CSV, 17 digits) and start values, writing
    folder/out.csv."""
    stop, interval, inputs, start, _ = FMUSIM_CASES[case]
    folder.mkdir(parents=True, exist_ok=True)
    t = np.arange(0.0, stop + interval / 2, interval)
    np.savetxt(folder / "in.csv", np.column_stack([t, *(f(t) for f in inputs.values())]), delimiter=",",
               header=",".join(["time", *inputs]), comments="", fmt="%.17g")
    command = [str(fmusim), "--interface-type", "cs", "--stop-time", repr(stop), "--output-interval", repr(interval),
               "--input-file", str(folder / "in.csv"), "--output-file", str(folder / "out.csv")]
    for name, value in {**start, **dict(extra)}.items():
        command += ["--start-value", name, repr(value)]
    return subprocess.run([*command, str(fmu)], env=env, cwd=folder, capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)


@pytest.mark.host
def test_fmusim_reports_an_fmus_refusal(native, fmusim, bare, tmp_path):
    """A tolerance out of its range: the FMU refuses it, fmusim prints the FMU's message as [Error] and exits with
    a non-zero status."""
    proc = run_fmusim(fmusim, native["ReframeBody"][3], "ReframeBody", bare, tmp_path, {"tolerance": -1.0})
    text = proc.stdout + proc.stderr
    assert proc.returncode != 0 and "[Error]" in text and "tolerance" in text, describe(proc, bare)


@pytest.mark.host
@pytest.mark.parametrize("name", NATIVE)
def test_fmusim_runs_the_native_fmi3_fmus_with_the_fmi2_numbers(native, fmusim, bare, tmp_path, name):
    """Each native FMI 3.0 FMU in fmusim, bare environment: exit status 0, no message at warning or error level,
    every row, and the same numbers as the FMI 2.0 FMU of the same source in fmusim, printed alike."""
    stop, interval, _, _, moved = FMUSIM_CASES[name]
    rows = {}
    for version in (2, 3):
        proc = run_fmusim(fmusim, native[name][version], name, bare, tmp_path / f"fmi{version}")
        text = proc.stdout + proc.stderr
        assert proc.returncode == 0 and "[Error]" not in text and "[Warning]" not in text, describe(proc, bare)
        lines = (tmp_path / f"fmi{version}" / "out.csv").read_text().splitlines()
        rows[version] = ([column.strip('"') for column in lines[0].split(",")], lines[1:])
    (names, values), (names2, values2) = rows[3], rows[2]
    assert names == names2 and values == values2
    assert len(values) == int(round(stop / interval)) + 1
    table = np.array([[float(x) for x in line.split(",")] for line in values])
    assert np.all(np.isfinite(table))
    assert np.max(np.abs(table[:, names.index(moved)])) > 0     # the inputs reached the FMU
