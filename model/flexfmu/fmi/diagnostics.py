"""Probes of built FMUs as users load them, each in a fresh host process (the venv's Python with fmpy):
a battery of bad values and calls, instantiate/free cycles with the resident memory, and short host
processes run to exit under CPU load.  benchmarks/reliability.py reports them (docs/reliability.md);
the tests assert on them (tests/test_fmu_loading.py)."""
from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

from flexfmu.errors import FlexfmuError

BATTERY = r"""
import json, math, sys, time, shutil
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
path = sys.argv[1]
md = read_model_description(path)
variables = {v.name: v for v in md.modelVariables}
by_kind = lambda kind, causality=None: [v for v in md.modelVariables if v.type == kind
                                        and (causality is None or v.causality == causality)]
outputs = by_kind("Real", "output")
inputs = by_kind("Real", "input")
real_parameters = by_kind("Real", "parameter")
results, slowest, nonfinite = [], 0.0, 0

def fresh(initialised=True):
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="r")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    if initialised:
        fmu.exitInitializationMode()
    return fmu

def attempt(label, action, initialised=True):
    global slowest, nonfinite
    fmu = fresh(initialised)
    tic = time.perf_counter()
    try:
        value = action(fmu)
        status = 0
        if isinstance(value, list) and any(isinstance(x, float) and not math.isfinite(x) for x in value):
            nonfinite += 1
    except Exception as exc:
        status = getattr(exc, "status", -1)
    slowest = max(slowest, time.perf_counter() - tic)
    results.append((label, status))
    fmu.freeInstance()

n_vr = len(md.modelVariables)
out_vr, in_vr = outputs[0].valueReference, inputs[0].valueReference if inputs else None
for bad in (n_vr, n_vr + 7, 2**31 - 1):
    attempt("getReal unknown vr", lambda f: f.getReal([bad]))
    attempt("setReal unknown vr", lambda f: f.setReal([bad], [0.0]))
for kind in ("Integer", "Boolean", "String"):
    for v in by_kind(kind)[:2]:
        attempt(f"getReal of a {kind}", lambda f: f.getReal([v.valueReference]))
        attempt(f"setReal of a {kind}", lambda f: f.setReal([v.valueReference], [1.0]), initialised=False)
for v in outputs[:5]:
    attempt("setReal on an output", lambda f: f.setReal([v.valueReference], [1.0]))
for v in real_parameters[:5]:
    attempt("setReal on a fixed parameter after init", lambda f: f.setReal([v.valueReference], [1.0]))
for bad in (float("nan"), float("inf"), -float("inf")):
    for v in inputs[:6]:
        attempt("non-finite input", lambda f: f.setReal([v.valueReference], [bad]))
    for v in real_parameters[:6]:
        attempt("non-finite parameter", lambda f: f.setReal([v.valueReference], [bad]), initialised=False)
    attempt("non-finite time", lambda f: f.doStep(currentCommunicationPoint=bad, communicationStepSize=1e-3))
    attempt("non-finite step", lambda f: f.doStep(currentCommunicationPoint=0.0, communicationStepSize=bad))
for t in (0.5, -1.0):
    attempt("wrong communication point", lambda f: f.doStep(currentCommunicationPoint=t, communicationStepSize=1e-3))
for h in (0.0, -1e-3):
    attempt("step <= 0", lambda f: f.doStep(currentCommunicationPoint=0.0, communicationStepSize=h))
attempt("second exitInitializationMode", lambda f: f.exitInitializationMode())
attempt("setupExperiment after init", lambda f: f.setupExperiment(startTime=0.0))
attempt("doStep before exitInitializationMode",
        lambda f: f.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3), initialised=False)
def after_terminate(f):
    f.terminate()
    f.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
attempt("doStep after terminate", after_terminate)
def damaged(cut):
    def run(f):
        data = f.serializeFMUstate(f.getFMUstate())
        f.deSerializeFMUstate(cut(data))
    return run
attempt("truncated state", damaged(lambda b: b[: len(b) // 2]))
attempt("garbage state", damaged(lambda b: bytes(len(b))))
attempt("state with garbage payload", damaged(lambda b: b[:60] + b"{" * 100000))
if "max_internal_steps" in variables:          # a step above the cap: fmi2Discard, a smaller one may do
    def over_cap(f):
        f.reset(); f.setupExperiment(startTime=0.0); f.enterInitializationMode()
        f.setInteger([variables["max_internal_steps"].valueReference], [1])
        for name, value in (("integrator", "rk4"), ("scheme", "consistent")):
            if name in variables:
                f.setString([variables[name].valueReference], [value])
        f.exitInitializationMode()
        f.doStep(currentCommunicationPoint=0.0, communicationStepSize=1.0)
    attempt("step above max_internal_steps", over_cap)
attempt("cancelStep", lambda f: f.cancelStep())
attempt("getDirectionalDerivative", lambda f: f.getDirectionalDerivative([out_vr], [in_vr or out_vr], [1.0]))
print(json.dumps({"results": results, "slowest_call_s": slowest, "nonfinite_ok": nonfinite}))
"""

CYCLES = r"""
import sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
path, cycles = sys.argv[1], int(sys.argv[2])
md = read_model_description(path)
unzipped = extract(path)
def rss_kib():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) for l in f if l.startswith("VmRSS"))
samples = {}
for k in range(cycles + 1):
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="c")
    fmu.instantiate(); fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode(); fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    fmu.freeInstance()
    if k in (cycles // 2, cycles):
        samples[k] = rss_kib()
print(samples[cycles // 2], samples[cycles])
"""

EXIT = r"""
import sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
paths, refuse, leave_open = sys.argv[1:-2], sys.argv[-2] == "1", sys.argv[-1] == "1"
kept = []
for path in paths:
    md = read_model_description(path)
    first_real = next(v.valueReference for v in md.modelVariables if v.type == "Real" and v.causality != "output")
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="x")
    fmu.instantiate(); fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode(); fmu.exitInitializationMode()
    for k in range(5):
        if refuse:
            for call in (lambda: fmu.setReal([first_real], [float("nan")]), fmu.exitInitializationMode):
                try:
                    call()
                except Exception:
                    pass
        fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
    if leave_open:
        kept.append(fmu)
    else:
        fmu.terminate(); fmu.freeInstance()
print("done")
"""

STATUS = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal", -1: "crash/other"}


def python(code: str, *args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter like this one (a host process)."""
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=timeout)


def battery(fmu: Path) -> dict:
    """The bad values and calls of BATTERY on ``fmu``: {"results": [(label, status)], "by_status": Counter,
    "ok_labels", "slowest_call_s", "nonfinite_ok"}, or {"crashed": exit status, "stderr"}."""
    out = python(BATTERY, str(fmu))
    if out.returncode != 0:
        return {"crashed": out.returncode, "stderr": out.stderr[-400:]}
    data = json.loads(out.stdout.splitlines()[-1])
    data["by_status"] = Counter(STATUS.get(status, str(status)) for _, status in data["results"])
    data["ok_labels"] = sorted({label for label, status in data["results"] if status == 0})
    return data


def cycles(fmu: Path, n: int) -> tuple[int, int]:
    """Resident memory (KiB) after n/2 and after n load-instantiate-step-free cycles of ``fmu``."""
    out = python(CYCLES, str(fmu), str(n))
    if out.returncode != 0:
        raise FlexfmuError(f"instantiate/free cycles of {fmu.name} crashed: {out.returncode} {out.stderr[-400:]}")
    early, late = map(int, out.stdout.split())
    return early, late


def exit_stress(fmus: list[Path], runs: int) -> Counter:
    """``runs`` host processes of EXIT on ``fmus`` beside a CPU-bound one, alternating refused calls and
    unfreed instances: how many ended each way ("exit 0, clean", else the exit status and stderr)."""
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])     # CPU load beside the runs
    codes = Counter()
    try:
        for run in range(runs):
            out = python(EXIT, *map(str, fmus), str(run % 2), str((run // 2) % 2))
            clean = out.returncode == 0 and "done" in out.stdout and not any(
                bad in out.stderr for bad in ("corrupted", "Segmentation", "double free", "Fatal Python"))
            codes["exit 0, clean" if clean else f"exit {out.returncode}: {out.stderr[-200:]}"] += 1
    finally:
        burner.kill()
        burner.wait()
    return codes
