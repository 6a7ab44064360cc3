"""The native Mooring (flexfmu.fmi.native_mooring, csrc/native_moordyn.c): the Mooring FMU with no Python in the host,
MoorDyn's shared library loaded from the FMU's binaries folder, run through fmpy against the Python simulator
(flexfmu.wec.mooring.MooringSimulator) on the same prescribed body motion.

The bound.  Both call the same MoorDyn library (the FMU carries a copy of the pip package's, the one cmoordyn calls)
in the same order with the same arguments, so they differ only where the arithmetic around MoorDyn differs:

* surge and heave only (rot = omega = 0): the rotation is the identity and every operation before MoorDyn (the
  fairleads pos + R r_i, their velocities) and after it (F, M about O, the tensions) is exact or the same IEEE
  operation in the same order on both sides: the outputs agree bit for bit (measured: 30 s at h = 0.01 s);
* with a rotation, numpy takes |rot| and R r_i from OpenBLAS's FMA kernels, the C kind from plain IEEE products (as
  every native kind: -ffp-contract=off): the fairleads differ by about an ulp, which the damped lines carry to
  ~1e-11 of the loads' scale (measured 6e-12 after 10 s of 0.02 rad pitch).

Both cases are held to 1e-10 of each load group's scale over the run (|F|, |M|, the tensions): the first would pass
at 0, the second has a factor ~15 of margin.
"""
from __future__ import annotations

import math
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from fmu_helpers import Instance, error_messages, restamp_crc  # noqa: E402

from flexfmu.errors import DivergenceError, ParameterError  # noqa: E402
from flexfmu.wec.mooring import OUTPUT_NAMES, MooringSimulator  # noqa: E402

pytestmark = pytest.mark.fmu

OUTPUTS = list(OUTPUT_NAMES)
RELATIVE = 1e-10
H = 0.01
PERIOD = 8.0


def motion(t: float, surge: float = 0.5, heave: float = 0.5, pitch: float = 0.0) -> dict:
    """Surge, heave and pitch oscillations of period PERIOD, with consistent rates."""
    w = 2 * math.pi / PERIOD
    out = {"pos_x": surge * math.sin(w * t), "vel_x": surge * w * math.cos(w * t),
           "pos_z": heave * math.sin(w * t + 1.0), "vel_z": heave * w * math.cos(w * t + 1.0)}
    if pitch:
        out.update(rot_y=pitch * math.sin(w * t + 2.0), omega_y=pitch * w * math.cos(w * t + 2.0))
    return out


def scales(rows: np.ndarray) -> np.ndarray:
    """Each output's scale: the largest |F|, |M| or tension of the run (F_y and M_x, M_z are ~0 by symmetry)."""
    group = [np.max(np.linalg.norm(rows[:, s], axis=1)) for s in (slice(0, 3), slice(3, 6))]
    return np.array([group[0]] * 3 + [group[1]] * 3 + [np.max(rows[:, 6:])] * 3)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    from flexfmu.fmi.native import build_registry_fmu
    return build_registry_fmu("Mooring", target=tmp_path_factory.mktemp("native_mooring") / "Mooring.fmu")


@pytest.fixture
def instance(fmu):
    made = []

    def make(name="mooring", **start):
        made.append(Instance(fmu, name, **start))
        return made[-1]
    yield make
    for inst in made:
        inst.free()


def run_native(inst, t0: float, steps: int, h: float = H, **shape) -> np.ndarray:
    rows = []
    for k in range(steps):
        t = t0 + k * h
        inst.set(**motion(t, **shape))
        inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        rows.append(inst.get(*OUTPUTS))
    return np.array(rows)


def run_python(sim, t0: float, steps: int, h: float = H, **shape) -> np.ndarray:
    rows = []
    for k in range(steps):
        sim.set_inputs(**motion(t0 + k * h, **shape))
        sim.step(h)
        rows.append([sim.outputs()[name] for name in OUTPUTS])
    return np.array(rows)


def test_the_fmu_carries_moordyn_beside_its_linux64_binary_only(fmu):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    from flexfmu.fmi import registry
    from flexfmu.fmi.variables import table

    assert validate_fmu(str(fmu)) == []
    names = zipfile.ZipFile(fmu).namelist()
    binaries = sorted(n for n in names if n.startswith("binaries/"))
    assert binaries[0] == "binaries/linux64/Mooring.so" and len(binaries) == 2
    assert binaries[1].startswith("binaries/linux64/libmoordyn"), binaries
    # the Python FMU's variables, in its order; only enabled stays settable
    md = read_model_description(str(fmu))
    assert [v.name for v in md.modelVariables] == [v.name for v in table(registry.BY_NAME["Mooring"])]
    info = __import__("json").loads(zipfile.ZipFile(fmu).read("resources/flexfmu_build.json"))
    assert info["kind"] == "moordyn" and info["platforms"] == ["linux64"] and info["runtime_parameters"] == ["enabled"]
    assert "MoorDyn" in info["platforms_unsupported"]["win64"]


def test_the_native_fmu_is_the_python_simulator(instance):
    """Surge and heave of 0.5 m at 8 s for 30 s, h = 0.01 s: within 1e-10 of each load's scale (module docstring:
    bit for bit expected)."""
    steps = int(round(30.0 / H))
    inst = instance(**motion(0.0)).initialize()
    sim = MooringSimulator()
    sim.set_inputs(**motion(0.0))
    start = np.array(inst.get(*OUTPUTS)), np.array([sim.outputs()[n] for n in OUTPUTS])
    native, python = run_native(inst, 0.0, steps), run_python(sim, 0.0, steps)
    error = np.max(np.abs(native - python), axis=0) / scales(python)
    print(f"\nnative - Python over {steps} steps, relative to each load's scale: {error.max():.3g} "
          f"(bit for bit: {np.array_equal(native, python)})")
    assert np.all(np.abs(start[0] - start[1]) <= RELATIVE * scales(python))
    assert np.all(error <= RELATIVE), error
    assert np.ptp(python[:, 2]) > 5e4 and np.ptp(python[:, 0]) > 5e3      # the motion moved the lines


def test_two_instances_in_one_process_are_independent(instance):
    """Interleaved steps of two instances with other motions (one with pitch: the rotation's path), each its own
    Python simulator within the bound."""
    shapes = ({"surge": 0.3, "heave": 0.6}, {"surge": 0.5, "heave": 0.2, "pitch": 0.02})
    insts = [instance(f"i{k}", **motion(0.0, **shape)).initialize() for k, shape in enumerate(shapes)]
    sims = [MooringSimulator() for _ in shapes]
    for sim, shape in zip(sims, shapes):
        sim.set_inputs(**motion(0.0, **shape))
    rows = [[], []]
    for k in range(500):
        for j in (0, 1):
            rows[j].append(run_native(insts[j], k * H, 1, **shapes[j])[0])
    for j in (0, 1):
        python = run_python(sims[j], 0.0, 500, **shapes[j])
        native = np.array(rows[j])
        assert np.all(np.max(np.abs(native - python), axis=0) <= RELATIVE * scales(python)), j
    assert not np.allclose(rows[0], rows[1], rtol=1e-3)


def test_disabled_gives_zero_outputs_and_no_moordyn(instance, monkeypatch, tmp_path):
    monkeypatch.setenv("TMPDIR", str(tmp_path))                 # where the instances put MoorDyn's input file
    off = instance("off", enabled=False).initialize()
    assert np.all(run_native(off, 0.0, 20) == 0.0)
    assert list(tmp_path.iterdir()) == []                        # no MoorDyn instance, no input file
    on = instance("on").initialize()
    folders = list(tmp_path.iterdir())
    assert len(folders) == 1 and folders[0].name.startswith("flexfmu_mooring_")
    assert (folders[0] / "lines.txt").read_text().startswith("MoorDyn input file")
    on.free()
    assert list(tmp_path.iterdir()) == []                        # removed with the instance


def test_moordyn_prints_nothing(fmu, capfd):
    inst = Instance(fmu, "quiet").initialize()
    try:
        run_native(inst, 0.0, 3)
    finally:
        inst.free()
    out, _ = capfd.readouterr()
    assert out == "", out[:500]


def test_fmu_state_round_trip_continues_bit_for_bit(instance):
    inst = instance("a", **motion(0.0)).initialize()
    run_native(inst, 0.0, 50)
    state = inst.fmu.getFMUState()
    first = run_native(inst, 0.5, 50)
    inst.fmu.setFMUState(state)
    assert np.array_equal(run_native(inst, 0.5, 50), first)
    serialized = inst.fmu.serializeFMUState(state)
    other = instance("b").initialize()                          # its own lines start at rest, not where a's were
    run_native(other, 0.0, 10, surge=0.1)
    other.fmu.setFMUState(other.fmu.deserializeFMUState(serialized))
    assert np.array_equal(run_native(other, 0.5, 50), first)
    assert np.ptp(first[:, 0]) > 100.0


def test_a_damaged_state_is_refused(instance):
    inst = instance("a", **motion(0.0)).initialize()
    run_native(inst, 0.0, 5)
    blob = bytearray(inst.fmu.serializeFMUState(inst.fmu.getFMUState()))
    at = blob.index(b"FXMOORDY")
    assert len(blob) - at > 40000                               # MoorDyn's serialised lines are in it
    blob[at + 30000] ^= 0x10                                    # one bit of MoorDyn's part, the front's CRC made good
    inst.expect_failure(inst.fmu.deserializeFMUState, restamp_crc(bytes(blob)))
    assert "its checksum differs" in error_messages(inst)[-1], inst.messages()


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")     # the Python simulator's last forces
def test_a_failed_moordyn_step_loses_the_state_until_one_is_restored(instance):
    """Fairleads shaken at 20 km/s in steps of 1 ms: MoorDyn's nodes go to NaN in the eighth step (the Python
    simulator's DivergenceError at the same step); later outputs are refused naming the lost state; a state saved
    before continues as before."""
    def shake(k):
        return {"vel_z": 2e4 if k % 2 == 0 else -2e4}
    sim = MooringSimulator()
    sim.outputs()
    with pytest.raises(DivergenceError, match=r"^state: MoorDyn's integration failed in the step from t = 0\.007 s"):
        for k in range(20):
            sim.set_inputs(**shake(k))
            sim.step(0.001)
    inst = instance("shaken").initialize()
    outputs = []
    for k in range(7):
        if k == 3:
            saved = inst.fmu.getFMUState()                      # before the fourth step
        inst.set(**shake(k))
        inst.fmu.doStep(currentCommunicationPoint=k * 0.001, communicationStepSize=0.001)
        if k < 6:                                               # (after the seventh the tensions overflow)
            outputs.append(inst.get(*OUTPUTS))
    inst.set(**shake(7))
    inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.007, communicationStepSize=0.001)
    assert error_messages(inst)[-1].startswith("state: MoorDyn's integration failed in the step from t = 0.007 s")
    inst.expect_failure(inst.get, "F_z")
    assert "restore an FMU state saved before" in error_messages(inst)[-1]
    inst.fmu.setFMUState(saved)
    for k in range(3, 6):
        inst.set(**shake(k))
        inst.fmu.doStep(currentCommunicationPoint=k * 0.001, communicationStepSize=0.001)
        assert inst.get(*OUTPUTS) == outputs[k]


def test_refusals_name_the_input_or_parameter(instance):
    # a fairlead torn beyond its line's length: the Python simulator's message, word for word
    sim = MooringSimulator()
    sim.set_inputs(pos_x=-60.0)
    with pytest.raises(ParameterError) as python:
        sim.step(0.01)
    inst = instance("far").initialize()
    inst.set(pos_x=-60.0)
    inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=0.01)
    assert error_messages(inst)[-1] == str(python.value)
    assert str(python.value).startswith("pos_x: -60.0 puts fairlead 1 ")
    # more internal steps than the cap: fmi2Discard, a smaller step may be taken
    inst = instance("long").initialize()
    inst.expect_failure(inst.fmu.doStep, currentCommunicationPoint=0.0, communicationStepSize=200.0, status=2)
    assert "step_size: 200.0 s needs 200000 internal steps" in inst.messages()
    # a line parameter is fixed at build: refused naming the command that rebuilds the FMU with it
    inst = instance("fixed")
    inst.expect_failure(inst.set, line_length=260.0)
    message = error_messages(inst)[-1]
    assert message.startswith("fmi2SetReal: line_length: got 260.0, but this native FMU was built with")
    assert "flexfmu build --runtime native --fmu Mooring --set line_length=260.0" in message


def test_a_build_for_another_platform_is_refused_naming_why(tmp_path):
    from flexfmu.fmi.native_mooring import build_mooring_fmu
    for platform in ("win64", "aarch64-linux"):
        with pytest.raises(ParameterError, match=rf"^platform: {platform}: a {platform} native Mooring would need "
                                                 rf"MoorDyn \(C\+\+.*\) built for {platform}.*\(allowed: linux64\)"):
            build_mooring_fmu(tmp_path / "Mooring.fmu", platforms=(platform,))
    assert not (tmp_path / "Mooring.fmu").exists()
