"""FFRBeam.fmu: the FFR model of a bent-rod scene, clamped, on a moving base (FMI 2.0 co-simulation).

Thin pythonfmu shell over flexfmu.ffr_beam_sim: parse parameters, call flexfmu, map I/O.
"""
from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real, String  # noqa: F401
from pythonfmu.enums import Fmi2Status

from flexfmu.errors import FlexfmuError
from flexfmu.ffr_beam_sim import INPUT_NAMES, OUTPUT_NAMES, VARIABLE_INFO, FFRBeamConfig, FFRBeamSimulator

# Relative tolerance on currentCommunicationPoint against the FMU's own time.
_TIME_RTOL = 1e-9

PARAMETERS = {  # name: (type, FMU default)
    "scene": (String, FFRBeamConfig.scene),
    "boundary": (String, FFRBeamConfig.boundary),
    "elements_per_segment": (Integer, FFRBeamConfig.elements_per_segment),
    "n_modes": (Integer, FFRBeamConfig.n_modes),
    "damping_ratio": (Real, FFRBeamConfig.damping_ratio),
    "load_s": (Real, FFRBeamConfig.load_s),
    "sensor_s": (Real, FFRBeamConfig.sensor_s),
}


class FFRBeam(Fmi2Slave):
    author = "flexfmu"
    description = "FFR discontinuous-beam model (Koda et al. 2025) of a clamped bent rod on a moving base"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._sim = None
        self._values = {name: default for name, (_, default) in PARAMETERS.items()}
        self._values.update(dict.fromkeys(INPUT_NAMES, 0.0))
        self._values.update(dict.fromkeys(OUTPUT_NAMES, 0.0))
        for name, (kind, _) in PARAMETERS.items():
            self.register_variable(kind(name, causality=Fmi2Causality.parameter, description=VARIABLE_INFO[name][1], variability=Fmi2Variability.fixed,
                                        getter=self._getter(name), setter=self._parameter_setter(name)))
        for name in INPUT_NAMES:
            self.register_variable(Real(name, causality=Fmi2Causality.input, description=VARIABLE_INFO[name][1], variability=Fmi2Variability.continuous,
                                        getter=self._getter(name), setter=self._input_setter(name)))
        for name in OUTPUT_NAMES:
            self.register_variable(Real(name, causality=Fmi2Causality.output, description=VARIABLE_INFO[name][1], variability=Fmi2Variability.continuous,
                                        initial=Fmi2Initial.exact, getter=self._getter(name)))

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
        self.log(message, Fmi2Status.error)
        raise RuntimeError(message)

    # ---- FMI calls
    def exit_initialization_mode(self):
        config = FFRBeamConfig(**{name: self._values[name] for name in PARAMETERS})
        try:
            self._sim = FFRBeamSimulator(config)
            self._sim.set_inputs(**{name: self._values[name] for name in INPUT_NAMES})
        except FlexfmuError as exc:
            self._fail(str(exc))
        self._values.update(self._sim.outputs())

    def do_step(self, current_time, step_size):
        sim = self._sim
        if abs(current_time - sim.state.t) > _TIME_RTOL * max(1.0, abs(sim.state.t)):
            self._fail(f"currentCommunicationPoint: got {current_time!r} s, expected the FMU's time "
                       f"{sim.state.t!r} s (roll back with setFMUstate to step from another time)")
        try:
            sim.set_inputs(**{name: self._values[name] for name in INPUT_NAMES})
            sim.step(step_size)
        except FlexfmuError as exc:
            self._fail(str(exc))
        self._values.update(sim.outputs())
        return True

    # ---- whole-state get/set/serialize (registered variables alone would miss the modal state)
    def _get_fmu_state(self):
        return {"values": dict(self._values), "sim": None if self._sim is None else self._sim.get_state()}

    def _set_fmu_state(self, state):
        self._values = dict(state["values"])
        if state["sim"] is not None:
            if self._sim is None:
                self._sim = FFRBeamSimulator(FFRBeamConfig(**state["sim"]["config"]))
            self._sim.set_state(state["sim"])
