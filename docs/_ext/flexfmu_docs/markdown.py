"""Markdown helpers shared by the generators."""
from __future__ import annotations

import re

_SPECIAL = re.compile(r"([\\`*_\[\]<>|#~{}$!])")


def escape(text: str) -> str:
    """``text`` as literal Markdown text: every character CommonMark or MyST could read as markup escaped."""
    return _SPECIAL.sub(r"\\\1", re.sub(r"\s+", " ", text))


def code(text: str) -> str:
    """``text`` as inline code, with a fence longer than any run of backticks inside it."""
    longest = max((len(run) for run in re.findall(r"`+", text)), default=0)
    fence = "`" * (longest + 1)
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def block(text: str, language: str = "text") -> str:
    """``text`` as a fenced code block."""
    longest = max((len(run) for run in re.findall(r"^`{3,}", text, re.MULTILINE)), default=2)
    fence = "`" * (longest + 1)
    return f"{fence}{language}\n{text.rstrip()}\n{fence}"


def prose(text: str) -> str:
    """Plain or reStructuredText prose as Markdown: ``literals`` (and Markdown `code`) as inline code, the rest
    escaped."""
    parts = re.split(r"``(.+?)``|`([^`]+)`", " ".join(text.split()))
    out = []
    for index, part in enumerate(parts):
        if part is None:
            continue
        out.append(code(part) if index % 3 else escape(part))
    return "".join(out)
