"""Numerical stability at the extremes (the matrix of tests/extremes.py) and refused scenes.

Every corner scene x both drag laws x the three methods must stay finite, keep the gap (method 2:
within one grid step), conserve momentum at impacts, never create energy without flow, finish
with bounded work, and (method 1) agree with a tight scipy integration.
docs/explanation/robustness/index.md shows the same matrix with its measurements (``python
tests/extremes.py``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from extremes import CELLS, failures, run_cell
from iceimpact import ParameterError, Scene, Simulator, SolverError
from scenes import EULER_DIVERGES_AFTER_IMPACT


@pytest.mark.parametrize("method", [1, 2, 3], ids=["exact", "fixed-step", "ode"])
@pytest.mark.parametrize("drag", [1, 2], ids=["linear", "quadratic"])
@pytest.mark.parametrize("cell", CELLS, ids=[c.name for c in CELLS])
def test_extreme_cell(cell, drag, method):
    res = run_cell(cell, drag, method)
    if not res.finished and res.notes[0].startswith("not run"):
        assert method == 3 and cell.t_end_ode == 0.0
        return
    if (drag, method) in cell.refused:  # a clear refusal, naming the parameter
        assert res.notes[0].startswith("refused: structure.Cd = "), res.notes
        return
    # a limitation of the method, documented where the cell says (and only that one)
    known = [cell.known[drag, method]] if (drag, method) in cell.known else []
    assert failures(res) == known, res


@pytest.mark.parametrize("method", [1, 2], ids=["exact", "fixed-step"])
@pytest.mark.parametrize("drag", [1, 2], ids=["linear", "quadratic"])
@pytest.mark.parametrize(("name", "h_other"), [("step 10 s (40 periods)", 0.01),
                                               ("step 10 s, omega_n = 1e4", 0.01),
                                               ("step 1e-6 s", 1e-3)])
def test_extreme_steps_give_the_same_impacts(name, h_other, drag, method):
    """Methods 1 and 2 anchor their flights (grid) at events, not at communication points: steps
    of 10 s (40 to 16,000 periods of the structure) or 1 us give the impacts of ordinary steps."""
    cell = next(c for c in CELLS if c.name == name)
    a = run_cell(cell, drag, method, reference=False)
    b = run_cell(cell, drag, method, h=h_other, reference=False)
    assert len(a.impact_times) == len(b.impact_times) > 0
    np.testing.assert_allclose(a.impact_times, b.impact_times, rtol=0, atol=1e-9)


def test_flow_reversal_separates_sticking_bodies():
    """e = 0.5: the bodies stick before t = 15 s; the reversed flow pulls the ice away (exact)."""
    sim = Simulator(Scene(impact_e=0.5))
    while sim.t < 15.0 - 1e-9:
        sim.advance(0.01, 0.1)
    assert sim.solver.sticking
    while sim.t < 20.0 - 1e-9:
        report = sim.advance(0.01, -0.1)
    assert not report.sticking and report.gap > 0.01 and report.w < 0.0


# Combinations that have no meaningful simulation are refused with an error naming them --------
REFUSED = [
    ({"structure_k": 1e300, "structure_m": 1e-10}, "structure.k / structure.m = inf"),
    ({"fluid_rho": 1e300, "ice_A": 1e300}, "fluid.rho * ice.Cd * ice.A / 2 = inf"),
    ({"structure_c": 1e300}, "zeta^2 = (structure.c / (2 sqrt(k m)))^2 = inf"),
    ({"drag_v_lin": 1e300}, "zeta^2 = ((structure.c + b) / (2 sqrt(k (m + M))))^2"),
    ({"ice_v0": 1e300}, "ice.M * ice.v0^2 / 2 = inf"),
    ({"structure_v0": -1e300}, "structure.m * structure.v0^2 / 2 = inf"),
    ({"structure_x0": 1e200, "ice_z0": 0.0}, "structure.k * structure.x0^2 / 2 = inf"),
    ({"flow_u": 1e300}, "flow.u = 1e+300 is not allowed: a flow speed whose drag force"),
    ({"ice_z0": 0.01}, "ice.z0 = 0.01 is not allowed: <= structure.x0 = 0.0"),
    ({"solver_dt": 1e-12}, "solver.dt = 1e-12 is not allowed: >= 1e-9"),
    ({"solver_rtol": 1e-15}, "solver.rtol = 1e-15 is not allowed: 1e-13 <= rtol < 1"),
]


@pytest.mark.parametrize(("changes", "message"), REFUSED, ids=[m.split(" =")[0]
                                                              for _, m in REFUSED])
def test_meaningless_combination_is_refused(changes, message):
    with pytest.raises(ParameterError) as err:
        Scene(**changes)
    assert message in str(err.value)
    assert "is not allowed" in str(err.value)


def test_drag_linearisation_speed_is_irrelevant_to_quadratic_drag():
    """v_lin only enters the linearised law: a huge one is fine with quadratic drag."""
    sim = Simulator(Scene(drag_model=2, drag_v_lin=1e300))
    report = sim.advance(5.0)
    assert math.isfinite(report.x) and report.impact_count >= 1


def test_flow_that_overflows_the_drag_is_refused_during_the_run():
    sim = Simulator(Scene(drag_model=2))
    sim.advance(0.5)
    before = sim.report
    with pytest.raises(ParameterError, match=r"flow.u = 1e\+200 is not allowed"):
        sim.advance(0.5, 1e200)  # B u^2 = 5e402 N
    assert sim.report == before and sim.t == before.t
    sim.advance(0.5, -0.1)  # the run goes on


# The article's explicit Euler step (method 2, quadratic drag) diverges when dt is too long -----
def test_unstable_euler_step_is_refused_up_front():
    """(B/M) dt |w0 - u| > 2: eq. 36 would diverge from the first step (found by random search:
    NaN outputs before this check)."""
    with pytest.raises(ParameterError) as err:
        Scene(structure_m=4.0, structure_k=4.0, ice_M=0.0617, ice_A=6.22, ice_Cd=1.33,
              ice_v0=0.30, drag_model=2, flow_u=1e-6, solver_method=2)
    assert str(err.value).startswith("solver.dt = 0.0001 is not allowed: < 2 M / (B |ice.v0 - "
                                     "flow.u|) = ")


def test_unstable_euler_step_stops_the_run_with_a_clear_error():
    sim = Simulator(Scene(**EULER_DIVERGES_AFTER_IMPACT))
    with pytest.raises(SolverError) as err:
        for _ in range(100):
            sim.advance(1e-3)
    text = str(err.value)
    assert "solver.dt = 0.0001 s is too large for the explicit Euler step" in text
    assert "use solver.dt < " in text and "or solver.method = 1" in text
    report = sim.report  # the last completed step, finite
    assert all(math.isfinite(v) for v in (report.x, report.v, report.z, report.w))
    with pytest.raises(SolverError, match="the run stopped"):  # and it stays stopped
        sim.advance(1e-3)
    # the exact method runs the same scene
    exact = Simulator(Scene(**{**EULER_DIVERGES_AFTER_IMPACT, "solver_method": 1}))
    assert exact.advance(0.1).impact_count >= 1


#: a 1 g floe at rest in contact with a 1e9 kg structure at rest 1e30 m from its equilibrium,
#: no flow (the far-scale search's starts): the spring pulls the structure into the floe at
#: 5.4e20 m/s by the first grid point (omega_n^2 x0 dt), and the plastic impact there gives the
#: floe that speed: (B/M) h |w - u| = 1.35e22 over the 50 us to a communication point, where
#: eq. 36 is stable up to 2
FAR_STRUCK_FLOE = {
    "structure_m": 1e9, "structure_k": 5.4e3, "structure_c": 0.0, "structure_x0": 1e30,
    "structure_v0": 0.0, "ice_M": 1e-3, "ice_z0": 1e30, "ice_v0": 0.0, "impact_e": 0.0,
    "drag_model": 2, "flow_u": 0.0, "solver_method": 2}


def test_method_2_partial_euler_step_after_an_impact_is_held_to_the_stability_limit():
    """Method 2 gives the state at a communication point between grid points by a partial Euler
    step (eq. 36 over h < dt) from the last grid point, whose ice velocity may be an impact's:
    eq. 36 was held to its stability limit only on the grid's own steps. Here the impact at
    t = 1e-4 s gives the floe 5.4e20 m/s, the partial step to t = 1.5e-4 s multiplied it by
    1.35e22, and the energy at u = 0 grew 9.8e18 times in one step (the next step was refused
    by the grid's rule). The partial step is now refused as the grid's would be, naming
    solver.dt, its value and the allowed range; a step to the grid point itself is computed,
    and loses energy (a plastic impact)."""
    from random_search import energy

    scene = Scene(**FAR_STRUCK_FLOE)
    sim = Simulator(scene)
    e0 = energy(scene, sim.solver.state)
    start = sim.report
    with pytest.raises(SolverError) as err:
        sim.advance(1.5e-4)
    text = str(err.value)
    assert ("solver.dt = 0.0001 s is too large for the explicit Euler step of the quadratic "
            "drag (eq. 36) from the grid point at t = 0.0001 s to the communication point "
            "5e-05 s later: (B/M) h |w - u| = 1.35e+22 > 2") in text
    assert "use solver.dt < 7.41e-27 s, or solver.method = 1" in text
    assert sim.t == 0.0 and sim.report == start  # refused: nothing changed
    report = sim.advance(1e-4)  # to the grid point: the impact, no partial step
    assert report.impacts == 1 and report.w == report.v < -5e20
    assert energy(scene, sim.solver.state) <= e0 * (1.0 + 1e-15)  # (its rounding: 1 ulp)
    # where the partial step is within the limit, it is computed (|w - u| does not grow) and
    # the grid's next step is refused: a 0.1 m/s structure striking a 1 g floe, dt = 1e-4 s
    scene = Scene(structure_m=1e3, structure_k=1.0, structure_c=0.0, structure_v0=-0.1,
                  ice_M=1e-3, ice_z0=0.0, ice_v0=0.0, impact_e=0.0, drag_model=2, flow_u=0.0,
                  solver_method=2)
    sim = Simulator(scene)
    report = sim.advance(1.1e-4)  # (B/M) h |w - u| = 0.5 over the last 1e-5 s
    assert report.impacts == 1 and abs(report.w) < abs(report.v)
    with pytest.raises(SolverError, match=r"at t = 0.0001 s: \(B/M\) dt \|w - u\| = 4.99 > 2"):
        sim.advance(1e-4)


@st.composite
def _far_starts(draw):
    """Method 2, quadratic drag, no flow: the structure and the ice anywhere up to what
    validation accepts (positions and speeds log-uniform up to a finite energy, either sign;
    the ice in contact or up to 1e308 m upstream, at the structure's speed, at rest or its
    own), masses 1e-6 to 1e9 kg, omega_n up to 1e12 rad/s, any restitution."""
    from random_search import FAR_MAX, energy_bound, far_values

    m = 10 ** draw(st.floats(-6.0, 9.0))
    M = 10 ** draw(st.floats(-6.0, 9.0))
    k = 10 ** draw(st.floats(-200.0, math.log10(m) + 24.0))
    zeta = draw(st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 5.0)))
    x0 = draw(st.one_of(st.just(0.0), far_values(energy_bound(k))))
    v0 = draw(far_values(energy_bound(m)))
    gap = draw(st.one_of(st.just(0.0), far_values(FAR_MAX, signed=False)))
    w0 = draw(st.one_of(st.just(v0), st.just(0.0), far_values(energy_bound(M))))
    e = draw(st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 1.0)))
    try:
        return Scene(structure_m=m, structure_k=k, structure_c=2.0 * zeta * math.sqrt(k * m),
                     structure_x0=x0, structure_v0=v0, ice_M=M, ice_z0=max(x0 - gap, -FAR_MAX),
                     ice_v0=w0, impact_e=e, drag_model=2, flow_u=0.0, solver_method=2)
    except ParameterError:
        assume(False)


@settings(max_examples=300, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(scene=_far_starts(), fraction=st.floats(0.1, 3.0))
def test_method_2_creates_no_energy_at_zero_flow_from_far_starts(scene, fraction):
    """Method 2 at u = 0 from far starts, in communication steps of 0.1 to 3 grid steps (most
    end between grid points, where the state is a partial Euler step): at every step the energy
    exceeds that of the last grid point before the step's start (``grid_energy``: a partial step
    that overshoots the flow speed reports less) by at most the far-scale search's rounding
    bound (1e-9 of the initial energy plus a few ulps of the states times their momenta,
    tools/random_search.py), or the step is refused by eq. 36's stability rule, naming
    solver.dt."""
    from random_search import ENERGY_TOLERANCE, energy, energy_floor, grid_energy

    sim = Simulator(scene)
    last = sim.solver.state
    e0 = e_last = energy(scene, last)
    for _ in range(12):
        try:
            sim.advance(fraction * scene.solver_dt, 0.0)
        except SolverError as exc:
            assert "solver.dt = 0.0001 s is too large for the explicit Euler step" in str(exc)
            return
        s = sim.solver.state
        e = energy(scene, s)
        bound = (e_last + ENERGY_TOLERANCE[2] * e0 + energy_floor(scene, s, 0.0, 0.0)
                 + energy_floor(scene, last, 0.0, 0.0))
        assert e <= bound, (e_last, e)
        e_last, last = grid_energy(scene, sim.solver, e, s)


def test_method_3_energy_error_stays_within_the_bound_of_its_tolerance():
    """docs/explanation/accuracy.md, "Method 3's energy error": with nothing dissipating (e = 1, c =
    0,
    Cd = 0, u = 0) method 3's energy moves by at most 3 N (2 rtol E + atol sqrt(2 E)
    (sqrt(k) + sqrt(m) + sqrt(M))) over N <= nfev / 12 DOP853 steps (atol = 1e-3 rtol): each
    step's local error is within 3 (atol + rtol |y|) per state, an elastic impact moves it by
    nothing. A heavy ice pressing on a light stiff structure (42 elastic impacts in 3 s) at
    rtol 1e-4 to 1e-10, and a structure ringing for 300 s (477 periods) with the ice out of
    reach: the drift keeps within the bound at every step, and reaches 1e-3 to 5e-2 of it, so
    the bound is not vacuous; the tool's search holds method 3 to it
    (tools/random_search.py, ``ode_energy_bound``)."""
    from random_search import energy, ode_energy_bound

    worst = 0.0
    runs = [(rtol, 100.0, 1.0, -0.01, 0.01) for rtol in (1e-4, 1e-6, 1e-8, 1e-10)]
    runs.append((1e-8, 10.0, 0.0, -2.0, 1.0))  # ringing from x0 = 0.5 m, the ice at rest
    for rtol, omega, ice_v0, ice_z0, h in runs:
        scene = Scene(structure_m=1.0, structure_k=omega ** 2, structure_c=0.0,
                      structure_x0=0.0 if ice_v0 else 0.5, structure_v0=0.0, ice_M=100.0,
                      ice_Cd=0.0, ice_z0=ice_z0, ice_v0=ice_v0, impact_e=1.0, flow_u=0.0,
                      solver_method=3, solver_rtol=rtol)
        sim = Simulator(scene)
        e0 = energy(scene, sim.solver.state)
        for _ in range(300):
            sim.advance(h, 0.0)
            e = energy(scene, sim.solver.state)
            bound = ode_energy_bound(scene, max(e, e0), sim.solver.nfev)
            assert abs(e - e0) <= bound
            worst = max(worst, abs(e - e0) / bound)
        assert sim.impact_count == (42 if ice_v0 else 0)
    assert worst > 1e-3
