"""ctypes bindings of the C reframe kernels (csrc/reframe_kernels.c, contract in csrc/reframe_kernels.h) with the
signatures of the numpy versions (flexfmu.reframe.kernels_numpy), which flexfmu.reframe.kernels picks when the
library is available.

The per-call cost is the point here (the FMU calls a step kernel per doStep; numpy's ``arr.ctypes.data`` alone
costs ~1 us), so addresses are not looked up per call: the model arrays of a call (P, LP, G, EX; PP; Psi and
the max-displacement blocks) are checked (C contiguous, float64 / int64, sizes consistent with nf) and their
addresses taken once, when a combination is first seen, and remembered keyed by the arrays' ids.  An entry
holds the small arrays themselves (their ids cannot be reused while it lives; at most _MAX_ENTRIES entries)
and weak references to the large ones (Psi, order), checked on every hit.  The held load values (one array
updated in place) are remembered the same way.  The per-call arrays (y, a new SV, sv, q) are copied into
fresh ctypes buffers (a few hundred bytes): the returned y and outputs are numpy arrays on such buffers, each
its own base (views of them have it as ``.base``, as flexfmu.reframe.results._state_vector relies on).  Arrays
that are not C-contiguous float64 are converted per call (a slower path, never taken by the library's own
callers).  Workspace and the scalar in/out arguments are per thread (the C functions run without the GIL).
Per call, beyond the arithmetic: ~2.4 us (steps), ~2.5 us (outputs), against ~1.7 us of the dispatch of the numba
kernels they replaced.
"""
from __future__ import annotations

import ctypes
import threading
import weakref
from ctypes import POINTER, c_double, c_int, c_void_p

import numpy as np

from flexfmu.core.structure import N_RIGID
from flexfmu.native.compiler import CSRC, load_kernels

__all__ = ["library", "reframe_steps", "consistent_steps", "reframe_outputs", "consistent_outputs",
           "max_node_norm", "offsets", "rodrigues", "rate_coefficient", "solve3", "quaternion", "bound",
           "block_norm", "exponential_coefficients", "ABI_VERSION", "N_RIGID", "BLOCK", "work_size"]

SOURCES = (CSRC / "reframe_kernels.c", CSRC / "lti_kernels.c")   # lti: ffx_lti_expm (exponential coefficients)
#: FFX_REFRAME_ABI_VERSION of the header these bindings follow
ABI_VERSION = 1
#: FFX_REFRAME_BLOCK: nodes per block and blocks per superblock of the max-displacement search (the one Python
#: definition: flexfmu.reframe.layout and the kernels read it from here; N_RIGID, FFX_REFRAME_N_RIGID, is
#: flexfmu.core.structure's)
BLOCK = 16
_F64 = np.dtype(np.float64)
_I64 = np.dtype(np.int64)
_P = c_void_p

_lib = None
_lib_lock = threading.Lock()


def work_size(nf: int) -> int:
    """FFX_REFRAME_WORK_SIZE(nf): doubles of workspace of the steps and output kernels."""
    return 256 + 64 * nf


def _declare(lib) -> None:
    f = lib.ffx_reframe_steps
    f.argtypes = [_P, _P, c_int, _P, _P, c_int, c_int, _P, c_int, POINTER(c_double), c_double, c_int, _P,
                  POINTER(c_int), _P]
    f.restype = c_int
    arr = [_P, _P, c_int, _P, c_int, c_int, _P, _P, _P, c_int, _P, c_int, c_int, _P, c_int, _P, _P, c_int,
           _P, _P, c_int, _P, _P]
    lib.ffx_reframe_outputs.argtypes = arr
    lib.ffx_reframe_outputs.restype = None
    lib.ffx_reframe_max_node_norm.argtypes = [_P, c_int, c_int, c_int, _P, c_int, _P, _P, c_int, _P, _P, c_int,
                                              _P, c_int]
    lib.ffx_reframe_max_node_norm.restype = c_double
    lib.ffx_reframe_bound.argtypes = [_P, _P, c_int, _P, c_int, c_double]
    lib.ffx_reframe_bound.restype = c_double
    lib.ffx_reframe_block_norm.argtypes = [_P, c_int, c_int, c_int, _P, c_int, c_int, _P, c_int, c_double]
    lib.ffx_reframe_block_norm.restype = c_double
    lib.ffx_reframe_offsets.argtypes = [c_int, _P]
    lib.ffx_reframe_offsets.restype = None
    lib.ffx_reframe_rodrigues.argtypes = [_P, _P]
    lib.ffx_reframe_rodrigues.restype = None
    lib.ffx_reframe_rate_coefficient.argtypes = [c_double]
    lib.ffx_reframe_rate_coefficient.restype = c_double
    lib.ffx_reframe_solve3.argtypes = [_P, _P, _P]
    lib.ffx_reframe_solve3.restype = None
    lib.ffx_reframe_quaternion.argtypes = [_P, _P]
    lib.ffx_reframe_quaternion.restype = None
    lib.ffx_reframe_exponential_coefficients.argtypes = [c_int, _P, _P, c_double, _P, _P]
    lib.ffx_reframe_exponential_coefficients.restype = c_int
    lib.ffx_reframe_abi_version.argtypes = []
    lib.ffx_reframe_abi_version.restype = c_int


def library() -> ctypes.CDLL:
    """The compiled kernels (flexfmu.native.compiler.load_kernels: compiled once per source digest into the
    user cache).  Raises flexfmu.native.compiler.CompilerError when there is no compiler and no cached build."""
    global _lib, _steps_fn, _outputs_fn, _max_fn
    if _lib is None:
        with _lib_lock:
            if _lib is None:
                lib = load_kernels("reframe_kernels", SOURCES)
                _declare(lib)
                version = lib.ffx_reframe_abi_version()
                if version != ABI_VERSION:
                    raise RuntimeError(f"reframe_kernels: library ABI {version}, bindings expect {ABI_VERSION}")
                # the per-call entry points without argtypes (ctypes converts half as fast with them): the
                # bindings pass only ctypes objects, None and Python ints
                steps, outputs, search = (lib[name] for name in ("ffx_reframe_steps", "ffx_reframe_outputs",
                                                                  "ffx_reframe_max_node_norm"))
                steps.restype, outputs.restype, search.restype = c_int, None, c_double
                _steps_fn, _outputs_fn, _max_fn = steps, outputs, search
                _lib = lib
    return _lib


_steps_fn = _outputs_fn = _max_fn = None


# --------------------------------------------------------------------------- buffers
_DBL: dict[int, type] = {}


def _dbl(n: int) -> type:
    """ctypes type double[n] (cached: making array types is slow)."""
    t = _DBL.get(n)
    if t is None:
        t = _DBL[n] = c_double * max(n, 1)
    return t


class _Thread(threading.local):
    """Per-thread workspace and scalar in/out arguments (the C functions run without the GIL):
    ``slot`` = (nf the workspace fits, workspace, t, pointer to t, steps done, pointer to it)."""

    def __init__(self):
        t, done = c_double(), c_int()
        self.slot = (-1, None, t, ctypes.pointer(t), done, ctypes.pointer(done))

    def grow(self, nf: int):
        _, _, t, t_ptr, done, done_ptr = self.slot
        self.slot = (nf, _dbl(work_size(nf))(), t, t_ptr, done, done_ptr)
        return self.slot


_tls = _Thread()


def _conforming(a, dtype=_F64) -> bool:
    return isinstance(a, np.ndarray) and a.dtype == dtype and a.flags.c_contiguous


def _f64(a, name: str, size=None):
    """a as a C-contiguous float64 array, checked (the slow path; the cached path never calls it)."""
    arr = np.ascontiguousarray(a, dtype=_F64)
    if size is not None and arr.size != size:
        raise ValueError(f"reframe kernels: {name} has {arr.size} values, expected {size}")
    return arr


def _as_buffer(a, n: int, name: str):
    """A fresh ctypes double[n] holding the values of a (n of them; the helpers' path, not the kernels')."""
    return _dbl(n).from_buffer_copy(_f64(a, name, n))


def _pointer(a):
    """c_void_p of a's data, None (NULL) for None or an empty array."""
    return None if a is None or a.size == 0 else c_void_p(a.ctypes.data)


def _param_size(nf: int) -> int:
    return 85 + 20 * nf + 12 * nf * nf


def _model(P, LP, G, EX, nf: int):
    """Checked (P, LP, G, EX pointers, n_loads) of conforming arrays (G, EX: None or non-empty)."""
    if P.size != _param_size(nf):
        raise ValueError(f"reframe kernels: P has {P.size} values, expected {_param_size(nf)} for nf = {nf}")
    stride = 5 + 6 * nf
    n_loads, rest = divmod(LP.size, stride)
    if rest:
        raise ValueError(f"reframe kernels: LP has {LP.size} values, not a multiple of 5 + 6 nf = {stride}")
    if G is not None and G.size != 9 * nf * nf:
        raise ValueError(f"reframe kernels: G has {G.size} values, expected 9 nf^2 = {9 * nf * nf}")
    if EX is not None and EX.size != 24 * nf:
        raise ValueError(f"reframe kernels: EX has {EX.size} values, expected 24 nf = {24 * nf}")
    return _pointer(P), _pointer(LP), _pointer(G), _pointer(EX), n_loads


#: the model arrays' checked pointers per combination of arrays (keyed by their ids).  An entry holds the
#: small model arrays themselves, so their ids cannot be reused while it lives, and weak references to the
#: large ones (Psi, order), checked on every hit; at most _MAX_ENTRIES entries (cleared when full).
_MAX_ENTRIES = 32
_steps_cache: dict = {}
_outputs_cache: dict = {}
_search_cache: dict = {}


def _remember(cache: dict, key, entry):
    if len(cache) >= _MAX_ENTRIES:
        cache.clear()
    cache[key] = entry
    return entry


class _Steps:
    __slots__ = ("keep", "nf", "P", "LP", "G", "EX", "n_loads", "tail", "Y", "ny", "last_sv", "seen", "SV1")

    def __init__(self, P, LP, G, EX, nf):
        nf = int(nf)
        self.keep = (P, LP, G, EX)
        self.nf = nf
        self.P, self.LP, self.G, self.EX, self.n_loads = _model(P, LP, G, EX, nf)
        self.tail = (3, self.n_loads, 6)
        self.ny = 24 + 2 * nf
        self.Y = _dbl(self.ny)
        self.last_sv = (None, None, 0)
        self.seen = None
        self.SV1 = _dbl(18 * self.n_loads)


def _steps_entry(P, LP, G, EX, nf):
    if all(a is None or _conforming(a) for a in (P, LP, G, EX)):
        return _remember(_steps_cache, (id(P), id(LP), id(G), id(EX), nf), _Steps(P, LP, G, EX, nf))
    return _Steps(*(None if a is None else _f64(a, "model array") for a in (P, LP, G, EX)), nf)   # not cached


# --------------------------------------------------------------------------- steps
def reframe_steps(P, LP, G, EX, nf, deformed, SV, held, t, dt, n, y):
    """n steps from state y at time t (as flexfmu.reframe.kernels_numpy.reframe_steps): (new y, new t, steps
    done, status), status 0 ok, 1 the loads of step ``steps done`` are not finite, 2 its state is not finite."""
    if G is not None and G.size == 0:
        G = None
    if EX is not None and EX.size == 0:
        EX = None
    e = _steps_cache.get((id(P), id(LP), id(G), id(EX), nf))
    if e is None:
        if _steps_fn is None:
            library()
        e = _steps_entry(P, LP, G, EX, nf)
    if n.__class__ is not int:
        n = int(n)
    if e.n_loads:
        last = e.last_sv                          # (SV, its address, rows) remembered: held loads are one
        if last[0] is SV:                         # array updated in place
            sv = last[1]
        elif SV.__class__ is np.ndarray and SV.dtype is _F64 and SV.ndim == 4 and SV.shape[0] == 1 \
                and SV.shape[1:] == e.tail and SV.flags.c_contiguous and e.seen is not SV:
            sv = e.SV1.from_buffer_copy(SV)       # one row seen first: copied (cheaper than its address);
            e.seen = SV                           # its address is remembered if it comes again
            last = (SV, sv, 1)
        else:
            last = _loads_pointer(SV, e)          # (also keeps a converted copy alive during the call)
            sv = last[1]
        if not held and last[2] < n:
            raise ValueError(f"reframe kernels: SV has {last[2]} rows for {n} steps")
    else:
        sv = None
    if y.__class__ is np.ndarray and y.dtype is _F64 and y.size == e.ny and y.flags.c_contiguous:
        buf = e.Y.from_buffer_copy(y)
    else:
        buf = e.Y.from_buffer_copy(_f64(y, "y", e.ny))
    slot = _tls.slot
    if slot[0] < e.nf:
        slot = _tls.grow(e.nf)
    t_obj = slot[2]
    t_obj.value = t
    status = _steps_fn(e.P, e.LP, e.n_loads, e.G, e.EX, e.nf, 1 if deformed else 0, sv, 1 if held else 0,
                       slot[3], c_double(dt), n, buf, slot[5], slot[1])
    return np.frombuffer(buf, _F64), t_obj.value, slot[4].value, status


def _loads_pointer(SV, e):
    """(SV, its address, rows) of the load values SV after checks (C-contiguous float64 (rows, 3, n_loads, 6),
    else converted: then the copy in place of SV, not remembered); remembered in the entry for the next call."""
    if SV.__class__ is np.ndarray and SV.dtype == _F64 and SV.flags.c_contiguous:
        arr = SV
    else:
        arr = _f64(SV, "SV")
    if arr.ndim != 4 or arr.shape[1:] != e.tail or arr.shape[0] < 1:
        raise ValueError(f"reframe kernels: SV of shape {arr.shape} for {e.n_loads} loads")
    found = (arr, c_void_p(arr.ctypes.data), int(arr.shape[0]))
    if arr is SV:
        e.last_sv = found
    return found


def consistent_steps(P, LP, nf, deformed, SV, held, t, dt, n, y):
    """:func:`reframe_steps` of the consistent scheme without geometric stiffness."""
    return reframe_steps(P, LP, None, None, nf, deformed, SV, held, t, dt, n, y)


# --------------------------------------------------------------------------- outputs
class _Search:
    """Checked pointers of the max-displacement search's arrays; n_nodes = 0 (an empty order): the search is
    skipped and the pointers are NULL."""

    __slots__ = ("keep", "refs", "args", "cols", "dpn")

    def __init__(self, Psi, dpn, order, bc, br, sc, sr, nf, cached=True):
        # cached: small arrays held, the large ones (Psi, order) weakly (checked on every hit); converted copies
        # (not cached): all held, for the call
        self.keep = (bc, br, sc, sr) if cached else (bc, br, sc, sr, Psi, order)
        self.refs = (weakref.ref(Psi), weakref.ref(order))
        self.dpn = dpn
        n_nodes = int(order.shape[0])
        if n_nodes == 0:
            self.cols = 0
            self.args = (None, 0, int(dpn), None, 0, None, None, 0, None, None, 0)
            return
        if Psi.ndim != 2 or Psi.shape[1] < N_RIGID + nf:
            raise ValueError(f"reframe kernels: Psi of shape {Psi.shape} for {nf} flexible modes")
        if int(order.min()) < 0 or int(dpn) * int(order.max()) + 2 >= Psi.shape[0]:
            raise ValueError("reframe kernels: node order outside Psi")
        n_blocks, n_super = int(bc.shape[0]), int(sc.shape[0])
        if bc.size != n_blocks * 3 * nf or br.size != n_blocks or sc.size != n_super * 3 * nf \
                or sr.size != n_super or n_blocks != -(-n_nodes // BLOCK) or n_super != -(-n_blocks // BLOCK):
            raise ValueError("reframe kernels: max-displacement blocks of inconsistent shapes")
        self.cols = int(Psi.shape[1])
        self.args = (_pointer(Psi), self.cols, int(dpn), _pointer(order), n_nodes, _pointer(bc), _pointer(br),
                     n_blocks, _pointer(sc), _pointer(sr), n_super)


def _search(Psi, dpn, order, bc, br, sc, sr, nf):
    """The checked search arrays (_Search: its ``args`` are the C arguments Psi .. n_super), remembered per
    combination when they conform, else converted for this call."""
    key = (id(Psi), dpn, id(order), id(bc), id(br), id(sc), id(sr), nf)
    e = _search_cache.get(key)
    if e is not None and e.refs[0]() is Psi and e.refs[1]() is order:
        return e
    if all(_conforming(a) for a in (Psi, bc, br, sc, sr)) and _conforming(order, _I64):
        return _remember(_search_cache, key, _Search(Psi, dpn, order, bc, br, sc, sr, nf))
    return _Search(_f64(Psi, "Psi"), dpn, np.ascontiguousarray(order, dtype=_I64),            # not cached
                   *(_f64(a, "blocks") for a in (bc, br, sc, sr)), nf, cached=False)


class _Outputs:
    __slots__ = ("keep", "nf", "P", "LP", "G", "n_loads", "PP", "n_points", "SV", "Y", "ny", "OUT", "n_out",
                 "last_search")

    def __init__(self, P, LP, G, PP, nf):
        nf = int(nf)
        self.keep = (P, LP, G, PP)
        self.nf = nf
        self.P, self.LP, self.G, _, self.n_loads = _model(P, LP, G, None, nf)
        if PP.size % (3 + 3 * nf):
            raise ValueError(f"reframe kernels: PP has {PP.size} values, not a multiple of 3 + 3 nf")
        self.n_points = PP.size // (3 + 3 * nf)
        self.PP = _pointer(PP)
        self.SV = _dbl(6 * self.n_loads) if self.n_loads else None
        self.ny = 24 + 2 * nf
        self.Y = _dbl(self.ny)
        self.n_out = 23 + 2 * nf + 18 * self.n_points
        self.OUT = _dbl(self.n_out)
        self.last_search = None


def _outputs_entry(P, LP, G, PP, nf):
    if all(a is None or _conforming(a) for a in (P, LP, G, PP)):
        return _remember(_outputs_cache, (id(P), id(LP), id(G), id(PP), nf), _Outputs(P, LP, G, PP, nf))
    return _Outputs(*(None if a is None else _f64(a, "model array") for a in (P, LP, G, PP)), nf)   # not cached


def reframe_outputs(P, LP, G, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    """All outputs of state y with load values sv (n_loads, 6) (as flexfmu.reframe.kernels_numpy.reframe_outputs;
    an empty ``order`` skips the max elastic displacement search: NOT_COMPUTED = -1 in its place)."""
    if G is not None and G.size == 0:
        G = None
    e = _outputs_cache.get((id(P), id(LP), id(G), id(PP), nf))
    if e is None:
        if _outputs_fn is None:
            library()
        e = _outputs_entry(P, LP, G, PP, nf)
    s = e.last_search                             # the previous call's search arrays, else looked up
    if s is None or s.refs[0]() is not Psi or s.refs[1]() is not order or s.keep[0] is not bc or s.keep[1] is not br \
            or s.keep[2] is not sc or s.keep[3] is not sr or s.dpn != dpn:
        s = e.last_search = _search(Psi, dpn, order, bc, br, sc, sr, e.nf)
    if e.n_loads:
        try:
            if sv.__class__ is not np.ndarray or sv.dtype is not _F64 or sv.size != 6 * e.n_loads:
                raise TypeError
            svb = e.SV.from_buffer_copy(sv)
        except (TypeError, ValueError, BufferError):
            svb = e.SV.from_buffer_copy(_f64(sv, "sv", 6 * e.n_loads))
    else:
        svb = None
    if y.__class__ is np.ndarray and y.dtype is _F64 and y.size == e.ny and y.flags.c_contiguous:
        yb = e.Y.from_buffer_copy(y)
    else:
        yb = e.Y.from_buffer_copy(_f64(y, "y", e.ny))
    out = e.OUT()
    slot = _tls.slot
    if slot[0] < e.nf:
        slot = _tls.grow(e.nf)
    _outputs_fn(e.P, e.LP, e.n_loads, e.G, e.nf, 1 if deformed else 0, svb, yb, e.PP, e.n_points, *s.args, out,
                slot[1])
    return np.frombuffer(out, _F64)


def consistent_outputs(P, LP, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr):
    """:func:`reframe_outputs` without geometric stiffness."""
    return reframe_outputs(P, LP, None, nf, deformed, sv, y, PP, Psi, dpn, order, bc, br, sc, sr)


# --------------------------------------------------------------------------- search and helpers
def max_node_norm(Psi, col, dpn, order, bc, br, sc, sr, q):
    """max over nodes i of |Phi_i q| (as flexfmu.reframe.kernels_numpy.max_node_norm_numpy), by the block bounds."""
    q = np.asarray(q)
    nf = int(q.shape[0])
    if nf == 0:
        return 0.0
    if order.shape[0] == 0:
        raise ValueError("reframe kernels: max_node_norm needs the node order (not empty)")
    if _max_fn is None:
        library()
    s = _search(Psi, dpn, order, bc, br, sc, sr, nf)
    if col < 0 or col + nf > s.cols:
        raise ValueError(f"reframe kernels: columns {col} .. {col + nf - 1} outside Psi")
    a = s.args
    return _max_fn(a[0], a[1], int(col), a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10],
                   _dbl(nf).from_buffer_copy(_f64(q, "q", nf)), nf)


def offsets(nf: int) -> tuple:
    """Start offsets of P's blocks (J0, A, B, C, D, k, c, A6, A6inv, com, end)."""
    out = (c_int * 11)()
    library().ffx_reframe_offsets(int(nf), out)
    return tuple(out)


def rodrigues(phi) -> np.ndarray:
    """exp(skew(phi)), row-major (9,), by the C kernels' ffx_reframe_rodrigues (the C twin of
    flexfmu.core.rotation.rodrigues_into, for the tests that compare the two)."""
    R = _dbl(9)()
    library().ffx_reframe_rodrigues(_as_buffer(phi, 3, "phi"), R)
    return np.frombuffer(R, _F64, 9)


def rate_coefficient(theta: float) -> float:
    """c(theta) of Eq. (22) by ffx_reframe_rate_coefficient (the C twin of
    flexfmu.core.rotation.rotvec_rate_coefficient)."""
    return library().ffx_reframe_rate_coefficient(float(theta))


def solve3(S, r) -> np.ndarray:
    """S x = r for a 3x3 S."""
    x = _dbl(3)()
    library().ffx_reframe_solve3(_as_buffer(S, 9, "S"), _as_buffer(r, 3, "r"), x)
    return np.frombuffer(x, _F64, 3)


def quaternion(R) -> np.ndarray:
    """(w, x, y, z), w >= 0, of the body -> global rotation matrix R, by the C kernels' ffx_reframe_quaternion
    (the C twin of flexfmu.core.rotation.quaternion_from_rotation, for the tests that compare the two)."""
    out = _dbl(4)()
    library().ffx_reframe_quaternion(_as_buffer(R, 9, "R"), out)
    return np.frombuffer(out, _F64, 4)


def bound(C, r, b, q, qn) -> float:
    """Upper bound of |Phi_i q| over (super)block b (flexfmu.reframe.kernels_numpy._bound)."""
    q = np.asarray(q)
    nf = int(q.shape[0])
    C = _f64(C, "C")
    r = _f64(r, "r")
    if not 0 <= b < r.size or C.size != r.size * 3 * nf:
        raise ValueError("reframe kernels: block index or block data of inconsistent shape")
    return library().ffx_reframe_bound(C.ctypes.data, r.ctypes.data, int(b), _as_buffer(q, nf, "q"), nf, float(qn))


def block_norm(Psi, col, dpn, order, b, q, best) -> float:
    """max(best, |Phi_i q| over the nodes of block b) (flexfmu.reframe.kernels_numpy._block_norm)."""
    q = np.asarray(q)
    nf = int(q.shape[0])
    Psi = _f64(Psi, "Psi")
    order = np.ascontiguousarray(order, dtype=_I64)
    if Psi.ndim != 2 or col + nf > Psi.shape[1] or (order.size and int(dpn) * int(order.max()) + 2 >= Psi.shape[0]):
        raise ValueError("reframe kernels: Psi, col, dpn and order of inconsistent shapes")
    return library().ffx_reframe_block_norm(Psi.ctypes.data, int(Psi.shape[1]), int(col), int(dpn), order.ctypes.data,
                                            int(order.size), int(b), _as_buffer(q, nf, "q"), nf, float(best))


#: FFX_REFRAME_EXPONENTIAL_WORK_SIZE
EXPONENTIAL_WORK_SIZE = 128 + 536


def exponential_coefficients(stiffness, damping, dt: float) -> np.ndarray:
    """flexfmu.reframe.schemes.exponential_coefficients (shape (nf, 6, 2, 2)) by the C port
    (ffx_reframe_exponential_coefficients); ParameterError when a coefficient is not finite."""
    from flexfmu.errors import ParameterError

    k = np.ascontiguousarray(stiffness, dtype=float).reshape(-1)
    c = np.ascontiguousarray(damping, dtype=float).reshape(-1)
    nf = k.size
    if c.size != nf:
        raise ParameterError("damping", f"{c.size} values for {nf} modes", "one per mode")
    out = np.zeros((nf, 6, 2, 2))
    if nf == 0:
        return out
    work = np.empty(EXPONENTIAL_WORK_SIZE)
    status = library().ffx_reframe_exponential_coefficients(nf, k.ctypes.data, c.ctypes.data, float(dt),
                                                            out.ctypes.data, work.ctypes.data)
    if status != 0 or not np.all(np.isfinite(out)):
        raise ParameterError("dt", f"{dt!r} s gives non-finite exponential propagators", "a finite time step > 0 (s)")
    return out
