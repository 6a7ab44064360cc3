"""Progress of long runs (co-simulations, sweeps, integrations) on a stream, stderr by default.

On a terminal a tqdm bar is drawn.  Anywhere else (a log file, a pipe, CI) a redrawn bar is noise:
every redraw is a ``\\r``-separated copy of the line, so there the progress is written as at most
one plain line per 10 % of the run (plus the final line), e.g.::

    flexfmu cosim: 30 % (t = 3 s of 10 s, 4.1 s elapsed, ~9.6 s left)

Both stay silent for runs that finish within ``delay`` seconds of wall time.

Why the log branch is not tqdm: tqdm's status printer always starts a line with ``\\r``, its monitor
thread resets ``miniters`` to 1 once ``maxinterval`` passes (so ``miniters`` alone does not bound the
number of lines in a slow run), and ``close()`` adds a line of its own.  Bending those settings is
more code and more fragile across tqdm versions than the twenty lines of ``_LogLines``.
"""
from __future__ import annotations

import sys
import time

from flexfmu.core.checks import require_int, require_real

#: Wall time (s) a run must take before any progress is shown (tqdm's ``delay``).
DEFAULT_DELAY_S = 1.0

#: The log branch writes a line each time the run crosses another 1/LOG_LINES_PER_RUN of its total.
LOG_LINES_PER_RUN = 10


class _NoProgress:
    """progress=False: the same interface, doing nothing."""

    def update_to(self, done: int, t: float | None = None) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class _TerminalBar(_NoProgress):
    """A tqdm bar counting steps (or tasks), with the simulated time as its postfix."""

    def __init__(self, total: int, label: str, stream, delay: float, unit: str, t_end: float | None):
        from tqdm import tqdm

        self.t_end = t_end
        self.bar = tqdm(total=total, desc=label, file=stream, delay=delay, unit=f" {unit}", leave=True)

    def update_to(self, done: int, t: float | None = None) -> None:
        if t is not None:
            # only stored here: tqdm formats it when (mininterval) it redraws
            self.bar.set_postfix_str(f"t = {t:.4g} s" + (f" of {self.t_end:.4g} s" if self.t_end else ""),
                                     refresh=False)
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        self.bar.close()


class _LogLines(_NoProgress):
    """At most one plain ``\\n``-terminated line per tenth of the run, the first once ``delay`` has passed."""

    def __init__(self, total: int, label: str, stream, delay: float, unit: str, t_end: float | None):
        self.total, self.label, self.stream, self.delay = total, label, stream, delay
        self.unit, self.t_end = unit, t_end
        self.start = time.perf_counter()
        self.last_tenth = 0          # no 0 % line: it would say nothing
        self.final_written = False

    def update_to(self, done: int, t: float | None = None) -> None:
        finished = done >= self.total
        tenth = LOG_LINES_PER_RUN * done // self.total
        if self.final_written or (tenth <= self.last_tenth and not finished):
            return
        elapsed = time.perf_counter() - self.start
        if elapsed < self.delay:
            return
        self.last_tenth, self.final_written = tenth, finished
        if t is not None:
            where = f"t = {t:.4g} s" + (f" of {self.t_end:.4g} s" if self.t_end else "")
        else:
            where = f"{done} of {self.total} {self.unit}s"
        left = "" if finished or done == 0 else f", ~{elapsed * (self.total - done) / done:.0f} s left"
        print(f"{self.label}: {100 * done // self.total} % ({where}, {elapsed:.1f} s elapsed{left})",
              file=self.stream, flush=True)


def progress_bar(total: int, label: str, enabled: bool = True, stream=None, delay: float | None = None,
                 unit: str = "step", t_end: float | None = None):
    """A progress display of a run of ``total`` steps: ``bar.update_to(done, t)`` after each step
    (``t``: the simulated time, s, shown as "t = 3 s of t_end"), ``bar.close()`` at the end (or use it
    as a context manager).  A tqdm bar if ``stream`` (default: sys.stderr at call time) is a terminal,
    otherwise a plain line per 10 %; nothing for ``enabled=False`` or a run shorter than ``delay``
    (s of wall time, default DEFAULT_DELAY_S)."""
    total = require_int(total, "total", 1, sys.maxsize, "a whole number of steps >= 1")
    if not enabled:
        return _NoProgress()
    stream = sys.stderr if stream is None else stream
    delay = require_real(DEFAULT_DELAY_S if delay is None else delay, "delay", ">= 0 s", lo=0.0)
    is_terminal = getattr(stream, "isatty", lambda: False)()
    kind = _TerminalBar if is_terminal else _LogLines
    return kind(total, label, stream, delay, unit, t_end)
