"""The work limits of each method (iceimpact.limits): scenes that would hang are refused up
front, with a message naming the limit. docs/explanation/robustness/limits.md."""

from __future__ import annotations

import math

import pytest

from iceimpact import ParameterError, Scene, Simulator
from iceimpact.contract import CHATTER_FRACTION
from iceimpact.fmi.adapter import FmuModel
from iceimpact.limits import (
    DRAG_RATE_MAX,
    OMEGA_MAX_EXACT,
    OMEGA_MAX_ODE,
    TAYLOR_RATE_MAX,
    TIME_RESOLUTION,
)

# --- accepted scenes that hang: the limits ------------------------------------------------------

def test_the_limits_follow_from_the_numerics():
    # the chatter time stays above the root search's time resolution up to t = 1e6 s
    assert math.isclose(2.0 * math.pi * CHATTER_FRACTION / OMEGA_MAX_EXACT,
                        TIME_RESOLUTION * 1e6)


@pytest.mark.parametrize("method, k", [(1, 1e40), (3, 1e40), (1, 1600 * 1e8 ** 2),
                                       (3, 1600 * 2e4 ** 2)])
def test_a_structure_too_stiff_to_resolve_is_refused(method, k):
    scene = dict(structure_k=k, ice_z0=-0.01, ice_v0=0.0, flow_u=0.0, solver_method=method)
    with pytest.raises(ParameterError, match=r"omega_n <= .* rad/s with solver.method"):
        Scene(**scene)
    Scene(**{**scene, "solver_method": 2})  # method 2's grid has no such limit


@pytest.mark.parametrize("method", [1, 3])
def test_the_stiffest_structure_accepted_runs_in_bounded_time(method):
    """Just inside the limit, the ice in contact moving towards the structure (an impact at
    t = 0, then the structure rings): 20 steps of 1 ms finish quickly and soundly."""
    omega = 0.99 * (OMEGA_MAX_EXACT if method == 1 else OMEGA_MAX_ODE)
    sim = Simulator(Scene(structure_k=1600 * omega ** 2, structure_x0=0.0, ice_z0=0.0,
                          ice_v0=0.01, flow_u=0.0, solver_method=method))
    for _ in range(20):
        r = sim.advance(1e-3)
        assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    assert sim.impact_count >= 1


@pytest.mark.parametrize("method, limit", [(1, "1.6e\\+06"), (3, "4.8e\\+05")])
def test_a_drag_too_stiff_to_integrate_is_refused(method, limit):
    # method 3's explicit integrators (the default DOP853) at ODE_EXPLICIT_RATE_MAX
    with pytest.raises(ParameterError, match=rf"flow.u.* speed <= {limit} m/s with quadratic"):
        Scene(drag_model=2, flow_u=1e12, solver_method=method)
    # mid-run: the step is refused and changes nothing
    sim = Simulator(Scene(drag_model=2, solver_method=method))
    sim.advance(1e-3)
    before = sim.save()
    with pytest.raises(ParameterError,
                       match=r"flow.u = 1000000000000.0 is not allowed: \|flow.u\| <= "):
        sim.advance(1e-3, 1e12)
    assert sim.save() == before
    Scene(drag_model=1, flow_u=1e12, solver_method=1)  # linear drag: closed forms


def test_a_stiff_linear_drag_is_refused_for_method_3():
    with pytest.raises(ParameterError, match=r"B \* drag.v_lin / ice.M"):
        Scene(ice_M=1e-6, solver_method=3)
    Scene(ice_M=1e-6, solver_method=1)


def test_the_drag_rate_limit_through_the_fmu():
    logs: list[str] = []
    fmu = FmuModel(lambda status, text: logs.append(text))
    fmu.set("drag.model", 2)
    assert fmu.initialize()
    assert fmu.do_step(0.0, 1e-3)
    x = fmu.get("structure.x")
    fmu.set("flow.u", 1e12)
    assert not fmu.do_step(1e-3, 1e-3)  # fmi2Discard, nothing changed
    assert "flow.u = 1000000000000.0 is not allowed" in logs[-1] and "1/s" in logs[-1]
    assert fmu.get("structure.x") == x
    fmu.set("flow.u", 0.1)
    assert fmu.do_step(1e-3, 1e-3)


@pytest.mark.parametrize("method", [1, 3])
def test_the_drag_rate_limit_at_the_limit_runs(method):
    """Just inside the drag-rate limit of each method: method 3 (LSODA) at DRAG_RATE_MAX on
    2 B u / M; method 1 at TAYLOR_RATE_MAX on its sticking phase's 2 B u / (m + M), the lower
    of its two limits for this scene."""
    if method == 1:
        u = 0.99 * TAYLOR_RATE_MAX * (1600.0 + 1600.0) / (2.0 * 499.5)
    else:
        u = 0.99 * DRAG_RATE_MAX * 1600.0 / (2.0 * 499.5)
    sim = Simulator(Scene(drag_model=2, flow_u=u, solver_method=method, solver_ode_method=3))
    for _ in range(5):
        r = sim.advance(1e-3)
        assert math.isfinite(r.x) and r.gap >= 0.0 and r.impulse >= 0.0
