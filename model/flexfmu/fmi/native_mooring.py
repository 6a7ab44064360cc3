"""The native Mooring: the Mooring FMU (flexfmu.wec.mooring: three catenary lines in MoorDyn) as the moordyn kind of
the native runtime (csrc/native_moordyn.c, whose header says what it does, call for call as the Python simulator).

What is baked into the model file: MoorDyn's input file of the build's configuration (the simulator's own
``moordyn_input``), the fairleads (body frame) and anchors (earth frame), line_length, depth, internal_time_step and
the simulator's cap on internal steps.  Every line parameter is fixed at build (another value is refused naming the
rebuild command, as FFRBeam's structural ones are); ``enabled`` stays a runtime parameter.

MoorDyn itself is C++ (MoorDyn-C 2.x): the FMU carries the shared library of the installed pip package ``moordyn``
(its ``moordyn.libs/libmoordyn-*.so*``, the library the Python simulator calls through cmoordyn) in
``binaries/linux64/`` beside the FMU's binary, which loads it at run time (dlopen from its own folder).  That library
is built for Linux x86-64 only, so the native Mooring has the linux64 binary only: a win64 or aarch64 native Mooring
would need MoorDyn built for that platform (and its binaries folder); a build asking for one is refused saying so,
and the kind refuses to load on any other platform (a binary rebuilt there from sources/).  The library needs the
host's libstdc++.so.6.

The simulator module is reached through the registry's plug-in point (``spec.load()``): fmi imports nothing of the
wave converter above it (tests/test_import_structure.py).
"""
from __future__ import annotations

import dataclasses
import html
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.fmi.model_file import RuntimeParameter
from flexfmu.fmi.native_build import NativeSource, build_native_fmu

#: the platforms MoorDyn's library (pip moordyn) is carried for
MOORDYN_PLATFORMS = ("linux64",)
#: the FMU's runtime parameters: enabled only (the lines are MoorDyn's input file, written at build)
RUNTIME = (RuntimeParameter("enabled", allowed="true | false"),)


def unsupported(platform: str) -> str:
    """Why there is no native Mooring for ``platform``."""
    return (f"a {platform} native Mooring would need MoorDyn (C++, MoorDyn-C 2.x) built for {platform}: the FMU "
            "carries the shared library of the pip package moordyn, which is built for Linux x86-64 (linux64) only")


def moordyn_library() -> Path:
    """The shared library of the installed pip package moordyn (what its Python wrapper cmoordyn calls)."""
    import importlib.util
    spec = importlib.util.find_spec("cmoordyn")
    found = sorted(Path(spec.origin).parent.joinpath("moordyn.libs").glob("libmoordyn*.so*")) if spec else []
    if len(found) != 1:
        what = "is not installed" if spec is None else f"has {len(found)} libmoordyn*.so* files in moordyn.libs"
        raise ParameterError("fmu", f"the native Mooring carries MoorDyn's shared library, but the pip package "
                                    f"moordyn {what}", "pip install moordyn (flexfmu's dev extra has it)")
    return found[0]


def _moordyn_version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("moordyn")
    except PackageNotFoundError:
        return "unknown"


def _text(value) -> str:
    """A value as --set takes it back."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def check_platforms(platforms) -> tuple:
    """The platforms asked for, each one MoorDyn's library is carried for; ParameterError naming why otherwise."""
    platforms = tuple(platforms)
    for platform in platforms:
        if platform not in MOORDYN_PLATFORMS:
            raise ParameterError("platform", f"{platform}: {unsupported(platform)}",
                                 ", ".join(MOORDYN_PLATFORMS))
    if not platforms:
        raise ParameterError("platform", "none given", ", ".join(MOORDYN_PLATFORMS))
    return platforms


def mooring_source(spec, values: dict, defaults: dict, model_name: str) -> NativeSource:
    """The registry's Mooring (``spec``) built with the parameter ``values`` as the moordyn kind: the simulator's
    MoorDyn input file and geometry in the model file, ``enabled`` a runtime parameter, MoorDyn's library beside the
    linux64 binary (``kind_files``)."""
    from flexfmu.core.checks import DEFAULT_MAX_INTERNAL_STEPS

    module = spec.load()                       # flexfmu.wec.mooring, named as text by the registry
    config = spec.config_class(**values)
    module.check(config)                       # ParameterError naming the parameter and its range
    library = moordyn_library()
    runtime_names = {p.name for p in RUNTIME}
    settings = {k: _text(v) for k, v in values.items() if v != defaults[k] and k not in runtime_names}
    rebuild = f"flexfmu build --runtime native --fmu {spec.name}" + (f" --name {model_name}"
                                                                     if model_name != spec.name else "")

    def entries(inputs, outputs, params):
        if sorted(inputs) != sorted(module.INPUT_NAMES) or sorted(outputs) != sorted(module.OUTPUT_NAMES):
            raise ParameterError("moordyn", "the FMU's inputs or outputs are not the Mooring's",
                                 ", ".join((*module.INPUT_NAMES, *module.OUTPUT_NAMES)))
        return {
            "moordyn.input": module.moordyn_input(config),
            "moordyn.library": library.name,
            "moordyn.fairleads": np.asarray(module.fairleads(config), float),
            "moordyn.anchors": np.asarray(module.anchors(config), float),
            "moordyn.real": np.array([config.line_length, config.depth, config.internal_time_step,
                                      DEFAULT_MAX_INTERNAL_STEPS], float),
            "moordyn.enabled": np.array([params.index("enabled") if "enabled" in params else -1,
                                         int(bool(config.enabled))], np.int32),
        }

    def kind_files(binaries: dict, missing: dict):
        """Only the linux64 binary (the others could not load MoorDyn), with MoorDyn's library beside it."""
        if "linux64" not in binaries:
            raise ParameterError("platform", "the native Mooring's linux64 binary was not built", "linux64")
        return ({"linux64": binaries["linux64"]}, {},
                {f"binaries/linux64/{library.name}": library.read_bytes()})

    others = "; ".join(f"{p}: {unsupported(p)}" for p in ("win64", "aarch64-linux"))
    page = (f"<h2>MoorDyn</h2><p>The lines are MoorDyn's (pip moordyn {html.escape(_moordyn_version())}): its "
            f"shared library <code>binaries/linux64/{html.escape(library.name)}</code> is loaded at run time from "
            "the folder of this FMU's binary (it needs the host's libstdc++.so.6); its input file, written from the "
            "parameters at build, goes to a private temporary folder of each instance (removed when the instance is "
            f"freed). Linux x86-64 only: {html.escape(others)}.</p>")
    return NativeSource(
        name=model_name, description=spec.description, spec=spec, values=values, runtime=RUNTIME, lti=None,
        experiment=dict(spec.experiment), kind="moordyn", kind_entries=entries, kind_files=kind_files,
        rebuild=rebuild, rebuild_settings=settings, documentation=page,
        info={"source": f"flexfmu.fmi.registry {spec.name}", "moordyn": _moordyn_version(),
              "moordyn_library": library.name,
              "platforms_unsupported": {p: unsupported(p) for p in ("win64", "aarch64-linux")}})


def build_mooring_fmu(target, settings: dict | None = None, *, platforms=MOORDYN_PLATFORMS, fmi_version: int = 2,
                      model_name: str | None = None) -> Path:
    """The native Mooring at ``target`` with the parameters ``settings`` {name: value} (the rest at their defaults)
    for ``platforms``: linux64 only, another is refused naming why (MoorDyn built for it would be needed)."""
    from flexfmu.fmi import registry
    from flexfmu.fmi.body_fmu import check_model_identifier

    check_platforms(platforms)
    spec = registry.BY_NAME["Mooring"]
    defaults = dataclasses.asdict(spec.config_class())
    unknown = sorted(set(settings or {}) - set(defaults))
    if unknown:
        raise ParameterError(unknown[0], "not a parameter of Mooring", ", ".join(defaults))
    name = check_model_identifier(model_name or spec.name)
    source = mooring_source(spec, {**defaults, **(settings or {})}, defaults, name)
    return build_native_fmu(source, target, fmi_version=fmi_version)
