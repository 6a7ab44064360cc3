#!/usr/bin/env python3
# Over 500 lines on purpose: one study over four problems (their references, sweeps, tables and charts).
"""Work-precision study: error against a converged reference versus CPU time, over the
time step, the number of modes and the mesh, for every method; PNG charts + docs/work_precision.md.

    flexfmu bench work-precision [--quick] [--out REPORT.md | -]
    .venv/bin/python benchmarks/work_precision.py [--quick] [--out-dir DIR] [--out PATH | -]      (the same)

Cases: the reframe body on the paper's plate (its load case) and on the free-free bent rod
(beam:spatial_double_L, a pulse at the free end: rigid + elastic motion); the FFR beam (spatial double-L,
XFF) under a hammer impulse and on a moving base.  One factor at a time: each chart panel varies one of
time step / number of modes / mesh from the case's base model and measures the error against the
reference of that sweep (docs/work_precision.md states each reference and why it is converged).

CPU times are time.process_time of this process, best of a few repeats (shared machine: +-20 %); every
ratio is from one run.  --quick: shorter records, fewer and smaller sweep points, one repeat (~2 min).
The report defaults to docs/work_precision.md of a source checkout, else ./work_precision.md, its charts to
figures/ beside it.  Without Exudyn the plate has no Exudyn runs and a self-converged time-step reference;
without matplotlib the charts are skipped.
Methods that other modules add later (a reframe scheme in flexfmu.reframe.integrator.SCHEMES, the FFR ``integrator``
field, the automatic model choice ``n_modes=-1`` / ``n_flexible_modes=-1`` with ``f_max`` / ``tolerance``)
are detected at run time and included when present.
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime
import gc
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.errors import FlexfmuError, ParameterError
from flexfmu.studies import common
from flexfmu.studies.references import load_generator, reference_path

PANELS = ("dt", "modes", "mesh")
PANEL_TITLES = {"dt": "time step", "modes": "number of modes", "mesh": "mesh"}
TARGETS = (1e-2, 1e-4)            # error levels at which the cheapest method is reported


# --------------------------------------------------------------------------- measurement helpers
def relative_max_error(u, u_ref) -> float:
    """max over the output times of |u - u_ref| divided by max over the output times of |u_ref|.

    u, u_ref: (n_t, 3) vectors on the same time grid (m).  The norm of every chart in this study."""
    u, u_ref = np.asarray(u, dtype=float), np.asarray(u_ref, dtype=float)
    if u.shape != u_ref.shape:
        raise ParameterError("u", f"shape {u.shape} differs from the reference's {u_ref.shape}",
                             "the same output grid as the reference")
    peak = float(np.max(np.linalg.norm(u_ref, axis=-1)))
    if not peak > 0.0:
        raise ParameterError("u_ref", "the reference is identically zero", "a reference with a nonzero peak")
    if not np.all(np.isfinite(u)):
        return math.inf
    return float(np.max(np.linalg.norm(u - u_ref, axis=-1)) / peak)


def best_cpu(fn, repeat: int):
    """(smallest process time of ``repeat`` calls of fn(), s; the last result)."""
    best, result = math.inf, None
    for _ in range(max(1, repeat)):
        gc.collect()
        t0 = time.process_time()
        result = fn()
        best = min(best, time.process_time() - t0)
    return best, result


def observed_order(dts, errors) -> float | None:
    """Slope of log(error) against log(dt) between the two smallest dt whose errors are finite and > 0."""
    pairs = sorted((d, e) for d, e in zip(dts, errors) if e is not None and math.isfinite(e) and e > 0)
    if len(pairs) < 2:
        return None
    (d1, e1), (d2, e2) = pairs[0], pairs[1]
    return math.log(e2 / e1) / math.log(d2 / d1)


@dataclass
class Point:
    """One run of a sweep: panel ("dt" | "modes" | "mesh"), method, the swept value, its label, CPU time of
    the set-up (model, modes, integrator) and of the time integration incl. outputs (s), the error."""

    panel: str
    method: str
    value: float
    label: str
    setup_cpu: float
    run_cpu: float
    error: float
    note: str = ""
    automatic: bool = False

    @property
    def cpu(self) -> float:
        """The CPU time charted: integration only for the time-step and modes sweeps (set-up is paid once per
        model, the integration every simulated second), set-up + integration for the mesh sweep (refining the
        mesh costs set-up; a modal integrator's step does not depend on the mesh)."""
        return self.setup_cpu + self.run_cpu if self.panel == "mesh" else self.run_cpu


@dataclass
class Case:
    key: str
    title: str
    description: str
    quantity: str
    references: dict = field(default_factory=dict)      # panel -> text
    base: str = ""
    points: list = field(default_factory=list)

    def add(self, point: Point) -> None:
        self.points.append(point)
        cpu = "–" if not math.isfinite(point.cpu) else f"{point.cpu:.3g} s"
        print(f"  {self.key:10s} {point.panel:5s} {point.method:24s} {point.label:>14s}  CPU {cpu:>10s}  "
              f"error {point.error:.3e} {point.note}", flush=True)


def _refused(case: Case, panel: str, method: str, value, label: str, exc: Exception) -> None:
    case.add(Point(panel, method, float(value), label, math.nan, math.nan, math.nan,
                   note=f"refused: {' '.join(str(exc).split())}"))


# --------------------------------------------------------------------------- optional features
def reframe_schemes() -> tuple:
    from flexfmu.reframe.integrator import SCHEMES
    return tuple(SCHEMES)


def _fields(cls) -> set:
    return {f.name for f in dataclasses.fields(cls)}


def ffr_integrators() -> tuple:
    """FFR integrators available: ("exact",) today; + "rk4" when FFRBeamConfig has an ``integrator`` field."""
    from flexfmu.ffr.simulator import FFRBeamConfig
    return ("exact", "rk4") if "integrator" in _fields(FFRBeamConfig) else ("exact",)


def ffr_auto_available() -> bool:
    from flexfmu.ffr.simulator import FFRBeamConfig
    return {"f_max", "tolerance"} <= _fields(FFRBeamConfig)


def reframe_auto_available() -> bool:
    from flexfmu.reframe.simulator import ReframeBodyConfig
    return {"f_max", "tolerance"} <= _fields(ReframeBodyConfig)


def exudyn_generator():
    """The Exudyn plate reference's generate.py as a module, or None without Exudyn."""
    try:
        import exudyn  # noqa: F401
    except ImportError:
        return None
    return load_generator("exudyn_plate")


# --------------------------------------------------------------------------- reframe body
def body_deflection(integ_or_baseline, q, node: int) -> np.ndarray:
    """Elastic displacement Phi q of a node, body frame (m), from flexible modal coordinates q (n_t, n_f)."""
    d = integ_or_baseline.data
    return np.asarray(q) @ d.Phi[d.trans_rows[node]].T


def run_reframe(integ, t_end, dt, load, node, out_period, omega0=(0.0, 0.0, 0.0)):
    """Loaded node's elastic deflection (body frame, m) every out_period s with the reframe integrator."""
    every = int(round(out_period / dt))
    state = integ.initial_state(omega0=omega0)
    r = integ.run(t_end, dt, load, state=state, every=every)
    return body_deflection(integ, r.q, node)


def run_baseline(baseline, t_end, dt, load, node, out_period, omega0=(0.0, 0.0, 0.0)):
    """The same with the fixed-frame linear baseline (its elastic part Phi q_F, linearised about the start)."""
    from flexfmu.linalg.modal_basis import N_RIGID
    every = int(round(out_period / dt))
    r = baseline.run(t_end, dt, load, omega0=omega0, every=every)
    return body_deflection(baseline, r.eta[:, N_RIGID:baseline.data.n_modes], node)


@dataclass
class BodyCase:
    """A reframe-body case: how to build the model, its load, the output node and the sweeps."""

    case: Case
    build: object              # mesh value -> Structure
    mesh_label: object         # mesh value -> str
    load: object               # structure -> load (PointLoad)
    node: object               # structure -> output node
    t_end: float
    out_period: float
    damping: float
    omega0: tuple
    base_mesh: object
    base_modes: int
    base_dt: float
    dts: tuple
    ref_dt: float
    modes: tuple
    ref_modes: int
    modes_dt: float
    meshes: tuple
    ref_mesh: object
    f_max: float
    tolerance: float
    case_load_node: object = None     # structure -> the loaded node (the automatic choice's static correction)


def _setup_body(bc: BodyCase, mesh, n_modes, scheme):
    """(structure, basis, integrator or baseline, set-up CPU s) for one model."""
    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.integrator import FixedFrameBaseline, ReframeIntegrator
    t0 = time.process_time()
    structure = bc.build(mesh)
    basis = modal_basis(structure, n_modes, bc.damping)
    integ = (FixedFrameBaseline(structure, basis) if scheme == "baseline"
             else ReframeIntegrator(structure, basis, scheme=scheme))
    return structure, integ, time.process_time() - t0


def _body_run(bc, integ, scheme, structure, dt):
    load, node = bc.load(structure), bc.node(structure)
    if scheme == "baseline":
        return lambda: run_baseline(integ, bc.t_end, dt, load, node, bc.out_period, bc.omega0)
    return lambda: run_reframe(integ, bc.t_end, dt, load, node, bc.out_period, bc.omega0)


def reference_scheme() -> str:
    """The exponential scheme when present (exact in the linear modal part: no RK4 limit, so a reference may
    keep every mode of the model), else the consistent scheme."""
    return "exponential" if "exponential" in reframe_schemes() else "consistent"


def _body_reference(bc, mesh, n_modes, dt, scheme="consistent"):
    """u_ref of a sweep; n_modes None: every flexible mode of the model."""
    if n_modes is None:
        n_modes = bc.build(mesh).n_dof - 6
    structure, integ, _ = _setup_body(bc, mesh, n_modes, scheme)
    return _body_run(bc, integ, scheme, structure, dt)()


def body_methods(panel: str) -> tuple:
    """Methods of a panel.  The model sweeps leave out the paper scheme: its model (M, K, modes) is the consistent
    scheme's, so it adds only its time error (first order, the time-step panel) at 10-20x the CPU time."""
    schemes = reframe_schemes() if panel == "dt" else tuple(s for s in reframe_schemes() if s != "paper")
    return schemes + ("baseline",)


def _method_name(scheme: str) -> str:
    return "fixed-frame baseline" if scheme == "baseline" else f"reframe {scheme}"


def sweep_body(bc: BodyCase, repeat: int, exudyn=None, exudyn_ref=None) -> Case:
    case = bc.case
    # ---- time step: base model; reference: the same model converged in time
    if exudyn_ref is not None:
        u_ref = exudyn_ref
    else:
        u_ref = _body_reference(bc, bc.base_mesh, bc.base_modes, bc.ref_dt)
    for scheme in body_methods("dt"):
        structure, integ, setup = _setup_body(bc, bc.base_mesh, bc.base_modes, scheme)
        for dt in bc.dts:
            try:
                cpu, u = best_cpu(_body_run(bc, integ, scheme, structure, dt), repeat)
            except FlexfmuError as exc:
                _refused(case, "dt", _method_name(scheme), dt, f"{dt:.3g} s", exc)
                continue
            case.add(Point("dt", _method_name(scheme), dt, f"{dt:.3g} s", setup, cpu, relative_max_error(u, u_ref)))
    if exudyn is not None:
        gen, fem = exudyn
        for dt in bc.dts:
            cpu, (table, _) = best_cpu(lambda: gen.simulate(fem, dt=dt, t_end=bc.t_end), repeat)
            case.add(Point("dt", "Exudyn FFRF (gen.-alpha)", dt, f"{dt:.3g} s", 0.0, cpu,
                           relative_max_error(table[:, EXUDYN_FAR], u_ref)))
    # ---- number of modes: base mesh; reference: ref_modes modes, converged in time
    # the exponential scheme is exact in the modal part and 4th order in the coupling: at half the sweep's
    # step its time error (<1e-9 in the time-step panel) is far below the modal truncation errors measured here
    u_ref = _body_reference(bc, bc.base_mesh, bc.ref_modes, bc.modes_dt / 2, reference_scheme())
    for scheme in body_methods("modes"):
        for n in bc.modes:
            try:
                structure, integ, setup = _setup_body(bc, bc.base_mesh, n, scheme)
                cpu, u = best_cpu(_body_run(bc, integ, scheme, structure, bc.modes_dt), repeat)
            except FlexfmuError as exc:
                _refused(case, "modes", _method_name(scheme), n, str(n), exc)
                continue
            case.add(Point("modes", _method_name(scheme), n, str(n), setup, cpu, relative_max_error(u, u_ref)))
    if exudyn is not None:
        gen, fem = exudyn
        for n in bc.modes:
            fem.ComputeEigenmodes(n, excludeRigidBodyModes=6, useSparseSolver=False)
            cpu, (table, _) = best_cpu(lambda: gen.simulate(fem, dt=bc.modes_dt, t_end=bc.t_end), repeat)
            case.add(Point("modes", "Exudyn FFRF (gen.-alpha)", n, str(n), 0.0, cpu,
                           relative_max_error(table[:, EXUDYN_FAR], u_ref)))
        fem.ComputeEigenmodes(gen.N_FLEXIBLE, excludeRigidBodyModes=6, useSparseSolver=False)
    if reframe_auto_available():
        _body_automatic(bc, u_ref, repeat)
    # ---- mesh: base modes; reference: the finest mesh, converged in time
    u_ref = _body_reference(bc, bc.ref_mesh, bc.base_modes, bc.ref_dt)
    for scheme in body_methods("mesh"):
        for mesh in bc.meshes:
            try:
                structure, integ, setup = _setup_body(bc, mesh, bc.base_modes, scheme)
                cpu, u = best_cpu(_body_run(bc, integ, scheme, structure, bc.base_dt), repeat)
            except FlexfmuError as exc:
                _refused(case, "mesh", _method_name(scheme), 0, bc.mesh_label(mesh), exc)
                continue
            case.add(Point("mesh", _method_name(scheme), structure.n_dof, bc.mesh_label(mesh), setup, cpu,
                           relative_max_error(u, u_ref), note=f"{structure.n_dof} DOFs"))
            del structure, integ
            gc.collect()
    return case


def _body_automatic(bc: BodyCase, u_ref, repeat) -> None:
    """The ReframeBody simulator's own choice (n_flexible_modes = -1, f_max, tolerance) on the base mesh, run
    with the integrator the simulator built."""
    from flexfmu.core.io import save_structure
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
    with tempfile.TemporaryDirectory() as tmp:
        structure = bc.build(bc.base_mesh)
        load_point = np.asarray(structure.nodes)[bc.case_load_node(structure)]
        output_point = np.asarray(structure.nodes)[bc.node(structure)]     # the choice also checks the point read
        npz = save_structure(Path(tmp) / "model.npz", structure)
        try:
            t0 = time.process_time()
            sim = ReframeBodySimulator(ReframeBodyConfig(
                model=str(npz), n_flexible_modes=-1, f_max=bc.f_max, tolerance=bc.tolerance, damping_ratio=bc.damping,
                load_point_x=float(load_point[0]), load_point_y=float(load_point[1]), load_point_z=float(load_point[2]),
                output_point_x=float(output_point[0]), output_point_y=float(output_point[1]),
                output_point_z=float(output_point[2])))
            setup = time.process_time() - t0
        except FlexfmuError as exc:
            _refused(bc.case, "modes", "reframe consistent", 0, "automatic", exc)
            return
    integ = sim.integrator
    structure = integ.data.structure
    cpu, u = best_cpu(_body_run(bc, integ, integ.scheme, structure, bc.modes_dt), repeat)
    n = integ.data.nf
    bc.case.add(Point("modes", _method_name(integ.scheme), n, f"auto: {n}", setup, cpu, relative_max_error(u, u_ref),
                      note=f"automatic choice, f_max = {bc.f_max:g} Hz, tolerance {bc.tolerance:g}", automatic=True))


#: The plate's output point: the mid-point of the end opposite the load (a point load's own node has a
#: singular 3-D elastic deflection that converges slowly in modes and mesh); u_far in the Exudyn table.
FAR_POINT = np.array([0.5, 0.0, 0.01])
EXUDYN_FAR = slice(7, 10)


def plate_case(quick: bool) -> BodyCase:
    from flexfmu.reframe.plate import LOAD_POINT, paper_plate
    from flexfmu.reframe.integrator import PointLoad, half_sine_pulse
    force = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)
    t_end = 0.2 if quick else 0.3
    case = Case("plate", "reframe body: the paper's plate",
                f"paper_plate, 5 % modal damping, the paper's load (50 N along global [1, 0, 1]/√2, 0.01 s half-sine, "
                f"at (-0.5, 0, 0.01) m), free flight to {t_end:g} s",
                "elastic deflection of the far end's mid-point (0.5, 0, 0.01) m, body frame")
    return BodyCase(
        case=case, build=lambda div: paper_plate(div), mesh_label=lambda div: "x".join(map(str, div)),
        load=lambda s: PointLoad(LOAD_POINT, half_sine_pulse(force, 0.01)),
        node=lambda s: int(np.argmin(np.linalg.norm(np.asarray(s.nodes) - FAR_POINT, axis=1))), t_end=t_end, out_period=1e-3, damping=0.05,
        omega0=(0.0, 0.0, 0.0), base_mesh=(20, 2, 1), base_modes=10, base_dt=1e-4,
        dts=(5e-4, 2.5e-4, 1.25e-4) + (() if quick else (6.25e-5, 3.125e-5)), ref_dt=1e-3 / 64,
        modes=(2, 4, 6, 10) if quick else (2, 4, 6, 8, 10, 15, 20, 30), ref_modes=30 if quick else 60,
        modes_dt=1e-4,
        meshes=((10, 2, 1), (20, 2, 1)) if quick else ((10, 2, 1), (20, 2, 1), (40, 4, 1)),
        ref_mesh=(40, 4, 1) if quick else (80, 6, 2), f_max=150.0, tolerance=1e-3,
        case_load_node=lambda s: int(np.argmin(np.linalg.norm(np.asarray(s.nodes) - LOAD_POINT, axis=1))))


ROD_FORCE = 10.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)     # N, global, peak of a 0.01 s half-sine


def rod_case(quick: bool) -> BodyCase:
    from flexfmu.reframe.models import default_load_point, load_model
    from flexfmu.reframe.integrator import PointLoad, half_sine_pulse
    t_end = 0.2
    case = Case("rod", "reframe body: free-free bent rod",
                "beam:spatial_double_L (free-free), 5 % modal damping, 10 N peak along global [1, 0, 1]/√2 as a "
                f"0.01 s half-sine at the free end (last node), from rest: it spins and vibrates; {t_end:g} s",
                "elastic deflection of the free end, body frame")
    return BodyCase(
        case=case, build=lambda n: load_model("beam:spatial_double_L", elements_per_segment=n),
        mesh_label=lambda n: f"{n} el/seg", load=lambda s: PointLoad(default_load_point(s),
                                                                   half_sine_pulse(ROD_FORCE, 0.01)),
        node=default_load_point, t_end=t_end, out_period=1e-3, damping=0.05, omega0=(0.0, 0.0, 0.0),
        base_mesh=8, base_modes=6, base_dt=1e-4,
        dts=(2.5e-4, 1.25e-4, 6.25e-5) + (() if quick else (3.125e-5, 1.5625e-5)), ref_dt=1e-3 / 256,
        modes=(1, 2, 3, 6, 10, 20) if quick else (1, 2, 3, 4, 6, 8, 10, 14, 20, 40), ref_modes=None,
        modes_dt=5e-5, meshes=(1, 2, 4) if quick else (1, 2, 4, 8), ref_mesh=8 if quick else 16,
        f_max=300.0, tolerance=1e-3, case_load_node=default_load_point)


def plate_exudyn(gen, t_end):
    """(generator module, FEMinterface of the 20x2x1 plate), and the stored converged Exudyn trajectory's
    far-end deflection on [0, t_end] (dt = 2.5e-6 s)."""
    _, fem, _ = gen.build_fem()
    lines = [line for line in reference_path("exudyn_plate").read_text().splitlines()
             if line.strip() and not line.startswith("#")]
    cols = {name: k for k, name in enumerate(lines[0].split(","))}
    ref = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    n = int(round(t_end / gen.OUTPUT_PERIOD)) + 1
    assert [cols[f"u_far_{c}"] for c in "xyz"] == list(range(EXUDYN_FAR.start, EXUDYN_FAR.stop))
    return (gen, fem), ref[:n][:, EXUDYN_FAR]


# --------------------------------------------------------------------------- FFR beam
HAMMER_FORCE = 20.0 * np.array([1.0, 0.7, 0.4])     # N peak, body frame, a 1 ms half-sine blow at the tip
HAMMER_PULSE = 1e-3


def hammer_input(t: float) -> np.ndarray:
    """FFRBeam input vector (INPUT_NAMES order) of the hammer case at time t."""
    u = np.zeros(15)
    if 0.0 <= t <= HAMMER_PULSE:
        u[0:3] = HAMMER_FORCE * math.sin(math.pi * t / HAMMER_PULSE)
    return u


BASE_SPIN, BASE_RAMP, BASE_ACC, BASE_FREQ = 3.0, 0.05, 5.0, 20.0


def base_input(t: float) -> np.ndarray:
    """Moving base: spin-up about body z to 3 rad/s over 0.05 s (smooth 1 - cos ramp), and a 20 Hz, 5 m/s^2
    sinusoidal acceleration of the base along body x and (half of it) y."""
    u = np.zeros(15)
    if t < BASE_RAMP:
        u[11] = 0.5 * BASE_SPIN * (1.0 - math.cos(math.pi * t / BASE_RAMP))
        u[14] = 0.5 * BASE_SPIN * math.pi / BASE_RAMP * math.sin(math.pi * t / BASE_RAMP)
    else:
        u[11] = BASE_SPIN
    a = BASE_ACC * math.sin(2.0 * math.pi * BASE_FREQ * t)
    u[6], u[7] = a, 0.5 * a
    return u


@dataclass
class FFRCase:
    case: Case
    inputs: object
    breakpoints: tuple         # times where the input has a kink (the reference integrates piecewise)
    t_end: float
    out_period: float
    base_eps: int
    base_modes: int
    dts: tuple
    modes: tuple
    ref_modes: int
    modes_dt: float
    meshes: tuple
    ref_eps: int
    mesh_dt: float
    f_max: float
    tolerance: float
    analytic: bool = False     # hammer: closed-form reference (hammer_analytic), every mode; else DOP853


def _ffr_config(eps, n_modes, integrator="exact", **extra):
    from flexfmu.ffr.simulator import FFRBeamConfig
    kw = dict(boundary="XFF", elements_per_segment=eps, n_modes=n_modes, damping_ratio=0.01)
    if "integrator" in _fields(FFRBeamConfig):
        kw["integrator"] = integrator
    kw.update(extra)
    return FFRBeamConfig(**kw)


def run_ffr(config, dt, t_end, inputs, out_period) -> np.ndarray:
    """Tip elastic displacement (body frame, m) every out_period s through FFRBeamSimulator, the inputs held
    over each step at their mid-step value (second order for smooth inputs)."""
    from flexfmu.ffr.simulator import FFRBeamSimulator
    sim = FFRBeamSimulator(config)
    every = int(round(out_period / dt))
    n = int(round(t_end / dt))
    sim.set_input_vector(inputs(0.0))
    out = [sim.output_vector()[9:12]]
    for k in range(n):
        sim.set_input_vector(inputs((k + 0.5) * dt))
        sim.step(dt)
        if (k + 1) % every == 0:
            out.append(sim.output_vector()[9:12])
    return np.array(out)


def ffr_reference(config, t_end, inputs, out_period, breakpoints, rtol=1e-11) -> np.ndarray:
    """The same model's equations of motion (ffr_dynamics Eq. (*), FFRBeamDynamics.acceleration) with the
    continuous input, integrated by scipy's DOP853 (rtol 1e-11), piecewise between the input's kinks: a time
    integration independent of the FFR step (matrix exponential / RK4 with held inputs)."""
    from scipy.integrate import solve_ivp

    from flexfmu.ffr.simulator import FFRBeamSimulator
    from flexfmu.ffr.dynamics import BaseMotion, ModalState
    dyn = FFRBeamSimulator(config).dynamics
    m = dyn.m
    zero = np.zeros(m)

    def parts(t):
        u = inputs(t)
        return u, BaseMotion(a0=u[6:9], omega=u[9:12], alpha=u[12:15])

    def system(t):
        """(A, b) of x' = A x + b at time t: the equations are affine in x = [eta; eta_dot]."""
        u, base = parts(t)
        f0 = dyn.acceleration(ModalState(zero, zero, t), u[0:3], u[3:6], base)
        if hasattr(dyn, "system_matrix"):
            A = dyn.system_matrix(base)
        else:                               # unit states give the affine map's columns exactly
            A = np.zeros((2 * m, 2 * m))
            A[:m, m:] = np.eye(m)
            for k in range(m):
                e = np.zeros(m)
                e[k] = 1.0
                A[m:, k] = dyn.acceleration(ModalState(e, zero, t), u[0:3], u[3:6], base) - f0
                A[m:, m + k] = dyn.acceleration(ModalState(zero, e, t), u[0:3], u[3:6], base) - f0
        return A, np.concatenate([zero, f0])

    def rhs(t, x):
        A, b = system(t)
        return A @ x + b

    n_out = int(round(t_end / out_period))
    grid = np.arange(n_out + 1) * out_period
    edges = [0.0] + [b for b in breakpoints if 0.0 < b < t_end] + [t_end]
    x = np.zeros(2 * m)
    eta = np.zeros((grid.size, m))
    for a, b in zip(edges[:-1], edges[1:]):
        sel = np.nonzero((grid >= a - 1e-12) & (grid <= b + 1e-12))[0]
        t_eval = np.union1d(grid[sel], [b])
        sol = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=rtol, atol=1e-16, t_eval=t_eval)
        if not sol.success:
            raise FlexfmuError(f"reference integration failed: {sol.message}")
        eta[sel] = sol.y[:m, np.searchsorted(t_eval, grid[sel])].T
        x = sol.y[:, -1]
    return eta @ dyn.tip_map.T


def hammer_analytic(config, t_end, out_period) -> np.ndarray:
    """Closed-form tip displacement (body frame, m) of the hammer case: with the base at rest the modal
    equations decouple, eta_i'' + 2 zeta w_i eta_i' + w_i^2 eta_i = g_i sin(pi t / T) on [0, T] (g = modal
    load of HAMMER_FORCE at load_s), free vibration after.  Solution: the steady sinusoidal particular part
    Im(g e^{i W t} / (w^2 - W^2 + 2 i zeta w W)) plus the damped free response that makes eta(0) = eta'(0) = 0;
    from T on, the free response of the state at T.  Every mode of the model can be kept (no time step)."""
    from flexfmu.ffr.simulator import FFRBeamSimulator
    dyn = FFRBeamSimulator(config).dynamics
    w = np.sqrt(dyn.stiffness)
    zeta = dyn.damping / (2.0 * w)
    wd = w * np.sqrt(1.0 - zeta**2)
    g = dyn.load_force_map @ HAMMER_FORCE
    W = math.pi / HAMMER_PULSE
    amp = g / (w**2 - W**2 + 2j * zeta * w * W)

    def free(t, e0, v0):
        """Damped free response (eta, eta_dot) after time t from (e0, v0), per mode."""
        a, b = e0, (v0 + zeta * w * e0) / wd
        decay = np.exp(-zeta * w * t)
        c, s = np.cos(wd * t), np.sin(wd * t)
        eta = decay * (a * c + b * s)
        eta_dot = decay * ((-zeta * w) * (a * c + b * s) + wd * (-a * s + b * c))
        return eta, eta_dot

    def forced(t):
        z = amp * np.exp(1j * W * t)
        e_h, v_h = free(t, -amp.imag, -(1j * W * amp).imag)         # cancels the particular part at t = 0
        return z.imag + e_h, (1j * W * z).imag + v_h

    e_T, v_T = forced(HAMMER_PULSE)
    grid = np.arange(int(round(t_end / out_period)) + 1) * out_period
    eta = np.array([forced(t)[0] if t <= HAMMER_PULSE else free(t - HAMMER_PULSE, e_T, v_T)[0] for t in grid])
    return eta @ dyn.tip_map.T


def _ffr_point(fc: FFRCase, panel, method, value, label, config, dt, u_ref, repeat, automatic=False, note="",
               setup=None):
    from flexfmu.ffr.simulator import FFRBeamSimulator
    try:
        if setup is None:
            t0 = time.process_time()
            FFRBeamSimulator(config)               # first construction of this configuration: the set-up
            setup = time.process_time() - t0
        cpu, u = best_cpu(lambda: run_ffr(config, dt, fc.t_end, fc.inputs, fc.out_period), repeat)
    except FlexfmuError as exc:
        _refused(fc.case, panel, method, value, label, exc)
        return
    fc.case.add(Point(panel, method, value, label, setup, cpu, relative_max_error(u, u_ref), note=note,
                      automatic=automatic))


def ffr_free_dofs(eps: int) -> int:
    from flexfmu.ffr.simulator import FFRBeamSimulator
    return FFRBeamSimulator(_ffr_config(eps, 1)).dynamics.model.n_free


def _ffr_ref(fc: FFRCase, eps: int, n_modes) -> np.ndarray:
    """u_ref of a sweep; n_modes None: every mode of the model."""
    config = _ffr_config(eps, ffr_free_dofs(eps) if n_modes is None else n_modes)
    if fc.analytic:
        return hammer_analytic(config, fc.t_end, fc.out_period)
    return ffr_reference(config, fc.t_end, fc.inputs, fc.out_period, fc.breakpoints)


def sweep_ffr(fc: FFRCase, repeat: int) -> Case:
    from flexfmu.ffr.simulator import FFRBeamConfig
    integrators = ffr_integrators()
    name = {"exact": "FFR modal, exact (expm)", "rk4": "FFR modal, RK4"}
    # ---- time step
    u_ref = _ffr_ref(fc, fc.base_eps, fc.base_modes)
    for integ in integrators:
        for dt in fc.dts:
            _ffr_point(fc, "dt", name.get(integ, integ), dt, f"{dt:.3g} s",
                       _ffr_config(fc.base_eps, fc.base_modes, integ), dt, u_ref, repeat)
    # ---- modes
    u_ref = _ffr_ref(fc, fc.base_eps, fc.ref_modes)
    for integ in integrators:
        for n in fc.modes:
            _ffr_point(fc, "modes", name.get(integ, integ), n, str(n), _ffr_config(fc.base_eps, n, integ),
                       fc.modes_dt, u_ref, repeat)
    if "static_correction" in _fields(FFRBeamConfig):
        for n in fc.modes:
            _ffr_point(fc, "modes", "FFR modal, exact + static correction", n, str(n),
                       _ffr_config(fc.base_eps, n, "exact", static_correction=1), fc.modes_dt, u_ref, repeat)
    if ffr_auto_available():
        from flexfmu.ffr.simulator import FFRBeamSimulator
        for integ in integrators:
            config = _ffr_config(0, -1, integ, f_max=fc.f_max, tolerance=fc.tolerance)
            try:
                t0 = time.process_time()
                sim = FFRBeamSimulator(config)         # the set-up, incl. the choice (mesh study, modes)
                setup = time.process_time() - t0
                n = sim.dynamics.m
                mesh_choice = getattr(getattr(sim, "model_choice", None), "mesh", None)
                eps = getattr(mesh_choice, "elements_per_segment", None)
            except FlexfmuError as exc:
                _refused(fc.case, "modes", name.get(integ, integ), 0, "automatic", exc)
                continue
            _ffr_point(fc, "modes", name.get(integ, integ), n, f"auto: {n}", config, fc.modes_dt, u_ref, repeat,
                       automatic=True, setup=setup, note=f"automatic choice ({n} modes"
                       + (f", {eps} el/seg" if eps else "") + f"), f_max = {fc.f_max:g} Hz, tolerance {fc.tolerance:g}")
    # ---- mesh
    u_ref = _ffr_ref(fc, fc.ref_eps, fc.base_modes)
    for integ in integrators:
        for eps in fc.meshes:
            _ffr_point(fc, "mesh", name.get(integ, integ), eps, f"{eps} el/seg", _ffr_config(eps, fc.base_modes, integ),
                       fc.mesh_dt, u_ref, repeat)
    return fc.case


def hammer_case(quick: bool) -> FFRCase:
    t_end = 0.05 if quick else 0.1
    case = Case("ffr_hammer", "FFR beam: hammer impulse",
                "spatial double-L clamped at its first point (XFF), 1 % modal damping; a 1 ms half-sine blow at the "
                f"tip, peak 20 N × (1, 0.7, 0.4) (body frame), base at rest; {t_end:g} s",
                "tip elastic displacement, body frame")
    return FFRCase(case, hammer_input, (HAMMER_PULSE,), t_end, 5e-4, base_eps=8, base_modes=6,
                   dts=(5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5) + (() if quick else (1.5625e-5,)),
                   modes=(1, 2, 4, 6, 10, 24) if quick else (1, 2, 3, 4, 6, 8, 10, 16, 24, 40),
                   ref_modes=None, modes_dt=1e-5,
                   meshes=(1, 2, 4) if quick else (1, 2, 4, 8), ref_eps=16 if quick else 32, mesh_dt=1e-5,
                   f_max=1.5 / HAMMER_PULSE, tolerance=1e-3, analytic=True)


def base_case(quick: bool) -> FFRCase:
    t_end = 0.1
    case = Case("ffr_base", "FFR beam: moving base",
                "spatial double-L, XFF, 1 % modal damping; the base spins up about body z to 3 rad/s over 0.05 s "
                "(1 − cos ramp) and accelerates sinusoidally (20 Hz, 5 m/s² along x, 2.5 m/s² along y); no force; "
                f"{t_end:g} s",
                "tip elastic displacement, body frame")
    return FFRCase(case, base_input, (BASE_RAMP,), t_end, 5e-4, base_eps=8, base_modes=6,
                   dts=(5e-4, 2.5e-4, 1.25e-4) + (() if quick else (6.25e-5,)),
                   modes=(1, 2, 4, 6) if quick else (1, 2, 3, 4, 6, 8, 12), ref_modes=12 if quick else 16,
                   modes_dt=1.25e-4 if quick else 6.25e-5, meshes=(1, 2) if quick else (1, 2, 4),
                   ref_eps=4 if quick else 8, mesh_dt=1.25e-4 if quick else 6.25e-5, f_max=300.0, tolerance=1e-3)


# --------------------------------------------------------------------------- charts
_COLORS = {"reframe consistent": "tab:blue", "reframe paper": "tab:orange", "reframe exponential": "tab:green",
           "fixed-frame baseline": "tab:gray", "Exudyn FFRF (gen.-alpha)": "tab:red",
           "FFR modal, exact (expm)": "tab:purple", "FFR modal, RK4": "tab:brown",
           "FFR modal, exact + static correction": "tab:olive"}
_MARKERS = ("o", "s", "^", "D", "v", "P", "X")


def _at_least_a_decade(ax) -> None:
    """Widen a log x-axis to one decade around its data (sweeps whose CPU time hardly changes would otherwise
    spread noise over the whole width) and label only the decades."""
    from matplotlib.ticker import LogLocator, NullFormatter
    xs = [x for line in ax.get_lines() for x in line.get_xdata() if x > 0]
    if xs:
        lo, hi = min(xs), max(xs)
        if hi / lo < 10.0:
            mid = math.sqrt(lo * hi)
            lo, hi = mid / math.sqrt(10.0), mid * math.sqrt(10.0)
        ax.set_xlim(lo / 1.3, hi * 1.3)
    ax.xaxis.set_major_locator(LogLocator(base=10.0))
    ax.xaxis.set_minor_formatter(NullFormatter())


def plot_case(case: Case, path: Path, plt) -> Path:
    """The case's three panels (``plt``: matplotlib.pyplot)."""
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.4))
    methods = list(dict.fromkeys(p.method for p in case.points))
    for ax, panel in zip(axes, PANELS):
        for k, method in enumerate(methods):
            pts = [p for p in case.points if p.panel == panel and p.method == method and not p.automatic
                   and math.isfinite(p.cpu) and math.isfinite(p.error) and p.error > 0]
            if not pts:
                continue
            color = _COLORS.get(method, f"C{k}")
            ax.plot([p.cpu for p in pts], [p.error for p in pts], marker=_MARKERS[k % len(_MARKERS)], color=color,
                    label=method, lw=1.5, ms=6)
            for j, p in enumerate(pts):
                if panel != "dt" or j in (0, len(pts) - 1):
                    ax.annotate(p.label, (p.cpu, p.error), textcoords="offset points", xytext=(4, 4), fontsize=7,
                                color=color)
        for p in case.points:
            if p.panel == panel and p.automatic and math.isfinite(p.cpu) and math.isfinite(p.error) and p.error > 0:
                ax.plot([p.cpu], [p.error], marker="*", ms=17, color=_COLORS.get(p.method, "k"), mec="k",
                        ls="none", label=f"automatic choice ({p.method}, {p.label.split(': ')[-1]} modes)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        _at_least_a_decade(ax)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_xlabel("CPU time, set-up + integration (s)" if panel == "mesh" else "CPU time of the integration (s)")
        ax.set_ylabel("error: max |u − u_ref| / max |u_ref| (–)")
        ax.set_title(f"{PANEL_TITLES[panel]}: {case.references.get(panel + '_short', '')}", fontsize=10)
    handles = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=min(len(handles), 4), fontsize=9,
               frameon=False)
    fig.suptitle(f"Work-precision, {case.title} — u: {case.quantity}", fontsize=12)
    fig.tight_layout(rect=(0, 0.09 if len(handles) > 4 else 0.06, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------- report
def fmt_err(e: float) -> str:
    if e is None or not math.isfinite(e):
        return "–" if e is None or math.isnan(e) else "diverged"
    return f"{e:.2e}"


def fmt_cpu(t: float) -> str:
    if t is None or not math.isfinite(t):
        return "–"
    return f"{t * 1e3:.1f} ms" if t < 1.0 else f"{t:.2f} s"


#: CPU times within this fraction count as equal when deciding whether a run is on the efficient front.
CPU_NOISE = 0.2


def dominated_by(point: Point, points) -> Point | None:
    """A point of the same panel with a smaller error at no more CPU time (within CPU_NOISE), if any: then
    ``point`` is not on the efficient front of that panel.  Automatic points do not dominate each other (the
    exact and RK4 automatic FFR runs tie to 4 digits)."""
    better = [q for q in points if q is not point and q.panel == point.panel and not q.automatic
              and math.isfinite(q.cpu)
              and math.isfinite(q.error) and q.cpu <= point.cpu * (1.0 + CPU_NOISE) and q.error < point.error]
    return min(better, key=lambda q: q.error) if better else None


def conclusions(case: Case) -> list[str]:
    """Sentences that state what the numbers of this case show (orders, plateaus, cheapest method per target)."""
    out = []
    pts = [p for p in case.points if math.isfinite(p.cpu) and math.isfinite(p.error)]
    methods = list(dict.fromkeys(p.method for p in case.points))
    for method in methods:
        row = sorted((p for p in pts if p.panel == "dt" and p.method == method), key=lambda p: -p.value)
        if len(row) >= 2:
            errs = ", ".join(f"{p.error:.1e}" for p in row)
            orders = [observed_order([a.value, b.value], [a.error, b.error]) for a, b in zip(row[:-1], row[1:])]
            out.append(f"{method}: time-step errors {errs} (dt {row[0].label} … {row[-1].label}); observed orders "
                       "between successive steps " + ", ".join("–" if q is None else f"{q:.2f}" for q in orders)
                       + ".")
    for panel in PANELS:
        for target in TARGETS:
            ok = [p for p in pts if p.panel == panel and p.error <= target and not p.automatic]
            if ok:
                best = min(ok, key=lambda p: p.cpu)
                out.append(f"{PANEL_TITLES[panel]} sweep, error ≤ {target:g}: cheapest is {best.method} at "
                           f"{best.label} ({fmt_cpu(best.cpu)}, error {best.error:.1e}).")
            else:
                out.append(f"{PANEL_TITLES[panel]} sweep: no run reached error ≤ {target:g}.")
    for p in pts:
        if p.automatic:
            dom = dominated_by(p, pts)
            out.append(f"{p.method}, {p.note}: {p.label.split(': ')[-1]} modes, error {p.error:.1e}, "
                       f"{fmt_cpu(p.cpu)} — " + ("on the efficient front of the panel (no run of any method is "
                                                f"more accurate at ≤ {1 + CPU_NOISE:g}× its CPU time)." if dom is None else
                                                f"not on the front: {dom.method} with {dom.label} modes reaches "
                                                f"{dom.error:.1e} in {fmt_cpu(dom.cpu)}."))
    refused = [p for p in case.points if p.note.startswith("refused")]
    for p in refused:
        out.append(f"{p.method} at {PANEL_TITLES[p.panel]} {p.label}: {p.note}.")
    return out


def write_report(path: Path, cases, figures, mach, quick, elapsed, extra_notes, today: str,
                 replotted: bool = False) -> None:
    lines = [
        "# Work-precision study",
        "",
        f"Made from {common.provenance()}.",
        "",
        "Written by `flexfmu bench work-precision` (flexfmu.studies.work_precision; also "
        "`benchmarks/work_precision.py`); the run: "
        + ("**--quick**" if quick else "**full**") + f", {today}, {elapsed:.0f} s; machine: {mach}."
        + (" Charts and text drawn again from the run's saved numbers (`--replot`)." if replotted else ""),
        "",
        "**What is measured.** For each case, one factor at a time is varied from the case's base model — the "
        "time step, the number of retained modes, the mesh — and each run's error is measured against the "
        "reference of that sweep (below). Error = max over the output times of |u − u_ref| divided by max over "
        "time of |u_ref|, u the case's output vector (stated per case). CPU time = `time.process_time` of this "
        "process, best of " + ("2 runs" if quick else "3 runs") + " (caches a method fills on its first run at a given "
        "time step, e.g. the exponential scheme's step matrices, are thus counted as set-up); the time-step and modes charts show the CPU "
        "time of the integration (incl. outputs), the mesh chart set-up (mesh, modes, integrator invariants) + "
        "integration. CPU times are noisy on a shared machine (±20 %); ratios only within this run.",
        "",
        "Methods found at run time: reframe schemes " + ", ".join(f"`{s}`" for s in reframe_schemes())
        + "; FFR integrators " + ", ".join(f"`{s}`" for s in ffr_integrators())
        + "; automatic model choice (f_max, tolerance): "
        + (" and ".join(name for name, ok in (("ReframeBody n_flexible_modes = -1", reframe_auto_available()),
                                              ("FFRBeam n_modes = -1, elements_per_segment = 0", ffr_auto_available()))
                        if ok) or "none") + ". Exudyn runs on the plate only (the model of the stored Exudyn "
        "reference, flexfmu/data/references/exudyn_plate); no Exudyn model of the rod or of the FFR beam was built.",
        "",
    ]
    for case, fig in zip(cases, figures):
        lines += [f"## {case.title}", "", case.description + ".", "", f"Output: {case.quantity}.", "",
                  f"Base model: {case.base}.", "", "References:", ""]
        lines += [f"- {PANEL_TITLES[p]}: {case.references[p]}" for p in PANELS if p in case.references]
        if fig is not None:                    # the chart, linked relative to the report
            lines += ["", f"![{case.title}]({Path(os.path.relpath(Path(fig).resolve(), path.parent.resolve())).as_posix()})"]
        lines += ["", "Conclusions (from this run's numbers):", ""]
        lines += [f"- {s}" for s in conclusions(case)]
        lines += ["", "| sweep | method | value | set-up CPU | integration CPU | error | note |",
                  "|---|---|---|---|---|---|---|"]
        for p in case.points:
            lines.append(f"| {PANEL_TITLES[p.panel]} | {p.method} | {p.label} | {fmt_cpu(p.setup_cpu)} | "
                         f"{fmt_cpu(p.run_cpu)} | {fmt_err(p.error)} | {p.note} |")
        lines.append("")
    if extra_notes:
        lines += [extra_notes.rstrip(), ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines))


def machine() -> str:
    """One line of the performance study's machine description."""
    from flexfmu.studies.performance import machine as machine_facts

    m = machine_facts()
    return f"{m['cpu']}, {m['cores']} cores, Python {m['python']}, numpy {m['numpy']}"


# --------------------------------------------------------------------------- driver
def _warm_up() -> None:
    """Load (on first use: compile) the C kernels and fill import caches before anything is timed."""
    from flexfmu.reframe.models import load_model
    from flexfmu.reframe.integrator import ReframeIntegrator
    rod = load_model("beam:spatial_double_L", elements_per_segment=2)
    for scheme in reframe_schemes():
        try:
            ReframeIntegrator(rod, 2, scheme=scheme).run(2e-3, 1e-4, None, every=5)
        except FlexfmuError:
            pass
    run_ffr(_ffr_config(2, 2), 1e-4, 1e-3, hammer_input, 5e-4)


def run(quick: bool, only=None) -> list:
    repeat = 2 if quick else 3
    _warm_up()
    cases = []
    if only in (None, "plate"):
        bc = plate_case(quick)
        gen = exudyn_generator()
        if gen is None:
            print(common.skipped("plate: the Exudyn runs and the Exudyn time-step reference", "exudyn"), flush=True)
        exudyn, exudyn_ref = plate_exudyn(gen, bc.t_end) if gen is not None else (None, None)
        c = bc.case
        c.base = (f"mesh {bc.mesh_label(bc.base_mesh)} ({bc.build(bc.base_mesh).n_dof} DOFs), {bc.base_modes} flexible "
                  f"modes, dt = {bc.base_dt:g} s")
        c.references = {
            "dt": ("the stored Exudyn trajectory of the same model (flexfmu/data/references/exudyn_plate: ObjectFFRF"
                   "reducedOrder, generalized-α, dt = 2.5e-6 s) — an independent code. Its own error, extrapolated "
                   "from Exudyn's second-order convergence in this panel (error at dt = 3.125e-5 s × (2.5e-6 / "
                   "3.125e-5)²), is ≈ 1e-7: the floor the reframe schemes reach." if exudyn_ref is not None else
                   f"the consistent scheme at dt = {bc.ref_dt:g} s (Exudyn not installed)."),
            "dt_short": f"{bc.mesh_label(bc.base_mesh)}, {bc.base_modes} modes",
            "modes": (f"{bc.ref_modes} flexible modes on the base mesh, the {reference_scheme()} scheme at "
                      f"dt = {bc.modes_dt / 2:g} s; every run at dt = {bc.modes_dt:g} s. The reference keeps 2× the sweep's "
                      "largest count; its own truncation error is not measured (a 3-D solid's modal series "
                      "converges slowly)."),
            "modes_short": f"{bc.mesh_label(bc.base_mesh)}, dt {bc.modes_dt:g} s, ref. {bc.ref_modes} modes",
            "mesh": (f"the {bc.mesh_label(bc.ref_mesh)} mesh with {bc.base_modes} flexible modes, consistent scheme at "
                     f"dt = {bc.ref_dt:g} s; every run at dt = {bc.base_dt:g} s. The reference's own mesh error is "
                     "not measured; it is smaller than the last sweep point's if the convergence continues."),
            "mesh_short": f"{bc.base_modes} modes, ref. {bc.mesh_label(bc.ref_mesh)}",
        }
        print(f"plate: {c.description}")
        cases.append(sweep_body(bc, repeat, exudyn, exudyn_ref))
    if only in (None, "rod"):
        bc = rod_case(quick)
        c = bc.case
        c.base = (f"{bc.mesh_label(bc.base_mesh)} ({bc.build(bc.base_mesh).n_dof} DOFs), {bc.base_modes} flexible "
                  f"modes, dt = {bc.base_dt:g} s")
        c.references = {
            "dt": (f"the consistent scheme on the same model at dt = {bc.ref_dt:.3g} s (self-convergence: it is "
                   "fourth order here, so its error is ~(ref dt / finest dt)^4 = 1/16 … 1/256 of the finest run's)."),
            "dt_short": f"{bc.mesh_label(bc.base_mesh)}, {bc.base_modes} modes",
            "modes": (f"every flexible mode of the model ({bc.build(bc.base_mesh).n_dof - 6}), the {reference_scheme()} "
                      f"scheme (no stability limit) at dt = {bc.modes_dt / 2:.3g} s; every run at dt = {bc.modes_dt:g} s "
                      "(the consistent scheme refuses mode counts whose dt·ω_max exceeds 2.8)."),
            "modes_short": f"{bc.mesh_label(bc.base_mesh)}, dt {bc.modes_dt:g} s, ref. all modes",
            "mesh": (f"{bc.mesh_label(bc.ref_mesh)} with {bc.base_modes} flexible modes, consistent scheme at "
                     f"dt = {bc.ref_dt:.3g} s; Hermite beam elements converge as h⁴ (docs/ffr_model.md), so the "
                     "reference's own error is ~1/16 of the finest sweep point's."),
            "mesh_short": f"{bc.base_modes} modes, ref. {bc.mesh_label(bc.ref_mesh)}",
        }
        print(f"rod: {c.description}")
        cases.append(sweep_body(bc, repeat))
    for key, make in (("ffr_hammer", hammer_case), ("ffr_base", base_case)):
        if only not in (None, key):
            continue
        fc = make(quick)
        c = fc.case
        c.base = f"{fc.base_eps} elements per segment, {fc.base_modes} modes"
        if fc.analytic:
            ref = ("the closed-form solution of the same model's decoupled modal equations under the continuous "
                   "half-sine blow (hammer_analytic; no time step, so exact up to rounding; checked against "
                   "DOP853 to 1e-11)")
        else:
            ref = ("the model's equations of motion (ffr_dynamics Eq. (*)) with the continuous input, integrated "
                   "by scipy DOP853 at rtol 1e-11 piecewise between the input's kinks — independent of the FFR "
                   "step")
        ref_modes = "every mode of the model" if fc.ref_modes is None else f"{fc.ref_modes} modes"
        c.references = {
            "dt": f"{ref}, same model. The FFR runs hold the input at its mid-step value over each step.",
            "dt_short": f"{fc.base_eps} el/seg, {fc.base_modes} modes",
            "modes": (f"{ref}, {ref_modes} ({fc.base_eps} elements per segment); every run at dt = {fc.modes_dt:g} s"
                      + " (its time error, from the time-step sweep, is the floor of this panel)."),
            "modes_short": (f"{fc.base_eps} el/seg, dt {fc.modes_dt:g} s, ref. "
                            + ("all modes" if fc.ref_modes is None else f"{fc.ref_modes} modes")),
            "mesh": (f"{ref}, {fc.ref_eps} elements per segment, {fc.base_modes} modes; every run at "
                     f"dt = {fc.mesh_dt:g} s; h⁴ convergence makes the reference's own error ~1/16 of the finest "
                     "sweep point's."),
            "mesh_short": f"{fc.base_modes} modes, dt {fc.mesh_dt:g} s, ref. {fc.ref_eps} el/seg",
        }
        print(f"{key}: {c.description}")
        cases.append(sweep_ffr(fc, repeat))
    return cases


#: Hand-written reading of the charts, appended to the report.  Its numbers are quoted from the full run of
#: 2026-11-21 08:37 UTC; re-read them after a new run.
NOTES = """## Reading the charts (full run of 2026-11-21 08:37 UTC)

**Time step.** The reframe `consistent` scheme is fourth order (rod: observed orders 3.25, 4.03, 3.90, 3.93;
plate: 3.0, 4.2, 4.2 down to 1.6e-7, where the plate panel meets the floor of its reference, the stored Exudyn
trajectory, ≈ 1.5e-7). The `exponential` scheme has the same order but a far smaller error constant, because
the modal part is exact: 1.1e-7 on the rod and 2.6e-7 (the reference floor) on the plate already at the
coarsest step, 2.5e-4 / 5e-4 s, in 15 / 20 ms. The printed `paper` scheme converges at first to second order
on the plate (8.4e-6 at dt = 3.1e-5 s), but on the rod it stalls at 4–6e-5 (it converges to its own limit,
defect (d) of docs/reframe.md), and its Python step costs 10–25× the consistent scheme's CPU time per step.
Exudyn's generalized-α on the same plate model is second order (orders 2.01): 2.1e-5 in 640 ms at
dt = 3.1e-5 s, where the consistent scheme reaches 3.0e-6 in 37 ms (dt = 1.25e-4 s) — 17× less CPU time for
a 7× smaller error. The fixed-frame linear baseline stops improving at 4.8e-5 on the plate (it turns
slowly, 0.05 rad/s) and at 1.2e-2 on the rod, which turns through a large angle: what is left is the error of
its small-rotation model, not of its time step.

**Number of modes.** Truncation dominates everything else in these cases: the plate's far-end deflection
with 10 modes is 5.7e-4 from the 60-mode reference, the rod's free-end deflection 3.1e-3 with 10 modes,
6.2e-4 with 20 and 1.2e-4 with 40 (all modes: the reference). With 40 modes the rod's dt·ω_max at dt = 5e-5 s
is 6.9: the consistent scheme and the baseline refuse the run (RK4 limit 2.8), the exponential scheme runs it
in 129 ms. In the reframe modes panel the CPU time grows slowly with the modes (plate: 35 ms for 2 modes,
78 ms for 30). In the FFR beam the per-step cost hardly depends on the modes (hammer: 92–101 ms for 1–40
modes; the Python per-step overhead dominates), so more modes are nearly free there. The static correction
(residual flexibility of the omitted modes) pays once the retained modes cover the input's band: hammer,
24 modes: 3.6e-5 with it, 8.5e-4 without; moving base, 6 modes: 8.8e-6 with, 7.3e-5 without. Below the
band it is harmful: with 1–3 modes under the 1 ms blow the error is 1.6–2.0 with the correction (0.75–0.85
without), because the omitted 40–300 Hz modes respond dynamically, not quasi-statically.

**Mesh.** The Hermite beams converge fast: rod free-end deflection 6.7e-3 (1 element per segment), 1.8e-3,
6.9e-5, 8.8e-6 (8) against 16 elements per segment; FFR hammer tip 4.6e-2, 7.2e-3, 5.1e-4, 5.3e-5 (8)
against 32. The plate's tetrahedral mesh converges slowly: 5.1e-2 (10x2x1), 1.2e-2 (20x2x1), 2.2e-3 (40x4x1)
against 80x6x2, so on the plate the mesh, not the time step or the integrator, limits the accuracy of the
paper's 20x2x1 load case. The script switches flexfmu's on-disk model cache off (FLEXFMU_CACHE=0) while it
measures, so the set-up CPU times are those of a fresh model. The integration CPU time does not depend on the mesh (rod: 25 ms for
24 … 150 DOFs; plate: 41–55 ms for 945 … 6561 DOFs).

**Automatic model choice** (stars; the simulators' own choice from f_max and tolerance 1e-3: every mode below
f_max, more above it until the mode-acceleration estimate of the truncation error is within tolerance/2, the
static correction, and for the FFR beam a mesh that resolves every retained mode; docs/model_size.md). It meets
the tolerance in every case: plate (f_max = 150 Hz, the band of the 10 ms pulse) 21 coordinates, 1.2e-4 in
69 ms, on the efficient front; rod (300 Hz) 16 coordinates, 4.8e-6 in 61 ms, on the front (the plain modal
sweep needs 40 modes for 1.2e-4). FFR hammer (1500 Hz, the band of the 1 ms blow): 24 modes on 12 elements
per segment, 5.1e-5 in 97 ms. It is flagged "not on the front" only because the panel's reference is the
8-element mesh: 24 modes with the static correction on that very mesh give 3.6e-5 at the same CPU; against a
16-element reference the automatic model is the more accurate one (4.1e-5 against 5.6e-5, docs/model_size.md).
Moving base (300 Hz): 15 modes, 8 elements per segment, 8.6e-6 in 461 ms; 12 modes give 7.9e-6 in 369 ms
(0.8× the CPU) — the rule guards `sensor_u` under a tip moment, an input this case never applies, so it keeps
more modes than this scene needs. The first choice (only the modes below f_max) missed the tolerance
(2.3e-3 on the hammer, 2.9e-3 on the plate): for response quantities the band of the input is not enough.

**FFR integrators.** With the inputs held at their mid-step value, the exact (matrix-exponential) step and
RK4 give the same errors to two digits in both FFR cases from dt = 2.5e-4 s on (second order, the hold's: orders
2.00; at 5e-4 s RK4's hammer error is 1.2e-1 against 9.4e-2) at the same CPU time within noise (hammer 8.7 vs
8.9 ms at dt = 1.25e-4 s; moving base 146 vs 146 ms),
so the input sampling, not the integrator, sets the accuracy of the FFR beam for a given step. With 6 modes
(dt·ω_max ≤ 1 here) RK4 is inside its stability limit; the exact step wins where retained modes are stiff
(RK4 must then sub-step, docs/stability.md, docs/model_size.md), which is why it stays the FFRBeam default.
"""


def save_run(path: Path, cases, mach: str, quick: bool, elapsed: float, today: str) -> None:
    """Every number of a run as JSON, so that the charts and the report can be drawn again (--replot)."""
    import json
    data = {"quick": quick, "date": today, "elapsed_s": elapsed, "machine": mach,
            "cases": [{"key": c.key, "title": c.title, "description": c.description, "quantity": c.quantity,
                       "references": c.references, "base": c.base,
                       "points": [dataclasses.asdict(p) for p in c.points]} for c in cases]}
    path.write_text(json.dumps(data, indent=1, allow_nan=True))


def load_run(path: Path):
    import json
    data = json.loads(Path(path).read_text())
    cases = []
    for c in data["cases"]:
        case = Case(c["key"], c["title"], c["description"], c["quantity"], c["references"], c["base"])
        case.points = [Point(**p) for p in c["points"]]
        cases.append(case)
    return cases, data["machine"], data["quick"], data["elapsed_s"], data["date"]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short records, fewer sweep points, two repeats")
    parser.add_argument("--out-dir", type=Path, default=None,
                        help="folder of the PNG charts (default: figures/ beside the report)")
    parser.add_argument("--save", type=Path, default=None, metavar="JSON",
                        help="also write every number of the run as JSON (for --replot)")
    parser.add_argument("--out", "--doc", dest="doc", default=str(common.default_report_dir() / "work_precision.md"),
                        help="Markdown report (default: docs/work_precision.md of a source checkout, else "
                             "./work_precision.md); '-' writes none")
    parser.add_argument("--case", choices=("plate", "rod", "ffr_hammer", "ffr_base"), default=None,
                        help="run one case only (default: all)")
    parser.add_argument("--replot", type=Path, default=None, metavar="JSON",
                        help="draw the charts and the report again from a run saved with --save")
    args = parser.parse_args(argv)
    if args.out_dir is None:
        args.out_dir = common.figures_dir(args.doc)
    if args.replot is not None:
        cases, mach, quick, elapsed, today = load_run(args.replot)
    else:
        t0 = time.perf_counter()
        mach = machine()
        print(f"machine: {mach}")
        # set-up CPU times must not come from flexfmu's on-disk cache of models and modal bases
        saved = os.environ.get("FLEXFMU_CACHE")
        os.environ["FLEXFMU_CACHE"] = "0"
        try:
            cases = run(args.quick, args.case)
        finally:
            if saved is None:
                os.environ.pop("FLEXFMU_CACHE", None)
            else:
                os.environ["FLEXFMU_CACHE"] = saved
        quick, elapsed = args.quick, time.perf_counter() - t0
        today = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        if args.save is not None:
            save_run(args.save, cases, mach, quick, elapsed, today)
    plt = common.pyplot()
    if plt is None:
        print(common.skipped("the charts", "matplotlib"))
        figures = [None] * len(cases)
    else:
        args.out_dir.mkdir(parents=True, exist_ok=True)
        figures = [plot_case(c, args.out_dir / f"work_precision_{c.key}.png", plt) for c in cases]
        for f in figures:
            print(f"wrote {f}")
    for c in cases:
        print(f"\n{c.title}:")
        for sentence in conclusions(c):
            print(f"  - {sentence}")
    if args.doc != "-":
        write_report(Path(args.doc), cases, figures, mach, quick, elapsed, NOTES, today,
                     replotted=args.replot is not None)
        print(f"wrote {args.doc}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
