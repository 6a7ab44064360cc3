"""flexfmu: flexible-body dynamics (FFR discontinuous beams, reframe integrator) for FMI co-simulation.

Pure numerics; the FMU wrappers live in ``fmu_src/`` and import this package.
"""
from flexfmu.errors import FlexfmuError, ParameterError

__version__ = "0.1.0"
__all__ = ["FlexfmuError", "ParameterError", "__version__"]
