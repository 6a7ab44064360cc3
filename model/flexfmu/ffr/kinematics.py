"""Motion of any point of the rod, given by its arc length (Koda et al. 2025, Eqs. 1-3, 12).

Body frame:   u_bar = u_bar0 + S q              (Eq. 2; S = C S_local C_bar^T B1, Eq. 13)
Global frame: r = R + A u_bar                    (Eqs. 1, 3, 12)
              r_dot  = R_dot + A (w x u_bar + S q_dot)
              r_ddot = R_ddot + A (a x u_bar + w x (w x u_bar) + 2 w x S q_dot + S q_ddot)
with A the body-to-global rotation and w, a the floating frame's angular velocity and
acceleration in *body* components (A_dot = A [w]x).  q is the unconstrained nodal
vector (6 DOF per node, body frame); expand constrained coordinates with B2 first.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flexfmu.ffr.mesh import Mesh


@dataclass(frozen=True)
class PointShape:
    """Interpolation of one point: dofs (12,) indices into q; translation / rotation (3, 12) body frame."""

    s: float
    undeformed_body: np.ndarray
    dofs: np.ndarray
    translation: np.ndarray
    rotation: np.ndarray

    def displacement_body(self, q: np.ndarray) -> np.ndarray:
        """Elastic displacement u_bar_f = S q of the point, m, body frame."""
        return self.translation @ np.asarray(q)[self.dofs]

    def rotation_body(self, q: np.ndarray) -> np.ndarray:
        """Small elastic rotation of the cross-section, rad, body frame."""
        return self.rotation @ np.asarray(q)[self.dofs]

    def full_translation(self, n_dof: int) -> np.ndarray:
        """Dense (3, n_dof) translation rows, for loads (S^T F) and output maps."""
        out = np.zeros((3, n_dof))
        out[:, self.dofs] = self.translation
        return out

    def full_rotation(self, n_dof: int) -> np.ndarray:
        out = np.zeros((3, n_dof))
        out[:, self.dofs] = self.rotation
        return out


def point_shape(mesh: Mesh, s: float, parameter: str = "s") -> PointShape:
    """Shape rows of the point at arc length ``s`` (m)."""
    e, xi = mesh.locate(s, parameter)
    C = mesh.element_rotation[e]
    S_local = mesh.element.shape_functions(xi, mesh.element_length[e], mesh.scene.section,
                                           mesh.scene.material)   # (6, 12) in element axes
    Cbar_T = np.kron(np.eye(4), C.T)                              # body -> element nodal coords
    S_body = np.kron(np.eye(2), C) @ S_local @ Cbar_T
    n1, n2 = mesh.elements[e]
    dofs = np.concatenate([6 * n1 + np.arange(6), 6 * n2 + np.arange(6)])
    x0 = (1 - xi) * mesh.nodes[n1] + xi * mesh.nodes[n2]
    return PointShape(s=float(s), undeformed_body=x0, dofs=dofs,
                      translation=S_body[:3], rotation=S_body[3:])


@dataclass(frozen=True)
class FramePose:
    """Floating frame state: origin R (m, global), A body->global, velocities/accelerations.

    R_dot, R_ddot in global components; omega_body, alpha_body in body components.
    """

    R: np.ndarray = field(default_factory=lambda: np.zeros(3))
    A: np.ndarray = field(default_factory=lambda: np.eye(3))
    R_dot: np.ndarray = field(default_factory=lambda: np.zeros(3))
    R_ddot: np.ndarray = field(default_factory=lambda: np.zeros(3))
    omega_body: np.ndarray = field(default_factory=lambda: np.zeros(3))
    alpha_body: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True)
class PointMotion:
    """Position, velocity, acceleration of a point, global frame (m, m/s, m/s^2)."""

    position_global: np.ndarray
    velocity_global: np.ndarray
    acceleration_global: np.ndarray


def point_motion(shape: PointShape, q, q_dot=None, q_ddot=None, pose: FramePose | None = None) -> PointMotion:
    """Global motion of the point (Eqs. 1-3) for elastic state (q, q_dot, q_ddot) and frame pose."""
    pose = pose or FramePose()
    zeros = np.zeros_like(np.asarray(q, dtype=float))
    q_dot = zeros if q_dot is None else q_dot
    q_ddot = zeros if q_ddot is None else q_ddot
    u = shape.undeformed_body + shape.displacement_body(q)
    v_el = shape.displacement_body(q_dot)
    a_el = shape.displacement_body(q_ddot)
    w, al = np.asarray(pose.omega_body, float), np.asarray(pose.alpha_body, float)
    r = pose.R + pose.A @ u
    v = pose.R_dot + pose.A @ (np.cross(w, u) + v_el)
    a = pose.R_ddot + pose.A @ (np.cross(al, u) + np.cross(w, np.cross(w, u)) + 2 * np.cross(w, v_el) + a_el)
    return PointMotion(r, v, a)
