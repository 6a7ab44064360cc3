import sys

from flexfmu.cli import main

sys.exit(main())
