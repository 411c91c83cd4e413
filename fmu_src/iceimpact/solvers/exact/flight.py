"""The flight segments of the exact method: both bodies free, each on its closed form
(:class:`Flight`), or the structure under the quadratic Morison drag integrated
(:class:`DraggedFlight`); their gap, its rate and the clearances that prove a stretch of the
flight free of contact."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import SolverError
from ...limits import TIME_RESOLUTION
from ...physics.ice import downstream_speed_bound
from ...physics.structure import (
    UNDER,
    Oscillator,
    under_response,
)
from ...record import Record
from ..base import ACCEL_CLEARANCE_PHASE, GAP_ROUNDING, GAP_ULPS
from ..contact_rules import Phase
from ..search.flight_search import FlightSearch
from ..search.rootfind import RootSearch
from ..search.taylor import StickingTaylor, TaylorStep, states_of_steps
from .segment import STEPPED, _floats, _SearchedSegment

if TYPE_CHECKING:
    from .context import SegmentContext


#: The period search looks no further than omega_n t = this (rad): beyond, one ulp of the phase
#: nears a degree.
DRIFT_PHASE_LIMIT = 2.0 ** 46


def _structure_motion(osc: Any, x0: float, v0: float) -> Callable[[float], tuple[float, float]]:
    """The structure's closed form from the anchor (x0, v0), ``t -> (x - x0, v)``: an
    under-damped Oscillator's from its constants (``osc.increment``'s, two calls fewer), else
    ``osc.increment``."""
    if type(osc) is Oscillator and osc.regime == UNDER:
        return under_response(*osc.under_constants(x0, v0))
    return osc.increment(x0, v0)


class Flight(_SearchedSegment):
    """Both bodies free: structure on its oscillator, ice on its drag law, from one anchor."""

    __slots__ = ("osc", "drag", "t0", "x0", "v0", "z0", "w0", "u", "start", "gap0", "_last",
                 "search", "_x_motion", "_z_motion", "kernel_constants")
    phase = Phase.FLIGHT
    ANCHOR = ("x0", "v0", "z0", "w0")
    #: the search is flight_search's one function (the gap and bounds are this class's closed
    #: forms), compiled where numba is; in pure Python too it takes fewer steps than
    #: RootSearch's methods (False: RootSearch, which the tests compare it with)
    _ONE_FUNCTION = True

    def __init__(self, context: SegmentContext, t0: float, x0: float, v0: float, z0: float,
                 w0: float, u: float, start: float = 0.0):
        # (structure_osc called only with a Morison drag: a flight starts at each impact)
        self.osc = osc = context.structure_osc(u) if context.structure_b else context.osc
        self.drag = drag = context.drag
        # (one store a statement: a multiple assignment of six builds and unpacks a tuple)
        self.t0 = t0
        self.x0 = x0
        self.v0 = v0
        self.z0 = z0
        self.w0 = w0
        self.u = u
        self.start = start
        self.gap0 = x0 - z0
        scale = abs(t0)  # (segment._time_eps, inline: a flight starts at each impact)
        time_eps = TIME_RESOLUTION * (scale if scale > 1.0 else 1.0)
        # the anchor itself: no increments, the anchor's velocities (the search starts there)
        self._last: tuple[float, float, float, float, float] = (0.0, 0.0, v0, 0.0, w0)
        # each body's closed form from the anchor, its constants computed once. The common
        # flight (an Oscillator, not a structure from outside or under the quadratic Morison
        # drag) has its search in one function (flight_search), which
        # evaluates the same closed forms on the same constants.
        # The Python closed forms of such a flight are built only when Python evaluates it
        # (most flights are searched and ended by the compiled function alone).
        if self._ONE_FUNCTION and type(osc) is Oscillator:
            self.kernel_constants = (x0 - z0, x0, z0, *osc.search_constants,
                                     *osc.response_constants(x0, v0),
                                     *drag.flight_constants(w0, u), u, *drag.law_constants,
                                     math.inf, 0)  # (no longest step, no Taylor steps)
            self._x_motion = None
            self.search = FlightSearch(start, time_eps)
        else:
            self._x_motion = _structure_motion(osc, x0, v0)
            self._z_motion = drag.response(*drag.flight_constants(w0, u))
            self.kernel_constants = None
            self.search = RootSearch(start, time_eps)

    # Displacements are evaluated as increments from the anchor, so that the gap near contact
    # (x ~ z, both large) keeps its accuracy instead of the rounding of x and z.
    def anchor(self) -> tuple[float, float, float, float]:
        return self.x0, self.v0, self.z0, self.w0

    def remember(self, state: tuple[float, float, float, float, float]) -> None:
        """Keep ``(tau, x - x0, v, z - z0, w)``, a state found by the compiled search (a root),
        as :meth:`_motion` keeps the last one it evaluates."""
        self._last = state

    def closed_forms(self) -> None:
        """Build the bodies' closed forms of a flight searched by the compiled function, if not
        yet built: Python evaluates its motion (a state between events, a step handed back;
        every evaluation of the motion asks)."""
        if self._x_motion is None:
            self._x_motion = _structure_motion(self.osc, self.x0, self.v0)
            self._z_motion = self.drag.response(*self.drag.flight_constants(self.w0, self.u))

    def _motion(self, tau: float) -> tuple[float, float, float, float, float]:
        """(tau, x - x0, v, z - z0, w) at tau; the last one is kept, since the root search asks
        again for the point it just tested (a probe after a sign test, the state at a root)."""
        last = self._last
        if last[0] == tau:
            return last
        if self._x_motion is None:
            self.closed_forms()
        dx, v = self._x_motion(tau)
        dz, w = self._z_motion(tau)
        self._last = last = (tau, dx, v, dz, w)
        return last

    def state(self, tau: float) -> tuple[float, float, float, float]:
        last = self._last  # (the state at a root: the point the search tested last)
        _, dx, v, dz, w = last if last[0] == tau else self._motion(tau)
        return self.x0 + dx, v, self.z0 + dz, w

    def state_array(self, anchor, tau):
        x0, v0, z0, w0 = anchor
        dx, v = self.osc.displacement_change_array(x0, v0, tau)
        dz, w = self.drag.displacement_change_array(w0, self.u, tau)
        return x0 + dx, v, z0 + dz, w

    def gap(self, tau: float) -> float:
        _, dx, _, dz, _ = self._motion(tau)
        return self.gap0 + (dx - dz)

    def gap_and_rate(self, tau: float) -> tuple[float, float]:
        """Gap and its rate v - w. (Newton's method asks at new points only: the motion is
        evaluated at once, and kept as :meth:`_motion` keeps it.)"""
        if self._x_motion is None:
            self.closed_forms()
        dx, v = self._x_motion(tau)
        dz, w = self._z_motion(tau)
        self._last = (tau, dx, v, dz, w)
        return self.gap0 + (dx - dz), v - w

    # the root search's signal: the gap (a subclass with its own gap names them again)
    value, value_and_rate = gap, gap_and_rate

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        """Gap, its rate and curvature, bounds on |gap''| and |gap'''| for all later times."""
        last = self._last
        if last[0] == tau:  # (at the anchor)
            _, dx, v, dz, w = last
        else:  # (the end of a search step: a new point) as _motion
            if self._x_motion is None:
                self.closed_forms()
            dx, v = self._x_motion(tau)
            dz, w = self._z_motion(tau)
            self._last = (tau, dx, v, dz, w)
        a_x, a_x_max, j_x_max = self.osc.bounds(self.x0 + dx, v)
        a_z, a_z_max, j_z_max = self.drag.accel_bounds(w, self.u)
        return (self.gap0 + (dx - dz), v - w, a_x - a_z, a_x_max + a_z_max, j_x_max + j_z_max)

    def clearance(self, tau: float) -> float:
        """Time from tau (s) during which the gap provably stays open, from the structure's
        envelope: the free structure never goes below ``offset - R``, R its amplitude bound
        (its energy never grows, eq. 8-10), and the ice moves downstream no faster than
        :func:`~iceimpact.physics.ice.downstream_speed_bound`. So the gap stays above
        ``offset - R - z(tau) - speed s`` (beyond the rounding of the positions).

        A stiff structure ringing with a large amplitude while the ice is still outside its
        reach costs the Taylor steps of the root search a few evaluations per period (its bound
        on the gap's curvature is omega_n^2 R); this spans those periods at once.

        A tangent ringing: the ice holding still (no downstream speed) exactly at the lowest
        point of the envelope, ``offset - R - z`` zero to within the rounding of the positions.
        The structure then grazes the ice once a period with no closing speed, and the gap can
        dip below zero by at most twice that rounding, and never by more than GAP_ROUNDING
        (1e-12 m): no impact, and nothing a root search could resolve (it located a touch at
        each period, to its time resolution, and took the structure's speed there, curvature x
        resolution, for a closing speed). The whole future is proven free of impacts.

        The ice's downstream displacement over a time s is also at most ``w s + A s^2 / 2``, A
        its acceleration bound for all later times (|w - u| only decays, eq. 5, 32), which is
        what bounds it when the flow speed u is large but the ice is slow to follow it: a heavy
        ice moving upstream (w < 0 < u) that the flow turns back takes about ``2 |w| / A`` to
        return to where it is, and longer to cross the margin, a time ``margin / u`` would cut
        into pieces far shorter than a period. The stretch is the longer of the two, and the
        tangent ringing above with the ice moving upstream (w < 0) is proven for the time
        ``2 |w| / A`` during which the ice stays upstream of where it is now."""
        offset = self.osc.offset
        if offset is None:  # an extrapolated (external) structure: no envelope, nothing proven
            return 0.0
        last = self._last  # (the search asks right after its probe at tau)
        if last[0] != tau:
            last = self._motion(tau)
        z = self.z0 + last[3]
        if z >= offset:  # the margin below is <= 0 for any reach >= 0 (most calls: ice at contact)
            return 0.0
        _, dx, v, _, w = last
        x = self.x0 + dx
        reach = self.osc.amplitude_bound(x - offset, v)
        lowest = offset - reach - z  # the envelope's lowest gap, now
        rounding = GAP_ULPS * (abs(x) + abs(z) + reach + abs(offset))
        speed = downstream_speed_bound(w, self.u, self.drag.drags)
        margin = lowest - rounding
        if margin <= 0.0:
            if speed == 0.0 or w < 0.0:
                touch = lowest >= -rounding and margin >= -GAP_ROUNDING
                if not touch:
                    return 0.0
                return math.inf if speed == 0.0 else self._accel_clearance(w, 0.0)
            return self._drift_clearance(tau, x - offset, v, w, reach, lowest, speed)
        if speed == 0.0:
            return math.inf
        cleared = margin / speed
        if w < 0.5 * speed:  # the ice is slow to follow the flow: the longer bound may win
            by_accel = self._accel_clearance(w, margin)
            if by_accel > cleared:
                return by_accel
        return cleared

    def _accel_clearance(self, w: float, margin: float) -> float:
        """The time (s) during which the ice's downstream displacement stays within ``margin``
        (m, >= 0) by the bound ``w s + A s^2 / 2`` on it (``clearance``), A the ice's
        acceleration bound for all later times: the positive root of ``A s^2 / 2 + w s =
        margin``, taken 1e-12 short of it (the rounding of the root). 0 (nothing proven) when
        that spans less than ``ACCEL_CLEARANCE_PHASE`` of the structure's phase: the root search
        crosses a few periods in a few steps by itself, and its path (so every impact time of
        an ordinary scene) stays as it was."""
        _, accel_bound, _ = self.drag.accel_bounds(w, self.u)
        if not accel_bound > 0.0:
            root = margin / w if w > 0.0 else math.inf
        else:
            disc = math.sqrt(w * w + 2.0 * accel_bound * margin)
            root = (2.0 * margin / (w + disc) if w > 0.0 else (disc - w) / accel_bound)
            root *= 1.0 - 1e-12
        if root * math.sqrt(self.osc.omega2) < ACCEL_CLEARANCE_PHASE:
            return 0.0
        return root

    def _drift_clearance(self, tau: float, y: float, v: float, w: float, reach: float,
                         lowest: float, speed: float) -> float:
        """Time from tau (s) during which the gap provably stays open, the ice drifting
        downstream at the lowest point of an undamped structure's envelope (``clearance``'s
        margin is gone): the periods whose troughs the ice has not yet reached, found by
        bisection over the periods instead of period by period. 0 where it does not apply.

        Undamped (eq. 9-10 with c = 0), the structure repeats itself exactly every period T,
        x(t + T) = x(t), and the ice never moves upstream (its velocity stays between w and u,
        eq. 5, 32, both >= 0), so g(t + T) = x(t) - z(t + T) <= g(t): no period's lowest gap is
        above the next one's, and if one period's dip stays >= 0, so do all the periods before
        it. Near a trough (x - offset <= -R/2, a sixth of a period either side) the gap is
        convex, ``g'' = -omega^2 (x - offset) - z'' >= omega^2 R / 2 - A = m`` (A the ice's
        acceleration bound), so its one minimum there lies within s = |g'(t_r)| / m of any
        point t_r, and by Taylor's theorem it is at least
        ``g(t_r) - g'(t_r)^2 / (2 g''(t_r)) - G s^3 / 6``, G a bound on |g'''| within s of
        t_r (omega^2 |v| + the ice's jerk bound): the dip, taken one Newton step from the
        trough. G s^3 is then about R (omega dt)^4 for the time dt between representable
        times, 1e-33 m at t = 1 s and omega = 4e7 rad/s, so a dip of 1e-19 m that no
        representable time can show is still seen. Away from the troughs
        x - offset > -R/2, and with the ice's drift over a period below R/8 the gap stays above
        R/4 there. The first period whose dip goes below zero is found by doubling, then
        bisection, from tau's period; the periods before it are root-free, and the stretch ends
        at the crest before it, where the gap is about 2R. There the search takes over and
        locates the impact as anywhere else. Each call evaluates at most 4 log2(periods) + 4
        probes however slowly the ice drifts. A dip within the rounding of the gap (a few ulps of
        the positions) may be taken for a touch
        (docs/explanation/robustness/flights.md#tangent-ringing).

        The doubling stops where omega t reaches ``DRIFT_PHASE_LIMIT`` (beyond, one ulp of the
        phase nears a degree); the search then goes on period by period."""
        osc = self.osc
        u = self.u
        if (osc.sigma != 0.0 or osc.regime != UNDER or not reach > 0.0 or lowest < -0.25 * reach
                or w < 0.0 or (u < 0.0 and self.drag.drags)):
            return 0.0  # damped, deep inside the envelope, or the ice can move upstream
        omega = osc.omega
        period = 2.0 * math.pi / omega
        _, accel_bound, jerk_bound = self.drag.accel_bounds(w, u)
        omega2 = omega * omega
        curvature = omega2 * reach
        if speed * period > 0.125 * reach or accel_bound > 0.25 * curvature:
            return 0.0  # the ice's drift over a period is no small change: nothing to gain
        convexity = 0.5 * curvature - accel_bound  # m above, > 0
        # y = R cos(omega s - phi) from tau: the next trough at omega s = phi + pi
        to_trough = (math.atan2(v / omega, y) + math.pi) / omega  # in [0, T]
        if to_trough > 5.0 * period / 6.0:
            return 0.0  # within a sixth of a period after a trough: the search rises out of it
        probe = self.probe

        def closes(k: int) -> bool:
            """Whether the gap may go below zero at the k-th trough after tau."""
            t_k = tau + (to_trough + k * period)
            g, dg, d2, _, _ = probe(t_k)
            if d2 > 0.0 and abs(dg) <= d2 * period / 12.0:
                t_k -= dg / d2  # a Newton step towards the bottom
                g, dg, d2, _, _ = probe(t_k)
            if not d2 >= convexity:
                return True  # (rounding: nothing proven)
            # the bottom is within s of t_k; on the way |g'''| <= omega^2 |v| + J_z, and
            # |v| <= |v(t_k)| + omega^2 R s
            s = abs(dg) / convexity
            v_k = self._motion(t_k)[2]
            rest = (omega2 * (abs(v_k) + curvature * s) + jerk_bound) * s * s * s / 6.0
            return g - 0.5 * dg * (dg / d2) - rest < 0.0

        if closes(0):
            return 0.0
        lo, stride, hi = 0, 1, None
        while omega * (tau + to_trough + (lo + stride) * period) <= DRIFT_PHASE_LIMIT:
            if closes(lo + stride):
                hi = lo + stride
                break
            lo += stride
            stride *= 2
        if hi is not None:
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if closes(mid):
                    hi = mid
                else:
                    lo = mid
        return to_trough + (lo + 0.5) * period  # to the crest after trough lo

    def impulse(self, tau_a: float, tau_b: float) -> float:
        return 0.0  # no contact force in flight


class DraggedFlight(Flight):
    """Flight with the quadratic Morison drag on the structure (docs/explanation/morison.md), which
    has no
    closed form: the structure's equation ``m x'' + c x' + k x = B_s |u - x'| (u - x')`` is the
    sticking equation of the quadratic drag without the ice, and is integrated by the same
    Taylor steps (:class:`~iceimpact.solvers.search.taylor.StickingTaylor` with no drag on an
    ice and B_s on the structure: order 36, each step's last terms below 1e-16 of its motion,
    at most a natural period long), from the anchor, each from the state the previous one
    ended in, so results do not depend on the communication step and are the same on every
    machine. The ice keeps its closed form. The root search is the same as :class:`Flight`'s:
    its bounds on the gap's second and third derivatives for all later times come from the
    structure's equation of motion (:meth:`DraggedStructure.bounds`, a non-growing energy of
    (v, x'')) and the ice's ``accel_bounds``; the values are the steps' polynomials."""

    FRONTIER_ONLY = False  # its Taylor steps are added while marching
    _ONE_FUNCTION = False  # (its motion is integrated)
    SAMPLING = STEPPED     # its Taylor steps' polynomials at all its samples (states_at)
    clearance = None       # no closed-form envelope of the structure's motion (RootSearch's
                           # signal takes None for "none")
    #: the compiled march handed this flight back (a step it does not make, a step of the
    #: search that is RootSearch's): Python goes on with it
    handed_back = False

    def __init__(self, context: SegmentContext, t0: float, x0: float, v0: float, z0: float,
                 w0: float, u: float, start: float = 0.0):
        structure = self.structure = context.dragged_structure
        self.period = self.natural_period(context)
        self.taylor = StickingTaylor(structure.mass, structure.damping, structure.stiffness,
                                     0.0, u, 0.0, max_step=self.period,
                                     structure_B=structure.drag.B)
        self.steps: list[TaylorStep] = []  # from the one holding the current time on
        self.frontier = -math.inf          # the steps reach this far, s from the anchor
        super().__init__(context, t0, x0, v0, z0, w0, u, start)
        # a search step never asks for the flight more than a step past its frontier
        self.search.max_step = self.period

    @staticmethod
    def natural_period(context: SegmentContext) -> float:
        """The structure's natural period, s: the longest Taylor step."""
        return 2.0 * math.pi / math.sqrt(context.k / context.m)

    def _step_from(self, lo: float, y: tuple[float, float, float]) -> None:
        x, v, _ = y
        where = (f"t = {self.t0 + lo!r} s (structure x = {x!r} m, v = {v!r} m/s, flow u = "
                 f"{self.u!r} m/s)")
        try:
            step = self.taylor.step(lo, y, math.inf, False)
        except (ArithmeticError, ValueError) as exc:
            raise SolverError(f"integration of the structure's flight failed at {where}: "
                              f"{exc}") from exc
        if self.steps and step.hi == lo == self.steps[-1].lo:
            # two steps in a row that do not advance the time (one at a sign change of
            # u - v is normal: the next one starts from u - v = 0)
            raise SolverError(f"integration of the structure's flight stalled at {where}")
        self.steps.append(step)
        self.frontier = step.hi

    def _structure(self, tau: float) -> tuple[float, float]:
        """x - x0 (m) and v (m/s) at tau (s from the anchor)."""
        if tau <= 0.0:
            return 0.0, self.v0
        if not self.steps:
            self._step_from(0.0, (self.x0, self.v0, 0.0))
        while tau > self.frontier:
            last = self.steps[-1]
            self._step_from(last.hi, last.y_hi)
        for step in reversed(self.steps):  # the last step starting at or before tau
            if step.lo <= tau:
                break
        x, v, _ = step.state(tau)
        return x - self.x0, v

    def state(self, tau: float) -> tuple[float, float, float, float]:
        dx, v = self._structure(tau)
        dz, w = self._z_motion(tau)
        # the solver never looks back before its current time: drop steps that end before it
        while len(self.steps) > 1 and self.steps[0].hi < tau:
            self.steps.pop(0)
        return self.x0 + dx, v, self.z0 + dz, w

    def states_at(self, tau: np.ndarray) -> tuple[np.ndarray, ...]:
        """Vectorised :meth:`state` at the times tau (s from the anchor, increasing, up to the
        next event at most): x, v, z, w, the same floats. The structure's Taylor steps up to the
        last time are made as :meth:`_structure` makes them, and evaluated at all the times at
        once (:func:`~iceimpact.solvers.search.taylor.states_of_steps`); the ice's closed form
        is its scalar one at each."""
        x0 = self.x0
        dx, v = np.zeros(tau.size), np.full(tau.size, self.v0)  # (tau <= 0: the anchor)
        later = tau > 0.0
        if later.any():
            times = tau[later]
            self._structure(float(times[-1]))  # (the steps up to it)
            y = states_of_steps(self.steps, times)
            dx[later], v[later] = y[:, 0] - x0, y[:, 1]
        z_motion = self._z_motion
        dz, w = np.array([z_motion(t) for t in tau.tolist()]).reshape(-1, 2).T
        return x0 + dx, v, self.z0 + dz, w

    def gap(self, tau: float) -> float:
        dx, _ = self._structure(tau)
        dz, _ = self._z_motion(tau)
        return self.gap0 + (dx - dz)

    def gap_and_rate(self, tau: float) -> tuple[float, float]:
        dx, v = self._structure(tau)
        dz, w = self._z_motion(tau)
        return self.gap0 + (dx - dz), v - w

    value, value_and_rate = gap, gap_and_rate  # the root search's signal, as Flight's

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        dx, v = self._structure(tau)
        dz, w = self._z_motion(tau)
        a_x, a_x_max, j_x_max = self.structure.bounds(self.x0 + dx, v, self.u)
        a_z, a_z_max, j_z_max = self.drag.accel_bounds(w, self.u)
        return (self.gap0 + (dx - dz), v - w, a_x - a_z, a_x_max + a_z_max, j_x_max + j_z_max)

    def snapshot(self, tau: float) -> dict[str, Any]:
        # The step holding tau is enough: taken again from its start, it and the steps after it
        # come out the same, to the last bit (the solver never looks back before tau)
        step = next((s for s in self.steps if s.hi >= tau), None)
        data = super().snapshot(tau)
        data["integrated"] = (None if step is None
                              else {"lo": step.lo, "y_lo": _floats(step.y_lo[:2])})
        return data

    @classmethod
    def read(cls, context: SegmentContext, rec: Record, u: float) -> Callable[[], Any]:
        """Validate a :meth:`snapshot` record; return the function that builds the segment."""
        rec.expect_keys(cls._SEARCHED_KEYS + ("integrated",))
        flight = Record({k: v for k, v in rec.data.items() if k != "integrated"}, rec.path)
        make_flight = super().read(context, flight, u)
        start = None
        integrated = rec.record("integrated", allow_none=True)
        if integrated is not None:
            integrated.expect_keys(("lo", "y_lo"))
            start = (integrated.real("lo", low=0.0), tuple(integrated.reals("y_lo", 2)))

        def make() -> DraggedFlight:
            seg = make_flight()
            if start is not None:
                seg._step_from(start[0], (*start[1], 0.0))
            return seg
        return make
