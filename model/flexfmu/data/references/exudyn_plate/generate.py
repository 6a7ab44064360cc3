"""Independent flexible reference for the reframe integrator: the paper's plate in Exudyn's reduced-order
floating frame of reference formulation (FEMinterface + ObjectFFRFreducedOrder).

    .venv/bin/python model/flexfmu/data/references/exudyn_plate/generate.py                # writes trajectory.csv (~30 s)
    .venv/bin/python model/flexfmu/data/references/exudyn_plate/generate.py --check        # + a run at 2 dt, prints the differences

Model (README.md next to this file):
  * M, K, node positions: flexfmu.reframe.plate.paper_plate((20, 2, 1)), the coarse plate of tests/test_reframe.py
    (1845 DOFs, tetra10 from scikit-fem, 1 kg corner masses) - the *input* shared with flexfmu;
  * modes: computed here by Exudyn's FEMinterface.ComputeEigenmodes (dense scipy eigh of K, M; the six
    rigid-body modes excluded), the first 10 flexible modes, mass-normalised; checked against
    flexfmu.linalg.modal_basis (same frequencies, same subspace);
  * 5% modal damping: ObjectFFRFreducedOrder takes a reduced damping matrix (dampingMatrixReduced); it is
    set to diag(2 zeta omega_i m_i) after the object is created (the FEM helper only offers Rayleigh);
  * load: the paper's, 50 N along global [1, 0, 1]/sqrt(2), a 0.01 s half-sine pulse (as
    flexfmu.reframe.integrator.half_sine_pulse(F, 0.01) in tests/test_reframe.py), on a MarkerSuperElementPosition of
    the mesh node at the load point (-0.5, 0, 0.01) m: Exudyn applies it at the *deformed* node position;
  * free flight to 1 s; generalized-alpha with spectral radius 1 (no numerical damping), dt = 2.5e-6 s.

Output, every 1 ms (1001 rows): t; omega_1..3 (body frame = Exudyn's reference frame, rad/s);
u_load_x/y/z and u_far_x/y/z (elastic displacement Psi q in the body frame of the node at the load point
(-0.5, 0, 0.01) and of the node at the opposite end (0.5, 0, 0.01), m); com_vel_x/y/z (global, m/s).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DIVISIONS = (20, 2, 1)
N_FLEXIBLE = 10
ZETA = 0.05
FORCE = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)      # N, global
PULSE = 0.01                                                    # s, half-sine duration
T_END = 1.0
DT = 2.5e-6
OUTPUT_PERIOD = 1e-3
FAR_POINT = np.array([0.5, 0.0, 0.01])
COLUMNS = (["t", "omega_1", "omega_2", "omega_3"] + [f"u_load_{c}" for c in "xyz"] + [f"u_far_{c}" for c in "xyz"]
           + [f"com_vel_{c}" for c in "xyz"])


def build_fem():
    """FEMinterface with the plate's nodes, M, K and the first N_FLEXIBLE free-free modes (Exudyn's solver)."""
    from exudyn.FEM import FEMinterface

    from flexfmu.reframe.plate import paper_plate

    plate = paper_plate(DIVISIONS)
    fem = FEMinterface()
    fem.nodes = {"Position": np.array(plate.nodes, dtype=float)}
    fem.massMatrix = plate.M.tocsr()
    fem.stiffnessMatrix = plate.K.tocsr()
    fem.ComputeEigenmodes(N_FLEXIBLE, excludeRigidBodyModes=6, useSparseSolver=False)   # dense eigh(K, M)
    freqs = np.sqrt(np.asarray(fem.eigenValues)[6:6 + N_FLEXIBLE]) / (2.0 * math.pi)
    return plate, fem, freqs


def check_modes(plate, Psi, freqs):
    """The same flexible modes as flexfmu.linalg.modal_basis: frequencies and the M-subspace (principal cosines)."""
    from flexfmu.linalg.modal_basis import modal_basis

    mb = modal_basis(plate, N_FLEXIBLE, ZETA)
    df = float(np.max(np.abs(freqs - mb.frequencies_hz) / mb.frequencies_hz))
    cosines = np.linalg.svd(mb.flexible.T @ (plate.M @ Psi), compute_uv=False)
    return df, float(1.0 - np.min(cosines)), mb.frequencies_hz


def simulate(fem, dt=DT, t_end=T_END):
    """Run Exudyn; return the output table (rows every OUTPUT_PERIOD) and some model data."""
    import exudyn as exu
    import exudyn.itemInterface as eii
    from exudyn.FEM import ObjectFFRFreducedOrderInterface

    from flexfmu.reframe.plate import LOAD_POINT

    Psi = np.asarray(fem.modeBasis["matrix"])
    cms = ObjectFFRFreducedOrderInterface(fem)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    obj = cms.AddObjectFFRFreducedOrder(mbs, positionRef=[0, 0, 0], initialVelocity=[0, 0, 0],
                                        initialAngularVelocity=[0, 0, 0], gravity=[0, 0, 0])
    oF, nR, nG = obj["oFFRFreducedOrder"], obj["nRigidBody"], obj["nGenericODE2"]
    # modal damping: the object's reduced damping matrix, diag(2 zeta omega_i m_i) (modes are M-orthogonal)
    mr = np.diag(cms.massMatrixReduced)
    omega = np.sqrt(np.diag(cms.stiffnessMatrixReduced) / mr)
    damping = np.diag(2.0 * ZETA * omega * mr)
    mc = exu.MatrixContainer()
    mc.SetWithDenseMatrix(damping, useDenseMatrix=False)
    mbs.SetObjectParameter(oF, "dampingMatrixReduced", mc)

    n_load = fem.GetNodeAtPoint(LOAD_POINT)
    n_far = fem.GetNodeAtPoint(FAR_POINT)
    m_load = mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=oF, meshNodeNumbers=[n_load],
                                                          weightingFactors=[1.0]))

    def pulse(mbs, t, load):
        s = t / PULSE
        return list(FORCE * math.sin(math.pi * s)) if 0.0 <= s <= 1.0 else [0.0, 0.0, 0.0]

    mbs.AddLoad(eii.LoadForceVector(markerNumber=m_load, loadVector=[0.0, 0.0, 0.0], bodyFixed=False,
                                    loadVectorUserFunction=pulse))
    OVT = exu.OutputVariableType
    sensors = {key: mbs.AddSensor(eii.SensorNode(nodeNumber=node, storeInternal=True, outputVariableType=ovt))
               for key, node, ovt in (("omega", nR, OVT.AngularVelocityLocal), ("vel", nR, OVT.Velocity),
                                      ("rot", nR, OVT.RotationMatrix), ("q", nG, OVT.Coordinates),
                                      ("qd", nG, OVT.Coordinates_t))}
    mbs.Assemble()

    ss = exu.SimulationSettings()
    n_steps = int(round(t_end / dt))
    ss.timeIntegration.numberOfSteps = n_steps
    ss.timeIntegration.endTime = n_steps * dt
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.generalizedAlpha.spectralRadius = 1.0     # no numerical dissipation
    ss.timeIntegration.newton.relativeTolerance = 1e-12
    ss.timeIntegration.newton.absoluteTolerance = 1e-12
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = OUTPUT_PERIOD
    mbs.SolveDynamic(ss, solverType=exu.DynamicSolverType.GeneralizedAlpha)

    data = {k: np.asarray(mbs.GetSensorStoredData(s)) for k, s in sensors.items()}
    t = data["omega"][:, 0]
    k = np.rint(t / OUTPUT_PERIOD)
    keep = np.abs(t - k * OUTPUT_PERIOD) < 0.25 * dt
    keep &= np.concatenate([[True], np.diff(k) > 0])
    for key in data:
        data[key] = data[key][keep]
    t = data["omega"][:, 0]
    expected = np.arange(int(round(t_end / OUTPUT_PERIOD)) + 1) * OUTPUT_PERIOD
    if t.shape != expected.shape or np.max(np.abs(t - expected)) > 0.25 * dt:
        raise RuntimeError(f"sensor times do not fall on the {OUTPUT_PERIOD} s grid")
    w = data["omega"][:, 1:]
    q, qd = data["q"][:, 1:], data["qd"][:, 1:]
    A = data["rot"][:, 1:].reshape(-1, 3, 3)                    # body -> global
    u_load = q @ Psi[3 * n_load:3 * n_load + 3].T
    u_far = q @ Psi[3 * n_far:3 * n_far + 3].T
    # centre of mass: chiU + c q in the body frame (c = T^T M Psi / m, ~0 for modes M-orthogonal to rigid motion)
    M = fem.massMatrix
    T = np.kron(np.ones((Psi.shape[0] // 3, 1)), np.eye(3))
    mass = float((T.T @ (M @ T))[0, 0])
    chi = (T.T @ (M @ np.asarray(fem.nodes["Position"]).ravel())) / mass
    c = (T.T @ (M @ Psi)) / mass
    r_com = chi + q @ c.T
    v_rel = np.cross(w, r_com) + qd @ c.T
    com_vel = data["vel"][:, 1:] + np.einsum("nij,nj->ni", A, v_rel)
    table = np.column_stack([expected, w, u_load, u_far, com_vel])
    info = {"n_load": n_load, "n_far": n_far, "mass": mass, "com": chi, "mode_com_coupling": float(np.abs(c).max()),
            "n_steps": n_steps, "omega": omega}
    return table, info


def write_csv(path, table, header_lines):
    with open(path, "w") as f:
        for line in header_lines:
            f.write(f"# {line}\n")
        f.write(",".join(COLUMNS) + "\n")
        for row in table:
            f.write(f"{row[0]:.4f}," + ",".join(f"{v:.9e}" for v in row[1:]) + "\n")


def main(argv=None):
    import exudyn as exu

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", type=float, default=DT, help=f"Exudyn time step, s (default {DT})")
    parser.add_argument("--out", type=Path, default=HERE / "trajectory.csv")
    parser.add_argument("--check", action="store_true", help="also run with 2 dt and print the differences")
    args = parser.parse_args(argv)

    t0 = time.perf_counter()
    plate, fem, freqs = build_fem()
    df, dsub, _ = check_modes(plate, np.asarray(fem.modeBasis["matrix"]), freqs)
    print(f"exudyn {exu.__version__}; plate {DIVISIONS}: {plate.n_dof} DOFs; flexible modes (Hz): "
          + ", ".join(f"{f:.4f}" for f in freqs))
    print(f"vs flexfmu.linalg.modal_basis: max relative frequency difference {df:.2e}, 1 - min principal cosine {dsub:.2e}")
    if df > 1e-6 or dsub > 1e-6:
        raise RuntimeError("Exudyn's modes are not flexfmu's modes")
    table, info = simulate(fem, args.dt)
    print(f"simulated {info['n_steps']} steps of {args.dt} s in {time.perf_counter() - t0:.1f} s; "
          f"load node {info['n_load']}, far node {info['n_far']}, mass {info['mass']:.6f} kg, "
          f"max |T^T M Psi|/m = {info['mode_com_coupling']:.1e}")
    i1 = int(round(PULSE / OUTPUT_PERIOD))
    print(f"omega after the load (t = {table[i1, 0]} s): {table[i1, 1:4]} rad/s; at 1 s {table[-1, 1:4]}")
    print(f"max |u_load| = {np.max(np.linalg.norm(table[:, 4:7], axis=1)):.6e} m, "
          f"max |u_far| = {np.max(np.linalg.norm(table[:, 7:10], axis=1)):.6e} m")
    if args.check:
        coarse, _ = simulate(fem, 2.0 * args.dt)
        dw = np.max(np.linalg.norm(coarse[i1:, 1:4] - table[i1:, 1:4], axis=1)) / np.linalg.norm(table[i1, 1:4])
        du = (np.max(np.linalg.norm(coarse[:, 4:7] - table[:, 4:7], axis=1))
              / np.max(np.linalg.norm(table[:, 4:7], axis=1)))
        print(f"dt {2 * args.dt} vs {args.dt}: max |d omega|/|omega| (t >= {PULSE} s) = {dw:.2e}, "
              f"max |d u_load| / max |u_load| = {du:.2e}  "
              f"(second order: the error of the {args.dt} run is ~1/3 of it)")
    header = [
        f"source: Exudyn {exu.__version__} ObjectFFRFreducedOrder, "
        "generated by model/flexfmu/data/references/exudyn_plate/generate.py",
        f"model: plate divisions {DIVISIONS[0]}x{DIVISIONS[1]}x{DIVISIONS[2]} ({plate.n_dof} DOFs), "
        f"{N_FLEXIBLE} flexible modes, zeta {ZETA}, dt {args.dt} s, generalized-alpha rho_inf 1",
        "flexible frequencies (Hz): " + " ".join(f"{f:.8f}" for f in freqs),
        f"load: {FORCE[0]:.10g},{FORCE[1]:.10g},{FORCE[2]:.10g} N global, half-sine {PULSE} s, "
        f"at node {info['n_load']} (-0.5, 0, 0.01) m, deformed position; "
        f"u_far: node {info['n_far']} (0.5, 0, 0.01) m",
    ]
    write_csv(args.out, table, header)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
