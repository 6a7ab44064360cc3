"""The Python kind of the one FMU runtime: a Python simulator behind a narrow bridge, vectors in and vectors out.

A Python FMU's binary is the runtime of the native FMUs (csrc/flexfmu_native.c: the call sequence, value
references, types, range checks, time and the clock, the FMU state and its layout, and the messages) over the
Python kind (csrc/native_python.c), which calls this module:

* :class:`PythonModel` (one per extraction, made by resources/flexfmu_loader.py from the FMU's spec):
  ``make(parameters)`` builds an instance from the runtime parameters in the model file's order (the config
  dataclass's fields); ``check_state(bytes)`` refuses bytes that are not a simulator state of this model;
* :class:`PythonInstance`: ``give_inputs(inputs)`` (INPUT_NAMES order; the runtime gives them only when they
  changed: every simulator holds its inputs until they are given again), ``step(h)``, ``outputs(level)``
  (OUTPUT_NAMES order, computed when the runtime needs them: a host that reads a few outputs does not pay for
  the rest; ``level`` 1 all but the module's DEFERRED_OUTPUTS, 2 all, 3 the deferred ones only), ``save()`` and
  ``restore(bytes)`` (the simulator's state as JSON), and ``messages``, the status-OK texts the runtime logs and
  clears after every call.

A refused call raises :class:`FmiStatus` (its status and one message, which the runtime logs); the instance is
left as it was.
"""
from __future__ import annotations

import json
import math
from dataclasses import fields
from typing import Protocol, runtime_checkable

from flexfmu.errors import FlexfmuError, StepRejected

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
#: format of the simulator's part of an FMU state (the runtime's layout holds the variables and the time)
STATE_FORMAT = 3
#: PythonInstance.outputs levels
PLAIN, ALL, DEFERRED_ONLY = 1, 2, 3


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
    """A simulator with the cheaper positional paths, which the instance uses when present."""

    def set_input_vector(self, values: list) -> None: ...   # INPUT_NAMES order
    def output_vector(self, include_deferred: bool = True): ...   # OUTPUT_NAMES order (numpy array)


class FmiStatus(Exception):
    """A call that returns ``fmi_status`` (fmi2Error, or fmi2Discard for a step a smaller one may
    take) with its text as the one logged message."""

    def __init__(self, message: str, fmi_status: int = ERROR):
        super().__init__(message)
        self.fmi_status = fmi_status


def _refused(exc: BaseException, what: str) -> FmiStatus:
    """The FmiStatus of a simulator's exception: its own message for flexfmu's errors, else what overflowed."""
    if isinstance(exc, StepRejected):
        return FmiStatus(str(exc), DISCARD)
    if isinstance(exc, FlexfmuError):
        return FmiStatus(str(exc))
    return FmiStatus(f"{what} ({type(exc).__name__}: {exc})")


_SIMULATOR_ERRORS = (FlexfmuError, ArithmeticError, RecursionError)


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"a number that is not finite ({text})")
    return value


def _no_constant(name: str):
    raise ValueError(f"a number that is not finite ({name})")


class PythonModel:
    """The model of one FMU spec (flexfmu.fmi.slave.FmuModel: a registry entry or an exported body)."""

    def __init__(self, spec):
        self.spec = spec
        self.name = spec.name
        self.config_class = spec.config_class
        self.input_names = tuple(spec.input_names)
        self.output_names = tuple(spec.output_names)
        self.parameter_fields = [(f.name, type(getattr(self.config_class(), f.name)))
                                 for f in fields(self.config_class)]
        #: the deferred outputs' positions, in the order the simulator's deferred_output_vector gives them
        self.deferred = [self.output_names.index(name) for name in spec.deferred_outputs]

    def make(self, values: list) -> PythonInstance:
        """An instance for the runtime parameters ``values`` (the runtime has checked that numbers are finite)."""
        config = {name: kind(value) for (name, kind), value in zip(self.parameter_fields, values)}
        try:
            sim = self.spec.make_simulator(self.config_class(**config))
        except _SIMULATOR_ERRORS as exc:
            raise _refused(exc, "the parameters drive the model beyond its range") from None
        return PythonInstance(self, sim)

    def check_state(self, data: bytes) -> None:
        """Refuse bytes that are not a simulator state of this model, before any instance sees them."""
        self._parse_state(data)

    def _parse_state(self, data: bytes) -> dict:
        try:
            state = json.loads(data.decode("utf-8"), parse_float=_finite_float, parse_constant=_no_constant)
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:
            raise FmiStatus(f"the simulator's state is damaged ({type(exc).__name__}: {exc})") from None
        if not isinstance(state, dict) or state.get("format") != STATE_FORMAT:
            raise FmiStatus("the simulator's state has an unknown format")
        if state.get("model") != self.name:
            raise FmiStatus(f"a simulator state of {state.get('model')!r}, not of {self.name!r}")
        if not isinstance(state.get("sim"), dict):
            raise FmiStatus("the simulator's state is not a mapping")
        return state


class PythonInstance:
    """One simulator of a :class:`PythonModel`."""

    def __init__(self, model: PythonModel, sim):
        self.model = model
        self.sim = sim
        self.messages: list[str] = []
        self._vector = isinstance(sim, VectorSimulator)
        self._collect_messages()

    def _collect_messages(self):
        """Move what the simulator chose and why (its ``messages`` list, if any) to the runtime's log."""
        messages = getattr(self.sim, "messages", None)
        while messages:
            self.messages.append(str(messages.pop(0)))

    def give_inputs(self, values: list) -> None:
        try:
            if self._vector:
                self.sim.set_input_vector(values)
            else:
                self.sim.set_inputs(**dict(zip(self.model.input_names, values)))
        except _SIMULATOR_ERRORS as exc:
            raise _refused(exc, "the inputs drive the model beyond its range") from None

    def step(self, step_size: float) -> None:
        try:
            self.sim.step(step_size)
        except _SIMULATOR_ERRORS as exc:
            raise _refused(exc, "the step overflowed") from None
        finally:
            self._collect_messages()

    def outputs(self, level: int) -> list:
        sim = self.sim
        try:
            if not self._vector:
                values = sim.outputs()
                return [float(values[name]) for name in self.model.output_names]
            if level == DEFERRED_ONLY and hasattr(sim, "deferred_output_vector"):
                values = [math.nan] * len(self.model.output_names)
                for i, value in zip(self.model.deferred, sim.deferred_output_vector()):
                    values[i] = float(value)
                return values
            if not self.model.deferred:
                return sim.output_vector().tolist()
            return sim.output_vector(include_deferred=level != PLAIN).tolist()
        except _SIMULATOR_ERRORS as exc:
            raise _refused(exc, "the outputs overflowed") from None

    def save(self) -> bytes:
        try:
            return json.dumps({"format": STATE_FORMAT, "model": self.model.name, "sim": self.sim.get_state()},
                              allow_nan=False).encode()
        except ValueError:
            raise FmiStatus("the simulator's state is not finite: it cannot be saved") from None

    def restore(self, data: bytes) -> None:
        state = self.model._parse_state(data)
        try:
            self.sim.set_state(state["sim"])
        except (FlexfmuError, KeyError, TypeError, ValueError, IndexError) as exc:
            raise FmiStatus(f"the state does not fit this FMU ({type(exc).__name__}: {exc})") from None
