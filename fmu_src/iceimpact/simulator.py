"""Stepping API and direct runs: what the FMU, the CLI and scripts call.

Two levels, like FMPy's ``simulate_fmu`` over ``FMU2Slave``:

- :class:`Simulator`: ``advance(h, u)`` over one communication step with the flow speed held
  constant (zero-order hold), returning a :class:`StepReport`; ``save``/``restore`` for roll-back
  (a small record of plain data, see :meth:`Simulator.save`). A step the method refuses changes
  nothing.
- :func:`run`: a whole simulation at constant flow, returning a :class:`Result` with the impact
  list and the states sampled at requested times, as numpy arrays.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from itertools import chain
from typing import Any

import numpy as np

from .contract import MAX_MODES, MODE_LOAD_INPUTS, SCENE_VARIABLES, STRUCTURE_INPUTS
from .errors import NonFiniteError, ParameterError, SolverError, StateError, checked_real
from .record import STATE_VERSION, Record, check_version
from .scene import METHOD_EXACT, METHOD_FIXED_STEP, METHOD_ODE, Scene, validate_flow
from .solvers.base import GAP_ROUNDING, Impact, Samples, Solver
from .solvers.exact import EventSolver, ExternalSolver, ModalSolver
from .solvers.fixed_step import FixedStepSolver
from .solvers.fixed_step_modal import ModalFixedStepSolver
from .solvers.impact_log import ImpactLog
from .solvers.ode import OdeSolver
from .solvers.ode_modal import ModalOdeSolver

_SOLVERS: dict[int, type[Solver]] = {METHOD_EXACT: EventSolver, METHOD_FIXED_STEP: FixedStepSolver,
                                     METHOD_ODE: OdeSolver}
#: the methods with the modal structure (structure.model = 3)
_MODAL_SOLVERS: dict[int, type[Solver]] = {METHOD_EXACT: ModalSolver,
                                           METHOD_FIXED_STEP: ModalFixedStepSolver,
                                           METHOD_ODE: ModalOdeSolver}
_INF = math.inf
_RESTITUTION = SCENE_VARIABLES["impact.e"]  # the tunable parameter of set_restitution


def _positive(value: float) -> bool:
    return value > 0.0


def make_solver(scene: Scene, record_impacts: bool = True) -> Solver:
    """The solver object for ``scene.solver_method`` (``record_impacts``: keep the impact list);
    with an external structure (structure.model = 2, method 1 only) :class:`ExternalSolver`."""
    if scene.external:
        return ExternalSolver(scene, record_impacts)
    if scene.modal and scene.solver_method in _MODAL_SOLVERS:
        return _MODAL_SOLVERS[scene.solver_method](scene, record_impacts)
    try:
        cls = _SOLVERS[scene.solver_method]
    except KeyError:
        raise ParameterError("solver.method", scene.solver_method,
                             "1 (exact), 2 (fixed-step) or 3 (ODE)") from None
    return cls(scene, record_impacts)


def reported_gap(gap):
    """(gap, penetration) as reported from x - z (m, a float or an array): a negative x - z is
    reported as a zero gap, and as a penetration beyond the rounding of contact
    (``GAP_ROUNDING``)."""
    if isinstance(gap, np.ndarray):
        reported = gap.copy()
        reported[gap < 0.0] = 0.0
        penetration = np.zeros_like(gap)
        inside = gap <= -GAP_ROUNDING  # (rare: a mask, not a full array of -gap)
        penetration[inside] = -gap[inside]
        return reported, penetration
    if gap < 0.0:
        return 0.0, (-gap if gap <= -GAP_ROUNDING else 0.0)
    return gap, 0.0


@dataclass(frozen=True)
class StepReport:
    """Outputs at the end of one communication step (the FMU's outputs, SI units)."""

    t: float             # s
    x: float             # structure displacement, m
    v: float             # structure velocity, m/s
    z: float             # ice displacement, m
    w: float             # ice velocity, m/s
    gap: float           # x - z, m, >= 0 (0 while the ice is past the structure)
    penetration: float   # z - x when the ice is past the structure, else 0, m (methods 2, 3)
    impulse: float       # impulse on the structure during the step (impacts + sticking), N.s
    force: float         # impulse / h, mean contact force over the step, N
    impacts: int         # impacts during the step
    impact_count: int    # impacts since the start
    t_last: float        # time of the latest impact, s (-1 before the first)
    sticking: bool       # bodies stick together at the end of the step
    spring_force: float  # k x, the structure's spring force (base shear of the SDOF), N; k_c x
    #                      with the modal structure (Scene.contact_stiffness); 0 with an
    #                      external structure (its forces live in the other FMU)
    coupling_force: float  # the force for the master to hold on an external structure over its
    #                        next step, N (= force, but with a Jacobi master while riding)
    mode1_q: float = 0.0  # modal structure (structure.model = 3): mode 1's q_k, m (0: none)
    mode1_v: float = 0.0  # and q_k', m/s
    mode2_q: float = 0.0  # modal structure (structure.model = 3): mode 2's q_k, m (0: none)
    mode2_v: float = 0.0  # and q_k', m/s
    mode3_q: float = 0.0  # modal structure (structure.model = 3): mode 3's q_k, m (0: none)
    mode3_v: float = 0.0  # and q_k', m/s
    mode4_q: float = 0.0  # modal structure (structure.model = 3): mode 4's q_k, m (0: none)
    mode4_v: float = 0.0  # and q_k', m/s
    mode5_q: float = 0.0  # modal structure (structure.model = 3): mode 5's q_k, m (0: none)
    mode5_v: float = 0.0  # and q_k', m/s


_REPORT_FIELDS = tuple(f.name for f in fields(StepReport))


def _new_report(values: dict[str, Any]) -> StepReport:
    """A StepReport from all its fields by name, without the frozen dataclass's per-field
    ``object.__setattr__`` (a fifth of a step's cost in an FMU); tests check it equals
    ``StepReport(**values)``."""
    report = object.__new__(StepReport)
    report.__dict__.update(values)
    return report


_REAL_REPORT_FIELDS = tuple(f.name for f in fields(StepReport) if f.type == "float")
_REPORT_COUNTS = ("impacts", "impact_count")
_SAVE_KEYS = ("version", "scene", "solver", "report", "reported_impacts", "failed")


def _read_report(rec: Record) -> StepReport:
    """A validated :class:`StepReport` from its record in a saved state."""
    rec.expect_keys(_REPORT_FIELDS)
    values: dict[str, Any] = {}
    for name in _REPORT_FIELDS:
        if name in _REPORT_COUNTS:
            values[name] = rec.integer(name, low=0)
        elif name == "sticking":
            values[name] = rec.flag(name)
        else:  # outputs only: any real number, the future does not depend on them
            values[name] = rec.real(name, finite=False)
    return StepReport(**values)


#: The modal outputs of a scene without the modal structure.
_NO_MODES = {f"mode{k}_{quantity}": 0.0 for k in range(1, MAX_MODES + 1) for quantity in "qv"}


def _modal_row(report: StepReport, n: int) -> list[float]:
    """A report's modal state (q_1..q_n, q_1'..q_n')."""
    return ([getattr(report, f"mode{k}_q") for k in range(1, n + 1)]
            + [getattr(report, f"mode{k}_v") for k in range(1, n + 1)])


def _modal_outputs(solver: Any) -> dict[str, float]:
    """The modes' q_k and q_k' at the solver's time (modes not used: 0)."""
    q, p = solver.modal_state()
    out = dict(_NO_MODES)
    for k, (qk, pk) in enumerate(zip(q, p, strict=True), start=1):
        out[f"mode{k}_q"], out[f"mode{k}_v"] = qk, pk
    return out


class Simulator:
    """Marches one scene step by step: ``advance(h, u)`` is one communication step.

    ``record_impacts=False`` keeps no impact list (``impacts`` stays empty; the counters and
    the reports are unchanged), so that memory stays flat over any number of steps.
    """

    def __init__(self, scene: Scene, record_impacts: bool = True):
        self.scene = scene
        self.external = scene.external  # structure.model = 2: the structure is in another FMU
        self.modal = scene.modal  # structure.model = 3: the built-in modal structure
        self._stiffness = scene.contact_stiffness  # structure.force's k (summed once: modal)
        self.record_impacts = record_impacts
        self.solver = make_solver(scene, record_impacts)
        self._n_reported = 0  # impacts already reported (an impact at t = 0 goes to step 1)
        self.failed: str | None = None  # why the latest step was refused by the method, if it was
        self._flow_checked: tuple[float, Scene | None] = (math.nan, None)  # the last valid u
        self.report = self._report(0.0, 0.0)

    @property
    def t(self) -> float:
        return self.solver.t

    @property
    def impacts(self) -> list[Impact]:
        """The impacts recorded (all of them for a simulator that recorded from the start)."""
        return self.solver.impacts

    @property
    def impact_count(self) -> int:
        return self.solver.impact_count

    @property
    def penetration_cause(self) -> str:
        """Why the method can leave the ice past the structure (see StepReport.penetration)."""
        return self.solver.penetration_cause

    @property
    def sticking(self) -> bool:
        return self.solver.sticking

    @property
    def sticking_since(self) -> float | None:
        """Start of the current sticking phase, s (None while the bodies are apart)."""
        return self.solver.sticking_since

    def advance(self, h: float, u: float | None = None,
                structure: tuple[float, float, float] | None = None,
                stop_at_event: bool = False, loads: Any = None,
                load_rates: Any = None) -> StepReport:
        """Advance by the communication step ``h`` (s) with flow speed ``u`` (m/s) held constant.

        ``u`` defaults to the scene's ``flow.u``. With an external structure (structure.model =
        2), ``structure`` is ``(x_in, v_in, a_in)``, the contact point's displacement (m),
        velocity (m/s) and acceleration (m/s2, 0 = not given) at the start of the step; it
        defaults to the scene's start values of those inputs (ignored with the built-in
        structure). With the modal structure (structure.model = 3), ``loads`` are the modes'
        generalized loads (N, one per mode used) at the step's start, held over the step, or
        changing at ``load_rates`` (N/s, one per mode; method 1 only) over it; they default to
        the scene's structure.mode<k>.load. Raises :class:`ParameterError` for a step that
        is not a positive finite number, too small to advance the time (t + h == t), or a flow
        speed that is not finite, and :class:`SolverError` when the method cannot go on. Either
        way the simulator is exactly as before the call: a later step from the same time
        reports the whole impulse of its interval. A step the method refused is refused again
        for the same input.

        With ``stop_at_event`` (methods 1 and 3; method 2 and a Jacobi-coupled external
        structure always step to the end) the step ends at the first contact event before
        ``t + h``: an impact, or the ice leaving the structure it rode on. The report is then
        the state just after it, at ``report.t`` (an impact's impulse included), and the next
        step goes on from there as the whole step would have (FMI 3.0's early return).
        """
        if not (h.__class__ is float and 0.0 < h < _INF):  # (the fast path: a valid float)
            h = checked_real("communication step", h, "a finite number > 0 (s)", _positive)
        t = self.solver.t
        t_end = t + h
        if not t_end > t:
            raise ParameterError("communication step", h, f"a step that advances the time "
                                 f"t = {t!r} s: t + h > t (smaller steps are lost to rounding)")
        return self._step(t_end, h, u, structure, stop_at_event, loads, load_rates)

    def advance_to(self, t_end: float, u: float | None = None,
                   structure: tuple[float, float, float] | None = None,
                   stop_at_event: bool = False, loads: Any = None,
                   load_rates: Any = None) -> StepReport:
        """Advance to the communication point ``t_end`` (s, > t), as :meth:`advance`."""
        t = self.solver.t
        if not (t_end.__class__ is float and t < t_end < _INF):
            t_end = checked_real("communication point", t_end, f"a finite time > t = {t!r} s",
                                 lambda value: value > t)
        return self._step(t_end, t_end - t, u, structure, stop_at_event, loads, load_rates)

    def _mode_loads(self, loads: Any, name: str = "loads",
                    unit: str = "N") -> tuple[float, ...] | None:
        """The modal structure's generalized loads of a step (N), or their rates (N/s), checked:
        one finite real number per mode used (structure.modes); None: the scene's
        structure.mode<k>.load (for rates: held)."""
        if loads is None:
            return self.scene.mode_loads if name == "loads" else None
        n = self.scene.structure_modes
        if (not isinstance(loads, tuple | list | np.ndarray) or getattr(loads, "ndim", 1) != 1
                or len(loads) != n):
            raise ParameterError(name, loads, f"one value ({unit}) per mode used: {n} "
                                 "(structure.modes)")
        return tuple(checked_real(spec.name + ("" if name == "loads" else " rate"), value,
                                  f"a finite real number ({unit})")
                     for spec, value in zip(MODE_LOAD_INPUTS, loads, strict=False))

    def _structure_inputs(self, structure: Any) -> tuple[float, float, float]:
        """The external structure's inputs of a step, checked: a tuple, list or 1-d array of
        three finite real numbers (Python or numpy), returned as Python floats."""
        if structure is None:
            return tuple(getattr(self.scene, v.field) for v in STRUCTURE_INPUTS)
        if (not isinstance(structure, tuple | list | np.ndarray)
                or getattr(structure, "ndim", 1) != 1 or len(structure) != len(STRUCTURE_INPUTS)):
            raise ParameterError("structure inputs", structure, "(x_in, v_in, a_in)")
        return tuple(checked_real(spec.name, value, f"a finite real number ({spec.unit})")
                     for spec, value in zip(STRUCTURE_INPUTS, structure, strict=True))

    def _step(self, t_end: float, h: float, u: float | None,
              structure: Any = None, stop_at_event: bool = False,
              loads: Any = None, load_rates: Any = None) -> StepReport:
        if u is None:
            u = self.scene.flow_u
        elif not (u.__class__ is float and u == self._flow_checked[0]
                  and self._flow_checked[1] is self.scene):
            u = validate_flow(u, self.scene)
            self._flow_checked = (u, self.scene)  # the same speed is not checked again
        inputs = self._structure_inputs(structure) if self.external else None
        mode_loads = self._mode_loads(loads) if self.modal else None
        mode_rates = self._mode_loads(load_rates, "load_rates", "N/s") if self.modal else None
        solver = self.solver
        checkpoint = solver.checkpoint()
        try:
            if inputs is not None:
                solver.inputs = inputs
            if mode_loads is not None:
                solver.set_loads(mode_loads, mode_rates)
            solver.begin_step()
            if stop_at_event:
                t_start = solver.state.t
                impulse = solver.advance_to(t_end, u, True)
                if solver.state.t != t_end:  # returned at an impact
                    h = solver.state.t - t_start
            else:
                impulse = solver.advance_to(t_end, u)
            report = self._report(impulse, h)
            # never let NaN or inf reach an output (the sum is finite when they all are, save
            # for an overflow of the sum itself, which the field-by-field test then clears)
            if not math.isfinite(report.t + report.x + report.v + report.z + report.w + report.gap
                                 + report.penetration + report.impulse + report.force
                                 + report.t_last + report.spring_force):
                check_finite({name: getattr(report, name) for name in _REAL_REPORT_FIELDS},
                             np.array([t_end]))
        except BaseException as exc:
            solver.rollback(checkpoint)  # a refused step changes nothing
            if isinstance(exc, SolverError):
                self.failed = stopped(self.solver.t, t_end, exc)
                raise SolverError(self.failed) from exc
            raise
        finally:
            solver.end_step()  # (no impact budget outside the step)
        self.failed = None
        self.report = report
        self._n_reported = solver.impact_count
        return report

    def _report(self, impulse: float, h: float) -> StepReport:
        solver = self.solver
        s = solver.state
        # Method 1 keeps x - z >= 0 up to rounding; method 3 up to its integration error (atol
        # = 1e-3 rtol m). The fixed-step scheme (method 2) tests impacts on grid points only,
        # so the ice can be up to one step's closing distance past the structure, or pass
        # through it when its eq. 26 window misses an impact. A negative x - z is reported as a
        # penetration, not as a negative gap.
        gap, penetration = reported_gap(s.x - s.z)
        count = solver.impact_count
        t_last = solver.t_last
        force = impulse / h if h > 0.0 else 0.0
        return _new_report({
            "t": s.t, "x": s.x, "v": s.v, "z": s.z, "w": s.w, "gap": gap,
            "penetration": penetration, "impulse": impulse,
            "force": force, "impacts": count - self._n_reported,
            "impact_count": count, "t_last": -1.0 if t_last is None else t_last,
            "sticking": solver.sticking,
            # the external structure's forces live in the other FMU
            "spring_force": 0.0 if self.external else self._stiffness * s.x,
            "coupling_force": solver.coupling_force if self.external else force,
            **(_modal_outputs(solver) if self.modal else _NO_MODES)})

    def set_restitution(self, e: float) -> None:
        """Change ``impact.e`` (tunable) for impacts from now on; 0 <= e <= 1."""
        e = checked_real(_RESTITUTION.name, e, _RESTITUTION.allowed, _RESTITUTION.in_range)
        self.scene = self.scene.replace(impact_e=e)
        self.solver.set_restitution(e)

    # saved states -------------------------------------------------------------------------------
    def sample(self, times: Any, u: float | None = None) -> Samples:
        """Advance to each of ``times`` (s; finite, strictly increasing, after t) in turn with
        the flow speed ``u`` held (default: the scene's ``flow.u``), as :meth:`advance_to` at each
        would, and return the states, the impulse of each interval and the sticking flags there
        (:class:`~iceimpact.solvers.base.Samples`).

        The path of :func:`run` for every method: the solver's vectorised sampler where it has
        one (the exact method: one march through every time, the states evaluated in closed
        forms at once, equal to stepping to rounding), else one :meth:`advance_to` per time.
        Either way no NaN or inf is returned (:func:`check_finite`, the fields a step checks)
        and a refusal is worded as a step's (:func:`stopped`). Where the method fails (a
        :class:`SolverError`), the samples are then taken again step by step from the call's
        start, so that the refusal names the step the failure lies in and the simulator stands
        at the last sample before it, as stepping leaves it; on a non-finite output the
        simulator is as before the call."""
        times = _increasing_times(times, self.solver.t, math.inf, "times")
        if u is None:
            u = self.scene.flow_u
        else:
            u = validate_flow(u, self.scene)
        solver = self.solver
        if not solver.SAMPLES_AT_ONCE:
            return self._sample_by_steps(times, u)
        t_start = solver.t
        checkpoint = solver.checkpoint()
        try:
            samples = solver.sample(times, u)
            starts = np.concatenate(([t_start], times[:-1]))
            k = self._stiffness  # as the report's spring force
            if not _surely_finite(samples, k, times - starts):
                gap, penetration = reported_gap(samples.x - samples.z)
                check_finite({"x": samples.x, "v": samples.v, "z": samples.z, "w": samples.w,
                              "gap": gap, "penetration": penetration,
                              "impulse": samples.impulse,
                              "force": samples.impulse / (times - starts),
                              "spring_force": (k * samples.x if k
                                               else np.zeros_like(samples.x))}, times, starts)
        except BaseException as exc:
            solver.rollback(checkpoint)
            if isinstance(exc, NonFiniteError):
                self.failed = stopped(exc.t_before, exc.t, exc)
            elif isinstance(exc, SolverError):
                # the vectorised march fails where the method does, which may lie many samples
                # after the interval it stood in (a long flight): stepping from the start to
                # the refused step finds the last sample the results are good up to
                return self._sample_by_steps(times, u)
            else:
                raise
            raise SolverError(self.failed) from exc
        self.failed = None
        self.report = self._report(float(samples.impulse[-1]), float(times[-1] - starts[-1]))
        self._n_reported = solver.impact_count
        return samples

    def _sample_by_steps(self, times: np.ndarray, u: float) -> Samples:
        n = self.scene.structure_modes if self.modal else 0
        out = Samples(len(times), n)
        for i, t in enumerate(times.tolist()):
            r = self.advance_to(t, u)
            out.x[i], out.v[i], out.z[i], out.w[i] = r.x, r.v, r.z, r.w
            out.impulse[i], out.sticking[i] = r.impulse, r.sticking
            if n:
                out.modal[i] = _modal_row(r, n)
        return out

    def save(self) -> dict[str, Any]:
        """The whole state as plain JSON-compatible data, a few kB at any run length (for FMI
        get/set/serialize FMU state; no impact history)::

            {"version": 2,
             "scene": {"structure.m": ..., ...},        # Scene.to_fmi()
             "solver": {...},                           # the method's snapshot
             "report": {"t": ..., ..., "sticking": ...},  # the last StepReport
             "reported_impacts": int,                   # impacts reported so far
             "failed": str | None}                      # why the latest step was refused

        ``json.loads(json.dumps(sim.save()))`` given to :meth:`restore` or :meth:`from_snapshot`
        continues exactly as this simulator would, to the last bit.
        """
        report = self.report
        return {"version": STATE_VERSION, "scene": self.scene.to_fmi(),
                "solver": self.solver.snapshot(),
                "report": {name: getattr(report, name) for name in _REPORT_FIELDS},
                "reported_impacts": self._n_reported, "failed": self.failed}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Return to a state from :meth:`save` (the snapshot stays reusable; any simulator can
        take it, its scene included). A malformed snapshot raises :class:`StateError` naming
        the field, and the simulator is unchanged."""
        rec = Record(snapshot, "")
        rec.expect_keys(_SAVE_KEYS)
        check_version(rec)
        scene = _read_scene(rec)
        report = _read_report(rec.record("report"))
        reported = rec.integer("reported_impacts", low=0)
        failed = rec.text("failed", allow_none=True)
        if _without_e(scene) == _without_e(self.scene):
            solver = self.solver  # keeps its impact list where the history is the same
        else:
            solver = make_solver(scene, self.record_impacts)
        solver_state = rec.raw("solver")
        apply = solver.read_snapshot(solver_state)  # checks every field, changes nothing
        if reported > solver_state["impact_count"]:
            raise StateError("reported_impacts", reported,
                             f"<= solver.impact_count = {solver_state['impact_count']}")
        if report.t != solver_state["t"]:
            raise StateError("report.t", report.t, f"the solver's time, {solver_state['t']!r} s")
        apply()
        self.scene, self.solver = scene, solver
        self.external, self.modal = scene.external, scene.modal  # the state's structure
        self._stiffness = scene.contact_stiffness
        self.report, self._n_reported, self.failed = report, reported, failed

    @classmethod
    def from_snapshot(cls, snapshot: dict[str, Any], record_impacts: bool = True) -> Simulator:
        """A new simulator in the state of a :meth:`save` (validated as :meth:`restore`)."""
        sim = cls(_read_scene(Record(snapshot, "")), record_impacts)
        sim.restore(snapshot)
        return sim


def _read_scene(rec: Record) -> Scene:
    """The scene of a saved state, validated by :meth:`Scene.from_fmi`."""
    values = rec.raw("scene")
    if not isinstance(values, dict):
        raise StateError("scene", values, "a dict of FMI-named parameters")
    try:
        return Scene.from_fmi(values)
    except ParameterError as exc:
        raise StateError(f"scene.{exc.name}", exc.value, exc.allowed) from exc


def _without_e(scene: Scene) -> dict[str, Any]:
    """The scene's parameters but the tunable restitution (a solver carries its own e)."""
    values = scene.to_fmi()
    del values["impact.e"]
    return values


@dataclass
class Result:
    """A whole run: samples (arrays over ``t``) and the impact list (arrays over impacts)."""

    scene: Scene
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    z: np.ndarray
    w: np.ndarray
    impulse: np.ndarray        # impulse on the structure in each sample interval, N.s
    sticking: np.ndarray       # bool per sample
    impacts: np.ndarray        # structured array, fields of :class:`Impact`
    sticking_since: float | None
    gap: np.ndarray            # x - z as the simulator reports it, m (>= 0, see StepReport)
    penetration: np.ndarray    # z - x when the ice is past the structure, else 0, m
    #: the modal structure's (structure.model = 3) modal coordinates q_k (m) and velocities
    #: q_k' (m/s), a column per mode (the FMU's structure.mode<k>.q and .v); else None
    modes_q: np.ndarray | None = None
    modes_v: np.ndarray | None = None

    @property
    def impact_times(self) -> np.ndarray:
        return self.impacts["t"]


IMPACT_DTYPE = np.dtype([(name, float) for name in Impact._fields])


def impacts_array(impacts: Sequence[Impact]) -> np.ndarray:
    """The impact list as a structured numpy array (fields t, x, v_minus, ..., restitution):
    every field is a float, so the flat sequence of all fields is read at once and viewed as
    records (a solver's :class:`~iceimpact.solvers.impact_log.ImpactLog` gives its rows)."""
    if isinstance(impacts, ImpactLog):
        return impacts.rows().view(IMPACT_DTYPE).reshape(-1)
    flat = np.fromiter(chain.from_iterable(impacts), dtype=float,
                       count=len(impacts) * len(IMPACT_DTYPE.names))
    return flat.view(IMPACT_DTYPE)


def _sample_times(t_end: float, dt: float, sample_times: Any) -> np.ndarray:
    """The sampling times of :func:`run`, checked: finite, strictly increasing, in (0, t_end]."""
    if sample_times is None:
        dt = checked_real("dt", dt, "a finite number > 0 (s)", _positive)
        n = int(math.floor(t_end / dt + 1e-9))
        times = dt * np.arange(1, n + 1)
        if n == 0 or times[-1] < t_end * (1 - 1e-12):
            times = np.append(times, t_end)
        return times
    return _increasing_times(sample_times, 0.0, t_end, "sample_times")


def _increasing_times(values: Any, t_now: float, t_end: float, name: str) -> np.ndarray:
    """``values`` as a float array, checked: finite, strictly increasing, in (t_now, t_end]
    (ParameterError naming ``name[i]`` otherwise)."""
    end = "" if t_end == math.inf else f", t_end = {t_end!r}]"
    allowed = (f"finite times in (t = {t_now!r}{end or ', inf)'} s, strictly increasing"
               if t_now else f"finite times in (0{end or ', inf)'} s, strictly increasing")
    try:
        raw = np.asarray(values)
        if raw.dtype.kind not in "iuf":  # (no bools, strings or objects taken as numbers)
            raise TypeError
        times = raw.astype(float)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(name, values, allowed) from None
    if times.ndim != 1 or times.size == 0:
        raise ParameterError(name, values, "a non-empty 1-d sequence of " + allowed)
    if (np.isfinite(times).all() and times[0] > t_now and times[-1] <= t_end
            and (times[1:] > times[:-1]).all()):
        return times
    previous = t_now  # the first time that is refused, and why
    for i, t in enumerate(times.tolist()):
        if not (math.isfinite(t) and previous < t <= t_end):
            why = allowed if i == 0 or not math.isfinite(t) or t > t_end else (
                f"{allowed}: > {name}[{i - 1}] = {previous!r}")
            raise ParameterError(f"{name}[{i}]", t, why)
        previous = t
    return times


def check_finite(values: dict[str, Any], times: np.ndarray,
                 starts: np.ndarray | None = None) -> None:
    """Refuse NaN and inf in what a step or a run reports: ``values`` are the reported fields,
    each a number or an array over ``times`` (the ends of steps starting at ``starts``; default:
    each at the time before it); raises :class:`NonFiniteError` naming every field that is not
    finite at the first time where one is not."""
    arrays = {name: np.atleast_1d(np.asarray(value, dtype=float))
              for name, value in values.items()}
    bad_any = np.zeros(len(times), dtype=bool)
    for array in arrays.values():
        bad_any |= ~np.isfinite(array)
    if not bad_any.any():
        return
    i = int(np.argmax(bad_any))
    names = [name for name, array in arrays.items() if not math.isfinite(array[i])]
    if starts is not None:
        before = float(starts[i])
    else:
        before = float(times[i - 1]) if i > 0 else math.nan
    raise NonFiniteError(names, float(times[i]), before)


def _surely_finite(samples: Samples, k: float, intervals: np.ndarray) -> bool:
    """Whether every field a sampled step reports is finite, proven from a few reductions: the
    states and impulses sum to finite numbers (a NaN or an infinity anywhere would make the
    sum one), and the largest magnitudes bound gap and penetration (|x - z| <= max |x| +
    max |z|), the spring force (k max |x|) and the force (max |impulse| / shortest interval,
    s), rounding being monotone. False says only that :func:`check_finite` must look element
    by element (a sum can overflow where every element is finite)."""
    x, z, impulse = samples.x, samples.z, samples.impulse
    for array in (x, samples.v, z, samples.w, impulse):
        if not math.isfinite(float(np.add.reduce(array))):
            return False
    if x.size == 0:
        return True
    x_max = max(float(x.max()), -float(x.min()))
    z_max = max(float(z.max()), -float(z.min()))
    impulse_max = max(float(impulse.max()), -float(impulse.min()))
    return (math.isfinite(x_max + z_max) and math.isfinite(k * x_max)
            and math.isfinite(impulse_max / float(intervals.min())))


def stopped(t: float, t_end: float, reason: Exception) -> str:
    """How a refused step (or sample interval) is reported, by every path that steps."""
    return (f"the run stopped at t = {t!r} s (the step to {t_end!r} s was refused; the state is "
            f"as before it): {reason}")


def run(scene: Scene, t_end: float, dt: float = 1e-2,
        sample_times: np.ndarray | None = None) -> Result:
    """Simulate ``scene`` at its constant flow speed from 0 to ``t_end`` (s).

    States are sampled every ``dt`` (s), or at ``sample_times`` (finite, strictly increasing,
    in (0, t_end]): :meth:`Simulator.sample`, each sample carrying what a step to it reports.
    Sampling does not change the trajectory: flights stay anchored at their events.
    """
    t_end = checked_real("t_end", t_end, "a finite number > 0 (s)", _positive)
    times = _sample_times(t_end, dt, sample_times)
    sim = Simulator(scene)
    first = sim.report
    samples = sim.sample(times)

    def column(name: str, dtype: type = float) -> np.ndarray:
        return np.concatenate(([getattr(first, name)], getattr(samples, name))).astype(
            dtype, copy=False)

    x, z = column("x"), column("z")
    gap, penetration = reported_gap(x - z)
    modes_q = modes_v = None
    if sim.modal:
        n = scene.structure_modes
        modal = np.vstack(([_modal_row(first, n)], samples.modal))
        modes_q, modes_v = modal[:, :n].copy(), modal[:, n:].copy()
    return Result(scene=scene, t=np.concatenate(([first.t], times)), x=x, v=column("v"),
                  z=z, w=column("w"), impulse=column("impulse"),
                  sticking=column("sticking", bool), impacts=impacts_array(sim.impacts),
                  sticking_since=sim.sticking_since, gap=gap, penetration=penetration,
                  modes_q=modes_q, modes_v=modes_v)
