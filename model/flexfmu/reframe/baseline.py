"""The fixed-frame linear baseline of the reframe integrator (:mod:`flexfmu.reframe.integrator`)."""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.core.structure import N_RIGID
from flexfmu.core.structure import Structure
from flexfmu.reframe.modeldata import _check_dt, _check_initial, _ModelData

__all__ = ["BaselineResult", "FixedFrameBaseline"]


@dataclass
class BaselineResult:
    """Fixed-frame linear baseline: t (n_t,), eta (n_t, 2 n_modes) modal state in the global frame,
    com_position / com_velocity (n_t, 3), points (n_p,), point_position / point_velocity (n_t, n_p, 3)."""

    t: np.ndarray
    eta: np.ndarray
    com_position: np.ndarray
    com_velocity: np.ndarray
    points: np.ndarray
    point_position: np.ndarray
    point_velocity: np.ndarray


class FixedFrameBaseline:
    """The same model integrated conventionally in the fixed global frame (the comparison baseline): Eq. (35) with RK4,
    x = Psi q the displacement from the initial (mesh) configuration, loads with undeformed arms and
    global components (follower loads use the initial orientation).  Valid only for small rotations:
    the comparison shows what the reframing buys."""

    def __init__(self, structure: Structure, basis):
        self.data = _ModelData(structure, basis)

    def run(self, t_end, dt, load=None, points=(), *, v0=(0, 0, 0), omega0=(0, 0, 0), q0=None, qd0=None,
            every: int = 1) -> BaselineResult:
        d = self.data
        dt = _check_dt(dt)
        d.check_stability(dt)
        if not (isinstance(t_end, numbers.Real) and math.isfinite(t_end) and t_end > 0):
            raise ParameterError("t_end", f"{t_end!r}", "finite, > 0")
        v0, omega0, q0, qd0, _, _ = _check_initial(d, v0, omega0, q0, qd0, None, None)
        loads = d.resolve_loads(load)
        pts = np.array([d.node_index(p, f"points[{k}]") for k, p in enumerate(points)], dtype=np.int64)
        nm = d.n_modes
        eta = np.concatenate([np.zeros(N_RIGID), q0, d.A6inv @ np.concatenate([v0, omega0]), qd0])

        def fq(t):
            out = np.zeros(nm)
            for ld in loads:
                out += d.Psi[d.trans_rows[ld.node]].T @ ld.force(t)
                if d.rot_rows is not None:
                    out += d.Psi[d.rot_rows[ld.node]].T @ ld.moment(t)
            return out

        def rhs(t, e):
            return np.concatenate([e[nm:], -d.kq * e[:nm] - d.cq * e[nm:] + fq(t)])

        n_steps = int(math.ceil((t_end - 1e-12 * t_end) / dt))
        rec = []
        tr = d.trans_rows[pts]

        def record(t, e):
            x = d.Psi @ e[:nm]
            xd = d.Psi @ e[nm:]
            tc = (d.A6 @ e[:N_RIGID])[:3]
            vc = (d.A6 @ e[nm:nm + N_RIGID])[:3]
            rec.append((t, e.copy(), d.com + tc, vc, d.nodes[pts] + x[tr], xd[tr]))

        t = 0.0
        record(t, eta)
        for n in range(n_steps):
            k1 = rhs(t, eta)
            k2 = rhs(t + 0.5 * dt, eta + 0.5 * dt * k1)
            k3 = rhs(t + 0.5 * dt, eta + 0.5 * dt * k2)
            k4 = rhs(t + dt, eta + dt * k3)
            eta = eta + (dt / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
            t = (n + 1) * dt
            if (n + 1) % every == 0 or n + 1 == n_steps:
                record(t, eta)
        cols = list(zip(*rec))
        return BaselineResult(t=np.array(cols[0]), eta=np.array(cols[1]), com_position=np.array(cols[2]),
                              com_velocity=np.array(cols[3]), points=pts, point_position=np.array(cols[4]),
                              point_velocity=np.array(cols[5]))
