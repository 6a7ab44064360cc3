"""The Mooring's quasi-static stiffness, from MoorDyn (flexfmu.wec.mooring) and from MoorPy, an independent model of
the same lines (docs/wave_converter.md "Mooring (MoorDyn)").

MoorDyn is dynamic: its static forces are those of lines that have settled.  :func:`settled_loads` runs the
MooringSimulator (the FMU's own code path) at rest until the lines settle, keeps that state, and for each offset
restores it, moves the body there along a half-cosine ramp (a quasi-static move that hardly excites the lines), holds
it and averages the loads over the end of the hold; the drag is scaled up (``drag_scale``) so the lines settle
sooner, which changes no static force.  :func:`moordyn_stiffness` takes central differences of those loads.

MoorPy (pip ``moorpy``) solves each line as an elastic catenary with sea-floor contact, analytically (no
discretisation); :func:`moorpy_system` builds the same three lines on a coupled body at O, and
:func:`moorpy_stiffness` is its System.getCoupledStiffness over the same offsets (central differences of re-solved
catenaries), so both sides difference the same finite offsets.
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.wec.mooring import INPUT_NAMES, MooringConfig, MooringSimulator, anchors, fairleads

#: the offsets of the central differences: 1 m in translation, 0.02 rad in rotation (fairleads move <= 0.1 m)
OFFSETS = (1.0, 1.0, 1.0, 0.02, 0.02, 0.02)
DOF_NAMES = ("surge", "sway", "heave", "roll", "pitch", "yaw")


def moorpy_system(cfg: MooringConfig = MooringConfig()):
    """MoorPy's System of the Mooring's lines: a coupled body at O with the fairleads, anchors on the sea floor, one
    line type with the Mooring's mass, volume-equivalent diameter and EA (its wet weight from them), solved."""
    try:
        import moorpy
    except ImportError:
        raise ParameterError("moorpy", "MoorPy is not installed", "pip install moorpy (flexfmu's dev extra)") from None
    system = moorpy.System(depth=cfg.depth, rho=cfg.rho, g=cfg.g)
    system.lineTypes["chain"] = {"name": "chain", "material": "chain", "d_vol": cfg.line_diameter,
                                 "m": cfg.line_mass, "EA": cfg.line_EA, "w": cfg.wet_weight}
    system.addBody(-1, [0.0] * 6)
    for i, (anchor, fairlead) in enumerate(zip(anchors(cfg), fairleads(cfg))):
        system.addPoint(1, anchor)
        system.addPoint(1, fairlead)
        system.bodyList[0].attachPoint(2 * i + 2, fairlead)
        system.addLine(cfg.line_length, "chain", nSegs=cfg.segments, pointA=2 * i + 1, pointB=2 * i + 2)
    system.initialize()
    system.solveEquilibrium()
    return system


def moorpy_loads(system) -> np.ndarray:
    """The lines' force and moment on the body about O (6,), earth frame."""
    return np.asarray(system.bodyList[0].getForces(lines_only=True), float)


def moorpy_tensions(system) -> np.ndarray:
    """Each line's tension at its fairlead (N)."""
    return np.array([line.TB for line in system.lineList])


def moorpy_stiffness(cfg: MooringConfig = MooringConfig(), offsets=OFFSETS) -> np.ndarray:
    """MoorPy's 6x6 stiffness -dF/dq about O (System.getCoupledStiffness, central differences over ``offsets``:
    one translation step and one rotation step, as MoorPy takes them)."""
    system = moorpy_system(cfg)
    return np.asarray(system.getCoupledStiffness(dx=offsets[0], dth=offsets[3], lines_only=True, nTries=1), float)


def _inputs(q: np.ndarray, q_dot: np.ndarray) -> dict:
    # rot is a rotation vector; about one axis at a time (the offsets here) its rate is the angular velocity
    return dict(zip(INPUT_NAMES, np.concatenate([q, q_dot]).tolist()))


def _move(sim: MooringSimulator, q0, q1, ramp: float, hold: float, average: float, step: float) -> np.ndarray:
    """Loads (n, 6) over the last ``average`` s of a half-cosine ramp from q0 to q1 over ``ramp`` s and a hold."""
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    n_ramp, n_hold, n_average = (int(round(x / step)) for x in (ramp, hold, average))
    loads = []
    for k in range(n_ramp + n_hold):
        s = min(k / n_ramp, 1.0) if n_ramp else 1.0
        w, w_dot = 0.5 - 0.5 * math.cos(math.pi * s), (0.5 * math.pi / ramp * math.sin(math.pi * s) if s < 1 else 0.0)
        sim.set_inputs(**_inputs(q0 + (q1 - q0) * w, (q1 - q0) * w_dot))
        sim.step(step)
        if k >= n_ramp + n_hold - n_average:
            loads.append(sim.loads.copy())
    return np.array(loads)


def settled_loads(cfg: MooringConfig, targets, *, drag_scale: float = 10.0, settle: float = 20.0,
                  ramp: float = 10.0, hold: float = 20.0, average: float = 10.0, step: float = 0.02):
    """MoorDyn's settled loads about O at rest and at each body offset of ``targets`` (6-vectors: pos, rot): (means,
    standard deviations over the averaging window), arrays (1 + len(targets), 6), the rest first."""
    sim = MooringSimulator(cfg, drag_scale=drag_scale)
    rest = np.zeros(6)
    windows = [_move(sim, rest, rest, 0.0, settle, average, step)]
    settled = sim.get_state()
    for q in targets:
        sim.set_state(settled)
        windows.append(_move(sim, rest, q, ramp, hold, average, step))
    return np.array([w.mean(axis=0) for w in windows]), np.array([w.std(axis=0) for w in windows])


def moordyn_stiffness(cfg: MooringConfig = MooringConfig(), dofs=(0, 2, 4), offsets=OFFSETS, **settling):
    """MoorDyn's stiffness columns -dF/dq_j for the DOFs ``dofs`` (central differences of settled_loads at +-
    offsets[j]): (K (6, 6) with NaN in the columns not measured, noise (6, 6): the loads' standard deviations over the
    averaging windows, (s+ + s-) / (2 d), a bound of what the windows' means may still carry of the lines' motion,
    loads at rest (6,))."""
    targets = []
    for j in dofs:
        for sign in (1.0, -1.0):
            q = np.zeros(6)
            q[j] = sign * offsets[j]
            targets.append(q)
    means, stds = settled_loads(cfg, targets, **settling)
    K, noise = np.full((6, 6), np.nan), np.full((6, 6), np.nan)
    for n, j in enumerate(dofs):
        plus, minus = 1 + 2 * n, 2 + 2 * n
        K[:, j] = -(means[plus] - means[minus]) / (2 * offsets[j])
        noise[:, j] = (stds[plus] + stds[minus]) / (2 * offsets[j])
    return K, noise, means[0]
