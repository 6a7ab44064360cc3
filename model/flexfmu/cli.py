# Over 500 lines on purpose: every sub-command's parser and its short handler in one place, so `flexfmu --help`
# and the handlers read together; the work itself is in the library functions each handler calls.
"""Command-line interface: a thin shell over library functions.

    flexfmu modal SCENE [--boundary B] [--elements-per-segment N] [--modes K] [--json] [--plot PNG]
    flexfmu modal MODEL [--material E,NU,RHO] [--length-unit U] [--nodes FILE] [--clamp SPEC] [--modes K]
                  [--json] [--plot PNG]
    flexfmu export MODEL -o OUT.fmu [--material E,NU,RHO] [--nodes FILE] [--clamp SPEC]
                  [--interface NAME=X,Y,Z]... [--modes N | --f-max HZ [--tolerance TOL]] [--damping ZETA]
                  [--runtime python|native]
    flexfmu build [--out dist] [--runtime python|native [--fmu FFRBeam|ReframeBody] [--set NAME=VALUE]...
                  [--name ID]]
    flexfmu reframe MODEL [--scheme consistent|exponential|paper] [--t-end T] [--dt DT] [--modes N]
                    [--force FX,FY,FZ] [--omega0 W1,W2,W3] [--every K] [--out result.csv]
    flexfmu cosim SYSTEM_FILE --t-end T [--step H] [--out results.csv] [--master fmpy|libcosim|ecos|library]
                    [--scheme gauss-seidel|jacobi] [--fmu-dir DIR] [--plot PNG] [--set INSTANCE.VARIABLE=VALUE]...
    flexfmu wec power-matrix [SYSTEM_FILE] [--hs H1,H2,..] [--tp T1,T2,..] [--seeds N] [--t-end T]
                    [--serial | --scheduler ADDRESS] [--out power_matrix.csv] [--plot power_matrix.png]
    flexfmu bench [performance|work-precision|stability|spinup] [--quick] [--out FILE]
    flexfmu main            the modal report of the paper's specimen (python3 tasks.py main does more)

Bad input exits with status 2 and a one-line message naming the parameter.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from flexfmu.ffr.assembly import BOUNDARY_HELP, BOUNDARY_PRESETS
from flexfmu.errors import FlexfmuError, ParameterError
from flexfmu.ffr.report import PAPER_SCENE, format_table, modal_analysis
from flexfmu.ffr.scene import builtin_scene_names, load_scene


def _load_user_model(args: argparse.Namespace):
    """The Structure of MODEL with --material, --length-unit and --nodes (flexfmu.importers)."""
    from flexfmu.importers import load_structure

    from flexfmu.importers.units import material_from_text

    options = {"material": material_from_text(args.material), "length_unit": args.length_unit,
               "coordinates": args.nodes}
    source = args.model if hasattr(args, "model") else args.scene
    return load_structure(source, **{k: v for k, v in options.items() if v is not None})


def _is_scene(text: str) -> bool:
    """A built-in scene or a scene JSON (it has "points"; a model JSON has "mesh")."""
    if text in builtin_scene_names():
        return True
    path = Path(text)
    if path.suffix.lower() != ".json" or not path.is_file():
        return False
    try:
        return "points" in json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, OSError, UnicodeDecodeError, TypeError):
        return True                     # load_scene reports what is wrong with it


def _modal_structure(args: argparse.Namespace) -> int:
    """Natural frequencies of an imported model: clamped (--clamp or the file's constraints) or free."""
    from flexfmu.body.build import clamp_from_text
    from flexfmu.body.modes import natural_modes

    if args.boundary is not None or args.elements_per_segment or args.rotary_inertia:
        raise ParameterError("boundary", "--boundary, --elements-per-segment and --rotary-inertia are scene options",
                             "a scene, or --clamp for a model file")
    structure = _load_user_model(args)
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


def _export(args: argparse.Namespace) -> int:
    """MODEL -> a self-contained FMU of a free or clamped flexible body with named interfaces."""
    from flexfmu.body.build import build_body, clamp_from_text
    from flexfmu.body.interfaces import interface_from_text
    from flexfmu.fmi.export import check_target, export_fmu

    check_target(args.output)                 # before the work: a bad name is known now

    if args.modes is not None and (args.f_max is not None or args.tolerance is not None):
        raise ParameterError("modes", "given with --f-max/--tolerance", "either --modes N, or --f-max HZ "
                             "[--tolerance TOL]")
    if args.modes is None and args.f_max is None:
        raise ParameterError("modes", "no model size given", "--modes N, or --f-max HZ [--tolerance TOL]")
    if not args.interface:
        raise ParameterError("interface", "none given", "at least one --interface NAME=X,Y,Z | NAME=SET")
    interfaces = [interface_from_text(text) for text in args.interface]
    structure = _load_user_model(args)
    body = build_body(structure, interfaces=interfaces, clamp=clamp_from_text(structure, args.clamp), n_modes=args.modes,
                      f_max=args.f_max,
                      tolerance=args.tolerance, damping_ratio=args.damping)
    for line in body.messages:
        print(f"flexfmu export: {line}", file=sys.stderr)
    target = export_fmu(body, args.output, runtime=args.runtime)
    print(f"wrote {target}: {body.summary()}" + (" (native runtime)" if args.runtime == "native" else ""))
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


#: ``flexfmu bench STUDY``: the module flexfmu.studies.<module>, each with main(argv) (benchmarks/<module>.py
#: are shells over the same).
BENCH_STUDIES = {"performance": "performance", "work-precision": "work_precision", "stability": "stability",
                 "spinup": "spinup"}


def _bench(args: argparse.Namespace) -> int:
    """Run a study of flexfmu.studies (default: performance) through its main(argv)."""
    import importlib

    module = BENCH_STUDIES[args.study]
    try:
        study = importlib.import_module(f"flexfmu.studies.{module}")
    except ModuleNotFoundError as exc:
        if exc.name != f"flexfmu.studies.{module}":
            raise                                  # a package the study needs: its own message names it
        print(f"flexfmu: error: bench {args.study}: no study module flexfmu.studies.{module} in "
              f"{Path(__file__).parent}", file=sys.stderr)
        return 2
    return study.main((["--quick"] if args.quick else []) + (["--out", args.out] if args.out else []))


def _main_job(args: argparse.Namespace) -> int:
    """The spatial double pendulum's converged modal report for every boundary preset."""
    scene = load_scene(PAPER_SCENE)
    for boundary in ("XFF", "XFX", "FXF", "FXF_mid"):
        print(format_table(scene.name, modal_analysis(scene, boundary, n_modes=6)))
        print()
    return 0


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
    if args.runtime == "native":
        from flexfmu.fmi.native import build_registry_fmu
        target = build_registry_fmu(args.fmu or "FFRBeam", _settings(args.set), out=out, model_name=args.name)
        print(f"built {target} (native runtime; fmpy validate: no problems)")
        return 0
    for option in ("fmu", "name"):
        if getattr(args, option) is not None:
            raise ParameterError(option, "is an option of --runtime native", "--runtime native --" + option)
    if args.set:
        raise ParameterError("set", "is an option of --runtime native (a Python FMU takes its parameters when "
                                    "instantiated)", "--runtime native --set NAME=VALUE")
    from flexfmu.fmi.build import build
    build(out)
    return 0


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
    if args.master == "libcosim":
        result = cosim.run_libcosim(system, args.t_end, h, progress=True)
    elif args.master == "ecos":
        result = cosim.run_ecos(system, args.t_end, h, progress=True)
    else:
        backend = "library" if args.master == "library" else "fmu"
        result = cosim.run(system, args.t_end, h, scheme=scheme, backend=backend, progress=True)
    print(f"{system.path}: {len(system.simulators)} simulators, {len(system.connections)} connections; "
          f"master {result.master}, step {h:g} s, t = {result.t[0]:g} .. {result.t[-1]:g} s")
    if wec.is_wec(system):
        print(wec.summary(result, system))
        balance = wec.energy_balance(result, system)
        print("energy balance over the run:")
        print(balance.table())
    if args.out is not None:
        if args.every > 1:
            keep = slice(None, None, args.every)
            result = cosim.CosimResult(result.t[keep], {k: v[keep] for k, v in result.columns.items()},
                                       result.step, result.scheme, result.master)
        result.write_csv(args.out)
        print(f"wrote {args.out} ({result.t.size} rows x {len(result.columns) + 1} columns)")
    if args.plot is not None:
        if not wec.is_wec(system):
            raise ParameterError("plot", "the system is not the wave-energy converter", "a system with WaveExcitation, "
                                 "Platform, Hydrostatics, FFRBeam and PTO")
        print(f"wrote {wec.plot_result(result, system, args.plot)}")
    return 0


def _floats(text: str, name: str) -> list:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ParameterError(name, f"{text!r} is not a comma-separated list of numbers", "e.g. 1.0,1.4,2.0") from None


def _wec_power_matrix(args: argparse.Namespace) -> int:
    """flexfmu wec power-matrix: flexfmu.wec.system.power_matrix, its CSV and heat map."""
    import numpy as np

    from flexfmu.wec import system as wec

    if args.seeds < 1:
        raise ParameterError("seeds", f"{args.seeds}", "integer >= 1")
    if args.workers < 1:
        raise ParameterError("workers", f"{args.workers}", "integer >= 1")
    scheduler = None if args.serial else (args.scheduler or "local")
    matrix = wec.power_matrix(args.system_file, _floats(args.hs, "hs"), _floats(args.tp, "tp"),
                              seeds=range(1, args.seeds + 1), t_end=args.t_end, step=args.step,
                              boundary=args.boundary, backend=args.backend, fmu_dir=args.fmu_dir,
                              scheduler=scheduler, n_workers=args.workers,
                              max_steepness=wec.MAX_STEEPNESS if args.max_steepness is None else args.max_steepness,
                              progress=True)
    n_runs = len(matrix.rows)
    print(f"{n_runs} co-simulations ({np.isfinite(matrix.power).sum()} of {matrix.power.size} cells) in "
          f"{matrix.wall_s:.0f} s ({'serial' if scheduler is None else 'Dask ' + scheduler})")
    for row in matrix.rows:
        if row.get("error"):
            print(f"  failed: Hs {row['wave_height']:g} m, Tp {row['wave_period']:g} s, seed {row['seed']}: "
                  f"{row['error']}")
    print(f"wrote {matrix.write_csv(args.out)}")
    if matrix.rows:
        print(f"wrote {wec.write_table(matrix.rows, args.out.with_name(args.out.stem + '_runs.csv'))}")
    print(f"wrote {matrix.plot(args.plot)}")
    return 0


def _add_model_options(parser: argparse.ArgumentParser) -> None:
    """The options of a model file (flexfmu.importers.load_structure) and its clamp."""
    group = parser.add_argument_group("model file")
    group.add_argument("--material", default=None, metavar="E,NU,RHO",
                       help="meshes: Young's modulus (Pa), Poisson's ratio, density (kg/m^3); default: the model "
                            "JSON beside the mesh")
    group.add_argument("--length-unit", default=None, choices=("m", "cm", "mm", "in"),
                       help="the file's length unit (Nastran, MAPDL: its consistent unit system); default m")
    group.add_argument("--nodes", type=Path, default=None, metavar="FILE",
                       help="MAPDL .full: the .cdb or .rst with the node coordinates (default: beside the .full)")
    group.add_argument("--clamp", default=None, metavar="SPEC",
                       help="clamp node sets (SET or SET1,SET2,...: all their DOFs), the file's constrained DOFs "
                            "('file'; the default when the file has some), or 'free' for a free body")


def build_parser() -> argparse.ArgumentParser:
    from flexfmu.reframe.schemes import SCHEMES

    parser = argparse.ArgumentParser(prog="flexfmu", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    modal = sub.add_parser("modal", help="natural frequencies of a scene or any importable model",
                           description="Natural frequencies (Hz) of a bent-rod scene under a set of clamps, or of any "
                                       "model flexfmu imports (mesh with material, model .json, Nastran .bdf, MAPDL "
                                       ".full, .npz, paper_plate): clamped by --clamp or the file's constrained "
                                       "DOFs, else free (elastic modes only). --plot draws the mode shapes.")
    modal.add_argument("scene", metavar="MODEL",
                       help=f"built-in scene ({', '.join(builtin_scene_names())}), a scene JSON, or a model file/spec")
    _add_model_options(modal)
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

    export = sub.add_parser(
        "export", help="a model file as a self-contained FMU of a flexible body with named interfaces",
        description="Turn a structural model (a mesh with its material, a Nastran deck, an MAPDL .full, a .npz or a "
                    "beam scene) into an FMI 2.0 co-simulation FMU: a free body (reframe integrator) or, with --clamp "
                    "or constrained DOFs in the file, a body clamped on a moving base; per interface NAME the inputs "
                    "NAME.F_x/y/z (and NAME.M_x/y/z) and the outputs NAME.pos_*/vel_*/acc_*, plus the body outputs "
                    "and f_1 ... f_6. Lengths and coordinates in m (after --length-unit scaling). See docs/export.md.")
    export.add_argument("model", metavar="MODEL", help="model file or spec (mesh, model .json, .bdf, .full, .npz, "
                                                       "beam:<scene>, paper_plate)")
    export.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.fmu",
                        help="the FMU to write; its stem is the model identifier")
    _add_model_options(export)
    export.add_argument("--interface", action="append", default=[], metavar="NAME=X,Y,Z",
                        help="an interface (repeatable): NAME=X,Y,Z (the nodes around the point), NAME=X,Y,Z,R "
                             "(the nodes within R m), NAME=SET (a node set; the point at its centre) or "
                             "NAME=SET@X,Y,Z")
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
    export.set_defaults(func=_export)

    build = sub.add_parser("build", help="build the FMUs of flexfmu.fmi.registry into dist/")
    build.add_argument("--out", type=Path, default=None, help="output folder (default: ./dist)")
    build.add_argument("--runtime", choices=("python", "native"), default="python",
                       help="python (default): every FMU of the registry, running flexfmu in the host's Python; "
                            "native: one C-only FMU (no Python) of --fmu, its model fixed by --set at build "
                            "(docs/fmu.md, 'Native runtime')")
    build.add_argument("--fmu", default=None, metavar="NAME",
                       help="native: the registry FMU to build: FFRBeam (default) or ReframeBody (scheme exponential)")
    build.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                       help="native: a parameter's value, fixed at build (repeatable; e.g. --set boundary=XFX)")
    build.add_argument("--name", default=None, metavar="ID",
                       help="native: the model identifier and file stem (default: the FMU's name)")
    build.set_defaults(func=_build)

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

    cosim_p = sub.add_parser(
        "cosim", help="co-simulate a system of FMUs described by an OspSystemStructure.xml or an SSP (.ssp)",
        description="Co-simulate a system of FMUs (OSP system structure file, or SSP 1.0) with a fixed communication "
                    "step: our fmpy master (Gauss-Seidel or Jacobi), libcosim or ecos (Jacobi), or the flexfmu library "
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
    cosim_p.add_argument("--every", type=int, default=1, metavar="K", help="write every K-th communication point")
    cosim_p.add_argument("--master", choices=("fmpy", "libcosim", "ecos", "library"), default="fmpy",
                         help="fmpy (default): our master over the FMUs; libcosim: DNV's libcosim; ecos: the ecos "
                              "engine (ecospy), given the system as SSP; library: the flexfmu models the FMUs wrap, "
                              "without FMI")
    cosim_p.add_argument("--scheme", choices=("gauss-seidel", "jacobi"), default=None,
                         help="coupling scheme (default gauss-seidel, in the file's simulator order; libcosim, "
                              "ecos: jacobi)")
    cosim_p.add_argument("--fmu-dir", type=Path, default=None, metavar="DIR",
                         help="take the FMUs from DIR instead of the file's sources (same file names)")
    cosim_p.add_argument("--plot", type=Path, default=None, metavar="PNG",
                         help="wave-energy converter: draw motion and harvested power")
    cosim_p.add_argument("--no-stability-check", action="store_true",
                         help="skip the coupling-stability check (a few seconds for the wave-energy converter)")
    cosim_p.set_defaults(func=_cosim)

    wec_p = sub.add_parser("wec", help="wave-energy converter studies (examples/wave_converter/)")
    wec_sub = wec_p.add_subparsers(dest="wec_command", required=True)
    pm = wec_sub.add_parser(
        "power-matrix", help="mean harvested power over significant wave height x peak period (JONSWAP)",
        description="The power matrix of the wave-energy converter: per cell (Hs, Tp) one JONSWAP co-simulation per "
                    "seed, mean harvested power over the second half of each run, averaged over the seeds; on a Dask "
                    "LocalCluster (default), a running scheduler (--scheduler) or serially (--serial). Writes the "
                    "matrix as CSV (rows Hs, columns Tp, W; empty cells not computed: steeper than --max-steepness "
                    "or failed) and a heat map; one row per co-simulation in CSV_runs.csv.")
    pm.add_argument("system_file", metavar="SYSTEM_FILE", type=Path, nargs="?",
                    default=Path("examples/wave_converter/OspSystemStructure.xml"),
                    help="OspSystemStructure.xml or .ssp (default examples/wave_converter/OspSystemStructure.xml)")
    pm.add_argument("--hs", default="0.05,0.1,0.15,0.2", metavar="H1,H2,...",
                    help="significant wave heights, m (default 0.05,0.1,0.15,0.2)")
    pm.add_argument("--tp", default="1.0,1.2,1.4,1.6,2.0", metavar="T1,T2,...",
                    help="peak periods, s (default 1.0,1.2,1.4,1.6,2.0)")
    pm.add_argument("--seeds", type=int, default=3, metavar="N", help="random-phase seeds 1..N per cell (default 3)")
    pm.add_argument("--t-end", type=float, default=60.0, metavar="T", help="length of each run, s (default 60)")
    pm.add_argument("--step", type=float, default=None, metavar="H", help="communication step (default: the file's)")
    pm.add_argument("--boundary", default="XFF", metavar="B", help="harvester clamps: XFF (default), XFX, FXF")
    pm.add_argument("--backend", choices=("library", "fmu"), default="library",
                    help="library (default): the models the FMUs wrap; fmu: the FMUs (--fmu-dir)")
    pm.add_argument("--fmu-dir", type=Path, default=None, metavar="DIR", help="take the FMUs from DIR")
    pm.add_argument("--max-steepness", type=float, default=None, metavar="S",
                    help="skip cells steeper than 2 pi Hs / (g Tp^2) > S (default 1/15)")
    where = pm.add_mutually_exclusive_group()
    where.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a LocalCluster)")
    where.add_argument("--serial", action="store_true", help="run in this process, without Dask")
    pm.add_argument("--workers", type=int, default=2, metavar="N", help="LocalCluster workers (default 2)")
    pm.add_argument("--out", type=Path, default=Path("power_matrix.csv"), metavar="CSV",
                    help="the matrix (default power_matrix.csv)")
    pm.add_argument("--plot", type=Path, default=Path("power_matrix.png"), metavar="PNG",
                    help="the heat map (default power_matrix.png)")
    pm.set_defaults(func=_wec_power_matrix)

    bench = sub.add_parser(
        "bench", help="benchmark studies (flexfmu.studies; also benchmarks/<study>.py)",
        description="Run a benchmark study (flexfmu.studies.<study>; works from an installed flexfmu): performance "
                    "(default; the performance table, report performance.md), work-precision (error against CPU "
                    "time; report work_precision.md and charts), stability (tables and charts of the failure "
                    "modes), spinup (linear models against a geometrically exact reference). Reports and charts go "
                    "to docs/ and docs/figures/ when flexfmu is a source checkout's model/flexfmu (an editable "
                    "install), else to the current directory and ./figures/. The reference trajectories are "
                    "package data (flexfmu/data/references/). Charts need matplotlib and the Exudyn comparisons "
                    "Exudyn; without them those parts are skipped with the pip command. More options: "
                    "python -m flexfmu.studies.<study> --help.")
    bench.add_argument("study", nargs="?", choices=tuple(BENCH_STUDIES), default="performance",
                       help="which study (default performance)")
    bench.add_argument("--quick", action="store_true", help="the study's short version")
    bench.add_argument("--out", default=None, metavar="REPORT.md",
                       help="the study's Markdown report; its charts go to figures/ beside it (default: performance "
                            "and work-precision write docs/<study>.md of a source checkout, else ./<study>.md; "
                            "stability and spinup write no report and draw their charts into docs/figures/ or "
                            "./figures/); '-': no report")
    bench.set_defaults(func=_bench)

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
