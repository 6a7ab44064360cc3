"""Sphinx configuration of the flexfmu documentation site.

    .venv/bin/python -m sphinx -W --keep-going -b html docs build/docs

The generated parts (the API reference from the docstrings, the CLI reference from flexfmu.cli.build_parser,
the FMU variable tables' freshness check, the examples gallery) are built from the code at build time by the
extensions in docs/_ext/, so they cannot drift from it; tests/test_docs_site.py builds the site with warnings
as errors.
"""
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT / "model"))        # the checkout's flexfmu, installed or not
sys.path.insert(0, str(DOCS / "_ext"))

import flexfmu  # noqa: E402

project = "flexfmu"
author = "flexfmu contributors"
copyright = "flexfmu contributors"
release = version = flexfmu.__version__

# No napoleon: the docstrings have no Google or numpy sections; their plain-text parameter lists are
# rendered by flexfmu_docs.docstrings.
extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "flexfmu_docs",
]

root_doc = "index"
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build"]
html_theme = "alabaster"

# Quotes and ellipses only: "--option" in prose stays two hyphens, not an en dash.
smartquotes_action = "qe"
