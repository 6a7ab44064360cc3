"""The derived outputs of a native LTI model (flexfmu.core.stress.DerivedStress: an output computed from other outputs,
not linearly) as the arrays csrc/derived_stress.h reads: one entry per derived output, its kind and section shape as
codes, its index and its sources' indices among the model's outputs, and the section's constants.  The model file
carries them (the LTI kind's ``lti.derived.*`` entries, flexfmu.fmi.model_file) and the C kernel through ctypes
evaluates them (flexfmu.native.lti_kernel); :func:`derived_of_arrays` is the inverse."""
from __future__ import annotations

import numpy as np

from flexfmu.core.stress import DERIVED_KINDS, SECTION_SHAPES, DerivedStress, SectionFibres
from flexfmu.errors import ParameterError

#: csrc/derived_stress.h's codes: FFX_DERIVED_* (the kinds from 1) and FFX_SECTION_* (0 none, the shapes from 1)
KIND_CODES = {kind: k + 1 for k, kind in enumerate(DERIVED_KINDS)}
SHAPE_CODES = {shape: k + 1 for k, shape in enumerate(SECTION_SHAPES)}
MAX_SOURCES = 6
#: the order of a section's constants (FFX_FIBRE_*)
FIBRES = ("A", "Iy", "Iz", "J", "y_max", "z_max", "torsion_arm")
#: the arrays' names (in LtiModel.arrays() with the prefix "derived_", in the model file with "lti.derived.")
NAMES = ("kind", "shape", "output", "sources", "fibres")


def check_derived(derived, output_names) -> tuple:
    """``derived`` as a tuple of DerivedStress whose outputs and sources are among ``output_names``, each derived
    output once and none the source of another; ParameterError naming ``derived_outputs`` otherwise."""
    derived = tuple(derived)
    names = set(output_names)
    outputs = [d.output for d in derived]
    for d in derived:
        if not isinstance(d, DerivedStress):
            raise ParameterError("derived_outputs", f"an entry of type {type(d).__name__}",
                                 "flexfmu.core.stress.DerivedStress entries")
        missing = [n for n in (d.output, *d.sources) if n not in names]
        if missing:
            raise ParameterError("derived_outputs", f"{d.output}: {', '.join(missing)} not among the outputs",
                                 "outputs of the model")
        if any(s in outputs for s in d.sources):
            raise ParameterError("derived_outputs", f"{d.output} is computed from a derived output",
                                 "sources of the linear part")
    if len(set(outputs)) != len(outputs):
        raise ParameterError("derived_outputs", "an output derived twice", "one entry per output")
    return derived


def derived_arrays(derived, output_names) -> dict:
    """{name: array} of NAMES for the DerivedStress ``derived`` of a model with outputs ``output_names``: kind, shape,
    output (int32, n), sources (int32, (n, 6), -1 after the kind's sources), fibres (float64, (n, 7))."""
    index = {name: k for k, name in enumerate(output_names)}
    n = len(derived)
    sources = np.full((n, MAX_SOURCES), -1, np.int32)
    fibres = np.zeros((n, len(FIBRES)))
    for k, d in enumerate(derived):
        sources[k, :len(d.sources)] = [index[s] for s in d.sources]
        if d.fibres is not None:
            fibres[k] = [float(getattr(d.fibres, name)) for name in FIBRES]
    return {"kind": np.array([KIND_CODES[d.kind] for d in derived], np.int32),
            "shape": np.array([0 if d.fibres is None else SHAPE_CODES[d.fibres.shape] for d in derived], np.int32),
            "output": np.array([index[d.output] for d in derived], np.int32),
            "sources": sources, "fibres": fibres}


def derived_of_arrays(arrays: dict, output_names) -> tuple:
    """The DerivedStress of :func:`derived_arrays`' ``arrays`` (keys NAMES); ParameterError naming the entry when
    one is not such an array."""
    kinds = {code: kind for kind, code in KIND_CODES.items()}
    shapes = {code: shape for shape, code in SHAPE_CODES.items()}
    out = []
    try:
        for k, code in enumerate(np.asarray(arrays["kind"]).tolist()):
            kind = kinds[code]
            count = 6 if kind == "tensor_von_mises" else 4
            sources = tuple(output_names[int(j)] for j in arrays["sources"][k][:count])
            fibres = None
            if kind != "tensor_von_mises":
                fibres = SectionFibres(shapes[int(arrays["shape"][k])], *map(float, arrays["fibres"][k]))
            out.append(DerivedStress(output_names[int(arrays["output"][k])], kind, sources, fibres))
    except (KeyError, IndexError, ValueError, TypeError) as exc:
        raise ParameterError("derived", f"not derived-output arrays ({exc!r})", "derived_arrays' output") from None
    return tuple(out)
