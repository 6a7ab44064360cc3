"""The sea-state x boundary sweep: one co-simulation per Dask task on a LocalCluster (through the FMUs),
the same table serially, and serially without Dask installed."""
import builtins

import pytest

from fmu_helpers import ROOT

from flexfmu.errors import ParameterError
from flexfmu.wec.system import Case, sweep

SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
CASES = [Case("XFF", "regular", 0.05, 1.4), Case("XFX", "jonswap", 0.08, 1.2, seed=7)]
T_END = 0.25


@pytest.fixture(scope="module")
def fmu_dir(fmus):
    """The session's one build (tests/conftest.py): the folder holding every FMU."""
    return next(iter(fmus.values())).parent


def _strip(rows):
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def test_sweep_on_a_dask_local_cluster_equals_the_serial_sweep(fmu_dir):
    import importlib.util
    assert importlib.util.find_spec("distributed"), "dask.distributed missing: install the project with its dev extra"
    on_dask = sweep(SYSTEM, CASES, T_END, backend="fmu", fmu_dir=fmu_dir, scheduler="local", n_workers=2)
    serial = sweep(SYSTEM, CASES, T_END, backend="library")
    # FMUs in worker processes = the library in this process (bit-identical with the same BLAS threading;
    # Dask's workers use one OpenBLAS thread, which can change the last digits)
    for a, b in zip(_strip(on_dask), _strip(serial)):
        assert a.keys() == b.keys()
        for key in a:
            assert a[key] == (b[key] if isinstance(b[key], str) else pytest.approx(b[key], rel=1e-9, abs=1e-300)), key
    assert [r["boundary"] for r in on_dask] == ["XFF", "XFX"]
    assert on_dask[0]["f_1_Hz"] == pytest.approx(39.6, abs=0.1) and on_dask[1]["f_1_Hz"] == pytest.approx(155.2, abs=0.1)
    assert all(r["mean_power_W"] > 0 and r["heave_amplitude_m"] > 0 for r in on_dask)


def test_serial_sweep_runs_without_dask(monkeypatch):
    real_import = builtins.__import__

    def no_dask(name, *args, **kwargs):
        if name == "dask" or name.startswith("dask."):
            raise ImportError(f"No module named {name!r}")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_dask)
    rows = sweep(SYSTEM, CASES[:1], 0.1, backend="library")
    assert rows[0]["boundary"] == "XFF" and rows[0]["mean_power_W"] >= 0
    with pytest.raises(ParameterError, match="cluster"):
        sweep(SYSTEM, CASES[:1], 0.1, backend="library", scheduler="local")
