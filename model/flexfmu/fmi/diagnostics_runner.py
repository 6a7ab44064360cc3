"""Run a probe script of built FMUs in a child process that may crash or hang, and count what came out.

A probe script (the host code of flexfmu.fmi.diagnostics_host with its items) prints one JSON line ``{"n": N}``,
then for each item ``{"begin": i, "label": ...}`` before it and its result after it.  ``run_resumable`` reads the
lines as they come, with a time limit per item: when the child dies during an item (a crash: a signal, an abort, an
exit in the middle) or says nothing within the limit (a hang: it is killed), that item is recorded as ``crash`` or
``hang`` and a new child resumes with the next item.  So one bad call costs one item, not the whole report.

``Tally`` classifies the results: by status (OK, Warning, Discard, Error, Fatal, crash, hang), and by what would
be a defect: a call that must be refused answered OK (silently wrong, also a probe's own check that failed), a
valid call refused, a non-finite output with OK, an ``internal error`` message, Fatal, a crash, a hang.
"""
from __future__ import annotations

import json
import os
import queue
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections import Counter
from dataclasses import dataclass, field

STATUSES = ("OK", "Warning", "Discard", "Error", "Fatal", "crash", "hang", "host exception")
ACCEPTED = ("OK", "Warning")
REFUSED = ("Discard", "Error", "Fatal")


def _kill(process: subprocess.Popen) -> None:
    """End the child and whatever it started (its own session: start_new_session)."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    process.wait()


def _reader(stream, lines: queue.Queue) -> None:
    for line in stream:
        lines.put(line)
    lines.put(None)


def _tail(path: str, limit: int = 600) -> str:
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    return text[-limit:]


#: The address space a probe's child may take (a parameter that sized an array unchecked would otherwise take the
#: machine's memory; numpy then raises MemoryError, which the FMU reports).  The Python FMUs' interpreter with numpy,
#: scipy and numba maps about 2 GiB.
MEMORY_LIMIT_BYTES = 8 * 2**30


def _limit_memory() -> None:
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


def _written_since(path: str, offset: int, limit: int = 300) -> str:
    with open(path, encoding="utf-8", errors="replace") as f:
        f.seek(offset)
        return f.read(limit).strip()


def run_resumable(script: str, config: dict, *, item_timeout: float = 60.0, startup_timeout: float = 180.0,
                  env: dict | None = None) -> list[dict]:
    """Every item's result of ``script`` (run as ``python -c script CONFIG_JSON``; CONFIG gains "start": the first
    item to run), in order; crashed and hung items as {"i", "label", "status": "crash" | "hang", "detail"}, and a child
    that fails before its first item as one result with label "start-up".  The child's address space is limited to
    MEMORY_LIMIT_BYTES."""
    scratch = tempfile.mkdtemp(prefix="flexfmu-probe-")     # the child's extractions; gone with it
    try:
        return _run_resumable(script, {**config, "scratch": scratch}, item_timeout, startup_timeout, env)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _run_resumable(script, config, item_timeout, startup_timeout, env) -> list[dict]:
    results: list[dict] = []
    start = 0
    while True:
        with tempfile.NamedTemporaryFile("w+", suffix=".stderr", delete=False) as err:
            err_path = err.name
        try:
            with open(err_path, "w") as err_file:
                process = subprocess.Popen([sys.executable, "-c", script, json.dumps({**config, "start": start})],
                                           stdout=subprocess.PIPE, stderr=err_file, text=True, env=env,
                                           start_new_session=True, preexec_fn=_limit_memory)
            lines: queue.Queue = queue.Queue()
            threading.Thread(target=_reader, args=(process.stdout, lines), daemon=True).start()
            current, n_items, resume = None, None, None
            while True:
                try:
                    line = lines.get(timeout=startup_timeout if n_items is None else item_timeout)
                except queue.Empty:
                    _kill(process)
                    if current is None:         # before an item or between two: the child itself hung
                        results.append({"i": start, "label": "start-up" if n_items is None else "between items",
                                        "status": "hang", "detail": f"no answer in {startup_timeout:.0f} s"})
                        return results
                    results.append({**current, "status": "hang",
                                    "detail": f"no answer in {item_timeout:.0f} s; stderr: {_tail(err_path)}"})
                    resume = current["i"] + 1
                    break
                if line is None:                 # the child ended
                    code = process.wait()
                    if current is not None:
                        results.append({**current, "status": "crash",
                                        "detail": f"exit status {code}; stderr: {_tail(err_path)}"})
                        resume = current["i"] + 1
                    elif n_items is None or code != 0:
                        results.append({"i": start, "label": "start-up" if n_items is None else "after the items",
                                        "status": "crash", "detail": f"exit status {code}; stderr: {_tail(err_path)}"})
                    break
                try:
                    message = json.loads(line)
                except ValueError:
                    continue                     # a line the FMU or a library printed
                if not isinstance(message, dict):
                    continue
                if "n" in message:
                    n_items = message["n"]
                elif "begin" in message:
                    current = {"i": message["begin"], "label": message["label"]}
                elif "i" in message:
                    if "stderr_at" in message:   # what the call printed on the host's stderr (e.g. numpy warnings)
                        message["stderr"] = _written_since(err_path, message.pop("stderr_at"))
                    results.append(message)
                    current = None
            process.stdout.close()
        finally:
            os.unlink(err_path)
        if resume is None or n_items is None or resume >= n_items:
            return results
        start = resume


@dataclass
class Tally:
    """Outcomes of many probes of one group: calls by status, and the findings (each a would-be defect)."""
    by_status: Counter = field(default_factory=Counter)
    tried: int = 0
    silently_wrong: int = 0
    valid_refused: int = 0
    nonfinite_ok: int = 0
    internal: int = 0
    skipped: int = 0
    findings: list = field(default_factory=list)

    def add(self, subject: str, result: dict) -> None:
        """Count one result of a probe of ``subject`` (an FMU's or a case's name).  A result stands for
        ``result["counts"]`` calls when it has them (e.g. a chunk of bit flips), else for one call of
        ``result["status"]``; ``expect`` "refuse" makes OK and Warning silently wrong, "ok" makes a refusal a
        valid call refused; ``wrong`` (text) or ``wrong_count`` is a probe's own check that failed."""
        if result.get("skip"):                      # nothing to probe (e.g. a call that logged nothing)
            self.skipped += 1
            return
        counts = Counter(result.get("counts") or {result.get("status", "host exception"): 1})
        self.by_status.update(counts)
        n = sum(counts.values())
        self.tried += n
        label = result.get("label", "?")
        expect = result.get("expect", "any")
        accepted = sum(counts[s] for s in ACCEPTED)
        refused = sum(counts[s] for s in REFUSED)
        wrong = result.get("wrong_count", 1 if result.get("wrong") else 0)
        if expect == "refuse" and accepted and not result.get("counts"):
            wrong = max(wrong, accepted)
            result.setdefault("wrong", f"answered {result.get('status')} where a refusal is due")
        elif expect == "refuse" and accepted:
            wrong = max(wrong, accepted)
        if wrong:
            self.silently_wrong += wrong
            self._finding(subject, label, "silently wrong", result.get("wrong") or f"{wrong} accepted", result)
        if expect == "ok" and refused:
            self.valid_refused += refused
            self._finding(subject, label, "valid call refused", "; ".join(result.get("messages", [])[:1]), result)
        if result.get("nonfinite") and accepted:
            self.nonfinite_ok += 1
            self._finding(subject, label, "non-finite with OK", result.get("nonfinite_detail", ""), result)
        if result.get("internal"):
            self.internal += len(result["internal"])
            self._finding(subject, label, "internal error", result["internal"][0], result)
        for status in ("crash", "hang", "Fatal", "host exception"):
            if counts[status]:
                self._finding(subject, label, status, result.get("detail") or "; ".join(result.get("messages", [])),
                              result)

    def _finding(self, subject, label, kind, detail, result):
        self.findings.append({"subject": subject, "label": label, "kind": kind, "detail": str(detail)[:600],
                              "note": result.get("note", "")})

    def merge(self, other: "Tally") -> None:
        self.by_status.update(other.by_status)
        for name in ("tried", "silently_wrong", "valid_refused", "nonfinite_ok", "internal", "skipped"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.findings += other.findings

    @property
    def crashes(self) -> int:
        return self.by_status["crash"]

    @property
    def hangs(self) -> int:
        return self.by_status["hang"]
