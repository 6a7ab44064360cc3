"""Reference results for FFRBeam.fmu in the fmi-cross-check layout, by means independent of the FMU.

    .venv/bin/python tests/reference/FFRBeam/generate.py            # rewrites every case folder's files
    .venv/bin/python tests/reference/FFRBeam/generate.py CASE ...   # only these cases

Each case folder gets FFRBeam_in.csv (step-shaped: inputs are held over each communication step),
FFRBeam_ref.csv, FFRBeam_ref.opt, FFRBeam_start.json (parameter start values; the fmi-cross-check
layout has no place for them) and, where the case uses one, its scene JSON.  The README.md of each
case (provenance) is written by hand.  Nothing here runs the FMU or flexfmu's time integration
(flexfmu.ffr.dynamics / flexfmu.ffr.simulator):

  uniform_base_acceleration  Euler-Bernoulli cantilever under its own inertia load, closed form
                             (the static state the heavily damped FMU settles to);
  static_tip_load            static FE solve K^-1 F (scipy spsolve on flexfmu.ffr.assembly's constrained
                             stiffness) of the spatial double-L, reactions by statics of the whole rod;
  step_response_mode1        the exact step response of a damped single-DOF oscillator for mode 1 of a
                             flat-bar cantilever (mode from a dense scipy.linalg.eigh of the assembled
                             M, K; allowed: the FMU's time integration is what is tested);
  centrifugal_spin           a cantilever on a base spinning about its clamp: the closed-form axial
                             stretch u'' + k^2 u = -k^2 x of the linear floating-frame model.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.ffr.scene import load_scene

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from crosscheck_files import num, step_table, write_csv  # noqa: E402  (shared cross-check writers)
FMU = "FFRBeam"
STEEL = {"E": 200e9, "nu": 0.29, "rho": 7850.0}


# ----------------------------------------------------------------------------- file writers
def write_case(name: str, *, start: dict, opt: dict, inputs: dict | None, ref_time, ref: dict,
               files: dict | None = None) -> Path:
    """inputs: {name: constant} held from StartTime to StopTime, or None; ref: {column: values}."""
    folder = HERE / name
    folder.mkdir(exist_ok=True)
    for fname, text in (files or {}).items():
        (folder / fname).write_text(text)
    (folder / f"{FMU}_start.json").write_text(json.dumps(start, indent=2) + "\n")
    (folder / f"{FMU}_ref.opt").write_text("".join(f"{k}, {num(v)}\n" for k, v in opt.items()))
    if inputs:
        t, v = step_table([opt["StartTime"]], [list(inputs.values())], opt["StopTime"])
        write_csv(folder / f"{FMU}_in.csv", ["time", *inputs], [t, *v.T])
    write_csv(folder / f"{FMU}_ref.csv", ["time", *ref], [ref_time, *ref.values()])
    print(f"{name}: {len(ref_time)} reference rows, columns {', '.join(ref)}")
    return folder


def scene_json(name: str, description: str, points, section: dict) -> str:
    return json.dumps({"schema_version": 1, "name": name, "description": description, "points": points,
                       "section": section, "material": STEEL}, indent=2) + "\n"


def opt_dict(stop: float, step: float, reltol: float) -> dict:
    return {"StartTime": 0.0, "StopTime": stop, "StepSize": step, "RelTol": reltol}


def grid(t0: float, t1: float, dt: float) -> np.ndarray:
    """Times k*dt for t0 <= k*dt <= t1 (k*dt, not accumulated, so they equal the FMU's output times)."""
    k0, k1 = round(t0 / dt), round(t1 / dt)
    return np.arange(k0, k1 + 1) * dt


def translation_field(n_dof: int, axis: int) -> np.ndarray:
    """Rigid translation e_axis of a 6-DOF-per-node beam model."""
    r = np.zeros(n_dof)
    r[axis::6] = 1.0
    return r


def rotation_field(nodes: np.ndarray, axis: int) -> np.ndarray:
    """Rigid rotation about the body axis e_axis through the origin: e x x on translations, e on rotations."""
    e = np.eye(3)[axis]
    r = np.zeros(6 * len(nodes))
    r.reshape(-1, 6)[:, :3] = np.cross(e, nodes)
    r.reshape(-1, 6)[:, 3:] = e
    return r


# ----------------------------------------------------------------------------- cases
def uniform_base_acceleration() -> Path:
    """Straight cantilever (x, 0.5 m, 8 mm steel) on a base accelerating at a0 = (2, 0, 9.81) m/s^2 from t = 0,
    all 48 modes retained, zeta = 0.9: the FMU settles to the static state of the inertia load -rho A a0."""
    L, d, n_el = 0.5, 0.008, 8
    a_x, a_z = 2.0, 9.81
    E, rho = STEEL["E"], STEEL["rho"]
    A, I = math.pi * d**2 / 4, math.pi * d**4 / 64
    p, q = rho * A * a_x, rho * A * a_z            # inertia load per length, along -x and -z
    m = rho * A * L
    h = L / n_el
    x_s = L / 2                                   # sensor at mid-length: a mesh node
    u = lambda x: -(p / (E * A)) * (L * x - x**2 / 2)                          # axial bar, u'' = p/EA
    w = lambda x: -(q / (E * I)) * x**2 * (6 * L**2 - 4 * L * x + x**2) / 24  # cantilever, EI w'''' = -q
    # Integrals of the FE displacement field, which is the interpolant of the exact one (nodally exact):
    # int (w - Hermite w) = w'''' h^5 / 720 and int (u - linear u) = -u'' h^3 / 12 per element.
    int_u = -(p / (E * A)) * L**3 / 3 + n_el * (p / (E * A)) * h**3 / 12       # int_0^L u_FE dx
    int_w = -(q / (E * I)) * L**5 / 20 + n_el * (q / (E * I)) * h**5 / 720      # int_0^L w_FE dx
    # Strain energy of the *discrete* model: Hermite cubics (bending) and linear bars (axial) are exact at
    # the nodes for a uniform load, so the FE solution is the interpolant of the exact one, and
    # U_FE = 1/2 int load . u_FE = U_exact (1 - (h/L)^4 / 36) (bending) and (1 - (h/L)^2 / 4) (axial).
    energy = (q**2 * L**5 / (40 * E * I) * (1 - (h / L)**4 / 36)
              + p**2 * L**3 / (6 * E * A) * (1 - (h / L)**2 / 4))
    # Reactions at rest: F = -int rho a0 = -m a0;  M (about the clamp) = -int rho (x + u) x a0, first order.
    s_u = np.array([m * L / 2 + rho * A * int_u, 0.0, rho * A * int_w])
    a0 = np.array([a_x, 0.0, a_z])
    M = -np.cross(s_u, a0)
    print(f"  reaction_M_y = {M[1]:.12f} N m (with the continuum's int w instead: "
          f"{(n_el * q / (E * I) * h**5 / 720 * rho * A * a_x) / M[1]:.1e} relative more)")
    t = grid(0.3, 0.5, 1e-3)
    one = np.ones_like(t)
    ref = {"tip_u_x": u(L) * one, "tip_u_z": w(L) * one, "sensor_u_x": u(x_s) * one, "sensor_u_z": w(x_s) * one,
           "sensor_a_x": a_x * one, "sensor_a_z": a_z * one, "reaction_F_x": -m * a_x * one,
           "reaction_F_z": -m * a_z * one, "reaction_M_y": M[1] * one, "elastic_energy": energy * one}
    print(f"  tip deflection -rho A a L^4/(8 EI) = {w(L):.9e} m, f_1 (continuum) = "
          f"{1.875104069**2 / (2 * math.pi * L**2) * math.sqrt(E * I / (rho * A)):.4f} Hz")
    scene = scene_json("cantilever", "Straight cantilever for FFRBeam reference cases: 0.5 m along body x, "
                       "8 mm solid steel rod.", [[0.0, 0.0, 0.0], [L, 0.0, 0.0]], {"shape": "circle", "diameter": d})
    return write_case(
        "uniform_base_acceleration",
        start={"scene": "cantilever.json", "boundary": "XFF", "elements_per_segment": n_el, "n_modes": 6 * n_el,
               "damping_ratio": 0.9, "load_s": -1.0, "sensor_s": x_s},
        opt=opt_dict(0.5, 1e-3, 1e-9), inputs={"base_a_x": a_x, "base_a_z": a_z}, ref_time=t, ref=ref,
        files={"cantilever.json": scene})


def static_tip_load() -> Path:
    """The spatial double-L, XFF, 4 elements per segment, all 72 modes, zeta = 0.9, a constant tip force and
    moment: the settled state equals the static FE solution q = K^-1 f."""
    n_el, zeta = 4, 0.9
    F = np.array([0.4, -1.2, 2.0])
    Mext = np.array([0.05, 0.02, -0.03])
    scene = load_scene("spatial_double_L")
    L, sensor_s = scene.total_length, 0.04
    model = build_beam_model(scene, "XFF", n_el, extra_arc_lengths=(L, sensor_s))
    mesh = model.mesh
    tip, sensor = mesh.node_at(L), mesh.node_at(sensor_s)
    f = np.zeros(model.n_dof)
    f[6 * tip:6 * tip + 3] = F
    f[6 * tip + 3:6 * tip + 6] = Mext
    q = model.B2 @ spla.spsolve(model.K_free.tocsc(), model.B2.T @ f)
    u_tip, u_sensor = q[6 * tip:6 * tip + 3], q[6 * sensor:6 * sensor + 3]
    # Statics of the whole rod: the clamps carry the load, about the origin with the load's deformed arm.
    r_tip = mesh.nodes[tip] + u_tip
    M_reaction = Mext + np.cross(r_tip, F)
    energy = 0.5 * f @ q
    residual = np.linalg.norm(model.K_free @ (model.B2.T @ q) - model.B2.T @ f) / np.linalg.norm(f)
    print(f"  |tip u| = {np.linalg.norm(u_tip):.6e} m, residual |K q - f| / |f| = {residual:.1e}, "
          f"K q arm effect |u x F| / |r0 x F| = {np.linalg.norm(np.cross(u_tip, F)) / np.linalg.norm(np.cross(mesh.nodes[tip], F)):.1e}")
    t = grid(0.2, 0.4, 1e-3)
    one = np.ones_like(t)
    ref = {}
    for i, a in enumerate("xyz"):
        ref[f"tip_u_{a}"] = u_tip[i] * one
    for i, a in enumerate("xyz"):
        ref[f"sensor_u_{a}"] = u_sensor[i] * one
    for i, a in enumerate("xyz"):
        ref[f"reaction_F_{a}"] = F[i] * one
    for i, a in enumerate("xyz"):
        ref[f"reaction_M_{a}"] = M_reaction[i] * one
    ref["elastic_energy"] = energy * one
    return write_case(
        "static_tip_load",
        start={"scene": "spatial_double_L", "boundary": "XFF", "elements_per_segment": n_el,
               "n_modes": model.n_free, "damping_ratio": zeta, "load_s": -1.0, "sensor_s": sensor_s},
        opt=opt_dict(0.4, 1e-3, 1e-8),
        inputs={"F_x": F[0], "F_y": F[1], "F_z": F[2], "M_x": Mext[0], "M_y": Mext[1], "M_z": Mext[2]},
        ref_time=t, ref=ref)


def step_response_mode1() -> Path:
    """Flat-bar cantilever (0.5 m along x, 20 mm wide along z, 5 mm high along y), one retained mode (first
    bending in x-y), zeta = 0.02, a tip force (0, 0.3, 0.2) N switched on at t = 0 from rest."""
    L, n_el, zeta, x_s = 0.5, 8, 0.02, 0.25
    F = np.array([0.0, 0.3, 0.2])
    scene_text = scene_json("cantilever_flat_bar", "Straight flat-bar cantilever for FFRBeam reference cases: "
                            "0.5 m along body x, steel 20 mm wide (body z) x 5 mm high (body y), so the first "
                            "bending mode (x-y plane) is well separated from the second (x-z).",
                            [[0.0, 0.0, 0.0], [L, 0.0, 0.0]], {"shape": "rectangle", "width": 0.02, "height": 0.005})
    path = HERE / "step_response_mode1" / "cantilever_flat_bar.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(scene_text)
    model = build_beam_model(load_scene(path), "XFF", n_el, extra_arc_lengths=(L, x_s))
    mesh, n = model.mesh, model.n_dof
    # Mode 1 from the assembled constrained M, K by scipy (not flexfmu.linalg.modal): a dense generalised eigh,
    # whose lowest eigenvalue carries ~eps lambda_max / lambda_1 (f_1 off by 1.1e-10 here), refined by inverse
    # iteration (error ratio (f_1 / f_2)^2 = 0.06 per step) and the Rayleigh quotient; mass-normalised.
    Kd, Md = model.K_free.toarray(), model.M_free.toarray()
    lam, vec = sla.eigh(Kd, Md, subset_by_index=[0, 1])
    v = vec[:, 0]
    lu = sla.lu_factor(Kd)
    for _ in range(4):
        v = sla.lu_solve(lu, Md @ v)
        v /= math.sqrt(v @ Md @ v)
    omega = math.sqrt(v @ Kd @ v)
    phi = model.B2 @ v
    # Mode 1 bends in the x-y plane: its axial, z, torsion and theta_y components vanish by symmetry; clear
    # their round-off so that tip_u_z is exactly 0 (checked small first).
    off_plane = np.tile(np.array([True, False, True, True, True, False]), n // 6)
    assert np.max(np.abs(phi[off_plane])) < 1e-9 * np.max(np.abs(phi))
    phi[off_plane] = 0.0
    print(f"  f_1 = {omega / (2 * math.pi):.12f} Hz (plain eigh {math.sqrt(lam[0]) / (2 * math.pi):.12f}, "
          f"f_2 = {math.sqrt(lam[1]) / (2 * math.pi):.4f} Hz), phi^T M phi - 1 = {phi @ model.M @ phi - 1:.1e}")
    tip, sensor = mesh.node_at(L), mesh.node_at(x_s)
    phi_tip, phi_s = phi[6 * tip:6 * tip + 3], phi[6 * sensor:6 * sensor + 3]
    g = phi_tip @ F                                   # modal force
    wd = omega * math.sqrt(1 - zeta**2)
    t = grid(0.0, 0.6, 2e-3)
    env = np.exp(-zeta * omega * t)
    eta = g / omega**2 * (1 - env * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t)))
    eta_d = g / wd * env * np.sin(wd * t)
    eta_dd = g * env * (np.cos(wd * t) - zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    # Reactions (fixed base): F - int rho S phi eta_dd and M_ext + r_F x F - int rho u0 x S phi eta_dd, with
    # int rho S_a phi = r_a^T M phi and e_a . int rho u0 x S phi = rot_a^T M phi (rigid fields through M).
    S_phi = np.array([translation_field(n, a) @ model.M @ phi for a in range(3)])
    R_phi = np.array([rotation_field(mesh.nodes, a) @ model.M @ phi for a in range(3)])
    r_F = mesh.nodes[tip] + np.outer(eta, phi_tip)
    reaction_F = F - np.outer(eta_dd, S_phi)
    reaction_M = np.cross(r_F, F) - np.outer(eta_dd, R_phi)
    ref = {"tip_u_y": phi_tip[1] * eta, "tip_u_z": phi_tip[2] * eta, "sensor_u_y": phi_s[1] * eta,
           "sensor_v_y": phi_s[1] * eta_d, "sensor_a_y": phi_s[1] * eta_dd,
           "reaction_F_y": reaction_F[:, 1], "reaction_F_z": reaction_F[:, 2],
           "reaction_M_x": reaction_M[:, 0], "reaction_M_y": reaction_M[:, 1], "reaction_M_z": reaction_M[:, 2],
           "f_1": np.full_like(t, omega / (2 * math.pi)), "elastic_energy": 0.5 * omega**2 * eta**2}
    return write_case(
        "step_response_mode1",
        start={"scene": "cantilever_flat_bar.json", "boundary": "XFF", "elements_per_segment": n_el, "n_modes": 1,
               "damping_ratio": zeta, "load_s": -1.0, "sensor_s": x_s},
        opt=opt_dict(0.6, 1e-3, 1e-8), inputs={"F_x": F[0], "F_y": F[1], "F_z": F[2]}, ref_time=t, ref=ref)


def centrifugal_spin() -> Path:
    """The cantilever of uniform_base_acceleration on a base spinning at a constant 60 rad/s about body z
    (through the clamp), all modes, zeta = 0.9: the settled axial stretch of the linear floating-frame model,
    rho A (omega^2 (x + u)) + EA u'' = 0 (centrifugal load with spin softening, no geometric stiffening),
    u(0) = 0, u'(L) = 0:  u = -x + sin(k x) / (k cos(k L)), k = omega sqrt(rho / E)."""
    L, d, n_el, Om = 0.5, 0.008, 8, 60.0
    E, rho = STEEL["E"], STEEL["rho"]
    A = math.pi * d**2 / 4
    m = rho * A * L
    k = Om * math.sqrt(rho / E)
    x_s = L / 2
    u = lambda x: -x + math.sin(k * x) / (k * math.cos(k * L))
    int_u = -L**2 / 2 + (1 - math.cos(k * L)) / (k**2 * math.cos(k * L))
    # At rest in the spinning frame the clamp supplies the centripetal force: the rod pulls it outwards,
    # F = -int rho a = +Om^2 int rho (x + u) e_x; no moment about the spin axis through the clamp.
    reaction_F_x = Om**2 * rho * A * (L**2 / 2 + int_u)
    # Sensor at rest in the spinning frame: the accelerometer reads the centripetal acceleration.
    sensor_a_x = -Om**2 * (x_s + u(x_s))
    print(f"  tip stretch {u(L):.9e} m (small-k limit rho Om^2 L^3 / (3E) = {rho * Om**2 * L**3 / (3 * E):.9e}), "
          f"reaction {reaction_F_x:.9f} N (rigid m Om^2 L/2 = {m * Om**2 * L / 2:.9f})")
    t = grid(0.3, 0.5, 1e-3)
    one = np.ones_like(t)
    ref = {"tip_u_x": u(L) * one, "sensor_u_x": u(x_s) * one, "sensor_a_x": sensor_a_x * one,
           "reaction_F_x": reaction_F_x * one}
    scene = scene_json("cantilever", "Straight cantilever for FFRBeam reference cases: 0.5 m along body x, "
                       "8 mm solid steel rod.", [[0.0, 0.0, 0.0], [L, 0.0, 0.0]], {"shape": "circle", "diameter": d})
    return write_case(
        "centrifugal_spin",
        start={"scene": "cantilever.json", "boundary": "XFF", "elements_per_segment": n_el, "n_modes": 6 * n_el,
               "damping_ratio": 0.9, "load_s": -1.0, "sensor_s": x_s},
        opt=opt_dict(0.5, 1e-3, 1e-6), inputs={"base_w_z": Om}, ref_time=t, ref=ref,
        files={"cantilever.json": scene})


CASES = {f.__name__: f for f in (uniform_base_acceleration, static_tip_load, step_response_mode1, centrifugal_spin)}

if __name__ == "__main__":
    for name in sys.argv[1:] or CASES:
        print(name)
        CASES[name]()
