"""The reframe scheme registry (flexfmu.reframe.schemes: SCHEMES, register_scheme): a scheme defined in this file,
registered for its tests only, reaches every user of the registry without another edit: the integrator, ReframeBody's
simulator, an exported free body's simulator and its Python FMU (run by fmpy), the CLI's choices; the native export
refuses it by name, since the C runtime has no code for it.

The scheme, "consistent_halved", is the consistent scheme with every step taken as two kernel steps of half its length
(Scheme.substeps = 2).  So its run with step h is by construction the consistent scheme's with step h / 2, bit for bit
(the same kernel calls with the same arguments) -- which holds only if every path really steps with it -- and, RK4
being fourth order, its error is about 1/16 of the consistent scheme's at h.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from flexfmu.errors import ParameterError
from flexfmu.reframe.schemes import (SCHEMES, ConsistentScheme, ExponentialScheme, register_scheme, scheme_names,
                                     unregister_scheme)

NAME = "consistent_halved"
PLATE_IF = [{"name": "A", "point": [-0.5, 0.0, 0.01]}, {"name": "B", "point": [0.5, 0.0, 0.0], "radius": 0.03}]


class HalvedScheme(ConsistentScheme):
    """Classical RK4 on the kernels, each step of dt as two of dt / 2."""

    name = NAME
    substeps = 2
    native_code = None            # the native runtime has no code for it (ConsistentScheme's 1 is the consistent one)


@pytest.fixture
def halved():
    """HalvedScheme registered for one test, unregistered afterwards (other tests never see it)."""
    register_scheme(HalvedScheme)
    try:
        yield NAME
    finally:
        unregister_scheme(NAME)
    assert NAME not in SCHEMES


@pytest.fixture(scope="module")
def beam():
    from flexfmu.reframe.models import load_model
    return load_model("beam:spatial_double_L", elements_per_segment=4)


@pytest.fixture(scope="module")
def plate_body():
    from flexfmu.body.build import build_body
    from flexfmu.reframe.models import load_model
    body = build_body(load_model("paper_plate", divisions=(8, 2, 1)), interfaces=PLATE_IF, f_max=200.0,
                      tolerance=1e-3)
    assert body.kind == "free"
    return body


# --------------------------------------------------------------------------- the registry itself
def test_a_registered_scheme_is_listed_where_the_registry_is_read(halved):
    from flexfmu.cli import build_parser
    from flexfmu.reframe.integrator import SCHEMES as reexported

    assert NAME in SCHEMES and NAME in reexported                   # one live registry, re-exported
    assert NAME in scheme_names("for_bodies") and NAME not in scheme_names(lambda s: s.native_code is not None)
    assert build_parser().parse_args(["reframe", "paper_plate", "--scheme", NAME]).scheme == NAME


def test_registration_refuses_a_taken_name_or_native_code_and_keeps_the_built_in_schemes():
    class Again(ConsistentScheme):
        name = "exponential"

    class Inherits(ConsistentScheme):       # native_code 1 inherited: the native runtime would step consistent
        name = "inherits_native"

    class BadName(ConsistentScheme):
        name = "Not a name"
        native_code = None

    for cls in (Again, Inherits, BadName):
        with pytest.raises(ValueError):
            register_scheme(cls)
    with pytest.raises(TypeError):
        register_scheme(object)
    with pytest.raises(ValueError):
        unregister_scheme("consistent")
    assert tuple(SCHEMES) == ("consistent", "paper", "exponential")
    assert SCHEMES["exponential"] is ExponentialScheme


def test_unknown_names_are_refused_naming_the_registered_ones(halved):
    from flexfmu.body.simulator import FlexBodyConfig, FlexBodySimulator
    from flexfmu.reframe.integrator import ReframeIntegrator
    from flexfmu.reframe.models import load_model
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

    with pytest.raises(ParameterError) as exc:
        ReframeIntegrator(load_model("beam:spatial_double_L", elements_per_segment=2), 2, scheme="implicit")
    assert exc.value.parameter == "scheme" and NAME in exc.value.allowed and "paper" in exc.value.allowed
    with pytest.raises(ParameterError) as exc:
        ReframeBodySimulator(ReframeBodyConfig(scheme="implicit"))
    assert exc.value.parameter == "scheme" and NAME in exc.value.allowed


# --------------------------------------------------------------------------- (a) the integrator
def _run(integ, dt, n, load):
    from flexfmu.reframe.results import _state_vector
    integ.set_initial(omega0=[4.0, -2.0, 7.0])
    return _state_vector(integ.advance_steps(integ.state, dt, n, load))


def test_integrator_steps_with_the_registered_scheme(halved, beam):
    """Bit for bit the consistent scheme at dt / 2 (under a time-varying load: the stage loads of the half steps);
    its error against the consistent scheme at dt / 32 is about 1/16 of the consistent scheme's at dt, and it
    differs from that by no more than the consistent scheme's own error."""
    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, half_sine_pulse

    basis = modal_basis(beam, 4)
    load = PointLoad(12, half_sine_pulse([30.0, 0.0, 40.0], 0.004))
    dt, n = 1e-4, 100
    y_halved = _run(ReframeIntegrator(beam, basis, scheme=NAME), dt, n, load)
    consistent = ReframeIntegrator(beam, basis, scheme="consistent")
    assert np.array_equal(y_halved, _run(consistent, dt / 2, 2 * n, load))
    y_full = _run(consistent, dt, n, load)
    reference = _run(consistent, dt / 32, 32 * n, load)
    e_full, e_halved = np.linalg.norm(y_full - reference), np.linalg.norm(y_halved - reference)
    print(f"\nerrors at dt = {dt:g} s: consistent {e_full:.3g}, {NAME} {e_halved:.3g} (ratio {e_full / e_halved:.3g})")
    assert e_full > 1e3 * np.finfo(float).eps * np.linalg.norm(reference)     # a measurable error
    assert 10.0 <= e_full / e_halved <= 24.0                                    # fourth order: 16
    assert np.linalg.norm(y_halved - y_full) <= 1.1 * e_full


# --------------------------------------------------------------------------- (b) ReframeBody
def test_reframebody_simulator_takes_the_registered_scheme(halved):
    """ReframeBody with internal steps h in the registered scheme equals the consistent scheme with h / 2."""
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

    common = dict(model="beam:spatial_double_L", n_flexible_modes=4, omega0_1=3.0, omega0_3=-5.0,
                  load_point_x=0.0, load_point_y=0.0, load_point_z=0.0, output_point_x=0.0, output_point_y=0.0,
                  output_point_z=0.0)                         # the rod's first node (points must lie on the body)
    sims = [ReframeBodySimulator(ReframeBodyConfig(scheme=NAME, internal_step=2.5e-4, **common)),
            ReframeBodySimulator(ReframeBodyConfig(scheme="consistent", internal_step=1.25e-4, **common)),
            ReframeBodySimulator(ReframeBodyConfig(scheme="consistent", internal_step=2.5e-4, **common))]
    assert sims[0].integrator.scheme == NAME and sims[0].integrator.stability_limited
    outputs = []
    for sim in sims:
        sim.set_inputs(F_x=20.0, F_z=-50.0, M_y=2.0)
        for _ in range(20):
            sim.step(1e-3)
        outputs.append(sim.output_vector())
    assert np.array_equal(outputs[0], outputs[1])
    assert not np.array_equal(outputs[0], outputs[2])              # it is not the consistent scheme at h


# --------------------------------------------------------------------------- (c) an exported free body
def _internal_steps(body):
    """A fixed internal step h within the body's RK4 stability limit, with 1 ms an integer multiple of it."""
    from flexfmu.body.simulator import FlexBodyConfig, FlexBodySimulator
    limit = FlexBodySimulator(body, FlexBodyConfig(scheme="consistent")).engine.limit
    return 1e-3 / math.ceil(1e-3 / (0.9 * limit))


START = {"omega0_1": 2.0, "omega0_3": 5.0, "v0_y": 0.3}
INPUTS = {"A.F_x": 20.0, "A.F_z": 50.0, "B.F_y": -10.0, "B.M_y": 3.0}


def _simulate(body, steps, **config):
    """(output names, outputs at t = 0 and after each communication step of ``steps``) of the body's simulator."""
    from flexfmu.body.simulator import FlexBodyConfig, FlexBodySimulator
    sim = FlexBodySimulator(body, FlexBodyConfig(**START, **config))
    sim.set_inputs(**{k: v for k, v in INPUTS.items() if k in sim.input_names})
    rows = [sim.output_vector()]
    for step in steps:
        sim.step(step)
        rows.append(sim.output_vector())
    return sim.output_names, np.array(rows)


def test_free_body_simulator_takes_the_registered_scheme(halved, plate_body):
    h = _internal_steps(plate_body)
    _, halved_rows = _simulate(plate_body, [1e-3] * 30, scheme=NAME, internal_step=h)
    _, consistent_rows = _simulate(plate_body, [1e-3] * 30, scheme="consistent", internal_step=h / 2)
    assert np.array_equal(halved_rows, consistent_rows)


@pytest.mark.fmu
def test_python_fmu_of_a_free_body_runs_the_registered_scheme(halved, plate_body, tmp_path):
    """The exported FMU (fmpy, in this process: the FMU's flexfmu is this one, with the scheme registered) with
    scheme consistent_halved: its outputs are the Python simulator's, and the consistent scheme's at h / 2, bit for
    bit."""
    fmpy = pytest.importorskip("fmpy")
    from flexfmu.fmi.export import export_fmu

    fmu = export_fmu(plate_body, tmp_path / "Plate.fmu")
    md = fmpy.read_model_description(str(fmu))
    names = [v.name for v in md.modelVariables if v.causality == "input"]
    signal = np.array([(0.0, *(INPUTS.get(n, 0.0) for n in names)), (1.0, *(INPUTS.get(n, 0.0) for n in names))],
                      dtype=[("time", float)] + [(n, float) for n in names])
    h, t_end = _internal_steps(plate_body), 0.03

    def run(**start):
        return fmpy.simulate_fmu(str(fmu), stop_time=t_end, step_size=1e-3, output_interval=1e-3, input=signal,
                                 start_values={**START, **start})

    halved_fmu = run(scheme=NAME, internal_step=h)
    consistent_fmu = run(scheme="consistent", internal_step=h / 2)
    coarse_fmu = run(scheme="consistent", internal_step=h)
    # the simulator with the host's steps (fmpy's t_{k+1} - t_k: 1 ms to a few ulps)
    names, rows = _simulate(plate_body, np.diff(halved_fmu["time"]), scheme=NAME, internal_step=h)
    assert len(halved_fmu) == len(rows) == 31
    for k, name in enumerate(names):
        assert np.array_equal(halved_fmu[name], rows[:, k]), name
        assert np.array_equal(halved_fmu[name], consistent_fmu[name]), name
    assert any(not np.array_equal(halved_fmu[n], coarse_fmu[n]) for n in names)


# --------------------------------------------------------------------------- (d) the native runtime
def test_native_export_refuses_the_registered_scheme_by_name(halved, plate_body, tmp_path):
    from flexfmu.fmi.native import export_native, registry_source

    with pytest.raises(ParameterError) as exc:
        export_native(plate_body, tmp_path / "Plate.fmu", scheme=NAME)
    assert exc.value.parameter == "scheme" and NAME in str(exc.value)
    assert exc.value.allowed.startswith("consistent | exponential,")          # those with a native form
    assert not (tmp_path / "Plate.fmu").exists()
    with pytest.raises(ParameterError) as exc:
        registry_source("ReframeBody", {"scheme": NAME})
    assert exc.value.parameter == "scheme" and NAME in str(exc.value) and exc.value.allowed.startswith("exponential,")
