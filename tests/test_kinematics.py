"""Point kinematics r = R + A(u0 + S q) (Eqs. 1-3, 12) against exact solutions."""
import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from conftest import STEEL, straight_rod
from error_bounds import gamma
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.ffr.kinematics import FramePose, point_motion, point_shape
from flexfmu.ffr.scene import load_scene


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def test_cantilever_static_deflection_is_exact_between_nodes():
    """Tip load P on a cantilever in an oblique direction: w(x) = P x^2 (3L - x) / (6 EI) at any x."""
    direction = np.array([1.0, 2.0, -0.5])
    L, d = 1.0, 0.01
    model = build_beam_model(straight_rod(L, d, direction), "XFF", 5)
    axis = direction / np.linalg.norm(direction)
    load_dir = np.cross(axis, [0.0, 0.0, 1.0])
    load_dir /= np.linalg.norm(load_dir)
    P = 3.0
    tip = point_shape(model.mesh, L)
    f = tip.full_translation(model.n_dof).T @ (P * load_dir)     # S^T F
    q_free = np.linalg.solve(model.K_free.toarray(), model.B2.T @ f)
    q = model.B2 @ q_free
    EI = STEEL["E"] * np.pi * d**4 / 64
    for s in [0.13, 0.5, 0.777, 1.0]:
        u = point_shape(model.mesh, s).displacement_body(q)
        expected = P * s**2 * (3 * L - s) / (6 * EI)
        assert u @ load_dir == pytest.approx(expected, rel=1e-10)
        # analytic reference: no axial displacement; held to the same 1e-10 of the deflection as the transverse one
        assert abs(u @ axis) < 1e-10 * expected
    # slope at the tip: P L^2 / (2 EI) about axis x load_dir
    rot = tip.rotation_body(q)
    assert rot @ np.cross(axis, load_dir) == pytest.approx(P * L**2 / (2 * EI), rel=1e-10)


def test_rigid_motion_field_is_reproduced_at_any_point(rng):
    """Nodal rigid motion (t + theta x x, theta) -> every point moves rigidly: shape functions are complete."""
    model = build_beam_model(load_scene("spatial_double_L"), "free", 3)
    t, theta = rng.normal(size=3), 1e-3 * rng.normal(size=3)
    q = np.zeros(model.n_dof)
    for i, x in enumerate(model.mesh.nodes):
        q[6 * i:6 * i + 3] = t + np.cross(theta, x)
        q[6 * i + 3:6 * i + 6] = theta
    # exact in exact arithmetic.  Rounding: shape rows (Hermite values ~10, xi 2, C and C^T gamma(19) each, the
    # 12-term products) generously gamma(60) relative, the element length within gamma(8) 2 X of the node
    # coordinates (X = max|x|): relative 2 X / L_min in the terms it scales; q's and the reference's t + theta x x
    # within gamma(3) (|t| + 2 |theta| |x|)
    X = float(np.abs(model.mesh.nodes).max())
    rel = gamma(60) * (1 + 2 * X / model.mesh.element_length.min())
    ref = gamma(5) * (np.abs(t) + 2 * np.abs(theta).sum() * X)     # + the 2 subtractions here
    for s in np.linspace(0, 0.45, 37):
        shape = point_shape(model.mesh, s)
        qe = np.abs(q[shape.dofs]) + np.concatenate([ref, 0 * ref, ref, 0 * ref])
        bound = rel * (np.abs(shape.translation) @ qe) + ref
        assert np.all(np.abs(shape.displacement_body(q) - t - np.cross(theta, shape.undeformed_body)) <= bound)
        assert np.all(np.abs(shape.rotation_body(q) - theta) <= rel * (np.abs(shape.rotation) @ qe))


def test_point_motion_matches_finite_differences(rng):
    """Global position, velocity, acceleration for a moving floating frame and a vibrating rod."""
    model = build_beam_model(load_scene("spatial_double_L"), "XFF", 3)
    shape = point_shape(model.mesh, 0.37)
    q_amp = 1e-3 * rng.normal(size=model.n_dof)
    A0 = Rotation.random(random_state=3).as_matrix()
    w_body = np.array([0.3, -1.1, 0.7])          # constant body-frame angular velocity
    R0, V0, G = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    nu = 7.0

    def state(t):
        A = A0 @ expm(t * _skew(w_body))
        q, qd, qdd = q_amp * np.sin(nu * t), q_amp * nu * np.cos(nu * t), -q_amp * nu**2 * np.sin(nu * t)
        pose = FramePose(R=R0 + V0 * t + 0.5 * G * t**2, A=A, R_dot=V0 + G * t, R_ddot=G,
                         omega_body=w_body, alpha_body=np.zeros(3))
        return point_motion(shape, q, qd, qdd, pose)

    t, h = 0.3, 1e-4
    m, mp, mm = state(t), state(t + h), state(t - h)
    np.testing.assert_allclose(m.velocity_global, (mp.position_global - mm.position_global) / (2 * h), rtol=1e-6)
    np.testing.assert_allclose(m.acceleration_global, (mp.velocity_global - mm.velocity_global) / (2 * h), rtol=1e-6)
    np.testing.assert_allclose(
        m.acceleration_global, (mp.position_global - 2 * m.position_global + mm.position_global) / h**2, rtol=1e-4)


def test_point_motion_with_angular_acceleration():
    """Pure rotation about a fixed axis with angular acceleration: a = alpha x r + w x (w x r)."""
    model = build_beam_model(load_scene("spatial_double_L"), "XFF", 2)
    shape = point_shape(model.mesh, 0.45)
    w, al = np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 5.0])
    m = point_motion(shape, np.zeros(model.n_dof), pose=FramePose(omega_body=w, alpha_body=al))
    r = shape.undeformed_body
    np.testing.assert_allclose(m.position_global, r)
    np.testing.assert_allclose(m.velocity_global, np.cross(w, r))
    np.testing.assert_allclose(m.acceleration_global, np.cross(al, r) + np.cross(w, np.cross(w, r)))


def test_arc_length_outside_rod_is_rejected():
    model = build_beam_model(load_scene("spatial_double_L"), "XFF", 2)
    from flexfmu.errors import ParameterError
    with pytest.raises(ParameterError, match="sensor_s"):
        point_shape(model.mesh, 0.46, "sensor_s")
