"""The root search (solvers/search/rootfind.py) at scales whose squares underflow."""

from __future__ import annotations

import math

import pytest

from iceimpact import Scene, Simulator
from iceimpact.limits import (
    TIME_RESOLUTION,
)
from iceimpact.physics.structure import Oscillator
from iceimpact.solvers.base import GAP_ROUNDING
from iceimpact.solvers.exact import Flight
from iceimpact.solvers.search.rootfind import RootSearch

# --- the root search at scales whose squares underflow ------------------------------------------

@pytest.mark.parametrize("speed", [2.5818798841184776e-288, 2.5818798841184776e-8])
def test_a_sticking_separation_at_scales_whose_squares_underflow_is_found(speed):
    """The random search's pair together at x = 0 moving at 2.6e-288 m/s, no drag, no flow: they
    ring together, x = (v0 / W) sin(W t) with W^2 = k / (m + M), and the contact force
    M k x / (m + M) turns tensile at t = pi / W, where the bodies part. The bounds on the force's
    derivatives (sums of squares of 1e-284) underflowed to 0, which told the search the force
    was linear, and then its Taylor stretch (a discriminant underflowing) spanned 1e14 s: the
    bodies stayed stuck through the tensile half-period (impulses of -0.1 of the momentum). The
    separation is now found at pi / W at any scale."""
    scene = Scene(structure_m=0.005189569780122153, structure_c=0.0,
                  structure_k=108.73418605233162, structure_x0=0.0, structure_v0=speed,
                  ice_M=0.005189569780122153, ice_A=1.0, ice_Cd=0.0, ice_z0=0.0, ice_v0=speed,
                  impact_e=0.0, drag_model=1, flow_u=0.0, solver_method=1)
    sim = Simulator(scene)
    for _ in range(5):
        r = sim.advance(0.01, 0.0)
        assert r.impulse >= 0.0 and r.gap >= 0.0
    apart = math.pi / math.sqrt(scene.structure_k / (scene.structure_m + scene.ice_M))
    assert not sim.sticking and isinstance(sim.solver.seg, Flight)
    assert abs(sim.solver.seg.t0 - apart) <= 1e-12


def test_a_pair_1e_240_m_from_equilibrium_parts_after_a_quarter_period():
    """The random search's stiff pair (W = sqrt(k / (m + M)) = 6.5e6 rad/s) resting together
    4.7e-240 m from the spring's rest point under a linear drag and a flow of +-2.2e-308 m/s:
    the contact force M k x / (m + M) (drag terms of relative size 1e-3 over the 2.4e-7 s)
    turns tensile at a quarter period, pi / (2 W). Its probes underflowed as above and the
    bodies stayed stuck with tensile impulses of -3.3e-230 N.s per 0.1 ms step."""
    scene = Scene(structure_m=245311.84342942314, structure_c=0.0,
                  structure_k=1.1008881654443012e+19, structure_x0=4.663560638713423e-240,
                  structure_v0=0.0, ice_M=12576.335271001795, ice_A=35.963144812094825,
                  ice_Cd=1.5558576617826123, ice_z0=4.663560638713423e-240, ice_v0=0.0,
                  impact_e=0.0, drag_model=1, drag_v_lin=0.2423178017375031,
                  flow_u=-2.2250738585072014e-308, solver_method=1)
    sim = Simulator(scene)
    u = scene.flow_u
    quarter = 0.5 * math.pi / math.sqrt(scene.structure_k / (scene.structure_m + scene.ice_M))
    for i in range(50):
        r = sim.advance(1e-4, u if i % 2 == 0 else -u)
        assert r.impulse >= 0.0 and r.gap >= 0.0
        assert math.isfinite(r.x) and math.isfinite(r.z)
        if i == 0:  # the flight that follows starts at the separation
            assert isinstance(sim.solver.seg, Flight)
            assert abs(sim.solver.seg.t0 - quarter) <= 1e-6 * quarter
    assert sim.impact_count == 0 and not sim.sticking


@pytest.mark.parametrize("exponent", [-1000, -960, 900])
def test_the_root_search_does_not_depend_on_the_scale_of_its_signal(exponent):
    """f = s cos t (|f''|, |f'''| <= s), first root pi / 2: the same root, to the bit, for s = 1
    and for scales whose squares underflow (2^-960, 2^-1000, subnormal) or overflow (2^900); and
    the amplitude bound of a free response at such scales is the scaled one."""
    def root_for(s):
        def probe(t):
            return s * math.cos(t), -s * math.sin(t), -s * math.cos(t), s, s
        search = RootSearch(0.0, TIME_RESOLUTION)
        return search.next_root_before(10.0, probe, lambda t: s * math.cos(t),
                                       lambda t: (s * math.cos(t), -s * math.sin(t)))
    scale = math.ldexp(1.0, exponent)
    assert root_for(scale) == root_for(1.0)
    assert abs(root_for(1.0) - 0.5 * math.pi) <= 1e-15 + 2e-15 * 0.5 * math.pi  # its tolerance
    osc = Oscillator(2.0, 0.0, 8.0)  # omega_n = 2
    if exponent > -1000:  # (a subnormal scale keeps fewer bits)
        assert osc.amplitude_bound(3.0 * scale, 8.0 * scale) == pytest.approx(5.0 * scale,
                                                                               rel=1e-15)


#: random-search scenes at the ends of double precision where nothing can happen (the ice out of
#: reach or at rest, no drag or no flow): (scene, communication step, flow of steps 0-3 in turn)
FROZEN_EXTREMES = {
    # the ice 0.067 m beyond the reach of a stiff structure, crawling at 1e-308 m/s: the
    # clearance (margin / speed) was 6e306 s, and the gap was evaluated at omega_n t = inf
    # (ValueError from math.cos); the search's k was 3.77e11 N/m, now above method 1's sticking
    # rate rule (TAYLOR_RATE_MAX) with quadratic drag: 3.0e10 keeps the scene within it, the
    # structure's reach and the ice's crawl as they were
    "ice crawling at 1e-308 m/s": (dict(
        structure_m=0.00043926462461252146, structure_c=0.0, structure_k=3.0e10,
        structure_x0=-0.41809125917960344, structure_v0=1.1125369292536007e-308,
        ice_M=3.306966185946854, ice_A=0.004425684103770009, ice_Cd=1e-15,
        ice_z0=-0.48545371398205006, ice_v0=1.1125369292536007e-308,
        impact_e=0.21608311446586376, drag_model=2, drag_v_lin=0.0016833848398599407,
        flow_u=0.0), 1e-4, (0.0,) * 4),
    # a structure ringing with 2e-196 m, the ice 0.022 m away: d2^2 and jerk * df both
    # underflow in the root search (a division by their sum, 0)
    "structure ringing with 2e-196 m": (dict(
        structure_m=5.047249916897516e-05, structure_c=0.0, structure_k=117694843.24735996,
        structure_x0=0.0, structure_v0=-3.042972614185134e-190, ice_M=5.047249916897518e-05,
        ice_A=0.004359259021143864, ice_Cd=0.0, ice_z0=-0.02210596527455649, ice_v0=0.0,
        impact_e=1.0, drag_model=1, drag_v_lin=0.0037798570126214757, flow_u=0.0), 0.37,
        (0.1, 0.1, 0.1, -0.1)),
    # the ice 2.2e-309 m (subnormal) upstream of a structure at rest: a probe of subnormal size
    # (its scale 2^1073 overflows; at most 2^1000 is used)
    "gap of 2.2e-309 m": (dict(
        structure_m=1.0, structure_c=197.9384957220146, structure_k=9794.9120221735,
        structure_x0=0.0, structure_v0=0.0, ice_M=1.0, ice_A=1.0, ice_Cd=0.0,
        ice_z0=-2.225073858507203e-309, ice_v0=0.0, impact_e=1.0, drag_model=2,
        drag_v_lin=1.1650348848649137, flow_u=0.0), 1e-3, (0.1,) * 4),
}


@pytest.mark.parametrize("name", list(FROZEN_EXTREMES))
def test_scenes_at_the_ends_of_double_precision_run_soundly(name):
    kw, h, flows = FROZEN_EXTREMES[name]
    scene = Scene(**kw, solver_method=1)
    sim = Simulator(scene)
    # the structure's envelope: |x| <= sqrt(x0^2 + (v0 / omega_n)^2) (its energy), the ice still
    lowest = -math.hypot(scene.structure_x0, scene.structure_v0 / scene.omega_n) - scene.ice_z0
    for i in range(8):
        r = sim.advance(h, flows[i % 4])
        values = (r.x, r.v, r.z, r.w, r.gap, r.impulse)
        assert all(map(math.isfinite, values)) and r.impulse == 0.0
        assert r.gap >= lowest - GAP_ROUNDING  # out of reach
    assert sim.impact_count == 0
