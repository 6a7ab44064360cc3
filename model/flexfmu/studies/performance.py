#!/usr/bin/env python3
"""Performance figures: figure, ours, peer or limit, ratio; writes docs/performance.md.

    flexfmu bench [performance] [--quick] [--out REPORT.md | -]
    .venv/bin/python benchmarks/performance.py [--quick] [--out ...]        (the same)

CPU time for per-step figures, wall time for set-up (see performance_timing.CLOCK); shared 2-core machine: expect +-20 %
between runs; every ratio in a table comes from the same run.  --quick extrapolates the 60 s records
from 1 s and skips the largest meshes, the default plate and Exudyn.  The report defaults to docs/performance.md
of a source checkout, else ./performance.md; without Exudyn its comparison is skipped.

The measurements are in performance_library (the library itself), performance_fmus (the FMUs through fmpy) and
performance_timing (clock, memory, machine); the report is written by performance_report.
"""
from __future__ import annotations

import argparse
import gc
import os
import tempfile
import time
from pathlib import Path

from flexfmu.studies import common
from flexfmu.studies.performance_fmus import (FFR_HAMMER_START, HAMMER_DT, HAMMER_RECORD, build_fmus, build_noop_fmu,
                                              ffrbeam_library_step, ffrbeam_lowlevel, fmu_instantiation,
                                              noop_fmu_calls, record_time, reframebody_calls, simulate_fmu_record)
from flexfmu.studies.performance_library import (exudyn_comparison, frame_modal_time, plate_integrator,
                                                 reframe_step_times, scaling_row, scaling_row_subprocess)
from flexfmu.studies.performance_report import fmt_t, write_report
from flexfmu.studies.performance_timing import machine, peak_memory_mb


def run(quick: bool) -> tuple[list, list, dict]:
    rows, notes, extra = [], [], {}

    def row(figure, ours, peer, ratio, note=""):
        rows.append((figure, ours, peer, "–" if ratio is None else f"{ratio:.2f}", note))
        print(f"{figure:60s} {ours:>12s} {peer:>14s} {rows[-1][3]:>6s} {note}", flush=True)

    print(f"{'figure':60s} {'ours':>12s} {'peer / limit':>14s} {'ratio':>6s}")
    from flexfmu.reframe import kernels as kern

    # (2) per step, m = 16, and (1) mesh independence
    small, info_s = plate_integrator((10, 2, 1))
    one, batch, outs, outs_lean = reframe_step_times(small)
    row("reframe step, m = 16, one advance() call", fmt_t(one), "20 µs", one / 20e-6, f"{info_s['n_dof']} DOFs")
    row("reframe step, m = 16, batched (advance_steps, FMU)", fmt_t(batch), "20 µs", batch / 20e-6)
    row("reframe outputs of one state (output_vector)", fmt_t(outs), "–", None)
    row("  without the max elastic displacement search", fmt_t(outs_lean), "–", None, "O(modes²): all other outputs")
    expo, _ = plate_integrator((10, 2, 1), scheme="exponential")
    _, batch_exp, _, _ = reframe_step_times(expo)
    row("reframe step, m = 16, exponential scheme (FMU default), batched", fmt_t(batch_exp), "20 µs",
        batch_exp / 20e-6, "same dt")
    del expo
    if kern.NATIVE:
        kern_backup = kern.consistent_steps
        kern.consistent_steps = kern.consistent_steps_numpy
        _, batch_np, _, _ = reframe_step_times(small, n=200)
        kern.consistent_steps = kern_backup
        row("reframe step, m = 16, numpy fallback (FLEXFMU_NATIVE_KERNELS=0)", fmt_t(batch_np), fmt_t(batch),
            batch_np / batch, "vs C")
    big_div = (40, 6, 2) if quick else (70, 8, 2)
    big, info_b = plate_integrator(big_div)
    _, batch_big, outs_big, outs_lean_big = reframe_step_times(big)
    row(f"reframe step, m = 16, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(batch_big), fmt_t(batch),
        batch_big / batch, "limit 1.2")
    row(f"reframe outputs, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(outs_big), fmt_t(outs),
        outs_big / outs, "max elastic displacement search")
    row(f"reframe outputs without that search, {info_b['n_dof']} vs {info_s['n_dof']} DOFs", fmt_t(outs_lean_big),
        fmt_t(outs_lean), outs_lean_big / outs_lean, "limit 1.2")
    del big
    gc.collect()

    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        fmus = build_fmus(tmp / "dist")
        noop = build_noop_fmu(tmp)
        from flexfmu.core.io import save_structure
        npz = save_structure(tmp / "plate_10x2x1.npz", small.data.structure)
        noop_calls = noop_fmu_calls(noop)
        floor = noop_calls["cycle"]
        row("fmpy + pythonfmu floor per call (no-op FMU): setReal(3) / doStep / getReal(6)",
            " / ".join(fmt_t(noop_calls[c]) for c in ("setReal", "doStep", "getReal")), "–", None,
            "median per call")
        rb = reframebody_calls(fmus["ReframeBody"], npz)
        fmu, held, lib, lib_held = rb["fmu"], rb["fmu_held"], rb["lib"], rb["lib_held"]
        lib_step = lib["set_input_vector"] + lib["step"]
        row("ReframeBody.fmu doStep (10 internal steps, new force each call) through fmpy", fmt_t(fmu["doStep"]),
            "–", None, "median per call")
        row("  the library: set_input_vector + step (10 internal steps)", fmt_t(lib_step), "–", None,
            f"{fmt_t(lib['set_input_vector'])} + {fmt_t(lib['step'])}")
        row("  doStep overhead: doStep − library", fmt_t(fmu["doStep"] - lib_step), "10 µs",
            (fmu["doStep"] - lib_step) / 10e-6, f"floor (no-op doStep) {fmt_t(noop_calls['doStep'])}")
        row("  doStep overhead, force held: doStep − library step", fmt_t(held["doStep"] - lib_held["step"]),
            "10 µs", (held["doStep"] - lib_held["step"]) / 10e-6, "no input change")
        row("  setReal(3 forces)", fmt_t(fmu["setReal"]), fmt_t(noop_calls["setReal"]),
            fmu["setReal"] / noop_calls["setReal"], "vs no-op FMU")
        row("  getReal(6 outputs), computed on this first read", fmt_t(fmu["getReal"]),
            fmt_t(noop_calls["getReal"] + lib["output_vector"]), fmu["getReal"] / (noop_calls["getReal"]
                                                                               + lib["output_vector"]),
            f"vs no-op getReal + library outputs {fmt_t(lib['output_vector'])}")
        row("  getReal(max_elastic_displacement) after those", fmt_t(rb["fmu_max"]["getReal max"]), "–", None,
            "the deferred whole-mesh search")
        cycle = fmu["setReal"] + fmu["doStep"] + fmu["getReal"]
        lib_cycle = lib_step + lib["output_vector"]
        noop_cycle = noop_calls["setReal"] + noop_calls["doStep"] + noop_calls["getReal"]
        row("  whole call cycle setReal + doStep + getReal − library (incl. outputs)", fmt_t(cycle - lib_cycle),
            "10 µs", (cycle - lib_cycle) / 10e-6, f"of which the no-op floor {fmt_t(noop_cycle)}")
        row("  the same beyond the floor", fmt_t(cycle - lib_cycle - noop_cycle), "10 µs",
            (cycle - lib_cycle - noop_cycle) / 10e-6, "our FMU layer")

        lib = ffrbeam_library_step()
        row("FFRBeam step + outputs, library (XFF, 6 modes)", fmt_t(lib), "–", None)
        duration = 1.0 if quick else HAMMER_RECORD
        low, how = record_time(lambda d: ffrbeam_lowlevel(fmus["FFRBeam"], d)["seconds"], duration)
        row("FFRBeam 60 s hammer record @ 10 kS/s, fmpy FMU2Slave loop", fmt_t(low), "12 s", low / 12.0, how)
        floor_low = floor * HAMMER_RECORD / HAMMER_DT
        row("  beyond the FMU2Slave floor (600 000 × no-op step)", fmt_t(low - floor_low), fmt_t(floor_low),
            None, "ours / floor: " + f"{(low - floor_low) / floor_low:.2f}")
        sim, how = record_time(lambda d: simulate_fmu_record(fmus["FFRBeam"], d, ("F_x", "F_y", "F_z"),
                                                             [f"sensor_a_{a}" for a in "xyz"], FFR_HAMMER_START),
                               duration)
        sim_floor, _ = record_time(lambda d: simulate_fmu_record(noop, d, ("i0", "i1", "i2"), ("o0", "o1", "o2"), {}),
                                   duration)
        row("FFRBeam 60 s hammer record, fmpy.simulate_fmu (user's route)", fmt_t(sim), "12 s", sim / 12.0, how)
        row("  the same simulate_fmu call on the no-op FMU (floor)", fmt_t(sim_floor), "12 s", sim_floor / 12.0,
            "fmpy input + recorder + pythonfmu")
        row("  FFRBeam beyond that floor", fmt_t(sim - sim_floor), fmt_t(sim_floor), (sim - sim_floor) / sim_floor)

        t_ffr = fmu_instantiation(fmus["FFRBeam"])
        row("FFRBeam.fmu instantiation (default, fresh process)", fmt_t(t_ffr), "1 s", t_ffr / 1.0)
        t_npz = fmu_instantiation(fmus["ReframeBody"], model=str(npz))
        row(f"ReframeBody.fmu instantiation ({info_s['n_dof']}-DOF .npz, fresh process)", fmt_t(t_npz), "1 s",
            t_npz / 1.0)
        if not quick:
            t_cold = fmu_instantiation(fmus["ReframeBody"], env={"FLEXFMU_CACHE": "0"})
            row("ReframeBody.fmu instantiation, default plate 51k DOFs, no model cache", fmt_t(t_cold), "1 s",
                t_cold / 1.0, "fresh process, FLEXFMU_CACHE=0")
            fmu_instantiation(fmus["ReframeBody"])                  # fills the on-disk cache if empty
            t_warm = fmu_instantiation(fmus["ReframeBody"])
            row("ReframeBody.fmu instantiation, default plate 51k DOFs, cache warm", fmt_t(t_warm), "1 s",
                t_warm / 1.0, "fresh process, on-disk model cache")

    # (4) Exudyn
    if not quick:
        ex = exudyn_comparison(quick)
        extra["exudyn"] = ex
        if ex is None:
            print(common.skipped("the comparison with Exudyn", "exudyn"), flush=True)
        for scheme, at in (ex or {}).get("ours_at", {}).items():
            theirs = ex["exudyn_at"]
            if at and theirs:
                row(f"CPU time to 1e-4 in ω and deflection vs Exudyn, {scheme}", fmt_t(at[1]), fmt_t(theirs[1]),
                    at[1] / theirs[1], f"dt ours {at[0]:g}, Exudyn {theirs[0]:g}")
            else:
                row(f"CPU time to 1e-4 in ω and deflection vs Exudyn, {scheme}", "–", "–", None,
                    "1e-4 not reached by " + ("ours" if not at else "Exudyn"))

    # (5) set-up
    n_frame, t_frame = frame_modal_time()
    row(f"frame set-up: mesh + assembly + 10 modes, {n_frame} DOFs", fmt_t(t_frame), "2 s", t_frame / 2.0)
    if not quick:
        from flexfmu.linalg.modal_basis import _mkl_pardiso, modal_basis
        from flexfmu.reframe.models import load_model
        pardiso = _mkl_pardiso() is not None and os.environ.get("FLEXFMU_PARDISO", "1") != "0"
        _, info_d = plate_integrator((100, 8, 2))
        row(f"plate set-up: mesh + assembly, {info_d['n_dof']} DOFs", fmt_t(info_d["assembly"]), "–", None)
        row(f"plate modal basis (10 flexible), {info_d['n_dof']} DOFs", fmt_t(info_d["modal"]), "2 s",
            info_d["modal"] / 2.0, "block Lanczos, shift-invert, computed, "
            + ("MKL PARDISO (pardiso extra)" if pardiso else "SuperLU (no pardiso extra)"))
        if pardiso:                        # the same without the optional extra
            os.environ["FLEXFMU_PARDISO"] = "0"
            try:
                plate = load_model("paper_plate")
                t0 = time.perf_counter()
                modal_basis(plate, 10, cache=False)
                t_superlu = time.perf_counter() - t0
            finally:
                del os.environ["FLEXFMU_PARDISO"]
            row("  the same with SuperLU (FLEXFMU_PARDISO=0, the default install)", fmt_t(t_superlu), "2 s",
                t_superlu / 2.0, "scipy's direct solver only")
        row(f"plate reframe invariants, {info_d['n_dof']} DOFs", fmt_t(info_d["integrator"]), "–", None)
        modal_basis(load_model("paper_plate"), 10)                    # fills the cache if empty
        t0 = time.perf_counter()
        modal_basis(load_model("paper_plate"), 10)
        t_hit = time.perf_counter() - t0
        row(f"plate model + modal basis from the on-disk cache, {info_d['n_dof']} DOFs", fmt_t(t_hit), "2 s",
            t_hit / 2.0, "load_model + modal_basis, cache hit")

    # (6) scaling: each row in a fresh process (its own peak memory)
    scaling = []
    base_div = (20, 2, 1)
    for nfx in (0, 10, 30, 50, 100):
        r = scaling_row_subprocess(base_div, nfx, 500 if nfx >= 50 else 2000)
        scaling.append(("modes", r))
        print(f"  scaling modes m={r['modes']}: step {fmt_t(r['step'])}", flush=True)
    for div in ((10, 2, 1), (40, 4, 1), (80, 6, 2)) + (() if quick else ((100, 8, 2), (150, 10, 2))):
        r = scaling_row_subprocess(div, 10, 1000)
        scaling.append(("mesh", r))
        print(f"  scaling mesh {r['n_dof']} DOFs: step {fmt_t(r['step'])}, set-up "
              f"{fmt_t(r['assembly'] + r['modal'] + r['integrator'])}, {r['peak_rss_mb']:.0f} MB", flush=True)
    extra["scaling"] = scaling
    extra["peak_rss_mb"] = peak_memory_mb()
    return rows, notes, extra


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short records, no 51k-DOF plate, no Exudyn")
    parser.add_argument("--out", default=str(common.default_report_dir() / "performance.md"),
                        help="report file (default: docs/performance.md of a source checkout, else ./performance.md); "
                             "'-' prints only")
    parser.add_argument("--scaling-row", help=argparse.SUPPRESS)     # nx,ny,nz:n_flexible:n_steps (internal)
    args = parser.parse_args(argv)
    if args.scaling_row:
        import json
        div, nfx, n_steps = args.scaling_row.split(":")
        print(json.dumps(scaling_row(tuple(int(v) for v in div.split(",")), int(nfx), int(n_steps))))
        return 0
    t0 = time.perf_counter()
    mach = machine()
    print(f"machine: {mach}")
    rows, _, extra = run(args.quick)
    if args.out != "-":
        write_report(Path(args.out), rows, extra, mach, args.quick, time.perf_counter() - t0)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
