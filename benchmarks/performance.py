#!/usr/bin/env python3
"""Performance figures (docs/performance.md): a shell over flexfmu.studies.performance, which `flexfmu bench performance` runs.

    .venv/bin/python benchmarks/performance.py --help
"""
import sys

from flexfmu.studies.performance import main

if __name__ == "__main__":
    sys.exit(main())
