"""Rotation from linear motion quantities (paper Section 2, Eqs. 17-22).

Implements Section 2 of X. Liu, "A Novel Approach for Flexible Body Dynamics
Computation via Synthesizing Incremental Motions in Reconfigured Inertial
Frames" (``shared/papers/reframe-flexible-body.txt``): the evolution
of the rotation vector ``phi = theta * lambda`` (Rodrigues, Eqs. 17-22).  The
angular velocity ``g`` and angular acceleration ``h`` of a rigid body from the
relative velocities / accelerations of three body points P, Q, R (Eqs. 4-14)
are in :mod:`flexfmu.core.angular_motion`.

Conventions (all SI: m, m/s, m/s^2, rad, rad/s, rad/s^2; float64)
------------------------------------------------------------------
* ``skew(v)`` is the standard cross-product matrix: ``skew(v) @ x == v x x``.
* ``paper_skew(v) == -skew(v)`` is the paper's matrix of Eqs. (17) and (21):
  ``M_hat = paper_skew(lambda)``, ``Omega = paper_skew(omega_body)``.
* ``A = rotation_matrix(phi) = exp(paper_skew(phi)) = exp(theta * M_hat)``
  (Eq. 18) is the paper's "coordinate transformation matrix of the body-fixed
  frame with respect to the global frame": it maps **global components to
  body components**, ``v_body = A @ v_global``; its rows are the body axes
  n'_i in global components.  The body->global matrix is ``A.T``, which is
  ``scipy.spatial.transform.Rotation.from_rotvec(phi).as_matrix()``.
  The axis ``lambda`` has the same components in both frames (``A @ lambda
  == lambda``), so "lambda in global components" (paper) is unambiguous.
* With this A, ``dA/dt = Omega @ A`` where ``Omega = paper_skew(omega_body)``
  (equivalently ``d(A.T)/dt = A.T @ skew(omega_body)``), so Eq. (20)-(22)
  take the **body-frame** angular velocity, exactly as Eq. (21) says.

The one home of the rotation formulas
-------------------------------------
Each formula is written once, here: Rodrigues (:func:`rodrigues`,
:func:`rodrigues_into`; checked: :func:`rotation_matrix`), the rotation
vector and unit quaternion of a matrix (:func:`quaternion_from_rotation`;
checked: :func:`rotvec_from_matrix`) and the rotation-vector rate of
Eqs. (20)-(22) (:func:`rotvec_rate_unchecked`, :func:`rotvec_rate_coefficient`;
checked: :func:`rotvec_rate`).  The unchecked forms are for per-step hot paths
(the numpy reframe kernels, the paper scheme) and take float (3,) / (3, 3)
arrays as they are; the checked ones check user input and call them.  The C
kernels (flexfmu/native/csrc/reframe_kernels.c) keep their own twins with the
same expressions in the same order (native FMUs have no Python);
tests/test_native_reframe_kernels.py compares the two.

Rotation-vector kinematics (Eqs. 20-22) as a 3-vector
-----------------------------------------------------
With ``M = theta M_hat = paper_skew(phi)`` and ``Omega = paper_skew(w)``
(w = body-frame angular velocity), Eq. (22)'s ``ad_M_hat = -[M_hat, .]``
with the paper's bracket ``[X, Y] = Y X - X Y`` is the ordinary commutator
``ad_M_hat(N) = M_hat N - N M_hat`` (the two sign flips cancel), and Eq. (22)
is the standard inverse of the derivative of the exponential map,
``dexp^{-1}_M``.  Because ``[paper_skew(a), paper_skew(b)] =
paper_skew(-(a x b))``, ``ad_M`` acts on the vectors as ``n -> -phi x n``, so

    dphi/dt = w + 1/2 phi x w + c(theta) phi x (phi x w),
    c(theta) = (1 - (theta/2) cot(theta/2)) / theta**2

(the Bortz equation with body-frame w).  ``c`` is evaluated with its Taylor
series for small theta (``c(0) = 1/12``, no 0/0) and is singular at
``theta = 2 pi`` (``cot(pi)``), hence :func:`reparametrize`.
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.core.vec3 import components as _components
from flexfmu.core.vec3 import cross as _cross
from flexfmu.core.vec3 import skew as _skew_unchecked

__all__ = [
    "skew",
    "paper_skew",
    "rodrigues",
    "rodrigues_into",
    "rotation_matrix",
    "rotvec_from_matrix",
    "quaternion_from_rotation",
    "rotvec_rate",
    "rotvec_rate_unchecked",
    "rotvec_rate_matrix",
    "reparametrize",
    "rotvec_rate_coefficient",
]

# Below this angle c(theta) of Eq. (22) is taken from its Taylor series
# (truncation error < theta**8 / 4.8e7 < 3e-16 at the switch).
_SERIES_THETA = 0.1
# Below this angle Rodrigues' coefficients sin(t)/t and (1 - cos t)/t^2 are taken from their series.
_RODRIGUES_SERIES_THETA = 1e-4


# --------------------------------------------------------------------------
# input checking
# --------------------------------------------------------------------------
def _vec3(x, name: str) -> np.ndarray:
    """Return ``x`` as a finite float64 3-vector or raise ParameterError(name) (flexfmu.core.angular_motion
    checks its inputs with it too)."""
    try:
        v = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(name, f"not a numeric 3-vector ({exc})", "finite 3-vector") from None
    if v.shape != (3,):
        raise ParameterError(name, f"shape {v.shape}, expected (3,)", "finite 3-vector")
    if not np.all(np.isfinite(v)):
        raise ParameterError(name, "contains NaN or Inf", "finite 3-vector")
    return v


# --------------------------------------------------------------------------
# skew matrices
# --------------------------------------------------------------------------
def skew(v) -> np.ndarray:
    """Standard cross-product matrix: ``skew(v) @ x == np.cross(v, x)``.

    ``[[0, -v3, v2], [v3, 0, -v1], [-v2, v1, 0]]``; any frame (the matrix has
    the components of ``v`` in whatever frame ``v`` is given).
    """
    return _skew_unchecked(_vec3(v, "v"))


def paper_skew(v) -> np.ndarray:
    """The paper's skew matrix of Eqs. (17) and (21): ``-skew(v)``.

    ``[[0, v3, -v2], [-v3, 0, v1], [v2, -v1, 0]]``, so
    ``paper_skew(v) @ x == x cross v``.  ``M_hat = paper_skew(lambda)``
    (Eq. 17), ``M = paper_skew(theta*lambda)``,
    ``Omega = paper_skew(omega_body)`` (Eq. 21).
    """
    return -skew(v)


# --------------------------------------------------------------------------
# Rodrigues and its inverse  (Eqs. 17-19)
# --------------------------------------------------------------------------
def _rodrigues_entries(x: float, y: float, z: float) -> tuple:
    """The 9 entries (row-major) of ``exp(skew(phi))``, phi = (x, y, z): the one Rodrigues formula.

    ``I + a K + b K K`` with ``K = skew(phi)``, ``a = sin(t)/t``, ``b = (1 - cos t)/t^2`` (t = |phi|; series
    below 1e-4 rad) and ``K K = phi phi^T - t^2 I``, element by element: the expressions, in this order, of
    the C kernels' twin ffx_reframe_rodrigues (flexfmu/native/csrc/reframe_kernels.c, compared in
    tests/test_native_reframe_kernels.py).
    """
    th2 = x * x + y * y + z * z
    th = math.sqrt(th2)
    if th < _RODRIGUES_SERIES_THETA:
        a = 1.0 - th2 / 6.0 + th2 * th2 / 120.0
        b = 0.5 - th2 / 24.0 + th2 * th2 / 720.0
    else:
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / th2
    return (1.0 + b * (x * x - th2), -a * z + b * x * y, a * y + b * x * z,
            a * z + b * x * y, 1.0 + b * (y * y - th2), -a * x + b * y * z,
            -a * y + b * x * z, a * x + b * y * z, 1.0 + b * (z * z - th2))


def rodrigues(phi) -> np.ndarray:
    """``exp(skew(phi))`` (3, 3), unchecked (hot paths; phi: a float (3,) array): the **body -> global**
    matrix of the rotation vector phi, ``rotation_matrix(phi).T``, scipy's
    ``Rotation.from_rotvec(phi).as_matrix()``.  Formula: :func:`_rodrigues_entries`."""
    x, y, z = _components(phi)
    return np.array(_rodrigues_entries(x, y, z)).reshape(3, 3)


def rodrigues_into(phi, R) -> np.ndarray:
    """:func:`rodrigues` written into the row-major (9,) array R (returned), unchecked."""
    x, y, z = _components(phi)
    R[:] = _rodrigues_entries(x, y, z)
    return R


def rotation_matrix(rotvec) -> np.ndarray:
    """Eqs. (18)-(19): ``A = exp(theta M_hat) = I + sin(theta) M_hat + (1 - cos(theta)) M_hat^2``.

    rotvec = theta * lambda (rad; same components in global and body frame).
    A maps **global components to body components** (``v_body = A @ v_global``)
    and equals ``Rotation.from_rotvec(rotvec).as_matrix().T``.

    The checked form of :func:`rodrigues` (``A = rodrigues(rotvec).T``: ``M = paper_skew(phi) = -skew(phi)``);
    its series for the coefficients below 1e-4 rad makes theta = 0 no special case.
    """
    return rodrigues(_vec3(rotvec, "rotvec")).T.copy()


def _rotvec_of(R) -> tuple:
    """The rotation vector (px, py, pz), ``|phi| <= pi``, of the **body -> global** matrix R (unchecked): the
    unit quaternion by Shepperd's largest-pivot method (scalar part made >= 0), then
    ``theta = 2 atan2(|q_v|, q_w)``.  The one home of the formula (:func:`rotvec_from_matrix`,
    :func:`quaternion_from_rotation`; the C kernels' twin is ffx_reframe_quaternion)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(R, dtype=np.float64).tolist()
    tr = r00 + r11 + r22
    k = 0
    best = tr
    for i, d in enumerate((r00, r11, r22)):      # the largest pivot (the first of equal ones)
        if d > best:
            best = d
            k = i + 1
    if k == 0:
        w = 0.5 * math.sqrt(1.0 + tr)
        x = (r21 - r12) / (4 * w)
        y = (r02 - r20) / (4 * w)
        z = (r10 - r01) / (4 * w)
    elif k == 1:
        x = 0.5 * math.sqrt(1.0 + r00 - r11 - r22)
        w = (r21 - r12) / (4 * x)
        y = (r01 + r10) / (4 * x)
        z = (r02 + r20) / (4 * x)
    elif k == 2:
        y = 0.5 * math.sqrt(1.0 - r00 + r11 - r22)
        w = (r02 - r20) / (4 * y)
        x = (r01 + r10) / (4 * y)
        z = (r12 + r21) / (4 * y)
    else:
        z = 0.5 * math.sqrt(1.0 - r00 - r11 + r22)
        w = (r10 - r01) / (4 * z)
        x = (r02 + r20) / (4 * z)
        y = (r12 + r21) / (4 * z)
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    n = math.sqrt(x * x + y * y + z * z)
    if n < 1e-8:   # theta < 2e-8: 2 atan2(n, w)/n = (2/w)(1 - (n/w)^2/3 + ...)
        scale = (2.0 / w) * (1.0 - (n / w) ** 2 / 3.0)
    else:
        scale = 2.0 * math.atan2(n, w) / n
    return scale * x, scale * y, scale * z


def rotvec_from_matrix(A, atol: float = 1e-6) -> np.ndarray:
    """Inverse of :func:`rotation_matrix`: phi with ``rotation_matrix(phi) == A``, ``|phi| <= pi``.

    A: global->body rotation matrix (same convention as :func:`rotation_matrix`).
    Robust for all angles including theta ~ pi: goes through the unit
    quaternion of ``A.T`` (Shepperd's largest-pivot method, scalar part
    made >= 0) and ``theta = 2 atan2(|q_v|, q_w)`` (:func:`_rotvec_of`).  At exactly theta = pi
    the sign of phi is arbitrary (both describe the same rotation).

    Raises :class:`ParameterError` ("A") if A is not 3x3, not finite, or not
    a proper rotation within ``atol`` (``|A^T A - I|_max``, ``det A > 0``).
    """
    try:
        A = np.asarray(A, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError("A", "not a numeric 3x3 matrix", "proper rotation matrix") from None
    if A.shape != (3, 3) or not np.all(np.isfinite(A)):
        raise ParameterError("A", f"shape {A.shape} or non-finite entries", "finite 3x3 rotation matrix")
    err = float(np.max(np.abs(A.T @ A - np.eye(3))))
    if err > atol or np.linalg.det(A) <= 0.0:
        raise ParameterError("A", f"not a proper rotation (|A^T A - I| = {err:.3g}, det = "
                                  f"{np.linalg.det(A):.6g})", f"orthonormal within {atol:g}, det = +1")
    return np.array(_rotvec_of(A.T))  # A.T: body -> global, R = exp(skew(phi))


def quaternion_from_rotation(R) -> np.ndarray:
    """Unit quaternion (w, x, y, z), w >= 0, of the **body -> global** rotation matrix R (unchecked: hot
    paths, the reframe outputs): ``(cos(t/2), sin(t/2) phi/t)`` of ``phi = _rotvec_of(R)``, t = |phi|."""
    px, py, pz = _rotvec_of(R)
    th = math.sqrt(px * px + py * py + pz * pz)
    s = 0.5 if th == 0.0 else math.sin(0.5 * th) / th
    return np.array((math.cos(0.5 * th), s * px, s * py, s * pz))


# --------------------------------------------------------------------------
# rotation-vector evolution  (Eqs. 20-22)
# --------------------------------------------------------------------------
def rotvec_rate_coefficient(theta: float) -> float:
    """``c(theta) = (1 - (theta/2) cot(theta/2)) / theta^2`` of Eq. (22); series near 0 (theta >= 0).

    The one Python form (the C kernels' twin: ffx_reframe_rate_coefficient)."""
    if theta < _SERIES_THETA:
        t2 = theta * theta
        return 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 / 1209600.0))
    half = 0.5 * theta
    return (1.0 - half * math.cos(half) / math.sin(half)) / (theta * theta)


def rotvec_rate_unchecked(phi, w) -> np.ndarray:
    """:func:`rotvec_rate` without input checks (hot paths; phi, w: float (3,) arrays)."""
    p0, p1, p2 = _components(phi)
    th = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    pxw = _cross(phi, w)
    return w + 0.5 * pxw + rotvec_rate_coefficient(th) * _cross(phi, pxw)


def rotvec_rate(rotvec, omega_body) -> np.ndarray:
    """Eqs. (20)-(22) as a 3-vector: ``d(theta lambda)/dt`` (rad/s).

    rotvec: phi = theta * lambda of ``A = rotation_matrix(phi)`` (global->body).
    omega_body: angular velocity with **body-frame** components (rad/s),
    the omega' of Eq. (21).

        dphi/dt = w + 1/2 phi x w + c(theta) phi x (phi x w),
        c = (1 - (theta/2) cot(theta/2)) / theta^2,  c -> 1/12 (series) as theta -> 0.

    This is ``paper_skew^{-1}`` of Eq. (20)'s ``dM/dt = f^{-1} Omega``
    (see :func:`rotvec_rate_matrix`).  Singular at theta = 2 pi: keep
    theta <= pi with :func:`reparametrize` (call it after every accepted
    integration step, never between the stages of one step).  The checked form of
    :func:`rotvec_rate_unchecked`.
    """
    return rotvec_rate_unchecked(_vec3(rotvec, "rotvec"), _vec3(omega_body, "omega_body"))


def rotvec_rate_matrix(M_hat, theta: float, Omega) -> np.ndarray:
    """Eq. (20) with Eq. (22) literally, in the paper's matrix form: ``dM/dt`` (3x3).

    M_hat = paper_skew(lambda) (Eq. 17), theta (rad), Omega =
    paper_skew(omega_body) (Eq. 21).  Uses the paper's
    ``ad_M_hat(N) = -[M_hat, N]`` with ``[M_hat, N] = N M_hat - M_hat N``.
    Returns ``dM/dt`` where ``M = theta M_hat``; equal to
    ``paper_skew(rotvec_rate(theta*lambda, omega_body))``.  Kept as the
    literal transcription for cross-checking; the integrator should use
    :func:`rotvec_rate`.
    """
    M_hat = np.asarray(M_hat, dtype=np.float64)
    Omega = np.asarray(Omega, dtype=np.float64)

    def ad(N):
        return -(N @ M_hat - M_hat @ N)

    if theta == 0.0:
        return Omega.copy()
    # (theta cot(theta/2)/2 - 1) = -theta^2 c(theta); series-safe via rotvec_rate_coefficient
    k2 = -theta * theta * rotvec_rate_coefficient(abs(theta))
    adO = ad(Omega)
    return Omega - (theta / 2.0) * adO - k2 * ad(adO)


def reparametrize(rotvec) -> np.ndarray:
    """Map phi with ``theta = |phi| > pi`` to the equivalent phi' with ``|phi'| <= pi``.

    ``phi' = lambda (theta - 2 pi k)``, k = ceil((theta - pi)/(2 pi)) (k = 1
    for pi < theta <= 3 pi, the case that occurs in integration), which has
    the same rotation matrix (``rotation_matrix(phi') == rotation_matrix(phi)``)
    and theta' in (-pi, pi], i.e. |phi'| <= pi.  Returned unchanged (copy)
    if theta <= pi.

    Why: Eq. (22)'s coefficient ``cot(theta/2)`` is singular at theta = 2 pi.
    When to call: after each accepted integration step of
    :func:`rotvec_rate` (not inside the stages of one step: all stages of a
    step must use the same chart).  With a step that turns the body by much
    less than pi, theta then never exceeds ~pi + |omega| dt.  phi' is a
    different point of the parameter space, so any quantity carried along
    in phi-coordinates (not needed here) would have to be mapped too.
    """
    phi = _vec3(rotvec, "rotvec")
    theta = float(np.linalg.norm(phi))
    if theta <= np.pi:
        return phi.copy()
    k = np.ceil((theta - np.pi) / (2.0 * np.pi))
    return phi * ((theta - 2.0 * np.pi * k) / theta)
