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

Only slaves import this module (it needs PythonFMU); they import it as ``iceimpact.fmi...``,
which inside an FMU is the FMU's private copy of the core (``iceimpact_fmu_boot``).
"""

from __future__ import annotations

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

from iceimpact_fmu_boot import fail_call

from ..contract import CONTINUOUS, DISCRETE, FIXED, INPUT, OUTPUT, PARAMETER, TUNABLE
from .lifecycle import FmuLifecycle
from .pythonfmu_fixes import guard_native_exit

_TYPES = {float: Real, int: Integer, bool: Boolean}
_CAUSALITY = {PARAMETER: Fmi2Causality.parameter, INPUT: Fmi2Causality.input,
              OUTPUT: Fmi2Causality.output}
_VARIABILITY = {FIXED: Fmi2Variability.fixed, TUNABLE: Fmi2Variability.tunable,
                CONTINUOUS: Fmi2Variability.continuous, DISCRETE: Fmi2Variability.discrete}


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

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        guard_native_exit()
        self._model = self.MODEL(self._log, fail=self._fail)
        for var in self.CONTRACT.VARIABLES:
            output = var.causality == OUTPUT
            self.register_variable(_TYPES[var.kind](
                var.name, causality=_CAUSALITY[var.causality],
                variability=_VARIABILITY[var.variability], description=var.description,
                initial=Fmi2Initial.calculated if output else None,
                getter=self._model.getter(var.name),
                setter=None if output else self._setter(var.name)),
                nested=False)

    def _setter(self, name: str):
        return lambda value: self._model.set(name, value)

    def _log(self, status: int, message: str) -> None:
        # FMI loggers treat the message as a printf format string
        self.log(message.replace("%", "%%"), Fmi2Status(status))

    def _fail(self, message: str) -> None:
        """Log an error and make the FMI call in progress return fmi2Error."""
        fail_call(self, message.replace("%", "%%"))

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
