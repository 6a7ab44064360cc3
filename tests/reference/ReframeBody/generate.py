"""Reference results for ReframeBody.fmu in the fmi-cross-check layout, by means independent of the FMU.

    .venv/bin/python tests/reference/ReframeBody/generate.py            # rewrites every case folder's files
    .venv/bin/python tests/reference/ReframeBody/generate.py CASE ...   # only these cases

Each case folder gets ReframeBody_in.csv (step-shaped: inputs are held over each communication step),
ReframeBody_ref.csv, ReframeBody_ref.opt, ReframeBody_start.json (parameter start values; the
fmi-cross-check layout has no place for them) and, where the case uses one, its .npz structure file
(flexfmu.core.io.save_structure).  The README.md of each case (provenance) is written by hand.  Nothing here
runs the FMU or flexfmu's integrator (flexfmu.reframe.integrator / flexfmu.reframe.simulator / flexfmu.linalg.modal_basis):

  constant_force_newton  Newton's law for the centre of mass of a free flexible body (closed form);
  rigid_paper_load       the paper's plate as a rigid body under the paper's load: Newton-Euler with a
                         quaternion, scipy solve_ivp (DOP853, rtol 1e-12), mass, centre of mass and inertia
                         tensor from the model's M and node positions (r^T M r);
  rigid_tumbling         the same rigid plate (a coarser mesh of it: same M-moments) spinning and drifting
                         initially, then hit by the same load.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from flexfmu.core.io import save_structure
from flexfmu.reframe.models import load_model
from flexfmu.reframe.plate import CORNER_MASS, CORNERS, DENSITY, LENGTHS, LOAD_POINT, paper_plate
from flexfmu.ffr.scene import load_scene

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from crosscheck_files import num, step_table, write_csv  # noqa: E402  (shared cross-check writers)
FMU = "ReframeBody"
PAPER_FORCE = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)    # N, global
PULSE = 0.01                                                        # s, half-sine duration
P1 = CORNERS[0]                                                     # the default output point


# ----------------------------------------------------------------------------- file writers
def write_case(name: str, *, start: dict, opt: dict, input_names, step_times, input_values, ref_time,
               ref: dict) -> Path:
    folder = HERE / name
    folder.mkdir(exist_ok=True)
    (folder / f"{FMU}_start.json").write_text(json.dumps(start, indent=2) + "\n")
    (folder / f"{FMU}_ref.opt").write_text("".join(f"{k}, {num(v)}\n" for k, v in opt.items()))
    t, v = step_table(step_times, input_values, opt["StopTime"])
    write_csv(folder / f"{FMU}_in.csv", ["time", *input_names], [t, *v.T])
    write_csv(folder / f"{FMU}_ref.csv", ["time", *ref], [ref_time, *ref.values()])
    print(f"{name}: {len(t)} input rows, {len(ref_time)} reference rows, columns {', '.join(ref)}")
    return folder


def opt_dict(stop: float, step: float, reltol: float) -> dict:
    return {"StartTime": 0.0, "StopTime": stop, "StepSize": step, "RelTol": reltol}


def steps(stop: float, h: float) -> np.ndarray:
    """Communication points k h, k = 0 .. n (k*h, not accumulated, as fmpy computes them)."""
    return np.arange(round(stop / h) + 1) * h


# ----------------------------------------------------------------------------- mass properties from M
def mass_properties(structure) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia tensor about it (undeformed body frame) as r^T M r with the rigid
    translation fields r = e_a and rotation fields r = e_a x (x - c) of the model's nodes (translational
    DOFs; on 6-DOF nodes the rotation field also carries e_a on the rotational DOFs)."""
    M, nodes, dpn = structure.M, np.asarray(structure.nodes, float), structure.dofs_per_node
    n = M.shape[0]

    def field(translation: np.ndarray, rotation: np.ndarray | None = None) -> np.ndarray:
        r = np.zeros((len(nodes), dpn))
        r[:, :3] = translation
        if rotation is not None and dpn == 6:
            r[:, 3:] = rotation
        return r.reshape(n)

    T = [field(np.broadcast_to(np.eye(3)[a], nodes.shape)) for a in range(3)]
    masses = np.array([T[a] @ (M @ T[a]) for a in range(3)])
    assert np.ptp(masses) <= 1e-12 * masses[0], masses
    m = float(masses[0])
    X = field(nodes)                                # the position field x
    c = np.array([T[a] @ (M @ X) for a in range(3)]) / m
    R = [field(np.cross(np.eye(3)[a], nodes - c), np.eye(3)[a]) for a in range(3)]
    J = np.array([[R[a] @ (M @ R[b]) for b in range(3)] for a in range(3)])
    return m, c, 0.5 * (J + J.T)


def plate_closed_form() -> tuple[float, np.ndarray, np.ndarray]:
    """The paper's plate (a homogeneous box plus eight corner point masses) in closed form, for a check."""
    Lx, Ly, Lz = LENGTHS
    mb = DENSITY * Lx * Ly * Lz
    m = mb + 8 * CORNER_MASS
    c = np.array([0.0, 0.0, 0.5 * Lz])              # box centre; the corner masses are symmetric about it
    J = mb / 12 * np.diag([Ly**2 + Lz**2, Lx**2 + Lz**2, Lx**2 + Ly**2])
    for p in CORNERS:
        r = p - c
        J += CORNER_MASS * (r @ r * np.eye(3) - np.outer(r, r))
    return m, c, J


# ----------------------------------------------------------------------------- rigid Newton-Euler
def quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    pw, pv, qw, qv = p[0], p[1:], q[0], q[1:]
    return np.concatenate([[pw * qw - pv @ qv], pw * qv + qw * pv + np.cross(pv, qv)])


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (body -> global) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def newton_euler(m, c0, J, load_point, force_steps, h, v0=(0.0, 0.0, 0.0), omega0=(0.0, 0.0, 0.0)):
    """Rigid body from rest pose (body frame = model frame, centre of mass at c0) under a global force held
    over each step [k h, (k+1) h) at the body point load_point.  State: centre of mass c, its velocity v
    (global), quaternion q (body -> global, scalar first), angular velocity w (body):
        c' = v,  m v' = F,  q' = q (0, w) / 2,  J w' = r x (R^T F) - w x J w,  r = load_point - c0.
    Returns the states at the communication points k h, k = 0 .. n (rows: c, v, q, w)."""
    Jinv = np.linalg.inv(J)
    r = np.asarray(load_point, float) - c0

    def rhs(_t, y, F):
        v, q, w = y[3:6], y[6:10], y[10:13]
        torque = np.cross(r, quat_matrix(q).T @ F)
        return np.concatenate([v, F / m, 0.5 * quat_mul(q, np.concatenate([[0.0], w])),
                               Jinv @ (torque - np.cross(w, J @ w))])

    y = np.concatenate([c0, v0, [1.0, 0.0, 0.0, 0.0], omega0])
    out = [y.copy()]
    for k, F in enumerate(force_steps):
        sol = solve_ivp(rhs, (k * h, (k + 1) * h), y, method="DOP853", rtol=1e-12, atol=1e-15,
                        args=(np.asarray(F, float),))
        assert sol.success, sol.message
        y = sol.y[:, -1].copy()
        y[6:10] /= np.linalg.norm(y[6:10])
        out.append(y.copy())
    return np.array(out)


def rigid_columns(states: np.ndarray, c0: np.ndarray, output_point: np.ndarray) -> dict:
    c, v, q, w = states[:, 0:3], states[:, 3:6], states[:, 6:10], states[:, 10:13]
    assert np.all(q[:, 0] > 0.05), "keep the rotation below pi: the FMU's quaternion has w >= 0"
    out = np.array([ci + quat_matrix(qi) @ (output_point - c0) for ci, qi in zip(c, q)])
    cols = {}
    for i in range(3):
        cols[f"omega_{i + 1}"] = w[:, i]
    for i, a in enumerate("xyz"):
        cols[f"com_vel_{a}"] = v[:, i]
    for i, a in enumerate("xyz"):
        cols[f"com_pos_{a}"] = c[:, i]
    for i, a in enumerate("wxyz"):
        cols[f"q_{a}"] = q[:, i]
    for i, a in enumerate("xyz"):
        cols[f"out_pos_{a}"] = out[:, i]
    return cols


def paper_pulse(h: float, stop: float) -> np.ndarray:
    """The paper's 0.01 s half-sine of 50 N along [1, 0, 1]/sqrt(2), sampled at the middle of each
    communication step (held over the step), then zero."""
    t_mid = (np.arange(round(stop / h)) + 0.5) * h
    return np.outer(np.where(t_mid < PULSE, np.sin(np.pi * t_mid / PULSE), 0.0), PAPER_FORCE)


def thin(ref_time: np.ndarray, cols: dict, every: int) -> tuple[np.ndarray, dict]:
    return ref_time[::every], {k: v[::every] for k, v in cols.items()}


# ----------------------------------------------------------------------------- cases
def constant_force_newton() -> Path:
    """The spatial double-L as a free flexible body (4 flexible modes, 5% damping), a constant global force at
    its tip from rest: the centre of mass moves as Newton says, whatever the rotation and vibration."""
    spec, F = "beam:spatial_double_L", np.array([3.0, -2.0, 5.0])
    structure = load_model(spec)                       # the FMU's model: 8 elements per segment, free-free
    m, _, _ = mass_properties(structure)
    scene = load_scene("spatial_double_L")
    print(f"  m = {m:.15g} kg (closed form rho A L: {m / scene.total_mass - 1:.1e} relative)")
    h, stop = 1e-3, 0.2
    t = steps(stop, h)
    # com_pos_* is not a reference column: the FMU reports the dummy rigid body's frame point there, which
    # for a 6-DOF beam model drifts from the true centre of mass by -int R (q A_j omega) / m dt (the term
    # com_vel_* includes), 1.2e-7 m = 3e-7 of the travel in this case (README.md).
    cols = {f"com_vel_{a}": F[i] * t / m for i, a in enumerate("xyz")}
    t_ref, ref = thin(t, cols, 2)
    tip = scene.points[-1]
    return write_case(
        "constant_force_newton",
        start={"model": spec, "scheme": "consistent", "n_flexible_modes": 4, "damping_ratio": 0.05,
               "internal_step": 0.0, "load_point_x": tip[0], "load_point_y": tip[1], "load_point_z": tip[2],
               "output_point_x": 0.0, "output_point_y": 0.0, "output_point_z": 0.0, "force_follows_body": False},
        opt=opt_dict(stop, h, 1e-10), input_names=["F_x", "F_y", "F_z"], step_times=[0.0], input_values=[F],
        ref_time=t_ref, ref=ref)


def _rigid_plate_case(name: str, divisions, stop: float, h: float, every: int, reltol: float,
                      v0=(0.0, 0.0, 0.0), omega0=(0.0, 0.0, 0.0)) -> Path:
    folder = HERE / name
    folder.mkdir(exist_ok=True)
    plate = paper_plate(divisions)
    npz = save_structure(folder / "plate.npz", plate)
    print(f"  plate {divisions}: {plate.n_dof} DOFs, {npz.name} {npz.stat().st_size / 1e3:.0f} kB")
    structure = load_model(str(npz))                   # what the FMU reads
    m, c0, J = mass_properties(structure)
    mc, cc, Jc = plate_closed_form()
    print(f"  m = {m:.15g} kg, c0 = {c0}, J diag = {np.diag(J)}; closed form (box + corner masses): "
          f"m {abs(m / mc - 1):.1e}, c0 {np.max(np.abs(c0 - cc)):.1e} m, J {np.max(np.abs(J - Jc)) / np.max(Jc):.1e} rel.")
    # The plate is symmetric about x = 0 and y = 0: c0_x, c0_y and the products of inertia are round-off
    # (~1e-17); set them to exactly zero, so that components that vanish by symmetry (omega_1, omega_3, q_x,
    # q_z, com_vel_y, com_pos_y under the paper's load) are exactly zero in the reference.
    assert np.max(np.abs(c0[:2])) < 1e-15 and np.max(np.abs(J - np.diag(np.diag(J)))) < 1e-15 * np.max(J)
    c0[:2] = 0.0
    J = np.diag(np.diag(J))
    nodes = np.asarray(structure.nodes)
    for label, p in (("load", LOAD_POINT), ("output", P1)):   # the FMU loads / reports the nearest node
        gap = np.min(np.linalg.norm(nodes - p, axis=1))
        assert gap < 1e-12, f"no node at the {label} point {p}"
    force = paper_pulse(h, stop)
    states = newton_euler(m, c0, J, LOAD_POINT, force, h, v0=np.asarray(v0, float), omega0=np.asarray(omega0, float))
    t = steps(stop, h)
    t_ref, ref = thin(t, rigid_columns(states, c0, P1), every)
    impulse = force.sum(0) * h
    print(f"  impulse {impulse} N s (continuous half-sine {PAPER_FORCE * 2 * PULSE / np.pi}), final omega "
          f"{states[-1, 10:13]} rad/s")
    # Step-shaped input: the pulse's steps, then zero to the end.
    n_pulse = int(np.flatnonzero(np.any(force != 0.0, axis=1))[-1]) + 2
    return write_case(
        name,
        start={"model": "plate.npz", "scheme": "consistent", "n_flexible_modes": 0, "internal_step": 0.0,
               "load_point_x": LOAD_POINT[0], "load_point_y": LOAD_POINT[1], "load_point_z": LOAD_POINT[2],
               "output_point_x": P1[0], "output_point_y": P1[1], "output_point_z": P1[2],
               "force_follows_body": False, "v0_x": v0[0], "v0_y": v0[1], "v0_z": v0[2],
               "omega0_1": omega0[0], "omega0_2": omega0[1], "omega0_3": omega0[2]},
        opt=opt_dict(stop, h, reltol), input_names=["F_x", "F_y", "F_z"], step_times=t[:n_pulse],
        input_values=force[:n_pulse], ref_time=t_ref, ref=ref)


def rigid_paper_load() -> Path:
    """The paper's plate, n_flexible_modes = 0, the paper's load (50 N half-sine of 0.01 s along [1, 0, 1]/sqrt(2)
    at (-0.5, 0, 0.01) m), from rest, 0.2 s in communication steps of 1 ms."""
    return _rigid_plate_case("rigid_paper_load", (20, 2, 1), stop=0.2, h=1e-3, every=1, reltol=1e-9)


def rigid_tumbling() -> Path:
    """The same rigid plate (mesh (4, 2, 1): the tetra10 mass matrix integrates r^T M r exactly, so every mesh
    has the same mass, centre of mass and inertia), spinning at omega0 = (0.4, -0.3, 2.0) rad/s (mostly about
    the major axis z) and drifting at v0 = (0.1, 0, -0.05) m/s, hit by the same load; 1 s in steps of 1 ms."""
    return _rigid_plate_case("rigid_tumbling", (4, 2, 1), stop=1.0, h=1e-3, every=5, reltol=1e-6,
                             v0=(0.1, 0.0, -0.05), omega0=(0.4, -0.3, 2.0))


CASES = {f.__name__: f for f in (constant_force_newton, rigid_paper_load, rigid_tumbling)}

if __name__ == "__main__":
    for name in sys.argv[1:] or CASES:
        print(name)
        CASES[name]()
