#!/usr/bin/env python3
"""Cost per communication step of each native point-absorber FMU (the wec kind, csrc/native_wec.c), measured by a
tiny C host (no Python in the loop): per step fmi2SetReal of every input, fmi2DoStep, fmi2GetReal of every output,
as a co-simulation master does, so the figures include the FMI front and the bridge's checks.

    .venv/bin/python benchmarks/native_wec_step_cost.py [--steps 120000] [--step 0.01] [--repeat 3]

The default is a 20-minute sea state at h = 0.01 s.  The wave is timed regular and as JONSWAP seas of the automatic
count (Tp 8 s, record 1200 s: 375 components), 500 and 5000 components, each also with the library rebuilt from the
FMU's sources/ with -DANCHOR_EVERY=1 (the phasors evaluated exactly, one cos and sin per component per step: what the
recurrence saves).  Each figure is the fastest of --repeat runs (a shared machine's other load only slows a run
down).  Printed: a Markdown table of microseconds per step and seconds per 20-minute record.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HOST = r"""
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c, fmi2String m, ...) {
    (void)e, (void)n, (void)c;
    if (s >= fmi2Warning) fprintf(stderr, "[%d] %s\n", s, m);
}
#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)
/* library resources guid steps h n_in vr_in... n_out vr_out... n_str (vr text)... n_int (vr value)... */
int main(int argc, char **argv) {
    (void)argc;
    void *lib = dlopen(argv[1], RTLD_NOW);
    if (!lib) return fprintf(stderr, "%s\n", dlerror()), 1;
    LOAD(fmi2Instantiate); LOAD(fmi2SetupExperiment); LOAD(fmi2EnterInitializationMode);
    LOAD(fmi2ExitInitializationMode); LOAD(fmi2DoStep); LOAD(fmi2GetReal); LOAD(fmi2SetReal);
    LOAD(fmi2SetString); LOAD(fmi2SetInteger); LOAD(fmi2FreeInstance);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("bench", fmi2CoSimulation, argv[3], argv[2], &cb, fmi2False, fmi2False);
    if (!c) return 2;
    int a = 4;
    long steps = atol(argv[a++]);
    double h = atof(argv[a++]);
    int n_in = atoi(argv[a++]);
    fmi2ValueReference vin[64], vout[64];
    for (int i = 0; i < n_in; i++) vin[i] = (fmi2ValueReference)atol(argv[a++]);
    int n_out = atoi(argv[a++]);
    for (int i = 0; i < n_out; i++) vout[i] = (fmi2ValueReference)atol(argv[a++]);
    fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0);
    fmi2EnterInitializationMode(c);
    for (int i = 0, n = atoi(argv[a++]); i < n; i++, a += 2) {
        fmi2ValueReference vr = (fmi2ValueReference)atol(argv[a]);
        fmi2String text = argv[a + 1];
        fmi2SetString(c, &vr, 1, &text);
    }
    for (int i = 0, n = atoi(argv[a++]); i < n; i++, a += 2) {
        fmi2ValueReference vr = (fmi2ValueReference)atol(argv[a]);
        fmi2Integer value = atoi(argv[a + 1]);
        fmi2SetInteger(c, &vr, 1, &value);
    }
    if (fmi2ExitInitializationMode(c) != fmi2OK) return 3;
    double u[64], y[64], sink = 0.0, t = 0.0;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (long k = 0; k < steps; k++) {
        for (int i = 0; i < n_in; i++) u[i] = 1e-3 * (double)((k * 7 + i * 13) % 101 - 50); /* small, bounded */
        if (n_in && fmi2SetReal(c, vin, (size_t)n_in, u) != fmi2OK) return 4;
        if (fmi2DoStep(c, t, h, fmi2True) != fmi2OK) return 5;
        t += h;
        if (fmi2GetReal(c, vout, (size_t)n_out, y) != fmi2OK) return 6;
        sink += y[0];
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    printf("%.9f %g\n", (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec), sink);
    fmi2FreeInstance(c);
    return 0;
}
"""


def _host(folder: Path) -> Path:
    from flexfmu.fmi.runtime import _fmi2_headers
    from flexfmu.native.compiler import find_compiler
    source = folder / "host.c"
    source.write_text(HOST)
    host = folder / "host"
    subprocess.run([find_compiler(), "-O2", "-std=c99", "-D_POSIX_C_SOURCE=200809L", f"-I{_fmi2_headers()}",
                    str(source), "-o", str(host), "-ldl"], check=True)
    return host


def _library_from_sources(unzipped: Path, name: str, define: str) -> Path:
    """The FMU's library rebuilt from its sources/ with ``define`` (the same flags as the build's)."""
    from flexfmu.native.compiler import KERNEL_FLAGS, find_compiler
    src = unzipped / "sources"
    files = [str(p) for p in sorted(src.glob("*.c")) if p.name not in ("flexfmu_fmi2.c", "front_common.c")]
    out = unzipped / f"{name}_{define.replace('=', '_')}.so"
    subprocess.run([find_compiler(), *KERNEL_FLAGS, "-shared", "-fvisibility=hidden", "-Wno-format-truncation",
                    f"-D{define}", f"-I{src}", *files, "-o", str(out), "-lm", "-lpthread", "-ldl"], check=True)
    return out


def _time(host: Path, fmu: Path, unzipped: Path, library: Path, steps: int, h: float, strings=None, ints=None,
          repeat: int = 1) -> float:
    from fmpy import read_model_description
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    ins = [str(v.valueReference) for v in md.modelVariables if v.causality == "input"]
    outs = [str(v.valueReference) for v in md.modelVariables if v.causality == "output"]
    args = [str(host), str(library), (unzipped / "resources").as_uri(), md.guid, str(steps), repr(h),
            str(len(ins)), *ins, str(len(outs)), *outs]
    for values in (strings or {}, ints or {}):
        args += [str(len(values)), *(x for k, v in values.items() for x in (str(vr[k]), str(v)))]
    best = float("inf")
    for _ in range(repeat):
        done = subprocess.run(args, capture_output=True, text=True)
        if done.returncode:
            raise RuntimeError(f"host exit {done.returncode}: {done.stderr}")
        best = min(best, float(done.stdout.split()[0]))
    return best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=120000)
    parser.add_argument("--step", type=float, default=0.01)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    from fmpy import extract

    from flexfmu.fmi.native import WEC_COMPONENTS, build_registry_fmu
    jonswap = {"sea_state": "jonswap"}
    cases = [("AbsorberWave", "regular", {}, {}), ("AbsorberWave", "JONSWAP, automatic (375)", jonswap, {}),
             ("AbsorberWave", "JONSWAP, 500 components", jonswap, {"n_components": 500}),
             ("AbsorberWave", "JONSWAP, 5000 components", jonswap, {"n_components": 5000}),
             ("AbsorberFloat", "6 DOF", {}, {}), ("AbsorberHydro", "53 memory states, drag", {}, {}),
             ("HeavePTO", "", {}, {})]
    record = 1200.0 / args.step
    print(f"{args.steps} steps of {args.step} s; a 20-minute record is {record:.0f} steps\n")
    print("| FMU | case | us/step | s per 20-min record | exact phasors (-DANCHOR_EVERY=1): us/step |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="wec-bench-") as tmp:
        folder = Path(tmp)
        host = _host(folder)
        fmus = {name: build_registry_fmu(name, target=folder / f"{name}.fmu") for name in WEC_COMPONENTS}
        unzipped = {name: Path(extract(str(fmu), str(folder / name))) for name, fmu in fmus.items()}
        exact = _library_from_sources(unzipped["AbsorberWave"], "AbsorberWave", "ANCHOR_EVERY=1")
        for name, case, strings, ints in cases:
            library = unzipped[name] / "binaries" / "linux64" / f"{name}.so"
            timing = (host, fmus[name], unzipped[name])
            seconds = _time(*timing, library, args.steps, args.step, strings, ints, args.repeat)
            per_step = 1e6 * seconds / args.steps
            direct = ""
            if name == "AbsorberWave" and strings:
                exact_seconds = _time(*timing, exact, args.steps, args.step, strings, ints, args.repeat)
                direct = f"{1e6 * exact_seconds / args.steps:.2f}"
            print(f"| {name} | {case} | {per_step:.2f} | {per_step * record * 1e-6:.3f} | {direct} |")
        shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
