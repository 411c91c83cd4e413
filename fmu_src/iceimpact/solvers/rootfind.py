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

Each iteration advances by the longest of these stretches. Near a simple root the monotone stretch
brackets it at once; a grazing touch (f' -> 0 as f -> 0) is approached geometrically and cannot be
stepped over, unlike a sign test on a fixed grid, which misses two close roots.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from scipy.optimize import brentq

from .state import Record

#: Iterations before the search gives up proving and reports a touch where it stands
#: (only a pathological, exactly tangent contact gets there; the touch is then real to rounding).
MAX_ITERATIONS = 100_000


class RootSearch:
    """Incremental search for the first time after a start point where f goes below zero.

    A zero that f only touches (f = f' = 0, then f >= 0) is not a root: a gap closing with no
    closing speed is no impact, a contact force that vanishes without turning tensile no
    separation.

    ``probe(t) -> (f, f', f'', K, J)`` gives value, slope, curvature and the bounds K, J;
    ``value(t) -> f`` is the cheap value alone. The search keeps its frontier (root-free up to
    ``clear``) between calls, so a sequence of horizons visits the same points as one long call:
    results do not depend on how the caller chops time.
    """

    __slots__ = ("probe", "value", "clearance", "a", "root", "time_eps", "iterations", "xtol",
                 "creep")

    def __init__(self, probe: Callable[[float], tuple[float, float, float]],
                 value: Callable[[float], float], start: float, time_eps: float,
                 clearance: Callable[[float], float] | None = None):
        self.probe = probe
        self.value = value
        self.clearance = clearance
        self.a = start          # f(a) >= 0 and [start, a) is root-free
        self.root: float | None = None
        self.time_eps = time_eps  # smallest meaningful time increment
        self.iterations = 0
        self.creep = 0
        self.xtol = 1e-15

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

    def next_root_before(self, horizon: float) -> float | None:
        """The first root if it is at or before ``horizon``, else None (frontier moved past)."""
        if self.root is not None:
            return self.root if self.root <= horizon else None
        while self.a <= horizon:
            self._step()
            if self.root is not None:
                return self.root if self.root <= horizon else None
        return None

    def _step(self) -> None:
        a = self.a
        f, df, d2, bound, jerk = self.probe(a)
        self.iterations += 1
        if f < 0.0 or (f == 0.0 and df < 0.0):  # going below zero here
            self.root = a
            return
        if bound <= 0.0:  # f is linear from here on
            if df < 0.0:
                self.root = a + f / -df
            else:
                self.a = math.inf
            return
        disc = math.sqrt(df * df + 2.0 * bound * f)
        h_free = (df + disc) / bound if df >= 0.0 else 2.0 * f / (disc - df)
        if self.clearance is not None:
            h_free = max(h_free, self.clearance(a))
        if df >= 0.0:
            # f' >= df + d2 s - jerk s^2 / 2 stays >= 0 up to h_rise: f cannot fall below f(a)
            if jerk > 0.0:
                h_rise = (d2 + math.sqrt(d2 * d2 + 2.0 * jerk * df)) / jerk
            else:
                h_rise = math.inf if d2 >= 0.0 else df / -d2
            h_free = max(h_free, h_rise)
        else:
            # f' <= df + d2 s + jerk s^2 / 2 stays < 0 up to h_mono: at most one root there
            h_mono = -df / bound
            if jerk > 0.0:
                root = math.sqrt(d2 * d2 - 2.0 * jerk * df)
                h_mono = max(h_mono, (root - d2) / jerk if d2 < 0.0 else -2.0 * df / (d2 + root))
            elif d2 <= 0.0:
                h_mono = math.inf
            if h_mono > h_free:
                b = a + min(h_mono, 1e300)
                if b > a:
                    if self.value(b) < 0.0:  # exactly one crossing in (a, b)
                        self.root = self._bracketed_root(a, b)
                        return
                    self.a = b
                    return
        if h_free == math.inf:
            self.a = math.inf
            return
        step = h_free
        eps = self.time_eps + 8.9e-16 * a  # a few ulps of the absolute time
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
        if self.value(b) < 0.0:  # rounding at the frontier: root-free before b, so it is b
            self.root = self._bracketed_root(a, b)
            return
        self.a = b

    def _bracketed_root(self, a: float, b: float) -> float:
        """The crossing in [a, b] (f(a) >= 0 > f(b)) by brentq, to near machine precision.

        Where rounding makes f noisy near its root brentq may not meet its tolerance; its best
        bracketed estimate is then kept (disp=False) instead of failing the run."""
        root, _ = brentq(self.value, a, b, xtol=self.xtol, rtol=8.9e-16, maxiter=200,
                         full_output=True, disp=False)
        return root
