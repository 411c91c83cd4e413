"""The structure as the ice sees it: the motion interface, and the external structure within a step.

The event solver's flights (:class:`iceimpact.solvers.exact.Flight`) ask the structure for its
motion from an anchor and for bounds on the derivatives of its displacement over the rest of the
flight; nothing else. Two structures answer:

- the built-in SDOF structure, :class:`iceimpact.physics.structure.Oscillator` (structure.model
  = 1);
- :class:`ExtrapolatedStructure`, a structure that lives in another FMU (structure.model = 2),
  as IceImpact extrapolates it over one communication step from the contact point's state the
  master gives at the step start.

Within one step the external structure is a point mass ``m`` (``structure.m``, its effective mass
at the contact point) under a constant force ``F_o``, the structure's own forces (spring,
damping, other loads) as estimated for the flight's anchor
(:mod:`iceimpact.solvers.exact.external`):
``x_s(tau) = x_a + v_a tau + a tau^2 / 2`` with ``a = F_o / m``. An impact makes the mass jump
in velocity (the impact law with ``m``), and the next flight is anchored on that jump, so the ice
meets a structure that felt the impact. The displacement is a polynomial: ``x_s'' = a`` and
``x_s''' = 0`` for all later times, the bounds the no-miss root search needs.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol


class StructureMotion(Protocol):
    """What a flight asks of the structure (the built-in Oscillator and ExtrapolatedStructure)."""

    def increment(self, x0: float, v0: float) -> Callable[[float], tuple[float, float]]:
        """The motion from the anchor (x0, v0): a function ``t -> (x(t) - x0, v(t))``."""

    def displacement_change(self, x0: float, v0: float, t: float) -> tuple[float, float]:
        """x(t) - x0 and v(t) from the anchor (x0, v0): ``increment(x0, v0)(t)``."""

    def acceleration(self, x: float, v: float) -> float:
        """x'' at the state (x, v), free of contact forces."""

    def derivatives(self, x: float, v: float) -> tuple[float, float, float]:
        """x'', x''', x'''' at the state (x, v)."""

    def amplitude_bound(self, y: float, ydot: float) -> float:
        """Bound on |y| for all later times, for the derivative pairs (x'', x''') and
        (x''', x'''') of a flight."""

    def bounds(self, x: float, v: float) -> tuple[float, float, float]:
        """(x'', bound on |x''|, bound on |x'''|) for all later times from the state (x, v):
        ``derivatives`` and their ``amplitude_bound``."""


class ExtrapolatedStructure:
    """An external structure within one communication step: constant acceleration ``a`` (m/s2)
    between impacts (see the module docstring)."""

    __slots__ = ("a",)
    #: no equilibrium to oscillate about, so no envelope bounds its motion (an oscillator's
    #: ``offset``; a flight's clearance proves nothing from it)
    offset = None

    def __init__(self, a: float):
        self.a = a

    def increment(self, x0: float, v0: float) -> Callable[[float], tuple[float, float]]:
        """``t -> (x(t) - x0, v(t))`` from the anchor (x0, v0)."""
        def constant_acceleration(t: float, a=self.a, v0=v0) -> tuple[float, float]:
            return (v0 + 0.5 * a * t) * t, v0 + a * t
        return constant_acceleration

    def displacement_change(self, x0: float, v0: float, t: float) -> tuple[float, float]:
        return self.increment(x0, v0)(t)

    def response(self, x0: float, v0: float, t: float) -> tuple[float, float]:
        dx, v = self.displacement_change(x0, v0, t)
        return x0 + dx, v

    def acceleration(self, x: float, v: float) -> float:
        return self.a

    def derivatives(self, x: float, v: float) -> tuple[float, float, float]:
        return self.a, 0.0, 0.0

    def amplitude_bound(self, y: float, ydot: float) -> float:
        # x'' is constant and x''' = 0: a derivative of order >= 2 keeps its value
        return abs(y)

    def bounds(self, x: float, v: float) -> tuple[float, float, float]:
        return self.a, abs(self.a), 0.0
