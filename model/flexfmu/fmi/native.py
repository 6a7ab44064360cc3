"""Native FMUs: an FMI 2.0 co-simulation FMU (or, with ``fmi_version=3``, an FMI 3.0 one: the same binary,
flexfmu.fmi.description_fmi3) whose binary is C only (no Python in the host), built from an FMU spec and a
configuration (``flexfmu build --runtime native``) or from an exported body, clamped or free (``flexfmu export ...
--runtime native``).

The binary is the same front as the Python FMUs' (csrc/flexfmu_fmi2.c: entry points, call-sequence table, FMU-state
header, logging) compiled in its native variant and linked statically with the native bridge (csrc/flexfmu_native.c:
variables, checks, time, FMU states) and a model kind (csrc/native_lti.c on flexfmu/native/csrc/lti_kernels.c for
clamped bodies; csrc/native_reframe.c on flexfmu/native/csrc/reframe_kernels.c for free ones).  Everything about the model is data, in ``resources/flexfmu_model.bin`` (format below); the
modelDescription comes from the same source as the Python FMU's (a pythonfmu slave over flexfmu.fmi.plumbing for
the same spec, completed by flexfmu.fmi.build), so the variables, value references, units, descriptions and the
DefaultExperiment are the Python FMU's.  What differs: parameters that shape the model (FFRBeam's scene, boundary,
mesh, modes, ...) are fixed at build (their start value is the build value; another value is refused naming the
rebuild command); runtime parameters (damping_ratio, max_internal_steps, internal_step) stay settable until
fmi2ExitInitializationMode.

What each FMU is made of (a NativeSource: the spec, the values built with, the runtime parameters, the kind's model)
is decided here, for the registry's FMUs (``registry_source``, ``build_registry_fmu``; the point absorber's four
components as the wec kind, csrc/native_wec.c: ``wec_source``, every parameter settable) and for exported bodies
(``body_source``, ``export_native``); flexfmu.fmi.native_build makes the FMU of a NativeSource (modelDescription,
model file, binary, sources/, documentation).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.fmi.model_file import RuntimeParameter

from flexfmu.fmi.native_build import NativeSource, build_native_fmu

#: the point absorber's components (flexfmu.wec.absorber) as the wec kind's components (csrc/native_wec.c)
WEC_COMPONENTS = {"AbsorberWave": "wave", "AbsorberFloat": "float", "AbsorberHydro": "hydro", "HeavePTO": "pto"}
#: FMU specs with a native form (flexfmu.fmi.registry names), and why the others have none yet
NATIVE_FMUS = ("FFRBeam", "ReframeBody", *WEC_COMPONENTS, "Mooring")
NOT_YET: dict = {}


def _max_internal_steps() -> RuntimeParameter:
    from flexfmu.core.checks import DEFAULT_MAX_INTERNAL_STEPS, MAX_INTERNAL_STEPS_RANGE
    lo, hi = MAX_INTERNAL_STEPS_RANGE
    return RuntimeParameter("max_internal_steps", lo, hi,
                            allowed=f"an integer {lo} .. {hi:.0e} (default {DEFAULT_MAX_INTERNAL_STEPS})")


# ---------------------------------------------------------------------------------------------- FFRBeam
def _parse_value(name: str, text, default):
    """A --set value as the config field's type (that of its default)."""
    if not isinstance(text, str):
        return text
    try:
        if isinstance(default, bool):
            lowered = text.strip().lower()
            if lowered not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return lowered in ("true", "1")
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
    except ValueError:
        raise ParameterError(name, f"got {text!r}", f"a {type(default).__name__}") from None
    return text


def registry_source(name: str = "FFRBeam", settings: dict | None = None, *, model_name: str | None = None
                    ) -> NativeSource:
    """The native source of the registry FMU ``name`` with the parameters ``settings`` {name: value or text} (the
    rest at their defaults); ParameterError for an FMU without a native form or a configuration it cannot have."""
    from flexfmu.fmi import registry
    from flexfmu.fmi.body_fmu import check_model_identifier

    if name not in registry.BY_NAME:
        raise ParameterError("fmu", f"got {name!r}", " | ".join(registry.BY_NAME))
    if name not in NATIVE_FMUS:
        why = NOT_YET.get(name, "the native runtime has its kinds only for clamped bodies")
        raise ParameterError("runtime", f"{name} has no native form yet ({why})",
                             f"--runtime python for {name}; --runtime native for {', '.join(NATIVE_FMUS)}")
    spec = registry.BY_NAME[name]
    model_name = check_model_identifier(model_name or name)
    defaults = dataclasses.asdict(spec.config_class())
    values = dict(defaults)
    for key, text in (settings or {}).items():
        if key not in defaults:
            raise ParameterError(key, "not a parameter of " + name, ", ".join(defaults))
        values[key] = _parse_value(key, text, defaults[key])
    if name == "ReframeBody":
        return _reframe_source(spec, values, defaults, model_name)
    if name == "Mooring":                       # the moordyn kind (MoorDyn's library carried beside the binary)
        from flexfmu.fmi.native_mooring import mooring_source
        return mooring_source(spec, values, defaults, model_name)
    if name in WEC_COMPONENTS:
        return wec_source(spec, WEC_COMPONENTS[name], values, _absorber_hull(spec), model_name,
                          divergence_limit=getattr(spec.load(), "_DIVERGENCE_LIMIT", math.inf))
    return _ffrbeam_source(spec, values, defaults, model_name)


def _ffrbeam_source(spec, values: dict, defaults: dict, model_name: str) -> NativeSource:
    from flexfmu.ffr import simulator as ffr
    from flexfmu.native.lti import LtiModel

    config = spec.config_class(**values)
    sim = ffr.FFRBeamSimulator(config)
    lti = LtiModel.from_ffrbeam(sim)
    # the modes chosen for n_modes = -1 depend on the damping ratio (the truncation estimate): then it is fixed too
    runtime = [_max_internal_steps()]
    if config.n_modes != -1:
        runtime.insert(0, RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True, allowed="0 <= damping_ratio < 1"))
    settings = {k: _cli_text(v) for k, v in values.items() if v != defaults[k] and k not in {p.name for p in runtime}}
    rebuild = f"flexfmu build --runtime native --fmu {spec.name}" + (f" --name {model_name}"
                                                                     if model_name != spec.name else "")
    return NativeSource(
        name=model_name, description=spec.description, spec=spec, values=values, runtime=tuple(runtime), lti=lti,
        experiment=dict(spec.experiment), messages=list(sim.messages), divergence_limit=ffr._DIVERGENCE_LIMIT,
        divergence_allowed="inputs within the linear model's range; spin below the first bending frequency",
        rebuild=rebuild, rebuild_settings=settings,
        info={"source": f"flexfmu.fmi.registry {spec.name}", "fit_error": lti.fit_error})


#: the reframe kind's runtime-parameter roles (csrc/native_reframe.c, reframe.role)
_REFRAME_ROLES = ("damping_ratio", "tolerance", "internal_step", "max_internal_steps", "v0_x", "v0_y", "v0_z",
                  "omega0_1", "omega0_2", "omega0_3", "force_follows_body")


def _reframe_source(spec, values: dict, defaults: dict, model_name: str) -> NativeSource:
    """ReframeBody (scheme "exponential") as the reframe kind (csrc/native_reframe.c): the arrays its Python
    simulator passes to the kernels, written once; the model (model, n_flexible_modes, f_max, the load and output
    points, scheme) fixed at build; damping_ratio and tolerance too when n_flexible_modes = -1 (the modes chosen
    depend on them)."""
    from flexfmu.reframe import simulator as rs
    from flexfmu.reframe.schemes import scheme_class

    config = spec.config_class(**values)
    # ReframeBody's model file has no scheme entry (reframe.body is an exported free body's): C steps code 0
    scheme_class(config.scheme, lambda s: s.native_code == 0, context="native: ",
                 hint=", the scheme the native ReframeBody steps (--runtime python for the others)")
    sim = rs.ReframeBodySimulator(config)
    integ = sim.integrator
    nf = integ.data.nf
    auto = config.n_flexible_modes == -1
    omega = np.sqrt(integ._kF)
    finite = "a finite number"
    lo, hi = rs.TOLERANCE_RANGE
    runtime = [RuntimeParameter("internal_step", 0.0, allowed="0 (automatic) or a step > 0 s"),
               _max_internal_steps(),
               *(RuntimeParameter(n, allowed=finite) for n in rs._INITIAL),
               RuntimeParameter("force_follows_body")]
    if not auto:
        # damping enters the kernels only as c_F = 2 zeta omega (flexfmu.linalg.modal_basis): recomputed at run time
        zeta = float(config.damping_ratio)
        if np.array_equal(integ._cF, 2.0 * np.full(nf, zeta) * omega):
            runtime.insert(0, RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True,
                                               allowed="0 <= damping_ratio < 1"))
        runtime.insert(1, RuntimeParameter("tolerance", lo, hi, hi_open=True,
                                           allowed=f"{lo:g} <= tolerance < {hi:g} (relative)"))
    names = {p.name for p in runtime}
    settings = {k: _cli_text(v) for k, v in values.items() if v != defaults[k] and k not in names}
    rebuild = f"flexfmu build --runtime native --fmu {spec.name}" + (f" --name {model_name}"
                                                                     if model_name != spec.name else "")
    order, bc, br, sc, sr = integ._umax
    LP = np.array(integ._kernel_loads(sim._loads), dtype=float)
    PP = np.array(integ._point_data(sim._points), dtype=float).reshape(1, 3 + 3 * nf)

    def entries(inputs, outputs, params):
        if list(inputs) != list(rs.INPUT_NAMES):
            raise ParameterError("reframe", "the FMU's inputs are not ReframeBody's", ", ".join(rs.INPUT_NAMES))
        columns = [int(sim._columns[rs.OUTPUT_NAMES.index(name)]) for name in outputs]
        return {
            "reframe.P": np.array(integ._P, dtype=float), "reframe.LP": LP, "reframe.PP": PP,
            "reframe.omega": omega, "reframe.Psi": np.ascontiguousarray(integ._Psi_c),
            "reframe.order": np.asarray(order, np.int32), "reframe.bc": bc, "reframe.br": br,
            "reframe.sc": sc, "reframe.sr": sr,
            "reframe.int": np.array([nf, integ.data.dpn, int(integ.deformed_load_arm), int(sim._accepts_moment), 1, 0],
                                    np.int32),
            "reframe.real": np.array([sim._arm, sim._J_min, sim._size, integ.data.mass], float),
            "reframe.columns": np.array(columns, np.int32),
            "reframe.role": np.array([params.index(n) if n in params else -1 for n in _REFRAME_ROLES], np.int32),
            "reframe.fixed": np.array([float(getattr(config, n)) for n in _REFRAME_ROLES], float),
        }

    return NativeSource(
        name=model_name, description=spec.description, spec=spec, values=values, runtime=tuple(runtime), lti=None,
        experiment=dict(spec.experiment), kind="reframe", kind_entries=entries, messages=list(sim.messages),
        rebuild=rebuild, rebuild_settings=settings, info={"source": f"flexfmu.fmi.registry {spec.name}"})


# ---------------------------------------------------------------------------------------------- point absorber
_DOFS = ("x", "y", "z", "rx", "ry", "rz")
#: each wec component's parameters, in csrc/native_wec.c's order (ROLES), and their ranges as the simulators check them
#: (flexfmu.wec.absorber: the same texts, so both runtimes refuse a value with the same message)
WEC_ROLES = {
    "wave": ("sea_state", "wave_height", "wave_period", "gamma", "seed", "n_components", "record_length", "ramp_time"),
    "float": ("heave_only",),
    "hydro": ("drag", *(f"drag_coefficient_{d}" for d in _DOFS), *(f"drag_area_{d}" for d in _DOFS)),
    "pto": ("damping", "stiffness", "force_limit"),
}
_WEC_RULES = {
    "wave_height": RuntimeParameter("wave_height", 0.0, allowed=">= 0 m"),
    "wave_period": RuntimeParameter("wave_period", 0.0, lo_open=True, allowed="> 0 s"),
    "gamma": RuntimeParameter("gamma", 1.0, allowed=">= 1"),
    "seed": RuntimeParameter("seed", 0.0, 2.0**31 - 1, allowed=f"0 .. {2**31 - 1}"),
    "n_components": RuntimeParameter("n_components", 0.0, 5000.0, allowed="0 (automatic) or 1 .. 5000"),
    "record_length": RuntimeParameter("record_length", 0.0, lo_open=True, allowed="> 0 s"),
    "damping": RuntimeParameter("damping", 0.0, allowed=">= 0 N.s/m"),
    "force_limit": RuntimeParameter("force_limit", 0.0, allowed=">= 0 N (0: no limit)"),
    **{f"drag_coefficient_{d}": RuntimeParameter(f"drag_coefficient_{d}", 0.0, allowed=">= 0") for d in _DOFS},
    **{f"drag_area_{d}": RuntimeParameter(f"drag_area_{d}", 0.0, allowed=">= 0 m^2 (m^5 for a rotation)")
       for d in _DOFS},
}
#: the refusal of a float or hydro step beyond its divergence limit (the simulators' text)
_WEC_DIVERGENCE = "a communication step inside the coupling-stability limit (examples/point_absorber/README.md)"


def _absorber_hull(spec):
    """The hull data (flexfmu.wec.absorber.hull.absorber_hull(): an AbsorberHull) of a point-absorber component: the
    module ``hull`` beside its simulator module, named as text as the registry names the simulator (fmi imports
    nothing of the wave converter above it; tests/test_import_structure.py's plug-in points)."""
    import importlib
    package = spec.module.rpartition(".")[0]
    return importlib.import_module(f"{package}.hull").absorber_hull()


def wec_source(spec, component: str, values: dict, hull, model_name: str, *,
               divergence_limit: float = math.inf) -> NativeSource:
    """A point-absorber component (``component`` of WEC_ROLES) as the wec kind (csrc/native_wec.c): the ``hull``'s
    data (an AbsorberHull, or any object with its fields) baked into the model file, every parameter a runtime
    parameter (``values``: their start values), so one FMU serves every sea state and PTO setting;
    ``divergence_limit``: the simulator's bound on |xi|, |xi_dot| (float) or on the memory states (hydro)."""
    roles = WEC_ROLES[component]
    defaults = dataclasses.asdict(spec.config_class())
    if set(defaults) != set(roles):
        raise ParameterError("fmu", f"{spec.name}'s parameters {sorted(defaults)} are not the wec kind's "
                             f"{component}'s", ", ".join(roles))
    runtime = tuple(_WEC_RULES.get(name, RuntimeParameter(name)) for name in roles)
    M_total = np.asarray(hull.M_rb, float) + np.asarray(hull.A_inf, float)
    rad = hull.radiation
    arrays = {
        "wave": lambda: {"wec.sea_state": str(values["sea_state"]), "wec.omega": np.asarray(hull.omega, float),
                         "wec.X": np.stack([np.real(hull.X), np.imag(hull.X)], axis=-1).astype(float)},
        "float": lambda: {"wec.M": M_total, "wec.M_inv": np.linalg.inv(M_total)},
        "hydro": lambda: {"wec.C": np.asarray(hull.C, float), "wec.A_r": np.asarray(rad.A_r, float),
                          "wec.B_r": np.asarray(rad.B_r, float), "wec.C_r": np.asarray(rad.C_r, float),
                          "wec.rho": np.float64(hull.rho)},
        "pto": dict,
    }[component]()

    def entries(inputs, outputs, params):
        fixed = [0.0 if isinstance(values[name], str) else float(values[name]) for name in roles]
        return {"wec.component": component, "wec.fixed": np.array(fixed, float),
                "wec.divergence_limit": np.float64(divergence_limit), **arrays}

    return NativeSource(
        name=model_name, description=spec.description, spec=spec, values=values, runtime=runtime, lti=None,
        experiment=dict(spec.experiment), kind="wec", kind_entries=entries, divergence_allowed=_WEC_DIVERGENCE,
        rebuild=f"flexfmu build --runtime native --fmu {spec.name}",
        info={"source": f"flexfmu.fmi.registry {spec.name}"})


def _cli_text(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def build_registry_fmu(name: str = "FFRBeam", settings: dict | None = None, *, out=None, target=None,
                       model_name: str | None = None, fmi_version: int = 2, interface: str = "cs",
                       arrays: bool = False) -> Path:
    """``flexfmu build --runtime native``: the native FMU of the registry entry ``name`` into ``target`` (default
    ``out``/<model name>.fmu); ``fmi_version`` 2 or 3; ``interface`` cs, me or both (flexfmu.fmi.interfaces);
    ``arrays`` (FMI 3.0): the Float64 array views beside the scalars (flexfmu.fmi.fmi3_arrays)."""
    source = registry_source(name, settings, model_name=model_name)
    if target is None:
        target = Path(out or "dist") / f"{source.name}.fmu"
    return build_native_fmu(source, target, fmi_version=fmi_version, interface=interface, arrays=arrays)


# ---------------------------------------------------------------------------------------------- exported bodies
def body_source(body, name: str, description: str | None = None, *, scheme: str = "exponential") -> NativeSource:
    """The native source of an exported body (flexfmu.body.FlexBody) as the native model kind its class names
    (``native_kind``): a ClampedBody as the LTI kind (:func:`_clamped_body_source`), a FreeBody as the reframe kind
    (:func:`_free_body_source`, its ``scheme`` fixed at build)."""
    from flexfmu.fmi.body_fmu import check_model_identifier

    check_model_identifier(name)
    native_kind = getattr(body, "native_kind", None)
    if native_kind not in _BODY_SOURCES:
        raise ParameterError("body", f"{type(body).__name__} (native kind {native_kind!r})",
                             "a FreeBody or a ClampedBody (flexfmu.body.model)")
    return _BODY_SOURCES[native_kind](body, name, description, scheme)


def _clamped_body_source(body, name: str, description: str | None, scheme: str) -> NativeSource:
    """An exported clamped body as the LTI kind (csrc/native_lti.c): the linear system extracted from its
    FlexBodySimulator's maps (flexfmu.native.lti.LtiModel.from_clamped_body), and the shape file of a body built with
    its shape data (resources/shape.npz, as the Python runtime's FMU: flexfmu animate); ``scheme`` is a free body's."""
    import tempfile

    from flexfmu.body.simulator import FlexBodySimulator
    from flexfmu.fmi.body_fmu import ExportedSpec, default_experiment, documentation_html, shape_resource
    from flexfmu.native.lti import LtiModel

    description = description or body.summary()
    spec = ExportedSpec(name, description, body)
    config = body.config_class()
    sim = FlexBodySimulator(body, config)
    lti = LtiModel.from_clamped_body(sim)
    zeta = float(body.damping_ratio)
    runtime = (RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True, special=-1.0, replacement=zeta,
                                allowed="-1 (the body's) or 0 <= damping_ratio < 1"),
               RuntimeParameter("internal_step", 0.0, allowed="0 (automatic) or a step > 0 s"),
               _max_internal_steps())
    with tempfile.TemporaryDirectory(prefix="flexfmu-shape-") as tmp:
        resources = {path.name: path.read_bytes() for path in shape_resource(body, Path(tmp))}
    page = documentation_html(name, body)
    # the shape file's paragraph (when it has one) and the model's summary
    summary = page[page.index("</p>", page.index("<h1>")) + len("</p>"):page.index("<h2>Variables</h2>")]
    return NativeSource(
        name=name, description=description, spec=spec, values=dataclasses.asdict(config), runtime=runtime, lti=lti,
        experiment=default_experiment(body), messages=[f"model: {body.summary()}", *body.messages],
        rebuild=f"flexfmu export MODEL -o {name}.fmu ... --runtime native", log_split=True, documentation=summary,
        resources=resources, info={"source": body.summary(), "fit_error": lti.fit_error})


def _free_body_source(body, name: str, description: str | None, scheme: str) -> NativeSource:
    """An exported free body as the reframe kind (csrc/native_reframe.c, its free-body entries): the arrays of
    its FlexBodySimulator's FreeDynamics written once, one load and one output point per interface, the outputs
    by the simulator's own columns plus the global frame vectors and the frequencies; ``scheme`` fixed at build,
    the other parameters settable."""
    from flexfmu.body.simulator import FlexBodySimulator
    from flexfmu.body.variables import INITIAL_MOTION, TOLERANCE_RANGE
    import tempfile

    from flexfmu.fmi.body_fmu import ExportedSpec, default_experiment, documentation_html, shape_resource
    from flexfmu.reframe.schemes import scheme_class

    code = scheme_class(scheme, lambda s: s.for_bodies and s.native_code is not None, context="native: ",
                        hint=", the free-body schemes with a native form").native_code
    description = description or body.summary()
    spec = ExportedSpec(name, description, body)
    config = body.config_class(scheme=scheme)
    sim = FlexBodySimulator(body, config)
    engine, dyn = sim.engine, sim.engine.dyn
    nf = dyn.nf
    zeta = float(body.damping_ratio)
    lo, hi = TOLERANCE_RANGE
    runtime = (RuntimeParameter("damping_ratio", 0.0, 1.0, hi_open=True, special=-1.0, replacement=zeta,
                                allowed="-1 (the body's) or 0 <= damping_ratio < 1"),
               RuntimeParameter("tolerance", lo, hi, hi_open=True, allowed=f"{lo:g} <= tolerance < {hi:g}"),
               RuntimeParameter("internal_step", 0.0, allowed="0 (automatic) or a step > 0 s"),
               _max_internal_steps(),
               *(RuntimeParameter(n, allowed="a finite number") for n in INITIAL_MOTION))
    order, bc, br, sc, sr = dyn.umax
    n_direct = len(engine.columns)
    # after the kernel columns: the 9 global frame vectors and the frequencies (reframe.extra, negative columns),
    # the shape coordinates q_1 .. q_nf (the kernels' own output columns q, flexfmu.reframe.layout), then the
    # gauges: rows on q (reframe.rows, negative columns after the constants; von Mises a zero row the C overwrites)
    n_constant, q_first = 9 + engine.frequencies.size, engine.flexible.start
    gauge_rows = np.ascontiguousarray(engine.shape_rows[nf:], dtype=float)
    first, loads = 0, []
    for moments in engine.moments:
        loads.append([first, 6 if moments else 3])
        first += loads[-1][1]
    limit = engine.limit                         # RK4_STABILITY_LIMIT / omega_max (consistent), else inf

    def entries(inputs, outputs, params):
        if list(inputs) != list(sim.input_names):
            raise ParameterError("reframe", "the FMU's inputs are not the body's", ", ".join(sim.input_names))
        columns = []
        for out in outputs:
            k = sim.output_names.index(out)
            j = k - n_direct
            columns.append(int(engine.columns[k]) if j < 0 else -1 - j if j < n_constant else
                           q_first + j - n_constant if j < n_constant + nf else -1 - (j - nf))
        von_mises = [[outputs.index(d.output), *(outputs.index(n) for n in d.sources)] for d in sim.derived_outputs]
        gauges = {"reframe.rows": gauge_rows,
                  "reframe.von_mises": np.array(von_mises, np.int32).reshape(-1, 7)} if gauge_rows.size else {}
        return {**gauges,
            "reframe.P": np.array(dyn.P, dtype=float), "reframe.LP": np.array(dyn.LP, dtype=float),
            "reframe.PP": np.array(dyn.PP, dtype=float).reshape(dyn.n_if, 3 + 3 * nf),
            "reframe.omega": np.sqrt(np.maximum(dyn.kF, 0.0)), "reframe.Psi": np.ascontiguousarray(dyn.Psi),
            "reframe.order": np.asarray(order, np.int32), "reframe.bc": bc, "reframe.br": br,
            "reframe.sc": sc, "reframe.sr": sr,
            "reframe.int": np.array([nf, 3, int(dyn.deformed), 1, 1, 0], np.int32),
            "reframe.real": np.array([0.0, 1.0, 0.0, dyn.mass], float),     # (arm, J_min, size: ReframeBody's)
            "reframe.columns": np.array(columns, np.int32),
            "reframe.role": np.array([params.index(n) if n in params else -1 for n in _REFRAME_ROLES], np.int32),
            "reframe.fixed": np.array([float(getattr(config, n)) if hasattr(config, n) else 0.0
                                       for n in _REFRAME_ROLES], float),
            "reframe.body": np.array([1, code, dyn.n_if, 0], np.int32),
            "reframe.loads": np.array(loads, np.int32).reshape(dyn.n_if, 2),
            "reframe.limit": np.array([limit], float),
            "reframe.extra": np.asarray(engine.frequencies, float).reshape(-1),
        }

    # the shape file of a body built with its shape data (u = Psi q of the outputs q_k, body frame: flexfmu animate)
    with tempfile.TemporaryDirectory(prefix="flexfmu-shape-") as tmp:
        resources = {path.name: path.read_bytes() for path in shape_resource(body, Path(tmp))}
    page = documentation_html(name, body)
    # the shape file's paragraph (when it has one) and the model's summary
    summary = page[page.index("</p>", page.index("<h1>")) + len("</p>"):page.index("<h2>Variables</h2>")]
    return NativeSource(
        name=name, description=description, spec=spec, values=dataclasses.asdict(config), runtime=runtime, lti=None,
        experiment=default_experiment(body), kind="reframe", kind_entries=entries, messages=list(sim.messages),
        rebuild=f"flexfmu export MODEL -o {name}.fmu ... --runtime native", log_split=True, documentation=summary,
        resources=resources, info={"source": body.summary(), "scheme": scheme})


#: the source of each native model kind an exported body's class names (FlexBody.native_kind)
_BODY_SOURCES = {"lti": _clamped_body_source, "reframe": _free_body_source}


def export_native(body, target, *, description: str | None = None, scheme: str = "exponential",
                  fmi_version: int = 2, interface: str = "cs", arrays: bool = False) -> Path:
    """``flexfmu export ... --runtime native``: the native FMU of a clamped or free body at ``target`` (NAME.fmu);
    ``scheme``: a free body's, fixed at build; ``fmi_version`` 2 or 3 (FMI 3.0 co-simulation)."""
    from flexfmu.fmi.body_fmu import check_target
    name = check_target(target)
    return build_native_fmu(body_source(body, name, description, scheme=scheme), target, fmi_version=fmi_version,
                            interface=interface, arrays=arrays)
