"""Modal basis of a free-free structure: exact rigid-body modes plus the first flexible modes.

Paper (reframe-flexible-body, Eqs. 24-27): Psi = [Psi_R | Psi_F], the first columns being the
rigid-body modes.  Here

* the six rigid-body modes are built from the node positions, not taken from an eigensolver:
  three unit translations and three infinitesimal rotations ``e_k x (x - c)`` about the centre
  of mass ``c`` (computed from M), with rotational DOFs equal to the rotation vector ``e_k`` on
  6-DOF nodes.  They are then mass-orthonormalised symmetrically (Loewdin,
  ``Phi_R = [T | R] G^{-1/2}`` with ``G = [T | R]^T M [T | R]``), which keeps each column as
  close as possible to "translation along / rotation about body axis k";
* the flexible modes come from ``K phi = omega^2 M phi`` (dense ``scipy.linalg.eigh`` for
  small models; for large ones a block Lanczos method on the shift-inverted problem with a slightly
  negative shift, so that K - sigma M is definite, one factorisation of K - sigma M and the exact
  rigid subspace deflated from the solves), are M-orthogonalised against the exact rigid modes and
  finished by a Rayleigh-Ritz step, so that ``Psi^T M Psi = I`` and
  ``Psi^T K Psi = diag(0, ..., 0, omega_1^2, ...)`` to round-off; omega^2 is each mode's Rayleigh
  quotient accumulated in extended precision, and every mode's residual
  ``|K phi - omega^2 M phi| / |K phi|`` is checked.

The factorisation uses SuperLU (scipy); if the optional ``pypardiso`` package (Intel MKL PARDISO) is
installed, its sparse Cholesky instead (faster), unless the environment sets ``FLEXFMU_PARDISO=0``.
"""
from __future__ import annotations

import numbers
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy
import scipy.linalg as sla
import scipy.sparse as sp

from flexfmu.core import cache as _cache
from flexfmu.core.blas import limited_for
from flexfmu.core.progress import progress_bar
from flexfmu.errors import ModalConvergenceError, ParameterError
from flexfmu.core.io import validate_structure
from flexfmu.linalg.cutoffs import BASIS_DENSE_MAX_DOF
from flexfmu.linalg.lanczos import (EPS, _block_lanczos, _mkl_pardiso, _MBasis, _normalize,  # noqa: F401
                                    _one_openblas_thread, _Pardiso, _shifted_solver, _upper_triangle)
from flexfmu.linalg.modal import dense_low_modes
from flexfmu.core.structure import N_RIGID, Structure

DENSE_LIMIT = BASIS_DENSE_MAX_DOF   # n_dof up to which method="auto" uses dense eigh (why: flexfmu.linalg.cutoffs)
DEFAULT_SIGMA = -1.0       # rad^2/s^2: shift for sparse shift-invert (K - sigma M is then definite)
RIGID_FORCE_RTOL = 1e-8    # max|K phi_rigid| / max(|K| |phi_rigid|) allowed (free-free check)
ZERO_EIG_RTOL = 1e-13      # a flexible omega^2 below this times max(K_ii / M_ii) counts as a zero mode
CACHE_MIN_DOF = 3000       # cache=None: bases of models this large or larger go to the on-disk cache
KRYLOV_BLOCK = 5           # columns per block solve of the sparse eigensolver (SuperLU: ~0.5x the time per column)
KRYLOV_RTOL = 1e-7         # sparse mode converged: Ritz residual |S M x - theta x|_M <= this * theta
KRYLOV_MAX_DIM = 400       # largest sparse search space (columns) before ModalConvergenceError
# (the Krylov settings are read here, per call, and passed to flexfmu.linalg.lanczos: tests and
# benchmarks/modal_plate.py vary them on this module)
RESIDUAL_RTOL = 1e-6       # returned mode: |K phi - lam M phi| / |K phi| <= this + 1000 x round-off floor


@dataclass(frozen=True)
class MassProperties:
    """Rigid-body mass properties computed from M and the node positions.

    mass:            total mass, kg.
    center_of_mass:  (3,) m, body frame.
    inertia:         (3, 3) inertia tensor about the centre of mass, body axes, kg m^2.
    """

    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray

    @property
    def principal_moments(self) -> np.ndarray:
        """Principal moments of inertia, ascending, kg m^2."""
        return np.linalg.eigvalsh(self.inertia)

    @property
    def principal_axes(self) -> np.ndarray:
        """(3, 3) columns = principal axes, in the order of :attr:`principal_moments`."""
        return np.linalg.eigh(self.inertia)[1]


@dataclass
class ModalBasis:
    """Psi = [rigid | flexible], mass-orthonormal (Psi^T M Psi = I).

    shapes:           (n_dof, 6 + n_flexible) Psi; columns 0-5 rigid, then flexible ascending.
    frequencies_hz:   (n_flexible,) flexible natural frequencies, Hz.
    stiffness:        (6 + n_flexible,) modal stiffness diag(Psi^T K Psi) = omega^2, exactly 0 for rigid.
    damping:          (6 + n_flexible,) modal damping diag, 2 zeta omega, 0 for rigid.
    damping_ratio:    (n_flexible,) zeta per flexible mode.
    mass, center_of_mass, inertia:   as :class:`MassProperties`.
    rigid_transform:  (6, 6) A with Psi_R = [T | R] A, T = unit translations along x, y, z,
                      R = unit rotations about x, y, z through the centre of mass; hence
                      [translation; rotation vector] = A q_R for rigid modal coordinates q_R.
    method:           "dense" or "sparse" (how the flexible modes were computed; "none" if 0).
    """

    shapes: np.ndarray
    frequencies_hz: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    damping_ratio: np.ndarray
    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray
    rigid_transform: np.ndarray
    method: str

    n_rigid = N_RIGID

    @property
    def n_flexible(self) -> int:
        return self.shapes.shape[1] - N_RIGID

    @property
    def n_modes(self) -> int:
        return self.shapes.shape[1]

    @property
    def rigid(self) -> np.ndarray:
        """(n_dof, 6) rigid-body modes."""
        return self.shapes[:, :N_RIGID]

    @property
    def flexible(self) -> np.ndarray:
        """(n_dof, n_flexible) flexible modes."""
        return self.shapes[:, N_RIGID:]

    @property
    def omega(self) -> np.ndarray:
        """(n_flexible,) flexible angular natural frequencies, rad/s."""
        return 2.0 * np.pi * self.frequencies_hz


# --------------------------------------------------------------------------- rigid-body modes
def _unit_fields(nodes: np.ndarray, dpn: int, origin: np.ndarray) -> np.ndarray:
    """(n_dof, 6): unit translations along x, y, z and unit rotations about x, y, z through ``origin``."""
    n = nodes.shape[0]
    r = nodes - origin
    B = np.zeros((n * dpn, 6))
    eye = np.eye(3)
    for k in range(3):
        B[k::dpn, k] = 1.0                                    # translation along e_k
        rot = np.cross(eye[k], r)                             # e_k x r
        for j in range(3):
            B[j::dpn, 3 + k] = rot[:, j]
        if dpn == 6:
            B[3 + k::dpn, 3 + k] = 1.0                        # rotation vector = e_k
    return B


def _rigid_parts(structure: Structure):
    """Mass, centre of mass, unnormalised rigid fields B about the COM and their Gram matrix."""
    nodes = np.asarray(structure.nodes, dtype=float)
    dpn = int(structure.dofs_per_node)
    M = structure.M
    B0 = _unit_fields(nodes, dpn, np.zeros(3))
    G0 = B0.T @ (M @ B0)
    masses = np.diag(G0)[:3]
    if np.any(masses <= 0.0):
        raise ParameterError("structure.M", f"rigid translation has no mass (x, y, z: {masses})",
                             "positive semi-definite with total mass > 0")
    mass = float(np.mean(masses))
    # Coupling translation i / rotation k about the origin: S_ik = m (e_k x c)_i = -m [c]x_ik.
    S = G0[:3, 3:]
    c = np.array([S[1, 2] - S[2, 1], S[2, 0] - S[0, 2], S[0, 1] - S[1, 0]]) / (2.0 * mass)
    B = _unit_fields(nodes, dpn, c)
    G = B.T @ (M @ B)
    G = 0.5 * (G + G.T)
    return mass, c, B, G


def mass_properties(structure: Structure) -> MassProperties:
    """Total mass, centre of mass and inertia tensor about it, from M via the rigid-body fields.

    inertia[k, l] = r_k^T M r_l with r_k the unit rotation about axis k through the centre of
    mass (for point masses this is sum m (|r|^2 delta_kl - r_k r_l)).
    """
    mass, c, _, G = _rigid_parts(validate_structure(structure))
    return MassProperties(mass=mass, center_of_mass=c, inertia=G[3:, 3:].copy())


def _rigid_orthonormal(structure: Structure):
    """Mass-orthonormal rigid modes of a validated structure, with A, mass, COM and inertia."""
    mass, c, B, G = _rigid_parts(structure)
    inertia = G[3:, 3:].copy()
    nodes = np.asarray(structure.nodes, dtype=float)
    size = float(np.linalg.norm(np.ptp(nodes, axis=0)))
    j_min = float(np.linalg.eigvalsh(inertia)[0])
    if j_min <= 1e-12 * mass * max(size, 1e-300) ** 2:
        raise ParameterError(
            "structure.M",
            f"singular free body: a rigid rotation has no inertia (smallest principal moment {j_min:.3g} kg m^2 "
            f"for mass {mass:.6g} kg and size {size:.3g} m), e.g. all nodes on one line without rotary inertia: "
            "fewer than six independent rigid-body modes",
            "mass and all three principal moments of inertia > 0")
    s, U = np.linalg.eigh(G)
    A = (U / np.sqrt(s)) @ U.T                      # G^{-1/2}, symmetric (Loewdin)
    return B @ A, A, mass, c, inertia


def rigid_body_modes(structure: Structure) -> np.ndarray:
    """(n_dof, 6) exact rigid-body modes, mass-orthonormal (Phi^T M Phi = I).

    Built from the node positions: translations along x, y, z and infinitesimal rotations about
    x, y, z through the centre of mass (from M); on 6-DOF nodes the rotational DOFs carry the
    rotation vector.  Symmetric orthonormalisation: see the module docstring.
    """
    return _rigid_orthonormal(validate_structure(structure))[0]


# --------------------------------------------------------------------------- flexible modes
def _check_n_flexible(n_flexible, n_dof: int) -> int:
    n_max = n_dof - N_RIGID
    allowed = f"integer 0 ... {n_max} (n_dof - 6)"
    if isinstance(n_flexible, bool) or not isinstance(n_flexible, numbers.Integral):
        raise ParameterError("n_flexible", f"{n_flexible!r} is not an integer", allowed)
    n = int(n_flexible)
    if n < 0 or n > n_max:
        raise ParameterError("n_flexible", f"{n} out of range", allowed)
    return n


def _check_damping(damping_ratio, n: int) -> np.ndarray:
    allowed = f"0 <= zeta <= 1, a number or {n} numbers (one per flexible mode)"
    try:
        z = np.asarray(damping_ratio, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError("damping_ratio", f"{damping_ratio!r} is not numeric", allowed) from None
    if z.ndim == 0:
        z = np.full(n, float(z))
    if z.shape != (n,):
        raise ParameterError("damping_ratio", f"shape {z.shape}", allowed)
    if not np.all(np.isfinite(z)) or np.any(z < 0.0) or np.any(z > 1.0):
        raise ParameterError("damping_ratio", f"{z}", allowed)
    return z


def _project_out(Phi: np.ndarray, M, V: np.ndarray) -> np.ndarray:
    """V minus its M-orthogonal projection onto the columns of Phi (Phi^T M Phi = I)."""
    return V - Phi @ (Phi.T @ (M @ V))



def _flexible_candidates(K, M, Phi: np.ndarray, n: int, method: str, sigma: float, progress=False) -> np.ndarray:
    """(n_dof, n) approximate lowest flexible eigenvectors of K phi = lambda M phi.

    dense:  flexfmu.linalg.modal.dense_low_modes on the full matrices (the inverted problem: eigh(K, M)
            loses ~1e-9 in the low modes through the Cholesky factor of M); the six lowest (rigid)
            eigenvectors are dropped by rigid content.
    sparse: block Lanczos in shift-invert mode (_block_lanczos), (K - sigma M)^{-1} factorised once
            (_shifted_solver), with the rigid-body subspace deflated: right-hand sides are stripped of
            their rigid part before the solve and results M-projected onto the flexible subspace after it.
            Without deflation the rigid components, amplified by 1/|sigma|, swamp the flexible
            ones and cost ~eps * lambda_max / |sigma| of relative accuracy (measured: residual
            3e-5 at sigma = -1 on the coarse plate, garbage at sigma = -0.01).
    """
    if method == "dense":
        Md = M.toarray()
        try:   # the inverted problem keeps the low modes accurate (flexfmu.linalg.modal.dense_low_modes)
            _, V = dense_low_modes(K.toarray(), Md, N_RIGID + n)
        except np.linalg.LinAlgError as exc:
            try:
                sla.cholesky(Md)
            except np.linalg.LinAlgError:
                raise ParameterError("structure.M", f"not positive definite ({exc})",
                                     "symmetric positive definite mass matrix for the dense eigensolver") from None
            raise ParameterError("structure.K", f"singular free body: K + s M is not positive definite ({exc}): "
                                 "K is indefinite or the structure has more than six zero-energy modes (a mechanism, "
                                 "or pieces not connected to each other)",
                                 "symmetric positive semi-definite K of a connected free structure") from None
        rigid_content = np.sum((Phi.T @ (M @ V)) ** 2, axis=0)
        return V[:, np.sort(np.argsort(rigid_content)[:n])]

    solve, close, _ = _shifted_solver(K, M, sigma)
    MPhi = np.asarray(M @ Phi)

    def apply_op(MX):
        X = solve(MX - MPhi @ (Phi.T @ MX))        # rhs without rigid part (P^T b)
        return X - Phi @ (MPhi.T @ X)               # result without rigid part (P x)

    bar = progress_bar(n, "flexible modes", enabled=bool(progress), unit="mode")   # on stderr, after 1 s
    try:
        with _one_openblas_thread():
            return _block_lanczos(apply_op, M, Phi, MPhi, n, KRYLOV_BLOCK, KRYLOV_RTOL, KRYLOV_MAX_DIM, bar.update_to)
    finally:
        close()
        bar.close()



def modal_basis(structure: Structure, n_flexible: int, damping_ratio=0.05, *,
                method: str = "auto", sigma: float = DEFAULT_SIGMA, cache: bool | None = None,
                progress: bool = False) -> ModalBasis:
    """Rigid-body modes plus the first ``n_flexible`` flexible modes of a free-free structure.

    n_flexible:     0 ... n_dof - 6; 0 gives a rigid body.
    damping_ratio:  modal damping ratio zeta (a number, or one per flexible mode), 0 ... 1;
                    modal damping 2 zeta omega (rigid modes: 0).  Paper: 0.05.
    method:         "auto" (dense up to DENSE_LIMIT DOFs), "dense" or "sparse".
    sigma:          shift of the sparse shift-invert solve, rad^2/s^2; must be < 0.
    cache:          keep the modes in the on-disk cache (:mod:`flexfmu.core.cache`) and reuse them: True,
                    False, or None (default) = for models of CACHE_MIN_DOF DOFs or more.  The key is
                    a digest of the structure's arrays (nodes, M, K), n_flexible, method, sigma and
                    the source of this module; the damping ratio is applied after the look-up.
    progress:       show the sparse solve's converged modes on stderr (flexfmu.core.progress; solves over 1 s).

    Raises ParameterError naming ``n_flexible``, ``damping_ratio``, ``method``, ``sigma``, ``cache``,
    ``structure.*`` (see :func:`flexfmu.core.io.validate_structure`), ``structure.M`` if a rigid
    rotation has no inertia, or ``structure.K`` if the structure is not free-free (rigid motion
    produces elastic forces), has more than six zero-energy modes, or K is indefinite;
    ModalConvergenceError if the sparse eigensolver does not converge or a mode fails the residual check.
    """
    if cache is not None and not isinstance(cache, bool):
        raise ParameterError("cache", f"{cache!r}", "True, False or None (automatic)")
    if method not in ("auto", "dense", "sparse"):
        raise ParameterError("method", repr(method), '"auto", "dense" or "sparse"')
    if not (np.isfinite(sigma) and sigma < 0.0):
        raise ParameterError("sigma", f"{sigma!r}", "finite and < 0 (rad^2/s^2)")
    # A cache key from the structure as given (CSR arrays, before validate_structure's symmetrised copies):
    # an entry exists only for arrays that passed validation and the computation, so a hit skips both.
    key = _cache_key(structure, n_flexible, method, float(sigma)) if cache is not False else None
    if key is not None and (cache or key[1] >= CACHE_MIN_DOF):
        n_dof = key[1]
        n = _check_n_flexible(n_flexible, n_dof)
        zeta = _check_damping(damping_ratio, n)
        parts = _from_cache(key[0], n_dof, n)
        if parts is None:
            s = validate_structure(structure)
            parts = _compute(s, n, method, float(sigma), progress)
            _cache.store(_CACHE_KIND, key[0], {**parts, "method": np.array(parts["method"])})
    else:
        s = validate_structure(structure)
        n = _check_n_flexible(n_flexible, s.n_dof)
        zeta = _check_damping(damping_ratio, n)
        if cache:      # not CSR arrays: the key from the validated copy
            key = _cache_key(s, n, method, float(sigma))
            parts = _from_cache(key[0], s.n_dof, n)
            if parts is None:
                parts = _compute(s, n, method, float(sigma), progress)
                _cache.store(_CACHE_KIND, key[0], {**parts, "method": np.array(parts["method"])})
        else:
            parts = _compute(s, n, method, float(sigma), progress)
    omega = np.sqrt(parts["lam"])
    return ModalBasis(shapes=parts["shapes"], frequencies_hz=omega / (2.0 * np.pi),
                      stiffness=np.concatenate([np.zeros(N_RIGID), parts["lam"]]),
                      damping=np.concatenate([np.zeros(N_RIGID), 2.0 * zeta * omega]), damping_ratio=zeta,
                      mass=float(parts["mass"]), center_of_mass=parts["center_of_mass"], inertia=parts["inertia"],
                      rigid_transform=parts["rigid_transform"], method=str(parts["method"]))


# --------------------------------------------------------------------------- on-disk cache
_CACHE_KIND = "modal_basis"
_ARRAYS = ("shapes", "lam", "mass", "center_of_mass", "inertia", "rigid_transform")


@lru_cache(maxsize=1)
def _source_digest() -> str:
    """Digest of the code that checks and computes a basis (this module, flexfmu.linalg.lanczos, .modal,
    .cutoffs (which path method="auto" takes), flexfmu.core.io): a changed algorithm never reads the bases of
    the old one, even at the same flexfmu version."""
    from flexfmu.core import io
    from flexfmu.linalg import cutoffs, lanczos, modal
    return "".join(_cache.file_digest(path)
                   for path in (__file__, lanczos.__file__, modal.__file__, cutoffs.__file__, io.__file__))


def _cache_key(structure, n_flexible, method: str, sigma: float) -> tuple[str, int] | None:
    """(key, n_dof) from the structure's own arrays, or None if they are not float CSR matrices of
    matching shapes with (N, 3) float nodes (then validate_structure first: it normalises them)."""
    nodes, dpn, M, K = structure.nodes, structure.dofs_per_node, structure.M, structure.K
    if not (isinstance(nodes, np.ndarray) and nodes.ndim == 2 and nodes.shape[1] == 3 and nodes.dtype == float
            and isinstance(dpn, numbers.Integral) and dpn in (3, 6)):
        return None
    n_dof = nodes.shape[0] * int(dpn)
    for A in (M, K):
        if not (sp.issparse(A) and A.format == "csr" and A.shape == (n_dof, n_dof) and A.dtype == float):
            return None
    if isinstance(n_flexible, bool) or not isinstance(n_flexible, numbers.Integral):
        return None                                            # _check_n_flexible reports it
    model = _cache.array_digest(nodes, np.array([int(dpn)]), M.indptr, M.indices, M.data,
                                K.indptr, K.indices, K.data)
    key = _cache.make_key(_CACHE_KIND, model=model, n_flexible=int(n_flexible), method=method, sigma=sigma,
                          numpy=np.__version__, scipy=scipy.__version__, code=_source_digest())
    return key, n_dof


def _from_cache(key: str, n_dof: int, n: int) -> dict | None:
    """The cached parts of a basis, or None if absent or not of the expected shapes."""
    parts = _cache.load(_CACHE_KIND, key)
    if parts is None or any(name not in parts for name in _ARRAYS + ("method",)):
        return None
    if parts["shapes"].shape != (n_dof, N_RIGID + n) or parts["lam"].shape != (n,) or \
            not all(np.all(np.isfinite(parts[name])) for name in _ARRAYS):
        return None
    return parts


def _stiffness_quotients(K: sp.csr_matrix, Psi: np.ndarray) -> np.ndarray:
    """psi^T K psi for each column, accumulated in extended precision (numpy longdouble: 64-bit mantissa on
    x86-64 Linux; plain double where longdouble is double).

    In double, K psi of a smooth low mode is the small difference of large terms (|K| |psi| / |K psi|
    ~ lambda_max / lambda): its round-off scatters the Rayleigh quotient by ~3e-9 relative (std, first
    mode of the 4 x 1 x 1 plate), more than the dense-sparse difference tests/test_modal_basis.py allows;
    the 11 more bits bring it to ~1e-12 ... 1e-10.  (0.1 s for ten modes of the 51k-DOF plate.)"""
    K_ext = sp.csr_matrix((K.data.astype(np.longdouble), K.indices, K.indptr), shape=K.shape)
    out = np.empty(Psi.shape[1])
    for j in range(Psi.shape[1]):
        psi = Psi[:, j].astype(np.longdouble)
        out[j] = float(psi @ (K_ext @ psi))
    return out


def _check_residuals(KPsi: np.ndarray, MPsi: np.ndarray, absK_absPsi: np.ndarray, lam: np.ndarray,
                     method: str) -> None:
    """Every returned mode is an eigenvector: max|K psi - lam M psi| / max|K psi| <= RESIDUAL_RTOL plus
    1000 times the round-off floor of evaluating K psi, eps max(|K| |psi|) / max|K psi|.

    The floor is large for smooth modes of stiff models (|K| |psi| >> |K psi|): 7e-10 for the first
    mode of the paper plate, 2.4e-4 for a 10k-DOF beam frame with rotary inertia, whose converged modes
    reach 10 ... 400 times their floor (the previous eigsh ones up to 27 000 times)."""
    scale = np.maximum(np.max(np.abs(KPsi), axis=0), np.finfo(float).tiny)
    residual = np.max(np.abs(KPsi - MPsi * lam), axis=0) / scale
    limit = RESIDUAL_RTOL + 1e3 * EPS * np.max(absK_absPsi, axis=0) / scale
    bad = np.flatnonzero(~(residual <= limit))
    if bad.size:
        raise ModalConvergenceError(
            f"{method} eigensolver: flexible mode(s) {(bad + 1).tolist()} are not eigenvectors "
            f"(max|K phi - omega^2 M phi| / max|K phi| = {np.max(residual[bad]):.3g} > {np.min(limit[bad]):.3g})")


def _compute(s: Structure, n: int, method: str, sigma: float, progress=False) -> dict:
    """Rigid and flexible modes of a validated structure: the arrays of a ModalBasis except the damping."""
    with limited_for(s.n_dof):    # small models: BLAS threads only wait for cores (flexfmu.core.blas)
        return _compute_modes(s, n, method, sigma, progress)


def _compute_modes(s: Structure, n: int, method: str, sigma: float, progress=False) -> dict:
    K, M = s.K, s.M
    n_dof = s.n_dof
    Phi, A, mass, c, inertia = _rigid_orthonormal(s)

    # Free-free check: rigid-body motion must produce no elastic forces.  Scale-free measure:
    # max|K phi| / max(|K| |phi|) per rigid mode, ~1e-15 for a consistent free-free K.
    absK = sp.csr_matrix((np.abs(K.data), K.indices, K.indptr), shape=K.shape)
    residual = np.max(np.abs(K @ Phi), axis=0) / np.maximum(np.max(absK @ np.abs(Phi), axis=0), 1e-300)
    if K.nnz and float(np.max(residual)) > RIGID_FORCE_RTOL:
        raise ParameterError(
            "structure.K",
            f"rigid-body motion produces elastic forces (max|K phi| / max(|K||phi|) = {np.max(residual):.3g} "
            f"> {RIGID_FORCE_RTOL:g}): the structure is constrained, has fewer than 6 rigid-body modes, "
            "or K does not match the node positions",
            "free-free K with six zero-energy rigid-body modes")

    if n == 0:
        used = "none"
        Psi_F = np.zeros((n_dof, 0))
        lam = np.zeros(0)
    else:
        used = method if method != "auto" else ("dense" if n_dof <= DENSE_LIMIT else "sparse")
        if used == "sparse" and n >= n_dof - N_RIGID - 1:
            used = "dense"                                   # (nearly) all modes: dense is exact and cheaper
        # progress passed only when on: tests replace _flexible_candidates by six-argument functions
        V = _flexible_candidates(K, M, Phi, n, used, sigma, **({"progress": True} if progress else {}))
        for _ in range(2):                                   # "twice is enough"
            V = _project_out(Phi, M, V)
        # Rayleigh-Ritz in the projected subspace: M-orthonormal, K-diagonal flexible modes.  The
        # eigenvalues are the Rayleigh quotients in double precision (relative round-off ~1e-9 on the
        # plate); those of the shift-inverted operator are 30x worse through SuperLU's round-off.
        KV = K @ V
        MV = M @ V
        Kr = V.T @ KV
        Mr = V.T @ MV
        lam, Q = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
        Psi_F = V @ Q
        mdiag = M.diagonal()
        lam_scale = float(np.max(K.diagonal()[mdiag > 0] / mdiag[mdiag > 0]))   # ~ largest omega^2
        if lam[0] < -ZERO_EIG_RTOL * lam_scale:
            raise ParameterError("structure.K", f"negative eigenvalue omega^2 = {lam[0]:.6g}: K (or M) is indefinite",
                                 "symmetric positive semi-definite K, positive definite M")
        lam = np.maximum(lam, 0.0)
        # A candidate that was really a (near-)zero-energy mode: mechanism, not a flexible mode.
        if lam[0] <= ZERO_EIG_RTOL * lam_scale:
            raise ParameterError("structure.K", "singular free body: more than six zero-energy modes (a mechanism, "
                                 "or pieces not connected to each other)",
                                 "a connected free-free structure with exactly six rigid-body modes")
        _check_residuals(KV @ Q, MV @ Q, absK @ np.abs(Psi_F), lam, used)
        lam = np.maximum(_stiffness_quotients(K, Psi_F) / np.einsum("ij,ij->j", Psi_F, MV @ Q), 0.0)

    return {"shapes": np.hstack([Phi, Psi_F]), "lam": lam, "mass": mass, "center_of_mass": c,
            "inertia": inertia, "rigid_transform": A, "method": used}
