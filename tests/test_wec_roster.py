"""The wave-energy converter's roster is read from the system file (flexfmu.wec.roles, flexfmu.wec.system): a new
component joins the system as its module and its registry row, and the audit, the summary and the chart take it in
with no other edit.

The new component is defined in this file, which is its module: a linear spring-damper mooring between the
platform's waterplane centre O and the sea floor, F = -k x - c v on the three translations.  The Platform has one
input per load group, so the mooring adds its force to the hydrostatic load in series: Hydrostatics -> mooring ->
Platform.hydro_*.  Its role says what it contributes to the audit: the energy its spring stores and its damper
dissipates, from its own outputs.  Registered here for the tests only; a user adds it for good as
model/flexfmu/wec/mooring.py (this section of the file) and one FmuSpec row in flexfmu/fmi/registry.py.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

from fmu_helpers import ROOT

from flexfmu import cli
from flexfmu.cosim import masters
from flexfmu.cosim.masters import SimulatorSpec, load_system, run, write_osp
from flexfmu.errors import ParameterError
from flexfmu.fmi import registry
from flexfmu.wec import system as wec
from flexfmu.wec.components import AXES, MemorylessSimulator, check_config, vector_info
from flexfmu.wec.roles import DISSIPATED, POTENTIAL, Panel, Role, Term, change, integral, roster

SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
#: the audit's tolerance and step in tests/test_wave_bem_cosim.py (the example's BEM hydrodynamics, Gauss-Seidel, 6 s):
#: the residual is the first-order coupling error of the held hydrostatic and memory loads, -1.12 % at the example's
#: 1 ms and -0.56 % at 0.5 ms for the example without the mooring (-0.94 % and -0.47 % with it)
AUDIT_TOLERANCE = 0.01
AUDIT_STEP = 5e-4
T_END = 6.0


# ---------------------------------------------------------------- the new component's module
INPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"vel_{a}" for a in AXES)
               + tuple(f"load_F_{a}" for a in AXES) + tuple(f"load_M_{a}" for a in AXES))
OUTPUT_NAMES = (tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES)
                + ("potential_energy", "damping_power"))


@dataclass(frozen=True)
class MooringConfig:
    stiffness: float = 400.0     # N/m, each translation
    damping: float = 150.0       # N s/m, each translation


class MooringSimulator(MemorylessSimulator):
    """The line's force on O plus the load passed through (the platform's hydro input takes one load)."""

    INPUTS = INPUT_NAMES

    def __init__(self, config: MooringConfig = MooringConfig()):
        super().__init__(config)
        check_config(config)

    def _outputs(self) -> dict:
        v = self.inputs
        x, xd = (np.array([v[f"{k}_{a}"] for a in AXES]) for k in ("pos", "vel"))
        k, c = self.config.stiffness, self.config.damping
        F = np.array([v[f"load_F_{a}"] for a in AXES]) - k * x - c * xd
        M = [v[f"load_M_{a}"] for a in AXES]
        return dict(zip(OUTPUT_NAMES, F.tolist() + M + [0.5 * k * float(x @ x), c * float(xd @ xd)]))


VARIABLE_INFO = {"stiffness": ("N/m", "line stiffness"), "damping": ("N.s/m", "line damping"),
                 **vector_info("pos", "m", "displacement of O", "global"),
                 **vector_info("vel", "m/s", "velocity of O", "global"),
                 **vector_info("load_F", "N", "load passed through", "global"),
                 **vector_info("load_M", "N.m", "moment passed through", "global"),
                 **vector_info("F", "N", "load plus the line's force", "global"),
                 **vector_info("M", "N.m", "moment passed through", "global"),
                 "potential_energy": ("J", "spring energy"), "damping_power": ("W", "damper power")}


class MooringRole(Role):
    """The spring's energy and the damper's, from the mooring's own outputs."""

    kind = "mooring"

    def energy(self, m, r):
        return [Term(POTENTIAL, "potential: mooring" + m.suffix, change(r.col(m.name, "potential_energy"))),
                Term(DISSIPATED, "dissipated: mooring damping" + m.suffix,
                     integral(r.col(m.name, "damping_power"), r.t))]

    def panels(self, m, r):
        return [Panel("mooring" + m.suffix, "mooring force", "N",
                      [(r.col(m.name, "F_x") - r.input_vec(m.name, "load_F_{}")[:, 0], {"label": "x"})])]


SYSTEM_ROLE = MooringRole()
#: the registry row (in flexfmu/fmi/registry.py's FMUS for good)
MOORING = registry.FmuSpec("Mooring", __name__, "MooringConfig", "MooringSimulator",
                           "Linear spring-damper mooring of a floating body's waterplane centre", role=__name__)


# ---------------------------------------------------------------- fixtures
@pytest.fixture
def mooring(monkeypatch):
    """The Mooring registered for one test: its row in the registry (FMUS, BY_NAME) and in the masters' table of
    library models, which they make from the registry when imported."""
    monkeypatch.setattr(registry, "FMUS", registry.FMUS + (MOORING,))
    monkeypatch.setitem(registry.BY_NAME, MOORING.name, MOORING)
    if hasattr(masters, "LIBRARY_MODULES"):
        monkeypatch.setitem(masters.LIBRARY_MODULES, MOORING.name, (MOORING.module, MOORING.config, MOORING.simulator))
    return MOORING


def with_mooring(path: Path, **values) -> Path:
    """A copy of the example's system file with the mooring between Hydrostatics and the Platform's hydro input
    (after hydro in the Gauss-Seidel order), its motion from the Platform."""
    system = load_system(SYSTEM)
    sims = list(system.simulators)
    i = [s.name for s in sims].index("hydro") + 1
    sims.insert(i, SimulatorSpec("mooring", path.parent / "Mooring.fmu", dict(values)))
    conns = [c for c in system.connections if not (c[0][0] == "hydro" and c[1][0] == "platform")]
    for k in "FM":
        for a in AXES:
            conns += [(("hydro", f"{k}_{a}"), ("mooring", f"load_{k}_{a}")),
                      (("mooring", f"{k}_{a}"), ("platform", f"hydro_{k}_{a}"))]
    conns += [(("platform", f"{q}_{a}"), ("mooring", f"{q}_{a}")) for q in ("pos", "vel") for a in AXES]
    return write_osp(replace(system, simulators=sims, connections=conns), path)


def without(system, names):
    """The system with the instances ``names`` and their connections taken out."""
    return replace(system, simulators=[s for s in system.simulators if s.name not in names],
                   connections=[c for c in system.connections if c[0][0] not in names and c[1][0] not in names])


# ---------------------------------------------------------------- tests
def test_a_new_component_joins_the_audit_and_the_balance_closes_only_with_its_terms(mooring, tmp_path, monkeypatch):
    system = load_system(with_mooring(tmp_path / "OspSystemStructure.xml"))
    assert [m.role.kind for m in roster(system).members] == ["wave", "platform", "hydrostatics", "mooring",
                                                             "harvester", "pto"]
    result = run(system, T_END, AUDIT_STEP, scheme="gauss-seidel", backend="library", record=wec.recorder(system))
    balance = wec.energy_balance(result, system)
    print(f"\n{balance.table()}")
    terms = balance.terms
    moored = terms["potential: mooring"] + terms["dissipated: mooring damping"]
    assert terms["dissipated: mooring damping"] > 0
    assert abs(balance.relative_residual) < AUDIT_TOLERANCE, balance.table()
    # the mooring's forces act through the platform's hydro input: the platform's own bookkeeping stays exact
    assert abs(balance.diagnostics["platform: d(kinetic) - sum of work_*"]) < 1e-9 * balance.wave_work
    # its terms sit between the others by category, in the file's order
    assert list(terms).index("potential: mooring") == list(terms).index("potential: hydrostatic") + 1

    # the same run audited as if the mooring's role said nothing: the balance does not close
    monkeypatch.setattr(MooringRole, "energy", lambda self, m, r: [])
    blind = wec.energy_balance(result, system)
    assert "potential: mooring" not in blind.terms
    assert blind.residual == pytest.approx(balance.residual + moored, rel=1e-12)
    assert abs(blind.relative_residual) > 2 * AUDIT_TOLERANCE, blind.table()


def test_the_cli_runs_the_new_system_with_the_library_master(mooring, tmp_path, capsys):
    path = with_mooring(tmp_path / "OspSystemStructure.xml")
    status = cli.main(["cosim", str(path), "--t-end", "0.5", "--master", "library", "--plot", str(tmp_path / "r.png")])
    out = capsys.readouterr()
    assert status == 0, out.err
    assert "potential: mooring" in out.out and "dissipated: mooring damping" in out.out
    assert "mean harvested power" in out.out and (tmp_path / "r.png").read_bytes()[:4] == b"\x89PNG"


def test_an_extra_instance_and_missing_optional_components(tmp_path):
    system = load_system(SYSTEM)
    base = run(system, 1.0, scheme="gauss-seidel", backend="library")
    # a second wave, unconnected (a probe of another heading): it loads nothing, so brings no work in; the
    # labels of a model's instances name them once the file holds more than one
    probe = replace(system, simulators=system.simulators + [replace(system.simulator("wave"), name="wave2")])
    probe = probe.with_values({"wave2": {"heading": 90.0}})
    result = run(probe, 1.0, scheme="gauss-seidel", backend="library")
    a, b = wec.energy_balance(base, system), wec.energy_balance(result, probe)
    assert b.inputs == {"work done by the wave force [wave]": a.wave_work}
    assert b.terms == a.terms and b.residual == a.residual
    assert wec.is_wec(probe) and "wave elevation at O [wave2]" in _labels(result, probe)
    assert wec.plot_result(result, probe, tmp_path / "probe.png").is_file()

    # no harvester and no PTO: nothing harvested, the rest of the audit as before (the example's hydrodynamics is
    # bem: the radiation term is the memory's signed work)
    bare = without(system, {"harvester", "pto"})
    result = run(bare, 1.0, AUDIT_STEP, scheme="gauss-seidel", backend="library", record=wec.recorder(bare))
    balance = wec.energy_balance(result, bare)
    assert list(balance.terms) == ["kinetic: platform incl. added mass", "potential: hydrostatic",
                                   wec.RADIATION_MEMORY_TERM]
    assert abs(balance.relative_residual) < AUDIT_TOLERANCE
    assert wec.harvested_power(result, bare, 0.5) == 0.0
    assert "mean harvested power          0 W" in wec.summary(result, bare)
    assert wec.plot_result(result, bare, tmp_path / "bare.png").is_file()


def _labels(result, system):
    from flexfmu.wec.roles import Recorded
    r = Recorded(result, roster(system))
    return [style["label"] for m in r.roster.members for p in m.role.panels(m, r) for _, style in p.curves]


def test_an_unknown_model_or_a_missing_wave_or_platform_is_refused_by_name():
    system = load_system(SYSTEM)
    barge = load_system(ROOT / "examples" / "flexible_barge" / "OspSystemStructure.xml")
    with pytest.raises(ParameterError, match=r"simulator: barge: Barge is not a component") as err:
        roster(barge)
    for model in ("WaveExcitation", "Platform", "Hydrostatics", "FFRBeam", "PTO"):
        assert model in str(err.value)
    assert "ReframeBody" not in str(err.value)                 # registered, but no part of this system
    assert not wec.is_wec(barge)
    with pytest.raises(ParameterError, match="no wave"):
        roster(without(system, {"wave"}))
    with pytest.raises(ParameterError, match="no platform"):
        wec.energy_balance(None, without(system, {"platform"}))
    # the studies that need one of a kind say so
    two = replace(system, simulators=system.simulators + [replace(system.simulator("harvester"), name="h2")])
    with pytest.raises(ParameterError, match="2 instances of the harvester role"):
        roster(two).one("harvester")


def test_the_cli_refuses_a_chart_of_a_system_that_is_not_a_converter_before_running_it(tmp_path, capsys):
    """--plot on the flexible-barge system: refused up front (no co-simulation is run, no CSV written), naming --plot
    and, from the roster, the simulator that is not a component."""
    out = tmp_path / "never.csv"
    status = cli.main(["cosim", str(ROOT / "examples" / "flexible_barge" / "OspSystemStructure.xml"), "--t-end", "0.1",
                       "--master", "library", "--out", str(out), "--plot", str(tmp_path / "r.png")])
    err = capsys.readouterr().err
    assert status == 2, err
    assert "plot: the system is not a wave-energy converter" in err and "Barge is not a component" in err, err
    assert not out.exists()
