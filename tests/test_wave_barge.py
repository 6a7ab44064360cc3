"""The flexible barge (flexfmu.wec.barge): the wave converter's platform as a free flexible body.

References: the frequency-domain RAO of the BEM database (flexfmu.wec.bem.response_amplitude_operator, eq.
BEM.2) for the slab's rigid-body mass matrix, which is a closed form (a uniform box: m, z_G and radii of
gyration (b^2 + t^2) / 12 ...); the point-mass algebra of the added mass.  The co-simulation couples library
simulators (FlexBodySimulator for the barge; WaveExcitation, Hydrostatics) in the order and hold of the
Gauss-Seidel master at the example's 1 ms step, as tests/test_wave_bem_cosim.py does for the rigid Platform,
whose error budget applies (0.48 % in heave at 1.7 s, 1 ms: the held coupling loads and the passive fit).
"""
import math
import tempfile
import time

import numpy as np
import pytest

pytest.importorskip("capytaine")
pytest.importorskip("meshio")

from error_bounds import gamma                                                          # noqa: E402
from test_wave_bem_cosim import HEIGHT, STEP, T_END                                  # noqa: E402

from flexfmu.body.build import build_body                                               # noqa: E402
from flexfmu.errors import ParameterError                                               # noqa: E402
from flexfmu.wec import bem                                                             # noqa: E402
from flexfmu.wec.barge import (BargeInLoop, BargeParameters, barge_structure, build_barge,  # noqa: E402
                               split_added_mass)
from flexfmu.wec.components import bem_added_mass_inf, bem_database                     # noqa: E402
from flexfmu.wec.hydrostatics import INPUT_NAMES as HYDRO_INPUTS                        # noqa: E402
from flexfmu.wec.hydrostatics import HydrostaticsConfig, HydrostaticsSimulator          # noqa: E402
from flexfmu.wec.rao import RigidPlatform, cosimulated_motion, steady_amplitude          # noqa: E402
from flexfmu.wec.wave import BoxParameters                                              # noqa: E402

AX = "xyz"
STIFF = BargeParameters(E=2.0e11, nu=0.3)      # steel-stiff: first elastic mode 319 Hz
HDPE = BargeParameters(E=1.0e9, nu=0.42)       # the example's hull: first elastic mode 22 Hz


def slab_rigid_box(p: BargeParameters) -> BoxParameters:
    """The box whose rigid-body mass matrix is the slab's: the displaced mass at z_G = the slab's centre, radii
    of gyration of a uniform box L x B x t."""
    b, t = p.box, p.thickness
    return BoxParameters(length=b.length, beam=b.beam, draft=b.draft, z_G=p.z_center,
                         r_xx=math.sqrt((b.beam ** 2 + t ** 2) / 12), r_yy=math.sqrt((b.length ** 2 + t ** 2) / 12),
                         r_zz=math.sqrt((b.length ** 2 + b.beam ** 2) / 12), rho=b.rho, g=b.g)


@pytest.fixture(scope="module")
def ds():
    return bem_database(BargeParameters().box)


@pytest.fixture(scope="module")
def bodies(ds):
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, p in (("stiff", STIFF), ("hdpe", HDPE)):
            out[name] = build_barge(p, tmp, A_inf=bem_added_mass_inf(ds), f_max=60.0, tolerance=1e-2)
    return out


def cosimulate_barge(body, period: float, heading: float = 0.0, t_end: float = T_END, h: float = STEP):
    """Times, the motion of O xi (n, 6) (O's rigid fit, the frame's rotation), the elevation, and the largest
    elastic displacement (m) of the barge in regular waves (Hydrostatics with added_mass = point)."""
    barge = BargeInLoop(body)
    t, xi, eta = cosimulated_motion(period, t_end, h, heading=heading, platform=barge,
                                    hydro_config=HydrostaticsConfig(hydrodynamics="bem", added_mass="point"))
    return t, xi, eta, barge.largest_elastic


def test_added_mass_is_a_point_mass_the_body_carries(bodies, ds):
    """The body's share of A_inf at O: the body's mass, centre of mass and inertia are the slab's plus a point
    mass A_33 at O plus the rotational block (parallel axes, closed form)."""
    A_body, A_lag = split_added_mass(bem_added_mass_inf(ds))
    # A_inf is exactly symmetric (0.5 (A + A^T)), so split's symmetrisation returns it; A_body's entries are copies
    # and A_lag = A - A_body exact where A_body is 0 or the copy; the translational diagonal A_ii - A_33 then + A_33:
    # 2 roundings of terms |A_ii| + |A_33|
    A = bem_added_mass_inf(ds)
    assert np.all(np.abs(A_body + A_lag - A) <= gamma(2) * (np.abs(A) + np.abs(A_body)))
    body, box = bodies["stiff"], slab_rigid_box(STIFF)
    m_s, m_a = box.rho * box.length * box.beam * box.draft, A_body[2, 2]
    assert body.mass == pytest.approx(m_s + m_a, rel=1e-10)
    c = np.array([0.0, 0.0, m_s * box.z_G / (m_s + m_a)])
    # c = first moment / mass from t^T M r (rigid fields; M the slab's consistent mass, |M| summing to rho = 10x M
    # (quadratic elements), plus D^T A_body D at the hydro patch).  Terms: the slab's <= rho m_s max|x|, the added
    # mass's |D t|^T |A_body| |D| |x|; roundings generously over-counted as 2 n_dof + 300 (the element quadrature and
    # assembly, the patch fit D, the products M B (row) and B^T (M B) (n_dof), the division), the mass's the same
    with tempfile.TemporaryDirectory() as tmp:
        Ms = barge_structure(STIFF, tmp).M
    rho_M = abs(Ms).sum() / Ms.sum()
    nodes = np.asarray(body.arrays["nodes"], float)
    hydro = next(i for i in body.interfaces if i.name == "hydro")
    dpn = body.dofs_per_node
    x_fit = np.abs(nodes[hydro.dofs // dpn]).max(axis=1)                            # |x| at the fitted DOFs
    D = np.abs(hydro.D[:6])
    S_a = (D @ np.ones(hydro.dofs.size)) @ np.abs(A_body) @ (D @ x_fit)
    S = rho_M * m_s * np.abs(nodes).max() + S_a
    bound = 2 * gamma(2 * Ms.shape[0] + 300) * S / body.mass
    assert np.all(np.abs(body.center_of_mass - c) <= bound + gamma(4) * np.abs(c))   # c's own 3 roundings
    # about the common centre of mass: the slab's inertia about G and the point mass's, both moved there
    J_slab = m_s * np.diag([box.r_xx ** 2, box.r_yy ** 2, box.r_zz ** 2])
    arm_s, arm_a = np.array([0, 0, box.z_G]) - c, -c
    shift = lambda m, r: m * (r @ r * np.eye(3) - np.outer(r, r))   # noqa: E731
    want = J_slab + shift(m_s, arm_s) + A_body[3:, 3:] + shift(m_a, arm_a)
    np.testing.assert_allclose(body.inertia, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
    # a free body's added mass must be one a point mass can carry
    with pytest.raises(ParameterError, match=r"added_mass\['hydro'\].*point mass"):
        build_body(body_structure(), interfaces=[{"name": "hydro", "point": [0, 0, 0], "node_set": "bottom"}],
                   n_modes=2, added_mass={"hydro": bem_added_mass_inf(ds)})
    with pytest.raises(ParameterError, match=r"added_mass\['keel'\].*no such interface"):
        build_body(body_structure(), interfaces=[{"name": "hydro", "point": [0, 0, 0], "node_set": "bottom"}],
                   n_modes=2, added_mass={"keel": A_body})


def body_structure():
    from flexfmu.wec.barge import barge_structure
    with tempfile.TemporaryDirectory() as tmp:
        return barge_structure(BargeParameters(elements=(2, 2, 1)), tmp)


def test_hydrostatics_applies_the_lagged_rest_of_the_added_mass(ds):
    """added_mass = point: F = (the platform model's force) - A_lagged [acc; alpha]."""
    _, A_lag = split_added_mass(bem_added_mass_inf(ds))
    acc = np.array([0.3, -0.2, 0.5, 0.02, -0.04, 0.01])
    plain = HydrostaticsSimulator(HydrostaticsConfig(hydrodynamics="bem"))
    split = HydrostaticsSimulator(HydrostaticsConfig(hydrodynamics="bem", added_mass="point"))
    inputs = dict(zip(HYDRO_INPUTS[12:], acc.tolist()), pos_z=0.01, rot_y=0.02)
    plain.set_inputs(**inputs)
    split.set_inputs(**inputs)
    f0, f1 = plain.outputs(), split.outputs()
    got = np.array([f1[f"{q}_{a}"] - f0[f"{q}_{a}"] for q in "FM" for a in AX])
    # f1 = f0 - A_lag acc on the same f0 bits (same code, same inputs), then f1 - f0: the 6-term product (gamma(6)),
    # the subtraction from f0 and back (2 roundings) of terms |f0| + |A_lag||acc|
    terms = np.array([abs(f0[f"{q}_{a}"]) for q in "FM" for a in AX]) + np.abs(A_lag) @ np.abs(acc)
    assert np.all(np.abs(got + A_lag @ acc) <= gamma(8) * terms + gamma(6) * np.abs(A_lag) @ np.abs(acc))
    with pytest.raises(ParameterError, match="added_mass.*platform.*point"):
        HydrostaticsSimulator(HydrostaticsConfig(added_mass="hull"))


@pytest.mark.parametrize("period", [1.0, 1.7, 2.5])
def test_stiff_barge_rao_matches_the_rigid_frequency_domain_rao(bodies, ds, period):
    """A steel-stiff barge (first elastic mode 319 Hz) moves as the rigid body of its mass matrix: its
    co-simulated RAO in head waves against the frequency-domain RAO of the slab's rigid-body mass matrix,
    within the 2 % the rigid Platform meets.  Part of A_inf (surge: A_11 - A_33 = -118 kg) is applied from
    the previous step's acceleration; the agreement shows the lagged part neither destabilises nor biases."""
    omega = 2 * math.pi / period
    _, rao = bem.response_amplitude_operator(ds, slab_rigid_box(STIFF).box().rigid_mass_matrix(), 0.0, [omega])
    start = time.perf_counter()
    t, xi, eta, _ = cosimulate_barge(bodies["stiff"], period)
    elapsed = time.perf_counter() - start
    a = HEIGHT / 2
    assert abs(steady_amplitude(t, eta, omega) / a - 1) < 1e-9
    print(f"\nstiff barge, T = {period} s ({elapsed:.1f} s wall for {T_END} s at {STEP * 1e3:g} ms):")
    for d, name in ((0, "surge"), (2, "heave"), (4, "pitch")):
        z = steady_amplitude(t, xi[:, d], omega) / a
        err = abs(z - rao[0, d]) / abs(rao[0, d])
        print(f"  {name}: co-sim |RAO| {abs(z):.4f}, frequency domain {abs(rao[0, d]):.4f}, "
              f"complex difference {100 * err:.2f} %")
        assert err < 0.02, (name, abs(z), abs(rao[0, d]), err)


def test_flexible_barge_moves_as_the_rigid_one_and_bends_quasi_statically(bodies, ds):
    """The HDPE barge (first elastic mode 22 Hz, 13x the wave frequency) at 1.7 s: the rigid-body RAO within
    the same 2 % (its bending is quasi-static, carried by the interfaces' static correction), a bounded elastic
    displacement, and no growth of the lagged added mass at its stiffest mode."""
    period = 1.7
    omega = 2 * math.pi / period
    _, rao = bem.response_amplitude_operator(ds, slab_rigid_box(HDPE).box().rigid_mass_matrix(), 0.0, [omega])
    t, xi, eta, elastic = cosimulate_barge(bodies["hdpe"], period)
    a = HEIGHT / 2
    print(f"\nHDPE barge ({bodies['hdpe'].summary()}), T = {period} s: largest elastic displacement "
          f"{elastic * 1e6:.2f} um for a = {a * 1e3:g} mm")
    for d, name in ((0, "surge"), (2, "heave"), (4, "pitch")):
        z = steady_amplitude(t, xi[:, d], omega) / a
        err = abs(z - rao[0, d]) / abs(rao[0, d])
        print(f"  {name}: co-sim |RAO| {abs(z):.4f}, frequency domain {abs(rao[0, d]):.4f}, "
              f"complex difference {100 * err:.2f} %")
        assert err < 0.02, (name, abs(z), abs(rao[0, d]), err)
    assert 0.0 < elastic < 1e-3


def cosimulate_platform(box: BoxParameters, period: float, heading: float, t_end: float = T_END, h: float = STEP):
    """The rigid Platform of ``box`` in the same loop."""
    from dataclasses import asdict

    from flexfmu.wec.platform import PlatformConfig
    platform = RigidPlatform(PlatformConfig(**asdict(box), hydrodynamics="bem"))
    return cosimulated_motion(period, t_end, h, heading=heading, platform=platform)[1]


def test_stiff_barge_in_oblique_waves_moves_as_the_rigid_platform(bodies, ds):
    """Heading 30 deg, 2.5 s, all six DOFs: the stiff barge against the rigid Platform of the same mass matrix in
    the same coupling loop (the lagged sway and sway-roll parts of A_inf are the only modelling difference),
    and both against the frequency-domain RAO (within the 2 % of the head-sea checks, roll included)."""
    period, heading = 2.5, 30.0
    omega = 2 * math.pi / period
    _, rao = bem.response_amplitude_operator(ds, slab_rigid_box(STIFF).box().rigid_mass_matrix(), heading, [omega])
    t, xi, _, _ = cosimulate_barge(bodies["stiff"], period, heading)
    xr = cosimulate_platform(slab_rigid_box(STIFF), period, heading)
    a = HEIGHT / 2
    print(f"\nstiff barge vs rigid Platform, heading {heading:g} deg, T = {period} s:")
    for d, name in enumerate(("surge", "sway", "heave", "roll", "pitch", "yaw")):
        zb, zr = steady_amplitude(t, xi[:, d], omega) / a, steady_amplitude(t, xr[:, d], omega) / a
        ref = rao[0, d]
        print(f"  {name}: barge {abs(zb):.4f}, rigid {abs(zr):.4f}, difference {100 * abs(zb - zr) / abs(zr):.3f} %;"
              f" frequency domain {abs(ref):.4f} (barge {100 * abs(zb - ref) / abs(ref):.2f} %, rigid "
              f"{100 * abs(zr - ref) / abs(ref):.2f} %)")
        assert abs(zb - zr) / abs(zr) < 0.005, name
        assert abs(zb - ref) / abs(ref) < 0.02, name


@pytest.mark.parametrize("field, value, allowed", [("thickness", 0.0, "> 0"), ("nu", 0.5, "0 <= nu < 0.5"),
                                                   ("elements", (4, 2), "three integers"), ("E", -1.0, "> 0")])
def test_bad_barge_parameters_name_the_field_and_its_range(field, value, allowed):
    from flexfmu.wec.barge import slab_mesh
    with pytest.raises(ParameterError, match=rf"{field}: got .*allowed: {allowed}"):
        slab_mesh(BargeParameters(**{field: value}))


def test_deck_gauge_sits_inside_the_slab_clear_of_the_mount_patch_and_reads_a_cell():
    """make_barge.py's default gauge: midship, a quarter beam off the centreline, under the deck, inside the slab and
    outside the mount's deck patch (whose RBE3 load would dominate a gauge inside it); flexfmu.body.stress finds it."""
    from flexfmu.body.stress import gauge_from_text, locate_gauges
    from flexfmu.wec.barge import deck_gauge

    p = BargeParameters()
    name, _, text = deck_gauge(p).partition("=")
    x, y, z = (float(v) for v in text.split(","))
    assert name == "deck"
    assert abs(x) < p.box.length / 2 and abs(y) < p.box.beam / 2
    assert p.z_center - p.thickness / 2 < z < p.z_center + p.thickness / 2
    assert max(abs(x - p.mount[0]), abs(y - p.mount[1])) > p.deck_patch
    with tempfile.TemporaryDirectory() as tmp:
        structure = barge_structure(p, tmp)
    located = locate_gauges(structure, [gauge_from_text(deck_gauge(p))])
    assert len(located) == 1
