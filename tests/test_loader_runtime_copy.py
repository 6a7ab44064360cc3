"""The per-user runtime copy of a Python FMU's flexfmu (flexfmu.fmi.loader._runtime_copy) is shared by processes
that load the same build at once: a complete copy another process renamed into place while this one was copying
is used, never removed (it was, and the other process's imports then failed)."""
from __future__ import annotations

import os
import shutil

from flexfmu.fmi import loader


def test_a_complete_copy_made_meanwhile_by_another_process_is_kept(tmp_path, monkeypatch):
    bundled = tmp_path / "extraction" / "flexfmu"
    bundled.mkdir(parents=True)
    (bundled / "__init__.py").write_text("")
    monkeypatch.setenv("FLEXFMU_CACHE_DIR", str(tmp_path / "cache"))
    target = tmp_path / "cache" / "fmu-runtime" / "build1"
    real_copytree = shutil.copytree

    def copy_while_another_process_finishes(src, dst, *args, **kwargs):
        # the other process renames its complete copy into place while this one copies
        other = target / "flexfmu"
        other.mkdir(parents=True)
        (other / "theirs.py").write_text("")
        (target / "complete").write_text("build1")
        return real_copytree(src, dst, *args, **kwargs)

    monkeypatch.setattr(loader.shutil, "copytree", copy_while_another_process_finishes)
    assert loader._runtime_copy(str(bundled), "build1") == str(target)
    assert (target / "flexfmu" / "theirs.py").is_file()          # the other process's copy is still there
    leftovers = [n for n in os.listdir(target.parent) if n.startswith(".build1-")]
    assert leftovers == []                                         # this process's scratch copy was cleaned up


def test_an_incomplete_copy_is_replaced(tmp_path, monkeypatch):
    bundled = tmp_path / "extraction" / "flexfmu"
    bundled.mkdir(parents=True)
    (bundled / "__init__.py").write_text("")
    monkeypatch.setenv("FLEXFMU_CACHE_DIR", str(tmp_path / "cache"))
    target = tmp_path / "cache" / "fmu-runtime" / "build2"
    (target / "flexfmu").mkdir(parents=True)                       # no marker: left incomplete by a crash
    assert loader._runtime_copy(str(bundled), "build2") == str(target)
    assert (target / "complete").is_file() and (target / "flexfmu" / "__init__.py").is_file()
