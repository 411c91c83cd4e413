"""The Taylor series of the sticking equation and the proof that a step holds no root: the
kernels of one step of :mod:`.taylor` (its module docstring has the equations).

- :func:`taylor_recurrence`: the coefficients of x, v and the ice's drag from a state, by the
  recurrence of the sticking equation (the Cauchy products summed in a fixed order);
- :func:`step_length`: the step-size rule of Jorba and Zou (the last two terms below TOLERANCE
  of the motion's scale), with the coefficients scaled by h^n (:func:`scale_table`);
- :func:`proof_sums` and :func:`proven_intervals`: the polynomials' values on the sample grid
  (numpy's pairwise order, :func:`pairwise_sum`) and the intervals where a curvature bound
  proves them nonnegative;
- :func:`ordinary_step`: one step up to that proof, over plain floats, lists and arrays, run as
  Python by the pure path and compiled by numba where it is installed (:data:`.taylor.KERNELS`),
  the same floats either way; :func:`horner_columns` evaluates a step's table.

The Python-only branches (a step length in logarithms, a step beyond ``_LONG_STEP``) raise
:class:`HandBack` where they are compiled: the caller takes that step again in Python.
"""

from __future__ import annotations

import math
from math import fsum as _fsum
from typing import Any

import numpy as np

from ...compiled import jit

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


#: A drag impulse over a step below this (N.s) has no size the step's tolerance can measure its
#: terms by: only x and v bound the step then (:func:`step_length`)
P_FLOOR = 1e-200


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
            if row == 2 and c0 + h * (c1 + h * c2) < P_FLOOR:
                # the drag impulse of a pair at rest where u - v = 0 (from P = 0 it is third
                # order at its start, or its terms are near underflow): no size to measure its
                # terms by (a size of 1e-300 made the step 0 s long); x and v bound the step,
                # P's series, made of v's, converging with theirs
                continue
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
                  partial, sums, proven, sign):
    """The step from lo (s) at state (x, v, P) up to the proof that it holds no root
    (:class:`StickingTaylor`'s coefficients; the work arrays of :class:`_Work`): fills
    ``table`` with its coefficients in theta = (tau - lo) / h and ``sums`` with the signals'
    values and curvature bounds (:func:`proof_sums`), ``proven`` with the intervals proven free
    of roots (:func:`proven_intervals`); returns (outcome, h, theta_end), outcome
    NO_ROOT (the step runs to theta_end), MAYBE_ROOT (a root of s r or of lam, when separation
    is looked for, may lie on it) or NO_STEP (h is not > 0). ``sign`` is the drag's sign s,
    0.0 for :func:`drag_sign`'s (a step from u - v = 0 whose sign that rule gets wrong is taken
    again with the other: :meth:`~.taylor.StickingTaylor.step`)."""
    if sign == 0.0:
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


def horner_columns(table, theta):
    """:func:`horner` of the three columns of a step's table (order, column) at theta, for
    numba: (x, v, P)."""
    x = v = p = 0.0
    for n in range(table.shape[0] - 1, -1, -1):
        x = x * theta + table[n, 0]
        v = v * theta + table[n, 1]
        p = p * theta + table[n, 2]
    return x, v, p


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



def compiled_step(numba: Any) -> dict[str, Any]:
    """numba's dispatchers of one step's kernels, by name: :func:`ordinary_step` (on the
    compiled forms of the functions it calls; the Python-only branches raise
    :class:`HandBack`), :func:`horner_columns` and :func:`taylor_recurrence`."""
    f8, i8, b1 = numba.float64, numba.int64, numba.boolean
    array, table = f8[::1], f8[:, ::1]
    cube = f8[:, :, ::1]
    any1 = f8[:]
    recurrence = jit(numba, (*(f8,) * 7, *(array,) * 4), taylor_recurrence)
    columns = jit(numba, (table, f8), horner_columns)
    bounded = jit(numba, (f8,) * 8, _bounded,
                  _root_of_ratio=jit(numba, (f8,) * 6, _hand_back_ratio))
    length = jit(numba, (table, f8), step_length, _bounded=bounded,
                 _last_nonzero=jit(numba, (table, i8), _last_nonzero))
    scale = jit(numba, (table, f8, array, array), scale_table,
                _scaled_long=jit(numba, (table, f8), _hand_back_long))
    pairwise = jit(numba, (any1, any1), pairwise_sum)
    sums = jit(numba, (cube, cube, f8[:, :]), _column_sums_one_by_one, pairwise_sum=pairwise)
    proof = jit(numba, (table, i8, cube, cube, table), proof_sums, _column_sums=sums)
    proven = jit(numba, (table, i8, b1[:, ::1]), proven_intervals)
    sign = jit(numba, (*(f8,) * 7, *(array,) * 4), drag_sign, taylor_recurrence=recurrence)
    fill = jit(numba, (*(f8,) * 10, *(array,) * 5, table), series,
               taylor_recurrence=recurrence)
    step_args = (*(f8,) * 5, b1, *(f8,) * 7, *(array,) * 5, table, array, cube, cube, table,
                 b1[:, ::1], f8)
    ordinary = jit(numba, step_args, ordinary_step, drag_sign=sign, series=fill,
                   step_length=length, scale_table=scale, proof_sums=proof,
                   proven_intervals=proven)
    return {"ordinary_step": ordinary, "horner_columns": columns,
            "taylor_recurrence": recurrence}
