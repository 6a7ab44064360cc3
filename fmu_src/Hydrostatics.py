"""Hydrostatics.fmu: linear hydrostatic restoring and radiation damping of a floating box (FMI 2.0 co-simulation).

Thin shell over flexfmu.hydrostatics_sim; the FMI plumbing is in flexfmu_fmu_base.
"""
from flexfmu_fmu_base import FlexfmuPlumbing
from pythonfmu import Fmi2Slave

from flexfmu import hydrostatics_sim


class Hydrostatics(Fmi2Slave):
    author = "flexfmu"
    description = "Linear hydrostatic restoring and radiation damping of a floating box (minimal Cummins model)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = FlexfmuPlumbing(self, hydrostatics_sim.HydrostaticsConfig, hydrostatics_sim.HydrostaticsSimulator, hydrostatics_sim)

    def exit_initialization_mode(self):
        self.fmu.exit_initialization_mode()

    def do_step(self, current_time, step_size):
        return self.fmu.do_step(current_time, step_size)

    def _get_fmu_state(self):
        return self.fmu.get_fmu_state()

    def _set_fmu_state(self, state):
        self.fmu.set_fmu_state(state)
