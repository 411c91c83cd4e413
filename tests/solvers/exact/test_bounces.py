"""The exact method's compiled march of bounces (solvers/exact/bounces.py) against the Python
march it stands for: the same impacts, states, impulses and samples, to the bit, for random scenes
stepped (with and without early return) and sampled through run(); its refusals and failures
leave the simulator as the Python march does."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, seed, settings

import random_scenes
from iceimpact import Scene, Simulator, SolverError, run
from iceimpact.solvers.exact import bounces
from iceimpact.solvers.exact.bounces import BounceMarch, bounce_march

compiled_only = pytest.mark.skipif(bounces.COMPILED is None,
                                   reason="numba absent or ICEIMPACT_PURE set: no compiled march")


def _bits(values) -> list[str]:
    return [float(v).hex() for v in values]


@compiled_only
def test_the_compiled_march_takes_the_bounces(monkeypatch):
    """In Figure 2's scene the compiled march makes nearly every impact: a few calls for some
    ten thousand impacts, stepped or sampled (else this file compares nothing)."""
    calls = [0]
    kernel = bounces.COMPILED

    def counted(*args):
        calls[0] += 1
        kernel(*args)

    monkeypatch.setattr(bounces, "COMPILED", counted)
    result = run(Scene(), 300.0)
    assert len(result.impacts) > 10_000 and calls[0] < 20
    calls[0] = 0
    sim = Simulator(Scene())
    for _ in range(300):
        sim.advance(1.0)
    assert sim.impact_count > 10_000 and calls[0] < 1_000


def _random_scenes(seed_value: int, examples: int, stepped: bool, sampled: bool,
                   early: bool = False) -> None:
    """Scenes as ``random_search.py --scales --flows`` draws them, stepped at their step h
    (with ``early``: stop_at_event) and sampled every h through run(), compiled and not."""
    @seed(seed_value)
    @settings(max_examples=examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(case=random_scenes.CASES)
    def check(case):
        scene, h, flow, signs = case
        if stepped:
            assert (random_scenes.stepped(scene, h, flow, signs, True, early)
                    == random_scenes.stepped(scene, h, flow, signs, False, early))
        if sampled:
            assert (random_scenes.sampled(scene, 3.0, h, True)
                    == random_scenes.sampled(scene, 3.0, h, False))
    check()


@compiled_only
@pytest.mark.parametrize("early", [False, True], ids=["steps", "early return"])
def test_random_scenes_stepped(early):
    """Scenes as ``random_search.py --scales --flows`` draws them (masses 1e-6 to 1e9 kg,
    omega_n to the method's limit, every damping regime, either drag law, restitution 0 to 1,
    flows constant, reversing, zero, random), stepped at 1 ms to 1 s, with and without
    stop_at_event: every step's numbers and every impact are the Python march's."""
    _random_scenes(39 + early, 300, stepped=True, sampled=False, early=early)


@compiled_only
def test_random_scenes_sampled():
    """The same scenes through run() (the vectorised sampler, whose flights the compiled march
    hands over in blocks): every sample and every impact are the Python march's."""
    _random_scenes(41, 300, stepped=False, sampled=True)


@compiled_only
@pytest.mark.slow
@pytest.mark.parametrize("early", [False, True], ids=["steps", "early return"])
def test_thousands_of_random_scenes(early):
    """As above, 3,000 scenes stepped and sampled, twice (about 10 minutes)."""
    _random_scenes(139 + early, 3000, stepped=True, sampled=True, early=early)


@pytest.mark.parametrize("fields, start", [
    ({}, 150.0), ({"drag_model": 2, "ice_A": 2.0}, 140.0),
    ({"ice_M": 6400.0, "flow_u": 2.0}, 150.0),
    ({"ice_M": 6400.0, "flow_u": 2.0, "drag_model": 2}, 55.0)])
def test_the_kernel_run_as_python_is_the_python_march(fields, start):
    """bounce_march itself, run as Python (numpy's scalars on the way): the numbers of the
    Python march, so what numba compiles is the march, whether or not numba is installed.
    From ``start`` (s), where the scene bounces often."""
    impacts = random_scenes.kernel_is_the_python_march(
        Scene(**fields), start, bounce_march, 6.0, np.linspace(start + 6.6, start + 10.0, 77))
    assert impacts > 20


@compiled_only
def test_a_failure_in_the_compiled_march_changes_nothing(monkeypatch):
    """A step that fails once the compiled march has made impacts (counted, the flight not yet
    handed back) leaves the simulator as it was; the step taken again is the Python march's."""
    scene = Scene(impact_e=0.7)
    sim, clean = Simulator(scene), Simulator(scene)
    clean.solver.bounces = None
    sim.advance(0.5)
    clean.advance(0.5)
    before = sim.save()
    real = BounceMarch._impacts
    seen = [0]

    def fails(self, n):
        real(self, n)
        seen[0] += n
        if seen[0]:
            raise FloatingPointError("injected")

    monkeypatch.setattr(BounceMarch, "_impacts", fails)
    with pytest.raises(FloatingPointError):
        sim.advance(12.0)
    assert seen[0] > 0  # impacts were made before the failure
    monkeypatch.setattr(BounceMarch, "_impacts", real)
    assert {k: v for k, v in sim.save().items() if k != "failed"} == {
        k: v for k, v in before.items() if k != "failed"}
    assert sim.advance(12.0) == clean.advance(12.0)
    assert sim.impacts == clean.impacts


@pytest.mark.parametrize("sampled", [False, True], ids=["steps", "sampled"])
def test_the_impact_budget_refuses_as_the_python_march(sampled):
    """solver.max_impacts: the step (or sample interval) that needs more is refused with the
    Python march's words, the same impacts counted before, the simulator where it was (a
    sampled march refused is undone whole)."""
    scene = Scene(solver_max_impacts=40)
    first = Simulator(Scene())
    first.advance(150.0)  # (Figure 2 bounces some 8 times a second from here)
    outcomes = []
    for compiled in (True, False):
        sim = Simulator(scene)
        sim.restore({**first.save(), "scene": sim.save()["scene"]})
        if not compiled:
            sim.solver.bounces = None
        with pytest.raises(SolverError, match="solver.max_impacts = 40") as info:
            if sampled:
                sim.sample(150.0 + np.array([0.1, 0.2, 3.2, 6.2, 9.2, 12.2, 18.2, 24.2, 30.2]))
            else:
                for _ in range(10):
                    sim.advance(3.0)
        outcomes.append((str(info.value), sim.impact_count, sim.t,
                         [_bits(i) for i in sim.impacts], _bits(vars(sim.solver.state).values())))
    assert outcomes[0] == outcomes[1]


def test_the_budget_in_a_sampled_run_is_per_sample_interval():
    """Each sample interval has its own budget: with 40 impacts, 3 s intervals of Figure 2 from
    150 s need more, 0.1 s intervals fewer."""
    first = Simulator(Scene())
    first.advance(150.0)
    sim = Simulator(Scene(solver_max_impacts=40))
    sim.restore({**first.save(), "scene": sim.save()["scene"]})
    samples = sim.sample(150.0 + np.arange(1, 301) * 0.1)
    assert sim.impact_count - first.impact_count > 150
    assert np.isfinite(samples.x).all()
