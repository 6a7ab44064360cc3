"""The FMUs the reliability report probes: every FMU kind in both runtimes.

- the Python FMUs of ``--dist`` (``flexfmu build``: the registry's FMUs, and whatever else is there);
- native FMUs of FFRBeam and ReframeBody (``flexfmu.fmi.native.build_registry_fmu``);
- an exported body clamped and one free, in both runtimes (``flexfmu.fmi.export.export_fmu``): the paper's plate on
  a coarse mesh (divisions (8, 2, 1), as tests/test_fmu_native_free.py makes it), free with interfaces A and B, and
  clamped on its nodes at x = -0.5 m with an interface at the far edge.

Python FMUs of different flexfmu builds cannot share a process (docs/fmu.md, "The runtime"): the dist FMUs were
built from one tree, the exported ones here from the tree this runs in, so ``group`` says which may meet in one
process (the foreign-state probes load two FMUs at once); native FMUs meet any.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

PLATE_INTERFACES = [{"name": "A", "point": [-0.5, 0.0, 0.01]}, {"name": "B", "point": [0.5, 0.0, 0.0], "radius": 0.03}]
CLAMPED_INTERFACES = [{"name": "tip", "point": [0.5, 0.0, 0.0], "radius": 0.03}]


@dataclass(frozen=True)
class FmuUnderTest:
    name: str           # as the report names it, e.g. "FFRBeam (native)"
    path: Path
    runtime: str        # "python" | "native"
    model: str          # what it models: the registry name, "clamped body", "free body" or the file's stem
    group: str          # FMUs of one group may share a process: "dist", "exported" (Python) or "native"


def plate_bodies():
    """(clamped, free) FlexBody of the coarse plate."""
    from flexfmu.body.build import build_body
    from flexfmu.reframe.models import load_model

    plate = load_model("paper_plate", divisions=(8, 2, 1))
    free = build_body(plate, interfaces=PLATE_INTERFACES, f_max=200.0, tolerance=1e-3)
    x = plate.nodes[:, 0]
    root = np.flatnonzero(x <= x.min() + 1e-9 * (x.max() - x.min()))
    clamped = build_body(dataclasses.replace(plate, node_sets={"root": root}), interfaces=CLAMPED_INTERFACES,
                         clamp="root", n_modes=6)
    return clamped, free


def fmus_under_test(dist: Path, out: Path) -> list[FmuUnderTest]:
    """The FMUs of ``dist`` and those built here into ``out``."""
    from flexfmu.fmi import native
    from flexfmu.fmi.export import export_fmu

    fmus = [FmuUnderTest(f"{p.stem} (python)", p, "python", p.stem, "dist") for p in sorted(dist.glob("*.fmu"))]
    for name in ("FFRBeam", "ReframeBody"):
        path = native.build_registry_fmu(name, target=out / "native" / name / f"{name}.fmu")
        fmus.append(FmuUnderTest(f"{name} (native)", Path(path), "native", name, "native"))
    clamped, free = plate_bodies()
    for model, body, stem in (("clamped body", clamped, "ClampedPlate"), ("free body", free, "FreePlate")):
        for runtime in ("python", "native"):
            path = export_fmu(body, out / runtime / stem / f"{stem}.fmu", runtime=runtime)
            fmus.append(FmuUnderTest(f"{stem} ({runtime})", Path(path), runtime, model,
                                     "exported" if runtime == "python" else "native"))
    return fmus


def partners(fmu: FmuUnderTest, fmus: list[FmuUnderTest]) -> list[dict]:
    """The FMUs whose states ``fmu`` is given in the foreign-state probes: the other runtime's FMU of the same model,
    and another FMU that may share its process (the next one of its group)."""
    chosen = []
    other_runtime = [f for f in fmus if f.model == fmu.model and f.runtime != fmu.runtime]
    if other_runtime:
        chosen.append({"path": str(other_runtime[0].path), "name": other_runtime[0].name,
                       "relation": "the other runtime"})
    same_group = [f for f in fmus if f.group == fmu.group and f.model != fmu.model]
    if same_group:
        after = [f for f in same_group if fmus.index(f) > fmus.index(fmu)]
        other = (after or same_group)[0]
        chosen.append({"path": str(other.path), "name": other.name, "relation": "another FMU"})
    return chosen
