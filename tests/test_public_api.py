"""The flat public API of flexfmu: its doctested examples run, every advertised name resolves, and
``import flexfmu`` (what every FMU does first) imports none of the numerics."""
import doctest
import subprocess
import sys

import flexfmu


def test_doctest_examples_of_the_public_api():
    failures, tried = doctest.testmod(flexfmu, optionflags=doctest.ELLIPSIS)
    assert tried >= 10 and failures == 0


def test_every_public_name_resolves():
    for name in flexfmu.__all__:
        assert getattr(flexfmu, name) is not None, name


def test_importing_flexfmu_imports_no_numerics():
    code = "import sys, flexfmu; print(sorted(m for m in sys.modules if m.startswith(('flexfmu.', 'numpy', 'scipy'))))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "['flexfmu.errors']", out.stdout
