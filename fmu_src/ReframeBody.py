"""ReframeBody.fmu: a free flexible body by the reframe integrator (FMI 2.0 co-simulation).

Thin shell over flexfmu.reframe_body_sim; the FMI plumbing is in flexfmu_fmu_base.
"""
from flexfmu_fmu_base import FlexfmuPlumbing
from pythonfmu import Fmi2Slave

from flexfmu import reframe_body_sim


class ReframeBody(Fmi2Slave):
    author = "flexfmu"
    description = ("Free flexible body from a conventional linear structural model by the reframe integrator "
                   "(Liu): large rigid motion plus vibration")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = FlexfmuPlumbing(self, reframe_body_sim.ReframeBodyConfig, reframe_body_sim.ReframeBodySimulator, reframe_body_sim)

    def exit_initialization_mode(self):
        self.fmu.exit_initialization_mode()

    def do_step(self, current_time, step_size):
        return self.fmu.do_step(current_time, step_size)

    def _get_fmu_state(self):
        return self.fmu.get_fmu_state()

    def _set_fmu_state(self, state):
        self.fmu.set_fmu_state(state)
