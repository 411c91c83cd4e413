"""The exact method's sticking phases (solvers/exact/sticking.py): a well over-damped phase
decaying to rest, under the linear drag."""

from __future__ import annotations

import numpy as np

from iceimpact import Scene, Simulator
from iceimpact.physics.structure import Oscillator
from iceimpact.solvers.exact import LinearStick
from work_counters import count_probes

# --- a well over-damped sticking phase decaying to rest (method 1, linear drag) ---------------

def _decimal_sticking_impulses(scene: Scene, x0: float, v0: float, u: float, h: float,
                               steps: int) -> list:
    """Each step's contact impulse of a linear-drag sticking phase from its anchor (x0, v0) at
    t = 0, from the closed form in 60-digit decimal arithmetic (mass m + M, damping c + b,
    equilibrium b u / k, the over-damped motion on its two exponents), as the ice's momentum
    balance over the step: the drag impulse b (u dt - dx) minus M dv."""
    from decimal import Decimal, localcontext
    with localcontext() as ctx:
        ctx.prec = 60
        b = Decimal(scene.drag_b)
        mass = Decimal(scene.structure_m) + Decimal(scene.ice_M)
        damping, stiff = Decimal(scene.structure_c) + b, Decimal(scene.structure_k)
        offset = b * Decimal(u) / stiff
        root = (damping * damping - 4 * stiff * mass).sqrt()
        s1, s2 = (-damping + root) / (2 * mass), (-damping - root) / (2 * mass)
        y0, w0 = Decimal(x0) - offset, Decimal(v0)
        a, c = (w0 - s2 * y0) / (s1 - s2), (s1 * y0 - w0) / (s1 - s2)

        def state(t):
            e1, e2 = (s1 * t).exp(), (s2 * t).exp()
            return a * e1 + c * e2, a * s1 * e1 + c * s2 * e2
        out, (y_a, v_a) = [], state(Decimal(0))
        for i in range(1, steps + 1):
            y_b, v_b = state(Decimal(i) * Decimal(h))
            out.append(b * (Decimal(u) * Decimal(h) - (y_b - y_a))
                       - Decimal(scene.ice_M) * (v_b - v_a))
            y_a, v_a = y_b, v_b
        return out


def test_a_decaying_over_damped_sticking_phase_gives_its_exact_small_impulses():
    """Method 1, linear drag, an over-damped pair sticking (m = 0.6 kg, c = 9.1e6 N.s/m,
    k = 1.4e10 N/m, M = 18 mg: zeta 50 together, no flow to speak of) decaying from 0.19 m/s.
    Each step's impulse was the integral from the anchor's force, lam0 dt plus that of
    q - q0, with the rounding of lam0 dt: by t = 0.014 s steps of 3e-14, 1.4e-13 and
    -8.3e-14 N.s (tensile) for a true 6e-20. The step's momentum balance on its own modes has
    a rounding that decays with the motion: each step now matches the closed form in decimal
    arithmetic (and is >= 0)."""
    v0 = 0.18913741007012352
    scene = Scene(structure_m=0.6026885668330727, structure_c=9059994.330384696,
                  structure_k=13919009506.926985, structure_x0=0.0, structure_v0=v0,
                  ice_M=0.01847137342471947, ice_A=122.97055369620666,
                  ice_Cd=0.5921239351774049, ice_z0=0.0, ice_v0=v0, impact_e=0.0,
                  drag_model=1, flow_u=-2.6161706687673503e-45, solver_method=1)
    sim = Simulator(scene)
    h, steps = 1e-4, 300
    exact = _decimal_sticking_impulses(scene, 0.0, v0, scene.flow_u, h, steps)
    for i in range(steps):
        r = sim.advance(h)
        assert r.sticking and r.impulse >= 0.0
        assert abs(float(exact[i]) - r.impulse) <= 1e-9 * float(exact[i]), i


def test_a_pair_sticking_to_rest_without_flow_keeps_exact_impulses_in_bounded_work(monkeypatch):
    """Method 1, linear drag, a 29 mg pair (k = 5.6e8 N/m, b = 1.5e4 kg/s) sticking from
    0.24 m with no flow: it is at rest (positions and speeds underflowed) by t = 0.03 s. The
    impulses from the anchor's force came out as +-2.3e-10 N.s per 0.01 s step (one ulp of
    lam0 dt), alternately tensile, and the contact force lam0 + (q - q0) as its rounding,
    1.5e-8 N, along which the separation search crawled, 2e4 steps per 0.01 s. Each step's
    impulse now matches the closed form in decimal arithmetic (>= 0, 0 at rest), and the
    force's two modes prove it compressive for ever (Q1 >= 0, Q1 + Q2 >= 0, no flow)."""
    x0, v0 = 0.24483121483815284, 0.09148875304197258
    scene = Scene(structure_m=2.929723032384046e-05, structure_c=0.0,
                  structure_k=555219947.5965517, structure_x0=x0, structure_v0=v0,
                  ice_M=2.929723032384046e-05, ice_A=208.22135853441782,
                  ice_Cd=0.14689286517096625, ice_z0=x0, ice_v0=v0, impact_e=0.09,
                  drag_model=1, flow_u=0.0, solver_method=1)
    calls = count_probes(monkeypatch, LinearStick, 20_000,
                         "the search crawls along the force's rounding")
    sim = Simulator(scene)
    h, steps = 0.01, 300
    exact = _decimal_sticking_impulses(scene, x0, v0, 0.0, h, steps)
    for i in range(steps):
        r = sim.advance(h)
        assert r.sticking and r.impulse >= 0.0
        assert abs(float(exact[i]) - r.impulse) <= 1e-9 * float(exact[i]) + 1e-300, i
    assert r.v == 0.0 and abs(r.x) <= 2.0 ** -52 * x0  # at rest, to the rounding of x0 + dx
    assert calls[0] <= 1_000


def test_a_pair_at_rest_stays_at_rest_when_the_flow_stops():
    """Method 1, linear drag: a pair at rest in contact (m = 6364 kg, k = 0.64 N/m, M = 80 kg,
    b = 1.2e5 kg/s: zeta 1.2e3 together), sticking under a flow of 1.7 m/s (equilibrium
    4,300 m away) that the first step sets to 0. The re-anchor took the sticking phase's
    velocity at its anchor from its two modes, A s1 + B s2, terms of 0.4 m/s each: 2.2e-16 m/s
    instead of 0, and a flight from that speed created energy from rest (1.6e-28 J by 3 s).
    The velocity is now v0 plus its increments while the fast mode is above half its start:
    exactly v0 at the anchor; nothing moves."""
    scene = Scene(structure_m=6364.4498697548715, structure_c=0.0,
                  structure_k=0.6364449869754872, ice_M=79.80895101228585,
                  ice_A=138.443389909025, ice_Cd=1.7117864047293625, ice_z0=0.0, ice_v0=0.0,
                  impact_e=0.0, drag_model=1, drag_v_lin=0.013438131022709217,
                  flow_u=1.7117864047293625, solver_method=1)
    sim = Simulator(scene)
    for _ in range(3):
        r = sim.advance(1.0, 0.0)
        assert (r.x, r.v, r.z, r.w, r.impulse) == (0.0, 0.0, 0.0, 0.0, 0.0)


def test_a_well_over_damped_response_starts_at_its_anchor_exactly():
    """The two-mode form of a well over-damped response (:meth:`Oscillator.increment`) gives
    the anchor's velocity exactly at t = 0, however far the equilibrium (A s1 + B s2 missed
    v0 = 0 by 2.2e-16 m/s at 4,300 m), scalar and vectorised alike, and near t = 0 matches
    the closed form in decimal arithmetic."""
    from decimal import Decimal, localcontext
    mass, damping, stiff = 6444.258820767157, 1590.728863692959, 0.6364449869754872
    osc = Oscillator(mass, damping, stiff, offset=4278.434268797329)
    assert osc.two_modes
    for x0, v0 in ((0.0, 0.0), (0.0, 1e-300), (3.0, -2.5e-3), (-1e6, 7.0)):
        assert osc.increment(x0, v0)(0.0) == (0.0, v0)
        dx, v = osc.displacement_change_array(x0, v0, np.array([0.0]))
        assert (dx[0], v[0]) == (0.0, v0)
    with localcontext() as ctx:
        ctx.prec = 50
        m_, c_, k_ = Decimal(mass), Decimal(damping), Decimal(stiff)
        root = (c_ * c_ - 4 * k_ * m_).sqrt()
        s1, s2 = (-c_ + root) / (2 * m_), (-c_ - root) / (2 * m_)
        y0 = -Decimal(osc.offset)
        a, b = -s2 * y0 / (s1 - s2), s1 * y0 / (s1 - s2)
        for t in (1e-6, 1e-3, 0.1, 10.0):
            exact = a * s1 * (s1 * Decimal(t)).exp() + b * s2 * (s2 * Decimal(t)).exp()
            v = osc.increment(0.0, 0.0)(t)[1]
            assert abs(float(Decimal(v) - exact)) <= 4e-16 * abs(float(exact)), t
            assert osc.displacement_change_array(0.0, 0.0, np.array([t]))[1][0] == v
