"""The no-op FMU (tests/fixtures/noop_fmu): the native FFRBeam's variables, no computation.

It is the baseline of benchmarks/fmusim_hammer.py: what a host costs per step without a model.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from fixtures.noop_fmu.build import build_noop_fmu

pytestmark = pytest.mark.fmu


@pytest.fixture(scope="module")
def native_and_noop(tmp_path_factory):
    from flexfmu.fmi import native
    folder = tmp_path_factory.mktemp("noop_fmu")
    reference = native.build_registry_fmu("FFRBeam", target=folder / "FFRBeam.fmu")
    return reference, build_noop_fmu(reference, folder / "NoopFFRBeam.fmu")


def _variables(fmu):
    with zipfile.ZipFile(fmu) as archive:
        root = ET.fromstring(archive.read("modelDescription.xml"))
    return [(v.get("name"), v.get("valueReference"), v.get("causality")) for v in root.iter("ScalarVariable")]


def test_noop_fmu_mirrors_the_reference_variables(native_and_noop):
    reference, noop = native_and_noop
    assert _variables(noop) == _variables(reference)


def test_noop_fmu_is_valid(native_and_noop):
    _, noop = native_and_noop
    assert validate_fmu(str(noop)) == []


def test_noop_fmu_runs_the_hammer_inputs_and_gives_zeros(native_and_noop):
    _, noop = native_and_noop
    dt = 1e-4
    t = np.arange(0.0, 0.01 + dt / 2, dt)
    pulse = np.where(t < 1e-3, 20.0 * np.sin(np.pi * t / 1e-3), 0.0)
    signals = np.zeros(len(t), dtype=[("time", float), ("F_x", float), ("F_y", float), ("F_z", float)])
    signals["time"], signals["F_x"], signals["F_y"], signals["F_z"] = t, pulse, 0.7 * pulse, 0.4 * pulse
    outputs = ["sensor_a_x", "sensor_a_y", "sensor_a_z", "f_1"]
    result = simulate_fmu(str(noop), stop_time=0.01, step_size=dt, output_interval=dt, input=signals,
                          start_values={"boundary": "FXF", "damping_ratio": 0.002, "load_s": 0.45, "sensor_s": 0.30},
                          output=outputs)
    assert len(result) == len(t)
    for name in outputs:
        assert np.all(result[name] == 0.0), name
