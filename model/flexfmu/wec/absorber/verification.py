"""The point absorber's co-simulation against its frequency-domain prediction (flexfmu.wec.absorber.frequency_domain):
the example system (examples/point_absorber/OspSystemStructure.xml) in its linear configuration (heave only, no drag,
no mooring, no force limit), run by a master over the library components, in a regular wave or a JONSWAP sea.

Regular wave: after the transient (the ramp, then SETTLE_TIME for the free response and the radiation memory to decay:
the slowest pole of the memory decays as e^{-0.28 t}, the heave mode with the PTO faster), over whole periods:
  heave amplitude   |2 / N sum_n z_n e^{-i w t_n}| over the N samples of the whole periods (the first harmonic:
                    exact for a sampled sinusoid; half the peak-to-peak would miss the peak by up to w h / 2 rad)
  mean PTO power    1 / N sum_n power_n (the PTO's power output; exact for a trigonometric polynomial of degree < N)
The co-simulation's Gauss-Seidel coupling holds each load over the step: its error is O(h).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from flexfmu.errors import require

#: the example system file (repository checkout)
SYSTEM_FILE = Path(__file__).resolve().parents[4] / "examples" / "point_absorber" / "OspSystemStructure.xml"
#: s after the ramp before the averaging starts
SETTLE_TIME = 60.0
#: the linear configuration's start values (INSTANCE.VARIABLE=VALUE)
LINEAR = ("float.heave_only=true", "hydro.drag=false", "mooring.enabled=false", "pto.force_limit=0")


def linear_system(assignments=(), system_file=SYSTEM_FILE, fmu_dir=None):
    """The example system in its linear configuration, with further start values ``assignments``."""
    from flexfmu.cosim.masters import load_system, with_assignments
    return with_assignments(load_system(system_file, fmu_dir=fmu_dir), tuple(LINEAR) + tuple(assignments))


def regular_wave_check(period: float, height: float = 1.0, damping: float = 6.0e5, step: float = 0.01,
                       n_periods: int = 4, ramp_time: float = 20.0, scheme: str = "gauss-seidel",
                       backend: str = "library", system_file=SYSTEM_FILE, fmu_dir=None) -> dict:
    """Heave amplitude (m) and mean PTO power (W) of the co-simulation in a regular wave of height H (m) and period
    T (s), PTO damping c (N s/m), communication step h (s; T / h must be a whole number), over n_periods whole periods
    after ramp_time + SETTLE_TIME; with the frequency-domain prediction and the relative errors."""
    from flexfmu.cosim.masters import run
    from flexfmu.wec.absorber.frequency_domain import regular_wave_response
    from flexfmu.wec.absorber.hull import absorber_hull
    per_period = period / step
    require(abs(per_period - round(per_period)) < 1e-9 * per_period, "step", f"{step!r} s with T = {period!r} s",
            "a step that divides the period")
    require(isinstance(n_periods, int) and n_periods >= 1, "n_periods", f"got {n_periods!r}", ">= 1")
    n_per = int(round(per_period))
    t_start = ramp_time + SETTLE_TIME
    k0 = int(math.ceil(t_start / step - 1e-9))
    n = n_per * n_periods
    t_end = (k0 + n) * step
    system = linear_system((f"wave.sea_state=regular", f"wave.wave_height={height!r}", f"wave.wave_period={period!r}",
                            f"wave.ramp_time={ramp_time!r}", f"pto.damping={damping!r}", "pto.stiffness=0"),
                           system_file, fmu_dir)
    import time
    start = time.perf_counter()
    result = run(system, t_end, step, scheme=scheme, backend=backend)
    wall = time.perf_counter() - start
    t = result.t
    i0 = int(np.argmin(np.abs(t - k0 * step)))
    sel = slice(i0, i0 + n)                              # n samples: whole periods, the last point left out
    z = result.columns["float.pos_z"][sel]
    w = 2 * math.pi / period
    amplitude = abs(2 / n * np.sum(z * np.exp(-1j * w * t[sel])))
    power = float(np.mean(result.columns["pto.power"][sel]))
    amp_fd, power_fd = regular_wave_response(absorber_hull(), height, period, damping)
    return {"period_s": period, "step_s": step, "heave_amplitude_m": float(amplitude), "mean_power_W": power,
            "predicted_amplitude_m": amp_fd, "predicted_power_W": power_fd,
            "amplitude_error": float(amplitude / amp_fd - 1), "power_error": float(power / power_fd - 1),
            "simulated_s": float(t_end), "wall_s": wall}
