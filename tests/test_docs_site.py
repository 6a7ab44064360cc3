"""The documentation site (docs/conf.py, Sphinx + MyST) builds with warnings as errors.

The build runs the generators of docs/_ext/flexfmu_docs (the API reference from flexfmu.__all__'s docstrings,
the CLI reference from flexfmu.cli.build_parser, the examples gallery, the check of docs/fmu.md's variable
tables), so a docstring that does not render, a broken cross-reference, a missing figure, an example left out of
the gallery or stale FMU tables fail here.  The same build by hand:

    .venv/bin/python -m sphinx -W --keep-going -b html docs build/docs
"""
import re
import subprocess
import sys
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"

pytestmark = pytest.mark.unit


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    # A subprocess: Sphinx's autodoc imports and its logging stay out of the test process.
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(out / "doctrees"), str(DOCS), str(out / "html")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"sphinx-build failed:\n{proc.stderr}{proc.stdout}"
    assert proc.stderr.strip() == "", proc.stderr
    return out / "html"


def _text(page: Path) -> str:
    return re.sub(r"<[^>]+>", " ", page.read_text(encoding="utf-8"))


def test_every_doc_page_is_in_the_site(site):
    fragments = {"performance_notes"}          # appended to performance.md by flexfmu.studies.performance
    for md in DOCS.glob("*.md"):
        if md.stem not in fragments:
            assert (site / f"{md.stem}.html").exists(), f"{md.name} is not built (not in a toctree?)"


def test_cli_reference_lists_every_option_of_every_command(site):
    import argparse

    from flexfmu.cli import build_parser

    text = _text(site / "cli.html")

    def walk(parser, path):
        assert path in text, path
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, f"{path} {name}")
            else:
                for option in action.option_strings:
                    assert option in text, f"{path} {option}"

    walk(build_parser(), "flexfmu")


def test_api_reference_documents_every_public_name(site):
    import flexfmu

    html = (site / "api.html").read_text(encoding="utf-8")
    for name in flexfmu.__all__:
        assert f'id="flexfmu.{name}"' in html, name


def test_gallery_shows_every_example_and_its_figures(site):
    html = (site / "examples.html").read_text(encoding="utf-8")
    for example in (DOCS.parent / "examples").iterdir():
        assert f"examples/{example.name}" in html, example.name
    for figure in re.findall(r'<img [^>]*src="([^"]+)"', html):
        assert (site / figure).exists(), figure
