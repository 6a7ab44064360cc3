"""The power matrix (flexfmu.wec.system.power_matrix, `flexfmu wec power-matrix`) on a tiny grid: the
Dask LocalCluster gives the serial numbers, cells steeper than the limit stay empty, the CSV is in the
IEC TS 62600-100 layout (rows Hs, columns Tp, W) and the heat map is drawn."""
import csv
import importlib.util
import time

import numpy as np
import pytest

from fmu_helpers import ROOT

from flexfmu import cli
from flexfmu.errors import ParameterError
from flexfmu.wec.system import power_matrix

SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
#: (0.3 m, 1.4 s) is too steep: not run.  The example's BEM database holds JONSWAP seas of Tp >= 1.26 s.
HS, TP, SEEDS, T_END = (0.05, 0.3), (1.4, 2.0), (1, 2), 0.2


def test_power_matrix_on_dask_equals_serial_and_leaves_steep_cells_empty(tmp_path, capsys):
    assert importlib.util.find_spec("distributed"), "dask.distributed missing: install the project with its dev extra"
    start = time.perf_counter()
    serial = power_matrix(SYSTEM, HS, TP, SEEDS, T_END, scheduler=None)
    wall_serial = time.perf_counter() - start
    start = time.perf_counter()
    dask = power_matrix(SYSTEM, HS, TP, SEEDS, T_END, scheduler="local", n_workers=2)
    with capsys.disabled():
        print(f"\npower matrix 2x2, {len(SEEDS)} seeds, {T_END} s runs: serial {wall_serial:.1f} s, "
              f"LocalCluster {time.perf_counter() - start:.1f} s")
    assert np.isnan(serial.power[1, 0]) and np.isnan(dask.power[1, 0])
    computed = np.isfinite(serial.power)
    assert computed.sum() == 3 and len(serial.rows) == 3 * len(SEEDS)
    assert np.all(serial.power[computed] > 0)
    assert np.allclose(dask.power[computed], serial.power[computed], rtol=1e-9, atol=0)
    # each cell is the mean of its seeds' runs, and the seeds differ (irregular seas)
    runs = [r["mean_power_W"] for r in serial.rows if r["wave_height"] == 0.05 and r["wave_period"] == TP[0]]
    # identity: the cell is np.mean of the same runs in the same (seed) order
    assert serial.power[0, 0] == float(np.mean(runs)) and runs[0] != runs[1]
    assert all(r["sea_state"] == "jonswap" for r in serial.rows)

    path = serial.write_csv(tmp_path / "pm.csv")
    with path.open() as f:
        rows = list(csv.reader(f))
    assert [float(x) for x in rows[0][1:]] == list(TP)
    assert [float(r[0]) for r in rows[1:]] == list(HS)
    assert rows[2][1] == "" and float(rows[1][1]) == serial.power[0, 0]
    png = serial.plot(tmp_path / "pm.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_power_matrix_serial_and_bad_input(tmp_path, capsys, monkeypatch):
    from flexfmu.core import progress
    monkeypatch.setattr(progress, "DEFAULT_DELAY_S", 0.0)      # a short sweep shows its progress too
    out, png = tmp_path / "m.csv", tmp_path / "m.png"
    status = cli.main(["wec", "power-matrix", str(SYSTEM), "--hs", "0.05", "--tp", "1.4,2.0", "--seeds", "1",
                       "--t-end", "0.1", "--serial", "--out", str(out), "--plot", str(png)])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "2 of 2 co-simulations" in captured.err and out.is_file() and png.is_file()
    assert (tmp_path / "m_runs.csv").is_file()
    for argv, name in [(["--hs", "0.05,x"], "hs"), (["--tp", "-1"], "tp"), (["--boundary", "FFF"], "boundary"),
                       (["--seeds", "0"], "seeds")]:
        assert cli.main(["wec", "power-matrix", str(SYSTEM), "--serial", "--t-end", "0.1", *argv]) == 2
        err = capsys.readouterr().err
        assert f"error: {name}" in err and err.count("\n") == 1, err
    with pytest.raises(ParameterError, match="seeds"):
        power_matrix(SYSTEM, HS, TP, (), T_END, scheduler=None)
