"""WaveExcitation.fmu: Froude-Krylov wave load on a floating box (FMI 2.0 co-simulation).

Thin shell over flexfmu.wave_excitation_sim; the FMI behaviour is flexfmu.fmi.plumbing's.
"""
from pythonfmu import Fmi2Slave

from flexfmu import wave_excitation_sim
from flexfmu.fmi.plumbing import Plumbing


class WaveExcitation(Fmi2Slave):
    author = "flexfmu"
    description = "Froude-Krylov force and moment of a regular Airy wave or a JONSWAP sea on a floating box"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = Plumbing(self, wave_excitation_sim.WaveExcitationConfig, wave_excitation_sim.WaveExcitationSimulator, wave_excitation_sim)

    def do_step(self, current_time, step_size):   # for pythonfmu's builder; the FMU's binary calls the plumbing
        return True
