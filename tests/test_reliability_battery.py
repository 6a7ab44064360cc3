"""The building blocks of the reliability report (benchmarks/reliability.py): the resumable child runner counts a
crash and a hang as one call each and goes on with the next; the tally turns results into the report's defect
counts; the host code's state helpers give a damaged state a valid header.  No FMU is loaded: the children run
small scripts on the report's own host code."""
from __future__ import annotations

import json
import struct
import sys
import zlib

import pytest

from flexfmu.fmi.diagnostics_host import HOST
from flexfmu.fmi.diagnostics_runner import Tally, run_resumable

pytestmark = pytest.mark.unit

SCRIPT = HOST + r'''
def fine():
    return {"status": "OK"}

def segfault():
    ctypes.string_at(0)                     # SIGSEGV: the child dies in the middle of this item

def deadlock():
    time.sleep(600)

def refused():
    return {"status": "Error", "messages": ["refused"]}

def noisy():
    print("RuntimeWarning: overflow", file=sys.stderr)
    return {"status": "OK"}

item("first", "any", fine)
item("crashes", "any", segfault)
item("hangs", "any", deadlock)
item("after the hang", "refuse", refused)
item("noisy", "any", noisy)
item("last", "any", fine)
main()
'''


def test_a_crash_and_a_hang_cost_one_item_each_and_the_run_goes_on():
    results = run_resumable(SCRIPT, {}, item_timeout=3.0, startup_timeout=60.0)
    assert [(r["label"], r["status"]) for r in results] == [
        ("first", "OK"), ("crashes", "crash"), ("hangs", "hang"), ("after the hang", "Error"), ("noisy", "OK"),
        ("last", "OK")]
    assert "exit status -11" in results[1]["detail"]          # the signal, as subprocess reports it
    assert "no answer in 3 s" in results[2]["detail"]
    assert results[4]["stderr"] == "RuntimeWarning: overflow"  # what a call printed on the host's stderr, kept
    assert "stderr" not in results[0] and "stderr" not in results[5]


def test_a_child_that_dies_before_its_first_item_is_one_start_up_crash():
    results = run_resumable("import sys; sys.exit(3)", {}, item_timeout=3.0, startup_timeout=60.0)
    assert [(r["label"], r["status"]) for r in results] == [("start-up", "crash")]


@pytest.mark.parametrize("result, counts", [
    ({"label": "a", "expect": "refuse", "status": "Error"}, (0, 0, 0, 0)),
    ({"label": "a", "expect": "refuse", "status": "OK"}, (1, 0, 0, 0)),
    ({"label": "a", "expect": "refuse", "status": "Warning"}, (1, 0, 0, 0)),
    ({"label": "a", "expect": "ok", "status": "Error"}, (0, 1, 0, 0)),
    ({"label": "a", "expect": "any", "status": "OK", "nonfinite": True}, (0, 0, 1, 0)),
    ({"label": "a", "expect": "any", "status": "Error", "nonfinite": True}, (0, 0, 0, 0)),
    ({"label": "a", "expect": "any", "status": "Error", "internal": ["internal error: KeyError: 'x'"]}, (0, 0, 0, 1)),
    ({"label": "a", "expect": "ok", "status": "OK", "wrong": "clock off"}, (1, 0, 0, 0)),
    ({"label": "flips", "expect": "refuse", "counts": {"Error": 98, "OK": 2}, "wrong_count": 2}, (2, 0, 0, 0)),
])
def test_the_tally_counts_what_would_be_defects(result, counts):
    tally = Tally()
    tally.add("FMU", dict(result))
    assert (tally.silently_wrong, tally.valid_refused, tally.nonfinite_ok, tally.internal) == counts
    assert tally.tried == sum(result.get("counts", {"x": 1}).values())
    assert len(tally.findings) == sum(1 for c in counts if c)


def test_crashes_hangs_and_fatal_are_findings_and_skipped_probes_count_nowhere():
    tally = Tally()
    for status in ("crash", "hang", "Fatal", "OK"):
        tally.add("FMU", {"label": status, "status": status})
    tally.add("FMU", {"label": "nothing logged", "skip": True, "status": "OK"})
    assert (tally.crashes, tally.hangs, tally.by_status["Fatal"], tally.tried, tally.skipped) == (1, 1, 1, 4, 1)
    assert sorted(f["kind"] for f in tally.findings) == ["Fatal", "crash", "hang"]


def test_with_payload_gives_a_changed_payload_a_matching_size_and_crc32(monkeypatch):
    """The header layout of docs/fmu.md ("Serialised FMU states"), built here with struct; the checksum checked with
    zlib over every byte after it."""
    monkeypatch.setattr(sys, "argv", ["host", json.dumps({})])
    namespace = {}
    exec(compile(HOST, "host", "exec"), namespace)
    guid = b"{1234}"
    payload = b"FXNATIVE" + bytes(range(40))
    after_crc = struct.pack("<I", len(guid)) + guid + payload
    blob = (b"FLEXFMU-STATE\n" + struct.pack("<3IQ", 2, 1, 3, len(payload))
            + struct.pack("<I", zlib.crc32(after_crc)) + after_crc)
    header = namespace["state_header"](blob)
    assert (header["payload"], header["payload_at"]) == (len(payload), len(blob) - len(payload))
    new = namespace["with_payload"](blob, payload + b"more")
    changed = namespace["state_header"](new)
    assert changed["payload"] == len(payload) + 4 and new.endswith(payload + b"more")
    assert changed["crc"] == zlib.crc32(new[namespace["CRC_AT"] + 4:])
