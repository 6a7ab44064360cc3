"""FMI Cross-Check packages of flexfmu's native FMUs (``flexfmu cross-check OUT_DIR``): for every model, FMI
version, interface and platform, the folder the FMI Cross-Check rules (modelica/fmi-cross-check,
FMI-CROSS-CHECK-RULES.md version 4.1, sections 9.1.4 and 9.1.5, and its README) ask of an exporting tool:

    OUT_DIR/fmus/<2.0|3.0>/<cs|me>/<platform>/flexfmu/<flexfmu version>/<Model>/
        <Model>.fmu      the native FMU; the same file in every platform folder it has a binary for
        <Model>_in.csv   every input of the FMU, piecewise constant over the communication steps (below)
        <Model>_ref.csv  the reference result: flexfmu's library simulator of the model, not the FMU
        <Model>_ref.opt  StartTime, StopTime, StepSize, RelTol, OutputIntervalLength
        README.md        what the model is, how the reference was made, how to reproduce it, what was checked

Platforms: FMI 2.0 the rules' names (linux64, win64; none for ARM Linux); FMI 3.0, which the rules predate, the
FMU's own binaries folders (x86_64-linux, x86_64-windows, aarch64-linux).  Inputs: pulses sampled at the
communication points t_k and held over [t_k, t_k+1), each jump two rows at the same time (the rules' CSV example):
an importer interpolating linearly, as the rules say, a co-simulation one setting the value after the jump at t_k
(fmpy), a model-exchange one integrating the staircase: all see what the reference was stepped with.  Checked by
fmpy's cross-check validator (:func:`validate`) and, where the host runs the FMU, fmpy simulating it as
fmpy.cross_check does (:func:`self_check`).  Model exchange (``interfaces=("me",)``): built with ``interface="me"``
where the builder takes it (:func:`accepts_interface`) and the model is an ODE, else skipped with the reason.
"""
from __future__ import annotations

import inspect
import json
import math
import platform as host_platform
import shutil
import sys
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.errors import NonFiniteError, ParameterError, require

TOOL = "flexfmu"
INTERFACES = ("cs", "me")
FMI_FOLDERS = {2: "2.0", 3: "3.0"}
#: the rules' platform folders (FMI 1.0 and 2.0)
RULES_PLATFORMS = ("c-code", "darwin64", "linux32", "linux64", "win32", "win64")
#: the platforms a user may name, in FMI 2.0's and in FMI 3.0's spelling: {FMI 2.0 name or None: FMI 3.0 name}
PLATFORM_NAMES = {"linux64": "x86_64-linux", "win64": "x86_64-windows", None: "aarch64-linux"}
#: fmpy's cross-check report flags a CSV of more rows, and fmpy doubles a communication step that makes more steps
MAX_ROWS = 1000
MAX_REFERENCE_VARIABLES = 10        # "at most 10 of the important variables" (9.1.4)
#: the tolerance an importer's solver is asked for (model exchange; co-simulation FMUs step themselves)
REL_TOL = 1e-6
G = 9.80665                         # m/s2, standard gravity: the shock's unit


@dataclass(frozen=True)
class Pulse:
    """A half-sine pulse of ``amplitude`` (the input's unit) on ``input``, from ``start`` for ``width`` s."""

    input: str
    amplitude: float
    start: float
    width: float

    def __call__(self, t: np.ndarray) -> np.ndarray:
        phase = (t - self.start) / self.width
        return np.where((phase >= 0.0) & (phase < 1.0), self.amplitude * np.sin(np.pi * phase), 0.0)


@dataclass(frozen=True)
class CrossCheckModel:
    """One model of the package: its name (the FMU's), what it is and what its inputs do (README), the record's
    length, the pulses, the reference's variables, and where it comes from (a flexfmu.fmi.registry entry built
    with ``settings``, or the bracket of examples/bracket exported clamped)."""

    name: str
    what: str
    scenario: str
    stop_time: float
    pulses: tuple
    outputs: tuple
    registry: str = ""
    settings: tuple = ()


MODELS = {model.name: model for model in (
    CrossCheckModel(
        "FFRBeam", registry="FFRBeam", settings=(("boundary", "XFF"), ("load_s", 0.45), ("sensor_s", 0.04)),
        what="FFRBeam in flexfmu's native runtime (the LTI kind: C only, the linear model stepped exactly by its "
             "zero-order-hold matrix exponential): the FFR discontinuous-beam model (Koda et al. 2025) of the "
             "paper's spatial double-L rod clamped at its base (XFF), 6 modes",
        scenario="the paper's virtual hammer test: a 1 ms half-sine blow of (20, 14, 8) N at s = 0.45 m, the "
                 "accelerometer at s = 0.04 m", stop_time=0.05,
        pulses=(Pulse("F_x", 20.0, 0.0, 1e-3), Pulse("F_y", 14.0, 0.0, 1e-3), Pulse("F_z", 8.0, 0.0, 1e-3)),
        outputs=("sensor_a_x", "sensor_a_y", "sensor_a_z", "tip_u_x", "tip_u_y", "tip_u_z", "reaction_F_x",
                 "reaction_F_y", "reaction_F_z", "elastic_energy")),
    CrossCheckModel(
        "ReframeBody", registry="ReframeBody",
        what="ReframeBody in flexfmu's native runtime (the reframe kind, C only, scheme exponential): a free "
             "flexible body by the reframe integrator (Liu), large rigid motion plus vibration; the paper's "
             "plate, 10 flexible modes",
        scenario="the paper's load case: 50 N along (1, 0, 1)/sqrt(2), global, at the load point as a 10 ms "
                 "half-sine; the plate, at rest before, flies off turning about y while its modes ring",
        stop_time=0.5,
        pulses=(Pulse("F_x", 50.0 / math.sqrt(2.0), 0.0, 0.01), Pulse("F_z", 50.0 / math.sqrt(2.0), 0.0, 0.01)),
        outputs=("pos_x", "pos_z", "vel_x", "vel_z", "q_y", "omega_2", "out_pos_z", "out_acc_x", "out_acc_z",
                 "max_elastic_displacement")),
    CrossCheckModel(
        "BracketClamped",
        what="the steel bracket of examples/bracket (a gmsh mesh of 10-node tetrahedra) exported by flexfmu as "
             "a native FMU (the LTI kind): `flexfmu export examples/bracket/bracket.json -o BracketClamped.fmu "
             "--clamp bolt_1,bolt_2 --interface tip=arm_top --modes 6 --runtime native`, a body clamped at "
             "its two bolt holes to a moving base with one interface at the top of its arm",
        scenario="a shock test: a 2 ms half-sine of 20 g upwards (z) on the base, then at 25 ms a 1 ms tap of 5 N "
                 "on the tip along y", stop_time=0.05,
        pulses=(Pulse("base_a_z", 20.0 * G, 0.0, 2e-3), Pulse("tip.F_y", 5.0, 0.025, 1e-3)),
        outputs=("tip.vel_x", "tip.vel_y", "tip.vel_z", "tip.acc_y", "tip.acc_z", "reaction_F_y",
                 "reaction_F_z", "reaction_M_x", "reaction_M_y", "reaction_M_z")),
)}
#: the bracket's model in a source checkout (examples/ is not part of an installed flexfmu)
BRACKET = Path(__file__).resolve().parents[3] / "examples" / "bracket" / "bracket.json"


@dataclass
class CrossCheckReport:
    """What :func:`generate` wrote, skipped (and why), found (fmpy's validator, the rules, the self-check) and
    measured: {(model, FMI version, interface): (variable, max |fmpy - reference| / max |reference|)}."""

    folders: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    problems: list = field(default_factory=list)
    differences: dict = field(default_factory=dict)
    validated: int = 0          # model folders fmpy's validator checked


# ---------------------------------------------------------------------------------------------- the FMU side
def accepts_interface(builder) -> bool:
    """Whether ``builder`` (build_registry_fmu, export_native) takes ``interface`` (model exchange)."""
    try:
        return "interface" in inspect.signature(builder).parameters
    except (TypeError, ValueError):
        return False


def _bracket_body(path: Path):
    """The bracket exported clamped at its bolts, interface tip at the arm's top, its 6 lowest modes (475 Hz to
    5.4 kHz, beyond the shock's and the tap's content; about 1 s to build, where --f-max 2000 and its residual
    vectors take about 5)."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.importers import load_structure

    structure = load_structure(path)
    return build_body(structure, interfaces=[interface_from_text("tip=arm_top")],
                      clamp=clamp_from_text(structure, "bolt_1,bolt_2"), n_modes=6)


def _build(model: CrossCheckModel, body, target: Path, fmi_version: int, interface: str) -> Path:
    """The model's native FMU at ``target``; ``interface`` "me" through the builder's ``interface`` (the caller
    has checked :func:`accepts_interface` of ``_builder``)."""
    options = {"target": target, "fmi_version": fmi_version, **({} if interface == "cs" else {"interface": interface})}
    if model.registry:
        return _builder(model)(model.registry, dict(model.settings), **options)
    return _builder(model)(body, **options)


def _builder(model: CrossCheckModel):
    from flexfmu.fmi import native
    return native.build_registry_fmu if model.registry else native.export_native


def binary_folders(fmu: Path) -> list[str]:
    """The binaries/ folders of ``fmu`` that hold a library."""
    with zipfile.ZipFile(fmu) as archive:
        return sorted({n.split("/")[1] for n in archive.namelist() if n.startswith("binaries/") and n.count("/") == 2
                       and not n.endswith("/")})


def platform_folders(fmu: Path, fmi_version: int, wanted) -> tuple[list[str], list[str]]:
    """(the cross-check platform folders of ``fmu`` among ``wanted`` (PLATFORM_NAMES in either spelling; None:
    all), the binaries with no folder in FMI ``fmi_version``'s cross-check and why)."""
    have, folders, left = binary_folders(fmu), [], []
    for name2, name3 in PLATFORM_NAMES.items():
        if wanted is None or name2 in wanted or name3 in wanted:
            name = name3 if fmi_version == 3 else name2 if name2 in RULES_PLATFORMS else None
            if name in have:
                folders.append(name)
            elif name is None and name3 in have:
                left.append(f"binaries/{name3}: the cross-check rules name no FMI 2.0 platform for it")
    return folders, left


# ---------------------------------------------------------------------------------------------- the reference
def input_staircase(model: CrossCheckModel, inputs: list, step: float, n_steps: int):
    """(t_k, the inputs at t_k in ``inputs`` order, the _in.csv rows): the pulses sampled at t_k = k step and held
    over the step; a jump at t_k is two rows at t_k, the held value before and after."""
    unknown = [p.input for p in model.pulses if p.input not in inputs]
    require(not unknown, "inputs", f"{model.name} has no input {', '.join(unknown)}", ", ".join(inputs))
    t = np.arange(n_steps + 1) * step
    u = np.zeros((n_steps + 1, len(inputs)))
    for pulse in model.pulses:
        u[:, inputs.index(pulse.input)] += pulse(t)
    rows = [[t[0], *u[0]]]
    for k in range(1, n_steps + 1):
        if not np.array_equal(u[k], u[k - 1]):
            rows += [[t[k], *u[k - 1]], [t[k], *u[k]]]
    return t, u, rows + ([[t[-1], *u[-1]]] if rows[-1][0] < t[-1] else [])


def reference_run(spec, config, inputs: list, u: np.ndarray, step: float, outputs: tuple) -> np.ndarray:
    """The reference: the library's simulator of ``spec`` with ``config`` (the Python model the FMU wraps),
    stepped as the Python runtime steps it (flexfmu.fmi.plumbing: inputs given when they change, held over the
    step), the inputs ``u`` (rows at t_k, columns in ``inputs`` order); the ``outputs`` at t_0 ... t_n."""
    from flexfmu.fmi.plumbing import ALL, PythonInstance, PythonModel

    instance = PythonInstance(PythonModel(spec), spec.make_simulator(config))
    order = [inputs.index(name) for name in spec.input_names]
    columns = [list(spec.output_names).index(name) for name in outputs]
    instance.give_inputs(u[0, order].tolist())
    rows = [instance.outputs(ALL)]
    for k in range(len(u) - 1):
        if k and not np.array_equal(u[k], u[k - 1]):
            instance.give_inputs(u[k, order].tolist())
        instance.step(step)
        rows.append(instance.outputs(ALL))
    return np.asarray(rows, dtype=float)[:, columns]


# ---------------------------------------------------------------------------------------------- the files
def _number(value) -> str:
    """A C floating-point literal that reads back as the same double (the rules' CSV numbers)."""
    value = float(value)
    if not math.isfinite(value):
        raise NonFiniteError("reference", f"a value that is not finite ({value})")
    return repr(value)


def write_csv(path: Path, names, rows) -> None:
    """The rules' CSV: quoted names in the first line, unquoted numbers, commas between elements only."""
    lines = [",".join(f'"{name}"' for name in names), *(",".join(_number(v) for v in row) for row in rows)]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


def write_opt(path: Path, stop_time: float, step: float) -> None:
    """_ref.opt: the required elements and OutputIntervalLength (SolverType left out: fmpy reads numbers only)."""
    options = dict(StartTime=0.0, StopTime=stop_time, StepSize=step, RelTol=REL_TOL, OutputIntervalLength=step)
    path.write_text("".join(f"{k}, {_number(v)}\n" for k, v in options.items()), encoding="ascii")


def _table(rows, header) -> str:
    return "\n".join("| " + " | ".join(map(str, row)) + " |" for row in [header, ["---"] * len(header), *rows])


def readme(model: CrossCheckModel, fmu: Path, fmi_version: int, interface: str, platform: str, step: float,
           n_rows: int, others: list, check: str) -> str:
    """README.md of one model folder."""
    from fmpy import read_model_description

    from flexfmu import __version__

    md = read_model_description(str(fmu))
    info = {v.name: (v.unit or "", v.description or "") for v in md.modelVariables}
    with zipfile.ZipFile(fmu) as archive:
        build = json.loads(archive.read("resources/flexfmu_build.json"))
    pulses = _table([(f"`{p.input}`", *info[p.input], f"{p.amplitude:.6g}", f"{p.start:g}", f"{p.width:g}")
                     for p in model.pulses], ("input", "unit", "description", "amplitude", "start (s)", "width (s)"))
    outputs = _table([(f"`{n}`", *info[n]) for n in model.outputs], ("variable", "unit", "description"))
    fixed = ", ".join(f"{k} = {v!r}" for k, v in build.get("parameters_fixed", {}).items())
    model_line = "" if model.registry else f"The model: {build.get('source', '')}.\n\n"
    simulator = (f"`{md.modelName}`'s simulator class of flexfmu.fmi.registry" if model.registry
                 else "flexfmu.body.simulator.FlexBodySimulator of the exported body")
    kind = {"cs": "co-simulation", "me": "model exchange"}[interface]
    return f"""# {model.name}: flexfmu {__version__}, FMI {FMI_FOLDERS[fmi_version]} {kind}, {platform}

{model.what[0].upper() + model.what[1:]}.

| file | what |
|---|---|
| `{model.name}.fmu` | the FMU; binaries {", ".join(binary_folders(fmu))}: the same file is in {", ".join(others)} |
| `{model.name}_in.csv` | every input of the FMU; the pulses below, held over each communication step |
| `{model.name}_ref.csv` | the reference result, {n_rows} rows (below) |
| `{model.name}_ref.opt` | StartTime 0, StopTime {model.stop_time:g} s, StepSize {step:g} s (the FMU's DefaultExperiment step), RelTol {REL_TOL:g} (for a model-exchange importer's solver), OutputIntervalLength {step:g} s |

{model_line}Parameters fixed at build: {fixed or "none"}; the others at their start values in the modelDescription.

## Inputs

{model.scenario[0].upper() + model.scenario[1:]}. The other inputs are 0.

{pulses}

Each pulse is sampled at t_k = k {step:g} s and held until t_k+1: a change at t_k is two rows at t_k in the _in.csv
(before, after), so an importer interpolating linearly, as the rules say, applies the held value.

## How the reference was made

Not with the FMU: with flexfmu's library simulator of the model ({simulator}, the Python model the FMU's C model
was built from; the same parameters), stepped as flexfmu's Python runtime steps it (flexfmu.fmi.plumbing: the
inputs set when they change, then a step of {step:g} s), the outputs read after every step. Numbers are written
with 17 significant digits at most (each reads back as the same double).

{outputs}

## Reproduce

    from fmpy import simulate_fmu
    from fmpy.util import read_csv
    result = simulate_fmu("{model.name}.fmu", stop_time={model.stop_time!r}, step_size={step!r}, output_interval={step!r},
                          input=read_csv("{model.name}_in.csv"))

Regenerate: `flexfmu cross-check OUT_DIR --model {model.name} --fmi-version {fmi_version} --interface {interface}`.

## Checked

{check}
"""


# ---------------------------------------------------------------------------------------------- checks
def self_check(folder: Path) -> tuple[str | None, dict]:
    """fmpy simulating the folder's FMU as fmpy.cross_check does, judged by fmpy's validate_result: (its problem or
    None, {variable of _ref.csv: max |result - reference| / max |reference|})."""
    from fmpy import simulate_fmu
    from fmpy.cross_check import validate_result
    from fmpy.util import read_csv, read_ref_opt_file

    name, inputs = folder.name, folder / f"{folder.name}_in.csv"
    opt, reference = read_ref_opt_file(str(folder / f"{name}_ref.opt")), read_csv(str(folder / f"{name}_ref.csv"))
    me = folder.parents[3].name == "me"          # <cs|me>/<platform>/flexfmu/<version>/<Model>
    result = simulate_fmu(str(folder / f"{name}.fmu"), validate=False, step_size=opt["StepSize"],
                          stop_time=opt["StopTime"], input=read_csv(str(inputs)) if inputs.exists() else None,
                          output=list(reference.dtype.names[1:]), fmi_type="ModelExchange" if me else "CoSimulation",
                          relative_tolerance=opt["RelTol"] if me else None)
    problem = validate_result(result=result, reference=reference, t_start=opt["StartTime"], t_stop=opt["StopTime"])
    # an input's jump at t_k: model exchange records t_k before and after it; the reference's row is the one before
    rows = np.searchsorted(result["time"], reference["time"] - 1e-9 * opt["StepSize"])
    if rows[-1] >= len(result) or not np.allclose(result["time"][rows], reference["time"], rtol=0, atol=1e-9):
        return problem or f"{len(result)} samples at other times than the reference's {len(reference)}", {}
    result = result[rows]
    return problem, {v: float(np.max(np.abs(result[v] - reference[v]))) / (float(np.max(np.abs(reference[v]))) or 1.0)
                     for v in reference.dtype.names[1:]}


def rule_problems(folder: Path) -> list[str]:
    """What the rules ask that fmpy's validator does not check: a README, the reference from StartTime to
    StopTime, at most 10 reference variables, the names quoted, every input of the FMU in _in.csv."""
    from fmpy import read_model_description
    from fmpy.util import read_csv, read_ref_opt_file

    name, path = folder.name, folder / f"{folder.name}_in.csv"
    opt, reference = read_ref_opt_file(str(folder / f"{name}_ref.opt")), read_csv(str(folder / f"{name}_ref.csv"))
    inputs = {v.name for v in read_model_description(str(folder / f"{name}.fmu")).modelVariables
              if v.causality == "input"}
    found = {
        "no README.md": not any((folder / f"README.{ext}").exists() for ext in ("md", "txt")),
        "the reference does not run from StartTime to StopTime": not (
            reference["time"][0] == opt["StartTime"] and math.isclose(reference["time"][-1], opt["StopTime"])),
        f"the reference has more than {MAX_REFERENCE_VARIABLES} variables": (
            len(reference.dtype.names) - 1 > MAX_REFERENCE_VARIABLES),
        "a CSV's names are not all quoted": not all(
            n.startswith('"') and n.endswith('"') for csv in folder.glob("*.csv")
            for n in csv.read_text().splitlines()[0].split(",")),
        f"{path.name} does not hold exactly the FMU's inputs": bool(inputs) and (
            not path.exists() or set(read_csv(str(path)).dtype.names[1:]) != inputs),
    }
    return [f"{folder}: {text}" for text, bad in found.items() if bad]


def validate(out_dir) -> tuple[int, list[str]]:
    """fmpy's cross-check validator on ``out_dir`` (a vendor repository's root, holding fmus/):
    fmpy.cross_check.validate_vendor_repo.validate_repo (which walks FMI 1.0 and 2.0 and the rules' platforms), and
    its validate_test_fmu on the model folders it leaves out (FMI 3.0); (the model folders validated, problems)."""
    from fmpy.cross_check.validate_vendor_repo import validate_repo, validate_test_fmu

    out_dir = Path(out_dir)
    _, _, problems = validate_repo(str(out_dir))          # its count includes the folders it leaves out
    folders = sorted(p for p in (out_dir / "fmus").glob("*/*/*/*/*/*") if p.is_dir())
    for folder in folders:
        version, _, platform = folder.relative_to(out_dir / "fmus").parts[:3]
        if version not in ("1.0", "2.0") or platform not in RULES_PLATFORMS:
            problems += validate_test_fmu(str(folder))
    return len(folders), list(problems)


# ---------------------------------------------------------------------------------------------- the package
def _check_choice(name: str, values, allowed) -> tuple:
    values = tuple(values)
    bad = [v for v in values if v not in allowed]
    if bad or not values:
        raise ParameterError(name, f"got {bad[0]!r}" if bad else "none given", " | ".join(map(str, allowed)))
    return values


def generate(out_dir, *, models=tuple(MODELS), fmi_versions=(2, 3), interfaces=("cs",), platforms=None,
             bracket=None, log=None) -> CrossCheckReport:
    """Write the cross-check folders of ``models`` for ``fmi_versions`` (2, 3), ``interfaces`` ("cs", "me") and
    ``platforms`` (PLATFORM_NAMES in either spelling; None: every platform each FMU has a binary for) under
    ``out_dir``/fmus (a model folder written is emptied first), then validate them (:func:`validate`,
    :func:`rule_problems`, :func:`self_check` where this host runs the FMU).  ``bracket``: examples/bracket's
    bracket.json (default: the source checkout's).  ``log``: a function given one line per folder written."""
    from flexfmu import __version__

    models = _check_choice("model", models, tuple(MODELS))
    fmi_versions = _check_choice("fmi-version", fmi_versions, tuple(FMI_FOLDERS))
    interfaces = _check_choice("interface", interfaces, INTERFACES)
    names = [n for pair in PLATFORM_NAMES.items() for n in pair if n]
    wanted = None if platforms is None else set(_check_choice("platform", platforms, names))
    out_dir, report, log = Path(out_dir), CrossCheckReport(), log or (lambda line: None)
    if out_dir.exists() and not out_dir.is_dir():
        raise ParameterError("out_dir", f"{out_dir} is a file", "a folder (made if missing)")
    bracket = Path(bracket) if bracket is not None else BRACKET
    for name in models:
        model, body, reference = MODELS[name], None, None
        if not model.registry and not bracket.is_file():
            report.notes.append(f"{name}: skipped: no {bracket} (examples/bracket of a source checkout)")
            continue
        body = None if model.registry else _bracket_body(bracket)
        for interface, version in [(i, v) for i in interfaces for v in fmi_versions]:
            if interface != "cs" and not accepts_interface(_builder(model)):
                report.notes.append(f"{name}: FMI {FMI_FOLDERS[version]} {interface} skipped: flexfmu.fmi.native."
                                    f"{_builder(model).__name__} builds co-simulation FMUs only")
                continue
            with tempfile.TemporaryDirectory(prefix="flexfmu-cross-check-") as staging:
                try:
                    fmu = _build(model, body, Path(staging) / f"{name}.fmu", version, interface)
                except ParameterError as exc:
                    if interface == "cs":
                        raise
                    report.notes.append(f"{name}: FMI {FMI_FOLDERS[version]} {interface} skipped: {exc}")
                    continue
                folders, left = platform_folders(fmu, version, wanted)
                report.notes += [f"{name}: FMI {FMI_FOLDERS[version]} {interface}: {text}" for text in left]
                reference = reference or _reference(model, body, fmu)
                _write_folders(out_dir, model, fmu, version, interface, folders, reference, report, log, __version__)
    report.validated, problems = validate(out_dir)
    report.problems[:0] = problems
    return report


def _reference(model: CrossCheckModel, body, fmu: Path) -> dict:
    """The model's inputs and reference (the same for every FMI version, interface and platform)."""
    from fmpy import read_model_description

    from flexfmu.fmi import registry
    from flexfmu.fmi.body_fmu import ExportedSpec

    md = read_model_description(str(fmu))
    step = float(md.defaultExperiment.stepSize)
    n_steps = int(round(model.stop_time / step))
    if not (math.isclose(n_steps * step, model.stop_time) and 0 < n_steps <= MAX_ROWS):
        raise ParameterError("stop_time", f"{model.name}: {model.stop_time:g} s is not 1 .. {MAX_ROWS} steps of "
                             f"the FMU's {step:g} s", f"a multiple of {step:g} s up to {MAX_ROWS * step:g} s")
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    t, u, rows = input_staircase(model, inputs, step, n_steps)
    # the library's side, with the parameters the FMU is built with: the registry entry, or the exported body
    spec = registry.BY_NAME[model.registry] if model.registry else ExportedSpec(model.name, body.summary(), body)
    config = spec.config_class(**dict(model.settings))
    if set(spec.input_names) != set(inputs):
        raise ParameterError("inputs", f"{model.name}: the FMU's inputs are not the library's",
                             ", ".join(spec.input_names))
    y = reference_run(spec, config, inputs, u, step, model.outputs)
    return {"step": step, "inputs": inputs, "in_rows": rows, "ref_rows": np.column_stack([t, y])}


def _write_folders(out_dir, model, fmu, version, interface, folders, reference, report, log, version_text):
    """One model folder per platform: the FMU, the CSVs, the options, README.md; checked."""
    import fmpy

    paths = [out_dir / "fmus" / FMI_FOLDERS[version] / interface / p / TOOL / version_text / model.name
             for p in folders]
    for platform, folder in zip(folders, paths):
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir(parents=True)
        shutil.copyfile(fmu, folder / fmu.name)
        write_csv(folder / f"{model.name}_in.csv", ["time", *reference["inputs"]], reference["in_rows"])
        write_csv(folder / f"{model.name}_ref.csv", ["time", *model.outputs], reference["ref_rows"])
        write_opt(folder / f"{model.name}_ref.opt", model.stop_time, reference["step"])
    check = (f"Not simulated when this package was generated (on {sys.platform}/{host_platform.machine()}, which "
             "runs none of these folders' platforms); fmpy's validator found the files valid.")
    here = sys.platform.startswith("linux") and host_platform.machine() in ("x86_64", "AMD64")
    for folder in [path for p, path in zip(folders, paths) if here and p in ("linux64", "x86_64-linux")]:
        problem, differences = self_check(folder)
        worst = max(differences, key=differences.get, default=None)
        if problem:
            report.problems.append(f"{folder}: fmpy's cross-check comparison: {problem}")
        if worst is not None:
            report.differences[(model.name, version, interface)] = (worst, differences[worst])
        check = (f"On x86-64 Linux, when this package was generated: fmpy {fmpy.__version__} simulating "
                 f"`{model.name}.fmu` as fmpy.cross_check does (the _ref.opt's step, stop time and, for model "
                 f"exchange, RelTol; the _in.csv) {'passes' if problem is None else 'fails'} fmpy's comparison "
                 "with the reference "
                 f"(fmpy.cross_check.validate_result{': ' + problem if problem else ''}); the largest difference, "
                 "max |fmpy - reference| / max |reference| per variable, is "
                 + (f"{differences[worst]:.2g} (`{worst}`)." if worst else "not measured (other sample times)."))
    for platform, folder in zip(folders, paths):
        others = [f"{FMI_FOLDERS[version]}/{interface}/{p}" for p in folders]
        (folder / "README.md").write_text(
            readme(model, folder / fmu.name, version, interface, platform, reference["step"],
                   len(reference["ref_rows"]), others, check), encoding="utf-8")
        report.problems += rule_problems(folder)
        report.folders.append(folder)
        log(f"wrote {folder}")
