"""The wave-energy converter as SSP 1.0 (flexfmu.cosim.ssp): the .ssp written from the OSP file is the
same system (one description), our master reads it, and three masters run it with the same coupling
(Jacobi, fixed step) to 1e-9: our fmpy master, libcosim (its own SSP loader, from_ssp_file) and the
ecos engine (ecospy, its SSP loader; in a subprocess as in tests/test_fmu_ecos.py).  Also
`flexfmu cosim --set` on .xml and .ssp."""
from __future__ import annotations

import csv
import dataclasses
import sys
import time
import zipfile
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from fmu_helpers import ROOT
from host_tools import describe, ecos_binaries, host_environment, run_host

from flexfmu import cli
from flexfmu.cosim.masters import load_system, run, run_libcosim, with_assignments
from flexfmu.cosim.ssp import SSD, write_ssp
from flexfmu.errors import ParameterError
from flexfmu.wec.wave_excitation import WaveExcitationConfig, WaveExcitationSimulator

from error_bounds import implementations_bound

OSP_FILE = ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml"
T_END = 0.5
# a short ramp: the platform moves within the run; the wave force at t0 is then zero in every master
QUICK = {"wave": {"ramp_time": 0.1}}


@pytest.fixture(scope="module")
def fmu_dir(fmus):
    return next(iter(fmus.values())).parent


@pytest.fixture(scope="module")
def host_home(tmp_path_factory):
    """One clean HOME for the module's ecos processes: flexfmu's cache (the box's BEM database, ~30 s to compute on
    a clean machine, and the compiled kernels) is filled once."""
    return tmp_path_factory.mktemp("ssp_host")


@pytest.fixture(scope="module")
def ssp_file(fmu_dir, tmp_path_factory):
    system = load_system(OSP_FILE, fmu_dir=fmu_dir)
    return write_ssp(system, tmp_path_factory.mktemp("ssp") / "wave_converter.ssp")


def _max_rel_diff(a, b, rows_a=slice(None), rows_b=slice(None)):
    assert set(a.columns) == set(b.columns)
    worst, where = 0.0, None
    for key in a.columns:
        x, y = a[key][rows_a], b[key][rows_b]
        assert x.shape == y.shape, key
        scale = np.abs(x).max()
        if scale == 0:
            assert np.all(y == 0), key
            continue
        err = np.abs(x - y).max() / scale
        if err > worst:
            worst, where = err, key
    return worst, where


def test_ssp_is_the_osp_system(ssp_file, fmu_dir, tmp_path):
    """One description: the archive holds the same simulators (order, FMUs, typed start values),
    connections, start time and step as the OSP file, with each FMU once in resources/."""
    osp = load_system(OSP_FILE, fmu_dir=fmu_dir)
    ssp = load_system(ssp_file)
    assert ssp.path == ssp_file and ssp.base_step == osp.base_step and ssp.start_time == osp.start_time
    assert [s.name for s in ssp.simulators] == [s.name for s in osp.simulators]
    assert [s.source.name for s in ssp.simulators] == [s.source.name for s in osp.simulators]
    for a, b in zip(ssp.simulators, osp.simulators):
        assert a.initial_values == b.initial_values
        assert [type(v) for v in a.initial_values.values()] == [type(v) for v in b.initial_values.values()]
        assert a.source.read_bytes() == b.source.read_bytes()
    assert ssp.connections == osp.connections and len(ssp.connections) == 51
    with zipfile.ZipFile(ssp_file) as zf:
        names = sorted(zf.namelist())
        ssd = ET.fromstring(zf.read("SystemStructure.ssd"))
    assert names == ["SystemStructure.ssd"] + sorted(f"resources/{m}.fmu" for m in
                                                     ("WaveExcitation", "Platform", "Hydrostatics", "FFRBeam", "PTO"))
    assert ssd.tag == f"{{{SSD}}}SystemStructureDescription" and ssd.get("version") == "1.0"
    # every connection end is a declared connector of its component (libcosim's parser requires it)
    connectors = {c.get("name"): {k.get("name"): k.get("kind") for k in c.iter(f"{{{SSD}}}Connector")}
                  for c in ssd.iter(f"{{{SSD}}}Component")}
    for c in ssd.iter(f"{{{SSD}}}Connection"):
        assert connectors[c.get("startElement")][c.get("startConnector")] == "output"
        assert connectors[c.get("endElement")][c.get("endConnector")] == "input"
    # the .ssd on its own (a folder) reads the same
    folder = tmp_path / "unpacked"
    zipfile.ZipFile(ssp_file).extractall(folder)
    assert load_system(folder).connections == osp.connections
    assert load_system(folder / "SystemStructure.ssd").simulator("wave").initial_values == \
        osp.simulator("wave").initial_values


def test_fmpy_master_reads_the_ssp_bit_identically(ssp_file, fmu_dir):
    osp = load_system(OSP_FILE, fmu_dir=fmu_dir).with_values(QUICK)
    ssp = load_system(ssp_file).with_values(QUICK)
    a = run(osp, 0.05, scheme="gauss-seidel", backend="fmu")
    b = run(ssp, 0.05, scheme="gauss-seidel", backend="fmu")
    assert all(np.array_equal(a[k], b[k]) for k in a.columns)


ECOS_DRIVER = r"""
import sys, time, numpy as np
from flexfmu.cosim.masters import load_system, run_ecos
path, t_end, out, values = sys.argv[1], float(sys.argv[2]), sys.argv[3], eval(sys.argv[4])
every = int(sys.argv[5]) if len(sys.argv) > 5 else 1
start = time.perf_counter()
r = run_ecos(load_system(path).with_values(values), t_end, every=every)
np.savez(out, t=r.t, names=np.array(list(r.columns)), data=np.array(list(r.columns.values())))
print(f"ECOS_WALL {time.perf_counter() - start:.3f}")
"""


def test_three_masters_run_the_ssp_to_1e9(ssp_file, host_home, tmp_path, capsys):
    """fmpy master (Jacobi), libcosim (from_ssp_file) and ecos (EcosSimulation(ssp_path)) on the same
    archive: every output of every FMU at every communication point."""
    system = load_system(ssp_file).with_values(QUICK)
    start = time.perf_counter()
    ours = run(system, T_END, scheme="jacobi", backend="fmu")
    walls = {"fmpy": time.perf_counter() - start}
    assert abs(ours["platform.pos_z"]).max() > 1e-4                    # the platform moves
    assert abs(ours["pto.F_z"]).max() > 0                               # the harvester loop carries force
    diffs = {}

    pytest.importorskip("libcosimpy", reason="libcosimpy (DNV's libcosim) is not installed: the dev extra")
    start = time.perf_counter()
    theirs = run_libcosim(system, T_END, description="ssp")
    walls["libcosim"] = time.perf_counter() - start
    # libcosim records from the first step on (its observer has nothing before it)
    # identity: run_libcosim's grid is start + h * arange(1, n + 1), run's start + h * arange(n + 1): the same
    # elementwise roundings of the same h and k
    assert np.array_equal(theirs.t, ours.t[1:])
    diffs["libcosim"] = _max_rel_diff(ours, theirs, slice(1, None))

    found = ecos_binaries()
    if isinstance(found, str):
        pytest.skip(f"ecos not available: {found} (libcosim agreed: {diffs['libcosim']})")
    out = tmp_path / "ecos.npz"
    env = host_environment(host_home)
    proc = run_host([sys.executable, "-c", ECOS_DRIVER, ssp_file, repr(T_END), out, repr(QUICK)], env, tmp_path,
                    timeout=600)
    assert proc.returncode == 0 and out.is_file(), describe(proc, env)
    walls["ecos"] = float(proc.stdout.split("ECOS_WALL")[-1])
    data = np.load(out)
    # identity: run_ecos's grid is start + h * arange(n + 1) as run's, h read from the same archive; npz is binary
    assert np.array_equal(data["t"], ours.t)
    ecos = type(ours)(data["t"], dict(zip(data["names"].tolist(), data["data"])), ours.step, "jacobi", "ecos")
    diffs["ecos"] = _max_rel_diff(ours, ecos)
    with capsys.disabled():
        print(f"\nSSP, Jacobi, h = {ours.step:g} s, {T_END} s: max relative difference to the fmpy master "
              + ", ".join(f"{k} {v[0]:.2e} ({v[1]})" for k, v in diffs.items())
              + "; wall " + ", ".join(f"{k} {v:.1f} s" for k, v in walls.items()))
    for host, (worst, where) in diffs.items():
        assert worst <= 1e-9, (host, worst, where)


def test_engines_record_every_kth_point_the_same_values(ssp_file, host_home, tmp_path):
    """libcosim and ecos with every = 7 (the steps between recorded points in one engine call): at the recorded
    points the same values, bit for bit, as recording every point (the engines take the same steps), and the last
    point recorded although n is no multiple of 7."""
    pytest.importorskip("libcosimpy", reason="libcosimpy (DNV's libcosim) is not installed: the dev extra")
    system = load_system(ssp_file).with_values(QUICK)
    every = run_libcosim(system, T_END, description="ssp")
    n = every.t.size                          # libcosim records from the first step: points 1 .. n
    assert n % 7 != 0
    sparse = run_libcosim(system, T_END, description="ssp", every=7)
    keep = [0] + list(range(6, n, 7)) + ([n - 1] if (n - 1) % 7 != 6 else [])
    assert np.array_equal(sparse.t, every.t[keep])
    assert all(np.array_equal(sparse[k], every[k][keep]) for k in every.columns)

    found = ecos_binaries()
    if isinstance(found, str):
        pytest.skip(f"ecos not available: {found}")
    env = host_environment(host_home)
    data = {}
    for k in (1, 7):
        out = tmp_path / f"ecos_{k}.npz"
        proc = run_host([sys.executable, "-c", ECOS_DRIVER, ssp_file, repr(T_END), out, repr(QUICK), str(k)], env,
                        tmp_path, timeout=600)
        assert proc.returncode == 0 and out.is_file(), describe(proc, env)
        data[k] = np.load(out)
    n = data[1]["t"].size - 1                 # ecos records t0 and points 1 .. n
    keep = list(range(0, n + 1, 7)) + ([n] if n % 7 else [])
    assert np.array_equal(data[7]["t"], data[1]["t"][keep])
    assert np.array_equal(data[7]["data"], data[1]["data"][:, keep])


def test_bad_ssp_files_name_the_problem(ssp_file, tmp_path):
    not_zip = tmp_path / "broken.ssp"
    not_zip.write_text("no archive")
    with pytest.raises(ParameterError, match="SYSTEM_FILE.*not a zip"):
        load_system(not_zip)
    folder = tmp_path / "unpacked"
    zipfile.ZipFile(ssp_file).extractall(folder)
    ssd = folder / "SystemStructure.ssd"
    text = ssd.read_text()
    ssd.write_text(text.replace('endConnector="wave_F_x" />', 'endConnector="wave_F_x"><ssc:LinearTransformation '
                                'factor="2.0" /></ssd:Connection>', 1))
    with pytest.raises(ParameterError, match="Connection.*transformation"):
        load_system(folder)
    ssd.write_text(text.replace('endElement="platform"', 'endElement="platfrom"', 1))
    with pytest.raises(ParameterError, match="platfrom"):
        load_system(folder)


# ---------------------------------------------------------------- flexfmu cosim --set
def test_set_changes_start_values_with_typed_values(ssp_file, fmu_dir):
    for system in (load_system(OSP_FILE, fmu_dir=fmu_dir), load_system(ssp_file)):
        changed = with_assignments(system, ["wave.wave_height=0.1", "wave.seed=7", "harvester.boundary=XFX",
                                            "wave.sea_state=jonswap", "pto.damping=5"])
        wave = changed.simulator("wave").initial_values
        assert wave["wave_height"] == 0.1 and wave["seed"] == 7 and type(wave["seed"]) is int
        assert wave["sea_state"] == "jonswap" and changed.simulator("pto").initial_values["damping"] == 5.0
        assert changed.simulator("harvester").initial_values["boundary"] == "XFX"
        assert system.simulator("wave").initial_values["wave_height"] == 0.05     # the original is unchanged


@pytest.mark.parametrize("kind", ["xml", "ssp"])
def test_cli_set_runs_and_rejects_unknown_names(kind, ssp_file, fmu_dir, tmp_path, capsys):
    path = str(OSP_FILE) if kind == "xml" else str(ssp_file)
    extra = ["--fmu-dir", str(fmu_dir)] if kind == "xml" else []

    def cosim(*sets, out=None):
        argv = ["cosim", path, "--t-end", "0.05", "--no-stability-check", *extra]
        argv += [a for s in sets for a in ("--set", s)]
        if out is not None:
            argv += ["--out", str(out)]
        return cli.main(argv)

    def column(csv_path, name):
        with csv_path.open() as f:
            rows = list(csv.reader(f))
        j = rows[0].index(name)
        return np.array([float(r[j]) for r in rows[1:]])

    assert cosim("wave.ramp_time=0", out=tmp_path / "a.csv") == 0
    assert cosim("wave.ramp_time=0", "wave.wave_height=0.1", out=tmp_path / "b.csv") == 0
    capsys.readouterr()
    a, b = column(tmp_path / "a.csv", "wave.F_z"), column(tmp_path / "b.csv", "wave.F_z")
    # linear in the wave height: F_z = Re(sum_j X_j e^{i(phi_j - w_j t)}), X_j = transfer_j a_j, amplitude a_j
    # from H (<= 7 roundings), the product (1), Re of the complex product (2), the n-term sum (n - 1), the ramp
    # (1): n + 10, over-counted as n + 16, on sum_j |X_j| of the doubled height; the CSV is repr, exact
    iv = load_system(path).simulator("wave").initial_values if kind == "ssp" else \
        load_system(path, fmu_dir=fmu_dir).simulator("wave").initial_values
    fields = {f.name for f in dataclasses.fields(WaveExcitationConfig)}
    cfg = WaveExcitationConfig(**{k: v for k, v in iv.items() if k in fields} | {"ramp_time": 0.0, "wave_height":
                                                                                 2 * iv.get("wave_height", 0.05)})
    X = WaveExcitationSimulator(cfg)._X[2]
    bound = implementations_bound(float(np.abs(X).sum()), X.size + 16)
    assert np.abs(a).max() > 0 and np.all(np.abs(b - 2 * a) <= bound)
    for bad, expect in [("waves.wave_height=1", "unknown instance 'waves' (allowed: wave, platform, hydro, harvester,"
                                                " pto)"),
                        ("wave.height=1", "wave has no parameter or input 'height' (allowed: wave.sea_state, "
                                          "wave.wave_height,"),
                        ("wave.wave_height=tall", "wave.wave_height: 'tall' is not a Real"),
                        ("wave_height=1", "is not INSTANCE.VARIABLE=VALUE")]:
        assert cosim(bad) == 2
        err = capsys.readouterr().err
        assert expect in err and err.count("\n") == 1, err


def test_ecos_stops_on_a_failed_initialisation_instead_of_recording_zeros(ssp_file):
    """ecos reports a failed FMU call only by its return value: a PTO whose damping its FMU refuses at
    initialisation ends the run with the failure, never with the zero outputs of models that did not run."""
    from flexfmu.cosim.masters import run_ecos
    from flexfmu.errors import CosimulationError, ParameterError
    found = ecos_binaries()
    if isinstance(found, str):
        pytest.skip(f"ecos not available: {found}")
    system = load_system(ssp_file).with_values({**QUICK, "pto": {"damping": -1.0}})
    try:
        with pytest.raises(CosimulationError, match=r"pto: exitInitializationMode failed: damping: got -1\.0"):
            run_ecos(system, 0.01)
    except ParameterError as exc:               # ecospy's library cannot be loaded in this process
        pytest.skip(str(exc))
