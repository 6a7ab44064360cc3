"""`flexfmu reframe`: a free flexible body under a constant force with the reframe integrator, with progress."""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from flexfmu.errors import ParameterError

#: Progress (stderr: a bar on a terminal, else a line per 10 %) starts once a run has taken this long (s of wall
#: time).
PROGRESS_AFTER_S = 2.0


def _vector3(text: str, name: str):
    """"FX,FY,FZ" -> three finite floats, or ParameterError naming the option."""
    allowed = "three comma-separated finite numbers, e.g. 0,0,1 (negative first value: --%s=-1,0,0)" % name
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        raise ParameterError(name, f"{text!r} is not numeric", allowed) from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ParameterError(name, repr(text), allowed)
    return values


def _run_with_progress(integ, t_end, dt, load, points, every, stream=None):
    """``integ.run`` in ~10 chunks (each a multiple of ``every`` steps, so the records are the same as
    one run), with the progress (flexfmu.core.progress) on ``stream`` after each chunk once the run
    takes longer than PROGRESS_AFTER_S."""
    import numpy as np

    from flexfmu.core.progress import progress_bar
    from flexfmu.reframe.integrator import ReframeResult

    n_steps = int(round(t_end / dt))
    if abs(n_steps * dt - t_end) > 1e-9 * max(1.0, t_end):
        n_steps = int(math.ceil(t_end / dt))
    chunk = max(every, int(math.ceil(n_steps / 10 / every)) * every)
    parts = []
    done = 0
    with progress_bar(n_steps, "flexfmu reframe", stream=stream, delay=PROGRESS_AFTER_S, t_end=t_end) as bar:
        while done < n_steps:
            done = min(done + chunk, n_steps)
            parts.append(integ.run(t_end if done == n_steps else done * dt, dt, load, points, every=every))
            bar.update_to(done, integ.state.t)
    if len(parts) == 1:
        return parts[0]
    fields = {}
    for name in ReframeResult.__dataclass_fields__:
        if name in ("points", "final_state"):
            continue
        fields[name] = np.concatenate([getattr(parts[0], name)] + [getattr(p, name)[1:] for p in parts[1:]])
    return ReframeResult(points=parts[0].points, final_state=parts[-1].final_state, **fields)


def _reframe(args: argparse.Namespace) -> int:
    """Integrate a free flexible body with the reframe integrator under a constant force."""
    import numpy as np

    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.models import default_load_point, default_output_point, load_model
    from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator

    force = _vector3(args.force, "force") if args.force is not None else None
    omega0 = _vector3(args.omega0, "omega0")
    if not (math.isfinite(args.t_end) and args.t_end > 0):
        raise ParameterError("t-end", f"{args.t_end!r}", "finite end time > 0 (s)")
    if not (math.isfinite(args.dt) and args.dt > 0):
        raise ParameterError("dt", f"{args.dt!r}", "finite time step > 0 (s)")
    if args.modes < 0:
        raise ParameterError("modes", f"{args.modes}", "number of flexible modes >= 0 (0: a rigid body)")
    if args.every < 1:
        raise ParameterError("every", f"{args.every}", "integer >= 1")

    start = time.perf_counter()
    structure = load_model(args.model)
    try:
        basis = modal_basis(structure, args.modes)
    except ParameterError as exc:
        if exc.parameter != "n_flexible":
            raise
        raise ParameterError("modes", f"{args.modes} flexible modes for a model with {structure.n_dof} DOFs",
                             exc.allowed) from None
    integ = ReframeIntegrator(structure, basis, scheme=args.scheme)
    integ.set_initial(omega0=omega0)
    if time.perf_counter() - start >= PROGRESS_AFTER_S:
        freqs = f" ({basis.frequencies_hz[0]:.4g} ... {basis.frequencies_hz[-1]:.4g} Hz)" if args.modes else ""
        print(f"flexfmu reframe: {structure.name}: {structure.n_dof} DOFs, {args.modes} flexible modes{freqs}, "
              f"set up in {time.perf_counter() - start:.1f} s; integrating to {args.t_end:g} s with dt = {args.dt:g} s",
              file=sys.stderr, flush=True)
    load_node, out_node = default_load_point(structure), default_output_point(structure)
    load = PointLoad(load_node, force) if force is not None else None
    result = _run_with_progress(integ, args.t_end, args.dt, load, [out_node], args.every)

    if args.out is not None:
        from flexfmu.reframe.simulator import OUTPUT_NAMES, output_values

        table = np.column_stack([result.t, output_values(result)])
        args.out.parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(args.out, table, delimiter=",", header=",".join(("time",) + OUTPUT_NAMES), comments="",
                   fmt="%.17g")
        print(f"wrote {args.out} ({table.shape[0]} rows x {table.shape[1]} columns)")
        return 0
    fmt = lambda v: "[" + ", ".join(f"{x:.9g}" for x in v) + "]"   # noqa: E731
    print(f"{structure.name}: {structure.n_dof} DOFs, {args.modes} flexible modes, scheme {args.scheme}, "
          f"t = {result.t[-1]:g} s, dt = {args.dt:g} s")
    print(f"load: {'none' if force is None else fmt(force) + ' N (global)'} at node {load_node} "
          f"{fmt(structure.nodes[load_node])} m")
    print(f"final omega (body)          {fmt(result.omega[-1])} rad/s")
    print(f"final COM velocity (global) {fmt(result.com_velocity[-1])} m/s")
    print(f"max elastic displacement    {np.max(result.max_elastic_displacement):.6g} m "
          f"(final {result.max_elastic_displacement[-1]:.6g} m)")
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu reframe` to ``sub``, the sub-commands of build_parser."""
    from flexfmu.reframe.schemes import SCHEMES

    reframe = sub.add_parser(
        "reframe", help="flexible-body motion of a free model with the reframe integrator",
        description="Large rigid motion plus vibration of a free flexible body (docs/reframe.md) under a constant "
                    "global force at the model's default load point (paper_plate: midway between P5 and P8; "
                    "beam / .npz: the last node); outputs at the default output point (P1; the first node).")
    reframe.add_argument("model", metavar="MODEL", help="paper_plate | beam:<scene> | path to a .npz")
    reframe.add_argument("--scheme", choices=sorted(SCHEMES), default="consistent",
                         help="consistent (default, RK4), exponential (exact in the modes' linear part, no RK4 "
                              "limit) or the paper's printed scheme")
    reframe.add_argument("--t-end", type=float, default=1.0, metavar="T", help="end time, s (default 1)")
    reframe.add_argument("--dt", type=float, default=1e-4, metavar="DT", help="time step, s (default 1e-4)")
    reframe.add_argument("--modes", type=int, default=10, metavar="N",
                         help="number of flexible modes, 5%% modal damping (default 10; 0: a rigid body)")
    reframe.add_argument("--force", default=None, metavar="FX,FY,FZ",
                         help="constant force in the global frame, N, at the default load point (default none)")
    reframe.add_argument("--omega0", default="0,0,0", metavar="W1,W2,W3",
                         help="initial angular velocity, body frame, rad/s (default 0,0,0)")
    reframe.add_argument("--every", type=int, default=1, metavar="K", help="write every K-th step (default 1)")
    reframe.add_argument("--out", type=Path, default=None, metavar="CSV",
                         help="write the time history as CSV (columns named like the ReframeBody FMU outputs); "
                              "default: print a summary")
    reframe.set_defaults(func=_reframe)
