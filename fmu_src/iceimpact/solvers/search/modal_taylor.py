"""High-order Taylor steps of the ice riding on the modal structure's contact point (method 1,
structure.model = 3), as functions over plain floats and arrays: run as Python, or compiled by
numba where it is installed, the same floats either way.

While the ice rides (z = x = sum phi_k q_k) the modes are coupled through the contact force on
the structure, ``lam = alpha D - beta sum phi_k f_k`` (alpha = m_eff / (M + m_eff), beta = M alpha,
f_k = (L_k - c_k q_k' - k_k q_k) / m_k mode k's free acceleration, D the drag on the ice at the
contact point's speed v, L_k the load, a polynomial of degree 1 in time over a communication
step): ``q_k'' = f_k + phi_k lam / m_k`` (docs/explanation/modes.md). Under
the linear drag ``D = b (u - v)`` the system is linear; under the quadratic drag ``D = s B r^2``
(r = u - v) while the sign s of r holds. Either way the Taylor coefficients follow exactly by
recurrence (``(r^2)_n`` the Cauchy product of r with itself)::

    q_k[n+1] = q_k'[n] / (n + 1)
    q_k'[n+1] = (f_k[n] + phi_k lam[n] / m_k) / (n + 1)
    P[n+1] = lam[n] / (n + 1)                           (P the contact impulse)

A step of order ``ORDER`` is as long as its last two terms stay below ``TOLERANCE`` of the motion's
scale (the step-size rule of Jorba and Zou, 2005), and spans at most ``RATE_SPAN`` over the
fastest rate of the modes and the drag. Under the quadratic drag a step ends where r changes sign;
the riding ends at the first root of lam's polynomial. Both roots are found without a miss by
:func:`first_negative` (a curvature bound from the coefficients proves each interval it skips).

**The same bits on every machine**: ``+ - * /``, ``sqrt`` and the C library's ``pow`` for the step
length only, in an order these functions fix; no numpy reduction, no BLAS; powers h^n by repeated
multiplication.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...compiled import compile_or_none, entry_point, jit

#: Order of the steps, the size of their last two terms relative to the motion's scale, and the
#: longest step in units of the fastest rate (1 / rate)
ORDER = 32
TOLERANCE = 1e-17
RATE_SPAN = 4.0
#: The root proof's grid on a step, and the halvings it may spend on each interval of it
GRID = 16
HALVINGS = 60
#: Iterations of the bracketing that resolves a sign change
BRACKET_ITERATIONS = 200
#: u - v below this fraction of the motion's speeds (|u|, |phi_k q_k'|, |phi_k omega_k q_k|) is
#: rounding (contact_rules' rule)
ROUNDING_SPEED = 1e-12

#: The rows of the modes' table: phi_k, m_k, c_k, k_k, the load's rate R_k (N/s), omega_k
PHI, MASS, DAMP, STIFF, RATE, OMEGA = range(6)


def horner(coeffs, theta):
    """``sum coeffs[n] theta^n`` by Horner's rule (a 1-d array)."""
    value = 0.0
    for n in range(coeffs.size - 1, -1, -1):
        value = value * theta + coeffs[n]
    return value


def horner_rows(table, theta, out):
    """:func:`horner` of each row of ``table`` at theta, into ``out``."""
    for j in range(table.shape[0]):
        out[j] = horner(table[j], theta)


def first_negative(coeffs, theta_from, theta_end):
    """The first theta in [theta_from, theta_end] where the polynomial ``sum coeffs[n] theta^n``
    goes below zero, or -1.0 if none. On an interval [a, b] where it is >= 0 at both ends,
    ``min(p(a), p(b)) >= K (b - a)^2 / 8`` proves it >= 0 throughout (K a bound on |p''| over
    [0, 1] from the coefficients), as does a rise from a (``p(a) + p'(a) s - K s^2 / 2 >= 0`` for
    ``s <= 2 p'(a) / K``); otherwise the interval is halved. A sign change is then bracketed to
    within a few ulps; a zero the polynomial only touches closer than the halvings resolve is
    no root."""
    if theta_end < theta_from:
        return -1.0
    if horner(coeffs, theta_from) < 0.0:
        return theta_from
    size = coeffs.size
    curvature = 0.0
    for n in range(2, size):
        c = coeffs[n]
        curvature += n * (n - 1) * (c if c >= 0.0 else -c)
    span = theta_end - theta_from
    stack = np.empty((HALVINGS + 2, 4))
    for i in range(GRID):
        a0 = theta_from + span * i / GRID
        b0 = theta_end if i == GRID - 1 else theta_from + span * (i + 1) / GRID
        stack[0, 0], stack[0, 1] = a0, horner(coeffs, a0)
        stack[0, 2], stack[0, 3] = b0, horner(coeffs, b0)
        top = 1
        budget = HALVINGS
        while top > 0:
            top -= 1
            a, pa, b, pb = stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3]
            if pa < 0.0:
                return a
            if pb < 0.0:
                if pa == 0.0 and a == theta_from:
                    # a zero at the start (u - v = 0 after a sign change): the crossing is the
                    # next one, beyond a point where the polynomial is above zero, if any
                    a = _rise_from_zero(coeffs, a, b)
                    if a < 0.0:
                        return theta_from
                return _crossing(coeffs, a, b)
            if min(pa, pb) >= curvature * (b - a) * (b - a) / 8.0 or budget <= 0:
                continue
            rate = 0.0  # p'(a), by Horner's rule on n c_n
            for n in range(size - 1, 0, -1):
                rate = rate * a + n * coeffs[n]
            if rate > 0.0 and (b - a) * curvature <= 2.0 * rate:
                continue
            budget -= 1
            mid = 0.5 * (a + b)
            pm = horner(coeffs, mid)
            stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3] = mid, pm, b, pb
            stack[top + 1, 0], stack[top + 1, 1] = a, pa
            stack[top + 1, 2], stack[top + 1, 3] = mid, pm
            top += 2
    return -1.0


def _rise_from_zero(coeffs, a, b):
    """A point of (a, b) where the polynomial, 0 at a and below 0 at b, is above 0 (halving
    towards a down to the smallest floats), or -1.0 if none: it goes below zero at once."""
    step = b - a
    for _ in range(1100):
        step *= 0.5
        theta = a + step
        if theta == a:
            return -1.0
        if horner(coeffs, theta) > 0.0:
            return theta
    return -1.0


def _crossing(coeffs, lo, hi):
    """The first point below zero of the polynomial on [lo, hi] (p(lo) >= 0 > p(hi)), to a few
    ulps: regula falsi with the Illinois rule, bisection where it stalls."""
    f_lo, f_hi = horner(coeffs, lo), horner(coeffs, hi)
    side = 0
    for _ in range(BRACKET_ITERATIONS):
        if hi - lo <= 4.0 * 2.0 ** -52 * max(abs(lo), abs(hi)) + 1e-300:
            break
        t = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
        if not lo < t < hi:
            t = 0.5 * (lo + hi)
        f_t = horner(coeffs, t)
        if f_t < 0.0:
            hi, f_hi = t, f_t
            if side == -1:
                f_lo *= 0.5
            side = -1
        else:
            lo, f_lo = t, f_t
            if side == 1:
                f_hi *= 0.5
            side = 1
    return hi


def ride_series(q, p, loads, modes, u, alpha, beta, coef, quadratic, sign, table, rs):
    """The Taylor coefficients (in time, s) from the modal state (q, q') under the loads
    ``loads`` (N, at the step's start): rows 0..N-1 of ``table`` each mode's q, N..2N-1 its q',
    2N the contact impulse P (from 0), 2N + 1 the contact force lam; ``rs`` the relative flow
    r = u - v. ``modes`` the table of rows PHI ... OMEGA (one column per mode); ``sign`` the
    quadratic drag's sign of r."""
    n_modes = q.size
    for k in range(n_modes):
        table[k, 0] = q[k]
        table[n_modes + k, 0] = p[k]
    impulse, force = 2 * n_modes, 2 * n_modes + 1
    table[impulse, 0] = 0.0
    for n in range(ORDER + 1):
        v = 0.0
        speed = abs(u)
        for k in range(n_modes):
            v += modes[PHI, k] * table[n_modes + k, n]
            if n == 0:  # the speeds of the motion (contact_rules.rounding_closing's scale)
                speed += abs(modes[PHI, k] * table[n_modes + k, 0]) + abs(
                    modes[PHI, k] * modes[OMEGA, k] * table[k, 0])
        r = (u if n == 0 else 0.0) - v
        if n == 0 and abs(r) <= ROUNDING_SPEED * speed:
            r = 0.0  # u - v at rounding level (after a sign change): 0, its sign unknown
        rs[n] = r
        if quadratic:
            square = 0.0
            for i in range(n + 1):
                square += rs[i] * rs[n - i]
            drag = sign * coef * square
        else:
            drag = coef * r
        free_sum = 0.0
        for k in range(n_modes):
            load = loads[k] if n == 0 else (modes[RATE, k] if n == 1 else 0.0)
            free = (load - modes[DAMP, k] * table[n_modes + k, n]
                    - modes[STIFF, k] * table[k, n]) / modes[MASS, k]
            free_sum += modes[PHI, k] * free
            if n < ORDER:
                table[n_modes + k, n + 1] = free  # (the contact force's part is added below)
        lam = alpha * drag - beta * free_sum
        table[force, n] = lam
        if n < ORDER:
            table[impulse, n + 1] = lam / (n + 1)
            for k in range(n_modes):
                table[k, n + 1] = table[n_modes + k, n] / (n + 1)
                table[n_modes + k, n + 1] = ((table[n_modes + k, n + 1]
                                              + modes[PHI, k] * lam / modes[MASS, k]) / (n + 1))


def step_length(table, loads, modes, u, rate):
    """The step (s): its last two terms below TOLERANCE of the motion's scale (each mode's
    omega_k |q_k - L_k / k_k| + |q_k'|, and |u|), at most RATE_SPAN / rate."""
    n_modes = modes.shape[1]
    scale = abs(u)
    last1 = last2 = 0.0
    for k in range(n_modes):
        omega = modes[OMEGA, k]
        scale += (omega * abs(table[k, 0] - loads[k] / modes[STIFF, k])
                  + abs(table[n_modes + k, 0]))
        last1 = max(last1, omega * abs(table[k, ORDER - 1]), abs(table[n_modes + k, ORDER - 1]))
        last2 = max(last2, omega * abs(table[k, ORDER]), abs(table[n_modes + k, ORDER]))
    h = RATE_SPAN / rate if rate > 0.0 else math.inf
    if scale > 0.0:
        if last1 > 0.0:
            h = min(h, (TOLERANCE * scale / last1) ** (1.0 / (ORDER - 1)))
        if last2 > 0.0:
            h = min(h, (TOLERANCE * scale / last2) ** (1.0 / ORDER))
    if not h < math.inf:
        h = 1.0
    return h


def ride_step(q, p, impulse0, loads, modes, u, alpha, beta, coef, quadratic, rate, table, rs,
              sign):
    """One step from the modal state (q, q') under the loads ``loads`` (N, at its start) with
    the contact impulse ``impulse0`` so far, the quadratic drag's sign ``sign`` (0.0: that of
    u - v, or from u - v = 0 the one it moves to):
    ``table`` filled with the polynomials in theta = tau / h (rows as :func:`ride_series`, the
    impulse's from impulse0); returns (h, theta_end), theta_end < 1 where the relative flow
    changes sign under the quadratic drag (the step ends there)."""
    forced = sign != 0.0
    if not forced:
        sign = 1.0
    ride_series(q, p, loads, modes, u, alpha, beta, coef, quadratic, sign, table, rs)
    if quadratic and not forced:
        lead = 1.0  # the sign of r, or where r = 0 the one it moves to
        for n in range(ORDER + 1):
            if rs[n] != 0.0:
                lead = rs[n]
                break
        if lead < 0.0:
            sign = -1.0
            ride_series(q, p, loads, modes, u, alpha, beta, coef, quadratic, sign, table, rs)
    h = step_length(table, loads, modes, u, rate)
    power = 1.0
    for n in range(ORDER + 1):
        for j in range(table.shape[0]):
            table[j, n] *= power
        rs[n] *= sign * power
        power *= h
    table[2 * q.size, 0] = impulse0
    theta_end = 1.0
    if quadratic:
        theta = first_negative(rs, 0.0, 1.0)
        if theta >= 0.0:
            theta_end = theta
    return h, theta_end


def ride_extend(q, p, impulse0, lo, t0, loads0, load_rates, since, modes, share, u, alpha,
                beta, coef, quadratic, rate, table, rs, end, loads):
    """The riding phase's next step, from the modal state (q, q') and the impulse so far at lo
    (s from the phase's start t0): the loads there (``Modes.loads_at``: loads0 given at
    ``since``, changing at load_rates) into ``loads``, :func:`ride_step` into ``table`` (under
    the quadratic drag, a step that would end at once, its drag sign rounding's, taken with the
    other sign), the state at its end into ``end``, and where the relative flow changes sign
    there, the modes' velocities moved to u - v = 0 exactly (``Modes.velocity_change`` by
    ``share``, as an impulse would move them). Returns (h, theta_end, the step's end, whether it
    advanced to finite values)."""
    n = q.size
    t = t0 + lo
    for k in range(n):
        loads[k] = loads0[k] + load_rates[k] * (t - since)
    h = 0.0
    theta_end = 1.0
    hi = lo
    for attempt in range(3 if quadratic else 1):
        sign = 0.0 if attempt == 0 else (1.0 if attempt == 1 else -1.0)
        h, theta_end = ride_step(q, p, impulse0, loads, modes, u, alpha, beta, coef, quadratic,
                                 rate, table, rs, sign)
        hi = lo + h * theta_end
        if hi > lo:
            break
    horner_rows(table, theta_end, end)
    if theta_end < 1.0:  # (Modes.contact's v, then Modes.velocity_change)
        v = 0.0
        for k in range(n):
            v += modes[0, k] * end[n + k]
        dv = u - v
        for k in range(n):
            end[n + k] = end[n + k] + share[k] * dv
    advanced = hi > lo
    for j in range(end.size):
        if not end[j] - end[j] == 0.0:  # (inf or NaN)
            advanced = False
    return h, theta_end, hi, advanced


#: The columns of a riding phase's steps (:func:`ride_steps`): each step's start lo and length h
#: (s from the phase's start; theta = (tau - lo) / h on it) and its end hi (lo + h theta_end)
LO, H, HI = range(3)
#: The counters of :func:`ride_steps`: the steps made, and those proven free of a separation
COUNT, CHECKED = range(2)
#: What :func:`ride_steps` returns with: the target reached (no separation before it); a
#: separation found (the steps after its own dropped); the arrays full (the caller grows them and
#: calls again); a step that could not advance to finite values (the caller raises)
REACHED, SEPARATES, FULL, STALLED = range(4)


def ride_steps(q0, p0, t0, loads0, load_rates, since, modes, share, u, alpha, beta, coef,
               quadratic, rate, rs, loads, q, p, steps, tables, ends, counts, target, start,
               check):
    """The riding phase's steps (from its anchor (q0, q0') at t0), made by :func:`ride_extend`
    each from the end of the last, into ``steps`` (:data:`LO`, :data:`H`, :data:`HI`),
    ``tables`` and ``ends`` (the rows at each step's end), ``counts`` (:data:`COUNT`,
    :data:`CHECKED`); ``q``, ``p`` scratch for a step's start.

    ``check`` 0: made until the last one ends at or after ``target``. ``check`` 1: each step
    from the last checked on (made when needed) searched for the separation, the first root of
    the contact force at or after ``start`` (:func:`first_negative` on its row), until a step
    ends after ``target``.

    Returns (outcome, step, theta): :data:`REACHED`; :data:`SEPARATES` (the step of the root and
    theta on it, the steps after it dropped from ``counts``); :data:`FULL`; :data:`STALLED`."""
    n = q0.size
    capacity = steps.shape[0]
    force = tables.shape[1] - 1
    i = counts[CHECKED] if check else 0
    while True:
        count = counts[COUNT]
        if check:
            made = i < count
        else:
            made = count > 0 and steps[count - 1, HI] >= target
            if made:
                return REACHED, 0, 0.0
        if not made:
            if count == capacity:
                return FULL, 0, 0.0
            if count == 0:
                for k in range(n):
                    q[k] = q0[k]
                    p[k] = p0[k]
                impulse, lo = 0.0, 0.0
            else:
                for k in range(n):
                    q[k] = ends[count - 1, k]
                    p[k] = ends[count - 1, n + k]
                impulse, lo = ends[count - 1, 2 * n], steps[count - 1, HI]
            h, theta_end, hi, advanced = ride_extend(
                q, p, impulse, lo, t0, loads0, load_rates, since, modes, share, u, alpha, beta,
                coef, quadratic, rate, tables[count], rs, ends[count], loads)
            if not advanced:
                return STALLED, count, 0.0
            steps[count, LO], steps[count, H], steps[count, HI] = lo, h, hi
            counts[COUNT] = count + 1
            continue
        lo, h, hi = steps[i, LO], steps[i, H], steps[i, HI]
        i += 1
        if hi >= start:
            theta = first_negative(tables[i - 1, force], max(0.0, (start - lo) / h),
                                   (hi - lo) / h)
            if theta >= 0.0:
                counts[COUNT] = i
                return SEPARATES, i - 1, theta
        counts[CHECKED] = i
        if hi > target:
            return REACHED, 0, 0.0


def ride_rows_at(steps, tables, ends, count, taus, out):
    """The rows (q, q', P, lam) at each time of ``taus`` (s from the phase's start, within the
    first ``count`` steps) into the rows of ``out``: in the last step starting at or before it
    (the first, before them all), :func:`horner_rows` at theta = (tau - lo) / h, or the step's
    end from its end on."""
    for r in range(taus.size):
        tau = taus[r]
        a, b = 0, count  # (bisect_right over the steps' starts)
        while a < b:
            mid = (a + b) // 2
            if tau < steps[mid, LO]:
                b = mid
            else:
                a = mid + 1
        i = max(a - 1, 0)
        if tau >= steps[i, HI]:
            for j in range(out.shape[1]):
                out[r, j] = ends[i, j]
        else:
            horner_rows(tables[i], (tau - steps[i, LO]) / steps[i, H], out[r])


KERNELS: dict[str, Any] = {}


def _build(numba: Any) -> dict[str, Any]:
    f8, i8 = numba.float64, numba.int64
    a1, a2 = f8[::1], f8[:, ::1]
    h = jit(numba, (a1, f8), horner)
    rows = jit(numba, (a2, f8, a1), horner_rows, horner=h)
    crossing = jit(numba, (a1, f8, f8), _crossing, horner=h)
    rise = jit(numba, (a1, f8, f8), _rise_from_zero, horner=h)
    negative = jit(numba, (a1, f8, f8), first_negative, horner=h, _crossing=crossing,
                   _rise_from_zero=rise)
    series = jit(numba, (a1, a1, a1, a2, f8, f8, f8, f8, i8, f8, a2, a1), ride_series)
    length = jit(numba, (a2, a1, a2, f8, f8), step_length)
    step = jit(numba, (a1, a1, f8, a1, a2, f8, f8, f8, f8, i8, f8, a2, a1, f8), ride_step,
               ride_series=series, step_length=length, first_negative=negative)
    extend = jit(numba, (a1, a1, f8, f8, f8, a1, a1, f8, a2, a1, f8, f8, f8, f8, i8, f8, a2,
                         a1, a1, a1), ride_extend, ride_step=step, horner_rows=rows)
    a3 = f8[:, :, ::1]
    steps = jit(numba, (a1, a1, f8, a1, a1, f8, a2, a1, f8, f8, f8, f8, i8, f8, a1, a1, a1, a1,
                        a2, a3, a2, i8[::1], f8, f8, i8), ride_steps, ride_extend=extend,
                first_negative=negative)
    rows_at = jit(numba, (a2, a3, a2, i8, a1, a2), ride_rows_at, horner_rows=rows)
    return {"ride_steps": entry_point(steps), "ride_rows_at": entry_point(rows_at)}


#: The compiled kernels where numba is (``fast`` extra), else None: the pure functions run
COMPILED = compile_or_none("the modal riding steps", _build)
if COMPILED is not None:
    KERNELS.update(COMPILED)
else:
    KERNELS.update(ride_steps=ride_steps, ride_rows_at=ride_rows_at)
