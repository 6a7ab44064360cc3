"""The derived outputs of the native runtime (csrc/derived_stress.c, the LTI kind's ``lti.derived.*`` entries,
flexfmu.native.lti's extraction) against flexfmu.core.stress, the one Python home of the formulas.

- The C formulas equal core/stress.py bit for bit on the same inputs (the same operations in the same order,
  compiled without FMA contraction): von Mises of a tensor, a circle's, a tube's and a rectangle's largest axial and
  von Mises stresses, at random section forces and at zeros.
- A stand-in model (FFRBeam's linear outputs, some of its outputs re-declared as derived from others: the extraction
  sees a probe whose outputs are evaluate_derived of the simulator's) is extracted with its derived rows out of the
  linear fit, checked through evaluate_derived, and refused when the simulator's derived values are not the formula's.
- The stand-in built as a native FMU: its derived outputs over a run with loads and base motion that move equal the
  Python simulator's (with evaluate_derived) to 1e-10 of each output's scale; a derived output read alone brings its
  sources; its directional derivatives equal central differences; bad model-file entries are refused at
  instantiation naming the entry and its output; a model file without the entries loads as before.
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


def python_run(sim, derived, n_steps: int, h: float = H) -> np.ndarray:
    """The Python simulator's outputs at 0, h, .. n h, the derived ones by evaluate_derived: the inputs at t_k held
    over the step after t_k, the outputs at t_k (k > 0) those of the state with the inputs its step held (a native
    co-simulation FMU's inputs are held from fmi2DoStep on)."""
    from flexfmu.ffr.simulator import INPUT_NAMES, OUTPUT_NAMES
    rows = []
    for k in range(n_steps + 1):
        if k:
            sim.step(h)
        y = np.array(sim.output_vector(), dtype=float) if k else None
        v = _inputs(k * h)
        sim.set_input_vector([v[n] for n in INPUT_NAMES])
        if not k:
            y = np.array(sim.output_vector(), dtype=float)
        evaluate_derived(derived, OUTPUT_NAMES, y)
        rows.append(y)
    return np.array(rows)


def relative_errors(mine, ref) -> np.ndarray:
    """Per output: max over the run of |mine - ref| / max |ref| (1 for an output that is zero all along)."""
    scale = np.abs(ref).max(axis=0)
    return np.abs(mine - ref).max(axis=0) / np.where(scale > 0, scale, 1.0)


def native_run(fmu, n_steps: int, h: float = H, first=(), **start) -> tuple[np.ndarray, np.ndarray]:
    """(every output at 0, h, .. n h as python_run's, the outputs ``first`` as read alone before the others)."""
    from fmu_helpers import Instance
    from flexfmu.ffr.simulator import INPUT_NAMES, OUTPUT_NAMES
    inst = Instance(fmu, "gauges", **start)
    try:
        inst.set(**_inputs(0.0))
        inst.initialize()
        rows, alone = [], []
        for k in range(n_steps + 1):
            if k:
                inst.fmu.doStep(currentCommunicationPoint=(k - 1) * h, communicationStepSize=h)
                inst.set(**{n: v for n, v in _inputs(k * h).items() if n in INPUT_NAMES})
            alone.append(inst.get(*first) if first else [])
            rows.append(inst.get(*OUTPUT_NAMES))
        return np.array(rows), np.array(alone)
    finally:
        inst.free()


@pytest.fixture(scope="module")
def standin_fmu(tmp_path_factory, standin):
    """The stand-in as a native FFRBeam FMU: the registry's source of STANDIN_SETTINGS with the stand-in model."""
    from flexfmu.fmi.native import registry_source
    from flexfmu.fmi.native_build import build_native_fmu
    source = registry_source("FFRBeam", STANDIN_SETTINGS)
    source.lti = standin[1]
    return build_native_fmu(source, tmp_path_factory.mktemp("standin") / "FFRBeam.fmu")


def test_the_stand_in_fmu_equals_the_python_simulator(standin_fmu):
    """Every output over 0.4 s of moving loads and base motion, the derived ones also read alone (their sources
    computed with them): equal to the Python simulator's with evaluate_derived to RTOL of each output's scale."""
    from flexfmu.ffr.simulator import OUTPUT_NAMES
    n = 400
    first = tuple(d.output for d in STANDIN)
    ours, alone = native_run(standin_fmu, n, first=first)
    theirs = python_run(_standin_simulator(), STANDIN, n)
    errors = relative_errors(ours, theirs)
    worst = int(np.argmax(errors))
    assert errors.max() < RTOL, (OUTPUT_NAMES[worst], errors[worst])
    rows = [OUTPUT_NAMES.index(d) for d in first]
    assert np.array_equal(alone, ours[:, rows])
    assert (np.abs(theirs[:, rows]).max(axis=0) > 0).all() and np.ptp(theirs[:, rows], axis=0).min() > 0
