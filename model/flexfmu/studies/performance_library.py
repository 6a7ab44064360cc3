"""The performance study's figures of the library itself (flexfmu.studies.performance): reframe steps and outputs
on the paper's plate, the set-up of a frame model, the scaling rows (each in a fresh process) and the CPU time to
an accuracy against Exudyn."""
from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np

from flexfmu.studies.performance_timing import best_time, peak_memory_mb

FORCE = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)   # the reframe paper's load, 10 ms half-sine


# --------------------------------------------------------------------------- reframe
def plate_integrator(divisions, n_flexible=10, scheme="consistent"):
    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.plate import paper_plate
    from flexfmu.reframe.integrator import ReframeIntegrator

    t0 = time.perf_counter()
    plate = paper_plate(divisions)
    t1 = time.perf_counter()
    basis = modal_basis(plate, n_flexible, cache=False)          # the computation, not the on-disk cache
    t2 = time.perf_counter()
    integ = ReframeIntegrator(plate, basis, scheme=scheme)
    t3 = time.perf_counter()
    return integ, {"assembly": t1 - t0, "modal": t2 - t1, "integrator": t3 - t2, "n_dof": plate.n_dof}


def reframe_step_times(integ, n=2000):
    """(single advance() call, batched advance_steps, output_vector, output_vector without the max elastic
    displacement search) per call, s; paper's load, moving."""
    from flexfmu.reframe.plate import LOAD_POINT
    from flexfmu.reframe.integrator import RK4_STABILITY_LIMIT, PointLoad, half_sine_pulse

    # the paper's 1e-4 s, or less where many retained modes need it (RK4: dt * omega_max <= 2.8)
    dt = min(1e-4, 0.9 * RK4_STABILITY_LIMIT / integ.data.omega_max) if integ.data.omega_max > 0 else 1e-4
    loads = integ.prepare_loads(PointLoad(LOAD_POINT, half_sine_pulse(FORCE, 0.01)))
    s0 = integ.initial_state(omega0=(0.5, 0.2, 0.8))
    s0 = integ.advance_steps(s0, dt, 20, loads)              # loaded, deforming, compiled
    pts = integ.point_indices([integ.data.structure.points["P1"]])

    def single():
        s = s0
        for _ in range(n):
            s = integ.advance(s, dt, loads)

    def batched():
        integ.advance_steps(s0, dt, n, loads)

    def outputs(max_elastic=True):
        for _ in range(n // 10):
            integ.output_vector(s0, loads, pts, max_elastic=max_elastic)

    return (best_time(single) / n, best_time(batched) / n, best_time(outputs) / (n // 10),
            best_time(lambda: outputs(False)) / (n // 10))


# --------------------------------------------------------------------------- set-up
def frame_modal_time(target_dof=10_000) -> tuple[int, float]:
    from flexfmu.ffr.assembly import build_beam_model
    from flexfmu.linalg.modal import solve_modes
    from flexfmu.ffr.scene import load_scene
    scene = load_scene("spatial_double_L")
    n_seg = len(scene.points) - 1
    eps = max(1, int(round(target_dof / (6 * n_seg))))
    t0 = time.perf_counter()
    model = build_beam_model(scene, "XFF", eps)
    solve_modes(model.K_free, model.M_free, 10)
    return model.n_free, time.perf_counter() - t0


# --------------------------------------------------------------------------- scaling
def scaling_row(divisions, n_flexible: int, n_steps: int) -> dict:
    """One scaling row, meant for a fresh process (its peak memory is the row's): set-up times, batched
    step and outputs of a state, peak resident memory."""
    integ, info = plate_integrator(divisions, n_flexible)
    _, batch, outs, _ = reframe_step_times(integ, n=n_steps)
    return {**info, "modes": 6 + n_flexible, "step": batch, "outputs": outs, "peak_rss_mb": peak_memory_mb()}


def scaling_row_subprocess(divisions, n_flexible: int, n_steps: int) -> dict:
    import json
    arg = ",".join(map(str, divisions)) + f":{n_flexible}:{n_steps}"
    out = subprocess.run([sys.executable, "-P", "-m", "flexfmu.studies.performance", "--scaling-row", arg],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


# --------------------------------------------------------------------------- Exudyn
def exudyn_comparison(quick: bool) -> dict | None:
    """CPU time to reach 1e-4 relative accuracy in omega and in the loaded point's elastic deflection,
    against the converged Exudyn reference trajectory (flexfmu/data/references/exudyn_plate, dt = 2.5e-6 s), for
    the reframe integrator (consistent and exponential schemes) and for Exudyn's own reduced-order FFRF
    (GeneralizedAlpha), both 1 s of the paper's load on the same plate (20x2x1), M, K, nodes and ten
    flexible modes."""
    try:
        import exudyn  # noqa: F401
    except ImportError:
        return None
    from flexfmu.studies.references import load_generator, reference_path
    gen = load_generator("exudyn_plate")
    lines = [line for line in reference_path("exudyn_plate").read_text().splitlines()
             if line.strip() and not line.startswith("#")]
    cols = {name: k for k, name in enumerate(lines[0].split(","))}              # the header row
    ref = np.loadtxt(lines[1:], delimiter=",")
    after = ref[:, 0] > 0.012
    w_ref = ref[:, [cols[f"omega_{i}"] for i in (1, 2, 3)]]
    u_ref = ref[:, [cols[f"u_load_{c}"] for c in "xyz"]]

    def errors(w, u):
        ew = np.max(np.linalg.norm(w[after] - w_ref[after], axis=1)) / np.max(np.linalg.norm(w_ref[after], axis=1))
        eu = np.max(np.linalg.norm(u - u_ref, axis=1)) / np.max(np.linalg.norm(u_ref, axis=1))
        return float(ew), float(eu)

    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.plate import LOAD_POINT, paper_plate
    from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, half_sine_pulse
    plate = paper_plate(gen.DIVISIONS)
    basis = modal_basis(plate, gen.N_FLEXIBLE, gen.ZETA)
    load = PointLoad(LOAD_POINT, half_sine_pulse(gen.FORCE, gen.PULSE))
    by_scheme = {}
    for scheme, steps in (("consistent", (5e-4, 2.5e-4, 1e-4, 5e-5, 2.5e-5)),
                          ("exponential", (1e-3, 5e-4, 2.5e-4, 1e-4, 5e-5))):   # divide the 1 ms output
        integ = ReframeIntegrator(plate, basis, scheme=scheme)
        node = integ.point_indices([LOAD_POINT])[0]
        Phi_load = integ.data.Phi[integ.data.trans_rows[node]]
        integ.run(0.01, 1e-4, load)                     # warm-up (kernel loading): not timed
        rows = []
        for dt in (steps[1:4] if quick else steps):
            every = int(round(gen.OUTPUT_PERIOD / dt))
            integ.set_initial()
            t0 = time.process_time()
            r = integ.run(gen.T_END, dt, load, every=every)
            cpu = time.process_time() - t0
            rows.append((dt, cpu, *errors(r.omega, r.q @ Phi_load.T)))
        by_scheme[scheme] = rows
    plate_fem, fem, _ = gen.build_fem()
    gen.simulate(fem, dt=1e-4, t_end=0.01)              # warm-up: not timed
    theirs = []
    for dt in ((1e-4, 5e-5) if quick else (2e-4, 1e-4, 5e-5, 2.5e-5)):
        t0 = time.process_time()
        table, _ = gen.simulate(fem, dt=dt)
        cpu = time.process_time() - t0
        theirs.append((dt, cpu, *errors(table[:, 1:4], table[:, 4:7])))

    def time_to(rows, tol=1e-4):
        ok = [r for r in rows if max(r[2], r[3]) <= tol]
        return min(ok, key=lambda r: r[1]) if ok else None
    return {"ours": by_scheme, "exudyn": theirs, "ours_at": {k: time_to(v) for k, v in by_scheme.items()},
            "exudyn_at": time_to(theirs)}
