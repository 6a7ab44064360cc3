"""`flexfmu build`: the FMUs of flexfmu.fmi.registry, or one native FMU of a registry entry."""
from __future__ import annotations

import argparse
from pathlib import Path

from flexfmu.errors import ParameterError


def add_fmi_version(parser) -> None:
    """--fmi-version 2|3 on ``parser`` (flexfmu build and export; both runtimes)."""
    parser.add_argument("--fmi-version", type=int, choices=(2, 3), default=2, metavar="{2,3}",
                        help="2 (default): FMI 2.0; 3: FMI 3.0 (docs/fmu.md, 'FMI 3.0')")


def add_interface_type(parser, *flags: str) -> None:
    """The FMI interface type(s) of the FMU on ``parser`` (``flags``: flexfmu build takes --interface and
    --interface-type, flexfmu export --interface-type, its --interface naming a body's interfaces)."""
    parser.add_argument(*flags, dest="interface_type", choices=("cs", "me", "both"), default="cs",
                        help="cs (default): co-simulation; me: model exchange; both (--runtime native; model exchange "
                             "for FFRBeam and clamped bodies, whose equations are ODEs; free bodies are "
                             "co-simulation only: docs/fmu.md, 'Model exchange and directional derivatives')")


def add_arrays(parser) -> None:
    """--fmi3-arrays on ``parser`` (flexfmu build and export)."""
    parser.add_argument("--fmi3-arrays", action="store_true",
                        help="with --runtime native --fmi-version 3: Float64 array views beside the scalar variables "
                             "(3-vectors, modal coordinates, natural frequencies sized by the structural parameter "
                             "n_retained_modes; an exported body's gauge tensors NAME.sigma, NAME.eps and shape "
                             "coordinates q; docs/fmu.md, 'Array variables'). Off by default: fmpy 0.3's "
                             "simulate_fmu feeds an input table column per input and cannot drive an array input")


def check_arrays(args: argparse.Namespace) -> None:
    """Array views are the native runtime's FMI 3.0 FMUs': refused otherwise before any work."""
    if args.fmi3_arrays and (args.runtime != "native" or args.fmi_version != 3):
        raise ParameterError("fmi3-arrays", "needs --runtime native --fmi-version 3 (FMI 2.0 has no arrays; the Python "
                             "runtime's FMUs have none)", "--runtime native --fmi-version 3 --fmi3-arrays")


def check_interface_type(args: argparse.Namespace, option: str) -> None:
    """Model exchange is the native runtime's: refused for the Python runtime before any work."""
    if args.interface_type != "cs" and args.runtime != "native":
        raise ParameterError(option, f"{args.interface_type}: the Python runtime's FMUs are co-simulation only; model "
                             "exchange is the native runtime's (FFRBeam, clamped bodies)",
                             f"cs, or --runtime native {option} {args.interface_type}")


def _settings(pairs: list) -> dict:
    """--set NAME=VALUE (repeatable; a later one wins) -> {name: text}."""
    out = {}
    for text in pairs:
        name, eq, value = text.partition("=")
        if not eq or not name.strip():
            raise ParameterError("set", f"got {text!r}", "NAME=VALUE, e.g. --set boundary=XFX")
        out[name.strip()] = value
    return out


def _build(args: argparse.Namespace) -> int:
    """Build the FMUs (flexfmu.fmi.build) from this flexfmu, installed or a source checkout; with --runtime
    native one native FMU (flexfmu.fmi.native) of the registry entry --fmu with its parameters from --set."""
    out = args.out if args.out else Path("dist")
    check_interface_type(args, "--interface")
    check_arrays(args)
    if args.runtime == "native":
        from flexfmu.fmi.native import build_registry_fmu
        target = build_registry_fmu(args.fmu or "FFRBeam", _settings(args.set), out=out, model_name=args.name,
                                    fmi_version=args.fmi_version, interface=args.interface_type,
                                    arrays=args.fmi3_arrays)
        version = ", FMI 3.0" if args.fmi_version == 3 else ""
        kinds = {"cs": "", "me": ", model exchange", "both": ", co-simulation and model exchange"}[args.interface_type]
        print(f"built {target} (native runtime{version}{kinds}; fmpy validate: no problems)")
        return 0
    for option in ("fmu", "name"):
        if getattr(args, option) is not None:
            raise ParameterError(option, "is an option of --runtime native", "--runtime native --" + option)
    if args.set:
        raise ParameterError("set", "is an option of --runtime native (a Python FMU takes its parameters when "
                                    "instantiated)", "--runtime native --set NAME=VALUE")
    from flexfmu.fmi.build import build
    build(out, args.fmi_version)
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu build` to ``sub``, the sub-commands of build_parser."""
    build = sub.add_parser("build", help="build the FMUs of flexfmu.fmi.registry into dist/")
    build.add_argument("--out", type=Path, default=None, help="output folder (default: ./dist)")
    build.add_argument("--runtime", choices=("python", "native"), default="python",
                       help="python (default): every FMU of the registry, running flexfmu in the host's Python; "
                            "native: one C-only FMU (no Python) of --fmu, its model fixed by --set at build "
                            "(docs/fmu.md, 'Native runtime')")
    build.add_argument("--fmu", default=None, metavar="NAME",
                       help="native: the registry FMU to build: FFRBeam (default), ReframeBody (scheme exponential), the "
                            "point absorber's AbsorberWave, AbsorberFloat, AbsorberHydro, HeavePTO, or Mooring "
                            "(MoorDyn; linux64)")
    build.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                       help="native: a parameter's value, fixed at build (repeatable; e.g. --set boundary=XFX)")
    build.add_argument("--name", default=None, metavar="ID",
                       help="native: the model identifier and file stem (default: the FMU's name)")
    add_fmi_version(build)
    add_interface_type(build, "--interface", "--interface-type")
    add_arrays(build)
    build.set_defaults(func=_build)
