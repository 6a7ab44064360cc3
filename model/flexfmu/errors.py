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
