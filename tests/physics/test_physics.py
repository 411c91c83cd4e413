"""Closed forms of the free flights and the impact law, each against an independent check."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from iceimpact.physics.contact import contact_force, impact, impact_energy_loss, impact_impulse
from iceimpact.physics.ice import LinearDrag, QuadraticDrag
from iceimpact.physics.structure import CRITICAL, OVER, UNDER, Oscillator

TIMES = [1e-6, 0.01, 0.3, 1.0, 7.0, 40.0]


def _ode_oscillator(osc, x0, v0, t):
    def rhs(_, y):
        return [y[1], -(osc.damping * y[1] + osc.stiffness * (y[0] - osc.offset)) / osc.mass]

    sol = solve_ivp(rhs, (0, max(t)), [x0, v0], method="DOP853", rtol=1e-13, atol=1e-16,
                    dense_output=True)
    return sol.sol(np.asarray(t))


# (mass, damping, stiffness, offset): undamped, under-damped (the article's), zeta just below 1,
# critical exactly, over-damped zeta = 5, a shifted equilibrium (the sticking phase's form)
OSCILLATORS = [
    (1600.0, 0.0, 1e6, 0.0),
    (1600.0, 200.0, 1e6, 0.0),
    (1.0, 2.0 * (1 - 1e-9), 1.0, 0.0),
    (4.0, 8.0, 4.0, 0.0),
    (1.0, 10.0, 1.0, 0.0),
    (3200.0, 250.0, 1e6, 5e-6),
]


@pytest.mark.parametrize("params", OSCILLATORS)
def test_oscillator_matches_ode(params):
    osc = Oscillator(*params)
    x0, v0 = 1e-3, -0.02
    ref = _ode_oscillator(osc, x0, v0, TIMES)
    scale = abs(x0) + abs(v0) / math.sqrt(osc.omega2)
    for i, t in enumerate(TIMES):
        x, v = osc.response(x0, v0, t)
        assert x == pytest.approx(ref[0, i], abs=1e-10 * scale)
        assert v == pytest.approx(ref[1, i], abs=1e-10 * scale * math.sqrt(osc.omega2) + 1e-14)
    xa, va = osc.response_array(x0, v0, np.array(TIMES))
    assert np.allclose(xa, ref[0], atol=1e-10 * scale, rtol=0)
    # the increments from the anchor, per sample anchors (run()'s vectorised sampling)
    anchors = np.full(len(TIMES), x0), np.full(len(TIMES), v0)
    dx, vd = osc.displacement_change_array(*anchors, np.array(TIMES))
    assert np.allclose(x0 + dx, ref[0], atol=1e-10 * scale, rtol=0)
    assert np.allclose(vd, ref[1], atol=1e-10 * scale * math.sqrt(osc.omega2) + 1e-14, rtol=0)


@pytest.mark.parametrize("params", OSCILLATORS)
def test_vectorised_increments_equal_the_scalar_ones(params):
    """displacement_change_array is displacement_change to rounding, across the over-damped
    branch switch (wo t = 1) and at small t, where the increment is far below x0."""
    osc = Oscillator(*params)
    t = np.concatenate([np.geomspace(1e-9, 50.0, 60),
                        [1.0 / osc.omega * (1 + d) for d in (-1e-9, 0.0, 1e-9) if osc.omega]])
    x0, v0 = 0.3 + np.linspace(0, 1, len(t)), -0.02 + np.zeros(len(t))
    dx, v = osc.displacement_change_array(x0, v0, t)
    for i, ti in enumerate(t.tolist()):
        dx_s, v_s = osc.displacement_change(float(x0[i]), float(v0[i]), ti)
        assert dx[i] == pytest.approx(dx_s, rel=1e-13, abs=1e-16 * abs(x0[i]))
        assert v[i] == pytest.approx(v_s, rel=1e-13, abs=1e-15)


def test_oscillator_regimes_are_decided_exactly():
    assert Oscillator(1.0, 0.0, 1.0).regime == UNDER
    assert Oscillator(4.0, 8.0, 4.0).regime == CRITICAL  # c = 2 sqrt(k m) exactly
    assert Oscillator(1.0, 10.0, 1.0).regime == OVER
    # continuity across critical damping
    below = Oscillator(1.0, 2.0 - 1e-7, 1.0).response(1.0, 0.5, 2.0)
    at = Oscillator(1.0, 2.0, 1.0).response(1.0, 0.5, 2.0)
    above = Oscillator(1.0, 2.0 + 1e-7, 1.0).response(1.0, 0.5, 2.0)
    assert below == pytest.approx(at, rel=1e-6)
    assert above == pytest.approx(at, rel=1e-6)


def test_overdamped_long_times_do_not_overflow():
    osc = Oscillator(1.0, 1e4, 1.0)  # zeta = 5000
    x, v = osc.response(1.0, 0.0, 1e5)
    assert math.isfinite(x) and math.isfinite(v)
    # slow mode e^{-t wn^2 / (2 sigma)} approximately
    assert x == pytest.approx(math.exp(-1e5 * 1e-4), rel=1e-3)


@pytest.mark.parametrize("params", OSCILLATORS)
def test_bounds_are_the_derivatives_and_their_amplitude_bounds(params):
    """Oscillator.bounds (one call per root-search step) writes the energy bound out: the same
    numbers, to the bit, as derivatives() and amplitude_bound(), in every regime; and the
    bounds hold over the later response (acceleration and jerk from the equation of motion)."""
    osc = Oscillator(*params)
    rng = np.random.default_rng(7)
    for x, v in [(1e-3, -0.02), (0.0, 0.0), (-3.7e-9, 1e-12), *rng.normal(size=(20, 2))]:
        a, j, s = osc.derivatives(x, v)
        assert osc.bounds(x, v) == (a, osc.amplitude_bound(a, j), osc.amplitude_bound(j, s))
    x0, v0 = 1e-3, -0.02
    a0, a_max, j_max = osc.bounds(x0, v0)
    t = np.linspace(0, 50, 20001)
    x, v = osc.response_array(x0, v0, t)
    acc = -(osc.damping * v + osc.stiffness * (x - osc.offset)) / osc.mass
    jerk = -(osc.damping * acc + osc.stiffness * v) / osc.mass
    assert acc[0] == pytest.approx(a0, rel=1e-12)
    assert np.all(np.abs(acc) <= a_max * (1 + 1e-12))
    assert np.all(np.abs(jerk) <= j_max * (1 + 1e-12))


def test_extrapolated_structure_bounds_and_increment():
    """The external structure within a step: constant acceleration, zero jerk; its increment
    from an anchor is the polynomial x - x0 = v0 t + a t^2 / 2."""
    from iceimpact.physics.external import ExtrapolatedStructure

    ext = ExtrapolatedStructure(-2.5)
    a, j, s = ext.derivatives(0.3, 0.1)
    assert ext.bounds(0.3, 0.1) == (a, ext.amplitude_bound(a, j), ext.amplitude_bound(j, s))
    assert ext.bounds(0.3, 0.1) == (-2.5, 2.5, 0.0)
    motion = ext.increment(0.3, 0.1)
    for t in (0.0, 0.01, 1.7):
        assert motion(t) == pytest.approx((0.1 * t - 1.25 * t * t, 0.1 - 2.5 * t), abs=1e-15)
        assert motion(t) == ext.displacement_change(0.3, 0.1, t)


@pytest.mark.parametrize("params", OSCILLATORS)
def test_amplitude_bound_holds_for_acceleration(params):
    osc = Oscillator(*params)
    x0, v0 = 1e-3, -0.02
    a0, j0, _ = osc.derivatives(x0, v0)
    bound = osc.amplitude_bound(a0, j0)
    t = np.linspace(0, 50, 20001)
    x, v = osc.response_array(x0, v0, t)
    acc = -(osc.damping * v + osc.stiffness * (x - osc.offset)) / osc.mass
    assert np.all(np.abs(acc) <= bound * (1 + 1e-12))


def _ode_ice(drag, z0, w0, u, t):
    def rhs(_, y):
        return [y[1], drag.force(y[1], u) / drag.mass]

    sol = solve_ivp(rhs, (0, max(t)), [z0, w0], method="DOP853", rtol=1e-13, atol=1e-16,
                    dense_output=True)
    return sol.sol(np.asarray(t))


@pytest.mark.parametrize("drag", [LinearDrag(1600.0, 49.95), QuadraticDrag(1600.0, 499.5),
                                  QuadraticDrag(400.0, 999.0)], ids=["linear", "quad", "quad2"])
@pytest.mark.parametrize("w0,u", [(0.01, 0.1), (0.3, 0.1), (-0.05, 0.1), (0.02, 0.0),
                                  (0.1, 0.1), (0.0, -0.2)])
def test_ice_matches_ode(drag, w0, u):
    z0 = -0.01
    ref = _ode_ice(drag, z0, w0, u, TIMES)
    for i, t in enumerate(TIMES):
        z, w = drag.motion(z0, w0, u, t)
        assert z == pytest.approx(ref[0, i], abs=1e-11)
        assert w == pytest.approx(ref[1, i], abs=1e-12)
    za, wa = drag.motion_array(z0, w0, u, np.array(TIMES))
    assert np.allclose(za, ref[0], atol=1e-11, rtol=0)
    assert np.allclose(wa, ref[1], atol=1e-12, rtol=0)
    dz, wd = drag.displacement_change_array(np.full(len(TIMES), w0), u, np.array(TIMES))
    assert np.allclose(z0 + dz, ref[0], atol=1e-11, rtol=0)
    assert np.array_equal(wd, wa)


@pytest.mark.parametrize("drag", [LinearDrag(10.0, 0.0), QuadraticDrag(10.0, 0.0)])
def test_no_drag_ice_coasts(drag):
    assert drag.motion(1.0, 0.5, 0.3, 4.0) == (3.0, 0.5)


@pytest.mark.parametrize("drag", [LinearDrag(1600.0, 49.95), QuadraticDrag(1600.0, 499.5)])
def test_ice_acceleration_bounds_hold(drag):
    u = 0.1
    t = np.linspace(0, 30, 3001)
    for w0 in (-0.3, 0.05, 0.4):
        _, wa = drag.motion_array(0.0, w0, u, t)
        acc = np.array([drag.force(w, u) for w in wa]) / drag.mass
        _, acc_max, jerk_max = drag.accel_bounds(w0, u)
        assert np.all(np.abs(acc) <= acc_max * (1 + 1e-12))
        jerk = np.gradient(acc, t)
        assert np.all(np.abs(jerk[1:-1]) <= jerk_max * (1 + 1e-3))


@pytest.mark.parametrize("e", [0.0, 0.1, 0.5, 1.0])
@pytest.mark.parametrize("masses", [(1600.0, 1600.0), (1600.0, 1.6), (1600.0, 1.6e6)])
def test_impact_law(e, masses):
    m, M = masses
    v, w = -0.003, 0.012
    v_plus, w_plus = impact(v, w, m, M, e)
    # eq. 12: momentum
    assert m * v_plus + M * w_plus == pytest.approx(m * v + M * w, rel=1e-14, abs=1e-18)
    # eq. 13: restitution
    assert v_plus - w_plus == pytest.approx(e * (w - v), rel=1e-12, abs=1e-16)
    ke_before = 0.5 * m * v * v + 0.5 * M * w * w
    ke_after = 0.5 * m * v_plus ** 2 + 0.5 * M * w_plus ** 2
    loss = impact_energy_loss(v, w, m, M, e)
    assert ke_before - ke_after == pytest.approx(loss, rel=1e-9, abs=1e-14 * ke_before)
    if e == 1.0:
        assert ke_after == pytest.approx(ke_before, rel=1e-13)
    assert impact_impulse(v, v_plus, m) == pytest.approx(-M * (w_plus - w), rel=1e-12)


def test_contact_force_sign():
    # ice pushed towards the structure (a_z > a_x): compressive, positive
    assert contact_force(-1.0, 0.5, 2.0, 2.0) == pytest.approx(1.5)
    assert contact_force(1.0, -0.5, 2.0, 2.0) < 0.0


@pytest.mark.parametrize("y0, v0", [(1.0, 0.0), (-7.7e12, 0.1), (3.0, -2.0)])
def test_deviation_integral_matches_quadrature(y0, v0):
    """``Oscillator.deviation_integral`` (int_0^t (y - y0) dt', on the two exponents) against
    adaptive quadrature of the closed-form response minus y0, well over-damped, at times
    inside the series (|s t| < 0.01) and past it."""
    from scipy.integrate import quad

    osc = Oscillator(2.0, 40.0, 3.0)
    assert osc.two_modes
    for t in (1e-4, 0.05, 0.7, 30.0):
        increment = osc.deviation_increment(y0, v0)
        exact, err = quad(lambda s, increment=increment: increment(s)[0], 0.0, t,
                          epsabs=0.0, epsrel=1e-13, limit=200)
        assert float(osc.deviation_integral(y0, v0, t)) == pytest.approx(exact, rel=1e-10,
                                                                         abs=1e-300)


# the C library's functions element by element (physics/elementwise.py) ---------------------------
@pytest.mark.parametrize("name", ["exp", "expm1", "log1p", "sin", "cos", "sinh", "cosh"])
def test_elementwise_functions_are_maths_to_the_bit(name):
    """Each element is Python's math function of it, to the bit (compiled by numba where it is
    installed, the same C library): over ten thousand arguments from 1e-300 to 700 in size, of
    either sign, and over the arguments the closed forms of a run use."""
    import warnings

    from iceimpact.physics import elementwise

    rng = np.random.default_rng(17)
    x = np.concatenate([np.sign(rng.standard_normal(5000)) * 10 ** rng.uniform(-300, 2.8, 5000),
                        rng.uniform(-40.0, 0.0, 4995), [0.0, -0.0, 1e-320, -0.7, 0.5]])
    scalar = getattr(math, name)
    expected = []
    for v in x.tolist():
        try:
            expected.append(scalar(v))
        except (OverflowError, ValueError):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                expected.append(float(getattr(np, name)(v)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = getattr(elementwise, name)(x.reshape(100, -1)).ravel()
    assert [v.hex() for v in got.tolist()] == [float(v).hex() for v in expected]


def test_elementwise_refused_elements_are_numpys_with_its_warning():
    """An element math refuses (exp(1000), log1p(-2)) is numpy's value with numpy's warning,
    compiled or not; the other elements are math's."""
    from iceimpact.physics import elementwise

    with pytest.warns(RuntimeWarning):
        out = elementwise.exp(np.array([1.0, 1000.0]))
    assert out[0] == math.exp(1.0) and out[1] == math.inf
    with pytest.warns(RuntimeWarning):
        out = elementwise.log1p(np.array([-2.0, 0.5]))
    assert math.isnan(out[0]) and out[1] == math.log1p(0.5)
    assert elementwise.sin(0.25).shape == () and elementwise.sin(0.25) == math.sin(0.25)
