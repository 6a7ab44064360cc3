"""The derived outputs of the native runtime (csrc/derived_stress.c, the LTI kind's ``lti.derived.*`` entries,
flexfmu.native.lti's extraction) against flexfmu.core.stress, the one Python home of the formulas, and the gauges of
FFRBeam and of an exported clamped body, native against Python.

- The C formulas equal core/stress.py bit for bit on the same inputs (the same operations in the same order,
  compiled without FMA contraction): von Mises of a tensor, a circle's, a tube's and a rectangle's largest axial and
  von Mises stresses, at random section forces and at zeros.
- A stand-in model (FFRBeam's linear outputs, three of them re-declared as derived from others: the extraction sees a
  probe whose outputs are evaluate_derived of the simulator's) is extracted with its derived rows out of the linear
  fit, checked through evaluate_derived, and refused when the simulator's values are not the declared formula's.
- FFRBeam with three gauges (``flexfmu build --runtime native --set gauge_K_s=...``) and examples/bracket with two
  (a node set's, a point's; export_native's steps): every output, the gauges' section forces, sigma_max, von_mises,
  stress and strain components among them, over a run with loads and base motion that move, equals the Python
  simulator's to RTOL of each output's scale (the derived ones read first, alone: their sources come with them);
  their directional derivatives equal central differences; FMI 3.0 gives FMI 2.0's gauges bit for bit.
- Bad derived entries in the model file are refused at instantiation naming the entry and its output; a model file
  without them loads.
"""
from __future__ import annotations

import ctypes
import dataclasses
import math
import shutil
import zipfile

import numpy as np
import pytest

from flexfmu.core.stress import DerivedStress, SectionFibres, evaluate_derived
from flexfmu.native import lti
from flexfmu.native.compiler import CompilerError

try:
    lti.library()
except CompilerError as exc:                     # pragma: no cover - no C compiler on this machine
    pytest.skip(f"no C compiler: {exc}", allow_module_level=True)

#: native against Python, per output, relative to its largest magnitude over the run (as tests/test_fmu_native.py):
#: the linear outputs agree to ~1e-14 and the formulas are Lipschitz with constant ~1 in that scale
RTOL = 1e-10
H = 1e-3

SECTIONS = {
    "circle": SectionFibres.of("circle", math.pi * 0.004**2, math.pi * 0.008**4 / 64, math.pi * 0.008**4 / 64,
                               math.pi * 0.008**4 / 32),
    "tube": SectionFibres.of("tube", math.pi * (0.01**2 - 0.008**2) / 4, math.pi * (0.01**4 - 0.008**4) / 64,
                             math.pi * (0.01**4 - 0.008**4) / 64, math.pi * (0.01**4 - 0.008**4) / 32),
    "rectangle": SectionFibres.of("rectangle", 0.02 * 0.005, 0.02 * 0.005**3 / 12, 0.005 * 0.02**3 / 12, 1.5e-9),
}


def _c_derived(derived, names, y) -> np.ndarray:
    """y with the derived outputs evaluated by the C (ffx_derived_evaluate)."""
    from flexfmu.native.lti_derived import derived_arrays
    a = derived_arrays(derived, names)
    y = np.ascontiguousarray(y, dtype=float).copy()
    lti.library().ffx_derived_evaluate(len(derived), *(a[k].ctypes.data for k in ("kind", "shape", "output",
                                                                                     "sources", "fibres")),
                                       None, y.ctypes.data)
    return y


# ---------------------------------------------------------------------------------------------- the formulas
def test_the_c_formulas_equal_core_stress_bit_for_bit(rng):
    names = tuple(f"s{k}" for k in range(6)) + ("N", "T", "My", "Mz") + tuple(f"d{k}" for k in range(7))
    derived = (DerivedStress("d0", "tensor_von_mises", names[:6]),
               *(DerivedStress(f"d{1 + 2 * k}", kind, ("N", "T", "My", "Mz"), fibres)
                 for k, fibres in enumerate(SECTIONS.values())
                 for kind in ("section_sigma_max",)),
               *(DerivedStress(f"d{2 + 2 * k}", "section_von_mises", ("N", "T", "My", "Mz"), fibres)
                 for k, fibres in enumerate(SECTIONS.values())))
    for trial in range(400):
        y = np.zeros(len(names))
        scale = 10.0 ** rng.uniform(-3, 8, size=10)
        y[:10] = rng.standard_normal(10) * scale * (rng.random(10) > 0.2)       # some exact zeros
        if trial == 0:
            y[:10] = 0.0
        mine = _c_derived(derived, names, y)
        theirs = y.copy()
        evaluate_derived(derived, names, theirs)
        assert np.array_equal(mine, theirs), (trial, mine - theirs)


# ---------------------------------------------------------------------------------------------- a stand-in model
#: FFRBeam's outputs, three of them re-declared as derived from others (units aside: the formulas do not care)
REACTIONS = ("reaction_F_x", "reaction_M_x", "reaction_M_y", "reaction_M_z")
STANDIN = (DerivedStress("elastic_energy", "section_von_mises", REACTIONS, SECTIONS["circle"]),
           DerivedStress("f_5", "section_sigma_max", REACTIONS, SECTIONS["rectangle"]),
           DerivedStress("f_6", "tensor_von_mises", ("reaction_F_x", "reaction_F_y", "reaction_F_z", "reaction_M_x",
                                                     "reaction_M_y", "reaction_M_z")))
#: XFF with the static correction and geometric stiffening on: every kind of output term
STANDIN_SETTINGS = {"boundary": "XFF", "load_s": 0.45, "sensor_s": 0.04, "static_correction": 1,
                    "geometric_stiffening": True, "damping_ratio": 0.01}


def _standin_simulator(**changes):
    from flexfmu.ffr.ffrbeam_config import FFRBeamConfig
    from flexfmu.ffr.simulator import FFRBeamSimulator
    return FFRBeamSimulator(FFRBeamConfig(**{**STANDIN_SETTINGS, **changes}))


def _standin_probe(sim, derived=STANDIN, formula=evaluate_derived):
    """The simulator's probe with ``derived`` declared and its outputs overwritten by ``formula``."""
    probe = sim.lti_probe()
    inner, names = probe.outputs, probe.output_names

    def outputs(x, v, p):
        y = np.array(inner(x, v, p), dtype=float)
        formula(derived, names, y)
        return y

    probe.outputs, probe.derived = outputs, tuple(derived)
    return probe


@pytest.fixture(scope="module")
def standin():
    sim = _standin_simulator()
    return sim, lti.extract(_standin_probe(sim))


def test_the_extraction_leaves_the_derived_outputs_out_of_the_fit_and_checks_them(standin, rng):
    sim, model = standin
    assert model.derived == STANDIN and model.fit_error["derived"] < 1e-13 and model.fit_error["outputs"] < 1e-13
    rows = [model.output_names.index(d.output) for d in STANDIN]
    assert not model.Cx[:, rows].any() and not model.Cu[:, rows].any() and not model.y0[:, rows].any()
    assert not np.isin(model.quad_row, rows).any()
    # the numpy model, the C kernel (linear part and derived outputs in C) and the arrays' round trip
    again = lti.LtiModel.from_arrays(model.arrays(), model.names(), model.kind)
    assert again.derived == model.derived
    kernel = model.kernel()
    for _ in range(5):
        x, u = rng.standard_normal(model.nx) * 1e-3, rng.standard_normal(model.nu)
        p = np.r_[0.01, rng.standard_normal(model.np - 1)]
        y = model.outputs(x, u, p)
        linear = y.copy()
        linear[rows] = 0.0
        expected = linear.copy()
        evaluate_derived(STANDIN, model.output_names, expected)
        assert np.array_equal(y, expected)
        c = kernel.outputs(x, u, p)
        assert np.allclose(c, y, rtol=1e-12, atol=0.0)
        assert np.array_equal(c, _c_derived(STANDIN, model.output_names, np.where(np.isin(range(model.ny), rows),
                                                                                   0.0, c)))


def test_derived_values_that_are_not_the_formula_are_refused():
    """A simulator whose declared derived outputs are not what it outputs (here: without the torsion) is refused."""
    def without_torsion(derived, names, y):
        evaluate_derived(derived, names, y)
        d = derived[0]
        index = {n: k for k, n in enumerate(names)}
        y[index[d.output]] = d.fibres.sigma_max(*(y[index[s]] for s in (d.sources[0], d.sources[2], d.sources[3])))

    with pytest.raises(lti.ContractError, match="derived"):
        lti.extract(_standin_probe(_standin_simulator(), formula=without_torsion))


def test_a_model_refuses_derived_outputs_it_does_not_have(standin):
    from flexfmu.errors import ParameterError
    _, model = standin
    bad = DerivedStress("no_such_output", "tensor_von_mises", STANDIN[2].sources)
    with pytest.raises(ParameterError, match="derived_outputs"):
        dataclasses.replace(model, derived=(bad,))
    chained = DerivedStress("f_4", "tensor_von_mises", ("elastic_energy", *STANDIN[2].sources[1:]))
    with pytest.raises(ParameterError, match="derived_outputs"):
        dataclasses.replace(model, derived=(*STANDIN, chained))


# ---------------------------------------------------------------------------------------------- the stand-in FMU
def _inputs(t: float) -> dict:
    """Loads (N, N m, body frame) and base motion (rad/s, rad/s^2, m/s^2) that move at every step."""
    two_pi = 2.0 * math.pi
    w = {"x": 0.3 * math.sin(two_pi * 0.5 * t), "y": 0.2 * math.cos(two_pi * 0.4 * t), "z": 0.1 * math.sin(3.0 * t)}
    dw = {"x": 0.3 * two_pi * 0.5 * math.cos(two_pi * 0.5 * t), "y": -0.2 * two_pi * 0.4 * math.sin(two_pi * 0.4 * t),
          "z": 0.3 * math.cos(3.0 * t)}
    return {"F_x": 20.0 * math.sin(two_pi * 3.0 * t), "F_y": 7.0 * math.cos(two_pi * 5.0 * t),
            "F_z": 4.0 * math.sin(two_pi * 2.0 * t + 1.0), "M_x": 0.5 * math.sin(two_pi * 4.0 * t),
            "M_y": 0.3 * math.cos(two_pi * 1.5 * t), "M_z": 0.2 * math.sin(two_pi * 7.0 * t),
            "base_a_x": 2.0 * math.sin(two_pi * 0.7 * t), "base_a_y": 1.5 * math.cos(two_pi * 0.9 * t),
            "base_a_z": -9.81 + 0.5 * math.sin(two_pi * 1.1 * t),
            **{f"base_w_{a}": v for a, v in w.items()}, **{f"base_dw_{a}": v for a, v in dw.items()}}


def _input_vector(names, t: float) -> list:
    """The FMU inputs ``names`` at t (an exported body's NAME.F_x as FFRBeam's F_x)."""
    values = _inputs(t)
    return [values[n.rpartition(".")[2]] for n in names]


def python_run(sim, derived, inputs, outputs, n_steps: int, h: float = H) -> np.ndarray:
    """The Python simulator's outputs at 0, h, .. n h, the derived ones by evaluate_derived: the inputs at t_k held
    over the step after t_k, the outputs at t_k (k > 0) those of the state with the inputs its step held (a native
    co-simulation FMU's inputs are held from fmi2DoStep on)."""
    rows = []
    for k in range(n_steps + 1):
        if k:
            sim.step(h)
        y = np.array(sim.output_vector(), dtype=float) if k else None
        sim.set_input_vector(_input_vector(inputs, k * h))
        if not k:
            y = np.array(sim.output_vector(), dtype=float)
        evaluate_derived(derived, outputs, y)
        rows.append(y)
    return np.array(rows)


def relative_errors(mine, ref) -> np.ndarray:
    """Per output: max over the run of |mine - ref| / max |ref| (1 for an output that is zero all along)."""
    scale = np.abs(ref).max(axis=0)
    return np.abs(mine - ref).max(axis=0) / np.where(scale > 0, scale, 1.0)


def native_run(fmu, inputs, outputs, n_steps: int, h: float = H, first=(), **start):
    """(the outputs ``outputs`` at 0, h, .. n h as python_run's, the outputs ``first`` as read alone before the
    others) of the native FMU ``fmu`` with the FMU inputs ``inputs``."""
    from fmu_helpers import Instance
    inst = Instance(fmu, "gauges", **start)
    try:
        inst.set(**dict(zip(inputs, _input_vector(inputs, 0.0))))
        inst.initialize()
        rows, alone = [], []
        for k in range(n_steps + 1):
            if k:
                inst.fmu.doStep(currentCommunicationPoint=(k - 1) * h, communicationStepSize=h)
                inst.set(**dict(zip(inputs, _input_vector(inputs, k * h))))
            alone.append(inst.get(*first) if first else [])
            rows.append(inst.get(*outputs))
        return np.array(rows), np.array(alone)
    finally:
        inst.free()


#: the double L clamped at s = 0 (XFF), a gauge at the clamp, at the first corner and on the last segment, the static
#: correction and geometric stiffening on (every kind of output term)
FFR_SETTINGS = {"boundary": "XFF", "load_s": 0.45, "sensor_s": 0.04, "static_correction": 1,
                "geometric_stiffening": True, "gauge_1_s": 0.0, "gauge_2_s": 0.16, "gauge_3_s": 0.375}


def _ffrbeam_simulator():
    from flexfmu.ffr.ffrbeam_config import FFRBeamConfig
    from flexfmu.ffr.simulator import FFRBeamSimulator
    return FFRBeamSimulator(FFRBeamConfig(**FFR_SETTINGS))


@pytest.fixture(scope="module")
def ffrbeam_fmu(tmp_path_factory):
    """FFRBeam with three gauges, by ``flexfmu build --runtime native --fmu FFRBeam --set ...`` (co-simulation and
    model exchange)."""
    from flexfmu.cli import main as flexfmu
    out = tmp_path_factory.mktemp("ffrbeam")
    status = flexfmu(["build", "--runtime", "native", "--fmu", "FFRBeam",
                      *(a for k, v in FFR_SETTINGS.items() for a in ("--set", f"{k}={v}")),
                      "--interface", "both", "--out", str(out)])
    assert status == 0
    return out / "FFRBeam.fmu"


def test_ffrbeams_gauges_equal_the_python_simulator(ffrbeam_fmu):
    """Every output (the gauges' section forces, sigma_max and von_mises among them) over 0.4 s of moving loads and
    base motion, the derived ones also read alone first (their sources computed with them): the native FMU equals
    the Python simulator (whose output_vector fills the derived outputs) to RTOL of each output's scale."""
    from flexfmu.ffr.simulator import INPUT_NAMES, OUTPUT_NAMES
    sim = _ffrbeam_simulator()
    derived = sim.derived_outputs
    assert len(derived) == 6
    n = 400
    first = tuple(d.output for d in derived)
    ours, alone = native_run(ffrbeam_fmu, INPUT_NAMES, OUTPUT_NAMES, n, first=first)
    theirs = python_run(sim, (), INPUT_NAMES, OUTPUT_NAMES, n)
    errors = relative_errors(ours, theirs)
    worst = int(np.argmax(errors))
    assert errors.max() < RTOL, (OUTPUT_NAMES[worst], errors[worst])
    assert np.array_equal(alone, ours[:, [OUTPUT_NAMES.index(d) for d in first]])
    gauges = [k for k, name in enumerate(OUTPUT_NAMES) if name.startswith("gauge_")]
    assert len(gauges) == 24 and np.ptp(theirs[:, gauges], axis=0).min() > 0        # every gauge output moves


def test_ffrbeams_section_stresses_directional_derivatives_equal_central_differences(ffrbeam_fmu):
    """sigma_max and von_mises of the circle section (the chain rule through hypot and |.|) and their section forces,
    as the bracket's below."""
    _check_directional(ffrbeam_fmu, "gauge_", [d.output for d in _ffrbeam_simulator().derived_outputs])


def _instantiate_edited(fmu, tmp_path, edit) -> tuple[bool, list]:
    """Instantiate ``fmu`` with its model file's entries edited by ``edit`` (entries dict, in place): (instantiated,
    log messages); the instance is freed."""
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

    from flexfmu.fmi.model_file import MODEL_FILE, read_model_file, write_model_file
    folder = tmp_path / f"fmu{len(list(tmp_path.iterdir()))}"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    entries = read_model_file(folder / "resources" / MODEL_FILE)
    edit(entries)
    write_model_file(folder / "resources" / MODEL_FILE, entries)
    md = read_model_description(str(fmu))
    log = []
    logger = fmi2CallbackLoggerTYPE(lambda c, name, status, category, message: log.append(message.decode()))
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = logger
    callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
    callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="edited")
    try:
        slave.instantiate(callbacks=callbacks)
    except Exception:                     # fmpy: the instance is NULL
        slave.freeLibrary()
        return False, log
    slave.freeInstance()
    slave.freeLibrary()
    shutil.rmtree(folder, ignore_errors=True)
    return True, log


def _set(name, index, value):
    """An edit of the model file's entry ``name`` at ``index`` to ``value`` (a function of the model's number of
    outputs and of the stand-in's derived rows: the value may depend on them)."""
    def edit(entries):
        ny, rows = entries["lti.y0"].shape[1], list(entries["lti.derived.output"])
        entries[name][index] = value(ny, rows) if callable(value) else value
    return edit


@pytest.mark.parametrize("edit, output, what", [
    (_set("lti.derived.fibres", (0, 0), math.nan), "gauge_1_sigma_max", "section constant"),
    (_set("lti.derived.fibres", (1, 3), -1.0), "gauge_1_von_mises", "section constant"),
    (_set("lti.derived.kind", 2, 7), "gauge_2_sigma_max", "unknown kind"),
    (_set("lti.derived.shape", 2, 0), "gauge_2_sigma_max", "section shape"),
    (_set("lti.derived.sources", (1, 2), lambda ny, rows: ny), "gauge_1_von_mises", "source index"),
    (_set("lti.derived.sources", (1, 4), 0), "gauge_1_von_mises", "source index"),
    (_set("lti.derived.sources", (2, 0), lambda ny, rows: rows[0]), "gauge_2_sigma_max", "derived output as a source"),
    (_set("lti.derived.output", 1, lambda ny, rows: rows[0]), "gauge_1_sigma_max", "another entry computes"),
    (_set("lti.derived.output", 0, -1), "(none)", "output index"),
], ids=["nan-constant", "negative-J", "kind", "shape", "source-range", "source-padding", "chained", "twice",
        "output-range"])
def test_bad_derived_entries_are_refused_naming_the_entry(ffrbeam_fmu, tmp_path, edit, output, what):
    made, log = _instantiate_edited(ffrbeam_fmu, tmp_path, edit)
    assert not made
    assert any("lti.derived" in m and f"(output {output})" in m and what in m and "allowed:" in m for m in log), log


def test_a_model_file_without_derived_entries_loads(ffrbeam_fmu, tmp_path):
    """An older model file (no lti.derived.* entries) loads; a wrongly shaped one is refused naming it."""
    def drop(entries):
        for name in [n for n in entries if n.startswith("lti.derived.")]:
            del entries[name]
    made, log = _instantiate_edited(ffrbeam_fmu, tmp_path, drop)
    assert made, log

    def short(entries):
        entries["lti.derived.fibres"] = entries["lti.derived.fibres"][:, :6].copy()
    made, log = _instantiate_edited(ffrbeam_fmu, tmp_path, short)
    assert not made and any("lti.derived.fibres" in m for m in log), log


# ---------------------------------------------------------------------------------------------- an exported body
#: examples/bracket clamped at its bolts, a tip interface, two gauges: a node set's averaged nodal stress, a point's
BRACKET_GAUGES = ("root=bolt_1", "arm=0.04,0.02,0.003")


@pytest.fixture(scope="module")
def bracket(tmp_path_factory):
    """(body, its native FMU of FMI 2.0, of FMI 3.0), co-simulation and model exchange, by the steps of ``flexfmu
    export ... --runtime native --gauge ...`` (flexfmu.fmi.native.export_native: body_source, build_native_fmu) from
    one body, the one the Python reference runs: two builds of a body differ by the eigensolver's tolerance (~1e-10
    in the outputs, a mode's sign), more than what is compared here."""
    pytest.importorskip("meshio")
    from pathlib import Path

    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.native import body_source
    from flexfmu.fmi.native_build import build_native_fmu
    from flexfmu.importers import load_structure
    structure = load_structure(Path(__file__).resolve().parents[1] / "examples" / "bracket" / "bracket.json")
    body = build_body(structure, interfaces=[interface_from_text("tip=arm_top")],
                      clamp=clamp_from_text(structure, "bolt_1,bolt_2"), n_modes=8, gauges=list(BRACKET_GAUGES))
    source, out = body_source(body, "BracketGauges"), tmp_path_factory.mktemp("bracket")
    return body, *(build_native_fmu(source, out / f"fmi{v}" / "BracketGauges.fmu", fmi_version=v, interface="both")
                   for v in (2, 3))


def test_the_exported_bodys_gauges_equal_the_python_simulator(bracket):
    """Every output (the gauges' stress and strain components and von Mises among them) over 0.3 s of moving
    interface loads and base motion: the native FMU equals the body's Python simulator to RTOL."""
    from flexfmu.body.simulator import FlexBodySimulator
    body, fmu, _ = bracket
    sim = FlexBodySimulator(body, body.config_class())
    names = tuple(sim.output_names)
    gauges = [k for k, n in enumerate(names) if n.startswith(("root.", "arm."))]
    assert len(gauges) == 2 * 13 and len(sim.derived_outputs) == 2
    n = 300
    first = tuple(d.output for d in sim.derived_outputs)
    ours, alone = native_run(fmu, tuple(sim.input_names), names, n, first=first)
    theirs = python_run(sim, sim.derived_outputs, tuple(sim.input_names), names, n)
    errors = relative_errors(ours, theirs)
    worst = int(np.argmax(errors))
    assert errors.max() < RTOL, (names[worst], errors[worst])
    assert np.array_equal(alone, ours[:, [names.index(d) for d in first]])
    assert np.ptp(theirs[:, gauges], axis=0).min() > 0          # every gauge output moves


def _check_directional(fmu, prefixes, derived):
    """The outputs named ``prefixes``* (the gauges'), ``derived`` among them: fmi2GetDirectionalDerivative against
    central differences of the model-exchange instance at a random state and random inputs (tests/test_fmu_directional
    .py's jacobians, at steps 1e-4 of each known's scale: the stresses are smooth away from their kinks (zero), so
    the differences err by (1e-4)^2 of their curvature and by rounding eps |y| / 1e-4); errors relative to each
    output's largest sensitivity."""
    from me_helpers import MeInstance
    from test_fmu_directional import jacobians, random_point
    inst = MeInstance(fmu, "me")
    try:
        x, inputs = random_point(inst, seed=11)
        exact, central, scales = jacobians(inst, x, inputs, step=1e-4)
        names = [v.name for v in inst.md.modelVariables if v.causality == "output"]
    finally:
        inst.free()
    rows = [k for k, n in enumerate(names) if n.startswith(prefixes)]
    sensitivity = np.max(np.abs(exact[rows]) * scales, axis=1)
    assert (sensitivity > 0).all()
    error = np.abs(exact - central)[rows] * scales / sensitivity[:, None]
    worst = np.unravel_index(error.argmax(), error.shape)
    assert error.max() < 1e-6, (names[rows[worst[0]]], error.max())
    assert all(np.abs(exact[names.index(d)]).max() > 0 for d in derived)


def test_the_bodys_gauges_directional_derivatives_equal_central_differences(bracket):
    """The gauges' von Mises (the chain rule through csrc/derived_stress.c) and their stress and strain sources."""
    body, fmu, _ = bracket
    _check_directional(fmu, ("root.", "arm."), [d.output for d in body.derived_outputs()])


def test_fmi3_gives_the_fmi2_gauges_bit_for_bit(bracket):
    """The same binary and model file behind both: fmpy's simulate_fmu of each over 50 ms of moving inputs gives the
    same gauge outputs, bit for bit; and the FMUs carry every platform's binary whose compiler is installed (the
    cross-compiled targets compile derived_stress.c too)."""
    from fmpy import read_model_description, simulate_fmu

    from flexfmu.native.compiler import PLATFORMS, missing_platforms
    body, fmu2, fmu3 = bracket
    records = []
    for fmu in (fmu2, fmu3):
        md = read_model_description(str(fmu))
        inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        t = np.arange(0.0, 0.05 + H / 2, H)
        signals = np.zeros(len(t), dtype=[("time", float)] + [(n, float) for n in inputs])
        signals["time"] = t
        for k, time in enumerate(t):
            for n, v in zip(inputs, _input_vector(inputs, time)):
                signals[n][k] = v
        records.append(simulate_fmu(str(fmu), start_time=0.0, stop_time=0.05, step_size=H, output_interval=H,
                                    input=signals))
    gauges = [n for n in records[0].dtype.names if n.startswith(("root.", "arm."))]
    assert len(gauges) == 26
    for name in gauges:
        assert np.array_equal(records[0][name], records[1][name]), name
        assert np.ptp(records[0][name]) > 0, name
    with zipfile.ZipFile(fmu2) as archive:
        folders = {n.split("/")[1] for n in archive.namelist() if n.startswith("binaries/")}
    assert folders == {p.name for p in PLATFORMS} - set(missing_platforms())
