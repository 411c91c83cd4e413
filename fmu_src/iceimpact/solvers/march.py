"""The one event loop of the event-driven methods: the exact solver (method 1, also against an
external structure) and the ODE solver (method 3).

Both march the same way, as Siconos' ``EventDriven::advanceToEvent`` does: a *segment* (a flight,
or the bodies together) carries the state from one event to the next; at an event the contact
rules (:mod:`~iceimpact.solvers.contact_rules`) decide what follows and start the next segment.
What differs between the methods is only how a segment is computed (closed forms and a no-miss
root search, or ``solve_ivp`` with a terminal event), so a method supplies four operations and
:meth:`EventMarch.march` does the bookkeeping once. The fixed-step scheme (method 2) has no
segments (it tests grid points, as the article does) and keeps its own loop.
"""

from __future__ import annotations

from typing import Any

from .base import Solver


class EventMarch(Solver):
    """A solver whose state is a segment between events. A subclass provides:

    1. ``next_event(t_end)``: the current segment's next event at or before ``t_end`` (s), as
       the method describes it (a time within the segment, or the event's time and state), or
       None when the segment reaches ``t_end``. It may compute ahead; it changes no state that
       a report shows.
    2. ``impulse_to(event)``: the contact impulse (N.s) on the structure over the current
       segment from where the march stands to the event (0 in flight).
    3. ``at_event(event)``: the state at the event goes through the contact rules, which start
       the next segment; the impulses of the impacts there go to ``pending_impulse``.
    4. ``finish(t_end)``: move within the current segment to ``t_end``, set ``state`` at
       ``t_end``; return the contact impulse on the way.
    5. ``reanchor(u, t_end)``: the flow speed changes to u at the current time (zero-order hold):
       the segment restarts there, from the current state (``t_end``: the end of the step about
       to be taken, a hint for how far to compute ahead).
    6. ``event_time(event)``: the time (s) of an event ``next_event`` returned.

    With ``stop_at_event``, :meth:`march` ends at the first contact event after its start and
    before ``t_end``: an event that brings an impact or starts or ends the bodies' sticking
    together (a touch without speed that leaves them in flight is not one; nor an event at the
    start, so that a step always advances the time). ``state`` is then the state just after it
    (an impact's impulse included in the returned one), and the next march goes on from there
    exactly as the uninterrupted march would have (an FMI 3.0 early return, docs/fmu.md).

    ``u`` is the flow speed of the current segment; ``pending_impulse`` holds the impulse of
    impacts at the current time not yet reported (an impact at t = 0 goes to the first step).
    """

    u: float
    pending_impulse: float
    #: a compiled march from the current segment on, where the method has one (the exact
    #: method's bounces, :class:`~iceimpact.solvers.exact.bounces.BounceMarch`): ``takes(seg)``
    #: and ``march(t_end, stop_at_event, t_start, impulse) -> (impulse, stopped at or None)``
    bounces: Any = None

    def advance_to(self, t_end: float, u: float, stop_at_event: bool = False) -> float:
        if u != self.u:  # (set_flow, inline: this runs at every communication step)
            self.reanchor(u, t_end)
        return self.march(t_end, stop_at_event)

    def set_flow(self, u: float, t_end: float) -> None:
        """Re-anchor the segment if the flow speed changes (rule 5), once for every path in."""
        if u != self.u:
            self.reanchor(u, t_end)

    def march(self, t_end: float, stop_at_event: bool = False) -> float:
        """Run the segments from the current one to ``t_end`` (with ``stop_at_event``: to the
        first contact event before it, see above); the impulse on the structure (the sum in event
        order, so that every path that marches adds the same numbers in the same order)."""
        impulse = self.pending_impulse
        self.pending_impulse = 0.0
        t_start = self.state.t
        bounces = self.bounces
        declined = None  # the segment the compiled march left to this loop
        while True:
            event = self.next_event(t_end)
            if event is None:
                impulse += self.finish(t_end)
                return impulse
            # an event in this step: the compiled march takes it and what follows, if it can
            # (asked only here, so that a step with no event costs it nothing)
            if bounces is not None and self.seg is not declined and bounces.takes(self.seg):
                impulse, stopped = bounces.march(t_end, stop_at_event, t_start, impulse)
                if stopped is not None:  # (an impact with stop_at_event, as below)
                    return impulse + self.finish(stopped)
                declined = self.seg
                continue
            impulse += self.impulse_to(event)
            if stop_at_event:
                count, sticking = self.impact_count, self.sticking
                t_event = self.event_time(event)
                impulse += self.take_event(event)
                # (never at the start: a step must advance the time)
                if ((self.impact_count != count or self.sticking != sticking)
                        and t_start < t_event < t_end):
                    impulse += self.finish(t_event)  # the new segment at its start: no impulse
                    return impulse
            else:
                impulse += self.take_event(event)

    def take_event(self, event: Any) -> float:
        """:meth:`at_event`; the impulse of its impacts, taken from ``pending_impulse``."""
        self.at_event(event)
        impulse, self.pending_impulse = self.pending_impulse, 0.0
        return impulse

    # the method's operations (numbered rules above) ---------------------------------------------
    def next_event(self, t_end: float) -> Any:
        raise NotImplementedError

    def impulse_to(self, event: Any) -> float:
        raise NotImplementedError

    def at_event(self, event: Any) -> None:
        raise NotImplementedError

    def finish(self, t_end: float) -> float:
        raise NotImplementedError

    def reanchor(self, u: float, t_end: float) -> None:
        raise NotImplementedError

    def event_time(self, event: Any) -> float:
        raise NotImplementedError
