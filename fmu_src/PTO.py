"""PTO.fmu: a linear damper/generator between a harvester point and its platform (FMI 2.0 co-simulation).

Thin shell over flexfmu.pto_sim; the FMI behaviour is flexfmu.fmi.plumbing's.
"""
from pythonfmu import Fmi2Slave

from flexfmu import pto_sim
from flexfmu.fmi.plumbing import Plumbing


class PTO(Fmi2Slave):
    author = "flexfmu"
    description = "Linear damper/generator between a harvester point and its platform; harvested power"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = Plumbing(self, pto_sim.PTOConfig, pto_sim.PTOSimulator, pto_sim)

    def do_step(self, current_time, step_size):   # for pythonfmu's builder; the FMU's binary calls the plumbing
        return True
