"""ReframeBody.fmu choosing for the user: the model size (n_flexible_modes = -1 with f_max and
tolerance), the internal step (RK4 limit: sub-stepped and logged) and the exponential scheme; each decision
is logged with status OK and the numbers behind it."""
import math

import numpy as np
import pytest
import scipy.linalg as sla

from flexfmu.reframe.models import load_model
from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator
from flexfmu.sizing.model_size import load_point_rows, modal_compliance
from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

BEAM = "beam:spatial_double_L"            # free-free bent rod; flexible modes 148, 266, 280, 980, ... Hz
TIP = (0.14, 0.15, 0.16)                  # its free end (node 12 with 8 elements per segment: the last node)
#: the output point at the rod's first node (the default is the plate's, off the rod: refused)
FIRST_NODE = dict(output_point_x=0.0, output_point_y=0.0, output_point_z=0.0)


@pytest.fixture
def body(fmu_instance):
    return lambda name="body", **start: fmu_instance("ReframeBody", name, **start)


def _ok_messages(inst):
    return [m for status, _, m in inst.log if status == 0]


def test_auto_model_size_is_logged_with_its_numbers(body):
    inst = body(model=BEAM, n_flexible_modes=-1, f_max=500.0, tolerance=1e-3, scheme="exponential",
                load_point_x=TIP[0], load_point_y=TIP[1], load_point_z=TIP[2], **FIRST_NODE).initialize()
    text = "\n".join(_ok_messages(inst))
    sim = ReframeBodySimulator(ReframeBodyConfig(model=BEAM, n_flexible_modes=-1, f_max=500.0, tolerance=1e-3,
                                                 load_point_x=TIP[0], load_point_y=TIP[1], load_point_z=TIP[2],
                                                 **FIRST_NODE))
    assert text.startswith("\n".join(sim.messages))       # the library's messages, word for word
    assert sim.messages[:2] == list(sim.model_choice.messages)           # the typed choice is what is logged
    assert sim.model_choice.basis.n_flexible == sim.integrator.data.nf     # the modes and 6 residual vectors
    n_keep = sim.integrator.data.nf - 6
    assert (f"kept {n_keep} flexible mode(s) (the 3 up to f_max = 500 Hz and {n_keep - 3} above, until the "
            "estimated dynamic truncation error") in text and ": 148.2, 265.8, 280.4, 979.9" in text, text
    assert "x2 safety <= 0.001" in text
    assert "added 6 residual-flexibility vectors" in text and "> tolerance 0.001" in text, text
    inst.set(F_x=1.0)
    inst.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    assert np.all(np.isfinite(inst.get("omega_1", "omega_2", "omega_3", "max_elastic_displacement")))


def test_auto_model_static_deflection_of_the_load_point_is_exact():
    """The chosen basis (3 modes below 500 Hz + the static correction) against the full model's static
    compliance at the tip, here from all 72 flexible modes of a dense generalized eigensolution; with
    tolerance 0.9 (met by the modes alone) no correction is added and the error is what the log says."""
    structure = load_model(BEAM)
    tip = int(np.argmin(np.linalg.norm(structure.nodes - np.array(TIP), axis=1)))
    lam, V = sla.eigh(structure.K.toarray(), structure.M.toarray())
    flex = np.arange(lam.size) >= 6                                  # ascending: six rigid, then flexible
    assert abs(lam[5]) <= 1e-6 * lam[6] and abs(math.sqrt(lam[6]) / (2 * math.pi) - 148.18) <= 0.01
    rows = load_point_rows(structure, tip)
    C_ref = (V[rows][:, flex] / lam[flex]) @ V[rows][:, flex].T
    sim = ReframeBodySimulator(ReframeBodyConfig(model=BEAM, n_flexible_modes=-1, f_max=500.0, tolerance=1e-3,
                                                 scheme="exponential", load_point_x=TIP[0], load_point_y=TIP[1],
                                                 load_point_z=TIP[2], **FIRST_NODE))
    basis = sim.integrator.data.basis
    n_keep = basis.n_flexible - 6                                    # modes, then the 6 residual vectors
    assert n_keep > 3 and np.all(basis.frequencies_hz[:3] <= 500.0) and basis.frequencies_hz[3] > 500.0
    np.testing.assert_allclose(basis.frequencies_hz[:n_keep], np.sqrt(lam[6:6 + n_keep]) / (2 * math.pi), rtol=1e-8)
    C = modal_compliance(basis, rows)
    for block in (slice(0, 3), slice(3, 6)):                         # forces (m/N), moments (rad/(N m))
        err = np.linalg.norm(C[block, block] - C_ref[block, block], 2) / np.linalg.norm(C_ref[block, block], 2)
        assert err <= 1e-6, err
    loose = ReframeBodySimulator(ReframeBodyConfig(model=BEAM, n_flexible_modes=-1, f_max=500.0, tolerance=0.9,
                                                   load_point_x=TIP[0], load_point_y=TIP[1], load_point_z=TIP[2],
                                                   output_point_x=TIP[0], output_point_y=TIP[1], output_point_z=TIP[2]))
    assert loose.integrator.data.nf == 3 and "no static correction" in loose.messages[1]
    err3 = max(np.linalg.norm(modal_compliance(loose.integrator.data.basis, rows)[b, b] - C_ref[b, b], 2)
               / np.linalg.norm(C_ref[b, b], 2) for b in (slice(0, 3), slice(3, 6)))
    logged = float(loose.messages[1].split(" is within ")[1].split(" ")[0])
    assert abs(logged - err3) <= 0.05 * err3 and err3 <= 0.9


def test_communication_step_beyond_the_rk4_limit_is_substepped_and_logged(body):
    """Six flexible modes (up to 1315 Hz), consistent scheme, communication step 10 ms: dt omega_max = 83
    is detected, split into 33 internal steps (90 % of the limit) and logged once; the result equals the
    library with dt = 10 ms / 33."""
    inst = body(model=BEAM, scheme="consistent", n_flexible_modes=6, omega0_3=3.0, load_point_x=TIP[0],
                load_point_y=TIP[1], load_point_z=TIP[2], **FIRST_NODE).initialize()
    F = np.array([0.5, -0.2, 1.0])
    inst.set(F_x=F[0], F_y=F[1], F_z=F[2])
    for k in range(3):
        inst.fmu.doStep(currentCommunicationPoint=k * 1e-2, communicationStepSize=1e-2)
    split = [m for m in _ok_messages(inst) if "internal step" in m]
    assert len(split) == 1, split
    assert "in 33 internal step(s)" in split[0] and "> 2.8: RK4 would diverge" in split[0] and "1315" in split[0]
    structure = load_model(BEAM)
    integ = ReframeIntegrator(structure, 6, scheme="consistent")
    integ.set_initial(omega0=(0.0, 0.0, 3.0))
    res = integ.run(0.03, 1e-2 / 33, PointLoad(TIP, F), points=[(-0.5, -0.025, 0.0)])
    lib = np.concatenate([res.omega[-1], res.point_position[-1, 0], res.point_acceleration[-1, 0]])
    fmu = inst.get("omega_1", "omega_2", "omega_3", "out_pos_x", "out_pos_y", "out_pos_z", "out_acc_x", "out_acc_y",
                   "out_acc_z")
    # identity: the Python FMU advances the library's ReframeIntegrator (the same model, modal_basis and kernels,
    # in this process) by the same steps 1e-2 / 33 under a constant load: the same operations in the same order
    assert np.array_equal(fmu, lib)


def test_exponential_scheme_through_the_fmu(body):
    """Exponential scheme, six flexible modes, 10 ms communication steps (dt omega_max = 83, one internal
    step each: the body turns by < 0.09 rad per step): equals the library with dt = 10 ms, and agrees with
    the consistent scheme at dt = 1e-5 s within 1e-6 (relative) while the consistent FMU needs 33 internal
    steps per communication step."""
    start = dict(model=BEAM, n_flexible_modes=6, omega0_1=1.0, omega0_3=3.0, load_point_x=TIP[0],
                 load_point_y=TIP[1], load_point_z=TIP[2], **FIRST_NODE)
    inst = body(scheme="exponential", **start).initialize()
    F = np.array([0.05, -0.02, 0.1])
    inst.set(F_x=F[0], F_y=F[1], F_z=F[2])
    for k in range(5):
        inst.fmu.doStep(currentCommunicationPoint=k * 1e-2, communicationStepSize=1e-2)
    split = [m for m in _ok_messages(inst) if "internal step" in m]
    assert len(split) == 1 and "in 1 internal step(s)" in split[0] and "no stability limit" in split[0], split
    names = ("omega_1", "omega_2", "omega_3", "out_pos_x", "out_pos_y", "out_pos_z", "com_vel_x", "com_vel_y",
             "com_vel_z")
    fmu = np.array(inst.get(*names))
    structure = load_model(BEAM)

    def library(scheme, dt):
        integ = ReframeIntegrator(structure, 6, scheme=scheme)
        integ.set_initial(omega0=(1.0, 0.0, 3.0))
        r = integ.run(0.05, dt, PointLoad(TIP, F), points=[(-0.5, -0.025, 0.0)], every=10**6)
        return np.concatenate([r.omega[-1], r.point_position[-1, 0], r.com_velocity[-1]])

    same = library("exponential", 1e-2)
    # identity: as above, the same integrator by the same 10 ms steps (one internal step each)
    assert np.array_equal(fmu, same)
    fine = library("consistent", 1e-5)
    err = np.max(np.abs(fmu - fine)) / np.abs(fine).max()
    print(f"\nexponential FMU (10 ms, 1 internal step) vs consistent dt = 1e-5 s: relative error {err:.2g}")
    assert err <= 1e-6


def test_auto_model_response_to_a_short_pulse_meets_the_tolerance():
    """The automatic basis in the response: free-free rod, a 2 ms half-sine blow (10 N) at the free
    end, f_max = 1.5 / pulse = 750 Hz, tolerance 1e-3.  The elastic deflection (body frame) of the loaded end and of
    the other end over 40 ms against the same rod with ALL its flexible modes (exponential scheme, exact in the
    modal part, same step: the difference is the truncation; the integrator itself is checked in
    tests/test_reframe_exponential.py).  The modes up to f_max alone miss the tolerance, so the test can fail."""
    from flexfmu.reframe.models import default_load_point
    from flexfmu.reframe.integrator import half_sine_pulse
    from flexfmu.sizing.model_size import auto_basis

    structure = load_model(BEAM)
    tip = default_load_point(structure)
    far = 0                                   # the clamp-free first point of the rod
    pulse, dt, t_end = 2e-3, 2e-5, 0.04
    force = 10.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)
    load = PointLoad(tuple(structure.nodes[tip]), half_sine_pulse(force, pulse))

    def deflections(basis):
        integ = ReframeIntegrator(structure, basis, scheme="exponential")
        r = integ.run(t_end, dt, load, state=integ.initial_state(), every=10)
        d = integ.data
        return {node: np.asarray(r.q) @ d.Phi[d.trans_rows[node]].T for node in (tip, far)}

    reference = deflections(structure.n_dof - 6)

    def errors(out):
        return {node: float(np.max(np.linalg.norm(out[node] - reference[node], axis=1))
                            / np.max(np.linalg.norm(reference[node], axis=1))) for node in out}

    choice = auto_basis(structure, 1.5 / pulse, 1e-3, 0.05, tip, far)
    basis, msgs = choice.basis, choice.messages
    err = errors(deflections(basis))
    print(f"\nautomatic basis ({basis.n_flexible} flexible coordinates): errors {err}")
    assert max(err.values()) <= 1e-3, (err, msgs)
    n_band = int(np.count_nonzero(basis.frequencies_hz <= 1.5 / pulse))
    assert basis.n_flexible > n_band + 6                # modes above f_max were kept (and 6 residual vectors)
    band_only = errors(deflections(n_band))
    print(f"the {n_band} modes up to f_max: errors {band_only}")
    assert max(band_only.values()) > 1e-3
