"""Errors that tell the user which input is wrong and what is allowed."""
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
