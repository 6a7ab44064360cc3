"""Scene description: a bent rod as data (JSON schema version 1), validated on load.

A scene is a polyline of straight segments with one cross-section and one
material, optional clamps and point masses given by arc length ``s`` (m, from
the first point), and the beam element type (``element``, a name registered in
flexfmu.ffr.elements; Euler-Bernoulli by default).  See docs/scene_format.md for
the schema and the rule for the local axes of non-circular sections.
"""
from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from flexfmu.core.checks import DENSITY_RANGE, YOUNG_MODULUS_RANGE, path_exists_as, shown
from flexfmu.errors import ParameterError, require
from flexfmu.ffr.elements import DEFAULT_ELEMENT, get_element

SCHEMA_VERSION = 1
#: Largest scene file read (bytes): a scene is a few points and constants (the built-in ones are < 1 kB); a
#: larger file is refused before it is read, not parsed for minutes.
MAX_SCENE_BYTES = 16 * 2**20
# Consecutive segments folding back onto each other (angle between directions
# close to 180 deg) have no meaningful bent-rod interpretation.
_FOLD_BACK_COS = -1.0 + 1e-9
#: A section a beam model resolves: its largest radius of gyration sqrt(max(Iy, Iz) / A) at most this fraction of the
#: rod's length (a beam, not a plate: a 1 m wide section on a 0.45 m rod is not one) ...
SECTION_SIZE_MAX = 0.1
#: ... and the rod at most this many of its smallest radii sqrt(min(Iy, Iz, J) / A) long: the bending stiffness
#: of a thinner section drowns in the rounding of the axial one (measured on a free 1 m rod, 10 mm wide: 1e-7 m
#: thick, L / r = 3.5e7, f_1 right to 4e-7; 1e-8 m thick, 3.5e8, 175 % off, silently; a 1e-9 m x 1 m section on
#: the 0.45 m double L gave frequencies of zero); 1e6 leaves a factor 35.
SLENDERNESS_MAX = 1e6
_TOP_LEVEL_FIELDS = {"schema_version", "name", "description", "points", "section", "material",
                     "clamps", "point_masses", "element"}


@dataclass(frozen=True)
class Section:
    """Cross-section constants, local element axes (see docs/scene_format.md).

    A: area, m^2.  Iy = int z^2 dA, Iz = int y^2 dA (bending about local y / z), m^4.
    J: Saint-Venant torsion constant, m^4.  Ip = Iy + Iz: polar moment used for torsional inertia.
    shear_coefficient: k = shear area / A of a shear-deformable element, if the scene gives it (None: the
    element's own rule, e.g. Cowper's value for the shape).
    """

    A: float
    Iy: float
    Iz: float
    J: float
    shape: str = "generic"
    shear_coefficient: float | None = None

    @property
    def Ip(self) -> float:
        return self.Iy + self.Iz


@dataclass(frozen=True)
class Material:
    E: float    # Pa
    nu: float   # -
    rho: float  # kg/m^3

    @property
    def G(self) -> float:
        return self.E / (2.0 * (1.0 + self.nu))


@dataclass(frozen=True)
class PointMass:
    s: float     # m, arc length
    mass: float  # kg


@dataclass(frozen=True)
class Scene:
    name: str
    points: np.ndarray                 # (n_points, 3) m, body frame
    section: Section
    material: Material
    clamps: tuple[float, ...] = ()     # arc lengths, m
    point_masses: tuple[PointMass, ...] = ()
    description: str = ""
    source: str = field(default="", compare=False)
    element: str = DEFAULT_ELEMENT     # a name in flexfmu.ffr.elements.ELEMENTS

    @property
    def segment_lengths(self) -> np.ndarray:
        return np.linalg.norm(np.diff(self.points, axis=0), axis=1)

    @property
    def vertex_arc_lengths(self) -> np.ndarray:
        """Arc length of every polyline vertex, m (first 0, last = total length)."""
        return np.concatenate([[0.0], np.cumsum(self.segment_lengths)])

    @property
    def total_length(self) -> float:
        return float(self.vertex_arc_lengths[-1])

    @property
    def total_mass(self) -> float:
        rod = self.material.rho * self.section.A * self.total_length
        return rod + sum(pm.mass for pm in self.point_masses)

    def point_at(self, s: float) -> np.ndarray:
        """Undeformed body-frame position of arc length s, m."""
        check_arc_length(self, s, "s")
        vertex_s = self.vertex_arc_lengths
        seg = int(np.clip(np.searchsorted(vertex_s, s, side="right") - 1, 0, len(vertex_s) - 2))
        t = (s - vertex_s[seg]) / (vertex_s[seg + 1] - vertex_s[seg])
        return (1 - t) * self.points[seg] + t * self.points[seg + 1]


def beam_model_dofs(scene: Scene, elements_per_segment: int, extra_arc_lengths=()) -> int:
    """DOFs of the beam model of ``scene`` at ``elements_per_segment`` (6 per node, before clamping), as
    flexfmu.ffr.mesh.build_mesh makes it: the segments' nodes and one more node for every clamp, point mass and
    extra arc length (an upper bound: such a node at an existing one is merged), known before the model is built."""
    n_segments = len(scene.points) - 1
    extra = len(tuple(extra_arc_lengths)) + len(scene.clamps) + len(scene.point_masses)
    return 6 * (n_segments * int(elements_per_segment) + 1 + extra)


def check_arc_length(scene: Scene, s: float, parameter: str) -> float:
    """Validate an arc length against the rod, with a tolerance for rounding at the ends."""
    total = scene.total_length
    tol = 1e-9 * total
    require(_is_number(s) and -tol <= float(s) <= total + tol, parameter,
            f"arc length {shown(s)} m is outside the rod", f"0 <= {parameter} <= {total:.6g} m")
    return float(min(max(float(s), 0.0), total))


# ---------------------------------------------------------------- validation

def _is_number(x) -> bool:
    if not isinstance(x, (int, float)) or isinstance(x, bool):
        return False
    try:
        return math.isfinite(x)
    except OverflowError:                 # a JSON integer too large for a float
        return False


def _positive(d: dict, key: str, prefix: str) -> float:
    name = f"{prefix}.{key}"
    require(key in d, name, "missing", "a number > 0")
    require(_is_number(d[key]) and d[key] > 0, name, f"must be a positive number, got {shown(d[key])}", "> 0")
    return float(d[key])


def _in_range(d: dict, key: str, prefix: str, bounds: tuple, unit: str) -> float:
    lo, hi = bounds
    value = _positive(d, key, prefix)
    require(lo <= value <= hi, f"{prefix}.{key}", f"{value:g} {unit} is outside the range models resolve",
            f"{lo:g} .. {hi:g} {unit}")
    return value


def _check_fields(d: dict, allowed: set[str], prefix: str) -> None:
    unknown = sorted(set(d) - allowed)
    require(not unknown, f"{prefix}{unknown[0][:60] if unknown else ''}",
            "unknown field", ", ".join(sorted(allowed)))


def section_from_dict(d) -> Section:
    """Section constants from one of the four schema forms, each with an optional ``shear_coefficient``."""
    require(isinstance(d, dict), "section", "must be an object", "circle | tube | rectangle | {A, Iy, Iz, J}")
    if "shear_coefficient" not in d:
        return _section_constants(d)
    k = d["shear_coefficient"]
    require(_is_number(k) and 0 < k <= 1, "section.shear_coefficient", f"got {shown(k)}",
            "0 < k <= 1 (shear area / area; not its inverse)")
    section = _section_constants(d)
    return Section(section.A, section.Iy, section.Iz, section.J, section.shape, float(k))


def _section_constants(d: dict) -> Section:
    shape = d.get("shape")
    if shape is None:
        _check_fields(d, {"A", "Iy", "Iz", "J", "shear_coefficient"}, "section.")
        A, Iy, Iz, J = (_positive(d, k, "section") for k in ("A", "Iy", "Iz", "J"))
        return Section(A, Iy, Iz, J, "generic")
    if shape == "circle":
        _check_fields(d, {"shape", "diameter", "shear_coefficient"}, "section.")
        dia = _positive(d, "diameter", "section")
        I = math.pi * dia**4 / 64
        return Section(math.pi * dia**2 / 4, I, I, 2 * I, "circle")
    if shape == "tube":
        _check_fields(d, {"shape", "outer_diameter", "inner_diameter", "shear_coefficient"}, "section.")
        do = _positive(d, "outer_diameter", "section")
        di = d.get("inner_diameter")
        require(_is_number(di) and 0 <= di < do, "section.inner_diameter",
                f"must be a number in [0, outer_diameter), got {shown(di)}", f"0 <= inner_diameter < {do} m")
        I = math.pi * (do**4 - di**4) / 64
        return Section(math.pi * (do**2 - di**2) / 4, I, I, 2 * I, "tube")
    if shape == "rectangle":
        _check_fields(d, {"shape", "width", "height", "shear_coefficient"}, "section.")
        b = _positive(d, "width", "section")    # along local z
        h = _positive(d, "height", "section")   # along local y
        long_side, short_side = max(b, h), min(b, h)
        r = short_side / long_side
        # Roark's approximation of the Saint-Venant torsion constant of a solid rectangle (< 4 % error).
        J = long_side * short_side**3 * (1 / 3 - 0.21 * r * (1 - r**4 / 12))
        return Section(b * h, h * b**3 / 12, b * h**3 / 12, J, "rectangle")
    raise ParameterError("section.shape", f"unknown shape {shown(shape)}",
                         "circle, tube, rectangle (or give A, Iy, Iz, J)")


def material_from_dict(d) -> Material:
    require(isinstance(d, dict), "material", "must be an object", "{E, nu, rho}")
    _check_fields(d, {"E", "nu", "rho"}, "material.")
    E = _in_range(d, "E", "material", YOUNG_MODULUS_RANGE, "Pa")
    rho = _in_range(d, "rho", "material", DENSITY_RANGE, "kg/m^3")
    require("nu" in d, "material.nu", "missing", "-1 < nu < 0.5")
    nu = d["nu"]
    require(_is_number(nu) and -1.0 < nu < 0.5, "material.nu", f"got {shown(nu)}", "-1 < nu < 0.5")
    return Material(E, float(nu), rho)


def _points_array(pts: list) -> np.ndarray:
    """(n, 3) float array of the scene's points, or ParameterError naming the first that is not 3 finite numbers.

    Checked in bulk (the types of all coordinates at once, then finiteness in numpy) and point by point only to
    name a failure: a per-point check with its message took 30 s for a million points, before a size check could
    refuse such a scene."""
    if set(map(type, pts)) == {list} and set(map(len, pts)) == {3} and \
            set(map(type, itertools.chain.from_iterable(pts))) <= {int, float}:
        try:
            points = np.asarray(pts, dtype=float)
        except OverflowError:                  # a JSON integer too large for a float: named below
            points = None
        if points is not None and np.all(np.isfinite(points)):
            return points
    for i, p in enumerate(pts):
        if not (isinstance(p, list) and len(p) == 3 and all(_is_number(c) for c in p)):
            raise ParameterError(f"points[{i}]", f"must be 3 finite numbers [x, y, z] in m, got {shown(p)}")
    return np.asarray(pts, dtype=float)


def scene_from_dict(d, source: str = "", check_size=None) -> Scene:
    """Validate a scene dictionary (schema version 1) and build a :class:`Scene`.  ``check_size(n_segments)``, if
    given, is called once the points are counted, before they are checked one by one (a model size limit refuses a
    scene of a million segments there, in the time it takes to read it)."""
    require(isinstance(d, dict), "scene", "must be a JSON object", "see docs/scene_format.md")
    _check_fields(d, _TOP_LEVEL_FIELDS, "")
    version = d.get("schema_version", SCHEMA_VERSION)
    require(version == SCHEMA_VERSION, "schema_version", f"unsupported version {shown(version)}", str(SCHEMA_VERSION))
    name = d.get("name", Path(source).stem if source else "scene")
    require(isinstance(name, str) and name != "", "name", "must be a non-empty string")

    pts = d.get("points")
    require(isinstance(pts, list) and len(pts) >= 2, "points",
            "need a list of at least 2 points [x, y, z]", "at least 2 points")
    if check_size is not None:
        check_size(len(pts) - 1)
    points = _points_array(pts)
    seg = np.diff(points, axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        lengths = np.linalg.norm(seg, axis=1)
    scale = max(float(np.max(np.abs(points))), 1e-300)
    # a length that overflows (coordinates near 1e308) would make every arc length check read "<= inf m"
    bad = np.flatnonzero(~(lengths > 1e-12 * scale) | ~np.isfinite(lengths))
    if bad.size:
        i = int(bad[0])
        if np.isfinite(lengths[i]):
            raise ParameterError(f"points[{i + 1}]", f"segment {i + 1} has zero length",
                                 "consecutive points must differ")
        raise ParameterError(f"points[{i + 1}]", f"segment {i + 1} is too long to represent ({shown(pts[i])} to "
                             f"{shown(pts[i + 1])})", "coordinates whose differences stay below 1e300 m")
    dirs = seg / lengths[:, None]
    folds = np.flatnonzero(~(np.einsum("ij,ij->i", dirs[:-1], dirs[1:]) > _FOLD_BACK_COS))
    if folds.size:
        i = int(folds[0])
        raise ParameterError(f"points[{i + 1}]", f"segments {i + 1} and {i + 2} fold back onto each other "
                             "(angle 180 deg)", "any angle between consecutive segments except a full fold-back")

    try:
        section = section_from_dict(d.get("section"))
    except OverflowError:                     # d^4, b h^3 of sizes near 1e77 m and above
        section = None
    require(section is not None and all(math.isfinite(v) and v > 0 for v in (section.A, section.Iy, section.Iz,
                                                                              section.J)),
            "section", "its area or moments overflow or underflow (not finite, or 0)",
            "sizes whose 4th powers stay within the floating-point range (about 1e-75 .. 1e75 m)")
    material = material_from_dict(d.get("material"))
    total = float(lengths.sum())
    require(math.isfinite(total), "points", "the rod's total length overflows", "coordinates below 1e300 m")
    r_min = math.sqrt(min(section.Iy, section.Iz, section.J) / section.A)
    r_max = math.sqrt(max(section.Iy, section.Iz) / section.A)
    require(r_max <= SECTION_SIZE_MAX * total and total <= SLENDERNESS_MAX * r_min, "section",
            f"radii of gyration sqrt(I / A) from {r_min:.3g} to {r_max:.3g} m on a {total:.4g} m rod: "
            + ("too wide for a beam" if r_max > SECTION_SIZE_MAX * total else
               f"{total / r_min:.3g} of them long, too thin to resolve"),
            f"sqrt(max(Iy, Iz) / A) <= {SECTION_SIZE_MAX:g} x rod length = {SECTION_SIZE_MAX * total:.3g} m and "
            f"sqrt(min(Iy, Iz, J) / A) >= rod length / {SLENDERNESS_MAX:.0e} = {total / SLENDERNESS_MAX:.3g} m")
    tol = 1e-9 * total

    clamps_raw = d.get("clamps", [])
    require(isinstance(clamps_raw, list), "clamps", "must be a list of arc lengths (m)")
    clamps = []
    for i, s in enumerate(clamps_raw):
        require(_is_number(s) and -tol <= s <= total + tol, f"clamps[{i}]",
                f"arc length {shown(s)} m is outside the rod", f"0 <= s <= {total:.6g} m")
        clamps.append(min(max(float(s), 0.0), total))

    masses_raw = d.get("point_masses", [])
    require(isinstance(masses_raw, list), "point_masses", "must be a list of {s, mass}")
    masses = []
    for i, pm in enumerate(masses_raw):
        require(isinstance(pm, dict), f"point_masses[{i}]", "must be an object {s, mass}")
        _check_fields(pm, {"s", "mass"}, f"point_masses[{i}].")
        s = pm.get("s")
        require(_is_number(s) and -tol <= s <= total + tol, f"point_masses[{i}].s",
                f"arc length {shown(s)} m is outside the rod", f"0 <= s <= {total:.6g} m")
        mass = _positive(pm, "mass", f"point_masses[{i}]")
        masses.append(PointMass(min(max(float(s), 0.0), total), mass))

    description = d.get("description", "")
    require(isinstance(description, str), "description", "must be a string")
    element = d.get("element", DEFAULT_ELEMENT)
    get_element(element, "element")           # a registered name, else ParameterError naming them
    return Scene(name=name, points=points, section=section, material=material,
                 clamps=tuple(sorted(set(clamps))), point_masses=tuple(masses),
                 description=description, source=source, element=element)


# ---------------------------------------------------------------- loading

def builtin_scene_names() -> list[str]:
    folder = resources.files("flexfmu") / "scenes"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".json"))


def load_scene(name_or_path: str | Path, parameter: str = "scene", check_size=None) -> Scene:
    """Load a built-in scene by name, or a scene JSON file by path, and validate it.  Every problem with the
    file (missing, a directory, empty, too large, unreadable, not UTF-8, not JSON, nested too deeply) is a
    ParameterError naming ``parameter`` (the FMU parameter that gave the name) and the file.  ``check_size``: as
    :func:`scene_from_dict`'s."""
    text = str(name_or_path)
    names = builtin_scene_names()
    allowed = "one of " + ", ".join(names) + ", or a path to a scene JSON (UTF-8)"
    if text in names:
        raw = (resources.files("flexfmu") / "scenes" / f"{text}.json").read_text(encoding="utf-8")
        source = f"builtin:{text}"
    else:
        path = Path(text)
        kind = path_exists_as(text)
        require(kind != "directory", parameter, f"{shown(text)} is a directory, not a scene file", allowed)
        require(kind == "file", parameter, f"{shown(text)} is neither a built-in scene nor an existing file"
                + (" (a device or pipe)" if kind == "other" else ""), allowed)
        source = str(path)
        try:
            size = path.stat().st_size
            require(size <= MAX_SCENE_BYTES, parameter, f"{shown(source)} is {size} bytes, too large for a scene file",
                    f"at most {MAX_SCENE_BYTES} bytes")
            data_bytes = path.read_bytes()
        except OSError as exc:
            raise ParameterError(parameter, f"{shown(source)} cannot be read ({exc.strerror or exc})",
                                 allowed) from None
        require(data_bytes.strip() != b"", parameter, f"{shown(source)} is empty", "a scene JSON object "
                "(docs/scene_format.md)")
        try:
            raw = data_bytes.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ParameterError(parameter, f"{shown(source)} is not UTF-8 text (byte {data_bytes[exc.start]:#04x} at "
                                 f"offset {exc.start})", "a scene JSON file encoded in UTF-8") from None
    try:
        data = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise ParameterError(parameter, f"{shown(source)} is not valid JSON: {exc}") from None
    except RecursionError:
        raise ParameterError(parameter, f"{shown(source)} nests JSON arrays or objects too deeply to read",
                             "a scene JSON (schema version 1: nested at most 3 levels)") from None
    except ValueError as exc:                 # e.g. an integer literal longer than Python converts
        raise ParameterError(parameter, f"{shown(source)} has a value that cannot be read: {exc}") from None
    try:
        return scene_from_dict(data, source=source, check_size=check_size)
    except RecursionError:
        raise ParameterError(parameter, f"{shown(source)} nests JSON arrays or objects too deeply",
                             "a scene JSON (schema version 1: nested at most 3 levels)") from None
