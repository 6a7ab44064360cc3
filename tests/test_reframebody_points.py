"""ReframeBody's load and output points must lie on the body (the rule of exported bodies' interfaces,
flexfmu.core.body_points): a point off it was silently replaced by the nearest node (load_point_x = 10 on the
1 m plate loaded x = 0.5 m and turned the plate the other way).  The references are the plate's and the rod's
own node coordinates."""
from __future__ import annotations

import numpy as np
import pytest

from flexfmu.errors import ParameterError
from flexfmu.reframe.models import load_model
from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

ROD = "beam:spatial_double_L"
ON_ROD = dict(load_point_x=0.14, load_point_y=0.15, load_point_z=0.16, output_point_x=0.0, output_point_y=0.0,
              output_point_z=0.0)


@pytest.mark.parametrize("changes, name, text", [
    (dict(load_point_x=10.0), "load_point_x",
     r"the load point \(10, 0, 0\.01\) m is 9\.5 m from the body's nearest node \(0\.5, 0, 0\.01\) m: outside the "
     r"body .*the body spans x -0\.5 \.\. 0\.5, y -0\.025 \.\. 0\.025, z 0 \.\. 0\.01 m"),
    (dict(output_point_z=-0.3), "output_point_z", r"the output point \(-0\.5, -0\.025, -0\.3\) m is 0\.3 m from"),
    (dict(model=ROD), "load_point_x",              # the plate's default points are off the rod
     r"the load point \(-0\.5, 0, 0\.01\) m is 0\.5001 m from the body's nearest node \(0, 0, 0\) m"),
    (dict(model=ROD, load_point_x=0.14, load_point_y=0.15, load_point_z=0.16), "output_point_x",
     r"the output point \(-0\.5, -0\.025, 0\) m is 0\.5006 m from the body's nearest node \(0, 0, 0\) m"),
    (dict(model=ROD, **{**ON_ROD, "load_point_x": 0.07, "load_point_y": 0.07, "load_point_z": 0.08}), "load_point_x",
     r"the load point \(0\.07, 0\.07, 0\.08\) m is 0\.09899 m from the body's nearest node \(0, 0, 0\.08\) m.*the "
     r"body spans x 0 \.\. 0\.14, y 0 \.\. 0\.15, z 0 \.\. 0\.16 m"),   # inside the rod's box, off the rod
])
def test_a_point_off_the_body_is_refused_naming_the_coordinate(changes, name, text):
    with pytest.raises(ParameterError, match=text) as error:
        ReframeBodySimulator(ReframeBodyConfig(**changes))
    assert error.value.parameter == name
    assert "within max(patch radius, local node spacing) = " in error.value.allowed
    assert "of its nearest node (as exported bodies' interfaces)" in error.value.allowed


def test_points_on_the_body_load_their_nearest_node():
    """On the plate's faces, inside it, and at the rod's ends: accepted, loaded at the nearest node."""
    plate = load_model("paper_plate")
    for point in ((0.5, 0.025, 0.0), (-0.2, 0.0, 0.005), (0.3, -0.025, 0.01)):
        sim = ReframeBodySimulator(ReframeBodyConfig(load_point_x=point[0], load_point_y=point[1],
                                                     load_point_z=point[2]))
        node = sim._loads.items[0].node
        assert node == int(np.argmin(np.linalg.norm(plate.nodes - np.array(point), axis=1)))
    rod = ReframeBodySimulator(ReframeBodyConfig(model=ROD, n_flexible_modes=2, **ON_ROD))
    nodes = rod.integrator.data.structure.nodes
    np.testing.assert_array_equal(nodes[rod._loads.items[0].node], [0.14, 0.15, 0.16])
    np.testing.assert_array_equal(nodes[rod._points[0]], [0.0, 0.0, 0.0])


def test_a_point_just_beyond_a_face_within_the_reach_is_accepted():
    """0.1 mm above the plate's top face (its elements are ~10 mm): on the body, within the rounding of a user's
    coordinates; 0.5 m above it is not."""
    ReframeBodySimulator(ReframeBodyConfig(load_point_z=0.0101))
    with pytest.raises(ParameterError, match="load_point_z"):
        ReframeBodySimulator(ReframeBodyConfig(load_point_z=0.51))


def test_the_automatic_model_uses_the_checked_points():
    """n_flexible_modes = -1 sizes the basis at the load and output points' nodes: a point off the body is refused
    before that work starts."""
    with pytest.raises(ParameterError, match="output_point_y"):
        ReframeBodySimulator(ReframeBodyConfig(n_flexible_modes=-1, output_point_y=2.0))
