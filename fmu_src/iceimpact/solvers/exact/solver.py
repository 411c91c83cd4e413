""":class:`EventSolver`: method 1, the exact event-driven solver (the package docstring says how it
works): its state, the march from event to event, the rules at each event, sampling many times in
one march, snapshots."""
from __future__ import annotations

from array import array
from collections.abc import Callable
from typing import Any

import numpy as np

from ...errors import StateError
from ...limits import TIME_RESOLUTION
from ...physics.ice import make_drag
from ...physics.structure import DraggedStructure, Oscillator
from ...record import Record
from ...scene import Scene
from ..base import Samples, State
from ..contact_rules import (
    EXACT_POLICY,
    ZENO_RESOLUTION,
    ContactRules,
    Outcome,
    Phase,
    reanchor_on_flow_change,
)
from ..march import EventMarch
from . import bounces
from .context import SegmentContext
from .flight import DraggedFlight, Flight
from .sampling import _SampleGroup, _sampling_kind, first_sample_after
from .segment import MARCHED, _SearchedSegment
from .sticking import LinearStick, QuadraticStick

#: Enum members as module constants (an enum class's attribute is looked up through its
#: metaclass, about 20 times the cost of a global; these are asked at every event).
_FLIGHT, _STICK = Phase.FLIGHT, Phase.STICK
_IMPACT, _STICK_OUTCOME = Outcome.IMPACT, Outcome.STICK


#: The samples of a segment that drops its steps before the times asked (its CHUNKED: a modal
#: riding phase) taken at once: it keeps the steps of that many, not those of a whole run
SAMPLE_CHUNK = 2048


class EventSolver(EventMarch):
    """Exact event-driven solver (method 1)."""

    name = "exact"
    SAMPLES_AT_ONCE = True
    #: A Zeno sequence is followed to its end, or closed at its estimated end, the bodies moving
    #: together to it (:meth:`ContactRules.impact`); False: closed at the chatter time.
    FOLLOW_ZENO = True
    #: Runs of bounces go through the compiled march where numba is (:mod:`.bounces`).
    COMPILED_BOUNCES = True

    def __init__(self, scene: Scene, record_impacts: bool = True):
        super().__init__(scene, record_impacts)
        self.drag = make_drag(scene)
        # Morison drag on the structure (docs/explanation/morison.md): linearised, a damping b_s
        # and an offset b_s u / k of the closed form (SegmentContext.structure_osc); quadratic,
        # an integrated flight (DraggedFlight). Off: b_s = 0 and the flight is today's closed
        # form.
        drag_s = self._structure_drag()
        self.dragged_structure = (DraggedStructure(self.m, self.c, self.k, drag_s)
                                  if drag_s is not None and drag_s.quadratic else None)
        self._flight_cls = Flight if self.dragged_structure is None else DraggedFlight
        #: what the segments and the march of bounces read (the laws, built once)
        self.context = context = self._context_class(
            self.m, self.c, self.k, self.M, self.drag, drag_s, self.dragged_structure,
            self._structure(), self._flight_cls, scene.solver_max_impacts)
        self.rules = context.rules = ContactRules(
            self.m, self.M, scene.omega_n, context.free_accels, EXACT_POLICY,
            scene.solver_chatter_fraction, time_resolution=ZENO_RESOLUTION * TIME_RESOLUTION,
            follow_zeno=self.FOLLOW_ZENO)
        #: the estimated end of the bounces of a Zeno sequence closed before it (s): the bodies
        #: move together until then, not yet sticking; None otherwise
        self.zeno_end: float | None = None
        self.u = scene.flow_u
        self.tau = 0.0  # position within the current segment
        self.pending_impulse = 0.0
        self.seg = None
        self._start()
        self.bounces = self._bounce_march()

    # what a subclass with a structure of its own changes ------------------------------------------
    #: the laws its segments read
    _context_class = SegmentContext

    def _new_flight(self, t: float, x: float, v: float, z: float, w: float, u: float,
                    start: float) -> Any:
        """A flight from time t and state (x, v, z, w), searched from ``start``."""
        return self._flight_cls(self.context, t, x, v, z, w, u, start)

    def _new_samples(self, n: int) -> Samples:
        """The records of n samples (:meth:`sample`)."""
        return Samples(n)

    def _sampled(self, out: Samples, i: int) -> None:
        """What else sample i records of a segment marched to it (a structure's own state)."""

    def _bounce_march(self) -> Any:
        """The compiled march of bounces of this solver's flights, or None (Python's march)."""
        if self.COMPILED_BOUNCES and bounces.COMPILED is not None:
            return bounces.BounceMarch(self)
        return None

    def _segment_class(self, phase: str) -> Any:
        """The class of a saved segment of this phase (``Phase`` value)."""
        if phase == Phase.FLIGHT.value:
            return self._flight_cls
        return QuadraticStick if self.drag.quadratic else LinearStick

    def _structure(self) -> Oscillator:
        """The structure's closed form without a flow: the oscillator of m, c, k."""
        return Oscillator(self.m, self.c, self.k)

    def _structure_drag(self):
        """The Morison drag on the structure (a drag law), or None when it is off."""
        return self.structure_drag

    def _start(self) -> None:
        """The first segment, from the scene's initial state (an impact at t = 0 goes to the
        first step)."""
        s = self.state
        self._begin(0.0, s.x, s.v, s.z, s.w, self.u)

    # segment construction -----------------------------------------------------------------------
    def _begin(self, t: float, x: float, v: float, z: float, w: float, u: float,
               reanchor: bool = False, after_impact: bool = False) -> None:
        """Start the segment that follows time t from state (x, v, z, w) (``reanchor``: after a
        change of the flow speed; ``after_impact``: the velocities after an impact; neither is
        a contact re-forming, see :meth:`ContactRules.at_contact`)."""
        self.u = u
        self.tau = 0.0
        if x - z > 0.0:
            self._fly(t, x, v, z, w, u)
            return
        decision = self.rules.at_contact(t, x, v, w, u, reanchor or after_impact)
        outcome = decision.outcome
        if outcome is _IMPACT:
            self._impact(t, x, decision.v, decision.w, u)
        elif outcome is _STICK_OUTCOME:
            self._stick(t, x, decision.v, u, hold=decision.hold)
        else:
            self._fly_from_contact(t, x, decision.v, decision.w, u, decision.lam)

    def _fly(self, t, x, v, z, w, u, start: float = 0.0) -> None:
        self.seg = self._new_flight(t, x, v, z, w, u, start)
        if self.sticking:  # (apart already: nothing to change)
            self._set_sticking(False, t)

    def _fly_from_contact(self, t: float, x: float, v: float, w: float, u: float,
                          lam: float) -> None:
        """Flight starting at zero gap with separating (or zero) relative velocity.

        With an opening speed s > 0 the search starts at 0, where g = 0 and g' = s > 0 are no
        root, and its first stretch proves ``g >= s h - K h^2/2 > 0`` beyond. With s = 0 it
        starts beyond the trivial root at 0, at the end of an interval proven root-free,
        ``g >= g2 h^2/2 - J h^3/6`` (gap curvature g2 = -lam / mu > 0, J a bound on |g'''|).
        """
        opening = v - w
        if opening > 0.0:
            # the search's first stretch from 0 proves the opening: g(0) = 0, g'(0) = s > 0
            self._fly(t, x, v, x, w, u, 0.0)
            return
        a_x, _, j_x_max = self.context.structure_bounds(x, v, u)
        a_z, _, j_z_max = self.drag.accel_bounds(w, u)
        curvature = a_x - a_z
        jerk_bound = j_x_max + j_z_max
        start = 0.0
        if curvature > 0.0 and jerk_bound > 0.0:
            start = 2.0 * curvature / jerk_bound
        self._fly(t, x, v, x, w, u, start)

    def _stick(self, t: float, x: float, v: float, u: float, hold: float = 0.0) -> None:
        """Bodies together from time t; separation is not looked for before ``t + hold``."""
        cls = QuadraticStick if self.drag.quadratic else LinearStick
        self.seg = cls(self.context, t, x, v, u, start=hold)
        self._set_sticking(True, t)

    def _impact(self, t: float, x: float, v_minus: float, w_minus: float, u: float) -> None:
        """The impact step (eq. 16-18, chatter and Zeno closure) at time t; what follows."""
        impact = self.rules.impact(t, x, v_minus, w_minus, self.e, u)
        self._record(impact)
        self.pending_impulse += impact.impulse
        self._begin(t, x, impact.v_plus, x, impact.w_plus, u, after_impact=True)
        self._zeno_tail(t)

    def record_rows(self, rows: np.ndarray) -> None:
        """Impacts the compiled march made, rows of
        :class:`~iceimpact.solvers.impact_log.ImpactLog` in time order (at least one): counted
        and listed as :meth:`_record` counts and lists each (the march kept the budget)."""
        self.impact_count += len(rows)
        self.t_last = float(rows[-1, 0])
        if self.record_impacts:
            self.impacts.extend_rows(rows)

    def _zeno_tail(self, t: float) -> None:
        """After an impact at time t that did not part the bodies: if it closed a Zeno sequence
        before the sequence's end (:meth:`ContactRules.take_accumulation`), the bodies move
        together to that estimated end and sticking starts there (a separation on the way
        ends the tail: the bounces never accumulated)."""
        end = self.rules.take_accumulation()
        if end is None:
            return
        if self.seg.phase is _STICK and end > t:
            self._set_sticking(False, t)
            self.zeno_end = end

    def _flight_end(self, t: float, x: float, v: float, w: float, u: float) -> None:
        """A flight's gap closing at time t, position x: :meth:`_begin` at zero gap, with the
        common case, an impact after which the bodies part (a bounce), decided in one call
        (:meth:`ContactRules.impact_at_contact`: the same decisions, the same flight)."""
        impact, parts = self.rules.impact_at_contact(t, x, v, w, self.e, u)
        if impact is None:
            self._begin(t, x, v, x, w, u)
            return
        self._record(impact)
        self.pending_impulse += impact.impulse
        if parts:  # at_contact's FLIGHT with an opening speed: the search from 0
            self.u = u
            self.tau = 0.0
            # _fly, from a flight (so not sticking: a flight and the sticking flag never
            # coexist, as _read checks of a snapshot)
            self.seg = self._new_flight(t, x, impact.v_plus, x, impact.w_plus, u, 0.0)
        else:
            self._begin(t, x, impact.v_plus, x, impact.w_plus, u, after_impact=True)
            self._zeno_tail(t)

    # marching (the loop is solvers/march.py's) --------------------------------------------------
    def next_event(self, t_end: float) -> float | None:
        seg = self.seg
        event = seg.next_event(t_end - seg.t0)
        end = self.zeno_end
        if end is not None and end <= t_end:  # the end of a Zeno tail, unless parted before
            tau_end = end - seg.t0
            if event is None or event > tau_end:
                return tau_end
        return event

    def event_time(self, tau_event: float) -> float:
        return self.seg.t0 + tau_event

    def impulse_to(self, tau_event: float) -> float:
        seg = self.seg
        return seg.impulse(self.tau, tau_event) if seg.PUSHES else 0.0

    def at_event(self, tau_event: float) -> None:
        seg = self.seg
        x, v, z, w = seg.state(tau_event)
        t_event = seg.t0 + tau_event
        u = self.u
        if seg.phase is _FLIGHT:
            self._flight_end(t_event, x, v, w, u)  # impact, or a touch without speed
        elif self.zeno_end is not None and tau_event == self.zeno_end - seg.t0:
            # the end of a Zeno tail: the bodies, together already, start sticking
            self.tau = tau_event
            self.zeno_end = None
            self._set_sticking(True, t_event)
        else:  # contact force turns tensile: separate with equal velocities
            self.zeno_end = None
            self._fly_from_contact(t_event, x, v, v, u, self.rules.free_contact_force(x, v, v, u))

    def finish(self, t_end: float) -> float:
        seg = self.seg
        tau_end = t_end - seg.t0
        impulse = seg.impulse(self.tau, tau_end) if seg.PUSHES else 0.0  # (flights: 0, no call)
        self.tau = tau_end
        x, v, z, w = seg.state(tau_end)
        self.state = State(t_end, x, v, z, w)
        return impulse

    def reanchor(self, u: float, t_end: float = 0.0) -> None:
        """Zero-order hold: a new flow speed re-anchors the closed forms at the current time."""
        x, v, z, w = reanchor_on_flow_change(*self.seg.state(self.tau),
                                             self.seg.phase is Phase.STICK)
        end, self.zeno_end = self.zeno_end, None
        t = self.state.t
        self._begin(t, x, v, z, w, u, reanchor=True)
        if end is not None and self.seg.phase is _STICK:  # a Zeno tail goes on to its end
            self._set_sticking(False, t)
            self.zeno_end = end

    def sample(self, times: np.ndarray, u: float) -> Samples:
        """Advance to each of ``times`` (increasing, after the current time) in turn with flow
        speed u, as ``advance_to(t, u)`` at each would, and return what each step reports.

        The march visits the same segments and events; the states at the sample times and the
        contact impulses are then evaluated per kind of segment in one vectorised pass of the
        closed forms (equal to the scalar ones to rounding). A quadratic-drag sticking phase
        and a flight under the quadratic Morison drag, which have no closed form, evaluate
        their Taylor steps' polynomials at all their samples at once
        (:meth:`QuadraticStick.states_at`, :meth:`DraggedFlight.states_at`, the same floats as
        their ``state``); a segment with neither is marched sample by sample. Each sample interval
        has its own impact budget (solver.max_impacts), as each step of a Simulator has."""
        try:
            return self._sample(times, u)
        finally:
            self.end_step()

    def _sample(self, times: np.ndarray, u: float) -> Samples:
        self.set_flow(u, float(times[-1]))
        times = np.ascontiguousarray(times, dtype=float)
        # the times as floats for the Python loop below, which reads them at every event; with
        # the compiled march it meets few events, and reads the array itself (no copy)
        t_list = times.tolist() if self.bounces is None else times
        n = len(t_list)
        out = self._new_samples(n)
        # impulse contributions in the order the scalar march adds them: (sample, value); the
        # values of force-carrying pieces are filled in by the vectorised pass (machine numbers,
        # copied as the march goes: see _SampleGroup)
        targets = array("q", (0,))
        values = array("d", (self.pending_impulse,))
        self.pending_impulse = 0.0
        # per kind of segment: STEPPED, MARCHED or the _SampleGroup of its samples
        kinds: dict[type, Any] = {}
        # the kind of the last segment's type, and whether its segments go to a _SampleGroup
        # (most segments follow one of their own type: a bounce's flight another flight)
        last_type: type | None = None
        kind: Any = None
        grouped = False
        at_event = self.at_event
        add_target, add_value = targets.append, values.append
        i = 0
        horizon = float(t_list[-1])
        interval = 0  # the sample interval whose impact budget runs
        self.begin_step()
        compiled = self.bounces
        declined = None  # the segment the compiled march left to this loop
        while i < n:
            seg = self.seg
            if compiled is not None and seg is not declined and compiled.takes(seg):
                i, interval = compiled.sample(times, i, interval, out, targets, values)
                declined = self.seg
                continue
            if type(seg) is not last_type:
                last_type = type(seg)
                kind = kinds.get(last_type)
                if kind is None:
                    kind = kinds[last_type] = _sampling_kind(seg)
                grouped = isinstance(kind, _SampleGroup)
            if kind is MARCHED or self.zeno_end is not None:  # march to the sample (a Zeno
                # tail's end is an event of the solver, not of its segment)
                if interval != i:
                    interval = i
                    self.begin_step(float(t_list[i - 1]))
                add_target(i)
                add_value(self.march(float(t_list[i])))
                out.set(i, self.state, self.sticking)
                self._sampled(out, i)
                i += 1
                continue
            t0 = seg.t0
            # a segment that drops its steps before the times asked (CHUNKED) is sampled
            # SAMPLE_CHUNK samples at a time: it keeps those of a chunk or two, not the run's
            chunk = (i + SAMPLE_CHUNK if n - i > SAMPLE_CHUNK and getattr(seg, "CHUNKED", False)
                     else n)
            if grouped:  # a _SearchedSegment: its next_event, without that call
                tau_event = seg.search.next_root_of(horizon - t0, seg)
            else:
                tau_event = seg.next_event(float(t_list[chunk - 1]) - t0)
            if tau_event is None and chunk < n:
                self._sample_steps(seg, times, i, chunk, None, out, targets, values)
                self.tau = float(t_list[chunk - 1]) - t0
                i = chunk
                continue
            if tau_event is None:
                j = n
            elif t_list[i] - t0 >= tau_event:  # (several events before one sample: no call)
                j = i
            elif i + 1 == n or t_list[i + 1] - t0 >= tau_event:  # (nor one: 3 in 4 of the
                j = i + 1  # bounces with a sample in Figure 2)
            else:
                j = first_sample_after(t_list, i + 2, t0, tau_event)
            if grouped:
                if i < j or seg.PUSHES:  # (a flight with no sample adds nothing: most bounces)
                    kind.add(seg, self.tau, i, j, tau_event, targets, values)
            else:
                self._sample_steps(seg, times, i, j, tau_event, out, targets, values)
            if tau_event is None:
                self.tau = horizon - t0
                x, v, z, w = seg.state(self.tau)
                self.state = State(horizon, x, v, z, w)
                break
            add_target(j)
            if interval != j:  # (the event is sample j's: the first at or after it)
                interval = j
                self.begin_step(float(t_list[j - 1]))
            at_event(tau_event)  # (take_event, inline: this runs at every impact)
            add_value(self.pending_impulse)
            self.pending_impulse = 0.0
            i = j
        values_array = np.array(values, dtype=float)
        for group in kinds.values():
            if isinstance(group, _SampleGroup):
                group.evaluate(times, out, values_array)
        # (out.impulse holds the sticking phases' inner samples, _sample_steps: no target's)
        np.add.at(out.impulse, np.array(targets, dtype=np.int64), values_array)
        return out

    def _sample_steps(self, seg: Any, times: np.ndarray, i: int, j: int,
                      tau_event: float | None, out: Samples, targets: array,
                      values: array) -> None:
        """Samples i..j-1 in a segment of Taylor steps, from the current position in it (and
        its end at ``tau_event`` before sample j, if it ends), all evaluated at once: the
        states and, in a sticking phase, the impulse pieces the scalar march adds, in its order
        (a flight has no contact force: no pieces). The intervals of samples i+1..j-1 lie
        within the phase: each has its one piece, ``0.0 + piece`` as the sum of the march's
        pieces gives it, written to ``out.impulse`` at once; sample i's and j's go to
        ``targets`` and ``values`` (their intervals have other pieces too)."""
        tau = times[i:j] - seg.t0
        if seg.phase is Phase.FLIGHT:  # a flight in Taylor steps (DraggedFlight) or of modes: no
            # contact force, so each interval's impulse is 0.0 but for its events' (the loop
            # adds them)
            if j > i:
                out.x[i:j], out.v[i:j], out.z[i:j], out.w[i:j] = seg.states_at(tau)
                if out.modal is not None:
                    out.modal[i:j] = seg.modal_states_at(tau)
            return
        ends = tau if tau_event is None else np.append(tau, tau_event)
        tau_all = np.concatenate(([self.tau], ends))
        y = seg.states_at(tau_all)
        x, v = y[1:j - i + 1, 0], y[1:j - i + 1, 1]
        out.x[i:j], out.v[i:j], out.z[i:j], out.w[i:j] = x, v, x, v
        out.sticking[i:j] = seg.phase is Phase.STICK
        if out.modal is not None:  # (the modal riding phase's rows: x, v, then q, q')
            out.modal[i:j] = y[1:j - i + 1, 2:2 + out.modal.shape[1]]
        pieces = seg.impulses_between(tau_all, y)
        if j > i:
            targets.append(i)
            values.append(float(pieces[0]))
            np.add(0.0, pieces[1:j - i], out=out.impulse[i + 1:j])
        if tau_event is not None:
            targets.append(j)
            values.append(float(pieces[-1]))

    # snapshots ----------------------------------------------------------------------------------
    def checkpoint(self) -> Any:
        """The solver's fields and the segment object with all its search holds (frontier, the
        probe at its end, a compiled search handed back): a flight or a linear sticking phase
        changes nothing else while marching (a quadratic one, with its Taylor steps, takes a full
        snapshot)."""
        seg = self.seg
        if not isinstance(seg, _SearchedSegment) or not seg.FRONTIER_ONLY:
            return super().checkpoint()
        search = seg.search
        degenerate = self.rules.degenerate
        return (self.state, self.e, self.impact_count, self.t_last, self.sticking,
                self.sticking_since, self.u, self.tau, self.pending_impulse, degenerate.run,
                degenerate.last, self.zeno_end, seg, search.checkpoint())

    def rollback(self, checkpoint: Any) -> None:
        if isinstance(checkpoint, dict):
            super().rollback(checkpoint)
            return
        (self.state, self.e, self.impact_count, self.t_last, self.sticking, self.sticking_since,
         self.u, self.tau, self.pending_impulse, run, last, self.zeno_end, seg,
         search) = checkpoint
        # the impacts listed are those from impacts_base on (none without record_impacts)
        del self.impacts[self.impact_count - self.impacts_base:]
        self.rules.degenerate.set((run, last))
        seg.search.rollback(search)
        self.seg = seg

    _KEYS = ("u", "tau", "pending_impulse", "degenerate", "zeno_end", "segment")

    def _snapshot(self) -> dict[str, Any]:
        return {"u": self.u, "tau": self.tau, "pending_impulse": self.pending_impulse,
                "degenerate": self.rules.degenerate.snapshot(), "zeno_end": self.zeno_end,
                "segment": self.seg.snapshot(self.tau)}

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        u = rec.real("u")
        tau = rec.real("tau", low=0.0)
        pending = rec.real("pending_impulse")
        degenerate = self.rules.degenerate.read(rec.record("degenerate"))
        zeno_end = rec.real("zeno_end", low=t, allow_none=True)
        if zeno_end is not None and rec.data["sticking"]:
            raise StateError(rec.field("zeno_end"), zeno_end, "null while sticking is true")
        seg_rec = rec.record("segment")
        phase = seg_rec.text("phase", [p.value for p in Phase])
        if (phase == Phase.STICK.value) != (rec.data["sticking"] or zeno_end is not None):
            raise StateError(seg_rec.field("phase"), phase,
                             "stick exactly when sticking is true or zeno_end is a time")
        make_segment = self._segment_class(phase).read(self.context, seg_rec, u)

        def apply() -> None:
            self.seg = make_segment()
            self.u, self.tau, self.pending_impulse = u, tau, pending
            self.zeno_end = zeno_end
            self.rules.degenerate.set(degenerate)
        return apply
