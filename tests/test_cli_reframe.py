"""`flexfmu reframe`: CSV columns, values against the library and physics, progress, bad input.

A small model keeps it fast: the free-free bent rod spatial_double_L (25 nodes, 6 DOF/node).
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from error_bounds import U, gamma

from flexfmu.cli import reframe as cli          # PROGRESS_AFTER_S lives with the reframe command
from flexfmu.cli import main
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.models import load_model
from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator

MODEL = "beam:spatial_double_L"
# The ReframeBody FMU's output names, written out here rather than imported.
EXPECTED_COLUMNS = (
    "time pos_x pos_y pos_z vel_x vel_y vel_z q_w q_x q_y q_z omega_1 omega_2 omega_3 alpha_1 alpha_2 alpha_3 "
    "com_pos_x com_pos_y com_pos_z com_vel_x com_vel_y com_vel_z out_pos_x out_pos_y out_pos_z "
    "out_vel_x out_vel_y out_vel_z out_acc_x out_acc_y out_acc_z out_acc_rigid_x out_acc_rigid_y out_acc_rigid_z "
    "max_elastic_displacement"
).split()
FORCE = np.array([1.0, -0.5, 2.0])
OMEGA0 = np.array([5.0, 2.0, 8.0])
ARGS = ["reframe", MODEL, "--modes", "2", "--t-end", "0.05", "--dt", "1e-4", "--every", "5",
        "--force", "1,-0.5,2", "--omega0", "5,2,8"]


def read_csv(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


@pytest.fixture(scope="module")
def beam():
    return load_model(MODEL)


@pytest.fixture(scope="module")
def csv_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "result.csv"
    assert main(ARGS + ["--out", str(out)]) == 0
    return read_csv(out)


def test_csv_columns(csv_run):
    header, data = csv_run
    assert header == EXPECTED_COLUMNS
    assert data.shape == (0.05 / 1e-4 / 5 + 1, len(EXPECTED_COLUMNS))
    # two roundings of t_k = k dt: the integrator's t += dt (n additions: gamma_n t, and fl(dt): u t) and
    # linspace's k * fl(0.05 / 100) (<= 3 u t)
    t = np.linspace(0.0, 0.05, 101)
    assert np.all(np.abs(data[:, 0] - t) <= (gamma(500) + 4 * U) * t)
    assert np.all(np.isfinite(data))


def test_csv_equals_library(csv_run, beam):
    """The CLI is a shell: its table equals one library run with the same inputs (chunking for the
    progress lines changes nothing)."""
    header, data = csv_run
    col = {name: k for k, name in enumerate(header)}
    integ = ReframeIntegrator(beam, modal_basis(beam, 2), scheme="consistent")
    integ.set_initial(omega0=OMEGA0)
    out_node, load_node = 0, beam.n_nodes - 1
    r = integ.run(0.05, 1e-4, PointLoad(load_node, FORCE), points=[out_node], every=5)

    def cols(prefix, names="xyz"):
        return data[:, [col[f"{prefix}{c}"] for c in names]]

    # identity: the CLI runs this library code in this process (the same modal basis, integrator and inputs; its
    # chunks continue the same state), and "%.17g" round-trips every double exactly
    pairs = [(cols("omega_", "123"), r.omega), (cols("alpha_", "123"), r.alpha), (cols("q_", "wxyz"), r.quaternion),
             (cols("pos_"), r.frame_origin), (cols("com_pos_"), r.com_position), (cols("com_vel_"), r.com_velocity),
             (cols("out_pos_"), r.point_position[:, 0]), (cols("out_vel_"), r.point_velocity[:, 0]),
             (cols("out_acc_"), r.point_acceleration[:, 0]),
             (cols("out_acc_rigid_"), r.point_acceleration_rigid[:, 0]),
             (data[:, col["max_elastic_displacement"]], r.max_elastic_displacement)]
    for got, expected in pairs:
        np.testing.assert_array_equal(got, expected)


def test_csv_physics(csv_run, beam):
    """Checks that do not use the integrator: initial values, unit quaternions, m dv_com/dt = F, and the
    frame-origin velocity against a difference quotient of pos."""
    header, data = csv_run
    col = {name: k for k, name in enumerate(header)}
    t = data[:, 0]
    get = lambda p, names="xyz": data[:, [col[f"{p}{c}"] for c in names]]   # noqa: E731
    # omega at t = 0 is not the given omega0 itself: the state holds the rigid rates A6^-1 [v0; omega0] (A6 the
    # basis' rigid transform, inverted in double) and the output maps them back with A6.  The product's rounding
    # is <= gamma_6 |A6| |A6^-1| |x|; the computed inverse's error <= gamma_{6n} kappa(A6) |A6^-1| (n = 6, LU with
    # partial pivoting, generous): together within gamma_64 kappa(A6) |A6| |A6^-1| |x|
    A6 = modal_basis(beam, 2).rigid_transform
    A6inv = np.linalg.inv(A6)
    x = np.concatenate([np.zeros(3), OMEGA0])
    bound = gamma(64) * np.linalg.cond(A6) * (np.abs(A6) @ (np.abs(A6inv) @ np.abs(x)))[3:]
    assert np.all(np.abs(get("omega_", "123")[0] - OMEGA0) <= bound)
    # identities at t = 0: the identity rotation's quaternion, node 0 itself (rotation I, no elastic
    # displacement) and the frame origin at the mesh origin
    np.testing.assert_array_equal(get("q_", "wxyz")[0], [1, 0, 0, 0])
    # |q| = 1 to the rounding of n = 500 rotation updates (a product of 3x3 matrices and the update's own
    # orthogonality, <= gamma_16 each) and of the quaternion extraction (<= gamma_16): (n + 1) gamma_16
    n_steps = round(0.05 / 1e-4)
    assert np.all(np.abs(np.linalg.norm(get("q_", "wxyz"), axis=1) - 1.0) <= (n_steps + 1) * gamma(16))
    np.testing.assert_array_equal(get("out_pos_")[0], beam.nodes[0])      # default output point: node 0
    np.testing.assert_array_equal(get("pos_")[0], 0.0)                    # frame origin = mesh origin
    mass = float(beam.M[0::6, :][:, 0::6].sum())                  # total mass: unit x-translation field
    # m dv_com/dt = F to 1e-10 relative; the velocity at t = 0 is the A6 round trip of the initial rates (as omega's
    # above, its rows :3), carried along with the momentum and rotated (R orthogonal: within its 2-norm)
    v0_bound = float(np.linalg.norm(gamma(64) * np.linalg.cond(A6) * (np.abs(A6) @ (np.abs(A6inv) @ np.abs(x)))[:3]))
    np.testing.assert_allclose(get("com_vel_"), np.outer(t, FORCE) / mass, rtol=1e-10, atol=v0_bound)
    # frame origin velocity: central difference of pos (records every 5e-4 s) agrees to O(h^2)
    pos, vel = get("pos_"), get("vel_")
    h = t[1] - t[0]
    fd = (pos[2:] - pos[:-2]) / (2 * h)
    assert np.max(np.abs(fd - vel[1:-1])) <= 2e-3 * np.max(np.abs(vel))
    assert data[0, col["max_elastic_displacement"]] == 0.0
    assert np.max(data[:, col["max_elastic_displacement"]]) > 0.0


def test_summary_and_rigid(capsys):
    assert main(["reframe", MODEL, "--modes", "0", "--t-end", "0.02", "--dt", "1e-3", "--omega0", "0,0,3"]) == 0
    out = capsys.readouterr().out
    assert "final omega (body)" in out and "final COM velocity" in out and "max elastic displacement" in out
    line = next(s for s in out.splitlines() if s.startswith("final omega"))
    w = [float(x) for x in line.split("[")[1].split("]")[0].split(",")]
    assert np.linalg.norm(w) == pytest.approx(3.0, rel=0.2)                   # free rigid tumbling, |omega| ~ 3
    assert "max elastic displacement    0 m" in out


def test_paper_scheme_and_progress(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli, "PROGRESS_AFTER_S", 0.0)
    out = tmp_path / "paper.csv"
    assert main(["reframe", MODEL, "--scheme", "paper", "--modes", "1", "--t-end", "0.01", "--dt", "1e-4",
                 "--force=-1,0,0", "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("flexfmu reframe: spatial_double_L: 150 DOFs, 1 flexible modes")   # set-up line
    progress = err[1:]
    assert 5 <= len(progress) <= 11 and all("%" in line for line in progress)
    assert progress[-1].split("%")[0].strip().endswith("100")
    header, data = read_csv(out)
    assert header == EXPECTED_COLUMNS and data.shape == (101, len(EXPECTED_COLUMNS))


def test_subprocess(tmp_path):
    out = tmp_path / "r.csv"
    proc = subprocess.run([sys.executable, "-m", "flexfmu", "reframe", MODEL, "--modes", "1", "--t-end", "0.002",
                           "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert read_csv(out)[1].shape == (21, len(EXPECTED_COLUMNS))


@pytest.mark.parametrize("argv, parameter", [
    (["nope"], "model"),
    (["beam:no_such_scene"], "model"),
    (["missing.npz"], "model"),
    ([MODEL, "--force", "1,2"], "force"),
    ([MODEL, "--force", "nan,0,0"], "force"),
    ([MODEL, "--omega0", "a,b,c"], "omega0"),
    ([MODEL, "--dt", "0"], "dt"),
    ([MODEL, "--dt=-1e-4"], "dt"),
    ([MODEL, "--t-end", "0"], "t-end"),
    ([MODEL, "--t-end", "inf"], "t-end"),
    ([MODEL, "--modes", "-1"], "modes"),
    ([MODEL, "--modes", "100000"], "modes"),
    ([MODEL, "--every", "0"], "every"),
    ([MODEL, "--modes", "10", "--dt", "1e-3"], "dt"),               # beyond RK4's stability limit
])
def test_bad_input_exit_2(argv, parameter, capsys):
    assert main(["reframe"] + argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"flexfmu: error: {parameter}:")


def test_bad_choice_exit_2(capsys):
    with pytest.raises(SystemExit) as exc:                          # argparse's own check
        main(["reframe", MODEL, "--scheme", "implicit"])
    assert exc.value.code == 2
    assert "invalid choice" in capsys.readouterr().err
