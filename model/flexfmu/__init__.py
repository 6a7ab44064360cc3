"""flexfmu: flexible-body dynamics (FFR discontinuous beams, reframe integrator) for FMI co-simulation.

The numerics, in subpackages (docs/architecture.md); the FMI side is flexfmu.fmi.
"""
from flexfmu.errors import FlexfmuError, ParameterError

__version__ = "0.1.0"
__all__ = ["FlexfmuError", "ParameterError", "__version__"]
