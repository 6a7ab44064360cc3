"""Command-line interface: a thin shell over library functions.

    flexfmu modal SCENE [--boundary B] [--elements-per-segment N] [--modes K] [--json]
    flexfmu build [--out dist]
    flexfmu main            the modal report of the paper's specimen (python3 tasks.py main does more)

Bad input exits with status 2 and a one-line message naming the parameter.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from flexfmu.assembly import BOUNDARY_HELP, BOUNDARY_PRESETS
from flexfmu.errors import FlexfmuError
from flexfmu.report import PAPER_SCENE, format_table, modal_analysis
from flexfmu.scene import builtin_scene_names, load_scene


def _modal(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene)
    boundary = args.boundary or "scene"
    result = modal_analysis(scene, boundary, n_modes=args.modes, elements_per_segment=args.elements_per_segment,
                            rotary_inertia=args.rotary_inertia)
    if args.json:
        model = result.model
        print(json.dumps({
            "scene": scene.name,
            "boundary": boundary,
            "clamps_s": list(model.clamp_s),
            "frequencies_hz": [float(f) for f in result.modes.frequencies_hz],
            "n_dof": int(model.n_free),
            "n_dof_unconstrained": int(model.n_dof),
            "elements_per_segment": result.elements_per_segment,
            "converged": result.converged,
            "rotary_inertia": bool(args.rotary_inertia),
        }))
    else:
        print(format_table(scene.name, result))
    return 0


def _main_job(args: argparse.Namespace) -> int:
    """The spatial double pendulum's converged modal report for every boundary preset."""
    scene = load_scene(PAPER_SCENE)
    for boundary in ("XFF", "XFX", "FXF", "FXF_mid"):
        print(format_table(scene.name, modal_analysis(scene, boundary, n_modes=6)))
        print()
    return 0


def _build(args: argparse.Namespace) -> int:
    """Build the FMUs with the source checkout's build_scripts/build_fmus.py."""
    import importlib.util

    script = Path(__file__).resolve().parents[2] / "build_scripts" / "build_fmus.py"
    if not script.is_file():
        print("flexfmu: error: build: needs a source checkout (build_scripts/build_fmus.py not found next to "
              f"the installed package at {Path(__file__).parent}); install with 'pip install -e .'", file=sys.stderr)
        return 2
    spec = importlib.util.spec_from_file_location("build_fmus", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.build(args.out.resolve() if args.out else script.parents[1] / "dist")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="flexfmu", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    modal = sub.add_parser("modal", help="natural frequencies of a bent-rod scene",
                           description="Natural frequencies (Hz) of a scene under a set of clamps.")
    modal.add_argument("scene", help=f"built-in scene ({', '.join(builtin_scene_names())}) or path to a scene JSON")
    modal.add_argument("--boundary", choices=BOUNDARY_PRESETS, default=None,
                       help="clamp preset; default: the scene's own clamps. "
                            + "; ".join(f"{k}: {v}" for k, v in BOUNDARY_HELP.items()))
    modal.add_argument("--elements-per-segment", type=int, default=0, metavar="N",
                       help="elements per segment; 0 (default) refines until the frequencies change < 1e-5")
    modal.add_argument("--modes", type=int, default=6, metavar="K", help="number of modes (default 6)")
    modal.add_argument("--rotary-inertia", action="store_true", help="include rotary inertia of bending")
    modal.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    modal.set_defaults(func=_modal)

    build = sub.add_parser("build", help="build the FMUs into dist/ (source checkout)")
    build.add_argument("--out", type=Path, default=None, help="output folder (default: dist/ of the checkout)")
    build.set_defaults(func=_build)

    main_job = sub.add_parser("main", help="the main job: the paper's spatial double pendulum, all boundaries")
    main_job.set_defaults(func=_main_job)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except FlexfmuError as exc:
        print(f"flexfmu: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
