"""On-disk cache of expensive set-up data (assembled models, modal bases) between processes.

Every FMU instance and CLI run of the default plate otherwise repeats the mesh, the assembly and
the sparse modal analysis (seconds); the in-process ``lru_cache`` of the simulators does not survive
the process.  Entries are ``.npz`` files (arrays only, no pickle) in ``<cache root>/models/``
(:func:`cache_root`: ``$FLEXFMU_CACHE_DIR``, else ``$XDG_CACHE_HOME/flexfmu``, else
``~/.cache/flexfmu``; the compiled C kernels live in ``<cache root>/native``, flexfmu.native.compiler).

* The key is a SHA-256 of a canonical JSON of what the data depends on (the caller's choice: a
  model spec and its options, or a digest of a model's arrays) plus the flexfmu version and
  :data:`FORMAT`, so that an upgrade or a change of the stored layout never reads old entries.
* Writes are atomic: a temporary file in the same folder, flushed and fsync'ed, then renamed; a
  reader sees a whole entry or none.  Two processes writing one entry both write whole files.
* A read checks the stored key and zip CRCs; an unreadable, truncated or foreign file is a miss
  (and is removed).  The cache is an accelerator: any I/O failure means "compute again".
* ``FLEXFMU_CACHE=0`` (or off / false / no) disables reading and writing; the folder is kept below
  ``FLEXFMU_CACHE_MAX_MB`` (default 2000) by removing the least recently used entries.
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
import zipfile
from functools import lru_cache
from pathlib import Path

import numpy as np

from flexfmu import __version__

FORMAT = 1                       # bump when what is stored under a key changes
_KEY_ENTRY = "__cache_key__"     # the full key, stored in every entry and checked on read


def enabled() -> bool:
    """False when the environment variable FLEXFMU_CACHE is 0 / off / false / no."""
    return os.environ.get("FLEXFMU_CACHE", "1").strip().lower() not in ("0", "off", "false", "no")


def cache_root() -> Path:
    """Per-user cache folder of flexfmu: $FLEXFMU_CACHE_DIR, else $XDG_CACHE_HOME/flexfmu, else
    ~/.cache/flexfmu (flexfmu.fmi.loader.cache_root repeats the rule: it cannot import flexfmu)."""
    explicit = os.environ.get("FLEXFMU_CACHE_DIR")
    if explicit:
        return Path(explicit)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "flexfmu"


def cache_dir() -> Path:
    """Folder of the model cache entries: ``<cache root>/models``."""
    return cache_root() / "models"


def _canonical(value):
    """JSON-able, order-independent form of a key part (tuples -> lists, numpy scalars -> numbers)."""
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return _canonical(value.tolist())
    if isinstance(value, float):
        return repr(value)                         # exact: 0.1 and 0.1000000000000001 differ
    if value is None or isinstance(value, (bool, int, str)):
        return value
    raise TypeError(f"cache key part of type {type(value).__name__}")


def make_key(kind: str, **parts) -> str:
    """Hex SHA-256 of kind, parts, the flexfmu version and FORMAT (canonical JSON)."""
    text = json.dumps({"kind": kind, "parts": _canonical(parts), "flexfmu": __version__, "format": FORMAT},
                      sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def array_digest(*arrays) -> str:
    """Hex SHA-256 of arrays' dtypes, shapes and bytes (a content key for a model's matrices)."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.data)
    return h.hexdigest()


@lru_cache(maxsize=32)
def file_digest(path) -> str:
    """Hex SHA-256 of a file's content (a source module: changed code never reads the old entries)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def meta_to_json(meta: dict) -> str:
    """A Structure's meta as JSON, arrays and tuples marked so that :func:`meta_from_json` restores them."""
    def encode(v):
        if isinstance(v, np.ndarray):
            return {"__ndarray__": v.tolist(), "dtype": v.dtype.str}
        if isinstance(v, tuple):
            return {"__tuple__": [encode(x) for x in v]}
        if isinstance(v, list):
            return [encode(x) for x in v]
        if isinstance(v, dict):
            return {str(k): encode(x) for k, x in v.items()}
        if isinstance(v, np.generic):
            return v.item()
        return v
    return json.dumps(encode(meta))


def meta_from_json(text: str) -> dict:
    """Inverse of :func:`meta_to_json`."""
    def decode(v):
        if isinstance(v, dict):
            if "__ndarray__" in v:
                return np.array(v["__ndarray__"], dtype=np.dtype(v["dtype"]))
            if "__tuple__" in v:
                return tuple(decode(x) for x in v["__tuple__"])
            return {k: decode(x) for k, x in v.items()}
        if isinstance(v, list):
            return [decode(x) for x in v]
        return v
    return decode(json.loads(text))


def _path(kind: str, key: str) -> Path:
    return cache_dir() / f"{kind}-{key[:40]}.npz"


def load(kind: str, key: str) -> dict[str, np.ndarray] | None:
    """The arrays stored under (kind, key), or None (no entry, cache disabled, or a bad file)."""
    if not enabled():
        return None
    path = _path(kind, key)
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}     # reads every member: zip CRCs checked
    except FileNotFoundError:
        return None
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile):
        _remove(path)                                            # truncated or corrupt: recompute
        return None
    stored = arrays.pop(_KEY_ENTRY, None)
    if stored is None or str(stored) != key:
        _remove(path)
        return None
    try:
        os.utime(path)                      # recently used: evicted last
    except OSError:
        pass
    return arrays


def max_bytes() -> int:
    """Size limit of the model cache: $FLEXFMU_CACHE_MAX_MB megabytes (default 2000)."""
    try:
        return int(float(os.environ.get("FLEXFMU_CACHE_MAX_MB", "2000")) * 1e6)
    except ValueError:
        return int(2000 * 1e6)


def store(kind: str, key: str, arrays: dict[str, np.ndarray]) -> Path | None:
    """Write arrays under (kind, key) atomically; the path, or None if disabled or the write failed.
    Then, if the cache exceeds :func:`max_bytes`, the least recently used other entries are removed
    (entries of superseded code versions are never read again: they age out this way)."""
    if not enabled():
        return None
    path = _path(kind, key)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.stem + ".", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **{_KEY_ENTRY: np.array(key)}, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError:
        if tmp is not None:
            _remove(Path(tmp))
        return None
    _evict(path.parent, keep=path)
    return path


def _evict(folder: Path, keep: Path) -> None:
    """Remove least recently used entries (modification time, refreshed on every hit) beyond max_bytes()."""
    try:
        entries = [(p.stat().st_mtime, p.stat().st_size, p) for p in folder.glob("*.npz") if p != keep]
        total = sum(size for _, size, _ in entries) + keep.stat().st_size
    except OSError:
        return
    for _, size, p in sorted(entries, key=lambda e: e[0]):
        if total <= max_bytes():
            break
        _remove(p)
        total -= size


def _remove(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass


def clear() -> int:
    """Remove every model cache entry (and stale temporary files); the number of files removed."""
    folder = cache_dir()
    n = 0
    if folder.is_dir():
        for p in list(folder.glob("*.npz")) + list(folder.glob("*.tmp")):
            _remove(p)
            n += 1
    return n


class BoundedCache(dict):
    """An in-memory memo of at most ``size`` entries that starts afresh when full: for per-instance caches
    of results keyed by inputs that may vary every step (held inputs, step sizes), where an LRU's
    bookkeeping would cost more than the occasional recomputation."""

    def __init__(self, size: int):
        super().__init__()
        self.size = size

    def __setitem__(self, key, value):
        if len(self) >= self.size and key not in self:
            self.clear()
        super().__setitem__(key, value)
