"""The C reframe kernels (flexfmu/native/csrc/reframe_kernels.c through flexfmu.native.reframe) against their
numpy reference (flexfmu.reframe.kernels_numpy) and the Python scalar helpers (kernels_numpy; the rotation
formulas of flexfmu.core.rotation): every public
kernel (steps, outputs, max elastic displacement search) on random data and on real models (the default
ReframeBody plate, a free body with interfaces, the bent rod with geometric stiffness), both schemes, and the
binding's contract (fresh arrays, in-place changes seen, conversions, threads, errors, a C caller of the header).

C and numpy evaluate the same formulas in different operation orders: their states and output vectors are
compared within the a-priori rounding bounds of tests/reframe_bounds.py (gamma of the longest rounding chain x
the size of the terms x the mass matrix's condition x the step map's growth, computed from each case's data;
formerly 1e-12 relative, read off one machine: measured 3.2e-15 (steps) and 6.2e-14 (free-body outputs)).
Where C repeats itself (the same compiled code on the same data) or a Python helper performs the same IEEE
operations in the same order, equality is exact.
"""
from __future__ import annotations

import math
import subprocess
import threading
from types import SimpleNamespace

import numpy as np
import pytest

from error_bounds import U, gamma
from flexfmu.core import rotation
from flexfmu.reframe import kernels as K
from flexfmu.reframe import kernels_numpy as KN
from reframe_bounds import outputs_bound, steps_bound
from flexfmu.reframe.layout import output_layout, param_layout

pytestmark = pytest.mark.skipif(not K.NATIVE, reason=f"C reframe kernels not available: {K.NATIVE_REASON}")

#: the numpy kernels under the names of the C ones
NP = SimpleNamespace(**{name: getattr(K, name + "_numpy") for name in ("reframe_steps", "reframe_outputs",
                                                                       "consistent_steps", "consistent_outputs")})


def _ratio(a, b, bound) -> float:
    """max |a - b| / bound (<= 1: within the bound)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape and bound > 0
    return float(np.max(np.abs(a - b), initial=0.0)) / bound


@pytest.fixture(scope="module")
def C():
    from flexfmu.native import reframe
    reframe.library()
    return reframe


# --------------------------------------------------------------------------- kernel argument sets
class Case:
    """One set of kernel arguments: P, LP, G, EX (empty: none / RK4), nf, deformed, SV, held, dt, n, y, PP,
    Psi, dpn, umax (order, bc, br, sc, sr)."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def steps(self, kernels, **over):
        a = {**self.__dict__, **over}
        return kernels.reframe_steps(a["P"], a["LP"], a["G"], a["EX"], a["nf"], a["deformed"], a["SV"], a["held"],
                                     a.get("t", 0.25), a["dt"], a["n"], a["y"])

    def outputs(self, kernels, y, sv, search=True):
        umax = self.umax if search else (np.zeros(0, dtype=np.int64),) + tuple(self.umax[1:])
        return kernels.reframe_outputs(self.P, self.LP, self.G, self.nf, self.deformed, sv, y, self.PP, self.Psi,
                                       self.dpn, *umax)

    def steps_bound(self, y_ref, n=None, **over):
        """What may separate two implementations' states after n steps (tests/reframe_bounds.py)."""
        a = {**self.__dict__, **over}
        n = a["n"] if n is None else n
        return steps_bound(a["P"], a["LP"], a["G"], a["EX"], a["nf"], a["SV"], a["dt"], n, a["y"], y_ref)

    def outputs_bound(self, y, sv, o_ref):
        """What may separate two implementations' output vectors of state y (tests/reframe_bounds.py)."""
        return outputs_bound(self.P, self.LP, self.G, self.nf, sv, y, self.PP, self.Psi, self.dpn, o_ref)


def _from_integrator(integ, loads, dt, n, state, points, deformed=True):
    from flexfmu.reframe.results import _state_vector
    SV, held = loads.stage_values(state.t, dt, n)
    ka = integ.kernel_arguments(loads, dt, np.asarray(points, dtype=np.int64))
    return Case(P=ka.P, LP=ka.LP, G=ka.G, EX=ka.EX, nf=ka.nf, deformed=deformed, SV=SV, held=held, dt=dt, n=n,
                y=_state_vector(state).copy(), PP=ka.PP, Psi=ka.Psi, dpn=ka.dpn, umax=ka.umax)


@pytest.fixture(scope="module")
def plate_cases():
    """The default ReframeBody plate (51k DOF, 10 flexible modes, the paper's load point) spinning, with
    the force held: exponential (the FMU default) and consistent (RK4) steps."""
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
    sim = ReframeBodySimulator(ReframeBodyConfig(omega0_1=0.3, omega0_2=-0.2, omega0_3=1.0, v0_x=0.1))
    sim.set_inputs(F_x=3.0, F_y=-2.0, F_z=50.0)
    integ = sim.integrator
    expo = _from_integrator(integ, sim._loads, 1e-3, 40, sim.state, sim._points)
    rk4 = Case(**{**expo.__dict__, "EX": np.zeros(0), "dt": 2e-5})
    return {"plate exponential": expo, "plate consistent": rk4}


@pytest.fixture(scope="module")
def beam_cases():
    """The bent rod (6 DOF per node) with a random geometric stiffness, a global load with a moment and a
    follower load, both half-sine pulses (load values per step, not held), both schemes."""
    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, half_sine_pulse
    from flexfmu.reframe.models import load_model
    beam = load_model("beam:spatial_double_L", elements_per_segment=4)
    rng = np.random.default_rng(51)
    G = 1e3 * rng.standard_normal((3, 3, 3, 3))
    G = 0.5 * (G + G.transpose(1, 0, 2, 3))
    out = {}
    for scheme, dt, n in (("exponential", 1e-3, 40), ("consistent", 5e-5, 200)):
        integ = ReframeIntegrator(beam, modal_basis(beam, 3), scheme=scheme, geometric_stiffness=G)
        s = integ.initial_state(omega0=(5.0, 2.0, 8.0), qd0=(1e-3, -2e-3, 1e-3))
        loads = integ.prepare_loads([PointLoad(12, half_sine_pulse([1.0, 0.0, 1.0], 0.005), moment=[0.0, 0.01, 0.0]),
                                     PointLoad(3, half_sine_pulse([0.0, 2.0, 0.5], 0.004), follower=True)])
        out[f"beam G {scheme}"] = _from_integrator(integ, loads, dt, n, s, [0, 7, 12])
        assert out[f"beam G {scheme}"].G.size and not out[f"beam G {scheme}"].held
    return out


@pytest.fixture(scope="module")
def free_cases():
    """A free body (flexfmu.body.free: the plate with two interfaces, modes to 200 Hz plus residual vectors,
    24 flexible coordinates), spinning, forces and moments held at both interfaces, both schemes."""
    from flexfmu.body.build import build_body
    from flexfmu.body.free import FreeDynamics
    from flexfmu.reframe.models import load_model
    plate = load_model("paper_plate", divisions=(8, 2, 1))
    body = build_body(plate, interfaces=[{"name": "A", "point": [-0.5, 0.0, 0.01]},
                                         {"name": "B", "point": [0.5, 0.0, 0.0], "radius": 0.03}],
                      f_max=200.0, tolerance=1e-3)
    ifs = body.interfaces
    out = {}
    for scheme, dt, n in (("exponential", 5e-4, 40), ("consistent", 2e-6, 100)):
        dyn = FreeDynamics(body.arrays, body.eigenvalues, 0.02, scheme, [i.rows for i in ifs],
                           [i.point for i in ifs], [i.moments for i in ifs])
        SV = np.zeros((1, 3, len(ifs), 6))
        SV[0, :, 0] = [10.0, -5.0, 30.0, 0.1, 0.2, -0.3]
        SV[0, :, 1] = [-4.0, 8.0, 1.0, -0.2, 0.0, 0.5]
        y = dyn.initial_state(np.array([0.1, 0.0, -0.2]), np.array([2.0, -1.0, 3.0]))
        EX = dyn._coefficients(dt) if scheme == "exponential" else np.zeros(0)
        out[f"free body {scheme}"] = Case(P=dyn.P, LP=dyn.LP, G=np.zeros(0), EX=EX, nf=dyn.nf, deformed=dyn.deformed,
                                          SV=SV, held=True, dt=dt, n=n, y=y, PP=dyn.PP, Psi=dyn.Psi, dpn=3,
                                          umax=dyn.umax, dyn=dyn)
    return out


def _random_case(nf: int, n_loads: int, rng, scheme: str, n_points: int = 3) -> Case:
    """Random but well-posed arguments: a positive mass matrix (small A_j, B_j, C_jk, D_j), a random rotation,
    random modal state, follower and global loads with and without rotational rows, random load values per
    step, a random geometric stiffness, exponential coefficients of random stiffness and damping."""
    from flexfmu.reframe.kernel_data import max_displacement_blocks
    from flexfmu.reframe.schemes import exponential_coefficients
    lay = param_layout(nf)
    P = np.zeros(lay.end)
    P[0] = 2.0 + rng.random()
    J0 = rng.standard_normal((3, 3))
    P[lay.J0:lay.A] = (J0 @ J0.T + 3 * np.eye(3)).ravel()
    P[lay.A:lay.B] = 0.05 * rng.standard_normal(9 * nf)
    B = 0.05 * rng.standard_normal((nf, 3, 3))
    P[lay.B:lay.C] = (B + B.transpose(0, 2, 1)).ravel()
    C = 0.02 * rng.standard_normal((nf, nf, 3, 3))
    P[lay.C:lay.D] = (0.5 * (C + C.transpose(1, 0, 3, 2))).ravel()              # C_kj = C_jk^T
    P[lay.D:lay.k] = 0.05 * rng.standard_normal(3 * nf * nf)
    kF = (2 * math.pi * rng.uniform(50, 400, nf)) ** 2
    cF = 0.04 * np.sqrt(kF)
    P[lay.k:lay.c], P[lay.c:lay.A6] = kF, cF
    A6 = np.eye(6) + 0.1 * rng.standard_normal((6, 6))
    P[lay.A6:lay.A6inv] = A6.ravel()
    P[lay.A6inv:lay.com] = np.linalg.inv(A6).ravel()
    P[lay.com:lay.end] = 0.1 * rng.standard_normal(3)
    blocks = []
    for i in range(n_loads):
        blocks.append(np.concatenate([[float(i % 2), float(i % 3 != 0)], rng.standard_normal(3),
                                      rng.standard_normal(3 * nf), rng.standard_normal(3 * nf) * (i % 3 != 0)]))
    LP = np.concatenate(blocks) if blocks else np.zeros(0)
    n = 7
    SV = rng.standard_normal((n, 3, n_loads, 6))
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    eta = np.zeros(2 * (6 + nf))
    eta[6:6 + nf] = 1e-3 * rng.standard_normal(nf)
    eta[6 + nf:] = rng.standard_normal(6 + nf) * np.r_[np.ones(6), 1e-1 * np.ones(nf)]
    y = np.concatenate([rng.standard_normal(3), Q.ravel(), eta])
    G = rng.standard_normal((3, 3, nf, nf))
    G = (0.5 * (G + G.transpose(1, 0, 2, 3))).ravel() if nf else np.zeros(0)
    dt = 2e-4 if scheme == "exponential" else 1e-5
    EX = exponential_coefficients(kF, cF, dt).reshape(-1) if scheme == "exponential" else np.zeros(0)
    n_nodes = 50
    nodes = rng.standard_normal((n_nodes, 3))
    dpn = 6
    Psi = np.zeros((dpn * n_nodes, 6 + nf))
    Psi[:, 6:] = rng.standard_normal((dpn * n_nodes, nf))
    trans_rows = (np.arange(n_nodes)[:, None] * dpn + np.arange(3)).astype(np.int64)
    umax = max_displacement_blocks(SimpleNamespace(nodes=nodes, n_nodes=n_nodes, Psi=Psi, nf=nf,
                                                   trans_rows=trans_rows), K.BLOCK)
    PP = np.concatenate([rng.standard_normal((n_points, 3)), rng.standard_normal((n_points, 3 * nf))], axis=1)
    return Case(P=P, LP=LP, G=G, EX=EX, nf=nf, deformed=bool(nf % 2), SV=SV, held=False, dt=dt, n=n, y=y,
                PP=np.ascontiguousarray(PP), Psi=Psi, dpn=dpn, umax=umax)


# --------------------------------------------------------------------------- comparisons
def _compare(case: Case, C) -> dict:
    """Steps, outputs (with and without the search) of C and numpy from the same arguments; |C - numpy| over
    the rounding bound of each (tests/reframe_bounds.py)."""
    y_c, t_c, k_c, st_c = case.steps(C)
    y_n, t_n, k_n, st_n = case.steps(NP)
    assert (k_c, st_c) == (k_n, st_n) == (case.n, 0)
    assert t_c == t_n
    assert np.max(np.abs(y_n - case.y)) > 1e-9                            # it moved
    sv = case.SV[-1, 2]
    diffs = {"steps": _ratio(y_c, y_n, case.steps_bound(y_n))}
    for search in (True, False):
        o_c = case.outputs(C, y_n, sv, search)
        o_n = case.outputs(NP, y_n, sv, search)
        diffs["outputs" if search else "outputs (no search)"] = _ratio(o_c, o_n, case.outputs_bound(y_n, sv, o_n))
        umax_at = output_layout(case.nf, case.PP.shape[0]).max_elastic_displacement
        assert o_c.size == o_n.size == output_layout(case.nf, case.PP.shape[0]).size
        if not search:
            assert o_c[umax_at] == K.NOT_COMPUTED == -1.0
        elif case.nf:
            assert o_c[umax_at] > 0.0
    # consistent_* (no G) are reframe_* with empty G
    if case.G.size == 0:
        args = (case.P, case.LP, case.nf, case.deformed, case.SV, case.held, 0.25, case.dt, case.n, case.y)
        y2 = C.consistent_steps(*args)[0] if case.EX.size == 0 else None
        if y2 is not None:            # identity: consistent_steps calls the same compiled step with G empty
            assert np.array_equal(y2, y_c)
        out_args = (case.P, case.LP, case.nf, case.deformed, sv, y_n, case.PP, case.Psi, case.dpn, *case.umax)
        # identity: consistent_outputs is the same compiled output kernel with G empty
        assert np.array_equal(C.consistent_outputs(*out_args), case.outputs(C, y_n, sv))
        o_n = K.consistent_outputs_numpy(*out_args)
        assert _ratio(C.consistent_outputs(*out_args), o_n, case.outputs_bound(y_n, sv, o_n)) <= 1.0
    return diffs


@pytest.mark.parametrize("name", ["plate exponential", "plate consistent"])
def test_plate_model_c_equals_numpy(plate_cases, C, name):
    diffs = _compare(plate_cases[name], C)
    print(f"\n{name}: C vs numpy {diffs}")
    assert max(diffs.values()) <= 1.0, diffs        # |C - numpy| / bound


@pytest.mark.parametrize("name", ["beam G exponential", "beam G consistent"])
def test_bent_rod_with_geometric_stiffness_c_equals_numpy(beam_cases, C, name):
    diffs = _compare(beam_cases[name], C)
    print(f"\n{name}: C vs numpy {diffs}")
    assert max(diffs.values()) <= 1.0, diffs        # |C - numpy| / bound


@pytest.mark.parametrize("name", ["free body exponential", "free body consistent"])
def test_free_body_c_equals_numpy(free_cases, C, name):
    case = free_cases[name]
    diffs = _compare(case, C)
    print(f"\n{name}: C vs numpy {diffs}")
    assert max(diffs.values()) <= 1.0, diffs        # |C - numpy| / bound
    # through FreeDynamics (the body FMU's path), which picks the kernels of flexfmu.reframe.kernels
    dyn = case.dyn
    y, t, k, st = dyn.steps(case.y, 0.0, case.dt, 5, case.SV)
    y_n = K.reframe_steps_numpy(case.P, case.LP, np.zeros(0), case.EX, case.nf, case.deformed, case.SV, True,
                                0.0, case.dt, 5, case.y)[0]
    assert (k, st) == (5, 0) and _ratio(y, y_n, case.steps_bound(y_n, n=5)) <= 1.0
    o_n = K.consistent_outputs_numpy(case.P, case.LP, case.nf, case.deformed, case.SV[0, 0], y, case.PP, case.Psi, 3,
                                     *case.umax)
    assert _ratio(dyn.outputs(y, case.SV), o_n, case.outputs_bound(y, case.SV[0, 0], o_n)) <= 1.0


@pytest.mark.parametrize("nf, n_loads", [(0, 2), (1, 1), (3, 0), (3, 3), (7, 4)])
@pytest.mark.parametrize("scheme", ["exponential", "consistent"])
def test_random_data_c_equals_numpy(C, nf, n_loads, scheme):
    rng = np.random.default_rng(1000 * nf + 10 * n_loads + (scheme == "consistent"))
    case = _random_case(nf, n_loads, rng, scheme)
    if nf == 0:                     # no flexible modes: the state still moves (rigid body); no search
        y_c, t_c, k_c, st_c = case.steps(C)
        y_n, t_n, k_n, st_n = case.steps(NP)
        assert (k_c, st_c, t_c) == (k_n, st_n, t_n) and _ratio(y_c, y_n, case.steps_bound(y_n)) <= 1.0
        o_c, o_n = case.outputs(C, y_n, case.SV[-1, 2]), case.outputs(NP, y_n, case.SV[-1, 2])
        assert _ratio(o_c, o_n, case.outputs_bound(y_n, case.SV[-1, 2], o_n)) <= 1.0
        assert o_c[output_layout(0, 3).max_elastic_displacement] == 0.0
        return
    diffs = _compare(case, C)
    assert max(diffs.values()) <= 1.0, diffs        # |C - numpy| / bound
    # without geometric stiffness and without the deformed arm: the other branches
    case.G, case.deformed = np.zeros(0), not case.deformed
    diffs = _compare(case, C)
    assert max(diffs.values()) <= 1.0, diffs        # |C - numpy| / bound


# --------------------------------------------------------------------------- status, time and in-place semantics
def test_non_finite_loads_and_state_report_the_same_step_as_numpy(C):
    rng = np.random.default_rng(3)
    case = _random_case(3, 2, rng, "consistent")
    SV = case.SV.copy()
    SV[4, 1, 0, 2] = np.nan                                # the loads of step 4
    y_c, t_c, k_c, st_c = case.steps(C, SV=SV)
    y_n, t_n, k_n, st_n = case.steps(NP, SV=SV)
    assert (k_c, st_c) == (k_n, st_n) == (4, 1) and t_c == t_n
    assert _ratio(y_c, y_n, case.steps_bound(y_n, n=4)) <= 1.0           # 4 steps done
    # held loads not finite: nothing done
    y_c, t_c, k_c, st_c = case.steps(C, SV=SV[4:5], held=True)
    assert (k_c, st_c, t_c) == (0, 1, 0.25) and np.array_equal(y_c, case.y)
    # a state that overflows: status 2 at that step, t includes it
    y = case.y.copy()
    y[12 + 6 + 3 + 1] = 1e300                             # a huge rigid velocity
    y_c, t_c, k_c, st_c = case.steps(C, y=y)
    assert (k_c, st_c) == (0, 2) and t_c == 0.25 + case.dt and not np.all(np.isfinite(y_c))
    with np.errstate(all="ignore"):
        try:
            numpy_result = case.steps(NP, y=y)[2:]
        except ValueError:                    # math.sin(inf) in the numpy Rodrigues: the integrator's callers
            numpy_result = (0, 2)             # treat it as the non-finite state it is
    assert numpy_result == (0, 2)
    # n = 0: the state as given
    y_c, t_c, k_c, st_c = case.steps(C, n=0)
    assert (k_c, st_c, t_c) == (0, 0, 0.25) and np.array_equal(y_c, case.y)


def test_time_is_advanced_by_repeated_addition_as_numpy(C):
    case = _random_case(2, 1, np.random.default_rng(4), "consistent")
    for t0, dt in ((0.1, 1e-3), (1.0 / 3.0, 1e-5 / 3.0)):
        assert case.steps(C, t=t0, dt=dt)[1] == case.steps(NP, t=t0, dt=dt)[1]


def test_results_are_fresh_arrays_and_inputs_are_not_written(C, plate_cases):
    case = plate_cases["plate exponential"]
    y0 = case.y.copy()
    SV0 = case.SV.copy()
    y1 = case.steps(C)[0]
    y2 = case.steps(C)[0]
    assert np.array_equal(case.y, y0) and np.array_equal(case.SV, SV0)
    assert y1 is not y2 and np.array_equal(y1, y2) and y1.flags.writeable and y1.flags.c_contiguous
    assert y1.dtype == np.float64 and y1.shape == y0.shape
    # views of a result have it as their base (flexfmu.reframe.results._state_vector reuses such states)
    assert y1[0:3].base is y1 and y1[12:].base is y1
    o1 = case.outputs(C, y1, case.SV[0, 0])
    o2 = case.outputs(C, y1, case.SV[0, 0])
    assert o1 is not o2 and np.array_equal(o1, o2)
    o1[:] = 0.0
    assert not np.array_equal(o1, o2)


def test_arrays_changed_in_place_are_seen(C):
    """The bindings remember the model arrays' addresses, not their values: a change in place (the held loads,
    damping in P) is used by the next call."""
    case = _random_case(3, 2, np.random.default_rng(5), "consistent")
    SV = case.SV[:1].copy()
    before = case.steps(C, SV=SV, held=True)[0]
    SV[0, :, 1, 0] += 5.0
    after = case.steps(C, SV=SV, held=True)[0]
    assert not np.array_equal(before, after)
    y_n = case.steps(NP, SV=SV, held=True)[0]
    assert _ratio(after, y_n, case.steps_bound(y_n, SV=SV)) <= 1.0
    lay = param_layout(3)
    P = case.P.copy()
    first = case.steps(C, P=P)[0]
    P[lay.c:lay.A6] *= 3.0
    second = case.steps(C, P=P)[0]
    assert not np.array_equal(first, second)
    y_n = case.steps(NP, P=P)[0]
    assert _ratio(second, y_n, case.steps_bound(y_n, P=P)) <= 1.0


def test_non_contiguous_and_other_dtype_inputs_are_converted(C):
    case = _random_case(3, 2, np.random.default_rng(6), "exponential")
    ref_y = case.steps(C)[0]
    ref_o = case.outputs(C, ref_y, case.SV[-1, 2])

    def strided(a):
        b = np.empty((a.size, 2))
        b[:, 0] = a.ravel()
        return b[:, 0].reshape(a.shape)

    y_s = strided(case.y)
    assert not y_s.flags.c_contiguous
    got = case.steps(C, P=strided(case.P), LP=strided(case.LP), G=strided(case.G),
                     EX=strided(case.EX), SV=np.asfortranarray(case.SV), y=y_s)[0]
    assert np.array_equal(got, ref_y)
    sv = np.asfortranarray(case.SV[-1, 2].T).T
    o = C.reframe_outputs(case.P, case.LP, case.G, np.int64(case.nf), case.deformed, sv,
                          ref_y.astype(np.longdouble) if hasattr(np, "longdouble") else ref_y, strided(case.PP),
                          np.asfortranarray(case.Psi), np.int64(case.dpn), case.umax[0].astype(np.int32),
                          *case.umax[1:])
    assert np.array_equal(o, ref_o)


def test_inconsistent_sizes_are_refused(C):
    case = _random_case(3, 2, np.random.default_rng(7), "exponential")
    with pytest.raises(ValueError, match="P has"):
        case.steps(C, P=case.P[:-1].copy())
    with pytest.raises(ValueError, match="LP"):
        case.steps(C, LP=case.LP[:-1].copy())
    with pytest.raises(ValueError, match="EX"):
        case.steps(C, EX=case.EX[:-2].copy())
    with pytest.raises(ValueError, match="G has"):
        case.steps(C, G=case.G[:-1].copy())
    with pytest.raises(ValueError, match="SV"):
        case.steps(C, SV=case.SV[:, :, :1].copy())
    with pytest.raises(ValueError, match="rows"):
        case.steps(C, n=case.SV.shape[0] + 1)
    with pytest.raises(ValueError, match="y has"):
        case.steps(C, y=case.y[:-1].copy())


def test_threads_use_their_own_workspace(C, plate_cases, beam_cases):
    cases = [plate_cases["plate exponential"], beam_cases["beam G consistent"]]
    want = [c.steps(C)[0] for c in cases]
    errors = []

    def run(i):
        try:
            for _ in range(20):
                if not np.array_equal(cases[i % 2].steps(C)[0], want[i % 2]):
                    errors.append(i)
        except Exception as exc:          # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not errors


# --------------------------------------------------------------------------- search and helpers
def test_max_elastic_displacement_search_equals_all_nodes(C, plate_cases):
    case = plate_cases["plate exponential"]
    order, bc, br, sc, sr = case.umax
    rng = np.random.default_rng(8)
    nf = case.nf
    rows = (case.dpn * np.arange(case.Psi.shape[0] // case.dpn)[:, None] + np.arange(3)).ravel()
    for q in [rng.standard_normal(nf), np.eye(nf)[0], np.eye(nf)[nf - 1], np.full(nf, 1e-4), np.zeros(nf)]:
        c = C.max_node_norm(case.Psi, 6, case.dpn, order, bc, br, sc, sr, q)
        blocks = KN.max_node_norm_blocks(case.Psi, 6, case.dpn, order, bc, br, sc, sr, q)
        full = K.max_node_norm_numpy(case.Psi, 6, case.dpn, order, bc, br, sc, sr, q)
        # identity: the plain-Python search performs the C search's operations in the same order (node sums
        # j = 0..nf-1 from 0.0, then u0^2 + u1^2 + u2^2, sqrt; the same bounds): the same maximum bit for bit
        assert c == blocks
        # numpy (BLAS, any order): each node norm within gamma_{nf+4} of the norm of (|Phi_i| |q|) [ASNA 3.5]
        terms = np.abs(case.Psi[rows, 6:6 + nf]) @ np.abs(q)
        assert abs(c - full) <= 2 * gamma(nf + 4) * float(np.max(np.linalg.norm(terms.reshape(-1, 3), axis=1)))
    assert C.max_node_norm(case.Psi, 6, case.dpn, order, bc, br, sc, sr, np.zeros(0)) == 0.0
    # the bound and one block's norm: identity with the Python reference (the same sums in the same order)
    q = rng.standard_normal(nf)
    qn = float(np.linalg.norm(q))
    for b in (0, 3, bc.shape[0] - 1):
        assert C.bound(bc, br, b, q, qn) == KN._bound(bc, br, b, q, qn)
        assert C.block_norm(case.Psi, 6, case.dpn, order, b, q, 0.0) == \
            KN._block_norm(case.Psi, 6, case.dpn, order, b, q, 0.0)
    for s in (0, sc.shape[0] - 1):
        assert C.bound(sc, sr, s, q, qn) == KN._bound(sc, sr, s, q, qn)


def _mp_rodrigues(phi):
    """exp(skew(phi)) of the double phi (taken exactly) at 40 digits."""
    import mpmath
    with mpmath.workdps(40):
        x, y, z = (mpmath.mpf(float(v)) for v in phi)
        th2 = x * x + y * y + z * z
        th = mpmath.sqrt(th2)
        a = mpmath.sin(th) / th if th else mpmath.mpf(1)
        b = (1 - mpmath.cos(th)) / th2 if th else mpmath.mpf(0.5)
        R = [1 + b * (x * x - th2), -a * z + b * x * y, a * y + b * x * z,
             a * z + b * x * y, 1 + b * (y * y - th2), -a * x + b * y * z,
             -a * y + b * x * z, a * x + b * y * z, 1 + b * (z * z - th2)]
        return np.array([float(r) for r in R]), float(a), float(b), float(th)


def _mp_rate_coefficient(th):
    import mpmath
    with mpmath.workdps(40):
        t = mpmath.mpf(float(th))
        if t == 0:
            return 1.0 / 12.0
        h = t / 2
        return float((1 - h * mpmath.cos(h) / mpmath.sin(h)) / (t * t))


def test_scalar_helpers_equal_the_python_ones(C):
    """Rodrigues, the rotation-vector rate coefficient and the quaternion, C and Python, against 40-digit
    mpmath values within their rounding bounds (libm sin, cos, atan2 within 1 ulp = 2u relative: an assumption
    on the C library, met by glibc, musl and Apple's libm; C and Python may call it differently, e.g. gcc's
    sin + cos -> sincos); solve3 exactly (the same IEEE operations in the same order, no libm)."""
    rng = np.random.default_rng(9)
    for th in [0.0, 1e-12, 5e-5, 1e-4, 2e-4, 0.05, 0.1, 0.3, 1.0, 2.5, np.pi, 6.0]:
        lam = rng.normal(size=3)
        phi = th * lam / np.linalg.norm(lam)
        R = np.empty(9)
        rotation.rodrigues_into(phi, R)
        R_mp, a, b, th_mp = _mp_rodrigues(phi)
        # entries 1 + b (x^2 - th^2), +-a z + b x y: a = sin/th within gamma_4 |a| (series: + th^6/5040), b th^2 =
        # (1 - cos) th^2/th2 within 2u (cos's ulp) + gamma_4 |b| th^2 (series: + th^6/40320), products and sums of
        # terms of size <= 1 + |a| th + 2 |b| th^2: gamma_6 of that [ASNA 3.1]
        bound = (gamma(4) * abs(a) * th_mp + 2 * U + gamma(4) * abs(b) * th_mp ** 2 + th_mp ** 6 / 5040
                 + gamma(6) * (1 + abs(a) * th_mp + 2 * abs(b) * th_mp ** 2))
        assert np.max(np.abs(C.rodrigues(phi) - R_mp)) <= bound
        assert np.max(np.abs(R - R_mp)) <= bound
        # c = (1 - t)/th^2, t = h cos h / sin h within gamma_6 |t| (cos, sin 2u each, product, quotient); 1 - t, th^2
        # and the quotient gamma_3 |c|; the series (th < 0.1) within gamma_8 |c| + its tail <= 2 th^8 / 47900160
        th_f = float(np.linalg.norm(phi))
        c_mp = _mp_rate_coefficient(th_f)
        if th_f >= 0.1:
            t = 0.5 * th_f / math.tan(0.5 * th_f)
            c_bound = (gamma(6) * abs(t) + U * abs(1 - t)) / th_f ** 2 + gamma(3) * abs(c_mp)
        else:
            c_bound = gamma(8) * abs(c_mp) + 2 * th_f ** 8 / 47900160
        assert abs(C.rate_coefficient(th_f) - c_mp) <= c_bound
        assert abs(rotation.rotvec_rate_coefficient(th_f) - c_mp) <= c_bound
        _check_quaternion(C, R)
    for _ in range(20):
        S = rng.standard_normal((3, 3))
        r = rng.standard_normal(3)
        # identity: elimination with partial pivoting, the same operations in the same order in C (compiled with
        # -ffp-contract=off) and Python, no libm: bit for bit
        assert np.array_equal(C.solve3(S, r), KN._solve3(S, r))
    # the four quaternion branches (largest diagonal element)
    for axis in range(3):
        phi = np.zeros(3)
        phi[axis] = 3.0
        R = np.empty(9)
        rotation.rodrigues_into(phi, R)
        _check_quaternion(C, R)
    for nf in (0, 1, 4, 9, 30):
        assert C.offsets(nf) == tuple(param_layout(nf))


def _check_quaternion(C, R):
    """C's quaternion is Python's branch formula re-normalised through the rotation vector (2 atan2(n, w), then
    cos, sin of the half angle): mathematically Q / |Q| for Python's Q.  Each side: sqrt(>= 1) and (R_ij +- R_ji)
    / (4 w), w >= 1/4, gamma_4 relative on components <= 1; the re-normalisation <= 12 roundings and 3 libm calls
    (1 ulp) on quantities <= 1: gamma_18.  So |C - Python| <= | |Q| - 1 | + gamma_4 + gamma_18 per component
    (|Q| computed, its own rounding gamma_4)."""
    Q = rotation.quaternion_from_rotation(R.reshape(3, 3))
    assert np.max(np.abs(C.quaternion(R.reshape(3, 3)) - Q)) <= abs(np.linalg.norm(Q) - 1.0) + 2 * gamma(4) + gamma(18)


# --------------------------------------------------------------------------- the header as a C caller sees it
_C_CALLER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "reframe_kernels.h"

int main(int argc, char **argv)
{
    int nf = atoi(argv[1]), n_loads = atoi(argv[2]), n = atoi(argv[3]), done = -1, status, i;
    int off[FFX_REFRAME_N_OFFSETS];
    size_t np_ = FFX_REFRAME_PARAM_SIZE(nf), nlp = (size_t)n_loads * FFX_REFRAME_LOAD_STRIDE(nf);
    size_t nsv = (size_t)n * 3 * n_loads * 6, nex = 24 * (size_t)nf, ny = FFX_REFRAME_STATE_SIZE(nf);
    double *P = malloc(np_ * sizeof(double)), *LP = malloc((nlp + 1) * sizeof(double));
    double *SV = malloc((nsv + 1) * sizeof(double)), *EX = malloc((nex + 1) * sizeof(double));
    double *y = malloc(ny * sizeof(double)), *work = malloc(FFX_REFRAME_WORK_SIZE(nf) * sizeof(double));
    double t, dt;
    FILE *f = fopen(argv[4], "rb");
    if (ffx_reframe_abi_version() != FFX_REFRAME_ABI_VERSION)
        return 3;
    if (fread(P, sizeof(double), np_, f) != np_ || fread(LP, sizeof(double), nlp, f) != nlp
        || fread(SV, sizeof(double), nsv, f) != nsv || fread(EX, sizeof(double), nex, f) != nex
        || fread(y, sizeof(double), ny, f) != ny || fread(&t, sizeof(double), 1, f) != 1
        || fread(&dt, sizeof(double), 1, f) != 1)
        return 4;
    fclose(f);
    ffx_reframe_offsets(nf, off);
    printf("%d %d %d\n", off[FFX_REFRAME_O_END], (int)FFX_REFRAME_PARAM_SIZE(nf), off[FFX_REFRAME_O_A6]);
    status = ffx_reframe_steps(P, LP, n_loads, NULL, EX, nf, 1, SV, 0, &t, dt, n, y, &done, work);
    printf("%d %d %.17g\n", status, done, t);
    for (i = 0; i < (int)ny; i++)
        printf("%.17g\n", y[i]);
    return 0;
}
"""


def test_a_c_program_calls_the_header_as_documented(C, tmp_path):
    """The header is the contract of native callers (the FMI bridge): a C program that includes it, sizes its
    arrays with its macros and calls ffx_reframe_steps gets the numbers of the Python bindings."""
    from flexfmu.native.compiler import CSRC, KERNEL_FLAGS, find_compiler
    case = _random_case(4, 2, np.random.default_rng(10), "exponential")
    data = tmp_path / "case.bin"
    np.concatenate([case.P, case.LP, case.SV.ravel(), case.EX, case.y, [0.5, case.dt]]).astype("<f8").tofile(data)
    exe = tmp_path / "caller"
    src = tmp_path / "caller.c"
    src.write_text(_C_CALLER)
    subprocess.run([find_compiler(), *KERNEL_FLAGS, f"-I{CSRC}", str(src), str(CSRC / "reframe_kernels.c"),
                    str(CSRC / "lti_kernels.c"), "-o", str(exe), "-lm"], check=True, capture_output=True)
    lines = subprocess.run([str(exe), "4", "2", str(case.n), str(data)], check=True, capture_output=True,
                           text=True).stdout.split("\n")
    end, size, a6 = map(int, lines[0].split())
    assert end == size == param_layout(4).end and a6 == param_layout(4).A6
    status, done, t = lines[1].split()
    y = np.array([float(v) for v in lines[2:2 + case.y.size]])
    y_py, t_py, k_py, st_py = C.reframe_steps(case.P, case.LP, np.zeros(0), case.EX, 4, True, case.SV, False, 0.5,
                                              case.dt, case.n, case.y)
    assert (int(status), int(done), float(t)) == (st_py, k_py, t_py) == (0, case.n, t_py)
    assert np.array_equal(y, y_py)


# ------------------------------------------------------------------------- exponential-scheme coefficients
#: the six 2x2 matrices of schemes.exponential_coefficients as combinations of the blocks e^Z, phi_1, phi_2, phi_3
#: of one augmented exponential: (fraction of dt in Z, factor in units of dt, [(block, coefficient)])
_EX_MATS = [(1.0, 0.0, [(0, 1.0)]), (0.5, 0.0, [(0, 1.0)]), (0.5, 0.5, [(1, 1.0)]),
            (1.0, 1.0, [(1, 1.0), (2, -3.0), (3, 4.0)]), (1.0, 1.0, [(2, 2.0), (3, -4.0)]),
            (1.0, 1.0, [(3, 4.0), (2, -1.0)])]


def _exponential_coefficients_mp(k, c, dt):
    """The exponential-scheme coefficients of the C port with every exponential in mpmath (40 digits), from the
    same double 8x8 matrices W the C code forms (the same IEEE operations, so the same bits), in the balanced
    coordinates (omega q, p) the port computes them in, and each balanced entry's error bound for a double
    port (error_bounds.expm_error_bound eps_W of the two exponentials, then the combinations):

    * the combination h sum_b c_b X_b of the blocks X_b = X[0:2, 2b:2b+2] of one exponential: its error is
      h X_err[0:2, :] (c kron I_2), of 2-norm <= h ||c||_2 eps_W (bounding every entry); t terms add t + 1
      roundings: + gamma_{t+1} h sum |c_b| |X_b|_ij;
    * the port's scaling back to (q, p) and the test's scaling forward again (by s = sqrt(k), exactly as the
      port forms it): two roundings, 2u |entry|; the reference rounded to double: u |entry|.

    Returns (s (nf,), balanced reference (nf, 6, 2, 2) as doubles, bound (nf, 6, 2, 2))."""
    import mpmath
    from error_bounds import U, expm_error_bound, gamma, mp_expm
    k = np.asarray(k, float)
    c = np.asarray(c, float)
    ref = np.zeros((k.size, 6, 2, 2))
    bound = np.zeros_like(ref)
    scales = np.zeros(k.size)
    with mpmath.workdps(40):
        for j in range(k.size):
            w = math.sqrt(k[j]) if k[j] > 0.0 else 0.0
            s = scales[j] = w if w > 0.0 else 1.0
            L = np.array([[0.0, s], [-k[j] / s, -c[j]]])
            blocks, eps_w = {}, {}
            for frac in (1.0, 0.5):
                W = np.zeros((8, 8))
                W[0:2, 0:2] = (frac * dt) * L
                for b in range(3):
                    W[2 * b:2 * b + 2, 2 * b + 2:2 * b + 4] = np.eye(2)
                X = mp_expm(W)
                blocks[frac] = [X[0:2, 2 * b:2 * b + 2] for b in range(4)]
                eps_w[frac] = expm_error_bound(W)
            for m, (frac, hf, terms) in enumerate(_EX_MATS):
                h = hf * dt if hf else 1.0
                M = sum((coef * blocks[frac][b] for b, coef in terms), mpmath.zeros(2, 2)) * h
                ref[j, m] = np.array(M.tolist(), float)
                absum = sum(abs(coef) * np.abs(np.array(blocks[frac][b].tolist(), float)) for b, coef in terms)
                norm_c = math.sqrt(sum(coef ** 2 for _, coef in terms))
                bound[j, m] = h * norm_c * eps_w[frac] + gamma(len(terms) + 1) * h * absum + 3 * U * np.abs(ref[j, m])
    return scales, ref, bound


@pytest.mark.parametrize("dt", [1e-5, 1e-4, 1e-3, 2.5e-3])
def test_exponential_coefficients_equal_the_extended_precision_reference(C, dt):
    """ffx_reframe_exponential_coefficients (ffx_lti_expm of the 8x8 augmented blocks) against the same
    coefficients with the exponentials in mpmath at 40 digits, entry by entry in the balanced coordinates
    (omega q, p) within the a-priori bound of a double-precision Pade-13 scaling and squaring
    (error_bounds.expm_error_bound, _exponential_coefficients_mp): the paper plate's 10 modes (25 .. 577 Hz,
    5 % damping) and modes from zero stiffness to 1e7 rad^2/s^2.  (Formerly against scipy.linalg.expm with 5e-13
    read off one machine: scipy is itself a double expm with errors of that order, and they depend on the BLAS.)"""
    from flexfmu.native import reframe as native
    from flexfmu.reframe import schemes
    from flexfmu.reframe.simulator import ReframeBodySimulator

    integ = ReframeBodySimulator().integrator
    cases = [(integ._kF, integ._cF),
             (np.array([0.0, 1.0, 4e2, 3.7e5, 1e7]), np.array([0.0, 0.1, 2.0, 60.0, 3e2]))]
    for k, c in cases:
        s, ref, bound = _exponential_coefficients_mp(k, c, dt)
        a = native.exponential_coefficients(k, c, dt)
        a[:, :, 0, 1] *= s[:, None]                       # to the balanced coordinates (omega q, p)
        a[:, :, 1, 0] /= s[:, None]
        err = np.abs(a - ref)
        size = np.abs(ref).max(axis=(2, 3))
        print(f"\ndt {dt}: max |C - mp| / bound {np.max(err / bound):.3g}; relative to each matrix: "
              f"max |C - mp| {np.max(err.max(axis=(2, 3)) / size):.3g}, bound <= {np.max(bound.max(axis=(2, 3)) / size):.3g}")
        assert np.all(err <= bound), (dt, np.max(err / bound))
    # the library's entry point takes the C port when the C kernels are in use
    assert np.array_equal(schemes.exponential_coefficients(integ._kF, integ._cF, dt),
                          native.exponential_coefficients(integ._kF, integ._cF, dt)) or not K.NATIVE


def test_exponential_coefficients_of_no_modes_and_bad_steps():
    from flexfmu.errors import ParameterError
    from flexfmu.native import reframe as native
    assert native.exponential_coefficients([], [], 1e-3).shape == (0, 6, 2, 2)
    with pytest.raises(ParameterError, match="dt"):
        native.exponential_coefficients([1e4], [1.0], float("nan"))
