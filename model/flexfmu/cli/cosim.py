"""`flexfmu cosim`: a system of FMUs from an OspSystemStructure.xml or an SSP with one of the masters."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from flexfmu.cosim.checks import MAX_RESULT_BYTES, check_output_path
from flexfmu.cosim.coupling import COUPLING_SCHEMES, INTERFACE_JACOBIAN, check_interface_jacobians
from flexfmu.errors import FlexfmuError, ParameterError


def _cosim(args: argparse.Namespace) -> int:
    """Run a system of FMUs from an OspSystemStructure.xml or an SSP (.ssp) with one of the masters."""
    from flexfmu.cosim import masters as cosim
    from flexfmu.wec import system as wec

    system = cosim.load_system(args.system_file, fmu_dir=args.fmu_dir)
    if args.set:
        system = cosim.with_assignments(system, args.set)
    h = system.base_step if args.step is None else args.step
    scheme = args.scheme or ("jacobi" if args.master in ("libcosim", "ecos") else "gauss-seidel")
    if args.master in ("libcosim", "ecos") and scheme != "jacobi":
        raise ParameterError("scheme", f"{scheme} with --master {args.master}",
                             f"jacobi ({args.master}'s fixed-step algorithm)")
    if args.every < 1:
        raise ParameterError("every", f"{args.every}", "integer >= 1")
    if not (math.isfinite(h) and h > 0):
        raise ParameterError("step", f"{h!r}", "finite step > 0 (s)")
    if not (math.isfinite(args.max_memory) and args.max_memory > 0):
        raise ParameterError("max-memory", f"{args.max_memory!r} GiB", "a finite limit > 0 GiB")
    max_bytes = args.max_memory * 2**30
    n = cosim.n_steps(args.t_end, system.start_time, h)
    check_output_path(args.out, "out")
    check_output_path(args.plot, "plot")
    if args.plot is not None:   # before the run: the chart needs a wave-energy converter's roster
        try:
            wec.roster(system)
        except ParameterError as exc:
            raise ParameterError("plot", f"the system is not a wave-energy converter: {exc}",
                                 "a system whose every simulator is a wave-energy converter component (docs/"
                                 "wave_converter.md), with a wave and a platform") from None
    # before anything runs (the stability check included): the file against its FMUs or models, the results' memory
    checked = cosim.check_system(system, "library" if args.master == "library" else "fmu")
    cosim.check_result_memory(n, checked.n_outputs, h, max_bytes)
    if scheme == INTERFACE_JACOBIAN:    # every FMU fed by a connection must give its interface Jacobian
        check_interface_jacobians(system, checked, "library" if args.master == "library" else "fmu")
    if not args.no_stability_check:
        try:
            check = cosim.stability_check(system, h, scheme)
        except FlexfmuError as exc:
            print(f"flexfmu cosim: note: no coupling-stability check ({exc})", file=sys.stderr)
        else:
            if not check["stable"]:
                print(f"flexfmu cosim: warning: step {h:g} s is outside the coupling-stability limit of this system "
                      f"({scheme}): the linearised coupled step is unstable at {check['first_unstable']:.3g} s "
                      f"(spectral radius at {h:g} s: {check['spectral_radius']:.6f}); expect growing oscillation "
                      "or divergence - use a smaller --step (docs/wave_converter.md)", file=sys.stderr, flush=True)
    # libcosim and ecos record only every K-th point (the steps between in one call: no Python in their loop)
    recorded_every = args.every if args.master in ("libcosim", "ecos") else 1
    if args.master == "libcosim":
        result = cosim.run_libcosim(system, args.t_end, h, progress=True, max_result_bytes=max_bytes,
                                    every=args.every)
    elif args.master == "ecos":
        result = cosim.run_ecos(system, args.t_end, h, progress=True, max_result_bytes=max_bytes, every=args.every)
    else:
        backend = "library" if args.master == "library" else "fmu"
        result = cosim.run(system, args.t_end, h, scheme=scheme, backend=backend, progress=True,
                           max_result_bytes=max_bytes)
    print(f"{system.path}: {len(system.simulators)} simulators, {len(system.connections)} connections; "
          f"master {result.master}, step {h:g} s, t = {result.t[0]:g} .. {result.t[-1]:g} s")
    if wec.is_wec(system):
        print(wec.summary(result, system))
        balance = wec.energy_balance(result, system)
        print("energy balance over the run:")
        print(balance.table())
    if args.out is not None:
        if args.every > 1 and recorded_every == 1:
            keep = slice(None, None, args.every)
            result = cosim.CosimResult(result.t[keep], {k: v[keep] for k, v in result.columns.items()},
                                       result.step, result.scheme, result.master)
        result.write_csv(args.out)
        print(f"wrote {args.out} ({result.t.size} rows x {len(result.columns) + 1} columns)")
    if args.plot is not None:
        print(f"wrote {wec.plot_result(result, system, args.plot)}")
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu cosim` to ``sub``, the sub-commands of build_parser."""
    cosim_p = sub.add_parser(
        "cosim", help="co-simulate a system of FMUs described by an OspSystemStructure.xml or an SSP (.ssp)",
        description="Co-simulate a system of FMUs (OSP system structure file, or SSP 1.0) with a fixed communication "
                    "step: our fmpy master (Gauss-Seidel, Jacobi or interface-Jacobian), libcosim or ecos (Jacobi), or "
                    "the flexfmu library "
                    "models the FMUs wrap. Warns when the step is outside the system's coupling-stability limit. "
                    "For the "
                    "wave-energy converter (examples/wave_converter/) also prints motion, harvested power and the "
                    "energy balance.")
    cosim_p.add_argument("system_file", metavar="SYSTEM_FILE", type=Path,
                         help="OspSystemStructure.xml, or an SSP: .ssp archive (FMUs in resources/) or .ssd")
    cosim_p.add_argument("--set", action="append", default=[], metavar="INSTANCE.VARIABLE=VALUE",
                         help="change a start value (repeatable), e.g. wave.wave_height=0.1; an unknown instance "
                              "or variable is an error that lists the allowed ones")
    cosim_p.add_argument("--t-end", type=float, required=True, metavar="T", help="end time, s")
    cosim_p.add_argument("--step", type=float, default=None, metavar="H",
                         help="communication step, s (default: the file's BaseStepSize)")
    cosim_p.add_argument("--out", type=Path, default=None, metavar="CSV",
                         help="write every output of every simulator as CSV (columns instance.variable)")
    cosim_p.add_argument("--every", type=int, default=1, metavar="K", help="write every K-th communication point (libcosim, ecos: record only those, the steps between in one call "
                              "of the engine; the summary and energy balance then use those points)")
    cosim_p.add_argument("--max-memory", type=float, default=MAX_RESULT_BYTES / 2**30, metavar="GIB",
                         help="refuse, before it starts, a run whose recorded results (every output at every "
                              "communication point, 8 bytes each) would exceed GIB gibibytes "
                              f"(default {MAX_RESULT_BYTES / 2**30:g})")
    cosim_p.add_argument("--master", choices=("fmpy", "libcosim", "ecos", "library"), default="fmpy",
                         help="fmpy (default): our master over the FMUs; libcosim: DNV's libcosim; ecos: the ecos "
                              "engine (ecospy), given the system as SSP; library: the flexfmu models the FMUs wrap, "
                              "without FMI")
    cosim_p.add_argument("--scheme", choices=COUPLING_SCHEMES, default=None,
                         help="coupling scheme (default gauss-seidel, in the file's simulator order; libcosim, "
                              "ecos: jacobi only). interface-jacobian: every simulator steps, then the coupling "
                              "equations are solved with the outputs linearised in the inputs (interface Jacobians: "
                              "the library models' output functions; FMUs must provide directional derivatives). "
                              "step-jacobian: the inputs held over each step solve the coupling over it, with the "
                              "outputs linearised in them over the step (by rolling the simulators back): also "
                              "loops through states (docs/stability.md)")
    cosim_p.add_argument("--fmu-dir", type=Path, default=None, metavar="DIR",
                         help="take the FMUs from DIR instead of the file's sources (same file names)")
    cosim_p.add_argument("--plot", type=Path, default=None, metavar="PNG",
                         help="wave-energy converter: draw motion and harvested power")
    cosim_p.add_argument("--no-stability-check", action="store_true",
                         help="skip the coupling-stability check (a few seconds for the wave-energy converter)")
    cosim_p.set_defaults(func=_cosim)
