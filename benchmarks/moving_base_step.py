#!/usr/bin/env python3
"""Cost of a clamped body's step when its base moves at every step (the wave converter's harvester: FFRBeam XFF on
the platform), old and new, and what the new step changes in the wave converter's run.

    .venv/bin/python benchmarks/moving_base_step.py [--steps 3000] [--rounds 3] [--t-end 20] [--skip-native]
                                                    [--skip-wec]

1. Python simulator (FFRBeamSimulator, the example's harvester parameters), per cycle set_input_vector + step +
   output_vector at h = 1 ms: fixed base (loads varying, base motion held), moving base by the maps (one exponential
   and fast_maps per step: the old path, moving_base_series = False), moving base by the series (the new path,
   flexfmu.native.lti_taylor).  Rounds interleave the three; each figure the median over rounds.
2. Native FMU (flexfmu build --runtime native, the same parameters) in a tiny C host (no Python in the loop): per
   step fmi2SetReal of the 15 inputs, fmi2DoStep, fmi2GetReal of the 9 outputs the example connects; fixed and
   moving base; the old path is the FMU's library rebuilt from its sources/ with -DFFX_LTI_NO_SERIES.  Fastest of
   --rounds runs each.
3. The wave converter (examples/wave_converter, library master, Gauss-Seidel, 1 ms) over --t-end s with the
   harvester by the series and by the maps: the harvester's outputs' largest difference (relative to each output's
   largest value), how its steps went (series / the cached maps / a new exponential), wall times; then the C kernel
   (flexfmu.native.lti.LtiSimulator: the native FMU's step) on the harvester's recorded inputs: the same outputs
   and its step counts.
4. Why not a first-order update: on the same recorded base motion (--frechet-steps of it), the maps at an anchor p0
   plus their Frechet derivative in p - p0 (expm(X0 + E) ~ expm(X0) + L(X0, E), E = X(p) - X(p0), X = [[hA, hB],
   [0, 0]] of FFRBeamDynamics' own system, the modal-force input): the fraction of steps that must re-anchor (a new
   exponential and new derivatives) to keep the *true* remainder ||expm(X0 + E) - expm(X0) - L(X0, E)|| (balanced
   2-norm: D^-1 . D with the series' weights) below 1e-12, i.e. with an oracle in place of any bound.

Ratios are within one run (the machine's load moves all figures of a run alike); no figure here is asserted.
"""
from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
HARVESTER = dict(scene="spatial_double_L", boundary="XFF", elements_per_segment=8, n_modes=6, damping_ratio=0.01,
                 load_s=0.45, sensor_s=0.45)
CONNECTED = ("reaction_F_x", "reaction_F_y", "reaction_F_z", "reaction_M_x", "reaction_M_y", "reaction_M_z",
             "sensor_v_x", "sensor_v_y", "sensor_v_z")
H = 1e-3


def platform(t: float) -> np.ndarray:
    """a0 (m/s^2), w (rad/s), dw (rad/s^2) of a floating platform at t (body frame): the size and periods of the wave
    converter's run (w_y 0.3 rad/s at 1.4 s)."""
    w = np.array([0.08 * np.sin(4.49 * t), 0.3 * np.sin(4.49 * t + 0.7), 0.02 * np.sin(3.1 * t)])
    dw = np.array([0.08 * 4.49 * np.cos(4.49 * t), 0.3 * 4.49 * np.cos(4.49 * t + 0.7), 0.02 * 3.1 * np.cos(3.1 * t)])
    a0 = np.array([0.35 * np.sin(4.49 * t + 1.0), 0.15 * np.cos(4.49 * t), 0.7 * np.sin(4.49 * t + 2.0)])
    return np.concatenate([a0, w, dw])


# ---------------------------------------------------------------------------------------------- 1. Python
def python_costs(steps: int, rounds: int) -> dict:
    from flexfmu.ffr.simulator import INPUT_NAMES, FFRBeamConfig, FFRBeamSimulator
    motion = np.array([platform(k * H) for k in range(steps)])

    def cycle_cost(case: str) -> float:
        sim = FFRBeamSimulator(FFRBeamConfig(**HARVESTER))
        sim.moving_base_series = case != "moving, maps (old)"
        u = np.zeros(len(INPUT_NAMES))
        for k in range(3):                                   # warm-up: the first maps, the polynomials
            u[6:15] = motion[k] if case != "fixed base" else motion[0]
            sim.set_input_vector(u)
            sim.step(H)
            sim.output_vector()
        t0 = time.perf_counter()
        for k in range(steps):
            u[:3] = (np.sin(40.0 * k * H), 0.5, 0.2)
            u[6:15] = motion[k] if case != "fixed base" else motion[0]
            sim.set_input_vector(u)
            sim.step(H)
            sim.output_vector()
        return (time.perf_counter() - t0) / steps * 1e6

    cases = ("fixed base", "moving, maps (old)", "moving, series (new)")
    samples = {c: [] for c in cases}
    for _ in range(rounds):
        for c in cases:
            samples[c].append(cycle_cost(c))
    return {c: statistics.median(v) for c, v in samples.items()}


# ---------------------------------------------------------------------------------------------- 2. native
HOST = r"""
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c, fmi2String m, ...) {
    (void)e, (void)n, (void)c;
    if (s >= fmi2Warning) fprintf(stderr, "[%d] %s\n", s, m);
}
#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)
/* library resources guid steps h moving vr_in[15] vr_out[9] */
int main(int argc, char **argv) {
    (void)argc;
    void *lib = dlopen(argv[1], RTLD_NOW);
    if (!lib) return fprintf(stderr, "%s\n", dlerror()), 1;
    LOAD(fmi2Instantiate); LOAD(fmi2SetupExperiment); LOAD(fmi2EnterInitializationMode);
    LOAD(fmi2ExitInitializationMode); LOAD(fmi2DoStep); LOAD(fmi2GetReal); LOAD(fmi2SetReal);
    LOAD(fmi2FreeInstance);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("bench", fmi2CoSimulation, argv[3], argv[2], &cb, fmi2False, fmi2False);
    if (!c) return 2;
    long steps = atol(argv[4]);
    double h = atof(argv[5]);
    int moving = atoi(argv[6]);
    fmi2ValueReference vin[15], vout[9];
    for (int i = 0; i < 15; i++) vin[i] = (fmi2ValueReference)atol(argv[7 + i]);
    for (int i = 0; i < 9; i++) vout[i] = (fmi2ValueReference)atol(argv[22 + i]);
    fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0);
    fmi2EnterInitializationMode(c);
    if (fmi2ExitInitializationMode(c) != fmi2OK) return 3;
    double u[15] = {0}, y[9], sink = 0.0, t = 0.0;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (long k = 0; k < steps; k++) {
        double tb = moving ? t : 0.0; /* fixed base: the platform's motion at t = 0, held */
        u[0] = sin(40.0 * t), u[1] = 0.5, u[2] = 0.2;
        u[6] = 0.35 * sin(4.49 * tb + 1.0), u[7] = 0.15 * cos(4.49 * tb), u[8] = 0.7 * sin(4.49 * tb + 2.0);
        u[9] = 0.08 * sin(4.49 * tb), u[10] = 0.3 * sin(4.49 * tb + 0.7), u[11] = 0.02 * sin(3.1 * tb);
        u[12] = 0.08 * 4.49 * cos(4.49 * tb), u[13] = 0.3 * 4.49 * cos(4.49 * tb + 0.7);
        u[14] = 0.02 * 3.1 * cos(3.1 * tb);
        if (fmi2SetReal(c, vin, 15, u) != fmi2OK) return 4;
        if (fmi2DoStep(c, t, h, fmi2True) != fmi2OK) return 5;
        t += h;
        if (fmi2GetReal(c, vout, 9, y) != fmi2OK) return 6;
        sink += y[0];
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    printf("%.9f %g\n", (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec), sink);
    fmi2FreeInstance(c);
    return 0;
}
"""


def native_costs(steps: int, rounds: int) -> dict:
    from fmpy import extract, read_model_description

    from flexfmu.ffr.simulator import INPUT_NAMES
    from flexfmu.fmi.native import build_registry_fmu
    from flexfmu.fmi.runtime import _fmi2_headers
    from flexfmu.native.compiler import KERNEL_FLAGS, find_compiler
    settings = {k: v for k, v in HARVESTER.items() if k in ("load_s", "sensor_s")}
    folder = Path(tempfile.mkdtemp(prefix="moving-base-"))
    try:
        fmu = build_registry_fmu("FFRBeam", settings, target=folder / "FFRBeam.fmu")
        unzipped = Path(extract(str(fmu), str(folder / "fmu")))
        (folder / "host.c").write_text(HOST)
        host = folder / "host"
        subprocess.run([find_compiler(), "-O2", "-std=c99", "-D_POSIX_C_SOURCE=200809L", f"-I{_fmi2_headers()}",
                        str(folder / "host.c"), "-o", str(host), "-ldl", "-lm"], check=True)
        src = unzipped / "sources"
        files = [str(p) for p in sorted(src.glob("*.c")) if p.name not in ("flexfmu_fmi2.c", "front_common.c")]
        old = folder / "FFRBeam_no_series.so"
        subprocess.run([find_compiler(), *KERNEL_FLAGS, "-shared", "-fvisibility=hidden", "-Wno-format-truncation",
                        "-DFFX_LTI_NO_SERIES", f"-I{src}", *files, "-o", str(old), "-lm", "-lpthread", "-ldl"],
                       check=True)
        new = unzipped / "binaries" / "linux64" / "FFRBeam.so"
        md = read_model_description(str(fmu))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        args = [str(vr[n]) for n in INPUT_NAMES] + [str(vr[n]) for n in CONNECTED]

        def run(library: Path, moving: int) -> float:
            best = float("inf")
            for _ in range(rounds):
                done = subprocess.run([str(host), str(library), (unzipped / "resources").as_uri(), md.guid,
                                       str(steps), repr(H), str(moving), *args], capture_output=True, text=True)
                if done.returncode:
                    raise RuntimeError(f"host exit {done.returncode}: {done.stderr}")
                best = min(best, float(done.stdout.split()[0]))
            return best / steps * 1e6

        return {"fixed base": run(new, 0), "moving, maps (old)": run(old, 1), "moving, series (new)": run(new, 1)}
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def print_costs(title: str, costs: dict) -> None:
    fixed = costs["fixed base"]
    print(f"\n{title}\n| case | us per cycle | / fixed base |\n|---|---|---|")
    for case, us in costs.items():
        print(f"| {case} | {us:.2f} | {us / fixed:.2f} |")
    print(f"old / new (moving base): {costs['moving, maps (old)'] / costs['moving, series (new)']:.1f}")


# ---------------------------------------------------------------------------------------------- 3. the example
def wave_converter(t_end: float) -> None:
    from flexfmu.cosim.masters import load_system, run
    from flexfmu.ffr.simulator import OUTPUT_NAMES, FFRBeamConfig, FFRBeamSimulator
    from flexfmu.native.lti import LtiModel, LtiSimulator
    system = load_system(ROOT / "examples" / "wave_converter" / "OspSystemStructure.xml")
    results = {}
    for series in (True, False):
        def record(slaves, series=series):
            sim = slaves["harvester"].sim
            sim.moving_base_series = series
            return {"series": sim._series_last, "inputs": sim._u.copy(), "outputs": sim.output_vector()}
        t0 = time.perf_counter()
        res = run(system, t_end, backend="library", scheme="gauss-seidel", record=record)
        results[series] = (res, time.perf_counter() - t0)
    new, old = results[True][0], results[False][0]
    took = new.extra["series"][1:]
    inputs = new.extra["inputs"]
    held = inputs[:, 9:15]
    changed = np.any(held[1:] != held[:-1], axis=1)             # step k+1's base motion against step k's
    n = took.size
    fresh = int(np.sum(changed & ~took))
    print(f"\nwave converter, {t_end:g} s at {system.base_step:g} s ({n} steps), library master, Gauss-Seidel:")
    print(f"  harvester steps by the series {int(took.sum())} ({took.mean():.2%}), by a new exponential {fresh} "
          f"({fresh / n:.2%}), by the cached maps {n - int(took.sum()) - fresh}")
    a, b = new.extra["outputs"], old.extra["outputs"]
    scale = np.abs(b).max(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    diff = np.abs(a - b).max(axis=0) / scale
    worst = int(np.argmax(diff))
    print(f"  harvester outputs, series run against the maps (exponential) run: largest difference "
          f"{diff[worst]:.2e} of the output's largest value ({OUTPUT_NAMES[worst]})")
    cols = [c for c in new.columns if not c.startswith("harvester.")]
    other = max(float(np.max(np.abs(new.columns[c] - old.columns[c])) / max(float(np.max(np.abs(old.columns[c]))),
                                                                            1e-300)) for c in cols)
    print(f"  the other FMUs' outputs: largest relative difference {other:.2e}")
    print(f"  wall time: series {results[True][1]:.1f} s, maps {results[False][1]:.1f} s "
          f"(ratio {results[False][1] / results[True][1]:.2f})")
    # the C kernel on the harvester's recorded inputs
    sim = FFRBeamSimulator(FFRBeamConfig(**HARVESTER))
    native = LtiSimulator(LtiModel.from_ffrbeam(sim))
    rows = []
    for k in range(1, inputs.shape[0]):
        native.set_input_vector(inputs[k])
        native.step(system.base_step)
        rows.append(native.output_vector())
    c_diff = np.abs(np.array(rows) - a[1:]).max(axis=0) / scale
    print(f"  C kernel (LtiSimulator) on the harvester's recorded inputs against the series run: largest difference "
          f"{c_diff.max():.2e}; its steps by the series {native.kernel.series_steps} of {n}, new exponentials "
          f"{native.kernel.counters[0]}")
    return inputs


def frechet_anchors(inputs: np.ndarray, steps: int, tolerance: float = 1e-12) -> None:
    import scipy.linalg as sla

    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    sim = FFRBeamSimulator(FFRBeamConfig(**HARVESTER))
    dyn = sim.dynamics
    mb = sim._moving_model()
    m = dyn.m
    d = np.concatenate([mb.system.weights, np.ones(m)])

    def X(p):
        A = dyn.system_matrix(mb.base(p))
        M = np.zeros((3 * m, 3 * m))
        M[:2 * m, :2 * m] = A
        M[m:2 * m, 2 * m:] = np.eye(m)
        return H * M

    def norm(Y):
        return float(np.linalg.norm(Y * d[None, :] / d[:, None], 2))

    anchors, X0, E0 = 0, None, None
    worst = 0.0
    for k in range(1, min(steps, inputs.shape[0])):
        Xk = X(inputs[k, 9:15])
        if X0 is not None:
            E = Xk - X0
            L = sla.expm_frechet(X0, E, compute_expm=False)
            remainder = norm(sla.expm(Xk) - E0 - L)
            if remainder <= tolerance:
                worst = max(worst, remainder)
                continue
        anchors += 1
        X0, E0 = Xk, sla.expm(Xk)
    n = min(steps, inputs.shape[0]) - 1
    print(f"\nfirst-order Frechet update on the harvester's recorded base motion, {n} steps at {H:g} s, remainder "
          f"<= {tolerance:g} (oracle: the true remainder, balanced 2-norm): {anchors} re-anchors ({anchors / n:.1%} "
          f"of the steps), each a new exponential and derivatives along the 12 monomial directions")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--native-steps", type=int, default=200000)
    parser.add_argument("--t-end", type=float, default=20.0)
    parser.add_argument("--skip-native", action="store_true")
    parser.add_argument("--skip-wec", action="store_true")
    parser.add_argument("--frechet-steps", type=int, default=20000, help="0: skip part 4")
    args = parser.parse_args(argv)
    print_costs(f"Python FFRBeamSimulator (the harvester), h = {H:g} s, {args.steps} cycles, median of "
                f"{args.rounds} rounds:", python_costs(args.steps, args.rounds))
    if not args.skip_native:
        print_costs(f"native FFRBeam FMU (the harvester) in a C host, h = {H:g} s, {args.native_steps} cycles "
                    f"(setReal 15 + doStep + getReal 9), fastest of {args.rounds}:",
                    native_costs(args.native_steps, args.rounds))
    if not args.skip_wec:
        inputs = wave_converter(args.t_end)
        if args.frechet_steps:
            frechet_anchors(inputs, args.frechet_steps)
    return 0


if __name__ == "__main__":
    sys.exit(main())
