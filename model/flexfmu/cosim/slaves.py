"""The slaves our master steps: an FMU through fmpy (:class:`FmuSlave`) or the flexfmu model the FMU wraps
(:class:`LibrarySlave`), and what each instance offers before one is made (:func:`interface`: inputs, outputs and
the start values it takes, read from the FMU's modelDescription.xml or from the library model).

An FMU that is missing or is no FMU, a start value of an unknown variable or of the wrong type is a ParameterError
that names where the system file declares it (SimulatorSpec.origin, .value_origins).
"""
from __future__ import annotations

import copy
import ctypes
import importlib
import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from flexfmu.cosim.system import SimulatorSpec
from flexfmu.errors import CosimulationError, ParameterError, require
from flexfmu.fmi.registry import FMUS

#: FMU model name -> the flexfmu module it wraps (config class, simulator class, names)
LIBRARY_MODULES = {spec.name: (spec.module, spec.config, spec.simulator) for spec in FMUS}
_PYTHON_TYPES = {bool: "Boolean", int: "Integer", float: "Real", str: "String"}
_BUILD_HINT = "an FMU file (build them with: flexfmu build, or pass --fmu-dir)"
_REPORT = 400


def where(spec: SimulatorSpec) -> str:
    """Where the system file declares the instance, or its name when it was made otherwise."""
    return spec.origin or f"simulator {spec.name}"


def value_where(spec: SimulatorSpec, variable: str) -> str:
    """Where the system file gives the instance's start value of ``variable``, else instance.variable."""
    return spec.value_origins.get(variable) or f"{spec.name}.{variable}"


def model_description(spec: SimulatorSpec):
    """fmpy's ModelDescription of the instance's FMU; a missing file, or one that is no FMU, is a ParameterError
    naming the Simulator element."""
    from fmpy import read_model_description

    source = Path(spec.source)
    require(source.is_file(), where(spec), f"FMU {str(source)!r} not found", _BUILD_HINT)
    allowed = "an FMI 2.0 co-simulation FMU: a zip archive with a valid modelDescription.xml"
    try:
        md = read_model_description(str(source))
    except Exception as exc:   # noqa: BLE001 - fmpy raises zip, XML, KeyError and bare Exceptions alike
        # fmpy's validation report spans lines: one line, at most _REPORT characters of it
        report = " ".join(f"{type(exc).__name__}: {exc}".split())
        report = report if len(report) <= _REPORT else report[:_REPORT] + " ..."
        raise ParameterError(where(spec), f"{str(source)!r} is not an FMU ({report})", allowed) from None
    require(md.fmiVersion == "2.0" and md.coSimulation is not None, where(spec),
            f"{str(source)!r} is an FMI {md.fmiVersion} FMU with "
            f"{'no co-simulation interface' if md.coSimulation is None else 'a co-simulation interface'}", allowed)
    return md


@dataclass(frozen=True)
class Interface:
    """What an instance offers: its inputs and outputs (in the FMU's order) and the start values it takes
    ({name: FMI type: Real, Integer, Boolean, String})."""

    inputs: tuple
    outputs: tuple
    settable: dict


def interface(spec: SimulatorSpec, backend: str = "fmu") -> Interface:
    """The instance's interface: from its FMU's modelDescription.xml (backend "fmu"), or from the library model
    the FMU wraps (backend "library": the model's INPUT_NAMES, OUTPUT_NAMES and config fields)."""
    if backend == "fmu":
        md = model_description(spec)
        variables = md.modelVariables
        return Interface(tuple(v.name for v in variables if v.causality == "input"),
                         tuple(v.name for v in variables if v.causality == "output"),
                         {v.name: ("Integer" if v.type == "Enumeration" else v.type) for v in variables
                          if v.causality in ("parameter", "input") and v.variability != "constant"})
    module, config = _library_model(spec)
    return Interface(tuple(module.INPUT_NAMES), tuple(module.OUTPUT_NAMES),
                     {f.name: _PYTHON_TYPES.get(type(f.default), "Real") for f in fields(config)})


def _library_model(spec: SimulatorSpec):
    require(spec.model in LIBRARY_MODULES, where(spec), f"{Path(spec.source).name}: no library model",
            ", ".join(f"{m}.fmu" for m in LIBRARY_MODULES))
    module_name, config_name, _ = LIBRARY_MODULES[spec.model]
    module = importlib.import_module(module_name)
    return module, getattr(module, config_name)


def start_value(spec: SimulatorSpec, variable: str, kind: str, settable):
    """The instance's start value of ``variable`` as its type ``kind`` (Real, Integer, Boolean, String): a number
    for a Real, an integral number for an Integer, a Boolean (or 0, 1) for a Boolean, text for a String.  An
    unknown variable or a value of another type is a ParameterError naming where the file gives it."""
    value = spec.initial_values[variable]
    at = value_where(spec, variable)
    require(variable in settable, at, f"{spec.name} has no parameter {variable!r}",
            ", ".join(settable) or "none: it takes no start values")
    wrong = f"{value!r} ({type(value).__name__}) is not {'an' if kind == 'Integer' else 'a'} {kind}"
    is_number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == "Real":
        require(is_number and math.isfinite(value), at, wrong, "a finite number")
        return float(value)
    if kind == "Integer":
        require(is_number and math.isfinite(value) and float(value).is_integer(), at, wrong, "an integer")
        return int(value)
    if kind == "Boolean":
        require(isinstance(value, bool) or value in (0, 1), at, wrong, "true | false | 1 | 0")
        return bool(value)
    require(isinstance(value, str), at, wrong, "text")
    return value


class LibrarySlave:
    """A flexfmu façade behaving like the FMU that wraps it (the FlexfmuPlumbing semantics)."""

    def __init__(self, spec: SimulatorSpec):
        self.module, self.config_class = _library_model(spec)
        self.sim_class = getattr(self.module, LIBRARY_MODULES[spec.model][2])
        self.name = spec.name
        self.input_names = tuple(self.module.INPUT_NAMES)
        self.output_names = tuple(self.module.OUTPUT_NAMES)
        defaults = {f.name: f.default for f in fields(self.config_class)}
        kinds = {name: _PYTHON_TYPES.get(type(value), "Real") for name, value in defaults.items()}
        params = dict(defaults)
        for key in spec.initial_values:
            params[key] = start_value(spec, key, kinds.get(key, "Real"), kinds)
        self.config = self.config_class(**params)
        self.values = dict.fromkeys(self.input_names + self.output_names, 0.0)
        self.sim = None

    def initialize(self, start_time: float = 0.0):
        require(start_time == 0.0, "StartTime", f"got {start_time!r}", "0 for the library backend")
        self.sim = self.sim_class(self.config)
        self.sim.set_inputs(**{n: self.values[n] for n in self.input_names})
        self.values.update(self.sim.outputs())

    def set(self, names, values):
        for n, v in zip(names, values):
            self.values[n] = float(v)

    def get(self, names):
        return [self.values[n] for n in names]

    def do_step(self, t: float, h: float):
        self.sim.set_inputs(**{n: self.values[n] for n in self.input_names})
        self.sim.step(h)
        self.values.update(self.sim.outputs())

    def output_jacobian(self, names) -> np.ndarray:
        """D = dy/du: the outputs' (output_names order) derivatives in the inputs ``names`` at the current state and
        the inputs the façade holds (those of its last step), (n_outputs, len(names)); the interface Jacobian of
        flexfmu.cosim.coupling.  The façade's state is not touched; its held inputs are restored."""
        held = {n: self.values[n] for n in self.input_names}
        D = np.empty((len(self.output_names), len(names)))
        try:
            for j, name in enumerate(names):
                # Central differences (y(u + e) - y(u - e)) / 2e have the truncation error e^2/6 d3y/du3 + ...: none
                # for an output that is a polynomial of degree <= 2 in the input, which every output of the wave
                # converter's façades is at fixed state (FFRBeam: affine in F, M, a0 (cross terms eta x F, eta x a0
                # included), degree 2 in omega, alpha through X = [alpha]x + [omega]x^2; Platform: affine; PTO,
                # Hydrostatics: affine, energies and power quadratic).  Then only rounding is left, about
                # u_r |y| / e, smaller the larger e: so e is the input's own size, at least 1 (SI: 1 N, 1 m/s^2,
                # 1 rad/s, well inside every façade's range), not a small step.  An output of higher degree (FFRBeam's
                # elastic_energy with static_correction: degree 4 in omega) gets e^2/6 d3y/du3; no connection
                # reads it, and its recorded value uses D only times the inputs' change over one step.
                e = max(1.0, abs(held[name]))
                plus, minus = (self._outputs_with(name, held[name] + s) for s in (e, -e))
                D[:, j] = (plus - minus) / (2.0 * e)
                self.sim.set_inputs(**{name: held[name]})
        finally:
            self.sim.set_inputs(**held)
        return D

    # the step-Jacobian scheme's rollback (flexfmu.cosim.coupling.InterfaceCoupling.step)
    def snapshot(self):
        return copy.deepcopy(self.sim.get_state()), dict(self.values)

    def restore(self, snapshot):
        state, values = snapshot
        self.sim.set_state(copy.deepcopy(state))
        self.values = dict(values)

    def discard(self, snapshot):
        pass

    def _outputs_with(self, name: str, value: float) -> np.ndarray:
        """The outputs with the input ``name`` at ``value`` (the others as they are)."""
        self.sim.set_inputs(**{name: value})
        out = self.sim.outputs()
        return np.array([out[n] for n in self.output_names], float)

    def free(self):
        pass


class FmuSlave:
    """An FMU instance through fmpy's FMU2Slave; FMI errors raise CosimulationError with the FMU's log."""

    _extracted: dict = {}

    def __init__(self, spec: SimulatorSpec):
        from fmpy import extract
        from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

        md = model_description(spec)
        key = str(Path(spec.source).resolve())
        if key not in FmuSlave._extracted:
            FmuSlave._extracted[key] = extract(key)
        self.name = spec.name
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.types = {v.name: ("Integer" if v.type == "Enumeration" else v.type) for v in md.modelVariables}
        causality = {v.name: v.causality for v in md.modelVariables}
        self.input_names = tuple(n for n, c in causality.items() if c == "input")
        self.output_names = tuple(n for n, c in causality.items() if c == "output")
        self.settable = {v.name for v in md.modelVariables
                         if v.causality in ("parameter", "input") and v.variability != "constant"}
        self.provides_directional_derivative = bool(getattr(md.coSimulation, "providesDirectionalDerivative", False))
        self.log: list[str] = []

        def logger(component, instance_name, status, category, message):
            self.log.append((message or b"").decode())

        self._logger = fmi2CallbackLoggerTYPE(logger)
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = self._logger
        callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
        callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=FmuSlave._extracted[key],
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=spec.name)
        self._call("fmi2Instantiate", self.fmu.instantiate, callbacks=callbacks, loggingOn=True)
        self._spec = spec
        self._vr_cache: dict = {}

    def _call(self, what, fn, *args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except Exception as exc:
            message = self.log[-1] if self.log else str(exc)
            raise CosimulationError(f"{self.name}: {what} failed: {message}") from None

    def initialize(self, start_time: float = 0.0):
        self._call("setupExperiment", self.fmu.setupExperiment, startTime=start_time)
        self._call("enterInitializationMode", self.fmu.enterInitializationMode)
        setters = {"Real": self.fmu.setReal, "Integer": self.fmu.setInteger, "Boolean": self.fmu.setBoolean,
                   "String": self.fmu.setString}
        for name in self._spec.initial_values:
            value = start_value(self._spec, name, self.types.get(name, "Real"), self.settable)
            self._call(f"setting {name}", setters[self.types[name]], [self.vr[name]], [value])
        self._call("exitInitializationMode", self.fmu.exitInitializationMode)

    def _vrs(self, names):
        key = tuple(names)
        hit = self._vr_cache.get(key)
        if hit is None:
            hit = self._vr_cache[key] = [self.vr[n] for n in names]
        return hit

    def set(self, names, values):
        if names:
            self.fmu.setReal(self._vrs(names), [float(v) for v in values])

    def get(self, names):
        return self.fmu.getReal(self._vrs(names)) if names else []

    def do_step(self, t: float, h: float):
        self._call(f"doStep at t = {t:.9g} s", self.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)

    def output_jacobian(self, names) -> np.ndarray:
        """D = dy/du: the outputs' (output_names order) derivatives in the inputs ``names``, (n_outputs, len(names)),
        from fmi2GetDirectionalDerivative at the current state and the inputs as last set (after a step: those it
        held; flexfmu_native.c gives the output function's derivatives there, in co-simulation too).  An FMU that
        does not provide directional derivatives is a ParameterError naming the instance."""
        require(self.provides_directional_derivative, where(self._spec),
                f"{self.name}: its FMU {Path(self._spec.source).name} provides no directional derivatives "
                "(providesDirectionalDerivative is not true in its modelDescription.xml)",
                "an FMU that provides them; or --master library, or --scheme gauss-seidel | jacobi")
        unknown = self._vrs(self.output_names)
        D = np.empty((len(unknown), len(names)))
        for j, vr in enumerate(self._vrs(names)):
            D[:, j] = self._call("fmi2GetDirectionalDerivative", self.fmu.getDirectionalDerivative, unknown, [vr],
                                 [1.0])
        return D

    # the step-Jacobian scheme's rollback (flexfmu.cosim.coupling.InterfaceCoupling.step): FMU states
    def snapshot(self):
        return self._call("fmi2GetFMUstate", self.fmu.getFMUstate)

    def restore(self, snapshot):
        self._call("fmi2SetFMUstate", self.fmu.setFMUstate, snapshot)

    def discard(self, snapshot):
        self._call("fmi2FreeFMUstate", self.fmu.freeFMUstate, snapshot)

    def free(self):
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()
