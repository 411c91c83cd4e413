"""The impact budget of a communication step (``solver.max_impacts``), and the stick-part cycle at
a stiff structure that makes it needed (docs/explanation/robustness/stiff-structures.md).

A step that would make more impacts than the budget is refused (SolverError in Python,
fmi2Discard at the FMU, exit status 2 in the CLI) with the budget, the rate of impacts and the two
ways on; nothing changes, and shorter steps go on exactly as a run that never met the budget.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fmu_host import FMI_DISCARD, FMI_OK, Instance, errors
from iceimpact import ParameterError, Scene, Simulator
from iceimpact.contract import INT32_MAX, MAX_EVALUATIONS, MAX_IMPACTS
from iceimpact.simulator import run
from iceimpact.solvers.base import SolverError
from scene_strategies import scenes
from scenes import SEED_49

#: Figure 2's run makes ten impacts by t = 30 s, in pairs 0.13 s apart (0.89 s and 1.01 s, 8.63 s
#: and 8.75 s, ...). Method 2 with the sign test (the window of eq. 26 jumps over them here).
_METHODS = ({"solver_method": 1}, {"solver_method": 2, "solver_detection": 2},
            {"solver_method": 3})


def _impacts_by(scene: Scene, t: float) -> int:
    sim = Simulator(scene.replace(solver_max_impacts=INT32_MAX))
    sim.advance(t)
    return sim.impact_count


@pytest.mark.parametrize("bad", [0, -1, 1.5, INT32_MAX + 1, math.nan, math.inf, True, "10"])
@pytest.mark.parametrize("name, default", [("max_impacts", MAX_IMPACTS),
                                           ("max_evaluations", MAX_EVALUATIONS)])
def test_the_budgets_are_positive_32_bit_integers(bad, name, default):
    with pytest.raises(ParameterError, match=rf"solver\.{name} = .* is not allowed: .*"
                                             rf"1 <= {name} <= 2147483647"):
        Scene(**{f"solver_{name}": bad})
    assert getattr(Scene(), f"solver_{name}") == default
    assert getattr(Scene(**{f"solver_{name}": INT32_MAX}), f"solver_{name}") == INT32_MAX
    assert (MAX_IMPACTS, MAX_EVALUATIONS) == (100_000, 4_000_000)


def _refused_unchanged(sim: Simulator, h: float) -> tuple[str, dict]:
    """A step of h that the simulator refuses: its message, and the simulator's record before
    it, which the refusal (and a second try) leaves as it was but for the record of why."""
    before = sim.save()
    with pytest.raises(SolverError) as refused:
        sim.advance(h)
    text = str(refused.value)
    after = sim.save()
    assert after.pop("failed").endswith(text) and before.pop("failed") is None
    assert after == before  # the refused step changed nothing else
    with pytest.raises(SolverError):  # the same step is refused again
        sim.advance(h)
    return text, before


@pytest.mark.parametrize("method", _METHODS, ids=["exact", "fixed-step", "ode"])
def test_a_step_over_the_budget_is_refused_and_changes_nothing(method):
    """Figure 2: ten impacts by t = 30 s. With a budget of 3, a 30 s step is refused with the
    budget, the time of the impact beyond it and the rate, and the simulator is exactly as before
    the step; a budget of exactly the step's impacts lets it through; 0.1 s steps then go on and
    end where a run without a budget ends."""
    scene = Scene(**method)
    n = _impacts_by(scene, 30.0)
    assert n == 10
    tight = Simulator(scene.replace(solver_max_impacts=3))
    tight.advance(1.0)
    text, _ = _refused_unchanged(tight, 29.0)
    assert "solver.max_impacts = 3" in text and "1 <= max_impacts <= 2147483647" in text
    assert "shorter communication steps" in text and "impacts a simulated second" in text
    assert Simulator(scene.replace(solver_max_impacts=n)).advance(30.0).impact_count == n
    free = Simulator(scene)
    free.advance(1.0)
    for k in range(290):
        tight.advance(1.0 + (k + 1) * 0.1 - tight.t)
        free.advance(1.0 + (k + 1) * 0.1 - free.t)
        assert max(tight.report.impacts, free.report.impacts) <= 3
    assert tight.solver.state == free.solver.state
    assert tight.impact_count == free.impact_count == n


def test_run_has_the_budget_per_sample_interval():
    """run() equals stepping a Simulator at its sample times, the budget included: each sample
    interval may make solver.max_impacts impacts, and one interval beyond it stops the run."""
    scene = Scene(solver_max_impacts=1)
    stepped = Simulator(scene)
    for k in range(300):
        stepped.advance((k + 1) * 0.1 - stepped.t)
    result = run(scene, 30.0, dt=0.1)
    assert len(result.impacts) == stepped.impact_count == 10
    assert result.x[-1] == stepped.solver.state.x
    with pytest.raises(SolverError, match=r"solver\.max_impacts = 3 "):
        run(Scene(solver_max_impacts=3), 30.0, dt=10.0)  # four impacts in the first 10 s
    assert len(run(Scene(solver_max_impacts=4), 30.0, dt=10.0).impacts) == 10


def test_the_cli_refuses_a_run_over_the_budget_with_exit_status_2():
    cmd = [sys.executable, "-m", "iceimpact.cli", "simulate", "--set", "solver.max_impacts=3",
           "--t-end", "30", "--dt"]
    out = subprocess.run([*cmd, "30"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2, out.stderr
    # worded as a refused step of the simulator: where the run stopped, then the budget
    assert ("iceimpact simulate: error: the run stopped at t = 0.0 s (the step to 30.0 s was "
            "refused; the state is as before it): the step needs more than solver.max_impacts "
            "= 3") in out.stderr
    assert "Traceback" not in out.stderr
    out = subprocess.run([*cmd, "1"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "10 impacts" in out.stdout, out.stderr


@pytest.mark.parametrize("budget", [{"solver.max_impacts": 3},
                                    {"solver.method": 3, "solver.max_evaluations": 3000}],
                         ids=["impacts", "evaluations"])
def test_the_fmu_discards_a_step_over_the_budget_and_goes_on(fmu_dir, model_description,
                                                             budget):
    """At the FMU, either budget: fmi2Discard with the core's message, outputs unchanged;
    shorter steps then go on and give the core's outputs."""
    name, value = list(budget.items())[-1]
    inst = Instance(fmu_dir, model_description)
    try:
        assert inst.initialize(budget) == FMI_OK
        assert inst.step(0.0, 1.0) == FMI_OK
        before = inst.outputs()
        assert inst.step(1.0, 29.0) == FMI_DISCARD
        assert f"the step needs more than {name} = {value} " in errors(inst)
        assert inst.outputs() == before
        for k in range(29):
            assert inst.step(1.0 + k, 1.0) == FMI_OK, errors(inst)
        sim = Simulator(Scene(**{key.replace(".", "_"): v for key, v in budget.items()}))
        for _ in range(30):
            want = sim.advance(1.0)
        got = inst.outputs()
        assert got["contact.count"] == want.impact_count == 10
        assert got["structure.x"] == pytest.approx(want.x, rel=0, abs=1e-12)
    finally:
        inst.free()


def _ringing_over_threshold(scene: Scene, sim: Simulator, u: float) -> float:
    """The stuck pair's ringing amplitude over the largest its drag holds, a closed form
    independent of the solver: stuck, (m + M) a = b (u - v) - k x and the contact force is
    lam = m a + k x = (m b (u - v) + M k x) / (m + M), so lam >= 0 while x >= -(m / M) x_eq,
    x_eq = b (u - v) / k the pair's equilibrium; the ringing about x_eq, of amplitude
    A = |(x - x_eq, v / omega_c)|, keeps lam >= 0 while A <= x_eq (m + M) / M."""
    m, M, k, b = scene.structure_m, scene.ice_M, scene.structure_k, scene.drag_b
    s = sim.solver.state
    x_eq = b * (u - s.v) / k
    omega_c = math.sqrt(k / (m + M))
    return math.hypot(s.x - x_eq, s.v / omega_c) / (x_eq * (m + M) / M)


def test_a_plastic_stick_part_cycle_ends_where_the_drag_holds_the_ringing():
    """The seed-49 scene at omega_n 1.7e5 rad/s (k / 1e4): stuck by a plastic impact, the pair
    rings beyond what its drag holds, parts once a period and meets again plastically, one
    impact a period of the stuck pair (omega_c / 2 pi = 23,418 a second), while the drag's
    damping of the pair, b / (2 (m + M)) = 0.1 1/s, brings the ringing down to the largest
    amplitude the drag holds. There the cycle ends (t = 0.11 s, 2,211 impacts) and the bodies
    stay stuck. On the search's scene (1.7e7 rad/s) the same cycle ends at t = 0.026 s after
    40,395 impacts, 14 s of CPU."""
    scene = Scene(**{**SEED_49, "structure_k": SEED_49["structure_k"] / 1e4})
    u = 0.1
    omega_c = math.sqrt(scene.structure_k / (scene.structure_m + scene.ice_M))
    sim = Simulator(scene)
    window = 0.01
    counts, over = [], []
    while sim.t < 0.5 - 1e-12:
        before = sim.impact_count
        r = sim.advance(window, u)
        counts.append(sim.impact_count - before)
        over.append(_ringing_over_threshold(scene, sim, u))
        assert r.impulse >= 0.0
    cycling = [k for k, n in enumerate(counts) if n > 0]
    end = cycling[-1]
    assert 0.08 < (end + 1) * window < 0.15
    # while it cycles: one impact a period of the stuck pair, the ringing above the threshold
    per_window = window * omega_c / (2.0 * math.pi)
    for k in cycling[2:-1]:
        assert abs(counts[k] - per_window) <= 1.0
        assert 1.0 < over[k] < 1.02
    # after: no impact, stuck, and the ringing within what the drag holds, decaying at the rate
    # of the drag's damping of the pair
    assert counts[end + 1:] == [0] * (len(counts) - end - 1)
    assert sim.sticking
    assert all(a < 1.0 for a in over[end + 1:])
    sigma = scene.drag_b / (2.0 * (scene.structure_m + scene.ice_M))
    decay = over[-1] / over[end + 1]
    assert decay == pytest.approx(math.exp(-sigma * (len(counts) - end - 2) * window), rel=1e-3)
    assert 2000 < sim.impact_count < 2500


def test_the_budget_refuses_a_long_step_of_the_stiff_stick_part_cycle_at_once():
    """On the search's own scene (omega_n 1.7e7 rad/s) a 10 s step would make ~40,000 impacts
    at ~0.3 ms each; a budget of 2,000 refuses it after a second or so of CPU, with the rate
    of its impacts (2.3e6 a simulated second, the stuck pair's frequency) in the message."""
    scene = Scene(**{**SEED_49, "solver_max_impacts": 2000})
    sim = Simulator(scene, record_impacts=False)
    with pytest.raises(SolverError, match=r"solver\.max_impacts = 2000 impacts") as refused:
        sim.advance(10.0, 0.1)
    assert sim.t == 0.0 and sim.impact_count == 0
    rate = float(str(refused.value).split(" impacts a simulated second")[0].rsplit(" ", 1)[1])
    assert 1e5 < rate < 3e6


def _as_twin(limited: Simulator, before: dict, h: float, want, made: int, budget: int,
             name: str) -> None:
    """The step of h with the budget: refused (naming it, and changing nothing but the record
    of why) exactly when the twin's same step made more than the budget, else the twin's."""
    try:
        got = limited.advance(h)
    except SolverError as exc:
        assert made > budget and name in str(exc), (made, str(exc))
        after = limited.save()
        assert after.pop("failed") and before.pop("failed") is None
        assert after == before
        return
    assert made <= budget
    assert got == want


@settings(max_examples=100, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(scene=scenes(), method=st.sampled_from([1, 2, 3]), budget=st.integers(1, 3),
       h=st.sampled_from([0.05, 0.25, 1.0]))
def test_the_budget_refuses_exactly_the_steps_that_need_more_impacts(scene, method, budget, h):
    """Random scenes over the extremes (tools/scene_strategies.py), each method: a twin without
    a budget steps the run; from each of its states a simulator with the budget takes the same
    step. It is refused exactly when the twin's step makes more than the budget's impacts, and
    then changes nothing but the record of why; otherwise it reports exactly the twin's step."""
    extra = {"solver_detection": 2} if method == 2 else {}
    try:
        twin = Simulator(scene.replace(solver_method=method, solver_max_impacts=INT32_MAX,
                                       **extra))
    except ParameterError:
        assume(False)
    t_end = 3.0 if method != 3 else 1.0
    while twin.t < t_end - 1e-12:
        snapshot = twin.save()
        limited = Simulator.from_snapshot(
            {**snapshot, "scene": {**snapshot["scene"], "solver.max_impacts": budget}})
        before = limited.save()
        # (the impacts the step makes: its report also counts one the start resolved at t = 0)
        made = -twin.impact_count
        want = twin.advance(h)
        made += twin.impact_count
        _as_twin(limited, before, h, want, made, budget, "solver.max_impacts")


# method 3's evaluation budget (solver.max_evaluations) ------------------------------------------
def _evaluations(sim: Simulator, h: float) -> int:
    """The right-hand-side evaluations a step of h is charged (it is taken): those of its
    integration chunks that end before the step does."""
    sim.advance(h)
    return sim.solver.step_evaluations


def test_a_step_over_the_evaluation_budget_is_refused_and_changes_nothing():
    """Method 3 on Figure 2: a 29 s step needs some 18,000 evaluations. With a budget of 3,000
    it is refused with the budget, where the integration stood and its rate, and the simulator
    is exactly as before the step; a budget of exactly the step's evaluations lets it through;
    0.5 s steps then go on and end where a run without a budget ends, to the bit."""
    scene = Scene(solver_method=3)
    free = Simulator(scene)
    free.advance(1.0)
    need = _evaluations(Simulator.from_snapshot(free.save()), 29.0)
    assert need > 3000
    tight = Simulator(scene.replace(solver_max_evaluations=3000))
    tight.advance(1.0)
    text, before = _refused_unchanged(tight, 29.0)
    assert "solver.max_evaluations = 3000 evaluations" in text
    assert "1 <= max_evaluations <= 2147483647" in text
    assert "shorter communication steps" in text and "evaluations a simulated second" in text
    exact = Simulator.from_snapshot({**before, "failed": None, "scene": {
        **before["scene"], "solver.max_evaluations": need}})
    exact.advance(29.0)  # exactly the step's evaluations: taken
    for _ in range(58):
        tight.advance(0.5)
        free.advance(0.5)
    assert tight.solver.state == free.solver.state
    assert tight.impact_count == free.impact_count


@pytest.mark.parametrize("method", [1, 2])
def test_methods_that_do_not_integrate_ignore_the_evaluation_budget(method):
    extra = {"solver_detection": 2} if method == 2 else {}
    scene = Scene(solver_method=method, **extra)
    limited = run(scene.replace(solver_max_evaluations=1), 30.0, dt=10.0)
    free = run(scene, 30.0, dt=10.0)
    assert np.array_equal(limited.x, free.x) and len(limited.impacts) == len(free.impacts)


def test_run_has_the_evaluation_budget_per_sample_interval():
    scene = Scene(solver_method=3, solver_max_evaluations=2000)
    with pytest.raises(SolverError, match=r"solver\.max_evaluations = 2000 evaluations"):
        run(scene, 30.0, dt=10.0)
    stepped = Simulator(scene)
    for k in range(60):
        stepped.advance((k + 1) * 0.5 - stepped.t)
    result = run(scene, 30.0, dt=0.5)
    assert result.x[-1] == stepped.solver.state.x
    assert len(result.impacts) == stepped.impact_count


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(scene=scenes(), budget=st.integers(50, 3000), h=st.sampled_from([0.05, 0.25, 1.0]))
def test_the_evaluation_budget_refuses_exactly_the_steps_that_need_more(scene, budget, h):
    """Random scenes over the extremes, method 3: from each state of a twin without a budget, a
    simulator with the budget takes the same step. It is refused exactly when the twin's step
    makes more evaluations than the budget (in the chunks that end before the step does: the
    one that reaches past it integrates ahead), and then changes nothing but the record of why;
    otherwise it reports exactly the twin's step."""
    try:
        twin = Simulator(scene.replace(solver_method=3, solver_max_evaluations=INT32_MAX))
    except ParameterError:
        assume(False)
    while twin.t < 1.0 - 1e-12:
        snapshot = twin.save()
        limited = Simulator.from_snapshot(
            {**snapshot, "scene": {**snapshot["scene"], "solver.max_evaluations": budget}})
        before = limited.save()
        want = twin.advance(h)
        made = twin.solver.step_evaluations
        _as_twin(limited, before, h, want, made, budget, "solver.max_evaluations")
