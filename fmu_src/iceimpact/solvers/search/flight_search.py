"""The root search of a flight's gap in one function: :class:`~.rootfind.RootSearch`'s common
steps, specialised to the free structure in every damping regime (eq. 9-10 and the critically
and over-damped forms) and the ice under either drag law (eq. 6-7, 31-33), compiled by numba when
it is installed (the ``fast`` extra).

A flight of Figure 2 spends most of its time in its root search: two probes of the gap and its
bounds, a Taylor stretch, a monotone stretch and one or two Newton points, some 80 calls of small
Python functions. :func:`flight_root` makes the same steps on plain floats, with the closed forms
and bounds written out, so that it compiles as one function; the solver calls it for each flight
it applies to (:meth:`FlightSearch.next_root_of`, :mod:`iceimpact.solvers.exact`).

Its rules are RootSearch's: the same functions of :mod:`.step` (:func:`~.step.plan`,
:func:`~.step.descend`, :func:`~.step.bracketed`), compiled here with the gap's evaluation
(:func:`_gap_point`) as their callee. Its arithmetic is that of the closed forms' scalar functions
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
from math import expm1, log1p, sqrt
from typing import Any

from ...compiled import compile_or_none, entry_point, jit, rebound
from ...physics.structure import (
    FORM_MODES,
    FORM_OVER,
    FORM_UNDER,
    _decay_pair,
    aperiodic_increment,
    under_increment,
)
from ..base import ACCEL_CLEARANCE_PHASE, GAP_ROUNDING, GAP_ULPS
from .rootfind import RootSearch
from .step import (
    AT_FRONTIER,
    BEYOND,
    FREE,
    MONOTONE,
    PASSED,
    ROOT,
    bracketed,
    descend,
    plan,
)

#: The outcomes of :func:`flight_root`: the frontier passed the horizon with no root (PASSED), a
#: root was found (ROOT, :mod:`.step`'s; it may lie beyond the horizon), or the next step is
#: RootSearch's to make (GENERIC).
GENERIC = 2


def _gap_point(context, t):
    """The gap at t, as the search evaluates it (:mod:`.step`'s ``evaluate``): (gap, its rate
    v - w, the motion (x - x0, v, z - z0, w)) on the flight's ``context`` (gap0, then the
    structure's form and its constants k of ``response_constants``, the ice's rate, w0, r0 and
    drag law, the Taylor steps ``integrated`` where the structure has no closed form (unused
    here)). The structure's free response is ``Oscillator.deviation_increment``'s
    (``under_increment`` or ``aperiodic_increment``), the ice's :func:`_ice_motion`; a
    structure in Taylor steps has its own (:mod:`.dragged`, which compiles this module's search
    with it)."""
    gap0, form, k, rate, w0, r0, quadratic, integrated = context
    if form == FORM_UNDER:
        dx, v = under_increment(t, k[0], k[1], k[2], k[3], k[4], k[5])
    else:
        dx, v = aperiodic_increment(t, form, k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7])
    dz, w = _ice_motion(t, rate, w0, r0, quadratic)
    return gap0 + (dx - dz), v - w, (dx, v, dz, w)


def _motion(t, form, k, rate, w0, r0, quadratic, integrated):
    """(x - x0, v, z - z0, w) at t: :func:`_gap_point`'s motion (the march of bounces samples
    a flight with it)."""
    return _gap_point((0.0, form, k, rate, w0, r0, quadratic, integrated), t)[2]


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


def _clearance(x, v, z, w, offset, omega2, sigma, over, s_slow, s_fast, u, coef, quadratic,
               integrated):
    """``Flight.clearance`` at a point where the ice is upstream of the structure's rest
    position (z < offset), written out for the oscillator (damping rate sigma; ``over`` and the
    exponents s1, s2 as :func:`_amplitude` takes them); NaN where the drift clearance or a
    hypot-scaled amplitude bound would be asked (RootSearch's). ``integrated`` is unused (a
    structure of another kind reads its motion there: :mod:`.modal_search`)."""
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

    Each step is :func:`~.step.plan`'s, a monotone stretch :func:`~.step.descend`'s, as
    RootSearch makes them; this function probes the gap (``Flight.probe``), computes the
    clearance (``Flight.clearance``) and makes the sign test at the end of a free step.

    Returns (outcome, a, root, iterations, creep, probed_at, f, f', f'', K, J, x - x0, v,
    z - z0, w): PASSED, ROOT (the root, and the motion there: the state of the event), or
    GENERIC with the frontier before the step RootSearch is to make.

    The closed forms are evaluated where :class:`~iceimpact.solvers.exact.Flight` evaluates
    them, no more: the last point evaluated and its motion are kept (``at``, ``motion``), first
    the anchor (no increments, the anchor's velocities), as Flight keeps its last point."""
    over = 1 if form >= FORM_OVER else 0
    context = (gap0, form, (c0, c1, c2, c3, c4, c5, c6, c7), rate, w0, r0, quadratic,
               integrated)
    v0 = c6 if form == FORM_MODES else c5
    at, point = 0.0, (gap0 + (0.0 - 0.0), v0 - w0, (0.0, v0, 0.0, w0))
    outcome = PASSED
    while a <= horizon:
        if a != at:  # (the anchor, a sign test's end and a Newton point are kept)
            at, point = a, _gap_point(context, a)
        dx, v, dz, w = point[2]
        if a == probed_at:
            f, df, d2, bound, jerk = pf, pdf, pd2, pbound, pjerk
        else:
            # Flight.probe: the structure's bounds and the drag's accel_bounds
            a_x, size_x, jerk_x = _structure_probe(x0 + dx, v, offset, mass, damping,
                                                   stiffness, omega2, over, s_slow, s_fast, u,
                                                   integrated)
            a_z, size, j_z = _ice_accel(w, u, coef, quadratic)
            f = point[0]
            df = point[1]
            d2 = a_x - a_z
            bound = size_x + size
            jerk = jerk_x + j_z
            if bound != bound or jerk != jerk:
                outcome = GENERIC  # (not PASSED: the frontier is short of the horizon)
                break  # (RootSearch's probe: hypot's scales)
        # Flight.clearance (0 with the ice at or past x = offset; NaN where Python's Flight
        # computes it)
        cleared = 0.0
        if not z0 + dz >= offset:
            cleared = _clearance(x0 + dx, v, z0 + dz, w, offset, omega2, sigma, over, s_slow,
                                 s_fast, u, coef, quadratic, integrated)
        what, b = plan(a, f, df, d2, bound, jerk, cleared, 1.0, max_step, time_eps,
                       iterations + 1, creep, False)
        if what == AT_FRONTIER:
            return (ROOT, a, a, iterations + 1, creep, probed_at, pf, pdf, pd2, pbound, pjerk,
                    dx, v, dz, w)
        outcome = GENERIC  # (any break below leaves the step to RootSearch)
        if what == MONOTONE:
            found, root, at, point = _descend(a, f, df, d2, b, 1.0, point, context)
            if found == PASSED:  # root-free up to b
                a = b
                iterations += 1
                outcome = PASSED
                continue
            if root != root:
                break  # (a NaN from the bracket: RootSearch makes the step)
            if root != at:  # (the state at the root: the last point evaluated, or anew)
                point = _gap_point(context, root)
            dx, v, dz, w = point[2]
            return (ROOT, a, root, iterations + 1, creep, probed_at, pf, pdf, pd2, pbound,
                    pjerk, dx, v, dz, w)
        if what == BEYOND:
            return (PASSED, math.inf, math.nan, iterations + 1, creep, probed_at, pf, pdf,
                    pd2, pbound, pjerk, math.nan, math.nan, math.nan, math.nan)
        if what != FREE:
            break  # (a probe to rescale, a linear signal, a tangent or degenerate start)
        # the sign test at b by the full probe, which the next step starts from
        at, point = b, _gap_point(context, b)
        dx, v, dz, w = point[2]
        f_b = point[0]
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
        pf, pdf, pd2 = f_b, point[1], a_x - a_z
        pbound, pjerk = bound_b, jerk_b
        iterations += 1
        creep = 0
        outcome = PASSED
    return (outcome, a, math.nan, iterations, creep, probed_at, pf, pdf, pd2, pbound, pjerk,
            math.nan, math.nan, math.nan, math.nan)


def python_root(**callees: Any) -> Any:
    """:func:`flight_root` run as Python with other functions of the motion (``_gap_point``,
    ``_structure_probe``, ``_clearance``: :mod:`.dragged`'s), the descent and the bracket
    evaluating the gap by the same ``_gap_point``."""
    return rebound(flight_root, _descend=_descent(callees["_gap_point"]), **callees)


def _descent(gap_point: Any) -> Any:
    """:func:`~.step.descend` (and the :func:`~.step.bracketed` it calls) evaluating the gap
    by ``gap_point``, run as Python."""
    return rebound(descend, evaluate=gap_point,
                   bracketed=rebound(bracketed, evaluate=gap_point))


#: the descent of :func:`flight_root` run as Python: the step's on the closed forms' gap
_descend = _descent(_gap_point)
_DISPATCHERS: dict[str, Any] = {}


def argument_types(numba: Any, integrated: Any) -> dict[str, Any]:
    """numba's type of each argument of the search's functions that is not a float, by its
    name (the one declaration from which :func:`signature` derives every signature), with the
    structure's steps of type ``integrated`` (an integer, unused, for the closed forms)."""
    f8, i8 = numba.float64, numba.int64
    k, motion = numba.types.UniTuple(f8, 8), numba.types.UniTuple(f8, 4)
    return {"iterations": i8, "creep": i8, "form": i8, "over": i8, "quadratic": i8, "sample": i8,
            "checked": numba.boolean, "k": k, "motion": motion, "integrated": integrated,
            "point": numba.types.Tuple((f8, f8, motion)),
            "context": numba.types.Tuple((f8, i8, k, f8, f8, f8, i8, integrated))}


def signature(numba: Any, function: Any, integrated: Any = None) -> tuple:
    """The argument types of ``function`` (a function of this package's search: the types
    of :func:`argument_types` by the parameters' names, a float for any other), the
    structure's steps of type ``integrated`` (default: the closed forms')."""
    types = argument_types(numba, numba.int64 if integrated is None else integrated)
    code = function.__code__
    return tuple(types.get(name, numba.float64) for name in code.co_varnames[:code.co_argcount])


def compiled_callees(numba: Any) -> dict[str, Any]:
    """numba's dispatchers of :func:`flight_root` and the functions it calls, by name, compiled
    once (a compiled caller, such as the exact method's march of bounces, calls them)."""
    if not _DISPATCHERS:
        decay_pair = jit(numba, signature(numba, _decay_pair), _decay_pair)
        aperiodic = jit(numba, signature(numba, aperiodic_increment), aperiodic_increment,
                        _decay_pair=decay_pair)
        under = jit(numba, signature(numba, under_increment), under_increment)
        ice_motion = jit(numba, signature(numba, _ice_motion), _ice_motion)
        gap_point = jit(numba, signature(numba, _gap_point), _gap_point,
                        aperiodic_increment=aperiodic, under_increment=under,
                        _ice_motion=ice_motion)
        ice_accel = jit(numba, signature(numba, _ice_accel), _ice_accel)
        accel_clearance = jit(numba, signature(numba, _accel_clearance), _accel_clearance,
                              _ice_accel=ice_accel)
        amplitude = jit(numba, signature(numba, _amplitude), _amplitude)
        clearance = jit(numba, signature(numba, _clearance), _clearance,
                        _accel_clearance=accel_clearance, _amplitude=amplitude)
        probe = jit(numba, signature(numba, _structure_probe), _structure_probe,
                    _amplitude=amplitude)
        callees = {"_gap_point": gap_point, "_ice_accel": ice_accel, "_clearance": clearance,
                   "_structure_probe": probe, "plan": jit(numba, signature(numba, plan), plan)}
        _DISPATCHERS.update(callees, _ice_motion=ice_motion, _amplitude=amplitude,
                            under_increment=under, aperiodic_increment=aperiodic,
                            _motion=jit(numba, signature(numba, _motion), _motion,
                                        _gap_point=gap_point),
                            flight_root=compile_root(numba, numba.int64, callees))
    return _DISPATCHERS


def compile_root(numba: Any, integrated: Any, callees: dict[str, Any],
                 borrows: bool = False) -> Any:
    """:func:`flight_root` compiled on ``callees`` (the compiled functions it calls by name:
    ``_gap_point``, ``_structure_probe``, ``_clearance``, ``_ice_accel``, ``plan``), the
    structure's steps of type ``integrated``: this module's closed forms, or another
    structure's motion (:mod:`.dragged`). The descent and the bracket are :mod:`.step`'s,
    compiled evaluating the gap by the same ``_gap_point``; ``borrows`` as
    :func:`~iceimpact.compiled.jit` takes it."""
    gap_point = callees["_gap_point"]
    bracket = jit(numba, signature(numba, bracketed, integrated), bracketed,
                  evaluate=gap_point, borrows=borrows)
    descent = jit(numba, signature(numba, descend, integrated), descend, evaluate=gap_point,
                  bracketed=bracket, borrows=borrows)
    return jit(numba, signature(numba, flight_root, integrated), flight_root, _descend=descent,
               borrows=borrows, **callees)


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
