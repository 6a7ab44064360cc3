"""The angular velocity g and angular acceleration h of a rigid body from three of its points (paper Section 2,
Eqs. 4-14).

Section 2 of X. Liu, "A Novel Approach for Flexible Body Dynamics Computation via Synthesizing Incremental Motions
in Reconfigured Inertial Frames" (``shared/papers/reframe-flexible-body.txt``): g and h from the relative
velocities / accelerations of three body points P, Q, R.  The rotation itself (Rodrigues, the rotation vector and
its rate, Eqs. 17-22) is in :mod:`flexfmu.core.rotation`.

Conventions (all SI: m, m/s, m/s^2, rad/s, rad/s^2; float64)
-------------------------------------------------------------
* ``angular_velocity`` / ``angular_acceleration`` are frame-agnostic: all
  inputs in one frame (global or body), result in that same frame.

Derivations of the equations missing from the extracted text
------------------------------------------------------------
Eq. (4)  ``{e1, e2, e3}^T = B {n'1, n'2, n'3}^T``: row i of B holds the
         components of e_i (``e1 = p/|p|``, ``e2 = q/|q|``,
         ``e3 = e1 x e2 / |e1 x e2|``); see :func:`oblique_basis`.
Eq. (8)  ``omega = B^T omega_hat``, i.e. ``omega = sum_i omega_hat^i e_i``.
         The hat components are the *contravariant* components (the
         coefficients of the expansion along e_i), NOT the dual/covariant
         projections ``omega . e_i``.  Proof: with ``v_P = omega x p`` and
         ``s = |e1 x e2|``, ``c = e1 . e2``:
         ``v_P . e3 = p omega_hat^2 (e2 x e1) . e3 = -p s omega_hat^2`` (Eq. 6),
         ``v_Q . e3 = q omega_hat^1 (e1 x e2) . e3 = q s omega_hat^1`` (Eq. 7),
         ``v_P . (e2 - c e1) = p omega_hat^3 (e3 x e1) . e2 = p s omega_hat^3``
         (Eq. 5), using ``e3 x e1 = (e2 - c e1)/s``.  The covariant reading
         would require ``omega . e1 = omega_hat^1 + c omega_hat^2`` instead,
         which differs whenever p, q are not orthogonal (the tests show it).
Eq. (13) ``alpha = B^T alpha_hat``, for the same reason: for a rigid body
         ``a_P/R = alpha x p + omega x v_P/R``, so Eqs. (10)-(12) are Eqs.
         (5)-(7) with ``v`` replaced by ``a - omega x v``.  Eq. (10) is
         written in the equivalent form ``(a_P - omega x v_P) . (e3 x e1)/p``.
"""
from __future__ import annotations

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.core.rotation import _vec3

__all__ = [
    "oblique_basis",
    "angular_velocity_oblique",
    "angular_velocity",
    "angular_acceleration_oblique",
    "angular_acceleration",
    "MIN_SINE",
]

#: Default smallest allowed ``|e1 x e2|`` (sine of the angle between p and q).
#: Errors in g and h are amplified by ~1/|e1 x e2|.
MIN_SINE = 1e-6


# --------------------------------------------------------------------------
# g and h  (Eqs. 4-14)
# --------------------------------------------------------------------------
def oblique_basis(p_vec, q_vec, min_sine: float = MIN_SINE):
    """Eq. (4): matrix B whose rows are e1, e2, e3, plus ``|e1 x e2|``.

    ``p_vec = RP``, ``q_vec = RQ`` (m) in any one frame; the rows of B are in
    that frame (the paper uses the body frame).  ``e1 = p/|p|``,
    ``e2 = q/|q|``, ``e3 = e1 x e2 / |e1 x e2|`` (unit, normal to e1, e2;
    e1, e2 generally not orthogonal).

    Returns ``(B, p, q, s)`` with ``p = |p_vec|``, ``q = |q_vec|`` and
    ``s = |e1 x e2|``.  Raises :class:`ParameterError` if p_vec or q_vec is
    zero / non-finite, or if they are (nearly) colinear (``s < min_sine``).
    """
    p_vec = _vec3(p_vec, "p_vec")
    q_vec = _vec3(q_vec, "q_vec")
    p = float(np.linalg.norm(p_vec))
    q = float(np.linalg.norm(q_vec))
    if not p > 0.0:
        raise ParameterError("p_vec", "zero length: points R and P coincide", "non-zero vector R->P")
    if not q > 0.0:
        raise ParameterError("q_vec", "zero length: points R and Q coincide", "non-zero vector R->Q")
    e1 = p_vec / p
    e2 = q_vec / q
    n = np.cross(e1, e2)
    s = float(np.linalg.norm(n))
    if not s >= min_sine:
        raise ParameterError(
            "p_vec, q_vec",
            f"R->P and R->Q are (nearly) colinear, |e1 x e2| = {s:.3g}",
            f"|e1 x e2| >= {min_sine:g} (P, Q, R not on one line)",
        )
    e3 = n / s
    return np.vstack((e1, e2, e3)), p, q, s


def _hat_components(B, p, q, s, w_P, w_Q) -> np.ndarray:
    """Shared core of Eqs. (5)-(7) and (10)-(12).

    For a rigid body ``w_P = x x p`` and ``w_Q = x x q`` with x = omega
    (Eqs. 5-7, w = v) or x = alpha (Eqs. 10-12, w = a - omega x v); returns
    the contravariant components ``x_hat`` of x along e1, e2, e3.
    """
    e1, e2, e3 = B
    x3 = float(w_P @ np.cross(e3, e1)) / p          # e3 x e1 = (e2 - (e1.e2) e1)/s
    x2 = -float(w_P @ e3) / (p * s)
    x1 = float(w_Q @ e3) / (q * s)
    return np.array([x1, x2, x3])


def angular_velocity_oblique(p_vec, q_vec, v_PR, v_QR, min_sine: float = MIN_SINE) -> np.ndarray:
    """Eqs. (5)-(7): components ``(omega_hat^1, omega_hat^2, omega_hat^3)``.

    They are the contravariant components along the oblique basis e1, e2, e3
    of :func:`oblique_basis` (``omega = sum_i omega_hat^i e_i``), not the
    projections ``omega . e_i``.  Inputs as in :func:`angular_velocity`.

    * Eq. (5): ``omega_hat^3 = v_P/R . (e2 - e1 (e1.e2)) / (p |e1 x e2|)``
    * Eq. (6): ``omega_hat^2 = -v_P/R . e3 / (p |e1 x e2|)``
    * Eq. (7): ``omega_hat^1 =  v_Q/R . e3 / (q |e1 x e2|)``

    Choice (as printed): omega_hat^3 is taken from P only.  For exactly rigid
    data Q gives the same value; for non-rigid data (a flexible body) the
    stretch components ``v_P/R . e1``, ``v_Q/R . e2`` and Q's estimate of
    omega_hat^3 are ignored.
    """
    B, p, q, s = oblique_basis(p_vec, q_vec, min_sine)
    v_PR = _vec3(v_PR, "v_PR")
    v_QR = _vec3(v_QR, "v_QR")
    return _hat_components(B, p, q, s, v_PR, v_QR)


def angular_velocity(p_vec, q_vec, v_PR, v_QR, min_sine: float = MIN_SINE) -> np.ndarray:
    """g of Eq. (9): angular velocity (rad/s) from relative velocities of P, Q.

    p_vec: R->P (m), q_vec: R->Q (m), v_PR = v_P - v_R, v_QR = v_Q - v_R (m/s),
    all four with components in the **same** frame (global, or body-fixed as
    in the paper); the returned omega is in that same frame.  p_vec and q_vec
    need not be orthogonal, only non-colinear (``|e1 x e2| >= min_sine``,
    else :class:`ParameterError`).

    Eqs. (5)-(7) give the oblique components (:func:`angular_velocity_oblique`);
    Eq. (8) (missing in the text, derived): ``omega = B^T omega_hat``.
    """
    B, p, q, s = oblique_basis(p_vec, q_vec, min_sine)
    v_PR = _vec3(v_PR, "v_PR")
    v_QR = _vec3(v_QR, "v_QR")
    return B.T @ _hat_components(B, p, q, s, v_PR, v_QR)


def angular_acceleration_oblique(p_vec, q_vec, v_PR, v_QR, a_PR, a_QR, omega,
                                 min_sine: float = MIN_SINE) -> np.ndarray:
    """Eqs. (10)-(12): contravariant components of alpha along e1, e2, e3.

    * Eq. (10): ``alpha_hat^3 = (e3 x (omega x v_P/R) - e3 x a_P/R) . e1 / p``
    * Eq. (11): ``alpha_hat^2 = (omega x v_P/R - a_P/R) . e3 / (p |e1 x e2|)``
    * Eq. (12): ``alpha_hat^1 = (a_Q/R - omega x v_Q/R) . e3 / (q |e1 x e2|)``

    Inputs as in :func:`angular_acceleration`.
    """
    B, p, q, s = oblique_basis(p_vec, q_vec, min_sine)
    v_PR = _vec3(v_PR, "v_PR")
    v_QR = _vec3(v_QR, "v_QR")
    a_PR = _vec3(a_PR, "a_PR")
    a_QR = _vec3(a_QR, "a_QR")
    omega = _vec3(omega, "omega")
    w_P = a_PR - np.cross(omega, v_PR)   # = alpha x p for a rigid body
    w_Q = a_QR - np.cross(omega, v_QR)   # = alpha x q
    return _hat_components(B, p, q, s, w_P, w_Q)


def angular_acceleration(p_vec, q_vec, v_PR, v_QR, a_PR, a_QR, omega,
                         min_sine: float = MIN_SINE) -> np.ndarray:
    """h of Eq. (14): angular acceleration (rad/s^2) from relative motion of P, Q.

    p_vec, q_vec: R->P, R->Q (m); v_PR, v_QR: relative velocities (m/s);
    a_PR = a_P - a_R, a_QR = a_Q - a_R (m/s^2); omega: angular velocity
    (rad/s, e.g. from :func:`angular_velocity`).  All in the same frame
    (global or body); alpha is returned in that frame.  (alpha = d omega/dt
    is the same whether differentiated in the global or the body frame.)

    Eqs. (10)-(12) give the oblique components; Eq. (13) (missing, derived):
    ``alpha = B^T alpha_hat``.  Eq. (14) prints ``v_O/R``, ``a_O/R``: read Q.
    """
    B, _, _, _ = oblique_basis(p_vec, q_vec, min_sine)
    return B.T @ angular_acceleration_oblique(p_vec, q_vec, v_PR, v_QR, a_PR, a_QR,
                                              omega, min_sine)
