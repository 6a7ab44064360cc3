"""The ecos co-simulation engine (ecospy's `ecos` CLI, a C++ host) runs our FMUs as users run it,
as a subprocess in ``host_tools.host_environment``, and must reproduce fmpy.

- one FMU, loaded into the ecos process:  ecos simulate --path X.fmu --scenarioConfig ... --csvConfig ...
- one FMU per system, in its own process through proxyfmu: an SSP folder whose component source is
  ``proxyfmu://localhost?file=X.fmu``, start values in an SSP parameter set (--parameterSet)
- a coupled pair (FFRBeam <-> PTO, the wave converter's harvester and damper) in a zipped .ssp,
  each FMU in its own proxyfmu process.

The CLI writes its CSV with C's "%f" (std::to_string): 6 decimals.  So the CLI cases require the
CSV text to equal fmpy's value printed the same way (exact up to the rounding of a tie), i.e. they
agree to 5e-7 absolute; the outputs compared are chosen >= 1e-2 in size.  The full-precision check
(bit for bit) runs the same zipped .ssp through ecospy's C library (`EcosSimulation.get_real`) in a Python
subprocess: the coupling (Jacobi, outputs after initialisation passed to the inputs before the first
step) is the one fmpy is driven with here.  ecos's time is accumulated, t += h, as here.  Bit for bit because
it is the same computation: the same FMU binaries, the same FMI calls with the same doubles (start values
written with repr, which round-trips; proxyfmu passes doubles unchanged), and the fmpy reference runs in a
subprocess in the hosts' environment (same HOME, so the same flexfmu cache entries; the same BLAS settings, which
select the kernels of the Python FMUs' set-up).  An fmpy run in the test process is not the same computation
(its environment and cache differ: the C host's test measured 2e-12 apart with OPENBLAS_CORETYPE=Prescott).
"""
from __future__ import annotations

import csv
import json
import shutil
import sys
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pytest

from host_tools import (describe, ecos_binaries, ecos_times, fresh_fmu_copy, host_environment, jacobi_reference,
                        jacobi_reference_in, run_host)

H = 1e-3
SSD_NS = ('xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
          'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
          'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"')

# name: (start values incl. held inputs, outputs compared, steps)
SINGLE = {
    "FFRBeam": ({"boundary": "XFX", "damping_ratio": 0.02, "load_s": 0.3, "F_z": 150.0, "base_a_x": 0.5},
                ["sensor_a_x", "sensor_a_z", "reaction_F_z", "reaction_M_x", "reaction_M_y"], 20),
    "ReframeBody": ({"model": "beam:spatial_double_L", "n_flexible_modes": 4, "load_point_x": 0.14,
                     "load_point_y": 0.15, "load_point_z": 0.16,
                     "output_point_x": 0.0, "output_point_y": 0.0, "output_point_z": 0.0, "omega0_3": 1.0,
                     "F_x": 20.0, "M_z": 0.1},
                    ["omega_1", "omega_3", "com_vel_x", "out_acc_y", "q_w"], 20),
}
# The harvester and its damper from examples/wave_converter, the base shaken upwards.
PAIR = {
    "components": {"harvester": ("FFRBeam", {"scene": "spatial_double_L", "boundary": "XFF", "n_modes": 6,
                                             "damping_ratio": 0.01, "load_s": 0.45, "sensor_s": 0.45,
                                             "base_a_z": 50.0}),
                   "pto": ("PTO", {"damping": 5.0, "attach_x": 0.14, "attach_y": 0.15, "attach_z": 0.16})},
    "connections": [("harvester", f"sensor_v_{a}", "pto", f"v_{a}") for a in "xyz"]
                   + [("pto", f"F_{a}", "harvester", f"F_{a}") for a in "xyz"],
    "outputs": [("harvester", "sensor_a_z"), ("harvester", "reaction_F_z"), ("harvester", "sensor_v_z"),
                ("pto", "F_z")],
    "steps": 30,
}


@pytest.fixture(scope="module")
def ecos():
    found = ecos_binaries()
    if isinstance(found, str):
        pytest.skip(f"ecos CLI not available: {found}")
    return found[0]


@pytest.fixture(scope="module")
def home(tmp_path_factory):
    """One HOME for the module's host processes: flexfmu's cache (compiled kernels) is filled once."""
    return tmp_path_factory.mktemp("ecos_home")


# ---------------------------------------------------------------- files for ecos
def _ssv(value) -> str:
    if isinstance(value, bool):
        return f'<ssv:Boolean value="{str(value).lower()}"/>'
    if isinstance(value, int):
        return f'<ssv:Integer value="{value}"/>'
    if isinstance(value, float):
        return f'<ssv:Real value="{value!r}"/>'
    return f"<ssv:String value={quoteattr(value)}/>"


def write_ssd(folder: Path, components: dict, connections=(), proxy=True) -> Path:
    """SystemStructure.ssd: components {instance: (fmu file name in folder, start values)}, each
    start value in the parameter set "start"; connections (src, output, dst, input) of Reals."""
    connectors = {name: {} for name in components}
    for src, out, dst, inp in connections:
        connectors[src][out] = "output"
        connectors[dst][inp] = "input"
    elements = []
    for name, (fmu_file, start) in components.items():
        source = f"proxyfmu://localhost?file={fmu_file}" if proxy else fmu_file
        conns = "".join(f'<ssd:Connector name="{v}" kind="{k}"><ssc:Real/></ssd:Connector>'
                        for v, k in connectors[name].items())
        params = "".join(f'<ssv:Parameter name="{k}">{_ssv(v)}</ssv:Parameter>' for k, v in start.items())
        elements.append(f'<ssd:Component name="{name}" source="{source}"><ssd:Connectors>{conns}</ssd:Connectors>'
                        '<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>'
                        f'<ssv:ParameterSet version="1.0" name="start"><ssv:Parameters>{params}</ssv:Parameters>'
                        '</ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>'
                        '</ssd:Component>')
    links = "".join(f'<ssd:Connection startElement="{s}" startConnector="{o}" endElement="{d}" endConnector="{i}"/>'
                    for s, o, d, i in connections)
    text = (f'<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription {SSD_NS} name="flexfmu" '
            f'version="1.0"><ssd:System name="flexfmu"><ssd:Elements>{"".join(elements)}</ssd:Elements>'
            f'<ssd:Connections>{links}</ssd:Connections></ssd:System></ssd:SystemStructureDescription>\n')
    path = Path(folder) / "SystemStructure.ssd"
    path.write_text(text)
    return path


def write_csv_config(path: Path, variables) -> Path:
    """Log only these (instance, variable) pairs."""
    by_instance = {}
    for inst, var in variables:
        by_instance.setdefault(inst, []).append(var)
    body = "".join(f'<ecos:component name="{inst}">' + "".join(f'<ecos:variable name="{v}"/>' for v in vs)
                   + "</ecos:component>" for inst, vs in by_instance.items())
    path.write_text('<?xml version="1.0" encoding="utf-8"?>\n<ecos:CsvConfig '
                    'xmlns:ecos="http://github.com/Ecos-platform/libecos/resources/schema/CsvConfig">'
                    f"<ecos:components>{body}</ecos:components></ecos:CsvConfig>\n")
    return path


def write_scenario(path: Path, actions) -> Path:
    """actions: [(t, variable id, real value)], applied before the step that starts at t."""
    body = "".join(f'<ecos:action t="{t!r}"><ecos:variable id="{vid}"><ecos:real value="{v!r}"/></ecos:variable>'
                   "</ecos:action>" for t, vid, v in actions)
    path.write_text('<?xml version="1.0" encoding="utf-8"?>\n<ecos:Scenario '
                    'xmlns:ecos="http://github.com/Ecos-platform/libecos/resources/schema/ScenarioConfig" '
                    f'name="load">{body}</ecos:Scenario>\n')
    return path


def run_ecos(ecos, path: Path, steps: int, cwd: Path, home: Path, *extra, timeout=120):
    """ecos simulate; returns (process, environment, CSV path, message for assertions)."""
    env = host_environment(home)
    # stopTime half a step past the last point: ecos steps while t + h <= stopTime, t accumulated
    cmd = [ecos, "simulate", "--path", path, "--stepSize", repr(H), "--stopTime", repr((steps + 0.5) * H),
           "-l", "debug", *extra]
    proc = run_host(cmd, env, cwd, timeout=timeout)
    csv_path = Path(cwd) / (Path(path).stem + ".csv")
    logs = "".join(f"\n--- {p.name} (proxyfmu):\n{p.read_text()[-3000:]}" for p in sorted((Path(cwd) / "logs").glob("*.txt")))
    return proc, env, csv_path, describe(proc, env, logs)


def check_ecos_ran(proc, message):
    # ecos 0.7.2 segfaults after a failed fmi2Instantiate (exit status), logs some errors and goes on
    # (the text), and ignores a failed fmi2DoStep: values frozen, exit 0 (only the comparison sees it)
    assert proc.returncode == 0, message
    text = proc.stdout + proc.stderr
    for bad in ("[error]", "[critical]", "Segmentation fault", "Unhandled Exception", "fmi2Error", "fmi2Fatal"):
        assert bad not in text, f"{bad!r} in the output" + message


def read_ecos_csv(path: Path, columns, message) -> tuple[list, list]:
    """(times, rows of strings in the order of columns [(instance, variable)])."""
    assert path.is_file(), f"no CSV {path}" + message
    with open(path, newline="") as f:
        rows = list(csv.reader(f, skipinitialspace=True))
    head = rows[0]
    index = {h.rsplit("[", 1)[0]: i for i, h in enumerate(head)}
    missing = [f"{i}::{v}" for i, v in columns if f"{i}::{v}" not in index]
    assert not missing, f"CSV has no {missing}; header {head}" + message
    data = [r for r in rows[1:] if r]
    return [float(r[1]) for r in data], [[r[index[f"{i}::{v}"]] for i, v in columns] for r in data]


def assert_printed_equal(text_rows, reference: np.ndarray, columns, message):
    """ecos's "%f" text equals fmpy's value printed the same way (either rounding at an exact tie)."""
    assert len(text_rows) == len(reference), f"{len(text_rows)} CSV rows, expected {len(reference)}" + message
    assert np.all(np.abs(reference).max(axis=0) >= 1e-2), "compared outputs too small for 6 decimals"
    bad = []
    for k, (texts, values) in enumerate(zip(text_rows, reference)):
        for text, value, col in zip(texts, values, columns):
            if text == f"{value:f}":
                continue
            frac = abs(value) * 1e6 % 1.0
            if abs(frac - 0.5) < 1e-6 and abs(float(text) - value) <= 5.000001e-7:
                continue
            bad.append(f"row {k} {col[0]}::{col[1]}: ecos {text}, fmpy {value!r}")
    assert not bad, "\n".join(bad[:20]) + message


# ---------------------------------------------------------------- fmpy references
def reference_in(components, connections, outputs, times, env, cwd):
    """jacobi_reference in a subprocess with the environment ``env`` of the host it is compared with (module
    docstring: then it is the same computation, down to the sign of a zero)."""
    return jacobi_reference_in(components, connections, outputs, times, env, cwd)


def pair_reference_in(fmus, env, cwd):
    components = {name: (fmus[model], start) for name, (model, start) in PAIR["components"].items()}
    return reference_in(components, PAIR["connections"], PAIR["outputs"], ecos_times(PAIR["steps"], H), env, cwd)


def build_pair_ssp(fmus, folder: Path) -> Path:
    """The coupled pair as a zipped .ssp with its FMUs inside, each run through proxyfmu."""
    content = folder / "pair"
    content.mkdir(parents=True)
    comps = {}
    for name, (model, start) in PAIR["components"].items():
        fresh_fmu_copy(fmus[model], content)
        comps[name] = (f"{model}.fmu", start)
    write_ssd(content, comps, PAIR["connections"], proxy=True)
    ssp = folder / "pair.ssp"
    with zipfile.ZipFile(ssp, "w") as zf:
        for p in content.iterdir():
            zf.write(p, p.name)
    shutil.rmtree(content)
    return ssp


# ---------------------------------------------------------------- tests
SCENARIO_OUTPUTS = ["sensor_a_x", "sensor_a_z", "reaction_F_z", "reaction_M_x"]


def scenario_run(ecos, fmu, tmp_path, home, steps: int = 20):
    """`ecos simulate --path FMU` (an FFRBeam; instance name "instance", its default parameters) with a scenario
    switching F_z at 0 and 0.01 s: (times, printed outputs, message for failures, inputs_at(t) for
    jacobi_reference, columns)."""
    load = {0.0: 150.0, 0.01: -60.0}
    columns = [("instance", o) for o in SCENARIO_OUTPUTS]
    scenario = write_scenario(tmp_path / "scenario.xml", [(t, "instance::F_z", v) for t, v in load.items()])
    config = write_csv_config(tmp_path / "csv.xml", columns)
    proc, env, csv_path, message = run_ecos(ecos, fresh_fmu_copy(fmu, tmp_path / "fmu"), steps, tmp_path, home,
                                            "--scenarioConfig", scenario, "--csvConfig", config)
    check_ecos_ran(proc, message)
    times, texts = read_ecos_csv(csv_path, columns, message)

    def inputs_at(t):   # scenario actions apply when |t - t_action| <= 1e-9
        hits = [v for ta, v in load.items() if abs(t - ta) <= 1e-9]
        return {"instance": {"F_z": hits[0]}} if hits else {}
    return times, texts, message, inputs_at, columns


def test_ecos_cli_one_fmu_in_process_with_a_scenario(ecos, fmus, home, tmp_path):
    """`ecos simulate --path FFRBeam.fmu`: the FMU in the ecos process (instance name "instance"),
    default parameters (the CLI sets none for a bare FMU), a load switched by a scenario."""
    steps = 20
    times, texts, message, inputs_at, columns = scenario_run(ecos, fmus["FFRBeam"], tmp_path, home, steps)
    reference = jacobi_reference({"instance": (fmus["FFRBeam"], {})}, (), columns, ecos_times(steps, H), inputs_at)
    assert np.allclose(times, H * np.arange(steps + 1), atol=1e-9)
    assert_printed_equal(texts, reference, columns, message)


@pytest.mark.parametrize("name", list(SINGLE))
def test_ecos_cli_one_fmu_through_proxyfmu(ecos, fmus, home, tmp_path, name):
    """An SSP folder with one component in its own proxyfmu process, start values (parameters and
    held inputs) from the parameter set applied with --parameterSet."""
    start, outputs, steps = SINGLE[name]
    folder = tmp_path / "system"
    fresh_fmu_copy(fmus[name], folder)
    write_ssd(folder, {"body": (f"{name}.fmu", start)})
    columns = [("body", o) for o in outputs]
    config = write_csv_config(tmp_path / "csv.xml", columns)
    proc, env, csv_path, message = run_ecos(ecos, folder, steps, tmp_path, home, "--parameterSet", "start",
                                            "--csvConfig", config)
    check_ecos_ran(proc, message)
    assert "[proxyfmu] Booting FMU instance 'body'" in proc.stdout + proc.stderr, message
    times, texts = read_ecos_csv(csv_path, columns, message)
    reference = reference_in({"body": (fmus[name], start)}, (), columns, ecos_times(steps, H), env, tmp_path)
    assert_printed_equal(texts, reference, columns, message)


def test_ecos_cli_coupled_pair_in_a_zipped_ssp(ecos, fmus, home, tmp_path):
    """FFRBeam and PTO coupled both ways, each in its own proxyfmu process, from a .ssp archive."""
    ssp = build_pair_ssp(fmus, tmp_path)
    config = write_csv_config(tmp_path / "csv.xml", PAIR["outputs"])
    proc, env, csv_path, message = run_ecos(ecos, ssp, PAIR["steps"], tmp_path, home, "--parameterSet", "start",
                                            "--csvConfig", config)
    check_ecos_ran(proc, message)
    text = proc.stdout + proc.stderr
    assert "Booting FMU instance 'harvester'" in text and "Booting FMU instance 'pto'" in text, message
    times, texts = read_ecos_csv(csv_path, PAIR["outputs"], message)
    reference = pair_reference_in(fmus, env, tmp_path)
    assert np.abs(reference[:, 3]).max() > 0.1        # the damper force acts: the coupling matters
    assert_printed_equal(texts, reference, PAIR["outputs"], message)


ECOSPY_DRIVER = r"""
import ctypes, json, os, sys
tbb = os.path.join(sys.prefix, "lib", "libtbb.so.12")   # PyPI's tbb, for machines without Debian's libtbb12
if os.path.exists(tbb):
    ctypes.CDLL(tbb, mode=ctypes.RTLD_GLOBAL)
from ecospy import EcosSimulation
path, h, steps, ids = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), json.loads(sys.argv[4])
sim = EcosSimulation(ssp_path=path, step_size=h)
sim.init(parameter_set="start")
rows = [[sim.get_real(i) for i in ids]]
for _ in range(steps):
    sim.step()
    rows.append([sim.get_real(i) for i in ids])
sim.terminate()
sim.free()
print("ROWS " + json.dumps([[repr(x) for x in r] for r in rows]))
"""


def test_ecospy_library_coupled_pair_to_full_precision(ecos, fmus, home, tmp_path):
    """The same .ssp through ecospy's C library (ecos's engine without the CLI's 6-decimal CSV), in a
    Python subprocess; the FMUs run in proxyfmu processes: fmpy's numbers, bit for bit (module docstring)."""
    ssp = build_pair_ssp(fmus, tmp_path)
    ids = [f"{i}::{v}" for i, v in PAIR["outputs"]]
    env = host_environment(home)   # the venv's python finds ecospy itself; the FMUs their packages
    proc = run_host([sys.executable, "-c", ECOSPY_DRIVER, ssp, repr(H), PAIR["steps"], json.dumps(ids)], env,
                    tmp_path, timeout=120)
    logs = "".join(f"\n--- {p.name}:\n{p.read_text()[-3000:]}" for p in sorted((tmp_path / "logs").glob("*.txt")))
    message = describe(proc, env, logs)
    assert proc.returncode == 0, message
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("ROWS ")]
    assert line, message
    got = np.array([[float(x) for x in r] for r in json.loads(line[-1][5:])])
    reference = pair_reference_in(fmus, env, tmp_path)
    assert got.shape == reference.shape, message
    # identity: the same FMUs, calls and environment (module docstring); repr round-trips exactly
    if not np.array_equal(got, reference):
        worst = np.max(np.abs(got - reference) / np.abs(reference).max(axis=0))
        pytest.fail(f"not bit for bit: relative difference {worst:.3g}" + message)
