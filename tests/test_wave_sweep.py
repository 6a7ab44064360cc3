"""The sea-state x boundary sweep: one co-simulation per Dask task on a LocalCluster (through the FMUs),
the same table serially, and serially without Dask installed."""
import builtins
import subprocess
import sys

import pytest

from fmu_helpers import ROOT

from flexfmu.errors import ParameterError
from flexfmu.wec.system import Case, sweep

SYSTEM = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
#: the example runs the BEM hydrodynamics, whose database holds a JONSWAP sea's 0.5 .. 3 w_p for Tp >= 1.26 s
CASES = [Case("XFF", "regular", 0.05, 1.4), Case("XFX", "jonswap", 0.08, 1.4, seed=7)]
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


#: A serial sweep in a process where Dask is not installed: sys.modules["dask"] = None makes both ``import dask``
#: fail and importlib.util.find_spec("dask") return None, as when it is absent (the BEM database's xarray asks
#: find_spec whether Dask is there, once per process, so this needs a fresh process).
NO_DASK = r"""
import sys
sys.modules["dask"] = None
from flexfmu.wec.system import Case, sweep
row = sweep(sys.argv[1], [Case("XFF", "regular", 0.05, 1.4)], 0.1, backend="library")[0]
loaded = sorted(m for m, module in sys.modules.items()
                if module is not None and m.split(".")[0] in ("dask", "distributed"))
print(row["boundary"], row["mean_power_W"], loaded)
"""


def test_serial_sweep_runs_without_dask(monkeypatch):
    out = subprocess.run([sys.executable, "-c", NO_DASK, str(SYSTEM)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    boundary, power, loaded = out.stdout.split(maxsplit=2)
    assert boundary == "XFF" and float(power) >= 0 and loaded.strip() == "[]", out.stdout

    real_import = builtins.__import__

    def no_dask(name, *args, **kwargs):
        if name == "dask" or name.startswith("dask."):
            raise ImportError(f"No module named {name!r}")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_dask)
    with pytest.raises(ParameterError, match="cluster"):
        sweep(SYSTEM, CASES[:1], 0.1, backend="library", scheduler="local")
