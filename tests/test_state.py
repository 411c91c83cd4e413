"""Saved states and refused steps: a small record of plain data that continues a run to the last
bit (through JSON), is refused field by field when malformed, and a step the method refuses
changes nothing."""

import copy
import json
import math
import pickle

import numpy as np
import pytest

from iceimpact import ParameterError, Scene, Simulator, SolverError, StateError, run
from iceimpact.record import STATE_VERSION

METHODS = {"exact": dict(solver_method=1),
           "fixed-step": dict(solver_method=2, solver_detection=2),
           "ode": dict(solver_method=3)}

#: communication steps (h, u) after a save: uneven steps and two flow changes
SUFFIX = ([(0.01, 0.1)] * 30 + [(0.013, 0.1)] * 7 + [(0.01, 0.3)] * 20 + [(0.007, -0.1)] * 20
          + [(0.01, 0.1)] * 40)


def json_copy(data):
    return json.loads(json.dumps(data))


def steps(sim, inputs):
    return [sim.advance(h, u) for h, u in inputs]


def stepped(scene, t_stop, u_before=0.1, **options):
    sim = Simulator(scene, **options)
    while sim.t < t_stop - 1e-9:
        sim.advance(0.01, u_before)
    return sim


def assert_continues_identically(sim, inputs=SUFFIX):
    """Save, round-trip through JSON, restore into fresh simulators: the same future."""
    saved = json_copy(sim.save())
    twin = Simulator(Scene())  # any simulator takes a state, its scene included
    twin.restore(saved)
    fresh = Simulator.from_snapshot(saved)
    expected = steps(sim, inputs)
    assert steps(fresh, inputs) == expected
    assert steps(twin, inputs) == expected
    assert fresh.save() == sim.save() == twin.save()
    return saved


# --- round trips ----------------------------------------------------------------------------------

@pytest.mark.parametrize("drag_model", [1, 2])
@pytest.mark.parametrize("method", list(METHODS))
def test_json_round_trip_continues_to_the_last_bit(method, drag_model):
    """Mid-flight, mid-sticking (e = 0 sticks after its first impacts), after a flow change."""
    scene = Scene(impact_e=0.0, drag_model=drag_model, **METHODS[method])
    sim = Simulator(scene)
    for t_stop, u in ((0.55, 0.1), (3.0, 0.1), (9.0, 0.1), (9.5, 0.25)):
        while sim.t < t_stop - 1e-9:
            sim.advance(0.01, u)
        assert_continues_identically(sim)


@pytest.mark.parametrize("drag_model", [1, 2])
@pytest.mark.parametrize("method", list(METHODS))
def test_round_trip_in_elastic_bouncing(method, drag_model):
    sim = stepped(Scene(impact_e=1.0, drag_model=drag_model, **METHODS[method]), 4.0)
    assert sim.impact_count > 0
    assert_continues_identically(sim)


def test_round_trip_inside_a_quadratic_sticking_step():
    """Exact method, quadratic drag, sticking: the saved state holds the start of the current
    Taylor step, which a restored solver takes again to the same polynomials."""
    sim = stepped(Scene(impact_e=0.0, drag_model=2), 30.0)
    segment = sim.save()["solver"]["segment"]
    assert segment["phase"] == "stick" and len(segment["steps"]) == 1
    lo, _ = segment["steps"][-1]
    assert lo < sim.t - segment["t0"]
    assert_continues_identically(sim, [(0.01, 0.1)] * 300 + [(0.01, -0.2)] * 100)


def test_round_trip_inside_the_fixed_step_look_ahead():
    scene = Scene(solver_method=2, solver_detection=2, drag_model=2, impact_e=0.5)
    sim = stepped(scene, 1.0)
    buffer = sim.save()["solver"]["buffer"]
    assert buffer is not None and buffer["n"] < sim.save()["solver"]["n"]
    assert_continues_identically(sim)


def test_round_trip_inside_an_ode_chunk():
    sim = stepped(Scene(solver_method=3), 1.234)
    state = sim.save()["solver"]
    assert state["y_lo"] is not None and state["t_lo"] < sim.t < state["t_hi"]
    assert_continues_identically(sim)


@pytest.mark.parametrize("method", list(METHODS))
def test_round_trip_after_a_restitution_change(method):
    sim = stepped(Scene(impact_e=0.9, **METHODS[method]), 2.0)
    sim.set_restitution(0.2)
    sim.advance(0.01)
    saved = assert_continues_identically(sim)
    assert saved["scene"]["impact.e"] == saved["solver"]["e"] == 0.2


def test_rollback_in_the_same_simulator_keeps_the_impact_history():
    sim = stepped(Scene(impact_e=0.5), 3.0)
    saved = sim.save()
    before = list(sim.impacts)
    first = steps(sim, SUFFIX * 3)
    assert len(sim.impacts) > len(before)
    sim.restore(saved)
    assert sim.impacts == before
    assert steps(sim, SUFFIX * 3) == first


def test_pickled_state_replays():
    """The FMU serializes the state with pickle: a dict of plain data."""
    sim = stepped(Scene(drag_model=2, impact_e=0.3), 5.0)
    saved = pickle.loads(pickle.dumps(sim.save()))
    expected = steps(sim, SUFFIX)
    sim.restore(saved)
    assert steps(sim, SUFFIX) == expected


def test_layout_is_plain_data_with_a_version():
    saved = Simulator(Scene()).save()
    assert set(saved) == {"version", "scene", "solver", "report", "reported_impacts", "failed"}
    assert saved["version"] == saved["solver"]["version"] == STATE_VERSION
    assert saved["scene"] == Scene().to_fmi()

    def plain(value):
        if isinstance(value, dict):
            return all(isinstance(k, str) and plain(v) for k, v in value.items())
        if isinstance(value, list):
            return all(plain(v) for v in value)
        return value is None or type(value) in (str, float, int, bool)

    for method in METHODS.values():
        for drag_model in (1, 2):
            saved = stepped(Scene(impact_e=0.0, drag_model=drag_model, **method), 2.0).save()
            assert plain(saved)
            assert json_copy(saved) == saved


# --- size and the impact list --------------------------------------------------------------------

SIZE_SCENES = {  # scenes that keep impacting: elastic chatter, a heavy floe on a fixed grid
    "exact": (Scene(), 10_000), "ode": (Scene(solver_method=3), 300),
    "fixed-step": (Scene(ice_M=4800.0, impact_e=0.3, **METHODS["fixed-step"]), 10_000)}


@pytest.mark.parametrize("method", list(METHODS))
def test_saved_state_stays_small_at_any_run_length(method):
    """The impact history is not part of the state: the size after 1e4 impacts (300 for the
    slower ODE method) is that after 10."""
    scene, target = SIZE_SCENES[method]
    sim = Simulator(scene, record_impacts=False)
    while sim.report.impact_count < 10:
        sim.advance(0.05)
    early = len(json.dumps(sim.save()))
    while sim.report.impact_count < target:
        sim.advance(1.0)
    late = len(json.dumps(sim.save()))
    assert early <= 16_384 and late <= 16_384
    assert abs(late - early) < 500
    assert sim.impacts == []


@pytest.mark.parametrize("method", list(METHODS))
def test_unrecorded_impacts_change_no_report(method):
    scene = Scene(impact_e=0.5, drag_model=2, **METHODS[method])
    recorded, bare = Simulator(scene), Simulator(scene, record_impacts=False)
    assert steps(bare, SUFFIX) == steps(recorded, SUFFIX)
    assert bare.impacts == [] and len(recorded.impacts) == recorded.impact_count > 0
    assert bare.impact_count == recorded.impact_count


# --- refusals ------------------------------------------------------------------------------------

def _set(path, value):
    def change(state):
        target = state
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
    return change


def _drop(path):
    def change(state):
        target = state
        for key in path[:-1]:
            target = target[key]
        del target[path[-1]]
    return change


BAD_EXACT = {
    "version": (_set(("version",), 99), "version"),
    "missing report": (_drop(("report",)), "report"),
    "unknown key": (_set(("extra",), 1), "extra"),
    "scene value": (_set(("scene", "ice.M"), -1.0), "scene.ice.M"),
    "scene name": (_set(("scene", "ice.mass"), 1.0), "scene.ice.mass"),
    "scene type": (_set(("scene",), [1, 2]), "scene"),
    "reported > count": (_set(("reported_impacts",), 10**6), "reported_impacts"),
    "report type": (_set(("report", "impacts"), 1.5), "report.impacts"),
    "report time": (_set(("report", "t"), 123.0), "report.t"),
    "failed type": (_set(("failed",), 3), "failed"),
    "solver type": (_set(("solver",), "x"), "solver"),
    "method": (_set(("solver", "method"), "ode"), "solver.method"),
    "time NaN": (_set(("solver", "t"), math.nan), "solver.t"),
    "time negative": (_set(("solver", "t"), -1.0), "solver.t"),
    "x infinite": (_set(("solver", "x"), math.inf), "solver.x"),
    "x text": (_set(("solver", "x"), "0.0"), "solver.x"),
    "x bool": (_set(("solver", "x"), True), "solver.x"),
    "e range": (_set(("solver", "e"), 1.5), "solver.e"),
    "count negative": (_set(("solver", "impact_count"), -1), "solver.impact_count"),
    "count float": (_set(("solver", "impact_count"), 3.0), "solver.impact_count"),
    "t_last after t": (_set(("solver", "t_last"), 1e9), "solver.t_last"),
    "t_last without impacts": (_set(("solver", "impact_count"), 0), "solver.t_last"),
    "sticking type": (_set(("solver", "sticking"), 1), "solver.sticking"),
    "sticking_since": (_set(("solver", "sticking_since"), 0.1), "solver.sticking_since"),
    "missing tau": (_drop(("solver", "tau")), "solver.tau"),
    "pending NaN": (_set(("solver", "pending_impulse"), math.nan), "solver.pending_impulse"),
    "degenerate run": (_set(("solver", "degenerate", "run"), -2), "solver.degenerate.run"),
    "phase": (_set(("solver", "segment", "phase"), "orbit"), "solver.segment.phase"),
    "phase vs sticking": (_set(("solver", "segment", "phase"), "stick"),
                          "solver.segment.phase"),
    "anchor length": (_set(("solver", "segment", "anchor"), [0.0, 0.0]),
                      "solver.segment.anchor"),
    "anchor NaN": (_set(("solver", "segment", "anchor", 2), math.nan),
                   "solver.segment.anchor[2]"),
    "search a": (_set(("solver", "segment", "search", "a"), -5.0), "solver.segment.search.a"),
    "search iterations": (_set(("solver", "segment", "search", "iterations"), "many"),
                          "solver.segment.search.iterations"),
    "search missing": (_drop(("solver", "segment", "search", "creep")),
                       "solver.segment.search.creep"),
}


@pytest.fixture(scope="module")
def exact_state():
    sim = stepped(Scene(impact_e=0.5), 2.0)
    assert sim.impact_count > 0 and not sim.sticking
    return sim.save()


def assert_refused_and_unchanged(sim, state, field):
    before = sim.save()
    twin = Simulator.from_snapshot(before)
    with pytest.raises(StateError) as err:
        sim.restore(state)
    assert err.value.field == field
    assert f"state field {field} = " in str(err.value) and "is not allowed" in str(err.value)
    assert sim.save() == before
    assert steps(sim, SUFFIX[:40]) == steps(twin, SUFFIX[:40])
    with pytest.raises(StateError):
        Simulator.from_snapshot(state)


@pytest.mark.parametrize("case", list(BAD_EXACT))
def test_malformed_state_is_refused_naming_the_field(exact_state, case):
    change, field = BAD_EXACT[case]
    state = copy.deepcopy(exact_state)
    change(state)
    sim = stepped(Scene(impact_e=0.9, drag_model=2), 1.0)  # a different run, left unchanged
    assert_refused_and_unchanged(sim, state, field)


BAD_OTHERS = {
    ("fixed-step", "chunk"): (_set(("solver", "chunk"), 3), "solver.chunk"),
    ("fixed-step", "grid"): (_set(("solver", "grid"), [0.0, 0.0, 0.0]), "solver.grid"),
    ("fixed-step", "pinned"): (_set(("solver", "pinned"), True), "solver.pinned"),
    ("fixed-step", "buffer"): (_set(("solver", "buffer"), {"n": -1, "grid": [0.0] * 4}),
                               "solver.buffer.n"),
    ("ode", "phase"): (_set(("solver", "phase"), "fly"), "solver.phase"),
    ("ode", "y_hi"): (_set(("solver", "y_hi"), [0.0, 0.0, 0.0]), "solver.y_hi"),
    ("ode", "t_hi"): (_set(("solver", "t_hi"), -1.0), "solver.t_hi"),
    ("ode", "event"): (lambda state: state["solver"].update(event=[state["solver"]["t_hi"],
                                                                   "y"]), "solver.event.y"),
    ("ode", "event time"): (lambda state: state["solver"].update(event=[-1.0, [0.0] * 4]),
                            "solver.event.t"),
    ("ode", "nfev"): (_set(("solver", "nfev"), None), "solver.nfev"),
    ("exact", "steps"): (_set(("solver", "segment", "steps"), [[1.0, [0.0] * 3], [0.5, [0.0] * 3]]),
                         "solver.segment.steps[1].lo"),
    ("exact", "step"): (_set(("solver", "segment", "steps"), [[0.0]]),
                        "solver.segment.steps[0]"),
    ("exact", "step state"): (_set(("solver", "segment", "steps"), [[0.0, [0.0, math.nan, 0.0]]]),
                              "solver.segment.steps[0].y_lo[1]"),
}


@pytest.mark.parametrize("key", list(BAD_OTHERS), ids=lambda k: "-".join(k))
def test_malformed_method_fields_are_refused(key):
    method, _ = key
    change, field = BAD_OTHERS[key]
    scene = Scene(drag_model=2, impact_e=0.0 if method == "exact" else 0.5, **METHODS[method])
    state = stepped(scene, 30.0 if method == "exact" else 3.0).save()  # exact: sticking
    change(state)
    assert_refused_and_unchanged(stepped(scene, 0.5), state, field)


def test_state_error_is_a_value_error():
    assert issubclass(StateError, ValueError)
    with pytest.raises(StateError, match="a dict"):
        Simulator(Scene()).restore(("old", "tuple", "snapshot"))


# --- refused steps -------------------------------------------------------------------------------

def test_refused_unstable_step_changes_nothing():
    """Method 2, quadratic drag: a flow spike makes the explicit Euler step diverge. The step is
    refused, the state is the one before it, the same spike is refused again, and a sane step
    from the same time reports what a run that never saw the spike reports."""
    scene = Scene(drag_model=2, impact_e=0.5, solver_method=2, solver_detection=2)
    clean = steps(Simulator(scene), [(0.01, 0.1)] * 400)
    k = next(i for i, r in enumerate(clean) if i > 10 and r.impacts > 0)  # a step with impacts
    sim = Simulator(scene)
    steps(sim, [(0.01, 0.1)] * k)
    before = sim.save()
    for _ in range(2):
        with pytest.raises(SolverError, match="the run stopped") as err:
            sim.advance(0.01, 1e5)
        assert "explicit Euler step" in str(err.value)
        assert sim.failed is not None
        assert {k: v for k, v in sim.save().items() if k != "failed"} == {
            k: v for k, v in before.items() if k != "failed"}
    after = steps(sim, [(0.01, 0.1)] * (400 - k))
    assert after == clean[k:]
    assert sim.failed is None
    assert after[0].impacts > 0 and after[0].impulse > 0.0


class _Fails:
    """Wraps a solver method: raises once, on the n-th call, after the real work of the first
    n - 1 calls (the step has already changed the solver when it fails)."""

    def __init__(self, method, n, error):
        self.method, self.n, self.error, self.calls = method, n, error, 0

    def __call__(self, *args, **kwargs):
        self.calls += 1
        if self.calls == self.n:
            raise self.error
        return self.method(*args, **kwargs)


@pytest.mark.parametrize("error", [SolverError("integration failed"), FloatingPointError("x")],
                         ids=["SolverError", "other"])
@pytest.mark.parametrize("method", ["exact", "ode"])
def test_step_failing_midway_changes_nothing(method, error):
    """A failure after some impacts of a long step: the next step from the same time reports
    the full impulse of its interval, each impact counted once."""
    scene = Scene(impact_e=0.7, **METHODS[method])
    sim, clean = Simulator(scene), Simulator(scene)
    steps(sim, [(0.01, 0.1)] * 50)
    steps(clean, [(0.01, 0.1)] * 50)
    solver = sim.solver
    solver.bounces = None  # (every impact through _record: tests/solvers/exact/test_bounces.py
    # fails the compiled march midway)
    before = sim.save()
    solver._record = _Fails(solver._record, 3, error)
    with pytest.raises(type(error)):
        sim.advance(12.0)
    assert solver._record.calls == 3  # two impacts were made before the failure
    del solver._record
    assert {k: v for k, v in sim.save().items() if k != "failed"} == {
        k: v for k, v in before.items() if k != "failed"}
    assert sim.advance(12.0) == clean.advance(12.0)
    assert sim.report.impacts >= 3
    assert steps(sim, SUFFIX) == steps(clean, SUFFIX)
    assert sim.impacts == clean.impacts


def test_step_failing_midway_from_a_linear_sticking_phase_changes_nothing():
    """The exact method's quick checkpoint of a linear sticking phase: a step that re-anchors
    it on a flow reversal, marches to the separation and fails there changes nothing."""
    scene = Scene(impact_e=0.0, flow_u=0.5)
    sim, clean = Simulator(scene), Simulator(scene)
    steps(sim, [(0.01, 0.5)] * 300)
    steps(clean, [(0.01, 0.5)] * 300)
    assert sim.sticking and type(sim.solver.seg).__name__ == "LinearStick"
    before = sim.save()
    solver = sim.solver
    solver._fly_from_contact = _Fails(solver._fly_from_contact, 1, SolverError("at separation"))
    with pytest.raises(SolverError):
        sim.advance(12.0, -0.2)
    assert solver._fly_from_contact.calls == 1
    del solver._fly_from_contact
    assert {k: v for k, v in sim.save().items() if k != "failed"} == {
        k: v for k, v in before.items() if k != "failed"}
    assert sim.advance(12.0, -0.2) == clean.advance(12.0, -0.2)
    assert not sim.sticking
    assert steps(sim, SUFFIX) == steps(clean, SUFFIX)


@pytest.mark.parametrize("h", [0.0, -0.01, math.nan, math.inf, True, "0.01", None])
def test_bad_step_is_refused_and_changes_nothing(h):
    scene = Scene(ice_z0=0.0, ice_v0=0.05, impact_e=0.5)  # an impact at t = 0: pending impulse
    sim, clean = Simulator(scene), Simulator(scene)
    with pytest.raises(ParameterError, match="communication step"):
        sim.advance(h)
    assert sim.save() == clean.save()
    first = sim.advance(0.01)
    assert first == clean.advance(0.01) and first.impacts == 1 and first.impulse > 0.0


@pytest.mark.parametrize("u", [math.nan, math.inf, "0.1", 1e300])
def test_bad_flow_is_refused_and_changes_nothing(u):
    sim, clean = stepped(Scene(drag_model=2), 1.0), stepped(Scene(drag_model=2), 1.0)
    with pytest.raises(ParameterError, match="flow.u"):
        sim.advance(0.01, u)
    assert sim.save() == clean.save()
    assert steps(sim, SUFFIX) == steps(clean, SUFFIX)


def test_step_too_small_to_advance_the_time_is_refused():
    sim = stepped(Scene(), 2.0)
    before = sim.save()
    with pytest.raises(ParameterError) as err:
        sim.advance(1e-17)
    assert err.value.name == "communication step" and "t + h > t" in str(err.value)
    assert sim.save() == before
    sim.advance(1e-15)  # representable: fine
    with pytest.raises(ParameterError, match="communication point"):
        sim.advance_to(sim.t)


# --- run() on the simulator ----------------------------------------------------------------------

@pytest.mark.parametrize("method", ["fixed-step", "ode"])
def test_run_reports_what_the_simulator_reports(method):
    scene = Scene(impact_e=0.5, drag_model=2, **METHODS[method])
    res = run(scene, 3.0, dt=0.05)
    sim = Simulator(scene)
    reports = [sim.report] + [sim.advance_to(float(t)) for t in res.t[1:]]
    assert np.array_equal(res.x, [r.x for r in reports])
    assert np.array_equal(res.gap, [r.gap for r in reports])
    assert np.array_equal(res.impulse, [r.impulse for r in reports])
    assert np.all(res.gap >= 0.0) and np.all(res.penetration >= 0.0)
    assert len(res.impacts) == sim.impact_count


#: a heavy floe's deflection when kicked in contact: four times its drag at u = 2 m/s over k
_KICKED_X0 = Scene(drag_model=2).drag_B * 4.0 / Scene().structure_k

#: exact-method scenes for run()'s vectorised sampling, with their horizons (s): every kind of
#: segment (flight, linear and quadratic sticking), under- and over-damped sticking
SAMPLED_SCENES = {
    "quadratic e=0.5": (dict(impact_e=0.5, drag_model=2), 10.0),
    "linear e=0.5": (dict(impact_e=0.5, ice_M=400.0), 10.0),
    "linear e=0": (dict(impact_e=0.0, flow_u=0.5), 3.0),
    "overdamped sticking": (dict(impact_e=0.3, structure_c=2.0 * math.sqrt(1e6 * 3200.0),
                                 flow_u=0.5), 3.0),
    "overdamped": (dict(impact_e=0.0, structure_c=2e5, structure_k=1e5, flow_u=0.5), 3.0),
    # a heavy floe kicked while in contact: four quadratic sticking phases that part again
    "quadratic sticking parts": (dict(impact_e=0.3, drag_model=2, ice_M=6400.0, flow_u=2.0,
                                      structure_x0=_KICKED_X0, structure_v0=0.3,
                                      ice_z0=_KICKED_X0, ice_v0=0.3), 5.0),
    # ice faster than a slow flow, stuck to the structure: u - v changes sign, then they part
    "quadratic sticking flips": (dict(impact_e=0.0, drag_model=2, flow_u=0.01,
                                      structure_x0=1e-3, structure_v0=0.05, ice_z0=1e-3,
                                      ice_v0=0.05), 3.0),
}


@pytest.mark.parametrize("name", list(SAMPLED_SCENES))
def test_run_samples_what_the_simulator_reports_to_rounding(name):
    """The exact method's run() marches the same events and evaluates the samples in
    vectorised closed forms: the simulator's reports to rounding, the same impacts."""
    values, t_end = SAMPLED_SCENES[name]
    scene = Scene(**values)
    res = run(scene, t_end, dt=0.02)
    sim = Simulator(scene)
    reports = [sim.report] + [sim.advance_to(float(t)) for t in res.t[1:]]
    # the closed forms add terms as large as the positions and the ice's drift with the flow
    scale = np.max(np.abs(res.x)) + np.max(np.abs(res.z)) + abs(scene.flow_u) * t_end
    for name_ in ("x", "z", "gap"):
        np.testing.assert_allclose(getattr(res, name_), [getattr(r, name_) for r in reports],
                                   rtol=0, atol=1e-14 * scale, err_msg=name_)
    for name_ in ("v", "w"):
        want = np.array([getattr(r, name_) for r in reports])
        np.testing.assert_allclose(getattr(res, name_), want, rtol=0,
                                   atol=1e-13 * np.max(np.abs(want)), err_msg=name_)
    want = np.array([r.impulse for r in reports])
    np.testing.assert_allclose(res.impulse, want, rtol=1e-9, atol=1e-12 * np.max(np.abs(want)),
                               err_msg="impulse")
    assert np.array_equal(res.sticking, [r.sticking for r in reports])
    assert np.array_equal(res.impacts["t"], [i.t for i in sim.impacts])
    assert np.all(res.gap >= 0.0) and np.all(res.penetration == 0.0)
    assert res.sticking_since == sim.sticking_since
    # both kinds of segment are sampled
    assert res.sticking.any() and not res.sticking.all()


def test_run_marches_a_segment_without_array_forms_sample_by_sample(monkeypatch):
    """A kind of segment with neither closed forms for arrays nor dense steps (its SAMPLING is
    "marched") is sampled as the simulator steps it: the same states, impulses and impacts as the
    vectorised sampling."""
    from iceimpact.solvers.exact import QuadraticStick
    from iceimpact.solvers.exact.segment import MARCHED

    values, t_end = SAMPLED_SCENES["quadratic sticking parts"]
    scene = Scene(**values)
    vectorised = run(scene, t_end, dt=0.02)
    monkeypatch.setattr(QuadraticStick, "SAMPLING", MARCHED)
    marched = run(scene, t_end, dt=0.02)
    assert np.array_equal(marched.impacts["t"], vectorised.impacts["t"])
    assert np.array_equal(marched.sticking, vectorised.sticking)
    for name in ("x", "v", "z", "w"):
        got, want = getattr(marched, name), getattr(vectorised, name)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.max(np.abs(want)),
                                   err_msg=name)
    np.testing.assert_allclose(marched.impulse, vectorised.impulse, rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(vectorised.impulse)))


@pytest.mark.parametrize("name", ["linear e=0.5", "linear e=0", "overdamped sticking"])
def test_run_evaluates_samples_in_chunks_with_the_values_of_one_pass(name, monkeypatch):
    """The sampler evaluates the closed forms in chunks of samples (CHUNK, for the cache and the
    allocator): elementwise, so every state and impulse is the one pass's to the bit, however
    the samples are cut, the flights' and the sticking phases' (with their impulse pieces)."""
    from iceimpact.solvers.exact import sampling

    values, t_end = SAMPLED_SCENES[name]
    scene = Scene(**values)
    monkeypatch.setattr(sampling, "CHUNK", 10**9)
    one_pass = run(scene, t_end, dt=1e-3)
    assert len(one_pass.t) > 2000 and one_pass.sticking.any() and not one_pass.sticking.all()
    for chunk in (1, 7, 512):
        monkeypatch.setattr(sampling, "CHUNK", chunk)
        cut = run(scene, t_end, dt=1e-3)
        for field in ("x", "v", "z", "w", "impulse", "sticking"):
            assert getattr(cut, field).tobytes() == getattr(one_pass, field).tobytes(), field


def test_chunks_cover_the_samples_once_in_order():
    from iceimpact.solvers.exact.sampling import CHUNK, _chunks

    for n in (0, 1, CHUNK, 2 * CHUNK, 2 * CHUNK + 1, 5 * CHUNK + 3):
        parts = _chunks(n)
        assert np.array_equal(np.concatenate([np.arange(n)[p] for p in parts] or [[]]),
                              np.arange(n))
        assert len(parts) == (1 if n <= 2 * CHUNK else -(-n // CHUNK))


def test_run_gap_is_never_negative_where_the_ice_passes_through():
    """The fixed-step window (eq. 26) lets the ice through the structure: reported as a
    penetration, never as a negative gap."""
    res = run(Scene(solver_method=2, solver_detection=1), 3.0)
    assert np.any(res.x - res.z < 0.0)
    assert np.all(res.gap >= 0.0)
    assert np.array_equal(res.penetration > 0.0, res.x - res.z <= -1e-12)


@pytest.mark.parametrize("times,index", [
    ([0.1, math.nan], 1), ([math.inf], 0), ([0.2, 0.1], 1), ([0.1, 0.1], 1), ([0.0, 0.5], 0),
    ([-0.1], 0), ([0.5, 1.5], 1)])
def test_bad_sample_times_are_refused(times, index):
    with pytest.raises(ParameterError) as err:
        run(Scene(), 1.0, sample_times=times)
    assert err.value.name == f"sample_times[{index}]"
    assert "(0, t_end = 1.0] s" in str(err.value)
    value = times[index]
    assert err.value.value == value or (math.isnan(value) and math.isnan(err.value.value))


def test_sample_times_must_be_a_sequence_of_numbers():
    with pytest.raises(ParameterError, match="sample_times"):
        run(Scene(), 1.0, sample_times=[[0.1, 0.2]])
    with pytest.raises(ParameterError, match="sample_times"):
        run(Scene(), 1.0, sample_times=["soon"])


def test_step_reports_are_ordinary_frozen_reports():
    """The simulator builds its StepReport without the dataclass __init__: the same object."""
    import dataclasses

    from iceimpact.simulator import StepReport

    sim = Simulator(Scene(impact_e=0.5))
    for _ in range(3):
        report = sim.advance(0.5)
    values = {f.name: getattr(report, f.name) for f in dataclasses.fields(StepReport)}
    assert values == report.__dict__
    twin = StepReport(**values)
    assert report == twin and hash(report) == hash(twin) and repr(report) == repr(twin)
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.x = 0.0


def test_method_2_impact_at_a_communication_point_keeps_the_state_restorable():
    """Method 2 takes a grid point within GRID_SLACK of the step's end as that end, but dated
    an impact there t_a + n dt, which rounds past it (0.050000000000000405 for the end 0.05):
    the impact, the new grid's anchor and t_last fell after the state's own time, and
    ``Simulator.from_snapshot(sim.save())`` (the FMU's fmi2SetFMUstate) refused the state it had
    just saved. Such an impact is now at the step's end (found by the budget's property test in
    test_step_budget.py)."""
    scene = Scene(structure_m=1.0, structure_c=0.0, structure_k=1.0, structure_x0=0.0,
                  structure_v0=0.0625, ice_M=1.0, ice_A=1.0, ice_Cd=0.0, ice_z0=0.0,
                  ice_v0=0.0625, impact_e=0.0, flow_u=0.0, solver_method=2,
                  solver_detection=2)
    sim = Simulator(scene)
    for _ in range(60):
        report = sim.advance(0.05)
        assert 0.0 <= report.t_last <= report.t
        again = Simulator.from_snapshot(sim.save())
        assert again.save() == sim.save()
    assert sim.impact_count > 1000


# --- the modal structure (structure.model = 3) ----------------------------------------------------

#: Two modes at the contact point, plastic impacts: the ice rides on the structure from ~0.53 s.
MODAL = dict(structure_model=3, structure_modes=2, structure_mode2_f=11.0, structure_mode2_phi=0.6,
             impact_e=0.0, flow_u=0.3, drag_model=2, ice_M=1200.0)
#: steps (h, u, loads) after a save: uneven steps, a flow change and loads on both modes
MODAL_SUFFIX = ([(0.01, 0.3, (0.0, 0.0))] * 30 + [(0.013, 0.3, (800.0, -300.0))] * 10
                + [(0.01, 0.1, (0.0, 150.0))] * 40)


def modal_steps(sim, inputs):
    return [sim.advance(h, u, loads=loads) for h, u, loads in inputs]


@pytest.mark.parametrize(("t_stop", "riding"), [(0.3, False), (0.61, True), (1.5, None)])
def test_modal_round_trip_continues_to_the_last_bit(t_stop, riding):
    """Before the first impact, riding (sticking) and later: saved, through JSON, restored into
    fresh simulators, the same future under changing loads and flow, modal outputs included."""
    sim = stepped(Scene(**MODAL), t_stop, u_before=0.3)
    if riding is not None:
        assert sim.sticking is riding
    saved = json_copy(sim.save())
    assert saved["scene"]["structure.model"] == 3 and len(saved["solver"]["loads"]) == 2
    twin = Simulator(Scene())  # an SDOF simulator takes a modal state, its scene included
    twin.restore(saved)
    fresh = Simulator.from_snapshot(saved)
    expected = modal_steps(sim, MODAL_SUFFIX)
    assert any(r.mode2_q != 0.0 for r in expected)
    assert modal_steps(fresh, MODAL_SUFFIX) == expected
    assert modal_steps(twin, MODAL_SUFFIX) == expected
    assert fresh.save() == sim.save() == twin.save()


@pytest.mark.parametrize("scene", [Scene(impact_e=0.5), Scene(**MODAL)], ids=["SDOF", "modal"])
def test_a_state_of_layout_version_1_is_refused_naming_the_field(scene):
    """Layout 1 (before the modal structure): its scene, report and solver lack the modal
    fields. Refused on its version, not misread; the simulator is unchanged."""
    state = stepped(scene, 1.0, u_before=0.3).save()
    assert state["version"] == STATE_VERSION == 2
    old = copy.deepcopy(state)
    old["version"] = old["solver"]["version"] = 1
    old["scene"] = {k: v for k, v in old["scene"].items() if ".mode" not in k}
    old["report"] = {k: v for k, v in old["report"].items() if not k.startswith("mode")}
    sim = stepped(Scene(**MODAL), 0.7, u_before=0.3)
    assert_refused_and_unchanged(sim, old, "version")
    solver_only = copy.deepcopy(state)
    solver_only["solver"]["version"] = 1
    assert_refused_and_unchanged(sim, solver_only, "solver.version")


@pytest.mark.parametrize(("change", "field"), [
    (_set(("solver", "loads"), [0.0]), "solver.loads"),
    (_set(("solver", "segment", "q"), [0.0, "x"]), "solver.segment.q"),
    (_drop(("solver", "segment", "p")), "solver.segment"),
    (_set(("scene", "structure.modes"), 6), "scene"),
])
def test_malformed_modal_state_is_refused_naming_the_field(change, field):
    state = stepped(Scene(**MODAL), 0.61, u_before=0.3).save()
    change(state)
    sim = stepped(Scene(impact_e=0.9, drag_model=2), 1.0)
    before = sim.save()
    with pytest.raises((StateError, ParameterError)) as err:
        sim.restore(state)
    assert field in str(err.value)
    assert sim.save() == before
