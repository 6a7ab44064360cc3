#!/usr/bin/env python3
"""Write the FMU variable tables of docs/fmu.md (flexfmu.fmi.variable_tables).

    .venv/bin/python build_scripts/document_fmus.py [--check]

--check exits 1 when a table is out of date (tests/test_docs_fmu.py checks the same), so the docs cannot
drift from the FMUs.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "fmu.md"
sys.path.insert(0, str(ROOT / "model"))          # a script of the source checkout, run without installing
from flexfmu.fmi.variable_tables import render  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if docs/fmu.md is out of date")
    args = parser.parse_args(argv)
    old = DOC.read_text(encoding="utf-8")
    new = render(old)
    if args.check:
        if new != old:
            print("docs/fmu.md: the variable tables are out of date; run build_scripts/document_fmus.py", file=sys.stderr)
            return 1
        return 0
    DOC.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
