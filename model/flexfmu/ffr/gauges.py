"""FFRBeam's strain gauges: the section forces of the rod at up to three arc lengths, as rows of the output maps.

A gauge sits on a mesh node (its arc length is one of build_mesh's extra_arc_lengths).  Its section is that of the
element AFTER the node (larger arc length); at the last point, that of the last element.  The section forces
(N, Vy, Vz, T, My, Mz) are the resultant force and the moment about the centroid that the part of the rod beyond the
cut exerts on the part before it, in the section frame: x along the element axis towards larger s, y and z the
element's section axes (the columns of the mesh's element_rotation C, body frame; docs/scene_format.md).

They come from the end forces of that element.  With the element's consistent matrices K_e, M_e and its nodal
vector q_e (body frame, 12 DOFs), the forces its two nodes exert on it are (flexfmu.ffr.dynamics Eq. (*) restricted
to the element: int_e rho S^T a dV with a = a0 + X (u0 + S q) + 2 W S q_dot + S q_ddot)

    g_e = K_e q_e + M_e q_ddot_e + M_e q_damp_e + S_bar_e^T a0 + sum_ab X_ab (P_ab,e + M_ab,e q_e)
          + 2 sum_ab W_ab M_ab,e q_dot_e,

W = [omega]x, X = [alpha]x + W^2, with the element's own inertia shape integrals (S_bar_e, P_ab,e, M_ab,e as
flexfmu.ffr.dynamics.inertia_integrals forms them, without the point masses, which sit on nodes).  q_damp =
Phi diag(2 zeta omega) eta_dot carries the modal damping: C = M Phi diag(2 zeta omega) Phi^T M is the damping matrix
that gives the retained modes their damping (Phi^T C Phi = diag(2 zeta omega)), a distributed force whose share on
the element is M_e q_damp_e; without it an interior section's forces would miss the damping load on the element
after the cut (a few % of the shear near a resonance; nothing at rest).  The section
after node 1 is then the cut just after the node: the part beyond exerts -g_1 (element axes); at the last point the
cut is just before it and the part beyond (the point with its load and point mass) exerts +g_2.  External loads act
on nodes, never inside an element, so none is subtracted: a load at the gauge's own node is on the part before the
cut (after the corner of a gauge at a corner), a load at the last point is beyond a gauge there.

Modal and static parts: q = Phi eta + q_res with q_res = R [F, M, a0, X_ab] the residual flexibility of the omitted
modes (the static correction, flexfmu.sizing.beam, when on), q_dot = Phi eta_dot, q_ddot = Phi eta_ddot with
eta_ddot from the modal equation.  The static correction enters through K_e only (it is computed from K, so its
X M_ab and inertia terms are not part of it), which makes a quasi-static load's section forces those of the full
model: at rest K q = f exactly, and g_e the element's exact end forces.  With geometric_stiffening the geometric
stiffness of the prestress is left out of g_e (second order).

The rows are affine in x = [eta; eta_dot] and u = [F, M, a0] for a held base rotation (of degree <= 2 in omega,
alpha), so they are rows of FFRBeamDynamics.fast_maps; the largest stresses of a section are nonlinear and computed
after them (flexfmu.core.stress, the simulator's derived_outputs).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.core.stress import DerivedStress, SectionFibres
from flexfmu.core.vec3 import skew as _skew
from flexfmu.errors import require
from flexfmu.ffr.ffrbeam_config import GAUGE_SLOTS, gauge_output

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)   # as flexfmu.ffr.dynamics.inertia_integrals
N_GAUGE_ROWS = 6 * GAUGE_SLOTS                              # six section forces per gauge slot


@dataclass(frozen=True)
class GaugeSection:
    """One gauge: its arc length s (m), element, which end of it (0: first node, 1: second), section axes R (3, 3:
    columns x, y, z in body frame), the element's DOFs (12,), ``select`` (6, 12): the element's nodal forces (body
    frame) -> the section forces, and the element's body-frame K_e, M_e (12, 12), S_bar_e^T (12, 3),
    P (3, 3, 12), M_ab (3, 3, 12, 12)."""

    s: float
    element: int
    end: int
    R: np.ndarray
    dofs: np.ndarray
    select: np.ndarray
    K: np.ndarray
    M: np.ndarray
    S_bar_T: np.ndarray
    P: np.ndarray
    M_ab: np.ndarray

    def nodal_forces(self, q, q_modal, q_dot, q_ddot, q_damp, a0, W, X) -> np.ndarray:
        """g_e (12,), body frame, term by term (the module's formula) from the nodal vectors on all DOFs: q with the
        static correction, q_modal = Phi eta (the inertial terms), q_dot, q_ddot, q_damp = Phi diag(2 zeta omega)
        eta_dot."""
        d = self.dofs
        g = self.K @ q[d] + self.M @ q_ddot[d] + self.M @ q_damp[d] + self.S_bar_T @ a0
        for a in range(3):
            for b in range(3):
                g = g + X[a, b] * (self.P[a, b] + self.M_ab[a, b] @ q_modal[d])
                g = g + 2.0 * W[a, b] * (self.M_ab[a, b] @ q_dot[d])
        return g


def _element_section(model, s: float, name: str) -> GaugeSection:
    mesh, sec, mat = model.mesh, model.mesh.scene.section, model.mesh.scene.material
    node = mesh.node_at(s, name)
    after = np.flatnonzero(mesh.elements[:, 0] == node)
    e, end = (int(after[0]), 0) if after.size else (int(np.flatnonzero(mesh.elements[:, 1] == node)[0]), 1)
    L, C = float(mesh.element_length[e]), mesh.element_rotation[e]
    Cbar = mesh.element.dof_rotation(C[None])[0]                                 # element -> body, (12, 12)
    K = Cbar @ mesh.element.stiffness(np.array([L]), sec, mat)[0] @ Cbar.T
    M = Cbar @ mesh.element.mass(np.array([L]), sec, mat, rotary_inertia=model.rotary_inertia)[0] @ Cbar.T
    # the element's inertia shape integrals (4 Gauss points, as flexfmu.ffr.dynamics.inertia_integrals)
    S_bar_T, P, M_ab = np.zeros((12, 3)), np.zeros((3, 3, 12)), np.zeros((3, 3, 12, 12))
    n1, n2 = mesh.elements[e]
    for xg, wg in zip(_GAUSS_X, _GAUSS_W):
        xi = 0.5 * (xg + 1.0)
        S = C @ mesh.element.shape_functions(xi, L, sec, mat)[:3] @ np.kron(np.eye(4), C.T)     # (3, 12) body
        x0 = (1 - xi) * mesh.nodes[n1] + xi * mesh.nodes[n2]
        w = mat.rho * sec.A * 0.5 * wg * L
        S_bar_T += w * S.T
        P += w * np.einsum("ak,b->abk", S, x0)
        M_ab += w * np.einsum("ak,bl->abkl", S, S)
    rows = slice(0, 6) if end == 0 else slice(6, 12)
    select = (-1.0 if end == 0 else 1.0) * Cbar.T[rows]      # -g_1 (beyond acts on before) or +g_2, element axes
    dofs = np.concatenate([6 * n1 + np.arange(6), 6 * n2 + np.arange(6)])
    return GaugeSection(float(s), e, end, C.copy(), dofs, select, K, M, S_bar_T, P, M_ab)


class GaugeSections:
    """The gauges of one FFRBeam model (GAUGE_SLOTS slots, None = no gauge) and their output rows.

    model: the BeamModel (its mesh has a node at every gauge); Phi (n_dof, m): the retained modes on all DOFs;
    arc_lengths: one per slot, an arc length (m, checked) or None."""

    def __init__(self, model, Phi: np.ndarray, arc_lengths=(None,) * GAUGE_SLOTS):
        require(len(arc_lengths) == GAUGE_SLOTS, "gauges", f"{len(arc_lengths)} slots", f"{GAUGE_SLOTS}")
        self.sections = tuple(None if s is None else _element_section(model, s, f"gauge_{k}_s")
                              for k, s in enumerate(arc_lengths, start=1))
        m = Phi.shape[1]
        self.present = any(g is not None for g in self.sections)
        # the rows' constant parts: select times K_e Phi_e, M_e Phi_e, S_bar_e^T, P_ab, M_ab Phi_e (zero rows: none)
        self.K_rows = np.zeros((N_GAUGE_ROWS, m))
        self.M_rows = np.zeros((N_GAUGE_ROWS, m))
        self.a0_rows = np.zeros((N_GAUGE_ROWS, 3))
        self.P_rows = np.zeros((9, N_GAUGE_ROWS))
        self.H_rows = np.zeros((9, N_GAUGE_ROWS, m))
        for k, g in enumerate(self.sections):
            if g is None:
                continue
            r, D, Phi_e = slice(6 * k, 6 * k + 6), g.select, Phi[g.dofs]
            self.K_rows[r] = D @ g.K @ Phi_e
            self.M_rows[r] = D @ g.M @ Phi_e
            self.a0_rows[r] = D @ g.S_bar_T
            self.P_rows[:, r] = (g.P @ D.T).reshape(9, 6)
            self.H_rows[:, r] = np.einsum("ik,abkl,lj->abij", D, g.M_ab, Phi_e).reshape(9, 6, m)

    def output_rows(self, Ax: np.ndarray, Fm: np.ndarray, p: np.ndarray, W: np.ndarray, X: np.ndarray,
                    damping: np.ndarray):
        """(Cx (18, 2m), Cu (18, 9), y0 (18,)) of the section forces for the held base rotation (W, X) from the
        modal equation eta_ddot = Ax x + Fm u - p (FFRBeamDynamics.fast_maps' terms) and the modal damping
        ``damping`` = 2 zeta omega (m,); without the static correction (:meth:`correction_rows`)."""
        m = self.K_rows.shape[1]
        if not self.present:
            return np.zeros((N_GAUGE_ROWS, 2 * m)), np.zeros((N_GAUGE_ROWS, 9)), np.zeros(N_GAUGE_ROWS)
        Cx = np.hstack([self.K_rows + np.tensordot(X.ravel(), self.H_rows, 1),
                        2.0 * np.tensordot(W.ravel(), self.H_rows, 1) + self.M_rows * damping]) + self.M_rows @ Ax
        Cu = self.M_rows @ Fm
        Cu[:, 6:9] += self.a0_rows
        y0 = X.ravel() @ self.P_rows - self.M_rows @ p
        return Cx, Cu, y0

    def correction_rows(self, residual: np.ndarray) -> np.ndarray:
        """(18, 18): the section forces of the static correction's residual displacement residual @ z (n_dof, 18;
        z = [F, M, a0, X_ab]), through K_e."""
        rows = np.zeros((N_GAUGE_ROWS, residual.shape[1]))
        for k, g in enumerate(self.sections):
            if g is not None:
                rows[6 * k:6 * k + 6] = g.select @ g.K @ residual[g.dofs]
        return rows

    def reference(self, q, q_modal, q_dot, q_ddot, q_damp, a0, omega, alpha) -> np.ndarray:
        """The section forces (18,) term by term (GaugeSection.nodal_forces), zeros for absent gauges."""
        W = _skew(np.asarray(omega, float))
        X = _skew(np.asarray(alpha, float)) + W @ W
        out = np.zeros(N_GAUGE_ROWS)
        for k, g in enumerate(self.sections):
            if g is not None:
                out[6 * k:6 * k + 6] = g.select @ g.nodal_forces(q, q_modal, q_dot, q_ddot, q_damp,
                                                                   np.asarray(a0, float), W, X)
        return out

    def derived_outputs(self, section) -> tuple:
        """The DerivedStress of every present gauge (sigma_max, von_mises) from its (N, T, My, Mz); ParameterError
        naming gauge_K_s for a section without an outline (flexfmu.core.stress.SectionFibres.of)."""
        out = []
        for k, g in enumerate(self.sections, start=1):
            if g is None:
                continue
            fibres = SectionFibres.of(section.shape, section.A, section.Iy, section.Iz, section.J, name=f"gauge_{k}_s")
            sources = tuple(gauge_output(k, q) for q in ("N", "T", "My", "Mz"))
            out += [DerivedStress(gauge_output(k, "sigma_max"), "section_sigma_max", sources, fibres),
                    DerivedStress(gauge_output(k, "von_mises"), "section_von_mises", sources, fibres)]
        return tuple(out)



class DerivedFill:
    """Fills the derived outputs ``derived`` (DerivedStress) of an output vector with names ``names``, as
    flexfmu.core.stress.evaluate_derived does, element for element the same operations, but one DerivedStress.evaluate
    per kind and section for all gauges at once (numpy arrays of the gauges' N, T, My, Mz): the per-step path (six
    scalar evaluations cost several times the linear outputs)."""

    def __init__(self, derived, names):
        index = {name: k for k, name in enumerate(names)}
        groups: dict = {}
        for d in derived:
            groups.setdefault((d.kind, d.fibres), []).append(d)
        self.plan = tuple((group[0], np.array([index[d.output] for d in group]),
                           tuple(np.array([index[d.sources[j]] for d in group]) for j in range(len(group[0].sources))))
                          for group in groups.values())

    def __call__(self, y: np.ndarray) -> None:
        for first, outputs, sources in self.plan:
            y[outputs] = first.evaluate([y[s] for s in sources])
