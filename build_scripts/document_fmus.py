#!/usr/bin/env python3
"""Write the FMU variable tables of docs/fmu.md from the library's VARIABLE_INFO and config defaults.

    .venv/bin/python build_scripts/document_fmus.py [--check]

Each table sits between ``<!-- variables:NAME -->`` and ``<!-- /variables:NAME -->``; --check exits 1
when a table is out of date (tests/test_docs_fmu.py runs it), so the docs cannot drift from the FMUs.
"""
from __future__ import annotations

import argparse
import re
import sys
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "fmu.md"
sys.path.insert(0, str(ROOT / "model"))
from flexfmu.fmi.registry import FMUS as _ALL  # noqa: E402

#: the FMUs whose variables docs/fmu.md tables: {name: (module, config class)}
FMUS = {spec.name: (spec.module, spec.config) for spec in _ALL if spec.documented}
_AXIS = re.compile(r"^(.*)_([xyzw123])$")
_AXIS_SETS = ("xyz", "wxyz", "123")


def _groups(names):
    """Consecutive names that differ only in an axis suffix (_x/_y/_z, _1/_2/_3, q_w..q_z) form one row."""
    rows = []
    for name in names:
        m = _AXIS.match(name)
        if rows and m and rows[-1][0] == m.group(1):
            rows[-1][1].append(m.group(2))
        else:
            rows.append([m.group(1), [m.group(2)]] if m else [name, []])
    out = []
    for base, axes in rows:
        siblings = [n for n in names if n.rsplit("_", 1)[0] == base]     # f_1 ... f_6 share the base "f"
        if "".join(axes) in _AXIS_SETS and len(siblings) == len(axes):
            out.append((base, axes))
        else:                                  # e.g. f_1 ... f_6: not a vector, one row each
            out += [(f"{base}_{a}" if a else base, []) for a in (axes or [""])]
    return out


def _describe(text: str, axes) -> str:
    if not axes:
        return text
    text = re.sub(r", body [xyz123]$", " (body frame)", text)
    return re.sub(r", [xyzw123]$", "", text)


def table(fmu: str) -> str:
    import importlib

    module_name, config_name = FMUS[fmu]
    module = importlib.import_module(module_name)
    defaults = asdict(getattr(module, config_name)())
    info = module.VARIABLE_INFO
    lines = ["| variable | causality | default | unit | description |", "|---|---|---|---|---|"]
    for names, causality in ((list(defaults), "parameter"), (list(module.INPUT_NAMES), "input"),
                             (list(module.OUTPUT_NAMES), "output")):
        for base, axes in _groups(names):
            members = [f"{base}_{a}" for a in axes] or [base]
            label = f"{base}_{'/'.join(axes)}" if axes else base
            default = ", ".join(repr(defaults[n]) for n in members) if causality == "parameter" else ""
            unit, text = info[members[0]]
            text = _describe(text, axes).replace("|", "\\|")      # a bare | would split the table cell
            lines.append(f"| `{label}` | {causality} | {default} | {unit or '–'} | {text} |".replace("|  |", "| |"))
    return "\n".join(lines)


def render(doc: str) -> str:
    for fmu in FMUS:
        start, end = f"<!-- variables:{fmu} -->", f"<!-- /variables:{fmu} -->"
        if start not in doc or end not in doc:
            raise SystemExit(f"document_fmus: {DOC} lacks the markers {start} ... {end}")
        head, rest = doc.split(start, 1)
        _, tail = rest.split(end, 1)
        doc = f"{head}{start}\n{table(fmu)}\n{end}\n\n{tail.lstrip(chr(10))}"
    return doc


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if docs/fmu.md is out of date")
    args = parser.parse_args(argv)
    old = DOC.read_text(encoding="utf-8")
    new = render(old)
    if args.check:
        if new != old:
            print("docs/fmu.md: the variable tables are out of date; run build_scripts/document_fmus.py", file=sys.stderr)
            return 1
        return 0
    DOC.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
