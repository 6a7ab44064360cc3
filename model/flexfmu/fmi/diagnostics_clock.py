"""Large start times, probed in a child process (flexfmu.fmi.diagnostics_runner): fmi2SetupExperiment at 1e6 s and
1e9 s, then steps as hosts compute them.  docs/fmu.md ("Errors", "Step sizes a host passes"): the FMU's clock is the
host's last communication point plus its step, so fmi2LastSuccessfulTime equals the host's time within 16 eps |t|;
a skipped or a repeated step is refused; a rollback with fmi2SetFMUstate steps again to the same outputs.  The
hosts: one passing h = t(k+1) - t(k) with t(k) = t0 + k h (fmpy's simulate_fmu, libcosim, fmusim), one passing the
constant h; the latter's outputs from t0 must equal those of a run from 0 (the models are time-invariant: only the
steps enter, and they are the same)."""
from __future__ import annotations

from pathlib import Path

from flexfmu.fmi.diagnostics_host import HOST
from flexfmu.fmi.diagnostics_runner import run_resumable

#: how far fmi2LastSuccessfulTime may be from the host's time, in units of eps |t| (docs/fmu.md, "Errors")
CLOCK_ULPS = 16
#: outputs of the constant-step run from t0 and from 0 (the same steps of a time-invariant model), relative to the
#: largest output of the run from 0: equal but for the rounding of time since the start, which none of the models
#: uses in its equations
SAME_RUN_RTOL = 1e-9

CLOCK = HOST + r'''
PATH = CONFIG["fmu"]
H, N = CONFIG["step"], CONFIG["steps"]
EPS = 2.220446049250313e-16
CLOCK_ULPS, SAME_RUN_RTOL = CONFIG["clock_ulps"], CONFIG["same_run_rtol"]


def host_times(t0):
    return [t0 + k * H for k in range(N + 1)]


def loaded(h):
    for name in h.inputs[:3]:
        h.set(name, 0.5)


def run_steps(h, times, clock_steps):
    """Steps from times[0] to times[-1]: h = t(k+1) - t(k) or the constant H; the worst clock deviation (eps |t|)
    and the outputs after each step."""
    worst, rows = 0.0, []
    for t, t_next in zip(times[:-1], times[1:]):
        h.doStep(currentCommunicationPoint=t, communicationStepSize=(t_next - t) if clock_steps else H)
        status, clock = h.clock()
        worst = max(worst, abs(clock - t_next) / (EPS * max(abs(t_next), 1.0)))
        rows.append(h.get())
    return worst, rows


def clock_check(worst, label):
    if not worst <= CLOCK_ULPS:
        raise Wrong(f"{label}: fmi2LastSuccessfulTime {worst:.3g} eps |t| from the host's time (allowed {CLOCK_ULPS})")


def clock_steps_item(t0):
    def action(h):
        loaded(h)
        worst, rows = run_steps(h, host_times(t0), True)
        clock_check(worst, "clock steps")
        out = {"note": f"clock within {worst:.2f} eps |t|"}
        if nonfinite(rows[-1]):
            out["nonfinite"], out["nonfinite_detail"] = True, str(rows[-1][:4])
        return out
    item(f"t0 = {t0:g}: {N} steps of t(k+1) - t(k), clock as the host's", "ok",
         lambda: probe(PATH, action, start_time=t0))


def off_step_item(t0, label, point):
    def action(h):
        loaded(h)
        times = host_times(t0)
        worst, rows = run_steps(h, times, True)
        clock_check(worst, "before the bad step")
        h.doStep(currentCommunicationPoint=point(times), communicationStepSize=H)
    item(f"t0 = {t0:g}: {label}", "refuse", lambda: probe(PATH, action, start_time=t0))


def rollback_item(t0):
    def action(h):
        loaded(h)
        times = host_times(t0)
        run_steps(h, times[:-1], True)
        state = h.getFMUstate()
        h.doStep(currentCommunicationPoint=times[-2], communicationStepSize=times[-1] - times[-2])
        first = h.get()
        h.setFMUstate(state)
        h.freeFMUstate(state)
        status, clock = h.clock()
        if clock != times[-2] and not abs(clock - times[-2]) <= CLOCK_ULPS * EPS * abs(times[-2]):
            raise Wrong(f"after the rollback fmi2LastSuccessfulTime is {clock!r}, the state was taken at {times[-2]!r}")
        h.doStep(currentCommunicationPoint=times[-2], communicationStepSize=times[-1] - times[-2])
        if h.get() != first:
            raise Wrong("the step taken again after fmi2SetFMUstate gives other outputs than the first time")
    item(f"t0 = {t0:g}: a rollback with fmi2SetFMUstate and the last step again, equal bit for bit", "ok",
         lambda: probe(PATH, action, start_time=t0))


def same_run_item(t0):
    def run_from(start):
        h = Host(PATH, "same")
        try:
            h.begin(start_time=start)
            loaded(h)
            worst, rows = run_steps(h, host_times(start), False)
            return worst, rows, h.log
        finally:
            h.free()

    def run():
        try:
            worst, late, log = run_from(t0)
            _, early, _ = run_from(0.0)
        except FMICallException as exc:
            return {"status": STATUS[exc.status], "detail": f"{exc.function} answered {exc.status}"}
        scale = max([abs(x) for row in early for x in row] + [1e-300])
        diff = max(abs(a - b) for ra, rb in zip(late, early) for a, b in zip(ra, rb))
        out = {"status": "OK", "note": f"difference {diff / scale:.2g} x the largest output; clock within "
                                       f"{worst:.2f} eps |t|",
               "internal": [m[:300] for _, m in log if "internal error" in m.lower()]}
        if not diff <= SAME_RUN_RTOL * scale:
            out["wrong"] = (f"outputs of {N} constant steps from t0 = {t0:g} differ from those from 0 by "
                            f"{diff / scale:.3g} x the largest output (allowed {SAME_RUN_RTOL:g})")
        elif not worst <= CLOCK_ULPS:
            out["wrong"] = f"fmi2LastSuccessfulTime {worst:.3g} eps |t| from the host's time"
        return out
    item(f"t0 = {t0:g}: {N} constant steps equal {N} steps from 0", "ok", run)


for t0 in CONFIG["start_times"]:
    clock_steps_item(t0)
    off_step_item(t0, "a skipped step (t(N) + h)", lambda times: times[-1] + H)
    off_step_item(t0, "a repeated step (t(N - 1))", lambda times: times[-2])
    rollback_item(t0)
    if CONFIG["compare"]:
        same_run_item(t0)
main()
'''


def clock_probes(fmu: Path, *, start_times=(1e6, 1e9), step: float = 1e-3, steps: int = 20, compare: bool = True,
                 item_timeout: float = 120.0) -> list[dict]:
    """CLOCK on ``fmu`` from each start time; ``compare``: also the constant-step run against one from 0 (for
    time-invariant models only)."""
    return run_resumable(CLOCK, {"fmu": str(fmu), "start_times": list(start_times), "step": step, "steps": steps,
                                 "compare": compare, "clock_ulps": CLOCK_ULPS, "same_run_rtol": SAME_RUN_RTOL},
                         item_timeout=item_timeout)
