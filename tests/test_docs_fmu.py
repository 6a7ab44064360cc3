"""docs/fmu.md's and docs/wave_converter.md's variable tables are generated from the FMUs' VARIABLE_INFO and config defaults
(flexfmu.fmi.variable_tables, written by build_scripts/document_fmus.py); this fails when a parameter, unit or
description changed without them."""
from pathlib import Path

from flexfmu.fmi import variable_tables

DOC = Path(__file__).resolve().parents[1] / "docs" / "fmu.md"


def test_fmu_variable_tables_are_up_to_date():
    for name, fmus in variable_tables.DOCUMENTS.items():
        doc = (DOC.parent / name).read_text(encoding="utf-8")
        assert variable_tables.render(doc, fmus) == doc, f"docs/{name}: run .venv/bin/python build_scripts/document_fmus.py"


def test_every_fmu_variable_is_in_its_table():
    import flexfmu.ffr.simulator as ffr
    import flexfmu.reframe.simulator as rb
    for module, fmu in ((ffr, "FFRBeam"), (rb, "ReframeBody")):
        text = variable_tables.table(fmu)
        for name in (*module.INPUT_NAMES, *module.OUTPUT_NAMES):
            base, _, axis = name.rpartition("_")
            assert f"`{name}`" in text or (f"`{base}_" in text and axis in text), name
