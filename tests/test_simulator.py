"""The simulator's guarantees on every path that reports: run()'s sampled path (the exact
method's samples at once) and stepping (every method) refuse a non-finite output alike, in the
same words."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from iceimpact import ParameterError, Scene, Simulator, SolverError, run
from iceimpact.simulator import reported_gap
from iceimpact.solvers.base import GAP_ROUNDING, State
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
    # sample 3 is t = 0.4 s (row 0 is t = 0); x, and the gap and k x made from it, the fields
    # a step names (the next test)
    assert match.group(1) == match.group(3) == "0.4"
    assert match.group(2) == "x, gap, spring_force"


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


@pytest.mark.parametrize("poison, named", [
    ({"x": math.nan}, "x, gap, spring_force"),
    ({"w": math.inf}, "w"),
    ({"x": 1e308, "z": -1e308}, "gap, spring_force"),  # finite states, x - z overflows
    ({"x": -1e308, "z": 1e308}, "penetration, spring_force"),
    ({"x": 1e308}, "spring_force"),             # k x overflows
    ({"impulse": 1e308}, "force"),              # impulse / dt overflows
])
def test_a_sampled_run_refuses_a_non_finite_output_naming_it(monkeypatch, poison, named):
    """run()'s sampled path checks what each sample reports, derived fields included, as a
    step does (its quick proof of finiteness gives way to the full check)."""
    original = EventSolver.sample

    def poisoned(self, times, u):
        out = original(self, times, u)
        for name, value in poison.items():
            getattr(out, name)[4] = value
        return out

    monkeypatch.setattr(EventSolver, "sample", poisoned)
    with pytest.raises(SolverError) as failed:
        run(Scene(), 1.0, dt=0.1)
    match = WORDING.fullmatch(str(failed.value))
    assert match, str(failed.value)
    assert match.group(1) == match.group(3) == "0.5"
    assert match.group(2) == named


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


@pytest.mark.parametrize("method", [1, 2, 3])
def test_sample_equals_stepping_and_leaves_the_simulator_where_stepping_does(method):
    scene = Scene(solver_method=method, ice_M=800.0)
    times = np.linspace(0.05, 2.0, 40)
    sampled, stepped = Simulator(scene), Simulator(scene)
    sampled.advance(0.01)
    stepped.advance(0.01)
    out = sampled.sample(times + 0.01)
    reports = [stepped.advance_to(t) for t in (times + 0.01).tolist()]
    for name in ("x", "v", "z", "w", "impulse"):
        expected = np.array([getattr(r, name) for r in reports])
        scale = np.max(np.abs(expected)) + 1e-300
        assert np.max(np.abs(getattr(out, name) - expected)) <= 1e-9 * scale, name
    assert list(out.sticking) == [r.sticking for r in reports]
    assert sampled.impact_count == stepped.impact_count > 0
    last, report = reports[-1], sampled.report
    assert (report.t, report.impact_count, report.sticking) == (last.t, last.impact_count,
                                                                last.sticking)
    assert report.force == pytest.approx(last.force, rel=1e-9, abs=1e-12)
    after_sample = sampled.advance(0.1)  # and goes on from there as the stepped one does
    after_steps = stepped.advance(0.1)
    assert after_sample.x == pytest.approx(after_steps.x, rel=1e-9, abs=1e-15)


@pytest.mark.parametrize("times, field", [
    ([], "times"), ([[0.2, 0.3]], "times"), ([0.2, 0.1], "times[1]"), ([0.2, math.nan], "times[1]"),
    ([0.5, math.inf], "times[1]"), ([0.05], "times[0]"), ("abc", "times"), ([10**400], "times")])
def test_sample_refuses_times_it_cannot_reach_and_changes_nothing(times, field):
    sim = Simulator(Scene())
    sim.advance(0.1)
    before = sim.save()
    with pytest.raises(ParameterError) as refused:
        sim.sample(times)
    assert str(refused.value).startswith(f"{field} = ")
    assert "strictly increasing" in str(refused.value) and "t = 0.1" in str(refused.value)
    assert sim.save() == before


def test_a_refused_sampled_interval_is_worded_as_a_step_and_stops_where_stepping_does():
    """The refusal names the sample interval the failure lies in, and the simulator stands at
    the last sample before it, as stepping to each sample leaves it."""
    scene = Scene(ice_M=800.0, solver_max_impacts=1)  # two impacts in (3.0, 3.5] s
    sim = Simulator(scene)
    times = np.linspace(0.5, 20.0, 40)
    with pytest.raises(SolverError) as refused:
        sim.sample(times)
    text = str(refused.value)
    match = re.fullmatch(r"the run stopped at t = (\S+) s \(the step to (\S+) s was refused; "
                         r"the state is as before it\): the step needs more than "
                         r"solver.max_impacts = 1 impacts .*", text)
    assert match, text
    start, end = float(match.group(1)), float(match.group(2))
    assert (start, end) == (3.0, 3.5)
    assert sim.failed == text and sim.t == start
    stepped = Simulator(scene)
    for t in times[times <= start].tolist():
        stepped.advance_to(t)
    assert sim.save()["solver"] == stepped.save()["solver"]


def test_a_failure_deep_in_a_long_flight_is_located_where_it_happens(monkeypatch):
    """A method failing many samples after the flight began (a long flight under the quadratic
    Morison drag, made to fail at its step past 5.9 s): the refusal names the time of the
    failure, and the run stops at the sample before the step that met it (the root search
    makes the flight's steps up to a natural period, 0.29 s, ahead), not where the flight began
    (0.14 s)."""
    from iceimpact.solvers.exact import flight

    make = flight.DraggedFlight._step_from

    def failing(self, lo, y):
        if self.t0 + lo > 5.9:
            raise SolverError(f"made to fail at t = {self.t0 + lo!r} s")
        return make(self, lo, y)
    monkeypatch.setattr(flight.DraggedFlight, "_step_from", failing)
    scene = Scene(structure_Cd=1.0, structure_A=2.0, drag_model=2, structure_v0=0.5,
                  ice_A=2.0)
    with pytest.raises(SolverError) as refused:
        run(scene, 20.0)
    match = re.match(r"the run stopped at t = (\S+) s \(the step to (\S+) s was refused", str(
        refused.value))
    assert match and 5.9 - 0.3 <= float(match.group(1)) < float(match.group(2)) <= 5.91
    assert "made to fail at t = 5.9" in str(refused.value)


# Numbers of the Python API: Python and numpy alike, refusals named -------------------------------
KINDS = [int, float, np.int64, np.int32, np.int16, np.float64, np.float32, np.float16]
REFUSED = [True, np.bool_(True), 10**400, -10**400, math.nan, math.inf, np.float64(math.inf),
           np.float32(math.nan), "1", 1j, np.array([1.0]), [1.0]]


def _refused(call, value, name: str) -> None:
    with pytest.raises(ParameterError) as err:
        call(value)
    assert err.value.name == name and err.value.value is value
    assert str(err.value).startswith(f"{name} = "), str(err.value)


@pytest.mark.parametrize("kind", KINDS, ids=lambda kind: kind.__name__)
def test_every_numeric_input_takes_python_and_numpy_numbers_as_python_floats(kind):
    """advance(np.int64(1)) and advance(np.float32(0.01)) were refused as 'not a finite number
    > 0'; every input now takes int, float and numpy integer and floating scalars, as the
    Python floats they are."""
    one, zero = kind(1), kind(0)
    scene = Scene(ice_z0=-1.0, ice_v0=0.0, structure_model=2)  # every input of a step in use
    sim, ref = Simulator(scene), Simulator(scene)
    r = sim.advance(one, one, (zero, one, zero))
    assert r == ref.advance(1.0, 1.0, (0.0, 1.0, 0.0)) and type(sim.t) is float
    r = sim.advance_to(kind(2), zero, np.array([one, zero, zero]))
    assert r == ref.advance_to(2.0, 0.0, (1.0, 0.0, 0.0)) and type(sim.t) is float
    sim.set_restitution(zero)
    assert sim.scene.impact_e == 0.0 and type(sim.scene.impact_e) is float
    # Scene fields hold Python numbers: int for an Integer, float for a Real
    held = Scene(structure_m=kind(100), ice_M=kind(50), flow_u=one, solver_method=kind(2),
                 solver_max_impacts=kind(100), structure_x_in=zero, ice_z0=kind(-1))
    assert held == Scene(structure_m=100.0, ice_M=50.0, flow_u=1.0, solver_method=2,
                         solver_max_impacts=100, structure_x_in=0.0, ice_z0=-1.0)
    for name in ("structure_m", "ice_M", "flow_u", "structure_x_in", "ice_z0", "structure_k"):
        assert type(getattr(held, name)) is float, name
    assert type(held.solver_method) is int and type(held.solver_max_impacts) is int
    if kind in (float, np.float64, np.float32, np.float16):  # a step of 0.01 s in that type
        h = kind(0.01)
        sim, ref = Simulator(Scene()), Simulator(Scene())
        assert sim.advance(h) == ref.advance(float(h)) and sim.t == float(h)


def _short(value) -> str:
    text = repr(value)
    sign = "-" if text[0] == "-" else ""
    return text if len(text) < 30 else f"{sign}10**{len(text) - 1 - len(sign)}"


@pytest.mark.parametrize("value", REFUSED, ids=_short)
def test_every_numeric_input_refuses_what_it_must_naming_it(value):
    sim = Simulator(Scene(structure_model=2))
    _refused(sim.advance, value, "communication step")
    _refused(sim.advance_to, value, "communication point")
    _refused(sim.set_restitution, value, "impact.e")
    _refused(lambda u: sim.advance(1e-3, u), value, "flow.u")
    _refused(lambda x: sim.advance(1e-3, None, (x, 0.0, 0.0)), value, "structure.x_in")
    _refused(lambda a: sim.advance(1e-3, None, (0.0, 0.0, a)), value, "structure.a_in")
    _refused(lambda m: Scene(structure_m=m), value, "structure.m")
    _refused(lambda n: Scene(solver_max_impacts=n), value, "solver.max_impacts")
    assert sim.t == 0.0 and sim.report.impact_count == 0


def test_numbers_out_of_range_are_refused_with_the_range():
    sim = Simulator(Scene())
    for call, value, name, allowed in (
            (sim.advance, np.float32(-0.01), "communication step", "a finite number > 0 (s)"),
            (sim.advance, np.int64(0), "communication step", "a finite number > 0 (s)"),
            (sim.advance_to, np.int64(0), "communication point", "a finite time > t = 0.0 s"),
            (sim.set_restitution, np.float32(1.5), "impact.e", "0 <= e <= 1"),
            (sim.set_restitution, 2, "impact.e", "0 <= e <= 1"),
            (lambda m: Scene(structure_m=m), np.int64(-1), "structure.m", "> 0"),
            (lambda n: Scene(solver_method=n), np.float64(1.5), "solver.method",
             "an integer, 1, 2 or 3")):
        with pytest.raises(ParameterError) as err:
            call(value)
        assert (err.value.name, err.value.value) == (name, value)
        assert err.value.allowed.startswith(allowed), err.value.allowed
    with pytest.raises(ParameterError, match=r"structure\.m = 1000000000000000000000.* is not "
                                             r"allowed: a real number within double precision"):
        Scene(structure_m=10**400)


@pytest.mark.parametrize("kwargs, field", [
    ({"t_end": 10**400}, "t_end"), ({"t_end": True}, "t_end"), ({"dt": 10**400}, "dt"),
    ({"dt": True}, "dt"), ({"sample_times": [True]}, "sample_times"),
    ({"sample_times": np.array([0.5, 1.0], dtype=object)}, "sample_times")])
def test_run_refuses_numbers_it_must_naming_them(kwargs, field):
    args = {"t_end": 1.0} | kwargs
    with pytest.raises(ParameterError) as refused:
        run(Scene(), **args)
    assert str(refused.value).startswith(f"{field} = ")


def test_run_takes_numpy_numbers_as_python_floats():
    """A float32 step computes in double precision: no sample past t_end."""
    result = run(Scene(), np.int64(1), dt=np.float32(0.1))
    assert result.t[-1] == 1.0 and len(result.t) == 11
    assert np.array_equal(result.x, run(Scene(), 1.0, dt=float(np.float32(0.1))).x)


def test_the_reported_gap_is_the_same_for_a_float_and_an_array():
    """A negative x - z is a zero gap, and a penetration from GAP_ROUNDING on; a float and an
    array give the same values, -0.0, infinities and NaN included."""
    gaps = [0.3, 0.0, -0.0, -0.5 * GAP_ROUNDING, -GAP_ROUNDING, -2e-3, math.inf, -math.inf,
            math.nan]
    gap, penetration = reported_gap(np.array(gaps))
    for k, x in enumerate(gaps):
        g, p = reported_gap(x)
        assert (math.copysign(1.0, gap[k]), math.copysign(1.0, penetration[k])) == \
            (math.copysign(1.0, g), math.copysign(1.0, p)), x
        assert (gap[k], penetration[k]) == (g, p) or math.isnan(x)
    assert gap.tolist()[:6] == [0.3, 0.0, -0.0, 0.0, 0.0, 0.0]
    assert penetration.tolist()[:6] == [0.0, 0.0, 0.0, 0.0, GAP_ROUNDING, 2e-3]
    assert math.isnan(gap[-1]) and penetration[-1] == 0.0


#: Figure 2's scene with a second mode (11 Hz, phi 0.6): bouncing to 54 s, then riding
TWO_MODES = dict(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                 structure_mode2_zeta=0.02, structure_mode2_phi=0.6)


@pytest.mark.parametrize("method", [1, 2, 3])
def test_run_gives_the_modal_state_at_every_sample(method):
    """run() of the modal structure carries each mode's q and q' (the FMU's
    structure.mode<k>.q and .v): at every sample the simulator's modal state when stepped to
    that time, to the bit, whose contact point is x and v; bouncing and riding both (to 55 s)."""
    scene = Scene(solver_method=method, **TWO_MODES)
    result = run(scene, 55.0)
    sim = Simulator(scene)
    rows = []
    for t in result.t[1:].tolist():
        sim.advance_to(t)
        q, p = sim.solver.modal_state()
        rows.append(q + p)
    rows = np.array(rows)
    assert result.modes_q.shape == result.modes_v.shape == (len(result.t), 2)
    assert result.modes_q[0].tolist() == [0.0, 0.0] and result.modes_v[0].tolist() == [0.0, 0.0]
    assert result.modes_q[1:].tobytes() == rows[:, :2].tobytes()
    assert result.modes_v[1:].tobytes() == rows[:, 2:].tobytes()
    phi = (1.0, 0.6)
    x = result.modes_q[:, 0] * phi[0] + result.modes_q[:, 1] * phi[1]
    v = result.modes_v[:, 0] * phi[0] + result.modes_v[:, 1] * phi[1]
    np.testing.assert_allclose(x, result.x, rtol=0, atol=1e-12 * np.abs(result.x).max())
    np.testing.assert_allclose(v, result.v, rtol=0, atol=1e-12 * np.abs(result.v).max())
    if method == 1:
        assert result.sticking.any() and len(result.impacts) > 5000


def test_run_has_no_modal_columns_without_the_modal_structure():
    result = run(Scene(), 1.0)
    assert result.modes_q is None and result.modes_v is None
