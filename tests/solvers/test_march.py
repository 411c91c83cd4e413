"""The one event loop (solvers/march.py): its rules on a toy method whose segments and events
are known in advance, and the methods that march through it."""

from __future__ import annotations

import math

import pytest

from iceimpact import Scene, Simulator
from iceimpact.solvers.base import State
from iceimpact.solvers.exact import EventSolver, ExternalSolver
from iceimpact.solvers.march import EventMarch
from iceimpact.solvers.ode import OdeSolver


class Toy(EventMarch):
    """Events at given times, each adding a known impact impulse; a contact force of 1 N
    between events (so each span's impulse is its length)."""

    def __init__(self, events: list[float]):
        super().__init__(Scene())
        self.events = list(events)
        self.u = 0.0
        self.pending_impulse = 0.25  # an impact at t = 0, reported by the first step
        self.log: list[tuple] = []
        self.at = 0.0  # where the march stands in the current segment

    def next_event(self, t_end):
        self.log.append(("next", t_end))
        if self.events and self.events[0] <= t_end:
            return self.events[0]
        return None

    def impulse_to(self, event):
        self.log.append(("to", event))
        return event - self.at

    def at_event(self, event):
        self.log.append(("at", event))
        self.events.pop(0)
        self.at = event
        self.pending_impulse += 10.0  # the impact there

    def finish(self, t_end):
        self.log.append(("finish", t_end))
        span = t_end - self.at
        self.at = t_end
        self.state = State(t_end, 0.0, 0.0, 0.0, 0.0)
        return span

    def reanchor(self, u, t_end):
        self.log.append(("reanchor", u, t_end))
        self.u = u


def test_a_step_adds_the_pending_impulse_the_spans_and_each_events_impacts_in_order():
    toy = Toy([0.5, 0.75, 2.5])
    impulse = toy.advance_to(1.0, 0.0)
    # 0.25 pending, 0.5 to the first event, 10 there, 0.25 to the second, 10, 0.25 to the end
    assert impulse == ((((0.25 + 0.5) + 10.0) + 0.25) + 10.0) + 0.25
    assert toy.log == [("next", 1.0), ("to", 0.5), ("at", 0.5), ("next", 1.0), ("to", 0.75),
                       ("at", 0.75), ("next", 1.0), ("finish", 1.0)]
    assert toy.pending_impulse == 0.0 and toy.state.t == 1.0
    toy.log.clear()
    assert toy.advance_to(2.0, 0.0) == 1.0  # no event: the span only
    assert toy.log == [("next", 2.0), ("finish", 2.0)]


class ToyImpacts(Toy):
    """Toy whose events are impacts (counted)."""

    def event_time(self, event):
        return event

    def at_event(self, event):
        super().at_event(event)
        self.impact_count += 1


def test_a_step_stopping_at_events_stops_after_its_start_and_before_its_end_only():
    toy = ToyImpacts([0.0, 0.5, 1.0])
    impulse = toy.advance_to(1.0, 0.0, stop_at_event=True)
    # the impact at the start (t = 0) is taken, not stopped at; the one at 0.5 is the stop
    assert toy.state.t == 0.5 and toy.impact_count == 2
    assert impulse == (0.25 + 0.0) + 10.0 + 0.5 + 10.0
    # the one at the end of the step is the step's end, not an early return
    assert toy.advance_to(1.0, 0.0, stop_at_event=True) == 0.5 + 10.0
    assert toy.state.t == 1.0 and toy.impact_count == 3


def test_the_flow_reanchors_the_segment_once_and_only_when_it_changes():
    toy = Toy([])
    toy.advance_to(1.0, 0.0)
    assert not [e for e in toy.log if e[0] == "reanchor"]
    toy.log.clear()
    toy.advance_to(2.0, -0.5)
    assert toy.log[0] == ("reanchor", -0.5, 2.0) and toy.u == -0.5
    toy.log.clear()
    toy.set_flow(-0.5, 3.0)
    assert toy.log == []


@pytest.mark.parametrize("cls", [EventSolver, OdeSolver, ExternalSolver])
def test_the_event_driven_methods_march_through_the_one_loop(cls):
    assert issubclass(cls, EventMarch)
    assert cls.march is EventMarch.march


@pytest.mark.parametrize("method", [1, 3])
def test_a_method_reports_every_event_the_loop_visits(method):
    """Each event the loop takes is the method's: counting at_event calls counts the impacts
    (plus the separations of a sticking phase, none in this scene's first seconds)."""
    sim = Simulator(Scene(ice_M=800.0, solver_method=method))
    sim.solver.bounces = None  # (the compiled march takes a run of bounces in one call)
    calls = [0]
    at_event = sim.solver.at_event

    def counted(event):
        calls[0] += 1
        at_event(event)

    sim.solver.at_event = counted
    for _ in range(50):
        sim.advance(0.1)
    assert sim.impact_count == calls[0] >= 3
    assert math.isfinite(sim.report.x)


# A step that returns at an impact (FMI 3.0's early return) -------------------------------------
from reference_digests import CASES, METHOD_3_CASES  # noqa: E402

#: The cases whose steps can return at impacts: methods 1 and 3, the external structure under a
#: Gauss-Seidel master; shortened so that the whole set runs in seconds.
_EARLY = [case for case in (*CASES, *METHOD_3_CASES)
          if case[1] == "step" and case[2].get("solver_method", 1) != 2]


def _stepped_with_early_return(scene: Scene, t_end: float, h: float, flow, stop: bool):
    """Step as reference_digests.stepped does (the same communication points), with each step
    returning at its impacts when ``stop``: the reports at the communication points, every
    report of a step that returned early, and the impulses summed per communication step."""
    sim = Simulator(scene)
    plan = [(0.0, scene.flow_u), *flow]
    at_points, early, impulses = [], [], []
    for k in range(round(t_end / h)):
        t = sim.t
        u = [u for since, u in plan if since <= k * h + 1e-12][-1]
        point = t + h
        impulse = 0.0
        while True:
            report = sim.advance_to(point, u, stop_at_event=stop)
            impulse += report.impulse
            if report.t == point:
                break
            early.append(report)
        at_points.append(report)
        impulses.append(impulse)
    return sim, at_points, early, impulses


@pytest.mark.parametrize("case", _EARLY, ids=[case[0] for case in _EARLY])
def test_a_step_returned_at_each_impact_goes_on_as_the_whole_step(case):
    name, _, changes, t_end, h, flow = case
    t_end = min(t_end, 5.0)
    scene = Scene(**changes)
    whole, points, _, impulses = _stepped_with_early_return(scene, t_end, h, flow, stop=False)
    cut, cut_points, early, cut_impulses = _stepped_with_early_return(scene, t_end, h, flow,
                                                                      stop=True)
    assert whole.impacts, "the case has impacts"
    # the same impacts, to the bit; an early return at each impact off the grid, and at each
    # separation (the ice leaving the structure it stuck to), nowhere else
    assert cut.impacts == whole.impacts
    off_grid = [i.t for i in whole.impacts if i.t not in {r.t for r in points}]
    times = [r.t for r in early]
    assert times == sorted(set(times)) and set(off_grid) <= set(times)
    for report in early:
        impact = next((i for i in whole.impacts if i.t == report.t), None)
        if impact is not None:  # the state just after the impact it stopped at
            assert (report.v, report.t_last) == (impact.v_plus, impact.t)
            assert report.impacts >= 1
        else:  # a separation: the bodies apart, no impact in the step
            assert report.impacts == 0 and not report.sticking
    # the same states at every communication point, to the bit
    for a, b in zip(points, cut_points, strict=True):
        assert (a.t, a.x, a.v, a.z, a.w, a.sticking, a.impact_count) == \
               (b.t, b.x, b.v, b.z, b.w, b.sticking, b.impact_count)
    # each communication step's impulse, split at its impacts, to rounding
    for a, b in zip(impulses, cut_impulses, strict=True):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-12 * max(map(abs, impulses)))


def test_method_2_steps_to_the_end_with_stop_at_event():
    scene = Scene(solver_method=2, solver_detection=2)
    a, b = Simulator(scene), Simulator(scene)
    for k in range(1, 301):
        ra = a.advance_to(k * 1e-2)
        rb = b.advance_to(k * 1e-2, stop_at_event=True)
        assert (ra.t, ra.x, ra.impulse) == (rb.t, rb.x, rb.impulse)
    assert a.impact_count > 0
