"""Materials and unit systems of model files: what turns a file's numbers into SI.

A mesh file (gmsh, Abaqus, VTK, ...) holds only coordinates: its ``length_unit`` scales them to metres and
the material is given separately, in SI.  A Nastran deck or MAPDL's matrices hold material constants or
matrices too, in the file's own *consistent* unit system; ``length_unit`` then names that system:

=======  ==========================  =======================================
name     length, force, mass, time   typical material numbers (steel)
=======  ==========================  =======================================
m        m, N, kg, s (SI)            E = 2.1e11 Pa,   rho = 7850 kg/m^3
cm       cm, dyn, g, s (CGS)         E = 2.1e12 Ba,   rho = 7.85 g/cm^3
mm       mm, N, t, s                 E = 2.1e5 MPa,   rho = 7.85e-9 t/mm^3
in       in, lbf, lbf s^2/in, s      E = 3.0e7 psi,   rho = 7.35e-4 lbf s^2/in^4
=======  ==========================  =======================================
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from flexfmu.core.checks import DENSITY_RANGE, YOUNG_MODULUS_RANGE, finite
from flexfmu.errors import ModelFileError, ParameterError

#: name -> (metres per length unit, newtons per force unit); the time unit is always the second.
UNIT_SYSTEMS = {"m": (1.0, 1.0), "cm": (1e-2, 1e-5), "mm": (1e-3, 1.0), "in": (0.0254, 4.4482216152605)}
UNIT_DESCRIPTIONS = {"m": "m, N, kg, s (SI)", "cm": "cm, dyn, g, s (CGS)", "mm": "mm, N, t, s (MPa, t/mm^3)",
                     "in": "in, lbf, lbf s^2/in, s (psi)"}
UNITS_ALLOWED = " | ".join(UNIT_SYSTEMS)
MATERIAL_ALLOWED = (f"{{'E': Young's modulus {YOUNG_MODULUS_RANGE[0]:g} .. {YOUNG_MODULUS_RANGE[1]:g} Pa, 'nu': "
                    f"Poisson's ratio in (-1, 0.5), 'rho': density {DENSITY_RANGE[0]:g} .. {DENSITY_RANGE[1]:g} "
                    "kg/m^3}")

#: The plausible size of a model: the largest extent of its nodes' bounding box, m (after the length unit).  Read
#: in metres because no length unit was given, a model outside 1 mm .. 10 m is likely in another unit (the 80 mm
#: example bracket, a mm mesh, read as metres is 80 m across); with a length unit given, outside 1 mm .. 1 km.  A
#: model outside gets a ModelSizeWarning (and a note in its provenance), not an error: it may be what was meant.
PLAUSIBLE_SIZE = {"assumed": (1e-3, 10.0), "given": (1e-3, 1e3)}


class ModelSizeWarning(UserWarning):
    """A model whose size is implausible in the length unit it was read in (PLAUSIBLE_SIZE)."""


def check_model_size(path, nodes_m, unit: str, assumed: bool) -> str | None:
    """Warn (ModelSizeWarning) and return the message when the model is implausibly large or small in ``unit``
    (PLAUSIBLE_SIZE; ``assumed``: no length unit was given, so metres were assumed); None when plausible."""
    nodes = np.asarray(nodes_m, dtype=float).reshape(-1, 3)
    extent = float(np.max(np.ptp(nodes, axis=0))) if nodes.shape[0] else 0.0
    lo, hi = PLAUSIBLE_SIZE["assumed" if assumed else "given"]
    if lo <= extent <= hi:
        return None
    how = "no length unit given, so metres assumed" if assumed else f"length unit {unit}"
    others = " | ".join(u for u in UNIT_SYSTEMS if u != unit)
    message = (f"{getattr(path, 'name', path)}: the model is {extent:.4g} m across (largest extent of its nodes; "
               f"{how}), outside the plausible {lo:g} .. {hi:g} m: if its coordinates are in another unit, give "
               f"--length-unit {others}" + (" (--length-unit m: metres indeed)" if assumed else ""))
    warnings.warn(message, ModelSizeWarning, stacklevel=3)
    return message


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material, SI: E (Pa), nu, rho (kg/m^3)."""

    E: float
    nu: float
    rho: float

    def as_tuple(self) -> tuple:
        return (("E", self.E), ("nu", self.nu), ("rho", self.rho))

    def lame(self) -> tuple[float, float]:
        """(lambda, mu), Pa."""
        lam = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        return lam, self.E / (2.0 * (1.0 + self.nu))

    def in_si(self, unit_system: str) -> "Material":
        """This material's numbers read in ``unit_system`` (stress F/L^2, density F s^2/L^4), as SI."""
        length, force = UNIT_SYSTEMS[unit_system]
        return Material(self.E * force / length**2, self.nu, self.rho * force / length**4)


def check_length_unit(value, where: str = "length_unit") -> str:
    """``value`` if it names a unit system (the table above), else ParameterError naming ``where``."""
    if not isinstance(value, str) or value.strip() not in UNIT_SYSTEMS:
        raise ParameterError(where, f"{value!r} is not a known length unit", UNITS_ALLOWED)
    return value.strip()


def check_material(value, where: str = "material", path=None, unit_system: str = "m", unit_hint: str = "") -> Material:
    """A :class:`Material`, SI, from a Material or a mapping with E, nu, rho in ``unit_system``'s numbers (a
    Nastran deck's); errors name ``where`` (and the file ``path`` when the material came from one).  E and rho
    must lie in flexfmu.core.checks' YOUNG_MODULUS_RANGE and DENSITY_RANGE once in SI (``unit_hint``: what to say
    when one is below its range, e.g. that the file may be in another unit system)."""
    def fail(key, message):
        if path is not None:
            raise ModelFileError(path, message, MATERIAL_ALLOWED, entity=key)
        raise ParameterError(key, message, MATERIAL_ALLOWED)

    if isinstance(value, Material):
        value = {"E": value.E, "nu": value.nu, "rho": value.rho}
    if not isinstance(value, dict):
        fail(where, f"{value!r} is not a mapping with E, nu and rho")
    unknown = sorted(set(value) - {"E", "nu", "rho"})
    if unknown:
        fail(f"{where}.{unknown[0]}", "unknown material constant")
    numbers = {}
    for key in ("E", "nu", "rho"):
        if key not in value:
            fail(f"{where}.{key}", "missing")
        if not finite(value[key]):
            fail(f"{where}.{key}", f"{value[key]!r} is not a finite number")
        numbers[key] = float(value[key])
    if numbers["E"] <= 0:
        fail(f"{where}.E", f"{numbers['E']!r} is not > 0")
    if not -1.0 < numbers["nu"] < 0.5:
        fail(f"{where}.nu", f"{numbers['nu']!r} is not in (-1, 0.5)")
    if numbers["rho"] <= 0:
        fail(f"{where}.rho", f"{numbers['rho']!r} is not > 0")
    material = Material(**numbers).in_si(unit_system)
    for key, (lo, hi), unit in (("E", YOUNG_MODULUS_RANGE, "Pa"), ("rho", DENSITY_RANGE, "kg/m^3")):
        si = getattr(material, key)
        if not lo <= si <= hi:
            read = "" if unit_system == "m" else f" ({numbers[key]:g} in {UNIT_DESCRIPTIONS[unit_system]})"
            hint = f" ({unit_hint})" if unit_hint and si < lo else ""
            fail(f"{where}.{key}", f"{si:g} {unit}{read} is outside {lo:g} .. {hi:g} {unit}{hint}")
    return material


def material_from_text(text: str | None):
    """"E,NU,RHO" -> {"E", "nu", "rho"} (checked by the importers), or None."""
    if text is None:
        return None
    allowed = "E,NU,RHO: Young's modulus (Pa), Poisson's ratio, density (kg/m^3), e.g. 2.1e11,0.3,7850"
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        raise ParameterError("material", f"{text!r} is not numeric", allowed) from None
    if len(values) != 3:
        raise ParameterError("material", repr(text), allowed)
    return dict(zip(("E", "nu", "rho"), values))
