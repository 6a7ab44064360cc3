"""What the stability studies share (flexfmu.studies.stability): the free-free bent rod of studies 1, 2 and 4,
its principal axes, and how a study draws its chart (or says why not)."""
from __future__ import annotations

from pathlib import Path

from flexfmu.linalg.modal_basis import mass_properties
from flexfmu.reframe.models import load_model
from flexfmu.studies import common

BEAM_MODEL = "beam:spatial_double_L"     # free-free bent rod, 6 DOF per node
BEAM_ELEMENTS = 4                        # elements per segment: 13 nodes, flexible modes 148, 266, 280 Hz


def draw_chart(figures: Path, name: str, draw) -> Path | None:
    """figures/name drawn by draw(plt, path); without matplotlib the chart is skipped, saying so."""
    plt = common.pyplot()
    if plt is None:
        print("   " + common.skipped(f"chart {name}", "matplotlib"))
        return None
    figures.mkdir(parents=True, exist_ok=True)
    draw(plt, figures / name)
    return figures / name


def beam(elements_per_segment: int = BEAM_ELEMENTS):
    return load_model(BEAM_MODEL, elements_per_segment=elements_per_segment)


def principal_axes(structure):
    """Principal moments (ascending) and axes (columns) of the rigid body (flexfmu.linalg.modal_basis.mass_properties:
    from M and the nodes, independent of the modal basis)."""
    props = mass_properties(structure)
    return props.principal_moments, props.principal_axes
