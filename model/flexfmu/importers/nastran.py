"""Nastran bulk data (``.bdf``, ``.nas``) read with pyNastran and assembled like any solid mesh.

Cards used: GRID (with CP coordinate systems), CTETRA (4 or 10 nodes), CHEXA (8 or 20 nodes), PSOLID -> MAT1
(E, NU, RHO) per element, SPC / SPC1 / SPCADD and GRID's PS field -> ``constrained_dofs`` (components 1-3;
4-6 do not exist on solid nodes).  The SPC set is the one the case control selects (``SPC = n``); a deck
without case control constrains every set it defines.  Each set's nodes are also the node set ``SPC_<id>``.
Structure's nodes are the GRIDs the elements use, sorted by id (``meta["node_ids"]``).

Material numbers are in the deck's consistent unit system, ``length_unit`` (:mod:`flexfmu.importers.units`;
default SI).  Any other element, mass or rigid card is refused rather than silently left out.
"""
from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from flexfmu.errors import ModelFileError
from flexfmu.importers.assembly import CellBlock
from flexfmu.importers.build import ReadMesh, structure_from_mesh, versions
from flexfmu.importers.units import UNIT_DESCRIPTIONS, Material, check_length_unit, check_material

INSTALL = "pip install --no-deps pyNastran==1.4.1 cpylog docopt-ng colorama"
#: (card, number of nodes) -> (meshio cell type, Nastran node order -> meshio (VTK) node order)
CARDS = {
    ("CTETRA", 4): ("tetra", list(range(4))),
    ("CTETRA", 10): ("tetra10", list(range(10))),                 # G5..G10 on edges 12 23 31 14 24 34, as VTK
    ("CHEXA", 8): ("hexahedron", list(range(8))),
    # Nastran: G9-G12 bottom edges, G13-G16 corner-to-corner (vertical) edges, G17-G20 top edges;
    # VTK: bottom, top, vertical.
    ("CHEXA", 20): ("hexahedron20", list(range(12)) + list(range(16, 20)) + list(range(12, 16))),
}
SUPPORTED_CARDS = "CTETRA (4 or 10 nodes), CHEXA (8 or 20 nodes) with PSOLID and MAT1"


def _bdf_class():
    import numpy as np_

    # pyNastran 1.4.1 calls np.in1d, which numpy 2.4 removed; np.isin is its documented replacement.
    if not hasattr(np_, "in1d"):
        np_.in1d = np_.isin
    try:
        from pyNastran.bdf.bdf import BDF
    except ImportError as exc:
        raise ModelFileError("pyNastran", f"is not installed ({exc})", INSTALL) from None
    return BDF


def read_deck(path: Path):
    """The pyNastran model of ``path``, not cross-referenced; ModelFileError with pyNastran's complaint."""
    BDF = _bdf_class()
    try:
        text = path.read_text(errors="replace")
    except OSError as exc:
        raise ModelFileError(path, f"cannot be read ({exc})", "a readable Nastran bulk data file") from None
    from cpylog import SimpleLogger

    model = BDF(log=SimpleLogger(level="critical"))     # problems reach the user as ModelFileError
    source, punch = str(path), True
    begin_bulk = re.search(r"(?im)^\s*BEGIN\s+BULK.*$", text)
    if begin_bulk and re.search(r"(?im)^\s*CEND\b", text):
        punch = False                                    # a whole deck: executive, case control, bulk
    elif begin_bulk:
        source = io.StringIO(text[begin_bulk.end():])    # bulk data after BEGIN BULK alone
    try:
        model.read_bdf(source, xref=False, punch=punch)
    except Exception as exc:                # pyNastran raises RuntimeError, SyntaxError, KeyError, ... on bad cards
        raise ModelFileError(path, f"cannot be read by pyNastran ({type(exc).__name__}: {str(exc).strip()[:300]})",
                             "a Nastran bulk data deck") from None
    return model


def _refuse_unsupported(path: Path, model) -> None:
    for eid, element in sorted(model.elements.items()):
        if (element.type, len(element.node_ids)) not in CARDS:
            raise ModelFileError(path, f"{element.type} with {len(element.node_ids)} nodes is not supported",
                                 SUPPORTED_CARDS, entity=f"{element.type} {eid}")
    for group in ("masses", "rigid_elements"):
        for eid, card in sorted(getattr(model, group).items()):
            raise ModelFileError(path, f"{card.type} is not supported (flexfmu assembles solid elements only)",
                                 SUPPORTED_CARDS, entity=f"{card.type} {eid}")


def _material(path: Path, model, element, unit: str, cache: dict) -> Material:
    pid = element.pid
    if pid not in cache:
        prop = model.properties.get(pid)
        if prop is None or prop.type != "PSOLID":
            what = "missing" if prop is None else f"a {prop.type}"
            raise ModelFileError(path, f"property {pid} is {what}", "a PSOLID naming a MAT1",
                                 entity=f"{element.type} {element.eid}")
        mat = model.materials.get(prop.mid)
        if mat is None or mat.type != "MAT1":
            what = "missing" if mat is None else f"a {mat.type}"
            raise ModelFileError(path, f"material {prop.mid} is {what}", "MAT1 with E, NU and RHO",
                                 entity=f"PSOLID {pid}")
        values = {"E": mat.e, "nu": mat.nu, "rho": mat.rho}
        missing = [k for k, v in values.items() if v is None or (k != "nu" and v == 0.0)]
        if missing:
            raise ModelFileError(path, f"{missing[0]} is missing or zero", "MAT1 with E > 0, NU, RHO > 0",
                                 entity=f"MAT1 {prop.mid}")
        cache[pid] = check_material(values, f"MAT1 {prop.mid}", path, unit_system=unit,
                                    unit_hint=f"the deck read in {UNIT_DESCRIPTIONS[unit]}: is it in mm-t-s or "
                                    "in-lbf-s? give its length unit" if unit == "m" else "")
    return cache[pid]


def _spc_components(path: Path, model, grid_ids: np.ndarray, notes: list) -> tuple[list, dict]:
    """[(grid id, component 0-2)], {"SPC_<id>": grid ids} of the active SPC sets (module docstring)."""
    set_ids = sorted(set(model.spcs) | set(model.spcadds))
    active = set_ids
    cc = model.case_control_deck
    if cc is not None:
        chosen = {int(sub.get_parameter("SPC")[0]) for sub in cc.subcases.values() if sub.has_parameter("SPC")}
        if chosen:
            unknown = sorted(chosen - set(set_ids))
            if unknown:
                raise ModelFileError(path, f"case control selects SPC set {unknown[0]}, which the deck does not define",
                                     "SPC set ids: " + (", ".join(map(str, set_ids)) or "none"), entity="SPC")
            active = sorted(chosen)
    fixed, sets, rotations = [], {}, 0
    for sid in set_ids:
        members = set()
        for card in model.get_reduced_spcs(sid, consider_spcadd=True, stop_on_failure=False):
            if card.type not in ("SPC", "SPC1"):
                raise ModelFileError(path, f"{card.type} is not supported", "SPC, SPC1, SPCADD", entity=f"{card.type} {sid}")
            comps = card.components if card.type == "SPC" else [card.components] * len(card.node_ids)
            if card.type == "SPC" and any(v not in (None, 0.0) for v in card.enforced):
                notes.append(f"SPC {sid}: enforced displacements ignored (constrained DOFs are fixed at zero)")
            for nid, comp in zip(card.node_ids, comps):
                members.add(int(nid))
                for c in str(comp):
                    if c in "123" and sid in active:
                        fixed.append((int(nid), int(c) - 1))
                    rotations += c in "456"
        sets[f"SPC_{sid}"] = np.array(sorted(members), dtype=np.int64)
    for nid in grid_ids:
        for c in str(model.nodes[int(nid)].ps or ""):
            if c in "123":
                fixed.append((int(nid), int(c) - 1))
    if rotations:
        notes.append(f"{rotations} SPC component(s) 4-6 ignored: solid nodes have no rotations")
    if len(active) > 1 and cc is None:
        notes.append("no case control: SPC sets " + ", ".join(map(str, active)) + " all applied")
    return fixed, sets


def load_nastran(path, *, length_unit: str | None = None, name: str | None = None, integration: str = "full"):
    """The Structure of a Nastran bulk data deck (see the module docstring)."""
    path = Path(path)
    unit = "m" if length_unit is None else check_length_unit(length_unit)
    model = read_deck(path)
    if not model.elements:
        raise ModelFileError(path, "no elements", SUPPORTED_CARDS, entity="CTETRA/CHEXA")
    _refuse_unsupported(path, model)
    grid_ids = np.array(sorted(model.nodes), dtype=np.int64)
    for eid, element in sorted(model.elements.items()):
        absent = [n for n in element.node_ids if n is None or int(n) not in model.nodes]
        if absent:
            raise ModelFileError(path, f"node {absent[0]} is " + ("blank (partial mid-side nodes)" if absent[0] is None
                                                                  else "not defined by a GRID card"),
                                 "GRID ids of all the element's nodes", entity=f"{element.type} {eid}")
    groups: dict = {}
    materials: dict = {}
    for eid, element in sorted(model.elements.items()):
        cell_type, order = CARDS[(element.type, len(element.node_ids))]
        material = _material(path, model, element, unit, materials)
        rows = groups.setdefault((cell_type, material), ([], []))
        rows[0].append(np.searchsorted(grid_ids, np.asarray(element.node_ids, dtype=np.int64))[order])
        rows[1].append(eid)
    blocks = [CellBlock(t, np.array(cells, dtype=np.int64), m, np.array(ids)) for (t, m), (cells, ids) in groups.items()]
    try:
        model.cross_reference()
        points = np.array([model.nodes[int(n)].get_position() for n in grid_ids], dtype=float).reshape(-1, 3)
    except Exception as exc:             # undefined coordinate systems, ...
        raise ModelFileError(path, f"cannot be cross-referenced by pyNastran ({type(exc).__name__}: "
                             f"{str(exc).strip()[:300]})", "GRID, CORD, PSOLID, MAT1 cards that refer to each other") from None

    notes: list = []
    fixed, sets = _spc_components(path, model, grid_ids, notes)
    for nid, _ in fixed:
        if model.nodes[nid].cd not in (0, None):
            raise ModelFileError(path, f"constrained in displacement coordinate system {model.nodes[nid].cd}",
                                 "SPCs on nodes with CD = 0 (basic)", entity=f"GRID {nid}")
    fixed_idx = np.array([(np.searchsorted(grid_ids, nid), c) for nid, c in fixed], dtype=np.int64).reshape(-1, 2)
    node_sets = {k: np.searchsorted(grid_ids, v[np.isin(v, grid_ids)]) for k, v in sets.items()}
    read = ReadMesh(points=points, blocks=blocks, node_sets=node_sets, fixed=fixed_idx, point_ids=grid_ids, notes=notes)
    units = (f"deck in {UNIT_DESCRIPTIONS[unit]}" + ("" if unit == "m" else ", converted to SI"))
    return structure_from_mesh(path, read, length_unit=unit, name=name or path.stem, file_format="nastran",
                               unit_assumed=length_unit is None,
                               reader=versions("pyNastran", "scikit-fem"), units_text=units, integration=integration)
