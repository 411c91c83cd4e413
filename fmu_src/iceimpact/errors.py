"""The three errors of the package, each naming what is wrong, its value and what is allowed.

- :class:`ParameterError`: a parameter or input outside its allowed range (scene validation, the
  simulator's arguments, the FMU's setters);
- :class:`SolverError`: a method cannot continue the run (the simulator keeps its state from
  before the step); :class:`NonFiniteError`, one that produced a value that is not finite;
- :class:`StateError`: a saved state (a snapshot, an FMU state blob) is malformed; nothing was
  changed.

And the one rule for what a number of the Python API is (:func:`real_number`, used by the scene,
the simulator's arguments and the sweeps): Python and numpy numbers alike, as a Python float.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["NonFiniteError", "ParameterError", "SolverError", "StateError", "checked_real",
           "real_number", "value_text"]

#: The types of a real number of the Python API: Python's int and float, numpy's integer and
#: floating scalars (bool and numpy.bool_ are not numbers here, nor complex, str or arrays).
REAL_TYPES = (int, float, np.integer, np.floating)


class ParameterError(ValueError):
    """A parameter is outside its allowed range; the message names it, its value and the range."""

    def __init__(self, name: str, value: Any, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{name} = {value_text(value)} is not allowed: {allowed}")


def real_number(value: Any) -> float | None:
    """``value`` as a Python float if it is a real number (:data:`REAL_TYPES`, not a bool),
    else None. An integer beyond double precision (``10**400``) is +-inf, refused wherever a
    finite number is needed; a numpy float32 keeps its exact value (0.01 as float32 is
    0.009999999776482582)."""
    if isinstance(value, float):  # float, numpy.float64
        return float(value)
    if isinstance(value, int):
        if value.__class__ is bool:
            return None
        try:
            return float(value)
        except OverflowError:  # beyond double precision
            return math.inf if value > 0 else -math.inf
    if isinstance(value, np.integer | np.floating):  # (numpy.bool_ is neither)
        return float(value)
    return None


def checked_real(name: str, value: Any, allowed: str,
                 ok: Callable[[float], bool] | None = None) -> float:
    """``value`` as a finite Python float (:func:`real_number`) for which ``ok`` holds (if
    given); otherwise :class:`ParameterError` naming ``name``, the value as given and
    ``allowed``."""
    number = real_number(value)
    if number is None or not math.isfinite(number) or (ok is not None and not ok(number)):
        raise ParameterError(name, value, allowed)
    return number


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
