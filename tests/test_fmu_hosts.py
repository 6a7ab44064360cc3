"""Third-party FMI tooling on our FMUs: fmu-manipulation-toolbox's checker and DNV's libcosim
(libcosimpy) as a host, which must reproduce fmpy's results."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from fmu_helpers import Instance

from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave


@pytest.mark.parametrize("name", ["FFRBeam", "ReframeBody"])
def test_fmu_manipulation_toolbox_check_passes(fmus, name):
    fmutool = Path(sys.executable).with_name("fmutool")   # the project venv's console script (dev extra)
    assert fmutool.exists(), "fmu-manipulation-toolbox missing: install the project with its dev extra"
    out = subprocess.run([fmutool, "-input", str(fmus[name]), "-check"], capture_output=True, text=True,
                         timeout=300)
    text = out.stdout + out.stderr
    assert out.returncode == 0, text
    assert "seems to be compliant with FMI-2.0" in text and "No semantic error" in text, text


CASES = {
    "FFRBeam": ({"boundary": "XFX", "damping_ratio": 0.02, "load_s": 0.3},
                lambda t: {"F_z": 1.5 * np.sin(60 * t), "base_a_x": 0.5, "base_w_z": 0.3},
                ["sensor_u_y", "sensor_a_x", "sensor_u_z", "reaction_F_z", "reaction_M_x"]),
    "ReframeBody": ({"model": "beam:spatial_double_L", "n_flexible_modes": 4, "load_point_x": 0.14,
                     "load_point_y": 0.15, "load_point_z": 0.16, "omega0_3": 1.0},
                    lambda t: {"F_x": 2.0 * np.cos(30 * t), "M_z": 0.01},
                    ["omega_1", "omega_2", "omega_3", "com_vel_x", "out_acc_y", "q_w", "max_elastic_displacement"]),
}


@pytest.mark.parametrize("name", list(CASES))
def test_libcosim_host_matches_fmpy(fmus, name):
    start, inputs, outputs = CASES[name]
    fmu = str(fmus[name])
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    kind = {v.name: v.type for v in md.modelVariables}
    h, n_steps = 1e-3, 25

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(step_size=int(round(h * 1e9)))   # ns
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=fmu, instance_name=name))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    manipulator = CosimManipulator.create_override()
    execution.add_manipulator(manipulator)
    for key, value in start.items():
        setter = {"Real": execution.real_initial_value, "Integer": execution.integer_initial_value,
                  "String": execution.string_initial_value}[kind[key]]
        setter(index, vr[key], value)
    host = []
    for k in range(n_steps):
        values = inputs(k * h)
        manipulator.slave_real_values(index, [vr[n] for n in values], list(values.values()))
        execution.step()
        host.append(observer.last_real_values(index, [vr[n] for n in outputs]))

    inst = Instance(fmus[name], "fmpy", **start).initialize()
    ours = []
    for k in range(n_steps):
        inst.set(**inputs(k * h))
        inst.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        ours.append(inst.get(*outputs))
    inst.free()
    host, ours = np.array(host), np.array(ours)
    scale = np.abs(ours).max(axis=0)
    assert np.all(scale > 0)
    assert np.max(np.abs(host - ours) / scale) <= 1e-12, np.abs(host - ours) / scale
