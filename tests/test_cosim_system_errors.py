"""`flexfmu cosim` on bad system files and bad run lengths: exit status 2 and one line that names the file, the
line of the offending element, the element and what is allowed (never a traceback, never a silent choice).

The system files are the wave-energy converter's example (examples/wave_converter/OspSystemStructure.xml) with one
thing broken, or a small file written here; the expected line is found in the broken text itself.  Every case stops
before a co-simulation starts (``--master library``: no FMU needed; the FMU cases read a file that is no FMU).
"""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from fmu_helpers import ROOT

from flexfmu import cli
from flexfmu.cosim.masters import load_system, run
from flexfmu.cosim.ssp import ssd_tree
from flexfmu.errors import ParameterError

pytestmark = pytest.mark.unit

EXAMPLE = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
TEXT = EXAMPLE.read_text()


def _line_of(text: str, marker, nth: int = 0) -> int:
    """1-based line of the nth occurrence of marker (or of (marker, nth)) in text."""
    if isinstance(marker, tuple):
        marker, nth = marker
    hits = [i + 1 for i, line in enumerate(text.splitlines()) if marker in line]
    assert len(hits) > nth, f"{marker!r} not in the test's file"
    return hits[nth]


#: the PTO's damping start value (the first in the example file)
_DAMPING_MARKER = '<InitialValue variable="damping">'


def _cosim(path: Path, *extra: str, master: str = "library") -> int:
    return cli.main(["cosim", str(path), "--t-end", "0.01", "--master", master, "--no-stability-check", *extra])


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("flexfmu: error: "), err
    assert "Traceback" not in err
    return err


def _broken(tmp_path: Path, old: str, new: str, count: int = 1) -> tuple[Path, str]:
    assert old in TEXT, old
    text = TEXT.replace(old, new, count)
    path = tmp_path / "OspSystemStructure.xml"
    path.write_text(text)
    return path, text


_PTO_SOURCE = '<Simulator name="pto" source="../../dist/PTO.fmu">'
_DAMPING = '<InitialValue variable="damping">\n                    <Real value="2.0" />'
_FIRST_CONNECTION = """<VariableConnection>
            <Variable simulator="wave" name="F_x" />"""

# (case id, old text, new text, marker of the element's line, element tag, words the message must hold)
OSP_CASES = [
    ("empty BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize></BaseStepSize>", "<BaseStepSize>",
     "BaseStepSize", ["empty", "> 0"]),
    ("textual BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize>fast</BaseStepSize>",
     "<BaseStepSize>", "BaseStepSize", ["'fast'", "> 0"]),
    ("zero BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize>0</BaseStepSize>", "<BaseStepSize>",
     "BaseStepSize", ["> 0"]),
    ("negative BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize>-1e-3</BaseStepSize>",
     "<BaseStepSize>", "BaseStepSize", ["> 0"]),
    ("NaN BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize>nan</BaseStepSize>", "<BaseStepSize>",
     "BaseStepSize", ["finite"]),
    ("infinite BaseStepSize", "<BaseStepSize>0.001</BaseStepSize>", "<BaseStepSize>inf</BaseStepSize>",
     "<BaseStepSize>", "BaseStepSize", ["finite"]),
    ("two BaseStepSizes", "<BaseStepSize>0.001</BaseStepSize>",
     "<BaseStepSize>0.001</BaseStepSize>\n    <BaseStepSize>0.002</BaseStepSize>", "0.002</BaseStepSize>",
     "BaseStepSize", ["line 4", "once"]),
    ("NaN StartTime", "<StartTime>0.0</StartTime>", "<StartTime>nan</StartTime>", "<StartTime>", "StartTime",
     ["finite"]),
    ("empty StartTime", "<StartTime>0.0</StartTime>", "<StartTime/>", "<StartTime", "StartTime", ["empty"]),
    ("empty Algorithm", "<Algorithm>fixedStep</Algorithm>", "<Algorithm/>", "<Algorithm", "Algorithm",
     ["fixedStep"]),
    ("other Algorithm", "<Algorithm>fixedStep</Algorithm>", "<Algorithm>variableStep</Algorithm>", "<Algorithm",
     "Algorithm", ["'variableStep'", "fixedStep"]),
    ("unknown root element", "<Algorithm>fixedStep</Algorithm>",
     "<Algorithm>fixedStep</Algorithm>\n    <Functions/>", "<Functions", "Functions", ["Simulators", "Connections"]),
    ("InitialValue with two values", '<Real value="2.0" />', '<Real value="2.0" /><Real value="3.0" />',
     '<InitialValue variable="damping">', "InitialValue", ["2 values", "one of"]),
    ("InitialValue without value", _DAMPING, '<InitialValue variable="damping">',
     '<InitialValue variable="damping">', "InitialValue", ["no value", "one of"]),
    ("InitialValue without variable", '<InitialValue variable="damping">', "<InitialValue>", "<InitialValue>",
     "InitialValue", ["variable"]),
    ("unknown value type", _DAMPING, _DAMPING.replace("Real", "Float"), "<Float", "Float",
     ["Real", "Integer", "Boolean", "String"]),
    ("textual Real", '<Real value="2.0" />', '<Real value="abc" />', 'value="abc"', "Real", ["'abc'", "finite"]),
    ("NaN Real", '<Real value="2.0" />', '<Real value="nan" />', 'value="nan"', "Real", ["finite"]),
    ("Real without value", '<Real value="2.0" />', "<Real />", "<Real />", "Real", ["value"]),
    ("fractional Integer", '<Integer value="8" />', '<Integer value="8.5" />', 'value="8.5"', "Integer", ["integer"]),
    ("textual Boolean", '<Real value="2.0" />', '<Boolean value="yes" />', 'value="yes"', "Boolean",
     ["true", "false"]),
    ("two InitialValues of one variable", _DAMPING, _DAMPING + "\n                </InitialValue>\n"
     '                <InitialValue variable="damping">\n                    <Real value="3.0" />',
     (_DAMPING_MARKER, 1), "InitialValue", ["twice", f"line {_line_of(TEXT, _DAMPING_MARKER)}"]),
    ("Simulator without source", _PTO_SOURCE, '<Simulator name="pto">', '<Simulator name="pto"', "Simulator",
     ["source"]),
    ("Simulator without name", _PTO_SOURCE, '<Simulator source="../../dist/PTO.fmu">', "<Simulator source",
     "Simulator", ["name"]),
    ("per-simulator step", _PTO_SOURCE, '<Simulator name="pto" source="../../dist/PTO.fmu" stepSize="0.01">',
     "stepSize", "Simulator", ["BaseStepSize"]),
    ("connection with three variables", _FIRST_CONNECTION,
     _FIRST_CONNECTION + '\n            <Variable simulator="hydro" name="F_x" />', "<VariableConnection>",
     "VariableConnection", ["3 Variables", "two"]),
    ("connection with one variable", _FIRST_CONNECTION, '<VariableConnection>', "<VariableConnection>",
     "VariableConnection", ["1 Variable", "two"]),
    ("variable without simulator", '<Variable simulator="wave" name="F_x" />', '<Variable name="F_x" />',
     '<Variable name="F_x" />', "Variable", ["simulator"]),
    ("connection to an unknown simulator", '<Variable simulator="wave" name="F_x" />',
     '<Variable simulator="waves" name="F_x" />', '"waves"', "Variable", ["'waves'", "wave, platform"]),
    ("connection of a variable to itself", '<Variable simulator="platform" name="wave_F_x" />',
     '<Variable simulator="wave" name="F_x" />', "<VariableConnection>", "VariableConnection", ["itself"]),
    ("other connection kind", _FIRST_CONNECTION, "<SignalConnection/>\n        " + _FIRST_CONNECTION,
     "<SignalConnection", "SignalConnection", ["VariableConnection"]),
]


@pytest.mark.parametrize("case", OSP_CASES, ids=[c[0] for c in OSP_CASES])
def test_bad_osp_file_names_element_line_and_what_is_allowed(case, tmp_path, capsys):
    _, old, new, marker, element, words = case
    path, text = _broken(tmp_path, old, new)
    assert _cosim(path) == 2
    err = _one_error_line(capsys)
    assert f"{path}:{_line_of(text, marker)} <{element}" in err, err
    assert "(allowed: " in err, err
    for word in words:
        assert word in err, (word, err)


def test_duplicate_simulator_name_names_both_lines(tmp_path, capsys):
    path, text = _broken(tmp_path, '<Simulator name="hydro"', '<Simulator name="pto"')
    assert _cosim(path) == 2
    err = _one_error_line(capsys)
    first, second = _line_of(text, '<Simulator name="pto"'), _line_of(text, '<Simulator name="pto"', 1)
    assert f"{path}:{second} <Simulator name=\"pto\">" in err and f"line {first}" in err, err
    assert "two simulators named 'pto'" in err and "unknown simulator" not in err, err


def test_not_xml_names_the_line(tmp_path, capsys):
    path, text = _broken(tmp_path, "<StartTime>0.0</StartTime>", "<StartTime>0.0</Start>")
    assert _cosim(path) == 2
    err = _one_error_line(capsys)
    assert f"{path}:{_line_of(text, '</Start>')}:" in err and "not XML" in err and "mismatched tag" in err, err


def test_two_connections_into_one_input_are_refused_naming_both(tmp_path, capsys):
    """hydro.F_x into platform.wave_F_x besides wave.F_x: one of them would silently win."""
    extra = """<VariableConnection>
            <Variable simulator="hydro" name="F_z" />
            <Variable simulator="platform" name="wave_F_x" />
        </VariableConnection>
        """
    path, text = _broken(tmp_path, _FIRST_CONNECTION, extra + _FIRST_CONNECTION)
    assert _cosim(path) == 2
    err = _one_error_line(capsys)
    first, second = _line_of(text, "<VariableConnection>"), _line_of(text, "<VariableConnection>", 1)
    assert "platform.wave_F_x" in err and "hydro.F_z -> platform.wave_F_x" in err and \
        "wave.F_x -> platform.wave_F_x" in err, err
    assert f"{path}:{second} <VariableConnection>" in err and f"{path}:{first} <VariableConnection>" in err, err
    assert "one connection into each input" in err, err
    # the library's own entry refuses it too, before any step
    with pytest.raises(ParameterError, match="platform.wave_F_x"):
        run(load_system(path), 0.01, backend="library")


@pytest.mark.parametrize("old, new, marker, words", [
    ('<Variable simulator="platform" name="wave_F_x" />', '<Variable simulator="platform" name="wave_Fx" />',
     "<VariableConnection>", ["platform has no input or output 'wave_Fx'", "wave_F_x"]),
    ('<InitialValue variable="damping">', '<InitialValue variable="dampening">', 'variable="dampening"',
     ["pto has no parameter 'dampening'", "damping"]),
    ('<Real value="2.0" />', '<String value="strong" />', '<InitialValue variable="damping">', ["'strong'", "Real"]),
], ids=["unknown connection variable", "unknown initial value", "String for a Real"])
def test_variables_unknown_to_the_model_are_named_with_their_line(old, new, marker, words, tmp_path, capsys):
    path, text = _broken(tmp_path, old, new)
    assert _cosim(path) == 2
    err = _one_error_line(capsys)
    assert f"{path}:{_line_of(text, marker)}" in err and "(allowed: " in err, err
    for word in words:
        assert word in err, (word, err)


SMALL = """<?xml version="1.0" encoding="utf-8"?>
<OspSystemStructure xmlns="http://opensimulationplatform.com/MSMI/OSPSystemStructure" version="0.1">
    <BaseStepSize>0.001</BaseStepSize>
    <Simulators>
        <Simulator name="pto" source="{source}" />
    </Simulators>
</OspSystemStructure>
"""


def test_a_source_that_is_no_fmu_is_named_with_its_line(tmp_path, capsys):
    (tmp_path / "PTO.fmu").write_text("not a zip archive")
    path = tmp_path / "OspSystemStructure.xml"
    path.write_text(SMALL.format(source="PTO.fmu"))
    assert _cosim(path, master="fmpy") == 2
    err = _one_error_line(capsys)
    assert f"{path}:5 <Simulator name=\"pto\">" in err and "not an FMU" in err and "(allowed: " in err, err
    # a zip without a modelDescription.xml is no FMU either
    with zipfile.ZipFile(tmp_path / "PTO.fmu", "w") as zf:
        zf.writestr("readme.txt", "empty")
    assert _cosim(path, master="fmpy") == 2
    err = _one_error_line(capsys)
    assert f"{path}:5 <Simulator name=\"pto\">" in err and "not an FMU" in err, err


def test_a_missing_fmu_is_named_with_its_line(tmp_path, capsys):
    path = tmp_path / "OspSystemStructure.xml"
    path.write_text(SMALL.format(source="no/such/PTO.fmu"))
    assert _cosim(path, master="fmpy") == 2
    err = _one_error_line(capsys)
    assert f"{path}:5 <Simulator name=\"pto\">" in err and "not found" in err, err


# ---------------------------------------------------------------- SSP
def _ssd_text() -> str:
    from xml.etree import ElementTree as ET
    system = load_system(EXAMPLE)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(ssd_tree(system), encoding="unicode")


SSD_TEXT = _ssd_text()

SSP_CASES = [
    ("NaN startTime", 'startTime="0.0"', 'startTime="nan"', "<ssd:DefaultExperiment", "DefaultExperiment",
     ["startTime", "finite"]),
    ("textual baseStepSize", 'baseStepSize="0.001"', 'baseStepSize="fast"', "baseStepSize", "FixedStepAlgorithm",
     ["'fast'", "> 0"]),
    ("zero baseStepSize", 'baseStepSize="0.001"', 'baseStepSize="0"', "baseStepSize", "FixedStepAlgorithm",
     ["> 0"]),
    ("baseStepSize missing", 'baseStepSize="0.001"', "", "<osp:FixedStepAlgorithm", "FixedStepAlgorithm",
     ["baseStepSize"]),
    ("component without source", 'source="resources/PTO.fmu"', "", '<ssd:Component name="pto"', "Component",
     ["source"]),
    ("duplicate component", '<ssd:Component name="hydro"', '<ssd:Component name="pto"',
     ('<ssd:Component name="pto"', 1), "Component", ["two components named 'pto'"]),
    ("connection without endConnector", 'endConnector="wave_F_x"', "", 'startConnector="F_x" endElement="platform"',
     "Connection", ["endConnector"]),
    ("textual Real parameter", '<ssv:Real value="2.0"', '<ssv:Real value="abc"', 'value="abc"', "Real",
     ["'abc'", "finite"]),
]


@pytest.mark.parametrize("case", SSP_CASES, ids=[c[0] for c in SSP_CASES])
def test_bad_ssd_names_element_line_and_what_is_allowed(case, tmp_path, capsys):
    _, old, new, marker, element, words = case
    assert old in SSD_TEXT, old
    text = SSD_TEXT.replace(old, new, 1)
    path = tmp_path / "SystemStructure.ssd"
    path.write_text(text)
    assert _cosim(path) == 2
    err = _one_error_line(capsys)
    assert f"{path}:{_line_of(text, marker)} <{element}" in err, err
    assert "(allowed: " in err, err
    for word in words:
        assert word in err, (word, err)


def test_ssd_in_an_archive_is_named_inside_the_archive(tmp_path, capsys):
    ssp = tmp_path / "system.ssp"
    text = SSD_TEXT.replace('startTime="0.0"', 'startTime="nan"')
    with zipfile.ZipFile(ssp, "w") as zf:
        zf.writestr("SystemStructure.ssd", text)
    assert _cosim(ssp) == 2
    err = _one_error_line(capsys)
    assert f"{ssp}!SystemStructure.ssd:{_line_of(text, '<ssd:DefaultExperiment')} <DefaultExperiment" in err, err


# ---------------------------------------------------------------- run length and memory
@pytest.mark.parametrize("argv, words", [
    (["--t-end", "1e300"], ["t-end", "step", "GiB", "--max-memory"]),
    (["--t-end", "0.01", "--step", "1e-300"], ["t-end", "step", "GiB"]),
    (["--t-end", "0.01", "--step", "5e-324"], ["t-end", "step"]),
    (["--t-end", "1e6", "--step", "0.001"], ["1e+09 communication steps", "GiB", "--max-memory"]),
    (["--t-end", "nan"], ["t-end", "finite"]),
    (["--t-end", "inf"], ["t-end", "finite"]),
    (["--t-end", "-1"], ["t-end", "> start time 0"]),
    (["--t-end", "0.01", "--step", "0"], ["step", "> 0"]),
    (["--t-end", "0.01", "--step", "-0.001"], ["step", "> 0"]),
    (["--t-end", "0.01", "--step", "nan"], ["step", "finite"]),
    (["--t-end", "0.01", "--step", "0.003"], ["step", "divide"]),
    (["--t-end", "0.01", "--max-memory", "0"], ["max-memory", "> 0"]),
    (["--t-end", "1", "--max-memory", "0.0001"], ["1000 communication steps", "--max-memory"]),
], ids=lambda v: " ".join(v) if isinstance(v, list) and v and v[0].startswith("--") else None)
def test_run_length_is_checked_before_the_run(argv, words, capsys):
    status = cli.main(["cosim", str(EXAMPLE), "--master", "library", *argv])
    assert status == 2
    err = _one_error_line(capsys)
    for word in words:
        assert word in err, (word, err)


def test_library_run_refuses_a_result_beyond_the_memory_limit():
    system = load_system(EXAMPLE)
    with pytest.raises(ParameterError, match="max-memory"):
        run(system, 1e6, 1e-3, backend="library")
    with pytest.raises(ParameterError, match="max-memory"):
        run(system, 1.0, 1e-3, backend="library", max_result_bytes=1000)


@pytest.mark.parametrize("option", ["--out", "--plot"])
def test_an_output_that_cannot_be_written_is_refused_before_the_run(option, tmp_path, capsys):
    """Not after the run, with IsADirectoryError or FileExistsError from the writer."""
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    for bad in (tmp_path, a_file / "results.csv"):
        assert cli.main(["cosim", str(EXAMPLE), "--t-end", "1e6", "--master", "library", option, str(bad)]) == 2
        err = _one_error_line(capsys)
        assert f"error: {option[2:]}: " in err and repr(str(bad)) in err, err


_MODEL_DESCRIPTION = """<?xml version="1.0"?>
<fmiModelDescription fmiVersion="2.0" modelName="m" guid="{{x}}">
  {interface}
  <ModelVariables>
    <ScalarVariable name="y" valueReference="0" causality="output"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="1"/></Outputs></ModelStructure>
</fmiModelDescription>
"""


@pytest.mark.parametrize("interface, words", [
    ('<ModelExchange modelIdentifier="m"/>', ["no co-simulation interface", "FMI 2.0 co-simulation"]),
    ('<CoSimulation modelIdentifier="m"/><Bogus/>', ["not an FMU", "modelDescription.xml"]),
], ids=["model exchange only", "invalid modelDescription"])
def test_an_fmu_the_master_cannot_run_is_named_with_its_line(interface, words, tmp_path, capsys):
    with zipfile.ZipFile(tmp_path / "PTO.fmu", "w") as zf:
        zf.writestr("modelDescription.xml", _MODEL_DESCRIPTION.format(interface=interface))
    path = tmp_path / "OspSystemStructure.xml"
    path.write_text(SMALL.format(source="PTO.fmu"))
    assert _cosim(path, master="fmpy") == 2
    err = _one_error_line(capsys)       # fmpy's validation report spans lines: one line here
    assert f"{path}:5 <Simulator name=\"pto\">" in err, err
    for word in words:
        assert word in err, (word, err)
