"""WaveExcitation.fmu: Froude-Krylov wave load on a floating box (FMI 2.0 co-simulation).

Thin shell over flexfmu.wave_excitation_sim; the FMI plumbing is in flexfmu_fmu_base.
"""
from flexfmu_fmu_base import FlexfmuPlumbing
from pythonfmu import Fmi2Slave

from flexfmu import wave_excitation_sim


class WaveExcitation(Fmi2Slave):
    author = "flexfmu"
    description = "Froude-Krylov force and moment of a regular Airy wave or a JONSWAP sea on a floating box"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = FlexfmuPlumbing(self, wave_excitation_sim.WaveExcitationConfig, wave_excitation_sim.WaveExcitationSimulator, wave_excitation_sim)

    def exit_initialization_mode(self):
        self.fmu.exit_initialization_mode()

    def do_step(self, current_time, step_size):
        return self.fmu.do_step(current_time, step_size)

    def _get_fmu_state(self):
        return self.fmu.get_fmu_state()

    def _set_fmu_state(self, state):
        self.fmu.set_fmu_state(state)
