"""FFRBeam.fmu: the FFR model of a bent-rod scene, clamped, on a moving base (FMI 2.0 co-simulation).

Thin shell over flexfmu.ffr_beam_sim; the FMI plumbing is in flexfmu_fmu_base.
"""
from flexfmu_fmu_base import FlexfmuPlumbing
from pythonfmu import Fmi2Slave

from flexfmu import ffr_beam_sim


class FFRBeam(Fmi2Slave):
    author = "flexfmu"
    description = "FFR discontinuous-beam model (Koda et al. 2025) of a clamped bent rod on a moving base"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = FlexfmuPlumbing(self, ffr_beam_sim.FFRBeamConfig, ffr_beam_sim.FFRBeamSimulator, ffr_beam_sim)

    def exit_initialization_mode(self):
        self.fmu.exit_initialization_mode()

    def do_step(self, current_time, step_size):
        return self.fmu.do_step(current_time, step_size)

    def _get_fmu_state(self):
        return self.fmu.get_fmu_state()

    def _set_fmu_state(self, state):
        self.fmu.set_fmu_state(state)
