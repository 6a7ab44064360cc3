"""Platform.fmu: a floating box as a rigid 6-DOF body with added mass, carrying a payload (FMI 2.0 co-simulation).

Thin shell over flexfmu.platform_sim; the FMI plumbing is in flexfmu_fmu_base.
"""
from flexfmu_fmu_base import FlexfmuPlumbing
from pythonfmu import Fmi2Slave

from flexfmu import platform_sim


class Platform(Fmi2Slave):
    author = "flexfmu"
    description = "Floating box as a rigid 6-DOF body (linear seakeeping, with added mass) carrying a payload at a mount point"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = FlexfmuPlumbing(self, platform_sim.PlatformConfig, platform_sim.PlatformSimulator, platform_sim)

    def exit_initialization_mode(self):
        self.fmu.exit_initialization_mode()

    def do_step(self, current_time, step_size):
        return self.fmu.do_step(current_time, step_size)

    def _get_fmu_state(self):
        return self.fmu.get_fmu_state()

    def _set_fmu_state(self, state):
        self.fmu.set_fmu_state(state)
