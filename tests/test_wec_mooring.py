"""The Mooring (flexfmu.wec.mooring): three slack catenary lines of the point absorber in MoorDyn, as a Python FMU.

Shown here:

* stiffness: MoorDyn's quasi-static stiffness about O (surge, heave and pitch columns of the 6x6, every row), from the
  settled loads at +- offsets (flexfmu.wec.mooring_reference, the FMU's simulator itself), at 20 and 40 segments per
  line, against MoorPy's System.getCoupledStiffness of the same lines over the same offsets (an analytic elastic
  catenary with sea-floor contact: an independent model).  The tolerance of each entry at 40 segments: the change
  from 20 to 40 segments (the lumped-mass discretisation, measured here) but at least 3 % of the entry's scale
  sqrt(K_ii K_jj) (the largest change from 40 to 80 segments measured, K_33: 2.7 %, docs/wave_converter.md), plus
  the noise bound of the averaged loads (what the lines' residual motion may leave in the windows' means);
* the FMU (built by flexfmu.fmi.build.build_one for this spec alone, run through fmpy): at rest the lines' vertical
  pull equals MoorPy's pretension within twice the 20-to-40-segment change, the horizontal force and the moments
  vanish (the lines' 120-degree symmetry), the three fairlead tensions are equal and MoorPy's; an FMU state got,
  set, serialised and restored in a second instance continues bit for bit (MoorDyn's lines included: the second
  instance's own lines start elsewhere); enabled = false gives zero outputs; bad parameters and inputs are refused
  naming them;
* the library: parameters out of range refused naming the parameter and the range, a motion that would tear a line
  taut or push a fairlead under the sea floor refused naming the input, a damaged state refused, and MoorDyn's
  Python wrapper's lost reference to None (each Deserialize) made good.
"""
from __future__ import annotations

import math
import sys

import numpy as np
import pytest

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from fmu_helpers import Instance, error_messages  # noqa: E402

from flexfmu.errors import ParameterError  # noqa: E402
from flexfmu.wec import mooring_reference as reference  # noqa: E402
from flexfmu.wec.mooring import (CHAIN_COEFFICIENTS, INPUT_NAMES, OUTPUT_NAMES, MooringConfig,  # noqa: E402
                                 MooringSimulator, rotation)

#: the largest change of a stiffness entry from 40 to 80 segments, relative to its scale sqrt(K_ii K_jj), measured
#: with mooring_reference.moordyn_stiffness (docs/wave_converter.md "Mooring (MoorDyn)": K_33, 2.7 %)
DISCRETISATION_FLOOR = 0.03
SEGMENTS = (20, 40)
DOFS = (0, 2, 4)                      # surge, heave, pitch
OUTPUTS = list(OUTPUT_NAMES)


# ---------------------------------------------------------------- the stiffness
@pytest.fixture(scope="module")
def stiffness():
    """{"moorpy": K, segments: (K, noise, loads at rest)} of the default lines."""
    out = {"moorpy": reference.moorpy_stiffness(MooringConfig())}
    for n in SEGMENTS:
        out[n] = reference.moordyn_stiffness(MooringConfig(segments=n), dofs=DOFS)
    return out


@pytest.mark.study
def test_the_defaults_are_moorpys_studless_chain():
    from moorpy.helpers import getLineProps, loadLineProps
    chain = getLineProps(50, "chain", lineProps=loadLineProps(None))
    cfg = MooringConfig()
    assert (cfg.line_diameter, cfg.line_mass, cfg.line_EA) == pytest.approx((chain["d_vol"], chain["m"], chain["EA"]),
                                                                             rel=1e-12)
    assert CHAIN_COEFFICIENTS == {k: chain[k] for k in ("Cd", "Ca", "CdAx", "CaAx")}
    assert cfg.wet_weight == pytest.approx(chain["w"], rel=1e-12)


@pytest.mark.study
def test_moordyn_stiffness_matches_moorpys_within_its_discretisation(stiffness):
    Kp = stiffness["moorpy"]
    (K20, _, _), (K40, noise, _) = stiffness[20], stiffness[40]
    names = reference.DOF_NAMES
    print("\nstiffness about O (N/m, N/rad, N m/m, N m/rad): MoorDyn 20 / 40 segments vs MoorPy")
    failures = []
    for j in DOFS:
        for i in range(6):
            scale = math.sqrt(Kp[i, i] * Kp[j, j])
            tolerance = max(abs(K20[i, j] - K40[i, j]), DISCRETISATION_FLOOR * scale) + noise[i, j]
            error = abs(K40[i, j] - Kp[i, j])
            if abs(Kp[i, j]) > 1e-3 * scale or error > 1e-3 * scale:
                print(f"  K[{names[i]}, {names[j]}]  {K20[i, j]:12.6g} {K40[i, j]:12.6g} {Kp[i, j]:12.6g}   "
                      f"|40 - MoorPy| / scale {error / scale:.2%} (allowed {tolerance / scale:.2%})")
            if not error <= tolerance:
                failures.append((names[i], names[j], K40[i, j], Kp[i, j], tolerance))
    assert not failures, failures
    # the diagonal itself, which carries the tolerance's scale: within 3 % plus the noise at 40 segments
    for j in DOFS:
        assert abs(K40[j, j] - Kp[j, j]) <= DISCRETISATION_FLOOR * Kp[j, j] + noise[j, j]


# ---------------------------------------------------------------- the FMU
@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    from flexfmu.fmi import registry, runtime
    from flexfmu.fmi.build import build_one
    return build_one(registry.BY_NAME["Mooring"], tmp_path_factory.mktemp("mooring") / "Mooring.fmu",
                     runtime.compile_runtime(runtime.build_folder()))


@pytest.fixture
def instance(fmu):
    made = []

    def make(name="mooring", **start):
        made.append(Instance(fmu, name, **start))
        return made[-1]
    yield make
    for inst in made:
        inst.free()


def motion(t: float) -> dict:
    """A body motion (surge, heave, pitch) that moves the lines; rates consistent with it."""
    w = 2 * math.pi / 3.0
    return {"pos_x": 0.5 * math.sin(w * t), "vel_x": 0.5 * w * math.cos(w * t),
            "pos_z": 0.3 * math.sin(1.3 * w * t), "vel_z": 0.39 * w * math.cos(1.3 * w * t),
            "rot_y": 0.02 * math.sin(0.7 * w * t), "omega_y": 0.014 * w * math.cos(0.7 * w * t)}


def run(inst, t0: float, steps: int, h: float = 0.01) -> np.ndarray:
    rows = []
    for k in range(steps):
        t = t0 + k * h
        inst.set(**motion(t))
        inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        rows.append(inst.get(*OUTPUTS))
    return np.array(rows)


@pytest.mark.fmu
def test_the_fmu_at_rest_holds_moorpys_pretension(instance, stiffness):
    inst = instance().initialize()
    rows = []
    for k in range(200):
        inst.fmu.doStep(currentCommunicationPoint=k * 0.01, communicationStepSize=0.01)
        rows.append(inst.get(*OUTPUTS))
    loads = np.array(rows)[100:].mean(axis=0)
    system = reference.moorpy_system(MooringConfig())
    F_moorpy, T_moorpy = reference.moorpy_loads(system), reference.moorpy_tensions(system)
    rest20, rest40 = stiffness[20][2], stiffness[40][2]
    discretisation = 2 * abs(rest20[2] - rest40[2]) / abs(rest40[2])
    print(f"\nat rest: F_z {loads[2]:.7g} N (MoorPy {F_moorpy[2]:.7g}), tensions {loads[6:]} N (MoorPy {T_moorpy}); "
          f"allowed {discretisation:.2%}")
    assert abs(loads[2] - F_moorpy[2]) <= discretisation * abs(F_moorpy[2])
    assert loads[6:] == pytest.approx(T_moorpy, rel=discretisation)
    assert np.all(np.abs(loads[[0, 1]]) <= 1e-6 * abs(loads[2]))
    assert np.all(np.abs(loads[3:6]) <= 1e-6 * abs(loads[2]) * MooringConfig().fairlead_radius)
    assert loads[6:] == pytest.approx([loads[6]] * 3, rel=1e-9)


@pytest.mark.fmu
def test_fmu_state_round_trip_continues_bit_for_bit(instance):
    inst = instance("a").initialize()
    run(inst, 0.0, 50)
    state = inst.fmu.getFMUState()
    first = run(inst, 0.5, 50)
    inst.fmu.setFMUState(state)
    again = run(inst, 0.5, 50)
    assert np.array_equal(first, again)
    serialized = inst.fmu.serializeFMUState(state)
    other = instance("b").initialize()               # its own lines start at rest, not where inst's were
    run(other, 0.0, 10)
    other.fmu.setFMUState(other.fmu.deserializeFMUState(serialized))
    assert np.array_equal(run(other, 0.5, 50), first)
    assert np.ptp(first[:, 0]) > 100.0                # the motion moved the lines: the comparison means something


@pytest.mark.fmu
def test_disabled_fmu_gives_zero_outputs(instance):
    inst = instance(enabled=False).initialize()
    assert np.all(run(inst, 0.0, 20) == 0.0)


@pytest.mark.fmu
@pytest.mark.parametrize("name, value", [("line_length", 150.0), ("internal_time_step", 0.01), ("segments", 1),
                                         ("line_mass", 5.0), ("fairlead_z", -120.0)])
def test_the_fmu_refuses_bad_parameters_naming_them(instance, name, value):
    inst = instance(**{name: value})
    inst.expect_failure(inst.fmu.exitInitializationMode)
    assert any(name in m and "allowed" in m for m in error_messages(inst)), inst.messages()


@pytest.mark.fmu
def test_the_fmu_refuses_non_finite_and_tearing_inputs_naming_them(instance):
    inst = instance().initialize()
    inst.expect_failure(inst.set, pos_x=math.nan)
    assert any("pos_x" in m for m in error_messages(inst)), inst.messages()
    inst = instance("far").initialize()
    inst.set(pos_x=-60.0)                           # line 1 (anchor at +x) would need 255 m
    inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=0.01)
    assert any("pos_x" in m and "fairlead 1" in m for m in error_messages(inst)), inst.messages()


# ---------------------------------------------------------------- the library
@pytest.mark.parametrize("values, name", [
    ({"depth": 0.0}, "depth"), ({"depth": math.inf}, "depth"), ({"fairlead_z": 1.0}, "fairlead_z"),
    ({"anchor_radius": 5.0}, "anchor_radius"), ({"segments": 2000}, "segments"), ({"segments": 20.0}, "segments"),
    ({"line_length": 216.0}, "line_length"), ({"line_length": 293.0}, "line_length"), ({"line_mass": 6.0}, "line_mass"),
    ({"line_EA": -1.0}, "line_EA"), ({"internal_time_step": 3e-3}, "internal_time_step"),
    ({"segments": 40, "internal_time_step": 1.2e-3}, "internal_time_step"), ({"enabled": 1}, "enabled"),
    ({"rho": 0.0}, "rho"), ({"g": math.nan}, "g"), ({"fairlead_radius": -1.0}, "fairlead_radius")])
def test_parameters_out_of_range_are_refused_by_name(values, name):
    with pytest.raises(ParameterError, match=rf"^{name}: .*\(allowed: "):
        MooringSimulator(MooringConfig(**values))


def test_the_rotation_is_scipys_rotation_vector():
    from scipy.spatial.transform import Rotation
    for rot in ([0.0, 0.0, 0.0], [1e-9, -2e-9, 3e-9], [0.02, 0.0, 0.0], [0.3, -0.2, 1.1]):
        assert np.allclose(rotation(rot), Rotation.from_rotvec(rot).as_matrix(), rtol=0, atol=1e-15)


def test_motions_and_states_are_checked(tmp_path):
    sim = MooringSimulator()
    with pytest.raises(ParameterError, match="^vel_x: "):
        sim.set_inputs(vel_x=math.inf)
    sim.set_inputs(pos_z=-98.0)
    with pytest.raises(ParameterError, match=r"^pos_z: .* under the sea floor .*\(allowed: "):
        sim.outputs()
    sim.set_inputs(pos_z=0.0, vel_y=1e4)              # in one step of 0.01 s: 100 m
    with pytest.raises(ParameterError, match=r"^vel_y: .* at the end of the step"):
        sim.step(0.01)
    sim.set_inputs(vel_y=0.0)
    sim.step(0.01)
    state = sim.get_state()
    state["moordyn"]["sha256"] = "0" * 64
    with pytest.raises(ParameterError, match="^FMUstate: MoorDyn's part is damaged"):
        sim.set_state(state)
    with pytest.raises(ParameterError, match="^FMUstate: was taken with other parameters"):
        MooringSimulator(MooringConfig(segments=10)).set_state(sim.get_state())
    # each restore gives None back the reference MoorDyn's wrapper takes (Python 3.11 would free None after
    # a few thousand restores)
    # (None's count moves by tens with whatever else the process frees or makes: 3000 restores, after a warm-up and
    # with the collector off, must not lose a tenth of the 3000 references one lost per restore would)
    good = sim.get_state()
    for _ in range(10):
        sim.set_state(good)
    import gc
    gc.disable()
    try:
        before = sys.getrefcount(None)
        for _ in range(3000):
            sim.set_state(good)
        lost = before - sys.getrefcount(None)
    finally:
        gc.enable()
    assert lost < 300, lost
    assert set(sim.outputs()) == set(OUTPUT_NAMES) and len(INPUT_NAMES) == 12
