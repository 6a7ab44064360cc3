"""The import structure of the package model/flexfmu: no import cycles, and no import that climbs the layers.

Every module under model/flexfmu is parsed with ``ast`` (nothing is imported).  Every ``import flexfmu.x`` and
``from flexfmu.x import y`` counts, at module level and inside functions alike (a lazy import hides a dependency
from the import-time order, not from the structure); relative imports are resolved, and ``from pkg import name``
counts as importing the submodule ``pkg.name`` when there is one, else ``pkg``.  Importing a submodule does not
count as importing its parent packages' ``__init__`` (Python runs them, but they are not what the code asks for).

1. No cycle: module A imports B, ..., and back to A is refused; each cycle is reported as a chain with the line of
   each import.
2. The layers, LAYERS below, bottom first: a module may import only its own subpackage and layers below.  Two
   subpackages in one layer are independent: neither imports the other.

Not seen, on purpose (plug-in points: modules named as text and imported by name at run time, so that a lower
layer can name what is built on it without depending on it):

- flexfmu/__init__.py ``_LAZY`` and flexfmu/body/__init__.py ``_WHERE``: the flat public API, each name imported
  on first use (``import flexfmu`` loads only the errors).
- flexfmu.fmi.registry: the one list of FMUs names each FMU's simulator module as text, the wave converter's
  (flexfmu.wec, above fmi) included; the build, the plumbing and flexfmu.cosim.masters' LibrarySlave import it
  through ``FmuSpec.load``.  A new FMU is a new entry, not a new import.
- flexfmu.cli's ``flexfmu bench`` studies and flexfmu.studies.common.optional (optional packages).
No layer climb that ``ast`` sees is excused.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

pytestmark = pytest.mark.unit

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIR = ROOT / "model" / "flexfmu"
PACKAGE = "flexfmu"

#: The layers of the package, bottom first: a module may import only its own subpackage and layers below.  A unit is
#: a subpackage (``ffr`` = flexfmu.ffr.*) or a top-level module (``errors``, ``cli``, ``__main__``; ``flexfmu`` is the
#: package's own __init__).  docs/architecture.md, "Layers", shows the same order.
LAYERS = [
    # the one error hierarchy: imports nothing of flexfmu
    ("errors",),
    # flexfmu/__init__.py: __version__ and the flat public API, whose names are imported on first use (_LAZY);
    # what it imports itself is the errors only, so every layer may read __version__ from it
    ("flexfmu",),
    # what every side shares: Structure, the .npz and on-disk caches, checks, rotations, BLAS threads
    ("core",),
    # eigenproblems of core's matrices: Modes, ModalBasis, the dense/sparse cut-offs
    ("linalg",),
    # sizing: how large a model must be (mesh, modes, static correction), from estimates and eigen-solves of the
    #   models the caller hands over (flexfmu.ffr.mesh_choice gives it the FFR beam's meshes): below the models it
    #   sizes, ffr, reframe and body.
    # native: the compiled per-step kernels and their ctypes bindings, which ffr, reframe and body call; each of
    #   those describes its own maps to it (flexfmu.ffr.lti_probe, flexfmu.body.lti_probe), so native imports none.
    # fatigue: rainflow counting, S-N curves and Miner damage of stress histories (arrays or result CSVs); it needs
    #   nothing of the models, so the layers above may assess what they compute.
    # The three are independent of each other.
    ("sizing", "native", "fatigue"),
    # the FFR discontinuous beam: scene, mesh, assembly, dynamics, FFRBeam's simulator (sized by sizing)
    ("ffr",),
    # the reframe integrator; its model specs include ``beam:<scene>``, a Structure from ffr's assembly
    ("reframe",),
    # importers: model files -> Structure (the specs through reframe.models).  body: any Structure -> FlexBody (the
    # reframe kernels, sizing.interfaces).  Siblings: a body is built from a Structure, wherever it came from; the
    # callers join the two (flexfmu.cli, flexfmu.wec.barge, examples/).
    ("importers", "body"),
    # viz: the deformed body as pictures (VTK series, animations) from a shape file or a model's mode shapes; it
    #   reads body's shape file and stress, knows nothing of FMI (the command line opens the FMUs and result CSVs)
    ("viz",),
    # the only place that knows FMI: wraps the simulators of ffr, reframe, body (registry, plumbing, build, export)
    ("fmi",),
    # co-simulation masters over the registry's FMUs or their simulators, OSP and SSP system files
    ("cosim",),
    # the wave-energy converter: its components' simulators and the system studies run through cosim
    ("wec",),
    # the benchmark studies (flexfmu bench) and the generator of their reference data
    ("studies", "data"),
    # the command line, a shell over the library, and ``python -m flexfmu``
    ("cli",),
    ("__main__",),
]


# ---------------------------------------------------------------------------------------------- the graph
def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package's __init__)."""
    out = {}
    for path in sorted(PACKAGE_DIR.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        parts = list(path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts.pop()
        out[".".join(parts)] = (path, is_package)
    return out


MODULES = _modules()


def _imported(module: str, is_package: bool, node: ast.AST) -> list[str]:
    """The flexfmu modules one import statement of ``module`` asks for (names, not yet checked to exist)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names if alias.name.split(".")[0] == PACKAGE]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:                                   # relative: from the module's package, up level - 1
        base = module.split(".") if is_package else module.split(".")[:-1]
        if node.level - 1 >= len(base):
            raise AssertionError(f"{module} line {node.lineno}: relative import beyond the package")
        base = base[:len(base) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    if target.split(".")[0] != PACKAGE:
        return []
    # ``from pkg import name``: the submodule pkg.name when there is one, else pkg itself
    return [f"{target}.{alias.name}" if f"{target}.{alias.name}" in MODULES else target for alias in node.names]


def imports_of(module: str, is_package: bool, source: str) -> list[tuple[str, int]]:
    """(flexfmu module, line) of every import in ``source``, the source of ``module``: anywhere in it, functions,
    classes and ``if``/``try`` blocks included."""
    return [(target, node.lineno) for node in ast.walk(ast.parse(source))
            for target in _imported(module, is_package, node)]


def import_graph() -> tuple[dict[str, dict[str, int]], list[str]]:
    """({module: {imported module: line of its first import}}, [imports that name no module of the package])."""
    graph: dict[str, dict[str, int]] = {name: {} for name in MODULES}
    unknown = []
    for module, (path, is_package) in MODULES.items():
        for target, line in imports_of(module, is_package, path.read_text(encoding="utf-8")):
            if target not in MODULES:
                unknown.append(f"{module} line {line}: {target}")
            elif target != module:                     # the first import's line (ast.walk is not in line order)
                graph[module][target] = min(graph[module].get(target, line), line)
    return graph, unknown


def strongly_connected(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.append(w)
                        if w == v:
                            break
                    if len(component) > 1:
                        out.append(sorted(component))
    return out


def cycles_in(component: list[str], graph: dict[str, dict[str, int]], limit: int = 20) -> list[list[str]]:
    """Elementary cycles within one component, each from its smallest module (at most ``limit``)."""
    members = set(component)
    found = []
    for start in sorted(component):
        def walk(path):
            for w in sorted(graph[path[-1]]):
                if len(found) >= limit:
                    return
                if w == start:
                    found.append(path + [start])
                elif w in members and w > start and w not in path:
                    walk(path + [w])
        walk([start])
    return found


def chain(cycle: list[str], graph: dict[str, dict[str, int]]) -> str:
    """"a --(line 12)--> b --(line 40)--> a": each arrow with the line of the import in the module before it."""
    text = cycle[0]
    for a, b in zip(cycle, cycle[1:]):
        text += f" --(line {graph[a][b]})--> {b}"
    return text


def unit_of(module: str) -> str:
    """The layer unit of a module: its subpackage (flexfmu.ffr.scene -> ffr), or the top-level module's name."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


LAYER_OF = {unit: k for k, layer in enumerate(LAYERS, start=1) for unit in layer}       # 1: the bottom layer


def layers_text() -> str:
    """LAYERS as one line, bottom first: "errors < flexfmu < core < ... < sizing, native < ..."."""
    return " < ".join(", ".join(layer) for layer in LAYERS)


# ---------------------------------------------------------------------------------------------- the tests
def test_the_parser_sees_every_form_of_import():
    source = """
import numpy
import flexfmu.ffr.scene
import flexfmu.ffr.mesh as mesh
from flexfmu.ffr import assembly, BOUNDARY_NAME_THAT_IS_NO_MODULE
from flexfmu.ffr.simulator import FFRBeamSimulator
from . import ssp
from .system import System
from .. import errors
from ..core.structure import Structure


def lazy():
    from flexfmu import __version__
    if True:
        import flexfmu.wec.system
"""
    found = {target for target, _ in imports_of("flexfmu.cosim.masters", False, source)}
    assert found == {"flexfmu.ffr.scene", "flexfmu.ffr.mesh", "flexfmu.ffr.assembly", "flexfmu.ffr",
                     "flexfmu.ffr.simulator", "flexfmu.cosim.ssp", "flexfmu.cosim.system", "flexfmu.errors",
                     "flexfmu.core.structure", "flexfmu", "flexfmu.wec.system"}, found
    # in a package's __init__, "." is the package itself
    assert imports_of("flexfmu.cosim", True, "from . import ssp\nfrom .masters import run") == [
        ("flexfmu.cosim.ssp", 1), ("flexfmu.cosim.masters", 2)]


def test_every_flexfmu_import_names_a_module_of_the_package():
    _, unknown = import_graph()
    if unknown:
        pytest.fail("imports of flexfmu modules that do not exist:\n  " + "\n  ".join(unknown), pytrace=False)


def test_no_import_cycles():
    graph, _ = import_graph()
    failures = []
    for component in strongly_connected(graph):
        failures += [chain(cycle, graph) for cycle in cycles_in(component, graph)]
    if failures:
        pytest.fail(f"{len(failures)} import cycle(s) in model/flexfmu (each arrow: the line of the import in the "
                    "module before it; imports inside functions count too).  Break each by moving what both sides "
                    "need into a module both import, or by passing it in:\n  " + "\n  ".join(failures),
                    pytrace=False)


def test_every_module_is_in_a_layer():
    units = sorted({unit_of(m) for m in MODULES})
    missing = [u for u in units if u not in LAYER_OF]
    assert not missing, (f"{', '.join(missing)}: in no layer of LAYERS in tests/test_import_structure.py; place each "
                         "where its imports allow (and say so in docs/architecture.md, \"Layers\")")
    listed = [u for layer in LAYERS for u in layer]
    assert len(listed) == len(set(listed)), "a unit is in two layers"
    stale = sorted(set(listed) - set(units))
    assert not stale, f"LAYERS names units that do not exist: {stale}"


def test_imports_do_not_climb_the_layers():
    graph, _ = import_graph()
    failures = []
    for module in sorted(graph):
        unit = unit_of(module)
        for target, line in sorted(graph[module].items()):
            other = unit_of(target)
            if other == unit or LAYER_OF[other] < LAYER_OF[unit]:
                continue
            below = ", ".join(u for layer in LAYERS[:LAYER_OF[unit] - 1] for u in layer) or "nothing"
            where = "in the same layer" if LAYER_OF[other] == LAYER_OF[unit] else f"layer {LAYER_OF[other]}"
            failures.append(f"{module} (line {line}) imports {target}: {unit} is layer {LAYER_OF[unit]} and may "
                            f"import only {unit} and the layers below ({below}); {other} is {where}")
    if failures:
        pytest.fail(f"{len(failures)} import(s) climb the layers ({layers_text()}; a module may import only its own "
                    "subpackage and layers below).  Move the code to the layer that needs it, or have the caller "
                    "pass it in:\n  " + "\n  ".join(failures), pytrace=False)


def test_architecture_page_shows_the_layers():
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert layers_text() in text, f"docs/architecture.md, \"Layers\", should show LAYERS' order: {layers_text()}"
