"""The structure: a damped single-degree-of-freedom oscillator in closed form (eq. 8-10, 24).

``mass * y'' + damping * y' + stiffness * y = 0`` with ``y = x - offset``. The same class serves the
free structure (offset 0) and the linear-drag sticking phase, where structure and ice move together
(mass m + M, damping c + b, offset b u / k: eq. 27-29 of the article, without its thresholds).

All damping regimes are covered: undamped (c = 0), under-damped (eq. 9-10), critically damped and
over-damped. The response is written on two basis functions, with sigma = damping / (2 mass):

    y(t) = y0 C(t) + (v0 + sigma y0) S(t)
    v(t) = v0 C(t) - (omega_n^2 y0 + sigma v0) S(t)

    under-damped:  C = e^{-sigma t} cos(wd t),  S = e^{-sigma t} sin(wd t) / wd
    critical:      C = e^{-sigma t},            S = t e^{-sigma t}
    over-damped:   C = e^{-sigma t} cosh(wo t), S = e^{-sigma t} sinh(wo t) / wo

Evaluation works on floats (``math``, fast, used by the event solver) and on numpy arrays (the
same functions of the C library element by element, :mod:`.elementwise`: the same floats on every
CPU).

Morison loads on the structure (docs/explanation/morison.md): the added mass m_a = rho Ca V moves
with it
(``mass`` m + m_a), and the linearised drag ``b_s (u - x')`` is a damping b_s plus a constant
force b_s u, i.e. an offset b_s u / k (:func:`morison_oscillator`): the closed forms stay exact.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from math import cos, cosh, exp, expm1, sin, sinh, sqrt

import numpy as np

from . import elementwise as ew

UNDER, CRITICAL, OVER = "under-damped", "critically damped", "over-damped"

#: A well over-damped velocity is v0 plus its increments while the fast mode's exponent s2 t
#: is above this (e^{s2 t} > 1/2), the sum of its two modes after (:meth:`Oscillator.modes`).
MODE_VELOCITY_SWITCH = -0.7


def _expm1_minus_x(s, t):
    """(e^{s t} - 1 - s t) / s (s < 0; t a float or an array), without cancellation: its
    series where |s t| < 0.01 (the first omitted term is below 1e-16 of the sum)."""
    x = np.multiply(s, t)
    small = np.abs(x) < 0.01
    xs = np.where(small, x, 0.0)
    series = xs * xs * (0.5 + xs * (1.0 / 6.0 + xs * (1.0 / 24.0 + xs * (1.0 / 120.0 + xs * (
        1.0 / 720.0 + xs * (1.0 / 5040.0))))))
    return np.where(small, series, ew.expm1(x) - x) / s


def _decay_pair_array(arg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_decay_pair` element by element (arg <= 0, an array): e^arg where it is below
    -0.7, e^arg - 1 elsewhere, each function evaluated where its value is used."""
    low = arg < -0.7
    decay = np.empty_like(arg)
    decay_m1 = np.empty_like(arg)
    decay[low] = ew.exp(arg[low])
    decay_m1[low] = decay[low] - 1.0
    high = ~low
    decay_m1[high] = ew.expm1(arg[high])
    decay[high] = 1.0 + decay_m1[high]
    return decay, decay_m1


def _decay_pair(arg: float) -> tuple[float, float]:
    """(e^arg, e^arg - 1) for arg <= 0, each without cancellation (the scalar form of the rule
    in :meth:`Oscillator.basis_parts_array`)."""
    if arg < -0.7:  # the decay is below 1/2: e - 1 has no cancellation
        decay = exp(arg)
        return decay, decay - 1.0
    decay_m1 = expm1(arg)  # above 1/2: 1 + (e - 1) loses nothing
    return 1.0 + decay_m1, decay_m1


def under_increment(t, neg_sigma, omega, y0, p, q, v0):
    """``(y(t) - y0, y'(t))`` of the under-damped free response (eq. 9-10) with the constants
    of :meth:`Oscillator.under_constants`: y = y0 C + p S, v = v0 C - q S, with C - 1 and S
    each without cancellation. A function over plain floats: the flights' closed form
    (:func:`under_response`) and the compiled flight search and march call it."""
    # _decay_pair(neg_sigma * t), written out: evaluated several times per impact
    arg = neg_sigma * t
    if arg < -0.7:
        decay = exp(arg)
        decay_m1 = decay - 1.0
    else:
        decay_m1 = expm1(arg)
        decay = 1.0 + decay_m1
    wt = omega * t
    cos_wt = cos(wt)
    half = sin(0.5 * wt)
    s = decay * sin(wt) / omega
    return y0 * (decay_m1 * cos_wt - 2.0 * half * half) + p * s, v0 * (decay * cos_wt) - q * s


def under_response(neg_sigma: float, omega: float, y0: float, p: float, q: float,
                   v0: float) -> Callable[[float], tuple[float, float]]:
    """The under-damped free response ``t -> (y(t) - y0, y'(t))`` with the constants of
    :meth:`Oscillator.under_constants` (eq. 9-10): :func:`under_increment`."""
    def under(t: float, neg_sigma=neg_sigma, omega=omega, y0=y0, p=p, q=q,
              v0=v0) -> tuple[float, float]:
        return under_increment(t, neg_sigma, omega, y0, p, q, v0)
    return under


def under_constants(offset: float, sigma: float, omega: float, omega2: float, x0: float,
                    v0: float) -> tuple[float, float, float, float, float, float]:
    """:meth:`Oscillator.under_constants` on the oscillator's own constants (offset, sigma,
    omega, omega2): a function over plain floats, which the compiled march of the exact method
    calls too (solvers/exact/bounces.py)."""
    y0 = x0 - offset
    return (-sigma, omega, y0, v0 + sigma * y0, omega2 * y0 + sigma * v0, v0)


#: The forms of a free response's increment (:func:`under_increment`, :func:`aperiodic_increment`):
#: the regime, and for an over-damped one whether it is written on its two exponents (well
#: over-damped, wo > sigma / 2)
FORM_UNDER, FORM_CRITICAL, FORM_OVER, FORM_MODES = 0, 1, 2, 3


def response_constants(form: int, offset: float, sigma: float, omega: float, omega2: float,
                       s_slow: float, s_fast: float, x0: float, v0: float) -> tuple[float, ...]:
    """The eight constants of the free response's increment from the anchor (x0, v0) in
    ``form``, as :func:`under_increment` (the first six) and :func:`aperiodic_increment` take
    them: ``(-sigma, omega, y0, p, q, v0, s1,
    s2)`` with y0 = x0 - offset, p = v0 + sigma y0, q = omega^2 y0 + sigma v0 (the basis
    functions' form: :func:`under_constants`' six and the over-damped exponents), or, well
    over-damped, ``(A, B, s1, s2, A s1, B s2, v0, 0)`` (:meth:`Oscillator.modes`). A function
    over plain floats, which the compiled march of the exact method calls too."""
    y0 = x0 - offset
    if form == FORM_MODES:
        gap = s_slow - s_fast
        a = (v0 - s_fast * y0) / gap
        b = (s_slow * y0 - v0) / gap
        return (a, b, s_slow, s_fast, a * s_slow, b * s_fast, v0, 0.0)
    neg_sigma, omega, y0, p, q, v0 = under_constants(offset, sigma, omega, omega2, x0, v0)
    return (neg_sigma, omega, y0, p, q, v0, s_slow, s_fast)


def aperiodic_increment(t, form, c0, c1, c2, c3, c4, c5, c6, c7):
    """``(y(t) - y0, y'(t))`` of a critically or over-damped free response (``form``
    FORM_CRITICAL, FORM_OVER or FORM_MODES) on the constants of :func:`response_constants`: the
    closed forms :meth:`Oscillator.deviation_increment` returns for these regimes, over plain
    floats (the compiled flight search and march call it too). The under-damped form is
    :func:`under_increment`."""
    if form == FORM_MODES:  # y = A e^{s1 t} + B e^{s2 t}: see Oscillator.modes
        fast_t = c3 * t
        slow_m1, fast_m1 = expm1(c2 * t), expm1(fast_t)
        if fast_t > MODE_VELOCITY_SWITCH:  # v0 plus its increments
            return c0 * slow_m1 + c1 * fast_m1, c6 + (c4 * slow_m1 + c5 * fast_m1)
        return c0 * slow_m1 + c1 * fast_m1, c4 * exp(c2 * t) + c5 * exp(fast_t)
    y0, p, q, v0 = c2, c3, c4, c5
    if form == FORM_CRITICAL:
        decay, decay_m1 = _decay_pair(c0 * t)
        s = t * decay
        return y0 * decay_m1 + p * s, v0 * decay - q * s
    wt = c1 * t
    if wt < 1.0:  # small wo t: sinh/wo without cancellation
        decay, decay_m1 = _decay_pair(c0 * t)
        cosh_wt = cosh(wt)
        half = sinh(0.5 * wt)
        c = decay * cosh_wt
        cm1 = decay_m1 * cosh_wt + 2.0 * half * half
        s = decay * sinh(wt) / c1
    else:
        slow, fast = exp(c6 * t), exp(c7 * t)
        c = 0.5 * (slow + fast)
        cm1 = c - 1.0
        s = 0.5 * (slow - fast) / c1
    return y0 * cm1 + p * s, v0 * c - q * s


class Oscillator:
    """Linear damped oscillator ``mass y'' + damping y' + stiffness (x - offset) = 0``."""

    __slots__ = ("mass", "damping", "stiffness", "offset", "sigma", "omega2", "regime", "omega",
                 "_s_fast", "_s_slow", "form", "search_constants")

    def __init__(self, mass: float, damping: float, stiffness: float, offset: float = 0.0):
        self.mass = mass
        self.damping = damping
        self.stiffness = stiffness
        self.offset = offset
        self.sigma = damping / (2.0 * mass)
        self.omega2 = stiffness / mass  # omega_n^2
        disc = 4.0 * stiffness * mass - damping * damping  # sign decides the regime exactly
        if disc > 0.0:
            self.regime = UNDER
            self.omega = math.sqrt(disc) / (2.0 * mass)  # damped frequency wd
        elif disc == 0.0:
            self.regime = CRITICAL
            self.omega = 0.0
        else:
            self.regime = OVER
            self.omega = math.sqrt(-disc) / (2.0 * mass)  # wo = sqrt(sigma^2 - wn^2)
        # over-damped exponents: slow root -wn^2/(sigma+wo) (no cancellation) and fast root
        self._s_slow = -self.omega2 / (self.sigma + self.omega) if self.regime == OVER else 0.0
        self._s_fast = -(self.sigma + self.omega)
        #: the form of its free response's increment (:data:`FORM_UNDER` ...)
        self.form = (FORM_UNDER if self.regime == UNDER else FORM_CRITICAL
                     if self.regime == CRITICAL else FORM_MODES if self.two_modes else FORM_OVER)
        #: (offset, mass, damping, stiffness, omega2, sigma, s1, s2, form) as the compiled
        #: flight search (solvers/search/flight_search.py) takes them
        self.search_constants = (offset, mass, damping, stiffness, self.omega2, self.sigma,
                                 self._s_slow, self._s_fast, self.form)

    # basis -----------------------------------------------------------------------------------
    def basis(self, t: float) -> tuple[float, float]:
        """(C(t), S(t)) for a float t >= 0."""
        if self.regime == UNDER:
            decay = math.exp(-self.sigma * t)
            wt = self.omega * t
            return decay * math.cos(wt), decay * math.sin(wt) / self.omega
        if self.regime == CRITICAL:
            decay = math.exp(-self.sigma * t)
            return decay, t * decay
        wt = self.omega * t
        if wt < 1.0:  # small wo t: sinh/wo without cancellation
            decay = math.exp(-self.sigma * t)
            return decay * math.cosh(wt), decay * math.sinh(wt) / self.omega
        slow, fast = math.exp(self._s_slow * t), math.exp(self._s_fast * t)
        return 0.5 * (slow + fast), 0.5 * (slow - fast) / self.omega

    def basis_parts_array(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C, C - 1, S) for an array of t >= 0, each without cancellation, as :meth:`increment`
        evaluates them for one t (see there)."""
        t = np.asarray(t, dtype=float)
        decay, decay_m1 = _decay_pair_array(-self.sigma * t)
        if self.regime == UNDER:
            wt = self.omega * t
            cos_wt = ew.cos(wt)
            half = ew.sin(0.5 * wt)
            return (decay * cos_wt, decay_m1 * cos_wt - 2.0 * half * half,
                    decay * ew.sin(wt) / self.omega)
        if self.regime == CRITICAL:
            return decay, decay_m1, t * decay
        wt = self.omega * t
        small = wt < 1.0
        ws = np.where(small, wt, 0.0)
        cosh_ws = ew.cosh(ws)
        half = ew.sinh(0.5 * ws)
        c, s = self.basis_array(t)
        return (np.where(small, decay * cosh_ws, c),
                np.where(small, decay_m1 * cosh_ws + 2.0 * half * half, c - 1.0),
                np.where(small, decay * ew.sinh(ws) / self.omega, s))

    def basis_array(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(C(t), S(t)) for an array of t >= 0."""
        t = np.asarray(t, dtype=float)
        if self.regime == UNDER:
            decay = ew.exp(-self.sigma * t)
            return decay * ew.cos(self.omega * t), decay * ew.sin(self.omega * t) / self.omega
        if self.regime == CRITICAL:
            decay = ew.exp(-self.sigma * t)
            return decay, t * decay
        wt = self.omega * t
        small = wt < 1.0
        with np.errstate(over="ignore", invalid="ignore"):
            decay = ew.exp(-self.sigma * t)
            c_small = decay * ew.cosh(np.where(small, wt, 0.0))
            s_small = decay * ew.sinh(np.where(small, wt, 0.0)) / self.omega
            slow, fast = ew.exp(self._s_slow * t), ew.exp(self._s_fast * t)
        return (np.where(small, c_small, 0.5 * (slow + fast)),
                np.where(small, s_small, 0.5 * (slow - fast) / self.omega))

    # response --------------------------------------------------------------------------------
    def response(self, x0: float, v0: float, t: float) -> tuple[float, float]:
        """Displacement and velocity at time t from (x0, v0) (eq. 24, all regimes)."""
        y0 = x0 - self.offset
        c, s = self.basis(t)
        return (self.offset + y0 * c + (v0 + self.sigma * y0) * s,
                v0 * c - (self.omega2 * y0 + self.sigma * v0) * s)

    def increment(self, x0: float, v0: float) -> Callable[[float], tuple[float, float]]:
        """The free response from the anchor (x0, v0) as a function ``t -> (x(t) - x0, v(t))``
        (eq. 9-10 and the other regimes), its constants computed once: the event solver's flights
        evaluate it several times per impact. x(t) - x0 is free of the rounding of x0 (gaps near
        contact need it). The scalar form of the closed form (:meth:`displacement_change` is one
        call of it; :meth:`displacement_change_array` its vectorised form).

        On the basis functions, ``y = y0 C + (v0 + sigma y0) S`` gives
        ``x - x0 = y0 (C - 1) + (v0 + sigma y0) S``, with (C, C - 1, S) each without
        cancellation: C - 1 at small t (displacement increments), C once the response has decayed
        (a velocity recovered as (C - 1) + 1 would carry an error of one ulp of 1, i.e.
        eps |v0|, long after v itself is below it).

        Well over-damped (wo > sigma / 2), on the two exponents s1 (slow), s2 (fast):
        ``y = A e^{s1 t} + B e^{s2 t}``, so ``x(t) - x0 = A (e^{s1 t} - 1) + B (e^{s2 t} - 1)``.
        With the basis functions, y0 (C - 1) and (v0 + sigma y0) S cancel each other when y0 is
        far larger than the motion (a sticking phase whose equilibrium b u / k is 1e9 m away
        moves 1e-4 m in a step); the exponent form has no such cancellation.

        The returned function takes t alone; its constants are bound as its default values (fast
        local variables, and no closure cells to make per anchor)."""
        return self.deviation_increment(x0 - self.offset, v0)

    def under_constants(self, x0: float, v0: float) -> tuple[float, ...]:
        """The constants of the under-damped free response from the anchor (x0, v0):
        ``(-sigma, omega, y0, p, q, v0)`` with y0 = x0 - offset, p = v0 + sigma y0 and
        q = omega^2 y0 + sigma v0, so that y = y0 C + p S and v = v0 C - q S (eq. 9-10). They
        are the ones :meth:`increment`'s under-damped function binds, and the compiled flight
        search (solvers/search/flight_search.py) takes them in this order."""
        return under_constants(self.offset, self.sigma, self.omega, self.omega2, x0, v0)

    def response_constants(self, x0: float, v0: float) -> tuple[float, ...]:
        """The eight constants of the free response from the anchor (x0, v0) in its form
        (:func:`response_constants`), as the compiled flight search takes them."""
        return response_constants(self.form, self.offset, self.sigma, self.omega, self.omega2,
                                  self._s_slow, self._s_fast, x0, v0)

    def deviation_increment(self, y0: float, v0: float) -> Callable[[float], tuple[float, float]]:
        """:meth:`increment` from the deviation y0 = x0 - offset itself: ``t -> (y(t) - y0,
        y'(t))``. Any free response given by its value and rate serves (the linear sticking
        phase follows its contact force's part ``-b y' - M y''`` so, without the offset)."""
        if self.regime == UNDER:  # (y0 - 0.0 is y0, a zero's sign included)
            return under_response(*under_constants(0.0, self.sigma, self.omega, self.omega2,
                                                   y0, v0))
        form = self.form
        constants = response_constants(form, 0.0, self.sigma, self.omega, self.omega2,
                                       self._s_slow, self._s_fast, y0, v0)

        def aperiodic(t: float, form=form, constants=constants) -> tuple[float, float]:
            return aperiodic_increment(t, form, *constants)
        return aperiodic

    def modes(self, y0, v0):
        """(A, B) of the well over-damped response ``y = A e^{s1 t} + B e^{s2 t}`` from (y0, v0)
        (floats or arrays; s1 the slow exponent, s2 the fast one, s1 - s2 = 2 wo).

        Its rate ``A s1 e^{s1 t} + B s2 e^{s2 t}`` is at t = 0 the difference of two terms of
        about |y0| omega_n^2 / (2 wo) each, so it misses v0 by their rounding: 2.2e-16 m/s for a
        pair at rest 4,300 m from its equilibrium (a sticking phase under a flow the next step
        set to 0, which re-anchored its flight on that speed: energy from rest). While the fast
        mode is above half its start (s2 t > ``MODE_VELOCITY_SWITCH``) the rate is therefore
        v0 plus its increments, ``v0 + A s1 (e^{s1 t} - 1) + B s2 (e^{s2 t} - 1)``: exactly v0 at
        t = 0, and rounding of the order of the increments; once the fast mode has decayed, the
        sum of the two modes, whose rounding decays with them
        (docs/explanation/robustness/flights.md#over-damped-velocity)."""
        slow, fast = self._s_slow, self._s_fast
        gap = slow - fast  # 2 wo
        return (v0 - fast * y0) / gap, (slow * y0 - v0) / gap

    @property
    def exponents(self) -> tuple[float, float]:
        """(s1, s2): the slow and the fast exponent of the over-damped response (see
        :meth:`modes`), 1/s, as the closed forms take them in every regime (s1 = 0 and
        s2 = -(sigma + omega) unless over-damped)."""
        return self._s_slow, self._s_fast

    def mode_values(self, a: float, b: float, t: float) -> tuple[float, float]:
        """The two modes ``A e^{s1 t}``, ``B e^{s2 t}`` at time t (s, a float), from the (A, B)
        of :meth:`modes`."""
        return a * exp(self._s_slow * t), b * exp(self._s_fast * t)

    @property
    def two_modes(self) -> bool:
        """Well over-damped (wo > sigma / 2): the response is written on its two exponents."""
        return self.regime == OVER and self.omega > 0.5 * self.sigma

    def deviation_integral(self, y0, v0, t):
        """``int_0^t (y - y0) dt'`` for the free response from (y0, v0) (floats or arrays like
        t), well over-damped only (:attr:`two_modes`), on the exponents s1, s2:
        ``A (e^{s1 t} - 1 - s1 t) / s1 + B (e^{s2 t} - 1 - s2 t) / s2``, each term without
        cancellation (a series where |s t| < 0.01), so that the integral stays accurate when y0
        is far larger than the motion (a sticking phase's contact force: lam0 plus the
        increments of a free response of 4e4 N that moves by 1e-11 N)."""
        slow, fast = self.deviation_integral_terms(*self.modes(y0, v0), t)
        return slow + fast

    def deviation_integral_terms(self, a, b, t):
        """The two terms of :meth:`deviation_integral` at t from the modes (A, B) of the
        response (:meth:`modes`); its rounding is a few ulps of the sum of their magnitudes."""
        return a * _expm1_minus_x(self._s_slow, t), b * _expm1_minus_x(self._s_fast, t)

    def mode_steps(self, a, b, t_a, t_b, exp=ew.exp, expm1=ew.expm1):
        """The change of each mode of the well over-damped response with modes (A, B)
        (:meth:`modes`) between t_a and t_b: ``(A (e^{s1 t_b} - e^{s1 t_a}),
        B (e^{s2 t_b} - e^{s2 t_a}))``, each as ``A e^{s t_a} (e^{s (t_b - t_a)} - 1)``, to a
        few ulps of itself: the change of y is their sum, that of y' the sum of each times its
        exponent. (y(t_b) - y0 minus y(t_a) - y0 carries the rounding of the anchor's scale,
        |A| + |B|, however far the motion has decayed since.) Floats with ``exp``, ``expm1``
        from :mod:`math`, or arrays with :mod:`.elementwise`'s."""
        slow, fast = self._s_slow, self._s_fast
        dt = t_b - t_a
        return (a * exp(slow * t_a) * expm1(slow * dt), b * exp(fast * t_a) * expm1(fast * dt))

    def displacement_change(self, x0: float, v0: float, t: float) -> tuple[float, float]:
        """x(t) - x0 (free of the rounding of x0) and v(t): :meth:`increment` at one time."""
        return self.increment(x0, v0)(t)

    def displacement_change_array(self, x0, v0, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised :meth:`displacement_change` (x0, v0 floats or arrays like t), with its
        exponent form when well over-damped."""
        y0 = x0 - self.offset
        if self.regime == OVER and self.omega > 0.5 * self.sigma:
            t = np.asarray(t, dtype=float)
            slow, fast = self._s_slow, self._s_fast
            a, b = self.modes(y0, v0)
            a_rate, b_rate = a * slow, b * fast
            fast_t = fast * t
            slow_m1, fast_m1 = ew.expm1(slow * t), ew.expm1(fast_t)
            return (a * slow_m1 + b * fast_m1,
                    np.where(fast_t > MODE_VELOCITY_SWITCH,
                             v0 + (a_rate * slow_m1 + b_rate * fast_m1),
                             a_rate * ew.exp(slow * t) + b_rate * ew.exp(fast_t)))
        c, cm1, s = self.basis_parts_array(t)
        return (y0 * cm1 + (v0 + self.sigma * y0) * s,
                v0 * c - (self.omega2 * y0 + self.sigma * v0) * s)

    def response_array(self, x0: float, v0: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised :meth:`response` (x0, v0 floats or arrays like t)."""
        y0 = x0 - self.offset
        c, s = self.basis_array(t)
        return (self.offset + y0 * c + (v0 + self.sigma * y0) * s,
                v0 * c - (self.omega2 * y0 + self.sigma * v0) * s)

    def acceleration(self, x: float, v: float) -> float:
        """y'' from the equation of motion."""
        return -(self.damping * v + self.stiffness * (x - self.offset)) / self.mass

    def derivatives(self, x: float, v: float) -> tuple[float, float, float]:
        """Acceleration, jerk and snap (2nd, 3rd, 4th derivatives of x) at state (x, v)."""
        a = self.acceleration(x, v)
        j = -(self.damping * a + self.stiffness * v) / self.mass
        s = -(self.damping * j + self.stiffness * a) / self.mass
        return a, j, s

    def bounds(self, x: float, v: float) -> tuple[float, float, float]:
        """(x'', bound on |x''|, bound on |x'''|) for all later times from the state (x, v): the
        :meth:`derivatives` and their :meth:`amplitude_bound`, in one call (a flight's root search
        asks at every step). Outside the over-damped regime the energy bound is written out here,
        equal to :meth:`amplitude_bound`'s to the bit (a test checks)."""
        return self.deviation_bounds(x - self.offset, v)

    def deviation_bounds(self, y: float, ydot: float) -> tuple[float, float, float]:
        """:meth:`bounds` of the free response from its deviation y (= x - offset) and its
        rate: the acceleration and bounds on its magnitude and the jerk's for all later times.
        A structure whose equilibrium moves (a load changing linearly in time) follows its free
        response about it (:mod:`.modes`)."""
        mass, damping, stiffness = self.mass, self.damping, self.stiffness
        a = -(damping * ydot + stiffness * y) / mass
        j = -(damping * a + stiffness * ydot) / mass
        s = -(damping * j + stiffness * a) / mass
        if self.regime != OVER:
            omega2 = self.omega2
            return a, sqrt(a * a + j * j / omega2), sqrt(j * j + s * s / omega2)
        return a, self.amplitude_bound(a, j), self.amplitude_bound(j, s)

    def derivative_chain(self, x: float, v: float, order: int) -> list[float]:
        """[y, y', y'', ..., y^(order)] at state (x, v), from the equation of motion."""
        chain = [x - self.offset, v]
        while len(chain) <= order:
            chain.append(-(self.damping * chain[-1] + self.stiffness * chain[-2]) / self.mass)
        return chain

    def amplitude_bound(self, y: float, ydot: float) -> float:
        """Bound on |y(t')| for all t' >= t, for any solution y with value y, rate ydot at t.

        Every derivative of a free response is itself a free response, and its energy
        ``mass ydot^2/2 + stiffness y^2/2`` never grows (damping >= 0), so
        ``|y(t')| <= sqrt(y^2 + (mass/stiffness) ydot^2)``. Over-damped, the response is
        ``A e^{s1 t} + B e^{s2 t}`` with both exponents negative, so also ``|y| <= |A| + |B|``:
        far tighter when sigma >> omega_n (the energy bound exceeds it by about sigma / omega_n,
        3e8 for a light floe sticking under a strong linear drag, and a root search on it
        crawled at 1e-13 s steps).

        At scales whose squares underflow (|y| below ~1e-154: a pair at rest 1e-288 m from its
        equilibrium) or overflow, the sum of squares gave 0 or inf, and a bound of 0 told the
        root search its signal was linear; there the same bound comes from ``math.hypot``.
        """
        energy = math.sqrt(y * y + ydot * ydot / self.omega2)
        if not 1e-140 < energy < 1e140:
            energy = math.hypot(y, ydot / math.sqrt(self.omega2))
        if self.regime != OVER:
            return energy
        slow, fast = self._s_slow, self._s_fast
        modes = (abs(ydot - fast * y) + abs(slow * y - ydot)) / (slow - fast)
        return min(energy, modes * (1.0 + 1e-15))  # a few ulps above the rounding of |A| + |B|


def morison_oscillator(mass: float, damping: float, stiffness: float, drag_b: float,
                       u: float) -> Oscillator:
    """The structure under a linearised Morison drag ``drag_b (u - x')`` (kg/s) in a flow of
    speed u (m/s): ``mass x'' + (damping + drag_b) x' + stiffness (x - drag_b u / stiffness) = 0``,
    i.e. ``mass x'' + damping x' + stiffness x = drag_b (u - x')``."""
    return Oscillator(mass, damping + drag_b, stiffness, offset=drag_b * u / stiffness)


def dragged_acceleration(x: float, v: float, u: float, mass: float, damping: float,
                         stiffness: float, drag_B: float) -> float:
    """The acceleration (m/s^2) of the structure under the quadratic Morison drag
    (:class:`DraggedStructure`) at state (x, v) in a flow of speed u: ``(F_s - damping v -
    stiffness x) / mass``, F_s the drag law's force on velocity v, ``-B_s |v - u| (v - u)``
    (``QuadraticDrag.force``). Plain floats: the compiled flight search calls it too."""
    r = v - u
    force = -drag_B * abs(r) * r
    return (force - damping * v - stiffness * x) / mass


def dragged_bounds(x: float, v: float, u: float, mass: float, damping: float,
                   stiffness: float, omega2: float,
                   drag_B: float) -> tuple[float, float, float]:
    """(acceleration, bound on its magnitude, bound on the jerk's) for all later times from
    state (x, v) of the structure under the quadratic Morison drag, omega2 = stiffness / mass:
    the bounds :class:`DraggedStructure` derives. Plain floats: the compiled flight search
    calls it too."""
    a = dragged_acceleration(x, v, u, mass, damping, stiffness, drag_B)
    accel_max = math.sqrt(a * a + omega2 * v * v)
    speed_max = math.sqrt(v * v + a * a / omega2)
    drag_rate_max = 2.0 * drag_B * (abs(u) + speed_max)  # |dF_s/dv|, kg/s
    jerk_max = ((damping + drag_rate_max) * accel_max + stiffness * speed_max) / mass
    return a, accel_max, jerk_max


class DraggedStructure:
    """The structure under the quadratic Morison drag (docs/explanation/morison.md), which has no
    closed form:
    ``mass x'' + damping x' + stiffness x = F_s(x')``, ``F_s = B_s |u - x'| (u - x')``, the flow
    speed u constant; ``drag`` gives F_s (:func:`iceimpact.physics.ice.make_structure_drag`).

    :meth:`bounds` bounds the acceleration and the jerk for all later times, so that a root search
    on the gap can prove intervals root-free, as :meth:`Oscillator.amplitude_bound` does for the
    closed forms. With a = x'', ``mass a' = -(damping + F_s') a - stiffness x'`` where
    ``F_s' = 2 B_s |u - x'| >= 0``, so ``E_a = mass a^2 / 2 + stiffness x'^2 / 2`` never grows:
    ``|a| <= sqrt(a0^2 + (stiffness/mass) v0^2)`` and ``|x'| <= sqrt(v0^2 + (mass/stiffness) a0^2)``
    from then on, and ``|a'| <= ((damping + 2 B_s (|u| + |x'|max)) |a|max + stiffness |x'|max)
    / mass``.
    """

    __slots__ = ("mass", "damping", "stiffness", "drag", "omega2")

    def __init__(self, mass: float, damping: float, stiffness: float, drag):
        self.mass, self.damping, self.stiffness, self.drag = mass, damping, stiffness, drag
        self.omega2 = stiffness / mass

    def acceleration(self, x: float, v: float, u: float) -> float:
        """x'' from the equation of motion, m/s^2 (:func:`dragged_acceleration`)."""
        return dragged_acceleration(x, v, u, self.mass, self.damping, self.stiffness,
                                    self.drag.B)

    def bounds(self, x: float, v: float, u: float) -> tuple[float, float, float]:
        """(x'', bound on |x''|, bound on |x'''|) for all later times from state (x, v)
        (:func:`dragged_bounds`)."""
        return dragged_bounds(x, v, u, self.mass, self.damping, self.stiffness, self.omega2,
                              self.drag.B)
