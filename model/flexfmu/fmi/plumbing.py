"""The FMI behaviour of one flexfmu FMU instance, as the FMU's binary (flexfmu/fmi/csrc) calls it.

The binary owns the call sequence (its table in csrc/flexfmu_fmi2.c, printed in docs/fmu.md) and the
FMU-state header; this class owns the variables: value references, types, causality, finiteness, the
simulator's life cycle, time, and the FMU state's content.  A refused call raises :class:`FmiStatus`
(its status and one message, which the binary logs); the instance is left as it was.  Messages the
simulator wants logged with status OK go to ``messages``, a list of (status, category, text) that the
binary drains after every call.

Per-step cost (what a master pays on top of the simulator's own step): inputs and outputs live in
plain lists indexed by position; setting an input to the value it has changes nothing, and the
simulator gets its inputs (``set_input_vector``, else ``set_inputs``) only after a change — every
simulator holds its inputs until they are set again.  Outputs are computed when first read after a
step, not in doStep: a master that reads a few outputs, or reads less often than it steps, does not pay
for the rest.  The values are those of the state and the inputs the step held, exactly what an eager
computation after the step gives.  A module's DEFERRED_OUTPUTS (costly, e.g. a search over the mesh) are
computed only when one of them is read.  Levels of ``_outputs_valid``: 0 none, 1 all but the deferred, 2 all.
"""
from __future__ import annotations

import json
import math
import sys
from dataclasses import asdict, fields
from typing import Protocol, runtime_checkable

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Variability, Integer, Real, String

from flexfmu.errors import FlexfmuError, StepRejected

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
#: currentCommunicationPoint must equal the FMU's clock within CLOCK_EPS units of roundoff of the time (eps |t|):
#: the clock is the host's own (currentCommunicationPoint + communicationStepSize of the last step), so what differs
#: is the rounding of one step (the host's t(k) + h against its t(k+1): a few ulps), never a sum over the run; a
#: skipped or repeated step differs by a whole step and is refused, at any start time.
CLOCK_EPS = 16.0
EPS = sys.float_info.epsilon
#: format of the FMU state's content (the binary adds its own header with the GUID)
STATE_FORMAT = 2
_KIND = {str: String, int: Integer, float: Real, bool: Boolean}
_TYPE_NAME = {Real: "Real", Integer: "Integer", Boolean: "Boolean", String: "String"}


class Simulator(Protocol):
    """What an FMU wraps (flexfmu.fmi.registry): built from its config dataclass (the parameters)."""

    time: float                         # s since the start

    def set_inputs(self, **inputs: float) -> None: ...    # held until set again; checked, naming each input
    def step(self, step_size: float) -> None: ...
    def outputs(self) -> dict[str, float]: ...
    def get_state(self) -> dict: ...                      # plain data (JSON), with the config
    def set_state(self, data: dict) -> None: ...
    # optional: ``messages``, a list of texts the FMU logs with status OK and clears


@runtime_checkable
class VectorSimulator(Simulator, Protocol):
    """A simulator with the cheaper positional paths, which the plumbing uses when present."""

    def set_input_vector(self, values: list) -> None: ...   # INPUT_NAMES order
    def output_vector(self, include_deferred: bool = True): ...   # OUTPUT_NAMES order (numpy array)


class FmiStatus(Exception):
    """A call that returns ``fmi_status`` (fmi2Error, or fmi2Discard for a step a smaller one may
    take) with its text as the one logged message."""

    def __init__(self, message: str, fmi_status: int = ERROR):
        super().__init__(message)
        self.fmi_status = fmi_status


class Plumbing:
    """One instance of the FMU ``spec`` (flexfmu.fmi.registry.FmuSpec, or an exported body's spec), which
    gives input_names, output_names, variable_info {name: (unit, description)}, deferred_outputs,
    config_class and make_simulator(config);
    the simulator is built from a config (the parameters) and has set_inputs(**) (or
    set_input_vector/output_vector), step(h), outputs(), get_state()/set_state(dict), time and optionally
    a ``messages`` list."""

    def __init__(self, slave, spec):
        self.slave = slave
        self.config_class = config_class = spec.config_class
        self.make_simulator = spec.make_simulator
        self.input_names = spec.input_names
        self.output_names = spec.output_names
        self.variable_info = spec.variable_info
        self.messages: list[tuple[int, str, str]] = []
        self._defaults = asdict(config_class())
        deferred = spec.deferred_outputs
        self._deferred_index = [self.output_names.index(name) for name in deferred]
        self._clear()
        for field in fields(config_class):
            kind = _KIND[type(self._defaults[field.name])]
            slave.register_variable(kind(field.name, causality=Fmi2Causality.parameter,
                                         variability=Fmi2Variability.fixed,
                                         description=self.variable_info[field.name][1],
                                         getter=self._parameter_getter(field.name),
                                         setter=self._parameter_setter(field.name)))
        for i, name in enumerate(self.input_names):
            slave.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                         description=self.variable_info[name][1],
                                         getter=self._input_getter(i), setter=self._input_setter(i)))
        for i, name in enumerate(self.output_names):
            slave.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                         initial=Fmi2Initial.exact, description=self.variable_info[name][1],
                                         getter=self._output_getter(i)))
        self._variables = dict(slave.vars)                    # value reference -> pythonfmu variable
        self._getters = {kind: {vr: v.getter for vr, v in self._variables.items() if type(v) is kind}
                         for kind in _TYPE_NAME}
        self._all_setters = {kind: {vr: v.setter for vr, v in self._variables.items()
                                    if type(v) is kind and v.causality != Fmi2Causality.output}
                             for kind in _TYPE_NAME}
        self._update_settable()

    def _update_settable(self):
        """What fmi2SetX may set now: inputs and parameters before initialisation, inputs after."""
        if self._sim is None:
            self._setters = self._all_setters
        else:
            self._setters = {kind: {vr: f for vr, f in setters.items()
                                    if self._variables[vr].causality != Fmi2Causality.parameter}
                             for kind, setters in self._all_setters.items()}

    def _clear(self):
        """The state after fmi2Instantiate / fmi2Reset."""
        self._values = dict(self._defaults)                   # the parameters
        self._inputs = getattr(self, "_inputs", [])
        self._inputs[:] = [0.0] * len(self.input_names)      # in place: the input setters hold this list
        self._inputs_changed = True                           # not yet given to the simulator
        self._outputs = [0.0] * len(self.output_names)        # OUTPUT_NAMES order, of the last step
        self._outputs_valid = 0
        self._sim = None
        self._vector_api = False
        self._start_time = 0.0
        self._clock = 0.0                                     # the host's time of the next step's start
        if hasattr(self, "_all_setters"):
            self._update_settable()

    # ---- variable access
    def _parameter_getter(self, name):
        return lambda: self._values[name]

    def _parameter_setter(self, name):
        def set_parameter(value):
            if self._sim is not None:
                raise FmiStatus(f"{name}: a fixed parameter can be set only before fmi2ExitInitializationMode")
            self._values[name] = value
        return set_parameter

    def _input_getter(self, i):
        return lambda: self._inputs[i]

    def _input_setter(self, i):
        inputs = self._inputs

        def set_input(value):
            if value != inputs[i]:
                inputs[i] = value
                self._inputs_changed = True
        return set_input

    def _output_getter(self, i):
        level = 2 if i in self._deferred_index else 1         # the validity level this output needs

        def get_output():
            if self._outputs_valid < level:
                self._read_outputs(level)
            return self._outputs[i]
        return get_output

    def _refuse_references(self, function: str, kind, vrs, setting: bool):
        """Raise the FmiStatus that names the first value reference ``function`` cannot take."""
        for vr in vrs:
            variable = self._variables.get(vr)
            if variable is None:
                raise FmiStatus(f"{function}: unknown value reference {vr} (this FMU has 0 .. {len(self._variables) - 1})")
            if type(variable) is not kind:
                wanted = _TYPE_NAME[type(variable)]
                raise FmiStatus(f"{function}: value reference {vr} is {variable.name!r}, a {wanted} variable; "
                                f"use fmi2{'Set' if setting else 'Get'}{wanted}")
            if setting and variable.causality == Fmi2Causality.output:
                raise FmiStatus(f"{function}: {variable.name!r} is an output; outputs cannot be set")
            if setting and variable.causality == Fmi2Causality.parameter and self._sim is not None:
                raise FmiStatus(f"{function}: {variable.name}: a fixed parameter can be set only before "
                                f"fmi2ExitInitializationMode")
        raise FmiStatus(f"{function}: bad value references {list(vrs)!r}")

    def _get(self, kind, function, vrs):
        getters = self._getters[kind]
        try:
            return [getters[vr]() for vr in vrs]
        except KeyError:
            self._refuse_references(function, kind, vrs, setting=False)

    def _set(self, kind, function, vrs, values, check):
        setters = self._setters[kind]
        try:
            chosen = [setters[vr] for vr in vrs]
        except KeyError:
            self._refuse_references(function, kind, vrs, setting=True)
        if not all(map(check, values)):                       # all checked before any is set
            vr, value = next((vr, v) for vr, v in zip(vrs, values) if not check(v))
            raise FmiStatus(f"{function}: {self._variables[vr].name}: got {value!r} (allowed: {_ALLOWED[kind]})")
        for setter, value in zip(chosen, values):
            setter(value)

    def get_real(self, vrs):
        return self._get(Real, "fmi2GetReal", vrs)

    def get_integer(self, vrs):
        return self._get(Integer, "fmi2GetInteger", vrs)

    def get_boolean(self, vrs):
        return self._get(Boolean, "fmi2GetBoolean", vrs)

    def get_string(self, vrs):
        return self._get(String, "fmi2GetString", vrs)

    def set_real(self, vrs, values):
        self._set(Real, "fmi2SetReal", vrs, values, math.isfinite)

    def set_integer(self, vrs, values):
        self._set(Integer, "fmi2SetInteger", vrs, values, lambda v: True)

    def set_boolean(self, vrs, values):
        self._set(Boolean, "fmi2SetBoolean", vrs, [bool(v) for v in values], lambda v: True)

    def set_string(self, vrs, values):
        self._set(String, "fmi2SetString", vrs, values, lambda v: isinstance(v, str))

    # ---- the simulator
    def _give_inputs(self):
        """Hand the inputs to the simulator (after a change only: see the module docstring)."""
        if self._vector_api:
            self._sim.set_input_vector(list(self._inputs))     # a copy: the setters change the list in place
        else:
            self._sim.set_inputs(**dict(zip(self.input_names, self._inputs)))
        self._inputs_changed = False

    def _read_outputs(self, level: int = 2):
        """Compute the outputs of the current state up to validity ``level`` (1: all but the deferred)."""
        sim = self._sim
        if sim is None:                       # before initialisation: the start values
            return
        try:
            if not self._vector_api:
                values = sim.outputs()
                outputs = [float(values[name]) for name in self.output_names]
            elif not self._deferred_index:
                outputs = sim.output_vector().tolist()
            elif self._outputs_valid == 1:    # only the deferred ones are missing
                outputs = list(self._outputs)
                for i, value in zip(self._deferred_index, sim.deferred_output_vector()):
                    outputs[i] = float(value)
            else:
                outputs = sim.output_vector(include_deferred=level == 2).tolist()
        except (FlexfmuError, ArithmeticError) as exc:
            raise FmiStatus(f"outputs: {exc}") from None
        if not all(map(math.isfinite, outputs)):
            wanted = range(len(outputs)) if level == 2 or not self._deferred_index else \
                [i for i in range(len(outputs)) if i not in self._deferred_index]
            bad = [self.output_names[i] for i in wanted if not math.isfinite(outputs[i])]
            if bad:
                raise FmiStatus(f"{', '.join(bad)}: not finite at t = {self._start_time + sim.time!r} s "
                                f"(the inputs or parameters drive the model beyond its range)")
        self._outputs = outputs
        self._outputs_valid = 2 if (level == 2 or not self._deferred_index) else 1

    def _config(self):
        return self.config_class(**{f.name: self._values[f.name] for f in fields(self.config_class)})

    def _build(self, values: dict):
        """A simulator of the parameters ``values``, its inputs given, or FmiStatus naming what is wrong."""
        for name, value in values.items():
            if isinstance(value, float) and not math.isfinite(value):
                raise FmiStatus(f"{name}: got {value!r} (allowed: a finite number)")
        try:
            sim = self.make_simulator(self.config_class(**values))
            sim.set_inputs(**dict(zip(self.input_names, self._inputs)))     # checked, naming each input
        except (FlexfmuError, ArithmeticError, RecursionError) as exc:
            raise FmiStatus(str(exc) if isinstance(exc, FlexfmuError) else
                            f"the parameters drive the model beyond its range ({type(exc).__name__}: {exc})") from None
        return sim

    def _log_messages(self):
        """Log (status OK) and clear what the simulator chose and why (its ``messages`` list, if any)."""
        messages = getattr(self._sim, "messages", None)
        while messages:
            self.messages.append((OK, "logAll", messages.pop(0)))

    # ---- FMI calls (the binary has checked the call sequence and the arguments' finiteness)
    def setup_experiment(self, start_time, stop_time, tolerance):
        self._start_time = self._clock = float(start_time)

    def enter_initialization_mode(self):
        pass

    def exit_initialization_mode(self):
        sim = self._build(dict(self._values))
        self._sim = sim
        self._update_settable()
        self._vector_api = isinstance(sim, VectorSimulator)
        self._inputs_changed = False
        self._log_messages()
        self._outputs_valid = 0
        self._read_outputs()             # every output once: a problem shows here rather than at a later read

    def do_step(self, current_time, step_size):
        sim = self._sim
        now = self._clock
        if abs(current_time - now) > CLOCK_EPS * EPS * max(abs(current_time), abs(now)):
            raise FmiStatus(f"currentCommunicationPoint: got {current_time!r} s, expected the FMU's time "
                            f"{now!r} s (roll back with fmi2SetFMUstate to step from another time)")
        try:
            if self._inputs_changed:
                self._give_inputs()
            self._outputs_valid = 0           # from here on the outputs are those of another state
            sim.step(step_size)
            self._clock = current_time + step_size    # the host's next communication point, as the host adds it
        except StepRejected as exc:
            raise FmiStatus(str(exc), DISCARD) from None
        except (FlexfmuError, ArithmeticError) as exc:
            raise FmiStatus(str(exc) if isinstance(exc, FlexfmuError) else
                            f"the step overflowed ({type(exc).__name__}: {exc})") from None
        finally:
            if getattr(sim, "messages", None):
                self._log_messages()

    def last_successful_time(self):
        return self._clock

    def terminate(self):
        pass

    def reset(self):
        self._clear()

    def free(self):
        self._sim = None

    # ---- FMU state: everything an instance holds, so that a restore needs no other call
    def get_fmu_state(self):
        if self._sim is not None and self._outputs_valid < 2:
            self._read_outputs()
        return {"format": STATE_FORMAT, "model": type(self.slave).__name__, "values": dict(self._values),
                "inputs": list(self._inputs), "outputs": list(self._outputs), "start_time": self._start_time, "clock": self._clock,
                "sim": None if self._sim is None else self._sim.get_state()}

    def set_fmu_state(self, state):
        if self._sim is not None and state["sim"] is not None and state["values"] == self._values:
            sim = self._sim
        elif state["sim"] is not None:       # another configuration, or not initialised: build its simulator
            sim = self._build(dict(state["values"]))
        else:
            sim = None
        if sim is not None:
            try:
                sim.set_state(state["sim"])
            except (FlexfmuError, KeyError, TypeError, ValueError) as exc:
                raise FmiStatus(f"fmi2SetFMUstate: the state does not fit this FMU ({type(exc).__name__}: {exc})") \
                    from None
        self._values = dict(state["values"])
        self._inputs[:] = state["inputs"]          # in place: the input setters hold this list
        self._outputs = list(state["outputs"])
        self._start_time = state["start_time"]
        self._clock = state["clock"]
        self._sim = sim
        self._update_settable()
        self._vector_api = isinstance(sim, VectorSimulator)
        self._outputs_valid = 2 if sim is not None else 0
        self._inputs_changed = True                # the simulator's inputs are those of the state's last step

    def serialize_fmu_state(self, state) -> bytes:
        return json.dumps(state, allow_nan=False).encode()

    def deserialize_fmu_state(self, data: bytes):
        try:
            state = json.loads(data.decode("utf-8"))
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:
            raise FmiStatus(f"fmi2DeSerializeFMUstate: the bytes are not a state of this FMU (truncated or damaged: "
                            f"{type(exc).__name__})") from None
        self._check_state(state)
        return state

    def _check_state(self, state):
        """The structure of a deserialised state, before anything of it is used."""
        def bad(why):
            raise FmiStatus(f"fmi2DeSerializeFMUstate: the bytes are not a state of this FMU ({why})")
        if not isinstance(state, dict) or state.get("format") != STATE_FORMAT:
            bad("unknown format")
        if state.get("model") != type(self.slave).__name__:
            bad(f"a state of {state.get('model')!r}")
        values = state.get("values")
        if not isinstance(values, dict) or set(values) != set(self._defaults):
            bad("its parameters are not this FMU's")
        for name, default in self._defaults.items():
            if type(values[name]) is not type(default) and not (isinstance(default, float)
                                                                and type(values[name]) is int):
                bad(f"parameter {name} has the wrong type")
            values[name] = type(default)(values[name])
        for key, size in (("inputs", len(self.input_names)), ("outputs", len(self.output_names))):
            column = state.get(key)
            if not (isinstance(column, list) and len(column) == size
                    and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                            for v in column)):
                bad(f"{key} are not {size} finite numbers")
        for key in ("start_time", "clock"):
            if not isinstance(state.get(key), (int, float)) or isinstance(state[key], bool) \
                    or not math.isfinite(state[key]):
                bad(f"{key} is not a finite number")
        if state.get("sim") is not None and not isinstance(state["sim"], dict):
            bad("simulator state")
        if isinstance(state.get("sim"), dict) and "time" in state["sim"]:
            t = state["sim"]["time"]
            if not isinstance(t, (int, float)) or isinstance(t, bool) or not math.isfinite(t):
                bad("the simulator's time is not a finite number")


_ALLOWED = {Real: "a finite number", Integer: "an integer", Boolean: "a boolean", String: "a UTF-8 string"}
