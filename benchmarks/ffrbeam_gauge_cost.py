"""Per-step cost of the Python FFRBeamSimulator (step + output_vector) with 0 and 3 strain gauges.

    .venv/bin/python benchmarks/ffrbeam_gauge_cost.py [--steps N]

The default model (spatial_double_L, XFF, 6 modes) at 1 ms: held inputs (fixed base, the maps cached) and base motion
that changes every step (the series step, output maps from the polynomials), with the static correction off and on.
Prints the median over 7 repeats of the time per cycle (us): a measurement for the docs, not a test.

Measured (2-core machine shared with other jobs, load average 2.7; set_input_vector + step + output_vector):

    static_correction  base     0 gauges (us)  3 gauges (us)
                    0  fixed            22.6           38.8
                    0  moving           95.2          122.7
                    1  fixed            25.8           42.9
                    1  moving          135.8          156.4

Of the fixed-base cycle's +16 us, the gauges' stresses take 13.3 us (flexfmu.ffr.gauges.DerivedFill: two
DerivedStress.evaluate calls on the three gauges' arrays; evaluate_derived's six scalar calls: 23.8 us), the 18 extra
rows of the output product about 1 us; the step itself is unchanged (4.4 us).  Output_vector alone: 10.4 us without
gauges, 24.9 us with three.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from flexfmu.ffr.simulator import INPUT_NAMES, FFRBeamConfig, FFRBeamSimulator

GAUGES = {"gauge_1_s": 0.0, "gauge_2_s": 0.16, "gauge_3_s": 0.3}


def per_cycle(cfg: FFRBeamConfig, moving: bool, n: int) -> float:
    sim = FFRBeamSimulator(cfg)
    u = np.zeros(len(INPUT_NAMES))
    u[0:3] = [1.0, -0.5, 0.3]
    inputs = [u.copy() for _ in range(n)]
    if moving:
        for k, v in enumerate(inputs):
            v[6:15] = 0.5 * np.sin(2 * np.pi * 1e-3 * k + np.arange(9))
    for v in inputs[:50]:                 # warm the caches (maps, the moving base's polynomials)
        sim.set_input_vector(v)
        sim.step(1e-3)
        sim.output_vector()
    times = []
    for _ in range(7):
        t0 = time.perf_counter()
        for v in inputs:
            sim.set_input_vector(v)
            sim.step(1e-3)
            sim.output_vector()
        times.append((time.perf_counter() - t0) / n * 1e6)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    n = parser.parse_args().steps
    print("static_correction  base     0 gauges (us)  3 gauges (us)")
    for corr in (0, 1):
        for moving in (False, True):
            cost = [per_cycle(FFRBeamConfig(static_correction=corr, **g), moving, n) for g in ({}, GAUGES)]
            print(f"{corr:17d}  {'moving' if moving else 'fixed ':6s}  {cost[0]:13.1f}  {cost[1]:13.1f}")


if __name__ == "__main__":
    main()
