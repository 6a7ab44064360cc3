"""Outputs of the reframe integrator that the FMU and the CLI share."""
import numpy as np

from flexfmu.ffr.assembly import build_beam_model
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, constant_load
from flexfmu.reframe.simulator import OUTPUT_NAMES, output_values
from flexfmu.ffr.scene import load_scene


def test_frame_origin_velocity_is_the_derivative_of_frame_origin():
    beam = build_beam_model(load_scene("spatial_double_L"), "free", 4).structure()
    integ = ReframeIntegrator(beam, modal_basis(beam, 3, 0.05))
    integ.set_initial(v0=(0.1, 0.0, -0.2), omega0=(5.0, 2.0, 8.0))
    dt = 2e-5
    res = integ.run(0.02, dt, PointLoad(len(beam.nodes) - 1, constant_load([0.3, -0.2, 0.5])), points=[0])
    central = (res.frame_origin[2:] - res.frame_origin[:-2]) / (2 * dt)
    scale = np.abs(res.frame_origin_velocity).max()
    assert np.max(np.abs(central - res.frame_origin_velocity[1:-1])) < 1e-6 * scale
    table = output_values(res)
    assert table.shape == (len(res.t), len(OUTPUT_NAMES))
    np.testing.assert_array_equal(table[:, OUTPUT_NAMES.index("omega_2")], res.omega[:, 1])
    np.testing.assert_array_equal(table[:, OUTPUT_NAMES.index("out_acc_rigid_z")], res.point_acceleration_rigid[:, 0, 2])
