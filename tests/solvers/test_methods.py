"""Methods 2 (the article's fixed-step scheme) and 3 (scipy ODE) against method 1 (exact)."""

import math
import pickle

import numpy as np
import pytest

from iceimpact import ParameterError, Scene, Simulator
from iceimpact.scene import (
    DETECTION_SIGN,
    DETECTION_WINDOW,
    METHOD_EXACT,
    METHOD_FIXED_STEP,
    METHOD_ODE,
    PARAMETERS,
)
from iceimpact.simulator import make_solver
from iceimpact.solvers.fixed_step import FixedStepSolver
from iceimpact.solvers.ode import ODE_METHODS, OdeSolver

FIG2 = Scene()
FIG8 = Scene(impact_e=0.5)
FIG13 = Scene(ice_A=2.0, drag_model=2)
FIG18 = Scene(impact_e=0.5, drag_model=2)


def impact_times(scene: Scene, t_end: float) -> np.ndarray:
    solver = make_solver(scene)
    solver.advance_to(t_end, scene.flow_u)
    return np.array([i.t for i in solver.impacts])


def fixed(scene: Scene, dt: float, detection: int = DETECTION_SIGN) -> Scene:
    return scene.replace(solver_method=METHOD_FIXED_STEP, solver_dt=dt, solver_detection=detection)


def ode(scene: Scene, rtol: float, method: int = 2) -> Scene:
    return scene.replace(solver_method=METHOD_ODE, solver_rtol=rtol, solver_ode_method=method)


# parameters and registry -------------------------------------------------------------------------

def test_new_parameters_are_integers_with_ranges():
    specs = {p.name: p for p in PARAMETERS}
    assert specs["solver.detection"].kind is int
    assert (specs["solver.detection"].minimum, specs["solver.detection"].maximum) == (1, 2)
    assert specs["solver.ode_method"].kind is int
    assert (specs["solver.ode_method"].minimum, specs["solver.ode_method"].maximum) == (1, 4)
    assert Scene().solver_detection == DETECTION_SIGN
    assert ODE_METHODS[Scene().solver_ode_method] == "DOP853"
    scene = Scene.from_fmi({"solver.detection": 2, "solver.ode_method": 4})
    assert (scene.solver_detection, scene.solver_ode_method) == (2, 4)
    for bad in ({"solver_detection": 3}, {"solver_detection": 0}, {"solver_ode_method": 5},
                {"solver_ode_method": 1.5}):
        with pytest.raises(ParameterError):
            Scene(**bad)


def test_every_method_is_registered():
    assert type(make_solver(Scene(solver_method=METHOD_FIXED_STEP))) is FixedStepSolver
    for code, name in ODE_METHODS.items():
        solver = make_solver(ode(FIG2, 1e-6, code))
        assert type(solver) is OdeSolver and solver.method == name
    assert make_solver(Scene(solver_method=METHOD_EXACT)).name == "exact"


# method 2: the article's scheme ---------------------------------------------------------------

def test_fixed_step_flight_is_the_articles_scheme():
    """No impact: the structure follows its closed form (eq. 24) at every grid point, the linear
    ice its closed form, the quadratic ice explicit Euler (eq. 34-36), step by step."""
    for drag_model in (1, 2):
        scene = Scene(drag_model=drag_model, ice_z0=-5.0, ice_v0=0.0, flow_u=0.3,
                      structure_v0=0.01, solver_dt=1e-2)
        solver = FixedStepSolver(fixed(scene, 1e-2))
        exact = make_solver(scene)
        z, w = scene.ice_z0, scene.ice_v0
        beta = scene.drag_B / scene.ice_M
        for i in range(1, 101):
            solver.advance_to(i * 1e-2, scene.flow_u)
            exact.advance_to(i * 1e-2, scene.flow_u)
            assert solver.state.x == pytest.approx(exact.state.x, rel=1e-12, abs=1e-15)
            if drag_model == 1:
                assert solver.state.z == pytest.approx(exact.state.z, rel=1e-12)
            else:
                r = w - scene.flow_u
                z, w = z + w * 1e-2, w - beta * abs(r) * r * 1e-2
                assert (solver.state.z, solver.state.w) == pytest.approx((z, w), rel=1e-12)
        assert not solver.impacts and solver.state.gap > 0.0


@pytest.mark.parametrize("scene", [FIG2, FIG13], ids=["fig2", "fig13"])
def test_fixed_step_converges_with_measured_order(scene):
    """Gap sign test: the first three impact times converge to the exact ones at first order
    (an impact is seen at the first grid point past it)."""
    exact = impact_times(scene, 10.0)[:3]
    dts = np.array([1e-2, 1e-3, 1e-4, 1e-5])
    errors = []
    for dt in dts:
        got = impact_times(fixed(scene, dt), exact[-1] + 0.5)
        assert got.size >= 3
        errors.append(np.max(np.abs(got[:3] - exact)))
    errors = np.array(errors)
    order = np.polyfit(np.log10(dts), np.log10(errors), 1)[0]
    assert 0.8 < order < 1.2, (order, errors)
    assert np.all(np.diff(errors) < 0.0)
    assert errors[-1] < 20 * dts[-1]


def test_tolerance_window_misses_impacts_the_exact_solver_finds():
    """Eq. 26 read literally, Delta = 0.1 min(|v dt|, |w dt|): at the first impact of the Figure 2
    scene the structure is still at rest, so Delta = 0 and the window has no width: at every dt the
    ice passes through the structure. Started again just after that impact, with the structure
    moving, the window is still narrower than the distance the gap closes in one step
    (|w - v| dt > 2 Delta): the next impact is missed too. The sign test finds both."""
    exact = make_solver(FIG2)
    exact.advance_to(10.0, FIG2.flow_u)
    first = exact.impacts[0]
    assert 0.8 < first.t < 1.0 and first.v_minus == 0.0
    for dt in (1e-2, 1e-3, 1e-4, 1e-5):
        window = FixedStepSolver(fixed(FIG2, dt, DETECTION_WINDOW))
        window.advance_to(2.0, FIG2.flow_u)
        assert not window.impacts
        assert window.state.gap < -0.01  # the ice is more than 1 cm past the structure
        sign = impact_times(fixed(FIG2, dt), 2.0)
        assert 0.0 <= sign[0] - first.t <= dt * (1 + 1e-9)
    moving = FIG2.replace(structure_x0=first.x, structure_v0=first.v_plus, ice_z0=first.x,
                          ice_v0=first.w_plus)
    nxt = impact_times(moving, 1.0)
    assert nxt.size >= 1 and 0.1 < nxt[0] < 0.15
    for dt in (1e-3, 1e-4, 1e-5):
        assert impact_times(fixed(moving, dt, DETECTION_WINDOW), 1.0).size == 0
        assert abs(impact_times(fixed(moving, dt), 1.0)[0] - nxt[0]) <= dt * (1 + 1e-9)


def test_method_2_finds_impacts_by_default():
    """Switching to method 2 and nothing else must give a usable run: the sign test is the
    default (the article's eq. 26 window, detection 1, misses every impact of Figure 2 and leaves
    the ice 0.22 m past the structure after 10 s)."""
    assert Scene(solver_method=METHOD_FIXED_STEP).solver_detection == DETECTION_SIGN
    sim = Simulator(Scene(solver_method=METHOD_FIXED_STEP))
    worst = 0.0
    for _ in range(1000):
        worst = max(worst, sim.advance(1e-2).penetration)
    exact = make_solver(FIG2)
    exact.advance_to(10.0, FIG2.flow_u)
    assert sim.impact_count == exact.impact_count > 0
    assert worst <= FIG2.flow_u * FIG2.solver_dt  # at most one step's closing distance
    window = Simulator(Scene(solver_method=METHOD_FIXED_STEP, solver_detection=DETECTION_WINDOW))
    report = window.advance(10.0)
    assert report.impact_count == 0 and report.penetration > 0.2  # kept, on request


def test_fixed_step_pins_the_articles_steady_state():
    """Slow flow (b u / M < 1e-4 m/s^2) and a damped structure: thresholds (i)-(iii) are met and
    the bodies are pinned at x = z = b u / k (eq. 28-29), loading the structure with b u."""
    u = 1e-3
    scene = Scene(flow_u=u, impact_e=0.5, structure_c=8e4, ice_z0=-1e-5, ice_v0=1e-3)
    solver = FixedStepSolver(fixed(scene, 1e-3))
    solver.advance_to(5.0, u)
    assert solver.impacts and solver.sticking and solver.sticking_since < 5.0
    b = scene.drag_b
    s = solver.state
    assert s.x == s.z == pytest.approx(b * u / scene.structure_k, rel=1e-12)
    assert s.v == s.w == 0.0
    assert solver.advance_to(6.0, u) == pytest.approx(b * u * 1.0, rel=1e-12)
    # a new flow speed releases the pin; the scheme marches on and settles again
    solver.advance_to(7.0, 2 * u)
    assert len(solver.impacts) > 0
    solver.advance_to(30.0, 2 * u)
    assert solver.sticking
    assert solver.state.x == pytest.approx(2 * b * u / scene.structure_k, rel=1e-12)


def test_articles_thresholds_never_pin_the_figure8_scene():
    """With u = 0.1 m/s the free floe's drag acceleration b u / M = 3.1e-3 m/s^2 is 30 times
    threshold (iii): the literal scheme chatters on (an impact every few steps) instead."""
    solver = FixedStepSolver(fixed(FIG8, 1e-3))
    solver.advance_to(40.0, FIG8.flow_u)
    assert not solver.sticking
    late = [i for i in solver.impacts if i.t > 30.0]
    assert len(late) > 1000  # more than one impact per 10 grid steps


@pytest.mark.parametrize("scene", [FIG8, FIG18], ids=["fig8", "fig18"])
def test_fixed_step_does_not_depend_on_communication_step(scene):
    ref = FixedStepSolver(fixed(scene, 1e-4))
    ref_impulse = ref.advance_to(5.0, scene.flow_u)
    for h in (1e-3 / 7, 0.037, 2.5e-5):
        sim = Simulator(fixed(scene, 1e-4))
        n = int(math.ceil(5.0 / h - 1e-9))
        impulse = sum(sim.advance(min(h, 5.0 - k * h)).impulse for k in range(n))
        assert sim.t == pytest.approx(5.0, abs=1e-9)
        assert [i.t for i in sim.impacts] == [i.t for i in ref.impacts]
        assert impulse == pytest.approx(ref_impulse, rel=1e-12)
        assert sim.solver.state.x == pytest.approx(ref.state.x, rel=1e-9, abs=1e-15)


def test_fixed_step_reports_penetration():
    solver = FixedStepSolver(fixed(FIG2, 1e-3))
    solver.advance_to(3.0, FIG2.flow_u)
    first = solver.impacts[0]
    # the gap closes at ~|w - v| per second: one step overshoots by up to that times dt
    assert 0.0 < solver.max_penetration <= first.approach_speed * 1e-3 * 1.01


# method 3: scipy ODE --------------------------------------------------------------------------

def test_ode_first_20_impacts_agree_with_exact():
    """DOP853 at rtol 1e-12 over the first 20 impacts of Figure 2 (54 s): the sensitivity of the
    motion amplifies the local errors, yet all agree within 1e-7 s."""
    exact = impact_times(FIG2, 60.0)[:20]
    got = impact_times(ode(FIG2, 1e-12), exact[-1] + 0.1)
    assert got.size >= 20
    assert np.max(np.abs(got[:20] - exact)) < 1e-7


@pytest.mark.parametrize("scene,method,rtol", [
    (FIG2, 1, 1e-8), (FIG2, 2, 1e-8), (FIG2, 3, 1e-8), (FIG13, 4, 1e-6)],
    ids=["RK45", "DOP853", "LSODA", "Radau"])
def test_ode_flights_agree_with_exact_within_tolerance(scene, method, rtol):
    """Each of the first 20 flights, restarted from the exact solver's post-impact state, ends
    at the exact next impact within 20 rtol of its duration."""
    exact = make_solver(scene)
    exact.advance_to(60.0, scene.flow_u)
    impacts = exact.impacts[:21]
    assert len(impacts) == 21
    for a, b in zip(impacts[:-1], impacts[1:], strict=True):
        start = scene.replace(structure_x0=a.x, structure_v0=a.v_plus, ice_z0=a.x,
                              ice_v0=a.w_plus)
        duration = b.t - a.t
        got = impact_times(ode(start, rtol, method), 1.5 * duration)
        assert got.size >= 1
        assert abs(got[0] - duration) <= 20 * rtol * duration, (a.t, got[0], duration)


@pytest.mark.parametrize("drag_model", [1, 2])
def test_ode_flow_reversal_separates(drag_model):
    scene = Scene(impact_e=0.0, drag_model=drag_model)
    solver = OdeSolver(ode(scene, 1e-9))
    solver.advance_to(20.0, scene.flow_u)
    assert solver.sticking
    solver.advance_to(21.0, -0.1)
    assert not solver.sticking and solver.state.gap > 0.0


def test_ode_does_not_depend_on_communication_step():
    scene = ode(FIG18, 1e-8)
    ref = OdeSolver(scene)
    ref.advance_to(6.0, scene.flow_u)
    sim = Simulator(scene)
    h = 1e-2 / 3
    for k in range(int(round(6.0 / h))):
        sim.advance((k + 1) * h - k * h)
    assert [i.t for i in sim.impacts] == pytest.approx([i.t for i in ref.impacts], abs=1e-12)


# both -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("scene", [
    fixed(FIG18, 1e-4), ode(FIG8, 1e-8), ode(FIG18, 1e-6, 3), ode(FIG8, 1e-6, 4)],
    ids=["fixed-step", "DOP853", "LSODA", "Radau"])
def test_snapshot_survives_pickle_and_replays(scene):
    """FMU get/set/serialize state: a pickled snapshot replays the same steps, mid-flight or
    while the bodies stick."""
    def replay(sim):
        reports = [sim.advance(1e-2) for _ in range(50)]
        return ([(r.t, r.x, r.v, r.z, r.w, r.impulse, r.impact_count, r.sticking)
                 for r in reports], list(sim.impacts))

    sim = Simulator(scene)
    for t_stop in (3.0, 12.0):
        while sim.t < t_stop - 1e-9:
            sim.advance(1e-2)
        snapshot = pickle.loads(pickle.dumps(sim.save()))
        first = replay(sim)
        sim.restore(snapshot)
        assert replay(sim) == first
