"""The three errors of the package, each naming what is wrong, its value and what is allowed.

- :class:`ParameterError`: a parameter or input outside its allowed range (scene validation, the
  simulator's arguments, the FMU's setters);
- :class:`SolverError`: a method cannot continue the run (the simulator keeps its state from
  before the step); :class:`NonFiniteError`, one that produced a value that is not finite;
- :class:`StateError`: a saved state (a snapshot, an FMU state blob) is malformed; nothing was
  changed.
"""

from __future__ import annotations

from typing import Any

__all__ = ["NonFiniteError", "ParameterError", "SolverError", "StateError", "value_text"]


class ParameterError(ValueError):
    """A parameter is outside its allowed range; the message names it, its value and the range."""

    def __init__(self, name: str, value: Any, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{name} = {value_text(value)} is not allowed: {allowed}")


def value_text(value: Any) -> str:
    """repr of a value, shortened when huge (an integer of 400 digits from a scene file)."""
    text = repr(value)
    if len(text) > 80:
        text = f"{text[:24]}...{text[-8:]} ({len(text)} characters)"
    return text


class SolverError(RuntimeError):
    """A method cannot continue the run (an unstable explicit step, a failed integration); the
    message says why and what to change. The simulator keeps its state from before the step."""


class NonFiniteError(SolverError):
    """A method produced a value that is not finite (at ``t``, the first such time; the time
    before it is ``t_before``)."""

    def __init__(self, names: list[str], t: float, t_before: float):
        self.t, self.t_before = t, t_before
        super().__init__(f"the method produced a non-finite {', '.join(names)} at t = {t!r} s")


class StateError(ValueError):
    """A saved state (a snapshot of a solver or a simulator) is malformed; the message names the
    field, its value and what was expected. Nothing was changed."""

    def __init__(self, field: str, value: Any, expected: str):
        self.field = field
        self.value = value
        self.expected = expected
        text = repr(value)
        if len(text) > 80:
            text = text[:77] + "..."
        super().__init__(f"state field {field} = {text} is not allowed: {expected}")
