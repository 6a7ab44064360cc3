#!/usr/bin/env python3
"""Spin-up study (docs/spinup.md): a shell over flexfmu.studies.spinup, which `flexfmu bench spinup` runs.

    .venv/bin/python benchmarks/spinup.py --help
"""
import sys

from flexfmu.studies.spinup import main

if __name__ == "__main__":
    sys.exit(main())
