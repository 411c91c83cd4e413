"""The no-miss root search (solvers/search/rootfind.py): Newton's method on monotone stretches
against closed-form roots and against the brentq path, close roots, convex and concave crossings."""

from __future__ import annotations

import gc
import math

import numpy as np
import pytest

from iceimpact.solvers.search.rootfind import RootSearch, Signal


def _polynomial(coefficients):
    """f(t) = sum c_k t^k with its probe (f, f', f'', K, J) and (f, f')."""
    c = list(coefficients) + [0.0] * (4 - len(coefficients))
    if any(c[4:]):
        raise ValueError("cubic at most")

    def f(t):
        return c[0] + t * (c[1] + t * (c[2] + t * c[3]))

    def df(t):
        return c[1] + t * (2 * c[2] + 3 * t * c[3])

    def probe(t):
        d2 = 2 * c[2] + 6 * c[3] * t
        # bounds for all later times: a cubic's curvature grows without bound unless c3 = 0
        return f(t), df(t), d2, abs(d2) if c[3] == 0 else math.inf, 6 * abs(c[3])

    return f, probe, lambda t: (f(t), df(t))


def _exponential(level):
    """f(t) = e^{-t} - level (convex, decreasing): every derivative is bounded by e^{-t}."""
    def f(t):
        return math.exp(-t) - level

    def probe(t):
        e = math.exp(-t)
        return e - level, -e, e, e, e

    return f, probe, lambda t: (f(t), -math.exp(-t))


def _cosine(level):
    """f(t) = cos t - level: every derivative is bounded by 1; concave before pi/2."""
    def probe(t):
        return math.cos(t) - level, -math.sin(t), -math.cos(t), 1.0, 1.0

    return (lambda t: math.cos(t) - level), probe, lambda t: (math.cos(t) - level, -math.sin(t))


class _Search:
    """A RootSearch with its signal: Newton's method if ``rate`` is given, else brentq."""

    def __init__(self, probe, f, rate=None, start=0.0):
        self.search = RootSearch(start, 1e-16)
        self.signal = (probe, f, rate)

    def next_root_before(self, horizon):
        return self.search.next_root_before(horizon, *self.signal)

    @property
    def iterations(self):
        return self.search.iterations


def _searches(f, probe, rate, start=0.0):
    return _Search(probe, f, rate, start), _Search(probe, f, None, start)


@pytest.mark.parametrize("case,root", [
    # concave: the first Newton point overshoots and brackets the root
    (_cosine(0.25), math.acos(0.25)),
    (_cosine(-0.999), math.acos(-0.999)),
    # convex: Newton approaches from above and never crosses
    (_exponential(0.5), math.log(2.0)),
    (_exponential(1e-6), math.log(1e6)),
])
def test_newton_and_brentq_find_the_same_first_root(case, root):
    f, probe, rate = case
    newton, bracketed = _searches(f, probe, rate)
    found = newton.next_root_before(1e3)
    reference = bracketed.next_root_before(1e3)
    assert found == pytest.approx(root, rel=4e-15, abs=2e-15)
    assert found == pytest.approx(reference, rel=4e-15, abs=2e-15)


def test_the_first_of_two_close_roots_is_found():
    """f = (t - 1)(t - 1.001): below zero for 1 ms only, which a grid would step over."""
    r1, r2 = 1.0, 1.001
    f, probe, rate = _polynomial([r1 * r2, -(r1 + r2), 1.0])
    search = _Search(probe, f, rate)
    # the coefficients' rounding (1e-16) moves the root by ~1e-16 / (r2 - r1)
    assert search.next_root_before(10.0) == pytest.approx(r1, abs=1e-12)
    assert search.iterations < 60


def test_a_touch_without_crossing_is_no_root():
    """f = (t - 1)^2 touches zero at t = 1 and rises again: no root, the frontier moves past."""
    f, probe, rate = _polynomial([1.0, -2.0, 1.0])
    found = _Search(probe, f, rate).next_root_before(3.0)
    # a touch is reported only where f is zero to rounding (f'' h^2 / 2 at the ulp level)
    assert found is None or abs(found - 1.0) < 1e-7


def test_newton_takes_fewer_evaluations_than_brentq():
    f, probe, rate = _exponential(0.5)
    calls = {"newton": 0, "brentq": 0}

    def counted(fn, key):
        def wrapper(t):
            calls[key] += 1
            return fn(t)
        return wrapper

    _Search(probe, counted(f, "newton"), counted(rate, "newton")).next_root_before(10.0)
    _Search(probe, counted(f, "brentq")).next_root_before(10.0)
    assert calls["newton"] < calls["brentq"]


def test_the_search_holds_its_signal_only_during_a_call():
    """No reference from the search to its segment between calls: no cycle to collect."""
    f, probe, rate = _exponential(0.5)
    search = RootSearch(0.0, 1e-16)
    assert search.next_root_before(0.1, probe, f, rate) is None
    held = [r for r in gc.get_referents(search) if r is not RootSearch]  # (and its class)
    assert not any(callable(r) or isinstance(r, Signal) for r in held)
    assert search.next_root_before(10.0, probe, f, rate) == pytest.approx(math.log(2.0))


# --- probes whose values lie far apart (docs/explanation/robustness/flights.md#probes-far-apart)

def _first_stretch(probe: tuple[float, float, float, float, float]) -> float:
    """The frontier after one step of a search from 0 on a signal with this probe, its value
    staying >= 0 (no sign test finds a crossing)."""
    search = RootSearch(0.0, 1e-300)
    search.next_root_before(0.0, lambda t: probe, lambda t: 1.0)
    return search.a


def _proven_stretch(probe: tuple[float, float, float, float, float]) -> float:
    """The longest stretch its bounds prove root-free, in 60-digit decimal arithmetic: the Taylor
    stretch (f + f' h - K h^2 / 2 >= 0) or, falling (f' < 0), the monotone one, where
    f' + f'' s + J s^2 / 2 (and f' + K s) stays < 0, whichever is longer."""
    from decimal import Decimal, localcontext

    with localcontext() as ctx:
        ctx.prec = 60
        f, df, d2, bound, jerk = (Decimal(value) for value in probe)
        free = (df + (df * df + 2 * bound * f).sqrt()) / bound
        mono = -df / bound
        if df < 0 and jerk > 0:
            mono = max(mono, (-d2 + (d2 * d2 - 2 * jerk * df).sqrt()) / jerk)
        return float(max(free, mono))


#: (name, probe (f, f', f'', K, J)) in a time unit of 2^-300 s and a value unit of 2^-900:
#: balanced ones whose squares then underflow
FAR_APART = {
    # f'^2 and K f both underflowed: the Taylor stretch came out as f / -f', 1415 times too long
    "falling, K decides": (1.0, -1e-3, 0.0, 1.0, 1.0),
    # f''^2 and J f' both underflowed in the monotone stretch's refinement (f'' > 0), which came
    # out as -2 f' / f'', 4.5 times the stretch the bounds prove
    "falling, f'' > 0 and J decide": (1.0, -1e-20, 1e-10, 1.0, 1.0),
    # the ordinary cases, for the rescaling itself
    "rising": (1.0, 0.5, -0.25, 1.0, 2.0),
    "falling, f'' < 0": (1.0, -0.5, -0.25, 1.0, 2.0),
}


@pytest.mark.parametrize("name", list(FAR_APART))
def test_probes_with_values_far_apart_prove_what_their_bounds_prove(name):
    """A probe is homogeneous: in a time unit tau every step length is tau times that of
    (f, f' tau, f'' tau^2, K tau^2, J tau^3). With tau = 2^-300 (and values times 2^-900, so that J
    is about 1) the squares and products of the step lengths underflowed, the scaling of all five
    values by one factor (for scales whose squares underflow) cannot help, and two stretches came
    out longer than their bounds prove (unsound). Each probe is now rescaled in time as well
    (``rootfind.balanced``): the stretch is exactly tau times the balanced probe's, and the proven
    one (decimal arithmetic) to rounding."""
    unit = FAR_APART[name]
    tau, scale = 2.0 ** -300, 2.0 ** -900
    far = tuple(value * scale / tau ** degree
                for value, degree in zip(unit, (0, 1, 2, 2, 3), strict=True))
    assert _first_stretch(far) == tau * _first_stretch(unit)
    assert _first_stretch(far) == pytest.approx(_proven_stretch(far), rel=1e-14)


def test_the_rescaling_is_exact_and_balances_the_exponents():
    """``balanced`` multiplies by powers of 2 only, and leaves an ordinary probe's values
    within a few binades of one another."""
    from iceimpact.solvers.search.rootfind import balanced

    probe = (1.1830521861667747e-271, -2.409919865102884e-184, 0.0, 4.909093465297727e-91, 1.0)
    *values, unit = balanced(*probe)
    p = math.frexp(unit)[1] - 1
    assert unit == math.ldexp(1.0, p)
    ratios = {value / original / unit ** degree
              for value, original, degree in zip(values, probe, (0, 1, 2, 2, 3), strict=True)
              if original}
    assert len(ratios) == 1 and math.frexp(ratios.pop())[0] == 0.5  # one power of 2
    nonzero = [abs(value) for value in values if value]
    assert max(nonzero) <= 1.0 and min(nonzero) >= 2.0 ** -20


def test_each_point_is_evaluated_once_and_a_segment_is_its_own_signal():
    """The sign test at the end of a search step is the full probe, which the next step starts
    from: no point is evaluated twice (before, the step's end was asked for its value and then
    probed). A segment-like object with the Signal's methods gives the same root as the
    functions."""
    f, probe, rate = _cosine(0.25)
    asked = []

    def counted(fn):
        def wrapped(t):
            asked.append(t)
            return fn(t)
        return wrapped

    class Segment:  # a signal as a segment gives it: methods named as Signal's attributes
        clearance = None

    segment = Segment()
    segment.probe, segment.value = counted(probe), counted(f)
    segment.value_and_rate = counted(rate)
    root = RootSearch(0.0, 1e-16).next_root_of(10.0, segment)
    assert root == pytest.approx(math.acos(0.25), abs=1e-14)
    assert len(asked) == len(set(asked))
    assert root == RootSearch(0.0, 1e-16).next_root_before(10.0, probe, f, rate)


def test_bracketed_newton_stops_when_its_step_rounds_to_the_point():
    """Newton's method inside a bracket, approaching the root from one end: where its last step
    is below half an ulp of the point it stands on, the next point rounds to that point, the end
    of the bracket. It is then converged (the step is within the tolerance); the search had
    bisected the whole bracket again (26 and 29 evaluations for 3 of these roots, up to 49 per
    impact in Figure 2's chatter), each root now takes at most 10, located as accurately."""
    rng = np.random.default_rng(1)
    counts = []
    for _ in range(2000):
        r, w, size = rng.uniform(0.05, 0.5), rng.uniform(5.0, 40.0), rng.uniform(5e-4, 2e-3)
        c, sign = math.cos(w * r), (1.0 if math.sin(w * r) > 0.0 else -1.0)
        calls = [0]

        def value_and_rate(t, w=w, size=size, c=c, sign=sign, calls=calls):
            calls[0] += 1
            return size * sign * (math.cos(w * t) - c), -size * w * abs(math.sin(w * t))
        lo, hi = r - rng.uniform(0.01, 0.3) / w, r + rng.uniform(0.01, 0.3) / w
        if not value_and_rate(lo)[0] > 0.0 > value_and_rate(hi)[0]:
            continue
        calls[0] = 0
        signal = Signal(lambda t: None, lambda t, f=value_and_rate: f(t)[0], value_and_rate)
        root = RootSearch(0.0, 1e-16)._bracketed_root(signal, lo, hi)
        assert abs(root - r) < 1e-13
        counts.append(calls[0])
    assert len(counts) > 1500
    assert max(counts) <= 10
