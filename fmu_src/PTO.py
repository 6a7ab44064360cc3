"""PTO.fmu: a linear damper/generator between a harvester point and its platform (FMI 2.0 co-simulation).

Thin shell over flexfmu.pto_sim; the FMI plumbing is in flexfmu_fmu_base.
"""
from flexfmu_fmu_base import FlexfmuPlumbing
from pythonfmu import Fmi2Slave

from flexfmu import pto_sim


class PTO(Fmi2Slave):
    author = "flexfmu"
    description = "Linear damper/generator between a harvester point and its platform; harvested power"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = FlexfmuPlumbing(self, pto_sim.PTOConfig, pto_sim.PTOSimulator, pto_sim)

    def exit_initialization_mode(self):
        self.fmu.exit_initialization_mode()

    def do_step(self, current_time, step_size):
        return self.fmu.do_step(current_time, step_size)

    def _get_fmu_state(self):
        return self.fmu.get_fmu_state()

    def _set_fmu_state(self, state):
        self.fmu.set_fmu_state(state)
