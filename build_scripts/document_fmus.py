#!/usr/bin/env python3
"""Write the FMU variable tables of docs/fmu.md and docs/wave_converter.md (flexfmu.fmi.variable_tables).

    .venv/bin/python build_scripts/document_fmus.py [--check]

--check exits 1 when a table is out of date (tests/test_docs_fmu.py checks the same), so the docs cannot
drift from the FMUs.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "model"))          # a script of the source checkout, run without installing
from flexfmu.fmi.variable_tables import DOCUMENTS, render  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a document's tables are out of date")
    args = parser.parse_args(argv)
    stale = 0
    for name, fmus in DOCUMENTS.items():
        doc = ROOT / "docs" / name
        old = doc.read_text(encoding="utf-8")
        new = render(old, fmus)
        if args.check:
            if new != old:
                print(f"docs/{name}: the variable tables are out of date; run build_scripts/document_fmus.py",
                      file=sys.stderr)
                stale = 1
        elif new != old:
            doc.write_text(new, encoding="utf-8")
    return stale


if __name__ == "__main__":
    sys.exit(main())
