"""The serialized FMU state of any of the project's FMUs: one layout, one reader.

A blob handed to fmi2DeSerializeFMUstate comes from outside (a file, another process, another
version of the FMU): it is data, never code. Every FMU writes the same layout::

    b"<model identifier> FMU state\\n"       magic line (StateCodec.magic)
    UTF-8 JSON object:
      {"format": 1,                          FORMAT, the layout version
       "fmu_version": "0.3.0",               the FMU that wrote it (must be this one)
       "state": {...}}                       the instance record (the model's snapshot)

JSON is parsed with the standard library; a blob larger than the FMU's size limit, with duplicate
keys, with NaN (unless the FMU allows it), or with another layout, format or FMU version is refused
with a :class:`~iceimpact.errors.StateError` naming the field. The instance record is then
checked by the FMU's own function (``check_record``), which refuses it the same way. Nothing in a
blob can name a class or a function to call.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

from ..errors import StateError

#: The layout version every FMU writes and reads.
FORMAT = 1


class StateCodec:
    """The blob layout of one FMU: ``model`` (its model identifier) names it in the magic line
    and in messages, ``version`` is the FMU version a blob must come from, ``check_record``
    validates the instance record (returning it, or raising StateError), ``max_bytes`` is the
    size beyond which a blob is refused unread (``typical`` says what a state has, for the
    message). ``allow_nan``: NaN may stand in the record (a field that takes a master's value
    unchecked until it is used)."""

    def __init__(self, model: str, version: str, check_record: Callable[[Any], dict[str, Any]],
                 max_bytes: int, typical: str, allow_nan: bool = False):
        self.model = model
        self.magic = f"{model} FMU state\n".encode()
        self.version = version
        self.check_record = check_record
        self.max_bytes = max_bytes
        self.typical = typical
        self.allow_nan = allow_nan

    def encode(self, record: dict[str, Any]) -> bytes:
        """The blob of an instance record (the model's ``snapshot()``)."""
        body = json.dumps({"format": FORMAT, "fmu_version": self.version, "state": record},
                          allow_nan=True, separators=(",", ":"))
        return self.magic + body.encode("utf-8")

    def refused(self, reason: str) -> bytes:
        """A blob that is refused, with ``reason``, when it comes back (for a state that could
        not be serialized: fmi2SerializeFMUstate itself has no way to fail)."""
        return self.magic + f"refused: {reason}".encode()

    def decode(self, blob: bytes) -> dict[str, Any]:
        """The instance record of a blob from :meth:`encode`, checked field by field.

        Raises StateError (naming what is wrong) for anything else: another file, a truncated or
        altered blob, another layout or FMU version, a field of the wrong type or out of range.
        """
        if not isinstance(blob, bytes | bytearray):
            raise StateError("blob", type(blob).__name__, "bytes")
        if len(blob) > self.max_bytes:
            raise StateError("blob size", len(blob), f"<= {self.max_bytes} bytes (a state of "
                             f"{self.model}.fmu has {self.typical}): refused unread")
        if not blob.startswith(self.magic):
            raise StateError("blob header", bytes(blob[:len(self.magic)]),
                             f"{self.magic!r}: this is not a state of {self.model}.fmu")
        constant = _nan_allowed if self.allow_nan else _nan_refused
        try:
            doc = json.loads(bytes(blob[len(self.magic):]).decode("utf-8"),
                             object_pairs_hook=_no_duplicates, parse_constant=constant)
        except StateError:
            raise
        except (ValueError, RecursionError) as exc:  # truncated, altered or not UTF-8
            raise StateError("blob", f"{len(blob)} bytes", "UTF-8 JSON after the header; it is "
                             f"damaged (truncated or altered): {exc}") from None
        if not isinstance(doc, dict) or set(doc) != {"format", "fmu_version", "state"}:
            raise StateError("layout", sorted(doc) if isinstance(doc, dict) else doc,
                             "an object with the keys format, fmu_version and state")
        if doc["format"] != FORMAT or isinstance(doc["format"], bool):
            raise StateError("format", doc["format"], f"{FORMAT}, the layout this FMU reads")
        if doc["fmu_version"] != self.version:
            raise StateError("fmu_version", doc["fmu_version"], f"{self.version!r}, the "
                             "version of this FMU: states are exchanged between equal versions "
                             "only")
        return self.check_record(doc["state"])


def check_keys(field: str, record: Any, keys: set[str]) -> None:
    """``record`` is an object with exactly ``keys``."""
    if not isinstance(record, dict) or set(record) != keys:
        got = sorted(record) if isinstance(record, dict) else type(record).__name__
        raise StateError(field, got, f"an object with the keys {sorted(keys)}")


def check_values(field: str, values: Any, names: set[str]) -> dict[str, Any]:
    """``values`` is an object holding the parameters ``names``, and only those (the types of
    the values are the record's to check)."""
    if not isinstance(values, dict) or set(values) != names:
        raise StateError(field, sorted(values) if isinstance(values, dict) else values,
                         "an object holding every parameter of the FMU, and only those")
    return values


def check_number(field: str, value: Any, finite: bool = True) -> None:
    """``value`` is a number (not a bool), finite unless ``finite=False``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise StateError(field, value, "a number")
    if finite and isinstance(value, float) and not math.isfinite(value):
        raise StateError(field, value, "a finite number")


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise StateError(key, value, "given once: the key appears twice (damaged state)")
        out[key] = value
    return out


def _nan_refused(name: str) -> float:
    if name == "Infinity":
        return math.inf
    if name == "-Infinity":
        return -math.inf
    raise StateError("blob", name, "numbers; NaN is no value any field may hold")


def _nan_allowed(name: str) -> float:
    return float(name)
