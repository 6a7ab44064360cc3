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


#: Test tiers (pytest markers, registered in pyproject.toml); .ci/run runs them all.
#: host: our FMUs in hosts other than fmpy; study: the studies' building blocks and independent references;
#: fmu: anything that builds or loads an FMU; unit: the library alone.  A test marked with a tier itself keeps
#: it (test_fmu_native.py: its C-host, ecos and libcosim tests are marked host, the rest are fmu).
TIERS = ("unit", "fmu", "host", "study")
HOST_FILES = {"test_fmu_c_host.py", "test_fmu_ecos.py", "test_fmu_hosts.py", "test_fmu_ssp.py"}
STUDY_FILES = {"test_work_precision.py", "test_stability.py", "test_spinup_models.py", "test_spinup_reference.py",
               "test_reframe_exudyn.py", "test_wave_sweep.py", "test_wave_power_matrix.py", "test_wave_barge.py"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if any(item.get_closest_marker(tier) for tier in TIERS):
            continue
        name = item.path.name
        tier = ("host" if name in HOST_FILES else "study" if name in STUDY_FILES
                else "fmu" if "fmus" in getattr(item, "fixturenames", ()) or name.startswith(("test_fmu", "test_fmi"))
                else "unit")
        item.add_marker(getattr(pytest.mark, tier))
