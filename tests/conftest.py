import numpy as np
import pytest

from flexfmu.scene import scene_from_dict

STEEL = {"E": 200e9, "nu": 0.29, "rho": 7850.0}


def straight_rod(length=1.0, diameter=0.01, direction=(1.0, 0.0, 0.0), origin=(0.0, 0.0, 0.0), **extra):
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    pts = [list(map(float, origin)), list(map(float, np.asarray(origin, float) + length * d))]
    return scene_from_dict({"name": "rod", "points": pts, "section": {"shape": "circle", "diameter": diameter},
                            "material": dict(STEEL), **extra})


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)
