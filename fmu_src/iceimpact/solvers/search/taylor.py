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
arrays (:func:`ordinary_step`; the recurrence and Horner's rule are kernels too), run as Python
by the pure path and compiled by numba where it is installed (:data:`KERNELS`,
:mod:`iceimpact.compiled`), the same floats either way; :func:`run_steps` makes the steps of
a sticking phase one after the other in one compiled call while they are ordinary, and hands
the others back to Python (docs/explanation/speed.md).
"""

from __future__ import annotations

import enum
import math
from bisect import bisect_right
from math import fsum as _fsum
from operator import attrgetter

import numpy as np
from scipy.optimize import brentq

from ...compiled import compile_or_none, entry_point, jit

#: Order of the Taylor steps (degree of the position polynomial).
ORDER = 36
#: The last two terms of a step stay below this fraction of the motion over the step.
TOLERANCE = 1e-16
#: Safety factor on the step length (Jorba and Zou: exp(-0.7 / (ORDER - 1))).
SAFETY = math.exp(-0.7 / (ORDER - 1))
#: Samples of the normalised step time at which the first root search starts.
SAMPLES = 8
#: Halvings in one root search before a zero the polynomial approaches is taken for a touch.
MAX_EVALUATIONS = 200

_POWERS = np.arange(ORDER + 1.0)
#: the exponents 0..ORDER as floats: given to the C library's pow at run time (a compiled loop
#: unrolled over constant exponents could turn pow(h, 2.0) into h * h, not always pow's floats)
_EXPONENT_LIST = _POWERS.tolist()
#: (i / SAMPLES)^n at the sample points, each correctly rounded (Python's int / int)
_VANDERMONDE = np.array([[i ** n / SAMPLES ** n for n in range(ORDER + 1)]
                         for i in range(SAMPLES + 1)])
_CURVATURE_WEIGHTS = (_POWERS * (_POWERS - 1)).astype(float)  # |p''| <= sum n(n-1)|c_n| on [0,1]
_GRID = np.linspace(0.0, 1.0, SAMPLES + 1)
_PROOF_MARGIN = 1.0 / (8.0 * SAMPLES * SAMPLES)  # (b - a)^2 / 8 for a sample interval
_RECIPROCALS = 1.0 / np.arange(1, ORDER + 1)
_RECIPROCAL_LIST = _RECIPROCALS.tolist()
_NO_TABLE = np.zeros((ORDER + 1, 3))
_NO_COLUMNS = ([0.0] * (ORDER + 1),) * 3
_INT_POWERS = np.arange(ORDER + 1)
#: Steps from this long on have h^ORDER beyond double precision (2^(28 x 36) < 2^1024 only
#: just): their coefficients are scaled without forming h^n (:func:`_scaled_long`).
_LONG_STEP = 2.0 ** 28
#: :func:`ordinary_step`'s outcomes: no root on the step (it runs its length), a root possible
#: (the caller searches), no step (its length is not > 0)
NO_ROOT, MAYBE_ROOT, NO_STEP = 0, 1, 2


class HandBack(Exception):
    """Raised by the compiled kernels where a step leaves their common path (a length in
    logarithms, a step beyond _LONG_STEP): the caller takes the step again in Python."""


def scale_table(table, h, exponents, powers):
    """The coefficients c_n h^n of theta = (tau - lo) / h, in place: h^n the C library's pow
    (Python's ``**`` on floats), one product per coefficient. Beyond _LONG_STEP
    (:func:`_scaled_long`)."""
    if h >= _LONG_STEP:
        _scaled_long(table, h)
        return
    for n in range(len(exponents)):
        powers[n] = h ** exponents[n]
    table *= powers


def _scaled_long(table, h):
    """:func:`scale_table` beyond _LONG_STEP, where h^n itself overflows (a structure of period
    1e74 s, k = 4e-148 N/m: h^36 = inf, and 0 x inf = NaN in the terms that underflowed) though
    each c_n h^n is finite: scaled by h's mantissa and exponent apart (ldexp)."""
    mantissa, exponent = math.frexp(h)
    table[...] = np.ldexp(table * [mantissa ** n for n in range(ORDER + 1)],
                          exponent * _INT_POWERS)


def _hand_back_ratio(c0, c1, c2, h, a, power):
    """The compiled kernels' stand-in for :func:`_root_of_ratio` (:class:`HandBack`)."""
    raise HandBack()


def _hand_back_long(table, h):
    """The compiled kernels' stand-in for :func:`_scaled_long` (:class:`HandBack`)."""
    raise HandBack()


def _last_nonzero(table, row):
    """(j, |c_j|) of the highest nonzero coefficient of a row whose last two are 0, if
    3 <= j < ORDER - 1, else (-1, 0.0). A row of degree 2 or less is exact (the drag impulse of
    a pair at rest, linear in time), and the step's size c_0 + c_1 h + c_2 h^2 holds it; with
    k > 0 a higher one is not a polynomial, and its last terms are 0 only by underflow (a rate
    of 2e-30 1/s, terms rate^n): taking them as no bound let a step span 1e67 s, where the
    terms in between are 1e400."""
    for j in range(ORDER - 2, 2, -1):
        if table[row, j] != 0.0:
            return j, abs(float(table[row, j]))
    return -1, 0.0


def _root_of_ratio(c0: float, c1: float, c2: float, h: float, a: float, power: float) -> float:
    """(TOLERANCE (c0 + c1 h + c2 h^2) / a)^power in logarithms, where the ratio overflows (a
    step of a structure with a period of 1e91 s tried at that length: the ratio's inf kept the
    step a period long, and its terms c_n h^n beyond double precision)."""
    terms = [math.log(c) + n * math.log(h) for n, c in enumerate((c0, c1, c2)) if c > 0.0]
    top = max(terms)
    log_size = math.log(TOLERANCE) + top + math.log(_fsum(math.exp(t - top) for t in terms))
    return math.exp(min(power * (log_size - math.log(a)), 700.0))


def _bounded(bound, size, a, power, c0, c1, c2, h):
    """min(bound, (size / a)^power), the power in logarithms where the ratio overflows."""
    ratio = size / a
    if ratio < math.inf:
        b = ratio ** power
    else:
        b = _root_of_ratio(c0, c1, c2, h, a, power)
    return b if b < bound else bound


def step_length(table, max_step):
    """Step length h: for x, v and P (rows of ``table``), each of the last two terms |c_j| h^j
    at most TOLERANCE of the size of the motion over the step, |c_0| + |c_1| h + |c_2| h^2
    (solved for h by fixed-point iteration from the longest step, contracting by ~2/j)."""
    h = max_step if math.isfinite(max_step) else 1.0
    low, high = 1.0 / (ORDER - 1), 1.0 / ORDER
    for _ in range(3):
        bound = max_step
        for row in range(3):
            c0, c1 = abs(float(table[row, 0])), abs(float(table[row, 1]))
            c2 = abs(float(table[row, 2]))
            a_low = abs(float(table[row, ORDER - 1]))
            a_high = abs(float(table[row, ORDER]))
            size = TOLERANCE * (c0 + h * (c1 + h * c2)) + 1e-300
            if a_low == 0.0 and a_high == 0.0:  # underflowed: the last nonzero term bounds
                j, a_j = _last_nonzero(table, row)
                if j >= 0:
                    bound = _bounded(bound, size, a_j, 1.0 / j, c0, c1, c2, h)
            if a_low > 0.0:
                bound = _bounded(bound, size, a_low, low, c0, c1, c2, h)
            if a_high > 0.0:
                bound = _bounded(bound, size, a_high, high, c0, c1, c2, h)
        h = SAFETY * bound
    return h


def pairwise_sum(terms, partial):
    """The sum of ``terms`` along their first axis (16 to 128 of them) as numpy's
    ``add.reduce`` sums a row (its pairwise summation: 8 partial sums over strides of 8, summed
    pairwise, then the rest in turn, added to 0.0): floats (a row, compiled) or arrays (the
    rows at once, element by element), the same floats. ``partial`` holds the 8 partial sums."""
    n = terms.shape[0]
    np.add(terms[0:8], terms[8:16], partial)
    for i in range(16, n - n % 8, 8):
        np.add(partial, terms[i:i + 8], partial)
    s = ((partial[0] + partial[1]) + (partial[2] + partial[3])) + \
        ((partial[4] + partial[5]) + (partial[6] + partial[7]))
    for i in range(n - n % 8, n):
        s = s + terms[i]
    return 0.0 + s


def _column_sums(terms, partial, sums):
    """sums[i, j] = :func:`pairwise_sum` of terms[j, i], all at once (pure path)."""
    sums[...] = pairwise_sum(terms.T, partial.T)


def _column_sums_one_by_one(terms, partial, sums):
    """:func:`_column_sums` one sum at a time, over floats (compiled in its place)."""
    for i in range(sums.shape[0]):
        for j in range(sums.shape[1]):
            sums[i, j] = pairwise_sum(terms[j, i], partial[0, 0])


def proven_intervals(sums, rows, proven):
    """Which sample intervals [a, b] are proven to keep each polynomial >= 0 (``proven[i, j]``
    for interval i of signal j; its values on the grid and its curvature bound K in ``sums``,
    :func:`proof_sums`): min(p(a), p(b)) >= K (b - a)^2 / 8, K >= |p''| on [0, 1] (at an
    interior minimum p' = 0, so p(a) and p(b) exceed it by at most K (b - a)^2 / 8). Returns
    whether all are, with each polynomial >= 0 at 0 (no root on the step)."""
    everywhere = True
    for j in range(rows):
        margin = sums[SAMPLES + 1, j] * _PROOF_MARGIN
        everywhere = everywhere and sums[0, j] >= 0.0
        for i in range(SAMPLES):
            ok = sums[i, j] >= margin and sums[i + 1, j] >= margin  # (NaN: not proven)
            proven[i, j] = ok
            everywhere = everywhere and ok
    return everywhere


def proof_sums(table, rows, terms, partial, sums):
    """For the signals, rows 3.. of ``table`` (s r, then lam; ``rows`` of them): their values
    on the sample grid, sums[:SAMPLES + 1], each the products c_n theta^n summed as numpy's
    add.reduce sums a row (:func:`pairwise_sum`; a matrix product's order would be the BLAS
    kernel's), and the bounds sum n (n - 1) |c_n| on |p''| on [0, 1], sums[SAMPLES + 1]."""
    for r in range(rows):
        np.multiply(_VANDERMONDE, table[3 + r], terms[r, :SAMPLES + 1])
        np.multiply(np.abs(table[3 + r]), _CURVATURE_WEIGHTS, terms[r, SAMPLES + 1])
    _column_sums(terms[:rows], partial[:rows], sums[:, :rows])


def drag_sign(x, v, u, drag_B, structure_B, c, k, order_over, reciprocals, rs, fs):
    """Sign of u - v from here on: its own, or at u - v = 0 that of its first non-zero
    Taylor coefficient (which does not depend on the drag's sign up to there)."""
    r0 = u - v
    if r0 != 0.0:
        return 1.0 if r0 > 0.0 else -1.0
    taylor_recurrence(x, v, u, drag_B, drag_B + structure_B if structure_B else drag_B, c, k,
                      order_over, reciprocals, rs, fs)
    for n in range(1, len(rs)):
        if rs[n] != 0.0:
            return 1.0 if rs[n] > 0.0 else -1.0
    return 1.0


def series(x, v, p, sign, u, drag_B, structure_B, c, k, M, order_over, reciprocals, exponents,
           rs, fs, table):
    """Taylor coefficients at state (x, v, P) with drag sign s into ``table``: rows x, v, P,
    s r and lam, orders 0..ORDER (lam to ORDER - 1, then 0). ``structure_B`` (kg/m), the
    quadratic Morison drag on the structure, drives the bodies with the ice's drag but is no
    part of the contact force nor of the ice's drag impulse P."""
    drag_ice = sign * drag_B
    # the drag driving the bodies: the ice's, with the structure's where it has one
    drag_total = sign * (drag_B + structure_B) if structure_B else drag_ice
    taylor_recurrence(x, v, u, drag_ice, drag_total, c, k, order_over, reciprocals, rs, fs)
    r, f = np.asarray(rs), np.asarray(fs)
    table[1, 0] = v
    table[1, 1:] = -r[1:]
    table[0, 0] = x
    table[0, 1:] = table[1, :-1] * _RECIPROCALS
    table[2, 0] = p
    table[2, 1:] = f * _RECIPROCALS
    table[3] = sign * r
    table[4, :-1] = f - M * _POWERS[1:] * table[1, 1:]
    table[4, -1] = 0.0


def ordinary_step(lo, x, v, p, until, look_for_separation, u, drag_B, structure_B, c, k, M,
                  max_step, order_over, reciprocals, exponents, rs, fs, table, powers, terms,
                  partial, sums, proven):
    """The step from lo (s) at state (x, v, P) up to the proof that it holds no root
    (:class:`StickingTaylor`'s coefficients; the work arrays of :class:`_Work`): fills
    ``table`` with its coefficients in theta = (tau - lo) / h and ``sums`` with the signals'
    values and curvature bounds (:func:`proof_sums`), ``proven`` with the intervals proven free
    of roots (:func:`proven_intervals`); returns (outcome, h, theta_end), outcome
    NO_ROOT (the step runs to theta_end), MAYBE_ROOT (a root of s r or of lam, when separation
    is looked for, may lie on it) or NO_STEP (h is not > 0)."""
    sign = drag_sign(x, v, u, drag_B, structure_B, c, k, order_over, reciprocals, rs, fs)
    series(x, v, p, sign, u, drag_B, structure_B, c, k, M, order_over, reciprocals, exponents,
           rs, fs, table)
    h = step_length(table, max_step)
    if not h > 0.0:
        return NO_STEP, h, 1.0
    theta_end = 1.0
    if lo + h > until:
        theta_end = (until - lo) / h
    scale_table(table, h, exponents, powers)
    rows = 2 if look_for_separation else 1
    proof_sums(table, rows, terms, partial, sums)
    if proven_intervals(sums, rows, proven):
        return NO_ROOT, h, theta_end
    return MAYBE_ROOT, h, theta_end


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


def horner_columns(table, theta):
    """:func:`horner` of the three columns of a step's table (order, column) at theta, for
    numba: (x, v, P)."""
    x = v = p = 0.0
    for n in range(table.shape[0] - 1, -1, -1):
        x = x * theta + table[n, 0]
        v = v * theta + table[n, 1]
        p = p * theta + table[n, 2]
    return x, v, p


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
                if horner(poly, a) <= 0.0:
                    return a
                if horner(poly, b) >= 0.0:
                    return b
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


def taylor_recurrence(x, v, u, drag_ice, drag_total, c, k, order_over, reciprocals, rs, fs):
    """The recurrence of the sticking equation's Taylor coefficients from (x, v) (module
    docstring): writes r_0..r_ORDER into ``rs`` and the ice's drag f_0..f_(ORDER-1) into ``fs``.
    ``drag_ice`` is s B, ``drag_total`` s (B + B_s) (s B without drag on the structure),
    ``order_over[n]`` 1 / ((m + M) (n + 1)), ``reciprocals[n]`` 1 / (n + 1). Lists in Python,
    arrays where numba compiles it (:data:`KERNELS`): the same floats either way."""
    rs[0] = u - v
    for n in range(len(fs)):
        # (r^2)_n = sum_i r_i r_{n-i}, the Cauchy product: each pair of terms once, doubled
        # (exactly), then the middle term where n is even; the order this loop fixes
        square = 0.0
        j = n
        for i in range((n + 1) >> 1):
            square += rs[i] * rs[j]
            j -= 1
        square *= 2.0
        if not n & 1:
            middle = rs[n >> 1]
            square += middle * middle
        fs[n] = drag_ice * square  # the drag on the ice
        v_next = (drag_total * square - c * v - k * x) * order_over[n]
        x = v * reciprocals[n]
        v = v_next
        rs[n + 1] = -v_next


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
            proven)
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
    """The module's kernels compiled by numba: the same floats as the pure functions. The
    Python-only branches (:func:`_root_of_ratio`, :func:`_scaled_long`) raise
    :class:`HandBack` in them."""

    def __init__(self, numba):
        f8, i8, b1 = numba.float64, numba.int64, numba.boolean
        array, table = f8[::1], f8[:, ::1]
        cube = f8[:, :, ::1]
        any1 = f8[:]
        recurrence = jit(numba, (*(f8,) * 7, *(array,) * 4), taylor_recurrence)
        self.recurrence = entry_point(recurrence)
        columns = jit(numba, (table, f8), horner_columns)
        self.step_states = entry_point(jit(
            numba, numba.void(array, array, array, cube, table, array, table), step_states))
        self.horner_columns = entry_point(columns)
        bounded = jit(numba, (f8,) * 8, _bounded,
                      _root_of_ratio=jit(numba, (f8,) * 6, _hand_back_ratio))
        length = jit(numba, (table, f8), step_length, _bounded=bounded,
                     _last_nonzero=jit(numba, (table, i8), _last_nonzero))
        scale = jit(numba, (table, f8, array, array), scale_table,
                    _scaled_long=jit(numba, (table, f8), _hand_back_long))
        pairwise = jit(numba, (any1, any1), pairwise_sum)
        sums = jit(numba, (cube, cube, f8[:, :]), _column_sums_one_by_one, pairwise_sum=pairwise)
        proof = jit(numba, (table, i8, cube, cube, table), proof_sums,
                    _column_sums=sums)
        proven = jit(numba, (table, i8, numba.boolean[:, ::1]), proven_intervals)
        sign = jit(numba, (*(f8,) * 7, *(array,) * 4), drag_sign, taylor_recurrence=recurrence)
        fill = jit(numba, (*(f8,) * 10, *(array,) * 5, table), series,
                   taylor_recurrence=recurrence)
        step_args = (*(f8,) * 5, b1, *(f8,) * 7, *(array,) * 5, table, array, cube, cube,
                     table, b1[:, ::1])
        ordinary = jit(numba, step_args, ordinary_step, drag_sign=sign, series=fill,
                       step_length=length, scale_table=scale, proof_sums=proof,
                       proven_intervals=proven)
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
                  look_for_separation: bool) -> tuple[int, float, float]:
        """:func:`ordinary_step` from lo at y, compiled where numba is (in Python where the
        compiled one hands back), into the work arrays."""
        args = (lo, *y, until, look_for_separation, self.u, self.B, self.structure_B, self.c,
                self.k, self.M, self.max_step, *self._constants, *self._work.arrays())
        if KERNELS is not None:
            try:
                return KERNELS.ordinary_step(*args)
            except HandBack:
                pass
        return ordinary_step(*args)

    def step(self, lo: float, y: tuple[float, float, float], until: float,
             look_for_separation: bool) -> TaylorStep:
        """The step from lo (s) at state y = (x, v, P), ending at ``until`` at the latest.
        Raises ArithmeticError where it would end in a state that is not finite."""
        step = TaylorStep(lo, y)
        outcome, h, theta_end = self._ordinary(lo, y, until, look_for_separation)
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
