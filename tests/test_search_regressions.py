"""Faults the random search found (tools/random_search.py --scales --flows), each replayed:
its scene runs soundly now. docs/explanation/robustness/searches.md and the pages it links."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

from iceimpact import ParameterError, Scene, Simulator
from iceimpact.limits import (
    STICKING_RATE,
    TAYLOR_RATE_MAX,
)
from iceimpact.physics.ice import LinearDrag, QuadraticDrag
from iceimpact.physics.structure import Oscillator
from scenes import toggled_flow

# --- faults the random search found (tools/random_search.py --scales --flows) -----------------

def test_a_stiff_structure_ringing_far_from_the_ice_costs_no_work_per_period():
    """Method 1, a stiff undamped structure (omega_n 1.3e7 rad/s) ringing with 0.6 m amplitude
    while the ice coasts towards the lowest point of its swing: the root search's Taylor steps
    (curvature bound omega_n^2 x amplitude) took a few evaluations per period, over 30 s of
    work per simulated second. The structure's envelope now proves the gap open until the ice
    can reach it. The impact time agrees with the closed form written out here
    (x = x0 cos(omega_n t), z = z0 + w0 t)."""
    omega, x0, z0, w0 = 1.3e7, -0.6, -0.65, 0.1
    sim = Simulator(Scene(structure_m=1600.0, structure_k=1600.0 * omega ** 2, structure_c=0.0,
                          structure_x0=x0, structure_v0=0.0, ice_M=1600.0, ice_Cd=0.0,
                          ice_z0=z0, ice_v0=w0, flow_u=0.1, impact_e=1.0, solver_method=1))
    while sim.t < 0.45 - 1e-12:
        r = sim.advance(0.05)
        assert r.gap > 0.0 and sim.impact_count == 0
    # a handful of search iterations, not one per fraction of each of 9e5 periods
    assert sim.solver.seg.search.iterations < 10
    sim.advance(0.1)
    assert sim.impact_count == 1

    def gap(t):
        return x0 * math.cos(omega * t) - (z0 + w0 * t)

    # the ice reaches the swing's lowest point x0 at t = 0.5 s; the impact is on the way down
    # to the first trough (t = 2 pi j / omega) after that
    trough = 2.0 * math.pi * math.ceil((x0 - z0) / w0 * omega / (2.0 * math.pi)) / omega
    exact = brentq(gap, trough - math.pi / omega, trough, xtol=1e-18, rtol=1e-15)
    assert abs(sim.impacts[0].t - exact) <= 1e-14


def _reversing(u: float, i: int) -> float:
    return u if i % 2 == 0 else -u


def test_a_flow_changing_at_every_step_costs_method_3_work_in_proportion_to_the_step():
    """Method 3 restarted a whole chunk (1 s here) at every flow change: with a flow reversing
    at every 0.1 ms step and a stiff damping (c/m = 2.5e4 1/s) a run of 50 ms did not finish in
    30 s. After a flow change the integration now spans the step, then doubles."""
    u = 0.92
    sim = Simulator(Scene(structure_m=0.0736, structure_c=1803.6, structure_k=33645.0,
                          structure_x0=-0.917, structure_v0=-0.84, ice_M=1.43e-5,
                          ice_Cd=0.0, ice_z0=-1.008, ice_v0=-0.84, impact_e=0.0,
                          drag_model=2, flow_u=-u, solver_method=3))
    sim.advance(1e-4)  # the scene's own flow: its first chunk of 1 s (~6e4 evaluations)
    before = sim.solver.nfev
    for i in range(1, 51):
        r = sim.advance(1e-4, _reversing(-u, i))
        assert r.gap >= 0.0 and math.isfinite(r.x)
    # a 1 s chunk of this stiff damping takes ~6e4 evaluations; a 0.1 ms step ~1e2
    assert sim.solver.nfev - before < 50 * 1000


@pytest.mark.parametrize("drag", [1, 2])
def test_method_3_follows_a_flow_changing_at_every_step(drag):
    """Figure 2 scene in flight, the ice 2 mm upstream closing at 10 mm/s, the flow reversed
    at every 1 ms step for 0.3 s, one impact on the way: method 3's states agree with method 1's
    (closed forms) to its tolerance at every step, and a snapshot taken inside a shortened span
    continues to the last bit."""
    exact = Simulator(Scene(drag_model=drag, ice_z0=-0.002, solver_method=1))
    ode = Simulator(Scene(drag_model=drag, ice_z0=-0.002, solver_method=3, solver_rtol=1e-10))
    for i in range(300):
        a, b = exact.advance(1e-3, _reversing(0.1, i)), ode.advance(1e-3, _reversing(0.1, i))
        for name in ("x", "v", "z", "w"):
            assert abs(getattr(a, name) - getattr(b, name)) <= 1e-6 * 0.01, (i, name, a, b)
    assert exact.impact_count == ode.impact_count >= 1
    saved = json.loads(json.dumps(ode.save()))
    inputs = [(7e-4, _reversing(0.1, i)) for i in range(20)] + [(0.05, 0.1)] * 10
    twin = Simulator.from_snapshot(saved)
    assert [twin.advance(h, u) for h, u in inputs] == [ode.advance(h, u) for h, u in inputs]


def test_the_rounding_closing_speed_rule_at_its_edges():
    """ContactRules.is_rounding writes its magnitudes without abs(): the same answer as
    |closing| <= 1e-12 (|v| + |w| + |u| + wn |x|) + 1e-300 for zeros of either sign, speeds at
    and just beyond the limit, infinities and NaN."""
    from itertools import product

    from iceimpact.solvers.contact_rules import EXACT_POLICY, ROUNDING_SPEED, ContactRules

    omega_n = 3.0
    rules = ContactRules(1.0, 2.0, omega_n, lambda *state: (0.0, 0.0), EXACT_POLICY, 1e-2)
    values = [0.0, -0.0, 2e-300, -2e-300, 0.5, -0.7, 3.0, math.inf, -math.inf, math.nan]
    checked = 0
    for x, v, w, u in product(values, repeat=4):
        limit = ROUNDING_SPEED * (abs(v) + abs(w) + abs(u) + omega_n * abs(x)) + 1e-300
        edges = [limit, math.nextafter(limit, math.inf)] if math.isfinite(limit) else [1.0]
        for closing in [0.0, -0.0, 1e-300, 1.0, math.inf, math.nan] + edges:
            for c in (closing, -closing):
                assert rules.is_rounding(c, x, v, w, u) == (abs(c) <= limit), (c, x, v, w, u)
                checked += 1
    assert checked > 100_000


@pytest.mark.parametrize("drag", [LinearDrag(1.0, 0.0), QuadraticDrag(1.0, 0.0),
                                  LinearDrag(1.0, 3.0), QuadraticDrag(1.0, 3.0)])
def test_the_ice_velocity_is_exact_at_the_anchor(drag):
    """w(0) = w0 to the last bit, and w = w0 at all times without drag, even when |w0| is far
    below |u|: u + (w0 - u) e^0 gave 0 for w0 = 1e-169, u = 0.1."""
    for w0 in (1e-169, -1.3e-169, 0.37, -2.0):
        assert drag.displacement_change(w0, 0.1, 0.0) == (0.0, w0)
        if drag.force(1.0, 0.0) == 0.0:  # no drag: the ice coasts
            assert drag.displacement_change(w0, 0.1, 7.0)[1] == w0


def test_bodies_at_rest_with_no_drag_and_a_toggled_flow_finish():
    """Method 1, both bodies in contact at speeds of 1e-169 m/s, no drag, the flow toggled:
    every flight from the contact saw the ice's velocity as 0 (the rounding above), an approach
    at rounding speed, and met a contact again at the same instant, without end (the first
    0.1 ms step did not finish in 30 s)."""
    v0 = -1.3342728836344646e-169
    sim = Simulator(Scene(structure_m=3.6256e-4, structure_c=0.0, structure_k=5.065e-7,
                          structure_x0=0.0, structure_v0=v0, ice_M=6.6e-8, ice_Cd=0.0,
                          ice_z0=0.0, ice_v0=v0, impact_e=0.0, drag_model=1, flow_u=0.0,
                          solver_method=1))
    for i in range(100):
        r = sim.advance(1e-4, toggled_flow(i))
        assert r.gap >= 0.0 and r.impulse >= 0.0 and abs(r.w) <= abs(v0)


def test_a_decayed_velocity_keeps_its_precision():
    """The flight's closed form recovered C(t) as (C - 1) + 1, an error of one ulp of 1: the
    velocity of a strongly over-damped structure (zeta = 46) carried eps |v0| long after it had
    decayed below that, and the root search, seeing that noise as a slope, crawled along a gap
    of 1e-24 m (0.01 s did not finish in 30 s). Checked against the slow exponential of the
    over-damped response, v = v0 s1 e^{s1 t} / (s1 - s2) once the fast one has died out."""
    m, c, k, v0 = 0.1326, 5.502e6, 2.658e10, 0.558
    osc = Oscillator(m, c, k)
    sigma, wo = c / (2.0 * m), math.sqrt((c / (2.0 * m)) ** 2 - k / m)
    slow, fast = -(k / m) / (sigma + wo), -(sigma + wo)
    for t in (1e-3, 7.6e-3, 3e-2):
        dx, v = osc.displacement_change(0.0, v0, t)
        exact = v0 * slow * math.exp(slow * t) / (slow - fast)
        assert v == pytest.approx(exact, rel=1e-9)
        assert dx == pytest.approx(v0 * math.exp(slow * t) / (slow - fast), rel=1e-9)
    sim = Simulator(Scene(structure_m=m, structure_c=c, structure_k=k, structure_x0=0.0,
                          structure_v0=v0, ice_M=4.3e-3, ice_Cd=0.0, ice_z0=0.0, ice_v0=0.0,
                          impact_e=0.0, flow_u=0.0, solver_method=1))
    sim.advance(0.01)
    assert sim.solver.seg.search.iterations < 1000 and sim.solver.state.gap > 0.0


def test_a_light_floe_struck_by_a_fast_structure_is_refused():
    """Quadratic drag with a light floe of a large area (B/M = 1.7e10 1/m) resting on a
    structure that moves at 0.45 m/s: the impact gives the ice a speed whose drag rate is 8e9
    1/s and the quadratic-drag sticking integration did not finish. The drag-rate rule now
    counts the speed an impact can give the ice (up to twice the structure's speed bound)."""
    scene = dict(structure_m=1e-5, structure_c=0.0, structure_k=11.68, structure_x0=0.86,
                 structure_v0=0.453, ice_M=1e-5, ice_A=261.6, ice_Cd=1.28, ice_z0=0.86,
                 ice_v0=0.0, impact_e=0.0, drag_model=2, flow_u=-6.6e-6)
    for method in (1, 3):
        with pytest.raises(ParameterError, match=r"structure.x0\)\^2\) = .* speed <= "):
            Scene(**scene, solver_method=method)
    Scene(**scene, solver_method=2, solver_dt=1e-5)  # method 2: its own rule, on solver.dt


def test_method_3_repeated_events_do_not_hold_a_pulling_contact():
    """Method 3 closes events repeating at one instant (integration noise at a loose tolerance)
    with a plastic contact and a pause of the event search. It held the bodies together
    whatever the sign of the contact force: in the Figure 2 scene with e = 0 at rtol 1e-9 it
    held them against a pull of 6 N at t = 8.276 s and lost the bounce that method 1 finds at
    8.284 s. While the force pulls, the bodies now fly apart instead: the impacts over 12 s
    are method 1's, to the tolerance."""
    def impacts(method, rtol):
        sim = Simulator(Scene(impact_e=0.0, solver_method=method, solver_rtol=rtol))
        while sim.t < 12.0 - 1e-9:
            r = sim.advance(0.01)
            assert r.impulse >= 0.0 and r.gap >= 0.0
        return [i.t for i in sim.impacts]

    exact, ode = impacts(1, 1e-8), impacts(3, 1e-9)
    assert len(exact) == len(ode) == 8
    assert max(abs(a - b) for a, b in zip(exact, ode, strict=True)) < 1e-4


def test_method_3_lets_a_fast_parting_ice_fly():
    """The ice starting on the structure and leaving at 35 m/s against a strong quadratic drag
    (lam chatter_time far above the parting momentum): method 3's slow-parting rule took it for
    integration noise and stuck the bodies with a plastic entry, an impulse of -17 N.s that
    pulled the ice back. Only a parting within the velocities' tolerance is noise now: the ice
    flies as it does with method 1 (closed forms). (The search's area was 9.446 m^2; 9.4 keeps
    the sticking drag rate within method 1's TAYLOR_RATE_MAX, which the reference run needs.)"""
    scene = dict(structure_m=1.0, structure_c=0.0, structure_k=22088.8, structure_x0=0.0,
                 structure_v0=0.0, ice_M=1.0, ice_A=9.4, ice_Cd=0.61, ice_z0=0.0,
                 ice_v0=-34.76, impact_e=0.0, drag_model=2, flow_u=0.1)
    exact = Simulator(Scene(**scene, solver_method=1))
    ode = Simulator(Scene(**scene, solver_method=3))
    for _ in range(5):
        a, b = exact.advance(1e-3), ode.advance(1e-3)
        assert b.impulse >= 0.0 and not b.sticking
        assert b.z == pytest.approx(a.z, rel=1e-6) and b.w == pytest.approx(a.w, rel=1e-6)
    assert ode.solver.state.z < -1e-3  # the ice is upstream, on its way back


def test_method_3_bodies_parting_under_noise_still_meet_again():
    """A 48.6 t floe at 1903 m/s strikes a 31.6 kg structure (e = 0): the bodies move together,
    the drag pulls them apart by 0.2 N at the start while the spring brings them together
    microseconds later. Method 3 met the gap event again and again at the instant of the impact
    (integration noise); a first sign-aware closure let the bodies fly with the gap event
    paused and the ice went 2e-7 m through the structure. The gap event of that flight is now
    set just below the noise of the positions, so the contact is met again: the motion is
    method 1's (closed forms) to the tolerance and the gap stays within it."""
    scene = dict(structure_m=31.62, structure_c=0.0, structure_k=21626.0, structure_x0=0.0,
                 structure_v0=0.961, ice_M=48641.0, ice_A=0.347, ice_Cd=0.001,
                 ice_z0=0.0, ice_v0=1903.0, impact_e=0.0, drag_model=1, flow_u=0.1)
    exact = Simulator(Scene(**scene, solver_method=1))
    ode = Simulator(Scene(**scene, solver_method=3))
    for _ in range(200):
        a, b = exact.advance(1e-4), ode.advance(1e-4)
        assert ode.solver.state.gap >= -1e-10 and b.impulse >= 0.0
        assert b.x == pytest.approx(a.x, rel=1e-6, abs=1e-9)


def test_sticking_far_from_its_equilibrium_keeps_the_impulse_sound():
    """Method 1, linear drag: a soft structure (k = 1.2e-4 N/m) pressed by a strong drag
    (b = 8.1e4 kg/s) sticks towards an equilibrium b u / k = 6.9e7 m away. Positions about it
    carry its rounding (1e-7 m) and b (xb - xa) turned that into contact impulses of +-0.1 N.s,
    some tensile. The displacement increments now come from the exponents of the over-damped
    motion: each step's impulse equals the structure's momentum balance
    m dv + c dx + k x dt (the force on the structure is its inertia, damping and spring)."""
    m, k = 1.0, 1.1779e-4
    sim = Simulator(Scene(structure_m=m, structure_c=0.0, structure_k=k, structure_x0=0.0,
                          structure_v0=0.0, ice_M=393.5, ice_A=812.19, ice_Cd=2.0, ice_z0=0.0,
                          ice_v0=0.0, impact_e=0.0, drag_model=1, flow_u=0.1,
                          solver_method=1))
    v_before, x_before = 0.0, 0.0
    for _ in range(8):
        r = sim.advance(1e-3)
        assert r.sticking and r.impulse >= 0.0
        balance = m * (r.v - v_before) + k * 0.5 * (r.x + x_before) * 1e-3
        assert r.impulse == pytest.approx(balance, rel=1e-6, abs=1e-12)
        v_before, x_before = r.v, r.x


@pytest.mark.parametrize("drag", [1, 2])
def test_a_flow_change_right_after_an_impact_at_t0_keeps_the_momentum(drag):
    """Method 3, the structure striking the ice at t = 0 (e = 0) and the flow changed at the
    first step: the re-anchor took the state last reported (before the impact) instead of the
    segment's, gave the ice the structure's pre-impact velocity and created momentum (energy
    grew from 1.3e-4 J to 0.37 J at u = 0). It now continues from the plastic impact, as
    method 1 does."""
    scene = dict(structure_m=2.626e-4, structure_c=0.0, structure_k=2.626e-4, structure_x0=0.09,
                 structure_v0=-0.98, ice_M=0.766, ice_Cd=0.0, ice_z0=0.09, ice_v0=0.0,
                 impact_e=0.0, drag_model=drag, flow_u=81.4)
    momentum = scene["structure_m"] * scene["structure_v0"]
    runs = []
    for method in (1, 3):
        sim = Simulator(Scene(**scene, solver_method=method))
        sim.advance(1e-6, 0.0)  # the spring's impulse over 1 us is 2e-11 N.s
        s = sim.solver.state
        assert scene["structure_m"] * s.v + scene["ice_M"] * s.w == pytest.approx(momentum,
                                                                                  rel=1e-6)
        sim.advance(1.0, 0.0)
        runs.append(sim.solver.state)
    exact, ode = runs
    assert ode.v == pytest.approx(exact.v, rel=1e-6) and ode.x == pytest.approx(exact.x, rel=1e-6)


def test_the_over_damped_amplitude_bound_is_sound_and_tight():
    """The bound on a free response's future |y| that the root searches use: over-damped it is
    now |A| + |B| of its two exponentials where that is tighter than the energy bound (by
    sigma / omega_n). Checked against a scipy integration of y'' + 2 sigma y' + omega_n^2 y = 0:
    never below the largest |y| ahead, and within a factor 2 of it."""
    from scipy.integrate import solve_ivp
    osc = Oscillator(2.2e-5, 4993.0, 1.14e-5)  # sigma 1.1e8 1/s, omega_n 0.72 rad/s
    two_sigma, omega2 = osc.damping / osc.mass, osc.stiffness / osc.mass
    for y0, v0 in ((1.0, 0.0), (0.0, 1.0), (1.0, -2e8), (-3.0, 5e7), (1e-3, -1e-3)):
        bound = osc.amplitude_bound(y0, v0)
        sol = solve_ivp(lambda t, s: [s[1], -two_sigma * s[1] - omega2 * s[0]], (0.0, 1e-6),
                        [y0, v0], method="Radau", rtol=1e-10, atol=1e-14, dense_output=True)
        peak = max(abs(y0), float(np.max(np.abs(sol.sol(np.linspace(0.0, 1e-6, 20001))[0]))))
        assert peak <= bound * (1 + 1e-6) and bound <= 2.0 * peak + 1e-12, (y0, v0, peak, bound)
        assert bound < math.sqrt(y0 * y0 + v0 * v0 / omega2) or v0 == 0.0


def test_a_light_floe_sticking_under_a_strong_linear_drag_finishes():
    """Method 1: a 10 g floe under a linear drag of b/M = 4.9e8 1/s sticks to a 11 g structure:
    the search for its separation bounded the contact force's derivatives by the energy bound,
    3e8 times too loose, and crawled at 1e-13 s steps."""
    sim = Simulator(Scene(structure_m=1.14e-5, structure_c=2.28e-5, structure_k=1.14e-5,
                          structure_x0=0.0, structure_v0=0.124, ice_M=1.02e-5, ice_A=6.82,
                          ice_Cd=1.5, ice_z0=0.0, ice_v0=0.0, impact_e=1.0, drag_model=1,
                          drag_v_lin=0.977, flow_u=0.1, solver_method=1))
    for _ in range(3):
        r = sim.advance(0.37)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.solver.seg.search.iterations < 100_000


def test_method_3_work_per_impact_follows_the_impact_not_the_chunk():
    """Method 3, a stiff undamped structure (omega_n 3e3 rad/s) bouncing the ice every ~0.4 ms:
    each impact started a segment integrated a whole chunk (1 s, ~1e4 periods) ahead, 4.6e5
    evaluations for 10 ms. A segment's first call now spans one period, then doubles."""
    sim = Simulator(Scene(structure_m=1.0, structure_c=0.0, structure_k=9.171e6,
                          structure_x0=0.0, structure_v0=0.0, ice_M=1.0, ice_A=1.023,
                          ice_Cd=0.2168, ice_z0=-1e-5, ice_v0=0.0, impact_e=1.0, drag_model=1,
                          drag_v_lin=0.9937, flow_u=3.48, solver_method=3))
    for i in range(100):
        r = sim.advance(1e-4, -3.48 if i % 4 == 3 else 3.48)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.impact_count >= 10
    assert sim.solver.nfev < 50_000


def test_a_structure_damped_too_stiffly_to_integrate_is_refused_for_method_3():
    """An over-damped structure relaxes at up to c / m: for method 3's explicit integrators a
    rate like the drag's, held to the same limit."""
    with pytest.raises(ParameterError,
                       match=r"structure.c / structure.m = 2000000.0 is not allowed: <= 1e\+06"):
        Scene(structure_c=2e6 * 1600.0, solver_method=3, solver_ode_method=3)
    Scene(structure_c=2e6 * 1600.0, solver_method=1)
    Scene(structure_c=0.9e6 * 1600.0, solver_method=3, solver_ode_method=3)


def test_a_structure_too_stiff_for_the_quadratic_sticking_steps_is_refused_for_method_1():
    """The random search's stiff, over-damped scene (omega of the bodies together 1.1e7 rad/s,
    c / (m + M) = 3.9e8 1/s) under quadratic drag ran without end in method 1's sticking phase
    (explicit Taylor steps of about 1 / rate): refused up front, naming the combination, its
    value and the limit; the same scene with linear drag (closed-form sticking) is accepted, and
    a rate just below the limit is accepted too."""
    stiff = dict(structure_m=232755831.8212012, structure_c=1.7993742487458515e+17,
                 structure_k=5.559221199183276e+22, ice_M=232755831.8212012, ice_A=1.0,
                 ice_Cd=0.3426254990962821, drag_v_lin=1.0, impact_e=0.5,
                 structure_x0=0.0, ice_z0=-0.01, flow_u=0.1)
    with pytest.raises(ParameterError) as err:
        Scene(drag_model=2, **stiff)
    message = str(err.value)
    assert message.startswith(STICKING_RATE)
    assert f"{TAYLOR_RATE_MAX:g} 1/s" in message and "drag.model = 1" in message
    Scene(drag_model=1, **stiff)
    Scene(drag_model=2, solver_method=2, **stiff)
    total = Scene().structure_m + Scene().ice_M
    Scene(drag_model=2, structure_c=0.0, structure_k=total * (0.99 * TAYLOR_RATE_MAX) ** 2)
    with pytest.raises(ParameterError):
        Scene(drag_model=2, structure_c=0.0, structure_k=total * (1.01 * TAYLOR_RATE_MAX) ** 2)


#: 1 kg floe on a 1 kg structure (m + M = 2 kg), quadratic drag at u = 1 m/s (method 1)
_PAIR = dict(structure_m=1.0, ice_M=1.0, ice_Cd=1.0, structure_x0=0.0, structure_v0=0.0,
             ice_z0=0.0, ice_v0=0.0, drag_model=2, flow_u=1.0, solver_method=1)


def _pair(omega_n: float, zeta: float, drag_rate: float, **fields) -> dict:
    """_PAIR with the structure's omega_n (rad/s) and zeta, and 2 B u / M = drag_rate (1/s)."""
    k = omega_n ** 2
    return {**_PAIR, "structure_k": k, "structure_c": 2.0 * zeta * math.sqrt(k),
            "ice_A": drag_rate / (2.0 * 499.5), **fields}


def test_sticking_phases_too_slow_for_the_taylor_steps_are_refused_for_method_1():
    """Method 1's quadratic-drag sticking phase takes Taylor steps of about 1 / rate (0.1 to
    0.3 steps x rate per simulated second), up to ~2e-5 s of CPU x rate per simulated second
    (tools/taylor_rate_cost.py). Under the former limit of 1e6 1/s the search found an
    over-damped structure (omega_n 1.6e4 rad/s, zeta 6.1) under a drag rate 2 B u / M of
    2.9e5 1/s sticking at ~3.2 s of CPU per simulated second, and stiff pairs (sqrt(k / (m + M))
    of 3.7e5-5.4e5 rad/s) at 4.5-10 s. The rule now holds each rate of the sticking equation,
    the drag's 2 (B + B_s) speed / (m + M) included, to TAYLOR_RATE_MAX = 1e5 1/s, up front and
    for each new flow.u, naming the rates, their values and the limit."""
    assert TAYLOR_RATE_MAX == 1e5
    # the over-damped scene: sqrt(k / (m + M)) = 1.1e4, c / (m + M) = 9.8e4, drag 1.45e5 1/s
    with pytest.raises(ParameterError) as err:
        Scene(**_pair(1.6e4, 6.1, 2.9e5))
    message = str(err.value)
    assert message.startswith(f"{STICKING_RATE} = 145000")
    assert "sqrt(structure.k / (m + M)) = 1.13e+04 rad/s" in message
    assert "structure.c / (m + M) = 9.76e+04 1/s" in message
    assert "2 (B + B_s) speed / (m + M) = 1.45e+05 1/s" in message
    assert "<= 100000 1/s with quadratic drag and solver.method = 1" in message
    Scene(**_pair(1.6e4, 6.1, 1.9e5))  # drag 9.5e4 1/s: accepted
    Scene(**_pair(1.6e4, 6.1, 2.9e5, drag_model=1))  # linear drag: closed-form sticking
    # a stiff pair: sqrt(k / (m + M)) = 3.7e5 rad/s
    with pytest.raises(ParameterError, match=r"= 370000.0000000\d* is not allowed: <= 100000"):
        Scene(**_pair(3.7e5 * math.sqrt(2.0), 0.0, 1e3))
    with pytest.raises(ParameterError, match=r"structure.c / \(m \+ M\) = 1.2e\+05 1/s"):
        Scene(**_pair(1e4, 12.0, 1e3))  # over-damped: c / (m + M) = 1.2e5 1/s
    Scene(**_pair(0.99e5 * math.sqrt(2.0), 0.0, 1e3))
    # the drag on the structure counts as well: B_s doubles the rate of a drag just inside
    Scene(**_pair(1e2, 0.0, 1.8e5))
    with pytest.raises(ParameterError, match=r"2 \(B \+ B_s\) speed / \(m \+ M\) = 1.8e\+05"):
        Scene(**_pair(1e2, 0.0, 1.8e5, structure_Cd=1.0,
                      structure_A=1.8e5 / (2.0 * 499.5)))
    # mid-run: a flow whose sticking drag rate exceeds the limit refuses that step only
    sim = Simulator(Scene(drag_model=2))
    sim.advance(1e-3)
    before = sim.save()
    u_max = TAYLOR_RATE_MAX * 3200.0 / (2.0 * 499.5)  # 3.2e5 m/s, below the 1.6e6 of 2 B u / M
    with pytest.raises(ParameterError, match=r"flow.u = .* is not allowed: \|flow.u\| <= "
                                             r"3.2e\+05 m/s .* 2 \(B \+ B_s\) \|flow.u\| / "
                                             r"\(m \+ M\) = 1.01e\+05 1/s"):
        sim.advance(1e-3, 1.01 * u_max)
    assert sim.save() == before
    sim.advance(1e-3, 0.99 * u_max)


@pytest.mark.parametrize("kind", ["stiff", "over-damped", "stiff drag"])
def test_taylor_sticking_steps_per_simulated_second_are_proportional_to_the_rate(kind):
    """Just inside TAYLOR_RATE_MAX, the scenes of tools/taylor_rate_cost.py (a 1 kg floe stuck
    from rest on a 9 kg structure whose sqrt(k / (m + M)), c / (m + M) or sticking drag rate is
    the given rate), the flow switched at every 1 ms step as there (1 and 0.5 m/s): the Taylor
    steps per simulated second stay below 0.6 x rate (measured 0.1-0.3 at 1e5 1/s), the work
    the limit was derived from; independent of CPU speed."""
    from iceimpact.solvers.search import taylor
    from taylor_rate_cost import LOW_FLOW, scene

    calls = [0]
    original, original_run = taylor.StickingTaylor.step, taylor.StickingTaylor.run

    def counted(self, *args, **kwargs):
        calls[0] += 1
        return original(self, *args, **kwargs)

    def counted_run(self, *args):  # (the steps of a compiled run)
        steps = original_run(self, *args)
        calls[0] += len(steps)
        return steps

    rate = 0.99 * TAYLOR_RATE_MAX
    taylor.StickingTaylor.step, taylor.StickingTaylor.run = counted, counted_run
    try:
        sim = Simulator(scene(kind, rate))
        for i in range(20):
            r = sim.advance(1e-3, 1.0 if i % 2 == 0 else LOW_FLOW[kind])
            assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    finally:
        taylor.StickingTaylor.step, taylor.StickingTaylor.run = original, original_run
    assert sim.sticking and sim.sticking_since == 0.0
    assert 0.0 < calls[0] <= 0.6 * rate * sim.t
    # just outside: refused (the stiff drag by the drag rule 2 B u / M <= 1e6 1/s as well)
    with pytest.raises(ParameterError, match=r"is not allowed: (<= 100000 1/s|speed <=)"):
        scene(kind, 1.01 * TAYLOR_RATE_MAX)


def test_a_sticking_separation_at_denormal_scales_is_located():
    """A light, stiff pair sticking at positions of 1e-178 m with no drag (a random search
    scene): the separation's root lies at a normalised time so close to 0 that brentq's default
    100 iterations did not reach it (RuntimeError). The Taylor step's root search now allows the
    bisection depth those scales need, and the run is sound."""
    scene = Scene(structure_m=1.2811449567924302e-06, structure_c=0.8540966378616202,
                  structure_k=1281144.9567924303, structure_x0=3.457191159007816e-178,
                  structure_v0=1.1857442825908975e-249, ice_M=0.0003156398940550749,
                  ice_A=0.005081541681607078, ice_Cd=0.0, ice_z0=3.457191159007816e-178,
                  ice_v0=0.0, impact_e=1.0, drag_model=2, drag_v_lin=0.00491631729782529,
                  flow_u=0.0)
    sim = Simulator(scene)
    for _ in range(3):
        report = sim.advance(10.0)
        values = [report.x, report.v, report.z, report.w, report.gap, report.impulse]
        assert all(math.isfinite(value) for value in values)
        assert report.gap >= 0.0 and report.impulse >= 0.0


# --- the far-scale search (tools/random_search.py --far):
# docs/explanation/robustness/searches.md#the-far-scale-search. Each case is the search's REPLAY
# line (scene fields not at their defaults); the replay turns every numpy warning into a fault, so
# an invalid value computed on the way fails

#: method 1, quadratic drag switched off (ice.Cd = 0), k = 4.2e-148 N/m: the sticking pair's
#: period is 9.9e74 s
ASTRONOMICAL_PERIOD = {
    "scene": {"structure_m": 1.0, "structure_c": 0.0, "structure_k": 4.2444766157712495e-148,
              "structure_v0": -0.8259178616762437, "ice_M": 10.0, "ice_A": 1.0023052380778996,
              "ice_Cd": 0.0, "ice_z0": 0.0, "ice_v0": -0.8259178616762437, "fluid_rho": 1.0,
              "impact_e": 0.0, "drag_model": 2, "drag_v_lin": 1.0000000001371239,
              "flow_u": 0.0},
    "h": 1.0, "flow": "constant", "signs": [False], "sizes": [0.0], "steps": 300}

#: method 1, quadratic drag, a structure of 2.8e8 kg on k = 6.6e-125 N/m under a drag of
#: 2 B |u - v| / (m + M) ~ 2e-30 1/s: the Taylor series' last terms underflow to 0
UNDERFLOWED_TERMS = {
    "scene": {"structure_m": 284076452.3109982, "structure_c": 2.73497824494906e-58,
              "structure_k": 6.582828266381306e-125, "structure_x0": -0.6883514913944402,
              "ice_M": 11.018745881556326, "ice_A": 0.8946609919312632, "ice_Cd": 1e-12,
              "ice_z0": -0.6883514913944402, "ice_v0": 0.0, "fluid_rho": 0.013651084997734028,
              "drag_model": 2, "drag_v_lin": 1.0, "flow_u": 0.0},
    "h": 0.04407721968487775, "flow": "random",
    "signs": [False, True, True, True, True, False, False, False],
    "sizes": [0.0, 0.0, 0.0, 1.0250940248359974e-06, 0.0, 0.0, 0.0, 0.0,
              4.2676068064123235e-05], "steps": 300}

#: method 1, linear drag, b / M = 3.5e37 1/s (fluid.rho 2.6e-29, drag.v_lin 6.4e60)
LOCKED_TO_THE_FLOW = {
    "scene": {"structure_m": 8.926031619946328e-06, "structure_c": 0.0, "structure_k": 1.0,
              "structure_v0": 0.6162070484044397, "ice_M": 8.926031619946328e-06,
              "ice_A": 3.3507734563837634, "ice_Cd": 1.1238575808295617, "ice_z0": 0.0,
              "ice_v0": 0.6162070484044397, "fluid_rho": 2.6084344370911257e-29,
              "drag_v_lin": 6.3835496569076216e+60, "flow_u": 0.0},
    "h": 1.0, "flow": "constant", "signs": [True], "sizes": [1.0], "steps": 300}

#: method 3, a damped 1.4 g structure (zeta 1) decaying to 5e-167 m by t = 14.5 s
DECAYED_BELOW_THE_TOLERANCE = {
    "scene": {"structure_m": 0.0014272055633688927, "structure_c": 0.07555674856341801,
              "structure_k": 1.0, "structure_x0": 5e-324, "structure_v0": 0.5970167737480874,
              "ice_M": 7002966.848558735, "ice_Cd": 0.0, "ice_z0": -0.0008989402896151912,
              "ice_v0": 0.0, "fluid_rho": 2.344228815319922, "drag_model": 2,
              "drag_v_lin": 1.0, "flow_u": 0.0, "solver_method": 3},
    "h": 0.08127746634415582, "flow": "constant", "signs": [True], "sizes": [1.0],
    "steps": 300}


def _far_replay(case):
    from random_search import replay

    outcome = replay(case)
    assert outcome.fault is None, outcome.fault
    assert not outcome.refused
    assert outcome.t == pytest.approx(case["steps"] * case["h"], rel=1e-12)
    return outcome


def test_a_taylor_step_longer_than_h_to_the_order_allows_keeps_finite_coefficients():
    """Method 1's sticking Taylor step is at most a period of the pair long; at a period of
    9.9e74 s (k = 4.2e-148 N/m) h^36 overflowed, its coefficients c_n h^n were 0 x inf = NaN
    where c_n had underflowed, and the step's polynomials evaluated to NaN: the warnings
    'overflow encountered in power', 'invalid value encountered in multiply' and, where a
    state was evaluated on the step, 'invalid value encountered in matmul' (taylor.py's
    ``evaluate``), then a SolverError refusing the first step ('state (nan, nan, nan)'), which
    the search counted as a refusal. Such a step's coefficients are now scaled by the mantissa
    and the exponent of h apart: the 300 steps run."""
    _far_replay(ASTRONOMICAL_PERIOD)


def test_a_taylor_step_whose_last_terms_underflow_is_not_a_period_long():
    """The step-length rule bounds a step by its last two terms, c_35 h^35 and c_36 h^36, at
    1e-16 of the motion. Under a drag rate of ~2e-30 1/s both underflowed to 0, which the rule
    took for no bound: the step spanned the pair's period, 1.3e67 s, over which the terms in
    between reach 1e400 (an overflow in the scaling; before, a NaN state and a SolverError at
    the fourth step). The highest nonzero term now bounds the step instead (a motion with
    k > 0 has no exactly polynomial part), and a ratio that overflows is taken in logarithms:
    the 300 steps run."""
    from iceimpact.solvers.search import taylor

    _far_replay(UNDERFLOWED_TERMS)
    # the rule at those scales: a finite step whose terms stay finite
    stepper = taylor.StickingTaylor(2.8e8, 0.0, 6.6e-125, 1e-14, 0.0, 11.0, max_step=1.3e67)
    step = stepper.step(0.0, (-0.69, 1e-37, 0.0), 1.0, True)
    assert math.isfinite(step.h) and step.h < 1e66
    assert np.isfinite(step.table).all()


def test_method_1_refuses_a_linear_drag_faster_than_its_time_resolution():
    """Method 1, linear drag at b / M = 3.5e37 1/s: the ice's velocity relaxes to the flow's
    within 1e-37 s, but its rounding, w - u of a few ulps, times b / M made an acceleration
    bound of 1e21 m/s^2 and a jerk bound of 3e58 m/s^3 for the gap, and the root search crept
    at its time resolution (no progress past 1e-9 s in 10 s of CPU; 1e27 1/s: 18 s for the
    300 steps). A relaxation faster than that resolution is refused up front, naming the
    limit; at the limit the scene runs its 300 steps at once."""
    from iceimpact.limits import EXACT_DRAG_RATE_MAX, TIME_RESOLUTION

    with pytest.raises(ParameterError, match=r"B \* drag.v_lin / ice.M = 3.51\d*e\+37 is not "
                       r"allowed: <= 1.12e\+15 1/s with linear drag and solver.method = 1"):
        Scene(**LOCKED_TO_THE_FLOW["scene"])
    assert EXACT_DRAG_RATE_MAX == 1.0 / TIME_RESOLUTION
    scene = dict(LOCKED_TO_THE_FLOW["scene"])
    scene["drag_v_lin"] *= 0.999 * EXACT_DRAG_RATE_MAX / 3.5124495532675686e+37
    outcome = _far_replay({**LOCKED_TO_THE_FLOW, "scene": scene})
    assert outcome.cpu < 5.0
    # methods 2 and 3 have their own rules (3: the explicit rate limit; 2: closed forms)
    Scene(**{**LOCKED_TO_THE_FLOW["scene"], "solver_method": 2})


def test_method_2_linear_drag_lag_evaluates_its_series_only_where_it_is_used():
    """Method 2's vectorised linear-drag flight evaluated the series of its lag
    ((1 - e^-x) / x - 1 below x = 1e-2) at every grid point and kept it only where x was
    small: at b / M = 1e137 1/s the series overflowed ('overflow encountered in multiply', a
    value computed and discarded). It is now evaluated at the small x only; the values are the
    same to the bit."""
    from iceimpact.physics.ice import _decay_lag_array, _log_lag_array

    x = np.array([0.0, 1e-3, 5e-3, 0.5, 1e140, np.inf])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lag = _decay_lag_array(x)
        log_lag = _log_lag_array(x[:-1])
    small = x[:3]
    assert lag[:3].tolist() == (-small * (0.5 - small * (1 / 6 - small * (
        1 / 24 - small * (1 / 120 - small / 720))))).tolist()
    assert lag[3] == -math.expm1(-0.5) / 0.5 - 1.0 and lag[4] == -1.0 and lag[5] == -1.0
    assert log_lag[3] == math.log1p(0.5) / 0.5 - 1.0 and log_lag[4] == pytest.approx(-1.0)
    case = {"scene": {"structure_m": 1.0023052380778996, "structure_c": 0.0,
                      "structure_k": 3.890700515741856e-05, "structure_v0": 0.9924532333761928,
                      "ice_M": 1e-06, "ice_A": 0.01979433004127083,
                      "ice_Cd": 0.22340065856941888, "ice_z0": -0.08509427629300018,
                      "ice_v0": 0.26875042375604674, "fluid_rho": 3.1622776601683795,
                      "drag_v_lin": 9.231604537263085e+134, "flow_u": -0.9999999999999999,
                      "solver_method": 2},
            "h": 1.0, "flow": "constant", "signs": [True], "sizes": [1.0], "steps": 3}
    _far_replay(case)


def test_method_3_error_norm_of_states_far_below_the_tolerance_is_not_a_nan():
    """Method 3, a damped structure decayed to 5e-167 m: scipy's DOP853 error norm,
    err5^2 / sqrt(err5^2 + 0.01 err3^2), was 0 / 0 once both squares underflowed ('invalid
    value encountered in scalar divide', printed to the user), and the NaN rejected the step
    (retried at a fifth of it). The norm of an error below any double is now 0 (a NaN from
    non-finite stages still rejects); ordinary steps are unchanged to the bit."""
    _far_replay(DECAYED_BELOW_THE_TOLERANCE)


def test_the_search_counts_method_3_busy_integrating_a_fast_structure_for_long():
    """The far-scale search's 300 steps of up to 1 s are up to 300 s of simulated time: an
    undamped 1087 rad/s structure (nothing else to integrate, so no rate) ran 250 s in its 30 s
    of CPU at 23 evaluations per rad/s of omega_n and simulated second, DOP853's ~12 steps a
    period, and was flagged a TIMEOUT. The work its omega_n rule allows, ODE_OMEGA_WORK per
    rad/s and simulated second (or the rate's, where that is more), now counts as busy."""
    from random_search import ODE_OMEGA_WORK, ODE_RESTART_WORK, ODE_WORK_FLOOR, busy_integrating

    scene = Scene(structure_m=1.0, structure_c=0.0, structure_k=1181163.7258910956,
                  structure_v0=6.103515625e-05, ice_M=1.0, ice_Cd=0.0, ice_z0=0.0,
                  ice_v0=6.103515625e-05, impact_e=1.0, drag_model=2, flow_u=0.0,
                  solver_method=3)
    omega = scene.omega_n
    measured = 23.1 * omega * 250.0
    assert busy_integrating(scene, 0.0, 250.0, int(measured), 250)
    allowed = ODE_OMEGA_WORK * omega * 250.0 + ODE_RESTART_WORK * 250 + ODE_WORK_FLOOR
    assert busy_integrating(scene, 0.0, 250.0, int(allowed), 250)
    assert not busy_integrating(scene, 0.0, 250.0, int(allowed) + 1, 250)


def test_method_2_does_not_pin_the_bodies_at_a_far_steady_state():
    """Method 2's steady state (eq. 27-29) pins the bodies at x = F / k once conditions (i)-(iii)
    hold near x = 0. On a structure of k = 8e-182 N/m under b u = 1.2e-10 N that position is
    8e170 m: the first grid step after the start moved both bodies there, creating k x^2 / 2 =
    2.5e160 J (the search's energy, computed with **, raised OverflowError). The pin now needs
    its own position within threshold (i) too, where the article's scenes have it (Figure 2:
    5e-6 m); here the ice drifts on with the flow."""
    scene = Scene(structure_m=1.0, structure_c=5.662101206033905e-91,
                  structure_k=8.01484751684265e-182, structure_v0=7.72942080896352e-141,
                  ice_M=1e-06, ice_A=0.002549214770303985, ice_Cd=1e-05, ice_z0=-1e-05,
                  ice_v0=7.72942080896352e-141, fluid_rho=1.0, impact_e=0.0,
                  drag_v_lin=0.0026403612183405326, flow_u=1.9, solver_method=2)
    sim = Simulator(scene)
    for _ in range(3):
        report = sim.advance(0.06955705053537756)
        assert abs(report.x) < 1e-4 and abs(report.z) < 1e-4
        assert not sim.sticking
    assert Simulator(Scene(solver_method=2, impact_e=0.0)).solver._pinnable()  # 5e-6 m
