"""Concurrent first loads of a Python FMU: several host processes that instantiate an FMU of a build none of them has
loaded before, at the same moment, as a co-simulation that starts its FMUs out of process does (ecos' proxyfmu), or
parallel runs of a sweep.  The first load copies the bundled flexfmu to the per-user runtime copy
(docs/fmu.md, "The runtime"); every process must get a working copy: each one instantiates, initialises, steps and
frees.  Each round gets its own empty cache folder (FLEXFMU_CACHE_DIR), so every round is a first load."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

from flexfmu.fmi.diagnostics_host import HOST

LOAD = HOST + r'''
host = Host(CONFIG["fmu"], "first-load")
try:
    host.begin()
    host.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    host.get()
    say(ok=True)
except Exception as exc:
    say(ok=False, detail=f"{type(exc).__name__}: {exc}", messages=[m[:400] for s, m in host.log if s >= 2][:2])
finally:
    if host.component:
        host.free()
'''


def concurrent_first_loads(fmu: Path, *, processes: int = 3, rounds: int = 5, timeout: float = 120.0) -> list[dict]:
    """``rounds`` times, ``processes`` children started together on ``fmu`` with a fresh cache folder: one result per
    child {"label", "status": "OK" | "Error" (a refused instantiate or step) | "crash" | "hang", "expect": "ok",
    "messages"}."""
    results = []
    for round_ in range(rounds):
        cache = tempfile.mkdtemp(prefix="flexfmu-first-load-")
        env = {**os.environ, "FLEXFMU_CACHE_DIR": cache}
        config = json.dumps({"fmu": str(fmu), "scratch": cache})
        try:
            children = [subprocess.Popen([sys.executable, "-c", LOAD, config], stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)
                        for _ in range(processes)]
            for k, child in enumerate(children):
                label = f"round {round_ + 1}, process {k + 1} of {processes}"
                try:
                    stdout, stderr = child.communicate(timeout=timeout)
                except subprocess.TimeoutExpired:
                    os.killpg(child.pid, signal.SIGKILL)
                    child.communicate()
                    results.append({"label": label, "status": "hang", "expect": "ok",
                                    "detail": f"no answer in {timeout:.0f} s"})
                    continue
                answer = next((json.loads(line) for line in stdout.splitlines() if line.startswith('{"ok"')), None)
                if answer is None:
                    results.append({"label": label, "status": "crash", "expect": "ok",
                                    "detail": f"exit status {child.returncode}; stderr: {stderr[-400:]}"})
                elif answer["ok"]:
                    results.append({"label": label, "status": "OK", "expect": "ok"})
                else:
                    results.append({"label": label, "status": "Error", "expect": "ok",
                                    "messages": answer["messages"] or [answer["detail"]],
                                    "internal": [m for m in answer["messages"] if "internal error" in m.lower()]})
        finally:
            shutil.rmtree(cache, ignore_errors=True)
    return results
