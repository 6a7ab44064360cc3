"""The shape file of a native exported clamped body: ``flexfmu export ... --runtime native`` writes
``resources/shape.npz`` as the Python runtime does (flexfmu.fmi.body_fmu.shape_resource, one writer for both), so
``flexfmu animate RESULT.csv --fmu NATIVE.fmu`` draws the body from the native FMU's own q outputs.

The case is a small hexahedral bar (tests/hex_bar.py) clamped at its root with a tip interface, --f-max 2000 (11
modes and 16 static-correction vectors: q holds both kinds). Checked: the shape file's q names are the FMU's outputs;
the animation and the VTK series of a short fmpy run of the native FMU hold u = Psi q of the CSV's rows; and the mean
of u = Psi q over the tip's node set equals the change of the FMU's own output tip.pos (the interface point is the
set's centre, so its translation is the mean of its nodes') within the rounding bound of the two sums.
"""
from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from hex_bar import bar_model  # noqa: E402

fmpy = pytest.importorskip("fmpy")
meshio = pytest.importorskip("meshio")
pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

from flexfmu.body.shape_file import read_fmu_shape  # noqa: E402
from flexfmu.cli import main as flexfmu  # noqa: E402
from flexfmu.native.compiler import CompilerError, find_compiler  # noqa: E402
from flexfmu.viz.series import deformed_series  # noqa: E402

pytestmark = pytest.mark.fmu
EPS = np.finfo(float).eps
H, N_STEPS = 1e-4, 30             # s: 3 ms of a tip load rising over 1 ms, then held (the first mode's period: 5.8 ms)


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    """(the native FMU exported by the command line, the bar's model JSON)."""
    try:
        find_compiler()
    except CompilerError as exc:                                       # pragma: no cover - no C compiler
        pytest.skip(f"no C compiler: {exc}")
    folder = tmp_path_factory.mktemp("native_shape")
    model = bar_model(folder)
    fmu = folder / "BarNative.fmu"
    code = flexfmu(["export", str(model), "-o", str(fmu), "--clamp", "root", "--interface", "tip=tip",
                    "--f-max", "2000", "--runtime", "native"])
    assert code == 0
    return fmu, model


@pytest.fixture(scope="module")
def run(native):
    """A short fmpy run of the native FMU under a tip force (body frame) that bends and stretches the bar: every q
    and the tip's position."""
    fmu, _ = native
    md = fmpy.read_model_description(str(fmu))
    q_names = [v.name for v in md.modelVariables if v.causality == "output" and v.name.startswith("q_")]
    t = np.arange(N_STEPS + 1) * H
    ramp = np.minimum(t / 1e-3, 1.0)
    signal = np.zeros(len(t), dtype=[("time", float), ("tip.F_x", float), ("tip.F_y", float), ("tip.F_z", float)])
    signal["time"] = t
    signal["tip.F_x"], signal["tip.F_y"], signal["tip.F_z"] = 2000.0 * ramp, 300.0 * ramp, -500.0 * ramp
    result = fmpy.simulate_fmu(str(fmu), stop_time=t[-1], step_size=H, output_interval=H, input=signal,
                               output=[*q_names, "tip.pos_x", "tip.pos_y", "tip.pos_z"])
    return q_names, result


def test_the_native_fmu_carries_the_shape_file_of_its_outputs(native):
    from flexfmu.importers import load_structure

    fmu, model = native
    shape = read_fmu_shape(fmu)
    md = fmpy.read_model_description(str(fmu))
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert shape.names == tuple(f"q_{k}" for k in range(1, shape.n_coordinates + 1))
    assert set(shape.names) <= set(outputs) and shape.n_coordinates == 27
    structure = load_structure(model)
    assert np.array_equal(shape.nodes, structure.nodes) and list(shape.cells) == ["hexahedron"]
    assert shape.stress is not None and shape.stress.shape == (len(structure.nodes), 6, 27)
    assert shape.body == "bar"
    with zipfile.ZipFile(fmu) as archive:
        page = archive.read("documentation/index.html").decode()
    assert "resources/shape.npz" in page and "u = Psi q" in page


def test_animate_draws_the_native_run(native, run, tmp_path, capsys):
    """fmpy's CSV of the run, animated with the native FMU's shape file: one frame per row drawn, the VTK frames'
    displacement = Psi q of the CSV's rows."""
    from fmpy.util import write_csv

    fmu, _ = native
    q_names, result = run
    csv = tmp_path / "run.csv"
    write_csv(csv, result)
    gif, vtk = tmp_path / "bar.gif", tmp_path / "vtk"
    code = flexfmu(["animate", str(csv), "--fmu", str(fmu), "--out", str(gif), "--vtk", str(vtk), "--every", "10"])
    assert code == 0, capsys.readouterr().err
    with Image.open(gif) as picture:
        assert picture.n_frames == 4                                 # rows 0, 10, 20, 30
    datasets = ET.parse(vtk / "frame.pvd").getroot().find("Collection").findall("DataSet")
    assert np.allclose([float(d.get("timestep")) for d in datasets], result["time"][::10], rtol=0, atol=1e-15)
    q = np.column_stack([result[n] for n in q_names])[::10]
    expected = deformed_series(read_fmu_shape(fmu), q).displacement
    for k, dataset in enumerate(datasets):
        got = meshio.read(vtk / dataset.get("file")).point_data["displacement"]
        assert np.array_equal(got, expected[k]), k
    assert np.abs(expected[-1]).max() > 1e-6                         # m: the load bends the bar visibly


def test_psi_q_over_the_tip_is_the_fmus_tip_motion(native, run):
    """The mean of u = Psi q over the tip's node set against tip.pos - tip.pos(t = 0), at every row. Bound: both are
    sums of products (the FMU's row for tip.pos, extracted from the same shapes, and the patch mean here) rounded in a
    different order, so they differ by at most a few eps of the sum of the magnitudes of their terms, and tip.pos
    carries the rounding of the position itself (|pos| ~ 0.4 m); 64 eps of that sum is far above the rounding and
    far below the displacement."""
    from flexfmu.importers import load_structure

    fmu, model = native
    q_names, result = run
    shape = read_fmu_shape(fmu)
    tip = load_structure(model).node_sets["tip"]
    q = np.column_stack([result[n] for n in q_names])
    rows = shape.Psi[tip].mean(axis=0)                                # (3, n): the tip point's translation per q
    mean_u = q @ rows.T
    pos = np.column_stack([result[f"tip.pos_{a}"] for a in "xyz"])
    assert np.allclose(pos[0], shape.nodes[tip].mean(axis=0), rtol=0, atol=4 * EPS)
    bound = 64 * EPS * (np.abs(pos).max() + np.abs(q) @ np.abs(rows).T)
    error = np.abs((pos - pos[0]) - mean_u)
    assert np.all(error <= bound), (error.max(), bound.max())
    assert np.abs(mean_u).max() > 1e3 * bound.max()                  # the comparison has something to compare
