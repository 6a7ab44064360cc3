"""flexfmu: flexible-body dynamics (FFR discontinuous beams, reframe integrator) for FMI co-simulation.

The public API is flat; the subpackages (docs/architecture.md) hold the implementation, and the FMI
side is flexfmu.fmi.  Names are imported on first use, so ``import flexfmu`` (as every FMU does) costs
nothing beyond the errors.

A beam scene, its converged natural frequencies and a point's mode shape (FFR, Koda et al. 2025):

>>> import flexfmu
>>> scene = flexfmu.load_scene("spatial_double_L")
>>> result = flexfmu.modal_analysis(scene, "XFF", n_modes=3)
>>> result.modes.frequencies_hz.round(1).tolist()
[39.6, 43.8, 105.5]
>>> sensor = flexfmu.point_shape(result.model.mesh, 0.04)     # 40 mm above the clamp
>>> sensor.displacement_body(result.model.B2 @ result.modes.shapes[:, 0]).shape
(3,)

A conventional structural model, its modal basis and the reframe integrator (Liu):

>>> import numpy as np
>>> rod = flexfmu.load_model("beam:spatial_double_L")
>>> basis = flexfmu.modal_basis(rod, 4)
>>> integ = flexfmu.ReframeIntegrator(rod, basis, scheme="exponential")
>>> load = flexfmu.PointLoad(0, flexfmu.half_sine_pulse(np.array([1.0, 0.0, 0.0]), 0.01))
>>> res = integ.run(0.02, 1e-3, load)
>>> bool(res.com_velocity[-1, 0] > 0)                          # pushed along +x
True

A user's FE model (a mesh and its material, a Nastran deck, MAPDL's .full) through one entry point:

>>> flexfmu.load_structure("no_such_bracket.msh", material={"E": 2.1e11, "nu": 0.3, "rho": 7850})  # doctest: +ELLIPSIS
Traceback (most recent call last):
    ...
flexfmu.errors.ParameterError: source: no such file or model: 'no_such_bracket.msh' (allowed: paper_plate | ...)

Bad input names the parameter and what is allowed:

>>> flexfmu.load_scene("no_such_scene")   # doctest: +ELLIPSIS
Traceback (most recent call last):
    ...
flexfmu.errors.ParameterError: scene: 'no_such_scene' is neither a built-in scene nor an existing file ...
"""
from importlib import import_module

from flexfmu.errors import (ConvergenceError, CosimulationError, DivergenceError, FlexfmuError,
                            ModalConvergenceError, ModelFileError, NonFiniteError, ParameterError, StepRejected)

#: The package version (PEP 440); the FMUs built by it record it.
__version__ = "0.1.0"

#: public name -> the module that defines it
_LAZY = {
    # beam scenes and the FFR model
    "Scene": "flexfmu.ffr.scene", "load_scene": "flexfmu.ffr.scene", "scene_from_dict": "flexfmu.ffr.scene",
    "build_beam_model": "flexfmu.ffr.assembly", "modal_analysis": "flexfmu.ffr.report",
    "point_shape": "flexfmu.ffr.kinematics", "point_motion": "flexfmu.ffr.kinematics",
    "FramePose": "flexfmu.ffr.kinematics", "FFRBeamConfig": "flexfmu.ffr.simulator",
    "FFRBeamSimulator": "flexfmu.ffr.simulator",
    # conventional models, modal bases, the reframe integrator
    # load_structure: every model source (meshes, Nastran, MAPDL .full, .npz, specs); .npz via flexfmu.core.io
    "Structure": "flexfmu.core.structure", "load_structure": "flexfmu.importers", "save_structure": "flexfmu.core.io",
    "Provenance": "flexfmu.core.structure",
    "load_model": "flexfmu.reframe.models", "paper_plate": "flexfmu.reframe.plate",
    "solve_modes": "flexfmu.linalg.modal", "modal_basis": "flexfmu.linalg.modal_basis",
    "ModalBasis": "flexfmu.linalg.modal_basis", "mass_properties": "flexfmu.linalg.modal_basis",
    "ReframeIntegrator": "flexfmu.reframe.integrator", "PointLoad": "flexfmu.reframe.integrator",
    "half_sine_pulse": "flexfmu.reframe.integrator", "constant_load": "flexfmu.reframe.integrator",
    "ReframeBodyConfig": "flexfmu.reframe.simulator", "ReframeBodySimulator": "flexfmu.reframe.simulator",
    # the FMUs
    "FMUS": "flexfmu.fmi.registry",
}

__all__ = ["ConvergenceError", "CosimulationError", "DivergenceError", "FlexfmuError", "ModalConvergenceError",
           "ModelFileError", "NonFiniteError", "ParameterError", "StepRejected", "__version__", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value          # later lookups skip this function
        return value
    raise AttributeError(f"module 'flexfmu' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
