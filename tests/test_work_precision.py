"""Building blocks of the work-precision study (flexfmu.studies.work_precision) and the
`flexfmu bench <study>` dispatcher.  Fast: small models, short records; no timing is asserted."""
from __future__ import annotations

import math

import numpy as np
import pytest

from flexfmu import cli
from flexfmu.errors import ParameterError

from error_bounds import gamma


@pytest.fixture(scope="module")
def wp():
    from flexfmu.studies import work_precision
    return work_precision


def test_error_norm_is_zero_against_itself_and_relative_to_the_peak(wp):
    t = np.linspace(0.0, 1.0, 101)
    u_ref = np.column_stack([np.sin(2 * np.pi * t), 0.5 * np.cos(2 * np.pi * t), 0.0 * t])   # peak |u_ref| = 1
    assert wp.relative_max_error(u_ref, u_ref) == 0.0
    shifted = u_ref + np.array([0.0, 0.0, 0.003])
    # |(0, 0, 0.003)| (u_ref z is exactly 0: square, sum, sqrt: 3 roundings) over the peak sqrt(sin^2 + cos^2 / 4)
    # at t = 0.25 (sin/cos <= 1 ulp each, squares, sum, sqrt: 5), the division (1): gamma(10), over-counted
    assert wp.relative_max_error(shifted, u_ref) == pytest.approx(0.003, rel=gamma(10), abs=0)
    assert wp.relative_max_error(2.0 * u_ref + np.array([0.0, 0.003, 0.0]), 2.0 * u_ref) == pytest.approx(0.0015)
    nan = u_ref.copy()
    nan[50, 1] = np.nan
    assert wp.relative_max_error(nan, u_ref) == math.inf           # a diverged run is an infinite error
    with pytest.raises(ParameterError, match="u_ref"):
        wp.relative_max_error(u_ref, 0.0 * u_ref)
    with pytest.raises(ParameterError, match="shape"):
        wp.relative_max_error(u_ref[:-1], u_ref)


def test_observed_order_and_efficient_front(wp):
    dts = [4e-4, 2e-4, 1e-4]
    assert wp.observed_order(dts, [3.0 * d**4 for d in dts]) == pytest.approx(4.0)
    assert wp.observed_order(dts, [0.1, math.nan, 0.0]) is None
    a = wp.Point("modes", "m", 4, "4", 0.0, 1.0, 1e-3)
    b = wp.Point("modes", "m", 6, "6", 0.0, 1.1, 1e-4)       # more accurate than a at ~ its CPU time
    c = wp.Point("modes", "m", 8, "8", 0.0, 2.0, 1e-5)
    assert wp.dominated_by(a, [a, b, c]) is b
    assert wp.dominated_by(b, [a, b, c]) is None
    assert wp.dominated_by(c, [a, b, c]) is None


def test_ffr_hammer_error_against_the_independent_reference_shrinks_at_second_order(wp):
    """The FFR step with the hammer force held at its mid-step value converges to the Radau solution of the
    same equations with the continuous force at second order (the hold's order), and the reference is
    resolved far below that."""
    cfg = wp._ffr_config(2, 3)
    t_end, out = 4e-3, 5e-4
    ref = wp.ffr_reference(cfg, t_end, wp.hammer_input, out, (wp.HAMMER_PULSE,))
    assert np.max(np.abs(ref)) > 1e-6                         # the blow moves the tip
    errors = [wp.relative_max_error(wp.run_ffr(cfg, dt, t_end, wp.hammer_input, out), ref)
              for dt in (1e-4, 5e-5, 2.5e-5)]
    assert errors[0] < 5e-2
    orders = [math.log2(errors[k] / errors[k + 1]) for k in range(2)]
    assert all(1.8 < p < 2.2 for p in orders), (errors, orders)
    loose = wp.ffr_reference(cfg, t_end, wp.hammer_input, out, (wp.HAMMER_PULSE,), rtol=1e-8)
    assert wp.relative_max_error(loose, ref) < 1e-2 * errors[-1]


def test_reframe_rod_error_shrinks_with_the_time_step(wp):
    """Rod case building blocks: elastic deflection of the loaded free end against a finer step; the
    consistent scheme is fourth order there, the fixed-frame baseline is not closer than it."""
    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.integrator import FixedFrameBaseline, ReframeIntegrator

    bc = wp.rod_case(quick=True)
    structure = bc.build(2)
    basis = modal_basis(structure, 2, bc.damping)
    integ = ReframeIntegrator(structure, basis)
    load, node = bc.load(structure), bc.node(structure)
    t_end = 0.02
    ref = wp.run_reframe(integ, t_end, 1e-3 / 64, load, node, 1e-3)
    assert np.max(np.abs(ref)) > 1e-7
    errors = [wp.relative_max_error(wp.run_reframe(integ, t_end, dt, load, node, 1e-3), ref)
              for dt in (5e-4, 2.5e-4)]
    assert errors[1] < errors[0] / 8.0, errors
    baseline = wp.run_baseline(FixedFrameBaseline(structure, basis), t_end, 2.5e-4, load, node, 1e-3)
    assert wp.relative_max_error(baseline, ref) > errors[1]


def test_bench_defaults_to_performance_and_dispatches_by_name():
    parser = cli.build_parser()
    assert parser.parse_args(["bench"]).study == "performance"                 # backward compatible
    args = parser.parse_args(["bench", "work-precision", "--quick", "--out", "-"])
    assert (args.study, args.quick, args.out) == ("work-precision", True, "-")
    with pytest.raises(SystemExit):
        parser.parse_args(["bench", "no-such-study"])


def test_bench_names_a_missing_study_file(monkeypatch, capsys):
    monkeypatch.setitem(cli.BENCH_STUDIES, "spinup", "no_such_study_file")
    assert cli.main(["bench", "spinup"]) == 2
    err = capsys.readouterr().err
    assert "bench spinup" in err and "flexfmu.studies.no_such_study_file" in err
