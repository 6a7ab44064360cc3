#!/usr/bin/env python3
"""Build the FMUs into dist/ (or --out): a shell over flexfmu.fmi.build (also `flexfmu build`).

    python build_scripts/build_fmus.py [--out dist]
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "model"))   # a source checkout without install

from flexfmu.fmi.build import build, main  # noqa: E402,F401  (build: for callers that load this file)

if __name__ == "__main__":
    sys.exit(main())
