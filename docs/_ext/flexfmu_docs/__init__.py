"""Sphinx extension of the flexfmu site: pages whose content is generated from the code at build time.

A page holds a marker comment ``<!-- generated: NAME -->``; on reading the page, the marker is replaced by the
Markdown of the generator NAME, so the page's hand-written part stays readable on GitHub and the generated
part cannot drift from the code:

- ``cli-reference``: every command, sub-command and option of ``flexfmu.cli.build_parser()`` (cli.py);
- ``api-reference``: autodoc entries for every name of ``flexfmu.__all__`` (api.py);
- ``examples-gallery``: every example of examples/ with its summary, commands and figures (gallery.py);
- ``unlisted-pages``: inside a toctree, the pages of docs/ that the page's toctrees do not name yet (a newly
  generated report gets into the site without an edit of index.md).

Docstrings are preprocessed for autodoc (docstrings.py: the aligned parameter lists, ``|x|`` norms).  It also
checks that docs/fmu.md's variable tables match the FMU registry (flexfmu.fmi.variable_tables), a
warning otherwise, so a strict build fails on stale tables as tests/test_docs_fmu.py does.
"""
from __future__ import annotations

import re
from pathlib import Path

from sphinx.util import logging

from . import api, cli, docstrings, gallery

def _unlisted_pages(app, docname: str, text: str) -> str:
    """The pages of docs/ that no toctree of this page names, one per line (for a toctree)."""
    listed = set(re.findall(r"^([\w/-]+)$", text, re.MULTILINE))
    pages = sorted(p.stem for p in Path(app.srcdir).glob("*.md") if p.stem != docname)
    return "\n".join(page for page in pages if page not in listed)


GENERATORS = {"cli-reference": cli.render, "api-reference": api.render, "examples-gallery": gallery.render,
              "unlisted-pages": _unlisted_pages}
MARKER = re.compile(r"^<!-- generated: ([a-z-]+) -->$", re.MULTILINE)
logger = logging.getLogger(__name__)


def _replace_markers(app, docname: str, source: list) -> None:
    def generate(match: re.Match) -> str:
        name = match.group(1)
        if name not in GENERATORS:
            logger.warning("unknown generated section %r (known: %s)", name, ", ".join(GENERATORS),
                           location=docname)
            return match.group(0)
        generator = GENERATORS[name]
        return generator(app, docname, source[0]) if generator is _unlisted_pages else generator()

    source[0] = MARKER.sub(generate, source[0])


def _check_fmu_tables(app) -> None:
    from flexfmu.fmi import variable_tables

    doc = Path(app.srcdir) / "fmu.md"
    text = doc.read_text(encoding="utf-8")
    if variable_tables.render(text) != text:
        logger.warning("docs/fmu.md: the FMU variable tables are out of date; run "
                       ".venv/bin/python build_scripts/document_fmus.py", location="fmu")


def setup(app):
    app.connect("source-read", _replace_markers)
    app.connect("builder-inited", _check_fmu_tables)
    app.connect("autodoc-process-docstring", docstrings.process)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
