"""The reframe integrator's side of the compiled kernels (flexfmu.reframe.kernels): the model data, loads and
output points it packs for them, the per-dt coefficients it caches, and its calls of the step and output kernels.

:class:`KernelCalls` is a base class of :class:`flexfmu.reframe.integrator.ReframeIntegrator` and is not used on
its own: its methods read what the integrator sets up (``data``, ``stepper``, ``scheme``, ``deformed_load_arm``,
``_Gk``, ``_ex_cache``); the integrator keeps the set-up, the initial conditions, the stepping and the outputs.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flexfmu.errors import FlexfmuError
from flexfmu.core.structure import N_RIGID
from flexfmu.reframe.kernel_data import inertia_invariants, max_displacement_blocks
from flexfmu.reframe.loads import _Prepared
from flexfmu.reframe.results import ReframeState, _state_from_vector, _state_vector

__all__ = ["KernelArguments", "KernelCalls"]


# --------------------------------------------------------------------------- small helpers
def _kernels():
    """flexfmu.reframe.kernels, imported on first use (its kernels load, or compile, the C library on first use)."""
    from flexfmu.reframe import kernels as _reframe_kernels

    return _reframe_kernels


# --------------------------------------------------------------------------- the kernel calls
class KernelArguments(NamedTuple):
    """:meth:`ReframeIntegrator.kernel_arguments`: P, LP, G, EX, PP as in flexfmu.reframe.kernels; Psi the
    modal matrix (C order), dpn DOFs per node; umax (umax_skip) the last five arguments of the output
    kernels with (without) the max-elastic-displacement search."""

    P: np.ndarray
    LP: np.ndarray
    G: np.ndarray
    EX: np.ndarray
    nf: int
    deformed: bool
    PP: np.ndarray
    Psi: np.ndarray
    dpn: int
    umax: tuple
    umax_skip: tuple


class KernelCalls:
    """The kernel calls of :class:`~flexfmu.reframe.integrator.ReframeIntegrator` (see the module docstring)."""

    # ---------------------------------------------------------------- kernel data
    def _exponential(self, dt: float) -> np.ndarray:
        """The scheme's kernel coefficients for dt, flat (exponential: ETD-RK4; cached: the FMU steps with one dt)."""
        EX = self._ex_cache.get(dt)
        if EX is None:
            EX = np.ascontiguousarray(self.stepper.kernel_coefficients(self._kF, self._cF, dt).reshape(-1))
            if len(self._ex_cache) >= 8:
                self._ex_cache.clear()
            self._ex_cache[dt] = EX
        return EX

    def _setup_consistent(self):
        """The kernels' model data: inertia invariants and packed parameters ``_P``
        (:func:`flexfmu.reframe.kernel_data.inertia_invariants`)."""
        inv = inertia_invariants(self.data)
        self._m, self._J0, self._Aj, self._Bsym = inv.m, inv.J0, inv.Aj, inv.Bsym
        self._Cjk, self._Dj, self._kF, self._cF, self._P = inv.Cjk, inv.Dj, inv.kF, inv.cF, inv.P
        self._points_cache = {}

    def _setup_max_displacement(self):
        """Node blocks of the exact max elastic displacement (:func:`flexfmu.reframe.kernel_data.max_displacement_blocks`)."""
        d = self.data
        self._umax = max_displacement_blocks(d, _kernels().BLOCK)
        # the same arguments with an empty node order: the output kernel skips the search
        self._umax_skip = (np.zeros(0, dtype=np.int64),) + self._umax[1:]
        self._Psi_c = np.ascontiguousarray(d.Psi)

    def _max_elastic_displacement(self, q) -> float:
        return float(_kernels().max_node_norm(self._Psi_c, N_RIGID, self.data.dpn, *self._umax,
                                              np.ascontiguousarray(q, dtype=float)))

    def max_elastic_displacement(self, state: ReframeState) -> float:
        """Largest elastic nodal displacement |Phi_i q| over all nodes of ``state``, m (body frame norm): the
        value :meth:`output_vector` leaves out with ``max_elastic=False``."""
        nm = self.data.n_modes
        return self._max_elastic_displacement(state.eta[N_RIGID:nm])

    # ---------------------------------------------------------------- consistent scheme
    def _kernel_loads(self, loads: "_Prepared") -> np.ndarray:
        """Node data of the loads for the step kernel: per load [follower, rotational DOFs, arm (3),
        translational rows of Phi (3 nf), rotational rows (3 nf)]; cached on ``loads``."""
        cached = loads._kernel
        if cached is not None and cached[0] is self:
            return cached[1]
        d = self.data
        nf = d.nf
        blocks = []
        for ld in loads.items:
            rot = d.Phi[d.rot_rows[ld.node]] if d.rot_rows is not None else np.zeros((3, nf))
            blocks.append(np.concatenate([[float(ld.follower), float(d.rot_rows is not None)], d.Xc[ld.node],
                                          d.Phi[d.trans_rows[ld.node]].ravel(), rot.ravel()]))
        LP = np.ascontiguousarray(np.concatenate(blocks) if blocks else np.zeros(0), dtype=float)
        loads._kernel = (self, LP)
        return LP

    def _consistent_steps(self, s: ReframeState, dt: float, n: int, loads: "_Prepared",
                          coefficients_dt: float | None = None) -> ReframeState:
        kern = _kernels()
        LP = self._kernel_loads(loads)
        SV, held = loads.stage_values(s.t, dt, n)
        y0 = _state_vector(s)
        EX = self.stepper.coefficients(dt if coefficients_dt is None else coefficients_dt)
        if EX is None and self._Gk.size == 0:
            y, t, done, status = kern.consistent_steps(self._P, LP, self.data.nf, self.deformed_load_arm, SV, held,
                                                       float(s.t), dt, n, y0)
        else:
            EX = np.zeros(0) if EX is None else EX
            y, t, done, status = kern.reframe_steps(self._P, LP, self._Gk, EX, self.data.nf, self.deformed_load_arm,
                                                    SV, held, float(s.t), dt, n, y0)
        if status == 1:
            loads.check((t, t + 0.5 * dt, t + dt))         # raises the history's ParameterError
        if status:
            raise FlexfmuError(f"reframe: non-finite state at t = {t:.6g} s (scheme {self.scheme!r})")
        return _state_from_vector(t, y)

    def _point_data(self, points: np.ndarray) -> np.ndarray:
        """Output points for the kernel: rows [X - c (3), translational rows of Phi (3 nf)]; cached."""
        key = points.tobytes()
        PP = self._points_cache.get(key)
        if PP is None:
            d = self.data
            PP = np.ascontiguousarray(np.hstack([d.Xc[points], d.Phi[d.trans_rows[points]].reshape(len(points), -1)])
                                      if len(points) else np.zeros((0, 3 + 3 * d.nf)), dtype=float)
            if len(self._points_cache) > 16:
                self._points_cache.clear()
            self._points_cache[key] = PP
        return PP

    def kernel_arguments(self, loads: "_Prepared", dt: float | None = None, points=()) -> "KernelArguments":
        """The arrays this integrator passes to the kernels (flexfmu.reframe.kernels, layouts in its
        docstring) for prepared loads, a step dt (EX: the scheme's coefficients for it, empty for RK4) and
        output point indices: for code that calls the kernels directly (equivalence tests, benchmarks)."""
        EX = self.stepper.coefficients(dt) if dt is not None else None
        pts = np.asarray(points, dtype=np.int64)
        return KernelArguments(P=self._P, LP=self._kernel_loads(loads), G=self._Gk,
                               EX=np.zeros(0) if EX is None else EX, nf=self.data.nf,
                               deformed=self.deformed_load_arm, PP=self._point_data(pts), Psi=self._Psi_c,
                               dpn=self.data.dpn, umax=self._umax, umax_skip=self._umax_skip)

    def output_vector(self, state: ReframeState, loads: "_Prepared", points: np.ndarray,
                      max_elastic: bool = True) -> np.ndarray:
        """All outputs of one state as one flat array, laid out as :func:`flexfmu.reframe.layout.output_layout`
        declares: frame origin (3), its velocity (3), quaternion (4), omega (3), alpha (3), com position (3),
        com velocity (3), q (nf), qdot (nf), max elastic displacement (1), then per point position,
        velocity, acceleration, and their rigid parts (6 x 3).  :meth:`snapshot` wraps it; the ReframeBody
        FMU reads it directly.

        max_elastic=False skips the search over the mesh for the max elastic displacement, the one output
        whose cost grows with the mesh, and puts -1 in its place (:meth:`max_elastic_displacement` gives
        it alone; the paper scheme computes it always); everything else is O(modes^2)."""
        if not self.stepper.kernel_outputs:
            snap = self.snapshot(state, loads, points)
            return np.concatenate([snap.frame_origin, snap.frame_origin_velocity, snap.quaternion, snap.omega,
                                   snap.alpha, snap.com_position, snap.com_velocity, snap.q, snap.qd,
                                   [snap.max_elastic_displacement],
                                   np.stack([snap.point_position, snap.point_velocity, snap.point_acceleration,
                                             snap.point_position_rigid, snap.point_velocity_rigid,
                                             snap.point_acceleration_rigid], axis=1).ravel()])
        d = self.data
        SV, held = loads.stage_values(state.t, 0.0, 1)
        if not held and not np.all(np.isfinite(SV)):
            loads.check((state.t,))
        y = _state_vector(state)
        kern = _kernels()
        umax = self._umax if max_elastic else self._umax_skip
        if self._Gk.size:
            return kern.reframe_outputs(self._P, self._kernel_loads(loads), self._Gk, d.nf, self.deformed_load_arm,
                                        SV[0, 0], y, self._point_data(points), self._Psi_c, d.dpn, *umax)
        return kern.consistent_outputs(self._P, self._kernel_loads(loads), d.nf, self.deformed_load_arm,
                                       SV[0, 0], y, self._point_data(points), self._Psi_c, d.dpn, *umax)
