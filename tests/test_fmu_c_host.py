"""A minimal C host (examples/c_host/fmi2_host.c: dlopen + fmi2 calls) runs the FMUs the way a
non-Python FMI tool does — libpython preloaded, PYTHONPATH to numpy/scipy — and matches fmpy."""
import os
import subprocess
import sysconfig
import zipfile
from pathlib import Path

import fmpy
import numpy as np
from fmpy import read_model_description

from fmu_helpers import ROOT, Instance


def _compile(tmp_path: Path) -> Path:
    exe = tmp_path / "fmi2_host"
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-std=c99", "-D_GNU_SOURCE", "-O2", f"-I{headers}", "-o", str(exe),
                    str(ROOT / "examples" / "c_host" / "fmi2_host.c"), "-ldl"], check=True)
    return exe


def _host_environment() -> dict:
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("LDLIBRARY")
    assert libpython.exists(), f"no shared libpython at {libpython}: a non-Python host cannot run these FMUs"
    site = sysconfig.get_paths()["purelib"]
    return {**os.environ, "LD_PRELOAD": str(libpython), "PYTHONPATH": site}


def test_c_host_matches_fmpy(fmus, tmp_path):
    exe = _compile(tmp_path)
    fmu = fmus["FFRBeam"]
    unzipped = tmp_path / "FFRBeam"
    with zipfile.ZipFile(fmu) as zf:
        zf.extractall(unzipped)
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = ["tip_u_z", "sensor_a_x", "reaction_M_y", "f_1"]
    h, n, force = 1e-3, 20, 1.5
    out = subprocess.run([str(exe), str(unzipped), "FFRBeam", md.guid, str(h), str(n), str(vr["F_z"]), str(force),
                          *[str(vr[o]) for o in outputs]], capture_output=True, text=True, timeout=120,
                         env=_host_environment())
    assert out.returncode == 0, out.stderr
    host = np.loadtxt(out.stdout.splitlines(), delimiter=",")
    assert host.shape == (n, 1 + len(outputs))

    inst = Instance(fmu, "fmpy").initialize()
    ours = []
    for k in range(n):
        inst.set(F_z=force)
        inst.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        ours.append(inst.get(*outputs))
    inst.free()
    ours = np.array(ours)
    scale = np.abs(ours).max(axis=0)
    assert np.max(np.abs(host[:, 1:] - ours) / scale) <= 1e-12
