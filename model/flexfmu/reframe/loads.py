"""Loads of the reframe integrator (:mod:`flexfmu.reframe.integrator`): point loads, their time
histories, and the loads of a run resolved once and gathered at the RK4 stage times for the kernels."""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import ParameterError

__all__ = ["PointLoad", "half_sine_pulse", "constant_load"]


def _finite_vec3(x, name):
    try:
        v = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(name, f"{x!r} is not numeric", "finite 3-vector") from None
    if v.shape != (3,):
        raise ParameterError(name, f"shape {v.shape}", "finite 3-vector")
    if not np.all(np.isfinite(v)):
        raise ParameterError(name, f"{v} contains NaN or Inf", "finite 3-vector")
    return v


_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False


class _History:
    """A load history: callable f(t) -> (3,), a table (times, values) or a constant 3-vector."""

    def __init__(self, spec, name):
        self.name = name
        self.kind = None
        if spec is None:
            self.kind = "zero"
        elif callable(spec):
            self.kind = "callable"
            self.fn = spec
        elif isinstance(spec, tuple) and len(spec) == 2:
            times = np.asarray(spec[0], dtype=float)
            values = np.asarray(spec[1], dtype=float)
            if times.ndim != 1 or values.shape != (times.size, 3) or times.size < 1:
                raise ParameterError(name, f"table shapes {times.shape}, {values.shape}",
                                     "(times (k,), values (k, 3)) with k >= 1")
            if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
                raise ParameterError(name, "table contains NaN or Inf", "finite times and values")
            if np.any(np.diff(times) <= 0.0):
                raise ParameterError(name, "table times not strictly increasing", "strictly increasing times")
            self.kind = "table"
            self.times, self.values = times, values
        else:
            self.kind = "constant"
            self.value = _finite_vec3(spec, name)

    @classmethod
    def held(cls, value: np.ndarray, name: str) -> "_History":
        """A constant history of a finite float (3,) array that the caller has checked (the per-step input
        path of a co-simulation: no checks, no conversion)."""
        h = cls.__new__(cls)
        h.name, h.kind, h.value = name, "constant", value
        return h

    @property
    def constant(self) -> bool:
        """True for a zero or constant history (its value does not depend on t)."""
        return self.kind in ("zero", "constant")

    def raw(self, t):
        """The value at t without the checks of ``__call__`` (hot loop: the kernel checks finiteness, and
        on any problem the caller re-evaluates through ``__call__`` for the error message)."""
        kind = self.kind
        if kind == "callable":
            return self.fn(t)
        if kind == "constant":
            return self.value
        if kind == "zero":
            return _ZERO3
        return self(t)

    def __call__(self, t):
        if self.kind == "zero":
            return np.zeros(3)
        if self.kind == "constant":
            return self.value
        if self.kind == "table":
            return np.array([np.interp(t, self.times, self.values[:, k]) for k in range(3)])
        try:
            v = np.asarray(self.fn(t), dtype=float)
        except (TypeError, ValueError) as exc:
            raise ParameterError(self.name, f"f({t}) is not numeric ({exc})", "f(t) -> finite (3,)") from None
        if v.shape != (3,):
            raise ParameterError(self.name, f"f({t}) has shape {v.shape}", "f(t) -> finite (3,)")
        if not np.all(np.isfinite(v)):
            raise ParameterError(self.name, f"f({t}) = {v} contains NaN or Inf", "f(t) -> finite (3,)")
        return v


@dataclass
class PointLoad:
    """A force (and on 6-DOF nodes optionally a moment) at one node.

    point:     node index, or coordinates (m, undeformed body frame): the nearest node is loaded.
    force:     N; a callable ``f(t) -> (3,)``, a table ``(times (k,), values (k, 3))`` (linear
               interpolation, end values held outside), a constant 3-vector, or None.
    moment:    N m, same forms; only on models with 6 DOFs per node.
    follower:  False: components in the global frame (fixed direction); True: components in the body
               frame (the load turns with the dummy body).
    """

    point: object
    force: object = None
    moment: object = None
    follower: bool = False


def half_sine_pulse(vector, duration: float, start: float = 0.0):
    """Load history ``vector * sin(pi (t - start)/duration)`` on [start, start + duration], 0 elsewhere.

    Continuous (no jump), so RK4 stage evaluations at the pulse ends are unambiguous; its impulse is
    ``vector * 2 duration / pi``.
    """
    v = _finite_vec3(vector, "vector")
    if not (isinstance(duration, numbers.Real) and math.isfinite(duration) and duration > 0):
        raise ParameterError("duration", f"{duration!r}", "> 0 (s)")
    t0, T = float(start), float(duration)

    def f(t):
        s = (t - t0) / T
        return v * math.sin(math.pi * s) if 0.0 <= s <= 1.0 else np.zeros(3)

    return f


def constant_load(vector):
    """Load history: constant ``vector`` from t = 0 on (a step load switched on at t = 0)."""
    v = _finite_vec3(vector, "vector")
    return lambda t: v


@dataclass
class _ResolvedLoad:
    node: int
    force: _History
    moment: _History
    follower: bool



class _Prepared:
    """Loads resolved once (node lookup, history checks) for a whole run; gathers their values at the RK4
    stage times into one array for the step kernel."""

    def __init__(self, items):
        self.items = items
        self._held = None        # (1, 3, n_loads, 6) values when every history is constant
        self._kernel = None      # (integrator, packed node data) for the consistent-scheme kernel

    @property
    def constant(self) -> bool:
        return all(ld.force.constant and ld.moment.constant for ld in self.items)

    def set_held(self, index: int, force, moment=None, *, checked: bool = False) -> None:
        """Make load ``index`` constant (checked like a PointLoad's constant force / moment): the input held
        over a co-simulation step.  checked=True: force and moment are finite float (3,) arrays already
        (the caller checked them), taken as they are."""
        ld = self.items[index]
        make = _History.held if checked else _History
        ld.force = make(force, "load.force")
        if moment is not None:
            ld.moment = make(moment, "load.moment")
        if self._held is not None:        # every load was constant and still is: update its row in place
            self._held[0, :, index, 0:3] = ld.force.raw(0.0)
            self._held[0, :, index, 3:6] = ld.moment.raw(0.0)

    def stage_values(self, t: float, dt: float, n: int):
        """Force and moment of every load at t_k, t_k + dt/2, t_k + dt (t_0 = t, t_{k+1} = t_k + dt) for
        k < n: ``(values (n, 3, n_loads, 6), False)``; ``(values (1, 3, n_loads, 6), True)`` if constant."""
        if self._held is None and self.constant:
            self._held = self._values([(0.0, 0.0, 0.0)])
        if self._held is not None:
            return self._held, True
        times = []
        for _ in range(n):
            times.append((t, t + 0.5 * dt, t + dt))
            t = t + dt
        return self._values(times), False

    def _values(self, times):
        items = self.items
        if not items:
            return np.zeros((len(times), 3, 0, 6))
        raw = []
        for stage_times in times:
            for ts in stage_times:
                for ld in items:
                    raw.append(ld.force.raw(ts))
                    raw.append(ld.moment.raw(ts))
        try:
            values = np.array(raw, dtype=float)
        except (TypeError, ValueError):
            values = None
        if values is None or values.shape != (len(raw), 3):
            for stage_times in times:
                self.check(stage_times)
            raise ParameterError("load", "load history values of inconsistent shape", "f(t) -> finite (3,)")
        return values.reshape(len(times), 3, len(items), 6)

    def check(self, stage_times) -> None:
        """Evaluate every history at the given times with the full checks (raises ParameterError)."""
        for ts in stage_times:
            for ld in self.items:
                ld.force(ts)
                ld.moment(ts)
