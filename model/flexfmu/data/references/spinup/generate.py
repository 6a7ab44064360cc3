"""Geometrically exact reference for the spin-up problem of Kane, Ryan & Banerjee (1987).

    .venv/bin/python model/flexfmu/data/references/spinup/generate.py            # trajectory.csv + spinup_tip_deflection.png (~40 s)
    .venv/bin/python model/flexfmu/data/references/spinup/generate.py --check    # + mesh, time-step and tolerance refinements and
                                                                   #   a second element type (~6 min in all)

Problem: a uniform cantilever, L = 10 m, EI = 1.4e4 N m^2, rho A = 1.2 kg/m, EA = 2.8e7 N, clamped at the
origin to a hub whose angle is prescribed,
    theta(t) = (6/15) [t^2/2 + (15/(2 pi))^2 (cos(2 pi t/15) - 1)]   for t < 15 s,   theta = 6 t - 45   after;
omega reaches 6 rad/s at 15 s; theta, omega and alpha (and the jerk) are continuous.  No gravity, no damping.

Model (README.md next to this file): Exudyn planar ANCF cable elements (ObjectANCFCable2D: Euler-Bernoulli,
axial strain |r'| - 1 and curvature exact for large displacements and rotations, no shear, no rotary inertia -
the beam of the problem statement), N_ELEMENTS equal elements.  The hub is a boundary condition: root position
fixed at the origin by two CoordinateConstraints, root slope r'(0) kept parallel to (cos theta, sin theta) by a
CoordinateVectorConstraint with a Python constraint function -sin(theta) r'_x + cos(theta) r'_y = 0 (the slope
length, i.e. the root axial strain, stays free).  Generalized-alpha (index 3), spectral radius RHO_INF.

--check also runs Exudyn's 2D geometrically exact (Simo-Reissner) beam, ObjectBeamGeometricallyExact2D with
NodeRigidBody2D, root node coordinates (x, y, phi) = (0, 0, theta(t)) by CoordinateConstraints with an
offsetUserFunction - a different element (shear-deformable, linear interpolation, rotary inertia), to show
the reference does not depend on the element type.

Output trajectory.csv, t = 0, 0.05, ..., T_END s: hub angle (the root-slope angle measured in Exudyn, unwrapped,
rad), tip deflection in the rotating hub frame v_tip = -sin(theta) x_tip + cos(theta) y_tip (m), tip axial
displacement in the hub frame u_tip = cos(theta) x_tip + sin(theta) y_tip - L (m).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
L, EI, RHO_A, EA = 10.0, 1.4e4, 1.2, 2.8e7
OMEGA_S, T_S = 6.0, 15.0                  # final hub rate (rad/s), spin-up time (s)
GA_CHECK = 1.0e7                          # shear stiffness of the geometrically exact cross-check (N)
RHO_J_CHECK = RHO_A * EI / EA             # its cross-section rotary inertia rho I = rho A I/A (kg m)
N_ELEMENTS = 32
DT = 6.25e-4
T_END = 40.0
RHO_INF = 0.8
NEWTON_TOL = 1e-10                        # on the Newton increment (residualMode 1), relative and absolute
OUTPUT_PERIOD = 0.05
COLUMNS = ["t", "hub_angle", "v_tip", "u_tip"]


# --- prescribed hub motion --------------------------------------------------------------------------------------
def theta(t):
    t = np.asarray(t, float)
    spin = OMEGA_S / T_S * (t * t / 2 + (T_S / (2 * np.pi)) ** 2 * (np.cos(2 * np.pi * t / T_S) - 1))
    return np.where(t < T_S, spin, OMEGA_S * t - OMEGA_S * T_S / 2)


def omega(t):
    t = np.asarray(t, float)
    return np.where(t < T_S, OMEGA_S / T_S * (t - T_S / (2 * np.pi) * np.sin(2 * np.pi * t / T_S)), OMEGA_S)


def alpha(t):
    t = np.asarray(t, float)
    return np.where(t < T_S, OMEGA_S / T_S * (1 - np.cos(2 * np.pi * t / T_S)), 0.0)


# --- Exudyn models ----------------------------------------------------------------------------------------------
def _settings(exu, dt, t_end, tol):
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(t_end / dt))
    ss.timeIntegration.endTime = int(round(t_end / dt)) * dt
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.generalizedAlpha.spectralRadius = RHO_INF
    # error measured on the Newton increment (m, slopes, rad) rather than on the residual: with EA = 2.8e7 N the
    # residual's round-off floor is above any useful residual tolerance when the loads are tiny (t < 0.2 s)
    ss.timeIntegration.newton.residualMode = 1
    ss.timeIntegration.newton.relativeTolerance = tol
    ss.timeIntegration.newton.absoluteTolerance = tol
    ss.timeIntegration.adaptiveStep = False          # a failed Newton step is an error, not a silent step cut
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = OUTPUT_PERIOD
    return ss


def _on_grid(t, dt, t_end):
    """Indices of the sensor rows on the OUTPUT_PERIOD grid (Exudyn's sensor times carry round-off)."""
    k = np.rint(t / OUTPUT_PERIOD)
    keep = (np.abs(t - k * OUTPUT_PERIOD) < 0.25 * dt) & np.concatenate([[True], np.diff(k) > 0])
    expected = np.arange(int(round(t_end / OUTPUT_PERIOD)) + 1) * OUTPUT_PERIOD
    if keep.sum() != expected.size:
        raise RuntimeError(f"sensor times do not fall on the {OUTPUT_PERIOD} s grid")
    return keep, expected


def _table(t, root_angle, tip_pos):
    th = np.unwrap(root_angle)
    x, y = tip_pos[:, 0], tip_pos[:, 1]
    v = -np.sin(th) * x + np.cos(th) * y
    u = np.cos(th) * x + np.sin(th) * y - L
    return np.column_stack([t, th, v, u])


def simulate_ancf(n_el=N_ELEMENTS, dt=DT, t_end=T_END, tol=NEWTON_TOL):
    """ANCF cable model. Returns (table, info): table columns COLUMNS on the output grid."""
    import exudyn as exu
    import exudyn.itemInterface as eii

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    h = L / n_el
    nodes = [mbs.AddNode(eii.NodePoint2DSlope1(referenceCoordinates=[i * h, 0.0, 1.0, 0.0])) for i in range(n_el + 1)]
    for i in range(n_el):
        mbs.AddObject(eii.ObjectANCFCable2D(nodeNumbers=[nodes[i], nodes[i + 1]], length=h, massPerLength=RHO_A,
                                            bendingStiffness=EI, axialStiffness=EA, useReducedOrderIntegration=0))
    ground = mbs.AddNode(eii.NodePointGround())
    m_ground = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    for k in range(2):                                           # root position (x, y) = (0, 0)
        m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=k))
        mbs.AddObject(eii.ObjectConnectorCoordinate(markerNumbers=[m_ground, m]))
    m_root = mbs.AddMarker(eii.MarkerNodeCoordinates(nodeNumber=nodes[0]))
    m_ground_all = mbs.AddMarker(eii.MarkerNodeCoordinates(nodeNumber=ground))

    # root slope along the hub axis: -sin(theta) r'_x + cos(theta) r'_y = 0; q holds the node's coordinates
    # *including* reference values, (x, y, r'_x, r'_y)
    def slope_constraint(mbs, t, item, q, q_t, velocity_level):
        th = float(theta(t))
        s, c = math.sin(th), math.cos(th)
        if velocity_level:
            return [-s * q_t[2] + c * q_t[3] - float(omega(t)) * (c * q[2] + s * q[3])]
        return [-s * q[2] + c * q[3]]

    def slope_jacobian(mbs, t, item, q, q_t, velocity_level):
        th = float(theta(t))
        return np.array([[0.0, 0.0, -math.sin(th), math.cos(th)]])

    mbs.AddObject(eii.ObjectConnectorCoordinateVector(
        markerNumbers=[m_root, m_ground_all], scalingMarker0=np.zeros((1, 4)), scalingMarker1=np.zeros((1, 0)),
        constraintUserFunction=slope_constraint, jacobianUserFunction=slope_jacobian))
    OVT = exu.OutputVariableType
    s_tip = mbs.AddSensor(eii.SensorNode(nodeNumber=nodes[-1], storeInternal=True, outputVariableType=OVT.Position))
    s_root = mbs.AddSensor(eii.SensorNode(nodeNumber=nodes[0], storeInternal=True, outputVariableType=OVT.Coordinates))
    mbs.Assemble()

    t0 = time.perf_counter()
    mbs.SolveDynamic(_settings(exu, dt, t_end, tol), solverType=exu.DynamicSolverType.GeneralizedAlpha)
    cpu = time.perf_counter() - t0
    tip = np.asarray(mbs.GetSensorStoredData(s_tip))
    root = np.asarray(mbs.GetSensorStoredData(s_root))          # displacements: (ux, uy, dr'_x, dr'_y)
    keep, t = _on_grid(tip[:, 0], dt, t_end)
    tip, root = tip[keep], root[keep]
    table = _table(t, np.arctan2(root[:, 4], 1.0 + root[:, 3]), tip[:, 1:3])
    info = {"cpu": cpu, "root_position_error": float(np.max(np.abs(root[:, 1:3]))), "steps": int(round(t_end / dt)),
            "root_slope_length_max": float(np.max(np.hypot(1.0 + root[:, 3], root[:, 4])))}
    return table, info


def simulate_gebeam(n_el, dt, t_end, tol=NEWTON_TOL):
    """Cross-check: Exudyn's 2D geometrically exact (Simo-Reissner) beam, hub = root node coordinates."""
    import exudyn as exu
    import exudyn.itemInterface as eii

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    h = L / n_el
    nodes = [mbs.AddNode(eii.NodeRigidBody2D(referenceCoordinates=[i * h, 0.0, 0.0])) for i in range(n_el + 1)]
    for i in range(n_el):
        mbs.AddObject(eii.ObjectBeamGeometricallyExact2D(
            nodeNumbers=[nodes[i], nodes[i + 1]], length=h, massPerLength=RHO_A, crossSectionInertia=RHO_J_CHECK,
            bendingStiffness=EI, axialStiffness=EA, shearStiffness=GA_CHECK))
    ground = mbs.AddNode(eii.NodePointGround())
    m_ground = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    for k in range(3):
        m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=k))
        if k < 2:
            mbs.AddObject(eii.ObjectConnectorCoordinate(markerNumbers=[m_ground, m]))
        else:
            mbs.AddObject(eii.ObjectConnectorCoordinate(
                markerNumbers=[m_ground, m], offsetUserFunction=lambda mbs, t, item, off: float(theta(t)),
                offsetUserFunction_t=lambda mbs, t, item, off: float(omega(t))))
    OVT = exu.OutputVariableType
    s_tip = mbs.AddSensor(eii.SensorNode(nodeNumber=nodes[-1], storeInternal=True, outputVariableType=OVT.Position))
    s_root = mbs.AddSensor(eii.SensorNode(nodeNumber=nodes[0], storeInternal=True, outputVariableType=OVT.Coordinates))
    mbs.Assemble()
    t0 = time.perf_counter()
    mbs.SolveDynamic(_settings(exu, dt, t_end, tol), solverType=exu.DynamicSolverType.GeneralizedAlpha)
    cpu = time.perf_counter() - t0
    tip = np.asarray(mbs.GetSensorStoredData(s_tip))
    root = np.asarray(mbs.GetSensorStoredData(s_root))
    keep, t = _on_grid(tip[:, 0], dt, t_end)
    tip, root = tip[keep], root[keep]
    return _table(t, root[:, 3], tip[:, 1:3]), {"cpu": cpu}


# --- linear estimates (no Exudyn) -------------------------------------------------------------------------------
def rotating_beam_matrices(n=20):
    """Linear in-plane bending of the beam in the hub frame, cubic Hermite elements, clamped root.

    Returns K (EI), G (geometric stiffness per omega^2, from the centrifugal tension
    T(x) = rho A omega^2 (L^2 - x^2)/2), M (consistent mass) and f (load per unit hub angular acceleration:
    the Euler force -rho A alpha x).  Quasi-static deflection: (K + omega^2 (G - M)) v = -alpha f; the -omega^2 M
    term is the transverse component of the centrifugal force (softening), G the stiffening.
    """
    h = L / n
    xg, wg = np.polynomial.legendre.leggauss(6)
    ndof = 2 * (n + 1)
    K, G, M, f = (np.zeros((ndof, ndof)), np.zeros((ndof, ndof)), np.zeros((ndof, ndof)), np.zeros(ndof))
    for e in range(n):
        sl = slice(2 * e, 2 * e + 4)
        for xi, w in zip(xg, wg):
            s = (xi + 1) / 2
            x, wt = e * h + s * h, w * h / 2
            N = np.array([1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, h * (s**3 - s**2)])
            dN = np.array([6 * s**2 - 6 * s, h * (1 - 4 * s + 3 * s**2), 6 * s - 6 * s**2, h * (3 * s**2 - 2 * s)]) / h
            ddN = np.array([12 * s - 6, h * (6 * s - 4), 6 - 12 * s, h * (6 * s - 2)]) / h**2
            K[sl, sl] += EI * np.outer(ddN, ddN) * wt
            G[sl, sl] += RHO_A * (L * L - x * x) / 2 * np.outer(dN, dN) * wt
            M[sl, sl] += RHO_A * np.outer(N, N) * wt
            f[sl] += RHO_A * x * N * wt
    free = slice(2, None)
    return K[free, free], G[free, free], M[free, free], f[free]


def quasi_static_tip(t, stiffening=True):
    K, G, M, f = rotating_beam_matrices()
    out = []
    for ti in np.atleast_1d(t):
        w2 = float(omega(ti)) ** 2
        A = K + w2 * ((G if stiffening else 0.0) - M)
        out.append(np.linalg.solve(A, -float(alpha(ti)) * f)[-2])
    return np.array(out)


def rotating_frequencies(w, k=3):
    from scipy.linalg import eigh
    K, G, M, _ = rotating_beam_matrices()
    return np.sqrt(eigh(K + w * w * (G - M), M, eigvals_only=True)[:k])


# --- output -----------------------------------------------------------------------------------------------------
def write_csv(path, table, header_lines):
    with open(path, "w") as f:
        for line in header_lines:
            f.write(f"# {line}\n")
        f.write(",".join(COLUMNS) + "\n")
        for row in table:
            f.write(f"{row[0]:.2f},{row[1]:.16e},{row[2]:.10e},{row[3]:.10e}\n")


def plot(path, table, t_qs, v_qs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, v, u = table[:, 0], table[:, 2], table[:, 3]
    fig, axes = plt.subplots(3, 1, figsize=(9, 10), gridspec_kw={"height_ratios": [3, 2, 2]})
    ax = axes[0]
    ax.plot(t, v, color="C0", lw=1.6, label="Exudyn ANCF cable, geometrically exact (reference)")
    ax.plot(t_qs, v_qs, "--", color="C1", lw=1.2, label="quasi-static linear estimate with centrifugal stiffening")
    ax.axvline(T_S, color="0.5", lw=0.8, ls=":")
    ax.set_ylabel("tip deflection $v_{tip}$ in hub frame (m)")
    ax.set_title("Spin-up of a cantilever (Kane, Ryan & Banerjee 1987): $\\omega$ 0 → 6 rad/s in 15 s")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=9)
    ax2 = ax.twinx()
    ax2.plot(t, omega(t), color="0.6", lw=1.0)
    ax2.set_ylabel("hub rate $\\omega$ (rad/s), grey", color="0.45")
    ax2.set_ylim(0, 13)
    ax = axes[1]
    late = t >= T_S
    ax.plot(t[late], 1e3 * v[late], color="C0", lw=1.2)
    ax.set_xlim(T_S, t[-1])
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel("$v_{tip}$ (mm)")
    ax.set_title("after spin-up (ω = 6 rad/s): residual free vibration about the steady value 0", fontsize=10)
    ax.grid(alpha=0.3)
    ax = axes[2]
    ax.plot(t, 1e3 * u, color="C2", lw=1.2, label="tip axial displacement $u_{tip}$ in hub frame")
    ax.axhline(1e3 * RHO_A * OMEGA_S**2 * L**3 / (3 * EA), color="k", lw=0.8, ls="--",
               label="steady centrifugal stretch $\\rho A\\,\\omega^2 L^3/(3\\,EA)$ = 0.514 mm")
    ax.set_ylabel("$u_{tip}$ (mm)")
    ax.set_xlabel("time t (s)")
    ax.set_title("axial: foreshortening of the bent beam during spin-up, then the centrifugal stretch", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=9)
    ins = ax.inset_axes([0.42, 0.42, 0.55, 0.33])
    ins.plot(t[late], 1e3 * u[late], color="C2", lw=1.0)
    ins.axhline(1e3 * RHO_A * OMEGA_S**2 * L**3 / (3 * EA), color="k", lw=0.8, ls="--")
    ins.set_xlim(T_S, t[-1])
    ins.tick_params(labelsize=8)
    ins.set_title("t ≥ 15 s (mm)", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _diff(a, b, mask=None):
    d = np.abs(a[:, 2] - b[:, 2]) if mask is None else np.abs(a[mask, 2] - b[mask, 2])
    du = np.abs(a[:, 3] - b[:, 3]) if mask is None else np.abs(a[mask, 3] - b[mask, 3])
    return float(d.max()), float(du.max())


def main(argv=None):
    import exudyn as exu

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="also run dt/2, 2x elements, tolerance/100 and the geometrically exact 2D beam")
    parser.add_argument("--out", type=Path, default=HERE / "trajectory.csv")
    args = parser.parse_args(argv)

    t_start = time.perf_counter()
    table, info = simulate_ancf()
    t, th, v, u = table.T
    print(f"exudyn {exu.__version__}: ANCFCable2D x {N_ELEMENTS}, dt {DT} s, {info['steps']} steps to {T_END} s "
          f"in {info['cpu']:.1f} s")
    ang_err = float(np.max(np.abs(th - theta(t))))
    print(f"hub: max |root slope angle - theta(t)| = {ang_err:.2e} rad, max |root position| = "
          f"{info['root_position_error']:.1e} m, max root slope length {info['root_slope_length_max']:.8f}")
    i_pk = int(np.argmax(np.abs(v)))
    late = t >= T_S
    tail = t >= T_END - 10.0
    u_stretch = RHO_A * OMEGA_S**2 * L**3 / (3 * EA)
    print(f"peak v_tip = {v[i_pk]:.6f} m at t = {t[i_pk]:.2f} s; t >= {T_S} s: mean v {v[late].mean():.3e} m, "
          f"max |v| {np.abs(v[late]).max():.3e} m; last 10 s: mean v {v[tail].mean():.3e} m")
    print(f"u_tip for t >= {T_S} s: mean {u[late].mean():.6e} m (linear centrifugal stretch {u_stretch:.6e} m)")

    v_qs = quasi_static_tip(t[t <= T_END])
    j_qs = int(np.argmin(v_qs))
    dev = float(np.max(np.abs(v - v_qs)))
    f0, f6 = rotating_frequencies(0.0), rotating_frequencies(OMEGA_S)
    w_lin = float(f0[0])
    t_cross = float(t[np.argmax(omega(t) >= w_lin)])
    print(f"quasi-static linear estimate with stiffening: peak {v_qs[j_qs]:.6f} m at {t[j_qs]:.2f} s; "
          f"max |v - v_qs| = {dev:.4f} m")
    print(f"linear in-plane frequencies (hub frame): omega = 0: {np.round(f0, 4)} rad/s; omega = 6 rad/s: "
          f"{np.round(f6, 4)} rad/s; without stiffening K - omega^2 M loses definiteness when omega > {w_lin:.4f} "
          f"rad/s (t = {t_cross:.2f} s)")

    header = [
        f"generator: model/flexfmu/data/references/spinup/generate.py; exudyn {exu.__version__}; python {sys.version.split()[0]}; "
        f"numpy {np.__version__}",
        f"problem: Kane, Ryan & Banerjee (1987) spin-up; L {L} m, EI {EI} N m^2, rhoA {RHO_A} kg/m, EA {EA} N; "
        f"theta = ({OMEGA_S}/{T_S})[t^2/2 + ({T_S}/2pi)^2 (cos(2 pi t/{T_S}) - 1)] for t < {T_S} s, "
        f"{OMEGA_S} t - {OMEGA_S * T_S / 2} after",
        f"model: ObjectANCFCable2D x {N_ELEMENTS} (Euler-Bernoulli, geometrically exact strains); root position "
        f"fixed, root slope along (cos theta, sin theta)",
        f"integrator: generalized-alpha index 3, spectral radius {RHO_INF}, dt {DT} s, Newton increment tolerance "
        f"{NEWTON_TOL}",
        "columns: t (s); hub_angle = root slope angle measured in Exudyn, unwrapped (rad); v_tip = -sin(th) x_tip + "
        "cos(th) y_tip (m); u_tip = cos(th) x_tip + sin(th) y_tip - L (m)",
        f"peak v_tip {v[i_pk]:.6f} m at {t[i_pk]:.2f} s; t >= {T_S} s: mean v_tip {v[late].mean():.3e} m, "
        f"max |v_tip| {np.abs(v[late]).max():.3e} m, mean u_tip {u[late].mean():.6e} m",
    ]
    write_csv(args.out, table, header)
    png = args.out.with_name("spinup_tip_deflection.png")
    t_fine = np.arange(0.0, T_END + 1e-9, 0.05)
    plot(png, table, t_fine, quasi_static_tip(t_fine))
    print(f"wrote {args.out} ({len(table)} rows) and {png}; total {time.perf_counter() - t_start:.1f} s")

    if args.check:
        print("\nconvergence checks (max over the whole run of |difference|; v_tip, u_tip):")
        spin = t < T_S
        runs = [
            (f"dt {DT / 2}", lambda: simulate_ancf(dt=DT / 2)),
            (f"dt {2 * DT}", lambda: simulate_ancf(dt=2 * DT)),
            (f"{2 * N_ELEMENTS} elements", lambda: simulate_ancf(n_el=2 * N_ELEMENTS)),
            (f"{N_ELEMENTS // 2} elements", lambda: simulate_ancf(n_el=N_ELEMENTS // 2)),
            (f"Newton tolerance {NEWTON_TOL / 100}", lambda: simulate_ancf(tol=NEWTON_TOL / 100)),
        ]
        for name, run in runs:
            other, oinfo = run()
            dv, du = _diff(table, other)
            dvs, _ = _diff(table, other, spin)
            print(f"  {name:>24s} vs stored: {dv:.2e} m, {du:.2e} m  (spin-up phase {dvs:.2e} m; "
                  f"{dv / abs(v[i_pk]):.1e} of the peak; {oinfo['cpu']:.1f} s)")
        n_ge, dt_ge, t_ge = 64, 1.25e-3, 20.0
        ge, ginfo = simulate_gebeam(n_ge, dt_ge, t_ge)
        m = t <= t_ge + 1e-9
        dv, du = _diff(table[m], ge)
        print(f"  ObjectBeamGeometricallyExact2D x {n_ge}, dt {dt_ge} (GA {GA_CHECK:.0e} N, rhoI {RHO_J_CHECK:.1e}"
              f" kg m) vs stored, t <= {t_ge} s: {dv:.2e} m, {du:.2e} m ({dv / abs(v[i_pk]):.1e} of the peak; "
              f"{ginfo['cpu']:.1f} s); peak {ge[np.argmax(np.abs(ge[:, 2])), 2]:.6f} m")
        print(f"total {time.perf_counter() - t_start:.1f} s")


if __name__ == "__main__":
    main()
