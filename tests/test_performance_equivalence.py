"""The fast paths compute the same numbers as the definitions (speed is measured in benchmarks/,
never asserted here):

* the consistent reframe step in modal space (invariants + step kernel) against the same scheme written
  in physical space (nodal vectors, the full M), and the paper scheme's modal frame transformation
  sum R_ab Psi^T M E_ab Psi against rotating every nodal triplet and expanding back;
* the C kernels (flexfmu.native.reframe) against their numpy versions, in process and with
  FLEXFMU_NATIVE_KERNELS=0 (tests/test_native_reframe_kernels.py compares them kernel by kernel);
* the exact max elastic displacement search against all nodes;
* FFRBeam's cached affine step / output maps against the term-by-term formulas.

Two implementations of one computation are compared within a-priori rounding bounds computed from the data
(tests/error_bounds.py, tests/reframe_bounds.py), never within a tolerance read off one machine.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from error_bounds import gamma, implementations_bound
from reframe_bounds import ops_stage, outputs_bound, steps_bound

from flexfmu.reframe import kernels as K
from flexfmu.core.structure import N_RIGID
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.models import load_model
from flexfmu.reframe.plate import paper_plate
from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, ReframeState, half_sine_pulse
from flexfmu.reframe.layout import output_layout, param_layout
from flexfmu.reframe.results import _state_vector

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def plate():
    return paper_plate((20, 2, 1))


@pytest.fixture(scope="module")
def beam():
    return load_model("beam:spatial_double_L", elements_per_segment=4)


# --------------------------------------------------------------------------- physical-space reference
def _rodrigues(phi):
    th = float(np.linalg.norm(phi))
    Kx = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if th < 1e-12:
        return np.eye(3) + Kx
    return np.eye(3) + math.sin(th) / th * Kx + (1 - math.cos(th)) / th**2 * Kx @ Kx


def _rotvec_rate(phi, w):
    th = float(np.linalg.norm(phi))
    pxw = np.cross(phi, w)
    c = 1 / 12 + th**2 / 720 if th < 1e-3 else (1 - 0.5 * th / math.tan(0.5 * th)) / th**2
    return w + 0.5 * pxw + c * np.cross(phi, pxw)


class PhysicalStep:
    """The consistent scheme (docs/reframe.md) evaluated with nodal vectors and the full mass matrix:
    the generalised mass matrix B^T M B with B = [T | S(X - c + Phi q) | Phi], dT/dq_j = (omega x phi_j)^T M w."""

    def __init__(self, integ: ReframeIntegrator):
        d = integ.data
        self.d, self.deformed = d, integ.deformed_load_arm
        self.M = d.M.toarray() if d.n_dof <= 4000 else d.M
        nd = d.n_dof
        self.T = np.zeros((nd, 3))
        for k in range(3):
            self.T[d.trans_rows[:, k], k] = 1.0

    def B(self, q):
        d = self.d
        y = d.Xc + (d.Phi @ q)[d.trans_rows]
        S = np.zeros((d.n_dof, 3))
        for k in range(3):
            S[d.trans_rows, k] = np.cross(np.eye(3)[k], y)
            if d.rot_rows is not None:
                S[d.rot_rows[:, k], k] = 1.0
        return np.hstack([self.T, S, d.Phi])

    def rhs(self, t, z, Rn, loads):
        d = self.d
        nf = d.nf
        phi = z[0:3]
        Rrel = _rodrigues(phi)
        R = Rn @ Rrel
        q, pq = z[12:12 + nf], z[12 + nf:]
        B = self.B(q)
        Mm = B.T @ (self.M @ B)
        xi = np.linalg.solve(Mm, np.concatenate([R.T @ z[6:9], Rrel.T @ z[9:12], pq]))
        v, w, qd = xi[:3], xi[3:6], xi[6:]
        Mw = self.M @ (B @ xi)
        U = d.Phi[d.trans_rows]                                     # (N, 3, nf)
        dTdq = np.einsum("nc,ncj->j", Mw[d.trans_rows], np.cross(w[None, :, None], U, axis=1))
        F_g, N_b, Q = np.zeros(3), np.zeros(3), np.zeros(nf)
        for ld in loads.items:
            f, m = ld.force(t), ld.moment(t)
            f_b, m_b = (f, m) if ld.follower else (R.T @ f, R.T @ m)
            F_g += R @ f_b
            rows = d.trans_rows[ld.node]
            arm = d.Xc[ld.node] + (d.Phi[rows] @ q if self.deformed else 0.0)
            N_b += np.cross(arm, f_b)
            Q += d.Phi[rows].T @ f_b
            if d.rot_rows is not None:
                N_b += m_b
                Q += d.Phi[d.rot_rows[ld.node]].T @ m_b
        p_b = R.T @ z[6:9]
        return np.concatenate([_rotvec_rate(phi, w), R @ v, F_g, Rrel @ (N_b - np.cross(v, p_b)), qd,
                               dTdq - d.kq[N_RIGID:] * q - d.cq[N_RIGID:] * qd + Q])

    def step(self, s, dt, loads):
        d = self.d
        nm, nf = d.n_modes, d.nf
        vw = d.A6 @ s.eta[nm:nm + N_RIGID]
        q, qd = s.eta[N_RIGID:nm], s.eta[nm + N_RIGID:]
        B = self.B(q)
        pi = B.T @ (self.M @ (B @ np.concatenate([vw, qd])))
        Rn = s.rotation
        z0 = np.concatenate([np.zeros(6), Rn @ pi[:3], pi[3:6], q, pi[6:]])
        k1 = self.rhs(s.t, z0, Rn, loads)
        k2 = self.rhs(s.t + 0.5 * dt, z0 + 0.5 * dt * k1, Rn, loads)
        k3 = self.rhs(s.t + 0.5 * dt, z0 + 0.5 * dt * k2, Rn, loads)
        k4 = self.rhs(s.t + dt, z0 + dt * k3, Rn, loads)
        z = z0 + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        Rrel = _rodrigues(z[0:3])
        R = Rn @ Rrel
        R = 1.5 * R - 0.5 * R @ R.T @ R
        q1 = z[12:12 + nf]
        B = self.B(q1)
        xi = np.linalg.solve(B.T @ (self.M @ B), np.concatenate([R.T @ z[6:9], Rrel.T @ z[9:12], z[12 + nf:]]))
        eta = np.concatenate([np.zeros(N_RIGID), q1, d.A6inv @ xi[:6], xi[6:]])
        return ReframeState(t=s.t + dt, position=s.position + z[3:6], rotation=R, eta=eta)


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(np.asarray(b))), 1e-300))


@pytest.mark.parametrize("model", ["plate", "beam"])
def test_modal_step_equals_physical_space_step(model, plate, beam):
    structure, n, dt = (plate, 4, 2e-4) if model == "plate" else (beam, 3, 5e-5)
    integ = ReframeIntegrator(structure, modal_basis(structure, n))
    rng = np.random.default_rng(6)
    s = integ.initial_state(v0=(0.3, -0.2, 0.1), omega0=(5.0, 2.0, 8.0), q0=1e-5 * rng.standard_normal(n),
                            qd0=1e-3 * rng.standard_normal(n))
    node = structure.points["load"] if model == "plate" else structure.nodes.shape[0] - 1
    loads = [PointLoad(node, half_sine_pulse([30.0, 10.0, 30.0], 0.002)),
             PointLoad(0, [0.0, 5.0, -3.0], follower=True,
                       moment=(lambda t: np.array([0.1, 0.0, 0.2 * t])) if model == "beam" else None)]
    prepared = integ.prepare_loads(loads)
    ref = PhysicalStep(integ)
    s_mod = s_phy = s
    for _ in range(10):
        s_mod = integ.advance(s_mod, dt, prepared)
        s_phy = ref.step(s_phy, dt, prepared)
    errs = [_rel(s_mod.eta, s_phy.eta), _rel(s_mod.rotation, s_phy.rotation),
            _rel(s_mod.position - s.position, s_phy.position - s.position)]
    # two implementations of the same scheme: the a-priori bound of tests/reframe_bounds.py for the kernels (the
    # states [position, R, eta]), its rounding chain lengthened by what the physical step adds per stage: B xi,
    # M (B xi), B^T (..) and B^T M B, generously 3 n_dof + nf + 6 each, x 5 stages (the terms' size is the same
    # as the modal invariants': |B|^T |M| |B| <= the mass matrix's diagonal scale by Cauchy-Schwarz)
    ka = integ.kernel_arguments(prepared, dt, np.array([node], dtype=np.int64))
    SV, _ = prepared.stage_values(s.t, dt, 10)
    y0, y_mod, y_phy = (_state_vector(x).copy() for x in (s, s_mod, s_phy))
    ops = 5 * ops_stage(ka.nf, len(prepared.items), bool(ka.G.size))
    bound = (steps_bound(ka.P, ka.LP, ka.G, ka.EX, ka.nf, SV, dt, 10, y0, y_mod)
             * gamma(ops + 5 * (3 * integ.data.n_dof + ka.nf + 6)) / gamma(ops))
    diff = float(np.max(np.abs(y_mod - y_phy)))
    print(f"\n{model}: modal vs physical-space step, 10 steps: eta {errs[0]:.1e}, R {errs[1]:.1e}, "
          f"position {errs[2]:.1e} (relative); max |state difference| {diff:.1e} <= bound {bound:.1e}")
    assert diff <= bound
    # batched steps are the same steps
    s_batch = integ.advance_steps(s, dt, 10, prepared)
    # identity: advance is advance_steps(.., 1), the same step kernel on the same numbers in the same order
    assert np.array_equal(s_batch.eta, s_mod.eta) and s_batch.t == s_mod.t
    # output point velocity (modal output kernel) = the node's velocity from the nodal state (physical)
    snap = integ.snapshot(s_mod, prepared, np.array([node]))
    nodal = integ.nodal_state(s_mod)
    # the output kernel vs the nodal expansion Psi eta, rotated: the output bound of tests/reframe_bounds.py (its
    # rounding chain, 2 ops_stage + 3 nf + 20, covers the nodal path's nm + 16; its scale the terms |v| +
    # |w| |X + Phi q| + |Phi| |qdot| and |position| + |X + Phi q|)
    o_ref = integ.output_vector(s_mod, prepared, np.array([node], dtype=np.int64))
    o_bound = outputs_bound(ka.P, ka.LP, ka.G, ka.nf, SV[-1, 2], y_mod, ka.PP, ka.Psi, ka.dpn, o_ref)
    assert np.max(np.abs(snap.point_velocity[0] - nodal.velocity[integ.data.trans_rows[node]])) <= o_bound
    assert np.max(np.abs(snap.point_position[0] - nodal.positions[node])) <= o_bound


def test_paper_transformation_modal_equals_physical(plate):
    integ = ReframeIntegrator(plate, modal_basis(plate, 4), scheme="paper")
    d = integ.data
    nm = d.n_modes
    rng = np.random.default_rng(7)
    eta, incr = rng.standard_normal(2 * nm), 1e-2 * rng.standard_normal(2 * nm)
    R = _rodrigues(np.array([0.3, -0.2, 0.5]))
    modal = integ.stepper._paper_transform(eta, incr, R)
    qt = eta[:nm] + incr[:nm]
    qt[:N_RIGID] = eta[:N_RIGID]
    qdt = eta[nm:] + incr[nm:]
    phys, terms = [], []
    absPsi, absM, absR = np.abs(d.Psi), abs(d.M), np.abs(R)
    for y in (qt, qdt):
        x = d.Psi @ y
        xr = (x.reshape(-1, 3) @ R.T).ravel()           # every translational triplet rotated (3-DOF nodes)
        phys.append(d.Psi.T @ (d.M @ xr))               # inverse modal expansion (Eqs. 30-31, M_q = I)
        terms.append(absPsi.T @ (absM @ ((absPsi @ np.abs(y)).reshape(-1, 3) @ absR.T).ravel()))
    # two groupings of the same products (sum_ab R_ab (Psi^T M E_ab Psi) q with the invariants formed once, and
    # Psi^T M rot_R(Psi q)): each within gamma_ops of the terms' size |Psi|^T |M| rot_|R|(|Psi| |q|); ops
    # generously 3 n_dof + 9 nm + 16 (the n_dof-long products with Psi and M, the 9-term sum over ab, the
    # nm-long product with q, each counted in full)
    bound = implementations_bound(np.concatenate(terms), 3 * d.n_dof + 9 * nm + 16)
    assert np.all(np.abs(modal - np.concatenate(phys)) <= bound)


def test_max_elastic_displacement_search_is_exact(plate):
    integ = ReframeIntegrator(plate, modal_basis(plate, 10))
    rng = np.random.default_rng(8)
    for q in [rng.standard_normal(10), np.eye(10)[0], np.eye(10)[9], np.full(10, 1e-4), np.zeros(10)]:
        all_nodes = float(np.max(np.linalg.norm((integ.data.Phi @ q)[integ.data.trans_rows], axis=1)))
        assert abs(integ._max_elastic_displacement(q) - all_nodes) <= _max_norm_bound(integ, q)


def _max_norm_bound(integ, q) -> float:
    """Two evaluations of max_i |Phi_i q| (the search's dot products vs numpy's Phi @ q): each component within
    gamma_nf (|Phi_i| |q|), the 3-norm adds gamma_4 of it; a max moves no more than its arguments:
    2 gamma_{nf + 4} max_i | |Phi_i| |q| | [ASNA 3.1, 3.5]."""
    terms = (np.abs(integ.data.Phi) @ np.abs(q))[integ.data.trans_rows]
    return 2 * gamma(len(q) + 4) * float(np.max(np.linalg.norm(terms, axis=1)))


# --------------------------------------------------------------------------- C kernels vs numpy
def _kernel_case(beam):
    integ = ReframeIntegrator(beam, modal_basis(beam, 3))
    s = integ.initial_state(omega0=(5.0, 2.0, 8.0), qd0=(1e-3, -2e-3, 1e-3))
    loads = integ.prepare_loads(PointLoad(beam.nodes.shape[0] - 1, half_sine_pulse([1.0, 0.0, 1.0], 0.005),
                                          moment=[0.0, 0.01, 0.0]))
    return integ, s, loads


@pytest.mark.skipif(not K.NATIVE, reason="C kernels not available: the numpy versions are the only ones")
def test_c_kernels_equal_numpy_versions(beam):
    integ, s, loads = _kernel_case(beam)
    dt, n = 5e-5, 200
    SV, held = loads.stage_values(s.t, dt, n)
    y0 = np.concatenate((s.position, s.rotation.ravel(), s.eta))
    pts = np.array([0, 7], dtype=np.int64)
    ka = integ.kernel_arguments(loads, dt, pts)
    args = (ka.P, ka.LP, ka.nf, True, SV, held, 0.0, dt, n, y0)
    y_c, t_c, k_c, st_c = K.consistent_steps(*args)
    y_np, t_np, k_np, st_np = K.consistent_steps_numpy(*args)
    assert (k_c, st_c, t_c) == (k_np, st_np, t_np) == (n, 0, t_c)
    # C and numpy: the same formulas in different operation orders, within the a-priori bounds of
    # tests/reframe_bounds.py (as tests/test_native_reframe_kernels.py; consistent_*: G and EX empty)
    none = np.zeros(0)
    assert np.max(np.abs(y_c - y_np)) <= steps_bound(ka.P, ka.LP, none, none, ka.nf, SV, dt, n, y0, y_np)
    out_args = (ka.P, ka.LP, ka.nf, True, SV[-1, 2], y_c, ka.PP, ka.Psi, ka.dpn, *ka.umax)
    o_np = K.consistent_outputs_numpy(*out_args)
    o_bound = outputs_bound(ka.P, ka.LP, none, ka.nf, SV[-1, 2], y_c, ka.PP, ka.Psi, ka.dpn, o_np)
    assert np.max(np.abs(K.consistent_outputs(*out_args) - o_np)) <= o_bound
    # an empty node order skips the max elastic displacement search: -1 there, every other output unchanged
    skip_args = out_args[:-5] + ka.umax_skip
    umax_at = output_layout(integ.data.nf, len(pts)).max_elastic_displacement
    full = K.consistent_outputs(*out_args)
    for kernel in (K.consistent_outputs, K.consistent_outputs_numpy):
        lean = kernel(*skip_args)
        assert lean[umax_at] == K.NOT_COMPUTED == -1.0 and full[umax_at] > 0.0
        keep = np.arange(full.size) != umax_at
        assert np.max(np.abs(lean[keep] - full[keep])) <= o_bound      # full: C; lean: C or numpy


def test_layout_module_agrees_with_the_kernels_and_the_snapshot(beam):
    """reframe.layout names P's blocks (as the C kernels' ffx_reframe_offsets) and the outputs' places: the sizes
    agree, and a Snapshot reads each output from the place the kernels write it."""
    for nf in (0, 1, 4, 9):
        if K.NATIVE:                                          # the C kernels' own offsets
            from flexfmu.native import reframe as native
            assert native.offsets(nf) == tuple(param_layout(nf))
        assert K.param_size(nf) == param_layout(nf).end
        L = output_layout(nf, 3)
        assert K.output_size(nf, 3) == L.size == L.points.stop
    integ, s, loads = _kernel_case(beam)
    pts = np.array([0, 7], dtype=np.int64)
    vec = integ.output_vector(s, loads, pts)
    snap = integ.snapshot(s, loads, pts)
    L = output_layout(integ.data.nf, len(pts))
    assert vec.size == L.size
    for name in ("frame_origin", "frame_origin_velocity", "quaternion", "omega", "alpha", "com_position",
                 "com_velocity", "q", "qd"):
        assert np.array_equal(vec[getattr(L, name)], getattr(snap, name)), name
    assert vec[L.max_elastic_displacement] == snap.max_elastic_displacement
    assert np.array_equal(vec[L.points].reshape(2, 6, 3)[:, 2], snap.point_acceleration)


def test_output_vector_without_the_search_and_the_search_alone_give_all_outputs(beam):
    integ, s, loads = _kernel_case(beam)
    s = integ.advance_steps(s, 5e-5, 100, loads)
    pts = np.array([0, 7], dtype=np.int64)
    full = integ.output_vector(s, loads, pts)
    lean = integ.output_vector(s, loads, pts, max_elastic=False)
    umax_at = output_layout(integ.data.nf, len(pts)).max_elastic_displacement
    q = s.eta[N_RIGID:N_RIGID + integ.data.nf]
    all_nodes = float(np.max(np.linalg.norm((integ.data.Phi @ q)[integ.data.trans_rows], axis=1)))
    assert lean[umax_at] == -1.0
    assert abs(integ.max_elastic_displacement(s) - all_nodes) <= _max_norm_bound(integ, q)
    assert full[umax_at] == integ.max_elastic_displacement(s)
    assert np.array_equal(np.delete(lean, umax_at), np.delete(full, umax_at))


def test_kernel_states_reuse_their_flat_array_only_while_it_is_theirs(beam):
    """A state from the kernels keeps its [position, rotation, eta] as one array for the next step; a field
    changed in place is seen, a field replaced by a new array is not lost (the flat array is rebuilt)."""
    integ, s0, loads = _kernel_case(beam)
    s = integ.advance_steps(s0, 5e-5, 10, loads)

    def copy(state):
        return ReframeState(t=state.t, position=state.position.copy(), rotation=state.rotation.copy(),
                            eta=state.eta.copy())

    def step(state):
        return integ.advance_steps(state, 5e-5, 10, loads)

    assert np.array_equal(step(s).eta, step(copy(s)).eta)
    s.position += 1.0                                        # in place: a view of the flat array
    assert np.array_equal(step(s).position, step(copy(s)).position)
    s.eta = s.eta + 1e-6                                     # a new array: the flat one is stale
    ref = step(copy(s))
    assert np.array_equal(step(s).eta, ref.eta) and not np.array_equal(ref.eta, step(copy(s0)).eta)


_FALLBACK_SCRIPT = """
import json, numpy as np
from flexfmu.reframe import kernels as K
from flexfmu.reframe.models import load_model
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.integrator import ReframeIntegrator, PointLoad, half_sine_pulse
from flexfmu.reframe.results import _state_vector
beam = load_model("beam:spatial_double_L", elements_per_segment=4)
integ = ReframeIntegrator(beam, modal_basis(beam, 3))
s = integ.initial_state(omega0=(5.0, 2.0, 8.0), qd0=(1e-3, -2e-3, 1e-3))
loads = integ.prepare_loads(PointLoad(beam.nodes.shape[0] - 1, half_sine_pulse([1.0, 0.0, 1.0], 0.005),
                                      moment=[0.0, 0.01, 0.0]))
pts = np.array([0, 7], dtype=np.int64)
t, y, o = [], [], []
for k in range(5):
    if k:
        s = integ.advance_steps(s, 5e-5, 50, loads)
    t.append(s.t)
    y.append(_state_vector(s).tolist())
    o.append(integ.output_vector(s, loads, pts).tolist())
print(json.dumps({"native": K.NATIVE, "t": t, "y": y, "o": o}))
"""


def test_numpy_fallback_gives_the_same_numbers(beam):
    """FLEXFMU_NATIVE_KERNELS=0 (as without a C compiler) runs the numpy versions: the same results as the C
    kernels within the a-priori bounds of tests/reframe_bounds.py (the case of _kernel_case, 200 steps, the
    states and output vectors every 50 steps)."""
    runs = {}
    for flag in ("0", "1"):
        env = dict(os.environ, FLEXFMU_NATIVE_KERNELS=flag)
        out = subprocess.run([sys.executable, "-c", _FALLBACK_SCRIPT], env=env, capture_output=True, text=True,
                             check=True, cwd=ROOT)
        runs[flag] = json.loads(out.stdout.strip().splitlines()[-1])
    assert runs["0"]["native"] is False and runs["0"]["t"] == runs["1"]["t"]
    integ, s0, loads = _kernel_case(beam)
    dt, pts = 5e-5, np.array([0, 7], dtype=np.int64)
    ka = integ.kernel_arguments(loads, dt, pts)
    y0 = _state_vector(s0).copy()
    for k, t in enumerate(runs["0"]["t"]):
        y_np, y_run = np.array(runs["0"]["y"][k]), np.array(runs["1"]["y"][k])
        # the states: steps_bound after 50 k steps (identical at k = 0)
        SV, _ = loads.stage_values(s0.t, dt, max(50 * k, 1))
        assert np.max(np.abs(y_np - y_run)) <= (steps_bound(ka.P, ka.LP, ka.G, ka.EX, ka.nf, SV, dt, 50 * k, y0,
                                                            y_run) if k else 0.0), k
        # the outputs, each at its run's own state: this process's output_vector (the C kernels when built) at
        # the numpy run's state against the numpy run's outputs, within outputs_bound; at the other run's state
        # the same code on the same numbers: identical (when this process has the C kernels, as that run did)
        here = [integ.output_vector(ReframeState(t=t, position=y[:3], rotation=y[3:12].reshape(3, 3), eta=y[12:]),
                                    loads, pts) for y in (y_np, y_run)]
        o_np, o_run = np.array(runs["0"]["o"][k]), np.array(runs["1"]["o"][k])
        sv = loads.stage_values(s0.t, dt, 200)[0]          # the loads' largest value over the run: a size
        assert np.max(np.abs(here[0] - o_np)) <= outputs_bound(ka.P, ka.LP, ka.G, ka.nf, sv, y_np, ka.PP, ka.Psi,
                                                               ka.dpn, o_np), k
        if K.NATIVE == runs["1"]["native"]:
            assert np.array_equal(here[1], o_run), k


# --------------------------------------------------------------------------- FFRBeam maps
def test_ffrbeam_fast_maps_equal_term_by_term_formulas():
    from flexfmu.ffr.simulator import INPUT_NAMES, FFRBeamConfig, FFRBeamSimulator
    from flexfmu.ffr.dynamics import BaseMotion, _skew

    sim = FFRBeamSimulator(FFRBeamConfig(n_modes=6))
    assert sim.static_correction is None                 # the outputs below: the maps' terms alone
    rng = np.random.default_rng(9)
    scale = np.array([1, 1, 1, 0.1, 0.1, 0.1, 2, 2, 2, 3, 3, 3, 5, 5, 5], float)
    for case in range(4):
        u = rng.standard_normal(len(INPUT_NAMES)) * scale
        if case == 0:
            u[9:] = 0.0
        sim.set_input_vector(u)
        before = sim.state.copy()
        sim.step(1e-3)
        base = BaseMotion(a0=u[6:9], omega=u[9:12], alpha=u[12:15])
        dyn = sim.dynamics
        ref_state = dyn.step(before, 1e-3, u[0:3], u[3:6], base)
        # two groupings of the same products (Ad x + Bu u + b0 with Bu = Bd (force maps), b0 = Bd f0 formed once,
        # against Ad x + Bd modal_force(u) term by term): each within gamma_ops of the size of the terms,
        # |Ad| |x| + |Bd| (|load maps| |F, M| + |F_a0| |a0| + sum_ab |X_ab| |P_hat_ab|); ops generously
        # 4 (2m + 9) + 64 as in test_clamped_body_held_maps_equal_term_by_term_formulas
        Ad, Bd = dyn._transition(1e-3, base)
        X = np.abs(_skew(base.alpha)) + np.abs(_skew(base.omega)) @ np.abs(_skew(base.omega))
        force_terms = (np.abs(dyn.load_force_map) @ np.abs(u[0:3]) + np.abs(dyn.load_moment_map) @ np.abs(u[3:6])
                       + np.abs(dyn.F_a0) @ np.abs(u[6:9]) + np.einsum("ab,abk->k", X, np.abs(dyn.P_hat)))
        x_before = np.concatenate([before.eta, before.eta_dot])
        ops = 4 * (2 * dyn.m + 9) + 64
        step_terms = np.abs(Ad) @ np.abs(x_before) + np.abs(Bd) @ force_terms
        assert np.all(np.abs(np.concatenate([sim.state.eta, sim.state.eta_dot])
                             - np.concatenate([ref_state.eta, ref_state.eta_dot]))
                      <= implementations_bound(step_terms, ops))
        # the outputs: |Cx| |x| + |Cu| |u| + |y0| (+ |L| |eta| |F| + |S_bar_hat| |eta| |a0| for the moment)
        fast, ref = sim.outputs(), sim.reference_outputs()
        maps = sim._maps(None)
        x = np.abs(np.concatenate([sim.state.eta, sim.state.eta_dot]))
        eta = x[:dyn.m]
        out_terms = (np.abs(maps.Cx) @ x + np.abs(maps.Cu) @ np.abs(u[0:9]) + np.abs(maps.y0))[:18]
        out_terms[15:18] += (np.linalg.norm(np.abs(dyn.load_disp_map) @ eta) * np.linalg.norm(u[0:3])
                             + np.linalg.norm(np.abs(dyn.S_bar_hat) @ eta) * np.linalg.norm(u[6:9]))
        for i, group in enumerate(("sensor_u", "sensor_v", "sensor_a", "tip_u", "reaction_F", "reaction_M")):
            a = np.array([fast[f"{group}_{x}"] for x in "xyz"])
            b = np.array([ref[f"{group}_{x}"] for x in "xyz"])
            assert np.all(np.abs(a - b) <= implementations_bound(out_terms[3 * i:3 * i + 3], ops)), group
        # the energy 1/2 sum k_j eta_j^2: a sum of positive terms, m long (in any grouping), its own size
        assert abs(fast["elastic_energy"] - ref["elastic_energy"]) <= implementations_bound(ref["elastic_energy"],
                                                                                             dyn.m + 8)


# --------------------------------------------------------------------------- clamped body maps
def test_clamped_body_held_maps_equal_term_by_term_formulas():
    """The clamped engine's step and outputs (ClampedDynamics.held_maps, multiplied out per held base rotation)
    against ClampedDynamics.step, acceleration, interface_motion and reactions; an interface with a moment input
    and one without, random inputs and states (the loads' and the base acceleration's moment arms are bilinear)."""
    import dataclasses

    from conftest import straight_rod
    from flexfmu.body.build import build_body
    from flexfmu.body.simulator import FlexBodyConfig, FlexBodySimulator
    from flexfmu.ffr.assembly import build_beam_model

    s = build_beam_model(straight_rod(0.5, 0.01, direction=(1.0, 0.3, -0.2)), "free", 8).structure()
    s = dataclasses.replace(s, node_sets={"root": np.array([0])})
    body = build_body(s, interfaces=[{"name": "tip", "point": s.nodes[-1].tolist()},
                                     {"name": "mid", "point": s.nodes[4].tolist(), "moments": False}],
                      clamp="root", n_modes=6)
    sim = FlexBodySimulator(body, FlexBodyConfig(damping_ratio=0.05))
    engine, dyn = sim.engine, sim.engine.dyn
    assert [i.moments for i in body.interfaces] == [True, False]
    rng = np.random.default_rng(17)
    scale = np.array([1, 1, 1, 0.1, 0.1, 0.1, 2, 2, 2, 3, 3, 3, 9, 9, 9, 40, 40, 40], float)
    for case in range(5):
        u = rng.standard_normal(len(sim.input_names)) * scale
        if case == 0:
            u[12:] = 0.0                                     # no base rotation
        sim.set_input_vector(u.tolist())
        engine.x = rng.standard_normal(2 * dyn.m) * 1e-4
        before = engine.x.copy()
        sim.step(1e-3)
        ref = dyn.step(before, 1e-3, engine.loads, engine.a0, engine.w, engine.alpha)
        # two groupings of the same products (the held maps multiply out what ClampedDynamics evaluates term by
        # term): each within gamma_ops of the size of the terms, |Ad| |x| + |Bd| (|force| |ul| + |force0|) for
        # the step, |Cx| |x| + |Cu| |ul| + |y0| + |ul| |moment_arm| |eta| for the outputs; ops generously
        # 4 (2m + n_loads) + 64: the inner products (2m, n_loads long), the maps' own entries (sums of products of
        # as many terms, formed once) and the few additions of the formulas, each counted twice over
        maps, ul = engine._maps(), np.abs(engine._loads_held)
        Ad, Bd = dyn.transition(1e-3, engine._w_key, engine._alpha_key)
        ops = 4 * (2 * dyn.m + ul.size) + 64
        step_terms = np.abs(Ad) @ np.abs(before) + np.abs(Bd) @ (np.abs(maps.force) @ ul + np.abs(maps.force0))
        assert np.all(np.abs(engine.x - ref) <= implementations_bound(step_terms, ops))
        fast, terms = engine.outputs(), engine.outputs_by_terms()
        x = np.abs(engine.x)
        out_terms = (np.abs(maps.Cx) @ x + np.abs(maps.Cu) @ ul + np.abs(maps.y0))[:fast.size]
        out_terms[maps.moment] += ul @ (np.abs(maps.moment_arm) @ x[:dyn.m]).reshape(-1, 3)
        for group in range(len(fast) // 3):                  # each 3-vector: position, velocity, ..., M
            g = slice(3 * group, 3 * group + 3)
            assert np.all(np.abs(fast[g] - terms[g]) <= implementations_bound(out_terms[g], ops)), group
        frequencies = [body.output_names().index(name) for name in body.frequency_names()]
        assert np.array_equal(sim.output_vector()[frequencies], body.natural_frequencies_hz)
