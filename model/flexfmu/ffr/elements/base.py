"""What an FFR beam element is: the interface every element type implements, and the element frame.

An element type is a small stateless object (in the manner of scikit-fem's element classes): it declares its
nodes and DOFs and gives its matrices and interpolation in *element axes*; the FFR modules do the rest (frames,
B_D1 assembly, boundary, point motion, inertia integrals, geometric stiffness).  The element-to-body rotation
C^ij and C_bar^ij (Koda et al. 2025, Eqs. 8-11) are the same for every two-node element with six nodal DOFs, so
they are defined here once and inherited.

Local element DOF order per node: (u, v, w, theta_x, theta_y, theta_z) along the element axes (x_bar along the
element, y_bar, z_bar the section axes); node 1 then node 2.  Rotations are right-handed: for an Euler-Bernoulli
element theta_z = dv/dx and theta_y = -dw/dx; a shear-deformable element's section rotations differ from these
slopes by the shear strain.
"""
from __future__ import annotations

import numpy as np


def element_rotation(directions: np.ndarray) -> np.ndarray:
    """C^ij: element-to-body rotation matrices, shape (n, 3, 3), from unit element axes (n, 3).

    Columns of C are the element axes x_bar, y_bar, z_bar in body components, so a
    vector with element components a has body components C @ a.  This is the
    transpose of Gere & Weaver's member rotation matrix R (body -> member), which the
    paper prints as Eq. 8 with Y as the reference ("vertical") axis:
        R = [[ cx,        cy,  cz       ],
             [-cx*cy/Q,   Q,  -cy*cz/Q  ],
             [-cz/Q,      0,   cx/Q     ]],   Q = sqrt(cx^2 + cz^2),
    and, for an element parallel to Y (Q = 0), Eq. 10:
        R = [[0, cy, 0], [-cy, 0, 0], [0, 0, 1]].
    So z_bar is horizontal (normal to Y and to the element) and y_bar leans towards +Y.
    """
    d = np.atleast_2d(np.asarray(directions, dtype=float))
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    cx, cy, cz = d[:, 0], d[:, 1], d[:, 2]
    # Eq. 8 is exact for any Q > 0 (hypot avoids underflow), so Eq. 10 is used only for
    # Q == 0.  For nearly vertical elements the section axes follow the tiny horizontal
    # component (inherent to the Gere & Weaver rule; irrelevant for circular sections).
    Q = np.hypot(cx, cz)
    vertical = Q == 0.0
    Qs = np.where(vertical, 1.0, Q)
    R = np.empty((d.shape[0], 3, 3))
    R[:, 0, :] = d
    R[:, 1, 0] = -cx * cy / Qs
    R[:, 1, 1] = Q
    R[:, 1, 2] = -cy * cz / Qs
    R[:, 2, 0] = -cz / Qs
    R[:, 2, 1] = 0.0
    R[:, 2, 2] = cx / Qs
    if vertical.any():  # Eq. 10
        sgn = np.sign(cy[vertical])
        Rv = np.zeros((int(vertical.sum()), 3, 3))
        Rv[:, 0, 1] = sgn
        Rv[:, 1, 0] = -sgn
        Rv[:, 2, 2] = 1.0
        R[vertical] = Rv
    return np.transpose(R, (0, 2, 1))


def element_dof_rotation(C: np.ndarray) -> np.ndarray:
    """C_bar (Eq. 11): (n, 12, 12) block-diagonal diag(C, C, C, C).

    e_body = C_bar @ e_element; the paper's Eq. 11 prints the transpose, the map
    from body to element nodal coordinates used inside B_D1 (Eq. 13).
    """
    n = C.shape[0]
    Cbar = np.zeros((n, 12, 12))
    for k in range(4):
        Cbar[:, 3 * k:3 * k + 3, 3 * k:3 * k + 3] = C
    return Cbar


# Local DOF indices of each sub-problem of a 12-DOF element.  For bending in the x-z plane the slope is
# -theta_y, handled by the sign vector XZ_SIGN.
AXIAL = [0, 6]
TORSION = [3, 9]
BEND_XY = [1, 5, 7, 11]   # v1, theta_z1, v2, theta_z2
BEND_XZ = [2, 4, 8, 10]   # w1, theta_y1, w2, theta_y2
XZ_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


def scatter(target: np.ndarray, idx: list[int], block: np.ndarray, sign: np.ndarray | None = None) -> None:
    """Add the (n, k, k) ``block`` on the local DOFs ``idx`` of ``target`` (n, 12, 12), rows and columns times
    ``sign`` (XZ_SIGN: the x-z bending plane, whose slope is -theta_y)."""
    if sign is not None:
        block = block * sign[None, :, None] * sign[None, None, :]
    target[:, np.ix_(idx, idx)[0], np.ix_(idx, idx)[1]] += block


class BeamElement:
    """A two-node beam element type of the FFR model.  Subclass it, set ``name``, implement the four methods
    below, and register the class (:func:`flexfmu.ffr.elements.register`); a scene then selects it by its name.

    Arguments shared by the methods: ``L`` element lengths (m), an array (n,) for the matrices and a scalar for
    the interpolation; ``section`` and ``material`` the scene's (:class:`flexfmu.ffr.scene.Section`,
    :class:`flexfmu.ffr.scene.Material`: A, Iy, Iz, J, Ip, shape, shear_coefficient; E, G, nu, rho).
    Everything is in element axes; the FFR modules rotate it to the body frame with C_bar.
    """

    #: Registry key: the value of a scene's "element" field.
    name: str = ""
    #: The FFR modules assemble, constrain and interpolate the nodal vector as 2 nodes x 6 DOFs
    #: (u, v, w, theta_x, theta_y, theta_z); registration checks that an element declares this layout.
    nodes_per_element: int = 2
    dofs_per_node: int = 6
    #: Asymptotic order in the element length h of the error of the natural frequencies on refinement (4: cubic
    #: Hermite bending with consistent mass).  Declared for the automatic mesh choice's Richardson estimate,
    #: which assumes 4 (flexfmu.sizing.mesh.CONVERGENCE_ORDER) and does not read it yet.
    convergence_order: int = 4

    @property
    def dofs_per_element(self) -> int:
        return self.nodes_per_element * self.dofs_per_node

    # ------------------------------------------------------------ frame (shared by two-node, six-DOF elements)
    def rotation(self, directions: np.ndarray) -> np.ndarray:
        """C^ij (n, 3, 3) element -> body from the element directions (n, 3) (Eqs. 8, 10)."""
        return element_rotation(directions)

    def dof_rotation(self, C: np.ndarray) -> np.ndarray:
        """C_bar (n, 12, 12) = diag(C, C, C, C) (Eq. 11): element nodal vector -> body."""
        return element_dof_rotation(C)

    # ------------------------------------------------------------ what an element type defines
    def stiffness(self, L, section, material) -> np.ndarray:
        """Element stiffness K^e, (n, 12, 12)."""
        raise NotImplementedError

    def mass(self, L, section, material, rotary_inertia: bool = False) -> np.ndarray:
        """Consistent element mass M^e, (n, 12, 12).  ``rotary_inertia``: add the rotary inertia of the bending
        slopes to an element that leaves it out by default (an element whose theory includes it ignores it)."""
        raise NotImplementedError

    def shape_functions(self, xi: float, L: float, section, material) -> np.ndarray:
        """Interpolation S of the centre line's displacement and the section's rotation at xi in [0, 1],
        (6, 12): rows (u, v, w, theta_x, theta_y, theta_z) of the point from the element's nodal vector.
        Kinematics (point motion, loads) uses it, and the inertia integrals its translation rows."""
        raise NotImplementedError

    def strain_gradients(self, xi: float, L: float, section, material) -> np.ndarray:
        """(3, 12): the rows of dv/dx, dw/dx and d theta_x/dx at xi in [0, 1], what the geometric stiffness of
        an axial prestress needs (the second-order axial strain (v'^2 + w'^2) / 2 and Wagner's torsion term,
        flexfmu.ffr.geometric_stiffness Eq. (3))."""
        raise NotImplementedError
