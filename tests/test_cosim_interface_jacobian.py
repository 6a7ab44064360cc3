"""The interface-Jacobian coupling scheme of our master (flexfmu.cosim.coupling, docs/stability.md "Interface-Jacobian
coupling"): where it is stable and where it is not, its interface Jacobians (the library's central differences
against the beam's mass and modes, and against the native FMU's exact directional derivatives), the coupling
equations it solves, the FMU path, and `flexfmu cosim --scheme interface-jacobian`."""
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from fmu_helpers import ROOT

from flexfmu import cli
from flexfmu.cosim.checks import check_system
from flexfmu.cosim.coupling import (COUPLING_SCHEMES, INTERFACE_JACOBIAN, InterfaceCoupling,
                                   check_interface_jacobians)
from flexfmu.cosim.masters import (STABILITY_TOLERANCE, Master, SimulatorSpec, System, load_system, run,
                                   spectral_radius)
from flexfmu.cosim.slaves import FmuSlave, LibrarySlave
from flexfmu.errors import CosimulationError, ParameterError

SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
IJ = INTERFACE_JACOBIAN
STABLE = 1 + STABILITY_TOLERANCE
#: The example's Gauss-Seidel limit as step_limit measures it (benchmarks/interface_jacobian.py, docs/stability.md):
#: the narrow band at 2.25 ms below the wide instability from 4.14 ms (tests/test_wave_cosim.py)
GS_STEP_LIMIT = 2.239e-3
AXES = "xyz"


# ------------------------------------------------------------------------------------------ stability
@pytest.mark.study
def test_stable_where_the_harvesters_inertial_loop_makes_gauss_seidel_and_jacobi_unstable():
    """A heavy harvester (FFRBeam, beam / platform mass ratio 10) on a rigid platform: the added-mass loop
    (platform compliance x the beam's residual inertia, gain 2.4 > 1: docs/stability.md study 3) makes Gauss-Seidel
    and Jacobi unstable at every step, down to 1e-5 s; solved at each communication point it is stable at 2x and
    5x that step, and a kicked run decays."""
    from flexfmu.studies.stability_cosim import cosim_run, instantaneous_loop_radius, platform_beam_system

    assert instantaneous_loop_radius(10.0) > 2.0
    system = platform_beam_system(10.0)
    for h in (1e-5, 2e-5, 5e-5):
        assert spectral_radius(system, h, "gauss-seidel") > 2.0, h
        assert spectral_radius(system, h, "jacobi") > 1.4, h           # sqrt(2.4): two exchanges of delay
    for h in (2e-5, 5e-5):
        assert spectral_radius(system, h, IJ) <= STABLE, h
    first, last, error = cosim_run(system, 5e-5, IJ, n_steps=100)
    assert error is None and last < first


@pytest.mark.study
def test_wave_converter_stable_where_jacobi_is_not_but_the_pto_lag_stays():
    """The wave converter: the scheme steps every simulator at once, as Jacobi, and is stable at 2 ms where Jacobi
    (limit 1.09 ms) is not.  Its limit is Gauss-Seidel's, not above it: the binding loop is the PTO damper on
    the rod (docs/wave_converter.md), whose force depends on the rod's velocity, a state (D = 0): exchanged at the
    communication point and held over the next step it lags as in Gauss-Seidel, and at 5x the Gauss-Seidel limit
    the scheme is unstable too; with the PTO off it is stable there in the constant-coefficient hydrodynamics.  (With
    the example's BEM hydrodynamics and the PTO off, the box's roll, damped by potential flow only, is weakly
    unstable there, |lambda| - 1 = 3.3e-4 against the PTO loop's 0.10: the held hydrostatic roll moment's lag,
    docs/wave_converter.md "Coupling stability".)"""
    system = load_system(SYSTEM)
    assert spectral_radius(system, 2e-3, "jacobi") > 1.01
    assert spectral_radius(system, 2e-3, IJ) <= STABLE
    h = round(5 * GS_STEP_LIMIT * 1e6) / 1e6
    assert spectral_radius(system, h, IJ) > 1.05
    constant = {name: {"hydrodynamics": "constant"} for name in ("wave", "platform", "hydro")}
    assert spectral_radius(system.with_values({"pto": {"damping": 0.0}, **constant}), h, IJ) <= STABLE


# ------------------------------------------------------------------------------------------ the interface Jacobian
def test_library_jacobian_of_the_clamp_reaction_is_minus_the_residual_mass():
    """FFRBeam's clamp reaction force in its base acceleration, from the façade's output function by central
    differences, is -(m I - L^T L): minus the rigid mass its retained modes do not carry, computed here from the
    finite-element mass matrix and a dense eigensolve of the free DOFs (L = Phi^T B2^T M R, R: rigid translation)."""
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator

    slave = LibrarySlave(SimulatorSpec("beam", Path("FFRBeam.fmu"), {}))
    slave.initialize(0.0)
    names = [f"base_a_{a}" for a in AXES]
    rows = [slave.output_names.index(f"reaction_F_{a}") for a in AXES]
    D = slave.output_jacobian(names)[rows]

    config = FFRBeamConfig()
    model = FFRBeamSimulator(config).dynamics.model
    R = np.zeros((model.n_dof, 3))
    for k in range(3):
        R[k::6, k] = 1.0
    M = model.M.toarray()
    _, phi = scipy.linalg.eigh(model.K_free.toarray(), model.M_free.toarray())
    L = phi[:, :config.n_modes].T @ model.B2.toarray().T @ M @ R
    residual = R.T @ M @ R - L.T @ L
    mass = float(R[:, 0] @ M @ R[:, 0])
    # the modes carry most of the mass: the check tells the residual from the whole (-m I)
    assert np.all(np.diag(residual) < 0.5 * mass)
    # two dense eigensolves of one pencil: L^T L does not depend on the modes' signs, and the modes agree to a
    # few hundred u relative to the gaps of the six retained frequencies (>= 10 %): 1e-9 of the block is loose
    assert np.abs(D + residual).max() <= 1e-9 * np.abs(residual).max()


def test_coupling_equations_hold_after_each_step():
    """After each interface-Jacobian step every connected input equals the output that feeds it, as recorded (the
    outputs for the solved inputs), and the affine outputs (platform accelerations, hydrostatic loads, PTO force)
    equal the façades' own outputs for those inputs: the linearisation is exact for them."""
    system = load_system(SYSTEM).with_values({"wave": {"ramp_time": 0.0}})
    master = Master(system, "library")
    master.initialize(IJ)
    for k in range(20):
        master.step(k * 1e-3, 1e-3, IJ)
    slaves, out = master.slaves, master.coupled_outputs
    for target, groups in master.plan.items():
        for source, outputs, inputs in groups:
            fed = np.array(slaves[target].get(inputs))
            given = np.array([out[source][slaves[source].output_names.index(o)] for o in outputs])
            assert np.abs(fed - given).max() <= 1e-12 * max(np.abs(given).max(), 1e-300), (source, target)
    affine = {"platform": ("acc_x", "acc_z", "alpha_y", "mount_a_x", "mount_a_z"),
              "hydro": ("F_z", "M_y"), "pto": ("F_x", "F_z", "stator_F_z")}
    for name, outputs in affine.items():
        sl = slaves[name]
        sl.sim.set_inputs(**{n: sl.values[n] for n in sl.input_names})
        exact = sl.sim.outputs()
        for o in outputs:
            coupled = out[name][sl.output_names.index(o)]
            assert abs(coupled - exact[o]) <= 1e-10 * max(abs(exact[o]), 1e-12), (name, o, coupled, exact[o])


class _Affine:
    """A slave stub with one input and one output y = gain u + offset (and its interface Jacobian)."""

    def __init__(self, gain, offset):
        self.gain, self.offset, self.u = gain, offset, 0.0
        self.output_names = ("y",)

    def get(self, names):
        return [self.u] if names == ("u",) else [self.gain * self.u + self.offset]

    def set(self, names, values):
        self.u = float(values[0])

    def output_jacobian(self, names):
        return np.array([[self.gain]])


def test_the_solve_is_exact_for_affine_outputs_and_a_loop_of_gain_one_is_refused():
    """a.y -> b.u, b.y -> a.u: u_b = 2 u_a + 1, u_a = -3 u_b + 4 has the one solution u_a = 1/7, u_b = 9/7
    whatever the inputs held before (to 1e-14: a 2 x 2 LU solve errs by a few u times the condition, < 10); with
    gains 1 and 1 and an offset (the loop u = u + 1) there is none."""
    plan = {"a": [("b", ("y",), ("u",))], "b": [("a", ("y",), ("u",))]}
    coupling = InterfaceCoupling(("a", "b"), plan)
    slaves = {"a": _Affine(2.0, 1.0), "b": _Affine(-3.0, 4.0)}
    slaves["a"].u, slaves["b"].u = 5.0, -2.0                  # held inputs far from the solution
    outputs = coupling.solve(slaves, 0.0)
    assert slaves["a"].u == pytest.approx(1 / 7, rel=1e-14) and slaves["b"].u == pytest.approx(9 / 7, rel=1e-14)
    assert outputs["a"][0] == pytest.approx(slaves["b"].u, rel=1e-14)
    with pytest.raises(CosimulationError, match=r"t = 0\.5 s: .* are singular .* through (a\.u, b\.u|b\.u, a\.u)"):
        coupling.solve({"a": _Affine(1.0, 1.0), "b": _Affine(1.0, 0.0)}, 0.5)


# ------------------------------------------------------------------------------------------ FMUs
def _fake_fmu(path: Path, provides: bool) -> Path:
    """An FMU archive with only a modelDescription.xml (an input u, an output y): enough for everything checked
    before an instance is made."""
    flag = ' providesDirectionalDerivative="true"' if provides else ""
    xml = f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Gain" guid="{{00000000-0000-0000-0000-000000000001}}">
  <CoSimulation modelIdentifier="Gain"{flag}/>
  <ModelVariables>
    <ScalarVariable name="u" valueReference="0" causality="input" variability="continuous"><Real start="0"/>
    </ScalarVariable>
    <ScalarVariable name="y" valueReference="1" causality="output" variability="continuous"><Real/>
    </ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="2"/></Outputs></ModelStructure>
</fmiModelDescription>
"""
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", xml)
    return path


def test_fmu_without_directional_derivatives_is_refused_naming_the_instance(tmp_path):
    without = _fake_fmu(tmp_path / "Gain.fmu", provides=False)
    system = System([SimulatorSpec("source", without, {}), SimulatorSpec("fed", without, {})],
                    [(("source", "y"), ("fed", "u"))], 1e-3)
    with pytest.raises(ParameterError, match=r"fed: its FMU Gain\.fmu provides no directional derivatives") as exc:
        run(system, 0.01, scheme=IJ, backend="fmu")
    assert "--master library" in str(exc.value) and "gauss-seidel" in str(exc.value)
    # an instance no connection feeds needs none; one that provides them passes
    alone = System(system.simulators, [], 1e-3)
    check_interface_jacobians(alone, check_system(alone), "fmu")
    (tmp_path / "with").mkdir()
    with_them = _fake_fmu(tmp_path / "with" / "Gain.fmu", provides=True)
    system = System([SimulatorSpec("source", without, {}), SimulatorSpec("fed", with_them, {})],
                    [(("source", "y"), ("fed", "u"))], 1e-3)
    check_interface_jacobians(system, check_system(system), "fmu")


@pytest.fixture(scope="module")
def native_beam(tmp_path_factory):
    """The native FFRBeam FMU (the registry's defaults), or a skip when it provides no directional derivatives."""
    from fmpy import read_model_description

    from flexfmu.fmi import native
    path = native.build_registry_fmu("FFRBeam", target=tmp_path_factory.mktemp("native_ij") / "FFRBeam.fmu")
    if not read_model_description(str(path)).coSimulation.providesDirectionalDerivative:
        pytest.skip("the native FFRBeam FMU provides no directional derivatives (providesDirectionalDerivative is "
                    "not true): the FMU path of the interface-Jacobian scheme needs them")
    return path


@pytest.mark.fmu
def test_fmu_directional_derivatives_equal_the_library_central_differences(native_beam):
    """At a loaded, spinning state: the native FFRBeam's exact fmi2GetDirectionalDerivative and the façade's central
    differences (exact for its outputs of degree <= 2 in each input) agree to the native-vs-Python contract."""
    spec = SimulatorSpec("beam", native_beam, {})
    fmu, lib = FmuSlave(spec), LibrarySlave(spec)
    try:
        inputs = {"F_z": 0.3, "M_x": 0.1, "base_a_x": 1.0, "base_w_y": 0.5, "base_dw_z": 2.0}
        for slave in (fmu, lib):
            slave.initialize(0.0)
            slave.set(list(inputs), list(inputs.values()))
            for k in range(5):
                slave.do_step(k * 1e-3, 1e-3)
        exact, central = fmu.output_jacobian(fmu.input_names), lib.output_jacobian(lib.input_names)
        scale = np.abs(exact).max() + np.abs(np.array(lib.get(lib.output_names))).max()
        assert np.abs(exact - central).max() <= 1e-10 * scale
    finally:
        fmu.free()


@pytest.mark.fmu
def test_fmu_master_equals_the_library_on_a_loop_of_two_native_beams(native_beam):
    """Two native FFRBeams in a loop through direct feedthrough both ways (beam 1's clamp reaction is beam 2's tip
    force, beam 2's sensor acceleration is beam 1's base acceleration), beam 1 kicked at its tip for one step:
    the interface-Jacobian master over the FMUs equals it over the library to the native-vs-Python contract, the
    loop's gain (< 0.1 here, asserted) amplifying the difference at most 1 / (1 - gain)."""
    conns = []
    for a in AXES:
        conns += [(("b1", f"reaction_F_{a}"), ("b2", f"F_{a}")), (("b2", f"sensor_a_{a}"), ("b1", f"base_a_{a}"))]
    system = System([SimulatorSpec("b1", native_beam, {}), SimulatorSpec("b2", native_beam, {})], conns, 1e-3)
    records = {}
    for backend in ("fmu", "library"):
        master = Master(system, backend)
        try:
            master.initialize(IJ)
            master.slaves["b1"].set(["F_z"], [1.0])
            rows = []
            for k in range(40):
                master.step(k * 1e-3, 1e-3, IJ)
                if k == 0:
                    master.slaves["b1"].set(["F_z"], [0.0])
                rows.append(master.outputs())
            if backend == "library":
                D1 = master.slaves["b1"].output_jacobian([f"base_a_{a}" for a in AXES])
                D2 = master.slaves["b2"].output_jacobian([f"F_{a}" for a in AXES])
                names = master.slaves["b1"].output_names
                gain = np.abs(np.linalg.eigvals(D1[[names.index(f"reaction_F_{a}") for a in AXES]]
                                                @ D2[[names.index(f"sensor_a_{a}") for a in AXES]])).max()
        finally:
            master.free()
        records[backend] = np.array(rows)
    assert gain < 0.1
    fmu, lib = records["fmu"], records["library"]
    scale = np.abs(lib).max(axis=0)
    moving = scale > 0
    assert moving.sum() > 20
    assert np.all(np.abs(fmu - lib).max(axis=0)[moving] <= 1e-10 / (1 - gain) * scale[moving])


# ------------------------------------------------------------------------------------------ API and CLI
def test_scheme_names_run_and_cli(tmp_path, capsys):
    assert IJ in COUPLING_SCHEMES and COUPLING_SCHEMES[:2] == ("jacobi", "gauss-seidel")
    system = load_system(SYSTEM)
    allowed = re.escape(" | ".join(COUPLING_SCHEMES))
    with pytest.raises(ParameterError, match=rf"scheme: got 'gauss_seidel' \(allowed: {allowed}\)"):
        run(system, 0.01, scheme="gauss_seidel", backend="library")
    out = tmp_path / "ij.csv"
    assert cli.main(["cosim", str(SYSTEM), "--t-end", "0.01", "--master", "library", "--scheme", IJ,
                     "--no-stability-check", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "master library (interface-jacobian), step 0.001 s" in captured.out
    assert out.read_text().count("\n") == 1 + 11
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["cosim", str(SYSTEM), "--t-end", "0.01", "--scheme", "newton"])
    assert exit_info.value.code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1 and "--scheme" in errors[0] and all(s in errors[0] for s in COUPLING_SCHEMES)
    assert cli.main(["cosim", str(SYSTEM), "--t-end", "0.01", "--master", "libcosim", "--scheme", IJ]) == 2
    assert "scheme: interface-jacobian with --master libcosim" in capsys.readouterr().err
