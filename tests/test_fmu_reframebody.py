"""ReframeBody.fmu driven through fmpy against the library (flexfmu.reframe.integrator) and Newton's law."""
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.models import load_model
from flexfmu.reframe.plate import LOAD_POINT
from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, constant_load


@pytest.fixture
def body(fmu_instance):
    return lambda name="body", **start: fmu_instance("ReframeBody", name, **start)


def test_fmpy_validate_reports_no_problems(fmus):
    assert validate_fmu(str(fmus["ReframeBody"])) == []


@pytest.mark.parametrize("scheme", ["consistent", "paper"])
def test_paper_plate_through_fmpy_equals_library(body, scheme):
    """Communication steps of 1 ms with internal steps of 0.1 ms equal the library with dt = 0.1 ms."""
    F = np.array([50.0, 0.0, 50.0]) / np.sqrt(2.0)
    inst = body(scheme=scheme, internal_step=1e-4).initialize()
    inst.set(F_x=F[0], F_y=F[1], F_z=F[2])
    for k in range(30):
        inst.fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
    plate = load_model("paper_plate")
    integ = ReframeIntegrator(plate, modal_basis(plate, 10, 0.05), scheme=scheme)
    res = integ.run(0.03, 1e-4, PointLoad(LOAD_POINT, constant_load(F)), points=[(-0.5, -0.025, 0.0)])
    names = ("omega_1", "omega_2", "omega_3", "com_vel_x", "com_vel_y", "com_vel_z", "out_pos_x", "out_pos_y",
             "out_pos_z", "out_acc_x", "out_acc_y", "out_acc_z", "q_w", "q_x", "q_y", "q_z")
    lib = np.concatenate([res.omega[-1], res.com_velocity[-1], res.point_position[-1, 0],
                          res.point_acceleration[-1, 0], res.quaternion[-1]])
    # identity: the Python FMU advances the library's ReframeIntegrator (the same model, modal_basis and kernels,
    # in this process) by the same 0.1 ms steps under a constant load: the same operations in the same order
    assert np.array_equal(inst.get(*names), lib)


def test_constant_force_gives_newtons_com_velocity(body):
    """com_vel = F t / m (Newton, the mass from M); automatic internal steps, variable communication steps."""
    plate = load_model("paper_plate")
    ones_x = np.zeros(plate.n_dof)
    ones_x[0::3] = 1.0
    mass = ones_x @ plate.M @ ones_x          # rigid translation's kinetic-energy mass
    inst = body().initialize()
    F = np.array([3.0, -2.0, 5.0])
    inst.set(F_x=F[0], F_y=F[1], F_z=F[2])
    t = 0.0
    for h in (1e-3, 2.5e-3, 0.7e-3, 4e-3):
        inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    np.testing.assert_allclose(inst.get("com_vel_x", "com_vel_y", "com_vel_z"), F * t / mass, rtol=1e-9)


def test_rollback_is_bit_identical(body):
    inst = body(model="beam:spatial_double_L", n_flexible_modes=4, load_point_x=0.14, load_point_y=0.15,
                load_point_z=0.16, output_point_x=0.0, output_point_y=0.0, output_point_z=0.0,
                omega0_3=2.0).initialize()

    def run(t0, n):
        out = []
        for k in range(n):
            inst.set(F_x=np.sin(40 * (t0 + k * 1e-3)), M_z=0.01)
            inst.fmu.doStep(currentCommunicationPoint=t0 + k * 1e-3, communicationStepSize=1e-3)
            out.append(inst.get("omega_1", "omega_2", "omega_3", "out_acc_x", "max_elastic_displacement"))
        return np.array(out)

    run(0.0, 10)
    state = inst.fmu.getFMUState()
    first = run(0.01, 10)
    inst.fmu.setFMUState(state)
    assert np.array_equal(run(0.01, 10), first)


#: points on the rod (its first node; the defaults are the plate's)
ON_ROD = dict(load_point_x=0.0, load_point_y=0.0, load_point_z=0.0, output_point_x=0.0, output_point_y=0.0,
              output_point_z=0.0)
ERRORS = [
    ("unknown model", {"model": "no_such_model"}, "model"),
    ("unknown scheme", {"scheme": "euler"}, "scheme"),
    ("internal step beyond the RK4 limit", {"model": "beam:spatial_double_L", "scheme": "consistent", "internal_step": 1.0,
                                            **ON_ROD}, "internal_step"),
    ("negative modes", {"model": "beam:spatial_double_L", "n_flexible_modes": -2}, "n_flexible_modes"),
    ("damping", {"model": "beam:spatial_double_L", "damping_ratio": -0.1}, "damping_ratio"),
]


@pytest.mark.parametrize("label, start, name", ERRORS, ids=[e[0] for e in ERRORS])
def test_bad_parameters_fail_initialisation_naming_them(body, label, start, name):
    inst = body(**start)
    inst.expect_failure(inst.fmu.exitInitializationMode)
    assert any(status >= 3 and name in message for status, _, message in inst.log), inst.log


def test_moment_on_a_solid_model_is_refused(body):
    inst = body(model="beam:spatial_double_L", n_flexible_modes=2, **ON_ROD).initialize()
    inst.set(M_x=1.0)
    inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)   # beams take moments
    solid = body("plate", n_flexible_modes=2).initialize()
    solid.set(M_y=1.0)
    solid.expect_failure(solid.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    assert any("M_y" in message for _, _, message in solid.log)


# --------------------------------------------------------------------------- outputs computed when read
_SPINNING_ROD = dict(model="beam:spatial_double_L", n_flexible_modes=4, load_point_x=0.14, load_point_y=0.15,
                     load_point_z=0.16, output_point_x=0.0, output_point_y=0.0, output_point_z=0.0, omega0_3=15.0)


def _force(k):
    f = 40.0 * np.sin(0.7 * k)
    return [f, -0.5 * f, 0.3 * f]


def test_exponential_split_does_not_depend_on_when_outputs_are_read():
    """Scheme exponential, automatic internal steps: the split uses the rates of a state with the inputs its
    step held (bounded for the input change) whether or not output_vector was called; a spinning rod whose
    split changes from step to step ends bit-identical either way."""
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

    def run(read_every):
        sim = ReframeBodySimulator(ReframeBodyConfig(**_SPINNING_ROD))
        splits = []
        for k in range(40):
            sim.set_input_vector(_force(k) + [0.0, 0.0, 0.0])
            splits.append(sim.internal_steps(0.006))
            sim.step(0.006)
            if read_every and k % read_every == 0:
                sim.output_vector(include_deferred=k % 2 == 0)
        return splits, sim.state

    (s1, a), (s2, b), (s3, c) = run(1), run(0), run(3)
    assert s1 == s2 == s3 and len(set(s1)) > 3                # the split varies: the case tests something
    for x in (b, c):
        assert np.array_equal(a.eta, x.eta) and np.array_equal(a.rotation, x.rotation)


def test_outputs_computed_on_read_equal_those_after_each_step(body):
    """Outputs are computed when first read after a step (max_elastic_displacement only when it is read):
    every read pattern — all outputs each step, none for a while, one value, the costly one alone, after
    new inputs were set but before the next step, after a rollback — gives the library's outputs of the
    state the step reached with the inputs that step held."""
    from flexfmu.reframe.simulator import OUTPUT_NAMES, ReframeBodyConfig, ReframeBodySimulator

    lib = ReframeBodySimulator(ReframeBodyConfig(**_SPINNING_ROD))
    expected = []
    for k in range(12):
        lib.set_input_vector(_force(k) + [0.0, 0.0, 0.0])
        lib.step(0.006)
        expected.append(lib.output_vector())          # eager: everything right after the step
    inst = body(**_SPINNING_ROD).initialize()
    vr = [inst.vr[n] for n in OUTPUT_NAMES]
    i_max = OUTPUT_NAMES.index("max_elastic_displacement")
    t = 0.0
    saved = None
    for k in range(12):
        inst.set(**dict(zip(("F_x", "F_y", "F_z"), _force(k))))
        inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.006)
        t += 0.006
        want = expected[k]
        if k == 4:
            saved = inst.fmu.getFMUstate()            # taken before any output of this step was read
        if k % 4 == 0:
            got = inst.fmu.getReal(vr)
        elif k % 4 == 1:
            got = None                                # not read at all
        elif k % 4 == 2:                              # the costly one alone, then the rest
            assert inst.fmu.getReal([vr[i_max]]) == [want[i_max]]
            got = inst.fmu.getReal(vr)
        else:                                         # new inputs set first: outputs still of the held ones
            inst.set(F_x=123.0, F_z=-45.0)
            assert inst.fmu.getReal([vr[3]]) == [want[3]]
            got = inst.fmu.getReal(vr)
            inst.set(**dict(zip(("F_x", "F_y", "F_z"), _force(k))))
        if got is not None:
            np.testing.assert_array_equal(got, want)
    inst.fmu.setFMUstate(saved)                       # back to after step 4: its outputs, all of them
    np.testing.assert_array_equal(inst.fmu.getReal(vr), expected[4])
    inst.fmu.freeFMUstate(saved)
