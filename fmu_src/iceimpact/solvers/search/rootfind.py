"""First root of a smooth signal, never missed: bounds on its higher derivatives prove where it
has none.

The signal f (the gap x - z in flight, the contact force in sticking) is known in closed form with
its first two derivatives, a bound K on |f''| and a bound J on |f'''|, both valid for all later
times. From a point a with f(a) >= 0:

- Taylor: ``f(a + h) >= f(a) + f'(a) h - K h^2 / 2``, positive up to the root ``h_free`` of the
  right-hand side, so [a, a + h_free) holds no root.
- Rising stretch: if f'(a) >= 0, ``f'(a + s) >= f'(a) + f''(a) s - J s^2 / 2`` stays >= 0 for a
  while, so f cannot fall below f(a) there. Right after a separation (f, f' and f'' all start at
  zero) this keeps the steps proportional to the elapsed time, where K alone would crawl.
- Monotone stretch: if f'(a) < 0, f' stays negative for ``h < h_mono`` (from K, and from
  ``f'(a) + f''(a) s + J s^2 / 2``); on [a, a + h_mono] f has at most one root, found by
  ``scipy.optimize.brentq`` if f changes sign, and none if f(a + h_mono) > 0.

- Clearance (optional): the caller may prove a root-free span by another argument, e.g. the
  envelope of an oscillator, which the Taylor bound cannot see past: ``clearance(a)`` returns
  its length (0 when it proves nothing).

Each iteration advances by the longest of these stretches, at most ``max_step`` (unbounded for
closed forms; a signal integrated numerically sets it so that a step never asks for the solution
far beyond the horizon). Near a simple root the monotone stretch
brackets it at once; a grazing touch (f' -> 0 as f -> 0) is approached geometrically and cannot be
stepped over, unlike a sign test on a fixed grid, which misses two close roots.

Given ``value_and_rate(t) -> (f, f')``, the single root of a monotone stretch is found by Newton's
method from its start: f decreases there, so a Newton point with f >= 0 leaves the stretch before
it root-free, and one with f < 0 brackets the root, which a safeguarded Newton iteration (bisection
when a step leaves the bracket) then converges on quadratically. That takes three to five
evaluations where a sign test at the end of the stretch and ``brentq`` took eight; without it the
search uses ``brentq``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from math import sqrt
from typing import Any

from scipy.optimize import brentq

from ...limits import TIME_RESOLUTION
from ...record import Record

#: Iterations before the search gives up proving and reports a touch where it stands
#: (only a pathological, exactly tangent contact gets there; the touch is then real to rounding).
MAX_ITERATIONS = 100_000

#: Newton steps from the start of a monotone stretch before the search falls back on the sign test
#: at its end (a simple root takes 3 to 5; more means a root close to the end of the stretch).
DESCENT_STEPS = 12

#: Iterations of the bracketed Newton-bisection search (bisection alone halves any bracket the
#: search can make, up to 1e300 s, to 1e-15 s within them).
BRACKET_STEPS = 1100

#: Relative tolerance on a located root, as brentq's ``rtol`` (4 ulps): the time resolution.
ROOT_RTOL = TIME_RESOLUTION

#: Absolute tolerance on a located root (s), as brentq's ``xtol``.
ROOT_XTOL = 1e-15

#: A root-free stretch longer than this (s) is the whole future: no run reaches its end, and the
#: closed forms overflow there (a clearance of 6e306 s, a margin over an ice speed of 1e-308
#: m/s, had the search evaluate the gap at omega_n t = inf).
FOREVER = 1e300

#: A probe whose largest value (of f, f', f'', K, J) is below this, or above its inverse, is
#: scaled to about 1 before the step lengths are computed: their squares (f'^2, 2 K f, ...)
#: underflowed at contact forces of 1e-286 N, and a discriminant of 0 gave a Taylor stretch of
#: 1e14 s that stepped over the separation.
SCALED_BELOW = 1e-100
SCALED_ABOVE = 1.0 / SCALED_BELOW

#: A probe with a nonzero value below this times its largest is rescaled in time as well
#: (:func:`balanced`): with f = 1.2e-271, f' = -2.4e-184, K = 4.9e-91, J = 1 both f'^2 and K f
#: underflowed, and the Taylor stretch came out as f / -f', 1415 times the one its bounds prove.
SPREAD = 1e-140

#: The time degree of each of (f, f', f'', K, J): a time unit tau multiplies them by tau^degree.
_DEGREES = (0, 1, 2, 2, 3)


def balanced(f: float, df: float, d2: float, bound: float,
             jerk: float) -> tuple[float, float, float, float, float, float]:
    """The probe (f, f', f'', K, J) in a time unit tau = 2^p and a value unit, both powers of 2
    (so the rescaling is exact): (f, f' tau, f'' tau^2, K tau^2, J tau^3) times 2^-q, and tau.
    p makes the values' binary exponents as close together as it can (the largest minus the
    smallest, over the nonzero values), q brings the largest to about 1. Every step length of
    the search is homogeneous of degree 1 in time and 0 in value, so it is the rescaled probe's
    times tau: equal to the unscaled one's where nothing under- or overflows, and where the
    values are far apart (f = 1e-2 m, f' = 1e-190 m/s) the squares and products that decide it
    no longer lose their precision."""
    values = (f, df, d2, bound, jerk)
    exponents = [(math.frexp(value)[1], degree)
                 for value, degree in zip(values, _DEGREES, strict=True) if value != 0.0]
    if not exponents:
        return f, df, d2, bound, jerk, 1.0
    # the spread, max - min of e + degree p, is convex in p: its least is where two of the lines
    # cross
    candidates = {0}
    for e_1, d_1 in exponents:
        for e_2, d_2 in exponents:
            if d_1 > d_2:
                cross = (e_2 - e_1) / (d_1 - d_2)
                candidates.update((math.floor(cross), math.ceil(cross)))

    def spread(p: int) -> int:
        shifted = [e + degree * p for e, degree in exponents]
        return max(shifted) - min(shifted)
    p = min(sorted(candidates, key=lambda q: (abs(q), q)), key=spread)  # least spread, |p|
    p = max(-1000, min(1000, p))  # tau = 2^p stays a normal number
    top = max(e + degree * p for e, degree in exponents)
    scaled = [math.ldexp(value, degree * p - top)
              for value, degree in zip(values, _DEGREES, strict=True)]
    return (*scaled, math.ldexp(1.0, p))


#: a sum of the five magnitudes at or above this has its largest at or above SCALED_BELOW
_SUM_NEAR_1_LOW = 5.0 * SCALED_BELOW


class Signal:
    """A signal for :class:`RootSearch` given as functions (see there): ``probe``, ``value``,
    ``value_and_rate`` and ``clearance`` (the last two may be None). A segment of the motion
    serves as its own signal, with methods of these names."""

    __slots__ = ("probe", "value", "value_and_rate", "clearance")

    def __init__(self, probe: Callable[[float], tuple[float, float, float, float, float]],
                 value: Callable[[float], float],
                 value_and_rate: Callable[[float], tuple[float, float]] | None = None,
                 clearance: Callable[[float], float] | None = None):
        self.probe, self.value = probe, value
        self.value_and_rate, self.clearance = value_and_rate, clearance


class RootSearch:

    """Incremental search for the first time after a start point where f goes below zero.

    A zero that f only touches (f = f' = 0, then f >= 0) is not a root: a gap closing with no
    closing speed is no impact, a contact force that vanishes without turning tensile no
    separation.

    ``probe(t) -> (f, f', f'', K, J)`` gives value, slope, curvature and the bounds K, J;
    ``value(t) -> f`` is the cheap value alone, ``value_and_rate(t) -> (f, f')`` (optional) the
    value and slope for Newton's method, ``clearance(t)`` (optional) a root-free span. They are
    the attributes of a :class:`Signal` (a segment is one: :meth:`next_root_of`), or given as
    functions (:meth:`next_root_before`), with each call and held only during it, so that a
    segment holding its search makes no reference cycle (it is freed at once, without the
    cyclic garbage collector, which took a fifth of an impact-heavy run). The search keeps its
    frontier (root-free up to ``a``) between calls, so a sequence of horizons visits the same
    points as one long call: results do not depend on how the caller chops time.
    """

    __slots__ = ("a", "root", "time_eps", "iterations", "creep", "max_step", "_probed_at",
                 "_probed")

    def __init__(self, start: float, time_eps: float, max_step: float = math.inf):
        self.a = start          # f(a) >= 0 and [start, a) is root-free
        self.root: float | None = None
        self.time_eps = time_eps  # smallest meaningful time increment
        self.iterations = 0
        self.creep = 0
        self.max_step = max_step  # longest step (s): a shorter root-free stretch is still one
        # the probe at the end of the last step, which its sign test evaluated: the next step
        # starts there (the point and its values; a frontier moved elsewhere asks again)
        self._probed_at = math.nan
        self._probed: tuple[float, float, float, float, float] | None = None

    def frontier(self) -> dict[str, Any]:
        """Where the search stands, as plain data: with the same signal and start,
        :meth:`set_frontier` continues it exactly (a snapshot of a solver holds it)."""
        return {"a": self.a, "root": self.root, "iterations": self.iterations,
                "creep": self.creep}

    @staticmethod
    def read_frontier(record: Record, start: float) -> tuple[float, float | None, int, int]:
        """Validated (a, root, iterations, creep) from a :meth:`frontier` record."""
        record.expect_keys(("a", "root", "iterations", "creep"))
        return (record.real("a", finite=False, low=start),
                record.real("root", low=start, allow_none=True),
                record.integer("iterations", low=0),
                record.integer("creep", low=0))

    def set_frontier(self, values: tuple[float, float | None, int, int]) -> None:
        self.a, self.root, self.iterations, self.creep = values

    def checkpoint(self) -> tuple:
        """All the search holds, for a rollback in memory: the frontier and the probe kept at
        its end (a snapshot keeps the frontier only; the probe is evaluated again from it)."""
        return self.a, self.root, self.iterations, self.creep, self._probed_at, self._probed

    def rollback(self, saved: tuple) -> None:
        self.a, self.root, self.iterations, self.creep, self._probed_at, self._probed = saved

    def next_root_before(self, horizon: float,
                         probe: Callable[[float], tuple[float, float, float, float, float]],
                         value: Callable[[float], float],
                         value_and_rate: Callable[[float], tuple[float, float]] | None = None,
                         clearance: Callable[[float], float] | None = None) -> float | None:
        """The first root of the signal given as functions (see the class) if it is at or
        before ``horizon``, else None (frontier moved past)."""
        return self.next_root_of(horizon, Signal(probe, value, value_and_rate, clearance))

    def next_root_of(self, horizon: float, signal: Any) -> float | None:
        """The first root of ``signal`` (any object with the attributes of a :class:`Signal`,
        such as a segment) if it is at or before ``horizon``, else None (frontier moved past)."""
        root = self.root
        if root is not None:
            return root if root <= horizon else None
        step = self._step  # (one lookup: a method is bound anew at each)
        while self.a <= horizon:
            step(signal)
            root = self.root
            if root is not None:
                return root if root <= horizon else None
        return None

    def _step(self, signal: Any) -> None:
        a = self.a
        if a == self._probed_at:  # the last step's sign test probed its end, here
            f, df, d2, bound, jerk = self._probed
        else:
            f, df, d2, bound, jerk = signal.probe(a)
        self.iterations += 1
        if f < 0.0 or (f == 0.0 and df < 0.0):  # going below zero here
            self.root = a
            return
        # the common path: the sum of the magnitudes (f >= 0 here, within a factor 5 of the
        # largest) near 1 and every value within SPREAD of it, f also where it is 0 (the start
        # of each bounce, at contact; the exact test below never rescales for f = 0); otherwise
        # the exact test
        df_size = df if df >= 0.0 else -df
        d2_size = d2 if d2 >= 0.0 else -d2
        total = f + df_size + d2_size + bound + jerk
        floor = SPREAD * total
        unit = 1.0  # the time unit of the step lengths below (s)
        if (0.0 < f < floor or df_size < floor or d2_size < floor or bound < floor or jerk < floor
                or not _SUM_NEAR_1_LOW <= total <= SCALED_ABOVE):
            # (rarely: a value is 0 or far below the largest, or all are tiny or huge)
            size = max(f, df_size, d2_size, bound, jerk)
            floor = SPREAD * size
            if 0.0 < size < math.inf and (
                    not SCALED_BELOW <= size <= SCALED_ABOVE or 0.0 < f < floor
                    or 0.0 < df_size < floor or 0.0 < d2_size < floor or 0.0 < bound < floor
                    or 0.0 < jerk < floor):
                # the squares below would underflow (or overflow), or the values are too far
                # apart for their products to keep their precision: rescale by powers of 2
                # (exact)
                f, df, d2, bound, jerk, unit = balanced(f, df, d2, bound, jerk)
        if bound <= 0.0:  # f is linear from here on
            if df < 0.0:
                self.root = a + unit * (f / -df)
            else:
                self.a = math.inf
            return
        disc = sqrt(df * df + 2.0 * bound * f)
        h_free = unit * ((df + disc) / bound if df >= 0.0 else 2.0 * f / (disc - df))
        max_step = self.max_step
        clearance = signal.clearance  # (one lookup: a method is bound anew at each)
        if clearance is not None:
            cleared = clearance(a)
            if cleared > h_free:  # max(), written out (this runs at every step)
                h_free = cleared
        if df >= 0.0:
            # f' >= df + d2 s - jerk s^2 / 2 stays >= 0 up to h_rise: f cannot fall below f(a)
            if jerk > 0.0:
                h_rise = unit * ((d2 + sqrt(d2 * d2 + 2.0 * jerk * df)) / jerk)
            else:
                h_rise = math.inf if d2 >= 0.0 else unit * (df / -d2)
            if h_rise > h_free:
                h_free = h_rise
        else:
            # f' <= df + d2 s + jerk s^2 / 2 stays < 0 up to h_mono: at most one root there
            h_mono = -df / bound
            if jerk > 0.0:
                root = sqrt(d2 * d2 - 2.0 * jerk * df)
                if d2 < 0.0:
                    h_jerk = (root - d2) / jerk
                    if h_jerk > h_mono:
                        h_mono = h_jerk
                elif d2 + root > 0.0:  # (both 0: d2^2 and jerk df underflowed; K's stretch holds)
                    h_jerk = -2.0 * df / (d2 + root)
                    if h_jerk > h_mono:
                        h_mono = h_jerk
            elif d2 <= 0.0:
                h_mono = math.inf
            h_mono *= unit
            if h_mono > h_free:
                span = FOREVER if FOREVER < h_mono else h_mono  # min(h_mono, FOREVER, max_step)
                if max_step < span:
                    span = max_step
                b = a + span
                if b > a:
                    if signal.value_and_rate is not None:
                        self._descend(signal, a, f, df, d2, b, unit)
                        return
                    if signal.value(b) < 0.0:  # exactly one crossing in (a, b)
                        self.root = self._bracketed_root(signal, a, b)
                        return
                    self.a = b
                    return
        if h_free > FOREVER and max_step == math.inf:
            self.a = math.inf
            return
        step = max_step if max_step < h_free else h_free  # min(h_free, max_step)
        eps = self.time_eps + TIME_RESOLUTION * a  # a few ulps of the absolute time
        if step < eps:
            if df < 0.0 or self.iterations > MAX_ITERATIONS:
                # tangent approach to within rounding: f here is below bound*eps^2, a touch
                self.root = a
                return
            # f = f' = 0 to rounding (a degenerate start): creep out with doubling steps so that
            # the work stays bounded; a crossing is still caught by the sign test at b
            step = eps * 2.0 ** min(self.creep, 1000)
            self.creep += 1
        else:
            self.creep = 0
        b = a + step
        # the sign test at b by the full probe, which the next step starts from
        probed = signal.probe(b)
        if probed[0] < 0.0:  # rounding at the frontier: root-free before b, so it is b
            self.root = self._bracketed_root(signal, a, b)
            return
        self.a = self._probed_at = b
        self._probed = probed

    def _descend(self, signal: Any, a: float, f: float, df: float, d2: float, b: float,
                 unit: float = 1.0) -> None:
        """Newton's method from a (f(a) = f >= 0, f'(a) = df < 0, f''(a) = d2, in the time
        ``unit`` of :func:`balanced`) on the monotone stretch [a, b]: set the root if it is in
        [a, b], else move the frontier to b.

        f decreases on [a, b], so a point t with f(t) >= 0 leaves [a, t] root-free (the
        frontier moves on), and one with f(t) < 0 brackets the only root in (a, t). The first
        point is the root of the second-order Taylor polynomial at a (one Newton step fewer),
        the next ones Newton points."""
        value_and_rate = signal.value_and_rate  # (one lookup: a method is bound anew at each)
        t, f_t, df_t = a, f, df
        disc = df * df - 2.0 * f * d2
        # first step: root of f + df h + d2 h^2 / 2 (cancellation-free form), else Newton's
        step = unit * (2.0 * f / (sqrt(disc) - df) if disc >= 0.0 else f / -df)
        for _ in range(DESCENT_STEPS):
            if not df_t < 0.0:  # f' vanishing to rounding inside the stretch
                break
            nxt = t + step
            if nxt >= b:  # any root is close to b: the sign test there decides
                break
            # converged from above, to tolerance (|t| written out: a call of abs() costs more)
            if step <= ROOT_XTOL + ROOT_RTOL * (t if t >= 0.0 else -t):
                self.root = t
                return
            f_n, df_n = value_and_rate(nxt)
            if f_n < 0.0:  # the root is in (t, nxt)
                self.root = self._bracketed_root(signal, t, nxt, nxt, f_n, df_n)
                return
            if f_n == 0.0:
                self.root = nxt
                return
            t, f_t, df_t = nxt, f_n, df_n
            step = f_t / -df_t if df_t < 0.0 else math.inf
        if signal.value(b) < 0.0:  # exactly one crossing in (t, b)
            self.root = self._bracketed_root(signal, t, b)
        else:
            self.a = b

    def _bracketed_root(self, signal: Any, a: float, b: float, t: float | None = None,
                        f_t: float = 0.0, df_t: float = 0.0) -> float:
        """The crossing in [a, b] (f(a) >= 0 > f(b)), to near machine precision: safeguarded
        Newton from t (with f(t) = f_t, f'(t) = df_t, else from b) if rates are given, else
        brentq."""
        value_and_rate = signal.value_and_rate
        if value_and_rate is None:
            return self._brentq(signal.value, a, b)
        if t is None:
            t = b
            f_t, df_t = value_and_rate(b)
        lo, hi = a, b
        step = step_before = hi - lo
        for _ in range(BRACKET_STEPS):
            nxt = t - f_t / df_t if df_t != 0.0 else math.nan
            if not lo < nxt < hi or 2.0 * abs(nxt - t) > step_before:
                if abs(nxt - t) <= ROOT_XTOL + ROOT_RTOL * abs(t):
                    # Newton's step from t is within the tolerance but rounds to t itself (a
                    # step below half an ulp of t) or past the bracket's end at t: the root is
                    # within the tolerance of t (bisection here halved the whole bracket again,
                    # some 40 evaluations, to land as close). Below zero at t: t is the first
                    # point below zero. Above (t = lo): the next float, if f is not above zero
                    # there (else bisection goes on from it).
                    if f_t < 0.0:
                        return t
                    after = math.nextafter(t, math.inf)
                    if after < hi:
                        f_after, _ = value_and_rate(after)
                        if f_after <= 0.0:
                            return after
                        lo = after
                nxt = lo + 0.5 * (hi - lo)  # bisection when Newton leaves or stalls
            step_before, step = step, abs(nxt - t)
            converged = step <= ROOT_XTOL + ROOT_RTOL * abs(nxt)
            if converged or not lo < nxt < hi:
                # converged: the last point evaluated is within the tolerance of the root
                return t if converged else nxt
            t = nxt
            f_t, df_t = value_and_rate(t)
            if f_t < 0.0:
                hi = t
            elif f_t > 0.0:
                lo = t
            else:
                return t
        return t

    def _brentq(self, value: Callable[[float], float], a: float, b: float) -> float:
        """The crossing in [a, b] (f(a) >= 0 > f(b)) by brentq, to near machine precision.

        Where rounding makes f noisy near its root brentq may not meet its tolerance; its best
        bracketed estimate is then kept (disp=False) instead of failing the run."""
        root, _ = brentq(value, a, b, xtol=ROOT_XTOL, rtol=ROOT_RTOL, maxiter=200,
                         full_output=True, disp=False)
        return root
