"""The independent reference trajectories the studies compare with.

Each lives in flexfmu/data/references/<name>/ with the generator that wrote it and a README giving its
provenance (software, model, convergence).  They ship with the package, so that ``flexfmu bench`` runs from an
installed flexfmu as well as from a source checkout; the tests read the same files, there is no second copy.

    spinup        Kane, Ryan & Banerjee (1987) spin-up, Exudyn geometrically exact ANCF cable (trajectory.csv)
    exudyn_plate  the paper's plate load case, Exudyn reduced-order FFRF (trajectory.csv)
"""
from __future__ import annotations

import importlib.util
from importlib import resources
from pathlib import Path

from flexfmu.errors import require

#: The references shipped with the package (folders of flexfmu/data/references/).
NAMES = ("spinup", "exudyn_plate")


def reference_dir(name: str) -> Path:
    """The folder of reference ``name`` (trajectory, generate.py, README.md)."""
    require(name in NAMES, "name", repr(name), ", ".join(NAMES))
    # a real directory: generate.py is loaded from it as a module, and the studies read the CSV by path
    return Path(str(resources.files("flexfmu") / "data" / "references" / name))


def reference_path(name: str, filename: str = "trajectory.csv") -> Path:
    """A file of reference ``name`` (default: its trajectory)."""
    return reference_dir(name) / filename


def load_generator(name: str):
    """The generator of reference ``name`` (its generate.py) as a module: its model constants and the
    functions that rebuild the reference's model in the other code (they import that code, e.g. Exudyn,
    only when called)."""
    path = reference_path(name, "generate.py")
    spec = importlib.util.spec_from_file_location(f"flexfmu_reference_{name}_generate", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
