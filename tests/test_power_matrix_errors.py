"""`flexfmu wec power-matrix` on bad input and failing runs: its arguments and the system are checked before any
co-simulation (exit 2, one line, nothing written); runs that fail make it exit non-zero, saying how many failed,
why, and the first one's message; an empty matrix is never written."""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from fmu_helpers import ROOT

from flexfmu import cli
from flexfmu.errors import FlexfmuError, ParameterError
from flexfmu.wec import system as wec_system
from flexfmu.wec.sweeps import PowerMatrix

SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"


def _power_matrix(tmp_path, *argv, system=SYSTEM) -> int:
    return cli.main(["wec", "power-matrix", str(system), "--hs", "0.05", "--tp", "1.4", "--seeds", "2", "--serial",
                     "--t-end", "0.1", "--out", str(tmp_path / "m.csv"), "--plot", str(tmp_path / "m.png"), *argv])


def _written(tmp_path) -> list:
    return sorted(p.name for p in tmp_path.iterdir() if p.suffix in (".csv", ".png"))


@pytest.fixture
def no_runs(monkeypatch):
    """Any co-simulation fails the test: the refusals must come before the first run."""
    def run_case(*args, **kwargs):
        raise AssertionError("a co-simulation ran")
    monkeypatch.setattr(wec_system, "run_case", run_case)


@pytest.mark.parametrize("argv, words", [
    (["--t-end", "-1"], ["t-end", "> start time 0"]),
    (["--t-end", "nan"], ["t-end", "finite"]),
    (["--t-end", "1e300"], ["t-end, step", "GiB"]),
    (["--step", "0"], ["step", "> 0"]),
    (["--step", "-0.001"], ["step", "> 0"]),
    (["--step", "nan"], ["step", "finite"]),
    (["--step", "0.03"], ["step", "divide"]),
    (["--max-steepness", "1e-9"], ["max-steepness", "steeper"]),
    (["--max-steepness", "nan"], ["max-steepness"]),
    (["--workers", "0"], ["workers"]),
])
def test_arguments_are_checked_before_any_run(argv, words, tmp_path, capsys, no_runs):
    assert _power_matrix(tmp_path, *argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("flexfmu: error: "), err
    for word in words:
        assert word in err, (word, err)
    assert _written(tmp_path) == []


def test_a_missing_fmu_is_refused_before_any_run(tmp_path, capsys, no_runs):
    empty = tmp_path / "no_fmus"
    empty.mkdir()
    assert _power_matrix(tmp_path, "--backend", "fmu", "--fmu-dir", str(empty)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{SYSTEM}:7 <Simulator name=\"wave\">" in err and "not found" in err, err
    assert _written(tmp_path) == []


@pytest.mark.parametrize("old, new, words", [
    ('<InitialValue variable="damping">', '<InitialValue variable="dampening">', ["pto has no parameter 'dampening'"]),
    ('<Variable simulator="pto" name="F_z" />', '<Variable simulator="pto" name="F_zz" />',
     ["pto has no input or output 'F_zz'"]),
    ("<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize>0</BaseStepSize>", ["<BaseStepSize>", "> 0"]),
], ids=["unknown start value", "unknown connection variable", "zero BaseStepSize"])
def test_a_bad_system_file_is_refused_before_any_run(old, new, words, tmp_path, capsys, no_runs):
    text = SYSTEM.read_text()
    assert old in text
    path = tmp_path / "system" / "OspSystemStructure.xml"
    path.parent.mkdir()
    path.write_text(text.replace(old, new, 1))
    assert _power_matrix(tmp_path, system=path) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{path}:" in err, err
    for word in words:
        assert word in err, (word, err)
    assert _written(tmp_path) == []


def _failing(monkeypatch, fail_seeds):
    """run_case failing (as a diverged run does) for the seeds in fail_seeds, and running the others."""
    real = wec_system.run_case

    def run_case(system_file, case, *args):
        if case.seed in fail_seeds:
            raise ParameterError("state", f"diverged at t = 0.05 s (seed {case.seed})")
        return real(system_file, case, *args)
    monkeypatch.setattr(wec_system, "run_case", run_case)


def test_every_run_failing_exits_non_zero_and_writes_nothing(tmp_path, capsys, monkeypatch):
    _failing(monkeypatch, {1, 2})
    assert _power_matrix(tmp_path) != 0
    err = capsys.readouterr().err
    line = [x for x in err.splitlines() if x.startswith("flexfmu: error: ")]
    assert len(line) == 1, err
    assert "2 of 2 co-simulations failed" in line[0] and "state: 2" in line[0], line
    assert "state: diverged at t = 0.05 s (seed 1)" in line[0] and "Hs 0.05 m, Tp 1.4 s, seed 1" in line[0], line
    assert _written(tmp_path) == []


def test_some_runs_failing_exit_non_zero_and_write_the_computed_cells(tmp_path, capsys, monkeypatch):
    _failing(monkeypatch, {2})
    assert _power_matrix(tmp_path) != 0
    captured = capsys.readouterr()
    line = [x for x in captured.err.splitlines() if x.startswith("flexfmu: error: ")]
    assert len(line) == 1 and "1 of 2 co-simulations failed" in line[0], captured.err
    assert "diverged at t = 0.05 s (seed 2)" in line[0], line
    assert _written(tmp_path) == ["m.csv", "m.png", "m_bins.csv", "m_runs.csv"]
    with (tmp_path / "m.csv").open() as f:
        rows = list(csv.reader(f))
    assert math.isfinite(float(rows[1][1])) and float(rows[1][1]) > 0      # the cell of seed 1
    with (tmp_path / "m_runs.csv").open() as f:
        runs = list(csv.DictReader(f))
    assert [r["error"] for r in runs] == ["", "state: diverged at t = 0.05 s (seed 2)"]


def test_an_empty_matrix_is_never_written(tmp_path):
    empty = PowerMatrix(np.array([0.05]), np.array([1.4]), np.array([[np.nan]]), [], "XFF", 1.0, (1,))
    for write in (empty.write_csv, empty.plot):
        with pytest.raises(FlexfmuError, match="no cell"):
            write(tmp_path / "m.x")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("option", ["--out", "--plot"])
def test_an_output_that_cannot_be_written_is_refused_before_any_run(option, tmp_path, capsys, no_runs):
    a_file = tmp_path / "a_file.txt"
    a_file.write_text("x")
    for bad in (tmp_path, a_file / "m.csv"):
        assert _power_matrix(tmp_path, option, str(bad)) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"error: {option[2:]}: " in err and repr(str(bad)) in err, err
    assert _written(tmp_path) == []


def test_a_sweep_beyond_the_run_limit_is_refused_at_once(tmp_path, capsys, no_runs):
    """10^9 seeds would build a billion cases before the first run: refused naming the count and the limit."""
    assert _power_matrix(tmp_path, "--seeds", "1000000000") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "1e+09 co-simulations" in err and "seeds" in err, err
