"""The flight's root search in one function (solvers/search/flight_search.py) against
RootSearch, whose steps it makes: the same points, the same roots, the same runs to the bit, in
pure Python and compiled by numba (where installed), and ICEIMPACT_PURE turning the compiled one
off."""

from __future__ import annotations

import hashlib
import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from iceimpact import ParameterError, Scene, Simulator, SolverError, run
from iceimpact.solvers.exact import EventSolver, Flight
from iceimpact.solvers.search import flight_search, rootfind
from iceimpact.solvers.search.flight_search import GENERIC, PASSED, ROOT, FlightSearch, flight_root
from random_search import FLOWS, flow_at, scale_scenes

SRC = Path(__file__).resolve().parents[3] / "fmu_src"

#: scenes whose flights the function takes (under-damped structure, either drag law) and a run
#: length (s) with some hundreds of impacts: Figure 2, a heavy floe (the ice upstream of the
#: structure's rest position: Flight.clearance), a damped structure, e < 1 (sticking phases
#: between the flights), the linearised Morison drag on the structure (an oscillator with an
#: offset that moves with the flow), the quadratic drag (Figure 13's A = 2 m2, a heavy floe,
#: Figure 18's quadratic sticking)
SCENES = {
    "figure2": ({}, 200.0),
    "heavy_floe": ({"ice_M": 6400.0, "flow_u": 2.0}, 60.0),
    "damped": ({"structure_c": 3000.0}, 60.0),
    "e_half": ({"impact_e": 0.5}, 60.0),
    "structure_drag": ({"structure_Cd": 1.0, "structure_A": 2.0}, 150.0),
    "quadratic_A2": ({"drag_model": 2, "ice_A": 2.0}, 60.0),
    "quadratic_heavy_floe": ({"drag_model": 2, "ice_M": 6400.0, "flow_u": 2.0}, 60.0),
    "quadratic_e_half": ({"drag_model": 2, "impact_e": 0.5}, 100.0),
    # every damping regime of the structure (critical: 4 k m = c^2 exactly; over-damped on its
    # basis functions, zeta = 1.1, and on its two exponents, zeta = 3)
    "critical": ({"structure_c": 80000.0}, 60.0),
    "over_damped": ({"structure_c": 88000.0}, 60.0),
    "well_over_damped": ({"structure_c": 240000.0, "drag_model": 2}, 60.0),
}


def _digest(result) -> str:
    h = hashlib.sha256()
    for key in ("t", "x", "v", "z", "w", "impulse", "sticking"):
        h.update(np.ascontiguousarray(getattr(result, key)).tobytes())
    h.update(np.ascontiguousarray(result.impacts["t"]).tobytes())
    return h.hexdigest()


class _Counted:
    """flight_root (pure) counting its outcomes."""

    def __init__(self):
        self.outcomes = {PASSED: 0, ROOT: 0, GENERIC: 0}

    def __call__(self, *args):
        out = flight_root(*args)
        self.outcomes[out[0]] += 1
        return out


@pytest.fixture
def pure_function(monkeypatch):
    """Flights search with the pure flight_root (counted), whether or not numba is there."""
    counted = _Counted()
    monkeypatch.setattr(EventSolver, "COMPILED_BOUNCES", False)  # (no compiled march around it)
    monkeypatch.setattr(Flight, "_ONE_FUNCTION", True)
    monkeypatch.setattr(FlightSearch, "kernel", staticmethod(counted))
    return counted


def _generic(monkeypatch):
    monkeypatch.setattr(Flight, "_ONE_FUNCTION", False)


@settings(max_examples=200, deadline=None)
@given(x0=st.floats(-1e3, 1e3), v0=st.floats(-1e3, 1e3), w0=st.floats(-1e2, 1e2),
       u=st.floats(-10.0, 10.0), t=st.floats(0.0, 1e3))
def test_the_closed_forms_on_their_constants_are_the_physics(x0, v0, w0, u, t):
    """Flight builds the motions of its compiled search from Oscillator.under_constants and
    LinearDrag.flight_constants: the same numbers as the physics' own increments, to the bit."""
    from iceimpact.physics.ice import linear_response, make_drag
    from iceimpact.physics.structure import UNDER, Oscillator, under_response

    scene = Scene()
    osc = Oscillator(scene.structure_m, scene.structure_c, scene.structure_k, 1e-4)
    assert osc.regime == UNDER
    assert under_response(*osc.under_constants(x0, v0))(t) == osc.increment(x0, v0)(t)
    drag = make_drag(scene)
    assert linear_response(*drag.flight_constants(w0, u))(t) == drag.increment(w0, u)(t)


@settings(max_examples=300, deadline=None)
@given(x0=st.floats(-1.0, 1.0), v0=st.floats(-10.0, 10.0), dz=st.floats(1e-9, 2.0),
       w0=st.floats(-5.0, 5.0), u=st.floats(-3.0, 3.0),
       c=st.sampled_from([0.0, 3000.0, 80000.0, 88000.0, 240000.0]),
       model=st.sampled_from([1, 2]), t=st.floats(0.0, 50.0))
def test_the_functions_pieces_are_the_flights(x0, v0, dz, w0, u, c, model, t):
    """The function's written-out pieces give the Flight's own values to the bit, for both
    drag laws and every damping regime (undamped, under-damped, critical, over-damped on its
    basis functions and on its two exponents): the motion (the physics' closed forms), the
    amplitude bounds, the ice's acceleration bounds and the clearance with the ice upstream of
    the structure's rest position (z < offset; NaN only where the function hands the step back:
    an undamped structure's drift clearance)."""
    from iceimpact.physics.structure import FORM_OVER
    scene = Scene(drag_model=model, structure_c=c, ice_A=2.0)
    solver = Simulator(scene).solver
    offset = solver.context.osc.offset
    flight = Flight(solver.context, 0.0, offset + x0, v0, offset - dz, w0, u)
    osc, drag = flight.osc, flight.drag
    xc, zc = osc.response_constants(offset + x0, v0), drag.flight_constants(w0, u)
    coef, quadratic = drag.law_constants
    dx, v, dzt, w = flight_search._motion(t, osc.form, xc, *zc, quadratic, 0)
    assert (dx, v) == osc.increment(offset + x0, v0)(t) and (dzt, w) == drag.increment(w0, u)(t)
    assert flight_search._ice_accel(w0, u, coef, quadratic) == drag.accel_bounds(w0, u)
    over = int(osc.form >= FORM_OVER)
    s_slow, s_fast = osc.exponents
    a, j, s = osc.derivatives(offset + x0, v0)
    _, a_bound, j_bound = osc.bounds(offset + x0, v0)
    probed = flight_search._structure_probe(offset + x0, v0, offset, osc.mass, osc.damping,
                                            osc.stiffness, osc.omega2, over, s_slow, s_fast, u,
                                            0)
    # (NaN: math.hypot's scales of the over-damped bounds, below)
    assert probed == osc.bounds(offset + x0, v0) or (over and math.isnan(sum(probed[1:])))
    if over:
        for (y, ydot), want in (((a, j), a_bound), ((j, s), j_bound)):
            got = flight_search._amplitude(y, ydot, osc.omega2, over, s_slow, s_fast)
            # NaN: math.hypot's scales, where the function hands the step to RootSearch
            assert got == want or (got != got and not 1e-140 < math.sqrt(
                y * y + ydot * ydot / osc.omega2) < 1e140)
    cleared = flight_search._clearance(offset + x0, v0, offset - dz, w0, offset, osc.omega2,
                                       osc.sigma, over, s_slow, s_fast, u, coef, quadratic, 0)
    if cleared == cleared:
        assert cleared == flight.clearance(0.0)
    else:  # an undamped structure, or an amplitude bound at the scales of math.hypot's form
        assert c == 0.0 or not 1e-140 < math.hypot(x0, v0 / math.sqrt(osc.omega2)) < 1e140


@pytest.mark.parametrize("name, roots", [
    ("figure2", 100), ("heavy_floe", 100), ("damped", 100), ("quadratic_A2", 100),
    ("critical", 40), ("over_damped", 40), ("well_over_damped", 15)])  # (then sticking)
def test_the_function_makes_nearly_every_search(name, roots, pure_function):
    """The clearance with the ice upstream, the quadratic drag, the over-damped amplitude
    bounds and a bracket's last float are the function's own: of its flights at most two hand
    a step to RootSearch."""
    fields, t_end = SCENES[name]
    run(Scene(**fields), t_end, dt=1e-2)
    assert pure_function.outcomes[ROOT] > roots
    assert pure_function.outcomes[GENERIC] <= 2


@pytest.mark.parametrize("name", list(SCENES))
def test_runs_equal_root_search_to_the_bit(name, pure_function, monkeypatch):
    """run() with the flights' searches in flight_root gives RootSearch's arrays, bit for bit,
    and the function made the searches (handing a step back to RootSearch where it must)."""
    fields, t_end = SCENES[name]
    scene = Scene(**fields)
    with_function = _digest(run(scene, t_end, dt=1e-2))
    assert pure_function.outcomes[ROOT] > 10
    _generic(monkeypatch)
    assert _digest(run(scene, t_end, dt=1e-2)) == with_function


@pytest.mark.parametrize("name", ["figure2", "heavy_floe", "quadratic_A2"])
def test_function_evaluates_the_closed_forms_no_more_often_than_root_search(name, monkeypatch):
    """The function takes the anchor's motion as Flight keeps it and reuses the motion at a root
    it has just evaluated: over a run it evaluates the closed forms (its own and the ones Python
    builds for the flight) no more often than RootSearch's Flight does, with the same run."""
    from iceimpact.solvers.exact import flight as flight_module

    count = [0]
    response_of = flight_module.under_response

    def counted(increment):
        def counted_increment(*args):
            count[0] += 1
            return increment(*args)
        return counted_increment

    def counted_response(*constants):
        response = response_of(*constants)

        def counted(t):
            count[0] += 1
            return response(t)
        return counted

    for form in ("under_increment", "aperiodic_increment"):  # (the structure's closed forms)
        monkeypatch.setattr(flight_search, form, counted(getattr(flight_search, form)))
    monkeypatch.setattr(FlightSearch, "kernel", staticmethod(flight_root))
    monkeypatch.setattr(flight_module, "under_response", counted_response)
    fields, t_end = SCENES[name]
    evaluations, digests = {}, {}
    for one_function in (True, False):
        monkeypatch.setattr(Flight, "_ONE_FUNCTION", one_function)
        count[0] = 0
        result = run(Scene(**fields), t_end, dt=1e-2)
        evaluations[one_function], digests[one_function] = count[0], _digest(result)
    assert digests[True] == digests[False]
    assert 0 < evaluations[True] <= evaluations[False]


def test_hands_steps_back_and_continues(pure_function, monkeypatch):
    """Over Figure 18 the function hands steps to RootSearch (flights that leave a sticking
    phase with no opening speed: a probe with a zero rate, which RootSearch rescales), and the
    run is RootSearch's."""
    fields, t_end = SCENES["quadratic_e_half"]
    with_function = _digest(run(Scene(**fields), t_end, dt=1e-2))
    assert pure_function.outcomes[GENERIC] > 0
    _generic(monkeypatch)
    assert _digest(run(Scene(**fields), t_end, dt=1e-2)) == with_function


def _stepped(scene: Scene, h: float, t_end: float) -> tuple:
    """Simulator.advance by h, the flow speed changed every second step (re-anchoring)."""
    sim = Simulator(scene)
    u = scene.flow_u
    states = []
    for k in range(round(t_end / h)):
        report = sim.advance(h, u * (1.0 + 0.25 * (k % 2)))
        state = sim.solver.state
        states.append((sim.t, state.x, state.v, state.z, state.w, report.impulse))
    return tuple(states), tuple(i.t for i in sim.impacts)


def test_chopped_horizons_and_flow_changes(pure_function, monkeypatch):
    """Short communication steps (horizons inside a flight: the search stops at each and goes
    on from its frontier) and a flow speed that changes at each step: the same as RootSearch."""
    scene = Scene(**SCENES["heavy_floe"][0])
    with_function = _stepped(scene, 0.013, 20.0)
    assert pure_function.outcomes[PASSED] > 100
    _generic(monkeypatch)
    assert _stepped(scene, 0.013, 20.0) == with_function


def test_frontier_and_snapshot_as_root_search(pure_function, monkeypatch):
    """A flight's search stopped at a horizon keeps RootSearch's frontier (a, iterations, creep),
    so snapshots and checkpoints are the same."""
    def frontiers():
        sim = Simulator(Scene())
        out = []
        for _ in range(300):
            sim.advance(0.01)
            seg = sim.solver.seg
            out.append((type(seg).__name__, json.dumps(sim.save(), sort_keys=True)))
        return out
    with_function = frontiers()
    assert pure_function.outcomes[PASSED] > 0
    _generic(monkeypatch)
    assert frontiers() == with_function


def test_search_from_a_flight_directly(pure_function):
    """Flights searched by FlightSearch and by RootSearch from the same anchors with the same
    sequence of horizons: the same roots, frontiers and counters (the ice downstream of the
    structure's rest position, where flight_root makes the steps itself)."""
    sim = Simulator(Scene())
    sim.advance(1.0)
    solver = sim.solver
    for v0, w0, gap in ((0.3, -0.2, 1e-3), (-0.05, 0.4, 1e-3), (0.0, 0.0, 0.0),
                        (1e-3, 1e-3, 1e-6), (0.2, 0.2, 0.0), (0.5, 0.1, 0.0)):
        x0 = 0.01 + gap
        flights = [Flight(solver.context, 0.0, x0, v0, x0 - gap, w0, 0.5) for _ in range(2)]
        flights[1].search = rootfind.RootSearch(0.0, flights[0].search.time_eps)
        assert isinstance(flights[0].search, FlightSearch)
        results = []
        for flight in flights:
            found = [flight.search.next_root_of(h, flight) for h in (1e-3, 0.02, 0.5, 3.0, 50.0)]
            s = flight.search
            results.append((found, s.a, s.root, s.iterations, s.creep))
        assert results[0] == results[1]
    assert pure_function.outcomes[PASSED] + pure_function.outcomes[ROOT] > 3


def test_pure_environment_keeps_pure_path():
    """ICEIMPACT_PURE=1: no compiled function; the flights search with the pure function."""
    code = ("from iceimpact.solvers.search import flight_search as f; from iceimpact.solvers.exact "
            "import Flight; print(f.COMPILED is None, Flight._ONE_FUNCTION)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env={**os.environ, "PYTHONPATH": str(SRC),
                                           "ICEIMPACT_PURE": "1"})
    assert done.stdout.split() == ["True", "True"]


_DIGESTS = """
import hashlib, json, sys
import numpy as np
from iceimpact import Scene, run
out = {}
for name, (fields, t_end) in json.loads(sys.argv[1]).items():
    r = run(Scene(**fields), t_end, dt=1e-2)
    h = hashlib.sha256()
    for key in ("t", "x", "v", "z", "w", "impulse", "sticking"):
        h.update(np.ascontiguousarray(getattr(r, key)).tobytes())
    h.update(np.ascontiguousarray(r.impacts["t"]).tobytes())
    out[name] = h.hexdigest()
print(json.dumps(out))
"""


@pytest.mark.skipif(os.environ.get("ICEIMPACT_PURE", "") not in ("", "0"),
                    reason="the compiled path is off (ICEIMPACT_PURE)")
def test_compiled_equals_pure():
    """numba installed (the ``fast`` extra, part of ``dev``): the flights search with the
    compiled function, and run() gives the pure path's arrays (ICEIMPACT_PURE=1) bit for bit."""
    pytest.importorskip("numba")
    assert flight_search.COMPILED is not None and Flight._ONE_FUNCTION
    digests = {}
    for pure in ("0", "1"):
        done = subprocess.run([sys.executable, "-c", _DIGESTS, json.dumps(SCENES)],
                              capture_output=True, text=True, check=True,
                              env={**os.environ, "PYTHONPATH": str(SRC), "ICEIMPACT_PURE": pure})
        digests[pure] = json.loads(done.stdout.strip().splitlines()[-1])
    assert digests["0"] == digests["1"]
    here = {name: _digest(run(Scene(**fields), t_end, dt=1e-2))
            for name, (fields, t_end) in SCENES.items()}
    assert here == digests["1"]


def test_compiled_function_values_equal_pure():
    """The compiled function returns the pure one's tuple, bit for bit, from the anchors of
    Figure 2's flights and random horizons (math's exp, expm1, sin, cos, sqrt the same)."""
    pytest.importorskip("numba")
    if flight_search.COMPILED is None:
        pytest.skip("the compiled path is off (ICEIMPACT_PURE)")
    rng = np.random.default_rng(7)
    sim = Simulator(Scene())
    checked = 0
    for _ in range(400):
        sim.advance(0.05)
        seg = sim.solver.seg
        if not isinstance(seg.search, FlightSearch):
            continue
        for horizon in rng.uniform(0.0, 2.0, 3):
            args = (float(horizon), 0.0, 0, 0, math.nan, *(math.nan,) * 5,
                    seg.search.time_eps, *seg.kernel_constants)
            pure, compiled = flight_root(*args), flight_search.COMPILED(*args)
            assert [float(v).hex() for v in compiled] == [float(v).hex() for v in pure]
            checked += 1
    assert checked > 100


def _stepped_case(scene, h: float, flow: str, signs: list[bool], one_function: bool) -> tuple:
    """random_search's stepping of a scene (3 s at most, its flow sequence), with or without
    the flight search in one function; each step's state, or the refusal."""
    kernel = flight_search.COMPILED or flight_root
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Flight, "_ONE_FUNCTION", one_function)
        mp.setattr(FlightSearch, "kernel", staticmethod(kernel))
        states = []
        try:
            sim = Simulator(scene)
            u0 = scene.flow_u if scene.flow_u != 0.0 else 0.1
            for i in range(max(1, min(300, round(3.0 / h)))):
                report = sim.advance(h, flow_at(flow, i, u0, signs))
                s = sim.solver.state
                states.append((sim.t, s.x, s.v, s.z, s.w, sim.impact_count, report.impulse))
        except (ParameterError, SolverError) as exc:
            states.append(type(exc).__name__)
        return tuple(states)


def test_extreme_scenes_as_root_search():
    """Scenes drawn as ``random_search.py --scales --flows`` draws them (masses 1e-6 to 1e9 kg,
    omega_n up to the exact method's limit, every damping, flows reversing, zero, random),
    stepped at 1 ms to 1 s: the flight search in one function (compiled where numba is
    installed) gives RootSearch's states at every step."""
    @seed(5)
    @settings(max_examples=150, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(scene=scale_scenes(1), h=st.sampled_from([1e-3, 1e-2, 0.1, 1.0]),
           flow=st.sampled_from(FLOWS), signs=st.lists(st.booleans(), min_size=1, max_size=8))
    def case(scene, h, flow, signs):
        assert (_stepped_case(scene, h, flow, signs, True)
                == _stepped_case(scene, h, flow, signs, False))
    case()


@pytest.mark.parametrize("which", ["frontier", "root"])
def test_a_nan_from_the_kernel_hands_the_search_back(monkeypatch, which):
    """Where Python's math would raise (a domain error) the compiled function gives NaN: the
    search then goes back to RootSearch from the frontier as it was, so a run is the pure
    path's, never a NaN frontier or root. Every call here returns a NaN at its first flight."""
    kw, t_end = SCENES["figure2"]
    _generic(monkeypatch)
    reference = _digest(run(Scene(**kw), 20.0))

    def poisoned(*args):
        out = list(flight_root(*args))
        if which == "frontier":
            out[1] = math.nan
        else:
            out[0], out[2] = ROOT, math.nan
        return tuple(out)

    monkeypatch.setattr(Flight, "_ONE_FUNCTION", True)
    monkeypatch.setattr(FlightSearch, "kernel", staticmethod(poisoned))
    assert _digest(run(Scene(**kw), 20.0)) == reference


_FMU_PROBE = """
import json, os, sys
from fmpy import simulate_fmu
simulate_fmu(sys.argv[1], stop_time=0.2, output_interval=0.1)
compiled = [m.COMPILED is not None for k, m in sys.modules.items()
            if k.startswith("_iceimpact_") and k.endswith(".solvers.search.flight_search")]
print(json.dumps({"compiled": compiled, "pure_env": os.environ.get("ICEIMPACT_PURE")}))
"""


@pytest.mark.parametrize("opt_in", [False, True])
def test_the_fmu_runs_the_pure_search_unless_the_host_opts_in(fmu_dir, opt_in):
    """numba's import (about 0.3 s of CPU and 120 MB in every host process, the compiled
    kernels' cache warm) costs an FMU more than its compiled kernels save at the steps hosts
    take (docs/explanation/speed.md): the FMU's core loads with the pure path, and the host's
    environment is left as it was; ICEIMPACT_FMU_COMPILED=1 lets it compile where the host's
    Python has numba."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("ICEIMPACT_PURE", "ICEIMPACT_FMU_COMPILED")}
    if opt_in:
        env["ICEIMPACT_FMU_COMPILED"] = "1"
    out = subprocess.run([sys.executable, "-c", _FMU_PROBE, fmu_dir], env=env,
                         capture_output=True, text=True, timeout=300, check=True)
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert seen["pure_env"] is None  # the host's environment as it was
    # (numba there: this process's compiled function, unless ICEIMPACT_PURE turned it off here)
    assert seen["compiled"] == [opt_in and importlib.util.find_spec("numba") is not None]


@pytest.mark.parametrize("handed_back", [False, True])
def test_a_rollback_gives_the_search_back_whole(handed_back):
    """EventSolver.rollback restores all a flight's search holds: its frontier, the probe kept
    at its end and whether the compiled search handed it back (RootSearch.checkpoint)."""
    sim = Simulator(Scene(ice_M=800.0))
    sim.advance(0.5)
    solver = sim.solver
    search = solver.seg.search
    search.handed_back = handed_back
    saved, before = solver.checkpoint(), search.checkpoint()
    solver.advance_to(solver.t + 0.7, sim.scene.flow_u)  # impacts: new segments, new searches
    assert solver.seg is not saved[12]
    solver.rollback(saved)
    assert solver.seg.search is search and search.checkpoint() == before
    assert search.handed_back is handed_back


def test_a_probe_at_hypots_scales_hands_the_step_back(pure_function):
    """An over-damped structure a hair's breadth (1e-150 m) from its rest position: the probe's
    amplitude bounds are at the scales of their math.hypot form, which only RootSearch takes.
    flight_root hands the step back (it does not answer "no root before the horizon" from a
    frontier short of it), and the search finds the impact RootSearch finds."""
    sim = Simulator(Scene(structure_c=88000.0))
    sim.advance(1.0)
    solver = sim.solver
    results = []
    for by_root_search in (False, True):
        flight = Flight(solver.context, 0.0, 1e-150, 0.0, -0.01, 0.3, 0.5)
        if by_root_search:
            flight.search = rootfind.RootSearch(0.0, flight.search.time_eps)
        found = flight.search.next_root_of(5.0, flight)
        results.append((found, flight.search.root, flight.search.iterations))
    assert results[0] == results[1]
    assert results[0][0] is not None and 0.0 < results[0][0] < 5.0
    assert pure_function.outcomes[GENERIC] >= 1
