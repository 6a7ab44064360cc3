"""A linear static 3D frame solver by the direct stiffness method, written from the textbook formulas as a reference
for FFRBeam's gauges (section forces).  Nothing here imports flexfmu: the element, the transformation, the assembly
and the section-force recovery are our own, so an error in flexfmu's beam code cannot hide in both.

Sources: W. McGuire, R. H. Gallagher, R. D. Ziemian, *Matrix Structural Analysis*, 2nd ed. (2000), Sec. 4.4 (the
12 x 12 Euler-Bernoulli frame element, Eq. 4.34) and Sec. 5.1 (transformation); J. S. Przemieniecki, *Theory of
Matrix Structural Analysis* (1968), Sec. 5.5 (same element).  Orientation of the section axes: the rule of
docs/scene_format.md ("Section constants and the local axes"; Gere & Weaver with body Y as the reference axis).

Equations
---------
(1) Local DOFs of an element from node i to node j, each node [u, v, w, theta_x, theta_y, theta_z]; local x along
    the element (i -> j), y and z the section axes.  Stiffness k = blocks of
      axial      EA/L [[1, -1], [-1, 1]]                         on (u_i, u_j)
      torsion    GJ/L [[1, -1], [-1, 1]]                         on (theta_x_i, theta_x_j)
      x-y plane  EIz/L^3 [[12, 6L, -12, 6L], [6L, 4L^2, -6L, 2L^2], [-12, -6L, 12, -6L], [6L, 2L^2, -6L, 4L^2]]
                 on (v_i, theta_z_i, v_j, theta_z_j)              (theta_z = dv/dx)
      x-z plane  EIy/L^3 [[12, -6L, -12, -6L], [-6L, 4L^2, 6L, 2L^2], [-12, 6L, 12, 6L], [-6L, 2L^2, 6L, 4L^2]]
                 on (w_i, theta_y_i, w_j, theta_y_j)              (theta_y = -dw/dx)
    Iz = int y^2 dA resists bending in the x-y plane, Iy = int z^2 dA in the x-z plane (docs/scene_format.md).
    k q = f: f are the forces and moments the nodes apply to the element, local axes.
(2) Section axes (columns of R, body frame): x = (r_j - r_i) / L; z = x cross Y / |x cross Y| (horizontal, normal to
    the element and to body Y), y = z cross x (so y . Y >= 0).  An element exactly parallel to Y (x = c Y,
    c = +-1): y = -c X, z = Z.  In a polyline x is its segment's direction (from the segment's vertices): a node
    interpolated on a segment parallel to Y, off it by rounding, must not turn the axes by 90 degrees.
(3) Global stiffness of the element K_e = T^T k T, T = blockdiag(R^T, R^T, R^T, R^T); assembled over the nodes;
    clamped nodes' six DOFs removed; K_ff q_f = f_f solved (dense, numpy.linalg.solve).
(4) Element end forces, local: f = k T q_e (no loads between the nodes: loads only at nodes, so (1) is exact for
    any mesh: the Euler-Bernoulli frame with nodal loads has cubic / linear fields, which the element reproduces).
(5) Section forces at distance a from node i (0 <= a <= L), the spec's convention: the force and moment about the
    section centroid that the part beyond the cut (towards j) exerts on the part before it, local axes.  The piece
    from the cut to node j is in equilibrium under the node's force f_j, moment m_j and minus the section's:
      [N, Vy, Vz] = f_j,   [T, My, Mz] = m_j + (L - a) e_x cross f_j.
    N > 0 is tension; sigma_xx(y, z) = N / A + My z / Iy - Mz y / Iz.
(6) At a node shared by two elements the section is that of the element after it (larger arc length); at the last
    point that of the last element (a = L).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

BODY_Y = np.array([0.0, 1.0, 0.0])


@dataclass(frozen=True)
class FrameSection:
    """Material and section constants: E, G (Pa), A (m^2), Iy = int z^2 dA, Iz = int y^2 dA, J (m^4)."""

    E: float
    G: float
    A: float
    Iy: float
    Iz: float
    J: float


def section_axes(start, end) -> np.ndarray:
    """R (3, 3): the element's axes x, y, z as columns, body frame, by the orientation rule, Eq. (2)."""
    d = np.asarray(end, float) - np.asarray(start, float)
    x = d / np.linalg.norm(d)
    z = np.cross(x, BODY_Y)
    if not np.any(z):                           # exactly parallel to body Y (x = c Y)
        c = x[1]
        y, z = np.array([-c, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    else:
        z = z / np.linalg.norm(z)
        y = np.cross(z, x)
    return np.column_stack((x, y, z))


def local_stiffness(section: FrameSection, L: float) -> np.ndarray:
    """The 12 x 12 Euler-Bernoulli frame element stiffness in local axes, Eq. (1)."""
    s = section
    k = np.zeros((12, 12))
    for dofs, c in (((0, 6), s.E * s.A / L), ((3, 9), s.G * s.J / L)):
        k[np.ix_(dofs, dofs)] += c * np.array([[1.0, -1.0], [-1.0, 1.0]])
    bend_xy = s.E * s.Iz / L**3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                                             [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]])
    bend_xz = s.E * s.Iy / L**3 * np.array([[12, -6 * L, -12, -6 * L], [-6 * L, 4 * L**2, 6 * L, 2 * L**2],
                                             [-12, 6 * L, 12, 6 * L], [-6 * L, 2 * L**2, 6 * L, 4 * L**2]])
    k[np.ix_((1, 5, 7, 11), (1, 5, 7, 11))] += bend_xy
    k[np.ix_((2, 4, 8, 10), (2, 4, 8, 10))] += bend_xz
    return k


@dataclass
class Frame:
    """Nodes (n, 3) m body frame; elements (i, j, FrameSection); clamps (node indices); nodal loads."""

    nodes: np.ndarray
    elements: list = field(default_factory=list)
    clamps: set = field(default_factory=set)
    loads: dict = field(default_factory=dict)
    axis_points: list = field(default_factory=list)

    def add_element(self, i: int, j: int, section: FrameSection, axis_points=None) -> int:
        """axis_points: (start, end) whose direction orients the section axes, Eq. (2) (default the nodes'):
        a polyline's segment, so that a node interpolated on it, off by rounding, tilts no axis."""
        self.elements.append((int(i), int(j), section))
        self.axis_points.append(None if axis_points is None else tuple(np.asarray(p, float) for p in axis_points))
        return len(self.elements) - 1

    def clamp(self, node: int) -> None:
        self.clamps.add(int(node))

    def load(self, node: int, force=(0.0, 0.0, 0.0), moment=(0.0, 0.0, 0.0)) -> None:
        """Add a force (N) and moment (N m), body frame, at a node."""
        f = self.loads.setdefault(int(node), np.zeros(6))
        f += np.concatenate([np.asarray(force, float), np.asarray(moment, float)])

    def element_geometry(self, e: int):
        """(L, R, T) of element e: length (m), section axes (columns, body frame), 12 x 12 transformation."""
        i, j, _ = self.elements[e]
        L = float(np.linalg.norm(self.nodes[j] - self.nodes[i]))
        R = section_axes(*(self.axis_points[e] or (self.nodes[i], self.nodes[j])))
        return L, R, np.kron(np.eye(4), R.T)

    def solve(self) -> "FrameSolution":
        """Assemble, clamp, solve, Eq. (3)."""
        n = len(self.nodes)
        K = np.zeros((6 * n, 6 * n))
        for e, (i, j, section) in enumerate(self.elements):
            L, _, T = self.element_geometry(e)
            dofs = np.r_[6 * i:6 * i + 6, 6 * j:6 * j + 6]
            K[np.ix_(dofs, dofs)] += T.T @ local_stiffness(section, L) @ T
        f = np.zeros(6 * n)
        for node, load in self.loads.items():
            f[6 * node:6 * node + 6] += load
        fixed = np.zeros(6 * n, bool)
        for node in self.clamps:
            fixed[6 * node:6 * node + 6] = True
        free = ~fixed
        q = np.zeros(6 * n)
        q[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
        return FrameSolution(self, q)


@dataclass
class FrameSolution:
    frame: Frame
    q: np.ndarray        # (6 n,) nodal displacements and rotations, body frame

    def displacement(self, node: int) -> np.ndarray:
        """[u, theta] (6,) of a node, body frame (m, rad)."""
        return self.q[6 * node:6 * node + 6]

    def end_forces(self, e: int) -> np.ndarray:
        """(12,) forces and moments the nodes i, j apply to element e, its local axes, Eq. (4)."""
        i, j, section = self.frame.elements[e]
        L, _, T = self.frame.element_geometry(e)
        qe = np.concatenate([self.displacement(i), self.displacement(j)])
        return local_stiffness(section, L) @ (T @ qe)

    def section_forces(self, e: int, a: float) -> np.ndarray:
        """[N, Vy, Vz, T, My, Mz] at distance a (m) from node i of element e, Eq. (5)."""
        L = self.frame.element_geometry(e)[0]
        f = self.end_forces(e)
        force_j, moment_j = f[6:9], f[9:12]
        return np.concatenate([force_j, moment_j + np.cross([L - a, 0.0, 0.0], force_j)])

    def reactions(self) -> np.ndarray:
        """(6,) sum of the clamps' reactions on the structure: force and moment about the body origin."""
        total = np.zeros(6)
        for e, (i, j, _) in enumerate(self.frame.elements):
            _, R, _ = self.frame.element_geometry(e)
            f = self.end_forces(e)
            for node, part in ((i, f[:6]), (j, f[6:])):
                if node in self.frame.clamps:     # the element pushes on the clamp with -part; the clamp on it +part
                    force, moment = R @ part[:3], R @ part[3:]
                    total += np.concatenate([force, moment + np.cross(self.frame.nodes[node], force)])
        return total


class PolylineFrame:
    """A polyline rod (one section) meshed with a node at every vertex and at every given arc length, for
    loads, clamps and cuts at arc lengths s (m) from the first point.  One element between neighbouring nodes:
    exact for nodal loads (Eq. 4)."""

    def __init__(self, points, section: FrameSection, arc_lengths=()):
        self.points = np.asarray(points, float)
        seg_len = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        self.vertex_s = np.concatenate([[0.0], np.cumsum(seg_len)])
        s_all = np.sort(np.concatenate([self.vertex_s, np.asarray(arc_lengths, float)]))
        tol = 1e-12 * self.vertex_s[-1]          # 0.16 given and 0.16000000000000003 by cumsum: one node
        keep = np.concatenate([[True], np.diff(s_all) > tol])
        s_nodes = s_all[keep]
        for k in range(len(s_nodes)):            # a vertex wins over a given arc length within tol of it
            near = np.abs(self.vertex_s - s_nodes[k]) <= tol
            if np.any(near):
                s_nodes[k] = self.vertex_s[np.argmax(near)]
        self.node_s = s_nodes
        self.frame = Frame(np.array([self.point_at(s) for s in s_nodes]))
        for k in range(len(s_nodes) - 1):
            seg = self.segment_of(0.5 * (s_nodes[k] + s_nodes[k + 1]))
            self.frame.add_element(k, k + 1, section, axis_points=(self.points[seg], self.points[seg + 1]))

    def segment_of(self, s: float) -> int:
        return int(np.clip(np.searchsorted(self.vertex_s, s, side="right") - 1, 0, len(self.vertex_s) - 2))

    def point_at(self, s: float) -> np.ndarray:
        seg = self.segment_of(s)
        t = (s - self.vertex_s[seg]) / (self.vertex_s[seg + 1] - self.vertex_s[seg])
        return (1 - t) * self.points[seg] + t * self.points[seg + 1]

    def node(self, s: float) -> int:
        k = int(np.argmin(np.abs(self.node_s - s)))
        if abs(self.node_s[k] - s) > 1e-12 * max(1.0, self.vertex_s[-1]):
            raise ValueError(f"no node at s = {s!r} m: pass it in arc_lengths")
        return k

    def clamp(self, s: float) -> None:
        self.frame.clamp(self.node(s))

    def load(self, s: float, force=(0.0, 0.0, 0.0), moment=(0.0, 0.0, 0.0)) -> None:
        self.frame.load(self.node(s), force, moment)

    def solve(self) -> FrameSolution:
        return self.frame.solve()

    def element_at(self, s: float) -> tuple[int, float]:
        """(element, distance from its first node) of the section at arc length s, Eq. (6)."""
        near = np.abs(self.node_s - s) <= 1e-12 * self.vertex_s[-1]
        if np.any(near):                         # at a node (within rounding): the element after it
            s = float(self.node_s[np.argmax(near)])
        e = int(np.searchsorted(self.node_s, s, side="right") - 1)
        e = min(max(e, 0), len(self.frame.elements) - 1)
        return e, float(s - self.node_s[e])

    def section_axes_at(self, s: float) -> np.ndarray:
        return self.frame.element_geometry(self.element_at(s)[0])[1]


def section_forces_at(model: PolylineFrame, solution: FrameSolution, s: float) -> np.ndarray:
    """[N, Vy, Vz, T, My, Mz] (N, N m) at arc length s, section frame, Eqs. (5)-(6)."""
    e, a = model.element_at(s)
    return solution.section_forces(e, a)
