"""What the work-precision study (flexfmu.studies.work_precision) measures and how: its panels, the error norm,
CPU time as the best of repeats, the observed order, one run of a sweep (Point) and a case's runs (Case); and the
methods present at run time (reframe schemes, FFR integrators, automatic model choice, Exudyn)."""
from __future__ import annotations

import dataclasses
import gc
import math
import time
from dataclasses import dataclass, field

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.studies.references import load_generator

PANELS = ("dt", "modes", "mesh")
PANEL_TITLES = {"dt": "time step", "modes": "number of modes", "mesh": "mesh"}


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


def refused(case: Case, panel: str, method: str, value, label: str, exc: Exception) -> None:
    case.add(Point(panel, method, float(value), label, math.nan, math.nan, math.nan,
                   note=f"refused: {' '.join(str(exc).split())}"))


# --------------------------------------------------------------------------- optional features
def reframe_schemes() -> tuple:
    from flexfmu.reframe.integrator import SCHEMES
    return tuple(SCHEMES)


def config_fields(cls) -> set:
    return {f.name for f in dataclasses.fields(cls)}


def ffr_integrators() -> tuple:
    """FFR integrators available: ("exact",) today; + "rk4" when FFRBeamConfig has an ``integrator`` field."""
    from flexfmu.ffr.simulator import FFRBeamConfig
    return ("exact", "rk4") if "integrator" in config_fields(FFRBeamConfig) else ("exact",)


def ffr_auto_available() -> bool:
    from flexfmu.ffr.simulator import FFRBeamConfig
    return {"f_max", "tolerance"} <= config_fields(FFRBeamConfig)


def reframe_auto_available() -> bool:
    from flexfmu.reframe.simulator import ReframeBodyConfig
    return {"f_max", "tolerance"} <= config_fields(ReframeBodyConfig)


def exudyn_generator():
    """The Exudyn plate reference's generate.py as a module, or None without Exudyn."""
    try:
        import exudyn  # noqa: F401
    except ImportError:
        return None
    return load_generator("exudyn_plate")
