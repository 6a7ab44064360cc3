"""Stress and strain gauges and shape coordinates of an exported FREE solid body, checked against the inertia-relief
static solution of the full, unreduced finite-element model solved here independently.

The case: a free steel bar (0.4 x 0.04 x 0.02 m, 40 x 5 x 3 hexahedra, 2952 DOFs) with interfaces ``tip`` (x = 0.4 m
face) and ``root`` (x = 0 face), loaded by held forces F_tip = (400, 300, 0) N and F_root = (0, 300, 0) N.  Their
moments about the centre of mass cancel, so the bar accelerates without turning (the deformed load arms u_P x F leave
a moment about z only, second order: the frame turns by ~1e-5 rad in the run, measured below).  After the start
transient has decayed the body is in steady rigid acceleration and its elastic deformation is the inertia-relief
static solution:

    K u = f - M Phi_r a_r,   Phi_r^T M Phi_r a_r = Phi_r^T f   (rigid translations and rotations about the centre of
    mass),  u M-orthogonal to the rigid motions,

solved by scipy's sparse LU on a statically determinate support (3-2-1: the load f - M Phi_r a_r is self-equilibrated,
so the support carries nothing) and stripped of its rigid part.  The stress of u is evaluated by scikit-fem's own mesh
(skfem.io.meshio), element finder, inverse mapping and basis gradients, not by flexfmu.body.stress.  The loads are
distributed over each face by the equal-weight rigid distribution (RBE3), re-derived here from its equilibrium.

The transient: each flexible coordinate of a step load from rest differs from its steady value by at most
e^(-zeta omega_1 t) / sqrt(1 - zeta^2) of it; with damping_ratio 0.3, omega_1 = 2 pi 696 Hz and t = 0.03 s that is
e^(-39), nothing.
"""
from __future__ import annotations

import math
import zipfile

import numpy as np
import pytest
import scipy.sparse.linalg as spla

skfem = pytest.importorskip("skfem")
meshio = pytest.importorskip("meshio")

from flexfmu.body.build import build_body  # noqa: E402
from flexfmu.body.simulator import FlexBodySimulator  # noqa: E402
from flexfmu.body.variables import FlexBodyConfig  # noqa: E402
from flexfmu.cli import main  # noqa: E402
from flexfmu.core.stress import VOIGT, von_mises  # noqa: E402
from flexfmu.importers import load_structure  # noqa: E402

E, NU, RHO = 2.1e11, 0.3, 7850.0
SIZE = (0.4, 0.04, 0.02)                      # m, along x, y, z; centred on y = z = 0
NODES = (41, 6, 4)
POINT = (0.13, 0.011, 0.006)                  # m, body frame: off both neutral planes, where bending and shear act
F_TIP, F_ROOT = np.array([400.0, 300.0, 0.0]), np.array([0.0, 300.0, 0.0])
ZETA, STEP, N_STEPS = 0.3, 1e-3, 30
INTERFACES = [{"name": "tip", "point": None, "node_set": "tip"}, {"name": "root", "point": None, "node_set": "root"}]
GAUGES = ["p={},{},{}".format(*POINT), "mid=middle"]
#: the brief's bound for the body with its static correction; the reduction's static error (1e-8), the transient
#: (e^-39) and the frame's turn (~1e-5 rad, asserted below) are far within it
RTOL = 0.01


@pytest.fixture(scope="module")
def bar(tmp_path_factory):
    """(mesh path, Structure, node index (nx, ny, nz))."""
    folder = tmp_path_factory.mktemp("free_bar")
    axes = [np.linspace(0.0, SIZE[0], NODES[0]), np.linspace(-SIZE[1] / 2, SIZE[1] / 2, NODES[1]),
            np.linspace(-SIZE[2] / 2, SIZE[2] / 2, NODES[2])]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    index = np.arange(points.shape[0]).reshape(NODES)
    nx, ny, nz = NODES
    cells = [[c[0, 0, 0], c[1, 0, 0], c[1, 1, 0], c[0, 1, 0], c[0, 0, 1], c[1, 0, 1], c[1, 1, 1], c[0, 1, 1]]
             for c in (index[i:i + 2, j:j + 2, k:k + 2] for i in range(nx - 1) for j in range(ny - 1)
                       for k in range(nz - 1))]
    path = folder / "bar.inp"
    meshio.write(str(path), meshio.Mesh(points, [("hexahedron", np.array(cells))],
                                        point_sets={"root": index[0].ravel(), "tip": index[-1].ravel(),
                                                    "middle": index[nx // 2].ravel()}))
    return path, load_structure(path, material={"E": E, "nu": NU, "rho": RHO}), index


# ---------------------------------------------------------------------------------------------- the full model
def face_load(structure, nodes, force):
    """Nodal forces (n_dof,) of ``force`` at the centre P of ``nodes``, distributed as a rigid patch with equal
    weights (RBE3): f_i = a + b x r_i (r_i = x_i - P) with sum_i f_i = F and sum_i r_i x f_i = 0."""
    r = structure.nodes[nodes] - structure.nodes[nodes].mean(axis=0)
    sr = r.sum(axis=0)
    cross = np.array([[0, -sr[2], sr[1]], [sr[2], 0, -sr[0]], [-sr[1], sr[0], 0]])
    A = np.block([[nodes.size * np.eye(3), -cross], [cross, np.sum(r * r) * np.eye(3) - r.T @ r]])
    ab = np.linalg.solve(A, np.concatenate([force, np.zeros(3)]))
    f = np.zeros(structure.n_dof)
    f[(3 * nodes[:, None] + np.arange(3)).ravel()] = (ab[:3] + np.cross(ab[3:], r)).ravel()
    return f


def inertia_relief(structure, f):
    """(u, a_r): the M-orthogonal elastic solution of K u = f - M T a_r and the rigid accelerations a_r (translation
    of the centre of mass, m/s^2; angular, rad/s^2), T the rigid fields about the centre of mass."""
    M, K, x = structure.M.tocsr(), structure.K.tocsr(), structure.nodes
    T = np.zeros((structure.n_dof, 6))
    for a in range(3):
        T[a::3, a] = 1.0
    mass_per_node = (M @ T[:, 0])[0::3]
    centre = mass_per_node @ x / mass_per_node.sum()
    for a in range(3):
        T[:, 3 + a] = np.cross(np.eye(3)[a], x - centre).ravel()
    G = T.T @ (M @ T)
    a_r = np.linalg.solve(G, T.T @ f)
    load = f - M @ (T @ a_r)
    assert np.abs(T.T @ load).max() < 1e-10 * np.abs(f).max()          # self-equilibrated
    corner, far, side = 0, int(np.argmax(x[:, 0] - x[:, 1])), int(np.argmax(x[:, 1] - x[:, 0]))
    held = [3 * corner, 3 * corner + 1, 3 * corner + 2, 3 * far + 1, 3 * far + 2, 3 * side + 2]
    free = np.setdiff1d(np.arange(structure.n_dof), held)
    u = np.zeros(structure.n_dof)
    u[free] = spla.splu(K[free][:, free].tocsc()).solve(load[free])
    u -= T @ np.linalg.solve(G, T.T @ (M @ u))
    return u, a_r


class SkfemStress:
    """Stress (Pa, VOIGT) of a displacement field (structure DOF order) by scikit-fem's trilinear hexahedra."""

    def __init__(self, path, structure):
        from scipy.spatial import cKDTree
        from skfem.io.meshio import from_meshio

        mesh = from_meshio(meshio.read(path))
        self.basis = skfem.Basis(mesh, skfem.ElementVector(skfem.ElementHex1()))
        self.finder = mesh.element_finder()
        component = np.empty(self.basis.N, dtype=np.int64)
        component[self.basis.nodal_dofs] = np.arange(3)[:, None]
        distance, node = cKDTree(structure.nodes).query(self.basis.doflocs.T)
        assert distance.max() < 1e-12
        self.dof = 3 * node + component
        self.lam, self.mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))

    def _stress(self, U, x, cells):
        b = self.basis
        X = b.mapping.invF(x[:, :, None], tind=cells)
        grad = 0.0
        for k in range(b.Nbfun):
            g = b.elem.gbasis(b.mapping, X, k, tind=cells)[0].grad[:, :, :, 0]          # (3, 3, n)
            grad = grad + g * U[self.dof][b.element_dofs[k, cells]][None, None]
        eps = 0.5 * (grad + grad.transpose(1, 0, 2))
        sigma = 2 * self.mu * eps + self.lam * np.trace(eps)[None, None] * np.eye(3)[:, :, None]
        return np.stack([sigma[a, c] for a, c in ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))], axis=1)

    def at_point(self, U, point):
        x = np.asarray(point, float).reshape(3, 1)
        return self._stress(U, x, self.finder(*x))[0]

    def node_set_mean(self, U, structure, nodes):
        """Mean over the nodes of the mean over the cells sharing each node of the cell's stress at the node."""
        cells = structure.cells["hexahedron"]
        values = []
        for n in nodes:
            sharing = cells[np.any(cells == n, axis=1)]
            centres = structure.nodes[sharing].mean(axis=1).T
            x = np.repeat(structure.nodes[n][:, None], sharing.shape[0], axis=1)
            values.append(self._stress(U, x, self.finder(*centres)).mean(axis=0))
        return np.mean(values, axis=0)


@pytest.fixture(scope="module")
def reference(bar):
    path, structure, index = bar
    f = face_load(structure, index[-1].ravel(), F_TIP) + face_load(structure, index[0].ravel(), F_ROOT)
    u, a_r = inertia_relief(structure, f)
    skf = SkfemStress(path, structure)
    return {"u": u, "a_r": a_r, "p": skf.at_point(u, POINT),
            "mid": skf.node_set_mean(u, structure, structure.node_sets["middle"])}


def settled_outputs(body):
    sim = FlexBodySimulator(body, FlexBodyConfig(damping_ratio=ZETA))
    sim.set_inputs(**{"tip.F_x": F_TIP[0], "tip.F_y": F_TIP[1], "root.F_y": F_ROOT[1]})
    for _ in range(N_STEPS):
        sim.step(STEP)
    return sim.outputs()


def stress_of(out, gauge):
    return np.array([out[f"{gauge}.sigma_{c}"] for c in VOIGT])


# ---------------------------------------------------------------------------------------------- the tests
def test_steady_acceleration_stress_is_the_inertia_relief_solution(bar, reference):
    """The free body sized by f_max (modes and static-correction vectors) reads the full model's inertia-relief
    stress within 1 % at a point and over a node set, its von Mises too; its shape coordinates give the full model's
    elastic displacement (u = Psi q); its centre of mass accelerates as the rigid projection says.  The retained
    modes alone (no static correction) are measured and must be worse."""
    _, structure, _ = bar
    body = build_body(structure, interfaces=INTERFACES, f_max=20000.0, gauges=GAUGES, with_shapes=True)
    assert body.n_coordinates > body.n_modes                         # the static correction is on
    out = settled_outputs(body)
    turn = 2 * math.acos(min(1.0, abs(out["q_w"])))
    assert turn < 1e-4                                               # the frame has not turned: global = body frame
    t = N_STEPS * STEP
    com_acc = np.array([out[f"com_vel_{a}"] for a in "xyz"]) / t
    assert np.allclose(com_acc, reference["a_r"][:3], rtol=1e-6)
    # the modes alone, 10 and twice as many: their truncation error (not monotone at a point: measured 1.6e-2 and
    # 1.8e-2 at ``p``, 5.3e-3 with 40)
    out_modes = {n: settled_outputs(build_body(structure, interfaces=INTERFACES, n_modes=n, gauges=GAUGES))
                 for n in (10, 20)}
    for gauge in ("p", "mid"):
        ref, got = reference[gauge], stress_of(out, gauge)
        error = np.abs(got - ref).max() / np.abs(ref).max()
        vm_error = abs(out[f"{gauge}.von_mises"] / von_mises(ref) - 1)
        error_modes = {n: np.abs(stress_of(o, gauge) - ref).max() / np.abs(ref).max() for n, o in out_modes.items()}
        print(f"{gauge}: von Mises full {von_mises(ref) / 1e6:.5f} MPa, FMU {out[f'{gauge}.von_mises'] / 1e6:.5f} "
              f"MPa (error {vm_error:.2e}, tensor {error:.2e}; {body.n_modes} modes + "
              f"{body.n_coordinates - body.n_modes} residual vectors); modes alone, tensor error: "
              + ", ".join(f"{n} modes {e:.2e}" for n, e in error_modes.items()))
        assert error < RTOL and vm_error < RTOL
        assert min(error_modes.values()) > error
        assert out[f"{gauge}.von_mises"] == pytest.approx(float(von_mises(got)), rel=1e-12)
        strain = np.array([out[f"{gauge}.eps_{c}"] for c in VOIGT])
        compliance = (1 + NU) / E * got - NU / E * np.concatenate([np.full(3, got[:3].sum()), np.zeros(3)])
        assert np.abs(strain - compliance).max() <= 1e-12 * np.abs(strain).max()
    q = np.array([out[f"q_{k}"] for k in range(1, body.n_coordinates + 1)])
    u = body.shape_data["Psi"].reshape(-1, q.size) @ q
    assert np.abs(u - reference["u"]).max() < RTOL * np.abs(reference["u"]).max()
    # the node-set gauge is the shape file's nodal stress shapes times q, averaged over the set
    S = body.shape_data["S"]
    mid = (S[structure.node_sets["middle"]] @ q).mean(axis=0)
    assert np.allclose(mid, stress_of(out, "mid"), rtol=0, atol=1e-9 * np.abs(mid).max())


def test_the_exported_free_body_names_its_gauges_and_carries_its_shapes(bar, tmp_path, capsys):
    """flexfmu export of the free bar with --gauge: the model description has q_1 .. q_n and the gauges' outputs with
    their units, says they are the elastic deformation's relative to the body frame and, with --modes, that the
    stress carries the truncation error (the command's messages say it too); resources/shape.npz holds n shapes in
    the body frame."""
    from flexfmu.body.shape_file import read_fmu_shape

    path, structure, _ = bar
    fmu = tmp_path / "FreeBar.fmu"
    args = ["export", str(path), "-o", str(fmu), "--material", f"{E},{NU},{RHO}", "--interface", "tip=tip",
            "--modes", "4", "--gauge", GAUGES[0]]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "truncation error" in err
    with zipfile.ZipFile(fmu) as z:
        description = z.read("modelDescription.xml").decode()
    for name in [f"q_{k}" for k in range(1, 5)] + [f"p.sigma_{c}" for c in VOIGT] + ["p.von_mises", "p.eps_xx"]:
        assert f'name="{name}"' in description, name
    assert "q_5" not in description
    assert "relative to the body frame" in description and "truncation error" in description
    shape = read_fmu_shape(fmu)
    assert shape.names == tuple(f"q_{k}" for k in range(1, 5))
    assert shape.Psi.shape == (structure.nodes.shape[0], 3, 4)
    assert shape.header.get("frame") == "body"


def test_the_native_free_body_has_the_python_bodys_gauges(bar, tmp_path):
    """The free bar as a native FMU (the reframe kind: the same kernels; the gauges' rows on q_F in C, von Mises by
    csrc/derived_stress.c): its q, gauge and com outputs over a step load equal the Python simulator's to 1e-10 of
    each output's largest value (the same arithmetic but the rows' sums, in another order)."""
    import fmpy

    from flexfmu.fmi.native import export_native
    from flexfmu.native.compiler import CompilerError
    _, structure, _ = bar
    body = build_body(structure, interfaces=INTERFACES, n_modes=6, gauges=GAUGES, with_shapes=True)
    try:
        fmu = export_native(body, tmp_path / "FreeBarNative.fmu")
    except CompilerError as exc:                                       # pragma: no cover - no C compiler
        pytest.skip(f"no C compiler: {exc}")
    with zipfile.ZipFile(fmu) as z:
        assert "resources/shape.npz" in z.namelist()
    names = ([f"q_{k}" for k in range(1, 7)] + [f"{g}.{c}" for g in ("p", "mid") for c in
             [f"sigma_{v}" for v in VOIGT] + ["von_mises"] + [f"eps_{v}" for v in VOIGT]] + ["com_pos_x", "omega_3"])
    h, n_steps = 2e-4, 50
    signal = np.array([(0.0, *F_TIP[:2], F_ROOT[1]), (n_steps * h, *F_TIP[:2], F_ROOT[1])],
                      dtype=[("time", float), ("tip.F_x", float), ("tip.F_y", float), ("root.F_y", float)])
    native = fmpy.simulate_fmu(str(fmu), stop_time=n_steps * h, step_size=h, output_interval=h, input=signal,
                               output=names, start_values={"damping_ratio": ZETA})
    sim = FlexBodySimulator(body, FlexBodyConfig(damping_ratio=ZETA))
    sim.set_inputs(**{"tip.F_x": F_TIP[0], "tip.F_y": F_TIP[1], "root.F_y": F_ROOT[1]})
    python = [sim.outputs()]
    for _ in range(n_steps):
        sim.step(h)
        python.append(sim.outputs())
    for name in names:
        ours = np.array([row[name] for row in python])
        scale = np.abs(ours).max()
        assert native[name].size == ours.size and scale > 0, name
        assert np.abs(native[name] - ours).max() <= 1e-10 * scale, name
