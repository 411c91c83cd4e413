"""Method 3 (solvers/ode.py) at its stiffness limits, as the random search found them
(tools/random_search.py --method 3 --scales --flows): bounded work, sound results."""

from __future__ import annotations

import math

import numpy as np
import pytest

from iceimpact import ParameterError, Scene, Simulator
from iceimpact.limits import (
    DRAG_RATE_MAX,
)

# --- method 3: stiffness, found by tools/random_search.py --method 3 --scales --flows ----------

def _search_case(scene: dict, h: float, flow: str, signs: list[bool]) -> dict:
    """A case as the random search prints it on its REPLAY line (defaults for the other
    fields), for random_search.replay."""
    return {"scene": {**Scene().__dict__, **scene}, "h": h, "flow": flow, "signs": signs,
            "time_limit": 10.0}


#: A critically damped structure (omega_n 3.96e3 rad/s, c / m = 7.9e3 1/s) come to rest after
#: an impact, its states 1e-24 m and below, the ice at rest at its equilibrium; no drag.
AT_REST_BELOW_TOLERANCE = dict(
    structure_m=0.004822483396403491, structure_c=38.23747872592765,
    structure_k=75796.2578163658, structure_x0=0.0, structure_v0=2.2250738585072014e-308,
    ice_M=0.004822483396403491, ice_A=0.10000230261160267, ice_Cd=0.0, ice_z0=0.0,
    ice_v0=-8.232872664026076e-167, impact_e=1.0, drag_model=1, drag_v_lin=1.000000000007083,
    flow_u=0.0, solver_method=3)


def test_method_3_at_rest_below_its_tolerance_does_not_ring_through_the_ice():
    """With states far below the absolute tolerance the error control let DOP853's steps grow
    to 1e-2 s, 80 times c / m past its stability bound: the unstable steps' dense output rang
    the structure 2.5e-10 m past the ice (25 times the tolerance). Steps are now bounded by
    STABLE_STEP / rate. Independent check: the exact method's positions, within 10 atol."""
    from iceimpact.solvers.ode import STABLE_STEP

    ode = Simulator(Scene(**AT_REST_BELOW_TOLERANCE))
    exact = Simulator(Scene(**{**AT_REST_BELOW_TOLERANCE, "solver_method": 1}))
    tolerance = 10 * ode.solver.atol  # 1e-10 m
    for _ in range(1000):
        ode.advance(1e-3, 0.1)
        exact.advance(1e-3, 0.1)
        s = ode.solver.state
        assert s.x - s.z >= -tolerance
        assert abs(s.x - exact.solver.state.x) <= tolerance
    rate = 38.23747872592765 / 0.004822483396403491  # c / m
    assert ode.solver._max_step(ode.solver.y_now) == pytest.approx(STABLE_STEP["DOP853"] / rate)


@pytest.mark.parametrize("case", [
    # a damped structure and a floe resting on it at 5.7e-279 m/s, no flow (quadratic drag):
    # contact impulses of -2.5e-282 N.s, 1e-4 of the momentum scale, from unstable steps
    _search_case(dict(structure_m=4.397240511281057, structure_c=417.67189687553866,
                      structure_k=9918.141445303148, structure_x0=0.0,
                      structure_v0=5.674991271961134e-279, ice_M=4.397240511281057,
                      ice_A=1.0, ice_Cd=1.0, ice_z0=0.0, ice_v0=5.674991271961134e-279,
                      impact_e=1.0, drag_model=2, drag_v_lin=0.0034023056836142845,
                      flow_u=0.0, solver_method=3), 1e-3, "zero", [True]),
    # a 33 mg floe on a 33 mg structure (omega_n 0.03 rad/s), linear drag b/M = 6.4e4 1/s,
    # flow signs at random: over 10 s of CPU for 0.44 s (5 s chunks ahead of 10 ms steps),
    # then a tensile impulse of -5.9e-20 N.s (5.5e-5 of the momentum scale)
    _search_case(dict(structure_m=3.300050358924868e-05, structure_c=9.670628403318691e-07,
                      structure_k=3.242253559770527e-08, structure_x0=1.401298464324817e-45,
                      structure_v0=0.0, ice_M=3.300050358924875e-05,
                      ice_A=0.2803355045709724, ice_Cd=1.5, ice_z0=1.401298464324817e-45,
                      ice_v0=1.401298464324817e-45, impact_e=1.0, drag_model=1,
                      drag_v_lin=0.010049579393317814, flow_u=8.9e-16, solver_method=3),
                 0.01, "random signs", [True, False, False, True, True, True, False, True,
                                        True, False, True, False, False, False, True, False]),
    # a critically damped structure (omega_n 1e4 rad/s) leaving the ice at rest, no flow: with
    # stable steps its decay is followed to underflow, positions 0 and speeds 1e-319 m/s, and
    # every step met a gap of exactly 0 as an event (over 10 s of CPU in the first 0.37 s step)
    _search_case(dict(structure_m=100.0023026116027, structure_c=2000046.0522320517,
                      structure_k=10000230261.160248, structure_x0=0.0,
                      structure_v0=0.990468330088397, ice_M=100.0023026116027,
                      ice_A=0.049139914759806544, ice_Cd=7.439588730544905e-235, ice_z0=0.0,
                      ice_v0=0.0, impact_e=0.0, drag_model=1, drag_v_lin=1.0,
                      flow_u=4509.90874376061, solver_method=3), 0.37, "zero", [True, False]),
    # the bodies at zero gap, the ice parting at 6.9e-213 m/s (2e-200 of the velocities'
    # tolerance) while the drag presses it back: method 3 takes the parting for integration
    # noise and sticks them with a plastic entry, -6.8e-213 N.s; the search flagged the step's
    # -1.7e-215 N.s against a momentum scale of 2e-212 until its impulse check took method 3's
    # absolute tolerance, mu PARTING_NOISE atol (1e-10 N.s), as its gap check does
    _search_case(dict(structure_m=1.0, structure_c=0.0, structure_k=4.718601971181243,
                      structure_x0=-2.2250738585e-313, structure_v0=-2.1061441388102723e-255,
                      ice_M=126.90283035995253, ice_A=3.781832400600783,
                      ice_Cd=0.654572658341806, ice_z0=-2.2250738585e-313,
                      ice_v0=-6.880602889092191e-213, impact_e=0.0, drag_model=1,
                      drag_v_lin=9.53930163557974, flow_u=0.0, solver_method=3),
                 10.0, "zero", [True]),
], ids=["at-rest-u0-quadratic", "light-floe-random-signs", "decay-to-underflow",
        "parting-below-tolerance"])
def test_method_3_search_cases_run_soundly(case):
    """Replayed exactly as the random search ran them (its checks are the independent ones:
    finite, gap >= -10 atol, impulse >= -1e-5 of the momentum scale, no energy created at
    u = 0) within its 10 s CPU limit."""
    from random_search import replay

    outcome = replay(case)
    assert outcome.fault is None and not outcome.refused
    assert outcome.t == pytest.approx(1.0 if case["h"] >= 1e-3 else 0.05)


def test_method_3_a_stiff_drag_on_a_slow_structure_does_not_integrate_far_ahead():
    """A 4 g floe stuck on a slow structure (period 4600 s) under a linear drag of b/M =
    1.4e5 1/s: every solve_ivp call spanned a 5 s chunk ahead of 10 ms steps, over 10 s of CPU
    for two steps. Chunks are now at most CHUNK_RATE / rate = 0.016 s: the integration stays
    within one chunk of the time asked, and its work within ~5 evaluations per step of
    STABLE_STEP / rate (the bound) over the time integrated."""
    from iceimpact.limits import integrated_rate
    from iceimpact.solvers.ode import CHUNK_RATE, STABLE_STEP

    scene = Scene(structure_m=0.00031837387396693875, structure_c=8.662664593413903e-07,
                  structure_k=5.892581332362994e-10, structure_x0=0.0, ice_M=0.003911992529513781,
                  ice_A=1.0, ice_Cd=1.0894605948212017, ice_z0=0.0, ice_v0=0.0, impact_e=1.0,
                  drag_model=1, drag_v_lin=1.0000097396015444, flow_u=0.1, solver_method=3)
    rate = integrated_rate(scene, 0.1)
    assert rate == pytest.approx(scene.drag_b / scene.ice_M)  # 1.39e5 1/s
    sim = Simulator(scene)
    for _ in range(5):
        r = sim.advance(0.01)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.solver.chunk_hi - sim.t <= CHUNK_RATE / rate
    steps = sim.solver.chunk_hi / (STABLE_STEP["DOP853"] / rate)
    assert sim.solver.nfev <= 20 * steps  # DOP853: 12 stages + 3 for its dense output


def test_method_3_explicit_integrators_have_a_rate_limit_from_their_cost():
    """RK45 and DOP853 cost ~3e-5 s of CPU x rate per simulated second near their stability
    bound: the rate rules of method 3 refuse above ODE_EXPLICIT_RATE_MAX = 3e5 1/s (10 s per
    simulated second), naming the combination, its value, the limit and the integrator, and
    pointing at LSODA, which keeps DRAG_RATE_MAX; method 1 keeps DRAG_RATE_MAX too."""
    from iceimpact.limits import ODE_EXPLICIT_RATE_MAX

    assert ODE_EXPLICIT_RATE_MAX == 3e5 and DRAG_RATE_MAX == 1e6
    light = dict(ice_M=1e-3, ice_A=1.0, ice_Cd=1.0, drag_model=1, solver_method=3)
    for ode_method, name in [(1, "RK45"), (2, "DOP853")]:
        with pytest.raises(ParameterError) as err:
            Scene(**light, drag_v_lin=1.0, solver_ode_method=ode_method)  # b/M = 5e5 1/s
        message = str(err.value)
        assert message.startswith("B * drag.v_lin / ice.M = 499500.0 is not allowed: <= 300000")
        assert f"solver.ode_method = {ode_method} ({name})" in message
        assert "solver.ode_method = 3 (LSODA" in message and "1e+06 1/s" in message
        with pytest.raises(ParameterError, match=r"structure.c / structure.m = 400000.0 .*"
                                                 r"<= 300000 1/s"):
            Scene(structure_c=4e5 * 1600.0, solver_method=3, solver_ode_method=ode_method)
        Scene(structure_c=2.9e5 * 1600.0, solver_method=3, solver_ode_method=ode_method)
    for ode_method in (3, 4):
        Scene(**light, drag_v_lin=1.0, solver_ode_method=ode_method)
    # mid-run, a flow whose quadratic drag rate exceeds the explicit limit is refused
    sim = Simulator(Scene(drag_model=2, solver_method=3))
    sim.advance(1e-3)
    u_max = ODE_EXPLICIT_RATE_MAX * 1600.0 / (2.0 * 499.5)
    with pytest.raises(ParameterError, match=r"flow.u = .* is not allowed: \|flow.u\| <= 4.8e"):
        sim.advance(1e-3, 1.01 * u_max)
    sim.advance(1e-3, 0.99 * u_max)


@pytest.mark.parametrize("kind", ["over-damped flight", "over-damped stuck", "linear drag"])
def test_method_3_work_per_simulated_second_is_proportional_to_the_rate(kind):
    """Just inside the explicit limit (0.99 x 3e5 1/s), the flow reversed at every 1 ms step:
    the work over the time integrated is proportional to the rate, 7 to 9 evaluations x rate
    per simulated second (DOP853: 15 per step of at most STABLE_STEP / rate, with rejected
    steps and restarts), the cost the limit was derived from; independent of CPU speed."""
    from iceimpact.limits import ODE_EXPLICIT_RATE_MAX

    rate = 0.99 * ODE_EXPLICIT_RATE_MAX
    if kind == "over-damped flight":
        scene = Scene(structure_m=1.0, structure_k=1e8, structure_c=rate, structure_x0=0.01,
                      ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0, solver_method=3)
    elif kind == "over-damped stuck":
        scene = Scene(structure_m=1.0, structure_k=1e8, structure_c=rate, structure_x0=0.0,
                      structure_v0=0.0, ice_M=1e-3, ice_z0=0.0, ice_v0=0.0, solver_method=3)
    else:
        scene = Scene(ice_M=1e-3, ice_A=1.0, ice_Cd=1.0, drag_model=1,
                      drag_v_lin=rate * 1e-3 / 499.5, solver_method=3)
    sim = Simulator(scene)
    for i in range(20):
        r = sim.advance(1e-3, 0.1 if i % 2 == 0 else -0.1)
        assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    assert sim.solver.nfev <= 12.0 * rate * sim.solver.chunk_hi


#: The random search's slow method-3 scene (seed 46): a 0.34 mg floe on a 1.8 g structure
#: (omega_n 0.16 rad/s, chatter time 0.39 s), linear drag b / M = 2.9e5 1/s (just inside the
#: explicit limit), e = 0.7, 1 ms steps with the flow reversed one step in four.
LIGHT_FLOE_NEAR_THE_RATE_LIMIT = _search_case(
    dict(structure_m=0.0018329234721427574, structure_c=0.0005841447487010957,
         structure_k=4.654109849934993e-05, structure_x0=4.177705884955332e-267,
         structure_v0=1e-16, ice_M=3.3519054173469566e-07, ice_A=0.19282973629443662,
         ice_Cd=0.5503080240880754, ice_z0=4.177705884955332e-267,
         ice_v0=-0.00013118567765448426, impact_e=0.7045244644744516, drag_model=1,
         drag_v_lin=0.0018488068422214442, flow_u=0.0, solver_method=3),
    1e-3, "reversed 1 in 4", [False, True, False, False, True, True, False])


def test_method_3_sticking_steps_are_bounded_by_the_rate_of_the_bodies_together():
    """Stuck, the bodies integrate (m + M) x'' + (c + b) x' + k x = b u: their rate is
    (c + b) / (m + M), 53 1/s for the light floe, not the floe's own b / M = 2.9e5 1/s in
    flight, which bounded the sticking steps to 1.7e-5 s (6,094 evaluations for its first
    3 ms, stuck from 9e-9 s). The rate of the bodies together is a mediant of the flight's:
    never above the larger of (c + b_s) / (m + m_a) and b / M (or 2 B speed / M)."""
    from iceimpact.limits import integrated_rate
    from iceimpact.solvers.contact_rules import Phase
    from iceimpact.solvers.ode import STABLE_STEP

    scene = Scene(**LIGHT_FLOE_NEAR_THE_RATE_LIMIT["scene"])
    sim = Simulator(scene)
    for _ in range(3):
        r = sim.advance(1e-3, 0.1)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.solver.phase is Phase.STICK
    assert sim.solver.nfev < 500
    together = (scene.structure_c + scene.drag_b) / (scene.structure_m + scene.ice_M)
    assert sim.solver._max_step(sim.solver.y_now) == pytest.approx(STABLE_STEP["DOP853"]
                                                                  / together)
    assert integrated_rate(scene, 0.1, together=True) == pytest.approx(together, rel=1e-15)
    for fields in [dict(), dict(drag_model=2, ice_A=2.0), dict(ice_M=6400.0, flow_u=2.0),
                   dict(structure_c=3000.0), dict(structure_Cd=1.0, structure_A=1.0),
                   dict(structure_Cd=1.0, structure_A=1.0, drag_model=2),
                   LIGHT_FLOE_NEAR_THE_RATE_LIMIT["scene"]]:
        sc = Scene(**{**fields, "solver_method": 3})
        quadratic = sc.drag_model == 2
        speed = 0.7
        structure = (sc.structure_c + (2.0 * sc.structure_drag_B * speed if quadratic
                                       else sc.structure_drag_b)) / sc.structure_mass
        ice = 2.0 * sc.drag_B * speed / sc.ice_M if quadratic else sc.drag_b / sc.ice_M
        assert integrated_rate(sc, 0.1, speed, together=True) <= max(structure, ice)


def test_method_3_light_floe_near_the_rate_limit_costs_the_rate_rules_work():
    """The search's slow scene ran at ~70 s of CPU per simulated second: each chatter-closed
    impact (every 4 ms) counted as a degenerate contact, so that from the ninth on the bodies
    were held for 2^n ns, doubling up to the chatter time, 0.39 s; each hold was integrated
    whole in one call at the flight's step bound (345,842 evaluations for 0.39 s) and thrown
    away at the flow change 1 ms later: 1.3e6 evaluations in the first 0.083 s, 91 % of them in
    holds. A hold is now integrated in the segment's spans (never more than a chunk ahead) and
    sticking steps are bounded by the bodies' own rate: the work stays within 4 evaluations x
    b / M per simulated second, checked at every step (DOP853: 15 per step of at most
    STABLE_STEP / rate = 1 / (5 rate) s, so 3 rate, plus the restarts at flow changes and
    impacts); independent of CPU speed."""
    from iceimpact.limits import integrated_rate
    from random_search import flow_at

    case = LIGHT_FLOE_NEAR_THE_RATE_LIMIT
    scene = Scene(**case["scene"])
    rate = integrated_rate(scene, 0.1)
    assert rate == pytest.approx(scene.drag_b / scene.ice_M)  # 2.9e5 1/s
    sim = Simulator(scene)
    for i in range(150):
        r = sim.advance(1e-3, flow_at(case["flow"], i, 0.1, case["signs"]))
        assert r.gap >= -10.0 * sim.solver.atol and math.isfinite(r.impulse)
        assert sim.solver.chunk_hi - sim.t <= sim.solver.chunk
        assert sim.solver.nfev <= 4.0 * rate * sim.t + 2000
    assert sim.impact_count >= 30
    # (its holds, each chatter-closed impact counted as a degenerate contact, are gone with fix
    # 32: a hold integrated in spans is pinned by the next test)


def test_method_3_a_forced_hold_is_integrated_in_the_segments_spans():
    """A forced hold (bodies together, separation not looked for until its end: a degenerate
    contact, or events repeating at one instant) of the chatter time, 0.39 s for this slow
    structure, was integrated whole in one call at the step bound of the light floe bouncing near
    the explicit rate limit
    (345,842 evaluations) and thrown away at the next flow change. It is now integrated in the
    segment's spans, never more than a chunk ahead of the time asked, and its end is still where
    the contact logic decides again."""
    from iceimpact.solvers.contact_rules import Phase

    case = LIGHT_FLOE_NEAR_THE_RATE_LIMIT
    scene = Scene(**dict(case["scene"], structure_x0=0.0, ice_z0=0.0, structure_v0=0.0,
                         ice_v0=0.0))
    sim = Simulator(scene)
    solver = sim.solver
    sim.advance(1e-3, 0.1)
    hold = solver.rules.chatter_time
    assert hold == pytest.approx(0.39, rel=0.02)
    x, v = solver.state.x, solver.state.v
    solver._segment(Phase.STICK, sim.t, [x, v, 0.0], hold=hold)
    start, nfev0 = sim.t, solver.nfev
    for _ in range(20):
        sim.advance(1e-3, 0.1)
        assert solver.chunk_hi - sim.t <= solver.chunk
        assert solver.hold_until == pytest.approx(start + hold)
    assert solver.nfev - nfev0 < 20000  # the hold whole: ~3.5e5


def test_method_3_radau_has_limits_from_its_steps_per_period_and_tolerance():
    """Radau's error estimate is of order 3: its steps per period of the structure and per
    relaxation after a flow change grow as rtol^(-1/4), whatever the rate (~350 per period and
    150-300 per flow change at rtol 1e-8; a structure ringing at 1e4 rad/s cost 82-84 s of CPU
    per simulated second). With solver.ode_method = 4 omega_n is held to 1e3 rad/s at rtol 1e-8,
    scaled as rtol^(1/4) up to OMEGA_MAX_ODE, and solver.rtol to >= 1e-10; the messages name
    the variable, its value and the range. LSODA keeps OMEGA_MAX_ODE and every rtol."""
    from iceimpact.limits import RADAU_OMEGA_MAX, RADAU_RTOL_MIN, omega_limit

    assert (RADAU_OMEGA_MAX, RADAU_RTOL_MIN) == (1e3, 1e-10)
    ringing = dict(structure_m=1.0, structure_k=1e8, structure_c=200.0, structure_x0=0.01,
                   ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0, solver_method=3)   # omega_n = 1e4
    with pytest.raises(ParameterError) as err:
        Scene(**ringing, solver_ode_method=4)
    assert str(err.value).startswith(
        "sqrt(structure.k / structure.m) = 10000.0 is not allowed: omega_n <= 1e+03 rad/s with "
        "solver.method = 3 and solver.ode_method = 4 (Radau)")
    with pytest.raises(ParameterError, match=r"omega_n <= 3.16e\+03 rad/s .*solver.rtol = 1e-06"):
        Scene(**ringing, solver_ode_method=4, solver_rtol=1e-6)
    assert Scene(**ringing, solver_ode_method=4, solver_rtol=1e-4).omega_n == 1e4
    assert omega_limit(Scene(solver_method=3, solver_ode_method=4, solver_rtol=1e-10)) == \
        pytest.approx(1e3 * 1e-2 ** 0.25)
    Scene(**{**ringing, "structure_k": 0.99e6}, solver_ode_method=4)
    with pytest.raises(ParameterError, match=r"^solver.rtol = 1e-11 is not allowed: >= 1e-10 "
                                             r"with solver.method = 3 and solver.ode_method = "
                                             r"4 \(Radau\)"):
        Scene(solver_method=3, solver_ode_method=4, solver_rtol=1e-11)
    Scene(solver_method=3, solver_ode_method=4, solver_rtol=1e-10)
    Scene(**ringing, solver_ode_method=3, solver_rtol=1e-13)  # LSODA


@pytest.mark.parametrize("kind, rate", [("linear drag", 1e3), ("linear drag", 9.9e5),
                                        ("quadratic drag", 1e3), ("quadratic drag", 9.9e5),
                                        ("ringing", 0.99e3)])
def test_method_3_radau_work_is_set_by_its_tolerance_not_the_rate(kind, rate):
    """Radau at rtol 1e-8, the flow reversed at every 1 ms step: each step costs at most ~300
    Radau steps (~7.5 evaluations each, 2200 measured at 9.9e5 1/s) whatever the drag rate
    from 1e3 to 1e6 1/s; a structure ringing at the omega_n limit, ~350 steps (~2500
    evaluations) per period. The law the Radau rules are derived from, independent of CPU
    speed (benchmarks/implicit_cost.py)."""
    from ode_rate_cost import scene as stiff_scene

    if kind == "ringing":  # omega_n = rate, zeta = 0.01, the ice out of reach
        scene = Scene(structure_m=1.0, structure_k=rate ** 2, structure_c=0.02 * rate,
                      structure_x0=0.01, ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0, solver_method=3,
                      solver_ode_method=4)
    else:
        scene = stiff_scene(kind, rate, 4)
    sim = Simulator(scene)
    steps = 10
    for i in range(steps):
        r = sim.advance(1e-3, scene.flow_u if i % 2 == 0 else -scene.flow_u)
        assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    if kind == "ringing":
        periods = sim.solver.chunk_hi * rate / (2.0 * math.pi)
        assert sim.solver.nfev <= 3000 * periods
    else:
        assert sim.solver.nfev <= 3000 * steps


def test_method_3_implicit_integrators_get_the_exact_jacobian():
    """LSODA and Radau are given d(rhs)/dy from the same drag laws (force_rate) instead of
    estimating it by finite differences: it matches central differences of each right-hand
    side (flight, flight with the Morison drag on the structure, sticking, sticking with it)."""
    from iceimpact.solvers.contact_rules import Phase
    from iceimpact.solvers.ode import OdeSolver

    def numeric(fun, y):
        y = np.asarray(y, dtype=float)
        cols = []
        for j in range(y.size):
            h = 1e-6 * max(1.0, abs(y[j]))
            dy = np.zeros_like(y)
            dy[j] = h
            cols.append((np.asarray(fun(0.0, y + dy)) - np.asarray(fun(0.0, y - dy))) / (2 * h))
        return np.array(cols).T

    morison = dict(structure_Cd=1.0, structure_A=2.0, structure_V=1.0, structure_Ca=1.0)
    for drag_model in (1, 2):
        for extra in ({}, morison):
            scene = Scene(drag_model=drag_model, flow_u=0.3, solver_method=3,
                          solver_ode_method=4, impact_e=0.0, **extra)
            solver = OdeSolver(scene)
            assert (solver.structure_drag is not None) == bool(extra)
            for phase, y in ((Phase.FLIGHT, [0.01, -0.2, -0.05, 0.7]),
                             (Phase.STICK, [0.01, -0.2, 0.0])):
                solver._equations(phase, 0.0)
                exact = np.array(solver.rhs.jacobian(0.0, y))
                assert exact.shape == (len(y), len(y))
                assert np.allclose(exact, numeric(solver.rhs, y), rtol=1e-7, atol=1e-9), \
                    (drag_model, extra, phase)


def test_a_light_pair_sticking_far_from_its_equilibrium_parts_nothing_in_bounded_time():
    """Method 1, linear drag: a light pair (m = 2.2e-6 kg, M = 1.1e-7 kg, k = 5.2e-9 N/m) under
    b = 4e5 kg/s sticks towards an equilibrium b u / k = 7.7e12 m away, where a position's ulp
    is 1e-3 m. The contact force (k x, 5e-13 N at 0.1 mm) was evaluated as b (u - v) - M a,
    terms of b u = 4e4 N, below its own rounding: the separation search took over 60 s of
    CPU for the first 1 ms. Positions, force and impulse now come from increments from the
    anchor: each step's impulse equals the structure's momentum balance m dv + k x dt (c = 0),
    and the pair drifts with the flow."""
    import signal

    def _out_of_time(signum, frame):
        raise TimeoutError("the sticking phase took over 5 s of CPU")

    m, k, u, h = 2.2e-6, 5.2e-9, 0.1, 1e-3
    sim = Simulator(Scene(structure_m=m, structure_c=0.0, structure_k=k, structure_x0=0.0,
                          structure_v0=u, ice_M=1.1e-7, ice_A=4004.0, ice_Cd=2.0, ice_z0=0.0,
                          ice_v0=u, impact_e=0.0, drag_model=1, flow_u=u, solver_method=1))
    assert sim.scene.drag_b == pytest.approx(4e5, rel=1e-5)
    previous = signal.signal(signal.SIGPROF, _out_of_time)
    signal.setitimer(signal.ITIMER_PROF, 5.0)
    try:
        v_before, x_before = u, 0.0
        for i in range(20):
            r = sim.advance(h)
            assert r.sticking and r.impulse >= 0.0
            balance = m * (r.v - v_before) + k * 0.5 * (r.x + x_before) * h
            assert r.impulse == pytest.approx(balance, rel=1e-6, abs=1e-24)
            assert r.x == pytest.approx(u * (i + 1) * h, rel=1e-9)
            v_before, x_before = r.v, r.x
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.signal(signal.SIGPROF, previous)


def test_sticking_far_from_its_equilibrium_keeps_its_positions_exact():
    """Method 1, linear drag, the scene above (equilibrium b u / k = 6.9e7 m): positions
    written as offset + y carried the offset's rounding, 2.3e-8 m off the exact motion over
    0.2 s; as increments from the anchor they match the closed form evaluated in 50-digit
    decimal arithmetic (the over-damped motion on its two exponents) to 1e-16 m."""
    from decimal import Decimal, localcontext

    m, k, u = 1.0, 1.1779e-4, 0.1
    scene = Scene(structure_m=m, structure_c=0.0, structure_k=k, structure_x0=0.0,
                  structure_v0=0.0, ice_M=393.5, ice_A=812.19, ice_Cd=2.0, ice_z0=0.0,
                  ice_v0=0.0, impact_e=0.0, drag_model=1, flow_u=u, solver_method=1)
    sim = Simulator(scene)
    with localcontext() as ctx:
        ctx.prec = 50
        mass, damping, stiff = Decimal(m) + Decimal(393.5), Decimal(scene.drag_b), Decimal(k)
        offset = damping * Decimal(u) / stiff
        root = (damping * damping - 4 * stiff * mass).sqrt()
        s1, s2 = (-damping + root) / (2 * mass), (-damping - root) / (2 * mass)
        a, b = -s2 * -offset / (s1 - s2), s1 * -offset / (s1 - s2)
        for i in range(1, 201):
            r = sim.advance(1e-3)
            t = Decimal(i) / 1000
            exact = offset + a * (s1 * t).exp() + b * (s2 * t).exp()
            assert abs(float(Decimal(r.x) - exact)) < 1e-16
