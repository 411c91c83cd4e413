"""The no-miss root search (solvers/rootfind.py): Newton's method on monotone stretches against
closed-form roots and against the brentq path, close roots, convex and concave crossings."""

from __future__ import annotations

import gc
import math

import pytest

from iceimpact.solvers.rootfind import RootSearch, Signal


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
