"""The FMU's behaviour, without PythonFMU: what each FMI call does to one instance.

:class:`FmuModel` holds the values the master set, the :class:`~iceimpact.Simulator` built from
them, and the rules of the FMI life cycle:

- parameters take effect at exitInitializationMode (or at the first doStep if a master skips
  initialization); a fixed parameter set afterwards is refused and not stored, so that
  fmi2Get returns the value the simulation uses; a tunable one takes effect from the next step;
- a step is refused (fmi2Discard) with a message naming the variable, its value and the allowed
  range, and then changes nothing: the next valid step from the same time reports the whole
  interval's impulse;
- the state is a small explicit record (:meth:`snapshot` / :meth:`restore`), serialized by
  :mod:`iceimpact.fmi.state`.

Messages go to the ``log(status, text)`` callback given at construction, with the FMI status
codes below; ``fail(text)`` reports an error that must make the FMI call in progress return
``fmi2Error`` (the instance cannot step with its parameters, a fixed parameter set after
initialization). The slave (``fmu_src/IceImpact.py``) only forwards both to the FMI library.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ..contract import FLOW_INPUT, OUTPUTS, PARAMETERS, SCENE_VARIABLES, STRUCTURE_INPUTS
from ..scene import ParameterError, Scene
from ..simulator import Simulator, StepReport
from ..solvers.base import SolverError

# FMI 2.0 status codes used in log messages.
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3

#: A master's communication point may differ from the sum of the step sizes by rounding only.
TIME_RTOL = 1e-9

#: How each tunable parameter reaches a running simulator (a test checks every tunable
#: variable of the contract has one).
TUNERS: dict[str, Callable[[Simulator, Any], None]] = {
    "impact.e": Simulator.set_restitution,
}

_OUTPUT_FIELDS = {o.name: o.field for o in OUTPUTS}

#: Parameters of the built-in structure that an external one (structure.model = 2) ignores.
IGNORED_WITH_EXTERNAL = ("structure.c", "structure.x0", "structure.v0")


class FmuModel:
    """One FMU instance's values, simulator and life-cycle rules (no FMI library involved)."""

    def __init__(self, log: Callable[[int, str], None],
                 fail: Callable[[str], None] | None = None):
        self._log = log
        self._fail = fail if fail is not None else (lambda text: log(ERROR, text))
        self.values: dict[str, float | int] = {v.name: v.start for v in PARAMETERS}
        self.flow_u = float(FLOW_INPUT.start)
        #: the external structure's inputs (structure.model = 2), by name
        self.structure_in: dict[str, Any] = {v.name: v.start for v in STRUCTURE_INPUTS}
        self.sim: Simulator | None = None
        self.report: StepReport = Simulator(Scene()).report
        self.start_time = 0.0
        self.time = 0.0
        self.pending: dict[str, Any] = {}   # tunable values set since the last step
        self.error: str | None = None       # why the instance cannot step
        self.penetration_logged = False

    # variables -----------------------------------------------------------------------------------
    def get(self, name: str) -> Any:
        """The value of a parameter, the input or an output."""
        if name in self.values:
            return self.pending.get(name, self.values[name])
        if name == FLOW_INPUT.name:
            return self.flow_u
        if name in self.structure_in:
            return self.structure_in[name]
        if name == "contact.t_last":  # in the master's time frame
            t = self.report.t_last
            return t + self.start_time if t >= 0.0 else -1.0
        return getattr(self.report, _OUTPUT_FIELDS[name])

    def set(self, name: str, value: Any) -> None:
        """fmi2Set of a parameter or the input; validated when it takes effect."""
        if name == FLOW_INPUT.name:
            self.flow_u = value
        elif name in self.structure_in:
            self.structure_in[name] = value  # checked by the next doStep
        elif self.sim is None:
            self.values[name] = value
        elif SCENE_VARIABLES[name].tunable:
            self.pending[name] = value  # validated and applied by the next doStep
        else:
            self._fail(f"{name} is a fixed parameter: setting it to {value!r} after "
                       "initialization is refused and the value in use, "
                       f"{self.values[name]!r}, is kept (use fmi2Reset to change it)")

    # life cycle ----------------------------------------------------------------------------------
    def setup_experiment(self, start_time: Any) -> None:
        if isinstance(start_time, int | float) and math.isfinite(start_time):
            self.start_time = self.time = float(start_time)
        else:
            self.error = f"start time = {start_time!r} is not allowed: a finite number of seconds"
            self._log(ERROR, self.error)

    def initialize(self, where: str = "exitInitializationMode") -> bool:
        """Build the simulator from the values; on failure log why and remember it."""
        if self.error is not None:
            return False
        try:
            scene = Scene.from_fmi({**self.values, FLOW_INPUT.name: self.flow_u})
            sim = Simulator(scene, record_impacts=False)
        except ParameterError as exc:
            self.error = f"{where}: {exc}"
        except Exception as exc:  # a defect in the core must not kill the host
            self.error = f"{where}: cannot create the simulator: {exc!r}"
        else:
            self.sim, self.report = sim, sim.report
            self.pending.clear()
            self.penetration_logged = False
            if scene.external:
                ignored = [f"{name} = {self.values[name]!r}" for name in IGNORED_WITH_EXTERNAL
                           if self.values[name] != SCENE_VARIABLES[name].start]
                if ignored:
                    self._log(WARNING, f"{where}: structure.model = 2 (external structure): "
                              f"{', '.join(ignored)} ignored; the structure's state comes from "
                              "the inputs structure.x_in, structure.v_in, structure.a_in")
            return True
        self._log(ERROR, self.error + "; the FMU will not step (fmi2Error) until the "
                  "parameter is corrected after fmi2Reset")
        return False

    def do_step(self, current_time: float, step_size: float) -> bool:
        """One communication step; False (fmi2Discard) refuses it and changes nothing."""
        try:
            return self._do_step(current_time, step_size)
        except Exception as exc:  # never let an exception reach the FMI library
            self._log(ERROR, f"doStep at t = {current_time!r} s failed: {exc!r}")
            return False

    def _do_step(self, current_time: float, step_size: float) -> bool:
        if self.sim is None and not self.initialize("doStep"):
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
        sim = self.sim
        before = sim.save() if self.pending else None
        try:
            for name, value in self.pending.items():
                TUNERS[name](sim, value)
            report = sim.advance(step_size, self.flow_u,
                                 tuple(self.structure_in[v.name] for v in STRUCTURE_INPUTS))
        except (ParameterError, SolverError) as exc:
            if before is not None:
                sim.restore(before)  # the tunables applied before the refusal are undone
            self._log(ERROR, f"doStep at t = {current_time!r} s: {exc}")
            return False
        self.values.update(self.pending)
        self.pending.clear()
        self.report = report
        self.time = current_time + step_size
        if report.penetration > 0.0 and not self.penetration_logged:
            self.penetration_logged = True
            self._log(WARNING, f"doStep at t = {current_time!r} s: the ice is "
                      f"{report.penetration:.3g} m past the structure (contact.penetration): "
                      f"{sim.penetration_cause}; solver.method = 1 locates every impact exactly "
                      "(logged once)")
        return True

    # state ---------------------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """Everything the future of this instance depends on, as plain data (no history)."""
        return {
            "values": dict(self.values),
            "flow_u": self.flow_u,
            "structure_in": dict(self.structure_in),
            "start_time": self.start_time,
            "time": self.time,
            "pending": dict(self.pending),
            "error": self.error,
            "penetration_logged": self.penetration_logged,
            "simulator": self.sim.save() if self.sim is not None else None,
        }

    def restore(self, record: dict[str, Any]) -> None:
        """Return to a :meth:`snapshot` (validated by :func:`iceimpact.fmi.state.check_record`);
        raises StateError and changes nothing if the simulator part is not sound."""
        sim = (Simulator.from_snapshot(record["simulator"], record_impacts=False)
               if record["simulator"] is not None else None)
        self.values = dict(record["values"])
        self.flow_u = record["flow_u"]
        self.structure_in = dict(record["structure_in"])
        self.start_time = record["start_time"]
        self.time = record["time"]
        self.pending = dict(record["pending"])
        self.error = record["error"]
        self.penetration_logged = record["penetration_logged"]
        self.sim = sim
        self.report = sim.report if sim is not None else Simulator(Scene()).report
