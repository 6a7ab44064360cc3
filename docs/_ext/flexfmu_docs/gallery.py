"""The examples gallery: every example of examples/ with its summary, the commands that run it and its
figures from docs/figures/.

The summaries and, for the Python examples, the commands are read from the examples themselves (the module
docstring's first paragraph and its indented usage lines; a folder's README.md or its scripts' docstrings; the
C host's header comment), so they are the examples' own words.  Where an example is a sequence of steps
(the bracket, the C host), EXAMPLES lists them; tests/test_docs_paths.py checks every path and ``flexfmu``
command of the rendered page as it does for the hand-written pages.  An example folder or file that
EXAMPLES does not list, or a figure that does not exist, is a build warning.
"""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

from sphinx.util import logging

from .markdown import block, code, escape, prose

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES_DIR = ROOT / "examples"
FIGURES_DIR = ROOT / "docs" / "figures"
logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Example:
    path: str                     # relative to examples/
    title: str
    figures: tuple[str, ...] = ()
    commands: tuple[str, ...] = ()     # when empty: the usage lines of the example's scripts' docstrings
    see: str = ""                 # the page that explains it


EXAMPLES = (
    Example("hammer_test.py", "Hammer test on FFRBeam.fmu", ("hammer_fft.png",), see="fmu.md"),
    Example("reframe_plate.py", "The reframe paper's plate on ReframeBody.fmu", ("reframe_plate.png",),
            see="reframe.md"),
    Example("bracket", "Your own mesh as an FMU: a steel bracket on the floating platform",
            ("bracket_modes.png", "bracket_system.png", "bracket_animation_still.png"),
            commands=(".venv/bin/flexfmu modal examples/bracket/bracket.json --clamp bolt_1,bolt_2 "
                      "--plot docs/figures/bracket_modes.png",
                      ".venv/bin/flexfmu export examples/bracket/bracket.json -o dist/Bracket.fmu "
                      "--clamp bolt_1,bolt_2 --interface tip=arm_top --f-max 2000 "
                      "--gauge root=0.0005,0.02,0.008 --gauge hole=bolt_1",
                      ".venv/bin/flexfmu cosim examples/bracket/OspSystemStructure.xml --t-end 10 "
                      "--out dist/bracket_system.csv",
                      ".venv/bin/python examples/bracket/plot_system.py dist/bracket_system.csv "
                      "dist/bracket_system.png",
                      ".venv/bin/flexfmu animate dist/bracket_system.csv --fmu dist/Bracket.fmu "
                      "--out dist/bracket_animation.gif --vtk dist/bracket_vtk",
                      ".venv/bin/flexfmu fatigue dist/bracket_system.csv --tensor-gauge bracket.root "
                      "--curve DNV-B1 --out dist/bracket_fatigue.csv --plot dist/bracket_fatigue.png"),
            see="export.md"),
    Example("flexible_barge", "The wave converter on a flexible barge", ("barge_vs_rigid.png",),
            see="wave_converter.md"),
    Example("wave_converter", "Wave-energy converter: a system of five FMUs",
            ("wave_converter_run.png", "wave_tuning.png", "wave_stability.png", "wave_power_matrix.png",
             "wave_bem_rao.png"),
            commands=(".venv/bin/flexfmu cosim examples/wave_converter/OspSystemStructure.xml --t-end 20 "
                      "--out results.csv --plot wec.png",
                      ".venv/bin/python examples/wave_converter/studies.py tuning --serial",
                      ".venv/bin/flexfmu wec power-matrix examples/wave_converter/OspSystemStructure.xml "
                      "--hs 0.05,0.1,0.2 --tp 1.4,2.0,2.5 --seeds 2 --t-end 20 --serial",
                      ".venv/bin/python examples/wave_converter/rao_chart.py"),
            see="wave_converter.md"),
    Example("point_absorber", "A full-scale point absorber: BEM, drag, MoorDyn, native components, IEC power matrix",
            ("point_absorber_power_matrix.png", "point_absorber_heave_spectrum.png", "point_absorber_drag.png"),
            commands=(".venv/bin/flexfmu cosim examples/point_absorber/OspSystemStructure.xml --t-end 200 "
                      "--out pa.csv --plot pa.png",
                      ".venv/bin/flexfmu cosim examples/point_absorber/OspSystemStructure.xml --master libcosim "
                      "--every 16 --fmu-dir dist/native/point_absorber --t-end 1200 --set wave.sea_state=jonswap",
                      ".venv/bin/flexfmu wec power-matrix examples/point_absorber/OspSystemStructure.xml --seeds 3",
                      ".venv/bin/python benchmarks/point_absorber_checks.py --plot heave_spectrum.png"),
            see="wave_converter.md"),
    Example("c_host", "A minimal FMI 2.0 host in C", (),
            commands=('gcc -std=c99 -D_GNU_SOURCE -O2 -I"$(.venv/bin/python -c \'import fmpy, os; '
                      'print(os.path.join(os.path.dirname(fmpy.__file__), "c-code"))\')" '
                      "-o fmi2_host examples/c_host/fmi2_host.c -ldl",
                      "./fmi2_host [--runs N] [--reload] [--quiet] [--clock-steps] STEP N_STEPS FMU [FMU...]"),
            see="fmu.md"),
)


def _paragraphs(text: str) -> list[str]:
    return [p.strip() for p in re.split(r"\n\s*\n", text.strip()) if p.strip()]


def _summary_paragraph(text: str) -> str:
    """The first paragraph that is prose (not an indented usage block or a heading)."""
    for paragraph in _paragraphs(text):
        if not paragraph.startswith(("#", "python", "flexfmu", "fmi2_host", "`")):
            return " ".join(paragraph.split())
    return ""


def _docstring(script: Path) -> str:
    return ast.get_docstring(ast.parse(script.read_text(encoding="utf-8"))) or ""


def _usage_lines(docstring: str) -> list[str]:
    """The indented command lines of a docstring, continuation lines joined."""
    commands: list[str] = []
    for line in docstring.splitlines():
        if not line.startswith("    "):
            continue
        text = line.strip()
        if text.startswith(("python", "flexfmu", ".venv/")):
            commands.append(text)
        elif commands and text.startswith("["):
            commands[-1] += " " + text
    return commands


def _c_header(source: Path) -> str:
    comment = source.read_text(encoding="utf-8").split("*/", 1)[0].removeprefix("/*")
    return "\n".join(line.strip().removeprefix("*").removeprefix(" ") for line in comment.splitlines())


def _summary_and_commands(example: Example) -> tuple[str, list[str]]:
    path = EXAMPLES_DIR / example.path
    if path.is_file():
        doc = _docstring(path)
        return prose(_summary_paragraph(doc)), _usage_lines(doc)
    readme = path / "README.md"
    scripts = sorted(path.glob("*.py"))
    if readme.exists():
        text = _summary_paragraph(readme.read_text(encoding="utf-8"))
        summary = prose(re.sub(r"\[([^]]+)\]\([^)]+\)", r"\1", text))       # links as their text
    elif scripts:
        summary = " ".join(f"{code(s.name)}: {prose(_summary_paragraph(_docstring(s)))}" for s in scripts)
    else:
        summary = " ".join(prose(_summary_paragraph(_c_header(source))) for source in sorted(path.glob("*.c")))
    commands = [line for s in scripts for line in _usage_lines(_docstring(s))]
    return summary, commands


def render() -> str:
    listed = {example.path for example in EXAMPLES}
    for entry in sorted(EXAMPLES_DIR.iterdir()):
        if entry.name not in listed and not entry.name.startswith((".", "_")) and entry.suffix != ".pyc":
            logger.warning("examples/%s is not in the gallery (docs/_ext/flexfmu_docs/gallery.py, EXAMPLES)",
                           entry.name)
    lines = []
    for example in EXAMPLES:
        path = EXAMPLES_DIR / example.path
        if not path.exists():
            logger.warning("the gallery lists examples/%s, which does not exist", example.path)
            continue
        summary, commands = _summary_and_commands(example)
        where = f"examples/{example.path}" + ("/" if path.is_dir() else "")
        lines += [f"## {escape(example.title)}", "", f"{code(where)}", ""]
        if summary:
            lines += [summary, ""]
        commands = list(example.commands) or commands
        if commands:
            lines += ["From the repository root:", "", block("\n".join(commands), "sh"), ""]
        for figure in example.figures:
            if not (FIGURES_DIR / figure).exists():
                logger.warning("the gallery's figure docs/figures/%s does not exist", figure)
                continue
            lines += [f"![{escape(example.title)}: {figure}](figures/{figure})", ""]
        if example.see:
            lines += [f"More: [{example.see.removesuffix('.md')}]({example.see}).", ""]
    return "\n".join(lines)
