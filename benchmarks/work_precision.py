#!/usr/bin/env python3
"""Work-precision study (docs/work_precision.md): a shell over flexfmu.studies.work_precision, which `flexfmu bench work-precision` runs.

    .venv/bin/python benchmarks/work_precision.py --help
"""
import sys

from flexfmu.studies.work_precision import main

if __name__ == "__main__":
    sys.exit(main())
