"""FFRBeam.fmu: the FFR model of a bent-rod scene, clamped, on a moving base (FMI 2.0 co-simulation).

Thin shell over flexfmu.ffr_beam_sim; the FMI behaviour is flexfmu.fmi.plumbing's.
"""
from pythonfmu import Fmi2Slave

from flexfmu import ffr_beam_sim
from flexfmu.fmi.plumbing import Plumbing


class FFRBeam(Fmi2Slave):
    author = "flexfmu"
    description = "FFR discontinuous-beam model (Koda et al. 2025) of a clamped bent rod on a moving base"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = Plumbing(self, ffr_beam_sim.FFRBeamConfig, ffr_beam_sim.FFRBeamSimulator, ffr_beam_sim)

    def do_step(self, current_time, step_size):   # for pythonfmu's builder; the FMU's binary calls the plumbing
        return True
