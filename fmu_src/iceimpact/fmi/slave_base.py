"""The PythonFMU slave of any FMU of the project: FMI plumbing only.

A slave (``fmu_src/IceImpact.py``, ``fmu_src/ModalStructure.py``) is a subclass of
:class:`FmuSlave` that names its contract table (``CONTRACT``: a module such as
:mod:`iceimpact.contract`) and its model class (``MODEL``: a
:class:`~iceimpact.fmi.lifecycle.FmuLifecycle`). This class registers the contract's variables,
takes the model description's metadata and default experiment from the contract, passes every
FMI call to the model, and serializes the FMU state with the model's codec.

No exception may leave a slave method: PythonFMU 0.7.0 turns it into ``fmi2Fatal`` and releases
the instance, and a later ``fmi2FreeInstance`` can then crash the host. Failures are logged
(variable, value, allowed range) and reported through ``do_step`` returning False
(``fmi2Discard``) or, where the call must fail, through ``fail_call`` (``fmi2Error``).

fmi2Get and fmi2Set are batch calls here (PythonFMU's own ``get_real`` and friends call one
getter per variable, with a type test each): the value references are the contract's variables
in order (the order they are registered in), so one table per FMI type, derived from the
contract when the slave class is made, maps a value reference to its slot in the model's
``published`` outputs (read after every step: one loop over the value references, no call
per variable) or to the name of a parameter or input. Anything else (parameters, inputs, a model
that publishes nothing) is asked of the model variable by variable. A value reference that is not
a variable of the call's type (or, for fmi2Set, an output) is refused with ``fmi2Error`` and a
message naming it, and the call then reads or sets nothing.

Only slaves import this module (it needs PythonFMU); they import it as ``iceimpact.fmi...``,
which inside an FMU is the FMU's private copy of the core (``iceimpact_fmu_boot``). It imports
nothing outside the package.
"""

from __future__ import annotations

import math
from functools import partial
from types import ModuleType
from typing import Any, ClassVar

from pythonfmu import (
    Boolean,
    DefaultExperiment,
    Fmi2Causality,
    Fmi2Initial,
    Fmi2Slave,
    Fmi2Variability,
    Integer,
    Real,
)
from pythonfmu.enums import Fmi2Status

from ..contract import CONTINUOUS, DISCRETE, FIXED, INPUT, OUTPUT, PARAMETER, TUNABLE, Variable
from ..errors import ParameterError
from .lifecycle import EARLY_RETURN, REACHED_TIME, FmuLifecycle
from .pythonfmu_fixes import guard_native_exit

#: A message logged with this category fails the current FMI call with fmi2Error: the FMU's loader
#: (fmu_native/loader.c, FAIL_CATEGORY) forwards it to the host as an error (category
#: logStatusError), whether or not the host turned logging on.
FAIL_CATEGORY = "fmi2Error"


def fail_call(slave: Fmi2Slave, message: str) -> None:
    """Make the FMI call in progress return ``fmi2Error`` and show ``message`` to the host.

    ``message`` is the text (FMI loggers treat it as a printf format: escape ``%`` as ``%%``).
    The slave method then returns normally (for ``do_step``, False or True: the status is
    fmi2Error either way). Without the loader (a host that loads PythonFMU's library directly)
    the message is an ordinary error-level log message. Not in ``exit_initialization_mode``:
    libcosim terminates the process on an fmi2Error from fmi2ExitInitializationMode; log the
    error there and fail the next ``do_step``.
    """
    slave.log(message, Fmi2Status.error, FAIL_CATEGORY)


#: The value references through which the FMI 3.0 layer of IceImpact3.fmu (fmu_native/fmi3.c,
#: compiled with these numbers) sets EARLY_RETURN (a Boolean) and reads REACHED_TIME (a Real, the
#: FMI 3.0 description's independent variable ``time``): the same slave serves both FMI
#: versions; no FMI 2.0 description lists them.
FMI3_CHANNEL = {EARLY_RETURN: (0x7FFFFF00, bool), REACHED_TIME: (0x7FFFFF01, float)}

_TYPES = {float: Real, int: Integer, bool: Boolean}
#: The FMI types, by the contract's kind, as the FMI functions name them (fmi2GetReal).
_TYPE_NAMES = {float: "Real", int: "Integer", bool: "Boolean", str: "String"}
#: What a refused fmi2Get gives for a value it cannot read (the call returns fmi2Error).
_UNDEFINED = {float: math.nan, int: 0, bool: False, str: ""}
_CAUSALITY = {PARAMETER: Fmi2Causality.parameter, INPUT: Fmi2Causality.input,
              OUTPUT: Fmi2Causality.output}
_VARIABILITY = {FIXED: Fmi2Variability.fixed, TUNABLE: Fmi2Variability.tunable,
                CONTINUOUS: Fmi2Variability.continuous, DISCRETE: Fmi2Variability.discrete}


def _batch_get(kind: type):
    """PythonFMU's ``get_<type>(vrs)`` for the FMI type of ``kind``: the published outputs read
    through the value-reference table (a loop, quicker than a comprehension on Python 3.11),
    anything else asked of the model variable by variable."""
    def get(self: FmuSlave, vrs: list[int]) -> list[Any]:
        published = self._model.published
        if published is not None:
            slots = self._output_slots[kind]
            values = []
            try:
                for vr in vrs:
                    values.append(published[slots[vr]])
                return values
            except KeyError:  # not only outputs of this type
                pass
        return self._get(vrs, kind)

    get.__name__ = f"get_{_TYPE_NAMES[kind].lower()}"
    return get


def _batch_set(kind: type):
    """PythonFMU's ``set_<type>(vrs, values)`` for the FMI type of ``kind``: every value
    reference checked first (a parameter or input of this type), then each value passed to the
    model; a call with one that is not is refused and sets nothing."""
    def set_(self: FmuSlave, vrs: list[int], values: list[Any]) -> None:
        names = self._set_names[kind]
        for vr in vrs:
            if vr not in names:
                self._all_of(vrs, kind, "Set")  # refuses the call, naming the value reference
                return
        set_value = self._model.set
        for vr, value in zip(vrs, values, strict=False):  # as long as each other (C)
            set_value(names[vr], value)

    set_.__name__ = f"set_{_TYPE_NAMES[kind].lower()}"
    return set_


class FmuSlave(Fmi2Slave):
    """An FMI 2.0 Co-Simulation slave made of a contract table and a model class."""

    CONTRACT: ClassVar[ModuleType]
    MODEL: ClassVar[type[FmuLifecycle]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        contract = cls.CONTRACT
        cls.author = contract.AUTHOR
        cls.description = contract.DESCRIPTION
        cls.license = contract.LICENSE
        cls.version = contract.VERSION
        experiment = contract.DEFAULT_EXPERIMENT
        cls.default_experiment = DefaultExperiment(start_time=experiment.start_time,
                                                   stop_time=experiment.stop_time,
                                                   step_size=experiment.step_size)
        # The value reference of a variable is its index in the contract (see __init__).
        variables: tuple[Variable, ...] = contract.VARIABLES
        outputs = tuple(v for v in variables if v.causality == OUTPUT)
        if cls.MODEL.OUTPUTS not in ((), outputs):
            raise TypeError(f"{cls.MODEL.__name__}.OUTPUTS are not the contract's outputs")
        slot = {v.name: i for i, v in enumerate(outputs)}
        cls._variables = variables
        #: by FMI type: value reference -> slot in the model's published outputs
        cls._output_slots = {kind: {vr: slot[v.name] for vr, v in enumerate(variables)
                                    if v.kind is kind and v.causality == OUTPUT}
                             for kind in _TYPE_NAMES}
        #: by FMI type: value reference -> name, for every variable but the outputs
        cls._settable = {kind: {vr: v.name for vr, v in enumerate(variables)
                                if v.kind is kind and v.causality != OUTPUT}
                         for kind in _TYPE_NAMES}
        #: by FMI type: the value references fmi2Get reads
        cls._readable = {kind: frozenset(vr for vr, v in enumerate(variables) if v.kind is kind)
                         for kind in _TYPE_NAMES}
        # the same, with the FMI 3.0 channel, which the refusals do not list
        set_vr, set_kind = FMI3_CHANNEL[EARLY_RETURN]
        get_vr, get_kind = FMI3_CHANNEL[REACHED_TIME]
        cls._set_names = {kind: {**names, **({set_vr: EARLY_RETURN} if kind is set_kind else {})}
                          for kind, names in cls._settable.items()}
        cls._get_refs = {kind: refs | ({get_vr} if kind is get_kind else set())
                         for kind, refs in cls._readable.items()}
        #: value reference -> name, of every variable fmi2Get may read
        cls._names = {**{vr: v.name for vr, v in enumerate(variables)}, get_vr: REACHED_TIME}

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        guard_native_exit()
        self._model = self.MODEL(self._log, fail=self._fail)
        for vr, var in enumerate(self._variables):
            output = var.causality == OUTPUT
            scalar = _TYPES[var.kind](
                var.name, causality=_CAUSALITY[var.causality],
                variability=_VARIABILITY[var.variability], description=var.description,
                initial=Fmi2Initial.calculated if output else None,
                getter=partial(self._model.get, var.name),
                setter=None if output else partial(self._model.set, var.name))
            self.register_variable(scalar, nested=False)
            if scalar.value_reference != vr:  # the batch tables rely on it
                raise RuntimeError(f"{var.name}: value reference {scalar.value_reference}, "
                                   f"expected {vr}")

    def _log(self, status: int, message: str) -> None:
        # FMI loggers treat the message as a printf format string
        self.log(message.replace("%", "%%"), Fmi2Status(status))

    def _fail(self, message: str) -> None:
        """Log an error and make the FMI call in progress return fmi2Error."""
        fail_call(self, message.replace("%", "%%"))

    # fmi2Get / fmi2Set: batch calls over tables made from the contract --------------------------
    def _get(self, vrs: list[int], kind: type) -> list[Any]:
        """fmi2Get<kind> the slow way: each variable asked of the model (parameters, inputs,
        a model that publishes nothing), or the call refused."""
        if not self._all_of(vrs, kind, "Get"):
            return [_UNDEFINED[kind]] * len(vrs)
        get = self._model.get
        names = self._names
        return [kind(get(names[vr])) for vr in vrs]

    def _all_of(self, vrs: list[int], kind: type, verb: str) -> bool:
        """True if every value reference is a variable of type ``kind`` (fmi2Set: not an
        output); else the call is refused (fmi2Error) naming the first that is not."""
        table = self._set_names[kind] if verb == "Set" else self._get_refs[kind]
        for vr in vrs:
            if vr not in table:
                listed = self._settable[kind] if verb == "Set" else self._readable[kind]
                self._fail(self._not_allowed(vr, kind, verb, sorted(listed)))
                return False
        return True

    def _not_allowed(self, vr: int, kind: type, verb: str, allowed: list[int]) -> str:
        type_name = _TYPE_NAMES[kind]
        what = f"the value reference of a {type_name} variable"
        if verb == "Set":
            what += " that is a parameter or an input"
        refs = _ranges(allowed) if allowed else f"{type(self).__name__}.fmu has none"
        text = str(ParameterError("value reference", vr, f"{what} ({refs})"))
        if 0 <= vr < len(self._variables):
            var = self._variables[vr]
            text += f"; {vr} is {var.name}, {var.causality}, {_TYPE_NAMES[var.kind]}"
        return f"fmi2{verb}{type_name}: {text}; nothing is {'set' if verb == 'Set' else 'read'}"

    get_real = _batch_get(float)
    get_integer = _batch_get(int)
    get_boolean = _batch_get(bool)
    get_string = _batch_get(str)
    set_real = _batch_set(float)
    set_integer = _batch_set(int)
    set_boolean = _batch_set(bool)
    set_string = _batch_set(str)

    # FMI life cycle ------------------------------------------------------------------------------
    def setup_experiment(self, start_time: float, stop_time: float | None,
                         tolerance: float | None) -> None:
        self._model.setup_experiment(start_time)

    def exit_initialization_mode(self) -> None:
        self._model.initialize()

    def do_step(self, current_time: float, step_size: float) -> bool:
        return self._model.do_step(current_time, step_size)

    # FMU state: a small record, serialized to a validated, versioned layout ----------------------
    def _get_fmu_state(self) -> dict[str, Any]:
        try:
            return self._model.snapshot()
        except Exception as exc:  # reported when this state is set or serialized
            self._model.refuse(f"fmi2GetFMUstate failed: {exc!r}")
            return {"refused": f"fmi2GetFMUstate failed: {exc!r}"}

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        try:
            if "refused" in state:  # a blob that fmi2DeSerializeFMUstate could not read
                reason = state["refused"]
            else:
                self._model.restore(self.MODEL.CODEC.check_record(state))
                return
        except Exception as exc:
            reason = str(exc)
        self._model.refuse(f"fmi2SetFMUstate refused, the instance is unchanged: {reason}")

    @classmethod
    def _fmu_state_to_bytes(cls, state: dict[str, Any]) -> bytes:
        try:
            return cls.MODEL.CODEC.encode(state)
        except Exception as exc:  # refused with this reason when the bytes come back
            return cls.MODEL.CODEC.refused(repr(exc))

    @classmethod
    def _fmu_state_from_bytes(cls, blob: bytes) -> dict[str, Any]:
        try:
            return cls.MODEL.CODEC.decode(blob)
        except Exception as exc:  # refused, with the reason, by _set_fmu_state
            return {"refused": f"fmi2DeSerializeFMUstate: {exc}"}


def _ranges(numbers: list[int]) -> str:
    """Sorted integers as runs: [0, 1, 2, 5] -> "0-2, 5"."""
    runs: list[list[int]] = []
    for n in numbers:
        if runs and n == runs[-1][1] + 1:
            runs[-1][1] = n
        else:
            runs.append([n, n])
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in runs)
