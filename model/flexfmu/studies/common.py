"""What the ``flexfmu bench`` studies share: where their reports and charts go, and how they name an optional
package they could not import.

Reports and charts default to the source checkout's docs/ (and docs/figures/) when this flexfmu is the
checkout's model/flexfmu (an editable install, or PYTHONPATH=model) - that is where the committed reports live;
from an installed flexfmu they default to the current directory (and ./figures/).
"""
from __future__ import annotations

import contextlib
import importlib
import io
import os
import sys
from pathlib import Path

#: pip commands that install the optional packages a study can use.
PIP = {"matplotlib": "pip install 'flexfmu[plots]' or pip install matplotlib",
       "exudyn": "pip install 'exudyn>=1.13,<2'"}


def source_checkout() -> Path | None:
    """The repository root when this flexfmu is a source checkout's model/flexfmu (it has docs/ and
    pyproject.toml beside model/), else None (an installed flexfmu)."""
    package = Path(__file__).resolve().parents[1]
    root = package.parents[1]
    if package.parent.name == "model" and (root / "pyproject.toml").is_file() and (root / "docs").is_dir():
        return root
    return None


def provenance() -> str:
    """Which code and day a generated report comes from: "commit 1a2b3c4 (dirty), 2026-11-27" in a source
    checkout (dirty: uncommitted changes to tracked files), else the installed flexfmu version and the day, so a
    reader can tell a stale report from a fresh one."""
    import datetime
    import subprocess
    today = datetime.date.today().isoformat()
    root = source_checkout()
    if root is not None:
        try:
            commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True,
                                    text=True, timeout=30).stdout.strip()
            dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                                   capture_output=True, text=True, timeout=30).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            commit, dirty = "", ""
        if commit:
            return f"commit {commit}{' (with uncommitted changes)' if dirty else ''}, {today}"
    from importlib.metadata import PackageNotFoundError, version
    try:
        return f"flexfmu {version('flexfmu')}, {today}"
    except PackageNotFoundError:
        return f"flexfmu (unknown version), {today}"


def default_report_dir() -> Path:
    """docs/ of the source checkout, else the current directory."""
    root = source_checkout()
    return root / "docs" if root is not None else Path.cwd()


def figures_dir(report: str | Path | None = None) -> Path:
    """Where charts go: figures/ beside ``report`` (a report's image links are figures/<name>), or beside the
    default report's place when there is none."""
    if report is None or str(report) == "-":
        return default_report_dir() / "figures"
    return Path(report).parent / "figures"


def optional(module: str):
    """The module ``module``, or None when it is not installed."""
    try:
        return importlib.import_module(module)
    except ImportError:
        return None


def skipped(what: str, package: str) -> str:
    """The line a study prints for a part it skips because ``package`` is missing."""
    return f"{what} skipped: {package} is not installed ({PIP.get(package, f'pip install {package}')})"


def pyplot():
    """matplotlib.pyplot on the Agg backend (charts are files), or None without matplotlib."""
    if optional("matplotlib") is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


class _Tee(io.TextIOBase):
    """Writes to a stream and keeps a copy."""

    def __init__(self, stream):
        self.stream, self.copy = stream, io.StringIO()

    def write(self, text):
        self.copy.write(text)
        return self.stream.write(text)

    def flush(self):
        self.stream.flush()


@contextlib.contextmanager
def recording():
    """Everything printed inside the block still goes to stdout; the yielded buffer holds a copy (a study's
    tables, for its report)."""
    tee = _Tee(sys.stdout)
    with contextlib.redirect_stdout(tee):
        yield tee.copy


def write_text_report(path: str | Path, title: str, intro: str, printed: str, charts) -> Path:
    """A Markdown report of a study that prints its results: the printed text verbatim, then its charts
    (paths of the chart files, linked relative to the report; None for a chart that was skipped)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"# {title}", "", f"Made from {provenance()}.", "", intro, "", "```text", printed.strip("\n"), "```", ""]
    lines += [f"![{Path(p).stem}]({Path(os.path.relpath(Path(p).resolve(), path.parent.resolve())).as_posix()})\n"
              for p in charts if p is not None]
    path.write_text("\n".join(lines))
    return path
