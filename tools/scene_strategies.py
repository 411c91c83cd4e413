"""Hypothesis strategies of random valid scenes: the property tests' and the random search's
(tools/random_search.py) draws."""

import math

from hypothesis import assume
from hypothesis import strategies as st

from iceimpact import ParameterError, Scene


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
