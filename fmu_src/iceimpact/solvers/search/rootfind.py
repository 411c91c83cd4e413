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

The rules of a step (the stretches, the descent, the bracketed Newton iteration) are the plain
functions of :mod:`.step`, which the compiled flight search (:mod:`.flight_search`) makes its
steps with too; :class:`RootSearch` keeps the frontier, probes the signal and makes what is
Python's alone (a rescaled probe, the creep out of a degenerate start, brentq without rates).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from scipy.optimize import brentq

from ...record import Record
from .step import (
    BEYOND,
    CREEP,
    FREE,
    LINEAR_BEYOND,
    MONOTONE,
    OFF_PATH,
    PASSED,
    ROOT_RTOL,
    ROOT_XTOL,
    SCALED_ABOVE,
    SCALED_BELOW,
    SPREAD,
    bracketed,
    descend,
    plan,
)

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


def _rescaled(f: float, df: float, d2: float, bound: float,
              jerk: float) -> tuple[float, float, float, float, float, float]:
    """A probe off :func:`~.step.plan`'s common path, tested exactly: (f, f', f'', K, J) and
    the time unit of its step lengths, rescaled by :func:`balanced` where the squares of the
    step lengths would underflow (or overflow), or the values lie too far apart for their
    products to keep their precision; else as it is, in a unit of 1 s (a value 0, or all of
    them far from 1 without reaching the scales that need it)."""
    df_size = df if df >= 0.0 else -df
    d2_size = d2 if d2 >= 0.0 else -d2
    size = max(f, df_size, d2_size, bound, jerk)
    floor = SPREAD * size
    if 0.0 < size < math.inf and (
            not SCALED_BELOW <= size <= SCALED_ABOVE or 0.0 < f < floor
            or 0.0 < df_size < floor or 0.0 < d2_size < floor or 0.0 < bound < floor
            or 0.0 < jerk < floor):
        return balanced(f, df, d2, bound, jerk)
    return f, df, d2, bound, jerk, 1.0


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
        """One step from the frontier a: the probe there (the one the last step's sign test
        took, if it ended here), then what :func:`~.step.plan` decides from it. Either the
        root is set, or the frontier moves on to a point b with [a, b) proven root-free and
        f(b) >= 0 (to infinity where the rest of time is root-free)."""
        a = self.a
        if a == self._probed_at:  # the last step's sign test probed its end, here
            f, df, d2, bound, jerk = self._probed
        else:
            f, df, d2, bound, jerk = signal.probe(a)
        self.iterations += 1
        clearance = signal.clearance  # (one lookup: a method is bound anew at each)
        cleared = 0.0 if clearance is None else clearance(a)
        if cleared != cleared:  # (NaN proves nothing)
            cleared = 0.0
        what, b = plan(a, f, df, d2, bound, jerk, cleared, 1.0, self.max_step, self.time_eps,
                       self.iterations, self.creep, False)
        unit = 1.0
        if what == OFF_PATH:  # (rarely)
            f, df, d2, bound, jerk, unit = _rescaled(f, df, d2, bound, jerk)
            what, b = plan(a, f, df, d2, bound, jerk, cleared, unit, self.max_step,
                           self.time_eps, self.iterations, self.creep, True)
        if what == FREE:
            self.creep = 0
            self._sign_test(signal, a, b)
        elif what == MONOTONE:
            if signal.value_and_rate is not None:
                self._descend(signal, a, f, df, d2, b, unit)
            elif signal.value(b) < 0.0:  # exactly one crossing in (a, b)
                self.root = self._brentq(signal.value, a, b)
            else:
                self.a = b
        elif what == BEYOND or what == LINEAR_BEYOND:
            self.a = math.inf
        elif what == CREEP:
            self.creep += 1
            self._sign_test(signal, a, b)
        else:  # AT_FRONTIER, LINEAR_ROOT, TOUCH: the root is b
            self.root = b

    def _sign_test(self, signal: Any, a: float, b: float) -> None:
        """The end b of a root-free step [a, b): the full probe there, which the next step
        starts from; below zero at b (rounding at the frontier: [a, b) is root-free), the root
        is bracketed in [a, b]."""
        probed = signal.probe(b)
        if probed[0] < 0.0:
            self.root = self._bracketed_root(signal, a, b)
            return
        self.a = self._probed_at = b
        self._probed = probed

    def _descend(self, signal: Any, a: float, f: float, df: float, d2: float, b: float,
                 unit: float = 1.0) -> None:
        """Newton's method on the monotone stretch [a, b] (:func:`~.step.descend`, f(a) = f,
        f'(a) = df < 0, f''(a) = d2 in the time ``unit`` of :func:`balanced`): set the root if
        it is in [a, b], else move the frontier to b."""
        found, root, _, _ = descend(a, f, df, d2, b, unit, None, signal.value_and_rate)
        if found == PASSED:
            self.a = b
        else:
            self.root = root

    def _bracketed_root(self, signal: Any, a: float, b: float) -> float:
        """The crossing in [a, b] (f(a) >= 0 > f(b)), to near machine precision: safeguarded
        Newton from b (:func:`~.step.bracketed`) if rates are given, else brentq."""
        value_and_rate = signal.value_and_rate
        if value_and_rate is None:
            return self._brentq(signal.value, a, b)
        point = value_and_rate(b)
        return bracketed(a, b, b, point[0], point[1], b, point, value_and_rate)[0]

    def _brentq(self, value: Callable[[float], float], a: float, b: float) -> float:
        """The crossing in [a, b] (f(a) >= 0 > f(b)) by brentq, to near machine precision.

        Where rounding makes f noisy near its root brentq may not meet its tolerance; its best
        bracketed estimate is then kept (disp=False) instead of failing the run."""
        root, _ = brentq(value, a, b, xtol=ROOT_XTOL, rtol=ROOT_RTOL, maxiter=200,
                         full_output=True, disp=False)
        return root
