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
    INPUT_NAMES, OUTPUT_NAMES and VARIABLE_INFO {name: (unit, description)}.

    Per-step cost (what a master pays per doStep on top of the simulator's own step): inputs and outputs
    live in plain lists indexed by position; an input setter only marks the inputs changed when the value
    differs, so the simulator gets its inputs (set_input_vector, else set_inputs) only after a change —
    every simulator holds its inputs until they are set again, and setting equal values changes nothing;
    fmi2GetReal / fmi2SetReal go straight to the variables' getters and setters (pythonfmu's own versions
    check each variable's type on every call; they still handle what is not a Real, for its error).

    Outputs are computed when first read after a step, not in doStep: a master that reads a few outputs,
    or reads them less often than it steps, does not pay for the rest.  The values are those of the state
    and the inputs the step held (new inputs reach the simulator only in the next doStep), exactly what an
    eager computation after the step gives.  A module's DEFERRED_OUTPUTS (costly outputs, e.g. a search
    over the mesh) are computed only when one of them is read (``output_vector(include_deferred=False)``,
    ``deferred_output_vector()``).  Levels of ``_outputs_valid``: 0 none, 1 all but the deferred, 2 all."""

    def __init__(self, slave: Fmi2Slave, config_class, simulator_class, module):
        self.slave = slave
        self.config_class = config_class
        self.simulator_class = simulator_class
        self.input_names = module.INPUT_NAMES
        self.output_names = module.OUTPUT_NAMES
        self.variable_info = module.VARIABLE_INFO
        self._sim = None
        self._vector_api = False
        self._values = asdict(self.config_class())          # the parameters
        self._inputs = [0.0] * len(self.input_names)         # INPUT_NAMES order
        self._inputs_changed = True                          # not yet given to the simulator
        self._outputs = [0.0] * len(self.output_names)       # OUTPUT_NAMES order, of the last step
        self._outputs_valid = 0                              # see the class docstring
        deferred = getattr(module, "DEFERRED_OUTPUTS", ())
        self._deferred_index = [self.output_names.index(name) for name in deferred]
        for field in fields(self.config_class):
            kind = _KIND[type(self._values[field.name])]
            self.slave.register_variable(kind(field.name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.fixed,
                                        description=self.variable_info[field.name][1],
                                        getter=self._parameter_getter(field.name),
                                        setter=self._parameter_setter(field.name)))
        for i, name in enumerate(self.input_names):
            self.slave.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        description=self.variable_info[name][1],
                                        getter=self._input_getter(i), setter=self._input_setter(i)))
        for i, name in enumerate(self.output_names):
            self.slave.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                        initial=Fmi2Initial.exact, description=self.variable_info[name][1],
                                        getter=self._output_getter(i)))
        reals = {vr: var for vr, var in self.slave.vars.items() if isinstance(var, Real)}
        self._real_getters = {vr: var.getter for vr, var in reals.items()}
        self._real_setters = {vr: var.setter for vr, var in reals.items() if var.setter is not None}
        # Instance attributes: pythonfmu's binary calls these by name on the slave instance.
        self.slave.get_real = self.get_real
        self.slave.set_real = self.set_real

    # ---- variable access
    def _parameter_getter(self, name):
        return lambda: self._values[name]

    def _parameter_setter(self, name):
        def set_parameter(value):
            if self._sim is not None:
                self._fail(f"{name}: a fixed parameter cannot be set after initialisation")
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

    def get_real(self, vrs):
        """fmi2GetReal: the values of Real variables ``vrs`` (value references); every Real holds a float."""
        getters = self._real_getters
        try:
            return [getters[vr]() for vr in vrs]
        except KeyError:          # not a Real: pythonfmu's version raises its TypeError
            return Fmi2Slave.get_real(self.slave, vrs)

    def set_real(self, vrs, values):
        """fmi2SetReal of Real variables ``vrs``, in order (as pythonfmu's: those before a bad one are set)."""
        setters = self._real_setters
        try:
            for vr, value in zip(vrs, values):
                setters[vr](value)
        except KeyError:          # not a settable Real: pythonfmu's version raises its TypeError
            Fmi2Slave.set_real(self.slave, vrs, values)

    def _fail(self, message: str):
        """Log with fmi2Error status (naming the variable), then fail the call."""
        self.slave.log(message, Fmi2Status.error)
        raise RuntimeError(message)

    def _give_inputs(self):
        """Hand the inputs to the simulator (after a change only: see the class docstring)."""
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
                self._outputs = [float(values[name]) for name in self.output_names]
            elif not self._deferred_index:
                self._outputs = sim.output_vector().tolist()
            elif self._outputs_valid == 1:    # only the deferred ones are missing
                for i, value in zip(self._deferred_index, sim.deferred_output_vector()):
                    self._outputs[i] = float(value)
            else:
                self._outputs = sim.output_vector(include_deferred=level == 2).tolist()
        except FlexfmuError as exc:
            self._fail(str(exc))
        self._outputs_valid = 2 if (level == 2 or not self._deferred_index) else 1

    # ---- FMI calls
    def exit_initialization_mode(self):
        config = self.config_class(**{f.name: self._values[f.name] for f in fields(self.config_class)})
        try:
            self._sim = self.simulator_class(config)
            self._vector_api = hasattr(self._sim, "set_input_vector") and hasattr(self._sim, "output_vector")
            self._sim.set_inputs(**dict(zip(self.input_names, self._inputs)))   # checked, naming each input
            self._inputs_changed = False
        except FlexfmuError as exc:
            self._fail(str(exc))
        self._log_messages()
        self._outputs_valid = 0
        self._read_outputs()             # every output once: a problem shows here rather than at a later read

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
        try:
            if self._inputs_changed:
                self._give_inputs()
            self._outputs_valid = 0           # from here on the outputs are those of another state
            sim.step(step_size)
        except FlexfmuError as exc:
            self._fail(str(exc))
        if getattr(sim, "messages", None):
            self._log_messages()
        return True

    # ---- whole-state get/set/serialize (registered variables alone would miss the internal state)
    def get_fmu_state(self):
        if self._outputs_valid < 2:
            self._read_outputs()
        return {"values": dict(self._values), "inputs": list(self._inputs), "outputs": list(self._outputs),
                "sim": None if self._sim is None else self._sim.get_state()}

    def set_fmu_state(self, state):
        self._values = dict(state["values"])
        self._inputs[:] = state["inputs"]          # in place: the input setters hold this list
        self._outputs = list(state["outputs"])
        self._outputs_valid = 2 if state["sim"] is not None else 0
        self._inputs_changed = True                # the simulator's inputs are those of the state's last step
        if state["sim"] is not None:
            if self._sim is None:
                self._sim = self.simulator_class(self.config_class(**state["sim"]["config"]))
                self._vector_api = hasattr(self._sim, "set_input_vector") and hasattr(self._sim, "output_vector")
            self._sim.set_state(state["sim"])
