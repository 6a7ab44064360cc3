"""An FMU of one user's flexible body (flexfmu.body.FlexBody): ``flexfmu export``'s last stage.

The FMU is self-contained: the reduced model is ``resources/flexfmu_body.npz`` (FlexBody.save), read
when an instance is made, so it runs after the source files are gone and on another machine; its
variables (the interfaces' inputs and outputs, the body outputs, f_1 ... f_6, the parameters) come from
that file; ``documentation/index.html`` says what model it holds, where it came from and how it was
reduced.  Everything else (the runtime, the FMI behaviour) is the same as the built-in FMUs'.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

from flexfmu.errors import ParameterError
# what both runtimes' FMUs of a body share; re-exported: slaves generated before flexfmu.fmi.slave import
# exported_spec from here
# (SHAPE_FILE, shape_resource: the shape file, written for both runtimes by body_fmu)
from flexfmu.fmi.body_fmu import (BODY_FILE, SHAPE_FILE, ExportedSpec, check_model_identifier,  # noqa: F401
                                  check_target, default_experiment, documentation_html, exported_spec, shape_resource)


def export_fmu(body, target: Path, *, description: str | None = None, runtime: str = "python",
               fmi_version: int = 2, interface: str = "cs", arrays: bool = False) -> Path:
    """Build the FMU of ``body`` (flexfmu.body.FlexBody) at ``target`` (``NAME.fmu``; NAME becomes the
    modelIdentifier); ``runtime`` "native": a C-only FMU (flexfmu.fmi.native, which does not import this module);
    ``fmi_version`` 3: FMI 3.0 co-simulation (either runtime)."""
    if runtime == "native":
        from flexfmu.fmi.native import export_native
        return export_native(body, target, description=description, fmi_version=fmi_version, interface=interface,
                             arrays=arrays)
    if runtime != "python":
        raise ParameterError("runtime", f"got {runtime!r}", "python | native")
    if fmi_version not in (2, 3):
        raise ParameterError("fmi_version", f"got {fmi_version!r}", "2 or 3")
    if arrays:
        raise ParameterError("arrays", "the Python runtime's FMUs have no array variables", "runtime native")
    if interface != "cs":
        raise ParameterError("interface", f"{interface!r}: the Python runtime's FMUs are co-simulation only",
                             "cs, or runtime native (model exchange for clamped bodies)")
    from flexfmu.fmi import build
    from flexfmu.fmi import runtime as python_runtime

    target = Path(target)
    name = check_target(target)
    description = description or body.summary()
    with tempfile.TemporaryDirectory() as tmp:
        model_file = Path(tmp) / BODY_FILE
        body.save(model_file)
        resources = (model_file,) + shape_resource(body, Path(tmp))
        spec = ExportedSpec(name, description, body)
        runtime_files = python_runtime.compile_runtime(python_runtime.build_folder(), fmi_version)
        return build.build_one(spec, target, runtime_files, experiment=default_experiment(body),
                               resources=resources, documentation={"index.html": documentation_html(name, body)},
                               fmi_version=fmi_version)
