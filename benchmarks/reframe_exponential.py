"""Accuracy per CPU second of the ReframeBody schemes on the default case (paper plate, 10 flexible modes,
the paper's 50 N half-sine load of 0.01 s at the paper's load point, sampled at the communication points
and held), 0.2 s.  For each communication step h the reference is the consistent scheme with internal
step 1e-5 s and the same held inputs.  Error: max over the communication points of |x - x_ref| / max|x_ref|
for omega (body), the output point's acceleration (global) and max_elastic_displacement; CPU time of the
stepping loop (process time), set-up excluded."""
import math
import sys
import time

import numpy as np

from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

T_END = 0.2
F = 50.0 * np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)


def force(t):
    return F * math.sin(math.pi * t / 0.01) if t <= 0.01 else np.zeros(3)


def run(scheme, h, internal_step=0.0, repeat=1):
    ReframeBodySimulator(ReframeBodyConfig(scheme=scheme, internal_step=internal_step))   # fills the set-up caches
    n = int(round(T_END / h))
    best = math.inf
    for _ in range(repeat):
        sim = ReframeBodySimulator(ReframeBodyConfig(scheme=scheme, internal_step=internal_step))
        out = []
        t0 = time.process_time()
        for k in range(n):
            f = force(k * h)
            sim.set_input_vector([f[0], f[1], f[2], 0.0, 0.0, 0.0])
            sim.step(h)
            out.append(sim.output_vector())
        best = min(best, time.process_time() - t0)
    out = np.array(out)
    return out, best, sim.internal_steps(h), sim.messages


def errors(out, ref):
    cols = {"omega": slice(10, 13), "out_acc": slice(28, 31), "max_elastic_displacement": slice(33, 34)}
    return {k: float(np.max(np.abs(out[:, c] - ref[:, c])) / np.max(np.abs(ref[:, c]))) for k, c in cols.items()}


if __name__ == "__main__":
    steps = [float(x) for x in sys.argv[1:]] or [2e-4, 5e-4, 1e-3, 2e-3, 5e-3]
    print(f"{'h (s)':>8s} {'scheme':>12s} {'int. steps':>10s} {'CPU (s)':>9s} {'err omega':>10s} {'err out_acc':>11s} "
          f"{'err u_max':>10s}")
    for h in steps:
        ref, _, _, _ = run("consistent", h, internal_step=1e-5)
        for scheme in ("consistent", "exponential"):
            out, cpu, n, msgs = run(scheme, h, repeat=3)
            e = errors(out, ref)
            print(f"{h:8.0e} {scheme:>12s} {n:10d} {cpu:9.3f} {e['omega']:10.2e} {e['out_acc']:11.2e} "
                  f"{e['max_elastic_displacement']:10.2e}", flush=True)
