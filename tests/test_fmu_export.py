"""flexfmu export: a user's model file -> a self-contained FMU, driven through fmpy.simulate_fmu as users do.

References are independent of the code under test: the rigid-body laws with the analytic mass and inertia of
the meshed box (rho * volume), and for the clamped body the static solution of the full imported model
(a sparse direct solve of K u = -M a) and the analytic total mass.
"""
from __future__ import annotations

import subprocess
import sys
import zipfile

import numpy as np
import pytest

from error_bounds import implementations_bound

fmpy = pytest.importorskip("fmpy")
meshio = pytest.importorskip("meshio")

RHO, E, NU = 7850.0, 2.1e11, 0.3
BOX = (0.4, 0.04, 0.02)          # m: a steel bar along x
DIVISIONS = (20, 4, 2)


def box_mesh(path, size=BOX, divisions=DIVISIONS):
    """A structured hexahedral mesh of the box [0, Lx] x [-Ly/2, Ly/2] x [-Lz/2, Lz/2] as Abaqus .inp, with
    node sets root (x = 0) and tip (x = Lx)."""
    axes = [np.linspace(0.0, size[0], divisions[0] + 1), np.linspace(-size[1] / 2, size[1] / 2, divisions[1] + 1),
            np.linspace(-size[2] / 2, size[2] / 2, divisions[2] + 1)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    nx, ny, nz = (d + 1 for d in divisions)
    index = np.arange(points.shape[0]).reshape(nx, ny, nz)
    cells = []
    for i in range(divisions[0]):
        for j in range(divisions[1]):
            for k in range(divisions[2]):
                c = index[i:i + 2, j:j + 2, k:k + 2]
                cells.append([c[0, 0, 0], c[1, 0, 0], c[1, 1, 0], c[0, 1, 0], c[0, 0, 1], c[1, 0, 1], c[1, 1, 1],
                              c[0, 1, 1]])
    point_sets = {"root": index[0].ravel(), "tip": index[-1].ravel()}
    meshio.write(str(path), meshio.Mesh(points, [("hexahedron", np.array(cells))], point_sets=point_sets))
    return points


def flexfmu(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "flexfmu", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def simulate(fmu, t_end, step, inputs=None, outputs=None, **start):
    """fmpy.simulate_fmu with constant inputs {name: value}."""
    signal = None
    if inputs:
        names = list(inputs)
        signal = np.array([(0.0, *inputs.values()), (t_end, *inputs.values())],
                          dtype=[("time", float)] + [(n, float) for n in names])
    return fmpy.simulate_fmu(str(fmu), stop_time=t_end, step_size=step, output_interval=step, input=signal,
                             output=outputs, start_values=start)


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    folder = tmp_path_factory.mktemp("box")
    path = folder / "bar.inp"
    box_mesh(path)
    return path


@pytest.fixture(scope="module")
def free_box_fmu(box):
    out = box.parent / "FreeBar.fmu"
    run = flexfmu("export", box, "-o", out, "--material", f"{E},{NU},{RHO}", "--modes", 6,
                  "--interface", f"left=0,0,0", "--interface", f"right={BOX[0]},0,0",
                  "--interface", f"middle={BOX[0] / 2},0,0")
    assert run.returncode == 0, run.stderr
    return out


def test_the_exported_fmu_is_self_contained_and_documented(free_box_fmu, box, tmp_path):
    names = zipfile.ZipFile(free_box_fmu).namelist()
    assert "resources/flexfmu_body.npz" in names and "documentation/index.html" in names
    md = fmpy.read_model_description(str(free_box_fmu))
    variables = {v.name: v for v in md.modelVariables}
    for name in ("left.F_x", "right.F_y", "middle.M_z", "left.pos_x", "right.acc_z", "com_vel_x", "f_1", "f_6"):
        assert name in variables, name
    assert variables["left.F_x"].unit == "N" and variables["right.pos_x"].unit == "m"
    assert variables["f_1"].unit == "Hz"
    doc = zipfile.ZipFile(free_box_fmu).read("documentation/index.html").decode()
    assert "bar.inp" in doc and "left" in doc
    # the source file gone, the FMU copied elsewhere: it still runs
    moved = tmp_path / "elsewhere" / "FreeBar.fmu"
    moved.parent.mkdir()
    moved.write_bytes(free_box_fmu.read_bytes())
    box.rename(box.with_suffix(".gone"))
    try:
        res = simulate(moved, 1e-3, 1e-4, {"left.F_x": 1.0}, ["com_vel_x"])
    finally:
        box.with_suffix(".gone").rename(box)
    assert np.isfinite(res["com_vel_x"]).all()


def test_free_body_force_at_an_interface_gives_com_velocity_F_t_over_m(free_box_fmu):
    mass = RHO * np.prod(BOX)
    force = np.array([3.0, -2.0, 5.0])
    t_end = 0.02
    res = simulate(free_box_fmu, t_end, 1e-4, {f"right.F_{a}": f for a, f in zip("xyz", force)},
                   ["com_vel_x", "com_vel_y", "com_vel_z"])
    v = np.array([res[f"com_vel_{a}"][-1] for a in "xyz"])
    expected = force * res["time"][-1] / mass
    print(f"\ncom_vel {v} m/s vs F t / m {expected} m/s")
    assert np.allclose(v, expected, rtol=1e-6, atol=1e-9 * np.linalg.norm(expected))


def test_free_body_couple_moves_no_com_and_gives_angular_momentum(free_box_fmu):
    """+F_y at the right end, -F_y at the left: a couple F L about z; the COM stays, J_z omega_z = F L t."""
    mass = RHO * np.prod(BOX)
    Jz = mass * (BOX[0] ** 2 + BOX[1] ** 2) / 12.0
    F, t_end = 2.0, 0.01
    res = simulate(free_box_fmu, t_end, 1e-4, {"right.F_y": F, "left.F_y": -F},
                   ["com_vel_x", "com_vel_y", "com_vel_z", "com_pos_y", "omega_3"])
    H, expected = Jz * res["omega_3"][-1], F * BOX[0] * res["time"][-1]
    # the resultant +F - F is 0 up to the interface weights' rounding, and the COM about which the body turns is
    # exact up to the rigid-field sums': <= 945 DOFs + ~80 roundings an entry, over-counted as 1024, on the terms
    # of each step's velocity change: the two forces 2 F dt / m and the turning speed at the body's size
    # |omega| |BOX| (taken at every step, generously), over the steps
    n_steps = round(t_end / 1e-4)
    scale = 2 * F * 1e-4 / mass + abs(res["omega_3"][-1]) * np.linalg.norm(BOX)
    assert max(abs(res[f"com_vel_{a}"][-1]) for a in "xyz") <= implementations_bound(scale, 1024, 1.0, n_steps)
    print(f"\nJ_z omega_z = {H:.6e} N m s vs F L t = {expected:.6e}")
    # the elastic deformation of the bar changes its inertia by a relative O(deflection / L) ~ 1e-6
    assert H == pytest.approx(expected, rel=1e-4)


def test_a_straight_rod_without_stub_exports_and_moves_rigidly(tmp_path):
    """A straight beam scene (colinear 6-DOF nodes): a force at one end gives com_vel = F t / m and the
    rotation of a slender rod about its centre, omega_z = F (L/2) t / (m L^2 / 12)."""
    import json

    L, d = 1.0, 0.02
    scene = {"name": "rod", "points": [[0, 0, 0], [L, 0, 0]], "section": {"shape": "circle", "diameter": d},
             "material": {"E": E, "nu": NU, "rho": RHO}}
    path = tmp_path / "rod.json"
    path.write_text(json.dumps(scene))
    out = tmp_path / "Rod.fmu"
    run = flexfmu("export", f"beam:{path}", "-o", out, "--modes", 4, "--interface", f"end={L},0,0")
    assert run.returncode == 0, run.stderr
    mass = RHO * np.pi * d ** 2 / 4 * L
    F, t_end = 0.5, 0.002
    res = simulate(out, t_end, 1e-5, {"end.F_y": F}, ["com_vel_y", "omega_3"])
    t = res["time"][-1]
    assert res["com_vel_y"][-1] == pytest.approx(F * t / mass, rel=1e-6)
    # J of the slender rod about its centre, plus the section's own (d^2 / 16 m) rotary part: relative 3e-5
    Jz = mass * L ** 2 / 12.0 + mass * d ** 2 / 16.0
    assert res["omega_3"][-1] == pytest.approx(F * (L / 2) * t / Jz, rel=1e-3)


@pytest.fixture(scope="module")
def clamped_box_fmu(box):
    out = box.parent / "Cantilever.fmu"
    run = flexfmu("export", box, "-o", out, "--material", f"{E},{NU},{RHO}", "--clamp", "root", "--modes", 8,
                  "--interface", f"tip={BOX[0]},0,0")
    assert run.returncode == 0, run.stderr
    return out


def test_clamped_body_base_acceleration_gives_the_static_deflection_and_reaction_m_a(clamped_box_fmu, box):
    """A constant base acceleration a0 (body frame, z), heavily damped: the tip settles at the static
    deflection of the full model under the inertial load -M a0 (sparse direct solve of the imported
    structure), and the reaction on the base is -(total mass) a0."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from flexfmu.importers import load_structure

    parameters = {v.name for v in fmpy.read_model_description(str(clamped_box_fmu)).modelVariables
                  if v.causality == "parameter"}
    assert parameters == {"damping_ratio", "internal_step", "max_internal_steps"}   # no free-body ones
    a0 = 9.81
    res = simulate(clamped_box_fmu, 1.0, 1e-3, {"base_a_z": a0}, ["tip.pos_z", "reaction_F_z"], damping_ratio=0.7)
    structure = load_structure(box, material={"E": E, "nu": NU, "rho": RHO})
    fixed = np.concatenate([3 * structure.node_sets["root"] + k for k in range(3)])
    free = np.setdiff1d(np.arange(structure.n_dof), fixed)
    load = -(structure.M @ np.tile([0.0, 0.0, a0], structure.n_nodes))
    u = np.zeros(structure.n_dof)
    K = sp.csr_matrix(structure.K)[free][:, free].tocsc()
    u[free] = spla.spsolve(K, load[free])
    tip = structure.node_sets["tip"]
    expected = u[3 * tip + 2].mean()
    got = res["tip.pos_z"][-1]
    print(f"\ntip static deflection {got:.6e} m vs full model {expected:.6e} m")
    assert got == pytest.approx(expected, rel=2e-3)
    mass = RHO * np.prod(BOX)
    assert res["reaction_F_z"][-1] == pytest.approx(-mass * a0, rel=1e-9)


@pytest.mark.parametrize("case", ["unknown element", "no material", "interface outside", "empty clamp",
                                  "unknown clamp", "singular free body", "ansys without coordinates",
                                  "ansys as a free body",
                                  "no size", "bad name"])
def test_bad_models_exit_2_with_one_line(case, tmp_path, box):
    material = ["--material", f"{E},{NU},{RHO}"]
    size = ["--modes", "4"]
    iface = ["--interface", "a=0,0,0"]
    out = tmp_path / "Bad.fmu"
    if case == "unknown element":
        path = tmp_path / "wedge.inp"
        meshio.write(str(path), meshio.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1],
                                                      [0, 1, 1.0]]), [("wedge", np.array([[0, 1, 2, 3, 4, 5]]))]))
        args, expect = [path, *material, *size, *iface], "wedge"
    elif case == "no material":
        args, expect = [box, *size, *iface], "material"
    elif case == "interface outside":
        args, expect = [box, *material, *size, "--interface", "far=5,5,5"], "far"
    elif case == "empty clamp":
        path = tmp_path / "bar.inp"
        points = box_mesh(path)
        mesh = meshio.read(str(path))
        mesh.point_sets["nothing"] = np.zeros(0, dtype=int)
        meshio.write(str(path), mesh)
        args, expect = [path, *material, *size, *iface, "--clamp", "nothing"], "clamp"
        del points
    elif case == "unknown clamp":
        args, expect = [box, *material, *size, *iface, "--clamp", "nowhere"], "nowhere"
    elif case == "singular free body":
        path = tmp_path / "two.inp"
        pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1.0]])
        cells = np.array([[0, 1, 2, 3, 4, 5, 6, 7], [8, 9, 10, 11, 12, 13, 14, 15]])
        meshio.write(str(path), meshio.Mesh(np.vstack([pts, pts + [3.0, 0, 0]]), [("hexahedron", cells)]))
        args, expect = [path, *material, *size, *iface], "free body"
    elif case == "ansys without coordinates":
        from ansys.mapdl.reader import examples
        import shutil
        full = tmp_path / "alone.full"
        shutil.copy(examples.fullfile, full)
        args, expect = [full, *size, *iface], ".cdb"
    elif case == "ansys as a free body":
        from ansys.mapdl.reader import examples
        from pathlib import Path
        cdb = Path(examples.fullfile).with_name("HexBeam.cdb")
        # MAPDL writes no mass or stiffness for the DOFs it constrains; the interface sits on such a node
        args, expect = [examples.fullfile, "--nodes", cdb, "--clamp", "free", *size, *iface], "constrained DOF"
    elif case == "no size":
        args, expect = [box, *material, *iface], "modes"
    else:
        args, expect = [box, *material, *size, *iface], "output"
        out = tmp_path / "1bad-name.fmu"
    run = flexfmu("export", *args, "-o", out)
    print(f"\n{case}: exit {run.returncode}: {run.stderr.strip()}")
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("flexfmu: error:") and expect in lines[0]
    assert "Traceback" not in run.stderr and not out.exists()


def test_the_exported_bracket_in_the_wave_converter_system(fmus, tmp_path):
    """docs/export.md's worked example: examples/bracket exported clamped at its bolts and mounted on the
    floating platform in place of the harvester.  The bracket (474 Hz) is quasi-static under the waves
    (0.7 Hz), so what it puts on the platform is Newton's for a rigid body on the moving mount:
    reaction = F_pto - m (a0 + alpha x c + omega x (omega x c)) (body frame)."""
    import shutil

    from flexfmu.cosim import masters as cosim

    root = __import__("pathlib").Path(__file__).resolve().parents[1]
    for name in ("WaveExcitation", "Platform", "Hydrostatics", "PTO"):
        shutil.copy(fmus[name], tmp_path / f"{name}.fmu")
    run = flexfmu("export", root / "examples/bracket/bracket.json", "-o", tmp_path / "Bracket.fmu",
                  "--clamp", "bolt_1,bolt_2", "--interface", "tip=arm_top", "--f-max", 2000)
    assert run.returncode == 0, run.stderr
    system = cosim.load_system(root / "examples/bracket/OspSystemStructure.xml", fmu_dir=tmp_path)
    result = cosim.run(system, 4.0, 1e-3)
    c = result.columns
    from flexfmu.importers import load_structure

    structure = load_structure(root / "examples/bracket/bracket.json")
    # the mesh's mass and centre of mass from M (the importers' tests check M)
    unit = [np.kron(np.ones(structure.n_nodes), np.eye(3)[k]) for k in range(3)]
    mass = float(unit[0] @ (structure.M @ unit[0]))
    com = np.array([unit[k] @ (structure.M @ (unit[k] * np.repeat(structure.nodes[:, k], 3))) for k in range(3)]) / mass
    # Newton for the rigid bracket on the moving mount (body frame): a_com = a0 + alpha x c + omega x (omega x c)
    a0 = np.column_stack([c[f"platform.mount_a_{a}"] for a in "xyz"])
    w = np.column_stack([c[f"platform.omega_{a}"] for a in "xyz"])
    dw = np.column_stack([c[f"platform.alpha_{a}"] for a in "xyz"])
    a_com = a0 + np.cross(dw, com) + np.cross(w, np.cross(w, com))
    f_pto = np.column_stack([c[f"pto.F_{a}"] for a in "xyz"])
    reaction = np.column_stack([c[f"bracket.reaction_F_{a}"] for a in "xyz"])
    residual = reaction - (f_pto - mass * a_com)
    amplitude = np.max(np.abs(reaction))
    print(f"\nreaction amplitude {amplitude:.4g} N, largest deviation from Newton's {np.max(np.abs(residual)):.3g} N")
    assert amplitude > 0.05
    # the master holds each input over a step: values one step apart differ by up to 2 pi h / T of the wave's
    # amplitude (h = 1 ms, T = 1.4 s: 4.5e-3), the bound of what the co-simulation can agree to
    assert np.max(np.abs(residual)) < 2 * np.pi * 1e-3 / 1.4 * amplitude
