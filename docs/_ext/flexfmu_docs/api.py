"""The API reference: an entry for every name of ``flexfmu.__all__``, grouped by kind (functions, classes,
exceptions, data) in the order of ``__all__``.  Callables go through autodoc; their docstrings are
reStructuredText (with the plain-text parameter lists that flexfmu_docs.docstrings converts), so the entries are wrapped in ``eval-rst``.  Data
has no docstring of its own: its ``#:`` comment where it is defined (flexfmu or, for a lazily imported name,
its module in ``flexfmu._LAZY``) is the description."""
from __future__ import annotations

import inspect

from sphinx.pycode import ModuleAnalyzer

KINDS = (("Functions", "autofunction"), ("Classes", "autoclass"), ("Exceptions", "autoexception"),
         ("Data", "data"))


def _kind(obj) -> str:
    if inspect.isclass(obj):
        return "autoexception" if issubclass(obj, BaseException) else "autoclass"
    return "autofunction" if callable(obj) else "data"


def _data_entry(flexfmu, name: str) -> list[str]:
    module = flexfmu._LAZY.get(name, "flexfmu")
    comment = ModuleAnalyzer.for_module(module).find_attr_docs().get(("", name), [])
    value = getattr(flexfmu, name)
    lines = [f".. py:data:: {name}", "   :module: flexfmu", f"   :type: {type(value).__name__}", ""]
    lines += [f"   {line}" for line in comment if line.strip()]
    if module != "flexfmu":
        lines.append(f"   Defined in ``{module}``.")
    return lines + [""]


def render() -> str:
    import flexfmu

    by_kind: dict[str, list[str]] = {}
    for name in flexfmu.__all__:
        by_kind.setdefault(_kind(getattr(flexfmu, name)), []).append(name)
    lines = []
    for title, directive in KINDS:
        names = by_kind.get(directive, [])
        if not names:
            continue
        lines += [f"## {title}", "", "```{eval-rst}"]
        for name in names:
            if directive == "data":
                lines += _data_entry(flexfmu, name)
            else:
                lines += [f".. {directive}:: flexfmu.{name}", *(["   :members:"] if directive == "autoclass" else []),
                          ""]
        lines += ["```", ""]
    return "\n".join(lines)
