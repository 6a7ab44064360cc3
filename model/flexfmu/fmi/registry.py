"""The one list of flexfmu's FMUs.  The build makes one FMU per entry (its pythonfmu slave generated from
:data:`SLAVE_TEMPLATE`), the co-simulation masters run the entry's simulator in place of the FMU
(``--master library``), and docs/fmu.md lists the variables of the documented ones.

A new FMU is a simulator module (a config dataclass, a simulator class, INPUT_NAMES, OUTPUT_NAMES,
VARIABLE_INFO; see flexfmu.fmi.plumbing) and one entry here.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field


@dataclass(frozen=True)
class FmuSpec:
    """One FMU: its model name (also the modelIdentifier), the simulator it wraps, what its
    modelDescription says, and whether docs/fmu.md carries its variable table."""

    name: str
    module: str                       # the simulator module, e.g. "flexfmu.ffr.simulator"
    config: str                       # its config dataclass (the parameters)
    simulator: str                    # its simulator class
    description: str
    experiment: dict = field(default_factory=dict)    # DefaultExperiment attributes
    documented: bool = False

    def load(self):
        """The simulator module."""
        return importlib.import_module(self.module)

    @property
    def config_class(self):
        return getattr(self.load(), self.config)

    @property
    def simulator_class(self):
        return getattr(self.load(), self.simulator)

    # What flexfmu.fmi.plumbing asks of any FMU spec (an exported body's spec answers from its model file).
    @property
    def input_names(self) -> tuple:
        return self.load().INPUT_NAMES

    @property
    def output_names(self) -> tuple:
        return self.load().OUTPUT_NAMES

    @property
    def variable_info(self) -> dict:
        return self.load().VARIABLE_INFO

    @property
    def deferred_outputs(self) -> tuple:
        return getattr(self.load(), "DEFERRED_OUTPUTS", ())

    def make_simulator(self, config):
        return self.simulator_class(config)


_WEC = {"startTime": "0", "stopTime": "20", "stepSize": "1e-3"}

#: Every FMU flexfmu builds (one FmuSpec each: model name, simulator, description, default experiment), in
#: build order; ``flexfmu build`` and build_scripts/build_fmus.py make one FMU per entry.
FMUS: tuple[FmuSpec, ...] = (
    FmuSpec("FFRBeam", "flexfmu.ffr.simulator", "FFRBeamConfig", "FFRBeamSimulator",
            "FFR discontinuous-beam model (Koda et al. 2025) of a clamped bent rod on a moving base",
            {"startTime": "0", "stopTime": "1", "stepSize": "1e-4"}, documented=True),
    FmuSpec("ReframeBody", "flexfmu.reframe.simulator", "ReframeBodyConfig", "ReframeBodySimulator",
            "Free flexible body from a conventional linear structural model by the reframe integrator "
            "(Liu): large rigid motion plus vibration",
            {"startTime": "0", "stopTime": "1", "stepSize": "1e-3"}, documented=True),
    # The wave-energy-converter components (docs/wave_converter.md).
    FmuSpec("WaveExcitation", "flexfmu.wec.wave_excitation", "WaveExcitationConfig", "WaveExcitationSimulator",
            "Froude-Krylov force and moment of a regular Airy wave or a JONSWAP sea on a floating box", _WEC),
    FmuSpec("Hydrostatics", "flexfmu.wec.hydrostatics", "HydrostaticsConfig", "HydrostaticsSimulator",
            "Linear hydrostatic restoring and radiation damping of a floating box (minimal Cummins model)", _WEC),
    FmuSpec("Platform", "flexfmu.wec.platform", "PlatformConfig", "PlatformSimulator",
            "Floating box as a rigid 6-DOF body (linear seakeeping, with added mass) carrying a payload at a "
            "mount point", _WEC),
    FmuSpec("PTO", "flexfmu.wec.pto", "PTOConfig", "PTOSimulator",
            "Linear damper/generator between a harvester point and its platform; harvested power", _WEC),
)
BY_NAME = {spec.name: spec for spec in FMUS}

#: The pythonfmu slave script of an FMU (pythonfmu's builder finds the class by ``class X(Fmi2Slave):``).
SLAVE_TEMPLATE = '''"""{name}.fmu: {description}.

Generated from flexfmu.fmi.registry by the build; the FMI behaviour is flexfmu.fmi.plumbing's.
"""
from pythonfmu import Fmi2Slave

from flexfmu.fmi.plumbing import Plumbing
from flexfmu.fmi.registry import BY_NAME


class {name}(Fmi2Slave):
    author = "flexfmu"
    description = {description!r}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = Plumbing(self, BY_NAME[{name!r}])

    def do_step(self, current_time, step_size):   # for pythonfmu's builder; the FMU's binary calls the plumbing
        return True
'''


def slave_script(spec: FmuSpec) -> str:
    return SLAVE_TEMPLATE.format(name=spec.name, description=spec.description)
