"""The exact method's flights at their hardest (solvers/exact/flight.py): exact tangent
ringing, a drifting ice at the lowest point of the structure's envelope, a heavy ice the flow
turns back next to a stiff structure's envelope: every impact found, no search that creeps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from iceimpact import Scene, Simulator
from iceimpact.limits import (
    TIME_RESOLUTION,
)
from iceimpact.solvers.base import GAP_ROUNDING
from iceimpact.solvers.exact import Flight, LinearStick
from scenes import ELASTIC_CHATTER
from work_counters import count_probes

# --- exact tangent ringing (method 1) -----------------------------------------------------------

#: omega_n = 4.1e7 rad/s, released from rest at -0.16 m, the ice at rest exactly at the lowest
#: point of the swing, no drag
TANGENT_OMEGA, TANGENT_X0 = 4.1e7, -0.16


def _tangent_ringing(u: float, v0: float = 0.0) -> Simulator:
    return Simulator(Scene(structure_m=1600.0, structure_k=1600.0 * TANGENT_OMEGA ** 2,
                           structure_c=0.0, structure_x0=TANGENT_X0, structure_v0=v0,
                           ice_M=1600.0, ice_Cd=0.0, ice_z0=TANGENT_X0, ice_v0=0.0, flow_u=u,
                           impact_e=1.0, solver_method=1))


@pytest.mark.parametrize("u", [0.0, 0.1])
def test_an_exact_tangent_ringing_is_no_impact(u):
    """The structure grazes the ice once a period (6.5e6 times a second) with no closing speed:
    the exact motion is x = x0 cos(omega_n t) with the ice at rest at x0 and never struck. The
    root search located a touch at the first graze to its time resolution and took the
    structure's speed there (0.33 m/s, curvature x resolution) for a closing speed, kicking the
    ice; each graze it met cost root-search work. The envelope now proves the whole future free
    of impacts at once: one search iteration for the run, whatever the number of grazes. Without
    drag the flow does not move the ice (u = 0.1: its speed bound is its own velocity, 0)."""
    sim = _tangent_ringing(u)
    k, m = sim.scene.structure_k, sim.scene.structure_m
    energy = 0.5 * k * TANGENT_X0 ** 2
    for _ in range(100):
        r = sim.advance(0.01)
        s = sim.solver.state
        assert s.x - s.z >= -GAP_ROUNDING and r.impulse == 0.0
        assert (s.z, s.w) == (TANGENT_X0, 0.0)
        # the closed form, written out (1 ulp of omega_n t = 4.1e7 rad is 7e-9 rad)
        assert abs(s.x - TANGENT_X0 * math.cos(TANGENT_OMEGA * sim.t)) <= 1e-8
        assert 0.5 * (k * s.x ** 2 + m * s.v ** 2) == pytest.approx(energy, rel=1e-9)
    assert sim.impact_count == 0
    assert sim.solver.seg.search.iterations <= 2
    # at the grazes themselves (t = 2 pi j / omega_n), to the rounding of the gap
    period = 2.0 * math.pi / TANGENT_OMEGA
    graze = _tangent_ringing(u)
    for _ in range(50):
        graze.advance(period)
        assert graze.solver.state.x - graze.solver.state.z >= -GAP_ROUNDING
    assert graze.impact_count == 0


@pytest.mark.parametrize("v0", [10.0, 100.0])
def test_a_graze_deeper_than_rounding_is_still_an_impact(v0):
    """The structure released upwards at v0 from the ice's position: its envelope reaches
    (v0 / omega_n)^2 / (2 |x0|) below the ice (1.9e-13 m and 1.9e-11 m), a real impact at the
    end of the first period with closing speed v0 (energy: the structure is back at x0), to the
    speed the search's time resolution gives (curvature omega_n^2 |x0| x 8.9e-16 s)."""
    sim = _tangent_ringing(0.0, v0)
    sim.advance(1e-6)
    assert sim.impact_count == 1
    hit = sim.impacts[0]
    # x0 cos(omega t) + (v0 / omega) sin(omega t) = x0 again at omega t = 2 pi - 2 atan(...)
    back = (2.0 * math.pi - 2.0 * math.atan(v0 / TANGENT_OMEGA / abs(TANGENT_X0))) / TANGENT_OMEGA
    assert abs(hit.t - back) <= 2.0 * TIME_RESOLUTION
    resolution = TANGENT_OMEGA ** 2 * abs(TANGENT_X0) * 2.0 * TIME_RESOLUTION
    assert abs(hit.w_minus - hit.v_minus - v0) <= resolution


#: the random search's scene (tools/random_search.py --method 1 --seed 12 --scales --flows): the
#: bodies together at -0.57 m/s, omega of the bodies together 3.9e7 rad/s, a linear drag b u of
#: 5.7e6 N (flow 6478 m/s); run at 0.37 s steps with the flow reversing at every step
RINGING_IN_CONTACT = dict(
    structure_m=3537.1073490753306, structure_c=0.0, structure_k=1.0599269884926448e+19,
    structure_x0=0.0, structure_v0=-0.5706191297623756, ice_M=3619.4971632535407,
    ice_A=1.282686929497336, ice_Cd=1.0689804569440564, ice_z0=0.0,
    ice_v0=-0.5706191297623756, impact_e=0.0, drag_model=1, drag_v_lin=1.282686929497336,
    flow_u=6478.176589776202, solver_method=1)


def test_bodies_ringing_stiffly_in_contact_stick_without_work_per_period():
    """After a chatter the bodies stick ringing with 3e-13 m (their contact force between 4.2e6
    and 7.2e6 N): the search for a separation took two Taylor steps per period (1.6e-7 s), over
    10 s of CPU for the first 0.37 s step. The oscillating part of the contact force is a free
    response, so its envelope proves the force compressive for the whole phase at once. The run
    with the flow reversing every step stays sound."""
    scene = Scene(**RINGING_IN_CONTACT)
    sim = Simulator(scene)
    sim.advance(0.01)
    seg = sim.solver.seg
    assert isinstance(seg, LinearStick) and seg.search.iterations <= 2
    sim.advance(0.36)
    u = scene.flow_u
    for i in range(1, 9):
        r = sim.advance(0.37, u if i % 2 == 0 else -u)
        s = sim.solver.state
        assert all(map(math.isfinite, (r.x, r.v, r.z, r.w, r.impulse)))
        assert s.x - s.z >= -GAP_ROUNDING
        momentum = (scene.structure_m + scene.ice_M) * (abs(s.v) + abs(s.w) + u)
        assert r.impulse >= -1e-9 * momentum
    assert sim.solver.seg.search.iterations < 100


@pytest.mark.parametrize("fraction", [0.5, 0.99, 1.01, 2.0])
def test_the_sticking_clearance_agrees_with_the_written_out_contact_force(fraction):
    """The random search's sticking pair ringing about its equilibrium b u / k with an amplitude
    of ``fraction`` times the one at which its contact force lam = b (u - v) - M x'' first
    touches zero: below it the clearance proves the force compressive for ever (checked on 50
    periods of the damped closed form written out here), above it proves nothing and the
    search finds the separation where the written-out force crosses zero."""
    scene, x_eq, v0, lam, period = _ringing_pair(fraction, RINGING_IN_CONTACT)  # sigma ~ 0.06 1/s
    solver = Simulator(scene).solver
    u = scene.flow_u
    t = np.linspace(0.0, 50.0 * period, 200_001)
    values = lam(t)
    seg = LinearStick(solver.context, 0.0, x_eq, v0, u)
    root = seg.next_event(50.0 * period)
    if fraction < 1.0:
        assert seg.clearance(0.0) == math.inf and root is None
        assert values.min() > 0.0 and seg.search.iterations == 1
    else:
        assert seg.clearance(0.0) == 0.0
        i = int(np.argmax(values < 0.0))
        exact = brentq(lam, t[i - 1], t[i], xtol=1e-30, rtol=1e-15)
        assert abs(root - exact) <= 2.0 * TIME_RESOLUTION


#: the stiff pair ringing in contact with its ice 82 mg heavier and a smaller floe (the random
#: search's replay; docs/explanation/robustness/sticking.md#stick-part-cycle): after its
#: chatter the pair rings in contact
#: 23 N beyond the drag force b u = 2.1e4 N, and the exact motion parts for 5.8e-9 s a period
#: (a gap of ~2e-19 m), re-contacting at a closing speed of rounding
STICK_PART_CYCLE = dict(
    structure_m=3537.1073490753306, structure_c=0.0, structure_k=1.0599269884926448e+19,
    structure_x0=0.0, structure_v0=-0.5706191297623756, ice_M=3537.1074305202383,
    ice_A=0.004848231011100569, ice_Cd=1.0689804569440564, ice_z0=0.0,
    ice_v0=-0.5706191297623756, fluid_rho=999.0, impact_e=0.0, drag_model=1,
    drag_v_lin=1.282686929497336, flow_u=6478.176589776202, solver_method=1)

#: events (impacts, separations, touches) a 0.37 s step of the scenes below may take; without
#: the tension rule of the stick-part cycle the scene takes 84,000 in 20 s of CPU without ending
#: the first step
_MAX_EVENTS_PER_STEP = 2000


def _ulps(value: float, n: int) -> float:
    for _ in range(abs(n)):
        value = math.nextafter(value, math.inf if n > 0 else 0.0)
    return value


@pytest.mark.parametrize("change", [
    {}, {"flow_u": 1}, {"flow_u": 2}, {"ice_M": -1}, {"flow_u": -1}, {"ice_M": 1}])
def test_a_stiff_pair_ringing_barely_beyond_its_drag_is_held_through_its_tension(change):
    """The stiff pair's contact force dips 23 N below zero for 2.4e-9 s a period (1.6e-7 s):
    the exact motion parts there with a gap of ~2e-19 m (GAP_ROUNDING is 1e-12 m) and
    re-contacts at a closing speed of rounding, merged; the step never ended. Such a tension is
    now held (LinearStick._tension_unresolvable): 3 s at 0.37 s steps, the flow reversing at
    every step, in bounded work, the gap never negative, every step impulse >= -1e-9 of the
    momentum scale and equal to the ice's momentum balance. The scene's one-ulp neighbours
    (flow.u one or two ulps either way, ice.M one ulp either way) alike."""
    params = dict(STICK_PART_CYCLE)
    for name, n in change.items():
        params[name] = _ulps(params[name], n)
    scene = Scene(**params)
    sim = Simulator(scene)
    solver = sim.solver
    event = solver.at_event
    count = [0]

    def counted(*args):
        count[0] += 1
        if count[0] > _MAX_EVENTS_PER_STEP:
            raise AssertionError(f"over {_MAX_EVENTS_PER_STEP} events in a step")
        return event(*args)

    solver.at_event = counted
    b, M, m = scene.drag_b, scene.ice_M, scene.structure_m
    u0 = scene.flow_u
    for i in range(9):
        h = min(0.37, 3.0 - sim.t)
        u = u0 if i % 2 == 0 else -u0
        count[0] = 0
        before = solver.state
        r = sim.advance(h, u)
        s = solver.state
        assert s.x - s.z >= 0.0
        momentum = (m + M) * (abs(s.v) + abs(s.w) + abs(u)) + scene.structure_k * abs(s.x) * h
        assert r.impulse >= -1e-9 * momentum
        # the ice's momentum balance over the step: M dw = b (u h - dz) - impulse
        balance = b * (u * h - (s.z - before.z)) - M * (s.w - before.w)
        terms = b * (abs(u) * h + abs(s.z - before.z)) + M * (abs(s.w) + abs(before.w))
        assert abs(r.impulse - balance) <= 1e-12 * terms
        assert solver.seg.search.iterations < 100
    assert sim.t == pytest.approx(3.0)


def _ringing_pair(fraction: float, fields: dict | None = None):
    """A pair ringing in contact (``fields``, STICK_PART_CYCLE by default) together at its
    equilibrium b u / k, moving at ``fraction`` times the speed at which its contact force
    first touches zero; the written-out force lam(t) and its period. lam = b u - b v - M a, with
    a = -omega2 y - 2 sigma v: its oscillating part has the amplitude
    A sqrt((M omega2)^2 + (b omega)^2) for y = A sin(omega t)."""
    scene = Scene(**(STICK_PART_CYCLE if fields is None else fields))
    b, u, M, k = scene.drag_b, scene.flow_u, scene.ice_M, scene.structure_k
    total, damping = scene.structure_m + M, scene.structure_c + b
    sigma, omega2 = damping / (2.0 * total), k / total
    wd = math.sqrt(omega2 - sigma ** 2)
    touching = b * u / math.hypot(M * omega2, b * math.sqrt(omega2))
    v0 = -fraction * touching * math.sqrt(omega2)

    def lam(t):
        decay, cos, sin = np.exp(-sigma * t), np.cos(wd * t), np.sin(wd * t)
        y = decay * v0 / wd * sin
        v = decay * (v0 * cos - sigma * v0 / wd * sin)
        return b * (u - v) - M * (-(damping * v + k * y) / total)

    return scene, b * u / k, v0, lam, 2.0 * math.pi / wd


@pytest.mark.parametrize("excess", [1e-3, 3e-2, 0.1])
def test_only_a_tension_too_slight_to_part_the_pair_resolvably_is_held(excess):
    """The stick-part cycle's threshold on the stiff pair (b u = 2.1e4 N, omega 3.9e7 rad/s):
    ringing 1e-3
    beyond the amplitude at which its contact force touches zero, the force dips 21 N below
    zero for 2.3e-9 s a period (checked on 50 written-out periods): a relative speed of
    2.8e-11 m/s, far below the rounding of the speeds (6.5e-9 m/s), so the phase is proven at
    once and its step impulses stay >= -1e-12 of the momentum scale. At 3e-2 and 0.1 beyond
    (relative speeds of 4.6e-9 and 2.7e-8 m/s: the latter resolvable) the separation search
    runs: 3e-2 is held, 0.1 parts where the written-out force crosses zero."""
    scene, y_rest, v0, lam, period = _ringing_pair(1.0 + excess)
    solver = Simulator(scene).solver
    seg = LinearStick(solver.context, 0.0, y_rest, v0, scene.flow_u)
    t = np.linspace(0.0, 50.0 * period, 400_001)
    values = lam(t)
    assert values.min() < 0.0  # the exact force does turn tensile
    root = seg.next_event(50.0 * period)
    mu = scene.structure_m * scene.ice_M / (scene.structure_m + scene.ice_M)
    depth = -values.min()
    stretch = np.count_nonzero(values[: len(t) // 50] < 0.0) * (t[1] - t[0])
    if excess < 0.05:
        assert root is None and seg.search.iterations == 1
        assert depth * stretch / mu <= 1e-12 * scene.flow_u
        momentum = (scene.structure_m + scene.ice_M) * scene.flow_u
        for a in t[:: 4_000][:-1]:  # steps of half a period
            assert seg.impulse(a, a + 0.5 * period) >= -1e-12 * momentum
    else:
        assert seg.clearance(0.0) == 0.0
        i = int(np.argmax(values < 0.0))
        exact = brentq(lam, t[i - 1], t[i], xtol=1e-30, rtol=1e-15)
        assert abs(root - exact) <= 2.0 * TIME_RESOLUTION


def test_a_separation_opening_a_resolvable_gap_still_flies():
    """The stiff pair ringing a thousand times beyond the amplitude at which its contact force
    touches zero: its tension is not held, the bodies part and fly, and the gap opens beyond
    GAP_ROUNDING (to 2.4e-10 m)."""
    scene, y_rest, v0, lam, period = _ringing_pair(1e3)
    scene = Scene(**dict(STICK_PART_CYCLE, structure_x0=y_rest, ice_z0=y_rest,
                         structure_v0=v0, ice_v0=v0))
    sim = Simulator(scene)
    widest, flew = 0.0, False
    for _ in range(400):
        sim.advance(period / 40.0)
        s = sim.solver.state
        assert s.x - s.z >= 0.0
        widest = max(widest, s.x - s.z)
        flew = flew or not sim.solver.sticking
    assert flew and widest > GAP_ROUNDING


@pytest.mark.parametrize("excess", [1e-4, 1e-3])
def test_a_tension_within_speed_rounding_that_opens_a_resolvable_gap_still_parts(excess):
    """A slow pair (omega 1 rad/s) under a faint drag (b u = 0.064 N) ringing 1e-4 and 1e-3
    beyond the energy radius at which its contact force touches zero: the tension gives a
    relative speed within the rounding of the speeds (1e-10 and 3.3e-9 m/s, below
    6.5e-9 m/s), but over its stretch (0.03 and 0.09 s) it opens a gap beyond GAP_ROUNDING
    (1.6e-12 and 1.6e-10 m), so it is not held: the bodies part where the force crosses zero
    and fly for about twice the tensile stretch."""
    params = dict(STICK_PART_CYCLE, structure_k=7074.0, ice_A=1.45e-8)
    scene = Scene(**params)
    solver = Simulator(scene).solver
    b, u, k = scene.drag_b, scene.flow_u, scene.structure_k
    rest = b * u / k
    seg = LinearStick(solver.context, 0.0, rest, -1.0, u)
    _, _, q, rate, _ = seg._force(0.0)
    v0 = -(1.0 + excess) * seg._push / seg.osc.amplitude_bound(q, rate)  # q is linear in v0
    seg = LinearStick(solver.context, 0.0, rest, v0, u)
    assert seg.clearance(0.0) == 0.0
    period = 2.0 * math.pi / seg.osc.omega
    root = seg.next_event(period)
    assert root is not None and seg.force(root) <= 1e-12 * seg._push
    sim = Simulator(Scene(**dict(params, structure_x0=rest, ice_z0=rest, structure_v0=v0,
                                 ice_v0=v0)))
    sim.advance(root * (1.0 - 1e-9))
    stretch = 2.0 * math.sqrt(2.0 * excess) / seg.osc.omega  # the tension's duration, ~
    widest, flying = 0.0, 0
    for _ in range(400):
        sim.advance(stretch / 100.0)
        s = sim.solver.state
        assert s.x - s.z >= 0.0
        widest = max(widest, s.x - s.z)
        flying += not sim.solver.sticking
    assert widest > GAP_ROUNDING and 150 <= flying <= 250


# --- a drifting ice at the lowest point of the envelope (method 1) -----------------------------

#: pi to 60 digits, for the exact impact times below
_PI = "3.14159265358979323846264338327950288419716939937510582097494459"

#: (flow / drag, ice velocity (m/s), ice's distance below the envelope's lowest point (m)):
#: coasting without drag, and at rest in a weak linear drag that pushes it downstream
DRIFTS = {
    "coasting at 1e-9 m/s": (dict(ice_Cd=0.0, flow_u=0.0), 1e-9, 5e-10),
    "coasting at 1e-13 m/s": (dict(ice_Cd=0.0, flow_u=0.0), 1e-13, 5e-14),
    "coasting at 1e-15 m/s": (dict(ice_Cd=0.0, flow_u=0.0), 1e-15, 5e-16),
    "at rest, linear drag, u = 1e-6 m/s": (dict(ice_Cd=1.0, drag_model=1, flow_u=1e-6), 0.0,
                                           1e-15),
    # turned back by the flow after 2 |w| / (kappa u) = 0.64 s (4.2e6 periods at 4.1e7 rad/s)
    "moving upstream at 1e-8 m/s, linear drag, u = 1e-6 m/s": (
        dict(ice_Cd=1.0, drag_model=1, flow_u=1e-6), -1e-8, 1e-15),
}


def _drifting(omega: float, flow: dict, w: float, below: float, swinging: bool) -> Simulator:
    """An undamped structure (m = M = 1600 kg, e = 1) swinging down to -0.16 m, released from
    rest there or (``swinging``) from its rest point at speed -0.16 omega_n; the ice ``below``
    m under the lowest point of its swing with velocity w."""
    start = dict(structure_x0=0.0, structure_v0=TANGENT_X0 * omega) if swinging else dict(
        structure_x0=TANGENT_X0, structure_v0=0.0)
    return Simulator(Scene(**{**dict(structure_m=1600.0, structure_k=1600.0 * omega ** 2,
                                     structure_c=0.0, **start, ice_M=1600.0,
                                     ice_z0=TANGENT_X0 - below, ice_v0=w, impact_e=1.0,
                                     solver_method=1), **flow}))


def _exact_first_impact(scene: Scene) -> tuple[float, float, float]:
    """Time (s), closing speed (m/s) and the ice's velocity (m/s) of the first impact, in
    60-digit decimal arithmetic from the scene's own numbers. The structure, released from rest
    at x0 or from 0 at speed v0 < 0, is at its lowest point L (x0, or v0 / omega_n) at every
    t_j = t_0 + j T (t_0 = 0 or T / 4); the ice (z0 + w0 t, or under the linear drag
    z0 + u t + (w0 - u)(1 - e^{-kappa t}) / kappa) moves downstream only, so the first trough
    it is past (z(t_j) > L, found by bisection over j) ends the first period the gap closes in
    (the earlier trough's dip, below (dz/dt)^2 / (2 omega_n^2 |L|) = 1e-33 m, is left out).
    Near it the gap is
    ``-d - w s + |L| omega_n^2 s^2 / 2`` (d = z(t_j) - L, w = dz/dt there; the next terms,
    (omega_n s)^4 |L| and z'' s^2, are below 1e-40 m), so it closes at its root s < 0, with
    closing speed sqrt(w^2 + 2 |L| omega_n^2 d)."""
    from decimal import Decimal, localcontext

    with localcontext() as ctx:
        ctx.prec = 60
        z0, w0 = Decimal(scene.ice_z0), Decimal(scene.ice_v0)
        omega = (Decimal(scene.structure_k) / Decimal(scene.structure_m)).sqrt()
        period = 2 * Decimal(_PI) / omega
        if scene.structure_v0 == 0.0:
            lowest, first = Decimal(scene.structure_x0), Decimal(0)
        else:
            assert scene.structure_x0 == 0.0 and scene.structure_v0 < 0.0
            lowest, first = Decimal(scene.structure_v0) / omega, period / 4
        if scene.ice_Cd == 0.0:
            def ice(t):
                return z0 + w0 * t, w0
        else:
            kappa, u = Decimal(scene.drag_b) / Decimal(scene.ice_M), Decimal(scene.flow_u)

            def ice(t):
                decay = (-kappa * t).exp()
                return z0 + u * t + (w0 - u) * (1 - decay) / kappa, u + (w0 - u) * decay
        lo, hi = -1, 1
        while ice(first + hi * period)[0] <= lowest:
            lo, hi = hi, 2 * hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (lo, mid) if ice(first + mid * period)[0] > lowest else (mid, hi)
        t_j = first + hi * period
        z, w = ice(t_j)
        depth, curvature = z - lowest, -lowest * omega * omega
        closing = (w * w + 2 * curvature * depth).sqrt()
        return float(t_j + (w - closing) / curvature), float(closing), float(w)


@pytest.mark.parametrize("swinging", [False, True])
@pytest.mark.parametrize("omega", [4.1e5, 4.1e7])
@pytest.mark.parametrize("name", list(DRIFTS))
def test_a_drifting_ice_meets_the_envelope_exactly_in_bounded_work(name, omega, swinging,
                                                                  monkeypatch):
    """The ice drifting downstream into the lowest point of an undamped structure's swing: the
    gap's dip deepens by the ice's drift per period, w T (1.5e-16 m to 1.5e-22 m), so its
    first impact comes after up to 1e7 periods at the bottom of the envelope. The root search
    walked those period by period (6.6e6 periods a second at omega_n = 4.1e7 rad/s, one
    simulated second of the ice at 1e-15 m/s did not finish in 5 s of CPU), and took a graze
    within its time resolution for a touch, then the structure's speed there for a closing
    speed: impacts up to 1.9e4 periods early, where the gap was still open by 2e-16 m. The
    periods the ice has not yet reached are now proven free by bisection over the periods
    (``Flight._drift_clearance``): a few hundred evaluations of the closed forms, whatever
    omega_n and the drift. The impact is the exact one (60-digit decimal arithmetic, above),
    to the search's time resolution."""
    flow, w, below = DRIFTS[name]
    sim = _drifting(omega, flow, w, below, swinging)
    calls = count_probes(monkeypatch, Flight, 10_000, "period by period")
    while sim.impact_count == 0:
        sim.advance(0.01)
        assert sim.t < 2.0
    assert calls[0] <= 300
    hit = sim.impacts[0]
    t_exact, closing, drift = _exact_first_impact(sim.scene)
    resolution = 8.9e-16 * (1.0 + t_exact)  # the search's time resolution there
    # and the rounding of the structure's lowest point: exact released from rest (x0 + x0 (C - 1)
    # at C = -1), 1.7e-17 m off through its rest point (v0 S / omega_n), 2.8e-17 m (one ulp of
    # 0.16) per 1e-15 m/s of drift is 0.028 s
    rounding = 0.0 if swinging is False else math.ulp(TANGENT_X0)
    assert abs(hit.t - t_exact) <= 2.0 * resolution + rounding / drift
    # the closing speed to what those give: the structure's speed changes by its curvature
    # omega_n^2 |x0| times the time (0.48 m/s over 1.8e-15 s at omega_n = 4.1e7), and a dip
    # deeper by the rounding closes at sqrt(2 curvature rounding)
    curvature = omega ** 2 * abs(TANGENT_X0)
    assert abs((hit.w_minus - hit.v_minus) - closing) <= (curvature * 2.0 * resolution
                                                          + math.sqrt(2.0 * curvature * rounding))


def test_an_ice_stopping_short_of_the_envelope_is_proven_clear_at_once(monkeypatch):
    """The ice coasting into the envelope's lowest point at 1e-12 m/s under a linear drag and no
    flow: it stops 5e-16 m short (z0 + w0 / kappa), within the rounding the envelope's margin
    allows, so no impact ever (exact: the ice never passes the structure's lowest point, which
    the structure released from rest there reaches exactly). The root search walked the
    grazes period by period, forever; the period search now proves the future up to
    omega_n t = 2^46 (1.7e6 s) free at once."""
    scene = Scene(structure_m=1600.0, structure_k=1600.0 * TANGENT_OMEGA ** 2,
                  structure_c=0.0, structure_x0=TANGENT_X0, structure_v0=0.0, ice_M=1600.0,
                  ice_Cd=1.0, drag_model=1, flow_u=0.0, ice_z0=TANGENT_X0 - 1e-15,
                  impact_e=1.0, solver_method=1)
    kappa = scene.drag_b / scene.ice_M
    sim = Simulator(Scene(**{**scene.__dict__, "ice_v0": 5e-16 * kappa}))
    from decimal import Decimal
    stop = Decimal(sim.scene.ice_z0) + Decimal(sim.scene.ice_v0) / (
        Decimal(sim.scene.drag_b) / Decimal(sim.scene.ice_M))
    assert stop < Decimal(TANGENT_X0)
    calls = count_probes(monkeypatch, Flight, 10_000, "period by period")
    for _ in range(100):
        r = sim.advance(0.01)
        assert r.gap >= 0.0 and r.impulse == 0.0
    assert sim.impact_count == 0
    assert calls[0] <= 300
    assert sim.solver.seg.search.a >= 1e4  # its frontier, s


# --- a heavy ice the flow turns back, next to a stiff structure's envelope (method 1) ----------

#: The random search's TIMEOUT (method 1, seed 12): a stiff undamped pair (omega_n 5.6e7 rad/s)
#: released from rest at its lowest point -0.57 m, where the heavy ice (M = 3.4e11 kg, linear
#: drag) starts at rest, the flow of 3340 m/s reversed at every 0.37 s step.
HEAVY_ICE = dict(structure_m=1e9, structure_c=0.0, structure_k=3.11296231733161e+24,
                 structure_x0=-0.5663221133377271, ice_M=336172133760.24585,
                 ice_Cd=0.9616590278639208, ice_z0=-0.5663221133377271, ice_v0=0.0,
                 drag_model=1, drag_v_lin=1.0, flow_u=-3339.8447649555183, solver_method=1)


@pytest.mark.parametrize("e", [0.0, 1.0])
def test_a_heavy_ice_the_flow_turns_back_is_proven_clear_of_a_stiff_envelope(e, monkeypatch):
    """The first step's flow carries the ice upstream (to -1.8e-6 m/s, 3e-7 m below the
    structure's lowest point), the second turns it back: the ice's downstream speed bound is
    then the flow's 3340 m/s, and the envelope's margin over it (``Flight.clearance``) proved
    1e-10 s at a time, a thousandth of a period, so the root search walked the 2e7 periods of
    the step (no 0.37 s step in 10 s of CPU). The ice's acceleration bound (4.8e-6 m/s^2) now
    proves the whole step at once. Exact answer: the ice's velocity is monotone within each
    step (it relaxes towards +-u), so the ice is furthest downstream at a step's start or end,
    and every step ends with it upstream of z0, the structure's lowest point: no impact, the
    structure rings freely (x0 cos omega_n t) and the gap stays >= 0."""
    scene = Scene(**HEAVY_ICE, impact_e=e)
    sim = Simulator(scene)
    calls = count_probes(monkeypatch, Flight, 10_000, "period by period")
    omega = math.sqrt(scene.structure_k / scene.structure_m)
    x0 = scene.structure_x0
    for i in range(8):  # 2.96 s
        r = sim.advance(0.37, scene.flow_u if i % 2 == 0 else -scene.flow_u)
        assert r.z < scene.ice_z0  # the exact answer's premise (above)
        assert r.gap >= 0.0 and r.impulse == 0.0 and sim.impact_count == 0
        # free ringing, to the rounding of the phase omega_n t (2e7 rad per step)
        phase_rounding = 4.0 * omega * r.t * 2.0 ** -53 * abs(x0)
        assert abs(r.x - x0 * math.cos(omega * r.t)) <= 2.0 * phase_rounding
        assert abs(r.v + x0 * omega * math.sin(omega * r.t)) <= 2.0 * omega * phase_rounding
    assert calls[0] <= 100  # a few probes a step, however many periods


def test_the_search_tells_a_run_busy_with_impacts_from_a_stall():
    """A run out of CPU time counts as busy, not as a TIMEOUT fault, only if its impacts keep
    within one per chatter time and it spent at most IMPACT_WORK s of CPU per impact, over the
    whole run and over its second half (a run stalled after many quick impacts is a fault)."""
    from iceimpact.solvers.contact_rules import chatter_time
    from random_search import IMPACT_WORK, busy_with_impacts

    scene = Scene(**ELASTIC_CHATTER)
    t = 0.5
    # even: the second half has cap / 2 of them
    cap = 2 * int(t / chatter_time(1e4, scene.solver_chatter_fraction) / 2)
    work, half = IMPACT_WORK * cap, cap // 2
    assert busy_with_impacts(scene, t, cap, work, half, work / 2)
    assert not busy_with_impacts(scene, t, 2 * cap + 2, work, half, work / 2)  # too many
    assert not busy_with_impacts(scene, t, cap, 2 * work, half, work / 2)  # too slow
    assert not busy_with_impacts(scene, t, cap, work, 0, work / 2)  # stalled late
    assert not busy_with_impacts(scene, t, cap, work, 10, work / 2)  # nearly stalled late
    assert not busy_with_impacts(scene, 0.0, 0, 0.0, 0, 0.0)


@pytest.mark.parametrize("method", [1, 2])
def test_a_run_following_zeno_sequences_is_busy_up_to_their_budget(method):
    """With e < 1 method 1 follows each Zeno sequence below the chatter time, up to ZENO_BUDGET
    bounces: a run of that many impacts per chatter time is busy, one beyond them is not;
    method 2 closes its sequences at the chatter time (one an interval)."""
    from iceimpact.solvers.contact_rules import ZENO_BUDGET, chatter_time
    from random_search import IMPACT_WORK, busy_with_impacts

    scene = Scene(**{**ELASTIC_CHATTER, "impact_e": 0.9, "solver_method": method})
    t = 0.5
    intervals = int(t / chatter_time(scene.omega_n, scene.solver_chatter_fraction)) + 1
    followed = intervals * (1 + ZENO_BUDGET) if method == 1 else intervals
    for impacts, busy in ((followed, True), (followed + intervals + 2, False)):
        work = IMPACT_WORK * impacts
        assert busy_with_impacts(scene, t, impacts, work, impacts // 2, work / 2) is busy


def test_a_slow_mode_far_below_the_fast_one_still_parts_the_bodies():
    """Method 1, linear drag, well over-damped sticking (the search with seed 48): a plastic
    impact at 0.17 m/s sticks a 0.8 mg floe to a 0.45 g structure (omega_n 1e-3 rad/s) under
    b = 217 kg/s, no flow. The fast mode (4.8e5 1/s) starts at 36 N of contact force; the
    slow one, the spring pulling the pair back against the floe's drag, is a tension of
    -1.6e-16 N, which the modes of the anchor's (q0, q0') gave as exactly 0: the bodies were
    never parted and every 0.1 ms step had an impulse of -1.6e-20 N.s. The force's modes now
    come from the deviation's (``Qk = -sk (b + M sk) Yk``): the bodies part where the two
    modes balance, at the time a 50-digit closed form gives, and no step pulls."""
    from decimal import Decimal, localcontext

    scene = Scene(structure_m=0.00045338246088430967, structure_c=0.0,
                  structure_k=4.533824608843097e-10, structure_x0=0.0,
                  structure_v0=-0.1663099506821799, ice_M=7.895833311786706e-07, ice_A=1.0,
                  ice_Cd=0.7718513369004822, ice_z0=0.0, ice_v0=7.589709039162833e-05,
                  impact_e=0.0, drag_model=1, drag_v_lin=0.5630380684168985, flow_u=0.0,
                  solver_method=1)
    sim = Simulator(scene)
    r = sim.advance(1e-4, 0.0)
    assert not r.sticking and sim.impact_count == 1
    impact = sim.impacts[0]
    parted = sim.solver.seg.t0  # the flight from the separation
    with localcontext() as ctx:
        ctx.prec = 50
        mass = Decimal(scene.structure_m) + Decimal(scene.ice_M)
        b = Decimal(scene.drag_b)
        k, M = Decimal(scene.structure_k), Decimal(scene.ice_M)
        root = (b * b - 4 * mass * k).sqrt()
        s1, s2 = (-b + root) / (2 * mass), (-b - root) / (2 * mass)
        v0 = Decimal(impact.v_plus)  # from x = 0, no flow: y0 = 0
        y1, y2 = v0 / (s1 - s2), -v0 / (s1 - s2)
        q1, q2 = -s1 * (b + M * s1) * y1, -s2 * (b + M * s2) * y2
        assert q1 < 0 < q2  # the slow mode pulls, the fast one pushes
        exact = float((-q2 / q1).ln() / (s1 - s2))
    assert parted == pytest.approx(exact, rel=1e-9)
    for _ in range(20):
        r = sim.advance(1e-4, 0.0)
        assert r.impulse >= 0.0 and not r.sticking
        assert sim.solver.state.x >= sim.solver.state.z


def test_the_search_tells_a_run_busy_integrating_at_its_rate_from_a_stall():
    """Method 3 at its explicit rate limit costs up to ~10 s of CPU per simulated second by its
    rate rule (the seed-53 search's damped 26 g structure, c / m = 2.7e5 1/s: 3.8 rate
    evaluations per simulated second, 9.9 s for its second). A run out of CPU time counts as
    busy, not as a TIMEOUT fault, while its evaluations keep within ODE_WORK of them per unit
    rate and simulated second (plus ODE_RESTART_WORK per step and ODE_WORK_FLOOR); beyond,
    and for the other methods or an implicit integrator, it is a fault."""
    from iceimpact.limits import integrated_rate
    from random_search import ODE_RESTART_WORK, ODE_WORK, ODE_WORK_FLOOR, busy_integrating

    scene = Scene(structure_m=0.026356702073031105, structure_c=7106.487429949025,
                  structure_k=2082983.3397196622, ice_M=8.48189216315647e-06, ice_Cd=0.0,
                  ice_z0=-0.04, impact_e=0.0, solver_method=3)
    rate = integrated_rate(scene, 0.1)
    assert rate == pytest.approx(2.7e5, rel=0.01)
    allowed = ODE_WORK * rate * 0.5 + ODE_RESTART_WORK * 50 + ODE_WORK_FLOOR
    assert busy_integrating(scene, 0.1, 0.5, int(allowed), 50)
    assert not busy_integrating(scene, 0.1, 0.5, int(allowed) + 1, 50)
    assert not busy_integrating(scene, 0.1, 0.0, 0, 0)
    assert not busy_integrating(scene.replace(solver_ode_method=3), 0.1, 0.5, 10, 50)  # LSODA
    assert not busy_integrating(scene.replace(solver_method=1), 0.1, 0.5, 10, 50)


def test_method_3_sees_a_meeting_hidden_inside_one_integrator_step():
    """A meeting hidden inside one integrator step (the search with seed 57): a light ice (0.59 kg,
    quadratic drag) following a slow
    structure, the flow reversed by random signs at 1 ms steps. DOP853 crossed a 3.5 ms dip of
    the gap below zero in one 4 ms step, whose ends both had an open gap: solve_ivp tests the
    event's sign at step ends only, so the ice went 2.5e-7 m through the structure with no
    impact. The dip's lowest point is where the gap's rate turns from closing to opening inside
    a step; the meeting is now found there on the dense output, and the impacts are those of
    the exact method, which shares no integration with it (its own no-miss root search)."""
    case = {"scene": dict(structure_m=0.5900798482397783, structure_c=8.186006944808163e-39,
                          structure_k=0.20546239680237188, structure_x0=-0.01,
                          structure_v0=-0.6095437618432101, ice_M=0.5902157347899184,
                          ice_A=0.5900798482397783, ice_Cd=0.1500251476655752, ice_z0=-0.01,
                          ice_v0=0.0, impact_e=0.02438189881828224, drag_model=2,
                          drag_v_lin=0.01, flow_u=0.0, solver_method=3),
            "h": 0.001, "flow": "random signs",
            "signs": [False, False, False, True, False, False, False, False, False]}
    from random_search import flow_at, replay

    outcome = replay(case)
    assert outcome.fault is None and outcome.min_gap >= 0.0
    runs = {}
    for method in (1, 3):
        sim = Simulator(Scene(**{**case["scene"], "solver_method": method}))
        k, lowest = 0, math.inf
        while sim.t < 0.8 - 1e-12:
            sim.advance(case["h"], flow_at(case["flow"], k, 0.1, case["signs"]))
            k += 1
            lowest = min(lowest, sim.solver.state.gap)
        # (the impacts both resolve: the exact method follows each Zeno sequence of this
        # e = 0.024 a few bounces further, closing speeds 1e-5 to 1e-8 m/s, which method 3,
        # whose bounces are no higher than its positions' noise, closes at their end)
        runs[method] = ([i.t for i in sim.impacts if i.approach_speed > 1e-4], lowest)
    exact, ode = runs[1][0], runs[3][0]
    assert len(ode) == len(exact) == 57
    assert max(abs(a - b) for a, b in zip(exact, ode, strict=True)) < 1e-6
    assert 0.7903 < ode[-2] < 0.7904  # the meeting inside the step [0.790, 0.794]
    assert runs[3][1] >= -1e-10


def test_method_3_sees_a_tensile_moment_hidden_inside_one_integrator_step():
    """A meeting hidden inside one integrator step, sticking: the seed-49 scene at omega_n 1.7e3
    rad/s (k / 1e8), a plastic ice
    stuck on an undamped structure and ringing just beyond what its drag holds. Its contact
    force turns tensile for a short moment each period, shorter than DOP853's steps: tested at
    step ends only, the bodies were held through it (a pull) and method 3 made 10, 4 and 1
    impacts in the windows where the exact method makes 24, 23 and 7. The contact force's
    lowest point inside a step, where its rate (``Together.contact_force_rate``) turns from
    negative to positive, is now checked: every 0.1 s window has the exact method's impacts,
    and the ringing the same amplitude, to 1e-3 of the drag's threshold."""
    from scenes import SEED_49

    windows = {}
    for method in (1, 3):
        scene = Scene(**{**SEED_49, "structure_k": SEED_49["structure_k"] / 1e8,
                         "solver_method": method})
        sim = Simulator(scene)
        counts, states = [], []
        for _ in range(6):
            before = sim.impact_count
            r = sim.advance(0.1, 0.1)
            assert r.impulse >= 0.0
            counts.append(sim.impact_count - before)
            states.append(sim.solver.state)
        windows[method] = counts, states
    assert windows[3][0] == windows[1][0] == [23, 23, 24, 23, 7, 0]
    # the pair's largest ringing its drag holds, x_eq (m + M) / M with x_eq = b u / k (m)
    scale = (scene.drag_b * 0.1 / scene.structure_k
             * (scene.structure_m + scene.ice_M) / scene.ice_M)
    for exact, ode in zip(windows[1][1], windows[3][1], strict=True):
        assert abs(exact.x - ode.x) < 1e-3 * scale


@pytest.mark.parametrize("drag_model", [1, 2], ids=["linear", "quadratic"])
@pytest.mark.parametrize("morison", [False, True], ids=["plain", "morison"])
def test_the_contact_force_rate_is_the_derivative_of_the_contact_force(drag_model, morison):
    """``Together.contact_force_rate`` (the look inside method 3's sticking steps for a hidden
    tensile moment) against
    a central difference of ``contact_force`` along the sticking motion, for both drag laws,
    with and without the Morison drag on the structure; arrays element by element."""
    from iceimpact.solvers.contact_rules import make_together
    from iceimpact.solvers.ode import OdeSolver

    extra = {"structure_Cd": 1.0, "structure_A": 2.0} if morison else {}
    scene = Scene(drag_model=drag_model, solver_method=3, **extra)
    solver = OdeSolver(scene)
    together = make_together(solver.m, solver.c, solver.k, solver.M, solver.drag, 0.3,
                             inertia_from_net=True, structure_drag=solver.structure_drag)
    states = np.array([[0.01, -0.02, 0.0], [-0.003, 0.4, 1.0], [0.0, 0.3, 0.0]]).T
    rates = together.contact_force_rate(states)
    for k in range(states.shape[1]):
        y = states[:, k]
        dy = np.array(together(0.0, y))
        delta = 1e-6
        numeric = (together.contact_force(y + delta * dy)
                   - together.contact_force(y - delta * dy)) / (2 * delta)
        assert rates[k] == pytest.approx(numeric, rel=1e-6, abs=1e-9)
        assert together.contact_force_rate(y) == pytest.approx(rates[k], rel=1e-15)


@pytest.mark.parametrize("fields", [
    {"structure_Cd": 1.0, "structure_A": 2.0, "drag_model": 2, "ice_A": 2.0},
    {"structure_Ca": 1.0, "structure_V": 0.5, "structure_Cd": 1.2, "structure_A": 1.0,
     "drag_model": 2, "ice_A": 2.0, "impact_e": 0.5},
])
def test_a_sampled_flight_in_taylor_steps_is_the_stepped_one(fields):
    """A flight under the quadratic Morison drag (DraggedFlight: the structure in Taylor steps)
    is sampled by its steps' polynomials at all its samples at once (states_at): the states
    stepping to each sample gives, to the bit, the same impacts, and the impulses to the
    rounding of their sums."""
    from iceimpact import run
    scene = Scene(**fields)
    sim = Simulator(scene)
    assert type(sim.solver.seg).__name__ == "DraggedFlight"
    result = run(scene, 20.0, dt=1e-2)
    reports = [sim.advance_to(t) for t in result.t[1:].tolist()]
    for name in ("x", "v", "z", "w"):
        assert getattr(result, name)[1:].tolist() == [getattr(r, name) for r in reports], name
    assert result.sticking[1:].tolist() == [r.sticking for r in reports]
    impulses = np.array([r.impulse for r in reports])
    np.testing.assert_allclose(result.impulse[1:], impulses, rtol=1e-14, atol=0.0)
    assert len(result.impacts) == sim.impact_count > 10


#: Flights of the structure under the quadratic Morison drag whose relative flow u - x' turns
#: many times, one of them only touching 0 (its Taylor step ended where it began)
REVERSING_FLIGHTS = {
    "touching": (dict(structure_Cd=1.0, structure_A=2.0, drag_model=2, structure_v0=0.5,
                      ice_A=2.0), 20.0),
    "plausible": (dict(structure_m=3485.0, structure_k=7.31e5, structure_c=3423.0,
                       ice_M=3087.0, ice_A=9.1, ice_Cd=0.59, flow_u=0.166, impact_e=1.0,
                       drag_model=2, ice_z0=-0.0249, ice_v0=0.923, structure_Ca=0.18,
                       structure_V=89.0, structure_Cd=0.58, structure_A=3.24), 60.0),
}


@pytest.mark.parametrize("name", list(REVERSING_FLIGHTS))
def test_a_flight_under_the_morison_drag_passes_any_reversal_of_the_relative_flow(name):
    from iceimpact import run

    kw, t_end = REVERSING_FLIGHTS[name]
    result = run(Scene(**kw), t_end)
    assert np.isfinite(result.x).all() and result.t[-1] == t_end


def test_the_structure_under_the_morison_drag_follows_an_integration_through_its_reversals():
    """The structure alone (the ice far upstream, undragged): its Taylor steps through some
    60 reversals of u - x' against DOP853 at rtol 1e-12, which shares no code with them."""
    from scipy.integrate import solve_ivp

    from iceimpact import run

    scene = Scene(structure_Cd=1.0, structure_A=2.0, drag_model=2, structure_v0=0.5,
                  ice_z0=-1e3, ice_v0=0.0, ice_Cd=0.0)
    m, c, k = scene.structure_mass, scene.structure_c, scene.structure_k
    B, u = scene.structure_drag_B, scene.flow_u

    def rhs(t, y):
        r = u - y[1]
        return [y[1], (B * abs(r) * r - c * y[1] - k * y[0]) / m]
    t_end = 20.0
    result = run(scene, t_end, dt=1e-2)
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, 0.5], method="DOP853", rtol=1e-12, atol=1e-15,
                    t_eval=result.t)
    assert len(result.impacts) == 0
    reversals = np.count_nonzero(np.diff(np.sign(u - sol.y[1])))
    assert reversals > 50
    np.testing.assert_allclose(result.x, sol.y[0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(result.v, sol.y[1], rtol=0, atol=1e-9)
