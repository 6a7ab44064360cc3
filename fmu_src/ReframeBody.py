"""ReframeBody.fmu: a free flexible body by the reframe integrator (FMI 2.0 co-simulation).

Thin shell over flexfmu.reframe_body_sim; the FMI behaviour is flexfmu.fmi.plumbing's.
"""
from pythonfmu import Fmi2Slave

from flexfmu import reframe_body_sim
from flexfmu.fmi.plumbing import Plumbing


class ReframeBody(Fmi2Slave):
    author = "flexfmu"
    description = ("Free flexible body from a conventional linear structural model by the reframe integrator "
                   "(Liu): large rigid motion plus vibration")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = Plumbing(self, reframe_body_sim.ReframeBodyConfig, reframe_body_sim.ReframeBodySimulator, reframe_body_sim)

    def do_step(self, current_time, step_size):   # for pythonfmu's builder; the FMU's binary calls the plumbing
        return True
