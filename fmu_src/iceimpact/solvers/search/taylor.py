"""High-order Taylor steps of the sticking phase under quadratic drag (method 1).

While the bodies stick they obey the sticking equation (model.md, sticking contact; the drag of
eq. 2-3 on the ice moving with the structure)::

    (m + M) x'' + c x' + k x = B |u - x'| (u - x')

While the sign s of the relative flow r = u - x' holds, the drag is ``s B r^2``, a polynomial in
the state, so the Taylor coefficients of x, v = x' and the drag impulse P (P' = drag) follow
exactly by recurrence, (r^2)_n being the Cauchy product of r with itself::

    x_{n+1} = v_n / (n + 1)
    v_{n+1} = (s B (r^2)_n - c v_n - k x_n) / ((m + M) (n + 1)),    r_0 = u - v_0, r_n = -v_n
    P_{n+1} = s B (r^2)_n / (n + 1)

and the contact force on the structure, ``lam = drag - M x''`` (the drag on the ice minus its
inertia), is the polynomial ``lam_n = s B (r^2)_n - M (n + 1) v_{n+1}``.

A step of order ``ORDER`` is as long as its last two terms stay below ``TOLERANCE`` of the
motion's scale (the step-size rule of Jorba and Zou, 2005), at most ``max_step``. Within the step
the polynomials are the dense output. A mode of rate lambda (the stiffest of the sticking
equation's: sqrt(k / (m + M)), c / (m + M), the drag's 2 B |u - v| / (m + M)) has terms
(lambda h)^n / n!, so steps are about 5 / lambda long (measured 0.1-0.3 steps x lambda per
simulated second) whatever the motion's amplitude: the work per simulated second is
proportional to lambda, which the validation holds to ``limits.TAYLOR_RATE_MAX``. A step ends early

- where r changes sign (the drag's polynomial changes): the next step starts with v = u exactly
  and takes the sign r moves to;
- where the contact force turns tensile (separation), when separation is looked for.

Both are first roots of a polynomial on the step, searched without a miss: on an interval of the
normalised step time [0, 1] where the polynomial is >= 0 at both ends, a bound K on its curvature
proves it nonnegative throughout when ``min(ends) >= K (b - a)^2 / 8``; otherwise the interval is
halved. A zero the polynomial only touches is no root (as in :mod:`.rootfind`).

Each step depends only on its start time and state, so steps do not depend on the communication
step, and a step rebuilt from its start (a restored state) has the same coefficients to the bit.

**The same bits on every machine** (docs/explanation/accuracy.md#machine-independence). The
arithmetic is
``+ - * /`` in an order this module fixes, so no BLAS kernel or SIMD level moves a bit: the
Cauchy products are summed by a loop in a fixed order (not by the built-in ``sum``, whose
rounding of floats changed in Python 3.12), the powers ``h^n`` are the C library's
``pow`` (Python's ``**`` on floats, not numpy's vectorised ``power``), the polynomials are
evaluated by Horner's rule, one coefficient after the other (:func:`horner`, and
:func:`horner_rows` for many times at once, operation for operation the same), and the values on
the sample grid are products summed in numpy's pairwise order (:func:`pairwise_sum`, numpy's
``add.reduce`` along a row, the order its code fixes, written out), never a matrix product
(``@`` goes to BLAS, whose kernels sum and fuse in CPU-specific orders).

A step up to the proof that no root lies on it is one function over plain floats, lists and
arrays (:func:`~.taylor_series.ordinary_step`, with the recurrence, the step-size rule and the
proof in :mod:`.taylor_series`; Horner's rule is a kernel too), run as Python by the pure path
and compiled by numba where it is installed (:data:`KERNELS`, :mod:`iceimpact.compiled`), the
same floats either way; :func:`run_steps` makes the steps of
a sticking phase one after the other in one compiled call while they are ordinary, and hands
the others back to Python (docs/explanation/speed.md).
"""

from __future__ import annotations

import enum
import math
from bisect import bisect_right
from operator import attrgetter

import numpy as np
from scipy.optimize import brentq

from ...compiled import compile_or_none, entry_point, jit
from .taylor_series import (
    _EXPONENT_LIST,
    _GRID,
    _NO_COLUMNS,
    _NO_TABLE,
    _POWERS,
    _RECIPROCAL_LIST,
    _RECIPROCALS,
    MAX_EVALUATIONS,
    MAYBE_ROOT,
    NO_ROOT,
    NO_STEP,
    ORDER,
    SAMPLES,
    HandBack,
    compiled_step,
    horner_columns,
    ordinary_step,
)


class StepEnd(enum.Enum):
    """How a Taylor step ends."""

    LENGTH = "length"          # its full length (or the end of a hold)
    FLIP = "flip"              # the relative flow u - v changes sign
    SEPARATION = "separation"  # the contact force turns tensile


def horner(coeffs: list[float], theta: float) -> float:
    """Value at theta of the polynomial sum coeffs[n] theta^n (Horner's rule, from the highest
    coefficient)."""
    acc = 0.0
    for c in reversed(coeffs):
        acc = acc * theta + c
    return acc


def horner_rows(coeffs: np.ndarray, rows: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """:func:`horner` for many polynomials at once, operation for operation (the same floats):
    ``coeffs[n, i, j]`` the n-th coefficient of polynomial j of table i; the values, a row for
    each time, of table ``rows[k]`` at ``theta[k]``."""
    acc = np.zeros((theta.size, coeffs.shape[2]))
    theta = theta[:, None]
    for n in range(coeffs.shape[0] - 1, -1, -1):
        acc *= theta
        acc += coeffs[n][rows]
    return acc


def step_states(los, his, hs, tables, ends, tau, out):
    """:func:`states_of_steps` as loops, for numba: ``out[k]`` the state (x, v, P) at
    ``tau[k]`` in the last step i with ``los[i] <= tau[k]`` (step 0 if none): the end state
    ``ends[i]`` from ``his[i]`` on, else :func:`horner` of the step's table ``tables[i]``
    (order, column) at theta = (tau - lo) / h. The samples of a step go through Horner's rule
    together, one coefficient at a time for all of them: a loop numba vectorises, each sample
    the same operations in the same order as alone."""
    count = tau.size
    thetas, xs, vs, ps = np.empty(count), np.empty(count), np.empty(count), np.empty(count)
    last = los.size - 1
    top = tables.shape[1] - 1
    i = 0
    k = 0
    while k < count:
        t = tau[k]
        while i < last and los[i + 1] <= t:
            i += 1
        while i > 0 and los[i] > t:
            i -= 1
        if not t < his[i]:
            out[k, 0], out[k, 1], out[k, 2] = ends[i, 0], ends[i, 1], ends[i, 2]
            k += 1
            continue
        lo, h, hi = los[i], hs[i], his[i]
        following = los[i + 1] if i < last else math.inf
        j = k  # samples k..j-1: inside step i
        while j < count:
            t = tau[j]
            if not (t < hi and t < following and (i == 0 or lo <= t)):
                break
            thetas[j - k] = (t - lo) / h
            j += 1
        length = j - k
        for q in range(length):
            xs[q] = vs[q] = ps[q] = 0.0
        for n in range(top, -1, -1):
            cx, cv, cp = tables[i, n, 0], tables[i, n, 1], tables[i, n, 2]
            for q in range(length):
                theta = thetas[q]
                xs[q] = xs[q] * theta + cx
                vs[q] = vs[q] * theta + cv
                ps[q] = ps[q] * theta + cp
        for q in range(length):
            out[k + q, 0], out[k + q, 1], out[k + q, 2] = xs[q], vs[q], ps[q]
        k = j


def _first_root(coeffs: np.ndarray, values: np.ndarray, curvature: float, doubtful: np.ndarray,
                theta_end: float) -> float | None:
    """First theta in (0, theta_end] where the polynomial sum coeffs[n] theta^n (>= 0 at 0) goes
    below zero, or None. ``values`` are its values on the sample grid, ``curvature`` a bound K on
    |p''| on [0, 1], ``doubtful`` the sample intervals not proven root-free
    (:func:`proven_intervals`), which are halved until proven or a sign change is found. A zero
    the polynomial approaches closer than the halvings resolve is taken for a touch (no
    root)."""
    if values[0] < 0.0:
        return 0.0
    poly = coeffs.tolist()
    budget = MAX_EVALUATIONS
    for i in doubtful.tolist():
        stack = [(_GRID[i], float(values[i]), _GRID[i + 1], float(values[i + 1]))]
        while stack:
            a, pa, b, pb = stack.pop()
            if a >= theta_end:
                return None
            if b > theta_end:
                b = theta_end
                pb = horner(poly, b)
            if pb < 0.0:
                # a root near theta = 0 may need bisection down to denormal scales (over 1,000
                # halvings): brentq's default of 100 iterations raised there; its best bracket
                # end is within the tolerance it reached
                # the grid's values (summed products) and Horner's differ by rounding: where
                # they disagree on a sign, the crossing is at that end
                at_a = horner(poly, a)
                if at_a < 0.0 or (at_a == 0.0 and a > 0.0):
                    return a
                if horner(poly, b) >= 0.0:
                    return b
                if at_a == 0.0:  # a zero at the step's start (u - v = 0 after a sign
                    # change): the crossing is the next one, beyond a point where it is > 0
                    a = _rise_from_zero(poly, b)
                    if a is None:
                        return 0.0
                root, _ = brentq(lambda theta: horner(poly, theta), a, b, xtol=1e-300,
                                 rtol=4.0 * 2.0 ** -52, maxiter=1100, full_output=True,
                                 disp=False)
                return root
            if min(pa, pb) >= curvature * (b - a) ** 2 / 8.0 or budget <= 0:
                continue  # proven >= 0 on [a, b] (or a touch)
            budget -= 1
            mid = 0.5 * (a + b)
            pm = horner(poly, mid)
            stack.append((mid, pm, b, pb))
            stack.append((a, pa, mid, pm))
    return None


def _rise_from_zero(poly: list[float], b: float) -> float | None:
    """A point of (0, b) where the polynomial, 0 at 0 and below 0 at b, is above 0 (halving b,
    at most 1,100 times: down to the smallest floats), or None if none is found: it goes below
    zero at once."""
    theta = b
    for _ in range(1100):
        theta *= 0.5
        if theta == 0.0:
            return None
        if horner(poly, theta) > 0.0:
            return theta
    return None


class TaylorStep:
    """One Taylor step from ``lo`` (s, from the segment's anchor) at state ``y_lo`` = (x, v, P):
    its polynomials in theta = (tau - lo) / h (``table``, a column each), its end ``hi`` <= lo + h,
    how it ends and the state there. As constructed, a step that ends where it starts: a
    separation at once."""

    __slots__ = ("lo", "hi", "h", "y_lo", "table", "columns", "end", "y_hi")

    def __init__(self, lo: float, y_lo: tuple[float, float, float]):
        self.lo = lo
        self.y_lo = y_lo
        self.h = 0.0
        self.table = _NO_TABLE      # coefficients, a column each for x, v, P
        self.columns = _NO_COLUMNS  # the same as lists of floats, for :meth:`evaluate`
        self.end = StepEnd.SEPARATION
        self.hi = lo
        self.y_hi = y_lo

    def state(self, tau: float) -> tuple[float, float, float]:
        """(x, v, P) at tau (s from the segment's anchor), lo <= tau; the end state from hi on."""
        if tau >= self.hi:
            return self.y_hi
        return self.evaluate((tau - self.lo) / self.h)

    def evaluate(self, theta: float) -> list[float]:
        """[x, v, P] at the normalised time theta of the step (:func:`horner`)."""
        if KERNELS is not None:
            return list(KERNELS.horner_columns(self.table, theta))
        x, v, p = self.columns
        return [horner(x, theta), horner(v, theta), horner(p, theta)]


#: a step's start, the key a list of steps is ordered by
_step_lo = attrgetter("lo")
#: Samples evaluated together by :func:`states_of_steps` (their temporaries stay in cache)
SAMPLE_CHUNK = 2048


def states_of_steps(steps: list[TaylorStep], tau: np.ndarray) -> np.ndarray:
    """Vectorised :meth:`TaylorStep.state`: rows (x, v, P) at the times tau (s from the segment's
    anchor, increasing), each in the last of ``steps`` starting at or before it (the first step
    for a time before them all), the same floats as :meth:`TaylorStep.state` at each. Compiled
    where numba is (:func:`step_states`), else :func:`horner_rows` over SAMPLE_CHUNK samples at
    a time."""
    tau = np.ascontiguousarray(tau, dtype=float)
    out = np.empty((tau.size, 3))
    if tau.size == 0:
        return out
    # the steps from the one holding tau[0] to the one holding tau[-1]
    first = max(bisect_right(steps, float(tau[0]), key=_step_lo) - 1, 0)
    steps = steps[first:max(bisect_right(steps, float(tau[-1]), key=_step_lo), first + 1)]
    if KERNELS is not None:
        KERNELS.step_states(np.array([s.lo for s in steps]), np.array([s.hi for s in steps]),
                            np.array([s.h for s in steps]), np.stack([s.table for s in steps]),
                            np.array([s.y_hi for s in steps]), tau, out)
        return out
    index = np.searchsorted([s.lo for s in steps], tau, side="right") - 1
    np.maximum(index, 0, out=index)
    for start in range(0, tau.size, SAMPLE_CHUNK):
        part = slice(start, start + SAMPLE_CHUNK)
        first, last = int(index[part][0]), int(index[part][-1])
        near = steps[first:last + 1]
        rows = index[part] - first
        times = tau[part]
        inside = times < np.array([s.hi for s in near])[rows]
        values = np.empty((times.size, 3))
        if inside.any():
            rows_in = rows[inside]
            los = np.array([s.lo for s in near])[rows_in]
            hs = np.array([s.h for s in near])[rows_in]
            tables = np.stack([s.table for s in near], axis=1)  # order, step, column
            values[inside] = horner_rows(tables, rows_in, (times[inside] - los) / hs)
        if not inside.all():
            values[~inside] = np.array([s.y_hi for s in near])[rows[~inside]]
        out[part] = values
    return out


def _clearly_pushes(table, rs, fs, x, v, drag_B, structure_B, c, k, M, total):
    """Whether the contact force at a step's start is a push beyond doubt: the series' lam_0
    above 1e-12 of the terms it is made of, far beyond the rounding by which the separation test
    (Together.contact_force, the same terms in another order) can differ from it; otherwise
    that test runs in Python."""
    r0 = rs[0]
    drive = abs((drag_B + structure_B) * r0 * r0) + abs(c * v) + abs(k * x)
    return table[4, 0] > 1e-12 * (abs(fs[0]) + M * drive / total)


def run_steps(lo, x, v, p, start, tau_end, u, drag_B, structure_B, c, k, M, total, max_step,
              order_over, reciprocals, exponents, rs, fs, table, powers, terms, partial, sums,
              proven, los, hs, his, states, tables, done):
    """Steps of a sticking phase from lo (s) at state (x, v, P), one from the end of the other,
    as :class:`StickingTaylor` takes them (a hold before ``start``, then looking for the
    separation), while each is an ordinary step: its contact force a push at its start beyond
    doubt (:func:`_clearly_pushes`), no root on it (:func:`ordinary_step`), a finite end after
    its start. Stops after the step reaching tau_end, or before the first step that is not
    ordinary (the caller takes it). Step i: ``los[i]``, ``hs[i]``, ``his[i]``, its
    coefficients ``tables[i]`` (order, column), its states at lo and hi ``states[i]``,
    ``states[i + 1]``; ``done[0]`` counts the steps (also when a :class:`HandBack` ends the
    run)."""
    done[0] = 0
    states[0, 0], states[0, 1], states[0, 2] = x, v, p
    count = 0
    while count < los.size:
        hold = lo < start
        until = start if hold else math.inf
        outcome, h, theta_end = ordinary_step(
            lo, x, v, p, until, not hold, u, drag_B, structure_B, c, k, M, max_step,
            order_over, reciprocals, exponents, rs, fs, table, powers, terms, partial, sums,
            proven, 0.0)
        if outcome != NO_ROOT or not (hold or _clearly_pushes(table, rs, fs, x, v, drag_B,
                                                              structure_B, c, k, M, total)):
            break
        step_table = tables[count]
        for n in range(ORDER + 1):
            for j in range(3):
                step_table[n, j] = table[j, n]
        x_hi, v_hi, p_hi = horner_columns(step_table, theta_end)
        hi = until if theta_end < 1.0 else lo + h
        if not (math.isfinite(x_hi) and math.isfinite(v_hi) and math.isfinite(p_hi)
                and hi > lo):
            break
        los[count], hs[count], his[count] = lo, h, hi
        count += 1
        done[0] = count
        states[count, 0], states[count, 1], states[count, 2] = x_hi, v_hi, p_hi
        lo, x, v, p = hi, x_hi, v_hi, p_hi
        if hi >= tau_end:
            break
    return count


class _Kernels:
    """The kernels compiled by numba: the same floats as the pure functions (one step's,
    :func:`~.taylor_series.compiled_step`; the runs of steps and the states on them, this
    module's). The Python-only branches of a step raise :class:`HandBack` in them."""

    def __init__(self, numba):
        f8, i8, b1 = numba.float64, numba.int64, numba.boolean
        array, table = f8[::1], f8[:, ::1]
        cube = f8[:, :, ::1]
        step = compiled_step(numba)
        ordinary, columns = step["ordinary_step"], step["horner_columns"]
        self.recurrence = entry_point(step["taylor_recurrence"])
        self.step_states = entry_point(jit(
            numba, numba.void(array, array, array, cube, table, array, table), step_states))
        self.horner_columns = entry_point(columns)
        self.ordinary_step = entry_point(ordinary)
        pushes = jit(numba, (table, array, array, *(f8,) * 8), _clearly_pushes)
        #: the dispatchers a compiled caller calls (the dragged flight's steps, .dragged)
        self.dispatchers = {"ordinary_step": ordinary, "horner_columns": columns}
        self.run_steps = entry_point(jit(
            numba, (*(f8,) * 14, *(array,) * 5, table, array, cube, cube, table, b1[:, ::1],
                    array, array, array, table, cube, i8[::1]),
            run_steps, ordinary_step=ordinary, horner_columns=columns,
            _clearly_pushes=pushes))


#: numba's compiled kernels where available (``fast`` extra), else None: the pure functions run
KERNELS: _Kernels | None = compile_or_none("the Taylor steps", _Kernels)


class _Work:
    """A stepper's work arrays (:func:`ordinary_step`): lists where the pure recurrence runs
    (faster in Python), arrays for the compiled kernels."""

    __slots__ = ("rs", "fs", "table", "powers", "terms", "partial", "sums", "proven")

    def __init__(self, compiled: bool):
        if compiled:
            self.rs, self.fs, self.powers = np.empty(ORDER + 1), np.empty(ORDER), \
                np.empty(ORDER + 1)
        else:
            self.rs, self.fs, self.powers = [0.0] * (ORDER + 1), [0.0] * ORDER, \
                [0.0] * (ORDER + 1)
        self.table = np.empty((5, ORDER + 1))
        self.terms = np.empty((2, SAMPLES + 2, ORDER + 1))  # signal, point, order
        self.partial = np.empty((2, SAMPLES + 2, 8))
        self.sums = np.empty((SAMPLES + 2, 2))
        self.proven = np.empty((SAMPLES, 2), dtype=bool)

    def arrays(self) -> tuple:
        return (self.rs, self.fs, self.table, self.powers, self.terms, self.partial, self.sums,
                self.proven)


#: Steps a compiled run makes at most in one call (:meth:`StickingTaylor.run`)
RUN_STEPS = 128


class StickingTaylor:
    """Taylor steps of the sticking equation for given coefficients: the bodies' total mass
    (kg), the structural damping c (N.s/m) and stiffness k (N/m), the quadratic drag constant B
    (kg/m, eq. 33) and flow speed u (m/s), and the ice mass M (kg) whose inertia the contact force
    subtracts from the drag. ``structure_B`` (kg/m) is the quadratic Morison drag on the
    structure (docs/explanation/morison.md): it drives the bodies with the ice's drag, but is no
    part of the contact force nor of the ice's drag impulse P."""

    def __init__(self, total_mass: float, damping: float, stiffness: float, drag_B: float,
                 flow_u: float, ice_mass: float, max_step: float, structure_B: float = 0.0):
        self.total, self.c, self.k = total_mass, damping, stiffness
        self.B, self.u, self.M = drag_B, flow_u, ice_mass
        self.structure_B = structure_B  # quadratic Morison drag on the structure (0: off)
        self.max_step = max_step
        order_over = [1.0 / (total_mass * (n + 1)) for n in range(ORDER)]
        self._work = _Work(KERNELS is not None)
        if KERNELS is not None:
            self._constants = (np.array(order_over), _RECIPROCALS, _POWERS)
        else:
            self._constants = (order_over, _RECIPROCAL_LIST, _EXPONENT_LIST)

    def _ordinary(self, lo: float, y: tuple[float, float, float], until: float,
                  look_for_separation: bool, sign: float = 0.0) -> tuple[int, float, float]:
        """:func:`ordinary_step` from lo at y (with the drag's sign ``sign``, 0.0: its own
        rule), compiled where numba is (in Python where the compiled one hands back), into the
        work arrays."""
        args = (lo, *y, until, look_for_separation, self.u, self.B, self.structure_B, self.c,
                self.k, self.M, self.max_step, *self._constants, *self._work.arrays(), sign)
        if KERNELS is not None:
            try:
                return KERNELS.ordinary_step(*args)
            except HandBack:
                pass
        return ordinary_step(*args)

    def step(self, lo: float, y: tuple[float, float, float], until: float,
             look_for_separation: bool) -> TaylorStep:
        """The step from lo (s) at state y = (x, v, P), ending at ``until`` at the latest.
        Raises ArithmeticError where it would end in a state that is not finite.

        From u - v = 0 the drag's sign is the one u - v moves to, read from its first non-zero
        Taylor coefficient. Where u - v only touches 0 (v at an extremum equal to u, the step
        before ending there on rounding), that coefficient is rounding, its sign may be wrong,
        and the step would end at once at a sign change that is not there: the step is then
        taken with the other sign, for which u - v keeps its sign (the drag is s B r^2, the
        same at r = 0 either way)."""
        step = self._step(lo, y, until, look_for_separation, 0.0)
        if step.end is StepEnd.FLIP and step.hi == lo and y[1] == self.u:
            for sign in (1.0, -1.0):
                other = self._step(lo, y, until, look_for_separation, sign)
                if not (other.end is StepEnd.FLIP and other.hi == lo):
                    return other
        return step

    def _step(self, lo: float, y: tuple[float, float, float], until: float,
              look_for_separation: bool, sign: float) -> TaylorStep:
        """:meth:`step` with the drag's sign ``sign`` (0.0: :func:`drag_sign`'s)."""
        step = TaylorStep(lo, y)
        outcome, h, theta_end = self._ordinary(lo, y, until, look_for_separation, sign)
        if outcome == NO_STEP:
            raise ArithmeticError(f"no Taylor step from t = {lo!r} s at state {y!r}")
        h, theta_end = float(h), float(theta_end)
        table = self._work.table  # coefficients of theta = (tau - lo) / h
        end = StepEnd.LENGTH
        if outcome == MAYBE_ROOT:
            rows = 2 if look_for_separation else 1
            values = self._work.sums[:SAMPLES + 1, :rows]
            curvatures = self._work.sums[SAMPLES + 1, :rows]
            proven = self._work.proven
            for row, kind in enumerate((StepEnd.FLIP, StepEnd.SEPARATION)[:rows]):
                root = _first_root(table[3 + row], values[:, row], float(curvatures[row]),
                                   np.flatnonzero(~proven[:, row]), theta_end)
                if root is not None:
                    theta_end, end = root, kind
        step.h, step.end = h, end
        step.table = np.ascontiguousarray(table[:3].T)
        if KERNELS is None:
            step.columns = table[:3].tolist()
        if end is StepEnd.LENGTH:
            step.hi = until if theta_end < 1.0 else lo + h
        else:
            step.hi = lo + theta_end * h
        x_hi, v_hi, p_hi = step.evaluate(theta_end)
        if end is StepEnd.FLIP:
            v_hi = self.u  # exactly: the next step starts from r = 0
        step.y_hi = (x_hi, v_hi, p_hi)
        if not (math.isfinite(x_hi) and math.isfinite(v_hi) and math.isfinite(p_hi)
                and step.hi >= lo):
            raise ArithmeticError(f"state {step.y_hi!r} at {step.hi!r} s from the start")
        return step

    def run(self, lo: float, y: tuple[float, float, float], start: float,
            tau_end: float) -> list[TaylorStep]:
        """The ordinary steps of a sticking phase from lo (s) at y = (x, v, P), a hold before
        ``start``, up to the one reaching tau_end, made by one compiled call
        (:func:`run_steps`): the steps :meth:`step` makes, to the bit; none where numba is not
        (or the first step is not ordinary): the caller then takes the next step itself."""
        if KERNELS is None:
            return []
        states = np.empty((RUN_STEPS + 1, 3))
        tables = np.empty((RUN_STEPS, ORDER + 1, 3))
        los, hs, his = np.empty(RUN_STEPS), np.empty(RUN_STEPS), np.empty(RUN_STEPS)
        done = np.zeros(1, dtype=np.int64)
        try:
            KERNELS.run_steps(lo, *y, start, tau_end, self.u, self.B, self.structure_B, self.c,
                              self.k, self.M, self.total, self.max_step, *self._constants,
                              *self._work.arrays(), los, hs, his, states, tables, done)
        except HandBack:
            pass
        count = int(done[0])
        ys = [tuple(row) for row in states[1:count + 1].tolist()]
        steps = []
        y_lo = y
        for lo_i, h, hi, table, y_hi in zip(los[:count].tolist(), hs[:count].tolist(),
                                            his[:count].tolist(), tables[:count], ys,
                                            strict=True):
            step = TaylorStep(lo_i, y_lo)
            step.h, step.hi, step.table, step.end, step.y_hi = h, hi, table, StepEnd.LENGTH, y_hi
            steps.append(step)
            y_lo = y_hi
        return steps
