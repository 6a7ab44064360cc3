"""Progress of long runs (flexfmu.core.progress): a tqdm bar on a terminal, a line per 10 % in a log."""
from __future__ import annotations

import io
import sys
import time
from pathlib import Path

import pytest

from flexfmu.core import progress
from flexfmu.core.progress import progress_bar
from flexfmu.cosim.masters import load_system, run
from flexfmu.errors import ParameterError

pytestmark = pytest.mark.unit

SYSTEM = Path(__file__).resolve().parents[1] / "examples" / "wave_converter" / "OspSystemStructure.xml"


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


def test_a_log_gets_at_most_a_line_per_tenth_and_no_carriage_return():
    log = io.StringIO()
    with progress_bar(1000, "flexfmu cosim", stream=log, delay=0.0, t_end=10.0) as bar:
        for k in range(1000):
            bar.update_to(k + 1, 0.01 * (k + 1))
    text = log.getvalue()
    lines = text.splitlines()
    assert "\r" not in text and 1 <= len(lines) <= 11
    assert lines[0].startswith("flexfmu cosim: 10 % (t = 1 s of 10 s, ") and "s elapsed" in lines[0]
    assert lines[-1].startswith("flexfmu cosim: 100 % (t = 10 s of 10 s, ")


def test_a_log_counts_tasks_and_writes_the_final_line_once():
    log = io.StringIO()
    bar = progress_bar(3, "sweep", stream=log, delay=0.0, unit="co-simulation")
    for done in (1, 2, 3, 3):
        bar.update_to(done)
    bar.close()
    lines = log.getvalue().splitlines()
    assert [line.split(" (")[0] for line in lines] == ["sweep: 33 %", "sweep: 66 %", "sweep: 100 %"]
    assert "(3 of 3 co-simulations, " in lines[-1]


def test_silent_when_disabled_or_shorter_than_the_delay():
    for kwargs in ({"enabled": False, "delay": 0.0}, {"delay": 60.0}):
        log, tty = io.StringIO(), FakeTerminal()
        for stream in (log, tty):
            with progress_bar(100, "run", stream=stream, **kwargs) as bar:
                for k in range(100):
                    bar.update_to(k + 1, float(k + 1))
        assert log.getvalue() == "" and tty.getvalue() == ""


def test_a_terminal_gets_a_tqdm_bar():
    tty = FakeTerminal()
    with progress_bar(1000, "flexfmu cosim", stream=tty, delay=0.0, t_end=10.0) as bar:
        for k in range(1000):
            bar.update_to(k + 1, 0.01 * (k + 1))
    text = tty.getvalue()
    assert "\r" in text                                   # redrawn in place
    final = text.split("\r")[-1]
    assert final.startswith("flexfmu cosim: 100%|") and "1000/1000" in final and "t = 10 s of 10 s" in final


def test_the_delay_holds_back_the_first_line():
    log = io.StringIO()
    with progress_bar(10, "run", stream=log, delay=0.05) as bar:
        bar.update_to(1)                       # within the delay: nothing
        time.sleep(0.06)
        bar.update_to(2)
        bar.update_to(10)
    lines = log.getvalue().splitlines()
    assert [line.split(" (")[0] for line in lines] == ["run: 20 %", "run: 100 %"]


def test_bad_arguments_name_the_parameter():
    with pytest.raises(ParameterError, match="total"):
        progress_bar(0, "run")
    with pytest.raises(ParameterError, match="delay"):
        progress_bar(10, "run", delay=-1.0)


def test_a_cosimulation_logged_to_a_file_writes_at_most_eleven_lines(tmp_path, monkeypatch):
    monkeypatch.setattr(progress, "DEFAULT_DELAY_S", 0.0)
    system = load_system(SYSTEM)
    log_path = tmp_path / "cosim.log"
    with log_path.open("w") as log:
        monkeypatch.setattr(sys, "stderr", log)
        run(system, 0.2, backend="library", progress=True)
        monkeypatch.setattr(sys, "stderr", sys.__stderr__)
    text = log_path.read_text()
    lines = text.splitlines()
    assert "\r" not in text and 1 <= len(lines) <= 11
    assert lines[-1].startswith("flexfmu cosim: 100 % (t = 0.2 s of 0.2 s, ")
