"""The input or parameter a failure of ReframeBody names is the one behind it: a huge initial velocity is blamed
on that velocity, never on an initial spin of 0 (the overflowing start makes the computed spin infinite too), in
the library and in the native FMU alike."""
from __future__ import annotations

import pytest

from flexfmu.errors import FlexfmuError
from flexfmu.reframe.body_config import ReframeBodyConfig
from flexfmu.reframe.simulator import ReframeBodySimulator


@pytest.mark.parametrize("name", ["v0_x", "v0_y", "v0_z"])
@pytest.mark.parametrize("value", [1e200, 1e300, -1e300])
def test_a_huge_initial_velocity_is_named(name, value):
    sim = ReframeBodySimulator(ReframeBodyConfig(**{name: value}))
    try:
        for _ in range(3):
            sim.step(1e-3)
    except FlexfmuError as exc:
        assert str(exc).startswith(f"{name}:"), str(exc)
    else:                                   # the body flies off in a straight line: finite, nothing to blame
        assert all(v == v for v in sim.outputs().values())


def test_the_native_fmu_names_the_same_initial_velocity(tmp_path):
    from fmu_helpers import Instance

    from flexfmu.fmi import native
    fmu = native.build_registry_fmu("ReframeBody", target=tmp_path / "ReframeBody.fmu")
    inst = Instance(fmu, "r", v0_y=1e300)
    try:
        try:
            inst.fmu.exitInitializationMode()
            for k in range(3):
                inst.fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
        except Exception:
            pass
        refusals = [m for s, _, m in inst.log if s >= 2]
        assert refusals and not any(m.startswith("omega0") for m in refusals), inst.log
        assert any("v0_y" in m for m in refusals), inst.log
    finally:
        inst.free()
