"""The options of a model file (flexfmu.importers.load_structure) and the Structure they load: `flexfmu modal`
and `flexfmu export` take the same ones."""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path


def load_user_model(args: argparse.Namespace):
    """The Structure of MODEL with --material, --length-unit and --nodes (flexfmu.importers); the importers'
    warnings (a model size implausible in its length unit) printed as one line each, ``flexfmu: warning: ...``."""
    from flexfmu.importers import load_structure
    from flexfmu.importers.units import ModelSizeWarning, material_from_text

    options = {"material": material_from_text(args.material), "length_unit": args.length_unit,
               "coordinates": args.nodes}
    source = args.model if hasattr(args, "model") else args.scene
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ModelSizeWarning)
        structure = load_structure(source, **{k: v for k, v in options.items() if v is not None})
    for warning in caught:
        if issubclass(warning.category, ModelSizeWarning):
            print(f"flexfmu: warning: {warning.message}", file=sys.stderr)
        else:                           # not ours: as Python would have shown it
            warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    return structure


def add_model_options(parser: argparse.ArgumentParser) -> None:
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
