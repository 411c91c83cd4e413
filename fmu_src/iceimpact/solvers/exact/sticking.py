"""The sticking segments of the exact method: the bodies pressed together, under the linear drag
in closed form (:class:`LinearStick`, cf. eq. 27-29) or the quadratic drag by Taylor steps
(:class:`QuadraticStick`); their contact force and the clearances that prove it stays a push."""

from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Callable
from operator import attrgetter
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import SolverError
from ...physics import elementwise as ew
from ...physics.structure import (
    UNDER,
    Oscillator,
)
from ...record import Record
from ..base import GAP_ROUNDING, GAP_ULPS
from ..contact_rules import (
    ROUNDING_SPEED,
    Phase,
    Together,
    make_together,
    separates,
    sticking_contact_force,
)
from ..search.rootfind import RootSearch
from ..search.taylor import StepEnd, StickingTaylor, TaylorStep, states_of_steps
from .segment import STEPPED, _entry, _SearchedSegment, _time_eps

if TYPE_CHECKING:
    from .context import SegmentContext


_NO_STATE = (math.nan, math.nan, math.nan)
#: Taylor steps in a row that do not advance the time before a sticking phase is given up.
_MAX_STALLED_STEPS = 4
#: a Taylor step's end, the key its segment's list of steps is ordered by (as by its start)
_step_hi = attrgetter("hi")

#: At most this many Taylor steps of a quadratic-drag sticking phase are saved in a snapshot
#: (those the future can ask for: one, or two at a step boundary).
_MAX_STEPS = 8


class LinearStick(_SearchedSegment):
    """Bodies together under linear drag: closed form (mass m+M, damping c+b, offset b u / k;
    with the Morison terms on the structure, m is m + m_a and b_s adds to b:
    docs/explanation/morison.md).

    Positions, velocities and the contact force are all evaluated as increments from the
    anchor, as a flight's are. The equilibrium b u / k can be far away (7.7e12 m for a light
    pair under b = 4e5 kg/s and k = 5.2e-9 N/m, where a position's ulp is 1e-3 m): a position
    written as offset + y carried that rounding, and the contact force ``b (u - v) - M x''``
    from it was a difference of terms of b u = 4e4 N for a force of 1e-11 N, below its own
    rounding, so that the separation search crawled. Here the force is
    ``lam = lam0 + (q - q0)``: lam0 from the anchor's own state (no offset in it), and
    ``q = -b y' - M y''`` a free response of the same oscillator (eq. 24), followed by its
    increments from (q0, lam0')."""

    __slots__ = ("M", "drag", "b", "t0", "x0", "v0", "u", "start", "osc", "search", "_increment",
                 "_lam0", "_q0", "_q_increment", "_last", "_b_all", "_c", "_push", "_q_modes",
                 "_y_modes", "_force_modes", "_mu")
    phase = Phase.STICK
    ANCHOR = ("x0", "v0")
    PUSHES = True

    def __init__(self, context: SegmentContext, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.M = context.M
        self.drag = context.drag
        self.b = b = context.drag.b
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.start = start
        b_s = context.structure_b  # linearised drag on the structure (0 when off)
        self.osc = osc = Oscillator(context.m + context.M, context.c + b + b_s, context.k,
                                    offset=(b + b_s) * u / context.k)
        self._increment = osc.increment(x0, v0)
        self._c = context.c
        self._b_all = b + b_s
        self._lam0, self._q0, rate0 = self._anchor_force(x0, v0)
        self._q_increment = osc.deviation_increment(self._q0, rate0)
        self._push = b * u
        self._mu = context.m * context.M / (context.m + context.M)  # reduced mass, kg
        # well over-damped: q's two modes at the anchor (see _force)
        self._q_modes = osc.modes(self._q0, rate0) if osc.two_modes else None
        self._y_modes = osc.modes(x0 - osc.offset, v0) if osc.two_modes else None
        self._force_modes = self._modes_of_force(self._y_modes) if osc.two_modes else None
        lam0 = self._lam0
        self._last: tuple[float, float, float, float, float] = (
            0.0, lam0, self._q0, rate0, abs(lam0))
        self.search = RootSearch(start, _time_eps(t0))

    def _modes_of_force(self, y_modes):
        """Well over-damped, the modes (Q1, Q2) of ``q = -b y' - M y''`` from those (Y1, Y2) of
        the deviation y (:meth:`Oscillator.modes`): ``Qk = -sk (b + M sk) Yk``, each to a few
        ulps of itself, for the contact force's form ``b u + Q1 e^{s1 t} + Q2 e^{s2 t}`` (see
        :meth:`_force`) and its clearance.

        Not from the anchor's (q0, q0') (``_q_modes``, which the impulse's integral form keeps:
        their sum is q0 to the bit there): Q1 = (q0' - s2 q0) / (s1 - s2) is a difference of
        terms of the fast mode's size, whose rounding swamps a slow mode far below it. A 0.45 g
        structure (omega_n 1e-3 rad/s) stuck to a 0.8 mg floe by a plastic impact at 0.17 m/s
        under b = 217 kg/s: the fast mode (4.8e5 1/s) starts at 36 N, the slow one, the spring
        pulling the pair back against the floe's drag, is a tension of -1.6e-16 N, and came out
        as exactly 0: the separation was never found, and the contact pulled at -1.6e-16 N, a
        step impulse of -1.6e-20 N.s in every 0.1 ms step."""
        s_slow, s_fast = self.osc.exponents
        b, M = self.b, self.M
        return -s_slow * (b + M * s_slow) * y_modes[0], -s_fast * (b + M * s_fast) * y_modes[1]

    def _anchor_force(self, x0, v0):
        """(lam0, q0, lam0') at an anchor (floats or arrays), lam = b u + q: the acceleration and
        jerk from the anchor's own state, (b + b_s) (u - v) - c v - k x, not k (x - offset),
        whose offset carries the rounding of a far equilibrium."""
        osc, b, M, u = self.osc, self.b, self.M, self.u
        a0 = (self._b_all * (u - v0) - self._c * v0 - osc.stiffness * x0) / osc.mass
        j0 = -(osc.damping * a0 + osc.stiffness * v0) / osc.mass
        lam0 = sticking_contact_force(self.drag.force(v0, u), M * a0)
        return lam0, -b * v0 - M * a0, -b * a0 - M * j0

    def state(self, tau: float) -> tuple[float, float, float, float]:
        dx, v = self._increment(tau)
        x = self.x0 + dx
        return x, v, x, v

    def state_array(self, anchor, tau):
        x0, v0 = anchor
        dx, v = self.osc.displacement_change_array(x0, v0, tau)
        x = x0 + dx
        return x, v, x, v

    def _force(self, tau: float) -> tuple[float, float, float, float, float]:
        """(tau, lam, q, lam', scale) at tau, scale the sum of the magnitudes of the terms lam
        is made of (its rounding is a few ulps of it); the last one is kept (the search asks
        again for it).

        lam is ``lam0 + (q - q0)``, whose rounding is that of the anchor's force lam0 however
        far the motion has decayed since. Well over-damped, q is also ``Q1 e^{s1 t} +
        Q2 e^{s2 t}`` (its modes from the deviation's, :meth:`_modes_of_force`), and
        ``lam = b u + Q1 e^{s1 t} + Q2 e^{s2 t}`` has a rounding that decays with the modes
        (b u aside, large where the equilibrium is far): whichever is smaller is taken. An
        over-damped pair (zeta 50, 18 mg on 0.6 kg) decaying at 1e-14 m/s has a force of
        3e-11 N; from lam0 = 5e4 N its rounding, 1e-11 N, made a sign change the search took
        for a separation."""
        last = self._last
        if last[0] == tau:
            return last
        dq, rate = self._q_increment(tau)
        lam0 = self._lam0
        lam, q, scale = lam0 + dq, self._q0 + dq, abs(lam0) + abs(dq)
        modes = self._force_modes
        if modes is not None:
            slow, fast = self.osc.mode_values(*modes, tau)
            push = self._push
            by_modes = abs(push) + abs(slow) + abs(fast)
            if by_modes < scale:
                q = slow + fast
                lam, scale = push + q, by_modes
        self._last = last = (tau, lam, q, rate, scale)
        return last

    def force(self, tau: float) -> float:
        """Contact force on the structure, N: drag on the ice minus its inertia."""
        return self._force(tau)[1]

    def force_and_rate(self, tau: float) -> tuple[float, float]:
        """Contact force (N) and its rate (N/s): -b a - M j, a and j the acceleration and jerk."""
        _, lam, _, rate, _ = self._force(tau)
        return lam, rate

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        """Contact force, its two derivatives, bounds on |lam''| and |lam'''| from here on: the
        higher derivatives of q from its equation of motion, mass q'' + damping q' + k q = 0."""
        _, lam, q, rate, _ = self._force(tau)
        osc = self.osc
        mass, damping, stiffness = osc.mass, osc.damping, osc.stiffness
        curvature = -(damping * rate + stiffness * q) / mass
        q3 = -(damping * curvature + stiffness * rate) / mass
        q4 = -(damping * q3 + stiffness * curvature) / mass
        return (lam, rate, curvature, osc.amplitude_bound(curvature, q3),
                osc.amplitude_bound(q3, q4))

    def clearance(self, tau: float) -> float:
        """Time from tau (s) during which the contact force provably stays compressive: all of
        it (inf) or nothing (0).

        ``lam = b (u - v) - M a = b u + q`` with ``q = -b y' - M y''`` (y = x - offset): a
        combination of derivatives of the free response is a free response of the same
        oscillator, so |q| never exceeds its amplitude bound from (q, q'), and lam stays above
        ``b u - R_q`` from here on (beyond the rounding of the terms it is made of). The
        bodies ringing stiffly in contact with an amplitude too small to part them (omega
        3.9e7 rad/s, 3e-13 m under a drag force b u of 5.7e6 N) cost the Taylor steps of the
        search two evaluations per period; this spans the whole phase at once.

        Well over-damped, q is ``Q1 e^{s1 s} + Q2 e^{s2 s}`` from tau on (s2 < s1 < 0, the
        modes of the anchor's (q0, q0') at tau, :meth:`Oscillator.modes`), and
        ``q = e^{s1 s} (Q1 + Q2 e^{(s2 - s1) s}) >= L e^{s1 s}`` for all s >= 0 with
        ``L = Q1 + min(Q2, 0)``. When L >= 0 (beyond its rounding), lam = b u + q stays >= 0
        for ever if b u >= 0, and while ``L e^{s1 s} > -b u`` if not: for
        ``s < ln(L / -b u) / -s1``. The amplitude bound cannot see it once the motion has
        decayed: a 29 mg pair at rest under no flow, stuck at 6.8e7 N on k = 5.6e8 N/m, had a
        force of 1.5e-8 N (the rounding of the anchor's), along which the search crawled, 2e4
        steps per 0.01 s.

        Under-damped with b u > 0, a force that does turn tensile, but every time too slightly
        to part the bodies resolvably, is held through its tension for the whole phase
        (:meth:`_tension_unresolvable`)."""
        _, lam, q, rate, scale = self._force(tau)
        push = self._push
        reach = self.osc.amplitude_bound(q, rate)
        rounding = GAP_ULPS * (abs(push) + abs(q) + reach + scale)
        if push - reach - rounding > 0.0:
            return math.inf
        if self._tension_unresolvable(push, reach + rounding):
            return math.inf
        modes = self._force_modes
        if modes is None:
            return 0.0
        osc = self.osc
        slow, fast = osc.mode_values(*modes, tau)
        lowest = slow + min(fast, 0.0)
        if not (slow >= 0.0 and lowest >= GAP_ULPS * (abs(slow) + abs(fast))):
            return 0.0
        if push >= 0.0:
            return math.inf
        if lowest <= -push:
            return 0.0
        # (a few ulps short of the bound: its logarithm's rounding)
        return math.log(lowest / -push) / -osc.exponents[0] * (1.0 - GAP_ULPS)

    def _tension_unresolvable(self, push: float, reach: float) -> bool:
        """Whether every tensile stretch of the contact force from here on is too slight to
        part the bodies resolvably, so that they are held together through it (otherwise a
        stiff pair parts and re-contacts once a period without end:
        docs/explanation/robustness/sticking.md#stick-part-cycle).

        Under-damped, q = -b y' - M y'' is a free response (see :meth:`clearance`); in its
        phase plane ``q = rho cos(theta)``, ``q' = -omega0 rho sin(theta)`` (omega0^2 =
        k / (m + M)) the energy radius rho never grows (it starts at most ``reach``) and
        ``theta' = omega0 - sigma sin(2 theta) >= omega0 - sigma > 0``. The force
        ``lam = b u + q`` (b u = ``push`` > 0) is tensile only where ``cos(theta) < -push / rho
        <= -push / reach``: once per turn of theta, for at most
        ``T = 2 arccos(push / reach) / (omega0 - sigma)``, and never below
        ``-D = push - reach``. The tension of one stretch has an impulse of at most D T, and
        the relative speed it can give the bodies, ``s = D T / mu`` (mu the reduced mass), is
        held to be unresolvable when it is within the rounding of the speeds at which a
        contact merges a closing speed (ROUNDING_SPEED |u|, below the speed scale
        :meth:`ContactRules.is_rounding` uses) and the gap it can open over a whole turn,
        ``s 2 pi / (omega0 - sigma)``, is within the gap tolerance GAP_ROUNDING. A flight
        from such a separation re-contacts at a closing speed the contact merges: what
        holding the bodies gives, without a flight the positions cannot resolve. The step
        impulse stays >= -s mu >= -ROUNDING_SPEED mu |u|, below 1e-12 of the phase's momentum
        scale (m + M) |u|."""
        osc = self.osc
        if not (push > 0.0 and osc.regime == UNDER):
            return False
        turn = math.sqrt(osc.omega2) - osc.sigma  # theta' >= turn
        if not turn > 0.0:
            return False
        duration = 2.0 * math.acos(min(push / reach, 1.0)) / turn
        speed = (reach - push) * duration / self._mu
        return (speed <= ROUNDING_SPEED * self.u
                and speed * (2.0 * math.pi / turn) <= GAP_ROUNDING)

    # the root search's signal (:class:`~iceimpact.solvers.search.rootfind.Signal`): the contact
    # force
    value, value_and_rate = force, force_and_rate

    def impulse(self, tau_a: float, tau_b: float) -> float:
        """Integral of the contact force: drag impulse on the ice minus its momentum change."""
        if tau_b <= tau_a:
            return 0.0
        if self._q_modes is not None:
            balance, integral, smaller = self._two_forms(
                self._lam0, self._q_modes, self._y_modes, tau_a, tau_b, math.exp, math.expm1)
            return float(balance if smaller else integral)
        # displacement increments from the anchor: positions about an equilibrium b u / k far
        # away carry its rounding, which b (xb - xa) would multiply
        dxa, va = self._increment(tau_a)
        dxb, vb = self._increment(tau_b)
        return self._impulse(dxa, va, dxb, vb, tau_b - tau_a)

    def impulse_array(self, anchor, tau_a, tau_b):
        osc = self.osc
        if osc.two_modes:
            x0, v0 = anchor
            lam0, q0, rate0 = self._anchor_force(x0, v0)
            balance, integral, smaller = self._two_forms(
                lam0, osc.modes(q0, rate0), osc.modes(x0 - osc.offset, v0), tau_a, tau_b,
                ew.exp, ew.expm1)
            return np.where(tau_b > tau_a, np.where(smaller, balance, integral), 0.0)
        dxa, va = self.osc.displacement_change_array(*anchor, tau_a)
        dxb, vb = self.osc.displacement_change_array(*anchor, tau_b)
        return np.where(tau_b > tau_a, self._impulse(dxa, va, dxb, vb, tau_b - tau_a), 0.0)

    def _impulse(self, dxa, va, dxb, vb, duration):
        """Drag impulse on the ice, -b (dx - u dt), minus its momentum change M dv (dxa, dxb:
        displacements from the anchor)."""
        return -self.b * ((dxb - dxa) - self.u * duration) - self.M * (vb - va)

    def _two_forms(self, lam0, q_modes, y_modes, tau_a, tau_b, exp, expm1):
        """Well over-damped, the impulse from tau_a to tau_b in two forms, and whether the
        first has the smaller rounding (floats with :mod:`math`'s exp and expm1, or arrays with
        numpy's): (balance, integral, balance's rounding < integral's). Each form is a sum of
        terms, its rounding eps times the sum of their magnitudes.

        - integral: the contact force's integral as ``lam0 (tau_b - tau_a)`` plus that of
          q - q0 (:meth:`Oscillator.deviation_integral`, from the modes of the anchor's
          (q0, q0')). Far from the equilibrium, b (dx - u dt) is a difference of displacements
          whose rounding exceeds small impulses; this form has none. But lam0 is the anchor's
          force, and its rounding stays while the motion decays
          (docs/explanation/robustness/sticking.md#far-equilibrium-sticking has the cases).
        - balance: the step's momentum balance on its own modes, the drag impulse on the ice
          ``b (u dt - dy)`` minus its momentum change ``M dy'``, with dy = d1 + d2 and
          dy' = s1 d1 + s2 d2 the changes of the two modes over the step
          (:meth:`Oscillator.mode_steps`, from the modes of the anchor's deviation):
          ``b u dt - (b + M s1) d1 - (b + M s2) d2``, whose rounding decays with the motion
          (b |u| dt aside, large where the equilibrium is far). From the displacement
          increments of the anchor instead, dy_b - dy_a would carry the rounding of the
          anchor's scale."""
        osc, b, M = self.osc, self.b, self.M
        duration = tau_b - tau_a
        i_slow_b, i_fast_b = osc.deviation_integral_terms(*q_modes, tau_b)
        i_slow_a, i_fast_a = osc.deviation_integral_terms(*q_modes, tau_a)
        integral = lam0 * duration + ((i_slow_b + i_fast_b) - (i_slow_a + i_fast_a))
        integral_rounding = (abs(lam0) * duration + abs(i_slow_b) + abs(i_fast_b)
                             + abs(i_slow_a) + abs(i_fast_a))
        d_slow, d_fast = osc.mode_steps(*y_modes, tau_a, tau_b, exp, expm1)
        push = b * self.u * duration
        s_slow, s_fast = osc.exponents
        slow_part = (b + M * s_slow) * d_slow
        fast_part = (b + M * s_fast) * d_fast
        balance = push - slow_part - fast_part
        balance_rounding = abs(push) + abs(slow_part) + abs(fast_part)
        return balance, integral, balance_rounding < integral_rounding

class QuadraticStick:
    """Bodies together under quadratic drag: Taylor steps (:mod:`.taylor`) from the anchor, each
    from the state the previous one ended in, until the contact force turns tensile. The steps
    depend only on the anchor, so results do not depend on the communication step; a saved state
    keeps the start of the steps still needed, which a restored segment takes again to the bit."""

    phase = Phase.STICK
    SAMPLING = STEPPED  # its dense output per segment (states_at)
    PUSHES = True

    def __init__(self, context: SegmentContext, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.start = start
        self.together = make_together(context.m, context.c, context.k, context.M, context.drag,
                                      u, inertia_from_net=False,
                                      structure_drag=context.structure_drag)
        self.taylor = _sticking_taylor(self.together)
        self.steps: list[TaylorStep] = []  # from the one holding the current time on
        self.separation: float | None = None
        self.frontier = -math.inf  # the steps reach this far (all times after a separation)
        self._stalled = 0  # steps in a row too short to advance the time
        # A communication step asks for the state at its end twice (state, impulse) and at its
        # start once more (impulse): the last two evaluations are kept.
        self._recent = ((math.nan, _NO_STATE), (math.nan, _NO_STATE))

    def _step_from(self, lo: float, y: tuple[float, float, float]) -> TaylorStep:
        """The Taylor step from lo at state y = (x, v, drag impulse); no separation is looked
        for before ``start`` (a hold), and a contact force already tensile separates at once."""
        hold = lo < self.start
        if not hold and separates(self.together.contact_force(y)):
            return TaylorStep(lo, y)
        try:
            step = self.taylor.step(lo, y, self.start if hold else math.inf, not hold)
        except (ArithmeticError, ValueError) as exc:
            raise SolverError(f"sticking-phase integration failed at t = {self.t0 + lo}: "
                              f"{exc}") from exc
        if step.hi == lo and step.end is not StepEnd.SEPARATION:
            # a step too short to advance the time: one at a sign change of u - v is normal
            # (the next one starts from u - v = 0), more in a row would never end
            self._stalled += 1
            if self._stalled > _MAX_STALLED_STEPS:
                raise SolverError(f"sticking-phase integration stalled at t = {self.t0 + lo}: "
                                  f"{self._stalled} Taylor steps too short to advance the time")
        else:
            self._stalled = 0
        return step

    def _extend_to(self, tau: float) -> None:
        """Steps until the frontier reaches tau or the phase separates: runs of ordinary steps
        in one compiled call (:meth:`StickingTaylor.run`), the others one by one here."""
        while tau > self.frontier:
            if self.steps:
                last = self.steps[-1]
                lo, y = last.hi, last.y_hi
            else:
                lo, y = 0.0, (self.x0, self.v0, 0.0)
            steps = self.taylor.run(lo, y, self.start, tau)
            if steps:
                self.steps += steps
                self.frontier = steps[-1].hi
                self._stalled = 0  # (each advanced the time)
            else:
                self._append(self._step_from(lo, y))

    def _append(self, step: TaylorStep) -> None:
        self.steps.append(step)
        self.frontier = step.hi
        if step.end is StepEnd.SEPARATION:
            self.separation, self.frontier = step.hi, math.inf

    def _y(self, tau: float) -> tuple[float, float, float]:
        (tau_a, y_a), (tau_b, y_b) = self._recent
        if tau == tau_b:
            return y_b
        if tau == tau_a:
            return y_a
        if tau > self.frontier:
            self._extend_to(tau)
        step = self.steps[-1]
        if step.lo > tau:
            for step in reversed(self.steps):  # noqa: B007 (the step holding tau)
                if step.lo <= tau:
                    break
        y = step.state(tau)
        self._recent = ((tau_b, y_b), (tau, y))
        return y

    def state(self, tau: float) -> tuple[float, float, float, float]:
        x, v, _ = self._y(tau)
        # the solver never looks back before its current time: drop steps that end before it
        steps = self.steps
        if len(steps) > 1 and steps[0].hi < tau:  # (their ends increase: a bisection)
            del steps[:min(bisect_left(steps, tau, key=_step_hi), len(steps) - 1)]
        return x, v, x, v

    def states_at(self, tau: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`_y`: rows (x, v, P) at the times tau (s from the anchor,
        increasing, within the steps reached: :meth:`next_event` was asked up to the last one),
        each in the last step starting at or before it, as :meth:`_y` picks it; all evaluated
        at once (:func:`~iceimpact.solvers.search.taylor.states_of_steps`), the same floats as
        :meth:`_y`'s."""
        return states_of_steps(self.steps, tau)

    def impulses_between(self, tau: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`impulse` over the pieces tau[k]..tau[k+1], from the states ``y``
        at tau (rows of :meth:`states_at`)."""
        pieces = self.together.impulse_array(y[:-1].T, y[1:].T)
        return np.where(tau[1:] > tau[:-1], pieces, 0.0)

    def next_event(self, tau_end: float) -> float | None:
        if tau_end > self.frontier:
            self._extend_to(tau_end)
        if self.separation is not None and self.separation <= tau_end:
            return self.separation
        return None

    def impulse(self, tau_a: float, tau_b: float) -> float:
        if tau_b <= tau_a:
            return 0.0
        return self.together.impulse(self._y(tau_a), self._y(tau_b))

    def snapshot(self, tau: float) -> dict[str, Any]:
        # steps ending before tau are never asked for again
        steps = [s for s in self.steps if s.hi >= tau] or self.steps[-1:]
        return {"phase": self.phase.value, "t0": self.t0, "anchor": [self.x0, self.v0],
                "start": self.start, "steps": [[s.lo, list(s.y_lo)] for s in steps]}

    @classmethod
    def read(cls, context: SegmentContext, rec: Record,
             u: float) -> Callable[[], QuadraticStick]:
        """Validate a :meth:`snapshot` record; return the function that builds the segment."""
        rec.expect_keys(("phase", "t0", "anchor", "start", "steps"))
        t0 = rec.real("t0", low=0.0)
        anchor = rec.reals("anchor", 2)
        start = rec.real("start", low=0.0)
        steps: list[tuple[float, tuple[float, ...]]] = []
        for i, item in enumerate(rec.items("steps", _MAX_STEPS)):
            entry = _entry(item, f"{rec.field('steps')}[{i}]", ("lo", "y_lo"))
            lo = entry.real("lo", low=steps[-1][0] if steps else 0.0)
            steps.append((lo, tuple(entry.reals("y_lo", 3))))

        def make() -> QuadraticStick:
            seg = cls(context, t0, *anchor, u, start)
            for lo, y in steps:
                seg._append(seg._step_from(lo, y))
            return seg
        return make


def _sticking_taylor(together: Together) -> StickingTaylor:
    """The Taylor stepper for the sticking equation of ``together`` (its masses, damping,
    stiffness, drag constants on the ice and, with the Morison terms, on the structure, and flow
    speed); steps at most one period of the bodies together."""
    period = 2.0 * math.pi / math.sqrt(together.k / together.total)
    return StickingTaylor(together.total, together.c, together.k, together.drag.B, together.u,
                          together.M, max_step=period, structure_B=together.structure_drag_B)
