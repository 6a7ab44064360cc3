"""The deformed shape: the shape file an exported FMU carries (flexfmu.body.shape_file), the nodal displacement and von
Mises stress of its shape coordinates (flexfmu.viz.series), the VTK series (flexfmu.viz.vtk), the animation
(flexfmu.viz.animate) and the commands `flexfmu animate` and `flexfmu modal --animate`.

References are hand-made: two tetrahedra with integer shapes, so u = Psi q is exact in floating point, and stress
shapes of a uniaxial and a pure-shear state, whose von Mises values are |sigma| and sqrt(3) |tau|."""
from __future__ import annotations

import io
import json
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from flexfmu.body.shape_file import (SHAPE_FORMAT, ShapeFile, read_fmu_shape, read_shape_file,
                                     write_shape_file)
from flexfmu.cli import main as flexfmu
from flexfmu.errors import ModelFileError, ParameterError
from flexfmu.viz.animate import animate
from flexfmu.viz.series import deformed_series
from flexfmu.viz.vtk import write_vtk_series

meshio = pytest.importorskip("meshio")
pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

pytestmark = pytest.mark.unit
EPS = np.finfo(float).eps

# two tetrahedra sharing the face (1, 2, 3); m, body frame
NODES = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]])
CELLS = {"tetra": np.array([[0, 1, 2, 3], [1, 2, 3, 4]])}
NAMES = ("q_1", "q_2", "q_3")


def _shapes():
    """Psi (5, 3, 3) of small integers; S (5, 6, 3): column 0 uniaxial sigma_xx = 2 Pa, column 1 pure shear
    sigma_xy = 1 Pa, column 2 zero, at every node."""
    Psi = (np.arange(5 * 3 * 3).reshape(5, 3, 3) % 7 - 3).astype(float)
    S = np.zeros((5, 6, 3))
    S[:, 0, 0] = 2.0
    S[:, 3, 1] = 1.0
    return Psi, S


@pytest.fixture
def shape_path(tmp_path):
    Psi, S = _shapes()
    return write_shape_file(tmp_path / "shape.npz", NODES, CELLS, Psi, S, NAMES, {"body": "twotets"})


# ---------------------------------------------------------------------------------------------- the shape file
def test_shape_file_round_trip(shape_path, tmp_path):
    Psi, S = _shapes()
    shape = read_shape_file(shape_path)
    assert np.array_equal(shape.nodes, NODES) and np.array_equal(shape.Psi, Psi) and np.array_equal(shape.stress, S)
    assert list(shape.cells) == ["tetra"] and np.array_equal(shape.cells["tetra"], CELLS["tetra"])
    assert shape.cells["tetra"].dtype == np.int64
    assert shape.names == NAMES and shape.n_coordinates == 3 and shape.body == "twotets"
    assert shape.header == {"frame": "body", "body": "twotets", "format": SHAPE_FORMAT, "version": 1}
    # without stress shapes: none read back
    bare = read_shape_file(write_shape_file(tmp_path / "bare.npz", NODES, CELLS, Psi, None, NAMES))
    assert bare.stress is None and np.array_equal(bare.Psi, Psi)


def _rewrite(path, target, **changes):
    """A copy of the npz ``path`` with arrays replaced (None: removed)."""
    with np.load(path, allow_pickle=False) as archive:
        arrays = {k: archive[k] for k in archive.files}
    for key, value in changes.items():
        key = key.replace("__", "/")
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = value
    np.savez_compressed(target, **arrays)
    return target


def _header(path, **fields):
    with np.load(path, allow_pickle=False) as archive:
        header = json.loads(str(archive["header"][()]))
    header.update(fields)
    return np.array(json.dumps(header))


@pytest.mark.parametrize("case, words", [
    ("newer version", ["version 2", "newer", "update flexfmu", "allowed: version 1"]),
    ("older version", ["version 0", "re-export"]),
    ("boolean version", ["version True"]),
    ("other format", ["format 'something-else'", SHAPE_FORMAT]),
    ("no header", ["no header", "Psi"]),
    ("missing Psi", ["lacks Psi"]),
    ("inconsistent", ["inconsistent arrays", "Psi"]),
    ("cell index out of range", ["cells/tetra", "0 ... 4"]),
    ("object array", ["not a readable shape file"]),
    ("truncated", ["not a readable shape file"]),
    ("flipped byte", ["not a readable shape file"]),
    ("text", ["not a readable shape file"]),
])
def test_shape_file_refusals(shape_path, tmp_path, case, words):
    bad = tmp_path / "bad.npz"
    raw = shape_path.read_bytes()
    if case == "newer version":
        _rewrite(shape_path, bad, header=_header(shape_path, version=2))
    elif case == "older version":
        _rewrite(shape_path, bad, header=_header(shape_path, version=0))
    elif case == "boolean version":
        _rewrite(shape_path, bad, header=_header(shape_path, version=True))
    elif case == "other format":
        _rewrite(shape_path, bad, header=_header(shape_path, format="something-else"))
    elif case == "no header":
        _rewrite(shape_path, bad, header=None)
    elif case == "missing Psi":
        _rewrite(shape_path, bad, Psi=None)
    elif case == "inconsistent":
        _rewrite(shape_path, bad, Psi=np.zeros((4, 3, 3)))
    elif case == "cell index out of range":
        _rewrite(shape_path, bad, cells__tetra=np.array([[0, 1, 2, 5]]))
    elif case == "object array":
        with zipfile.ZipFile(shape_path) as z, zipfile.ZipFile(bad, "w") as out:
            for name in z.namelist():
                out.writestr(name, z.read(name))
            buffer = io.BytesIO()
            np.save(buffer, np.array([{"a": 1}], dtype=object), allow_pickle=True)
            out.writestr("extra.npy", buffer.getvalue())
    elif case == "truncated":
        bad.write_bytes(raw[: len(raw) // 2])
    elif case == "flipped byte":
        flipped = bytearray(raw)
        flipped[len(raw) // 3] ^= 0xFF
        bad.write_bytes(bytes(flipped))
    else:
        bad.write_text("time,q_1\n0,1\n")
    with pytest.raises(ModelFileError) as info:
        read_shape_file(bad)
    text = str(info.value)
    assert str(bad) in text
    for word in words:
        assert word in text, (word, text)


def test_shape_file_writer_refuses_bad_arrays(tmp_path):
    Psi, S = _shapes()
    out = tmp_path / "x.npz"
    with pytest.raises(ParameterError, match="Psi"):
        write_shape_file(out, NODES, CELLS, Psi[:4], S, NAMES)
    with pytest.raises(ParameterError, match="stress"):
        write_shape_file(out, NODES, CELLS, Psi, S[:, :5], NAMES)
    with pytest.raises(ParameterError, match="names"):
        write_shape_file(out, NODES, CELLS, Psi, S, ("q_1", "q_1", "q_3"))
    with pytest.raises(ParameterError, match="cells/tetra"):
        write_shape_file(out, NODES, {"tetra": [[0, 1, 2, 7]]}, Psi, S, NAMES)
    with pytest.raises(ParameterError, match="finite"):
        write_shape_file(out, NODES, CELLS, np.where(Psi == 0, np.nan, Psi), S, NAMES)
    assert not out.exists()


# ---------------------------------------------------------------------------------------------- the series
def test_deformed_series_is_psi_q_and_von_mises_of_s_q(shape_path):
    shape = read_shape_file(shape_path)
    q = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [3.0, -1.0, 2.0], [0.0, 0.0, -4.0]])
    t = np.array([0.0, 0.5, 1.0, 1.5])
    series = deformed_series(shape, q, t)
    assert series.n_frames == 4 and np.array_equal(series.t, t) and series.name == "twotets"
    expected = np.zeros((4, 5, 3))
    for frame in range(4):                 # integers times integers: every sum is exact
        for k in range(3):
            expected[frame] += shape.Psi[:, :, k] * q[frame, k]
    assert np.array_equal(series.displacement, expected)
    # uniaxial 2 q_1 and shear q_2: von Mises = sqrt((2 q_1)^2 + 3 q_2^2) at every node
    reference = np.sqrt((2.0 * q[:, 0]) ** 2 + 3.0 * q[:, 1] ** 2)
    assert np.allclose(series.von_mises, reference[:, None], rtol=8 * EPS, atol=0.0)
    assert series.von_mises[0, 0] == 2.0 and series.von_mises[3, 0] == 0.0


def test_deformed_series_refuses_wrong_q(shape_path):
    shape = read_shape_file(shape_path)
    with pytest.raises(ParameterError, match=r"q: shape \(2, 2\).*3 columns|q: shape \(2, 2\)"):
        deformed_series(shape, np.zeros((2, 2)))
    with pytest.raises(ParameterError, match="NaN"):
        deformed_series(shape, np.array([[0.0, np.nan, 0.0]]))
    with pytest.raises(ParameterError, match="t"):
        deformed_series(shape, np.zeros((2, 3)), [0.0])


# ---------------------------------------------------------------------------------------------- VTK and GIF
def test_vtk_series_holds_every_frame(shape_path, tmp_path):
    shape = read_shape_file(shape_path)
    q = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0], [2.0, 1.0, -1.0]])
    t = np.array([0.0, 0.1, 0.25])
    series = deformed_series(shape, q, t)
    folder = tmp_path / "vtk"
    (folder).mkdir()
    (folder / "frame_0099.vtu").write_text("stale")            # an earlier, longer series' file
    pvd = write_vtk_series(series, folder)
    assert pvd == folder / "frame.pvd"
    datasets = ET.parse(pvd).getroot().find("Collection").findall("DataSet")
    assert [d.get("file") for d in datasets] == ["frame_0000.vtu", "frame_0001.vtu", "frame_0002.vtu"]
    assert [float(d.get("timestep")) for d in datasets] == list(t)
    assert sorted(p.name for p in folder.glob("*.vtu")) == [d.get("file") for d in datasets]
    for k, dataset in enumerate(datasets):
        mesh = meshio.read(folder / dataset.get("file"))
        assert np.array_equal(mesh.points, NODES)
        assert [c.type for c in mesh.cells] == ["tetra"] and np.array_equal(mesh.cells[0].data, CELLS["tetra"])
        assert set(mesh.point_data) == {"displacement", "von_mises"}
        assert np.array_equal(mesh.point_data["displacement"], series.displacement[k])
        assert np.array_equal(mesh.point_data["von_mises"], series.von_mises[k])


def test_gif_is_written_with_every_frame(shape_path, tmp_path):
    shape = read_shape_file(shape_path)
    q = np.array([[0.0, 0.0, 0.0], [0.5, 0.2, 0.0], [1.0, 0.4, 0.1], [0.5, 0.2, 0.3]])
    series = deformed_series(shape, q, [0.0, 0.1, 0.2, 0.3])
    still = tmp_path / "still.png"
    done = animate(series, tmp_path / "a.gif", fps=5, still=(2, still), dpi=40)
    assert done.path.stat().st_size > 0 and done.frames == 4
    with Image.open(done.path) as gif:
        assert gif.n_frames == 4
    with Image.open(still) as picture:
        assert picture.size[0] > 100
    # the largest displacement drawn at 10 % of the body's size (its bounding box's longest side, 1 m)
    largest = np.max(np.linalg.norm(series.displacement, axis=2))
    assert done.largest_displacement[0] == largest and done.body_size[0] == 1.0
    assert done.scales[0] * largest == pytest.approx(0.1, rel=4 * EPS)
    fixed = animate(series, tmp_path / "b.gif", scale=3.0, dpi=40)
    assert fixed.scales == (3.0,)


@pytest.mark.parametrize("cells", [{"line": [[0, 1], [1, 2], [2, 4]]}, {}], ids=["beam lines", "no cells"])
def test_gif_of_lines_and_of_bare_nodes(tmp_path, cells):
    Psi, _ = _shapes()
    shape = ShapeFile(NODES, {k: np.asarray(v) for k, v in cells.items()}, Psi, None, NAMES, {"body": "b"})
    series = deformed_series(shape, np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.0]]))
    assert series.von_mises is None and series.colour()[1] == "|u|"
    done = animate([series, series], tmp_path / "lines.gif", dpi=30)
    with Image.open(done.path) as gif:
        assert gif.n_frames == 2


def test_animation_refuses_unknown_formats_and_mp4_without_ffmpeg(shape_path, tmp_path):
    from matplotlib import animation

    series = deformed_series(read_shape_file(shape_path), np.zeros((2, 3)))
    with pytest.raises(ParameterError, match=r"out: a\.avi.*\.gif"):
        animate(series, tmp_path / "a.avi")
    with pytest.raises(ParameterError, match="scale"):
        animate(series, tmp_path / "a.gif", scale=-1.0)
    if not animation.FFMpegWriter.isAvailable():
        with pytest.raises(ParameterError, match="MP4 needs ffmpeg"):
            animate(series, tmp_path / "a.mp4")


# ---------------------------------------------------------------------------------------------- the commands
def _fmu(path, shape_path=None):
    """An FMU-like zip: a modelDescription.xml and, given one, resources/shape.npz."""
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
        if shape_path is not None:
            z.write(shape_path, "resources/shape.npz")
    return path


def _csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(x)) for x in r) for r in rows) + "\n")
    return path


def test_animate_command_end_to_end(shape_path, tmp_path, capsys):
    fmu = _fmu(tmp_path / "Body.fmu", shape_path)
    rows = [[0.01 * k, 1.0 + k, 0.1 * k, -0.5 * k, 0.1 * k, 0.2 * k, 7.0] for k in range(6)]
    result = _csv(tmp_path / "run.csv",
                  ["time", "body.q_1", "body.q_2", "body.q_3", "other.x", "body.tip.pos_x", "other.q_9"], rows)
    out, vtk = tmp_path / "anim.gif", tmp_path / "vtk"
    code = flexfmu(["animate", str(result), "--fmu", str(fmu), "--out", str(out), "--vtk", str(vtk),
                    "--every", "2", "--fps", "4"])
    assert code == 0, capsys.readouterr().err
    assert "3 frames (every 2 rows)" in capsys.readouterr().out
    with Image.open(out) as gif:
        assert gif.n_frames == 3
    datasets = ET.parse(vtk / "frame.pvd").getroot().find("Collection").findall("DataSet")
    assert [float(d.get("timestep")) for d in datasets] == [0.0, 0.02, 0.04]
    shape = read_fmu_shape(fmu)
    q = np.array([r[1:4] for r in rows[::2]])
    last = meshio.read(vtk / datasets[-1].get("file"))
    assert np.array_equal(last.point_data["displacement"], deformed_series(shape, q).displacement[-1])


def test_animate_command_reads_bare_columns_and_chooses_instances(shape_path, tmp_path, capsys):
    fmu = _fmu(tmp_path / "Body.fmu", shape_path)
    bare = _csv(tmp_path / "bare.csv", ["time", "q_1", "q_2", "q_3"], [[0, 1, 2, 3], [1, 0, 1, 0]])
    assert flexfmu(["animate", str(bare), "--fmu", str(fmu), "--out", str(tmp_path / "a.gif")]) == 0
    two = _csv(tmp_path / "two.csv", ["time", "a.q_1", "a.q_2", "a.q_3", "b.q_1", "b.q_2", "b.q_3"],
               [[0, 1, 2, 3, 4, 5, 6], [1, 0, 1, 0, 1, 0, 1]])
    assert flexfmu(["animate", str(two), "--fmu", str(fmu), "--out", str(tmp_path / "b.gif")]) == 2
    err = capsys.readouterr().err
    assert "2 instances" in err and "a, b" in err and "--instance" in err
    assert flexfmu(["animate", str(two), "--fmu", str(fmu), "--instance", "b", "--out", str(tmp_path / "b.gif")]) == 0
    assert flexfmu(["animate", str(two), "--fmu", str(fmu), "--instance", "c", "--out", str(tmp_path / "c.gif")]) == 2
    assert "no column c.q_1" in capsys.readouterr().err


def test_animate_command_bad_inputs(shape_path, tmp_path, capsys):
    fmu = _fmu(tmp_path / "Body.fmu", shape_path)
    plain = _fmu(tmp_path / "FFRBeam.fmu")
    no_q = _csv(tmp_path / "no_q.csv", ["time", "bracket.tip.pos_x", "wave.eta"], [[0, 1, 2]])
    some_q = _csv(tmp_path / "some_q.csv", ["time", "bracket.q_1", "bracket.q_2"], [[0, 1, 2]])
    good = _csv(tmp_path / "good.csv", ["time", "q_1", "q_2", "q_3"], [[0, 1, 2, 3]])
    gif = str(tmp_path / "x.gif")

    def error(*argv):
        assert flexfmu(["animate", *map(str, argv)]) == 2
        return capsys.readouterr().err

    text = error(no_q, "--fmu", fmu, "--out", gif)            # what the CSV has
    assert "no shape coordinates q_1 ... q_3" in text and "bracket, wave" in text and "bracket.tip.pos_x" in text
    text = error(some_q, "--fmu", fmu, "--out", gif)
    assert "lacks bracket.q_3" in text and "bracket.q_1, bracket.q_2" in text
    text = error(good, "--fmu", plain, "--out", gif)          # which FMUs carry a shape file, how to get one
    assert "carries no resources/shape.npz" in text and "flexfmu export" in text and "built-in FMUs" in text
    text = error(good, "--fmu", tmp_path / "absent.fmu", "--out", gif)
    assert "no such file" in text
    (tmp_path / "junk.fmu").write_bytes(b"not a zip")
    assert "not a readable FMU" in error(good, "--fmu", tmp_path / "junk.fmu", "--out", gif)
    assert "no such file" in error(tmp_path / "absent.csv", "--fmu", fmu, "--out", gif)
    assert "every" in error(good, "--fmu", fmu, "--every", "0", "--out", gif)
    assert "scale" in error(good, "--fmu", fmu, "--scale", "nan", "--out", gif)
    assert "unknown animation format" in error(good, "--fmu", fmu, "--out", tmp_path / "x.txt")
    no_time = _csv(tmp_path / "no_time.csv", ["q_1", "q_2", "q_3"], [[1, 2, 3]])
    assert "no time column" in error(no_time, "--fmu", fmu, "--out", gif)
    (tmp_path / "head.csv").write_text("time,q_1,q_2,q_3\n")
    assert "no rows" in error(tmp_path / "head.csv", "--fmu", fmu, "--out", gif)
    (tmp_path / "words.csv").write_text("time,q_1,q_2,q_3\n0,1,2,3\n0.1,1,oops,3\n")
    assert "not numbers" in error(tmp_path / "words.csv", "--fmu", fmu, "--out", gif)
    (tmp_path / "nan.csv").write_text("time,q_1,q_2,q_3\n0,1,2,3\n0.1,1,nan,3\n")
    assert "NaN or infinite shape coordinates at t = 0.1" in error(tmp_path / "nan.csv", "--fmu", fmu, "--out", gif)


def _hex_bar(path):
    """A free steel bar 0.2 x 0.02 x 0.02 m of four linear hexahedra, as .vtu with its model JSON."""
    nx = 5
    X, Y, Z = np.meshgrid(np.linspace(0, 0.2, nx), [0.0, 0.02], [0.0, 0.02], indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = np.arange(points.shape[0]).reshape(nx, 2, 2)
    cells = [[idx[i, 0, 0], idx[i + 1, 0, 0], idx[i + 1, 1, 0], idx[i, 1, 0],
              idx[i, 0, 1], idx[i + 1, 0, 1], idx[i + 1, 1, 1], idx[i, 1, 1]] for i in range(nx - 1)]
    meshio.write(path, meshio.Mesh(points, [("hexahedron", np.array(cells))]))
    path.with_suffix(".json").write_text(json.dumps({"mesh": path.name,
                                                     "material": {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}}))
    return path.with_suffix(".json")


def test_modal_animate_writes_the_modes(tmp_path, capsys):
    model = _hex_bar(tmp_path / "bar.vtu")
    gif, vtk = tmp_path / "modes.gif", tmp_path / "modes"
    assert flexfmu(["modal", str(model), "--modes", "2", "--animate", str(gif), "--vtk", str(vtk)]) == 0
    out = capsys.readouterr().out
    assert f"wrote {gif}" in out and "24 frames per period" in out
    with Image.open(gif) as picture:
        assert picture.n_frames == 24
    datasets = ET.parse(vtk / "mode.pvd").getroot().find("Collection").findall("DataSet")
    assert [float(d.get("timestep")) for d in datasets] == [1.0, 2.0]
    first = meshio.read(vtk / datasets[0].get("file"))
    assert [c.type for c in first.cells] == ["hexahedron"]
    assert {"displacement", "von_mises"} <= set(first.point_data)
    # the first mode of a free bar bends it: the bending moment is largest mid-span and zero at the free ends, so
    # the nodal von Mises of the mode shape is larger at mid-span (x = 0.1 m) than at either end
    x, vm = first.points[:, 0], first.point_data["von_mises"]
    assert vm[np.isclose(x, 0.1)].max() > max(vm[x == 0.0].max(), vm[x == 0.2].max()) > 0.0
    assert np.max(np.abs(first.point_data["displacement"])) > 0
    assert flexfmu(["modal", str(model), "--modes", "2", "--animate", str(tmp_path / "m.avi")]) == 2
    assert "unknown animation format" in capsys.readouterr().err
