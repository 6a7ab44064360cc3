#!/usr/bin/env python3
"""Stability where methods fail (docs/stability.md): a shell over flexfmu.studies.stability, which `flexfmu bench stability` runs.

    .venv/bin/python benchmarks/stability.py --help
"""
import sys

from flexfmu.studies.stability import main

if __name__ == "__main__":
    sys.exit(main())
