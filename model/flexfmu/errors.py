"""The one error hierarchy of flexfmu: errors that tell the user which input is wrong and what is allowed.

    FlexfmuError
    ├── ParameterError           a value outside its allowed range (names the parameter and the range)
    │   ├── DivergenceError      a run that diverged (names the input or parameter behind it, else "state")
    │   └── ModelFileError       a model file that cannot become a Structure (names the file, the card,
    │                            element, node or set, and what is allowed)
    ├── NonFiniteError           a value that must be finite is not (names it, or its cause)
    ├── StepRejected             a step a smaller one may take (an FMU answers fmi2Discard)
    ├── ConvergenceError         an iterative solver did not converge
    │   └── ModalConvergenceError    the sparse eigensolver, or a mode failing its residual check
    └── CosimulationError        an FMU or master failed in a co-simulation (with the FMU's log)
"""
from __future__ import annotations


class FlexfmuError(Exception):
    """Base class of all errors raised on purpose by flexfmu."""


class ParameterError(FlexfmuError, ValueError):
    """A user-supplied value is outside its allowed range.

    ``parameter`` names the offending field (e.g. ``"material.E"``) and
    ``allowed`` states the allowed range, so a CLI or FMU can report both.
    """

    def __init__(self, parameter: str, message: str, allowed: str | None = None):
        self.parameter = parameter
        self.allowed = allowed
        text = f"{parameter}: {message}"
        if allowed:
            text += f" (allowed: {allowed})"
        super().__init__(text)


def require(condition: bool, parameter: str, message: str, allowed: str | None = None) -> None:
    """Raise :class:`ParameterError` unless ``condition`` holds."""
    if not condition:
        raise ParameterError(parameter, message, allowed)


class NonFiniteError(FlexfmuError, ValueError):
    """A value that must be finite is not (an input, a parameter, the state or an output).

    ``name`` is the offending variable, or the input or parameter that made the state overflow."""

    def __init__(self, name: str, message: str):
        self.parameter = name
        super().__init__(f"{name}: {message}")


class StepRejected(FlexfmuError):
    """A communication step that cannot be taken as asked, but a smaller one may succeed (an FMU
    answers fmi2Discard and keeps the state of the step's start).  ``parameter`` names what set the
    limit (e.g. ``max_internal_steps``)."""

    def __init__(self, parameter: str, message: str):
        self.parameter = parameter
        super().__init__(f"{parameter}: {message}")


class DivergenceError(ParameterError):
    """A run that diverged; ``parameter`` names the input or parameter behind it (else ``state``)."""


class ModelFileError(ParameterError):
    """A model file (mesh, Nastran deck, MAPDL matrices, model JSON) that cannot be turned into a Structure.

    ``parameter`` is the file, followed by the offending entity in brackets when there is one (a card,
    element, node, set or JSON key), e.g. ``beam.bdf [CTETRA 12]``; ``path`` and ``entity`` hold them apart.
    """

    def __init__(self, path, message: str, allowed: str | None = None, *, entity: str | None = None):
        self.path = str(path)
        self.entity = entity
        # one line: a CLI prints it as is, and the readers' own messages span several
        super().__init__(self.path + (f" [{entity}]" if entity else ""), " ".join(str(message).split()), allowed)


class ConvergenceError(FlexfmuError, RuntimeError):
    """An iterative solver did not converge within its limits."""


class ModalConvergenceError(ConvergenceError):
    """The sparse eigensolver did not converge, or a returned mode is not an eigenvector."""


class CosimulationError(FlexfmuError):
    """An FMU call or a master failed during a co-simulation; the message carries the FMU's log."""
