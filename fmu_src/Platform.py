"""Platform.fmu: a floating box as a rigid 6-DOF body with added mass, carrying a payload (FMI 2.0 co-simulation).

Thin shell over flexfmu.platform_sim; the FMI behaviour is flexfmu.fmi.plumbing's.
"""
from pythonfmu import Fmi2Slave

from flexfmu import platform_sim
from flexfmu.fmi.plumbing import Plumbing


class Platform(Fmi2Slave):
    author = "flexfmu"
    description = "Floating box as a rigid 6-DOF body (linear seakeeping, with added mass) carrying a payload at a mount point"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmu = Plumbing(self, platform_sim.PlatformConfig, platform_sim.PlatformSimulator, platform_sim)

    def do_step(self, current_time, step_size):   # for pythonfmu's builder; the FMU's binary calls the plumbing
        return True
