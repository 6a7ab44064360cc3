"""States and outputs of the reframe integrator (:mod:`flexfmu.reframe.integrator`): the explicit
state, its flat form for the kernels, and the output records of one state and of a run."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.reframe.layout import STATE

__all__ = ["ReframeState", "NodalState", "ReframeResult", "Snapshot"]


@dataclass
class ReframeState:
    """Explicit state of the reframe integrator.

    t:         s.
    position:  (3,) global position of the frame point = centre of mass of the dummy rigid body, m.
    rotation:  (3, 3) body -> global rotation of the dummy body (its frame is the current frame).
    eta:       (2 n_modes,) modal state in the current frame, Eq. (33): [q_R, q_F, qdot_R, qdot_F].
    rotvec:    (3,) scheme="paper" only: the integrated rotation vector M of Eq. (38), |M| <= pi,
               with ``rotation_matrix(rotvec) == rotation.T``.
    """

    t: float
    position: np.ndarray
    rotation: np.ndarray
    eta: np.ndarray
    rotvec: np.ndarray | None = None


def _state_vector(s: ReframeState) -> np.ndarray:
    """[position, rotation (row-major), eta] of a state as one float array for the kernels.  A state made by
    the kernels holds views into one such array (``_flat``): reused while all three fields are still views
    of it (assigning a new array to a field makes a copy here instead); the kernels never write into y0."""
    flat = s.__dict__.get("_flat")
    if flat is not None and s.position.base is flat and s.rotation.base is flat and s.eta.base is flat:
        return flat
    return np.concatenate((s.position, np.ravel(s.rotation), s.eta)).astype(float, copy=False)


def _state_from_vector(t: float, y: np.ndarray) -> ReframeState:
    s = ReframeState(t=t, position=y[STATE.position], rotation=y[STATE.rotation].reshape(3, 3), eta=y[STATE.eta])
    s.__dict__["_flat"] = y
    return s


@dataclass
class NodalState:
    """All nodal quantities of a state.

    positions:      (N, 3) global node positions, m.
    displacement:   (n_dof,) elastic displacement x in the current frame (body components).
    velocity_body:  (n_dof,) nodal velocities (translations: m/s; rotational DOFs: angular
                    velocity of the node, rad/s), body components, in the inertial frame.
    velocity:       (n_dof,) the same in global components.
    """

    positions: np.ndarray
    displacement: np.ndarray
    velocity_body: np.ndarray
    velocity: np.ndarray


@dataclass
class ReframeResult:
    """Time histories from :meth:`ReframeIntegrator.run` (first axis: the n_t output times).

    t (n_t,); frame_origin (n_t, 3): global position of the body frame origin (mesh origin of the
    dummy body); frame_origin_velocity (n_t, 3) its time derivative, global; rotation (n_t, 3, 3) body -> global; quaternion (n_t, 4) (w, x, y, z);
    omega, alpha (n_t, 3) body frame, rad/s, rad/s^2; com_position, com_velocity (n_t, 3) global;
    q, qd (n_t, n_flexible) flexible modal coordinates / velocities; max_elastic_displacement (n_t,)
    max over nodes of |elastic translation|, m; points (n_p,) node indices; point_position,
    point_velocity, point_acceleration (n_t, n_p, 3) global, full motion; point_position_rigid,
    point_velocity_rigid, point_acceleration_rigid the embedded rigid part
    (a_o + alpha x r + omega x (omega x r)); final_state: the last :class:`ReframeState`.
    """

    t: np.ndarray
    frame_origin: np.ndarray
    frame_origin_velocity: np.ndarray
    rotation: np.ndarray
    quaternion: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    com_position: np.ndarray
    com_velocity: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    max_elastic_displacement: np.ndarray
    points: np.ndarray
    point_position: np.ndarray
    point_velocity: np.ndarray
    point_acceleration: np.ndarray
    point_position_rigid: np.ndarray
    point_velocity_rigid: np.ndarray
    point_acceleration_rigid: np.ndarray
    final_state: ReframeState = None



@dataclass
class Snapshot:
    """Outputs of one state: the fields of :class:`ReframeResult` without the time axis (point fields
    (n_p, 3))."""

    t: float
    frame_origin: np.ndarray
    frame_origin_velocity: np.ndarray
    rotation: np.ndarray
    quaternion: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    com_position: np.ndarray
    com_velocity: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    max_elastic_displacement: float
    point_position: np.ndarray
    point_velocity: np.ndarray
    point_acceleration: np.ndarray
    point_position_rigid: np.ndarray
    point_velocity_rigid: np.ndarray
    point_acceleration_rigid: np.ndarray
