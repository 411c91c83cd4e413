"""The structure under the quadratic Morison drag in the compiled march (solvers/search/
dragged.py): its flights' Taylor steps made in arrays, searched and sampled by the compiled
search and march, against DraggedFlight and RootSearch in Python: the same impacts, states,
impulses and samples, to the bit; a flight whose steps the kernel does not make (a possible
reversal of the relative flow) handed back."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, seed, settings
from hypothesis import strategies as st

import random_scenes
from iceimpact import ParameterError, Scene, Simulator, run
from iceimpact.physics.structure import DraggedStructure, dragged_bounds
from iceimpact.solvers.exact import DraggedFlight, bounces
from iceimpact.solvers.exact.bounces import DRAGGED_MARCH, BounceMarch
from iceimpact.solvers.search import dragged, taylor

compiled_only = pytest.mark.skipif(
    bounces.COMPILED is None or bounces.dragged_kernel() is None,
    reason="numba absent or ICEIMPACT_PURE set: no compiled march")

#: Scenes of the Morison pages: a floe in a current striking a pile with a drag of its own
MORISON = {
    "pile A = 2 m2, ice A = 2 m2": dict(structure_Cd=1.0, structure_A=2.0, drag_model=2,
                                        ice_A=2.0),
    "pile A = 20 m2, u = 0.5 m/s": dict(structure_Cd=1.0, structure_A=20.0, drag_model=2,
                                        flow_u=0.5),
}


def _bits(values) -> list[str]:
    return [float(v).hex() for v in values]


def _sampled(scene: Scene, t_end: float, dt: float, compiled: bool,
             monkeypatch: pytest.MonkeyPatch) -> list:
    from iceimpact.solvers.exact import EventSolver
    monkeypatch.setattr(EventSolver, "COMPILED_BOUNCES", compiled)
    r = run(scene, t_end, dt=dt)
    return [_bits(getattr(r, key)) for key in ("t", "x", "v", "z", "w", "impulse")] + [
        r.sticking.tolist(), _bits(r.impacts.view(float))]


@compiled_only
@pytest.mark.parametrize("name", list(MORISON))
def test_the_compiled_march_makes_the_flights(name, monkeypatch):
    """Sampled through run() over 60 s and stepped at 50 ms (every third step with early
    return), the compiled march gives the Python march's numbers to the bit, and makes the
    impacts itself: a few calls for hundreds of impacts sampled."""
    scene = Scene(**MORISON[name])
    calls = [0]
    kernel = bounces.dragged_kernel()

    def counted(*args):
        calls[0] += 1
        kernel(*args)

    monkeypatch.setattr(bounces, "dragged_kernel", lambda: counted)
    compiled = _sampled(scene, 60.0, 0.01, True, monkeypatch)
    assert compiled == _sampled(scene, 60.0, 0.01, False, monkeypatch)
    assert len(compiled[-1]) > 8 * 300 and calls[0] < 10
    steps = []
    for on in (True, False):
        sim = Simulator(scene)
        if not on:
            sim.solver.bounces = None
        rows = []
        for i in range(300):
            report = sim.advance(0.05, stop_at_event=i % 3 == 0)
            s = sim.solver.state
            rows.append(_bits((sim.t, s.x, s.v, s.z, s.w, report.impulse)) + [sim.impact_count])
        steps.append((rows, [_bits(i) for i in sim.impacts]))
    assert steps[0] == steps[1] and len(steps[0][1]) > 5


def test_the_kernel_run_as_python_is_the_python_march():
    """bounce_march on the dragged structure's functions, run as Python (DRAGGED_MARCH): the
    numbers of DraggedFlight and RootSearch, so what numba compiles is that march, whether or
    not numba is installed."""
    scene = Scene(**MORISON["pile A = 2 m2, ice A = 2 m2"])
    # (from 50 s, where the floe strikes a few times a second)
    impacts = random_scenes.kernel_is_the_python_march(scene, 50.0, DRAGGED_MARCH, 2.0,
                                                       np.linspace(52.6, 54.0, 57))
    assert impacts > 10


@compiled_only
def test_a_flight_the_kernel_does_not_step_is_handed_back(monkeypatch):
    """A structure swinging faster than a slow flow reverses the relative flow in flight: the
    Taylor step on which that may happen is found in Python (brentq), so the kernel hands the
    flight back before changing it, and DraggedFlight makes it from its anchor: the run is the
    Python march's to the bit."""
    scene = Scene(structure_Cd=1.0, structure_A=2.0, drag_model=2, flow_u=0.03, ice_A=5.0,
                  structure_v0=0.2)  # (some 150 reversals in 60 s, 3 impacts)
    handed = []
    real = BounceMarch._flight

    def flight(self, seg, F, N):
        out = real(self, seg, F, N)
        handed.append(out.handed_back)
        return out

    monkeypatch.setattr(BounceMarch, "_flight", flight)
    compiled = _sampled(scene, 60.0, 0.01, True, monkeypatch)
    assert any(handed)
    assert compiled == _sampled(scene, 60.0, 0.01, False, monkeypatch)
    assert len(compiled[-1]) == 8 * 3


def test_a_failed_step_marks_the_steps_failed():
    """No room for another step, or a step that is not an ordinary one, marks the steps failed
    and gives NaN (the march then hands the flight back); the anchor is exact."""
    scene = Scene(**MORISON["pile A = 2 m2, ice A = 2 m2"])
    solver = Simulator(scene).solver
    seg = solver.seg
    assert type(seg) is DraggedFlight
    steps = dragged.new_steps(seg.taylor, solver.dragged_structure.omega2, capacity=2)
    dragged._dragged_new_flight(steps, seg.t0, seg.x0, seg.v0)
    assert dragged._dragged_structure(0.0, steps) == (0.0, seg.v0)
    dx, v = dragged._dragged_structure(0.5 * seg.period, steps)
    assert (seg.x0 + dx, v) == (seg.x0 + seg._structure(0.5 * seg.period)[0],
                                seg._structure(0.5 * seg.period)[1])
    assert not dragged._dragged_failed(steps)
    assert all(math.isnan(y) for y in dragged._dragged_structure(5.0 * seg.period, steps))
    assert dragged._dragged_failed(steps)
    dragged._dragged_new_flight(steps, seg.t0, seg.x0, seg.v0)
    assert not dragged._dragged_failed(steps)


@settings(max_examples=300, deadline=None)
@given(x=st.floats(-2.0, 2.0), v=st.floats(-5.0, 5.0), u=st.floats(-3.0, 3.0),
       B=st.floats(0.0, 1e5), c=st.floats(0.0, 1e5))
def test_the_bounds_are_the_structures(x, v, u, B, c):
    """The plain-float bounds the compiled search calls are DraggedStructure's, to the bit."""
    from iceimpact.physics.ice import QuadraticDrag
    structure = DraggedStructure(4e4, c, 2e5, QuadraticDrag(4e4, B))
    assert dragged_bounds(x, v, u, 4e4, c, 2e5, 2e5 / 4e4, B) == structure.bounds(x, v, u)
    r = v - u
    assert structure.acceleration(x, v, u) == (-B * abs(r) * r - c * v - 2e5 * x) / 4e4


#: random scenes with the quadratic Morison drag on the structure: random_scenes' draws under
#: the quadratic drag law, with a pile of drag coefficient 0.1 to 2 and area 1e-3 to 1e2 m2,
#: omega_n below 300 rad/s
MORISON_CASES = st.tuples(random_scenes.CASES, st.floats(0.1, 2.0), st.floats(-3.0, 2.0))


def _morison_scene(case):
    (scene, h, flow, signs), cd, log_area = case
    try:
        scene = dataclasses.replace(scene, drag_model=2, structure_Cd=cd,
                                    structure_A=10.0 ** log_area)
    except ParameterError:
        assume(False)
    # (a stiffer structure takes a Taylor step a period in both marches: seconds a scene)
    assume(scene.omega_n < 300.0)
    return scene, h, flow, signs


def _random_morison(seed_value: int, examples: int) -> None:
    @seed(seed_value)
    @settings(max_examples=examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(case=MORISON_CASES)
    def check(case):
        scene, h, flow, signs = _morison_scene(case)
        assert (random_scenes.stepped(scene, h, flow, signs, True, False)
                == random_scenes.stepped(scene, h, flow, signs, False, False))
        assert (random_scenes.sampled(scene, 3.0, h, True)
                == random_scenes.sampled(scene, 3.0, h, False))
    check()


@compiled_only
def test_random_morison_scenes():
    """Scenes as ``random_search.py --scales --flows`` draws them (masses, stiffnesses and
    damping regimes across their scales, flows constant, reversing, zero, random) with the
    quadratic Morison drag on the structure, stepped and sampled through run(): every number
    is the Python march's."""
    _random_morison(3939, 150)


@compiled_only
@pytest.mark.slow
def test_thousands_of_random_morison_scenes():
    """As above, 2,000 scenes (about 10 minutes)."""
    _random_morison(39390, 2000)


def test_the_steps_are_taylors():
    """The kernel's arrays hold the steps StickingTaylor makes, from the anchor on."""
    scene = Scene(**MORISON["pile A = 2 m2, ice A = 2 m2"])
    solver = Simulator(scene).solver
    seg = solver.seg
    steps = dragged.new_steps(seg.taylor, solver.dragged_structure.omega2)
    dragged._dragged_new_flight(steps, seg.t0, seg.x0, seg.v0)
    dragged._dragged_structure(3.5 * seg.period, steps)
    seg._structure(3.5 * seg.period)
    count = int(steps[1][dragged.COUNTERS.COUNT])
    assert count == len(seg.steps) >= 4
    for i, step in enumerate(seg.steps):
        assert (steps[2][i], steps[3][i], steps[4][i]) == (step.lo, step.h, step.hi)
        assert np.array_equal(steps[5][i], step.table) and tuple(steps[6][i]) == step.y_hi
    assert taylor.ORDER + 1 == steps[5].shape[1]
