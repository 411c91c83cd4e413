"""Property tests over random valid scenes (hypothesis)."""

import numpy as np
from hypothesis import HealthCheck, given, settings

from iceimpact import Simulator
from scene_strategies import scenes


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
