"""Impact counts of long runs and rounding
(docs/explanation/accuracy.md#impact-counts-and-rounding).

The two impact-heavy e = 1 scenes of ``benchmarks/core_speed.py`` whose counts moved most when the
root search changed: every flight of the exact solver agrees with an independent DOP853
integration (``ode_reference``) to rounding, yet the whole trajectories part within 20-40
impacts, because the motion amplifies any rounding; the count over 100 s moves by far more than
2 % when the ice's start moves by 1e-15 m; and the count over 1,000 s is the count up to the
chatter sequence that ends in permanent sticking, whose time is as sensitive.
"""

import numpy as np
import pytest

from iceimpact import Scene, run
from ode_reference import simulate as ode_simulate

SCENES = {"quadratic_A2": Scene(drag_model=2, ice_A=2.0),
          "heavy_floe": Scene(ice_M=6400.0, flow_u=2.0)}
#: impacts compared: a little beyond where the two trajectories have parted by 1e-3 s (about
#: impact 22 and 38)
FLIGHTS = {"quadratic_A2": 30, "heavy_floe": 45}


@pytest.mark.parametrize("name", list(SCENES))
def test_every_flight_agrees_with_ode_while_the_trajectories_part(name):
    """Restarted from each of the exact solver's post-impact states, DOP853 at rtol 1e-13 finds
    the next impact within 1e-11 s (measured: 1e-13 s), flight after flight, through the impacts
    where one DOP853 run from t = 0 has moved more than 1e-3 s away from the exact solver: the
    parting is the amplification of rounding, not a wrong flight."""
    scene, n = SCENES[name], FLIGHTS[name]
    exact = run(scene, 40.0).impacts
    assert len(exact) > n and np.all(exact["restitution"][:n + 1] == 1.0)
    for i in range(n):
        y0 = [exact["x"][i], exact["v_plus"][i], exact["x"][i], exact["w_plus"][i]]
        nxt = ode_simulate(scene, exact["t"][i] + 10.0, max_impacts=1, rtol=1e-13, atol=1e-16,
                           t0=exact["t"][i], y0=y0)
        assert len(nxt["t"]) == 1
        assert abs(nxt["t"][0] - exact["t"][i + 1]) < 1e-11, i
    whole = ode_simulate(scene, 40.0, max_impacts=n, rtol=1e-13, atol=1e-16)["t"]
    assert len(whole) == n
    shift = np.abs(whole - exact["t"][:n])
    assert shift[0] < 1e-12
    assert shift.max() > 1e-3


@pytest.mark.parametrize("name", list(SCENES))
def test_count_over_100_s_moves_more_than_2_percent_under_a_1e15_m_move(name):
    """The ice's start moved by 0 to 5e-15 m (``core_speed.py --spread``): the impact counts
    over 100 s spread over more than 2 % of their mean (measured: 36 % and 89 %), while the first
    impacts stay put."""
    scene = SCENES[name]
    counts, first = [], []
    for move in np.linspace(0.0, 5e-15, 6):
        impacts = run(scene.replace(ice_z0=scene.ice_z0 - move), 100.0).impacts
        counts.append(len(impacts))
        first.append(impacts["t"][0])
    assert (max(counts) - min(counts)) / np.mean(counts) > 0.02
    assert max(first) - min(first) < 1e-12


@pytest.mark.parametrize("name", list(SCENES))
def test_count_over_1000_s_is_the_count_until_the_motion_sticks(name):
    """The elastic chatter closes with one plastic impact (the chatter closure) and the bodies
    stick for good: every impact before is elastic, none follows, so 1,000 s count the same
    impacts as 300 s."""
    scene = SCENES[name]
    short, long = run(scene, 300.0), run(scene, 1000.0, dt=0.1)
    assert short.sticking_since is not None and short.sticking_since < 300.0
    restitution = short.impacts["restitution"]
    assert restitution[-1] == 0.0 and np.all(restitution[:-1] == 1.0)
    assert short.impacts["t"][-1] == short.sticking_since
    assert len(long.impacts) == len(short.impacts)
    assert long.sticking[long.t > short.sticking_since].all()
