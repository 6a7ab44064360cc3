"""`flexfmu modal` (natural frequencies of a scene or of any importable model) and `flexfmu main` (the paper's
specimen, every boundary preset): their parsers and handlers."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from flexfmu.cli.model_file import add_model_options, load_user_model
from flexfmu.core.checks import MAX_BEAM_DOFS, MAX_SOLID_DOFS, dof_limit, model_size_limit
from flexfmu.ffr.assembly import BOUNDARY_HELP, BOUNDARY_PRESETS
from flexfmu.errors import ParameterError
from flexfmu.ffr.report import PAPER_SCENE, format_table, modal_analysis
from flexfmu.ffr.scene import beam_model_dofs, builtin_scene_names, load_scene

_SMALLER_MESH = "a coarser mesh"


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


def _check_beam_spec(text: str, limit) -> None:
    """A beam:<scene> model spec (the free rod at reframe's 8 elements per segment) within ``limit``, checked as its
    scene is read, before the model is built."""
    from flexfmu.core.checks import path_exists_as
    from flexfmu.reframe.models import BEAM_PREFIX, DEFAULT_ELEMENTS_PER_SEGMENT

    name = text[len(BEAM_PREFIX):].strip() if text.startswith(BEAM_PREFIX) else None
    if name is None or (name not in builtin_scene_names() and path_exists_as(name) != "file"):
        return                                                 # not a beam spec, or load_structure names it
    n_el = DEFAULT_ELEMENTS_PER_SEGMENT

    def check(n_segments: int, scene=None) -> None:
        dofs = 6 * (n_segments * n_el + 1) if scene is None else beam_model_dofs(scene, n_el)
        limit.check(dofs, f"the beam model of {text} ({n_segments} segments at {n_el} elements per segment)", "MODEL",
                    "a scene with fewer segments")

    scene = load_scene(name, parameter="MODEL", check_size=check)
    check(len(scene.points) - 1, scene)


def _modal_structure(args: argparse.Namespace) -> int:
    """Natural frequencies of an imported model: clamped (--clamp or the file's constraints) or free.  The model's
    size is checked against --max-dofs (default MAX_SOLID_DOFS) before a mesh is assembled, and the modes' progress
    shown on stderr when the solve takes more than a second."""
    from flexfmu.body.build import clamp_from_text
    from flexfmu.body.modes import natural_modes

    if args.boundary is not None or args.elements_per_segment or args.rotary_inertia:
        raise ParameterError("boundary", "--boundary, --elements-per-segment and --rotary-inertia are scene options",
                             "a scene, or --clamp for a model file")
    if str(args.scene).startswith("beam:"):
        _check_beam_spec(str(args.scene), dof_limit(MAX_BEAM_DOFS, args.max_dofs, "--max-dofs"))
    limit = dof_limit(MAX_SOLID_DOFS, args.max_dofs, "--max-dofs")
    with model_size_limit(limit, "MODEL", _SMALLER_MESH, label="flexfmu modal"):     # meshes: before assembly
        structure = load_user_model(args)
    if not str(args.scene).startswith("beam:"):        # files read assembled (.npz, MAPDL .full), paper_plate
        limit.check(structure.n_dof, f"model {args.scene} ({structure.n_nodes:,} nodes x "
                    f"{structure.dofs_per_node} DOFs)", "MODEL", _SMALLER_MESH)
    modes = natural_modes(structure, clamp=clamp_from_text(structure, args.clamp), n_modes=args.modes,
                          progress=True)
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
    _animate_modes(args, structure, modes.shapes, modes.frequencies_hz, None)
    return 0


def _modal(args: argparse.Namespace) -> int:
    if not _is_scene(args.scene):
        return _modal_structure(args)
    for option in ("material", "length_unit", "nodes", "clamp"):
        if getattr(args, option) is not None:
            raise ParameterError(option.replace("_", "-"), "is an option of model files, not of scenes",
                                 "--boundary for a scene")
    limit = dof_limit(MAX_BEAM_DOFS, args.max_dofs, "--max-dofs")
    first = args.elements_per_segment or 2                     # the refinement starts at 2 elements per segment

    def check(n_segments: int) -> None:                        # as the scene is read: its segments alone
        limit.check(6 * (n_segments * first + 1), f"the beam model of scene {args.scene} ({n_segments} segments at "
                    f"{first} elements per segment)", "scene", "a scene with fewer segments")

    scene = load_scene(args.scene, check_size=check)
    boundary = args.boundary or "scene"
    result = modal_analysis(scene, boundary, n_modes=args.modes, elements_per_segment=args.elements_per_segment,
                            rotary_inertia=args.rotary_inertia, dof_limit=limit)
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
            "refinement_stopped": result.stopped or None,
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
    if args.animate is not None or args.vtk is not None:
        model = result.model
        _animate_modes(args, model.structure(), model.B2 @ result.modes.shapes, result.modes.frequencies_hz,
                       {"line": model.mesh.elements})
    return 0


def _animate_modes(args: argparse.Namespace, structure, shapes, frequencies_hz, cells) -> None:
    """--animate GIF: every mode oscillating over one period, side by side, each scaled to 10 % of the model's
    size and coloured by its von Mises stress (solids with cells; else |u|) relative to its largest; --vtk DIR: the
    modes as the frames of a VTK series (frame k = mode k, the mass-normalised shape as the displacement)."""
    if args.animate is None and args.vtk is None:
        return
    from flexfmu.viz.animate import animate, check_output
    from flexfmu.viz.modes import mode_pictures
    from flexfmu.viz.vtk import write_vtk_series

    if args.animate is not None:
        check_output(args.animate)                    # before the stress shapes are evaluated
    pictures = mode_pictures(structure, shapes, frequencies_hz, cells=cells)
    if pictures.stress is None:
        print(f"flexfmu modal: note: the animation is coloured by |u|: {pictures.why_no_stress}", file=sys.stderr)
    if args.vtk is not None:
        print(f"wrote {write_vtk_series(pictures.as_frames(), args.vtk, basename='mode')} "
              f"({pictures.frequencies_hz.size} modes as frames)")
    if args.animate is not None:
        done = animate(pictures.oscillating(), args.animate, fps=12,
                       title=f"{pictures.name or 'model'}: the modes, each over one period")
        print(f"wrote {done.path} ({done.frames} frames per period)")


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
    modal.add_argument("--animate", type=Path, nargs="?", const=Path("modes.gif"), default=None, metavar="OUT.gif",
                       help="animate the modes, each oscillating, coloured by the von Mises stress of the mode shape "
                            "(solid models with cells; else by |u|), into OUT.gif (default modes.gif; .mp4 with "
                            "ffmpeg)")
    modal.add_argument("--vtk", type=Path, default=None, metavar="DIR",
                       help="write the modes as a VTK series, DIR/mode.pvd (frame k = mode k: point data "
                            "displacement, von_mises)")
    modal.add_argument("--boundary", choices=BOUNDARY_PRESETS, default=None,
                       help="clamp preset; default: the scene's own clamps. "
                            + "; ".join(f"{k}: {v}" for k, v in BOUNDARY_HELP.items()))
    modal.add_argument("--elements-per-segment", type=int, default=0, metavar="N",
                       help="elements per segment; 0 (default) refines until the frequencies change < 1e-5")
    modal.add_argument("--modes", type=int, default=6, metavar="K", help="number of modes (default 6)")
    modal.add_argument("--rotary-inertia", action="store_true", help="include rotary inertia of bending")
    modal.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    modal.add_argument("--max-dofs", type=int, default=None, metavar="N",
                       help=f"largest model set up, in DOFs (default: {MAX_SOLID_DOFS:,} for a model file, "
                            f"{MAX_BEAM_DOFS:,} per mesh of a scene: the sizes that fit 60 s and 8 GB on the reference "
                            "machine, docs/export.md; or the environment variable FLEXFMU_MAX_DOFS)")
    modal.set_defaults(func=_modal)


def add_main_parser(sub) -> None:
    """Add `flexfmu main` to ``sub``, the sub-commands of build_parser."""
    main_job = sub.add_parser("main", help="the main job: the paper's spatial double pendulum, all boundaries")
    main_job.set_defaults(func=_main_job)
