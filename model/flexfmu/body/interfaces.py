"""Interfaces of a flexible body: named points where it meets other models, each tied to a patch of nodes
by an RBE3-like (interpolation) distribution.

An interface has a name (a letter, then letters, digits or _; unique in the body), a point P (x_P, body-frame
coordinates of the undeformed structure, m) and a patch of nodes i with positions x_i, r_i = x_i - x_P.

Patch (one of):
  node_set   a named node set of the Structure (gmsh physical group, Abaqus NSET, ...);
  radius     every node with |x_i - x_P| <= radius (m);
  default    6 DOFs per node (beams): the nearest node (its rotational DOFs carry moments); 3 DOFs per node
             (solids): the nearest node and every node that shares an element with it (its row of K's
             sparsity pattern), i.e. about one element around the point on any mesh density.

The point must lie at its patch: within max(patch radius, local spacing) of the nearest patch node, where the
patch radius is the largest distance of a patch node from the patch centroid and the local spacing the
distance from that nearest node to the closest other node of the structure.  So a point on or inside the
meshed material, or at the centre of a ring of nodes (a bolt hole's wall), is accepted; a point away from
the body is not (flexfmu.core.body_points: the rule ReframeBody's load and output points follow too).

Distribution.  The point's motion (u, theta) is the weighted least-squares rigid fit of the patch motion:

    u_i ~ u + theta x r_i   (translations),     theta_i ~ theta   (rotations, when fitted)          (I1)
    min sum_i w_i |B_i [u; theta] - d_i|^2_W,  B_i = [[I, -[r_i]x], [0, I]],  W = diag(1, 1, 1, l^2 I)  (I2)
    [u; theta] = D d_patch,   D = A^+ [w_1 B_1^T W ... w_k B_k^T W],   A = sum_i w_i B_i^T W B_i          (I3)

with equal weights w_i = 1 (as RBE3's default).  Only the translations are fitted when they determine a
rotation (three or more non-colinear nodes); on 6-DOF structures whose patch translations do not (one node,
nodes on a line) the nodes' rotations are fitted too, with weight l^2 (l: the patch radius, else the local
spacing), so a one-node patch is a rigid link to its node.  A force F and moment M at the point go to the
patch DOFs as

    f = D^T [F; M],   sum_i f_i = F,   sum_i (r_i x f_i + m_i) = M,   [F; M] . [u; theta] = f . d_patch  (I4)

(the rows of A [u; theta] = sum_i w_i B_i^T W d_i are the force and moment sums; the last identity is
reciprocity).  A patch whose fit leaves a rotation undetermined (3-DOF nodes on a line, or one such node)
cannot carry a moment: then M is not an input, and a force at P is refused unless P lies on that line.
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from flexfmu.core.body_points import element_neighbours, patch_reach
from flexfmu.core.body_points import local_spacing as _local_spacing  # noqa: F401  (its former home)
from flexfmu.core.checks import finite, shown
from flexfmu.errors import ParameterError

NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")
NAME_ALLOWED = "a letter, then letters, digits or _ (at most 64), unique in the body"
#: a rotation counts as determined by the fit when its eigenvalue in A (rotations scaled by the patch size)
#: is above this fraction of the largest
RANK_RTOL = 1e-8
#: a force needs its point on the axis of a rotation the patch cannot carry, within this fraction of the patch size
LEVER_RTOL = 1e-6


@dataclass(frozen=True)
class Interface:
    """What the user asks for: ``name``, ``point`` (3,) in m (body frame; None with a node_set: the set's
    centre), and the patch: ``node_set`` (a name of Structure.node_sets) or ``radius`` (m), or neither (the
    default patch, module docstring).
    ``moments``: None = M_x, M_y, M_z are inputs if the patch can carry a moment; True = required (refused if it
    cannot); False = forces only."""

    name: str
    point: tuple
    node_set: str | None = None
    radius: float | None = None
    moments: bool | None = None


@dataclass(frozen=True)
class Patch:
    """A resolved interface: point (3,), patch nodes (k,), the fitted DOFs (their indices in the Structure,
    3 or 6 per node), D (6, n_fitted) of Eq. (I3), whether M is an input, and how the patch was chosen."""

    name: str
    point: np.ndarray
    nodes: np.ndarray
    dofs: np.ndarray
    D: np.ndarray
    moments: bool
    rule: str

    @property
    def n_loads(self) -> int:
        """3 (force) or 6 (force and moment)."""
        return 6 if self.moments else 3

    def loads(self, n_dof: int) -> np.ndarray:
        """(n_dof, n_loads) nodal loads of unit F_x, F_y, F_z (, M_x, M_y, M_z) at the point: D^T (I4)."""
        G = np.zeros((n_dof, self.n_loads))
        G[self.dofs] = self.D[:self.n_loads].T
        return G

    def translation(self, n_dof: int) -> np.ndarray:
        """(3, n_dof): the point's translation u from the nodal displacements (I3)."""
        O = np.zeros((3, n_dof))
        O[:, self.dofs] = self.D[:3]
        return O


def interface_from_dict(data, index: int = 0) -> Interface:
    """An Interface from JSON-like data: {"name", "point", optional "node_set" | "radius", "moments"}."""
    where = f"interfaces[{index}]"
    if isinstance(data, Interface):
        return data
    if not isinstance(data, dict):
        raise ParameterError(where, f"{shown(data)}", '{"name": ..., "point": [x, y, z], "node_set" | "radius": ...}')
    unknown = set(data) - {"name", "point", "node_set", "radius", "moments"}
    if unknown:
        raise ParameterError(f"{where}.{sorted(unknown)[0]}", "unknown key", "name, point, node_set, radius, moments")
    if "name" not in data or "point" not in data:
        raise ParameterError(where, "needs a name and a point", '{"name": ..., "point": [x, y, z], ...}')
    return Interface(name=data["name"], point=data["point"], node_set=data.get("node_set"),
                     radius=data.get("radius"), moments=data.get("moments"))


def interface_from_text(text: str) -> Interface:
    """--interface NAME=X,Y,Z[,R] | NAME=SET | NAME=SET@X,Y,Z  ->  flexfmu.body.Interface (coordinates in m)."""
    allowed = ("NAME=X,Y,Z (m, body frame; the nodes around the point) | NAME=X,Y,Z,R (the nodes within R m) | "
               "NAME=SET (a node set; the point at its centre) | NAME=SET@X,Y,Z")
    name, sep, rest = text.partition("=")
    if not sep or not name or not rest:
        raise ParameterError("interface", repr(text), allowed)
    node_set, _, coords = rest.partition("@") if "@" in rest else (None, "", rest)
    try:
        values = [float(part) for part in coords.split(",")]
    except ValueError:
        if node_set is None and "," not in rest:          # NAME=SET
            return Interface(name=name, point=None, node_set=rest)
        raise ParameterError("interface", f"{text!r}: coordinates are not numeric", allowed) from None
    if len(values) not in (3, 4) or (node_set is not None and len(values) != 3):
        raise ParameterError("interface", repr(text), allowed)
    return Interface(name=name, point=tuple(values[:3]), node_set=node_set,
                     radius=values[3] if len(values) == 4 else None)


def _check_spec(spec: Interface, index: int, names: set) -> tuple[str, np.ndarray]:
    if not isinstance(spec, Interface):
        spec = interface_from_dict(spec, index)
    name = spec.name
    if not (isinstance(name, str) and NAME_PATTERN.fullmatch(name)):
        raise ParameterError(f"interfaces[{index}].name", f"{shown(name)}", NAME_ALLOWED)
    if name in names:
        raise ParameterError(f"interfaces.{name}", "duplicate name", NAME_ALLOWED)
    try:
        point = np.array(spec.point, dtype=float)
    except (TypeError, ValueError):
        point = None
    if point is None or point.shape != (3,) or not np.all(np.isfinite(point)):
        raise ParameterError(f"interfaces.{name}.point", f"{shown(spec.point)}", "three finite coordinates, m")
    if spec.node_set is not None and spec.radius is not None:
        raise ParameterError(f"interfaces.{name}", "both node_set and radius given", "one of them, or neither")
    if spec.radius is not None and not (finite(spec.radius) and spec.radius > 0):
        raise ParameterError(f"interfaces.{name}.radius", f"{shown(spec.radius)}", "a finite radius > 0 m")
    if spec.moments not in (None, True, False):
        raise ParameterError(f"interfaces.{name}.moments", f"{shown(spec.moments)}", "null (automatic), true, false")
    return name, point


def _patch_nodes(structure, spec: Interface, name: str, point: np.ndarray, dpn: int):
    nodes = structure.nodes
    dist = np.linalg.norm(nodes - point, axis=1)
    if spec.node_set is not None:
        sets = structure.node_sets or {}
        if spec.node_set not in sets:
            known = ", ".join(sorted(map(str, sets))) or "none in this model"
            raise ParameterError(f"interfaces.{name}.node_set", f"unknown node set {shown(spec.node_set)}",
                                 f"a node set of the model: {known}")
        try:
            members = np.unique(np.asarray(sets[spec.node_set], dtype=np.int64).ravel())
        except (TypeError, ValueError):
            members = np.zeros(0, dtype=np.int64)
        members = members[(members >= 0) & (members < nodes.shape[0])]
        if members.size == 0:
            raise ParameterError(f"interfaces.{name}.node_set", f"node set {spec.node_set!r} selects no node",
                                 "a node set with at least one node of the model")
        return members, f"node set {spec.node_set!r}"
    if spec.radius is not None:
        members = np.flatnonzero(dist <= spec.radius)
        if members.size == 0:
            raise ParameterError(f"interfaces.{name}.radius", f"no node within {spec.radius:g} m of the point "
                                 f"(nearest: {dist.min():.4g} m)", f"a radius >= {dist.min():.4g} m")
        return members, f"the nodes within {spec.radius:g} m"
    nearest = int(np.argmin(dist))
    if dpn == 6:
        return np.array([nearest]), f"the nearest node ({nearest})"
    return (element_neighbours(structure.K.tocsr(), nearest, dpn),
            f"the nearest node ({nearest}) and its element neighbours")


def _fit(r: np.ndarray, dpn: int, with_rotations: bool, length: float):
    """A (6, 6) and the stacked B_i^T W (6, n_fitted) of Eqs. (I2)-(I3) for arms r (k, 3)."""
    k = r.shape[0]
    per = 6 if with_rotations else 3
    BtW = np.zeros((6, per * k))
    for i, ri in enumerate(r):
        BtW[:3, per * i:per * i + 3] = np.eye(3)
        BtW[3:, per * i:per * i + 3] = np.array([[0.0, -ri[2], ri[1]], [ri[2], 0.0, -ri[0]], [-ri[1], ri[0], 0.0]])
        if with_rotations:
            BtW[3:, per * i + 3:per * i + 6] = length ** 2 * np.eye(3)
    # A = sum_i B_i^T W B_i: B_i^T W B_i from the translation rows [I, -[r]x] and rotation rows l^2 [0, I]
    A = np.zeros((6, 6))
    for i, ri in enumerate(r):
        S = np.array([[0.0, -ri[2], ri[1]], [ri[2], 0.0, -ri[0]], [-ri[1], ri[0], 0.0]])
        Bt = np.hstack([np.eye(3), -S])
        A += Bt.T @ Bt
        if with_rotations:
            A[3:, 3:] += length ** 2 * np.eye(3)
    return A, BtW


def _resolve(structure, spec: Interface, name: str, point: np.ndarray) -> Patch:
    dpn = int(structure.dofs_per_node)
    nodes_xyz = np.asarray(structure.nodes, dtype=float)
    members, rule = _patch_nodes(structure, spec, name, point, dpn)
    xyz = nodes_xyz[members]
    reach = patch_reach(nodes_xyz, members, point)
    radius, spacing, size = reach.radius, reach.spacing, reach.size
    if not reach.on_body:
        raise ParameterError(f"interfaces.{name}.point", f"{point.tolist()} m is {reach.distance:.4g} m from the "
                             f"nearest node of its patch ({rule}): outside the body",
                             f"a point within max(patch radius, local node spacing) = {reach.reach:.4g} m of the patch")
    length = radius if radius > 0 else (spacing or size)
    r = xyz - point
    scale = np.diag([1.0, 1.0, 1.0, 1.0 / length, 1.0 / length, 1.0 / length])   # rotations as l theta: A ~ O(1)

    def rank_ok(A):
        lam = np.linalg.eigvalsh(scale @ A @ scale)
        return lam[0] > RANK_RTOL * lam[-1]

    A, BtW = _fit(r, dpn, False, length)
    fitted_rotations = False
    if not rank_ok(A) and dpn == 6:
        A, BtW = _fit(r, dpn, True, length)
        fitted_rotations = True
    full = rank_ok(A)
    As = scale @ A @ scale
    # full rank: a direct solve (balances exact to round-off); else the pseudo-inverse (free rotations left 0)
    D = scale @ (np.linalg.solve(As, scale @ BtW) if full else
                 np.linalg.pinv(As, rcond=RANK_RTOL, hermitian=True) @ scale @ BtW)
    per = 6 if fitted_rotations else 3
    dofs = (members[:, None] * dpn + np.arange(per)).ravel().astype(np.int64)
    if spec.moments and not full:
        raise ParameterError(f"interfaces.{name}.moments", f"the patch ({rule}: {members.size} node(s)"
                             f"{', on one line' if members.size > 1 else ''}) cannot carry a moment",
                             "moments false, or a patch of three or more non-colinear nodes")
    if not full:
        # the rotations the fit leaves free: a force at P must not turn the patch about them (lever ~ 0)
        lam, V = np.linalg.eigh(As)
        free = V[:, lam <= RANK_RTOL * lam[-1]]
        # scaled coordinates: u = v[:3], theta = v[3:] / l; the lever |u| / |theta| is the distance of P from the axis
        lever = float(np.max(length * np.linalg.norm(free[:3], axis=0)
                             / np.maximum(np.linalg.norm(free[3:], axis=0), 1e-300)))
        if lever > LEVER_RTOL * length:
            raise ParameterError(f"interfaces.{name}.point", f"the patch ({rule}: {members.size} node(s) on one line) "
                                 f"cannot carry the moment of a force at {point.tolist()} m, {lever:.3g} m off the "
                                 "line of its nodes", "the point on the patch's line of nodes, or a patch of three "
                                 "or more non-colinear nodes")
    moments = full if spec.moments is None else bool(spec.moments)
    how = f"{rule}: {members.size} node(s), equal weights, " + (
        "translations and rotations fitted" if fitted_rotations else "translations fitted")
    return Patch(name=name, point=point, nodes=members.astype(np.int64), dofs=dofs, D=D, moments=moments, rule=how)


def resolve_interfaces(structure, specs) -> tuple[Patch, ...]:
    """The patches of ``specs`` (Interface or dicts) on ``structure`` (module docstring); ParameterError naming
    the interface for a bad name, point, node set, radius or a patch that cannot carry its loads."""
    if specs is None:
        specs = ()
    if isinstance(specs, (Interface, dict)):
        specs = (specs,)
    try:
        specs = list(specs)
    except TypeError:
        raise ParameterError("interfaces", f"{shown(specs)}", "a list of interfaces") from None
    if not specs:
        raise ParameterError("interfaces", "none given", "at least one interface (name, point, patch)")
    if not sp.issparse(structure.K):
        raise ParameterError("structure.K", "not a sparse matrix", "scipy.sparse CSR")
    names: set = set()
    out = []
    for k, spec in enumerate(specs):
        spec = interface_from_dict(spec, k)
        if spec.point is None and isinstance(spec.node_set, str):
            # a node set alone: the point at its centre (a bolt hole's axis, a face's centre)
            sets = structure.node_sets or {}
            if spec.node_set not in sets:
                raise ParameterError(f"interfaces.{spec.name}.node_set", f"unknown node set {shown(spec.node_set)}",
                                     ", ".join(sorted(map(str, sets))) or "none: the model defines no node sets")
            nodes = np.asarray(sets[spec.node_set], dtype=np.int64)
            if nodes.size == 0:
                raise ParameterError(f"interfaces.{spec.name}.node_set", f"node set {spec.node_set!r} selects no node",
                                     "a node set with nodes of the model")
            spec = dataclasses.replace(spec, point=tuple(np.asarray(structure.nodes)[nodes].mean(axis=0)))
        name, point = _check_spec(spec, k, names)
        names.add(name)
        out.append(_resolve(structure, spec, name, point))
    return tuple(out)
