"""The validated model of the reframe integrators (:mod:`flexfmu.reframe.integrator`,
:mod:`flexfmu.reframe.baseline`): structure and modal basis checks, index arrays, load resolution,
the RK4 stability check and the checks of an initial state."""
from __future__ import annotations

import math
import numbers

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.linalg.modal_basis import ModalBasis
from flexfmu.linalg.modal_basis import modal_basis as _modal_basis
from flexfmu.core.structure import N_RIGID, Structure
from flexfmu.reframe.loads import PointLoad, _finite_vec3, _History, _ResolvedLoad

#: RK4 is stable for an undamped oscillator while dt * omega <= 2*sqrt(2) = 2.83; refuse above 2.8.
RK4_STABILITY_LIMIT = 2.8
_ORTHO_RTOL = 1e-8       # Psi^T M Psi = I within this (relative to 1)
_RIGID_RTOL = 1e-8       # |K psi_rigid| / (|K| |psi_rigid|) allowed for the first six columns


def _check_dt(dt):
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real) or not math.isfinite(dt) or dt <= 0.0:
        raise ParameterError("dt", f"{dt!r}", "finite time step > 0 (s)")
    return float(dt)



class _ModelData:
    """Validated structure + modal basis, index arrays and load handling shared by both integrators."""

    def __init__(self, structure: Structure, basis):
        if not isinstance(structure, Structure):
            raise ParameterError("structure", f"{type(structure).__name__}", "a flexfmu Structure")
        if isinstance(basis, numbers.Integral) and not isinstance(basis, bool):
            basis = _modal_basis(structure, int(basis))
        if not isinstance(basis, ModalBasis):
            raise ParameterError("basis", f"{type(basis).__name__}", "a ModalBasis or the number of flexible modes")
        self.structure = structure
        self.basis = basis
        nodes = np.asarray(structure.nodes, dtype=float)
        dpn = int(structure.dofs_per_node)
        n_dof = nodes.shape[0] * dpn
        M, K = structure.M.tocsr(), structure.K.tocsr()
        if M.shape != (n_dof, n_dof) or K.shape != (n_dof, n_dof):
            raise ParameterError("structure.M", f"M {M.shape}, K {K.shape} for {n_dof} DOFs",
                                 "square matrices of size N * dofs_per_node")
        Psi = np.asarray(basis.shapes, dtype=float)
        if Psi.ndim != 2 or Psi.shape[0] != n_dof:
            raise ParameterError("basis.shapes", f"shape {Psi.shape}", f"({n_dof}, 6 + n_flexible)")
        if Psi.shape[1] < N_RIGID:
            raise ParameterError("basis.shapes", f"only {Psi.shape[1]} modes: fewer than 6 rigid-body modes",
                                 "6 rigid-body modes first, then the flexible ones")
        # The first six columns must be rigid-body modes (no strain energy) and span six motions.
        PR = Psi[:, :N_RIGID]
        res = np.max(np.abs(K @ PR), axis=0) / np.maximum(np.max(abs(K) @ np.abs(PR), axis=0), 1e-300)
        G = Psi.T @ (M @ Psi)
        ortho = float(np.max(np.abs(G - np.eye(Psi.shape[1]))))
        if np.max(res) > _RIGID_RTOL or np.any(np.abs(basis.stiffness[:N_RIGID]) > 0) or \
                np.linalg.matrix_rank(PR.T @ (M @ PR), tol=1e-8) < N_RIGID:
            raise ParameterError("basis.shapes", "fewer than 6 rigid-body modes in the first six columns "
                                 f"(max |K psi| / (|K| |psi|) = {np.max(res):.3g})",
                                 "columns 0-5: six independent rigid-body modes")
        if ortho > _ORTHO_RTOL:
            raise ParameterError("basis.shapes", f"not mass-orthonormal (|Psi^T M Psi - I| = {ortho:.3g})",
                                 f"Psi^T M Psi = I within {_ORTHO_RTOL:g}")
        self.nodes = nodes
        self.dpn = dpn
        self.n_nodes = nodes.shape[0]
        self.n_dof = n_dof
        self.M, self.K = M, K
        self.Psi = Psi
        self.n_modes = Psi.shape[1]
        self.nf = self.n_modes - N_RIGID
        self.Phi = Psi[:, N_RIGID:]
        self.kq = np.asarray(basis.stiffness, dtype=float)
        self.cq = np.asarray(basis.damping, dtype=float)
        self.A6 = np.asarray(basis.rigid_transform, dtype=float)
        self.A6inv = np.linalg.inv(self.A6)
        self.mass = float(basis.mass)
        self.com = np.asarray(basis.center_of_mass, dtype=float)
        self.Xc = nodes - self.com
        self.trans_rows = (np.arange(self.n_nodes)[:, None] * dpn + np.arange(3)).astype(np.int64)
        self.rot_rows = (self.trans_rows + 3) if dpn == 6 else None
        self.omega_max = float(np.sqrt(np.max(self.kq))) if self.nf else 0.0

    # ---- nodes and loads
    def node_index(self, point, name):
        if isinstance(point, numbers.Integral) and not isinstance(point, bool):
            i = int(point)
            if not 0 <= i < self.n_nodes:
                raise ParameterError(name, f"node {i} out of range", f"0 ... {self.n_nodes - 1}")
            return i
        x = _finite_vec3(point, name)
        return int(np.argmin(np.linalg.norm(self.nodes - x, axis=1)))

    def resolve_loads(self, load):
        if load is None:
            return []
        loads = [load] if isinstance(load, PointLoad) else list(load)
        out = []
        for k, ld in enumerate(loads):
            if not isinstance(ld, PointLoad):
                raise ParameterError(f"load[{k}]", f"{type(ld).__name__}", "PointLoad")
            node = self.node_index(ld.point, f"load[{k}].point")
            if ld.moment is not None and self.dpn != 6:
                raise ParameterError(f"load[{k}].moment", "moments need rotational DOFs",
                                     "None on models with 3 DOFs per node")
            out.append(_ResolvedLoad(node, _History(ld.force, "load.force"),
                                     _History(ld.moment, "load.moment"), bool(ld.follower)))
        return out

    def check_stability(self, dt):
        if self.omega_max * dt > RK4_STABILITY_LIMIT:
            raise ParameterError(
                "dt", f"dt * omega_max = {dt:g} * {self.omega_max:.6g} = {dt * self.omega_max:.3g} > "
                      f"{RK4_STABILITY_LIMIT}: RK4 would diverge on the highest flexible mode "
                      f"({self.omega_max / (2 * np.pi):.6g} Hz)",
                f"dt <= {RK4_STABILITY_LIMIT / self.omega_max:.4g} s, or fewer flexible modes")


def _check_initial(data: _ModelData, v0, omega0, q0, qd0, rotation0, position0):
    v0 = _finite_vec3(v0, "v0")
    omega0 = _finite_vec3(omega0, "omega0")
    nf = data.nf

    def modal(x, name):
        if x is None:
            return np.zeros(nf)
        a = np.asarray(x, dtype=float)
        if a.shape != (nf,) or not np.all(np.isfinite(a)):
            raise ParameterError(name, f"shape {a.shape} or non-finite", f"finite ({nf},) flexible modal values")
        return a

    q0, qd0 = modal(q0, "q0"), modal(qd0, "qd0")
    if rotation0 is None:
        R0 = np.eye(3)
    else:
        R0 = np.asarray(rotation0, dtype=float)
        if R0.shape != (3, 3) or not np.all(np.isfinite(R0)) or \
                np.max(np.abs(R0.T @ R0 - np.eye(3))) > 1e-9 or np.linalg.det(R0) <= 0:
            raise ParameterError("rotation0", "not a proper rotation matrix", "orthonormal 3x3, det +1")
    pos = data.com.copy() if position0 is None else _finite_vec3(position0, "position0")
    return v0, omega0, q0, qd0, R0, pos
