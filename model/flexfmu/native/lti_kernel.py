"""The C kernel of flexfmu.native.lti's models (csrc/lti_kernels.c) through ctypes: the compiled library, its
matrix exponential, the step and outputs of an LtiModel (LtiKernel) and a minimal simulator on them (LtiSimulator).
The structures mirror csrc/lti_kernels.h; the derived outputs (flexfmu.native.lti_derived) are evaluated after the
others by csrc/derived_stress.c, as the native FMU does.  The model is an flexfmu.native.lti.LtiModel, which imports
this module (so this one names it without importing it)."""
from __future__ import annotations

import ctypes
import math

import numpy as np

from flexfmu.errors import NonFiniteError, ParameterError
from flexfmu.native.compiler import CSRC, load_kernels

SOURCES = (CSRC / "lti_kernels.c", CSRC / "derived_stress.c")
OK, NONFINITE, SINGULAR, BAD_ARGUMENT = 0, 1, 2, 3


# ---------------------------------------------------------------------------------------------- ctypes
_dp = ctypes.POINTER(ctypes.c_double)
_ip = ctypes.POINTER(ctypes.c_int)


class _Model(ctypes.Structure):
    _fields_ = [("nx", ctypes.c_int), ("nu", ctypes.c_int), ("ny", ctypes.c_int), ("np", ctypes.c_int),
                ("nmono", ctypes.c_int), ("A", _dp), ("B", _dp), ("b", _dp), ("Cx", _dp), ("Cu", _dp), ("y0", _dp),
                ("nquad", ctypes.c_int), ("quad_row", _ip), ("quad_i", _ip), ("quad_j", _ip), ("quad_value", _dp),
                ("quad_start", _ip)]  # NULL here: the outputs are computed whole


class _Maps(ctypes.Structure):
    _fields_ = [("model", ctypes.POINTER(_Model)), ("step_valid", ctypes.c_int), ("output_valid", ctypes.c_int),
                ("h", ctypes.c_double), ("p_step", _dp), ("p_output", _dp), ("Ad", _dp), ("Bd", _dp), ("bd", _dp),
                ("Cx", _dp), ("Cu", _dp), ("y0", _dp), ("z", _dp), ("mono", _dp), ("x_new", _dp), ("aug", _dp),
                ("expm_work", _dp), ("n_step_updates", ctypes.c_long), ("n_output_updates", ctypes.c_long),
                # the moving-base step (flexfmu.native.lti_taylor)
                ("weights", _dp), ("norms", _dp), ("used", _dp), ("A_held", _dp), ("g_held", _dp),
                ("p_taylor", _dp), ("mono_before", _dp), ("a_cols", _dp), ("taylor_h", ctypes.c_double),
                ("taylor_substeps", ctypes.c_int), ("taylor_terms", ctypes.c_int), ("taylor_ready", ctypes.c_int),
                ("taylor_last", ctypes.c_int), ("n_taylor_steps", ctypes.c_long)]


def library() -> ctypes.CDLL:
    """The compiled lti kernels (flexfmu.native.compiler: cached per source digest), prototypes declared; pointer
    arguments as void * (pass array addresses as ints on the per-step path: ~1 us a call)."""
    lib = load_kernels("lti", SOURCES)
    if not getattr(lib, "_ffx_lti_declared", False):
        c_int, c_double, c_size, c_long, vp = (ctypes.c_int, ctypes.c_double, ctypes.c_size_t, ctypes.c_long,
                                               ctypes.c_void_p)
        for name, res, args in (
                ("ffx_lti_check_model", c_int, [vp]),
                ("ffx_lti_monomials", None, [c_int, vp, vp]),
                ("ffx_lti_assemble_dynamics", None, [vp, vp, vp, vp, vp]),
                ("ffx_lti_assemble_outputs", None, [vp, vp, vp, vp, vp]),
                ("ffx_lti_expm_work_len", c_size, [c_int]),
                ("ffx_lti_expm", c_int, [c_int, vp, vp, vp]),
                ("ffx_lti_maps_work_len", c_size, [vp]),
                ("ffx_lti_maps_init", c_int, [vp, vp, vp, c_size]),
                ("ffx_lti_maps_invalidate", None, [vp]),
                ("ffx_lti_update_step_maps", c_int, [vp, vp, c_double]),
                ("ffx_lti_update_output_maps", c_int, [vp, vp]),
                ("ffx_lti_step", c_int, [vp, vp, c_double, vp, vp, vp]),
                ("ffx_lti_steps", c_int, [vp, vp, c_double, c_long, vp, vp, vp]),
                ("ffx_lti_outputs", c_int, [vp, vp, vp, vp, vp]),
                ("ffx_lti_output_rows", c_int, [vp, vp, vp, vp, vp, c_int, vp]),
                ("ffx_lti_quad_starts", c_int, [vp, vp]),
                ("ffx_lti_balance", None, [c_int, vp, vp]),
                ("ffx_lti_taylor_plan", c_int, [c_double, vp, vp]),
                ("ffx_lti_taylor_tail", c_double, [c_double, c_int]),
                ("ffx_lti_taylor_prepare", c_int, [vp, vp, vp, c_double, c_long, vp]),
                ("ffx_lti_taylor_steps", c_int, [vp, c_long, vp, vp]),
                ("ffx_lti_steps_held", c_int, [vp, vp, vp, c_double, c_long, vp, vp, vp]),
                ("ffx_lti_status_string", ctypes.c_char_p, [c_int]),
                ("ffx_derived_evaluate", None, [c_int, vp, vp, vp, vp, vp, vp, vp]),
                ("ffx_derived_directional", None, [c_int, vp, vp, vp, vp, vp, vp, vp]),
                ("ffx_derived_check", c_int, [c_int, vp, vp, vp, vp, vp, c_int, vp, vp]),
                ("ffx_von_mises", c_double, [vp]),
                ("ffx_section_sigma_max", c_double, [c_int, vp, c_double, c_double, c_double]),
                ("ffx_section_von_mises", c_double, [c_int, vp, c_double, c_double, c_double, c_double])):
            f = getattr(lib, name)
            f.restype, f.argtypes = res, args
        lib._ffx_lti_declared = True
    return lib


def _ptr(a: np.ndarray, kind=_dp):
    return a.ctypes.data_as(kind)


def expm(M) -> np.ndarray:
    """The C kernel's matrix exponential (ffx_lti_expm) of a square matrix."""
    lib = library()
    M = np.ascontiguousarray(M, dtype=np.float64)
    n = M.shape[0]
    if M.ndim != 2 or M.shape != (n, n):
        raise ParameterError("M", f"shape {M.shape}", "square")
    E = np.empty_like(M)
    work = np.empty(max(1, lib.ffx_lti_expm_work_len(n)))
    status = lib.ffx_lti_expm(n, M.ctypes.data, E.ctypes.data, work.ctypes.data)
    if status != OK:
        raise NonFiniteError("M", f"expm: {lib.ffx_lti_status_string(status).decode()}")
    return E


class LtiKernel:
    """The C step and outputs of an LtiModel, the maps cached in the kernel for the last (p, h).  Arguments are
    copied into buffers the C side reads (``x``, ``u``, ``p``), so a call costs a few microseconds."""

    def __init__(self, model):
        self.model = model
        self.lib = lib = library()
        self._arrays = model.arrays()                   # kept alive: the struct points into them
        a = self._arrays
        self._model = _Model(model.nx, model.nu, model.ny, model.np, model.nmono, _ptr(a["A"]), _ptr(a["B"]),
                             _ptr(a["b"]), _ptr(a["Cx"]), _ptr(a["Cu"]), _ptr(a["y0"]), model.nquad,
                             _ptr(a["quad_row"], _ip), _ptr(a["quad_i"], _ip), _ptr(a["quad_j"], _ip),
                             _ptr(a["quad_value"]))
        self._model_addr = ctypes.addressof(self._model)
        if lib.ffx_lti_check_model(self._model_addr) != OK:
            raise ParameterError("model", "inconsistent sizes or quadratic-term indices", "lti_kernels.h's layout")
        n = lib.ffx_lti_maps_work_len(self._model_addr)
        self._work = np.zeros(max(1, n))
        self._maps = _Maps()
        self._maps_addr = ctypes.addressof(self._maps)
        status = lib.ffx_lti_maps_init(self._maps_addr, self._model_addr, self._work.ctypes.data, n)
        if status != OK:
            raise ParameterError("model", lib.ffx_lti_status_string(status).decode())
        # argument buffers (at least one element: a valid address even when empty)
        self.x, self.u, self.p = (np.zeros(max(1, k)) for k in (model.nx, model.nu, model.np))
        self.p_before = np.zeros(max(1, model.np))       # the p the step before held (steps_held, advance_held)
        self._x_next, self._y = np.zeros(max(1, model.nx)), np.zeros(max(1, model.ny))
        self._ax, self._au, self._ap, self._axn, self._ay = (b.ctypes.data for b in (self.x, self.u, self.p,
                                                                                     self._x_next, self._y))
        self._apb = self.p_before.ctypes.data
        self._step, self._outputs = lib.ffx_lti_steps, lib.ffx_lti_outputs
        self._step_held = lib.ffx_lti_steps_held
        self._nx, self._ny = model.nx, model.ny
        # the derived outputs: (n, kind, shape, output, sources, fibres) as ffx_derived_evaluate takes them
        self._derived = None
        if model.derived:
            self._derived = (len(model.derived), *(a[f"derived_{k}"].ctypes.data for k in ("kind", "shape", "output",
                                                                                          "sources", "fibres")))

    def _load(self, x, u, p) -> None:
        m = self.model
        for buf, value, n, name in ((self.x, x, m.nx, "x"), (self.u, u, m.nu, "u"), (self.p, p, m.np, "p")):
            if value is None:
                continue
            if np.shape(value) != (n,):
                raise ParameterError(name, f"shape {np.shape(value)}", f"({n},)")
            buf[:n] = value

    def _fail(self, status: int, what: str):
        text = self.lib.ffx_lti_status_string(status).decode()
        if status == BAD_ARGUMENT:
            return ParameterError(what, text)
        return NonFiniteError(what, text)

    def step(self, x, u, p, h: float) -> np.ndarray:
        """x after one exact step h with u and p held (x, u, p: arrays of nx, nu, np)."""
        return self.steps(x, u, p, h, 1)

    def steps(self, x, u, p, h: float, n: int) -> np.ndarray:
        """x after n such steps."""
        self._load(x, u, p)
        status = self._step(self._maps_addr, self._ap, h, n, self._ax, self._au, self._axn)
        if status != OK:
            raise self._fail(status, "step_size" if status == BAD_ARGUMENT else "state")
        return self._x_next[:self._nx].copy()

    def steps_held(self, x, u, p_before, p, h: float, n: int = 1) -> np.ndarray:
        """x after n steps h with u and p held after a step that held p_before (ffx_lti_steps_held: the series
        for base motion that moves by little, else the maps; flexfmu.native.lti_taylor's rule)."""
        self._load(x, u, p)
        self._load_before(p_before)
        status = self._step_held(self._maps_addr, self._apb, self._ap, h, n, self._ax, self._au, self._axn)
        if status != OK:
            raise self._fail(status, "step_size" if status == BAD_ARGUMENT else "state")
        return self._x_next[:self._nx].copy()

    def _load_before(self, p_before) -> None:
        n = self.model.np
        if np.shape(p_before) != (n,):
            raise ParameterError("p_before", f"shape {np.shape(p_before)}", f"({n},)")
        self.p_before[:n] = p_before

    def advance_held(self, h: float, n: int = 1) -> None:
        """advance, with the buffer p_before as the p of the step before (ffx_lti_steps_held)."""
        status = self._step_held(self._maps_addr, self._apb, self._ap, h, n, self._ax, self._au, self._ax)
        if status != OK:
            raise self._fail(status, "step_size" if status == BAD_ARGUMENT else "state")

    def advance(self, h: float, n: int = 1) -> None:
        """The buffers' x after n steps h with the buffers' u and p, in place (the per-step path of a simulator)."""
        status = self._step(self._maps_addr, self._ap, h, n, self._ax, self._au, self._ax)
        if status != OK:
            raise self._fail(status, "step_size" if status == BAD_ARGUMENT else "state")

    def outputs(self, x=None, u=None, p=None) -> np.ndarray:
        """y for (x, u, p); None: the buffer's value."""
        if x is not None or u is not None or p is not None:
            self._load(x, u, p)
        status = self._outputs(self._maps_addr, self._ap, self._ax, self._au, self._ay)
        if status != OK:
            raise self._fail(status, "outputs")
        if self._derived is not None:
            self.lib.ffx_derived_evaluate(*self._derived, None, self._ay)
        return self._y[:self._ny].copy()

    def step_maps(self, p, h: float):
        """Copies of (Ad, Bd, bd) of (p, h)."""
        m = self.model
        self._load(None, None, p)
        status = self.lib.ffx_lti_update_step_maps(self._maps_addr, self._ap, float(h))
        if status != OK:
            raise self._fail(status, "step maps")
        mp = self._maps
        view = lambda ptr, n: np.ctypeslib.as_array(ptr, shape=(n,)).copy()      # noqa: E731
        return (view(mp.Ad, m.nx * m.nx).reshape(m.nx, m.nx), view(mp.Bd, m.nx * m.nu).reshape(m.nx, m.nu),
                view(mp.bd, m.nx))

    def invalidate(self) -> None:
        self.lib.ffx_lti_maps_invalidate(self._maps_addr)

    @property
    def counters(self) -> tuple[int, int]:
        """(step-map recomputations, output-map recomputations) so far."""
        return int(self._maps.n_step_updates), int(self._maps.n_output_updates)

    @property
    def series_steps(self) -> int:
        """Steps taken by the series (flexfmu.native.lti_taylor) so far."""
        return int(self._maps.n_taylor_steps)

    def weights(self) -> np.ndarray:
        """The series' norm weights d (nx) the kernel balanced A's constant coefficient to."""
        return np.ctypeslib.as_array(self._maps.weights, shape=(self.model.nx,)).copy()


class LtiSimulator:
    """A minimal simulator of an LtiModel on the C kernel (FMU input vector in, outputs out): state x, time t,
    the held inputs and the parameter-fed p (``set_parameter``, e.g. damping_ratio at run time).  Each step knows
    the p the step before held (at construction: the p of the inputs then), as the native FMU's bridge does, so that
    base motion that moves at every step goes by the series (ffx_lti_steps_held)."""

    def __init__(self, model):
        self.model = model
        self.kernel = model.kernel()
        self.t = 0.0
        self._v = np.zeros(len(model.input_names))
        self._params = {n: float(model.p_start[k]) for k, n in enumerate(model.param_names)
                        if model.p_from_input[k] < 0}
        self._split()
        self.kernel.p_before[:model.np] = self.kernel.p[:model.np]

    def _split(self):
        u, p = self.model.split_inputs(self._v, self._params)
        self.kernel._load(None, u, p)

    @property
    def time(self) -> float:
        return self.t

    @property
    def x(self) -> np.ndarray:
        return self.kernel.x[:self.model.nx].copy()

    @x.setter
    def x(self, value) -> None:
        self.kernel._load(value, None, None)

    def set_parameter(self, name: str, value: float) -> None:
        if name not in self._params:
            raise ParameterError(name, "not a parameter of the native model", ", ".join(self._params))
        if not math.isfinite(value):
            raise NonFiniteError(name, f"{value!r}")
        self._params[name] = float(value)
        self._split()

    def set_input_vector(self, values) -> None:
        v = np.asarray(values, dtype=float)
        if v.shape != self._v.shape:
            raise ParameterError("inputs", f"{v.size} values", f"{self._v.size} values")
        if not np.all(np.isfinite(v)):
            raise NonFiniteError(self.model.input_names[int(np.flatnonzero(~np.isfinite(v))[0])], "not finite")
        self._v = v.copy()
        self._split()

    def step(self, h: float) -> None:
        """One exact step h; the state is unchanged on failure (NonFiniteError)."""
        self.kernel.advance_held(h)
        self.kernel.p_before[:] = self.kernel.p
        self.t += h

    def output_vector(self) -> np.ndarray:
        return self.kernel.outputs()
