"""Solid meshes read with meshio (gmsh .msh, Abaqus .inp, VTK .vtu / .vtk, Exodus, MED, XDMF, ...).

The volume cells (:mod:`flexfmu.importers.elements`) are assembled; surface, line and vertex cells are kept
only as node sets.  Node sets come from meshio's ``point_sets`` (Abaqus NSET), ``cell_sets`` (Abaqus ELSET,
gmsh 4 physical groups: the nodes of the set's cells) and gmsh 2 physical groups (``gmsh:physical`` cell data
named by ``field_data``).  The material is given in SI, as an argument or in a model JSON::

    {"mesh": "bracket.msh",                                   path relative to the JSON file
     "material": {"E": 2.1e11, "nu": 0.3, "rho": 7850},       Pa, -, kg/m^3
     "length_unit": "mm",                                     the mesh's coordinates (default "m")
     "name": "bracket",                                       optional (default: the JSON's stem)
     "integration": "full"}                                   optional: "full" or "reduced" (elements.py)

A mesh with a model JSON beside it that names it (``<mesh stem>.json``) is read as that JSON says: its length
unit, integration and name always hold (one given again as an argument is refused, never silently replaced), its
material unless a material is given (then the given one is used, and the provenance says so).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from flexfmu.core.checks import shown
from flexfmu.errors import ModelFileError, ParameterError
from flexfmu.importers.assembly import CellBlock
from flexfmu.importers.build import ReadMesh, structure_from_mesh, versions
from flexfmu.importers.elements import ALIASES, CELL_TYPES, SUPPORTED, check_integration, volume_cell_types
from flexfmu.importers.units import UNITS_ALLOWED, check_length_unit, check_material

JSON_KEYS = ("mesh", "material", "length_unit", "name", "integration")
JSON_DEPTH = 2                              # the object, and the material in it
JSON_ALLOWED = ('{"mesh": path, "material": {"E", "nu", "rho"}, "length_unit": ' + f'"{UNITS_ALLOWED}", "name": text, '
                '"integration": "full | reduced"}')


def mesh_extensions() -> list[str]:
    """File extensions meshio reads (``.msh``, ``.inp``, ``.vtu``, ...)."""
    from meshio._helpers import extension_to_filetypes
    return sorted(extension_to_filetypes)


def read_meshio(path: Path):
    """``(meshio.Mesh, format name)``, or ModelFileError naming the file and meshio's complaint."""
    from meshio._helpers import _filetypes_from_path, reader_map

    try:
        formats = _filetypes_from_path(path)
    except (KeyError, ValueError):
        raise ModelFileError(path, "unknown mesh file extension", ", ".join(mesh_extensions())) from None
    # meshio's own readers, one format at a time: meshio.read prints and calls sys.exit when a read fails
    formats = sorted(formats, key=lambda f: f != "gmsh")            # .msh: gmsh before ANSYS's
    failures = []
    for fmt in formats:
        try:
            return reader_map[fmt](str(path)), fmt
        except Exception as exc:                # meshio raises anything from ReadError to IndexError on bad input
            failures.append(f"{type(exc).__name__}: {str(exc).strip()[:200] or 'no detail'}")
    raise ModelFileError(path, f"cannot be read as {' or '.join(formats)} by meshio ({'; '.join(failures)})",
                         f"a valid {' or '.join(formats)} mesh file")


def _node_sets(mesh) -> dict:
    """name -> point indices, from point sets, cell sets and gmsh 2 physical groups."""
    sets: dict[str, set] = {}

    def add(name, points):
        sets.setdefault(str(name), set()).update(int(p) for p in np.asarray(points).ravel())

    for name, points in mesh.point_sets.items():
        add(name, points)
    for name, per_block in mesh.cell_sets.items():
        if str(name).startswith("gmsh:"):
            continue                          # meshio's bookkeeping (bounding entities), not a user set
        for block, rows in zip(mesh.cells, per_block):
            if rows is not None and len(rows):
                add(name, block.data[np.asarray(rows, dtype=np.int64)])
    physical = mesh.cell_data.get("gmsh:physical")
    if physical is not None and not mesh.cell_sets:
        for name, (tag, dim) in ((n, tuple(int(v) for v in np.asarray(td)[:2])) for n, td in mesh.field_data.items()):
            for block, tags in zip(mesh.cells, physical):
                if block.dim == dim:
                    add(name, block.data[np.asarray(tags) == tag])
    return {name: np.array(sorted(points), dtype=np.int64) for name, points in sets.items()}


def read_blocks(path: Path, mesh, material) -> tuple[list[CellBlock], list[str]]:
    """The volume cell blocks of a meshio mesh and notes on the cells that were dropped."""
    volume_types = volume_cell_types()
    blocks, dropped = [], {}
    offset = 0
    for block in mesh.cells:
        cell_type = ALIASES.get(block.type, block.type)
        n = len(block.data)
        if cell_type in CELL_TYPES:
            blocks.append(CellBlock(cell_type, np.asarray(block.data, dtype=np.int64), material,
                                    np.arange(offset, offset + n)))
        elif cell_type in volume_types:
            raise ModelFileError(path, f"volume cell type {block.type!r} is not supported", SUPPORTED,
                                 entity=f"{block.type} cells")
        else:
            dropped[block.type] = dropped.get(block.type, 0) + n
        offset += n
    notes = [f"not assembled (node sets only): " + ", ".join(f"{n} {t}" for t, n in dropped.items())] if dropped else []
    return blocks, notes


def _sibling_json(path: Path):
    candidate = path.with_suffix(".json")
    if candidate.is_file():
        try:
            spec = json.loads(candidate.read_text())
        except (OSError, ValueError, UnicodeDecodeError, RecursionError):
            return None                       # not a model JSON of this mesh (nested beyond any model JSON)
        if isinstance(spec, dict) and isinstance(spec.get("mesh"), str) and \
                (candidate.parent / spec["mesh"]).resolve() == path.resolve():
            return candidate
    return None


def load_mesh(path, *, material=None, length_unit: str | None = None, name: str | None = None,
              integration: str | None = None, provenance_notes=()) -> "Structure":
    """The Structure of a mesh file (see the module docstring); ``material`` a mapping with E, nu, rho (SI)."""
    path = Path(path)
    sibling = _sibling_json(path)
    if sibling is not None:
        # the model JSON naming this mesh holds its length unit: never dropped, even when the material is given
        return load_model_json(sibling, material=material, length_unit=length_unit, integration=integration,
                               material_replaces=material is not None)
    if material is None:
        raise ModelFileError(path, "no material: give material={'E': ..., 'nu': ..., 'rho': ...} or a model "
                             f"JSON naming this mesh ({path.with_suffix('.json').name})", JSON_ALLOWED,
                             entity="material")
    return read_mesh_file(path, material=material, length_unit=length_unit, name=name, integration=integration,
                          provenance_notes=provenance_notes)


def read_mesh_file(path: Path, *, material, length_unit: str | None, name: str | None, integration: str | None,
                   provenance_notes=()) -> "Structure":
    """load_mesh once the material is known (no model JSON looked up)."""
    mat = check_material(material)
    unit = "m" if length_unit is None else check_length_unit(length_unit)
    integration = check_integration("full" if integration is None else integration)
    mesh, fmt = read_meshio(path)
    blocks, notes = read_blocks(path, mesh, mat)
    read = ReadMesh(points=np.asarray(mesh.points, dtype=float), blocks=blocks, node_sets=_node_sets(mesh),
                    notes=notes + list(provenance_notes))
    if read.points.ndim != 2 or read.points.shape[1] != 3:
        # 2-D meshes carry no z: they have no volume cells either
        raise ModelFileError(path, f"points have {read.points.shape[-1]} coordinates", "3-D points (x, y, z)")
    return structure_from_mesh(path, read, length_unit=unit, name=name or path.stem, file_format=fmt,
                               reader=versions("meshio", "scikit-fem"), integration=integration,
                               unit_assumed=length_unit is None)


def load_model_json(path, *, material=None, length_unit: str | None = None, integration: str | None = None,
                    material_replaces: bool = False) -> "Structure":
    """The Structure described by a model JSON (mesh, material, length unit; see the module docstring).

    An argument the JSON also holds is refused ("given both"), except the material with ``material_replaces``
    (a mesh loaded with its own material while a model JSON beside it names it: the JSON's length unit,
    integration and name still hold, and the provenance says whose material was used)."""
    path = Path(path)
    try:
        spec = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(path, f"cannot be read ({exc.__class__.__name__}: {exc})", "a readable JSON file") from None
    except ValueError as exc:
        raise ModelFileError(path, f"is not valid JSON ({exc})", JSON_ALLOWED) from None
    except RecursionError:                    # json's recursive reader: arrays or objects nested ~1000 deep
        raise ModelFileError(path, "nests JSON arrays or objects too deeply to read",
                             f"a model JSON (nested at most {JSON_DEPTH} levels): {JSON_ALLOWED}") from None
    if not isinstance(spec, dict):
        raise ModelFileError(path, "is not a JSON object", JSON_ALLOWED)
    unknown = sorted(set(spec) - set(JSON_KEYS))
    if unknown:
        hint = " (a beam scene JSON is loaded as beam:<path>)" if "points" in spec else ""
        raise ModelFileError(path, f"unknown key{hint}", JSON_ALLOWED, entity=unknown[0])
    if not isinstance(spec.get("mesh"), str) or not spec["mesh"].strip():
        raise ModelFileError(path, f"missing or not a path: {shown(spec.get('mesh'))}", JSON_ALLOWED, entity="mesh")
    for key, given in (("material", material), ("length_unit", length_unit), ("integration", integration)):
        if key in spec and given is not None and not (key == "material" and material_replaces):
            raise ParameterError(key, f"given both as an argument and in {shown(str(path))}", "one of the two")
    if "material" not in spec and material is None:
        raise ModelFileError(path, "missing (and no material argument)", JSON_ALLOWED, entity="material")
    notes = [f"model JSON {path}"]
    if material is not None and "material" in spec:
        notes.append(f"material given as an argument, replacing {path.name}'s")
    mat = check_material(material) if material is not None else check_material(spec["material"], "material", path)
    unit = length_unit
    if "length_unit" in spec:
        if not isinstance(spec["length_unit"], str) or spec["length_unit"].strip() not in UNITS_ALLOWED.split(" | "):
            raise ModelFileError(path, f"{spec['length_unit']!r} is not a known length unit", UNITS_ALLOWED,
                                 entity="length_unit")
        unit = spec["length_unit"].strip()
    if "integration" in spec and spec["integration"] not in ("full", "reduced"):
        raise ModelFileError(path, f"{spec['integration']!r}", "full | reduced", entity="integration")
    integration = spec.get("integration", integration or "full")
    mesh_path = path.parent / spec["mesh"]
    if not mesh_path.is_file():
        raise ModelFileError(path, f"no such mesh file: {shown(str(mesh_path))}", "an existing mesh file", entity="mesh")
    name = spec.get("name") if isinstance(spec.get("name"), str) else path.stem
    return read_mesh_file(mesh_path, material=mat, length_unit=unit, name=name, integration=integration,
                          provenance_notes=tuple(notes))
