"""The FFR beam element types and their registry: a scene's ``"element"`` names one (default Euler-Bernoulli).

A new element type is a module here with a :class:`BeamElement` subclass, and one :func:`register` call below
(or anywhere before the scene that names it is loaded: tests register their own).  Scenes validate their
``element`` field against this registry, and the FFR modules (mesh, assembly, kinematics, dynamics, geometric
stiffness) take the element object from the mesh (:attr:`flexfmu.ffr.mesh.Mesh.element`).
"""
from __future__ import annotations

from flexfmu.core.checks import shown
from flexfmu.errors import require
from flexfmu.ffr.elements.base import BeamElement
from flexfmu.ffr.elements.euler_bernoulli import EulerBernoulliElement
from flexfmu.ffr.elements.timoshenko import TimoshenkoElement

#: name -> element class, in registration order.
ELEMENTS: dict[str, type[BeamElement]] = {}
DEFAULT_ELEMENT = "euler_bernoulli"


def register(element_class: type[BeamElement]) -> type[BeamElement]:
    """Make ``element_class`` selectable by its ``name`` (returns it, so it also serves as a class decorator).
    It must subclass BeamElement and keep the FFR nodal layout (2 nodes x 6 DOFs); a name is registered once."""
    if not (isinstance(element_class, type) and issubclass(element_class, BeamElement)):
        raise TypeError(f"an element type is a subclass of BeamElement, got {element_class!r}")
    name = element_class.name
    if not (isinstance(name, str) and name.isidentifier()):
        raise ValueError(f"{element_class.__name__}.name must be an identifier, got {name!r}")
    if name in ELEMENTS and ELEMENTS[name] is not element_class:
        raise ValueError(f"element {name!r} is already registered ({ELEMENTS[name].__name__})")
    if (element_class.nodes_per_element, element_class.dofs_per_node) != (2, 6):
        raise ValueError(f"{element_class.__name__}: the FFR modules take 2 nodes x 6 DOFs per element, got "
                         f"{element_class.nodes_per_element} x {element_class.dofs_per_node}")
    ELEMENTS[name] = element_class
    return element_class


def element_names() -> tuple[str, ...]:
    return tuple(ELEMENTS)


def get_element(name: str = DEFAULT_ELEMENT, parameter: str = "element") -> BeamElement:
    """The element object registered as ``name``; a ParameterError naming ``parameter`` and the registered names
    otherwise."""
    require(isinstance(name, str) and name in ELEMENTS, parameter, f"unknown element {shown(name)}",
            " | ".join(ELEMENTS))
    return ELEMENTS[name]()


register(EulerBernoulliElement)
register(TimoshenkoElement)

__all__ = ["BeamElement", "DEFAULT_ELEMENT", "ELEMENTS", "EulerBernoulliElement", "TimoshenkoElement",
           "element_names", "get_element", "register"]
