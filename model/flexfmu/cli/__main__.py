"""``python -m flexfmu.cli``, the same as ``flexfmu`` and ``python -m flexfmu``."""
import sys

from flexfmu.cli import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
