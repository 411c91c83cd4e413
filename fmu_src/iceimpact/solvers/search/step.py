"""One step of the no-miss root search, on plain floats: the rules both searches follow.

:class:`~.rootfind.RootSearch` (any signal, in Python) and
:func:`~.flight_search.flight_root` (a flight's gap, compiled by numba where installed) make
their steps with these functions, so the two searches visit the same points and return the same
roots by construction. Each function is plain Python on floats that numba compiles as it is;
the signal is evaluated through the name ``evaluate``, which the compiled search replaces by its
own (:func:`iceimpact.compiled.jit`'s callees).

A step starts at the frontier a, where the probe gives the signal f, its slope f', its curvature
f'', a bound K on |f''| and a bound J on |f'''| for all later times, and f(a) >= 0 with [start, a)
root-free. :func:`plan` decides the step from the probe alone (the stretches proven root-free or
monotone, the module docstring of :mod:`.rootfind` derives them); :func:`descend` finds the root
of a monotone stretch or proves it root-free; :func:`bracketed` converges on a root once it is
bracketed. The caller probes, keeps its counters and makes the sign test at the end of a free
step (the probe there, which the next step starts from).
"""

from __future__ import annotations

import math
import operator
from math import nextafter, sqrt

from ...limits import TIME_RESOLUTION

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
#: (:func:`~.rootfind.balanced`): with f = 1.2e-271, f' = -2.4e-184, K = 4.9e-91, J = 1 both
#: f'^2 and K f underflowed, and the Taylor stretch came out as f / -f', 1415 times the one its
#: bounds prove.
SPREAD = 1e-140

#: a sum of the five magnitudes at or above this has its largest at or above SCALED_BELOW
SUM_NEAR_1_LOW = 5.0 * SCALED_BELOW

# What :func:`plan` decides (its first value). The compiled flight search makes the first four
# itself and hands the step to RootSearch for the others (rare: ``> AT_FRONTIER``).
#: [a, b) is root-free: the sign test at b, by the probe there
FREE = 0
#: f decreases on [a, b], which holds at most one root: :func:`descend`
MONOTONE = 1
#: root-free for ever: the frontier goes to infinity
BEYOND = 2
#: f is going below zero at a itself: the root is a
AT_FRONTIER = 3
#: the clearance is NaN (the compiled flight search's sign that only Python computes it)
UNCLEARED = 4
#: the probe is off the common path: rescaled (:func:`~.rootfind.balanced`), or tested exactly,
#: and planned again with ``checked`` set
OFF_PATH = 5
#: K = 0, f is linear from a on and crosses zero at b
LINEAR_ROOT = 6
#: K = 0, f is linear from a on and never decreases: root-free for ever
LINEAR_BEYOND = 7
#: the step is shorter than the time resolution while f decreases (or the search has run out of
#: iterations): a tangent approach to within rounding, a touch at a
TOUCH = 8
#: the step is shorter than the time resolution with f' >= 0 (f = f' = 0 to rounding, a
#: degenerate start): b = a + the time resolution doubled at each such step, the sign test at b
CREEP = 9

#: What :func:`descend` finds (its first value): the stretch is root-free up to its end, or holds
#: the root it returns.
PASSED, ROOT = 0, 1

#: The signal at t, ``evaluate(context, t) -> point`` with f = point[0], f' = point[1] (the rest
#: of the point is the caller's: a flight keeps its motion there). In Python the context is
#: the signal's ``value_and_rate`` itself; the compiled flight search compiles these functions
#: with its own evaluation (:func:`~.flight_search._gap_point`).
evaluate = operator.call


def plan(a, f, df, d2, bound, jerk, cleared, unit, max_step, time_eps, iterations, creep,
         checked):
    """The step from the frontier a, from the probe there (f, f', f'', K, J), the clearance
    (``cleared`` s proven root-free by another argument, 0 if none), the step lengths' time
    ``unit`` (1, or the rescaled probe's: :func:`~.rootfind.balanced`), the longest step, the
    time resolution ``time_eps`` and the counters (``iterations`` with this step). With
    ``checked`` the root test at a and the common-path test were passed already (a rescaled
    probe). Returns (what, b), ``what`` one of the constants above:

    - the root test at the frontier: f < 0, or f = 0 with f' < 0, is AT_FRONTIER (the root a);
    - a NaN clearance is UNCLEARED; a probe off the common path (a magnitude far below the
      others, zero, or all tiny or huge, where the squares below could under- or overflow) is
      OFF_PATH;
    - K = 0: f is linear, LINEAR_ROOT at b = a + f / -f' or LINEAR_BEYOND;
    - the Taylor stretch ``f(a + h) >= f + f' h - K h^2 / 2 > 0`` proves [a, a + h_free)
      root-free, and so does the clearance; with f' >= 0 the rising stretch (f' stays >= 0 while
      ``f' + f'' s - J s^2 / 2 >= 0``, so f stays >= f(a)) too: the longest of them is the free
      stretch;
    - with f' < 0, f' stays < 0 for s < h_mono (from K, and from ``f' + f'' s + J s^2 / 2``): if
      that is longer than the free stretch, MONOTONE on [a, b], b = a + min(h_mono, FOREVER,
      max_step), which holds at most one root;
    - a free stretch beyond FOREVER with no longest step is BEYOND;
    - else FREE at b = a + min(free stretch, max_step): [a, b) is root-free; a step shorter
      than the time resolution is TOUCH (f' < 0 or out of iterations) or CREEP (b at the time
      resolution doubled ``creep`` times)."""
    if not checked:
        if f < 0.0 or (f == 0.0 and df < 0.0):  # going below zero here
            return AT_FRONTIER, a
        if cleared != cleared:
            return UNCLEARED, a
        # the common path: the sum of the magnitudes (f >= 0 here, within a factor 5 of the
        # largest) near 1 and every value within SPREAD of it, f also where it is 0 (the start
        # of each bounce, at contact)
        df_size = df if df >= 0.0 else -df
        d2_size = d2 if d2 >= 0.0 else -d2
        total = f + df_size + d2_size + bound + jerk
        floor = SPREAD * total
        if (0.0 < f < floor or df_size < floor or d2_size < floor or bound < floor
                or jerk < floor or not SUM_NEAR_1_LOW <= total <= SCALED_ABOVE):
            return OFF_PATH, a
    if bound <= 0.0:  # f is linear from here on
        if df < 0.0:
            return LINEAR_ROOT, a + unit * (f / -df)
        return LINEAR_BEYOND, math.inf
    disc = sqrt(df * df + 2.0 * bound * f)
    h_free = unit * ((df + disc) / bound if df >= 0.0 else 2.0 * f / (disc - df))
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
                return MONOTONE, b
    if h_free > FOREVER and max_step == math.inf:
        return BEYOND, math.inf
    step = max_step if max_step < h_free else h_free  # min(h_free, max_step)
    eps = time_eps + TIME_RESOLUTION * a  # a few ulps of the absolute time
    if step < eps:
        if df < 0.0 or iterations > MAX_ITERATIONS:
            # tangent approach to within rounding: f here is below bound*eps^2, a touch
            return TOUCH, a
        # f = f' = 0 to rounding: creep out with doubling steps so that the work stays
        # bounded; a crossing is still caught by the sign test at b
        return CREEP, a + eps * 2.0 ** min(creep, 1000)
    return FREE, a + step


def descend(a, f, df, d2, b, unit, point, context):
    """Newton's method from a (f(a) = f >= 0, f'(a) = df < 0, f''(a) = d2, in the time ``unit``
    of :func:`plan`; ``point`` the signal at a as :data:`evaluate` gives it) on the monotone
    stretch [a, b]: (PASSED, b, ...) where [a, b] is root-free, else (ROOT, the root, ...), each
    with the last point evaluated and the signal there (``at``, ``point``; a and the given point
    if none was).

    f decreases on [a, b], so a point t with f(t) >= 0 leaves [a, t] root-free, and one with
    f(t) < 0 brackets the only root in (a, t) (:func:`bracketed`). The first point is the root
    of the second-order Taylor polynomial at a (one Newton step fewer), the next ones Newton
    points; after DESCENT_STEPS, or where a Newton point would leave the stretch, the sign of f
    at b decides."""
    at = a
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
            return ROOT, t, at, point
        at, point = nxt, evaluate(context, nxt)
        f_n, df_n = point[0], point[1]
        if f_n < 0.0:  # the root is in (t, nxt)
            root, at, point = bracketed(t, nxt, nxt, f_n, df_n, at, point, context)
            return ROOT, root, at, point
        if f_n == 0.0:
            return ROOT, nxt, at, point
        t, f_t, df_t = nxt, f_n, df_n
        step = f_t / -df_t if df_t < 0.0 else math.inf
    at, point = b, evaluate(context, b)
    if not point[0] < 0.0:  # root-free up to b
        return PASSED, b, at, point
    # exactly one crossing in (t, b)
    root, at, point = bracketed(t, b, b, point[0], point[1], at, point, context)
    return ROOT, root, at, point


def bracketed(lo, hi, t, f_t, df_t, at, point, context):
    """The crossing in [lo, hi] (f(lo) >= 0 > f(hi)), to near machine precision, by Newton's
    method from t (f(t) = f_t, f'(t) = df_t; ``at`` and ``point`` the last point evaluated and
    the signal there), safeguarded: a bisection where a Newton step leaves the bracket or does
    not halve the step before it. Returns the root, and the last point evaluated with the signal
    there (the root itself when it is that point)."""
    step = step_before = hi - lo
    for _ in range(BRACKET_STEPS):
        nxt = t - f_t / df_t if df_t != 0.0 else math.nan
        if not lo < nxt < hi or 2.0 * abs(nxt - t) > step_before:
            if abs(nxt - t) <= ROOT_XTOL + ROOT_RTOL * abs(t):
                # Newton's step from t is within the tolerance but rounds to t itself (a step
                # below half an ulp of t) or past the bracket's end at t: the root is within the
                # tolerance of t (bisection here halved the whole bracket again, some 40
                # evaluations, to land as close). Below zero at t: t is the first point below
                # zero. Above (t = lo): the next float, if f is not above zero there (else
                # bisection goes on from it).
                if f_t < 0.0:
                    return t, at, point
                after = nextafter(t, math.inf)
                if after < hi:
                    at, point = after, evaluate(context, after)
                    if point[0] <= 0.0:
                        return after, at, point
                    lo = after
            nxt = lo + 0.5 * (hi - lo)  # bisection when Newton leaves or stalls
        step_before, step = step, abs(nxt - t)
        converged = step <= ROOT_XTOL + ROOT_RTOL * abs(nxt)
        if converged or not lo < nxt < hi:
            # converged: the last point evaluated is within the tolerance of the root
            return (t if converged else nxt), at, point
        t = at = nxt
        point = evaluate(context, t)
        f_t, df_t = point[0], point[1]
        if f_t < 0.0:
            hi = t
        elif f_t > 0.0:
            lo = t
        else:
            return t, at, point
    return t, at, point
