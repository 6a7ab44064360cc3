"""Model specifications shared by the CLI and the ReframeBody FMU: a string names a conventional model.

    paper_plate          the reframe paper's plate (:func:`flexfmu.reframe.plate.paper_plate`)
    beam:<scene>         a built-in scene name or a scene JSON path, as a free-free bent rod
                         (:func:`flexfmu.ffr.assembly.build_beam_model` with boundary "free")
    <path>.npz           a structural model file (:func:`flexfmu.core.io.load_structure`)

and the model's default load and output points (node indices):

=============  =====================================  ===================
model          default load point                     default output point
=============  =====================================  ===================
paper_plate    the paper's, midway between P5 and P8  P1
beam, .npz     the last node                          the first node
=============  =====================================  ===================
"""
from __future__ import annotations

import json

import numpy as np

from flexfmu.core.checks import path_exists_as, shown
from flexfmu.errors import ParameterError
from flexfmu.core.structure import Structure

MODEL_ALLOWED = "paper_plate | beam:<scene> | path to a .npz"
BEAM_PREFIX = "beam:"
DEFAULT_ELEMENTS_PER_SEGMENT = 8

# Options each kind of model accepts (keyword arguments of load_model).
_OPTIONS = {
    "paper_plate": ("divisions", "corner_mass"),
    "beam": ("elements_per_segment", "rotary_inertia"),
    "npz": (),
}


def _check_options(kind: str, options: dict) -> None:
    allowed = _OPTIONS[kind]
    for key in options:
        if key not in allowed:
            raise ParameterError(key, f"not an option of a {kind} model",
                                 ", ".join(allowed) if allowed else "no options")


def load_model(spec: str, **options) -> Structure:
    """The conventional structural model named by ``spec`` (see the module docstring).

    options:  paper_plate: ``divisions`` (nx, ny, nz), ``corner_mass`` (kg);
              beam:<scene>: ``elements_per_segment`` (default 8), ``rotary_inertia`` (default False);
              .npz: none.

    ``meta["model"]`` of the returned structure is ``spec``; ``meta["kind"]`` is "paper_plate",
    "beam" or "npz".  Raises :class:`ParameterError` naming ``model`` for an unknown spec, a
    scene or file that does not exist, or the offending option / file key.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise ParameterError("model", f"{shown(spec)}", MODEL_ALLOWED)
    spec = spec.strip()
    if spec == "paper_plate":
        _check_options("paper_plate", options)
        structure = _cached_paper_plate(**options)
        kind = "paper_plate"
    elif spec.startswith(BEAM_PREFIX):
        from flexfmu.ffr.assembly import build_beam_model
        from flexfmu.ffr.scene import builtin_scene_names, load_scene

        _check_options("beam", options)
        name = spec[len(BEAM_PREFIX):].strip()
        scenes = builtin_scene_names()
        if name not in scenes and path_exists_as(name) != "file":
            what = ("a directory" if path_exists_as(name) == "directory"
                    else "neither a built-in scene nor an existing file")
            raise ParameterError("model", f"{shown(spec)}: scene {shown(name)} is {what}",
                                 "beam:<" + " | ".join(scenes) + " | path to a scene JSON>")
        n = options.get("elements_per_segment", DEFAULT_ELEMENTS_PER_SEGMENT)
        structure = build_beam_model(load_scene(name, parameter="model"), "free", n,
                                     rotary_inertia=bool(options.get("rotary_inertia", False))).structure()
        kind = "beam"
    elif spec.lower().endswith(".npz"):
        from flexfmu.core.io import load_structure

        _check_options("npz", options)
        kind = path_exists_as(spec)
        if kind != "file":
            raise ParameterError("model", f"{shown(spec)} is a directory, not a .npz file" if kind == "directory"
                                 else f"no such file: {shown(spec)}", MODEL_ALLOWED)
        try:
            structure = load_structure(spec)
        except ParameterError as exc:
            if exc.parameter != "path":
                raise
            raise ParameterError("model", str(exc).split(": ", 1)[-1], MODEL_ALLOWED) from None
        kind = "npz"
    else:
        raise ParameterError("model", f"{shown(spec)} is not a known model", MODEL_ALLOWED)
    structure.meta = dict(structure.meta or {})
    structure.meta.update(model=spec, kind=kind)
    return structure


def _cached_paper_plate(**options) -> Structure:
    """:func:`flexfmu.reframe.plate.paper_plate` through the on-disk cache (:mod:`flexfmu.core.cache`): the mesh and
    the assembly of the default plate take seconds, reading them back a fraction of that.  Keyed by the
    checked divisions and corner mass, the source of flexfmu.reframe.plate and the scikit-fem version."""
    from importlib.metadata import version

    import scipy.sparse as sp

    from flexfmu.core import cache

    from flexfmu.reframe import plate

    divisions = plate._check_divisions(options.get("divisions", plate.DEFAULT_DIVISIONS))
    corner_mass = plate._check_corner_mass(options.get("corner_mass", plate.CORNER_MASS))
    key = cache.make_key("paper_plate", divisions=divisions, corner_mass=corner_mass,
                         code=cache.file_digest(plate.__file__), skfem=version("scikit-fem"))
    hit = cache.load("paper_plate", key)
    if hit is not None:
        try:
            n_dof = hit["nodes"].shape[0] * 3
            M, K = (sp.csr_matrix((hit[f"{m}_data"], hit[f"{m}_indices"], hit[f"{m}_indptr"]), shape=(n_dof, n_dof))
                    for m in "MK")
            return Structure(nodes=hit["nodes"], dofs_per_node=3, M=M, K=K, name=str(hit["name"]),
                             meta=cache.meta_from_json(str(hit["meta"])),
                             points={str(k): int(v) for k, v in json.loads(str(hit["points"])).items()})
        except (KeyError, ValueError, TypeError):
            pass                                   # an entry of another layout: assemble again
    structure = plate.paper_plate(divisions, corner_mass=corner_mass)
    cache.store("paper_plate", key, {"nodes": structure.nodes, "name": np.array(structure.name),
                                     "meta": np.array(cache.meta_to_json(structure.meta)),
                                     "points": np.array(json.dumps(structure.points)),
                                     **{f"{m}_{part}": getattr(A, part) for m, A in (("M", structure.M), ("K", structure.K))
                                        for part in ("data", "indices", "indptr")}})
    return structure


def _named_point(structure: Structure, name: str):
    pts = getattr(structure, "points", None)
    if isinstance(pts, dict) and name in pts:
        return int(pts[name])
    return None


def default_load_point(structure: Structure) -> int:
    """Node index of the default load point: the paper's load point on the plate (``points["load"]``),
    else the last node (the free end of a bent rod)."""
    i = _named_point(structure, "load")
    return i if i is not None else int(np.asarray(structure.nodes).shape[0] - 1)


def default_output_point(structure: Structure) -> int:
    """Node index of the default output point: P1 on the plate (``points["P1"]``), else the first node."""
    i = _named_point(structure, "P1")
    return i if i is not None else 0
