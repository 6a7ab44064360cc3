"""Flexible bodies with named interfaces, from any Structure: a free body (the reframe integrator) or a body
clamped to a moving base (the FFR equations with inertia integrals from M), reduced to a :class:`FlexBody`
(one .npz) and simulated by :class:`FlexBodySimulator` (what an exported FMU wraps).

    interfaces  Interface (what the user asks for), Patch (resolved: nodes, RBE3-like D)
    free        the free body's reduced arrays and the reframe kernels on them
    clamped     the clamped body's equations (B0)-(B6) and reduced arrays; clamped_dynamics: their stepping
    model       FlexBody: the reduced model, save / load; its kinds FreeBody and ClampedBody (what differs)
    variables   FlexBodyConfig, ClampedBodyConfig: the FMU's parameters and their checks
    engines     FreeEngine, ClampedEngine: the state and the step of each kind
    build       build_body: Structure + interfaces -> FreeBody or ClampedBody
    simulator   FlexBodySimulator, input_names, output_names, variable_info
"""
from __future__ import annotations

__all__ = ["Interface", "FlexBody", "FreeBody", "ClampedBody", "build_body", "FlexBodyConfig", "FlexBodySimulator",
           "input_names", "output_names", "variable_info"]

_WHERE = {"Interface": "interfaces", "FlexBody": "model", "FreeBody": "model", "ClampedBody": "model",
          "build_body": "build", "FlexBodyConfig": "simulator",
          "FlexBodySimulator": "simulator", "input_names": "simulator", "output_names": "simulator",
          "variable_info": "simulator"}


def __getattr__(name):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib import import_module
    value = getattr(import_module(f"flexfmu.body.{_WHERE[name]}"), name)
    globals()[name] = value
    return value
