"""ModalStructure.fmu's behaviour, without PythonFMU: what each FMI call does to one instance.

:class:`ModalFmuModel` is the FMI life cycle every FMU of the project follows
(:class:`~iceimpact.fmi.lifecycle.FmuLifecycle`: when parameters take effect, refusals, time and
step-size checks) around the :class:`~iceimpact.modal.ModalStructure` built from the values, and
adds what is the structure FMU's own:

- every parameter is fixed; one set after initialization is refused: the call returns
  fmi2Error with a message naming the parameter, the value refused and the value kept (as
  IceImpact.fmu does), and the value in use stays;
- a step with a non-finite force, or whose response overflows, is refused (fmi2Discard) and
  changes nothing;
- the state is a small explicit record (:meth:`~ModalFmuModel.snapshot` /
  :meth:`~ModalFmuModel.restore`), serialized by :func:`encode` / :func:`decode` in the layout of
  :mod:`iceimpact.fmi.state_codec` and checked field by field by :func:`check_record`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ..errors import ParameterError, StateError
from ..fmi.lifecycle import ERROR, FmuLifecycle
from ..fmi.state_codec import StateCodec, check_keys, check_number, check_values
from .contract import (
    FORCE_INPUT,
    MAX_MODES,
    MODEL_IDENTIFIER,
    MODES_PARAMETER,
    PARAMETERS,
    VERSION,
)
from .structure import ModalStructure, Mode

__all__ = ["ModalFmuModel", "StateError", "check_record", "decode", "default_values", "encode",
           "structure_from_values"]

_PARAMETER_NAMES = {p.name for p in PARAMETERS}


def structure_from_values(values: dict[str, Any]) -> ModalStructure:
    """The structure the FMI parameter ``values`` describe (modes 1 to ``modes``).

    Raises ParameterError naming the FMI variable, its value and its allowed range.
    """
    n = values[MODES_PARAMETER.name]
    if isinstance(n, bool) or not isinstance(n, int) or not MODES_PARAMETER.in_range(n):
        raise ParameterError(MODES_PARAMETER.name, n, MODES_PARAMETER.allowed)
    modes = [Mode(f=values[f"mode{k}.f"], zeta=values[f"mode{k}.zeta"], m=values[f"mode{k}.m"],
                  phi=values[f"mode{k}.phi"], name=f"mode{k}") for k in range(1, n + 1)]
    return ModalStructure(modes, q0=[values[f"mode{k}.q0"] for k in range(1, n + 1)],
                          v0=[values[f"mode{k}.v0"] for k in range(1, n + 1)])


def default_values() -> dict[str, float | int]:
    return {p.name: p.start for p in PARAMETERS}


# Serialized state --------------------------------------------------------------------------------
# b"ModalStructure FMU state\n" followed by the UTF-8 JSON object
#   {"format": 1, "fmu_version": "0.1.0", "state": <ModalFmuModel.snapshot()>}

#: Refused unread beyond this size (bytes): a valid state is about 1 kB.
MAX_BYTES = 1 << 14

_RECORD_KEYS = {"values", "force", "step_force", "start_time", "time", "error", "structure"}


def check_record(record: Any) -> dict[str, Any]:
    """Check the types of an instance record (the structure part is rebuilt by restore)."""
    check_keys("state", record, _RECORD_KEYS)
    values = check_values("values", record["values"], _PARAMETER_NAMES)
    for name, value in values.items():
        if name == MODES_PARAMETER.name:
            if isinstance(value, bool) or not isinstance(value, int):
                raise StateError(f"values[{name!r}]", value, "an integer")
        else:
            check_number(f"values[{name!r}]", value, finite=False)  # refused at initialization
    check_number(FORCE_INPUT.name, record["force"], finite=False)  # refused at the next step
    check_number("step_force", record["step_force"])
    check_number("start_time", record["start_time"])
    check_number("time", record["time"])
    if record["error"] is not None and not isinstance(record["error"], str):
        raise StateError("error", record["error"], "text or null")
    structure = record["structure"]
    if structure is not None:
        check_keys("structure", structure, {"q", "qdot"})
        for key in ("q", "qdot"):
            seq = structure[key]
            if not isinstance(seq, list) or not 1 <= len(seq) <= MAX_MODES:
                raise StateError(f"structure.{key}", seq,
                                 f"a list of 1 to {MAX_MODES} numbers")
            for i, value in enumerate(seq):
                check_number(f"structure.{key}[{i}]", value)
    return record


# NaN may stand in the record: a master's force or parameter value, refused when it is used.
CODEC = StateCodec(MODEL_IDENTIFIER, VERSION, check_record, MAX_BYTES, "about 1 kB",
                   allow_nan=True)
MAGIC = CODEC.magic
encode = CODEC.encode
decode = CODEC.decode


class ModalFmuModel(FmuLifecycle):
    """One ModalStructure.fmu instance's values, structure and life-cycle rules (no FMI library
    involved). ``log(status, text)`` reports a message; ``fail(text)`` reports it and makes the
    current FMI call return fmi2Error (used for a doStep refused because the parameters are
    invalid)."""

    PARAMETERS = PARAMETERS
    CORE_NAME = "structure"
    CODEC = CODEC

    def __init__(self, log: Callable[[int, str], None], fail: Callable[[str], None]):
        super().__init__(log, fail)
        self.force = float(FORCE_INPUT.start)
        self.structure: ModalStructure | None = None
        self._idle = structure_from_values(self.values)  # outputs before initialization
        self.step_force = self.force     # the force of the last step (for a, if force is bad)

    # variables -----------------------------------------------------------------------------------
    @property
    def initialized(self) -> bool:
        return self.structure is not None

    def read(self, name: str) -> float:
        if name == FORCE_INPUT.name:
            return self.force
        structure = self.structure if self.structure is not None else self._idle
        if name == "x":
            return structure.x
        if name == "v":
            return structure.v
        if name == "a":
            force = self.force if math.isfinite(self.force) else self.step_force
            return structure.acceleration(force)
        raise KeyError(name)

    def write_input(self, name: str, value: Any) -> bool:
        if name != FORCE_INPUT.name:
            return False
        self.force = value
        return True

    # life cycle ----------------------------------------------------------------------------------
    def build(self) -> None:
        self.structure = structure_from_values(self.values)

    def advance(self, current_time: float, step_size: float) -> bool:
        if not math.isfinite(self.force):
            self._log(ERROR, f"doStep at t = {current_time!r} s: {FORCE_INPUT.name} = "
                      f"{self.force!r} N is not allowed: finite")
            return False
        structure = self.structure
        before = structure.snapshot()
        state = structure.advance(step_size, self.force)
        if not all(math.isfinite(value) for value in state):
            structure.restore(before)
            self._log(ERROR, f"doStep at t = {current_time!r} s: the structure's response to "
                      f"{FORCE_INPUT.name} = {self.force!r} N overflows; the state is unchanged")
            return False
        self.step_force = self.force
        return True

    # state ---------------------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """Everything the future of this instance depends on, as plain data."""
        return {
            "values": dict(self.values),
            "force": self.force,
            "step_force": self.step_force,
            "start_time": self.start_time,
            "time": self.time,
            "error": self.error,
            "structure": self.structure.snapshot() if self.structure is not None else None,
        }

    def restore(self, record: dict[str, Any]) -> None:
        """Return to a :meth:`snapshot` (validated by :func:`check_record`); raises StateError
        and changes nothing if the structure part does not fit the values."""
        structure = None
        if record["structure"] is not None:
            try:
                structure = structure_from_values(record["values"])
                structure.restore(record["structure"])
            except ParameterError as exc:
                raise StateError("structure", record["structure"],
                                 f"a state of the structure the values describe: {exc}") from None
        self.values = dict(record["values"])
        self.force = record["force"]
        self.step_force = record["step_force"]
        self.start_time = record["start_time"]
        self.time = record["time"]
        self.error = record["error"]
        self.structure = structure
