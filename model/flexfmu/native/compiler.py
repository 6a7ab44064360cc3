"""Compile flexfmu's C kernels (flexfmu/native/csrc) into shared libraries: for the library (loaded with
ctypes, cached per source digest in ``<cache root>/native``) and for native FMUs (flexfmu.fmi.native).

The kernels are C99 with no dependency beyond libc/libm.  The flags keep IEEE semantics (no fast-math,
no FMA contraction), so a kernel gives the same numbers wherever it is built with the same compiler.

A native FMU's binary is also cross-compiled for the other PLATFORMS (Windows x86-64 with MinGW-w64, Linux aarch64)
when their compilers are installed (``missing_platforms`` says which are not and what to install).
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path

from flexfmu.errors import FlexfmuError

CSRC = Path(__file__).resolve().parent / "csrc"
#: IEEE arithmetic as written: the native FMU and the library must give the same numbers
KERNEL_FLAGS = ("-std=c99", "-O2", "-fPIC", "-ffp-contract=off", "-fno-fast-math", "-Wall", "-Wextra")


@dataclass(frozen=True)
class Platform:
    """A platform a native FMU's binary is built for: its folder under the FMU's binaries/, the C compiler on PATH
    (None: the host's, ``find_compiler``), the library's suffix, the Debian package of the compiler, the flags
    beyond KERNEL_FLAGS and the libraries linked."""

    name: str
    compiler: str | None
    suffix: str
    package: str
    flags: tuple = ()
    libraries: tuple = ("m", "pthread", "dl")


#: linux64 and win64 are FMI 2.0's folder names; FMI 2.0 has none for ARM Linux (fmpy, fmusim and FMI Library load
#: binaries/linux64 there too, the x86-64 name), so the aarch64 library goes to FMI 3.0's aarch64-linux
PLATFORMS = (
    Platform("linux64", None, ".so", "gcc"),
    # -static-libgcc: no libgcc DLL beside it (it imports KERNEL32 and msvcrt only); MinGW's own C99 printf family
    # (%zu, two-digit exponents as glibc's) instead of msvcrt's; GCC checks printf formats against msvcrt's, so
    # -Wno-format here (the Linux builds check the same formats)
    Platform("win64", "x86_64-w64-mingw32-gcc", ".dll", "gcc-mingw-w64-x86-64",
             ("-static-libgcc", "-D__USE_MINGW_ANSI_STDIO=1", "-Wno-format"), ("m",)),
    Platform("aarch64-linux", "aarch64-linux-gnu-gcc", ".so", "gcc-aarch64-linux-gnu"),
)


class PlatformsMissingWarning(UserWarning):
    """A native FMU was built without some PLATFORMS' binaries: their cross compilers are not installed."""


def platform_compiler(platform: Platform) -> str | None:
    """The compiler of ``platform`` on PATH (the host's: ``find_compiler``), None when it is not installed."""
    if platform.compiler is None:
        try:
            return find_compiler()
        except CompilerError:
            return None
    return shutil.which(platform.compiler)


def install_hint(platform: Platform) -> str:
    """What to install for ``platform``'s compiler."""
    return f"apt-get install {platform.package} (Debian/Ubuntu; it provides {platform.compiler or 'gcc'})"


def missing_platforms() -> dict[str, str]:
    """{platform name: what to install} for the PLATFORMS whose compiler is not on PATH."""
    return {p.name: install_hint(p) for p in PLATFORMS if platform_compiler(p) is None}


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


def compile_shared(sources, output: Path, include_dirs=(), extra_flags=(), libraries=("m",), compiler=None) -> Path:
    """Compile C ``sources`` into the shared library ``output`` (written atomically) with ``compiler`` (a cross
    compiler of PLATFORMS; default: the host's)."""
    cc = compiler or find_compiler()
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
