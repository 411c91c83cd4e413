"""The serialized FMU state: a fixed, versioned, documented layout, validated field by field.

A blob handed to fmi2DeSerializeFMUstate comes from outside (a file, another process, another
version of the FMU): it is data, never code. The layout is::

    b"IceImpact FMU state\\n"                 magic line (MAGIC)
    UTF-8 JSON object:
      {"format": 1,                          FORMAT, the layout version
       "fmu_version": "0.3.0",               the FMU that wrote it (must be this one)
       "state": {...}}                       the instance record (FmuModel.snapshot)

The record holds the master's values, times, pending tunable values, the error that stops the
instance if any, and the simulator's own snapshot (scene, the current segment's anchor, counters,
latest impact time, pending impulse; never the impact history), so its size does not grow with
the run (a few kB). JSON is parsed with the standard library; a blob larger than
:data:`MAX_BYTES`, with NaN, duplicate keys or any field of the wrong type or range is refused with
a :class:`~iceimpact.solvers.base.StateError` that names the field. Nothing in it can name a class
or a function to call.
"""

from __future__ import annotations

import json
import math
from typing import Any

from ..contract import FLOW_INPUT, PARAMETERS, STRUCTURE_INPUTS, VERSION
from ..solvers.base import StateError

MAGIC = b"IceImpact FMU state\n"
FORMAT = 1
#: Refused unread beyond this size (bytes): a valid state is a few kB.
MAX_BYTES = 1 << 16

_PARAMETER_NAMES = {p.name for p in PARAMETERS}
_TUNABLE_NAMES = {p.name for p in PARAMETERS if p.tunable}
_RECORD_KEYS = {"values", "flow_u", "structure_in", "start_time", "time", "pending", "error",
                "penetration_logged", "simulator"}


def encode(record: dict[str, Any]) -> bytes:
    """The blob of an instance record (:meth:`iceimpact.fmi.adapter.FmuModel.snapshot`)."""
    body = json.dumps({"format": FORMAT, "fmu_version": VERSION, "state": record},
                      allow_nan=True, separators=(",", ":"))
    return MAGIC + body.encode("utf-8")


def decode(blob: bytes) -> dict[str, Any]:
    """The instance record of a blob from :func:`encode`, checked field by field.

    Raises StateError (naming what is wrong) for anything else: another file, a truncated or
    altered blob, another layout or FMU version, a field of the wrong type or out of range.
    """
    if not isinstance(blob, bytes | bytearray):
        raise StateError("blob", type(blob).__name__, "bytes")
    if len(blob) > MAX_BYTES:
        raise StateError("blob size", len(blob), f"<= {MAX_BYTES} bytes (a state of "
                         "IceImpact.fmu has a few kB): refused unread")
    if not blob.startswith(MAGIC):
        raise StateError("blob header", bytes(blob[:len(MAGIC)]),
                         f"{MAGIC!r}: this is not a state of IceImpact.fmu")
    try:
        doc = json.loads(bytes(blob[len(MAGIC):]).decode("utf-8"),
                         object_pairs_hook=_no_duplicates, parse_constant=_infinity)
    except StateError:
        raise
    except (ValueError, RecursionError) as exc:  # truncated, altered or not UTF-8
        raise StateError("blob", f"{len(blob)} bytes", f"UTF-8 JSON after the header; it is "
                         f"damaged (truncated or altered): {exc}") from None
    if not isinstance(doc, dict) or set(doc) != {"format", "fmu_version", "state"}:
        raise StateError("layout", sorted(doc) if isinstance(doc, dict) else doc,
                         "an object with the keys format, fmu_version and state")
    if doc["format"] != FORMAT or isinstance(doc["format"], bool):
        raise StateError("format", doc["format"], f"{FORMAT}, the layout this FMU reads")
    if doc["fmu_version"] != VERSION:
        raise StateError("fmu_version", doc["fmu_version"], f"{VERSION!r}, the version of "
                         "this FMU: states are exchanged between equal versions only")
    return check_record(doc["state"])


def check_record(record: Any) -> dict[str, Any]:
    """Check the instance part of a state (the simulator part is checked when restored)."""
    if not isinstance(record, dict) or set(record) != _RECORD_KEYS:
        got = sorted(record) if isinstance(record, dict) else type(record).__name__
        raise StateError("state", got, f"an object with the keys {sorted(_RECORD_KEYS)}")
    values = record["values"]
    if not isinstance(values, dict) or set(values) != _PARAMETER_NAMES:
        raise StateError("state.values", sorted(values) if isinstance(values, dict) else values,
                         "an object holding every parameter of the FMU, and only those")
    for name, value in values.items():
        _number(f"state.values[{name!r}]", value)
    pending = record["pending"]
    if not isinstance(pending, dict) or not set(pending) <= _TUNABLE_NAMES:
        raise StateError("state.pending", pending, "an object of tunable parameters only "
                         f"({', '.join(sorted(_TUNABLE_NAMES))})")
    for name, value in pending.items():
        _number(f"state.pending[{name!r}]", value, finite=False)  # refused at the next step if bad
    _number(f"state.flow_u ({FLOW_INPUT.name})", record["flow_u"], finite=False)  # likewise
    inputs = record["structure_in"]
    names = {v.name for v in STRUCTURE_INPUTS}
    if not isinstance(inputs, dict) or set(inputs) != names:
        raise StateError("state.structure_in", inputs, "an object holding "
                         + ", ".join(sorted(names)))
    for name, value in inputs.items():
        _number(f"state.structure_in[{name!r}]", value, finite=False)  # checked by doStep
    _number("state.start_time", record["start_time"])
    _number("state.time", record["time"])
    if record["error"] is not None and not isinstance(record["error"], str):
        raise StateError("state.error", record["error"], "text or null")
    if not isinstance(record["penetration_logged"], bool):
        raise StateError("state.penetration_logged", record["penetration_logged"],
                         "true or false")
    if record["simulator"] is not None and not isinstance(record["simulator"], dict):
        raise StateError("state.simulator", record["simulator"], "an object or null")
    return record


def _number(name: str, value: Any, finite: bool = True) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise StateError(name, value, "a number")
    if finite and isinstance(value, float) and not math.isfinite(value):
        raise StateError(name, value, "a finite number")


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise StateError(key, value, "given once: the key appears twice (damaged state)")
        out[key] = value
    return out


def _infinity(name: str) -> float:
    if name == "Infinity":
        return math.inf
    if name == "-Infinity":
        return -math.inf
    raise StateError("blob", name, "numbers; NaN is no value any field may hold")
