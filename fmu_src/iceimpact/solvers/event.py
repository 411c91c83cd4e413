"""Method 1, exact and event-driven: closed-form flights, exact impact times, a sticking phase.

Between events each body follows its closed form (structure: eq. 9-10 and the other damping
regimes, :mod:`iceimpact.physics.structure`; ice: eq. 6-7 or the exact quadratic-drag solution,
:mod:`iceimpact.physics.ice`), anchored at the event that started the segment, so communication
steps never re-base them. Impact times are the first roots of the gap g = x - z, located by
:class:`~iceimpact.solvers.rootfind.RootSearch`, which proves the intervals it skips root-free and
so never misses a grazing touch. Each impact applies eq. 16-17.

The contact rules (impact step, chatter and Zeno closure, degenerate contacts, sticking entry,
contact force, separation, re-anchoring on a flow change) are those of
:mod:`iceimpact.solvers.contact_rules`, with its :data:`EXACT_POLICY`. A Zeno sequence (e < 1,
bodies pressed together) is closed by one plastic impact once the rest of the sequence would take
less than ``ZENO_TIME``; the bodies then stick: linear drag in closed
form (a damped oscillator of mass m + M, damping c + b, equilibrium b u / k, cf. eq. 27-29),
quadratic drag by high-order Taylor steps (:mod:`iceimpact.solvers.taylor`: while the sign of
u - x' holds the right-hand side is a polynomial, so the series follow by recurrence; each step
from the state the previous one ended in, none ahead of the time asked for). They separate when
the contact force would turn tensile.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Callable
from operator import attrgetter
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..errors import SolverError, StateError
from ..limits import TIME_RESOLUTION
from ..physics.ice import downstream_speed_bound, linear_response, make_drag
from ..physics.structure import (
    UNDER,
    DraggedStructure,
    Oscillator,
    morison_oscillator,
    under_response,
)
from ..record import Record
from ..scene import Scene
from .base import GAP_ROUNDING, Solver, State
from .contact_rules import (
    EXACT_POLICY,
    ROUNDING_SPEED,
    ContactRules,
    Outcome,
    Phase,
    Together,
    make_together,
    reanchor_on_flow_change,
    separates,
    sticking_contact_force,
)
from .flight_search import COMPILED, FlightSearch
from .rootfind import RootSearch
from .taylor import StepEnd, StickingTaylor, TaylorStep

_NO_STATE = (math.nan, math.nan, math.nan)
#: Enum members as module constants (an enum class's attribute is looked up through its
#: metaclass, about 20 times the cost of a global; these are asked at every event).
_FLIGHT = Phase.FLIGHT
_IMPACT, _STICK_OUTCOME = Outcome.IMPACT, Outcome.STICK
#: Taylor steps in a row that do not advance the time before a sticking phase is given up.
_MAX_STALLED_STEPS = 4

#: Rounding of a gap evaluated from positions of magnitude X is below GAP_ULPS * X (m).
GAP_ULPS = 16.0 * 2.0 ** -52

#: The period search looks no further than omega_n t = this (rad): beyond, one ulp of the phase
#: nears a degree.
DRIFT_PHASE_LIMIT = 2.0 ** 46

#: The ice's acceleration bound proves a stretch of the flight open (Flight.clearance) only when
#: it spans at least this much of the structure's phase omega_n t (rad), 256 periods.
ACCEL_CLEARANCE_PHASE = 512.0 * math.pi

#: At most this many Taylor steps of a quadratic-drag sticking phase are saved in a snapshot
#: (those the future can ask for: one, or two at a step boundary).
_MAX_STEPS = 8


def _time_eps(t: float) -> float:
    scale = abs(t)
    return TIME_RESOLUTION * (scale if scale > 1.0 else 1.0)  # max(1.0, |t|)


class _SearchedSegment:
    """Snapshot of a segment given in closed form from its anchor, with a root search: the
    anchor values named by ``ANCHOR``, the search start and its frontier (Flight, LinearStick).

    Its ``anchor``, ``state_array``, ``impulse_array`` and ``PUSHES`` let
    :meth:`EventSolver.sample` evaluate all the samples in segments of one kind at once; any
    segment kind that gives them joins that vectorised pass (a segment of Taylor steps gives
    ``states_at`` and ``impulses_between`` instead, evaluated per segment), the others are
    sampled step by step."""

    __slots__ = ()
    ANCHOR: tuple[str, ...] = ()
    #: a contact force acts during the segment (its impulse is not zero)
    PUSHES = False
    #: marching changes nothing in the segment but its search frontier, so a checkpoint of the
    #: frontier undoes a step (:meth:`EventSolver.checkpoint`)
    FRONTIER_ONLY = True

    def anchor(self) -> tuple[float, ...]:
        return tuple(getattr(self, name) for name in self.ANCHOR)

    def next_event(self, tau_end: float) -> float | None:
        """The segment's event if at or before tau_end: the first root of its ``value`` (a
        flight's gap, its impact; a sticking phase's contact force, its separation). The
        segment is its root search's signal (:class:`~iceimpact.solvers.rootfind.Signal`);
        :meth:`EventSolver.sample` calls the search directly, as here."""
        return self.search.next_root_of(tau_end, self)

    def state_array(self, anchor: tuple[np.ndarray, ...],
                    tau: np.ndarray) -> tuple[np.ndarray, ...]:
        """Vectorised :meth:`state` for segments of this kind with the same parameters and flow
        speed as this one: one anchor (arrays, ``ANCHOR`` order) and tau per sample."""
        raise NotImplementedError

    def impulse_array(self, anchor: tuple[np.ndarray, ...], tau_a: np.ndarray,
                      tau_b: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`impulse`, as :meth:`state_array`."""
        return np.zeros(np.shape(tau_a))
    _SEARCHED_KEYS = ("phase", "t0", "anchor", "start", "search")

    def snapshot(self, tau: float) -> dict[str, Any]:
        return {"phase": self.phase.value, "t0": self.t0,
                "anchor": list(self.anchor()), "start": self.start,
                "search": self.search.frontier()}

    @classmethod
    def read(cls, solver: EventSolver, rec: Record, u: float) -> Callable[[], Any]:
        """Validate a :meth:`snapshot` record; return the function that builds the segment."""
        rec.expect_keys(cls._SEARCHED_KEYS)
        t0 = rec.real("t0", low=0.0)
        anchor = rec.reals("anchor", len(cls.ANCHOR))
        start = rec.real("start", low=0.0)
        frontier = RootSearch.read_frontier(rec.record("search"), start)

        def make() -> Any:
            seg = cls(solver, t0, *anchor, u, start)
            seg.search.set_frontier(frontier)
            return seg
        return make


class Flight(_SearchedSegment):
    """Both bodies free: structure on its oscillator, ice on its drag law, from one anchor."""

    __slots__ = ("osc", "drag", "t0", "x0", "v0", "z0", "w0", "u", "start", "gap0", "_last",
                 "search", "_x_motion", "_z_motion", "closed_form_constants")
    phase = Phase.FLIGHT
    ANCHOR = ("x0", "v0", "z0", "w0")
    #: the search may be flight_search's (the gap and bounds are this class's closed forms);
    #: it is where numba compiled it
    _ONE_FUNCTION = COMPILED is not None

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, z0: float,
                 w0: float, u: float, start: float = 0.0):
        # (structure_osc called only with a Morison drag: a flight starts at each impact)
        self.osc = osc = solver.structure_osc(u) if solver.structure_b else solver.osc
        self.drag = drag = solver.drag
        # (one store a statement: a multiple assignment of six builds and unpacks a tuple)
        self.t0 = t0
        self.x0 = x0
        self.v0 = v0
        self.z0 = z0
        self.w0 = w0
        self.u = u
        self.start = start
        self.gap0 = x0 - z0
        # the anchor itself: no increments, the anchor's velocities (the search starts there)
        self._last: tuple[float, float, float, float, float] = (0.0, 0.0, v0, 0.0, w0)
        # each body's closed form from the anchor, its constants computed once. The common
        # flight (an under-damped Oscillator, not a structure from outside or under the
        # quadratic Morison drag, and the linear drag) has its search in one function
        # (flight_search), which evaluates the same closed forms on the same constants.
        if (self._ONE_FUNCTION and type(osc) is Oscillator and osc.regime == UNDER
                and not drag.quadratic):
            x_constants = osc.under_constants(x0, v0)
            z_constants = drag.flight_constants(w0, u)
            self._x_motion = under_response(*x_constants)
            self._z_motion = linear_response(*z_constants)
            self.closed_form_constants = x_constants + z_constants
            self.search = FlightSearch(start, _time_eps(t0))
        else:
            self._x_motion = osc.increment(x0, v0)
            self._z_motion = drag.increment(w0, u)
            self.search = RootSearch(start, _time_eps(t0))

    # Displacements are evaluated as increments from the anchor, so that the gap near contact
    # (x ~ z, both large) keeps its accuracy instead of the rounding of x and z.
    def anchor(self) -> tuple[float, float, float, float]:
        return self.x0, self.v0, self.z0, self.w0

    def remember(self, state: tuple[float, float, float, float, float]) -> None:
        """Keep ``(tau, x - x0, v, z - z0, w)``, a state found by the compiled search (a root),
        as :meth:`_motion` keeps the last one it evaluates."""
        self._last = state

    def _motion(self, tau: float) -> tuple[float, float, float, float, float]:
        """(tau, x - x0, v, z - z0, w) at tau; the last one is kept, since the root search asks
        again for the point it just tested (a probe after a sign test, the state at a root)."""
        last = self._last
        if last[0] == tau:
            return last
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
        the positions) may be taken for a touch, as fix 13's holding-still ice is.

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


#: Tolerances of the integration of the structure's flight under the quadratic Morison drag.
DRAGGED_RTOL = 1e-12
DRAGGED_ATOL = (1e-15, 1e-15)  # x - x0 (m), v (m/s)


class _FlightChunk:
    """One solve_ivp call of an integrated flight: from ``lo`` (state ``y_lo``) to ``hi`` =
    ``lo + length``, its dense output ``sol``."""

    __slots__ = ("lo", "hi", "y_lo", "sol", "length")

    def __init__(self, lo: float, hi: float, y_lo: np.ndarray, sol: object | None,
                 length: float):
        self.lo, self.hi, self.y_lo, self.sol, self.length = lo, hi, y_lo, sol, length


class DraggedFlight(Flight):
    """Flight with the quadratic Morison drag on the structure (docs/morison.md), which has no
    closed form: the structure's increment ``[x - x0, v]`` is integrated with DOP853 (rtol 1e-12)
    in chunks fixed from the anchor (so results do not depend on the communication step): the
    first 1/128 of the longest, each one twice the previous, up to 2 periods (0.05 to 5 s), so
    that the short bounces of a chatter integrate little beyond their end. The ice keeps its
    closed form. The root search is the same as :class:`Flight`'s: its
    bounds on the gap's second and third derivatives for all later times come from the
    structure's equation of motion (:meth:`DraggedStructure.bounds`, a non-growing energy of
    (v, x'')) and the ice's ``accel_bounds``; the values are the dense output's, so no root is
    skipped beyond the integration's accuracy."""

    FRONTIER_ONLY = False  # its integration chunks change while marching
    _ONE_FUNCTION = False  # (its motion is integrated)
    state_array = None     # no closed form: sampled point by point
    clearance = None       # no closed-form envelope of the structure's motion

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, z0: float,
                 w0: float, u: float, start: float = 0.0):
        self.structure = solver.dragged_structure
        self.chunk = self.longest_chunk(solver)
        self.hi = 0.0                       # integrated up to here, s from the anchor
        self.y_hi = np.array([0.0, v0])
        self.next_length = self.chunk / 128.0  # of the chunk from hi, s
        self.chunks: list[_FlightChunk] = []
        super().__init__(solver, t0, x0, v0, z0, w0, u, start)
        # a search step never asks for the flight more than a chunk past its frontier
        self.search.max_step = self.chunk

    @staticmethod
    def longest_chunk(solver: EventSolver) -> float:
        """Longest integration chunk, s: 2 natural periods, 0.05 to 5 s."""
        period = 2.0 * math.pi / math.sqrt(solver.k / solver.m)
        return min(max(0.05, 2.0 * period), 5.0)

    def _rhs(self, tau: float, y: np.ndarray) -> list[float]:
        return [y[1], self.structure.acceleration(self.x0 + y[0], y[1], self.u)]

    def _integrate(self, lo: float, hi: float, y_lo: np.ndarray):
        res = solve_ivp(self._rhs, (lo, hi), y_lo, method="DOP853",
                        rtol=DRAGGED_RTOL, atol=DRAGGED_ATOL, dense_output=True)
        if not res.success:
            raise SolverError(f"integration of the structure's flight failed at t = "
                              f"{self.t0 + lo}: {res.message}")
        return res

    def _structure(self, tau: float) -> tuple[float, float]:
        """x - x0 (m) and v (m/s) at tau (s from the anchor)."""
        while tau > self.hi or (not self.chunks and tau > 0.0):  # (restored: none yet)
            hi = self.hi + self.next_length
            res = self._integrate(self.hi, hi, self.y_hi)
            self.chunks.append(_FlightChunk(self.hi, hi, self.y_hi, res.sol, self.next_length))
            self.hi, self.y_hi = hi, res.y[:, -1]
            self.next_length = min(2.0 * self.next_length, self.chunk)
        if tau <= 0.0:
            return 0.0, self.v0
        for chunk in reversed(self.chunks):
            if chunk.lo <= tau <= chunk.hi:
                if chunk.sol is None:  # restored from a snapshot: the same call, the same output
                    chunk.sol = self._integrate(chunk.lo, chunk.hi, chunk.y_lo).sol
                y = chunk.sol(tau)
                return float(y[0]), float(y[1])
        raise SolverError(f"the structure's flight is not integrated at t = {self.t0 + tau}")

    def state(self, tau: float) -> tuple[float, float, float, float]:
        dx, v = self._structure(tau)
        dz, w = self._z_motion(tau)
        # the solver never looks back before its current time: drop chunks that end before it
        while len(self.chunks) > 1 and self.chunks[0].hi < tau:
            self.chunks.pop(0)
        return self.x0 + dx, v, self.z0 + dz, w

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
        # The chunk holding tau is enough: integrated again from its start, it and the chunks
        # after it come out the same, to the last bit (the solver never looks back before tau).
        # (lengths: the chunk's own, then doubling as before)
        chunk = next((c for c in self.chunks if c.hi >= tau), None)
        if chunk is None:
            lo, y_lo, length = self.hi, self.y_hi, self.next_length
        else:
            lo, y_lo, length = chunk.lo, chunk.y_lo, chunk.length
        data = super().snapshot(tau)
        data["integrated"] = {"lo": lo, "y_lo": _floats(y_lo), "length": length}
        return data

    @classmethod
    def read(cls, solver: EventSolver, rec: Record, u: float) -> Callable[[], Any]:
        """Validate a :meth:`snapshot` record; return the function that builds the segment."""
        rec.expect_keys(cls._SEARCHED_KEYS + ("integrated",))
        flight = Record({k: v for k, v in rec.data.items() if k != "integrated"}, rec.path)
        make_flight = super().read(solver, flight, u)
        integrated = rec.record("integrated")
        integrated.expect_keys(("lo", "y_lo", "length"))
        lo = integrated.real("lo", low=0.0)
        y_lo = integrated.reals("y_lo", 2)
        longest = cls.longest_chunk(solver)
        length = integrated.real("length", low=0.0, high=longest)
        if length <= 0.0:
            raise StateError(integrated.field("length"), length, f"in (0, {longest!r}] s")

        def make() -> DraggedFlight:
            seg = make_flight()
            seg.hi, seg.y_hi, seg.next_length, seg.chunks = lo, np.array(y_lo), length, []
            return seg
        return make


class LinearStick(_SearchedSegment):
    """Bodies together under linear drag: closed form (mass m+M, damping c+b, offset b u / k;
    with the Morison terms on the structure, m is m + m_a and b_s adds to b: docs/morison.md).

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

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.M = solver.M
        self.drag = solver.drag
        self.b = b = solver.drag.b
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.start = start
        b_s = solver.structure_b  # linearised drag on the structure (0 when off)
        self.osc = osc = Oscillator(solver.m + solver.M, solver.c + b + b_s, solver.k,
                                    offset=(b + b_s) * u / solver.k)
        self._increment = osc.increment(x0, v0)
        self._c = solver.c
        self._b_all = b + b_s
        self._lam0, self._q0, rate0 = self._anchor_force(x0, v0)
        self._q_increment = osc.deviation_increment(self._q0, rate0)
        self._push = b * u
        self._mu = solver.m * solver.M / (solver.m + solver.M)  # reduced mass, kg
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
        part the bodies resolvably, so that they are held together through it (fix 28).

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
        scale (m + M) |u|.

        Fix 14's stiff pair (omega0 3.9e7 rad/s, b u = 2.1e4 N) rang 23 N beyond b u: a
        tension of 2.4e-9 s a period (s = 3e-11 m/s against 6.5e-9 m/s, a gap of ~2e-19 m);
        the exact motion parted and re-contacted once a period, and the step never ended."""
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

    # the root search's signal (:class:`~iceimpact.solvers.rootfind.Signal`): the contact force
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
                np.exp, np.expm1)
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
          (q0, q0')). Far from the equilibrium (fix 21), b (dx - u dt) is a difference of
          displacements whose rounding (b ulp(dx), 5e-15 N.s for 1e-4 m under b = 4e5 kg/s)
          exceeds an impulse of 1e-11 N over 1 ms; this form has none. But lam0 is the
          anchor's force, and its rounding stays while the motion decays: a 29 mg pair sticking
          from 0.24 m on k = 5.6e8 N/m (no flow) was at rest by t = 0.03 s, where a 0.01 s
          step's impulse came out as +-2.3e-10 N.s, one ulp of lam0 dt = 1.5e6 N.s, alternately
          tensile; an over-damped pair (zeta 50) decaying at 1e-14 m/s gave steps of 3e-14,
          1.4e-13 and -8.3e-14 N.s for a true 6e-20.
        - balance: the step's momentum balance on its own modes, the drag impulse on the ice
          ``b (u dt - dy)`` minus its momentum change ``M dy'``, with dy = d1 + d2 and
          dy' = s1 d1 + s2 d2 the changes of the two modes over the step
          (:meth:`Oscillator.mode_steps`, from the modes of the anchor's deviation):
          ``b u dt - (b + M s1) d1 - (b + M s2) d2``, whose rounding decays with the motion
          (b |u| dt aside, large where the equilibrium is far). From the displacement
          increments of the anchor instead, dy_b - dy_a carries the rounding of the anchor's
          scale: the zeta 50 pair's steps were 6e-20 N.s, or -3e-23."""
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

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.start = start
        self.together = make_together(solver.m, solver.c, solver.k, solver.M, solver.drag, u,
                                      inertia_from_net=False,
                                      structure_drag=solver.structure_drag)
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
        if not (all(map(math.isfinite, step.y_hi)) and step.hi >= lo):
            raise SolverError(f"sticking-phase integration failed at t = {self.t0 + lo}: "
                              f"state {step.y_hi!r} at t = {self.t0 + step.hi}")
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

    def _extend(self) -> None:
        if self.steps:
            last = self.steps[-1]
            step = self._step_from(last.hi, last.y_hi)
        else:
            step = self._step_from(0.0, (self.x0, self.v0, 0.0))
        self._append(step)

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
        while tau > self.frontier:
            self._extend()
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
        if len(steps) > 1 and steps[0].hi < tau:
            drop = 1
            while drop < len(steps) - 1 and steps[drop].hi < tau:
                drop += 1
            del steps[:drop]
        return x, v, x, v

    def states_at(self, tau: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`_y`: rows (x, v, P) at the times tau (s from the anchor,
        increasing, within the steps reached: :meth:`next_event` was asked up to the last one),
        each in the last step starting at or before it, as :meth:`_y` picks it; the samples in
        one step are evaluated at once (:meth:`TaylorStep.states`), equal to :meth:`_y` to
        rounding."""
        steps = self.steps
        index = np.searchsorted([s.lo for s in steps], tau, side="right") - 1
        np.maximum(index, 0, out=index)  # none before the first step kept (as _y)
        out = np.empty((tau.size, 3))
        bounds = [0, *(np.flatnonzero(np.diff(index)) + 1).tolist(), tau.size]
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            out[a:b] = steps[index[a]].states(tau[a:b])
        return out

    def impulses_between(self, tau: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`impulse` over the pieces tau[k]..tau[k+1], from the states ``y``
        at tau (rows of :meth:`states_at`)."""
        pieces = self.together.impulse_array(y[:-1].T, y[1:].T)
        return np.where(tau[1:] > tau[:-1], pieces, 0.0)

    def next_event(self, tau_end: float) -> float | None:
        while tau_end > self.frontier:
            self._extend()
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
    def read(cls, solver: EventSolver, rec: Record, u: float) -> Callable[[], QuadraticStick]:
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
            seg = cls(solver, t0, *anchor, u, start)
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


def _floats(y) -> list[float]:
    return [float(c) for c in y]


def _entry(item: Any, field: str, names: tuple[str, ...]) -> Record:
    """A list entry [a, b, ...] of a snapshot as a record with the given field names."""
    if not isinstance(item, list | tuple) or len(item) != len(names):
        raise StateError(field, item, "[" + ", ".join(names) + "]")
    return Record(dict(zip(names, item, strict=True)), field)


def _first_sample_after(times: list[float], i: int, t0: float, tau_event: float) -> int:
    """The first index j >= i with ``times[j] - t0 >= tau_event``: the first sample a march
    reaches after the event (the test advance_to makes; it holds from its first j on, since
    times increase and rounding is monotone). Most events are a few samples apart: the first
    ones are tested in turn, then a bisection on the absolute times and a check of the exact
    test around it."""
    n = len(times)
    j = i
    stop = i + 8
    if stop > n:
        stop = n
    while j < stop:
        if times[j] - t0 >= tau_event:
            return j
        j += 1
    if j == n:
        return n
    j = bisect_left(times, t0 + tau_event, j, n)
    while j > i and times[j - 1] - t0 >= tau_event:
        j -= 1
    while j < n and times[j] - t0 < tau_event:
        j += 1
    return j


#: How :meth:`EventSolver.sample` evaluates a kind of segment (or by a _SampleGroup).
_STEPPED, _MARCHED = "stepped", "marched"


def _sampling_kind(seg: Any) -> Any:
    """_STEPPED for segments of Taylor steps (dense output per segment), a new _SampleGroup
    for those with array closed forms (all their samples at once), else _MARCHED (stepped to
    each sample)."""
    if hasattr(seg, "states_at"):
        return _STEPPED
    if getattr(seg, "state_array", None) is not None:
        return _SampleGroup(seg)
    return _MARCHED


class Samples:
    """States (m, m/s), contact impulses (N.s) and sticking flags at a run's sample times."""

    __slots__ = ("x", "v", "z", "w", "impulse", "sticking")

    def __init__(self, n: int):
        self.x, self.v, self.z, self.w = (np.empty(n) for _ in range(4))
        self.impulse = np.zeros(n)
        self.sticking = np.zeros(n, dtype=bool)

    def set(self, i: int, state: State, sticking: bool) -> None:
        self.x[i], self.v[i], self.z[i], self.w[i] = state.x, state.v, state.z, state.w
        self.sticking[i] = sticking


class _SampleGroup:
    """The samples falling in segments of one kind (Flight or LinearStick), gathered during a
    sampled march and evaluated at once by the representative segment's array closed forms."""

    def __init__(self, representative: _SearchedSegment):
        self.rep = representative
        # per segment its anchor's values, flat (floats: no tuple per segment for the cyclic
        # garbage collector to track)
        self.anchors: list[float] = []
        self.t0: list[float] = []
        self.first: list[int] = []                  # its samples: first..stop-1
        self.stop: list[int] = []
        # force-carrying pieces, one run per segment: anchor index, tau_from, samples i..j-1,
        # tau_event (nan: none), position of the first piece in the impulse values
        self.pieces: list[tuple[int, float, int, int, float, int]] = []
        # the anchor's values of a segment of this kind (the ANCHOR fields, read at once), and
        # the lists' appends, bound once (add runs for most segments of a sampled run)
        self._anchor_of = attrgetter(*representative.ANCHOR)
        self._add_anchor, self._add_t0 = self.anchors.extend, self.t0.append
        self._add_first, self._add_stop = self.first.append, self.stop.append
        self._pushes = representative.PUSHES

    def add(self, seg: _SearchedSegment, tau_from: float, i: int, j: int,
            tau_event: float | None, targets: list[int], values: list[float]) -> None:
        """Samples i..j-1 in ``seg`` (from ``tau_from``); its event, if any, before sample j.

        A segment with a contact force adds one impulse piece per sample (from the previous
        sample, or ``tau_from``, to it) and one to its event, in the order the scalar march adds
        them; their values are filled in by :meth:`evaluate`."""
        self._add_anchor(self._anchor_of(seg))
        self._add_t0(seg.t0)
        self._add_first(i)
        self._add_stop(j)
        if not self._pushes:
            return
        k = len(self.t0) - 1
        self.pieces.append((k, tau_from, i, j, math.nan if tau_event is None else tau_event,
                            len(values)))
        targets.extend(range(i, j))
        values.extend([0.0] * (j - i))
        if tau_event is not None:
            targets.append(j)
            values.append(0.0)

    def evaluate(self, times: np.ndarray, out: Samples, values: np.ndarray) -> None:
        first = np.array(self.first, dtype=int)
        counts = np.array(self.stop, dtype=int) - first
        rows = np.repeat(np.arange(len(counts)), counts)
        # sample indices: each segment's run first..stop-1, concatenated
        index = np.arange(len(rows)) + np.repeat(first - (np.cumsum(counts) - counts), counts)
        width = len(self.rep.ANCHOR)
        anchors = np.array(self.anchors, dtype=float).reshape(len(self.t0), width)
        t0 = np.array(self.t0)
        tau = times[index] - t0[rows]
        x, v, z, w = self.rep.state_array(tuple(anchors[rows].T), tau)
        out.x[index], out.v[index], out.z[index], out.w[index] = x, v, z, w
        out.sticking[index] = self.rep.phase is Phase.STICK
        if self.pieces:
            k, tau_from, i, j, tau_event, position = (np.array(c) for c in
                                                       zip(*self.pieces, strict=True))
            n_samples = j - i
            n_pieces = n_samples + ~np.isnan(tau_event)
            run = np.repeat(np.arange(len(k)), n_pieces)  # the run of each piece
            o = np.arange(len(run)) - np.repeat(np.cumsum(n_pieces) - n_pieces, n_pieces)
            m = i[run] + o  # its sample (its end), or j for the piece to the event
            seg_t0 = t0[k[run]]
            # as the march: each piece from the previous sample (or tau_from) to its sample
            # (or the event), the times from the anchor as times[m] - t0
            tau_b = np.where(o < n_samples[run], times[np.minimum(m, len(times) - 1)] - seg_t0,
                             tau_event[run])
            tau_a = np.where(o == 0, tau_from[run], times[np.maximum(m - 1, 0)] - seg_t0)
            values[position[run] + o] = self.rep.impulse_array(tuple(anchors[k[run]].T),
                                                               tau_a, tau_b)


class EventSolver(Solver):
    """Exact event-driven solver (method 1)."""

    name = "exact"

    # no Morison drag on the structure unless __init__ finds it (subclasses with their own
    # structure, such as the external one, keep these)
    structure_b = 0.0
    dragged_structure: DraggedStructure | None = None
    _flight_cls: type[Flight] = Flight
    _osc_by_flow: tuple[float, Oscillator] | None = None

    def __init__(self, scene: Scene, record_impacts: bool = True):
        super().__init__(scene, record_impacts)
        self.osc = Oscillator(self.m, self.c, self.k)
        self.drag = make_drag(scene)
        # Morison drag on the structure (docs/morison.md): linearised, a damping b_s and an offset
        # b_s u / k of the closed form (structure_osc); quadratic, an integrated flight
        # (DraggedFlight). Off: b_s = 0 and the flight is today's closed form.
        drag_s = self.structure_drag
        self.structure_b = drag_s.b if drag_s is not None and not drag_s.quadratic else 0.0
        self.dragged_structure = (DraggedStructure(self.m, self.c, self.k, drag_s)
                                  if drag_s is not None and drag_s.quadratic else None)
        self._flight_cls = Flight if self.dragged_structure is None else DraggedFlight
        self._osc_by_flow: tuple[float, Oscillator] | None = None
        self.rules = ContactRules(self.m, self.M, scene.omega_n, self._free_accels, EXACT_POLICY)
        self.u = scene.flow_u
        self.tau = 0.0  # position within the current segment
        self.pending_impulse = 0.0
        s = self.state
        self.seg = None
        self._begin(0.0, s.x, s.v, s.z, s.w, self.u)  # an impact at t = 0 goes to the 1st step

    # segment construction -----------------------------------------------------------------------
    def structure_osc(self, u: float) -> Oscillator:
        """The structure's closed form in a flow of speed u: the oscillator of m, c, k, with the
        linearised Morison drag's damping and offset when it is on (the last one is kept)."""
        if not self.structure_b:
            return self.osc
        if self._osc_by_flow is None or self._osc_by_flow[0] != u:
            self._osc_by_flow = (u, morison_oscillator(self.m, self.c, self.k,
                                                       self.structure_b, u))
        return self._osc_by_flow[1]

    def _structure_bounds(self, x: float, v: float, u: float) -> tuple[float, float, float]:
        """The structure's acceleration and bounds on |x''| and |x'''| for all later times."""
        if self.dragged_structure is not None:
            return self.dragged_structure.bounds(x, v, u)
        return self.structure_osc(u).bounds(x, v)

    def _free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        if self.dragged_structure is not None:
            a_x = self.dragged_structure.acceleration(x, v, u)
        else:
            # (structure_osc called only with a Morison drag: this runs at every impact)
            osc = self.structure_osc(u) if self.structure_b else self.osc
            a_x = osc.acceleration(x, v)
        return a_x, self.drag.accel_bounds(w, u)[0]

    def _begin(self, t: float, x: float, v: float, z: float, w: float, u: float,
               reanchor: bool = False, after_impact: bool = False) -> None:
        """Start the segment that follows time t from state (x, v, z, w) (``reanchor``: after a
        change of the flow speed; ``after_impact``: the velocities after an impact; neither is
        a contact re-forming, see :meth:`ContactRules.at_contact`)."""
        self.u = u
        self.tau = 0.0
        if x - z > 0.0:
            self._fly(t, x, v, z, w, u)
            return
        decision = self.rules.at_contact(t, x, v, w, u, reanchor or after_impact)
        outcome = decision.outcome
        if outcome is _IMPACT:
            self._impact(t, x, decision.v, decision.w, u)
        elif outcome is _STICK_OUTCOME:
            self._stick(t, x, decision.v, u, hold=decision.hold)
        else:
            self._fly_from_contact(t, x, decision.v, decision.w, u, decision.lam)

    def _fly(self, t, x, v, z, w, u, start: float = 0.0) -> None:
        self.seg = self._flight_cls(self, t, x, v, z, w, u, start)
        if self.sticking:  # (apart already: nothing to change)
            self._set_sticking(False, t)

    def _fly_from_contact(self, t: float, x: float, v: float, w: float, u: float,
                          lam: float) -> None:
        """Flight starting at zero gap with separating (or zero) relative velocity.

        With an opening speed s > 0 the search starts at 0, where g = 0 and g' = s > 0 are no
        root, and its first stretch proves ``g >= s h - K h^2/2 > 0`` beyond. With s = 0 it
        starts beyond the trivial root at 0, at the end of an interval proven root-free,
        ``g >= g2 h^2/2 - J h^3/6`` (gap curvature g2 = -lam / mu > 0, J a bound on |g'''|).
        """
        opening = v - w
        if opening > 0.0:
            # the search's first stretch from 0 proves the opening: g(0) = 0, g'(0) = s > 0
            self._fly(t, x, v, x, w, u, 0.0)
            return
        a_x, _, j_x_max = self._structure_bounds(x, v, u)
        a_z, _, j_z_max = self.drag.accel_bounds(w, u)
        curvature = a_x - a_z
        jerk_bound = j_x_max + j_z_max
        start = 0.0
        if curvature > 0.0 and jerk_bound > 0.0:
            start = 2.0 * curvature / jerk_bound
        self._fly(t, x, v, x, w, u, start)

    def _stick(self, t: float, x: float, v: float, u: float, hold: float = 0.0) -> None:
        """Bodies together from time t; separation is not looked for before ``t + hold``."""
        cls = QuadraticStick if self.drag.quadratic else LinearStick
        self.seg = cls(self, t, x, v, u, start=hold)
        self._set_sticking(True, t)

    def _impact(self, t: float, x: float, v_minus: float, w_minus: float, u: float) -> None:
        """The impact step (eq. 16-18, chatter and Zeno closure) at time t; what follows."""
        impact = self.rules.impact(t, x, v_minus, w_minus, self.e, u)
        self._record(impact)
        self.pending_impulse += impact.impulse
        self._begin(t, x, impact.v_plus, x, impact.w_plus, u, after_impact=True)

    def _flight_end(self, t: float, x: float, v: float, w: float, u: float) -> None:
        """A flight's gap closing at time t, position x: :meth:`_begin` at zero gap, with the
        common case, an impact after which the bodies part (a bounce), decided in one call
        (:meth:`ContactRules.impact_at_contact`: the same decisions, the same flight)."""
        impact, parts = self.rules.impact_at_contact(t, x, v, w, self.e, u)
        if impact is None:
            self._begin(t, x, v, x, w, u)
            return
        self._record(impact)
        self.pending_impulse += impact.impulse
        if parts:  # at_contact's FLIGHT with an opening speed: the search from 0
            self.u = u
            self.tau = 0.0
            # _fly, from a flight (so not sticking: a flight and the sticking flag never
            # coexist, as _read checks of a snapshot)
            self.seg = self._flight_cls(self, t, x, impact.v_plus, x, impact.w_plus, u, 0.0)
        else:
            self._begin(t, x, impact.v_plus, x, impact.w_plus, u, after_impact=True)

    # marching -----------------------------------------------------------------------------------
    def advance_to(self, t_end: float, u: float) -> float:
        if u != self.u:  # zero-order hold: a new flow speed re-anchors the closed forms here
            x, v, z, w = reanchor_on_flow_change(*self.seg.state(self.tau),
                                                 self.seg.phase is Phase.STICK)
            self._begin(self.state.t, x, v, z, w, u, reanchor=True)
        return self._march(t_end, u)

    def _march(self, t_end: float, u: float) -> float:
        """Run the segments from the current one to ``t_end``; the impulse on the structure."""
        impulse = self.pending_impulse
        self.pending_impulse = 0.0
        while True:
            seg = self.seg
            tau_end = t_end - seg.t0
            tau_event = seg.next_event(tau_end)
            if tau_event is None:
                impulse += seg.impulse(self.tau, tau_end)
                self.tau = tau_end
                break
            impulse += seg.impulse(self.tau, tau_event)
            impulse += self._event(seg, tau_event, u)
        x, v, z, w = self.seg.state(self.tau)
        self.state = State(t_end, x, v, z, w)
        return impulse

    def _event(self, seg, tau_event: float, u: float) -> float:
        """The event ending ``seg`` at ``tau_event``: the segments that follow; the impulse of
        its impacts."""
        x, v, z, w = seg.state(tau_event)
        t_event = seg.t0 + tau_event
        if seg.phase is _FLIGHT:
            self._flight_end(t_event, x, v, w, u)  # impact, or a touch without speed
        else:  # contact force turns tensile: separate with equal velocities
            self._fly_from_contact(t_event, x, v, v, u, self.rules.free_contact_force(x, v, v, u))
        impulse, self.pending_impulse = self.pending_impulse, 0.0
        return impulse

    def sample(self, times: np.ndarray, u: float) -> Samples:
        """Advance to each of ``times`` (increasing, after the current time) in turn with flow
        speed u, as ``advance_to(t, u)`` at each would, and return what each step reports.

        The march visits the same segments and events; the states at the sample times and the
        contact impulses are then evaluated per kind of segment in one vectorised pass of the
        closed forms (equal to the scalar ones to rounding). A quadratic-drag sticking phase,
        which has no closed form, evaluates its Taylor steps' polynomials at all its samples at
        once (:meth:`QuadraticStick.states_at`, equal to :meth:`QuadraticStick.state` to
        rounding); a segment with neither is marched sample by sample. Each sample interval
        has its own impact budget (solver.max_impacts), as each step of a Simulator has."""
        try:
            return self._sample(times, u)
        finally:
            self.end_step()

    def _sample(self, times: np.ndarray, u: float) -> Samples:
        if u != self.u:
            x, v, z, w = reanchor_on_flow_change(*self.seg.state(self.tau),
                                                 self.seg.phase is Phase.STICK)
            self._begin(self.state.t, x, v, z, w, u, reanchor=True)
        t_list = times.tolist()
        n = len(t_list)
        out = Samples(n)
        # impulse contributions in the order the scalar march adds them: (sample, value); the
        # values of force-carrying pieces are filled in by the vectorised pass
        targets: list[int] = [0]
        values: list[float] = [self.pending_impulse]
        self.pending_impulse = 0.0
        # per kind of segment: _STEPPED, _MARCHED or the _SampleGroup of its samples
        kinds: dict[type, Any] = {}
        # the kind of the last segment's type, and whether its segments go to a _SampleGroup
        # (most segments follow one of their own type: a bounce's flight another flight)
        last_type: type | None = None
        kind: Any = None
        grouped = False
        event = self._event
        add_target, add_value = targets.append, values.append
        i = 0
        horizon = t_list[-1]
        interval = 0  # the sample interval whose impact budget runs
        self.begin_step()
        while i < n:
            seg = self.seg
            if type(seg) is not last_type:
                last_type = type(seg)
                kind = kinds.get(last_type)
                if kind is None:
                    kind = kinds[last_type] = _sampling_kind(seg)
                grouped = isinstance(kind, _SampleGroup)
            if kind is _MARCHED:  # march to the sample
                if interval != i:
                    interval = i
                    self.begin_step(t_list[i - 1])
                add_target(i)
                add_value(self._march(t_list[i], u))
                out.set(i, self.state, self.sticking)
                i += 1
                continue
            t0 = seg.t0
            if grouped:  # a _SearchedSegment: its next_event, without that call
                tau_event = seg.search.next_root_of(horizon - t0, seg)
            else:
                tau_event = seg.next_event(horizon - t0)
            if tau_event is None:
                j = n
            elif t_list[i] - t0 >= tau_event:  # (several events before one sample: no call)
                j = i
            elif i + 1 == n or t_list[i + 1] - t0 >= tau_event:  # (nor one: 3 in 4 of the
                j = i + 1  # bounces with a sample in Figure 2)
            else:
                j = _first_sample_after(t_list, i + 2, t0, tau_event)
            if grouped:
                if i < j or seg.PUSHES:  # (a flight with no sample adds nothing: most bounces)
                    kind.add(seg, self.tau, i, j, tau_event, targets, values)
            else:
                self._sample_steps(seg, times, i, j, tau_event, out, targets, values)
            if tau_event is None:
                self.tau = horizon - t0
                x, v, z, w = seg.state(self.tau)
                self.state = State(horizon, x, v, z, w)
                break
            add_target(j)
            if interval != j:  # (the event is sample j's: the first at or after it)
                interval = j
                self.begin_step(t_list[j - 1])
            add_value(event(seg, tau_event, u))
            i = j
        impulse = np.zeros(n)
        values_array = np.array(values)
        for group in kinds.values():
            if isinstance(group, _SampleGroup):
                group.evaluate(times, out, values_array)
        np.add.at(impulse, targets, values_array)
        out.impulse = impulse
        return out

    def _sample_steps(self, seg: QuadraticStick, times: np.ndarray, i: int, j: int,
                      tau_event: float | None, out: Samples, targets: list[int],
                      values: list[float]) -> None:
        """Samples i..j-1 in a sticking phase of Taylor steps, from the current position in it
        (and its end at ``tau_event`` before sample j, if it ends): states and the impulse
        pieces the scalar march adds, in its order, all evaluated at once."""
        tau = times[i:j] - seg.t0
        ends = tau if tau_event is None else np.append(tau, tau_event)
        tau_all = np.concatenate(([self.tau], ends))
        y = seg.states_at(tau_all)
        x, v = y[1:j - i + 1, 0], y[1:j - i + 1, 1]
        out.x[i:j], out.v[i:j], out.z[i:j], out.w[i:j] = x, v, x, v
        out.sticking[i:j] = seg.phase is Phase.STICK
        targets.extend(range(i, j))
        if tau_event is not None:
            targets.append(j)
        values.extend(seg.impulses_between(tau_all, y).tolist())

    # snapshots ----------------------------------------------------------------------------------
    def checkpoint(self) -> Any:
        """The solver's fields and the segment object with its search frontier: a flight or a
        linear sticking phase changes nothing else while marching (a quadratic one, with its
        Taylor steps, takes a full snapshot)."""
        seg = self.seg
        if not isinstance(seg, _SearchedSegment) or not seg.FRONTIER_ONLY:
            return super().checkpoint()
        search = seg.search
        degenerate = self.rules.degenerate
        return (self.state, self.e, self.impact_count, self.t_last, len(self.impacts),
                self.sticking, self.sticking_since, self.u, self.tau, self.pending_impulse,
                degenerate.run, degenerate.last, seg, search.a, search.root, search.iterations,
                search.creep)

    def rollback(self, checkpoint: Any) -> None:
        if isinstance(checkpoint, dict):
            super().rollback(checkpoint)
            return
        (self.state, self.e, self.impact_count, self.t_last, n_impacts, self.sticking,
         self.sticking_since, self.u, self.tau, self.pending_impulse, run, last, seg,
         *frontier) = checkpoint
        del self.impacts[n_impacts:]
        self.rules.degenerate.set((run, last))
        seg.search.set_frontier(tuple(frontier))
        self.seg = seg

    _KEYS = ("u", "tau", "pending_impulse", "degenerate", "segment")

    def _snapshot(self) -> dict[str, Any]:
        return {"u": self.u, "tau": self.tau, "pending_impulse": self.pending_impulse,
                "degenerate": self.rules.degenerate.snapshot(),
                "segment": self.seg.snapshot(self.tau)}

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        u = rec.real("u")
        tau = rec.real("tau", low=0.0)
        pending = rec.real("pending_impulse")
        degenerate = self.rules.degenerate.read(rec.record("degenerate"))
        seg_rec = rec.record("segment")
        phase = seg_rec.text("phase", [p.value for p in Phase])
        if (phase == Phase.STICK.value) != rec.data["sticking"]:
            raise StateError(seg_rec.field("phase"), phase, "stick exactly when sticking is true")
        if phase == Phase.FLIGHT.value:
            cls = self._flight_cls
        else:
            cls = QuadraticStick if self.drag.quadratic else LinearStick
        make_segment = cls.read(self, seg_rec, u)

        def apply() -> None:
            self.seg = make_segment()
            self.u, self.tau, self.pending_impulse = u, tau, pending
            self.rules.degenerate.set(degenerate)
        return apply
