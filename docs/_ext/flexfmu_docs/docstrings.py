"""autodoc preprocessing for the plain-text conventions of flexfmu's docstrings.

The docstrings are written to read well in ``help()`` and in the source: parameters as an aligned list

    name:       what it is, its unit
                and the continuation, aligned with the text

and norms written ``|x|``.  In reStructuredText the aligned continuation lines are an "unexpected
indentation" and ``|x|`` is a substitution reference, so before autodoc renders a docstring:

- each such list becomes a definition list (the name as a literal, its text joined into one definition);
- ``|x|`` outside inline literals is escaped to a literal ``|x|``.

Everything else (reStructuredText roles, literals, doctests) is left as written.
"""
from __future__ import annotations

import re

PARAMETER = re.compile(r"^(?P<indent> *)(?P<name>[A-Za-z_][\w.*\[\]]*(?:, ?[A-Za-z_][\w.*]*)*):\s+(?P<text>\S.*)$")
NORM = re.compile(r"(?<![|\\\w])\|(?=[^\s|])([^|`]*?[^\s|\\])\|(?![|\w])")
LITERAL = re.compile(r"(``.+?``)")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _parameter_lists(lines: list[str]) -> list[str]:
    out: list[str] = []
    i = 0
    while i < len(lines):
        match = PARAMETER.match(lines[i])
        if not match:
            out.append(lines[i])
            i += 1
            continue
        indent = len(match.group("indent"))
        fields: list[list[str]] = []          # [name, text] per field
        continuation = 0
        j = i
        while j < len(lines):
            line = lines[j]
            field = PARAMETER.match(line)
            if field and len(field.group("indent")) == indent:
                fields.append([field.group("name"), field.group("text")])
            elif line.strip() and _indent(line) > indent and fields:
                fields[-1][1] += " " + line.strip()
                continuation += 1
            else:
                break
            j += 1
        if continuation == 0 and len(fields) < 2:       # a sentence that happens to start "word: ..."
            out.append(lines[i])
            i += 1
            continue
        pad = " " * indent
        if out and out[-1].strip():
            out.append("")
        for name, text in fields:
            out += [f"{pad}``{name}``", f"{pad}   {text}"]
        if j < len(lines) and lines[j].strip():
            out.append("")
        i = j
    return out


def _escape_norms(line: str) -> str:
    if line.lstrip().startswith((">>>", "...", "|", "+")):
        return line
    parts = LITERAL.split(line)
    return "".join(part if part.startswith("``") else NORM.sub(r"\\|\1\\|", part) for part in parts)


def _literal_blocks(lines: list[str]):
    """Per line: True inside a literal block (after a paragraph ending in ``::``) or a doctest."""
    inside, base = False, 0
    for k, line in enumerate(lines):
        if inside and line.strip() and _indent(line) <= base:
            inside = False
        yield inside or line.lstrip().startswith(">>>")
        if line.rstrip().endswith("::") and not inside:
            inside, base = True, _indent(line)


def process(app, what, name, obj, options, lines: list[str]) -> None:
    literal = list(_literal_blocks(lines))
    kept = [line if is_literal else _escape_norms(line) for line, is_literal in zip(lines, literal)]
    if not any(literal):
        kept = _parameter_lists(kept)
    lines[:] = kept
