"""docs/reliability.md from the results benchmarks/reliability.py collected: the summary first, then each group's
table, the calls that would be defects with what they said, the cycles and the exit stress."""
from __future__ import annotations

import platform
import re
import time
from collections import Counter

from flexfmu.fmi.diagnostics_clock import CLOCK_ULPS, SAME_RUN_RTOL
from flexfmu.fmi.diagnostics_runner import Tally
from flexfmu.studies.common import provenance

GROUPS = [("battery", "1. Bad values and calls"), ("states", "2. Foreign and damaged states"),
          ("reentrant", "3. Loggers that call back"), ("clock", "4. Large start times")]
#: a call slower than this is listed among the observations
SLOW_CALL_S = 5.0
SUMMARY_COLUMNS = ("crash", "hang", "silently wrong", "internal error", "Fatal", "non-finite with OK",
                   "valid call refused", "other")


def tallies(data, group) -> dict:
    out = {}
    for fmu in data["fmus"]:
        tally = Tally()
        for result in data[group][fmu.name]:
            tally.add(fmu.name, result)
        out[fmu.name] = tally
    return out


def load_tallies(data) -> dict:
    out = {}
    for name, results in data["loads"].items():
        out[name] = Tally()
        for result in results:
            out[name].add(name, result)
    return out


def _total(per_fmu: dict) -> Tally:
    total = Tally()
    for tally in per_fmu.values():
        total.merge(tally)
    return total


def _defects(t: Tally) -> dict:
    return {"crash": t.crashes, "hang": t.hangs, "silently wrong": t.silently_wrong, "internal error": t.internal,
            "Fatal": t.by_status["Fatal"], "non-finite with OK": t.nonfinite_ok, "valid call refused": t.valid_refused,
            "other": t.by_status["host exception"]}


def _cli_defects(cases) -> dict:
    kinds = Counter(c["kind"] for c in cases)
    return {"crash": kinds["crash"], "hang": kinds["hang"], "silently wrong": kinds["exit 0"],
            "internal error": kinds["traceback"] + kinds["internal error"], "Fatal": 0, "non-finite with OK": 0,
            "valid call refused": kinds["control failed"], "other": kinds["other"] + kinds["inconclusive"]}


def _row(cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _escape(text: str, limit: int = 220) -> str:
    text = re.sub(r"\s+", " ", str(text)).strip()
    text = text if len(text) <= limit else text[:limit - 1] + "…"
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace("|", "\\|")


def summary(data, groups: dict) -> list[str]:
    lines = ["## Summary", "",
             "Per group: the calls or cases tried and how many ended in each kind of defect (target: all 0). "
             "*silently wrong*: a call that must be refused answered OK (or a probe's own check failed: a clock off "
             "the host's, outputs that differ); *valid call refused*: a call the FMU must take refused; *other*: a "
             "probe that could not run (host exception) or, for the CLI, an outcome neither good nor counted (exit "
             "status other than 2, more than one line).", "",
             _row(["group", "FMUs / cases", "calls / cases", *SUMMARY_COLUMNS]),
             _row(["---"] * (3 + len(SUMMARY_COLUMNS)))]
    totals = Counter()
    n_tried = 0
    for key, title in GROUPS:
        total = _total(groups[key])
        defects = _defects(total)
        totals.update(defects)
        n_tried += total.tried
        lines.append(_row([title, len(groups[key]), total.tried, *defects.values()]))
    cli = _cli_defects(data["cli"])
    totals.update(cli)
    n_tried += len(data["cli"])
    lines.append(_row(["5. CLI and system files", len(data["cli"]), len(data["cli"]), *cli.values()]))
    loads = _total(load_tallies(data))
    totals.update(_defects(loads))
    n_tried += loads.tried
    lines.append(_row(["6. Concurrent first loads", len(data["loads"]), loads.tried, *_defects(loads).values()]))
    cycle_failures = Counter(r.get("failure") for r in data["cycles"].values() if r.get("failure"))
    cycles = dict.fromkeys(SUMMARY_COLUMNS, 0)
    cycles.update({"crash": cycle_failures["crash"], "hang": cycle_failures["hang"]})
    totals.update(cycles)
    n_cycles = data["config"]["cycles"] * len(data["cycles"])
    n_tried += n_cycles
    lines.append(_row(["Instantiate/free cycles", len(data["cycles"]), n_cycles, *cycles.values()]))
    exits = dict.fromkeys(SUMMARY_COLUMNS, 0)
    for label, count in data["exit"].items():
        if label.startswith("hang"):
            exits["hang"] += count
        elif label != "exit 0, clean":
            exits["crash"] += count
    totals.update(exits)
    n_tried += sum(data["exit"].values())
    lines.append(_row(["Exit-code stress", len(data["exit_fmus"]), sum(data["exit"].values()), *exits.values()]))
    lines.append(_row(["**total**", "", f"**{n_tried}**", *(f"**{totals[c]}**" for c in SUMMARY_COLUMNS)]))
    return lines


def battery_section(data, per_fmu) -> list[str]:
    lines = ["## 1. Bad values and calls", "",
             "Each call on a fresh instance: unknown value references and other types, outputs and "
             "fixed parameters set, NaN and infinite values, non-finite start times, a String that is not UTF-8, wrong "
             "communication points, steps <= 0, of 1e300, 1e-300 and 5e-324 s and a clock that overflows, calls out of "
             "sequence, the unsupported functions, a step above max_internal_steps, and every parameter at extreme "
             "values (Real -1, 0, 1e308; Integer -1, 2^31 - 1; String empty) followed by a loaded step whose outputs "
             "must be finite.", "",
             _row(["FMU", "tried", "OK", "Warning", "Discard", "Error", "Fatal", "crash", "hang", "wrong",
                   "internal", "non-finite OK", "slowest call (s)"]), _row(["---"] * 13)]
    for fmu in data["fmus"]:
        t = per_fmu[fmu.name]
        slowest = max((r.get("seconds", 0.0) for r in data["battery"][fmu.name]), default=0.0)
        s = t.by_status
        lines.append(_row([fmu.name, t.tried, s["OK"], s["Warning"], s["Discard"], s["Error"], s["Fatal"], s["crash"],
                           s["hang"], t.silently_wrong, t.internal, t.nonfinite_ok, f"{slowest:.2f}"]))
    lines += ["", "Extreme parameter values the FMUs accepted (initialised and stepped with finite outputs; each "
              "FMU's own range check is the judge, listed for review):", ""]
    for fmu in data["fmus"]:
        accepted = {}
        for r in data["battery"][fmu.name]:
            m = re.match(r"parameter (\S+) = (.*)", r["label"])
            if m and r.get("status") in ("OK", "Warning"):
                accepted.setdefault(m.group(1), []).append(m.group(2))
        if accepted:
            lines.append(f"- {fmu.name}: " + "; ".join(f"`{k}` {', '.join(v)}" for k, v in accepted.items()))
    return lines


def states_section(data, per_fmu) -> list[str]:
    lines = ["## 2. Foreign and damaged states", "",
             "Per FMU, from a state taken after three loaded steps: the in-memory state of another FMU and of the "
             "other runtime's FMU of the same model (fmi2SetFMUstate, fmi2SerializedFMUstateSize) and their "
             "serialised states; every single-bit flip of the serialised state (a sample when it is larger than 8 "
             "KiB: every header bit and `--flips` others, seeded); truncations and extensions; payloads changed on "
             "purpose with the CRC-32 stamped again (tests/fmu_helpers.py's restamp_crc): NaN or infinity in the "
             "times, values, held inputs, outputs and state vector, 1e300 in the state, another layout version, "
             "sizes or flags, and for Python FMUs NaN or 1e999 in the simulator's JSON, another format or model, "
             "the JSON cut short. Controls: the state restored, and one taken before initialisation.", "",
             _row(["FMU", "state bytes", "bit flips refused", "foreign refused", "truncated/extended refused",
                   "restamped refused", "controls OK", "crash", "hang", "wrong", "non-finite OK"]),
             _row(["---"] * 11)]
    for fmu in data["fmus"]:
        results = data["states"][fmu.name]
        t = per_fmu[fmu.name]

        def share(pattern):
            chosen = [r for r in results if re.search(pattern, r["label"])]
            tried = sum(sum((r.get("counts") or {"x": 1}).values()) for r in chosen)
            refused = sum(sum(v for k, v in (r.get("counts") or {r.get("status"): 1}).items()
                              if k in ("Error", "Discard", "Fatal")) for r in chosen)
            return f"{refused} / {tried}"
        size = next((re.search(r"of (\d+) bytes", r["label"]).group(1) for r in results
                     if r["label"].startswith("truncated to")), "?")
        controls = [r for r in results if "(control)" in r["label"]]
        lines.append(_row([fmu.name, size, share(r"^single-bit flips"), share(r"state of (the other|another)"),
                           share(r"^(truncated|extended)"), share(r"^restamped"),
                           f"{sum(r.get('status') == 'OK' for r in controls)} / {len(controls)}",
                           t.crashes, t.hangs, t.silently_wrong, t.nonfinite_ok]))
    return lines


def reentrant_section(data, per_fmu) -> list[str]:
    lines = ["## 3. Loggers that call back", "",
             "A logger callback that calls fmi2GetReal, fmi2GetRealStatus or fmi2DoStep into the instance whose call "
             "is "
             "logging (at most 3 calls per probe), during a refused fmi2DoStep at a wrong time, an fmi2DoStep out of "
             "sequence, a refused fmi2SetReal of NaN, fmi2ExitInitializationMode, fmi2SetDebugLogging with an "
             "unknown category and fmi2Terminate (the last three only when they log). Each on a fresh instance, in "
             "a child process killed after 30 s without an answer (a deadlock is a hang). Must be: every call from "
             "the logger refused (fmi2Error), the refused outer calls still refused, a message naming the refusal, "
             "and the instance answering fmi2GetReal afterwards.", "",
             _row(["FMU", "probes", "calls back refused", "calls that logged nothing (no probe)", "crash", "hang",
                   "wrong"]),
             _row(["---"] * 7)]
    for fmu in data["fmus"]:
        t = per_fmu[fmu.name]
        lines.append(_row([fmu.name, t.tried, t.by_status["Error"], t.skipped, t.crashes, t.hangs, t.silently_wrong]))
    return lines


def clock_section(data, per_fmu) -> list[str]:
    steps = data["config"]["clock_steps"]
    lines = ["## 4. Large start times", "",
             f"fmi2SetupExperiment(startTime = t0) with t0 = 1e6 s and 1e9 s, three inputs at 0.5, then {steps} steps "
             "of 1 ms: a host passing h = t(k+1) - t(k) with t(k) = t0 + k h must find fmi2LastSuccessfulTime within "
             f"{CLOCK_ULPS} eps |t| of its t(k+1) after every step; a skipped step (t(N) + h) and a repeated one "
             f"(t(N - 1)) must be refused; a rollback with fmi2SetFMUstate and the last step again must give the same "
             "outputs bit for bit; a host passing the constant h from t0 must get the outputs of the same run "
             f"from 0 (to {SAME_RUN_RTOL:g} of the largest output: the models are time-invariant).", "",
             _row(["FMU", "t0", "clock steps", "skipped refused", "repeated refused", "rollback, step again",
                   "same as from 0"]),
             _row(["---"] * 7)]
    for fmu in data["fmus"]:
        results = data["clock"][fmu.name]
        for t0 in ("1e+06", "1e+09"):
            mine = {re.sub(r"^t0 = \S+: ", "", r["label"]): r for r in results if r["label"].startswith(f"t0 = {t0}:")}

            def cell(prefix):
                r = next((v for k, v in mine.items() if k.startswith(prefix)), None)
                if r is None:
                    return "—"
                text = r.get("status", "?")
                if r.get("wrong"):
                    text += " **wrong**: " + _escape(r["wrong"], 120)
                elif r.get("note"):
                    text += ": " + _escape(r["note"], 90)
                return text
            lines.append(_row([fmu.name, t0, cell(f"{steps} steps of"), cell("a skipped"), cell("a repeated"),
                               cell("a rollback"), cell(f"{steps} constant")]))
    return lines


def cli_section(data) -> list[str]:
    lines = ["## 5. CLI and system files", "",
             f"`python -m flexfmu ...` in a process of its own (killed after 180 s), run from {data['cli_from']} so "
             "that "
             "our fmpy master can load the FMUs (one process holds one flexfmu build). The broken files are the "
             "wave-energy converter's example with one change; the cosim cases with `--t-end 0.01 --fmu-dir DIST` "
             "and each master; the power-matrix cases with one cell, one seed, `--serial --t-end 0.1`. Good: exit 2 "
             "and one line, no traceback; the controls must exit 0.", "",
             _row(["case", "exit", "outcome", "first line of stderr"]), _row(["---"] * 4)]
    for case in data["cli"]:
        lines.append(_row([_escape(case["label"], 80), case["exit"], case["kind"],
                           _escape(case["first_line"] or case.get("detail", ""), 160)]))
    return lines


def loads_section(data) -> list[str]:
    config = data["config"]
    lines = ["## 6. Concurrent first loads", "",
             f"{config['first_load_processes']} host processes started together on a Python FMU whose build none of "
             f"them has loaded (an empty cache folder, FLEXFMU_CACHE_DIR, per round), {config['first_load_rounds']} "
             "rounds: the first load copies the bundled flexfmu to the per-user runtime copy (docs/fmu.md, 'The "
             "runtime'), and every process must instantiate, initialise and step. The other groups' Python FMUs were "
             "loaded once before they started, so they do not meet this.", "",
             _row(["FMU", "processes", "OK", "refused", "crash", "hang", "what a refused one said"]),
             _row(["---"] * 7)]
    for name, tally in load_tallies(data).items():
        said = next((r["messages"][0] for r in data["loads"][name] if r.get("messages")), "")
        lines.append(_row([name, tally.tried, tally.by_status["OK"], tally.valid_refused, tally.crashes, tally.hangs,
                           _escape(said, 200)]))
    return lines


def findings_section(data, groups) -> list[str]:
    lines = ["## Findings", "",
             "Every call or case above counted as a defect, with what the FMU or CLI said.", ""]
    found = []
    for key, title in GROUPS:
        for tally in groups[key].values():
            found += [(title, f) for f in tally.findings]
    for tally in load_tallies(data).values():
        found += [("6. Concurrent first loads", f) for f in tally.findings]
    for case in data["cli"]:
        if case["kind"] not in ("good", "control ok"):
            found.append(("5. CLI and system files", {"subject": "flexfmu", "label": case["label"],
                                                      "kind": case["kind"], "detail": case.get("detail", ""),
                                                      "note": ""}))
    for name, r in data["cycles"].items():
        if r.get("failure"):
            found.append(("Instantiate/free cycles", {"subject": name, "label": "cycles", "kind": r["failure"],
                                                      "detail": r["detail"], "note": ""}))
    for label, count in data["exit"].items():
        if label != "exit 0, clean":
            found.append(("Exit-code stress", {"subject": ", ".join(data["exit_fmus"]), "label": f"{count} runs",
                                               "kind": "exit", "detail": label, "note": ""}))
    if not found:
        return lines + ["None."]
    lines += [_row(["group", "FMU / command", "call or case", "kind", "what it said"]), _row(["---"] * 5)]
    for title, f in found:
        detail = f["detail"] + (f" ({f['note']})" if f.get("note") else "")
        lines.append(_row([title.split(". ", 1)[-1], f["subject"], _escape(f["label"], 90), f["kind"],
                           _escape(detail, 300)]))
    return lines


def observations_section(data) -> list[str]:
    """What is not counted as a defect but a user may meet: calls that printed on the host's stderr, slow calls."""
    noisy, slow = [], []
    for key, title in GROUPS:
        for fmu in data["fmus"]:
            for r in data[key][fmu.name]:
                if r.get("stderr"):
                    noisy.append(_row([title.split(". ", 1)[-1], fmu.name, _escape(r["label"], 90), r.get("status"),
                                       _escape(r["stderr"], 200)]))
                if r.get("seconds", 0.0) > SLOW_CALL_S:
                    slow.append(f"- {fmu.name}, {r['label']}: {r['seconds']:.1f} s ({r.get('status')})")
    lines = ["## Observations (not counted)", "",
             "Calls that printed on the host's stderr (a Python FMU's warnings reach the host's own stderr):", ""]
    if noisy:
        lines += [_row(["group", "FMU", "call", "status", "printed"]), _row(["---"] * 5)] + noisy
    else:
        lines.append("None.")
    lines += ["", f"Calls slower than {SLOW_CALL_S:.0f} s:", ""] + (slow or ["None."])
    return lines


def cycles_section(data) -> list[str]:
    n = data["config"]["cycles"]
    lines = [f"## Instantiate/free cycles ({n} per FMU)", "",
             "Each cycle loads the library, instantiates, initialises, takes one step and frees (fmpy unloads the "
             "library); resident memory after half of the cycles (Python's own caches and arenas fill during the first "
             "few hundred) and after all of them.", "",
             _row(["FMU", "RSS at half (KiB)", "RSS at end (KiB)", "growth per cycle (B)"]), _row(["---"] * 4)]
    for fmu in data["fmus"]:
        r = data["cycles"][fmu.name]
        if r.get("failure"):
            lines.append(_row([fmu.name, "—", "—", f"{r['failure']}: {_escape(r['detail'], 100)}"]))
        else:
            lines.append(_row([fmu.name, r["early"], r["late"], f"{1024 * (r['late'] - r['early']) / (0.5 * n):.0f}"]))
    return lines


def render(data, dist) -> str:
    groups = {key: tallies(data, key) for key, _ in GROUPS}
    fmus = data["fmus"]
    config = data["config"]
    seconds = data["seconds"]
    timing = ", ".join(f"{k} {v:.0f} s" for k, v in seconds.items())
    lines = ["# Reliability report", "", f"Made from {provenance()}.", "",
             f"Generated by `benchmarks/reliability.py{' --quick' if config['quick'] else ''}` on "
             f"{time.strftime('%Y-%m-%d')} ({platform.platform()}, Python {platform.python_version()}) in "
             f"{data['total_seconds'] / 60:.1f} min (wall time of each group's probes, two at a time: {timing}). "
             f"FMUs: the Python FMUs of `{dist.name}/` ({', '.join(f.name for f in fmus if f.group == 'dist')}), "
             "native FFRBeam and ReframeBody built by `flexfmu.fmi.native.build_registry_fmu`, and the paper's plate "
             "on a coarse mesh exported clamped (ClampedPlate) and free (FreePlate) in both runtimes "
             "(`flexfmu.fmi.export.export_fmu`; benchmarks/reliability_fmus.py). Every probe runs through fmpy's "
             "FMU2Slave in a child process per FMU and group with a time limit per call: a crash or a hang ends that "
             "call only, is counted, and a new child goes on with the next call "
             "(`flexfmu.fmi.diagnostics_runner`).", "",
             "Run it: `flexfmu build --out DIR && python benchmarks/reliability.py --dist DIR` (about 4 minutes on two "
             "cores; `--quick` for a smoke run of a few minutes).", ""]
    lines += summary(data, groups) + [""]
    lines += battery_section(data, groups["battery"]) + [""]
    lines += states_section(data, groups["states"]) + [""]
    lines += reentrant_section(data, groups["reentrant"]) + [""]
    lines += clock_section(data, groups["clock"]) + [""]
    lines += cli_section(data) + [""]
    lines += loads_section(data) + [""]
    lines += findings_section(data, groups) + [""]
    lines += observations_section(data) + [""]
    lines += cycles_section(data) + [""]
    lines += [f"## Exit-code stress ({sum(data['exit'].values())} host processes under CPU load)", "",
              f"Each process loads {', '.join(data['exit_fmus'])}, steps each, and exits; half of them make refused "
              "calls (a NaN input or parameter, a second exitInitializationMode) every step, half leave their "
              "instances unfreed.", ""]
    lines += [f"- {_escape(label, 300)}: {count}" for label, count in data["exit"].items()]
    lines += ["", "## Hosts", "",
              "fmpy (this report and the test suite), libcosim (`tests/test_fmu_hosts.py`), the ecos CLI with "
              "proxyfmu (`tests/test_fmu_ecos.py`) and a C host in a bare environment (`tests/test_fmu_c_host.py`, "
              "`tests/test_fmu_loading.py`) run in `python3 tasks.py test`; see docs/fmu.md, 'Hosts'.", ""]
    return "\n".join(lines)
