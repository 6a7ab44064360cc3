"""One C style: every C source the project keeps (the FMU runtime, the kernels, the example host, the test
fixtures) is as clang-format formats it with the repository's .clang-format, by the clang-format that
pyproject.toml's dev extra pins (formatting differs between clang-format versions)."""
from __future__ import annotations

import subprocess
from pathlib import Path

import clang_format
import pytest

ROOT = Path(__file__).resolve().parents[1]


def c_sources() -> list[Path]:
    listed = subprocess.run(["git", "ls-files", "*.c", "*.h"], cwd=ROOT, capture_output=True, text=True)
    if listed.returncode == 0 and listed.stdout.strip():
        return [ROOT / line for line in listed.stdout.split()]
    # not a git checkout (an unpacked source archive): every C file but third-party headers
    return sorted(p for p in ROOT.rglob("*.[ch]") if ".venv" not in p.parts and "build" not in p.parts)


def unformatted(path: Path) -> str:
    """clang-format's complaints about ``path`` ('' when it is formatted)."""
    result = subprocess.run([clang_format.get_executable("clang-format"), "--style=file", "--dry-run", "--Werror",
                             str(path)], cwd=ROOT, capture_output=True, text=True)
    return result.stderr if result.returncode else ""


def test_the_style_file_is_the_one_clang_format_reads():
    assert (ROOT / ".clang-format").is_file()
    assert len(c_sources()) >= 10


@pytest.mark.parametrize("path", c_sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_c_source_is_formatted(path):
    complaints = unformatted(path)
    assert not complaints, (f"{path.relative_to(ROOT)} is not in the project's C style; run: "
                            f".venv/bin/clang-format --style=file -i {path.relative_to(ROOT)}\n{complaints[:2000]}")


def test_an_unformatted_source_is_found(tmp_path):
    """The check can fail: a badly laid out copy of a source is reported."""
    bad = tmp_path / "bad.c"
    bad.write_text("int   f( int x ){return x+1;}\n")
    (tmp_path / ".clang-format").write_text((ROOT / ".clang-format").read_text())
    assert "bad.c" in unformatted(bad)
