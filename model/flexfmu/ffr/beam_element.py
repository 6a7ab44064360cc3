"""The Euler-Bernoulli element's functions and the element frame, under their former module name.

The element types now live in :mod:`flexfmu.ffr.elements` (one module each, selected by a scene's "element");
this module re-exports the default element's functions for code that imports them from here.
"""
from __future__ import annotations

from flexfmu.ffr.elements.base import element_dof_rotation, element_rotation
from flexfmu.ffr.elements.euler_bernoulli import local_mass, local_shape_functions, local_stiffness

__all__ = ["element_dof_rotation", "element_rotation", "local_mass", "local_shape_functions", "local_stiffness"]
