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

from dataclasses import dataclass

from flexfmu.core.checks import finite
from flexfmu.errors import ModelFileError, ParameterError

#: name -> (metres per length unit, newtons per force unit); the time unit is always the second.
UNIT_SYSTEMS = {"m": (1.0, 1.0), "cm": (1e-2, 1e-5), "mm": (1e-3, 1.0), "in": (0.0254, 4.4482216152605)}
UNIT_DESCRIPTIONS = {"m": "m, N, kg, s (SI)", "cm": "cm, dyn, g, s (CGS)", "mm": "mm, N, t, s (MPa, t/mm^3)",
                     "in": "in, lbf, lbf s^2/in, s (psi)"}
UNITS_ALLOWED = " | ".join(UNIT_SYSTEMS)
MATERIAL_ALLOWED = "{'E': Young's modulus > 0 (Pa), 'nu': Poisson's ratio in (-1, 0.5), 'rho': density > 0 (kg/m^3)}"


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


def check_material(value, where: str = "material", path=None) -> Material:
    """A :class:`Material` from a Material or a mapping with E, nu, rho; errors name ``where``
    (and the file ``path`` when the material came from one)."""
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
    return Material(**numbers)


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
