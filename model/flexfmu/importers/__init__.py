"""Model files -> :class:`~flexfmu.core.structure.Structure`: one entry point, :func:`load_structure`.

==========================================  =================================================  ==================
source                                      read by                                            module
==========================================  =================================================  ==================
``paper_plate``, ``beam:<scene>``, ``.npz``  flexfmu.reframe.models.load_model                  (existing specs)
model JSON ``.json`` (mesh + material)      meshio + scikit-fem                                solid
mesh ``.msh .inp .vtu .vtk .med .xdmf ...``  meshio + scikit-fem (material given)               solid
Nastran ``.bdf .nas``                       pyNastran + scikit-fem (MAT1 from the deck)        nastran
MAPDL ``.full`` (+ ``.cdb`` or ``.rst``)    ansys-mapdl-reader (M and K as MAPDL wrote them)   ansys
==========================================  =================================================  ==================

Assembly (solid, nastran): :mod:`~flexfmu.importers.assembly` on the cell types of
:mod:`~flexfmu.importers.elements`; units: :mod:`~flexfmu.importers.units`.  Every problem is a
:class:`~flexfmu.errors.ParameterError`, for a file a :class:`~flexfmu.errors.ModelFileError` naming the file
and the card, element, node, set or key.
"""
from __future__ import annotations

from pathlib import Path

from flexfmu.core.checks import path_exists_as, shown
from flexfmu.core.structure import Provenance, node_set  # noqa: F401  (node_set: importable from here too)
from flexfmu.errors import ParameterError

NASTRAN_SUFFIXES = (".bdf", ".nas")
ANSYS_SUFFIXES = (".full",)
SOURCES_ALLOWED = ("paper_plate | beam:<scene> | .npz | model .json | mesh (.msh, .inp, .vtu, ...) | "
                   "Nastran .bdf/.nas | MAPDL .full")


def _reject(options: dict, kind: str, allowed=()) -> None:
    for key, value in options.items():
        if value is not None and key not in allowed:
            raise ParameterError(key, f"not an option of a {kind} source",
                                 ", ".join(allowed) if allowed else "no options")


def load_structure(source, *, material=None, length_unit: str | None = None, coordinates=None,
                   integration: str | None = None, name: str | None = None, **model_options):
    """The Structure of ``source``: a model spec or a model file (table in the module docstring).

    material:     mesh files: {"E": Pa, "nu": -, "rho": kg/m^3} (or a model JSON beside the mesh).
    length_unit:  mesh files: the unit of the coordinates; Nastran and MAPDL: the file's consistent unit
                  system ("m", "cm", "mm", "in"; :mod:`flexfmu.importers.units`).  Default "m".
    coordinates:  MAPDL .full: the archive (.cdb) or result file (.rst) with the node coordinates
                  (default: ``<stem>.cdb`` or ``<stem>.rst`` beside the .full).
    integration:  meshes and Nastran: "full" (default) or "reduced" (quadratic hexahedra's stiffness 2x2x2).
    name:         the Structure's name (default: the file's stem).
    model_options: options of the existing specs (``divisions``, ``elements_per_segment``, ...).
    """
    from flexfmu.reframe.models import BEAM_PREFIX

    if not isinstance(source, (str, Path)) or not str(source).strip():
        raise ParameterError("source", f"{shown(source)}", SOURCES_ALLOWED)
    text = str(source).strip()
    options = {"material": material, "length_unit": length_unit, "coordinates": coordinates,
               "integration": integration}
    if text == "paper_plate" or text.startswith(BEAM_PREFIX) or text.lower().endswith(".npz"):
        from flexfmu.reframe.models import load_model

        _reject({**options, "name": name}, "paper_plate / beam / .npz")
        structure = load_model(text, **model_options)
        if structure.provenance == Provenance():
            structure.provenance = Provenance(source=text, format=structure.meta.get("kind", ""), reader="flexfmu")
        return structure
    if model_options:
        raise ParameterError(next(iter(model_options)), "not an option of a model file", "material, length_unit, "
                             "coordinates, integration, name")
    path = Path(text)
    kind = path_exists_as(path)
    if kind != "file":
        raise ParameterError("source", f"{shown(text)} is a directory" if kind == "directory" else
                             f"no such file or model: {shown(text)}", SOURCES_ALLOWED)
    suffix = path.suffix.lower()
    if suffix == ".json":
        from flexfmu.importers.solid import load_model_json

        _reject({**options, "name": name}, "model JSON", ("material", "length_unit", "integration"))
        return load_model_json(path, material=material, length_unit=length_unit, integration=integration)
    if suffix in NASTRAN_SUFFIXES:
        from flexfmu.importers.nastran import load_nastran

        _reject(options, "Nastran", ("length_unit", "integration"))
        return load_nastran(path, length_unit=length_unit, name=name, integration=integration or "full")
    if suffix in ANSYS_SUFFIXES:
        from flexfmu.importers.ansys import load_ansys_full

        _reject(options, "MAPDL .full", ("length_unit", "coordinates"))
        return load_ansys_full(path, coordinates=coordinates, length_unit=length_unit, name=name)
    from flexfmu.importers.solid import load_mesh, mesh_extensions

    if suffix not in mesh_extensions():
        raise ParameterError("source", f"{shown(text)}: unknown file type {suffix or '(no extension)'}",
                             SOURCES_ALLOWED)
    _reject(options, "mesh", ("material", "length_unit", "integration"))
    return load_mesh(path, material=material, length_unit=length_unit, name=name, integration=integration)
