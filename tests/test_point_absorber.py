"""The point absorber (examples/point_absorber, flexfmu.wec.absorber; the lead's specification /work/pa_spec.md):

- the co-simulation through the library master in regular waves, heave only, no drag, no mooring, against the
  frequency-domain prediction of the same BEM database (flexfmu.wec.absorber.frequency_domain) within 1 % in mean
  PTO power and heave amplitude at the example's step.  Error budget (measured, examples/point_absorber/README.md):
  the Gauss-Seidel coupling's first-order error of the held loads, 1.07 % of the power per 10 ms at T = 5 s (0.54 %
  at 5 ms, 2.15 % at 20 ms), 0.67 % at the example's 6.25 ms; the radiation fit's own, the step -> 0 limit, <= 0.02 %;
- SplitMix64 against its published first outputs (Vigna's splitmix64.c, seed 0), and the wave's phases from it;
- JONSWAP: 4 sqrt(sum S_k dw) = Hs to rounding, the shape against DNV-RP-C205's closed form (its own normalisation
  A_gamma = 1 - 0.287 ln gamma) up to a constant, and that constant against the band's quadrature within the midpoint
  rule's error bound;
- the float's energy balance d(kinetic) = sum of work_* to rounding (six DOFs, drag, mooring, a JONSWAP sea);
- the SSP written from the OSP file is the same system (the library master runs both to the same bits);
- bad parameters: one ParameterError naming the parameter.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("capytaine")

from flexfmu.cosim.masters import load_system, run, with_assignments                     # noqa: E402
from flexfmu.errors import ParameterError                                                 # noqa: E402
from flexfmu.wec.absorber import frequency_domain as fd                                   # noqa: E402
from flexfmu.wec.absorber.float_body import GROUPS                                        # noqa: E402
from flexfmu.wec.absorber.hull import absorber_hull                                       # noqa: E402
from flexfmu.wec.absorber.verification import SYSTEM_FILE, regular_wave_check            # noqa: E402
from flexfmu.wec.absorber.wave import (AbsorberWaveConfig, AbsorberWaveSimulator, jonswap_shape,  # noqa: E402
                                       sea_components, splitmix64, splitmix64_uniforms)

#: the example's communication step (its BaseStepSize)
STEP = 0.00625
#: near the optimal damping at 8 s (frequency_domain.optimal_damping: 6.12e5 N s/m)
DAMPING = 6.0e5


@pytest.fixture(scope="module")
def hull():
    return absorber_hull()


def test_example_step_is_the_measured_one():
    assert load_system(SYSTEM_FILE).base_step == STEP


@pytest.mark.parametrize("period", [5.0, 8.0, 12.0])
def test_regular_wave_power_and_heave_within_one_percent_of_the_frequency_domain(period):
    r = regular_wave_check(period, height=1.0, damping=DAMPING, step=STEP)
    assert abs(r["power_error"]) < 0.01, r
    assert abs(r["amplitude_error"]) < 0.01, r
    # the error is the coupling's, first order in the step: not a cancellation of larger errors
    assert r["power_error"] > 0 and r["amplitude_error"] > 0, r


def test_jonswap_record_mean_power_and_heave_variance_against_the_spectral_prediction(hull):
    """Over exactly one record length 2 pi / dw the components are orthogonal (at (m + 1/2) dw): the mean power and
    the heave variance equal their spectral sums whatever the phases, up to the coupling's error, which in regular
    waves is <= 0.67 % at this step over the spectrum's band (a 320 s record here; benchmarks/point_absorber_checks.py
    runs 20-minute records of three seeds: +0.22 % in power)."""
    from flexfmu.wec.absorber.verification import SETTLE_TIME, linear_system
    record, ramp, hs, tp = 320.0, 20.0, 2.0, 8.0          # 2.5 record / Tp = 100 components: dw = 2 pi / record
    system = linear_system(("wave.sea_state=jonswap", f"wave.wave_height={hs}", f"wave.wave_period={tp}", "wave.seed=2",
                            "wave.n_components=0", f"wave.record_length={record}", f"wave.ramp_time={ramp}",
                            f"pto.damping={DAMPING}", "pto.stiffness=0"))
    t0 = ramp + SETTLE_TIME
    result = run(system, t0 + record, STEP, scheme="gauss-seidel", backend="library")
    i0 = int(np.argmin(np.abs(result.t - t0)))
    sel = slice(i0, i0 + int(round(record / STEP)))
    sea = sea_components(AbsorberWaveConfig(sea_state="jonswap", wave_height=hs, wave_period=tp,
                                            record_length=record))
    assert sea.dw == pytest.approx(2 * math.pi / record, rel=1e-12)
    power = fd.spectral_mean_power(hull, sea.omega, sea.density, sea.dw, DAMPING)
    variance = float(np.sum(np.abs(fd.heave_rao(hull, sea.omega, DAMPING)) ** 2 * sea.density * sea.dw))
    assert np.mean(result.columns["pto.power"][sel]) == pytest.approx(power, rel=0.01)
    assert np.var(result.columns["float.pos_z"][sel]) == pytest.approx(variance, rel=0.01)


def test_splitmix64_matches_its_published_outputs():
    assert splitmix64(0, 3) == [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F]
    u = splitmix64_uniforms(0, 3)
    assert u == [(z >> 11) * 2.0**-53 for z in (0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F)]
    assert all(0.0 <= x < 1.0 for x in u)
    sea = sea_components(AbsorberWaveConfig(sea_state="jonswap", seed=0, n_components=3))
    assert sea.phase.tolist() == [2 * math.pi * x for x in u]


@pytest.mark.parametrize("hs, tp, gamma", [(2.5, 8.0, 3.3), (1.0, 10.0, 1.0), (4.0, 6.0, 7.0)])
def test_jonswap_normalisation_and_shape_against_dnv(hs, tp, gamma):
    sea = sea_components(AbsorberWaveConfig(sea_state="jonswap", wave_height=hs, wave_period=tp, gamma=gamma))
    w, S, dw = sea.omega, sea.density, sea.dw
    assert 4 * math.sqrt(np.sum(S * dw)) == pytest.approx(hs, rel=1e-14)
    assert 4 * math.sqrt(np.sum(sea.amplitude**2 / 2)) == pytest.approx(hs, rel=1e-14)
    # DNV-RP-C205 (2010) eq. 3.5.5: S_J = A_gamma S_PM gamma^exp(-0.5 ((w - wp) / (sigma wp))^2),
    # S_PM = 5/16 Hs^2 wp^4 w^-5 exp(-5/4 (w / wp)^-4)
    wp = 2 * math.pi / tp

    def dnv(x):
        sigma = np.where(x <= wp, 0.07, 0.09)
        return ((1 - 0.287 * math.log(gamma)) * 5 / 16 * hs**2 * wp**4 * x**-5 * np.exp(-1.25 * (x / wp) ** -4)
                * gamma ** np.exp(-0.5 * ((x - wp) / (sigma * wp)) ** 2))
    ratio = S / dnv(w)
    assert np.ptp(ratio) <= 1e-12 * ratio.mean()                 # the same shape, to rounding
    # the constant: ours normalises the discrete band (midpoint rule over the bins) to (Hs / 4)^2, so against the
    # band's integral of the DNV form it is 1 within the midpoint rule's error (b - a) dw^2 max|f''| / 24
    x = np.linspace(0.5 * wp, 3 * wp, 400001)
    f = dnv(x)
    integral = np.trapezoid(f, x)
    curvature = np.max(np.abs(np.gradient(np.gradient(f, x), x)))
    bound = 2.5 * wp * dw**2 * curvature / 24 / integral
    assert ratio.mean() * integral / (hs / 4) ** 2 == pytest.approx(1.0, abs=bound + 1e-9)
    assert bound < 0.01                                          # a check that can tell a wrong factor
    assert np.allclose(jonswap_shape(w, wp, gamma) / dnv(w), (jonswap_shape(w, wp, gamma) / dnv(w))[0], rtol=1e-12)


def test_wave_outputs_are_the_specified_sums(hull):
    cfg = AbsorberWaveConfig(sea_state="jonswap", wave_height=2.0, wave_period=9.0, n_components=50, seed=7,
                             ramp_time=10.0)
    sim = AbsorberWaveSimulator(cfg)
    sea = sim.sea
    X = np.array([[np.interp(w, hull.omega, hull.X[:, i].real) + 1j * np.interp(w, hull.omega, hull.X[:, i].imag)
                   for i in range(6)] for w in sea.omega])
    for t in (0.0, 3.0, 10.0, 123.4):
        sim.t = t
        out = sim.outputs()
        r = 0.5 * (1 - math.cos(math.pi * t / 10.0)) if t < 10.0 else 1.0
        arg = sea.omega * t - sea.phase
        assert out["elevation"] == pytest.approx(r * np.sum(sea.amplitude * np.cos(arg)), abs=1e-12)
        for i, name in enumerate(("F_x", "F_y", "F_z", "M_x", "M_y", "M_z")):
            ref = r * np.sum(sea.amplitude * np.abs(X[:, i]) * np.cos(arg - np.angle(X[:, i])))
            assert out[name] == pytest.approx(ref, rel=1e-12, abs=1e-9 * np.abs(X[:, 2]).max())


def test_float_energy_balance_to_rounding():
    system = with_assignments(load_system(SYSTEM_FILE), (
        "wave.sea_state=jonswap", "wave.wave_height=2.0", "wave.wave_period=9.0", "wave.n_components=100",
        "wave.ramp_time=5", "float.heave_only=false", "hydro.drag=true", "mooring.enabled=true"))
    result = run(system, 30.0, STEP, scheme="gauss-seidel", backend="library")
    c = result.columns
    ke = c["float.kinetic_energy"]
    works = np.array([c[f"float.work_{g}"] for g in GROUPS])
    gross = np.sum(np.abs(works[:, -1])) + abs(ke[-1])
    assert gross > 1e5                                             # the loads did work
    # each step adds rounding of ~eps of the terms: n steps x 16 eps is a generous bound
    n = len(result.t) - 1
    residual = np.abs(ke - ke[0] - np.sum(works - works[:, :1], axis=0))
    assert residual.max() <= n * 16 * np.finfo(float).eps * gross


def test_ssp_from_the_osp_file_is_the_same_system(tmp_path):
    from xml.etree import ElementTree as ET

    from flexfmu.cosim.ssp import load_ssp, ssd_tree
    osp = with_assignments(load_system(SYSTEM_FILE), ("mooring.enabled=false", "wave.ramp_time=1"))
    (tmp_path / "SystemStructure.ssd").write_bytes(ET.tostring(ssd_tree(osp), encoding="utf-8"))
    ssp = load_ssp(tmp_path)
    assert ssp.base_step == osp.base_step
    assert [(s.name, s.model, s.initial_values) for s in ssp.simulators] == \
        [(s.name, s.model, s.initial_values) for s in osp.simulators]
    assert sorted(ssp.connections) == sorted(osp.connections)
    a = run(osp, 2.0, None, scheme="gauss-seidel", backend="library")
    b = run(ssp, 2.0, None, scheme="gauss-seidel", backend="library")
    for key in a.columns:
        assert np.array_equal(a.columns[key], b.columns[key]), key


@pytest.mark.parametrize("model, values, name", [
    ("wave", {"wave_period": 0.5}, "wave_period"),
    ("wave", {"sea_state": "jonswap", "wave_period": 2.0}, "wave_period"),
    ("wave", {"sea_state": "storm"}, "sea_state"),
    ("wave", {"seed": -1}, "seed"),
    ("wave", {"n_components": 5001}, "n_components"),
    ("wave", {"sea_state": "jonswap", "record_length": 1e6}, "record_length"),
    ("wave", {"gamma": 0.5}, "gamma"),
    ("hydro", {"drag_area_z": -1.0}, "drag_area_z"),
    ("hydro", {"drag_coefficient_x": float("nan")}, "drag_coefficient_x"),
    ("pto", {"damping": -1.0}, "damping"),
    ("pto", {"force_limit": -1.0}, "force_limit"),
    ("pto", {"stiffness": float("inf")}, "stiffness"),
])
def test_bad_parameters_name_themselves(model, values, name):
    from flexfmu.wec.absorber import hydro, pto, wave
    module, config, simulator = {"wave": (wave, "AbsorberWaveConfig", "AbsorberWaveSimulator"),
                                 "hydro": (hydro, "AbsorberHydroConfig", "AbsorberHydroSimulator"),
                                 "pto": (pto, "HeavePTOConfig", "HeavePTOSimulator")}[model]
    with pytest.raises(ParameterError) as info:
        getattr(module, simulator)(getattr(module, config)(**values))
    assert info.value.parameter == name and info.value.allowed


def test_frequency_domain_power_is_maximal_at_the_optimal_damping(hull):
    c = fd.optimal_damping(hull, 8.0)
    p = [fd.regular_wave_response(hull, 1.0, 8.0, k * c)[1] for k in (0.9, 1.0, 1.1)]
    assert p[1] > p[0] and p[1] > p[2]
