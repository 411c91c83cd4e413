"""The FMI life cycle shared by the project's FMUs, without PythonFMU.

:class:`FmuLifecycle` holds the values a master set and the rules every FMU follows; a model
(:class:`iceimpact.fmi.adapter.FmuModel` for IceImpact.fmu,
:class:`iceimpact.modal.fmu.ModalFmuModel` for ModalStructure.fmu) adds what it builds from the
values (its *core*), its input and outputs, what one step does, and its state record:

- parameters take effect at exitInitializationMode (or at the first doStep if a master skips
  initialization); a fixed parameter set afterwards is refused and not stored, so that fmi2Get
  returns the value in use; a tunable one is held in :attr:`~FmuLifecycle.pending` until the next
  step takes it;
- a start time that is not a finite number, or parameters the core refuses, are logged (name,
  value, allowed range) and every doStep is then refused with fmi2Error (the ``fail`` callback)
  and the same message;
- a step size that is not finite and > 0, or a communication point other than the end of the last
  step, is refused (fmi2Discard, a False return) and changes nothing, as is a step the model
  refuses;
- no exception leaves :meth:`~FmuLifecycle.do_step`.

Messages go to the ``log(status, text)`` callback with the FMI status codes below; ``fail(text)``
reports an error that must make the FMI call in progress return ``fmi2Error``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from ..contract import Variable
from ..errors import ParameterError
from .state_codec import StateCodec

# FMI 2.0 status codes used in log messages.
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3

#: A master's communication point may differ from the sum of the step sizes by rounding only.
TIME_RTOL = 1e-9
_INF = math.inf

#: What the FMI 3.0 layer (fmu_native/fmi3.c) sets and reads beside the contract's variables:
#: whether steps return at impacts (fmi3InstantiateCoSimulation's earlyReturnAllowed), and the
#: time the last step reached (its lastSuccessfulTime).
EARLY_RETURN = "fmi3.earlyReturnAllowed"
REACHED_TIME = "fmi3.lastSuccessfulTime"


class FmuLifecycle:
    """One FMU instance's values and life-cycle rules (no FMI library involved).

    A model sets the class attributes and implements the hooks marked below.
    """

    #: The contract's parameters (their start values are the values before any fmi2Set).
    PARAMETERS: tuple[Variable, ...] = ()
    #: The contract's outputs, in the order of :attr:`published`.
    OUTPUTS: tuple[Variable, ...] = ()
    #: What :meth:`build` makes from the values, as messages name it ("simulator").
    CORE_NAME = "model"
    #: The layout of this FMU's serialized state.
    CODEC: StateCodec

    def __init__(self, log: Callable[[int, str], None],
                 fail: Callable[[str], None] | None = None):
        self._log = log
        self._fail = fail if fail is not None else (lambda text: log(ERROR, text))
        self._tunable = {p.name for p in self.PARAMETERS if p.tunable}
        self.values: dict[str, float | int] = {p.name: p.start for p in self.PARAMETERS}
        self.start_time = 0.0
        self.time = 0.0
        self.pending: dict[str, Any] = {}   # tunable values set since the last step
        self.error: str | None = None       # why the instance cannot step
        #: The outputs' values in the order of :attr:`OUTPUTS` (a list or tuple), for a model
        #: that keeps them ready (refreshed whenever they change; the FMU reads them at every
        #: step without a call per variable); None: every output is read through :meth:`get`.
        self.published: Sequence[Any] | None = None
        #: Steps end at the first impact in them (FMI 3.0's early return); see :meth:`do_step`.
        self.early_return = False
        #: Where the step in progress returned early (set by :meth:`advance`), else None.
        self.returned_at: float | None = None

    # hooks of a model ----------------------------------------------------------------------------
    @property
    def initialized(self) -> bool:
        """True once :meth:`build` succeeded (the core exists)."""
        raise NotImplementedError

    def read(self, name: str) -> Any:
        """The value of the input or an output."""
        raise NotImplementedError

    def write_input(self, name: str, value: Any) -> bool:
        """Store ``value`` if ``name`` is the input (True), else False."""
        raise NotImplementedError

    def build(self) -> None:
        """Make the core from :attr:`values`; raise ParameterError naming a bad value, and change
        nothing then."""
        raise NotImplementedError

    def advance(self, current_time: float, step_size: float) -> bool:
        """One step from the checked ``current_time``, taking :attr:`pending`; False (after
        logging why) refuses it and changes nothing. With :attr:`early_return` a model may end
        the step at an event before its end: it then sets :attr:`returned_at` to that time."""
        raise NotImplementedError

    # variables -----------------------------------------------------------------------------------
    def get(self, name: str) -> Any:
        """The value of a parameter, the input or an output."""
        if name in self.values:
            return self.pending.get(name, self.values[name])
        if name == REACHED_TIME:
            return self.time
        return self.read(name)

    def set(self, name: str, value: Any) -> None:
        """fmi2Set of a parameter or the input; validated when it takes effect."""
        if self.write_input(name, value):
            return
        if name == EARLY_RETURN:
            self.early_return = bool(value)
            return
        if not self.initialized:
            self.values[name] = value
        elif name in self._tunable:
            self.pending[name] = value  # validated and applied by the next doStep
        else:
            self.refuse(f"{name} is a fixed parameter: setting it to {value!r} after "
                        "initialization is refused and the value in use, "
                        f"{self.values[name]!r}, is kept (use fmi2Reset to change it)")

    def refuse(self, text: str) -> None:
        """Report a refused call (a fixed parameter set after initialization, a state that does
        not fit): logged as an error, and the FMI call returns fmi2Error (``fail``)."""
        self._fail(text)

    # life cycle ----------------------------------------------------------------------------------
    def setup_experiment(self, start_time: Any) -> None:
        if isinstance(start_time, int | float) and math.isfinite(start_time):
            self.start_time = self.time = float(start_time)
        else:
            self.error = f"start time = {start_time!r} is not allowed: a finite number of seconds"
            self._log(ERROR, self.error)

    def initialize(self, where: str = "exitInitializationMode") -> bool:
        """Build the core from the values; on failure log why and remember it."""
        if self.error is not None:
            return False
        try:
            self.build()
        except ParameterError as exc:
            self.error = f"{where}: {exc}"
        except Exception as exc:  # a defect in the core must not kill the host
            self.error = f"{where}: cannot create the {self.CORE_NAME}: {exc!r}"
        else:
            self.pending.clear()
            return True
        self._log(ERROR, self.error + "; the FMU will not step (fmi2Error) until the "
                  "parameter is corrected after fmi2Reset")
        return False

    def do_step(self, current_time: float, step_size: float) -> bool:
        """One communication step; False (fmi2Discard) refuses it and changes nothing."""
        try:
            if not self.initialized and not self.initialize("doStep"):
                self._fail(f"doStep refused: {self.error}")
                return False
            if not 0.0 < step_size < _INF:  # finite and > 0 (NaN fails it)
                self._log(ERROR, f"doStep: communication step size = {step_size!r} s is not "
                          "allowed: finite and > 0")
                return False
            now = self.time
            scale = now if now >= 1.0 else (-now if now <= -1.0 else 1.0)  # max(1, |now|)
            if not (-_INF < current_time < _INF
                    and abs(current_time - now) <= TIME_RTOL * scale):
                self._log(ERROR, f"doStep: current communication point = {current_time!r} s "
                          f"does not match the time of the FMU, {self.time!r} s (the end of the "
                          "last step)")
                return False
            self.returned_at = None
            if not self.advance(current_time, step_size):
                return False
            returned_at = self.returned_at
            self.time = current_time + step_size if returned_at is None else returned_at
            return True
        except Exception as exc:  # never let an exception reach the FMI library
            self._log(ERROR, f"doStep at t = {current_time!r} s failed: {exc!r}")
            return False
