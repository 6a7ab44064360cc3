"""An FMU's variables, from its spec (flexfmu.fmi.slave.FmuModel), in value-reference order: the parameters (the
config dataclass's fields), the inputs (INPUT_NAMES), the outputs (OUTPUT_NAMES), each with its type, unit and
description.  Both the modelDescription.xml (through pythonfmu, :func:`declare`) and the model file the runtime
reads (flexfmu.fmi.model_file.entries, from :func:`table`) come from here, so their value references agree.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

PYTHON_TYPES = {float: "Real", int: "Integer", bool: "Boolean", str: "String"}


@dataclass(frozen=True)
class Variable:
    name: str
    type: str              # Real, Integer, Boolean, String
    causality: str         # parameter, input, output
    start: object          # a parameter's value (the default, or the value built with); 0.0 for the others
    unit: str
    description: str


def table(spec, values: dict | None = None) -> list[Variable]:
    """The variables of ``spec`` in value-reference order; parameters start at ``values`` (default: the config's
    defaults).  An unknown name in ``values`` is refused."""
    from flexfmu.errors import ParameterError

    defaults = asdict(spec.config_class())
    unknown = set(values or {}) - set(defaults)
    if unknown:
        raise ParameterError(sorted(unknown)[0], "not a parameter of this FMU", ", ".join(defaults))
    current = {**defaults, **(values or {})}
    info = spec.variable_info
    rows = [Variable(name, PYTHON_TYPES[type(default)], "parameter", current[name], *info[name])
            for name, default in defaults.items()]
    rows += [Variable(name, "Real", "input", 0.0, *info[name]) for name in spec.input_names]
    rows += [Variable(name, "Real", "output", 0.0, *info[name]) for name in spec.output_names]
    return rows


def declare(slave, spec, values: dict | None = None) -> None:
    """Register the variables of ``spec`` with the pythonfmu slave ``slave`` (which writes the modelDescription
    from them), in :func:`table`'s order, so that pythonfmu's value references are the runtime's."""
    from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Variability, Integer, Real, String

    classes = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}
    for v in table(spec, values):
        getter = (lambda value=v.start: value) if v.causality == "parameter" else (lambda: 0.0)
        if v.causality == "parameter":
            variable = classes[v.type](v.name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                       description=v.description, getter=getter, setter=lambda value: None)
        elif v.causality == "input":
            variable = Real(v.name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                            description=v.description, getter=getter, setter=lambda value: None)
        else:
            variable = Real(v.name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                            initial=Fmi2Initial.exact, description=v.description, getter=getter)
        slave.register_variable(variable)
