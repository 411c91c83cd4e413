"""IceImpact: the FMI 2.0 Co-Simulation slave (PythonFMU) around :mod:`iceimpact`.

FMI plumbing only: the variables are registered from the contract table
(:mod:`iceimpact.contract`), every call is passed to :class:`iceimpact.fmi.adapter.FmuModel`,
which holds the life-cycle rules, and the FMU state is serialized by :mod:`iceimpact.fmi.state`.
The model core is bundled under ``resources/`` by ``build_fmu.py``.

No exception may leave a slave method: PythonFMU 0.7.0 turns it into ``fmi2Fatal`` and releases
the instance, and a later ``fmi2FreeInstance`` can then crash the host. Failures are logged
(variable, value, allowed range) and reported through ``do_step`` returning False
(``fmi2Discard``).
"""

from __future__ import annotations

from typing import Any

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

from iceimpact import contract
from iceimpact.fmi import state as fmu_state
from iceimpact.fmi.adapter import FmuModel
from iceimpact.fmi.pythonfmu_fixes import guard_native_exit, hold_module_dict
from iceimpact_fmu_boot import fail_call

hold_module_dict(globals())  # at each execution, should PythonFMU run this module itself

_TYPES = {float: Real, int: Integer, bool: Boolean}
_CAUSALITY = {contract.PARAMETER: Fmi2Causality.parameter, contract.INPUT: Fmi2Causality.input,
              contract.OUTPUT: Fmi2Causality.output}
_VARIABILITY = {contract.FIXED: Fmi2Variability.fixed, contract.TUNABLE: Fmi2Variability.tunable,
                contract.CONTINUOUS: Fmi2Variability.continuous,
                contract.DISCRETE: Fmi2Variability.discrete}
_EXPERIMENT = contract.DEFAULT_EXPERIMENT


class IceImpact(Fmi2Slave):
    """Flow-driven repeated ice impacts on a flexible structure (FMI 2.0 Co-Simulation)."""

    author = contract.AUTHOR
    description = contract.DESCRIPTION
    license = contract.LICENSE
    version = contract.VERSION
    default_experiment = DefaultExperiment(start_time=_EXPERIMENT.start_time,
                                           stop_time=_EXPERIMENT.stop_time,
                                           step_size=_EXPERIMENT.step_size)

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        guard_native_exit()
        self._model = FmuModel(self._log, fail=self._fail)
        for var in contract.VARIABLES:
            output = var.causality == contract.OUTPUT
            self.register_variable(_TYPES[var.kind](
                var.name, causality=_CAUSALITY[var.causality],
                variability=_VARIABILITY[var.variability], description=var.description,
                initial=Fmi2Initial.calculated if output else None,
                getter=self._getter(var.name), setter=None if output else self._setter(var.name)),
                nested=False)

    def _getter(self, name: str):
        return lambda: self._model.get(name)

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
            self._fail(f"fmi2GetFMUstate failed: {exc!r}")
            return {"refused": f"fmi2GetFMUstate failed: {exc!r}"}

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        try:
            if "refused" in state:  # a blob that fmi2DeSerializeFMUstate could not read
                reason = state["refused"]
            else:
                self._model.restore(fmu_state.check_record(state))
                return
        except Exception as exc:
            reason = str(exc)
        self._fail(f"fmi2SetFMUstate refused, the instance is unchanged: {reason}")

    @staticmethod
    def _fmu_state_to_bytes(state: dict[str, Any]) -> bytes:
        try:
            return fmu_state.encode(state)
        except Exception as exc:  # refused with this reason when the bytes come back
            return fmu_state.MAGIC + f"refused: {exc!r}".encode()

    @staticmethod
    def _fmu_state_from_bytes(blob: bytes) -> dict[str, Any]:
        try:
            return fmu_state.decode(blob)
        except Exception as exc:  # refused, with the reason, by _set_fmu_state
            return {"refused": f"fmi2DeSerializeFMUstate: {exc}"}

