"""IceImpact.fmu's behaviour, without PythonFMU: what each FMI call does to one instance.

:class:`FmuModel` is the FMI life cycle every FMU of the project follows
(:class:`~iceimpact.fmi.lifecycle.FmuLifecycle`: when parameters take effect, refusals, time and
step-size checks) around a :class:`~iceimpact.Simulator` built from the values, and adds what is
IceImpact's own:

- a tunable parameter takes effect from the next step (:data:`TUNERS`); a step refused because of
  it (or of the solver) is undone, tunables included, and the next valid step from the same time
  reports the whole interval's impulse;
- the first step that leaves the ice past the structure logs a warning naming the cause;
- the state is a small explicit record (:meth:`snapshot` / :meth:`restore`), serialized by
  :mod:`iceimpact.fmi.state`.

Messages go to the ``log(status, text)`` callback given at construction, with the FMI status
codes of :mod:`~iceimpact.fmi.lifecycle`; ``fail(text)`` reports an error that must make the FMI
call in progress return ``fmi2Error`` (the instance cannot step with its parameters, a fixed
parameter set after initialization). The slave (``fmu_src/IceImpact.py``) only forwards both to
the FMI library.
"""

from __future__ import annotations

from collections.abc import Callable
from operator import itemgetter
from typing import Any

from ..contract import (
    FLOW_INPUT,
    LOAD_LINEAR,
    MODE_LOAD_INPUTS,
    OUTPUTS,
    PARAMETERS,
    SCENE_VARIABLES,
    STRUCTURE_EXTERNAL,
    STRUCTURE_INPUTS,
    STRUCTURE_MODAL,
)
from ..errors import ParameterError, SolverError
from ..scene import Scene
from ..simulator import Simulator, StepReport
from . import state
from .lifecycle import ERROR, WARNING, FmuLifecycle

#: How each tunable parameter reaches a running simulator (a test checks every tunable
#: variable of the contract has one).
TUNERS: dict[str, Callable[[Simulator, Any], None]] = {
    "impact.e": Simulator.set_restitution,
}

#: Where each output stands in :attr:`FmuModel.published` (the contract's order).
_OUTPUT_SLOTS = {o.name: slot for slot, o in enumerate(OUTPUTS)}
_T_LAST = _OUTPUT_SLOTS["contact.t_last"]
#: The StepReport fields of the outputs, in the contract's order, read in one call.
_REPORT_ROW = itemgetter(*(o.field for o in OUTPUTS))

#: Parameters of the built-in structure that an external one (structure.model = 2) ignores.
IGNORED_WITH_EXTERNAL = ("structure.c", "structure.x0", "structure.v0")
#: Parameters of the SDOF structure that the modal one (structure.model = 3) ignores.
IGNORED_WITH_MODES = ("structure.m", "structure.c", "structure.k", "structure.x0", "structure.v0")
#: What each other structure ignores, what it is, and where its state comes from instead (the
#: warning of :meth:`FmuModel.build`).
IGNORED = {
    STRUCTURE_EXTERNAL: (IGNORED_WITH_EXTERNAL, "external structure", "the structure's state "
                         "comes from the inputs structure.x_in, structure.v_in, structure.a_in"),
    STRUCTURE_MODAL: (IGNORED_WITH_MODES, "modal structure",
                      "the structure is structure.modes modes, structure.mode<k>.*"),
}


class FmuModel(FmuLifecycle):
    """One IceImpact.fmu instance's values, simulator and life-cycle rules (no FMI library)."""

    PARAMETERS = PARAMETERS
    OUTPUTS = OUTPUTS
    CORE_NAME = "simulator"
    CODEC = state.CODEC

    def __init__(self, log: Callable[[int, str], None],
                 fail: Callable[[str], None] | None = None):
        super().__init__(log, fail)
        self.flow_u = float(FLOW_INPUT.start)
        #: the structure's inputs by name: the external structure's (structure.model = 2) and
        #: the modal structure's loads (3)
        self.structure_in: dict[str, Any] = {v.name: v.start
                                             for v in STRUCTURE_INPUTS + MODE_LOAD_INPUTS}
        self.sim: Simulator | None = None
        #: the mode loads given at the last step's start and its time (s): their rates with
        #: structure.load_order = 1 (None before a first step)
        self.loads_before: tuple[float, tuple[float, ...]] | None = None
        self.publish(Simulator(Scene()).report)
        self.penetration_logged = False

    # variables -----------------------------------------------------------------------------------
    @property
    def initialized(self) -> bool:
        return self.sim is not None

    def read(self, name: str) -> Any:
        slot = _OUTPUT_SLOTS.get(name)
        if slot is not None:
            return self.published[slot]
        if name == FLOW_INPUT.name:
            return self.flow_u
        return self.structure_in[name]

    def publish(self, report: StepReport) -> None:
        """Make ``report`` the outputs' values (:attr:`published`), contact.t_last in the
        master's time frame (-1 before the first impact)."""
        self.report = report
        row = _REPORT_ROW(report.__dict__)
        t = row[_T_LAST]
        # the report's value is already the output's with start time 0 (t + 0.0 is t for t > 0)
        # and before the first impact (-1.0): the row is then used as it is, at most steps
        if not ((t > 0.0 and self.start_time == 0.0) or t == -1.0):
            row = list(row)
            row[_T_LAST] = t + self.start_time if t >= 0.0 else -1.0
        self.published = row

    def write_input(self, name: str, value: Any) -> bool:
        if name == FLOW_INPUT.name:
            self.flow_u = value
        elif name in self.structure_in:
            self.structure_in[name] = value  # checked by the next doStep
        else:
            return False
        return True

    # life cycle ----------------------------------------------------------------------------------
    def build(self) -> None:
        scene = Scene.from_fmi({**self.values, FLOW_INPUT.name: self.flow_u})
        sim = Simulator(scene, record_impacts=False)
        self.sim = sim
        self.loads_before = None
        self.publish(sim.report)
        self.penetration_logged = False
        ignores = IGNORED.get(scene.structure_model)
        if ignores is not None:
            names, what, instead = ignores
            ignored = [f"{name} = {self.values[name]!r}" for name in names
                       if self.values[name] != SCENE_VARIABLES[name].start]
            if ignored:
                self._log(WARNING, f"structure.model = {scene.structure_model} ({what}): "
                          f"{', '.join(ignored)} ignored; {instead}")

    def advance(self, current_time: float, step_size: float) -> bool:
        sim = self.sim
        pending = self.pending
        before = sim.save() if pending else None
        try:
            if pending:
                for name, value in pending.items():
                    TUNERS[name](sim, value)
            structure = (tuple(self.structure_in[v.name] for v in STRUCTURE_INPUTS)
                         if sim.external else None)
            given = tuple(self.structure_in[v.name] for v in MODE_LOAD_INPUTS)
            n = sim.scene.structure_modes
            loads = given[:n] if sim.modal else None
            rates = (self.load_rates(current_time, given)[:n]
                     if sim.modal and sim.scene.structure_load_order == LOAD_LINEAR else None)
            if self.early_return:
                # to the master's point itself, so that the steps after an early return end
                # on the master's grid (sim.t + step_size may differ from it by rounding)
                end = current_time + step_size - self.start_time
                report = sim.advance_to(end, self.flow_u, structure, stop_at_event=True,
                                        loads=loads, load_rates=rates)
                if report.t != end:
                    self.returned_at = report.t + self.start_time
            else:
                report = sim.advance(step_size, self.flow_u, structure, loads=loads,
                                     load_rates=rates)
        except (ParameterError, SolverError) as exc:
            if before is not None:
                sim.restore(before)  # the tunables applied before the refusal are undone
            self._log(ERROR, f"doStep at t = {current_time!r} s: {exc}")
            return False
        if pending:
            self.values.update(pending)
            pending.clear()
        if sim.modal:
            self.loads_before = (current_time, given)
        self.publish(report)
        if report.penetration > 0.0 and not self.penetration_logged:
            self.penetration_logged = True
            self._log(WARNING, f"doStep at t = {current_time!r} s: the ice is "
                      f"{report.penetration:.3g} m past the structure (contact.penetration): "
                      f"{sim.penetration_cause}; solver.method = 1 locates every impact exactly "
                      "(logged once)")
        return True

    def load_rates(self, t: float, loads: tuple[float, ...]) -> tuple[float, ...]:
        """The mode loads' rates (N/s) for a step from t with the loads given now: their change
        since the last step's start over the time between (0 for the first step, or a step from
        the same time)."""
        before = self.loads_before
        if before is None or not t > before[0]:
            return (0.0,) * len(loads)
        span = t - before[0]
        return tuple((now - then) / span for now, then in zip(loads, before[1], strict=True))

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
            "loads_before": (None if self.loads_before is None
                             else [self.loads_before[0], list(self.loads_before[1])]),
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
        before = record["loads_before"]
        self.loads_before = None if before is None else (before[0], tuple(before[1]))
        self.sim = sim
        self.publish(sim.report if sim is not None else Simulator(Scene()).report)
