"""`flexfmu modal` (natural frequencies of a scene or of any importable model) and `flexfmu main` (the paper's
specimen, every boundary preset): their parsers and handlers."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from flexfmu.cli.model_file import add_model_options, load_user_model
from flexfmu.ffr.assembly import BOUNDARY_HELP, BOUNDARY_PRESETS
from flexfmu.errors import ParameterError
from flexfmu.ffr.report import PAPER_SCENE, format_table, modal_analysis
from flexfmu.ffr.scene import builtin_scene_names, load_scene


def _is_scene(text: str) -> bool:
    """A built-in scene or a scene JSON (it has "points"; a model JSON has "mesh")."""
    if text in builtin_scene_names():
        return True
    path = Path(text)
    if path.suffix.lower() != ".json" or not path.is_file():
        return False
    try:
        return "points" in json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, OSError, UnicodeDecodeError, TypeError, RecursionError):
        return True                     # load_scene reports what is wrong with it (nesting too deep included)


def _modal_structure(args: argparse.Namespace) -> int:
    """Natural frequencies of an imported model: clamped (--clamp or the file's constraints) or free."""
    from flexfmu.body.build import clamp_from_text
    from flexfmu.body.modes import natural_modes

    if args.boundary is not None or args.elements_per_segment or args.rotary_inertia:
        raise ParameterError("boundary", "--boundary, --elements-per-segment and --rotary-inertia are scene options",
                             "a scene, or --clamp for a model file")
    structure = load_user_model(args)
    modes = natural_modes(structure, clamp=clamp_from_text(structure, args.clamp), n_modes=args.modes)
    if args.json:
        print(json.dumps({"model": str(args.scene), "name": structure.name, "kind": modes.kind,
                          "clamp": modes.clamp, "frequencies_hz": [float(f) for f in modes.frequencies_hz],
                          "n_dof": int(structure.n_dof), "n_nodes": int(structure.n_nodes),
                          "mass_kg": float(modes.mass)}))
    else:
        print(modes.table())
    if args.plot is not None:
        from flexfmu.body.modes import plot_modes
        print(f"wrote {plot_modes(structure, modes, args.plot)}")
    return 0


def _modal(args: argparse.Namespace) -> int:
    if not _is_scene(args.scene):
        return _modal_structure(args)
    for option in ("material", "length_unit", "nodes", "clamp"):
        if getattr(args, option) is not None:
            raise ParameterError(option.replace("_", "-"), "is an option of model files, not of scenes",
                                 "--boundary for a scene")
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
    if args.plot is not None:
        from flexfmu.body.modes import NaturalModes, plot_modes

        model = result.model
        structure = model.structure()
        modes = NaturalModes(scene.name, "clamped" if model.clamped_nodes.size else "free", f"boundary {boundary}",
                             result.modes.frequencies_hz, model.B2 @ result.modes.shapes, float("nan"))
        print(f"wrote {plot_modes(structure, modes, args.plot)}")
    return 0


def _main_job(args: argparse.Namespace) -> int:
    """The spatial double pendulum's converged modal report for every boundary preset."""
    scene = load_scene(PAPER_SCENE)
    for boundary in ("XFF", "XFX", "FXF", "FXF_mid"):
        print(format_table(scene.name, modal_analysis(scene, boundary, n_modes=6)))
        print()
    return 0


def add_parser(sub) -> None:
    """Add `flexfmu modal` to ``sub``, the sub-commands of build_parser."""
    modal = sub.add_parser("modal", help="natural frequencies of a scene or any importable model",
                           description="Natural frequencies (Hz) of a bent-rod scene under a set of clamps, or of any "
                                       "model flexfmu imports (mesh with material, model .json, Nastran .bdf, MAPDL "
                                       ".full, .npz, paper_plate): clamped by --clamp or the file's constrained "
                                       "DOFs, else free (elastic modes only). --plot draws the mode shapes.")
    modal.add_argument("scene", metavar="MODEL",
                       help=f"built-in scene ({', '.join(builtin_scene_names())}), a scene JSON, or a model file/spec")
    add_model_options(modal)
    modal.add_argument("--plot", type=Path, default=None, metavar="PNG", help="draw the mode shapes into PNG")
    modal.add_argument("--boundary", choices=BOUNDARY_PRESETS, default=None,
                       help="clamp preset; default: the scene's own clamps. "
                            + "; ".join(f"{k}: {v}" for k, v in BOUNDARY_HELP.items()))
    modal.add_argument("--elements-per-segment", type=int, default=0, metavar="N",
                       help="elements per segment; 0 (default) refines until the frequencies change < 1e-5")
    modal.add_argument("--modes", type=int, default=6, metavar="K", help="number of modes (default 6)")
    modal.add_argument("--rotary-inertia", action="store_true", help="include rotary inertia of bending")
    modal.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    modal.set_defaults(func=_modal)


def add_main_parser(sub) -> None:
    """Add `flexfmu main` to ``sub``, the sub-commands of build_parser."""
    main_job = sub.add_parser("main", help="the main job: the paper's spatial double pendulum, all boundaries")
    main_job.set_defaults(func=_main_job)
