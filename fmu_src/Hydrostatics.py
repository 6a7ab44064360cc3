"""Hydrostatics.fmu: linear hydrostatic restoring and radiation damping of a floating box (FMI 2.0 co-simulation).

Thin shell over flexfmu.hydrostatics_sim; the FMI behaviour is flexfmu.fmi.plumbing's.
"""
from pythonfmu import Fmi2Slave

from flexfmu import hydrostatics_sim
from flexfmu.fmi.plumbing import Plumbing


class Hydrostatics(Fmi2Slave):
    author = "flexfmu"
    description = "Linear hydrostatic restoring and radiation damping of a floating box (minimal Cummins model)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = Plumbing(self, hydrostatics_sim.HydrostaticsConfig, hydrostatics_sim.HydrostaticsSimulator, hydrostatics_sim)

    def do_step(self, current_time, step_size):   # for pythonfmu's builder; the FMU's binary calls the plumbing
        return True
