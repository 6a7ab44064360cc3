"""A free body: the reframe integrator's kernel schemes (consistent, exponential: flexfmu.reframe.schemes, those with
``for_bodies``) on the reduced model alone, loaded and observed at named interfaces.

Reduction (:func:`free_invariants`, at build time): the kernels' inertia invariants of the kinetic energy
(flexfmu.reframe.kernel_data.inertia_invariants: m, J0, A_j, B_j + B_j^T, C_jk, D_j from M, the node positions
and the modal basis; O(nf^2) numbers), the rigid transform A6, the centre of mass, the flexible eigenvalues, and
the translational mode rows of every node (for the largest elastic displacement).  M, K and the full basis are
not needed afterwards.

Interfaces.  A load at an interface is the patch's nodal loads f = D^T [F; M] (flexfmu.body.interfaces Eq. (I4)).
Its generalised forces are exactly those of one load at the point P with the point's modal rows D Phi_patch: the
flexible ones sum_i Phi_i^T f_i = (D Phi_patch)^T [F; M], the rigid ones the total force F and the moment
sum_i (x_i - c) x f_i + m_i = (x_P - c) x F + M about the centre of mass c (Eq. (I4)).  So each interface is one
load of the kernels (flexfmu.reframe.kernels' LP block) with arm x_P - c, translational rows D_u Phi_patch and
rotational rows D_theta Phi_patch: the distributed load costs no more than a point load.  The one difference
from loading the patch nodes one by one is the deformed lever arm (deformed_load_arm): u_P x F here, sum_i
u_i x f_i there, which differ at second order (the patch's own deformation times the load).  Likewise the outputs
of an interface are those of a point with arm x_P - c and rows D_u Phi_patch: the rigid fit of the patch motion.

Forces and moments are inputs in the global frame (as ReframeBody's with force_follows_body = false).

Centre of mass.  The frame point (com_pos) is the centre of mass of the deformed body too: the elastic
displacement u = Phi q moves the mass centre by T^T M u / m = 0 (every flexible coordinate, residual vectors
included, is M-orthogonal to the rigid translations T), exactly for the discretised body.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from flexfmu.core.step_size import StepSizes
from flexfmu.linalg.modal_basis import N_RIGID, ModalBasis
from flexfmu.reframe.kernel_data import inertia_invariants, max_displacement_blocks
from flexfmu.reframe.layout import output_layout, param_layout
from flexfmu.reframe.modeldata import _ModelData
from flexfmu.reframe.schemes import scheme_class

_EX_MEMO = 8                       # kernel coefficients kept per step size


def free_invariants(structure, basis: ModalBasis) -> dict:
    """The reduced arrays of a free body (module docstring) from its Structure and modal basis (rigid modes
    first; residual vectors, if any, after the flexible modes)."""
    d = _ModelData(structure, basis)                 # checks the basis: rigid modes, M-orthonormal
    inv = inertia_invariants(d)
    n_nodes, nf = d.n_nodes, d.nf
    return {"mass": np.array(inv.m), "J0": inv.J0, "Aj": inv.Aj, "Bsym": inv.Bsym, "Cjk": inv.Cjk, "Dj": inv.Dj,
            "A6": d.A6.copy(), "center_of_mass": d.com.copy(), "inertia": np.asarray(basis.inertia, float).copy(),
            "nodes": d.nodes.copy(), "translations": d.Phi[d.trans_rows.ravel()].reshape(n_nodes, 3, nf).copy()}


class FreeDynamics:
    """The reframe kernels on a free body's reduced arrays ``inv`` (:func:`free_invariants`), its flexible
    eigenvalues omega^2 (nf,), damping ratio, scheme (a name in flexfmu.reframe.schemes.SCHEMES whose class has
    ``for_bodies``: "exponential", "consistent") and interfaces: ``rows`` (6, nf)
    maps D Phi_patch, ``points`` (n_if, 3) body-frame coordinates, ``moments`` (n_if,) bools.

    State: y of flexfmu.reframe.layout.STATE (frame point = centre of mass, global; rotation body -> global; eta).
    Loads: ``SV`` (1, 3, n_if, 6) [F, M] per interface, held over a step: global (body frame with follower=True).
    deformed_load_arm: the moment of a load on the rigid motion uses the deformed point (as the integrator's)."""

    def __init__(self, inv: dict, eigenvalues, damping_ratio: float, scheme: str, rows, points, moments,
                 deformed_load_arm: bool = True, follower: bool = False):
        from flexfmu.reframe import kernels

        self._kern = kernels
        #: the scheme's class (flexfmu.reframe.schemes.Scheme): its kernel coefficients and substeps
        self.scheme_class = cls = scheme_class(scheme, "for_bodies")
        self.scheme = scheme
        self._expo = cls.kernel_coefficients              # None: classical RK4
        self._substeps = cls.substeps
        self.deformed = bool(deformed_load_arm)
        kF = np.asarray(eigenvalues, dtype=float)
        nf = self.nf = kF.size
        self.kF = kF
        self.cF = 2.0 * float(damping_ratio) * np.sqrt(np.maximum(kF, 0.0))
        self.mass = float(inv["mass"])
        self.com = np.asarray(inv["center_of_mass"], float)
        self.A6 = np.asarray(inv["A6"], float)
        self.A6inv = np.linalg.inv(self.A6)
        self.J0 = np.asarray(inv["J0"], float)
        P = np.concatenate([[self.mass], self.J0.ravel(), np.ravel(inv["Aj"]), np.ravel(inv["Bsym"]),
                            np.ravel(inv["Cjk"]), np.ravel(inv["Dj"]), kF, self.cF, self.A6.ravel(),
                            self.A6inv.ravel(), self.com])
        if P.size != param_layout(nf).end:
            raise ValueError(f"free-body invariants of {P.size} numbers for {nf} flexible coordinates")
        self.P = np.ascontiguousarray(P)
        self.points = np.asarray(points, float).reshape(-1, 3)
        arms = self.points - self.com
        self.n_if = arms.shape[0]
        blocks, pts = [], []
        for arm, D, mom in zip(arms, rows, moments):
            D = np.asarray(D, float)
            rot = D[3:] if mom else np.zeros((3, nf))
            blocks.append(np.concatenate([[float(follower), float(bool(mom))], arm, D[:3].ravel(), rot.ravel()]))
            pts.append(np.concatenate([arm, D[:3].ravel()]))
        self.LP = np.ascontiguousarray(np.concatenate(blocks) if blocks else np.zeros(0))
        self.PP = np.ascontiguousarray(np.array(pts).reshape(self.n_if, 3 + 3 * nf))
        nodes = np.asarray(inv["nodes"], float)
        U = np.asarray(inv["translations"], float)
        n_nodes = nodes.shape[0]
        Psi = np.zeros((3 * n_nodes, N_RIGID + nf))              # the max search reads columns N_RIGID ...
        Psi[:, N_RIGID:] = U.reshape(3 * n_nodes, nf)
        self.Psi = np.ascontiguousarray(Psi)
        ns = SimpleNamespace(nodes=nodes, n_nodes=n_nodes, Psi=self.Psi, nf=nf,
                             trans_rows=(np.arange(n_nodes)[:, None] * 3 + np.arange(3)).astype(np.int64))
        self.umax = max_displacement_blocks(ns, kernels.BLOCK)
        self.umax_skip = (np.zeros(0, dtype=np.int64),) + self.umax[1:]
        self.layout = output_layout(nf, self.n_if)
        self._ex = {}
        self._ex_steps = StepSizes()          # the time steps of _ex's keys (flexfmu.core.step_size)
        self.omega_max = float(np.sqrt(kF.max())) if nf else 0.0

    def initial_state(self, v0, omega0) -> np.ndarray:
        """y at t = 0: undeformed, body frame = mesh frame, centre-of-mass velocity v0 (global) and angular
        velocity omega0 (body)."""
        nf = self.nf
        eta = np.zeros(2 * (N_RIGID + nf))
        eta[N_RIGID + nf:2 * N_RIGID + nf] = self.A6inv @ np.concatenate([v0, omega0])
        return np.concatenate([self.com, np.eye(3).ravel(), eta])

    def _coefficients(self, dt: float):
        dt = self._ex_steps.canonical(dt)     # a host's last-bit variants of dt share its coefficients
        EX = self._ex.get(dt)
        if EX is None:
            EX = np.ascontiguousarray(self._expo(self.kF, self.cF, dt).reshape(-1))
            if len(self._ex) >= _EX_MEMO:
                self._ex.clear()
            self._ex[dt] = EX
        return EX

    def steps(self, y: np.ndarray, t: float, dt: float, n: int, SV: np.ndarray):
        """n steps of dt: (y, t, kernel steps done, status) as flexfmu.reframe.kernels.reframe_steps (0 ok, 2 not
        finite); each step is the scheme's substeps kernel steps."""
        if self._substeps != 1:
            dt, n = dt / self._substeps, n * self._substeps
        if self._expo is None:
            return self._kern.consistent_steps(self.P, self.LP, self.nf, self.deformed, SV, True, t, dt, n, y)
        return self._kern.reframe_steps(self.P, self.LP, np.zeros(0), self._coefficients(dt), self.nf, self.deformed,
                                        SV, True, t, dt, n, y)

    def outputs(self, y: np.ndarray, SV: np.ndarray, max_elastic: bool = True) -> np.ndarray:
        """The output vector of flexfmu.reframe.layout.output_layout(nf, n_if) for state y and the held loads."""
        umax = self.umax if max_elastic else self.umax_skip
        return self._kern.consistent_outputs(self.P, self.LP, self.nf, self.deformed, SV[0, 0], y, self.PP, self.Psi,
                                             3, *umax)
