"""Probes of built FMUs as users load them, each in a host process of its own (the venv's Python with fmpy,
never importing flexfmu: a Python FMU needs the process free of another flexfmu build):

- BATTERY, ``battery``: bad values and calls, each on a fresh instance, in a child that a crash or a hang costs one
  call (flexfmu.fmi.diagnostics_runner; the host code: flexfmu.fmi.diagnostics_host);
- ``cycles``: instantiate/free cycles with the resident memory;
- ``exit_stress``: short host processes run to exit under CPU load.

The other probe groups have modules of their own: diagnostics_states (foreign and damaged FMU states),
diagnostics_reentrant (loggers that call back), diagnostics_clock (large start times).  benchmarks/reliability.py
reports them all (docs/reliability.md); tests/test_fmu_loading.py asserts on the cycles and the exit stress.
"""
from __future__ import annotations

import subprocess
import sys
from collections import Counter
from pathlib import Path

from flexfmu.errors import FlexfmuError
from flexfmu.fmi.diagnostics_host import HOST
from flexfmu.fmi.diagnostics_runner import run_resumable

BATTERY = HOST + r"""
PATH = CONFIG["fmu"]
QUICK = CONFIG.get("quick", False)
md = description(PATH)
n_vr = len(md.modelVariables)
outputs, inputs = variables(PATH, "Real", "output"), variables(PATH, "Real", "input")
out_vr, in_vr = outputs[0].valueReference, (inputs[0].valueReference if inputs else None)
NAN, INF = float("nan"), float("inf")


def call(label, expect, action, level="initialised"):
    item(label, expect, lambda: probe(PATH, action, level))


def step_and_read(f, h=1e-3, t=0.0):
    f.doStep(currentCommunicationPoint=t, communicationStepSize=h)
    values = f.get()
    status, clock = f.clock()
    if not math.isfinite(clock):
        raise Wrong(f"fmi2LastSuccessfulTime {clock} after a step answered OK")
    return values


# unknown value references and other types
for bad in (n_vr, n_vr + 7, 2**32 - 1):
    call(f"fmi2GetReal of unknown vr {bad}", "refuse", lambda f, bad=bad: f.getReal([bad]))
    call(f"fmi2SetReal of unknown vr {bad}", "refuse", lambda f, bad=bad: f.setReal([bad], [0.0]), "init")
for kind in ("Integer", "Boolean", "String"):
    for v in variables(PATH, kind)[:2]:
        call(f"fmi2GetReal of a {kind}", "refuse", lambda f, v=v: f.getReal([v.valueReference]))
        call(f"fmi2SetReal of a {kind}", "refuse", lambda f, v=v: f.setReal([v.valueReference], [1.0]), "init")
    call(f"fmi2Get{kind} of a Real", "refuse", lambda f, kind=kind: getattr(f, "get" + kind)([out_vr]))
call("fmi2GetReal of no variables", "ok", lambda f: f.getReal([]))
# what may not be set
for v in outputs[:5]:
    call("fmi2SetReal on an output", "refuse", lambda f, v=v: f.setReal([v.valueReference], [1.0]))
for v in variables(PATH, "Real", "parameter")[:5]:
    call("fmi2SetReal on a parameter after initialisation", "refuse",
         lambda f, v=v: f.setReal([v.valueReference], [v.start and float(v.start) or 1.0]))
for bad in (NAN, INF, -INF):
    for v in inputs[:4]:
        call("non-finite input", "refuse", lambda f, v=v, bad=bad: f.setReal([v.valueReference], [bad]))
    for v in variables(PATH, "Real", "parameter")[:4]:
        call("non-finite parameter", "refuse", lambda f, v=v, bad=bad: f.setReal([v.valueReference], [bad]), "init")
    call("non-finite communication point", "refuse",
         lambda f, bad=bad: f.doStep(currentCommunicationPoint=bad, communicationStepSize=1e-3))
    call("non-finite step", "refuse",
         lambda f, bad=bad: f.doStep(currentCommunicationPoint=0.0, communicationStepSize=bad))
    def bad_start(f, bad=bad):
        f.setupExperiment(startTime=bad)
        f.enterInitializationMode()
        f.exitInitializationMode()
        return step_and_read(f, t=bad)
    call("non-finite start time", "refuse", bad_start, "instantiated")
for v in variables(PATH, "String", "parameter")[:1]:
    def not_utf8(f, v=v):
        vr, text = (ctypes.c_uint * 1)(v.valueReference), (ctypes.c_char_p * 1)(b"\xff\xfe bad")
        status = f.raw("fmi2SetString", f.component, vr, 1, text)
        f.statuses.append(status)
    call("a String that is not UTF-8", "refuse", not_utf8, "init")
# the clock and the step
for t in (0.5, -1.0, 1e-3):
    call("wrong communication point", "refuse",
         lambda f, t=t: f.doStep(currentCommunicationPoint=t, communicationStepSize=1e-3))
for h in (0.0, -1e-3):
    call("step <= 0", "refuse", lambda f, h=h: f.doStep(currentCommunicationPoint=0.0, communicationStepSize=h))
for h in (1e300, 1e-300, 5e-324):
    call(f"step of {h:g} s", "any", lambda f, h=h: step_and_read(f, h))
def overflowing_clock(f):
    step_and_read(f, 1e308)
    return step_and_read(f, 1e308, 1e308)
call("two steps of 1e308 s (the clock overflows)", "refuse", overflowing_clock)
# the call sequence
call("second fmi2ExitInitializationMode", "refuse", lambda f: f.exitInitializationMode())
call("fmi2SetupExperiment after initialisation", "refuse", lambda f: f.setupExperiment(startTime=0.0))
call("fmi2DoStep in initialisation mode", "refuse",
     lambda f: f.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3), "init")
call("fmi2GetRealStatus in initialisation mode", "refuse",
     lambda f: f.statuses.append(f.clock()[0]), "init")
def after_terminate(f):
    f.terminate()
    f.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
call("fmi2DoStep after fmi2Terminate", "refuse", after_terminate)
def terminate_twice(f):
    f.terminate()
    f.terminate()
call("second fmi2Terminate", "refuse", terminate_twice)
def reset_and_rerun(f):
    step_and_read(f)
    f.reset()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    return step_and_read(f)
call("fmi2Reset and a second run", "ok", reset_and_rerun)
if "max_internal_steps" in {v.name for v in md.modelVariables}:      # fmi2Discard: a smaller step may do
    def over_cap(f):
        f.set("max_internal_steps", 1)
        for name, value in (("integrator", "rk4"), ("scheme", "consistent"), ("internal_step", 1e-4)):
            if name in f.vr:
                try:
                    f.set(name, value)
                except FMICallException:
                    del f.statuses[-1]              # fixed at build in a native FMU: not this probe's refusal
        f.exitInitializationMode()
        f.doStep(currentCommunicationPoint=0.0, communicationStepSize=1.0)
    call("step above max_internal_steps", "any", over_cap, "init")
for name, action in (("fmi2CancelStep", lambda f: f.cancelStep()),
                     ("fmi2GetDirectionalDerivative",
                      lambda f: f.getDirectionalDerivative([out_vr], [in_vr or out_vr], [1.0])),
                     ("fmi2SetRealInputDerivatives",
                      lambda f: f.setRealInputDerivatives([in_vr or out_vr], [1], [1.0])),
                     ("fmi2GetRealOutputDerivatives", lambda f: f.getRealOutputDerivatives([out_vr], [1]))):
    call(name, "refuse", action)
# extreme parameter values: whatever the model says, never a crash, a hang, NaN with OK or an internal error
EXTREMES = {"Real": (-1.0, 0.0, 1e308), "Integer": (-1, 2**31 - 1), "String": ("",)}
for kind, values in EXTREMES.items():
    for v in variables(PATH, kind, "parameter")[:2 if QUICK else None]:
        for value in values[:1 if QUICK else None]:
            def extreme(f, v=v, value=value):
                f.set(v.name, value)
                f.exitInitializationMode()
                for name in f.inputs[:3]:               # a load, so that the outputs depend on the parameter
                    f.set(name, 0.5)
                return step_and_read(f)
            call(f"parameter {v.name} = {value!r}", "any", extreme, "init")
main()
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


def battery(fmu: Path, *, quick: bool = False, item_timeout: float = 60.0) -> list[dict]:
    """The bad values and calls of BATTERY on ``fmu``, each on a fresh instance: one result per call
    (flexfmu.fmi.diagnostics_runner: status, expect, messages; crash and hang counted per call)."""
    return run_resumable(BATTERY, {"fmu": str(fmu), "quick": quick}, item_timeout=item_timeout)


def cycles(fmu: Path, n: int) -> tuple[int, int]:
    """Resident memory (KiB) after n/2 and after n load-instantiate-step-free cycles of ``fmu``."""
    out = python(CYCLES, str(fmu), str(n))
    if out.returncode != 0:
        raise FlexfmuError(f"instantiate/free cycles of {fmu.name} crashed: {out.returncode} {out.stderr[-400:]}")
    early, late = map(int, out.stdout.split())
    return early, late


def exit_stress(fmus: list[Path], runs: int, timeout: float = 600) -> Counter:
    """``runs`` host processes of EXIT on ``fmus`` beside a CPU-bound one, alternating refused calls and
    unfreed instances: how many ended each way ("exit 0, clean", a hang after ``timeout`` s, else the exit status and
    stderr)."""
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])     # CPU load beside the runs
    codes = Counter()
    try:
        for run in range(runs):
            try:
                out = python(EXIT, *map(str, fmus), str(run % 2), str((run // 2) % 2), timeout=timeout)
            except subprocess.TimeoutExpired:
                codes[f"hang: no exit within {timeout:.0f} s"] += 1
                continue
            clean = out.returncode == 0 and "done" in out.stdout and not any(
                bad in out.stderr for bad in ("corrupted", "Segmentation", "double free", "Fatal Python"))
            codes["exit 0, clean" if clean else f"exit {out.returncode}: {out.stderr[-200:]}"] += 1
    finally:
        burner.kill()
        burner.wait()
    return codes
