"""`flexfmu export`: a model file as a self-contained FMU of a flexible body with named interfaces."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from flexfmu.cli.build import add_arrays, add_fmi_version, add_interface_type, check_arrays, check_interface_type
from flexfmu.cli.model_file import add_model_options, load_user_model
from flexfmu.errors import ParameterError


def _export(args: argparse.Namespace) -> int:
    """MODEL -> a self-contained FMU of a free or clamped flexible body with named interfaces."""
    try:
        return _export_body(args)
    except ParameterError as exc:
        if exc.parameter != "gauge":
            raise
        # the library names its argument (gauges); the command line's user typed --gauge
        text = str(exc)[len("gauge: "):]
        if exc.allowed and text.endswith(f" (allowed: {exc.allowed})"):
            text = text[:-len(f" (allowed: {exc.allowed})")]
        raise ParameterError("--gauge", text, exc.allowed) from None


def _export_body(args: argparse.Namespace) -> int:
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.body.stress import gauge_from_text
    from flexfmu.fmi.export import check_target, export_fmu

    check_target(args.output)                 # before the work: a bad name is known now
    check_interface_type(args, "--interface-type")
    check_arrays(args)

    if args.modes is not None and (args.f_max is not None or args.tolerance is not None):
        raise ParameterError("modes", "given with --f-max/--tolerance", "either --modes N, or --f-max HZ "
                             "[--tolerance TOL]")
    if args.modes is None and args.f_max is None:
        raise ParameterError("modes", "no model size given", "--modes N, or --f-max HZ [--tolerance TOL]")
    if not args.interface:
        raise ParameterError("interface", "none given", "at least one --interface NAME=X,Y,Z | NAME=SET")
    for text in args.interface:
        if text in ("cs", "me", "both"):     # flexfmu build's --interface: here it names a body's interface
            raise ParameterError("interface", f"{text!r} names no body interface; the FMI interface type is "
                                 "--interface-type", f"--interface-type {text}, and --interface NAME=X,Y,Z | NAME=SET")
    interfaces = [interface_from_text(text) for text in args.interface]
    gauges = [gauge_from_text(text) for text in args.gauge]        # bad text refused before the model is read
    structure = load_user_model(args)
    clamp = clamp_from_text(structure, args.clamp)
    body = build_body(structure, interfaces=interfaces, clamp=clamp, n_modes=args.modes, f_max=args.f_max,
                      tolerance=args.tolerance, damping_ratio=args.damping, gauges=gauges,
                      with_shapes=True)     # a solid's shape file, either runtime (flexfmu animate)
    for line in body.messages:
        print(f"flexfmu export: {line}", file=sys.stderr)
    target = export_fmu(body, args.output, runtime=args.runtime, fmi_version=args.fmi_version,
                        interface=args.interface_type, arrays=args.fmi3_arrays)
    version = "FMI 3.0" if args.fmi_version == 3 else ""
    kinds = {"cs": "", "me": "model exchange", "both": "co-simulation and model exchange"}[args.interface_type]
    notes = ", ".join(note for note in ("native runtime" if args.runtime == "native" else "", version, kinds) if note)
    print(f"wrote {target}: {body.summary()}" + (f" ({notes})" if notes else ""))
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu export` to ``sub``, the sub-commands of build_parser."""
    export = sub.add_parser(
        "export", help="a model file as a self-contained FMU of a flexible body with named interfaces",
        description="Turn a structural model (a mesh with its material, a Nastran deck, an MAPDL .full, a .npz or a "
                    "beam scene) into an FMU (FMI 2.0 or 3.0; co-simulation, and with --runtime native model exchange "
                    "of a clamped body: --interface-type): a free body (reframe integrator) or, with --clamp "
                    "or constrained DOFs in the file, a body clamped on a moving base; per interface NAME the inputs "
                    "NAME.F_x/y/z (and NAME.M_x/y/z) and the outputs NAME.pos_*/vel_*/acc_*, plus the body outputs "
                    "and f_1 ... f_6, its shape coordinates q_1 ... q_m and per --gauge NAME its stress, von Mises and "
                    "strain outputs (a free body's: of its elastic deformation, body frame). Lengths and coordinates "
                    "in m (after --length-unit scaling). See docs/export.md.")
    export.add_argument("model", metavar="MODEL", help="model file or spec (mesh, model .json, .bdf, .full, .npz, "
                                                       "beam:<scene>, paper_plate)")
    export.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.fmu",
                        help="the FMU to write; its stem is the model identifier")
    add_model_options(export)
    export.add_argument("--interface", action="append", default=[], metavar="NAME=X,Y,Z",
                        help="an interface (repeatable): NAME=X,Y,Z (the nodes around the point), NAME=X,Y,Z,R "
                             "(the nodes within R m), NAME=SET (a node set; the point at its centre) or "
                             "NAME=SET@X,Y,Z")
    export.add_argument("--gauge", action="append", default=[], metavar="NAME=SET|X,Y,Z",
                        help="a stress and strain gauge of a solid body (repeatable): NAME=SET (the averaged "
                             "nodal stress of a node set) or NAME=X,Y,Z (the stress at a point, m, body frame); "
                             "outputs NAME.sigma_xx .. NAME.sigma_xz, NAME.von_mises (Pa), NAME.eps_xx .. NAME.eps_xz, "
                             "body frame (docs/export.md, 'Gauges')")
    size = export.add_argument_group("model size (one of)")
    size.add_argument("--modes", type=int, default=None, metavar="N", help="keep N elastic modes")
    size.add_argument("--f-max", type=float, default=None, metavar="HZ",
                      help="keep the modes up to HZ, and more until the interfaces' truncation error is within "
                           "--tolerance, with a static correction at the interfaces")
    size.add_argument("--tolerance", type=float, default=None, metavar="TOL",
                      help="relative truncation error at the interfaces for --f-max (default 1e-3)")
    export.add_argument("--damping", type=float, default=0.02, metavar="ZETA",
                        help="modal damping ratio (default 0.02; an FMU parameter too)")
    export.add_argument("--runtime", choices=("python", "native"), default="python",
                        help="python (default): the FMU runs flexfmu in the host's Python; native: a C-only binary "
                             "with no Python (clamped and free bodies; a free body's scheme exponential fixed at build; docs/fmu.md, "
                             "'Native runtime')")
    add_fmi_version(export)
    add_interface_type(export, "--interface-type")
    add_arrays(export)
    export.set_defaults(func=_export)
