"""The docs name only things that exist: repository paths, ``flexfmu`` commands, scripts, modules; and no
text of the project refers to tracker issues by number.

What is checked, in README.md, docs/*.md, the examples' README.md files and the examples gallery as the site
renders it (docs/_ext/flexfmu_docs/gallery.py):

Paths.  Every token that starts with a top-level folder of the checkout (``model/``, ``examples/``,
``benchmarks/``, ``docs/``, ``tests/``, ``build_scripts/``, ``.ci/``) or is ``tasks.py``/``pyproject.toml``,
anywhere in the text (prose, inline code, code blocks), and every relative Markdown link target (relative to
the file that holds it), exists.  ``flexfmu/...`` is the package's path (``model/flexfmu/...``).  A
placeholder ``<name>`` or a ``*`` is a wildcard and ``{a,b}`` an alternative: at least one file must match.
Generated outputs are not in the checkout and are not checked: anything under ``dist/`` or ``build/`` (the
output folders of ``tasks.py main``, ``flexfmu build``, the examples and the site build).

Commands.  A ``flexfmu ...`` command (also ``.venv/bin/flexfmu``, ``python -m flexfmu``) in a code block, after
an optional ``$`` prompt, with ``\\`` continuations joined and ``# comments`` dropped, must parse with the real
parser, ``flexfmu.cli.build_parser().parse_args``.  A usage synopsis that does not parse as written (one with
``[optional]`` parts, ``a|b`` alternatives, ``...``, ``<placeholders>`` or ALL-CAPS metavars such as MODEL) is
checked part by part instead: its sub-commands must exist and every option it names must be an option of
that sub-command.  Inline code such as `flexfmu export` names a command rather than running it and gets the
same part-by-part check when it does not parse.  In a code block with ``$`` prompts only the prompt lines
are commands (the rest is output).

Scripts and modules.  The script of every ``python``/``python3``/``.venv/bin/python X.py`` exists, the module
of every ``python -m flexfmu.x`` exists, and every dotted name ``flexfmu.a.b`` names a module of the package
(or a name its module's source defines).

Issue numbers.  No text file of docs, README.md, model, tests, benchmarks, examples or build_scripts points at
a tracker issue (ISSUE_REFERENCE: the word followed by a number, or a bound or request cited as the tracker's as a
reason): the text says what is meant instead (the bound, the requirement).
"""
from __future__ import annotations

import contextlib
import glob
import io
import re
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from flexfmu.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.unit

GENERATED_OUTPUT_DIRS = ("dist/", "build/")
PATH_TOKEN = re.compile(r"(?<![\w/.~$-])((?:model|examples|benchmarks|docs|tests|build_scripts|\.ci|flexfmu|dist|build)"
                        r"/[^\s`'\")\],;|]*|tasks\.py|pyproject\.toml)")
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
INLINE_CODE = re.compile(r"(`+)(.+?)\1")
DOTTED = re.compile(r"(?<![\w.])flexfmu(?:\.[A-Za-z_]\w*)+")
PYTHONS = {"python", "python3", ".venv/bin/python"}
SYNOPSIS_MARK = re.compile(r"[\[\]|<>]|\.\.\.|…")
METAVAR = re.compile(r"^[A-Z][A-Z0-9_]*(?:\.[a-z]+)?$")        # MODEL, SYSTEM_FILE, OUT.fmu
ISSUE_REFERENCE = re.compile(r"\bissues?\s*#?\d|\bthe issue(?:'s|\s+asks)", re.IGNORECASE)


@dataclass(frozen=True)
class Doc:
    name: str          # for messages: the file, or the generated page
    folder: Path       # Markdown links are relative to it
    text: str


def _docs() -> list[Doc]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "examples").glob("*/README.md"))]
    docs = [Doc(str(f.relative_to(ROOT)), f.parent, f.read_text(encoding="utf-8")) for f in files]
    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    try:
        from flexfmu_docs import gallery
        markdown = re.sub(r"\\([^\sA-Za-z0-9])", r"\1", gallery.render())       # its escapes: docs/wave\_converter.md
        docs.append(Doc("docs/examples.md (the generated gallery)", ROOT / "docs", markdown))
    finally:
        sys.path.remove(str(ROOT / "docs" / "_ext"))
    return docs


DOCS = _docs()


def _split_blocks(text: str) -> tuple[str, list[list[str]]]:
    """(the text outside fenced code blocks, the blocks' lines)."""
    prose, blocks, fence, block = [], [], None, []
    for line in text.splitlines():
        stripped = line.strip()
        if fence is None and re.match(r"^(`{3,}|~{3,})", stripped):
            fence, block = re.match(r"^(`{3,}|~{3,})", stripped).group(1), []
        elif fence is not None and stripped.startswith(fence) and stripped.strip("`~") == "":
            blocks.append(block)
            fence = None
        elif fence is not None:
            block.append(line)
        else:
            prose.append(line)
    return "\n".join(prose), blocks


# ---------------------------------------------------------------- paths
def _exists(path: str) -> bool:
    path = path.split("#")[0]
    if path.startswith("flexfmu/"):
        path = "model/" + path
    for alternative in _brace_alternatives(re.sub(r"<[^>]*>", "*", path)):
        if glob.glob(str(ROOT / alternative)) or (ROOT / alternative).exists():
            return True
    return False


def _brace_alternatives(path: str) -> list[str]:
    match = re.search(r"\{([^{}]*)\}", path)
    if not match:
        return [path]
    return [alt for part in match.group(1).split(",")
            for alt in _brace_alternatives(path[:match.start()] + part + path[match.end():])]


def _path_tokens(text: str):
    for match in PATH_TOKEN.finditer(text):
        token = match.group(1).rstrip(".:!?*\\")
        if token.startswith(GENERATED_OUTPUT_DIRS) or "..." in token or "…" in token:
            continue
        yield token


def _missing_paths(doc: Doc) -> list[str]:
    missing = [f"{doc.name}: {token}" for token in dict.fromkeys(_path_tokens(doc.text)) if not _exists(token)]
    for match in LINK.finditer(doc.text):
        target = (match.group(1) or match.group(2)).split("#")[0]
        if not target or re.match(r"^[a-z]+:", target):
            continue
        if not (doc.folder / target).exists():
            missing.append(f"{doc.name}: link ({target})")
    return missing


@pytest.mark.parametrize("doc", DOCS, ids=[d.name for d in DOCS])
def test_every_repository_path_in_the_docs_exists(doc):
    missing = _missing_paths(doc)
    assert not missing, "paths in the docs that are not in the checkout:\n  " + "\n  ".join(missing)


# ---------------------------------------------------------------- commands
def _command_lines(block: list[str]) -> list[str]:
    """The shell commands of a code block: prompt lines only if it has prompts, continuations joined."""
    prompted = any(line.lstrip().startswith("$ ") for line in block)
    commands, pending = [], None
    for line in block:
        text = line.strip()
        if pending is not None:
            pending += " " + text.removesuffix("\\")
            if not text.endswith("\\"):
                commands.append(pending)
                pending = None
            continue
        if prompted:
            if not text.startswith("$ "):
                continue
            text = text[2:]
        if text.endswith("\\"):
            pending = text.removesuffix("\\")
        else:
            commands.append(text)
    if pending is not None:
        commands.append(pending)
    return commands


def _words(command: str) -> list[str]:
    """The command's words: comments dropped, split at ; && ||, leading VAR=value assignments dropped."""
    try:
        words = shlex.split(command, comments=True)
    except ValueError:                                   # an unbalanced quote: split on blanks
        words = command.split("#")[0].split()
    for separator in (";", "&&", "||"):
        if separator in words:
            words = words[:words.index(separator)]
    while words and re.match(r"^[A-Za-z_]\w*=", words[0]):
        words = words[1:]
    return words


def _flexfmu_argv(words: list[str]) -> list[str] | None:
    if words and words[0] in ("flexfmu", ".venv/bin/flexfmu"):
        return words[1:]
    if len(words) >= 3 and words[0] in PYTHONS and words[1:3] == ["-m", "flexfmu"]:
        return words[3:]
    return None


def _parse_error(argv: list[str]) -> str | None:
    """None if ``argv`` parses, else argparse's message."""
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            build_parser().parse_args(argv)
    except SystemExit as exc:
        if exc.code not in (0, None):
            return err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else f"exit {exc.code}"
    return None


def _choices() -> set[str]:
    """Every value some option or positional of the parser accepts by name (XFF is a value, not a metavar)."""
    import argparse

    values, parsers = set(), [build_parser()]
    while parsers:
        parser = parsers.pop()
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                parsers += list(action.choices.values())
            elif action.choices:
                values |= {str(choice) for choice in action.choices}
    return values


CHOICES = _choices()


def _is_synopsis(argv: list[str]) -> bool:
    """A usage synopsis: [optional] parts, a|b alternatives, ..., <placeholders> or ALL-CAPS metavars."""
    return any(SYNOPSIS_MARK.search(word) or (METAVAR.match(word) and word not in CHOICES) for word in argv)


def _synopsis_error(argv: list[str]) -> str | None:
    """Part by part: the sub-commands exist and every option named is one of the last sub-command's."""
    import argparse

    parser, path = build_parser(), "flexfmu"
    tokens = [t for word in argv for t in re.split(r"[\[\]|]", word) if t]
    index = 0
    while True:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or index >= len(tokens) or tokens[index].startswith("-"):
            break
        token = tokens[index]
        if token in subs[0].choices:
            parser, path, index = subs[0].choices[token], f"{path} {token}", index + 1
            continue
        if _is_synopsis([token]):
            break                                        # a placeholder for the sub-command
        return f"{path}: no sub-command {token!r} (allowed: {', '.join(subs[0].choices)})"
    for token in tokens[index:]:
        option = token.split("=")[0]
        if option.startswith("-") and option not in ("-", "--") and option not in parser._option_string_actions:
            return f"{path}: no option {option}"
    return None


def _commands(doc: Doc):
    """(where, words, is_inline) of every command in the doc."""
    prose, blocks = _split_blocks(doc.text)
    for block in blocks:
        for command in _command_lines(block):
            yield command, _words(command), False
    for match in INLINE_CODE.finditer(prose):
        yield match.group(2), _words(match.group(2)), True


def _bad_commands(doc: Doc) -> list[str]:
    bad = []
    for command, words, inline in _commands(doc):
        argv = _flexfmu_argv(words)
        if argv is None:
            continue
        error = _parse_error(argv)
        if error and (inline or _is_synopsis(argv)):
            error = _synopsis_error(argv)
        if error:
            bad.append(f"{doc.name}: {command!r}: {error}")
    return bad


@pytest.mark.parametrize("doc", DOCS, ids=[d.name for d in DOCS])
def test_every_flexfmu_command_in_the_docs_parses(doc):
    bad = _bad_commands(doc)
    assert not bad, "flexfmu commands in the docs that the parser rejects:\n  " + "\n  ".join(bad)


# ---------------------------------------------------------------- scripts and modules
def _module_exists(dotted: str) -> bool:
    """``flexfmu.a.b.name``: the longest prefix that is a module of the package, and the rest a name its
    source defines (no import: some modules need optional dependencies)."""
    parts = dotted.split(".")
    for end in range(len(parts), 0, -1):
        base = ROOT / "model" / Path(*parts[:end])
        source = base / "__init__.py" if base.is_dir() else base.with_suffix(".py")
        if source.exists():
            rest = parts[end:]
            return not rest or re.search(rf"\b{re.escape(rest[0])}\b", source.read_text(encoding="utf-8")) is not None
    return False


def _bad_scripts_and_modules(doc: Doc) -> list[str]:
    bad = []
    for command, words, _ in _commands(doc):
        if not words or words[0] not in PYTHONS:
            continue
        if len(words) >= 3 and words[1] == "-m":
            module = words[2]
            if module.startswith("flexfmu") and "<" not in module and not _module_exists(module):
                bad.append(f"{doc.name}: {command!r}: no module {module}")
        elif len(words) >= 2 and words[1].endswith(".py") and not _exists(words[1]):
            bad.append(f"{doc.name}: {command!r}: no script {words[1]}")
    for dotted in dict.fromkeys(DOTTED.findall(doc.text)):
        if not _module_exists(dotted):
            bad.append(f"{doc.name}: {dotted}: no such module or name")
    return bad


@pytest.mark.parametrize("doc", DOCS, ids=[d.name for d in DOCS])
def test_every_script_and_module_in_the_docs_exists(doc):
    bad = _bad_scripts_and_modules(doc)
    assert not bad, "scripts and modules in the docs that do not exist:\n  " + "\n  ".join(bad)


# ---------------------------------------------------------------- issue numbers
TEXT_SUFFIXES = {".md", ".py", ".txt", ".rst", ".c", ".h", ".toml", ".cfg", ".ini", ".json", ".xml", ".sh", ".yml",
                 ".yaml", ".ssd", ".cmake", ""}
SKIPPED_DIRS = {".venv", ".git", "__pycache__", "dist", "build", ".pytest_cache", "_build"}


def _project_text_files():
    yield ROOT / "README.md"
    for top in ("docs", "model", "tests", "benchmarks", "examples", "build_scripts"):
        for path in sorted((ROOT / top).rglob("*")):
            if (path.is_file() and path.suffix.lower() in TEXT_SUFFIXES
                    and not SKIPPED_DIRS.intersection(path.relative_to(ROOT).parts)):
                yield path


def test_no_issue_numbers_in_docs_or_code():
    found = []
    for path in _project_text_files():
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue
        for number, line in enumerate(text.splitlines(), 1):
            if ISSUE_REFERENCE.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:120]}")
    assert not found, ("say what is meant instead of pointing at a tracker issue:\n  " + "\n  ".join(found))
