"""The reframe-body cases of the work-precision study (flexfmu.studies.work_precision): the paper's plate and the
free-free bent rod, their runs with every reframe scheme and the fixed-frame baseline, the sweeps over time step,
modes and mesh, the automatic model choice and the stored Exudyn trajectory of the plate."""
from __future__ import annotations

import gc
import math
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexfmu.errors import FlexfmuError
from flexfmu.studies.references import reference_path
from flexfmu.studies.work_precision_measure import (Case, Point, best_cpu, reframe_auto_available,
                                                    reframe_schemes, refused, relative_max_error)


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
    from flexfmu.core.structure import N_RIGID
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
                refused(case, "dt", _method_name(scheme), dt, f"{dt:.3g} s", exc)
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
                refused(case, "modes", _method_name(scheme), n, str(n), exc)
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
                refused(case, "mesh", _method_name(scheme), 0, bc.mesh_label(mesh), exc)
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
            refused(bc.case, "modes", "reframe consistent", 0, "automatic", exc)
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
