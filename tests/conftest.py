import numpy as np
import pytest

from flexfmu.ffr.scene import scene_from_dict

STEEL = {"E": 200e9, "nu": 0.29, "rho": 7850.0}


def straight_rod(length=1.0, diameter=0.01, direction=(1.0, 0.0, 0.0), origin=(0.0, 0.0, 0.0), **extra):
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    pts = [list(map(float, origin)), list(map(float, np.asarray(origin, float) + length * d))]
    return scene_from_dict({"name": "rod", "points": pts, "section": {"shape": "circle", "diameter": diameter},
                            "material": dict(STEEL), **extra})


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


@pytest.fixture(scope="session")
def fmus(tmp_path_factory):
    """All FMUs, built once per test session: {model name: path}."""
    from fmu_helpers import build_fmus
    return build_fmus(tmp_path_factory.mktemp("dist"))


@pytest.fixture
def fmu_instance(fmus):
    """Factory: fmu_instance(fmu_name, instance_name, **start_values) -> Instance; all freed afterwards."""
    from fmu_helpers import Instance
    made = []

    def make(fmu_name, name="instance", /, **start):   # positional-only: "model" is a parameter name
        inst = Instance(fmus[fmu_name], name, **start)
        made.append(inst)
        return inst

    yield make
    for inst in made:
        inst.free()
