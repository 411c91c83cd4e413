"""Property tests over random valid scenes (hypothesis)."""

import math

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from iceimpact import ParameterError, Scene, Simulator


@st.composite
def scenes(draw):
    """Valid scenes over the extremes: M/m from 1e-3 to 1e3, omega_n from 0.1 to 1e4 rad/s,
    zeta from 0 to 5 (0, 1 - 1e-8 and 1 exactly included), flows from -1 to 10 m/s (0 and
    1e-6 included), the ice starting in contact or up to 5 cm away, at the structure's speed
    or not. Combinations that validation refuses (docs/explanation/robustness/limits.md) are not
    scenes to run."""
    m = draw(st.floats(1.0, 1e6))
    omega_n = 10 ** draw(st.floats(-1.0, 4.0))
    zeta = draw(st.one_of(st.just(0.0), st.just(1.0), st.just(1 - 1e-8), st.floats(0.0, 5.0)))
    k = m * omega_n ** 2
    x0 = draw(st.one_of(st.just(0.0), st.floats(-0.01, 0.01)))
    v0 = draw(st.floats(-0.1, 0.1))
    values = dict(
        structure_m=m, structure_k=k, structure_c=2.0 * zeta * math.sqrt(k * m),
        structure_x0=x0, structure_v0=v0,
        ice_M=m * 10 ** draw(st.floats(-3.0, 3.0)), ice_A=draw(st.floats(0.01, 10.0)),
        ice_Cd=draw(st.one_of(st.just(0.0), st.floats(0.0, 2.0))),
        ice_z0=x0 - draw(st.one_of(st.just(0.0), st.floats(0.0, 0.05))),
        ice_v0=draw(st.one_of(st.just(v0), st.floats(-0.2, 1.0))),
        impact_e=draw(st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 1.0))),
        drag_model=draw(st.sampled_from([1, 2])),
        flow_u=draw(st.one_of(st.just(0.0), st.just(1e-6), st.floats(-1.0, 10.0))))
    try:
        return Scene(**values)
    except ParameterError:
        assume(False)


def _stepped(scene, h, t_end):
    sim = Simulator(scene)
    reports = []
    while sim.t < t_end - 1e-12:
        reports.append(sim.advance(h))
    return sim, reports


# derandomize: CI runs a fixed, reviewed set of examples; exploration with fresh seeds is done
# by hand (hypothesis --hypothesis-seed) before changes to the solver land
@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(scene=scenes())
def test_random_scenes_are_sound(scene):
    h = 0.01
    sim, reports = _stepped(scene, h, 3.0)
    values = np.array([[r.x, r.v, r.z, r.w, r.gap, r.impulse, r.force, r.t_last]
                       for r in reports])
    assert np.all(np.isfinite(values))
    assert min(r.x - r.z for r in reports) >= -1e-12
    for i in sim.impacts:
        before = scene.structure_m * i.v_minus + scene.ice_M * i.w_minus
        after = scene.structure_m * i.v_plus + scene.ice_M * i.w_plus
        scale = scene.structure_m * abs(i.v_minus) + scene.ice_M * abs(i.w_minus)
        assert abs(after - before) <= 1e-12 * scale + 1e-300
        assert i.w_minus - i.v_minus >= 0.0
    # the first 10 impact times do not depend on the communication step
    sim7, _ = _stepped(scene, h / 7, 3.0)
    a = [i.t for i in sim.impacts[:10]]
    b = [i.t for i in sim7.impacts[:10]]
    assert len(a) == len(b)
    assert np.allclose(a, b, rtol=0, atol=1e-9)
