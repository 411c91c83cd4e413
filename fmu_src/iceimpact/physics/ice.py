"""The ice: a free mass driven by Morison drag from a current of speed u (eq. 1-7, 31-36).

With r = w - u the velocity relative to the flow and u constant:

- linearised drag (eq. 4-7), kappa = b / M:
  ``r(t) = r0 e^{-kappa t}``, ``z(t) = z0 + u t + r0 (1 - e^{-kappa t}) / kappa``;
- quadratic drag (eq. 3, 31-33), beta = B / M:
  ``r(t) = r0 / (1 + beta |r0| t)``, ``z(t) = z0 + u t + sign(r0) ln(1 + beta |r0| t) / beta``.

The article integrates the quadratic law with explicit Euler (eq. 34-36); the closed form above is
exact. Both hold for any sign of r0 and for u = 0; with no drag (Cd = 0) the ice coasts.

The same laws give the Morison drag on the structure (:func:`make_structure_drag`, off unless a
scene asks for it; docs/explanation/morison.md).
"""

from __future__ import annotations

from collections.abc import Callable
from math import expm1, log1p

import numpy as np

from . import elementwise as ew


def _decay_lag_array(x: np.ndarray) -> np.ndarray:
    """(1 - e^{-x}) / x - 1 for x >= 0, element by element, as :meth:`LinearDrag.increment`
    evaluates it for one x (series below 1e-2)."""
    small = x < 1e-2
    safe = np.where(small, 1.0, x)
    s = np.where(small, x, 0.0)  # the series only where it is used: a large x overflows it
    series = -s * (0.5 - s * (1 / 6 - s * (1 / 24 - s * (1 / 120 - s / 720))))
    return np.where(small, series, -ew.expm1(-safe) / safe - 1.0)


def _log_lag_array(y: np.ndarray) -> np.ndarray:
    """ln(1 + y) / y - 1 for y >= 0, element by element, as :meth:`QuadraticDrag.increment`
    evaluates it for one y (series below 1e-3)."""
    small = y < 1e-3
    safe = np.where(small, 1.0, y)
    s = np.where(small, y, 0.0)  # the series only where it is used: a large y overflows it
    series = -s * (0.5 - s * (1 / 3 - s * (0.25 - s * (0.2 - s / 6))))
    return np.where(small, series, ew.log1p(safe) / safe - 1.0)


class _DragLaw:
    """What both drag laws derive from their closed forms."""

    __slots__ = ()

    def displacement_change_array(self, w0, u: float, t: np.ndarray):
        """Vectorised ``displacement_change``: z(t) - z0 and w(t) of free flights (w0 a float or
        an array like t)."""
        return self.motion_array(0.0, w0, u, t)


def linear_response(kappa: float, w0: float, r0: float) -> Callable[[float], tuple[float, float]]:
    """The free flight under the linear drag ``t -> (z(t) - z0, w(t))`` with the constants of
    :meth:`LinearDrag.flight_constants` (eq. 6-7)."""
    def linear(t: float, kappa=kappa, w0=w0, r0=r0) -> tuple[float, float]:
        x = kappa * t
        if x < 1e-2:  # series, truncation ~ x^6 / 5040
            lag = -x * (0.5 - x * (1 / 6 - x * (1 / 24 - x * (1 / 120 - x / 720))))
        else:
            lag = -expm1(-x) / x - 1.0
        return w0 * t + r0 * t * lag, w0 + r0 * expm1(-x)
    return linear


def quadratic_response(rate: float, w0: float, r0: float
                       ) -> Callable[[float], tuple[float, float]]:
    """The free flight under the quadratic drag ``t -> (z(t) - z0, w(t))`` with the constants of
    :meth:`QuadraticDrag.flight_constants` (rate = beta |r0|; exact solution of eq. 32)."""
    def quadratic(t: float, rate=rate, w0=w0, r0=r0) -> tuple[float, float]:
        y = rate * t
        if y < 1e-3:  # series, truncation ~ y^6 / 7
            lag = -y * (0.5 - y * (1 / 3 - y * (0.25 - y * (0.2 - y / 6))))
        else:
            lag = log1p(y) / y - 1.0
        return w0 * t + r0 * t * lag, w0 - r0 * (y / (1.0 + y))
    return quadratic


def linear_flight_constants(kappa: float, w0: float, u: float) -> tuple[float, float, float]:
    """:meth:`LinearDrag.flight_constants` over plain floats (the compiled march of the exact
    method calls it too, solvers/exact/bounces.py)."""
    return kappa, w0, w0 - u


def quadratic_flight_constants(beta: float, w0: float, u: float) -> tuple[float, float, float]:
    """:meth:`QuadraticDrag.flight_constants` over plain floats (as
    :func:`linear_flight_constants`)."""
    r0 = w0 - u
    return beta * abs(r0), w0, r0


class LinearDrag(_DragLaw):
    """Linearised Morison drag ``M w' = -b (w - u)`` (eq. 4-5)."""

    __slots__ = ("mass", "b", "kappa", "law_constants")
    quadratic = False

    def __init__(self, mass: float, b: float):
        self.mass = mass
        self.b = b
        self.kappa = b / mass
        #: the law as the compiled flight search takes it: (coefficient, quadratic)
        self.law_constants = (self.kappa, 0)

    def force(self, w: float, u: float) -> float:
        """Drag force on the ice, N."""
        return -self.b * (w - u)

    @property
    def drags(self) -> bool:
        """The drag acts in the closed forms (kappa > 0); without it the ice coasts."""
        return self.kappa > 0.0

    def force_rate(self, w: float, u: float) -> float:
        """dF/dw, kg/s (used for the sticking phase's contact-force rate)."""
        return -self.b

    def motion(self, z0: float, w0: float, u: float, t: float) -> tuple[float, float]:
        """Ice displacement and velocity at time t of a free flight (eq. 6-7)."""
        dz, w = self.displacement_change(w0, u, t)
        return z0 + dz, w

    def increment(self, w0: float, u: float) -> Callable[[float], tuple[float, float]]:
        """The free flight from velocity w0 as a function ``t -> (z(t) - z0, w(t))`` (eq. 6-7),
        its constants computed once (the scalar form; :meth:`motion_array` the vectorised one).

        The drift is ``w0 t + r0 t L(kappa t)`` with the lag ``L(x) = (1 - e^{-x}) / x - 1``
        behind coasting at w0, free of cancellation at small x (its series), so it is exact to
        rounding even when far below the rounding of u t. The velocity is
        ``w0 + r0 (e^{-x} - 1)``: exactly w0 at t = 0 and without drag, even when |w0| << |u|.
        (The returned function takes t alone; its constants, :meth:`flight_constants`, are bound
        as its default values; solvers/search/flight_search.py's _motion repeats this form operation
        for operation on the same constants.)"""

        return linear_response(self.kappa, w0, w0 - u)

    def flight_constants(self, w0: float, u: float) -> tuple[float, float, float]:
        """The constants of the free flight from velocity w0 at flow speed u: ``(kappa, w0,
        r0 = w0 - u)``, as :meth:`increment` binds them and the compiled flight search
        (solvers/search/flight_search.py) takes them."""
        return linear_flight_constants(self.kappa, w0, u)

    #: the flight's closed form on :meth:`flight_constants`
    response = staticmethod(linear_response)

    def displacement_change(self, w0: float, u: float, t: float) -> tuple[float, float]:
        """z(t) - z0 and w(t) of a free flight: :meth:`increment` at one time."""
        return self.increment(w0, u)(t)

    def motion_array(self, z0: float, w0: float, u: float, t: np.ndarray):
        """Vectorised :meth:`motion`."""
        t = np.asarray(t, dtype=float)
        r0 = w0 - u
        x = self.kappa * t
        # the velocity as displacement_change's: w0 + r0 (e^{-x} - 1)
        return z0 + w0 * t + r0 * t * _decay_lag_array(x), w0 + r0 * ew.expm1(-x)

    def accel_bounds(self, w: float, u: float) -> tuple[float, float, float]:
        """(acceleration, bound on |acceleration|, bound on |jerk|) for all later times.

        |r| only decays, so |w'| = kappa |r| and |w''| = kappa^2 |r| are bounded by today's values.
        """
        kappa = self.kappa
        a = -kappa * (w - u)
        size = a if a > 0.0 else 0.0 - a  # |a| (abs() written out: a root search asks at each
        # step; 0.0 - a gives +0.0 for either zero, as abs does)
        return a, size, kappa * size


class QuadraticDrag(_DragLaw):
    """Quadratic Morison drag ``M w' = -B |w - u| (w - u)`` (eq. 3, 31-33)."""

    __slots__ = ("mass", "B", "beta", "law_constants")
    quadratic = True

    def __init__(self, mass: float, B: float):
        self.mass = mass
        self.B = B
        self.beta = B / mass
        #: the law as the compiled flight search takes it: (coefficient, quadratic)
        self.law_constants = (self.beta, 1)

    def force(self, w: float, u: float) -> float:
        """Drag force on the ice, N (eq. 2)."""
        r = w - u
        return -self.B * abs(r) * r

    @property
    def drags(self) -> bool:
        """The drag acts in the closed forms (beta > 0); without it the ice coasts."""
        return self.beta > 0.0

    def force_rate(self, w: float, u: float) -> float:
        """dF/dw, kg/s."""
        return -2.0 * self.B * abs(w - u)

    def motion(self, z0: float, w0: float, u: float, t: float) -> tuple[float, float]:
        """Ice displacement and velocity at time t of a free flight (exact solution of eq. 32)."""
        dz, w = self.displacement_change(w0, u, t)
        return z0 + dz, w

    def increment(self, w0: float, u: float) -> Callable[[float], tuple[float, float]]:
        """The free flight from velocity w0 as a function ``t -> (z(t) - z0, w(t))`` (exact
        solution of eq. 32), its constants computed once (the scalar form; :meth:`motion_array`
        the vectorised one).

        The drift is ``w0 t + r0 t L(y)``, y = beta |r0| t, with the lag
        ``L(y) = ln(1 + y) / y - 1`` free of cancellation at small y (its series). The velocity
        is ``w0 - r0 y / (1 + y)``: exactly w0 at t = 0 and without drag, even when
        |w0| << |u|. (The returned function takes t alone; its constants are bound as its
        default values.)"""
        return quadratic_response(*self.flight_constants(w0, u))

    def flight_constants(self, w0: float, u: float) -> tuple[float, float, float]:
        """The constants of the free flight from velocity w0 at flow speed u: ``(beta |r0|,
        w0, r0 = w0 - u)``, as :meth:`increment` binds them and the compiled flight search
        (solvers/search/flight_search.py) takes them."""
        return quadratic_flight_constants(self.beta, w0, u)

    #: the flight's closed form on :meth:`flight_constants`
    response = staticmethod(quadratic_response)

    def displacement_change(self, w0: float, u: float, t: float) -> tuple[float, float]:
        """z(t) - z0 and w(t) of a free flight: :meth:`increment` at one time."""
        return self.increment(w0, u)(t)

    def motion_array(self, z0: float, w0: float, u: float, t: np.ndarray):
        """Vectorised :meth:`motion`."""
        t = np.asarray(t, dtype=float)
        r0 = w0 - u
        y = self.beta * np.abs(r0) * t
        # the velocity as displacement_change's: w0 - r0 y / (1 + y)
        return z0 + w0 * t + r0 * t * _log_lag_array(y), w0 - r0 * (y / (1.0 + y))

    def accel_bounds(self, w: float, u: float) -> tuple[float, float, float]:
        """(acceleration, bound on |acceleration|, bound on |jerk|) for all later times.

        |r| only decays: |w'| = beta r^2 and |w''| = 2 beta^2 |r|^3 never exceed today's values.
        """
        r = w - u
        speed = abs(r)
        a = -self.beta * speed * r
        size = abs(a)
        return a, size, 2.0 * self.beta * speed * size


def downstream_speed_bound(w: float, u: float, drags: bool = True) -> float:
    """Bound on the ice's downstream velocity (m/s, >= 0) for all later times of a free flight
    from velocity w in a flow u: under either drag law the velocity relative to the flow, w - u,
    only decays without changing sign (eq. 5, 32), so w stays between w and u. Without drag
    (``drags`` False: Cd = 0) the ice coasts at w whatever the flow."""
    return max(w, u, 0.0) if drags else max(w, 0.0)


def make_drag(scene) -> LinearDrag | QuadraticDrag:
    """The drag law a scene asks for (``drag.model`` 1 = linearised, 2 = quadratic)."""
    if scene.drag_model == 2:
        return QuadraticDrag(scene.ice_M, scene.drag_B)
    return LinearDrag(scene.ice_M, scene.drag_b)


def make_structure_drag(scene) -> LinearDrag | QuadraticDrag | None:
    """Morison drag of the flow on the structure under ``drag.model``, None when off (structure.Cd
    structure.A = 0; docs/explanation/morison.md). The same law as the ice's, on the structure's
    velocity v
    and mass m + m_a: ``F_s = B_s |u - v| (u - v)`` (quadratic) or ``b_s (u - v)`` (linearised),
    B_s = rho Cd_s A_s / 2, b_s = B_s v_lin."""
    if not scene.structure_drag_on:
        return None
    if scene.drag_model == 2:
        return QuadraticDrag(scene.structure_mass, scene.structure_drag_B)
    return LinearDrag(scene.structure_mass, scene.structure_drag_b)
