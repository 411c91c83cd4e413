"""Zeno sequences (0 < e < 1) against an independent reference (tests/zeno_reference.py: closed
forms in 80-digit arithmetic, followed bounce by bounce to 1e-24 s of the sequence's end): the
exact method follows each sequence to within ZENO_TIME (1e-9 s) of its end and the bodies stick
there, not where a bounce first falls below the chatter time (docs/explanation/accuracy.md,
"Zeno sequences and sticking").

The default scene with e = 0.5 is followed from t = 0. With e = 0.8 the scene amplifies rounding
(a change of 1e-18 m at the start moves its sticking by milliseconds at 26 s, pinned below), so
no double-precision run follows it from t = 0: the reference is restarted from the method's own
state, after every impact for the flights, and before the bounces fall below the chatter time
for each sequence, its sticking and its release.
"""

from __future__ import annotations

import math

import mpmath as mp
import pytest

import zeno_reference
from iceimpact import Scene, Simulator, run
from iceimpact.simulator import make_solver
from iceimpact.solvers.contact_rules import ZENO_BUDGET, ZENO_TIME, chatter_time

#: The tolerances asked for: sticking starts and releases, impacts (s).
PHASE_TOL, IMPACT_TOL = 1e-6, 1e-9


def events(scene: Scene, t_end: float):
    """A run of method 1 or 3 event by event: the solver, its sticking starts and releases."""
    solver = make_solver(scene)
    starts, releases = [], []
    was = solver.sticking
    while True:
        event = solver.next_event(t_end)
        if event is None:
            break
        t_event = event[0] if isinstance(event, tuple) else solver.seg.t0 + event
        solver.impulse_to(event)
        solver.take_event(event)
        if solver.sticking and not was:
            starts.append(solver.sticking_since)
        elif was and not solver.sticking:
            releases.append(t_event)
        was = solver.sticking
    return solver, starts, releases


def chunks(times, starts):
    """Impact times split at the sticking starts."""
    out, k = [[]], 0
    for t in times:
        while k < len(starts) and t > starts[k]:
            out.append([])
            k += 1
        out[-1].append(t)
    return out


def test_e_05_follows_the_reference_from_the_start():
    """Figure 2's scene with e = 0.5 over 12 s: 2 sticking phases, 1 release. Each sticking
    start within ZENO_TIME of the reference's (measured 5.2e-10 and 8.1e-10 s early; the chatter
    closure started them 4.3 and 3.5 ms early), the release within 1e-11 s (measured 3.4e-13 s),
    and every impact the method makes within 1e-10 s of the reference's (measured 2.2e-11 s, the
    rounding the motion amplifies over 12 s); the method's impacts of a sequence are the
    reference's first ones, the rest falling within ZENO_TIME of its closing impact."""
    solver, starts, releases = events(Scene(impact_e=0.5), 12.0)
    ref = zeno_reference.default_scene(0.5).run(12.0)
    ref_starts = [float(t) for t in ref.stick_starts]
    assert len(starts) == len(ref_starts) == 2 and len(releases) == len(ref.releases) == 1
    for got, want in zip(starts, ref_starts, strict=True):
        assert abs(got - want) <= ZENO_TIME
    assert abs(releases[0] - float(ref.releases[0])) <= 1e-11
    mine = chunks([i.t for i in solver.impacts], starts)
    theirs = chunks([float(i[0]) for i in ref.impacts], ref_starts)
    for got, want in zip(mine, theirs, strict=True):
        assert 0 < len(got) <= len(want)
        assert max(abs(a - b) for a, b in zip(got, want, strict=False)) <= 1e-10
        assert want[-1] - got[-1] <= ZENO_TIME  # the bounces the closure skips
    closing = [i for i in solver.impacts if i.restitution == 0.0]
    assert [i.t for i in closing] == starts


def _reference_from(e: float, impact, t_end: float, **kw):
    """The reference restarted from the state after one of the method's impacts."""
    state = (impact.x, impact.v_plus, impact.x, impact.w_plus)
    return zeno_reference.default_scene(e, impact.t, state).run(t_end, **kw)


@pytest.mark.parametrize("e, t_end", [(0.5, 12.0), (0.8, 30.0)])
def test_each_sequence_its_sticking_and_release_follow_the_reference(e, t_end):
    """Restarted from the method's state at the last impact before its bounces fall below the
    chatter time (2.5 ms, where the chatter closure used to end them), the reference's bounces
    match the method's within 1e-9 s, its sticking starts within 1e-6 s (within ZENO_TIME), and
    its release (and the impact after it) within 1e-6 s. Measured: e = 0.5, 24 and 23 impacts
    within 3.6e-15 s, the starts 5.2e-10 and 8.3e-10 s early, the release within 3.6e-15 s;
    e = 0.8, 74 impacts within 2.8e-14 s, the start 8.3e-10 s early."""
    solver, starts, releases = events(Scene(impact_e=e), t_end)
    assert starts
    threshold = chatter_time(Scene().omega_n, Scene().solver_chatter_fraction)
    impacts = solver.impacts
    for k, start in enumerate(starts):
        closing = next(i for i, imp in enumerate(impacts) if imp.t == start)
        first = closing
        while first > 0 and impacts[first].t - impacts[first - 1].t < threshold:
            first -= 1
        first -= 1  # the impact whose flight is the last one longer than the chatter time
        release = releases[k] if k < len(releases) else None
        horizon = t_end if release is None else release + 0.5
        ref = _reference_from(e, impacts[first], horizon)
        ref_start = float(ref.stick_starts[0])
        assert abs(start - ref_start) <= ZENO_TIME
        got = [imp.t for imp in impacts[first + 1:closing + 1]]
        want = [float(i[0]) for i in ref.impacts if i[0] <= ref.stick_starts[0]]
        assert len(got) <= len(want)
        assert max(abs(a - b) for a, b in zip(got, want, strict=False)) <= IMPACT_TOL
        assert want[-1] - got[-1] <= ZENO_TIME
        if release is not None:
            assert abs(release - float(ref.releases[0])) <= PHASE_TOL
            after_mine = next(imp.t for imp in impacts if imp.t > release)
            after_ref = next(float(i[0]) for i in ref.impacts if i[0] > ref.releases[0])
            assert abs(after_mine - after_ref) <= IMPACT_TOL


def test_every_flight_of_e_08_follows_the_reference():
    """Restarted from the method's state after each of its impacts up to its sticking (e = 0.8,
    26 s; 125 impacts, its sequence's included), the reference's next impact is the method's
    within 1e-9 s (measured: 8e-15 s)."""
    solver, starts, _ = events(Scene(impact_e=0.8), 27.0)
    impacts = [i for i in solver.impacts if i.t < starts[0]]
    worst = 0.0
    for before, after in zip(impacts, impacts[1:], strict=False):
        ref = _reference_from(0.8, before, after.t + 1.0, max_impacts=1)
        worst = max(worst, abs(float(ref.impacts[0][0]) - after.t))
    assert worst <= IMPACT_TOL


def test_the_e_08_scene_amplifies_a_change_of_1e18_m_into_milliseconds():
    """Why e = 0.8 is compared flight by flight: in the reference itself, the ice starting
    1e-18 m further upstream sticks more than 1e-3 s apart (17 ms), its 15th impact already
    2.8e-9 s apart. A double-precision run, whose first position carries rounding of that order,
    cannot follow it from t = 0."""
    base = zeno_reference.default_scene(0.8).run(27.0)
    z0 = mp.mpf(-0.01) * (1 + mp.mpf("1e-16"))
    moved = zeno_reference.default_scene(0.8, state=(0.0, 0.0, z0, 0.01)).run(27.0)
    assert abs(moved.stick_starts[0] - base.stick_starts[0]) > 1e-3
    assert abs(moved.impacts[15][0] - base.impacts[15][0]) > IMPACT_TOL


def test_method_3_follows_the_reference_to_its_tolerance():
    """Method 3 (DOP853) follows the same rule; its sticking starts and release approach the
    reference's as its tolerance tightens: within 4e-4 s at rtol 1e-8 (measured 1.2e-4, 3.9e-4 and
    5.1e-6 s; its bounces are closed once no higher than its positions' noise, at their estimated
    end), within 1e-7 s at rtol 1e-12 (measured 6.9e-9, 2.3e-8, 3.5e-10 s)."""
    ref = zeno_reference.default_scene(0.5).run(12.0)
    want = [float(t) for t in ref.stick_starts] + [float(t) for t in ref.releases]
    for rtol, tol in ((1e-8, 4e-4), (1e-12, 1e-7)):
        _, starts, releases = events(Scene(impact_e=0.5, solver_method=3, solver_rtol=rtol),
                                     12.0)
        got = starts + releases
        assert len(got) == len(want)
        assert max(abs(a - b) for a, b in zip(got, want, strict=True)) <= tol, rtol


def test_a_sequence_beyond_the_budget_sticks_at_its_estimated_end():
    """e = 0.9: from the chatter time on, the sequence would take ~170 bounces, more than
    ZENO_BUDGET. It is closed at its first bounce shorter than the chatter time: one plastic
    impact, the bodies moving together (gap 0, not yet sticking), and sticking from the
    estimated end ``t + bounce / (1 - e)``, 24 ms later. Against the reference restarted from
    the state before that impact: the estimated end within 2e-3 s of the true one (measured
    1.0e-3 s early, 4 % of the tail: the geometric series takes the contact force of the closing
    impact for the whole tail; the chatter closure was 25 ms early)."""
    e = 0.9
    scene = Scene(impact_e=e)
    omega, fraction = scene.omega_n, scene.solver_chatter_fraction
    bounces = math.log(chatter_time(omega, fraction) / ((1 - e) * ZENO_TIME)) / math.log(1 / e)
    assert bounces > ZENO_BUDGET
    solver, starts, _ = events(scene, 40.0)
    closing = next(i for i in solver.impacts if i.restitution == 0.0)
    assert starts[0] - closing.t > 0.01
    before = solver.impacts[solver.impacts.index(closing) - 1]
    ref = _reference_from(e, before, 40.0)
    assert abs(starts[0] - float(ref.stick_starts[0])) <= 2e-3
    # the tail: together, not sticking, then sticking from its end
    sim = Simulator(scene)
    while sim.t < closing.t:
        sim.advance(1e-3)
    reports = [sim.advance(1e-3) for _ in range(40)]
    tail = [r for r in reports if r.t < starts[0]]
    assert tail and all(r.gap == 0.0 and not r.sticking for r in tail)
    assert all(r.sticking for r in reports if r.t > starts[0])
    assert sim.solver.sticking_since == starts[0]


@pytest.mark.parametrize("method", [1, 3])
def test_a_state_saved_in_a_tail_continues_identically(method):
    """A state saved while the bodies move together towards a Zeno sequence's estimated end
    (e = 0.9: not yet sticking, ``zeno_end`` set) and restored into a new simulator, through
    JSON, gives the same steps to the bit as the run that went on: the tail's end is state."""
    import json

    scene = Scene(impact_e=0.9, solver_method=method)
    sim = Simulator(scene)
    while sim.solver.zeno_end is None:
        sim.advance(1e-3)
    assert not sim.solver.sticking
    saved = json.loads(json.dumps(sim.save()))
    went_on = [sim.advance(1e-3) for _ in range(60)]
    restored = Simulator.from_snapshot(saved)
    assert restored.solver.zeno_end == saved["solver"]["zeno_end"]
    again = [restored.advance(1e-3) for _ in range(60)]
    assert again == went_on
    assert not went_on[0].sticking and went_on[-1].sticking


def test_a_tail_in_a_snapshot_is_checked():
    """A snapshot whose tail contradicts its phase is refused, naming the field."""
    from iceimpact import StateError

    sim = Simulator(Scene(impact_e=0.9))
    while sim.solver.zeno_end is None:
        sim.advance(1e-3)
    saved = sim.save()
    bad = json_copy(saved)
    bad["solver"]["sticking"], bad["solver"]["sticking_since"] = True, bad["solver"]["t"]
    with pytest.raises(StateError, match="zeno_end"):
        Simulator.from_snapshot(bad)
    bad = json_copy(saved)
    bad["solver"]["zeno_end"] = bad["solver"]["t"] - 1.0
    with pytest.raises(StateError, match="zeno_end"):
        Simulator.from_snapshot(bad)


def json_copy(data):
    import json

    return json.loads(json.dumps(data))


def test_run_samples_a_tail_as_the_steps_give_it():
    """run()'s sampler marches through a Zeno tail (its end is an event of the solver, not of
    the segment) and gives what a Simulator stepped to each sample gives: the same sticking
    flags and impact count, states to 1e-14 m, impulses to 1e-10 N.s (measured 2.8e-15 m and
    9e-12 N.s, the level of the runs without a tail: 2e-12 N.s at e = 0.5)."""
    scene = Scene(impact_e=0.9)
    result = run(scene, 40.0, dt=1e-2)
    sim = Simulator(scene)
    reports = [sim.advance(1e-2) for _ in range(4000)]
    assert [r.sticking for r in reports] == result.sticking[1:].tolist()
    assert max(abs(r.x - x) for r, x in zip(reports, result.x[1:], strict=True)) < 1e-14
    assert max(abs(r.impulse - j) for r, j in zip(reports, result.impulse[1:],
                                                  strict=True)) < 1e-10
    assert len(result.impacts) == sim.impact_count
    assert result.sticking_since == sim.sticking_since > 36.4
