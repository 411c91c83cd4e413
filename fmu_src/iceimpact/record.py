"""Reading a saved solver state: every field checked (keys, type, finiteness, range) before any
of it is used, so that a malformed snapshot is refused with a :class:`StateError` naming the
field, and the solver it was meant for stays as it was.

A snapshot is plain data (dict, list, str, float, int, bool, None; floats may be +-inf where a
field allows it), so that it survives ``json.dumps``/``json.loads`` and ``pickle`` unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from .errors import StateError

#: Version of the snapshot layout written by the solvers and the simulator: 2 adds the modal
#: structure's parameters, outputs and state (an earlier state is refused, never misread).
STATE_VERSION = 2

_MISSING = "<missing>"


class Record:
    """One dict of a snapshot, read field by field with checks; ``path`` names it in errors."""

    __slots__ = ("data", "path")

    def __init__(self, data: Any, path: str):
        if not isinstance(data, dict):
            raise StateError(path, data, "a dict of named fields")
        self.data = data
        self.path = path

    def field(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def expect_keys(self, keys: Iterable[str]) -> None:
        """The record holds exactly these keys."""
        keys = list(keys)
        for key in keys:
            if key not in self.data:
                raise StateError(self.field(key), _MISSING, "a required field")
        for key in self.data:
            if key not in keys:
                raise StateError(self.field(str(key)), self.data[key],
                                 "no such field; expected " + ", ".join(keys))

    def raw(self, key: str) -> Any:
        if key not in self.data:
            raise StateError(self.field(key), _MISSING, "a required field")
        return self.data[key]

    def real(self, key: str, *, finite: bool = True, low: float | None = None,
             high: float | None = None, allow_none: bool = False) -> float | None:
        """A real number (int or float, not bool, never NaN), finite unless ``finite=False``,
        within [low, high] when given."""
        value = self.raw(key)
        return check_real(value, self.field(key), finite=finite, low=low, high=high,
                          allow_none=allow_none)

    def integer(self, key: str, *, low: int | None = None, high: int | None = None) -> int:
        value = self.raw(key)
        if isinstance(value, bool) or not isinstance(value, int):
            raise StateError(self.field(key), value, "an integer")
        if (low is not None and value < low) or (high is not None and value > high):
            raise StateError(self.field(key), value, f"an integer in [{low}, {high}]")
        return int(value)

    def flag(self, key: str) -> bool:
        value = self.raw(key)
        if not isinstance(value, bool):
            raise StateError(self.field(key), value, "true or false")
        return value

    def text(self, key: str, choices: Iterable[str] | None = None,
             allow_none: bool = False) -> str | None:
        value = self.raw(key)
        if value is None and allow_none:
            return None
        if not isinstance(value, str):
            raise StateError(self.field(key), value, "a string" + (" or null" if allow_none
                                                                  else ""))
        if choices is not None:
            choices = list(choices)
            if value not in choices:
                raise StateError(self.field(key), value, "one of " + ", ".join(choices))
        return value

    def reals(self, key: str, length: int, *, finite: bool = True,
              allow_none: bool = False) -> list[float] | None:
        """A list of ``length`` real numbers."""
        value = self.raw(key)
        if value is None and allow_none:
            return None
        if not isinstance(value, list | tuple) or len(value) != length:
            raise StateError(self.field(key), value, f"a list of {length} real numbers")
        return [check_real(item, f"{self.field(key)}[{i}]", finite=finite)
                for i, item in enumerate(value)]

    def items(self, key: str, max_length: int) -> list[Any]:
        value = self.raw(key)
        if not isinstance(value, list | tuple) or len(value) > max_length:
            raise StateError(self.field(key), value, f"a list of at most {max_length} entries")
        return list(value)

    def record(self, key: str, allow_none: bool = False) -> Record | None:
        value = self.raw(key)
        if value is None and allow_none:
            return None
        return Record(value, self.field(key))


def check_real(value: Any, field: str, *, finite: bool = True, low: float | None = None,
               high: float | None = None, allow_none: bool = False) -> float | None:
    """``value`` as a float after the checks of :meth:`Record.real`."""
    if value is None and allow_none:
        return None
    kind = "a finite real number" if finite else "a real number (+-inf allowed)"
    if allow_none:
        kind += " or null"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise StateError(field, value, kind)
    value = float(value)
    if math.isnan(value) or (finite and not math.isfinite(value)):
        raise StateError(field, value, kind)
    if (low is not None and value < low) or (high is not None and value > high):
        raise StateError(field, value, f"{kind} in [{low!r}, {high!r}]")
    return value


def check_version(record: Record) -> None:
    version = record.raw("version")
    if isinstance(version, bool) or version != STATE_VERSION:
        raise StateError(record.field("version"), version,
                         f"{STATE_VERSION} (the layout this version of iceimpact writes)")
