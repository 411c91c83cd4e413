"""ModalStructure.fmu's behaviour, without PythonFMU: what each FMI call does to one instance.

:class:`ModalFmuModel` holds the values the master set, the :class:`~iceimpact.modal.
ModalStructure` built from them, and the FMI life-cycle rules (the same as IceImpact.fmu's):

- parameters take effect at exitInitializationMode (or at the first doStep if a master skips
  initialization); a parameter set afterwards is refused and not stored, so that fmi2Get returns
  the value in use;
- invalid parameters are logged at exitInitializationMode (name, value, allowed range) and every
  doStep is then refused with fmi2Error (the ``fail`` callback) and the same message;
- a step with a non-finite force, a step size that is not finite and > 0, or a communication
  point other than the end of the last step is refused (fmi2Discard) and changes nothing;
- the state is a small explicit record (:meth:`~ModalFmuModel.snapshot` /
  :meth:`~ModalFmuModel.restore`), serialized by :func:`encode` / :func:`decode` as a versioned
  JSON blob validated field by field (data, never code: no pickle).

Messages go to the ``log(status, text)`` callback with the FMI status codes below.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

from .modal import ModalStructure, Mode
from .modal_contract import (
    FORCE_INPUT,
    MAX_MODES,
    MODES_PARAMETER,
    PARAMETERS,
    VERSION,
)
from .scene import ParameterError

# FMI 2.0 status codes used in log messages.
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3

#: A master's communication point may differ from the sum of the step sizes by rounding only.
TIME_RTOL = 1e-9

_PARAMETER_NAMES = {p.name for p in PARAMETERS}


class StateError(ValueError):
    """An FMU state that cannot be restored; the message names the field."""


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


class ModalFmuModel:
    """One FMU instance's values, structure and life-cycle rules (no FMI library involved).

    ``log(status, text)`` reports a message; ``fail(text)`` reports it and makes the current FMI
    call return fmi2Error (used for a doStep refused because the parameters are invalid).
    """

    def __init__(self, log: Callable[[int, str], None], fail: Callable[[str], None]):
        self._log = log
        self._fail = fail
        self.values: dict[str, float | int] = default_values()
        self.force = float(FORCE_INPUT.start)
        self.structure: ModalStructure | None = None
        self._idle = structure_from_values(self.values)  # outputs before initialization
        self.step_force = self.force     # the force of the last step (for a, if force is bad)
        self.start_time = 0.0
        self.time = 0.0
        self.error: str | None = None   # why the instance cannot step

    # variables -----------------------------------------------------------------------------------
    def get(self, name: str) -> float | int:
        """The value of a parameter, the input or an output."""
        if name in self.values:
            return self.values[name]
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

    def set(self, name: str, value: Any) -> None:
        """fmi2Set of a parameter or the input; validated when it takes effect."""
        if name == FORCE_INPUT.name:
            self.force = value
        elif self.structure is None:
            self.values[name] = value
        else:
            self._log(ERROR, f"{name} is a fixed parameter: setting it to {value!r} after "
                      f"initialization is refused and the value in use, {self.values[name]!r}, "
                      "is kept (use fmi2Reset to change it)")

    # life cycle ----------------------------------------------------------------------------------
    def setup_experiment(self, start_time: Any) -> None:
        if isinstance(start_time, int | float) and math.isfinite(start_time):
            self.start_time = self.time = float(start_time)
        else:
            self.error = f"start time = {start_time!r} is not allowed: a finite number of seconds"
            self._log(ERROR, self.error)

    def initialize(self, where: str = "exitInitializationMode") -> bool:
        """Build the structure from the values; on failure log why and remember it."""
        if self.error is not None:
            return False
        try:
            structure = structure_from_values(self.values)
        except ParameterError as exc:
            self.error = f"{where}: {exc}"
        except Exception as exc:  # a defect in the core must not kill the host
            self.error = f"{where}: cannot create the structure: {exc!r}"
        else:
            self.structure = structure
            return True
        self._log(ERROR, self.error + "; the FMU will not step (fmi2Error) until the parameter "
                  "is corrected after fmi2Reset")
        return False

    def do_step(self, current_time: float, step_size: float) -> bool:
        """One communication step; False refuses it and changes nothing."""
        try:
            return self._do_step(current_time, step_size)
        except Exception as exc:  # never let an exception reach the FMI library
            self._log(ERROR, f"doStep at t = {current_time!r} s failed: {exc!r}")
            return False

    def _do_step(self, current_time: float, step_size: float) -> bool:
        if self.structure is None and not self.initialize("doStep"):
            self._fail(f"doStep refused: {self.error}")
            return False
        if not (math.isfinite(step_size) and step_size > 0.0):
            self._log(ERROR, f"doStep: communication step size = {step_size!r} s is not "
                      "allowed: finite and > 0")
            return False
        if not (math.isfinite(current_time) and abs(current_time - self.time)
                <= TIME_RTOL * max(1.0, abs(self.time))):
            self._log(ERROR, f"doStep: current communication point = {current_time!r} s does "
                      f"not match the time of the FMU, {self.time!r} s (the end of the last step)")
            return False
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
        self.time = current_time + step_size
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
        """Return to a :meth:`snapshot` (checked by :func:`check_record`); raises StateError and
        changes nothing if the record is not sound."""
        record = check_record(record)
        structure = None
        if record["structure"] is not None:
            try:
                structure = structure_from_values(record["values"])
                structure.restore(record["structure"])
            except ParameterError as exc:
                raise StateError(f"FMU state field structure: {exc}") from None
        self.values = dict(record["values"])
        self.force = record["force"]
        self.step_force = record["step_force"]
        self.start_time = record["start_time"]
        self.time = record["time"]
        self.error = record["error"]
        self.structure = structure


# Serialized state --------------------------------------------------------------------------------
# b"ModalStructure FMU state\n" followed by the UTF-8 JSON object
#   {"format": 1, "fmu_version": "0.1.0", "state": <ModalFmuModel.snapshot()>}
# A blob comes from outside (a file, another process): it is data, never code, and is checked
# field by field before anything is changed.

MAGIC = b"ModalStructure FMU state\n"
FORMAT = 1
#: Refused unread beyond this size (bytes): a valid state is about 1 kB.
MAX_BYTES = 1 << 14

_RECORD_KEYS = {"values", "force", "step_force", "start_time", "time", "error", "structure"}


def encode(record: dict[str, Any]) -> bytes:
    """The blob of an instance record (:meth:`ModalFmuModel.snapshot`)."""
    body = json.dumps({"format": FORMAT, "fmu_version": VERSION, "state": record},
                      allow_nan=True, separators=(",", ":"))
    return MAGIC + body.encode("utf-8")


def decode(blob: bytes) -> dict[str, Any]:
    """The instance record of a blob from :func:`encode`, checked field by field (StateError
    naming what is wrong otherwise)."""
    if not isinstance(blob, bytes | bytearray):
        raise StateError(f"an FMU state must be bytes, not {type(blob).__name__}")
    if len(blob) > MAX_BYTES:
        raise StateError(f"FMU state of {len(blob)} bytes refused: a state of "
                         f"ModalStructure.fmu has at most {MAX_BYTES} bytes")
    if not blob.startswith(MAGIC):
        raise StateError("not a state of ModalStructure.fmu (its first bytes are "
                         f"{bytes(blob[:len(MAGIC)])!r}, expected {MAGIC!r})")
    try:
        doc = json.loads(bytes(blob[len(MAGIC):]).decode("utf-8"),
                         object_pairs_hook=_no_duplicates)
    except StateError:
        raise
    except (ValueError, RecursionError) as exc:  # truncated, altered or not UTF-8
        raise StateError(f"FMU state is damaged (truncated or altered): {exc}") from None
    if not isinstance(doc, dict) or set(doc) != {"format", "fmu_version", "state"}:
        raise StateError("FMU state has not the layout of ModalStructure.fmu (keys format, "
                         "fmu_version, state)")
    if isinstance(doc["format"], bool) or doc["format"] != FORMAT:
        raise StateError(f"FMU state layout format = {doc['format']!r} is not supported: this "
                         f"FMU reads format {FORMAT}")
    if doc["fmu_version"] != VERSION:
        raise StateError(f"FMU state written by ModalStructure.fmu {doc['fmu_version']!r} "
                         f"cannot be restored by version {VERSION}")
    return check_record(doc["state"])


def check_record(record: Any) -> dict[str, Any]:
    """Check the types of an instance record (the structure part is rebuilt by restore)."""
    if not isinstance(record, dict) or set(record) != _RECORD_KEYS:
        got = sorted(record) if isinstance(record, dict) else type(record).__name__
        raise StateError(f"FMU state record has keys {got}, expected {sorted(_RECORD_KEYS)}")
    values = record["values"]
    if not isinstance(values, dict) or set(values) != _PARAMETER_NAMES:
        raise StateError("FMU state field values must hold every parameter, and only those")
    for name, value in values.items():
        if name == MODES_PARAMETER.name:
            if isinstance(value, bool) or not isinstance(value, int):
                raise StateError(f"FMU state field values['modes'] = {value!r}: an integer")
        else:
            _number(f"values[{name!r}]", value, finite=False)  # refused at initialization
    _number(FORCE_INPUT.name, record["force"], finite=False)  # refused at the next step
    _number("step_force", record["step_force"])
    _number("start_time", record["start_time"])
    _number("time", record["time"])
    if record["error"] is not None and not isinstance(record["error"], str):
        raise StateError(f"FMU state field error = {record['error']!r}: text or null")
    structure = record["structure"]
    if structure is not None:
        if not isinstance(structure, dict) or set(structure) != {"q", "qdot"}:
            raise StateError("FMU state field structure must be null or an object with q and "
                             "qdot")
        for key in ("q", "qdot"):
            seq = structure[key]
            if not isinstance(seq, list) or not 1 <= len(seq) <= MAX_MODES:
                raise StateError(f"FMU state field structure.{key} must be a list of 1 to "
                                 f"{MAX_MODES} numbers")
            for i, value in enumerate(seq):
                _number(f"structure.{key}[{i}]", value)
    return record


def _number(name: str, value: Any, finite: bool = True) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise StateError(f"FMU state field {name} = {value!r}: a number")
    if finite and not math.isfinite(value):
        raise StateError(f"FMU state field {name} = {value!r}: a finite number")


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise StateError(f"FMU state is damaged: key {key!r} appears twice")
        out[key] = value
    return out

