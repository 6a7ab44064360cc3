"""Compile flexfmu's C kernels (flexfmu/native/csrc) into shared libraries: for the library (loaded with
ctypes, cached per source digest in ``<cache root>/native``) and for native FMUs (flexfmu.fmi.native).

The kernels are C99 with no dependency beyond libc/libm.  The flags keep IEEE semantics (no fast-math,
no FMA contraction), so a kernel gives the same numbers wherever it is built with the same compiler.
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path

from flexfmu.errors import FlexfmuError

CSRC = Path(__file__).resolve().parent / "csrc"
#: IEEE arithmetic as written: the native FMU and the library must give the same numbers
KERNEL_FLAGS = ("-std=c99", "-O2", "-fPIC", "-ffp-contract=off", "-fno-fast-math", "-Wall", "-Wextra")


class CompilerError(FlexfmuError):
    """No C compiler, or the kernels do not compile."""

    def __init__(self, why: str):
        self.parameter = "C compiler"
        super().__init__(f"C compiler: {why}")


def find_compiler() -> str:
    """$CC, else gcc, clang or cc on PATH; CompilerError saying what to install when there is none."""
    for name in (os.environ.get("CC"), "gcc", "clang", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    raise CompilerError("none found (looked for $CC, gcc, clang, cc on PATH); install one, "
                        "e.g. `apt-get install gcc` (Debian/Ubuntu) or `xcode-select --install` (macOS)")


def compile_shared(sources, output: Path, include_dirs=(), extra_flags=(), libraries=("m",)) -> Path:
    """Compile C ``sources`` into the shared library ``output`` (written atomically)."""
    cc = find_compiler()
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".so", dir=output.parent)
    os.close(fd)
    command = [cc, *KERNEL_FLAGS, *extra_flags, "-shared", *(f"-I{d}" for d in (CSRC, *include_dirs)),
               *map(str, sources), "-o", tmp, *(f"-l{lib}" for lib in libraries)]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        os.unlink(tmp)
        raise CompilerError(f"compiling failed:\n{' '.join(command)}\n{result.stderr}")
    os.replace(tmp, output)
    return output


def sources_digest(sources) -> str:
    digest = hashlib.sha256()
    for path in sorted(map(Path, sources)):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    for path in sorted(CSRC.glob("*.h")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    digest.update(" ".join(KERNEL_FLAGS).encode())
    return digest.hexdigest()[:24]


_LOCK = threading.Lock()
_LOADED: dict[str, ctypes.CDLL] = {}


def _library_folders() -> list[Path]:
    """Where compiled libraries are kept: ``<cache root>/native``, else (read-only home) a per-user folder in
    the system temp folder."""
    from flexfmu.core.cache import cache_root
    user = getattr(os, "getuid", lambda: "user")()
    return [Path(cache_root()) / "native", Path(tempfile.gettempdir()) / f"flexfmu-{user}" / "native"]


def load_kernels(name: str, sources) -> ctypes.CDLL:
    """The shared library ``name`` of C ``sources``, compiled once per source digest into the cache
    (``<cache root>/native/<name>-<digest>.so``; the system temp folder when the cache is not writable) and
    loaded once per process.  Raises CompilerError when it must be compiled and cannot be."""
    sources = [Path(s) for s in sources]
    key = f"{name}-{sources_digest(sources)}"
    with _LOCK:
        lib = _LOADED.get(key)
        if lib is None:
            folders = _library_folders()
            path = next((f / f"{key}.so" for f in folders if (f / f"{key}.so").is_file()), None)
            if path is None:
                failures = []
                for folder in folders:
                    try:
                        path = compile_shared(sources, folder / f"{key}.so")
                        break
                    except OSError as exc:            # a folder that cannot be written: the next one
                        failures.append(f"{folder}: {exc}")
                else:
                    raise CompilerError("no writable folder for the compiled kernels (" + "; ".join(failures) + ")")
            lib = _LOADED[key] = ctypes.CDLL(str(path))
        return lib
