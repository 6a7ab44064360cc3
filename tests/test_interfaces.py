"""Interfaces of flexible bodies (flexfmu.body.interfaces): the RBE3-like distribution's balances and reciprocity,
rigid-motion reproduction, patch rules and the errors that name the interface.

References: statics (sum of forces, moments about the point) and the definition of work; no simulation."""
import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import straight_rod
from error_bounds import gamma, implementations_bound
from flexfmu.body.interfaces import RANK_RTOL, Interface, _fit, _local_spacing, resolve_interfaces
from flexfmu.core.structure import Structure
from flexfmu.errors import ParameterError
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.reframe.models import load_model


@pytest.fixture(scope="module")
def plate():
    s = load_model("paper_plate", divisions=(8, 2, 1))
    ring = np.flatnonzero(np.abs(np.linalg.norm(s.nodes[:, :2] - [0.25, 0.0], axis=1) - 0.02) < 0.015)
    return dataclasses.replace(s, node_sets={"ring": ring, "empty": np.zeros(0, dtype=np.int64),
                                             "edge": np.flatnonzero((s.nodes[:, 0] == 0.5) & (s.nodes[:, 2] == 0.0))})


@pytest.fixture(scope="module")
def rod():
    return build_beam_model(straight_rod(1.0, 0.02), "free", 8).structure()


def _skew(r):
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def _fit_error(structure, patch):
    """(e, l): a bound e on ||D G - I|| (G the patch's rigid motions, in the fit's scaled coordinates [u; l theta])
    and the fit's length l.  D = S As^-1 S B^T W solves with the 6 x 6 As = S A S whose entries are sums over the k
    patch nodes (k + 2 roundings, terms |B|^T|B| <= 6 ||As|| in norm), LU (gamma(18)) or the eigen-decomposition
    of pinv (generously 100 roundings): backward error E, ||E|| <= 6 gamma(2k + 100) ||As||, so ||D G - I|| <=
    kappa ||E|| / ||As||, kappa over the eigenvalues the fit keeps (RANK_RTOL) [ASNA 7.1]."""
    nodes = np.asarray(structure.nodes, float)
    xyz = nodes[patch.nodes]
    radius = float(np.max(np.linalg.norm(xyz - xyz.mean(axis=0), axis=1)))
    near = int(patch.nodes[np.argmin(np.linalg.norm(xyz - patch.point, axis=1))])
    size = float(np.linalg.norm(np.ptp(nodes, axis=0))) or 1.0
    length = radius if radius > 0 else (_local_spacing(nodes, near) or size)
    rotations = structure.dofs_per_node == 6 and patch.dofs.size == 6 * patch.nodes.size
    A, _ = _fit(xyz - patch.point, structure.dofs_per_node, rotations, length)
    S = np.diag([1.0] * 3 + [1.0 / length] * 3)
    lam = np.linalg.eigvalsh(S @ A @ S)
    kappa = lam[-1] / lam[lam > RANK_RTOL * lam[-1]].min()
    return 6 * kappa * gamma(2 * patch.nodes.size + 100), length


def _check_balances(structure, patch, rng):
    """sum f_i = F, sum (r_i x f_i + m_i) = M, reciprocity, and a rigid patch motion fitted exactly."""
    dpn = structure.dofs_per_node
    n = structure.n_dof
    FM = rng.normal(size=6)
    f = patch.loads(n) @ FM[:patch.n_loads]                       # nodal loads on all DOFs
    forces = f.reshape(-1, dpn)[:, :3]
    moments = f.reshape(-1, dpn)[:, 3:] if dpn == 6 else np.zeros((f.size // 3, 3))
    r = structure.nodes - patch.point
    # sum f_i = (D G)^T [F; M] = F exactly: ||D G - I|| (_fit_error) of [F; M / l], + the k-term sums here
    e, l = _fit_error(structure, patch)
    F_, M_ = np.abs(FM[:3]).sum(), np.abs(FM[3:patch.n_loads]).sum()
    k = patch.nodes.size
    bound = e * (F_ + M_ / l) + gamma(k) * np.abs(forces).sum(axis=0)
    assert np.all(np.abs(forces.sum(axis=0) - FM[:3]) <= bound)
    total_moment = np.cross(r, forces).sum(axis=0) + moments.sum(axis=0)
    want = FM[3:] if patch.moments else np.zeros(3)
    # the same in the moment rows: e (l F + M), + cross products and 2k + 1 sums of terms |r||f| and |m|
    terms = 2 * (np.abs(r) * np.abs(forces).sum(axis=1, keepdims=True)).sum(axis=0).max() + np.abs(moments).sum()
    bound = e * (l * F_ + M_) + gamma(2 * k + 3) * terms
    assert np.all(np.abs(total_moment - want) <= bound)
    # reciprocity: the work of F, M on the fitted (u, theta) equals the work of the nodal loads on the motion
    d = rng.normal(size=n)
    fit = np.zeros(6)
    fit[:] = patch.D @ d[patch.dofs]
    w_point = FM[:3] @ fit[:3] + (FM[3:] @ fit[3:] if patch.moments else 0.0)
    # the same D both ways, FM . (D d) vs (D^T FM) . d: two orders of the same sums of |FM| |D| |d| terms
    scale = np.abs(FM[:patch.n_loads]) @ np.abs(patch.D[:patch.n_loads]) @ np.abs(d[patch.dofs])
    assert abs(w_point - f @ d) <= implementations_bound(scale, patch.dofs.size + 6)
    # a rigid motion of the patch: u_i = u0 + theta0 x r_i (rotations theta0) is fitted exactly
    u0, th0 = rng.normal(size=3), rng.normal(size=3) * 0.1
    rigid = np.zeros(n)
    for i in range(structure.nodes.shape[0]):
        rigid[dpn * i:dpn * i + 3] = u0 + np.cross(th0, r[i])
        if dpn == 6:
            rigid[dpn * i + 3:dpn * i + 6] = th0
    fit = patch.D @ rigid[patch.dofs]
    # D G = I to ||D G - I|| <= e (_fit_error) in the scaled coordinates [u; l theta]: e ||[u0; l th0]|| on u, / l on
    # theta; the motion's own rounding (r_i, the cross product, the sum: gamma_4 (|u0| + |th0| x |r_i|), |.| x |.| the
    # cross product's terms' sizes) and the product D (.) over the patch DOFs: |D| (that + gamma_dofs |rigid|)
    ar, at = np.abs(r), np.abs(th0)
    terms = np.stack([at[1] * ar[:, 2] + at[2] * ar[:, 1], at[2] * ar[:, 0] + at[0] * ar[:, 2],
                      at[0] * ar[:, 1] + at[1] * ar[:, 0]], axis=1)
    d_rigid = np.zeros(n)
    for j in range(3):
        d_rigid[j::dpn] = gamma(4) * (abs(u0[j]) + terms[:, j])
    sel = patch.dofs
    spread = np.abs(patch.D) @ (d_rigid[sel] + gamma(sel.size) * np.abs(rigid[sel]))
    fitted = e * float(np.linalg.norm(np.r_[u0, l * th0]))
    assert np.all(np.abs(fit[:3] - u0) <= fitted + spread[:3])
    if patch.moments:
        assert np.all(np.abs(fit[3:] - th0) <= fitted / l + spread[3:])


def test_default_radius_and_node_set_patches_balance(plate, rng):
    specs = [Interface("A", (-0.5, 0.0, 0.01)),                          # default: a node and its neighbours
             Interface("B", (0.0, 0.0, 0.005), radius=0.02),
             Interface("C", (0.25, 0.0, 0.005), node_set="ring")]        # the point inside a ring of nodes
    patches = resolve_interfaces(plate, specs)
    for p in patches:
        assert p.moments and p.nodes.size >= 4
        _check_balances(plate, p, rng)
    print("\npatch sizes:", {p.name: p.nodes.size for p in patches})


def test_beam_node_is_a_rigid_link_and_carries_moments(rod, rng):
    p, q = resolve_interfaces(rod, [Interface("end", (1.0, 0.0, 0.0)), Interface("off", (0.5, 0.01, 0.0))])
    assert p.nodes.size == 1 and p.moments and p.dofs.size == 6
    for patch in (p, q):
        _check_balances(rod, patch, rng)
    # the offset link: a unit force along x at (0.5, 0.01, 0) gives the node (0.5, 0, 0) the moment of the force
    # about it, (x_P - x_node) x F = (0, 0.01, 0) x (1, 0, 0) = (0, 0, -0.01)
    f = q.loads(rod.n_dof) @ np.array([1.0, 0, 0, 0, 0, 0])
    node = int(q.nodes[0])
    # ||D G - I|| (_fit_error) of the unit force, as a moment l |F|; the arm P - x_node within gamma(1) |P|
    e, l = _fit_error(rod, q)
    bound = e * l + gamma(1) * np.abs(q.point).max()
    assert np.all(np.abs(f[6 * node + 3:6 * node + 6] - [0.0, 0.0, -0.01]) <= bound)


def test_colinear_solid_patch_is_force_only(plate, rng):
    edge = plate.node_sets["edge"]
    assert edge.size >= 2
    p = resolve_interfaces(plate, [Interface("E", tuple(plate.nodes[edge].mean(axis=0)), node_set="edge")])[0]
    assert not p.moments and p.n_loads == 3
    _check_balances(plate, p, rng)


@pytest.mark.parametrize("spec, parameter, words", [
    ([Interface("A", (0, 0, 0)), Interface("A", (0.1, 0, 0))], "interfaces.A", "duplicate"),
    ([Interface("1a", (0, 0, 0))], "interfaces[0].name", ""),
    ([Interface("A", (0, 0, 0), node_set="nope")], "interfaces.A.node_set", "unknown node set"),
    ([Interface("A", (0, 0, 0), node_set="empty")], "interfaces.A.node_set", "selects no node"),
    ([Interface("A", (3.0, 0, 0))], "interfaces.A.point", "outside the body"),
    ([Interface("A", (0.0, 0.0, 0.2), radius=0.01)], "interfaces.A.radius", "no node within"),
    ([Interface("A", (0, 0, 0), node_set="ring", radius=0.1)], "interfaces.A", "both"),
    ([Interface("A", (0.5, 0.0, 0.0), node_set="edge", moments=True)], "interfaces.A.moments", "cannot carry"),
    ([Interface("A", (0.5, 0.0, 0.004), node_set="edge")], "interfaces.A.point", "cannot carry the moment"),
    ([Interface("A", (0.0, float("nan"), 0.0))], "interfaces.A.point", ""),
    ([{"name": "A", "point": [0, 0, 0], "size": 3}], "interfaces[0].size", "unknown key"),
    ([], "interfaces", "none"),
])
def test_errors_name_the_interface(plate, spec, parameter, words):
    with pytest.raises(ParameterError) as err:
        resolve_interfaces(plate, spec)
    assert err.value.parameter == parameter
    assert words in str(err.value)


def test_point_outside_a_bent_rod_and_the_rule_scale():
    """A point inside the bounding box of an L but away from its nodes is outside; next to a node it is not."""
    nodes = np.array([[0.0, 0, 0], [0.5, 0, 0], [1.0, 0, 0], [1.0, 0.5, 0], [1.0, 1.0, 0]])
    n = nodes.shape[0] * 3
    K = sp.diags(np.ones(n - 3), 3, shape=(n, n)) + sp.eye(n)
    s = Structure(nodes=nodes, dofs_per_node=3, M=sp.eye(n, format="csr"), K=(K + K.T).tocsr())
    with pytest.raises(ParameterError) as err:
        resolve_interfaces(s, [Interface("A", (0.2, 0.8, 0.0))])
    assert err.value.parameter == "interfaces.A.point"
    p = resolve_interfaces(s, [Interface("A", (0.6, 0.0, 0.0))])[0]      # on the line of nodes 0, 1, 2
    assert set(p.nodes) == {0, 1, 2} and not p.moments
    with pytest.raises(ParameterError) as err:                           # off that line: F would turn it
        resolve_interfaces(s, [Interface("A", (0.5, 0.3, 0.0))])
    assert "cannot carry the moment" in str(err.value)
