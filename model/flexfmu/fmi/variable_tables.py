"""The FMU variable tables of docs/fmu.md and of docs/wave_converter.md's point absorber (Markdown), from the FMUs' variable tables (flexfmu.fmi.variables, whence
the modelDescription and the model file come too): parameters with their defaults,
inputs and outputs with unit and description; vector components (_x/_y/_z, _1/_2/_3, q_w..q_z) share a row.
Each table sits between ``<!-- variables:NAME -->`` and ``<!-- /variables:NAME -->``;
build_scripts/document_fmus.py rewrites both documents (DOCUMENTS) and tests/test_docs_fmu.py checks they are up to
date.
"""
from __future__ import annotations

import re

from flexfmu.errors import ParameterError
from flexfmu.fmi import variables
from flexfmu.fmi.registry import BY_NAME, FMUS

#: the FMUs whose variables docs/fmu.md tables
DOCUMENTED = tuple(spec.name for spec in FMUS if spec.documented)
#: the FMUs whose variables docs/wave_converter.md tables (its point-absorber section)
POINT_ABSORBER = ("AbsorberWave", "AbsorberFloat", "AbsorberHydro", "HeavePTO", "Mooring")
#: each generated document (relative to the repository's docs/) and the FMUs it tables
DOCUMENTS = {"fmu.md": DOCUMENTED, "wave_converter.md": POINT_ABSORBER}
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


def table(fmu) -> str:
    """The Markdown variable table of an FMU: a registry name, or any spec with config_class, input_names,
    output_names and variable_info (flexfmu.fmi.registry.FmuSpec, flexfmu.fmi.export.ExportedSpec)."""
    spec = BY_NAME[fmu] if isinstance(fmu, str) else fmu
    rows = {v.name: v for v in variables.table(spec)}       # the FMU's one variable table
    lines = ["| variable | causality | default | unit | description |", "|---|---|---|---|---|"]
    for causality in ("parameter", "input", "output"):
        for base, axes in _groups([v.name for v in rows.values() if v.causality == causality]):
            members = [f"{base}_{a}" for a in axes] or [base]
            label = f"{base}_{'/'.join(axes)}" if axes else base
            default = ", ".join(repr(rows[n].start) for n in members) if causality == "parameter" else ""
            first = rows[members[0]]
            text = _describe(first.description, axes).replace("|", "\\|")      # a bare | would split the table cell
            lines.append(f"| `{label}` | {causality} | {default} | {first.unit or '–'} | {text} |"
                         .replace("|  |", "| |"))
    return "\n".join(lines)


def render(doc: str, fmus=DOCUMENTED) -> str:
    """``doc`` with the table of each of ``fmus`` (default: docs/fmu.md's) between its markers."""
    for fmu in fmus:
        start, end = f"<!-- variables:{fmu} -->", f"<!-- /variables:{fmu} -->"
        if start not in doc or end not in doc:
            raise ParameterError("doc", f"lacks the markers {start} ... {end}", "both markers of every documented FMU")
        head, rest = doc.split(start, 1)
        _, tail = rest.split(end, 1)
        doc = f"{head}{start}\n{table(fmu)}\n{end}\n\n{tail.lstrip(chr(10))}"
    return doc
