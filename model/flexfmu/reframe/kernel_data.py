"""The model data of the reframe kernels (:mod:`flexfmu.reframe.kernels`), computed once per integrator from
the conventional model: the inertia invariants packed into ``P`` and the node blocks of the exact max
elastic displacement search."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from flexfmu.core.structure import N_RIGID
from flexfmu.reframe.layout import param_layout

__all__ = ["inertia_invariants", "max_displacement_blocks"]


def inertia_invariants(d) -> SimpleNamespace:
    """Inertia invariants of the kinetic energy T = 1/2 w^T M w (body components).

    Nodal velocity w = T v + S(y) omega + Phi qdot with y = X - c + u, u = Phi q: S(y) is the
    rotation field (omega x y on translational DOFs, omega on rotational DOFs), split as
    S(y) = S0 + sum_j q_j S_j (S_j: omega x phi_j on translational DOFs).  Then the generalised
    mass matrix of (v, omega, qdot) is

        [[m I,  A(q),   0   ],
         [A^T,  J(q),   D(q)],
         [0,    D^T,    I   ]]

    with A(q) = sum q_j T^T M S_j (0 for an isotropic mass matrix), J(q) = S(y)^T M S(y),
    D(q) = sum q_j S_j^T M Phi (T^T M Phi = S0^T M Phi = 0: Phi is M-orthogonal to the rigid modes).
    The invariants come from a few sparse-times-dense and dense products (BLAS), O(nnz(M) nf +
    n_dof nf^2); the step kernel (flexfmu.reframe.kernels) then costs O(nf^2) whatever the mesh.

    d: the model (flexfmu.reframe.modeldata._ModelData).  Returns m, J0, Aj, Bsym, Cjk, Dj, kF, cF and
    P, the packed parameters (flexfmu.reframe.layout.param_layout).
    """
    nd, nf, N = d.n_dof, d.nf, d.n_nodes
    tr = d.trans_rows
    out = SimpleNamespace()
    T = np.zeros((nd, 3))
    S0 = np.zeros((nd, 3))
    for k in range(3):
        T[tr[:, k], k] = 1.0
        S0[tr, k] = np.cross(np.eye(3)[k], d.Xc)
        if d.rot_rows is not None:
            S0[d.rot_rows[:, k], k] = 1.0
    J0 = S0.T @ (d.M @ S0)
    out.J0 = 0.5 * (J0 + J0.T)
    out.m = float(np.mean(np.diag(T.T @ (d.M @ T))))
    # SJ[:, 3 j + k] = S_j e_k = e_k x phi_j on the translational rows.
    U = d.Phi[tr]                                             # (N, 3, nf) translational mode shapes
    SJ = np.zeros((nd, nf, 3))
    for k in range(3):
        SJ[tr, :, k] = np.cross(np.eye(3)[k][None, :, None], U, axisa=1, axisb=1, axisc=1)
    SJ = SJ.reshape(nd, 3 * nf)
    MSJ = np.asarray(d.M @ SJ)
    out.Aj = (T.T @ MSJ).reshape(3, nf, 3).transpose(1, 0, 2).copy()         # T^T M S_j
    Bj = (S0.T @ MSJ).reshape(3, nf, 3).transpose(1, 0, 2)                   # S0^T M S_j
    out.Bsym = Bj + np.transpose(Bj, (0, 2, 1))
    C = SJ.T @ MSJ
    C = 0.5 * (C + C.T)                                 # exactly C_kj = C_jk^T (the kernels rely on it)
    out.Cjk = C.reshape(nf, 3, nf, 3).transpose(0, 2, 1, 3).copy()  # S_j^T M S_k
    out.Dj = (MSJ.T @ d.Phi).reshape(nf, 3, nf)                          # S_j^T M Phi
    out.kF = d.kq[N_RIGID:]
    out.cF = d.cq[N_RIGID:]
    del SJ, MSJ
    P = np.concatenate([[out.m], out.J0.ravel(), out.Aj.ravel(), out.Bsym.ravel(), out.Cjk.ravel(),
                        out.Dj.ravel(), out.kF, out.cF, d.A6.ravel(), d.A6inv.ravel(), d.com])
    assert P.size == param_layout(nf).end
    out.P = np.ascontiguousarray(P, dtype=float)
    del N
    return out


def max_displacement_blocks(d, B: int) -> tuple:
    """Node blocks for the exact max elastic displacement (_reframe_kernels.max_node_norm): nodes in
    Morton (Z-curve) order of their coordinates; per block and superblock the mean of the nodes'
    translational mode-shape rows and the largest distance of a node's rows from it.  d: the model; B:
    nodes per block and blocks per superblock.  Returns (order, bc, br, sc, sr), the last five arguments
    of the output kernels."""
    span = max(float(np.max(np.ptp(d.nodes, axis=0))), 1e-300)          # one scale: compact blocks
    cell = np.minimum(((d.nodes - d.nodes.min(axis=0)) / span * 1023.0).astype(np.int64), 1023)
    code = np.zeros(d.n_nodes, dtype=np.int64)
    for bit in range(10):
        for axis in range(3):
            code |= ((cell[:, axis] >> bit) & 1) << (3 * bit + axis)
    order = np.argsort(code, kind="stable")
    U = d.Psi[d.trans_rows[order], N_RIGID:].reshape(d.n_nodes, 3 * d.nf)    # Phi_i rows, curve order

    def groups(X, starts, size):
        C = np.add.reduceat(X, starts, axis=0) / np.diff(np.append(starts, size))[:, None]
        return C

    starts = np.arange(0, d.n_nodes, B)
    bc = groups(U, starts, d.n_nodes)
    dist = np.sqrt(np.einsum("nk,nk->n", U - np.repeat(bc, np.diff(np.append(starts, d.n_nodes)), axis=0),
                             U - np.repeat(bc, np.diff(np.append(starts, d.n_nodes)), axis=0)))
    br = np.maximum.reduceat(dist, starts)
    sstarts = np.arange(0, bc.shape[0], B)                       # superblocks: B blocks
    node_starts = starts[sstarts]
    sc = groups(U, node_starts, d.n_nodes)
    counts = np.diff(np.append(node_starts, d.n_nodes))
    sdist = np.sqrt(np.einsum("nk,nk->n", U - np.repeat(sc, counts, axis=0), U - np.repeat(sc, counts, axis=0)))
    sr = np.maximum.reduceat(sdist, node_starts)
    return (np.ascontiguousarray(order, dtype=np.int64), np.ascontiguousarray(bc), np.ascontiguousarray(br),
            np.ascontiguousarray(sc), np.ascontiguousarray(sr))
