"""A system file's XML read with the line of every element, so that an error in it names the file, the line, the
element and what is allowed (``path:12 <BaseStepSize>: 'fast' is not a number (allowed: ...)``).

ElementTree records no line numbers; expat, which it parses with, knows the line of each start tag
(``CurrentLineNumber``).  :func:`parse` drives expat itself into an ElementTree TreeBuilder and keeps the line of
each element beside the tree, so the readers (flexfmu.cosim.system: OSP, flexfmu.cosim.ssp: SSP) walk ordinary
Elements.  Tags keep ElementTree's ``{namespace}local`` form.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET
from xml.parsers import expat

from flexfmu.errors import ParameterError

#: attributes that identify an element in a message, in this order: <Simulator name="pto">
_IDENTIFYING = ("name", "variable", "simulator")


def tag(element) -> str:
    """The element's tag without its namespace."""
    return element.tag.split("}", 1)[-1]


def children(element, name: str) -> list:
    """The element's children with this tag (namespaces ignored); none for no element."""
    return [c for c in element if tag(c) == name] if element is not None else []


def one_line(text) -> str:
    """Any message as one line (a CLI prints the error as is)."""
    return " ".join(str(text).split())


@dataclass
class SourceTree:
    """A parsed XML file: its root, the line of every element, and the file's name as messages show it."""

    root: ET.Element
    lines: dict
    label: str

    def where(self, element) -> str:
        """``label:line <tag name="...">``: where an element is, as a message names it."""
        attrs = "".join(f' {a}="{element.get(a)}"' for a in _IDENTIFYING if element.get(a) is not None)
        return f"{self.label}:{self.lines.get(element, '?')} <{tag(element)}{attrs}>"

    def line(self, element) -> str:
        return f"line {self.lines.get(element, '?')}"

    def error(self, element, message: str, allowed: str) -> ParameterError:
        """The error of one element: one line naming file, line, element, what is wrong and what is allowed."""
        return ParameterError(self.where(element), one_line(message), allowed)

    def require(self, condition: bool, element, message: str, allowed: str) -> None:
        if not condition:
            raise self.error(element, message, allowed)

    def attribute(self, element, name: str, allowed: str) -> str:
        """A required, non-empty attribute."""
        value = element.get(name)
        self.require(value is not None and value.strip() != "", element,
                     f"no {name}" if value is None else f"empty {name}", allowed)
        return value.strip()

    def number(self, element, text, what: str, *, positive: bool = False, unit: str = "s") -> float:
        """A finite number (> 0 if positive) from an element's text or attribute, ``what`` naming it."""
        allowed = f"a finite number{' > 0' if positive else ''}, {unit}"
        self.require(text is not None and text.strip() != "", element, f"{what} is empty", allowed)
        try:
            value = float(text)
        except ValueError:
            raise self.error(element, f"{what} {text.strip()!r} is not a number", allowed) from None
        self.require(math.isfinite(value), element, f"{what} {text.strip()!r} is not finite", allowed)
        self.require(value > 0 or not positive, element, f"{what} {text.strip()!r} is not > 0", allowed)
        return value


def _qualified(name: str) -> str:
    # expat with namespace_separator "}" gives "uri}local"; ElementTree writes "{uri}local"
    return "{" + name if "}" in name else name


def parse(path, label: str | None = None, what: str = "an XML file") -> SourceTree:
    """Parse the XML file at ``path``; ``label`` names it in messages (default: the path); ``what`` says what
    the file should be when it is not XML."""
    path = Path(path)
    label = str(path) if label is None else label
    builder = ET.TreeBuilder()
    parser = expat.ParserCreate(namespace_separator="}")
    lines: dict = {}

    def start(name, attributes):
        element = builder.start(_qualified(name), {_qualified(k): v for k, v in attributes.items()})
        lines[element] = parser.CurrentLineNumber

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda name: builder.end(_qualified(name))
    parser.CharacterDataHandler = builder.data
    parser.buffer_text = True
    try:
        parser.Parse(path.read_bytes(), True)
    except expat.ExpatError as exc:
        raise ParameterError(f"{label}:{exc.lineno}", f"not XML ({expat.errors.messages[exc.code]}, column "
                             f"{exc.offset + 1})", what) from None
    return SourceTree(builder.close(), lines, label)
