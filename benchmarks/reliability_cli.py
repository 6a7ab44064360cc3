"""`flexfmu cosim` and `flexfmu wec power-matrix` on broken system files and failing arguments, each in its own
process with a time limit, classified by what a user sees.

Good: exit status 2 and one error line on stderr ("flexfmu: error: ..."; a progress line before it is noted), no
traceback.  Bad: a traceback (counted as an
internal error), exit 0 for a broken case (silently wrong), a hang (killed after the limit), a signal (crash), or
anything else (another exit status, more than one line).  The controls (an intact file) must exit 0.

The broken files are the wave-energy converter's example (examples/wave_converter/OspSystemStructure.xml) with one
thing changed, as tests/test_cosim_system_errors.py makes them; written beside nothing, so the FMUs come from
``--fmu-dir`` (the report's Python FMUs).  Each cosim case runs with the library master (no FMU loaded) and with our
fmpy master over the FMUs.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"

_PTO_SOURCE = '<Simulator name="pto" source="../../dist/PTO.fmu">'
_FIRST_CONNECTION = """<VariableConnection>
            <Variable simulator="wave" name="F_x" />"""
_DAMPING = '<InitialValue variable="damping">\n                    <Real value="2.0" />'
_SECOND_INTO_WAVE_F_X = """<VariableConnection>
            <Variable simulator="hydro" name="F_z" />
            <Variable simulator="platform" name="wave_F_x" />
        </VariableConnection>
        """

#: (label, old text, new text): the example with one change
BROKEN_FILES = [
    ("empty BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize></BaseStepSize>"),
    ("textual BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize>fast</BaseStepSize>"),
    ("empty Algorithm", "<Algorithm>fixedStep</Algorithm>", "<Algorithm/>"),
    ("InitialValue with two values", '<Real value="2.0" />', '<Real value="2.0" /><Real value="3.0" />'),
    ("unknown value type", _DAMPING, _DAMPING.replace("Real", "Float")),
    ('Real value "abc"', '<Real value="2.0" />', '<Real value="abc" />'),
    ("Simulator without source", _PTO_SOURCE, '<Simulator name="pto">'),
    ("connection with three variables", _FIRST_CONNECTION,
     _FIRST_CONNECTION + '\n            <Variable simulator="hydro" name="F_x" />'),
    ("two simulators with one name", '<Simulator name="hydro"', '<Simulator name="pto"'),
    ("StartTime nan", "<StartTime>0.0</StartTime>", "<StartTime>nan</StartTime>"),
    ("two connections into one input", _FIRST_CONNECTION, _SECOND_INTO_WAVE_F_X + _FIRST_CONNECTION),
]
#: (label, extra arguments) on the intact example
BAD_ARGUMENTS = [("--t-end 1e300", ["--t-end", "1e300"]), ("--step 1e-300", ["--t-end", "0.01", "--step", "1e-300"])]

SMALL = """<?xml version="1.0" encoding="utf-8"?>
<OspSystemStructure xmlns="http://opensimulationplatform.com/MSMI/OSPSystemStructure" version="0.1">
    <BaseStepSize>0.001</BaseStepSize>
    <Simulators>
        <Simulator name="pto" source="PTO.fmu" />
    </Simulators>
</OspSystemStructure>
"""


@dataclass
class CliCase:
    label: str
    argv: list
    expect_exit: int = 2          # 0 for a control


def cosim_cases(folder: Path, dist: Path, *, masters=("library", "fmpy")) -> list[CliCase]:
    """The broken files and arguments, written under ``folder``, for each master; the controls."""
    text = EXAMPLE.read_text()
    cases = []
    for k, (label, old, new) in enumerate(BROKEN_FILES):
        if old not in text:
            raise ValueError(f"the example has changed: {old!r} not in {EXAMPLE}")
        path = folder / f"cosim_{k}" / "OspSystemStructure.xml"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text.replace(old, new, 1))
        for master in masters:
            cases.append(CliCase(f"cosim: {label} ({master})", ["cosim", str(path), "--t-end", "0.01", "--master",
                                                                 master, "--fmu-dir", str(dist)]))
    for label, extra in BAD_ARGUMENTS:
        for master in masters:
            cases.append(CliCase(f"cosim: {label} ({master})",
                                 ["cosim", str(EXAMPLE), "--master", master, "--fmu-dir", str(dist), *extra]))
    not_zip = folder / "not_zip"
    not_zip.mkdir(parents=True, exist_ok=True)
    (not_zip / "PTO.fmu").write_text("not a zip archive")
    (not_zip / "OspSystemStructure.xml").write_text(SMALL)
    cases.append(CliCase("cosim: source not a zip (fmpy)",
                         ["cosim", str(not_zip / "OspSystemStructure.xml"), "--t-end", "0.01", "--master", "fmpy"]))
    for master in masters:
        cases.append(CliCase(f"cosim: intact file, control ({master})",
                             ["cosim", str(EXAMPLE), "--t-end", "0.01", "--master", master, "--fmu-dir", str(dist)],
                             expect_exit=0))
    return cases


def power_matrix_cases(folder: Path, dist: Path) -> list[CliCase]:
    """flexfmu wec power-matrix: bad arguments, a missing FMU, runs that all fail; a control."""
    empty = folder / "no_fmus"
    empty.mkdir(parents=True, exist_ok=True)
    failing = folder / "failing" / "OspSystemStructure.xml"
    failing.parent.mkdir(parents=True, exist_ok=True)
    failing.write_text(EXAMPLE.read_text().replace('<Real value="2.0" />', '<Real value="-1.0" />', 1))

    def argv(tag, *extra, system=EXAMPLE):
        out = folder / f"pm_{tag}"
        return ["wec", "power-matrix", str(system), "--hs", "0.05", "--tp", "1.4", "--seeds", "1", "--serial",
                "--t-end", "0.1", "--out", str(out / "m.csv"), "--plot", str(out / "m.png"), *extra]
    for tag in ("control", "t_end", "step", "missing", "failing"):
        (folder / f"pm_{tag}").mkdir(parents=True, exist_ok=True)
    return [CliCase("power-matrix: --t-end -1", argv("t_end", "--t-end", "-1")),
            CliCase("power-matrix: --step 0", argv("step", "--step", "0")),
            CliCase("power-matrix: a missing FMU", argv("missing", "--backend", "fmu", "--fmu-dir", str(empty))),
            CliCase("power-matrix: every run fails (PTO damping -1)",
                    argv("failing", "--backend", "fmu", "--fmu-dir", str(dist), system=failing)),
            CliCase("power-matrix: intact, control", argv("control"), expect_exit=0)]


#: what a case's outcome counts as: good, or the kind of defect (the report's summary columns)
KINDS = ("good", "control ok", "traceback", "internal error", "exit 0", "hang", "crash", "other", "control failed",
         "inconclusive")


def bundled_flexfmu(fmu: Path, folder: Path) -> Path:
    """The flexfmu package a Python FMU bundles (resources/flexfmu), extracted under ``folder``: the folder to put on
    PYTHONPATH so that the CLI is the same build as the FMUs it loads (one process holds one flexfmu build)."""
    with zipfile.ZipFile(fmu) as archive:
        for name in archive.namelist():
            if name.startswith("resources/flexfmu/"):
                archive.extract(name, folder)
    return folder / "resources"


def run_case(case: CliCase, *, timeout: float = 180.0, pythonpath: Path | None = None) -> dict:
    """``python -m flexfmu`` with the case's arguments (``pythonpath``: where flexfmu is imported from, else the
    installed one): {"label", "kind" (one of KINDS), "exit", "first_line", "lines" (non-empty lines on stderr),
    "detail"}."""
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(pythonpath), env.get("PYTHONPATH")]))
    process = subprocess.Popen([sys.executable, "-m", "flexfmu", *case.argv], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True, cwd=ROOT, env=env)
    try:
        stdout, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        return {"label": case.label, "kind": "hang", "exit": None, "first_line": "", "lines": 0,
                "detail": f"killed after {timeout:.0f} s: flexfmu " + " ".join(case.argv)}
    code = process.returncode
    lines = [line for line in stderr.splitlines() if line.strip()]
    first = lines[0][:300] if lines else ""
    errors = [line for line in lines if line.startswith("flexfmu: error: ")]
    result = {"label": case.label, "exit": code, "first_line": first, "lines": len(lines), "detail": ""}
    if "Traceback" in stderr or "Traceback" in stdout:
        text = stderr if "Traceback" in stderr else stdout
        kind, result["detail"] = "traceback", text[-400:]
    elif code < 0:
        kind, result["detail"] = "crash", f"signal {-code}: {stderr[-300:]}"
    elif "internal error" in (stderr + stdout).lower():
        kind = "internal error"
        result["detail"] = next(line for line in (stderr + stdout).splitlines() if "internal error" in line.lower())
    elif "is already imported in this process" in stderr:
        kind = "inconclusive"
        result["detail"] = "the FMUs are another flexfmu build than the CLI's own: " + first
    elif case.expect_exit == 0:
        kind = "control ok" if code == 0 else "control failed"
        result["detail"] = "" if code == 0 else stderr[-300:]
    elif code == 0:
        kind, result["detail"] = "exit 0", "the broken case ran: " + stdout[-200:]
    elif code == 2 and len(errors) == 1:
        kind = "good"
        result["first_line"] = errors[0][:300]
        if len(lines) > 1:                       # e.g. the sweep's progress line before the error
            result["detail"] = f"exit 2, one error line (and {len(lines) - 1} other line(s) on stderr: {lines[0][:80]})"
    else:
        kind, result["detail"] = "other", f"exit {code}, {len(lines)} lines on stderr: {stderr[-300:]}"
    result["kind"] = kind
    return result
