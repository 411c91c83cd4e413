"""The simulator's guarantees on every path that reports: run()'s sampled path (the exact
method's samples at once) and stepping (every method) refuse a non-finite output alike, in the
same words."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from iceimpact import Scene, Simulator, SolverError, run
from iceimpact.solvers.base import State
from iceimpact.solvers.exact import EventSolver

WORDING = re.compile(r"the run stopped at t = \S+ s \(the step to (\S+) s was refused; the state "
                     r"is as before it\): the method produced a non-finite (.+) at t = (\S+) s")


def test_run_sampled_refuses_a_non_finite_output_in_the_words_of_a_step(monkeypatch):
    original = EventSolver.sample

    def poisoned(self, times, u):
        samples = original(self, times, u)
        samples.x[3] = math.nan
        return samples

    monkeypatch.setattr(EventSolver, "sample", poisoned)
    assert EventSolver.SAMPLES_AT_ONCE
    with pytest.raises(SolverError) as failed:
        run(Scene(), 1.0, dt=0.1)
    match = WORDING.fullmatch(str(failed.value))
    assert match, str(failed.value)
    # sample 3 is t = 0.4 s (row 0 is t = 0); x, and the gap made from it
    assert match.group(1) == match.group(3) == "0.4"
    assert match.group(2) == "x, gap"


def test_a_stepped_run_refuses_a_non_finite_output_in_the_same_words(monkeypatch):
    original = EventSolver.advance_to

    def poisoned(self, t_end, u):
        impulse = original(self, t_end, u)
        if t_end > 0.35:
            s = self.state
            self.state = State(s.t, math.nan, s.v, s.z, s.w)
        return impulse

    monkeypatch.setattr(EventSolver, "advance_to", poisoned)
    monkeypatch.setattr(EventSolver, "SAMPLES_AT_ONCE", False)  # run() steps the simulator
    with pytest.raises(SolverError) as failed:
        run(Scene(), 1.0, dt=0.1)
    match = WORDING.fullmatch(str(failed.value))
    assert match, str(failed.value)
    assert match.group(1) == match.group(3) == "0.4"
    assert match.group(2) == "x, gap, spring_force"  # the step reports k x too


def test_a_refused_step_leaves_the_simulator_as_it_was(monkeypatch):
    sim = Simulator(Scene(ice_M=800.0))
    sim.advance(0.5)
    before = sim.save()
    monkeypatch.setattr(EventSolver, "advance_to",
                        lambda self, t_end, u: math.inf)  # an impulse that is not finite
    with pytest.raises(SolverError, match="non-finite impulse, force"):
        sim.advance(0.1)
    monkeypatch.undo()
    after = sim.save()
    assert after.pop("failed") and before.pop("failed") is None  # the refusal, recorded
    assert after == before
    assert np.isfinite(sim.advance(0.1).x)
