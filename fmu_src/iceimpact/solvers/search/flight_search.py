"""The root search of a flight's gap in one function: :class:`~.rootfind.RootSearch`'s common
steps, specialised to the free structure in every damping regime (eq. 9-10 and the critically
and over-damped forms) and the ice under either drag law (eq. 6-7, 31-33), compiled by numba when
it is installed (the ``fast`` extra).

A flight of Figure 2 spends most of its time in its root search: two probes of the gap and its
bounds, a Taylor stretch, a monotone stretch and one or two Newton points, some 80 calls of small
Python functions. :func:`flight_root` makes the same steps on plain floats, with the closed forms
and bounds written out, so that it compiles as one function; the solver calls it for each flight
it applies to (:meth:`FlightSearch.next_root_of`, :mod:`iceimpact.solvers.exact`).

Its rules are RootSearch's, its arithmetic that of the closed forms' scalar functions
(``Oscillator.deviation_increment``'s forms, ``aperiodic_increment``, the drag laws'
``increment`` and ``accel_bounds``, ``bounds`` and ``amplitude_bound``, ``Flight.probe``,
``gap_and_rate``, ``clearance``), operation for operation, with RootSearch's constants, so the
points it visits and the root it returns are RootSearch's to the bit
(tests/solvers/search/test_flight_search.py checks both against each other, and the runs with
and without numba). Where a step leaves the common path (a probe to rescale, an amplitude bound
at the scales of its ``math.hypot`` form, the drift clearance of an undamped structure, a
degenerate or tangent start, a crossing at the frontier by rounding) it returns the frontier as
it was before that step, and RootSearch makes that step and the rest of the search.

numba compiles it without ``fastmath`` (no contraction of a product and a sum into one fused
operation, no reordering), and its ``math`` functions call the same C library as CPython's, so the
compiled function gives the same floats as the pure one. Without numba, or with
``ICEIMPACT_PURE=1`` in the environment, the function runs in Python (still faster than
RootSearch's methods: it evaluates the closed forms no more often and makes fewer calls); the
results are the same either way.
"""

from __future__ import annotations

import math
from math import expm1, log1p, nextafter, sqrt
from typing import Any

from ...compiled import compile_or_none, entry_point, jit
from ...limits import TIME_RESOLUTION
from ...physics.structure import (
    FORM_MODES,
    FORM_OVER,
    FORM_UNDER,
    _decay_pair,
    aperiodic_increment,
    under_increment,
)
from ..base import ACCEL_CLEARANCE_PHASE, GAP_ROUNDING, GAP_ULPS
from .rootfind import (
    _SUM_NEAR_1_LOW,
    BRACKET_STEPS,
    DESCENT_STEPS,
    FOREVER,
    ROOT_RTOL,
    ROOT_XTOL,
    SCALED_ABOVE,
    SPREAD,
    RootSearch,
)

#: The outcomes of :func:`flight_root`: the frontier passed the horizon with no root, a root was
#: found (it may lie beyond the horizon), or the next step is RootSearch's to make.
PASSED, ROOT, GENERIC = 0, 1, 2


def _motion(t, form, k, rate, w0, r0, quadratic, integrated):
    """(x - x0, v, z - z0, w) at t: the structure's free response in its form on the
    constants k of ``response_constants`` (``Oscillator.deviation_increment``'s:
    ``under_increment`` or ``aperiodic_increment``) and the ice's (:func:`_ice_motion`).
    ``integrated`` is the structure's Taylor steps where it has no closed form
    (:mod:`.dragged`, which compiles this module's search with its own ``_motion``); unused
    here."""
    if form == FORM_UNDER:
        dx, v = under_increment(t, k[0], k[1], k[2], k[3], k[4], k[5])
    else:
        dx, v = aperiodic_increment(t, form, k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7])
    dz, w = _ice_motion(t, rate, w0, r0, quadratic)
    return dx, v, dz, w


def _ice_motion(t, rate, w0, r0, quadratic):
    """(z - z0, w) at t: the ice's increment (``LinearDrag.increment``, rate kappa, or
    ``QuadraticDrag.increment``, rate beta |r0|), written out."""
    x = rate * t
    if quadratic:
        if x < 1e-3:  # series, truncation ~ y^6 / 7
            lag = -x * (0.5 - x * (1 / 3 - x * (0.25 - x * (0.2 - x / 6))))
        else:
            lag = log1p(x) / x - 1.0
        return w0 * t + r0 * t * lag, w0 - r0 * (x / (1.0 + x))
    if x < 1e-2:  # series, truncation ~ x^6 / 5040
        lag = -x * (0.5 - x * (1 / 6 - x * (1 / 24 - x * (1 / 120 - x / 720))))
    else:
        lag = -expm1(-x) / x - 1.0
    return w0 * t + r0 * t * lag, w0 + r0 * expm1(-x)


def _structure_probe(x, v, offset, mass, damping, stiffness, omega2, over, s_slow, s_fast, u,
                     integrated):
    """The structure's part of ``Flight.probe``: its acceleration at (x, v) and bounds on the
    magnitudes of its acceleration and jerk for all later times (``Oscillator.bounds``,
    written out; over-damped, ``over`` 1, the amplitude bound of :func:`_amplitude`); NaN
    bounds where RootSearch's probe is to be taken (hypot's scales)."""
    a_x = -(damping * v + stiffness * (x - offset)) / mass
    j_x = -(damping * a_x + stiffness * v) / mass
    s_x = -(damping * j_x + stiffness * a_x) / mass
    if over:
        return (a_x, _amplitude(a_x, j_x, omega2, over, s_slow, s_fast),
                _amplitude(j_x, s_x, omega2, over, s_slow, s_fast))
    return a_x, sqrt(a_x * a_x + j_x * j_x / omega2), sqrt(j_x * j_x + s_x * s_x / omega2)


def _ice_accel(w, u, coef, quadratic):
    """(acceleration, bound on |acceleration|, bound on |jerk|) of the ice for all later times:
    ``LinearDrag.accel_bounds`` (coef kappa) or ``QuadraticDrag.accel_bounds`` (coef beta)."""
    if quadratic:
        r = w - u
        speed = abs(r)
        a = -coef * speed * r
        size = abs(a)
        return a, size, 2.0 * coef * speed * size
    a = -coef * (w - u)
    size = a if a > 0.0 else 0.0 - a
    return a, size, coef * size


def _amplitude(y, ydot, omega2, over, s_slow, s_fast):
    """``Oscillator.amplitude_bound``, written out: the energy bound, and over-damped (``over``
    1, exponents s1, s2) the smaller of it and |A| + |B|; NaN where its ``math.hypot`` form
    would be asked (RootSearch's)."""
    energy = sqrt(y * y + ydot * ydot / omega2)
    if not 1e-140 < energy < 1e140 and not (y == 0.0 and ydot == 0.0):
        return math.nan
    if not over:
        return energy
    modes = (abs(ydot - s_fast * y) + abs(s_slow * y - ydot)) / (s_slow - s_fast)
    return min(energy, modes * (1.0 + 1e-15))


def _clearance(x, v, z, w, offset, omega2, sigma, over, s_slow, s_fast, u, coef, quadratic):
    """``Flight.clearance`` at a point where the ice is upstream of the structure's rest
    position (z < offset), written out for the oscillator (damping rate sigma; ``over`` and the
    exponents s1, s2 as :func:`_amplitude` takes them); NaN where the drift clearance or a
    hypot-scaled amplitude bound would be asked (RootSearch's)."""
    reach = _amplitude(x - offset, v, omega2, over, s_slow, s_fast)
    if reach != reach:
        return math.nan  # (its math.hypot form: RootSearch's)
    lowest = offset - reach - z
    rounding = GAP_ULPS * (abs(x) + abs(z) + reach + abs(offset))
    # downstream_speed_bound
    if coef > 0.0:
        speed = max(w, u, 0.0)
    else:
        speed = max(w, 0.0)
    margin = lowest - rounding
    if margin <= 0.0:
        if speed == 0.0 or w < 0.0:
            if not (lowest >= -rounding and margin >= -GAP_ROUNDING):
                return 0.0
            if speed == 0.0:
                return math.inf
            return _accel_clearance(w, 0.0, u, coef, quadratic, omega2)
        if sigma == 0.0:
            return math.nan  # (undamped: Flight._drift_clearance may prove periods)
        return 0.0
    if speed == 0.0:
        return math.inf
    cleared = margin / speed
    if w < 0.5 * speed:
        by_accel = _accel_clearance(w, margin, u, coef, quadratic, omega2)
        if by_accel > cleared:
            return by_accel
    return cleared


def _accel_clearance(w, margin, u, coef, quadratic, omega2):
    """``Flight._accel_clearance``, written out."""
    accel_bound = _ice_accel(w, u, coef, quadratic)[1]
    if not accel_bound > 0.0:
        root = margin / w if w > 0.0 else math.inf
    else:
        disc = sqrt(w * w + 2.0 * accel_bound * margin)
        root = (2.0 * margin / (w + disc) if w > 0.0 else (disc - w) / accel_bound)
        root *= 1.0 - 1e-12
    if root * sqrt(omega2) < ACCEL_CLEARANCE_PHASE:
        return 0.0
    return root


def _bracketed(lo, hi, t, f_t, df_t, motion, gap0, form, k, rate, w0, r0, quadratic,
               integrated):
    """``RootSearch._bracketed_root`` from the Newton point t (f(t) = f_t, f'(t) = df_t, the
    motion there ``motion``), its bracket [lo, hi] (f(lo) >= 0 > f(hi)). Returns the root, and
    the last point evaluated with its motion (the state at the root when it is that point)."""
    step = step_before = hi - lo
    at = t
    for _ in range(BRACKET_STEPS):
        nxt = t - f_t / df_t if df_t != 0.0 else math.nan
        if not lo < nxt < hi or 2.0 * abs(nxt - t) > step_before:
            if abs(nxt - t) <= ROOT_XTOL + ROOT_RTOL * abs(t):
                if f_t < 0.0:
                    return t, at, motion
                after = nextafter(t, math.inf)
                if after < hi:
                    at, motion = after, _motion(after, form, k, rate, w0, r0, quadratic,
                                                integrated)
                    if gap0 + (motion[0] - motion[2]) <= 0.0:
                        return after, at, motion
                    lo = after
            nxt = lo + 0.5 * (hi - lo)
        step_before, step = step, abs(nxt - t)
        converged = step <= ROOT_XTOL + ROOT_RTOL * abs(nxt)
        if converged or not lo < nxt < hi:
            return (t if converged else nxt), at, motion
        t = at = nxt
        motion = _motion(t, form, k, rate, w0, r0, quadratic, integrated)
        dx, v, dz, w = motion
        f_t, df_t = gap0 + (dx - dz), v - w
        if f_t < 0.0:
            hi = t
        elif f_t > 0.0:
            lo = t
        else:
            return t, at, motion
    return t, at, motion


def flight_root(horizon, a, iterations, creep, probed_at, pf, pdf, pd2, pbound, pjerk,
                time_eps, gap0, x0, z0, offset, mass, damping, stiffness, omega2, sigma,
                s_slow, s_fast, form, c0, c1, c2, c3, c4, c5, c6, c7, rate, w0, r0, u, coef,
                quadratic, max_step, integrated):
    """RootSearch's steps from the frontier a (its probe there, if taken: ``probed_at`` and
    the five values) while a <= horizon, for the gap of a flight: structure from (x0, v0) on the
    oscillator (mass, damping, stiffness, offset, omega2, sigma and the over-damped exponents
    s1, s2: ``Oscillator.search_constants``), its free response in ``form`` on the constants
    c0..c7 (``response_constants``), ice from velocity w0 under its drag law (``quadratic`` 0:
    the linear drag, coef = rate = kappa; 1: the quadratic drag, coef = beta, rate = beta |r0|;
    r0 = w0 - u), gap0 = x0 - z0; no step longer than ``max_step`` (RootSearch's: inf for a
    closed form), ``integrated`` the structure's Taylor steps where the search is compiled
    with the motion of :mod:`.dragged` (unused here).

    Returns (outcome, a, root, iterations, creep, probed_at, f, f', f'', K, J, x - x0, v,
    z - z0, w): PASSED, ROOT (the root, and the motion there: the state of the event), or
    GENERIC with the frontier before the step RootSearch is to make.

    The closed forms are evaluated where :class:`~iceimpact.solvers.exact.Flight` evaluates
    them, no more: the last point evaluated and its motion are kept (``at``, ``motion``), first
    the anchor (no increments, the anchor's velocities), as Flight keeps its last point."""
    k = (c0, c1, c2, c3, c4, c5, c6, c7)
    over = 1 if form >= FORM_OVER else 0
    at, motion = 0.0, (0.0, c6 if form == FORM_MODES else c5, 0.0, w0)
    outcome = PASSED
    while a <= horizon:
        if a != at:  # (the anchor, a sign test's end and a Newton point are kept)
            at, motion = a, _motion(a, form, k, rate, w0, r0, quadratic, integrated)
        dx, v, dz, w = motion
        if a == probed_at:
            f, df, d2, bound, jerk = pf, pdf, pd2, pbound, pjerk
        else:
            # Flight.probe: the structure's bounds and the drag's accel_bounds
            a_x, size_x, jerk_x = _structure_probe(x0 + dx, v, offset, mass, damping,
                                                   stiffness, omega2, over, s_slow, s_fast, u,
                                                   integrated)
            a_z, size, j_z = _ice_accel(w, u, coef, quadratic)
            f = gap0 + (dx - dz)
            df = v - w
            d2 = a_x - a_z
            bound = size_x + size
            jerk = jerk_x + j_z
            if bound != bound or jerk != jerk:
                break  # (RootSearch's probe: hypot's scales)
        if f < 0.0 or (f == 0.0 and df < 0.0):
            return (ROOT, a, a, iterations + 1, creep, probed_at, pf, pdf, pd2, pbound, pjerk,
                    dx, v, dz, w)
        df_size = df if df >= 0.0 else -df
        d2_size = d2 if d2 >= 0.0 else -d2
        total = f + df_size + d2_size + bound + jerk
        floor = SPREAD * total
        outcome = GENERIC  # (any break below leaves the step to RootSearch)
        if (0.0 < f < floor or df_size < floor or d2_size < floor or bound < floor
                or jerk < floor or not _SUM_NEAR_1_LOW <= total <= SCALED_ABOVE
                or bound <= 0.0):
            break  # (a probe RootSearch may rescale, or a linear signal)
        disc = sqrt(df * df + 2.0 * bound * f)
        h_free = (df + disc) / bound if df >= 0.0 else 2.0 * f / (disc - df)
        if not z0 + dz >= offset:  # Flight.clearance (0 with the ice at or past x = offset)
            cleared = _clearance(x0 + dx, v, z0 + dz, w, offset, omega2, sigma, over, s_slow,
                                 s_fast, u, coef, quadratic)
            if cleared != cleared:
                break  # (a clearance RootSearch's Flight computes)
            if cleared > h_free:
                h_free = cleared
        if df >= 0.0:
            if jerk > 0.0:
                h_rise = (d2 + sqrt(d2 * d2 + 2.0 * jerk * df)) / jerk
            else:
                h_rise = math.inf if d2 >= 0.0 else df / -d2
            if h_rise > h_free:
                h_free = h_rise
        else:
            h_mono = -df / bound
            if jerk > 0.0:
                root = sqrt(d2 * d2 - 2.0 * jerk * df)
                if d2 < 0.0:
                    h_jerk = (root - d2) / jerk
                    if h_jerk > h_mono:
                        h_mono = h_jerk
                elif d2 + root > 0.0:
                    h_jerk = -2.0 * df / (d2 + root)
                    if h_jerk > h_mono:
                        h_mono = h_jerk
            elif d2 <= 0.0:
                h_mono = math.inf
            if h_mono > h_free:
                span = FOREVER if FOREVER < h_mono else h_mono
                if max_step < span:
                    span = max_step
                b = a + span
                if b > a:
                    # RootSearch._descend: Newton's method from a on the monotone stretch [a, b]
                    t, f_t, df_t = a, f, df
                    disc = df * df - 2.0 * f * d2
                    step = 2.0 * f / (sqrt(disc) - df) if disc >= 0.0 else f / -df
                    found = math.nan
                    stalled = False
                    for _ in range(DESCENT_STEPS):
                        if not df_t < 0.0:
                            break
                        nxt = t + step
                        if nxt >= b:
                            break
                        if step <= ROOT_XTOL + ROOT_RTOL * (t if t >= 0.0 else -t):
                            found = t
                            break
                        at, motion = nxt, _motion(nxt, form, k, rate, w0, r0, quadratic,
                                                  integrated)
                        dx, v, dz, w = motion
                        f_n = gap0 + (dx - dz)
                        df_n = v - w
                        if f_n < 0.0:
                            found, at, motion = _bracketed(t, nxt, nxt, f_n, df_n, motion, gap0,
                                                           form, k, rate, w0, r0, quadratic,
                                                           integrated)
                            stalled = found != found
                            break
                        if f_n == 0.0:
                            found = nxt
                            break
                        t, f_t, df_t = nxt, f_n, df_n
                        step = f_t / -df_t if df_t < 0.0 else math.inf
                    if stalled:
                        break  # (a NaN from the bracket: RootSearch makes the step)
                    if found != found:  # no root in the descent: the sign test at b decides
                        at, motion = b, _motion(b, form, k, rate, w0, r0,
                                                quadratic, integrated)
                        dx, v, dz, w = motion
                        f_b = gap0 + (dx - dz)
                        if not f_b < 0.0:  # root-free up to b
                            a = b
                            iterations += 1
                            outcome = PASSED
                            continue
                        # exactly one crossing in (t, b)
                        found, at, motion = _bracketed(t, b, b, f_b, v - w, motion, gap0,
                                                       form, k, rate, w0, r0, quadratic,
                                                       integrated)
                        if found != found:
                            break  # (RootSearch's, as a NaN from the bracket above)
                    if found != at:  # (the state at the root: the last point evaluated, or anew)
                        motion = _motion(found, form, k, rate, w0, r0,
                                         quadratic, integrated)
                    dx, v, dz, w = motion
                    return (ROOT, a, found, iterations + 1, creep, probed_at, pf, pdf, pd2,
                            pbound, pjerk, dx, v, dz, w)
        if h_free > FOREVER and max_step == math.inf:
            return (PASSED, math.inf, math.nan, iterations + 1, creep, probed_at, pf, pdf,
                    pd2, pbound, pjerk, math.nan, math.nan, math.nan, math.nan)
        step = max_step if max_step < h_free else h_free
        if step < time_eps + TIME_RESOLUTION * a:
            break  # (a tangent or degenerate start: RootSearch's creep)
        b = a + step
        # the sign test at b by the full probe, which the next step starts from
        at, motion = b, _motion(b, form, k, rate, w0, r0, quadratic, integrated)
        dx, v, dz, w = motion
        f_b = gap0 + (dx - dz)
        if f_b < 0.0:
            break  # (rounding at the frontier: RootSearch's bracket from b)
        a_x, size_x, jerk_x = _structure_probe(x0 + dx, v, offset, mass, damping, stiffness,
                                               omega2, over, s_slow, s_fast, u, integrated)
        a_z, size, j_z = _ice_accel(w, u, coef, quadratic)
        bound_b = size_x + size
        jerk_b = jerk_x + j_z
        if bound_b != bound_b or jerk_b != jerk_b:
            break  # (RootSearch's probe at b: hypot's scales)
        a = probed_at = b
        pf, pdf, pd2 = f_b, v - w, a_x - a_z
        pbound, pjerk = bound_b, jerk_b
        iterations += 1
        creep = 0
        outcome = PASSED
    return (outcome, a, math.nan, iterations, creep, probed_at, pf, pdf, pd2, pbound, pjerk,
            math.nan, math.nan, math.nan, math.nan)


_DISPATCHERS: dict[str, Any] = {}


def compiled_callees(numba: Any) -> dict[str, Any]:
    """numba's dispatchers of :func:`flight_root` and the functions it calls, by name, compiled
    once (a compiled caller, such as the exact method's march of bounces, calls them)."""
    if not _DISPATCHERS:
        f8, i8 = numba.float64, numba.int64
        decay_pair = jit(numba, (f8,), _decay_pair)
        aperiodic = jit(numba, (f8, i8) + (f8,) * 8, aperiodic_increment, _decay_pair=decay_pair)
        under = jit(numba, (f8,) * 7, under_increment)
        ice_motion = jit(numba, (f8, f8, f8, f8, i8), _ice_motion)
        motion = jit(numba, motion_signature(numba, i8), _motion, aperiodic_increment=aperiodic,
                     under_increment=under, _ice_motion=ice_motion)
        ice_accel = jit(numba, (f8, f8, f8, i8), _ice_accel)
        accel_clearance = jit(numba, (f8, f8, f8, f8, i8, f8), _accel_clearance,
                              _ice_accel=ice_accel)
        amplitude = jit(numba, (f8, f8, f8, i8, f8, f8), _amplitude)
        clearance = jit(numba, (f8,) * 7 + (i8,) + (f8,) * 4 + (i8,), _clearance,
                        _accel_clearance=accel_clearance, _amplitude=amplitude)
        probe = jit(numba, probe_signature(numba, i8), _structure_probe, _amplitude=amplitude)
        callees = {"_motion": motion, "_ice_accel": ice_accel, "_clearance": clearance,
                   "_structure_probe": probe}
        _DISPATCHERS.update(callees, _ice_motion=ice_motion,
                            flight_root=compile_root(numba, i8, callees))
    return _DISPATCHERS


def motion_signature(numba: Any, integrated: Any) -> tuple:
    """The argument types of :func:`_motion` (and of a motion compiled in its place) with the
    structure's steps of type ``integrated``."""
    f8, i8 = numba.float64, numba.int64
    return (f8, i8, numba.types.UniTuple(f8, 8), f8, f8, f8, i8, integrated)


def probe_signature(numba: Any, integrated: Any) -> tuple:
    """The argument types of :func:`_structure_probe` (and of one compiled in its place)."""
    f8, i8 = numba.float64, numba.int64
    return (f8,) * 7 + (i8, f8, f8, f8, integrated)


def compile_root(numba: Any, integrated: Any, callees: dict[str, Any]) -> Any:
    """:func:`flight_root` compiled on ``callees`` (the compiled functions it calls by name:
    ``_motion``, ``_structure_probe``, ``_clearance``, ``_ice_accel``), the
    structure's steps of type ``integrated``: this module's closed forms, or another
    structure's motion (:mod:`.dragged`)."""
    f8, i8 = numba.float64, numba.int64
    bracketed = jit(numba, (f8,) * 5 + (numba.types.UniTuple(f8, 4), f8, i8,
                                        numba.types.UniTuple(f8, 8), f8, f8, f8, i8, integrated),
                    _bracketed, _motion=callees["_motion"])
    return jit(numba, (f8, f8, i8, i8) + (f8,) * 18 + (i8,) + (f8,) * 13 + (i8, f8, integrated),
               flight_root, _bracketed=bracketed, **callees)


def _compiled():
    """:func:`flight_root` compiled by numba, or None (not installed, or ICEIMPACT_PURE set:
    :mod:`iceimpact.compiled`).

    Compiled at import for its one signature (floats, the two counters integers), so that no
    run pays for it; the machine code goes to the kernels' cache in the user's cache folder
    (:mod:`iceimpact.compiled`), which later imports load, wherever the source lies."""
    return compile_or_none("the flight search",
                           lambda numba: entry_point(compiled_callees(numba)["flight_root"]))


#: numba's compiled :func:`flight_root` where available (``fast`` extra), else None: the
#: flights then search with the pure function
COMPILED = _compiled()
_UNPROBED = (math.nan,) * 5


class FlightSearch(RootSearch):
    """The root search of a flight's gap (the free structure in any damping regime, the ice
    under either drag law):
    RootSearch, whose common steps :func:`flight_root` makes. The signal is the
    :class:`~iceimpact.solvers.exact.Flight` itself (its anchor, its oscillator and the
    constants of its closed forms)."""

    #: the steps' function: the compiled one where numba is, else the pure one
    kernel = staticmethod(flight_root if COMPILED is None else COMPILED)
    #: a step was RootSearch's: the rest of the search is too (a probe to rescale, an undamped
    #: structure's drift clearance, a tangent start: rare). A class default, so that the
    #: search of a flight, made at every impact, needs no __init__ of its own.
    handed_back = False

    def checkpoint(self) -> tuple:
        # RootSearch.checkpoint's fields and handed_back, in one tuple (taken at every step)
        return (self.a, self.root, self.iterations, self.creep, self._probed_at, self._probed,
                self.handed_back)

    def rollback(self, saved: tuple) -> None:
        (self.a, self.root, self.iterations, self.creep, self._probed_at, self._probed,
         self.handed_back) = saved

    def next_root_of(self, horizon: float, signal: Any) -> float | None:
        root = self.root
        if root is not None:
            return root if root <= horizon else None
        if not self.a <= horizon:
            return None
        if self.handed_back:
            return RootSearch.next_root_of(self, horizon, signal)
        # the flight's constants (Flight.kernel_constants): gap0, x0, z0, the oscillator's
        # (Oscillator.search_constants), its free response's (response_constants), the ice's
        # (rate, w0, r0: the drag's flight_constants), u, the drag law (coefficient,
        # quadratic: its law_constants)
        (outcome, a, root, iterations, creep, probed_at, f, df, d2, bound, jerk, dx, v, dz,
         w) = self.kernel(horizon, self.a, self.iterations, self.creep, self._probed_at,
                          *(self._probed or _UNPROBED), self.time_eps, *signal.kernel_constants)
        if a != a or (outcome == ROOT and root != root):
            # a NaN where Python's math would have raised (a domain error): the compiled
            # function's only departure from the pure one; RootSearch makes the search from
            # the frontier as it was, and raises or answers as the pure path does
            return self._hand_back(horizon, signal)
        self.a, self.iterations, self.creep = a, iterations, creep
        if probed_at != self._probed_at:
            self._probed_at = probed_at
            self._probed = (f, df, d2, bound, jerk)
        if outcome == ROOT:
            self.root = root
            signal.remember((root, dx, v, dz, w))  # the state there
            return root if root <= horizon else None
        if outcome == GENERIC:
            return self._hand_back(horizon, signal)
        return None

    def _hand_back(self, horizon: float, signal: Any) -> float | None:
        """RootSearch makes this search from its frontier on."""
        self.handed_back = True
        return RootSearch.next_root_of(self, horizon, signal)
