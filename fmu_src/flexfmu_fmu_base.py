"""The FMI plumbing shared by the flexfmu FMUs (pythonfmu).  Each FMU's slave class derives directly
from Fmi2Slave and hands its calls to a FlexfmuPlumbing, which registers the variables from the
simulator's config dataclass and name lists and maps FMI calls onto the simulator; the numerics stay
in flexfmu.

Composition, not a shared base class: pythonfmu's binary finds the slave class by the text
``class X(Fmi2Slave):`` in the script, and a slave deriving from another class crashes the second
fmi2Instantiate in a process.  Bundled into every FMU next to its slave script; the module name is
unique to this project because all FMUs in one host share one Python interpreter.
"""
from dataclasses import asdict, fields

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real, String  # noqa: F401
from pythonfmu.enums import Fmi2Status

from flexfmu.errors import FlexfmuError

# Relative tolerance on currentCommunicationPoint against the FMU's own time.
TIME_RTOL = 1e-9
_KIND = {str: String, int: Integer, float: Real, bool: Boolean}


class FlexfmuPlumbing:
    """FMI behaviour of one slave.  ``module`` provides the config class, the simulator class (built
    from a config; set_inputs(**), step(h), outputs() -> dict, get_state()/set_state(dict), time),
    INPUT_NAMES, OUTPUT_NAMES and VARIABLE_INFO {name: (unit, description)}."""

    def __init__(self, slave: Fmi2Slave, config_class, simulator_class, module):
        self.slave = slave
        self.config_class = config_class
        self.simulator_class = simulator_class
        self.input_names = module.INPUT_NAMES
        self.output_names = module.OUTPUT_NAMES
        self.variable_info = module.VARIABLE_INFO
        self._sim = None
        self._vector_api = False
        defaults = asdict(self.config_class())
        self._values = dict(defaults)
        self._values.update(dict.fromkeys(self.input_names, 0.0))
        self._values.update(dict.fromkeys(self.output_names, 0.0))
        for field in fields(self.config_class):
            kind = _KIND[type(defaults[field.name])]
            self.slave.register_variable(kind(field.name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.fixed,
                                        description=self.variable_info[field.name][1],
                                        getter=self._getter(field.name), setter=self._parameter_setter(field.name)))
        for name in self.input_names:
            self.slave.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        description=self.variable_info[name][1],
                                        getter=self._getter(name), setter=self._input_setter(name)))
        for name in self.output_names:
            self.slave.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                        initial=Fmi2Initial.exact, description=self.variable_info[name][1],
                                        getter=self._getter(name)))

    # ---- variable access
    def _getter(self, name):
        return lambda: self._values[name]

    def _parameter_setter(self, name):
        def set_parameter(value):
            if self._sim is not None:
                self._fail(f"{name}: a fixed parameter cannot be set after initialisation")
            self._values[name] = value
        return set_parameter

    def _input_setter(self, name):
        def set_input(value):
            self._values[name] = value
        return set_input

    def _fail(self, message: str):
        """Log with fmi2Error status (naming the variable), then fail the call."""
        self.slave.log(message, Fmi2Status.error)
        raise RuntimeError(message)

    # ---- FMI calls
    def exit_initialization_mode(self):
        config = self.config_class(**{f.name: self._values[f.name] for f in fields(self.config_class)})
        try:
            self._sim = self.simulator_class(config)
            self._vector_api = hasattr(self._sim, "set_input_vector") and hasattr(self._sim, "output_vector")
            self._sim.set_inputs(**{name: self._values[name] for name in self.input_names})
        except FlexfmuError as exc:
            self._fail(str(exc))
        self._log_messages()
        self._values.update(self._sim.outputs())

    def _log_messages(self):
        """Log (status OK) and clear what the simulator chose and why (its ``messages`` list, if any):
        automatic model size, RK4 sub-stepping."""
        messages = getattr(self._sim, "messages", None)
        while messages:
            self.slave.log(messages.pop(0), Fmi2Status.ok)

    def do_step(self, current_time, step_size):
        sim = self._sim
        if abs(current_time - sim.time) > TIME_RTOL * max(1.0, abs(sim.time)):
            self._fail(f"currentCommunicationPoint: got {current_time!r} s, expected the FMU's time "
                       f"{sim.time!r} s (roll back with setFMUstate to step from another time)")
        values = self._values
        try:
            if self._vector_api:     # per-call overhead: inputs and outputs as vectors, no dicts of checks
                sim.set_input_vector([values[name] for name in self.input_names])
                sim.step(step_size)
                values.update(zip(self.output_names, sim.output_vector().tolist()))
            else:
                sim.set_inputs(**{name: values[name] for name in self.input_names})
                sim.step(step_size)
                values.update(sim.outputs())
        except FlexfmuError as exc:
            self._fail(str(exc))
        if getattr(sim, "messages", None):
            self._log_messages()
        return True

    # ---- whole-state get/set/serialize (registered variables alone would miss the internal state)
    def get_fmu_state(self):
        return {"values": dict(self._values), "sim": None if self._sim is None else self._sim.get_state()}

    def set_fmu_state(self, state):
        self._values = dict(state["values"])
        if state["sim"] is not None:
            if self._sim is None:
                self._sim = self.simulator_class(self.config_class(**state["sim"]["config"]))
                self._vector_api = hasattr(self._sim, "set_input_vector") and hasattr(self._sim, "output_vector")
            self._sim.set_state(state["sim"])
