"""IceImpact.fmu's serialized state: its instance record, validated field by field.

The blob layout, magic line, size limit and the refusal of duplicate keys and NaN are those of
every FMU of the project (:mod:`iceimpact.fmi.state_codec`)::

    b"IceImpact FMU state\\n"                 magic line (MAGIC)
    UTF-8 JSON object:
      {"format": 1,                          FORMAT, the layout version
       "fmu_version": "0.3.0",               the FMU that wrote it (must be this one)
       "state": {...}}                       the instance record (FmuModel.snapshot)

The record holds the master's values, times, pending tunable values, the error that stops the
instance if any, and the simulator's own snapshot (scene, the current segment's anchor, counters,
latest impact time, pending impulse; never the impact history), so its size does not grow with
the run (a few kB). A blob larger than :data:`MAX_BYTES`, with NaN, duplicate keys or any field of
the wrong type or range is refused with a :class:`~iceimpact.errors.StateError` that names
the field. Nothing in it can name a class or a function to call.
"""

from __future__ import annotations

from typing import Any

from ..contract import (
    FLOW_INPUT,
    MODE_LOAD_INPUTS,
    MODEL_IDENTIFIER,
    PARAMETERS,
    STRUCTURE_INPUTS,
    VERSION,
)
from ..errors import StateError
from .state_codec import FORMAT, StateCodec, check_keys, check_number, check_values

__all__ = ["CODEC", "FORMAT", "MAGIC", "MAX_BYTES", "check_record", "decode", "encode"]

#: Refused unread beyond this size (bytes): a valid state is a few kB.
MAX_BYTES = 1 << 16

_PARAMETER_NAMES = {p.name for p in PARAMETERS}
_TUNABLE_NAMES = {p.name for p in PARAMETERS if p.tunable}
_RECORD_KEYS = {"values", "flow_u", "structure_in", "start_time", "time", "pending", "error",
                "penetration_logged", "simulator", "loads_before"}
_STRUCTURE_INPUT_NAMES = {v.name for v in STRUCTURE_INPUTS + MODE_LOAD_INPUTS}


def check_record(record: Any) -> dict[str, Any]:
    """Check the instance part of a state (the simulator part is checked when restored)."""
    check_keys("state", record, _RECORD_KEYS)
    values = check_values("state.values", record["values"], _PARAMETER_NAMES)
    for name, value in values.items():
        check_number(f"state.values[{name!r}]", value)
    pending = record["pending"]
    if not isinstance(pending, dict) or not set(pending) <= _TUNABLE_NAMES:
        raise StateError("state.pending", pending, "an object of tunable parameters only "
                         f"({', '.join(sorted(_TUNABLE_NAMES))})")
    for name, value in pending.items():
        # refused at the next step if bad
        check_number(f"state.pending[{name!r}]", value, finite=False)
    check_number(f"state.flow_u ({FLOW_INPUT.name})", record["flow_u"], finite=False)  # likewise
    inputs = check_values("state.structure_in", record["structure_in"], _STRUCTURE_INPUT_NAMES)
    for name, value in inputs.items():
        check_number(f"state.structure_in[{name!r}]", value, finite=False)  # checked by doStep
    before = record["loads_before"]
    if before is not None:
        if not (isinstance(before, list) and len(before) == 2 and isinstance(before[1], list)
                and len(before[1]) == len(MODE_LOAD_INPUTS)):
            raise StateError("state.loads_before", before, "null or [the time (s), the "
                             f"{len(MODE_LOAD_INPUTS)} mode loads (N) given then]")
        check_number("state.loads_before[0]", before[0])
        for k, value in enumerate(before[1]):
            check_number(f"state.loads_before[1][{k}]", value)
    check_number("state.start_time", record["start_time"])
    check_number("state.time", record["time"])
    if record["error"] is not None and not isinstance(record["error"], str):
        raise StateError("state.error", record["error"], "text or null")
    if not isinstance(record["penetration_logged"], bool):
        raise StateError("state.penetration_logged", record["penetration_logged"],
                         "true or false")
    if record["simulator"] is not None and not isinstance(record["simulator"], dict):
        raise StateError("state.simulator", record["simulator"], "an object or null")
    return record


CODEC = StateCodec(MODEL_IDENTIFIER, VERSION, check_record, MAX_BYTES, "a few kB")
MAGIC = CODEC.magic
encode = CODEC.encode
decode = CODEC.decode
