"""Free flexible bodies (flexfmu.body: build_body without a clamp, FlexBodySimulator).

References independent of the code under test: Newton's and Euler's laws for the rigid motion (a rigid-body ODE
solved by scipy), the momentum balance with the couple integrated from the outputs, the centre of mass from the
Structure's own M, analytic free-free Euler-Bernoulli frequencies, and the reframe integrator with the patch
loads applied node by node (another implementation)."""
import json

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.integrate import solve_ivp

from conftest import STEEL, straight_rod
from error_bounds import gamma, implementations_bound
from reframe_bounds import ops_stage, steps_bound
from flexfmu.body.build import build_body
from flexfmu.body.free import FreeDynamics, free_invariants
from flexfmu.body.interfaces import resolve_interfaces
from flexfmu.body.model import FlexBody
from flexfmu.body.simulator import FlexBodyConfig, FlexBodySimulator, input_names, output_names, variable_info
from flexfmu.core.structure import N_RIGID, Structure
from flexfmu.errors import NonFiniteError, ParameterError, StepRejected
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator
from flexfmu.reframe.models import load_model

UNITS = {"m", "m/s", "m/s2", "N", "N.m", "Hz", "rad/s", "rad/s2", "s", "kg", "J", ""}
PLATE_IF = [{"name": "A", "point": [-0.5, 0.0, 0.01]}, {"name": "B", "point": [0.5, 0.0, 0.0], "radius": 0.03}]


@pytest.fixture(scope="module")
def plate():
    return load_model("paper_plate", divisions=(8, 2, 1))


@pytest.fixture(scope="module")
def plate_body(plate):
    return build_body(plate, interfaces=PLATE_IF, f_max=200.0, tolerance=1e-3)


@pytest.fixture(scope="module")
def rod():
    return build_beam_model(straight_rod(1.0, 0.02), "free", 40).structure()


def _run(sim, inputs, dt, n, record=None):
    sim.set_inputs(**inputs)
    out = [sim.outputs()] if record else None
    for _ in range(n):
        sim.step(dt)
        if record:
            out.append(sim.outputs())
    return out


def test_constant_force_moves_the_centre_of_mass_by_newton(plate_body):
    F, t = np.array([2.0, -1.0, 30.0]), 0.05
    sim = FlexBodySimulator(plate_body, FlexBodyConfig(v0_x=0.2))
    _run(sim, {"A.F_x": F[0], "A.F_y": F[1], "A.F_z": F[2]}, 1e-3, 50)
    o = sim.outputs()
    v = np.array([o[f"com_vel_{a}"] for a in "xyz"])
    want = F * t / plate_body.mass + [0.2, 0.0, 0.0]
    print(f"\ncom_vel {v}, F t / m + v0 {want}, rel. error {np.abs(v - want).max() / np.abs(want).max():.2e}")
    np.testing.assert_allclose(v, want, rtol=1e-10)


def _angular_momentum(body, structure, state):
    """H (global) of the deformed, moving body from the Structure's M and the nodal velocities."""
    inv = body.arrays
    nf = body.n_coordinates
    y = np.array(state["y"])
    R = y[3:12].reshape(3, 3)
    eta = y[12:]
    q, qdR, qd = eta[N_RIGID:N_RIGID + nf], eta[N_RIGID + nf:2 * N_RIGID + nf], eta[2 * N_RIGID + nf:]
    vw = inv["A6"] @ qdR
    U = inv["translations"]                                   # (N, 3, nf)
    yb = structure.nodes - inv["center_of_mass"] + U @ q      # arms from the frame point, body frame
    wb = vw[:3] + np.cross(vw[3:], yb) + U @ qd               # nodal velocities, body frame
    p = (structure.M @ wb.ravel()).reshape(-1, 3)
    return R @ np.cross(yb, p).sum(axis=0)


def test_couple_turns_the_body_by_euler(plate, plate_body):
    """Equal and opposite forces at A and B: the centre of mass stays, the angular momentum (from M and the nodal
    velocities) equals the couple (p_A - p_B) x F integrated over time (trapezoid, the outputs' positions)."""
    F = np.array([0.0, 0.0, 40.0])
    sim = FlexBodySimulator(plate_body, FlexBodyConfig())
    sim.set_inputs(**{"A.F_z": F[2], "B.F_z": -F[2]})
    rec, q_max = [sim.outputs()], np.zeros(plate_body.n_coordinates)
    for _ in range(200):                                    # as _run, recording the flexible coordinates' max |q_j|
        sim.step(2e-4)
        rec.append(sim.outputs())
        q_max = np.maximum(q_max, _flexible_coordinates(sim, plate_body))
    arm = np.array([[r[f"A.pos_{a}"] - r[f"B.pos_{a}"] for a in "xyz"] for r in rec])
    couple = np.cross(arm, F)
    impulse = 0.5 * 2e-4 * (couple[1:] + couple[:-1]).sum(axis=0)
    H = _angular_momentum(plate_body, plate, sim.get_state())
    o = rec[-1]
    com_v = np.array([o[f"com_vel_{a}"] for a in "xyz"])
    w = np.array([o[f"omega_{k}"] for k in (1, 2, 3)])
    q = np.array([o["q_w"], o["q_x"], o["q_y"], o["q_z"]])
    Rq = _quat_matrix(q)
    H_rigid = Rq @ (plate_body.inertia @ w)
    print(f"\nH {H}, couple x t {impulse}, rel. {np.abs(H - impulse).max() / np.abs(impulse).max():.2e}; "
          f"J omega (global) {H_rigid}, rel. {np.abs(H_rigid - impulse).max() / np.abs(impulse).max():.2e}")
    # com_vel = R (m v + A(q) w) / m; exactly A(q) = sum_j q_j T^T M S_j = 0 (modes M-orthogonal to the
    # translations), in doubles only up to the rounding of the basis' orthogonality and of T^T M S_j: as in
    # test_deformed_body_centre_of_mass_is_the_frame_point generously gamma(4 n_dof + 100) of the terms
    # T^T |M| |S_j| <= T^T |M| |U_j| (|e_k x u| <= |u| componentwise); |A|_2 <= |A|_F <= sqrt(3) |a|_2.  It enters
    # through the output's A w and the mass solve's -A w_dot / m integrated (<= |A| sum dt |alpha|); plus each
    # step's rounding of the loads' sum (terms dt sum |F_i| / m, the kernel's chain 5 ops_stage + 10 for the
    # output's R p / m), carried with growth 1 (momentum is integrated additively)
    nf, absM = plate_body.n_coordinates, abs(plate.M)
    Ut = np.abs(plate_body.arrays["translations"]).reshape(-1, nf)
    t_j = (absM @ Ut).reshape(-1, 3, nf).sum(axis=0)                      # (3, nf): T^T |M| |U_j|
    a = gamma(4 * plate.M.shape[0] + 100) * (t_j @ q_max)
    A_norm = np.sqrt(3.0) * np.linalg.norm(a)
    alpha_sum = 2e-4 * sum(np.linalg.norm([r[f"alpha_{k}"] for k in (1, 2, 3)]) for r in rec[1:])
    bound = (A_norm * (np.linalg.norm(w) + alpha_sum) / plate_body.mass
             + implementations_bound(2e-4 * 2 * np.abs(F).sum() / plate_body.mass, 5 * ops_stage(nf, 2, False) + 10,
                                     1.0, 200))
    print(f"|com_vel| {np.abs(com_v).max():.2e}, bound {bound:.2e} (was {1e-12 * np.abs(F).max() * 0.04 / plate_body.mass:.2e})")
    assert np.abs(com_v).max() <= bound
    np.testing.assert_allclose(H, impulse, rtol=1e-8, atol=1e-8 * np.abs(impulse).max())
    # the rigid estimate differs by the elastic angular momentum only, a fraction ~ u / L of it
    ratio = o["max_elastic_displacement"] / 1.0
    assert np.abs(H_rigid - impulse).max() <= 10 * ratio * np.abs(impulse).max() + 1e-9 * np.abs(impulse).max()


def _flexible_coordinates(sim, body) -> np.ndarray:
    """|q_j| of the flexible coordinates of the simulator's current state."""
    nf = body.n_coordinates
    return np.abs(np.array(sim.get_state()["y"])[12 + N_RIGID:12 + N_RIGID + nf])


def _quat_matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_deformed_body_centre_of_mass_is_the_frame_point(plate, plate_body):
    sim = FlexBodySimulator(plate_body, FlexBodyConfig(omega0_2=3.0))
    _run(sim, {"A.F_z": 200.0, "B.M_x": 5.0}, 1e-3, 20)
    o = sim.outputs()
    y = np.array(sim.get_state()["y"])
    R = y[3:12].reshape(3, 3)
    nf = plate_body.n_coordinates
    u = plate_body.arrays["translations"] @ y[12 + N_RIGID:12 + N_RIGID + nf]
    x = y[:3] + (plate.nodes - plate_body.center_of_mass + u) @ R.T       # deformed nodes, global
    Mx = (plate.M @ x.ravel()).reshape(-1, 3).sum(axis=0)                # T^T M x
    com = Mx / plate_body.mass
    got = np.array([o[f"com_pos_{a}"] for a in "xyz"])
    print(f"\nmax elastic displacement {o['max_elastic_displacement']:.3g} m; |COM(M, deformed) - com_pos| "
          f"{np.abs(com - got).max():.2e} m")
    assert o["max_elastic_displacement"] > 1e-6
    # com_pos is the frame point y[:3]; T^T M x / m differs from it by rounding only: the COM c (sums of n_dof
    # terms), the basis' M-orthogonality to the translations (two projections of n_dof-term inner products and
    # the Ritz combination), and here x (6 roundings), M x, the node sum and / m; all generously within
    # gamma(4 n_dof + 100) of the terms |M| (|y0| + |nodes| + |c| + |u|) summed over the nodes, / m
    absM = abs(plate.M)
    size = np.abs(y[:3]).sum() + np.abs(plate.nodes) + np.abs(plate_body.center_of_mass).sum() + np.abs(u)
    terms = (absM @ size.ravel()).reshape(-1, 3).sum(axis=0) / plate_body.mass
    assert np.all(np.abs(got - com) <= gamma(4 * plate.M.shape[0] + 100) * terms)


def test_straight_rod_without_stub_follows_newton_euler(rod):
    """A 6-DOF rod along x (colinear nodes, no stub): force F_y at one end; rigid reference theta'' = (L/2) cos(theta)
    F / J (the force fixed in the global frame)."""
    L, F, T = 1.0, 10.0, 0.05
    ReframeIntegrator(rod, 4)                               # the consistent scheme takes the rod as it is
    with pytest.raises(ParameterError) as err:
        ReframeIntegrator(rod, 4, scheme="paper")           # the paper scheme needs three non-colinear points
    assert err.value.parameter == "reference_points"
    body = build_body(rod, interfaces=[{"name": "left", "point": [0, 0, 0]}, {"name": "right", "point": [L, 0, 0]}],
                      n_modes=12)
    for scheme in ("exponential", "consistent"):
        sim = FlexBodySimulator(body, FlexBodyConfig(damping_ratio=0.3, scheme=scheme))
        _run(sim, {"right.F_y": F}, 1e-4, 500)
        o = sim.outputs()
        J = body.mass * L**2 / 12
        sol = solve_ivp(lambda t, z: [z[1], 0.5 * L * np.cos(z[0]) * F / J], (0, T), [0, 0], rtol=1e-12, atol=1e-14)
        theta, omega = sol.y[:, -1]
        angle = 2 * np.arctan2(o["q_z"], o["q_w"])
        print(f"\n{scheme}: com_vel_y {o['com_vel_y']:.12g} vs F t / m {F * T / body.mass:.12g}; omega_3 "
              f"{o['omega_3']:.9g} vs {omega:.9g}; angle {angle:.9g} vs {theta:.9g}")
        assert o["com_vel_y"] == pytest.approx(F * T / body.mass, rel=1e-10)
        # the elastic part (static deflection ~ F L^2 / (E I) ~ 1e-4 of L) perturbs the frame's rotation less
        assert o["omega_3"] == pytest.approx(omega, rel=1e-5)
        assert angle == pytest.approx(theta, rel=1e-5)


def test_free_free_rod_frequencies_against_euler_bernoulli():
    L, d = 1.0, 0.02
    rod = build_beam_model(straight_rod(L, d), "free", 80).structure()
    body = build_body(rod, interfaces=[{"name": "end", "point": [L, 0, 0]}], n_modes=6)
    EI = STEEL["E"] * np.pi * d**4 / 64
    rhoA = STEEL["rho"] * np.pi * d**2 / 4
    beta_L = np.array([4.730040745, 7.853204624, 10.995607838])
    analytic = np.repeat(beta_L**2 / (2 * np.pi * L**2) * np.sqrt(EI / rhoA), 2)     # bending in y and z
    rel = body.natural_frequencies_hz / analytic - 1
    print(f"\nf_1..f_6 {body.natural_frequencies_hz}, relative error {rel}")
    sim = FlexBodySimulator(body, FlexBodyConfig())
    o = sim.outputs()
    assert [o[f"f_{k}"] for k in range(1, 7)] == body.natural_frequencies_hz.tolist()
    assert np.all(rel > 0)                                  # a conforming FE model converges from above
    assert np.all(rel < 1e-6)                               # 80 elements: (h)^4 convergence, 2.5e-7 at mode 5


def test_interface_loads_equal_the_patch_nodes_loaded_one_by_one(plate):
    """The interface as one kernel load (arm x_P - c, rows D Phi) against the reframe integrator with the patch's
    nodal forces D^T [F; M] as separate point loads: the same motion (without the deformed lever arm, which the
    two evaluate differently at second order)."""
    basis = modal_basis(plate, 8, 0.05)
    patch = resolve_interfaces(plate, PLATE_IF[:1])[0]
    rows = patch.D @ basis.shapes[patch.dofs, N_RIGID:]
    F, Mo = np.array([3.0, -2.0, 50.0]), np.array([1.0, 2.0, -0.5])
    g = patch.D.T @ np.concatenate([F, Mo])
    loads = [PointLoad(int(n), force=g[3 * k:3 * k + 3], follower=True) for k, n in enumerate(patch.nodes)]
    SV = np.zeros((1, 3, 1, 6))
    SV[0, :, 0] = np.concatenate([F, Mo])
    for scheme in ("consistent", "exponential"):
        dyn = FreeDynamics(free_invariants(plate, basis), basis.stiffness[N_RIGID:], 0.05, scheme, [rows],
                           [patch.point], [True], deformed_load_arm=False, follower=True)
        integ = ReframeIntegrator(plate, basis, scheme=scheme, deformed_load_arm=False)
        state = integ.initial_state(v0=(0.1, 0, 0), omega0=(0.5, 1.0, 2.0))
        ref = integ.run(0.05, 1e-4, loads, every=500, state=state).final_state
        y0 = dyn.initial_state(np.array([0.1, 0, 0]), np.array([0.5, 1.0, 2.0]))
        y, t, done, status = dyn.steps(y0, 0.0, 1e-4, 500, SV)
        want = np.concatenate([ref.position, ref.rotation.ravel(), ref.eta])
        # not an identity: the same compiled kernel, but other arguments (one interface load with rows D Phi vs
        # the patch nodes' loads one by one: other LP, SV, operation order), so a bound (tests/reframe_bounds.py)
        # on the integrator's arguments (its n_loads = patch nodes over-counts the load sums, which also covers
        # the rounding of D Phi against the nodal D^T [F; M])
        prep = integ.prepare_loads(loads)
        ka = integ.kernel_arguments(prep, 1e-4)
        SV_ref, _ = prep.stage_values(0.0, 1e-4, 500)
        bound = steps_bound(ka.P, ka.LP, ka.G, ka.EX, ka.nf, SV_ref, 1e-4, 500, y0, want)
        err = np.abs(y - want).max()
        print(f"\n{scheme}: max difference {err:.2e}, bound {bound:.2e} (relative {bound / np.abs(want).max():.1e})")
        assert status == 0 and err <= bound


def test_save_load_reproduces_the_outputs(plate_body, tmp_path):
    path = plate_body.save(tmp_path / "plate.npz")
    body = FlexBody.load(path)
    print(f"\nfile size {path.stat().st_size} bytes for {body.n_coordinates} coordinates")
    runs = []
    for b in (plate_body, body):
        sim = FlexBodySimulator(b, FlexBodyConfig())
        _run(sim, {"A.F_z": 10.0, "B.M_y": 1.0}, 1e-3, 10)
        runs.append(sim.output_vector())
    assert np.array_equal(runs[0], runs[1])
    assert input_names(body) == input_names(plate_body) and output_names(body) == output_names(plate_body)
    bad = tmp_path / "bad.npz"
    bad.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(ParameterError) as err:
        FlexBody.load(bad)
    assert err.value.parameter == str(bad)
    with np.load(path) as z:
        parts = {k: z[k] for k in z.files}
    header = json.loads(str(parts["header"]))
    for change in ({"version": 99}, {"kind": "floating"}):
        np.savez(tmp_path / "other.npz", **{**parts, "header": np.array(json.dumps({**header, **change}))})
        with pytest.raises(ParameterError):
            FlexBody.load(tmp_path / "other.npz")
    np.savez(tmp_path / "other.npz", **{**parts, "inv.J0": np.zeros((2, 2))})
    with pytest.raises(ParameterError) as err:
        FlexBody.load(tmp_path / "other.npz")
    assert "J0" in str(err.value)


def test_simulator_contract(plate_body):
    info = variable_info(plate_body)
    names = set(input_names(plate_body)) | set(output_names(plate_body)) | set(FlexBodyConfig.__dataclass_fields__)
    assert names <= set(info) and all(unit in UNITS for unit, _ in info.values())
    assert all(("global" in info[n][1]) for n in input_names(plate_body))
    sim = FlexBodySimulator(plate_body, FlexBodyConfig())
    with pytest.raises(NonFiniteError) as err:
        sim.set_inputs(**{"B.F_y": float("inf")})
    assert err.value.parameter == "B.F_y"
    with pytest.raises(ParameterError) as err:
        sim.set_inputs(**{"C.F_x": 1.0})
    assert err.value.parameter == "C.F_x"
    sim.set_inputs(**{"A.F_x": 1.0})
    state = json.loads(json.dumps(sim.get_state()))
    sim.step(1e-3)
    after = sim.output_vector()
    sim.set_state(state)
    sim.step(1e-3)
    assert np.array_equal(sim.output_vector(), after)
    capped = FlexBodySimulator(plate_body, FlexBodyConfig(scheme="consistent", max_internal_steps=2))
    with pytest.raises(StepRejected):
        capped.step(1.0)
    capped.step(1e-5)
    for bad in ({"damping_ratio": 1.5}, {"scheme": "paper"}, {"tolerance": 0.0}, {"max_internal_steps": 0},
                {"internal_step": 1.0, "scheme": "consistent"}):
        with pytest.raises(ParameterError) as err:
            FlexBodySimulator(plate_body, FlexBodyConfig(**bad))
        assert err.value.parameter in bad
    assert any("model size" in m for m in sim.messages)


def _springs(nodes, pairs, k=1e6, mass=1.0):
    """3-DOF nodes joined by axial springs (a truss), lumped masses."""
    nodes = np.asarray(nodes, float)
    n = 3 * len(nodes)
    K = np.zeros((n, n))
    for i, j in pairs:
        e = (nodes[j] - nodes[i]) / np.linalg.norm(nodes[j] - nodes[i])
        kk = k * np.outer(e, e)
        for a, b, sgn in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            K[3 * a:3 * a + 3, 3 * b:3 * b + 3] += sgn * kk
    return Structure(nodes=np.asarray(nodes, float), dofs_per_node=3, M=sp.csr_matrix(mass * np.eye(n)),
                     K=sp.csr_matrix(K))


@pytest.mark.parametrize("case", ["colinear", "two pieces"])
def test_singular_free_body_is_refused(case):
    if case == "colinear":                          # 3-DOF nodes on a line: no inertia about it
        s = _springs([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], [(0, 1), (1, 2), (2, 3)])
    else:                                           # two tetrahedra not connected to each other
        tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
        pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
        s = _springs(np.vstack([tet, tet + [5, 0, 0]]), pairs + [(i + 4, j + 4) for i, j in pairs])
    with pytest.raises(ParameterError) as err:
        build_body(s, interfaces=[{"name": "A", "point": [1, 0, 0], "radius": 1.5}], n_modes=2)
    print(f"\n{case}: {err.value}")
    assert "singular free body" in str(err.value)


def test_global_rotation_outputs_follow_the_frame(plate_body):
    """rot_*, omega_*, alpha_* (global) against the quaternion and the body-frame omega_k, alpha_k the same
    outputs carry: a body spun about a tilted axis, then pushed off its centre."""
    sim = FlexBodySimulator(plate_body, FlexBodyConfig(omega0_1=0.4, omega0_2=-0.3, omega0_3=0.9))
    _run(sim, {"B.F_z": 5.0}, 1e-3, 400)
    o = sim.outputs()
    q = np.array([o[f"q_{c}"] for c in "wxyz"])
    from scipy.spatial.transform import Rotation
    R = Rotation.from_quat([q[1], q[2], q[3], q[0]])            # scipy: scalar last; body -> global
    rot = np.array([o[f"rot_{a}"] for a in "xyz"])
    # two implementations of the same functions of q: each within gamma_32 of the exact value (normalisation 6,
    # atan2 / sin and angle / s 4 with libm 1 ulp, Rodrigues' or the quaternion matrix 12, R x 5; <= 32
    # counted generously) of terms <= pi (|rot| <= pi) resp. pi sum|x| (||dR|| <= ||d rot||, |R x| <= sum|x|)
    assert np.all(np.abs(rot - R.as_rotvec()) <= implementations_bound(np.pi, 32))
    for name in ("omega", "alpha"):
        body = np.array([o[f"{name}_{k}"] for k in (1, 2, 3)])
        bound = implementations_bound(np.pi * np.abs(body).sum(), 32)
        assert np.all(np.abs(np.array([o[f"{name}_{a}"] for a in "xyz"]) - R.apply(body)) <= bound)
    assert np.linalg.norm(rot) > 0.3
