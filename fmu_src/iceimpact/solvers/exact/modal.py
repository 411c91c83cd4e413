"""Method 1 with the modal structure (structure.model = 3): N modes at the contact point, inside the
exact solver (docs/explanation/modes.md).

The contact rules are the SDOF's (:mod:`~iceimpact.solvers.contact_rules`) on the contact point,
with its effective mass ``1 / m_eff = sum phi_k^2 / m_k`` in place of m (eq. 12-17) and its free
acceleration ``sum phi_k q_k''``. What the modes add is their state: the solver keeps the modal
state at each event, and any instant change of the contact point's velocity (an impact) is an
impulse there, which changes mode k's velocity by ``phi_k J / m_k`` (:meth:`Modes.velocity_change`).

- **Flight** (:class:`ModalFlight`): each mode on its closed form (every damping regime, its held
  load an offset), the ice on its drag law; the gap ``sum phi_k q_k - z`` and its bounds for all
  later times are sums over the modes, so the root search (:class:`RootSearch`) proves every
  stretch it skips root-free, as for the SDOF.
- **Riding** (:class:`ModalRide`): the ice rides on the contact point, ``z = x``. The modes are
  then coupled through the contact force ``lam = m_eff (D + M S) / (M + m_eff)``, ``S = -sum
  phi_k f_k`` (f_k mode k's free acceleration): a linear system under the linear drag, polynomial
  under the quadratic drag while the relative flow keeps its sign. Both are followed by
  high-order Taylor steps whose coefficients follow by recurrence (the series of the matrix
  exponential, without LAPACK: the same bits on every CPU); a step ends where the relative flow
  changes sign, and the riding ends at the first root of lam's polynomial, found without a miss
  (a curvature bound proves each interval it skips).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Callable, Sequence
from typing import Any

from scipy.optimize import brentq

from ...errors import SolverError
from ...physics.ice import downstream_speed_bound
from ...physics.modes import Modes
from ...physics.structure import Oscillator
from ...record import Record
from ..base import GAP_ULPS, State
from ..contact_rules import Phase, reanchor_on_flow_change
from ..search.rootfind import RootSearch
from .context import SegmentContext
from .segment import MARCHED, _time_eps
from .solver import EventSolver

#: Order of the riding phase's Taylor steps, and the size of their last two terms relative to the
#: motion's scale (the step-size rule of Jorba and Zou, 2005)
ORDER = 24
TOLERANCE = 1e-17
#: A riding step spans at most this many units of the fastest rate (its series converge fast)
RATE_SPAN = 2.0
#: Grid of a step's root proof, and the halvings it may spend on it
_GRID = 16
_HALVINGS = 400


class ModalContext(SegmentContext):
    """:class:`SegmentContext` with the modes (``modes``, under the held loads) and the modal
    state at the current instant (``now(v)``: the modes' (q, q') with the contact point moving
    at v, set by the solver), from which the contact rules' free accelerations and the bounds of
    a flight leaving the contact are taken."""

    __slots__ = ("modes", "now")

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.modes: Modes | None = None
        self.now: Callable[[float], tuple[list[float], list[float]]] | None = None
        self.free_accels = self._modal_free_accels

    def _modal_free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        q, p = self.now(v)
        return self.modes.contact_acceleration(q, p), self.drag.accel_bounds(w, u)[0]

    def structure_bounds(self, x: float, v: float, u: float) -> tuple[float, float, float]:
        q, p = self.now(v)
        return self.modes.bounds(q, p)


class ModalFlight:
    """Both bodies free: each mode on its closed form from the anchor (q0, q0'), the ice on its
    drag law from (z0, w0); the signal of the root search is the gap x - z."""

    __slots__ = ("modes", "drag", "t0", "q0", "p0", "z0", "w0", "u", "start", "x0", "v0",
                 "gap0", "search", "_motions", "_z_motion", "_last")
    phase = Phase.FLIGHT
    PUSHES = False
    FRONTIER_ONLY = True
    SAMPLING = MARCHED

    def __init__(self, context: ModalContext, t0: float, q0: Sequence[float],
                 p0: Sequence[float], z0: float, w0: float, u: float, start: float = 0.0):
        self.modes = modes = context.modes
        self.drag = drag = context.drag
        self.t0, self.z0, self.w0, self.u, self.start = t0, z0, w0, u, start
        self.q0, self.p0 = tuple(q0), tuple(p0)
        self.x0, self.v0 = modes.contact(self.q0, self.p0)
        self.gap0 = self.x0 - z0
        # each mode's closed form from its anchor, t -> (q - q0, q'), constants computed once
        self._motions = tuple(osc.increment(qk, pk) for osc, qk, pk in
                              zip(modes.oscillators, self.q0, self.p0, strict=True))
        self._z_motion = drag.response(*drag.flight_constants(w0, u))
        self._last: tuple = (0.0, 0.0, self.v0, 0.0, w0, (0.0,) * modes.count, self.p0)
        self.search = RootSearch(start, _time_eps(t0))

    def _motion(self, tau: float) -> tuple:
        """(tau, x - x0, v, z - z0, w, (q_k - q_k0), (q_k')) at tau; the last one is kept (the
        search asks again for the point it just tested)."""
        last = self._last
        if last[0] == tau:
            return last
        dq, p = [], []
        dx = v = 0.0
        for phi, motion in zip(self.modes.phi, self._motions, strict=True):
            dqk, pk = motion(tau)
            dq.append(dqk)
            p.append(pk)
            dx += phi * dqk
            v += phi * pk
        dz, w = self._z_motion(tau)
        self._last = last = (tau, dx, v, dz, w, dq, p)
        return last

    def modal_state(self, tau: float) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at tau."""
        _, _, _, _, _, dq, p = self._motion(tau)
        return [q0 + d for q0, d in zip(self.q0, dq, strict=True)], list(p)

    def state(self, tau: float) -> tuple[float, float, float, float]:
        _, dx, v, dz, w, _, _ = self._motion(tau)
        return self.x0 + dx, v, self.z0 + dz, w

    def gap(self, tau: float) -> float:
        _, dx, _, dz, _, _, _ = self._motion(tau)
        return self.gap0 + (dx - dz)

    def gap_and_rate(self, tau: float) -> tuple[float, float]:
        _, dx, v, dz, w, _, _ = self._motion(tau)
        return self.gap0 + (dx - dz), v - w

    value, value_and_rate = gap, gap_and_rate

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        """Gap, its rate and curvature, bounds on |gap''| and |gap'''| for all later times: the
        modes' bounds summed (:meth:`Modes.bounds`) and the ice's."""
        _, dx, v, dz, w, dq, p = self._motion(tau)
        q = [q0 + d for q0, d in zip(self.q0, dq, strict=True)]
        a_x, a_x_max, j_x_max = self.modes.bounds(q, p)
        a_z, a_z_max, j_z_max = self.drag.accel_bounds(w, self.u)
        return (self.gap0 + (dx - dz), v - w, a_x - a_z, a_x_max + a_z_max, j_x_max + j_z_max)

    def clearance(self, tau: float) -> float:
        """Time from tau (s) during which the gap provably stays open: the contact point stays
        within ``sum |phi_k| R_k`` of ``sum phi_k offset_k`` (:meth:`Modes.envelope`), and the
        ice moves downstream no faster than its speed bound (as :meth:`Flight.clearance`)."""
        _, dx, v, dz, w, dq, p = self._motion(tau)
        z = self.z0 + dz
        q = [q0 + d for q0, d in zip(self.q0, dq, strict=True)]
        centre, reach = self.modes.envelope(q, p)
        x = self.x0 + dx
        margin = (centre - reach - z) - GAP_ULPS * (abs(x) + abs(z) + reach + abs(centre))
        if not margin > 0.0:
            return 0.0
        speed = downstream_speed_bound(w, self.u, self.drag.drags)
        return math.inf if speed == 0.0 else margin / speed

    def next_event(self, tau_end: float) -> float | None:
        """The impact: the first root of the gap, if at or before tau_end."""
        return self.search.next_root_of(tau_end, self)

    def impulse(self, tau_a: float, tau_b: float) -> float:
        return 0.0

    _KEYS = ("phase", "t0", "q", "p", "z", "w", "start", "search")

    def snapshot(self, tau: float) -> dict[str, Any]:
        return {"phase": self.phase.value, "t0": self.t0, "q": list(self.q0),
                "p": list(self.p0), "z": self.z0, "w": self.w0, "start": self.start,
                "search": self.search.frontier()}

    @classmethod
    def read(cls, context: ModalContext, rec: Record, u: float) -> Callable[[], Any]:
        rec.expect_keys(cls._KEYS)
        t0 = rec.real("t0", low=0.0)
        n = context.modes.count
        q, p = rec.reals("q", n), rec.reals("p", n)
        z, w = rec.real("z"), rec.real("w")
        start = rec.real("start", low=0.0)
        frontier = RootSearch.read_frontier(rec.record("search"), start)

        def make() -> ModalFlight:
            seg = cls(context, t0, q, p, z, w, u, start)
            seg.search.set_frontier(frontier)
            return seg
        return make


def _horner(coeffs: Sequence[float], theta: float) -> float:
    value = 0.0
    for c in reversed(coeffs):
        value = value * theta + c
    return value


def first_negative(coeffs: Sequence[float], theta_from: float, theta_end: float) -> float | None:
    """The first theta in [theta_from, theta_end] (within [0, 1]) where the polynomial
    ``sum coeffs[n] theta^n`` goes below zero, or None. On an interval [a, b] where it is >= 0 at
    both ends, ``min(p(a), p(b)) >= K (b - a)^2 / 8`` proves it >= 0 throughout (K a bound on
    |p''| over [0, 1], from the coefficients); otherwise the interval is halved. A sign change is
    then resolved by brentq; a zero it only touches closer than the halvings resolve is no
    root."""
    if theta_end < theta_from:
        return None
    value_from = _horner(coeffs, theta_from)
    if value_from < 0.0:
        return theta_from
    curvature = 0.0
    for n in range(2, len(coeffs)):
        c = coeffs[n]
        curvature += n * (n - 1) * (c if c >= 0.0 else -c)
    rates = [n * c for n, c in enumerate(coeffs)][1:]
    span = theta_end - theta_from
    for i in range(_GRID):
        budget = _HALVINGS
        a = theta_from + span * i / _GRID
        b = theta_end if i == _GRID - 1 else theta_from + span * (i + 1) / _GRID
        stack = [(a, _horner(coeffs, a), b, _horner(coeffs, b))]
        while stack:
            a, pa, b, pb = stack.pop()
            if pa < 0.0:
                return a
            if pb < 0.0:
                root = brentq(lambda theta: _horner(coeffs, theta), a, b, xtol=1e-300,
                              rtol=4.0 * 2.0 ** -52, maxiter=1100)
                return root
            if min(pa, pb) >= curvature * (b - a) ** 2 / 8.0 or budget <= 0:
                continue
            # rising from a (a zero there included): p >= p(a) + p'(a) s - K s^2 / 2 >= 0
            rate = _horner(rates, a)
            if rate > 0.0 and (b - a) * curvature <= 2.0 * rate:
                continue
            budget -= 1
            mid = 0.5 * (a + b)
            pm = _horner(coeffs, mid)
            stack.append((mid, pm, b, pb))
            stack.append((a, pa, mid, pm))
    return None


class _RideStep:
    """One Taylor step of a riding phase from ``lo`` (s, from the segment's anchor): the
    polynomials in theta = (tau - lo) / h of each mode's q and q', of the contact impulse P and
    of the contact force lam, its end ``hi`` and whether the riding ends there."""

    __slots__ = ("lo", "h", "hi", "q", "p", "impulse", "force", "separates")

    def state(self, tau: float) -> tuple[list[float], list[float], float]:
        theta = (tau - self.lo) / self.h if self.h > 0.0 else 0.0
        return ([_horner(c, theta) for c in self.q], [_horner(c, theta) for c in self.p],
                _horner(self.impulse, theta))


class ModalRide:
    """The ice riding on the contact point of the modes (z = x), from the anchor (q0, q0') at t0,
    under the flow u; the riding ends at the first root of the contact force (not looked for
    before ``start``, a degenerate contact's hold). See the module docstring."""

    phase = Phase.STICK
    PUSHES = True
    FRONTIER_ONLY = False
    SAMPLING = MARCHED

    def __init__(self, context: ModalContext, t0: float, q0: Sequence[float],
                 p0: Sequence[float], u: float, start: float = 0.0):
        self.modes = modes = context.modes
        self.drag = context.drag
        self.M = context.M
        self.t0, self.u, self.start = t0, u, start
        self.q0, self.p0 = tuple(q0), tuple(p0)
        m_eff = modes.effective_mass
        self._alpha = m_eff / (self.M + m_eff)
        self._beta = self.M * self._alpha
        self._quadratic = self.drag.quadratic
        self._drag_coef = self.drag.B if self._quadratic else self.drag.b
        drag_rate = (2.0 * self._drag_coef * (abs(u) + abs(modes.contact(q0, p0)[1]) + 1.0)
                     if self._quadratic else self._drag_coef) / self.M
        self._rate = modes.rates() + drag_rate
        self._steps: list[_RideStep] = []
        self._los: list[float] = []
        self._end: float | None = None  # the separation, once found
        self._checked = 0  # the steps before this one are proven free of a separation

    # the Taylor steps --------------------------------------------------------------------------
    def _series(self, q: Sequence[float], p: Sequence[float], sign: float) -> tuple:
        """Taylor coefficients (in time, s) of each mode's q, q', the impulse P and lam from the
        state (q, q'), to ORDER (see the module docstring); ``sign`` the relative flow's sign
        under the quadratic drag."""
        modes = self.modes
        n_modes = modes.count
        phis, masses = modes.phi, modes.mass
        oscs = modes.oscillators
        damp = [osc.damping for osc in oscs]
        stiff = [osc.stiffness for osc in oscs]
        loads = modes.loads
        alpha, beta, coef, u = self._alpha, self._beta, self._drag_coef, self.u
        qs = [[q[k]] for k in range(n_modes)]
        ps = [[p[k]] for k in range(n_modes)]
        rs: list[float] = []
        force: list[float] = []
        for n in range(ORDER + 1):
            v = 0.0
            for k in range(n_modes):
                v += phis[k] * ps[k][n]
            r = (u if n == 0 else 0.0) - v
            rs.append(r)
            if self._quadratic:
                square = 0.0
                for i in range(n + 1):
                    square += rs[i] * rs[n - i]
                drag = sign * coef * square
            else:
                drag = coef * r
            free = []
            free_sum = 0.0
            for k in range(n_modes):
                fk = ((loads[k] if n == 0 else 0.0) - damp[k] * ps[k][n]
                      - stiff[k] * qs[k][n]) / masses[k]
                free.append(fk)
                free_sum += phis[k] * fk
            lam = alpha * drag - beta * free_sum
            force.append(lam)
            if n == ORDER:
                break
            for k in range(n_modes):
                qs[k].append(ps[k][n] / (n + 1))
                ps[k].append((free[k] + phis[k] * lam / masses[k]) / (n + 1))
        impulse = [0.0] + [force[n] / (n + 1) for n in range(ORDER)]
        return qs, ps, impulse, force, rs

    def _step_length(self, qs: list, ps: list) -> float:
        """The step: its last two terms below TOLERANCE of the motion's scale (the modes' speeds,
        omega q and q'), at most RATE_SPAN over the fastest rate."""
        omegas = [math.sqrt(osc.omega2) for osc in self.modes.oscillators]
        scale = abs(self.u)
        last = [0.0, 0.0]
        for k, omega in enumerate(omegas):
            scale += omega * abs(qs[k][0] - self.modes.oscillators[k].offset) + abs(ps[k][0])
            for j, n in enumerate((ORDER - 1, ORDER)):
                last[j] = max(last[j], omega * abs(qs[k][n]), abs(ps[k][n]))
        h = RATE_SPAN / self._rate if self._rate > 0.0 else math.inf
        if scale > 0.0:
            for j, n in enumerate((ORDER - 1, ORDER)):
                if last[j] > 0.0:
                    h = min(h, (TOLERANCE * scale / last[j]) ** (1.0 / n))
        if not math.isfinite(h):
            h = 1.0
        return h

    def _make_step(self, lo: float, q: Sequence[float], p: Sequence[float],
                   impulse0: float) -> _RideStep:
        sign = 1.0
        qs, ps, impulse, force, rs = self._series(q, p, sign)
        if self._quadratic:
            # the drag's sign is the relative flow's, or where it is 0 the one it moves to
            lead = next((r for r in rs if r != 0.0), 1.0)
            if lead < 0.0:
                sign = -1.0
                qs, ps, impulse, force, rs = self._series(q, p, sign)
        h = self._step_length(qs, ps)
        scaled = [[c * h ** n for n, c in enumerate(col)] for col in qs + ps]
        step = _RideStep()
        step.lo, step.h = lo, h
        n_modes = self.modes.count
        step.q, step.p = scaled[:n_modes], scaled[n_modes:]
        step.impulse = [c * h ** n for n, c in enumerate(impulse)]
        step.impulse[0] = impulse0
        step.force = [c * h ** n for n, c in enumerate(force)]
        end = 1.0
        if self._quadratic:  # the step ends where the relative flow changes sign
            relative = [sign * c * h ** n for n, c in enumerate(rs)]
            theta = first_negative(relative, 0.0, 1.0)
            if theta is not None:
                end = theta
        step.hi = lo + h * end
        if step.hi <= lo:
            raise SolverError(f"the riding phase's Taylor steps stalled at t = {self.t0 + lo!r} "
                              f"s (modal state q = {list(q)}, q' = {list(p)})")
        step.separates = False
        return step

    def _extend(self) -> _RideStep:
        """The next step, from the end of the last one (the first from the anchor)."""
        if self._steps:
            last = self._steps[-1]
            q, p, impulse = last.state(last.hi)
            lo = last.hi
        else:
            q, p, impulse, lo = list(self.q0), list(self.p0), 0.0, 0.0
        step = self._make_step(lo, q, p, impulse)
        self._steps.append(step)
        self._los.append(lo)
        return step

    def _step_at(self, tau: float) -> _RideStep:
        while not self._steps or self._steps[-1].hi < tau:
            if self._end is not None:
                break
            self._extend()
        i = bisect_right(self._los, tau) - 1
        return self._steps[max(i, 0)]

    # the segment's interface -----------------------------------------------------------------
    def next_event(self, tau_end: float) -> float | None:
        """The separation: the first tau >= start where the contact force turns tensile, if at
        or before tau_end."""
        if self._end is not None:
            return self._end if self._end <= tau_end else None
        i = self._checked
        while True:
            if i == len(self._steps):
                if self._steps and self._steps[-1].lo > tau_end:
                    return None
                self._extend()
            step = self._steps[i]
            i += 1
            if step.hi < self.start:
                self._checked = i
                continue
            theta_from = max(0.0, (self.start - step.lo) / step.h)
            theta_end = (step.hi - step.lo) / step.h
            theta = first_negative(step.force, theta_from, theta_end)
            if theta is not None:
                self._end = tau = step.lo + theta * step.h
                del self._steps[i:]
                del self._los[i:]
                return tau if tau <= tau_end else None
            self._checked = i
            if step.hi > tau_end:
                return None

    def modal_state(self, tau: float) -> tuple[list[float], list[float]]:
        q, p, _ = self._step_at(tau).state(tau)
        return q, p

    def state(self, tau: float) -> tuple[float, float, float, float]:
        q, p = self.modal_state(tau)
        x, v = self.modes.contact(q, p)
        return x, v, x, v

    def impulse(self, tau_a: float, tau_b: float) -> float:
        if tau_b <= tau_a:
            return 0.0
        return self._step_at(tau_b).state(tau_b)[2] - self._step_at(tau_a).state(tau_a)[2]

    _KEYS = ("phase", "t0", "q", "p", "start")

    def snapshot(self, tau: float) -> dict[str, Any]:
        """The anchor: its Taylor steps are rebuilt from it, the same floats."""
        return {"phase": self.phase.value, "t0": self.t0, "q": list(self.q0),
                "p": list(self.p0), "start": self.start}

    @classmethod
    def read(cls, context: ModalContext, rec: Record, u: float) -> Callable[[], Any]:
        rec.expect_keys(cls._KEYS)
        t0 = rec.real("t0", low=0.0)
        n = context.modes.count
        q, p = rec.reals("q", n), rec.reals("p", n)
        start = rec.real("start", low=0.0)
        return lambda: cls(context, t0, q, p, u, start)


class ModalSolver(EventSolver):
    """The exact event-driven method with the modal structure (see the module docstring). The
    modes' loads of the next step are set by :meth:`set_loads` (the simulator does it)."""

    name = "exact"
    _context_class = ModalContext
    #: its flights are sums of modes: the compiled march of bounces takes the SDOF's only
    COMPILED_BOUNCES = False

    def __init__(self, scene: Any, record_impacts: bool = True):
        self._modes = Modes(scene.mode_table, scene.mode_loads)
        x0, v0 = scene.modal_start
        self._now: tuple[list[float], list[float], float] = (
            [row[4] for row in scene.mode_table], [row[5] for row in scene.mode_table], v0)
        super().__init__(scene, record_impacts)

    def _structure(self) -> Oscillator:
        """Unused by the modal segments (the context's ``osc`` of the SDOF fields)."""
        return Oscillator(self.m, self.c, self.k)

    def _start(self) -> None:
        context = self.context
        context.modes = self._modes
        context.now = self.modal_now
        x0, v0 = self.scene.modal_start
        s = self.state
        self.state = State(0.0, x0, v0, s.z, s.w)
        self._begin(0.0, x0, v0, s.z, s.w, self.u)

    # the modal state at the current instant ----------------------------------------------------
    def modal_now(self, v: float) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at the current event with the contact point moving at v: the
        velocities of the state found there, changed by the impulse that moved v."""
        q, p, v_ref = self._now
        if v == v_ref:
            return list(q), list(p)
        return list(q), self.context.modes.velocity_change(p, v - v_ref)

    def _take_now(self, tau: float) -> None:
        q, p = self.seg.modal_state(tau)
        self._now = (q, p, self.context.modes.contact(q, p)[1])

    def modal_state(self) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at the solver's time."""
        return self.seg.modal_state(self.tau)

    # segments -----------------------------------------------------------------------------------
    def _new_flight(self, t: float, x: float, v: float, z: float, w: float, u: float,
                    start: float) -> ModalFlight:
        q, p = self.modal_now(v)
        return ModalFlight(self.context, t, q, p, z, w, u, start)

    def _stick(self, t: float, x: float, v: float, u: float, hold: float = 0.0) -> None:
        q, p = self.modal_now(v)
        self.seg = ModalRide(self.context, t, q, p, u, start=hold)
        self._set_sticking(True, t)

    def _segment_class(self, phase: str) -> Any:
        return ModalFlight if phase == Phase.FLIGHT.value else ModalRide

    def at_event(self, tau_event: float) -> None:
        self._take_now(tau_event)
        super().at_event(tau_event)

    def reanchor(self, u: float, t_end: float = 0.0) -> None:
        self._take_now(self.tau)
        super().reanchor(u, t_end)

    def set_loads(self, loads: Sequence[float]) -> None:
        """Hold the modes' generalized loads (N) from now on: the segment is re-anchored at the
        current time on the modes under them (as a new flow speed is)."""
        loads = tuple(loads)
        if loads == self.context.modes.loads:
            return
        self._take_now(self.tau)
        self.context.modes = self.context.modes.with_loads(loads)
        x, v, z, w = reanchor_on_flow_change(*self.seg.state(self.tau),
                                             self.seg.phase is Phase.STICK)
        end, self.zeno_end = self.zeno_end, None
        t = self.state.t
        self._begin(t, x, v, z, w, self.u, reanchor=True)
        if end is not None and self.seg.phase is Phase.STICK:
            self._set_sticking(False, t)
            self.zeno_end = end

    # snapshots ----------------------------------------------------------------------------------
    def checkpoint(self) -> Any:
        return (super().checkpoint(), self.context.modes)

    def rollback(self, checkpoint: Any) -> None:
        inner, self.context.modes = checkpoint
        super().rollback(inner)

    _KEYS = EventSolver._KEYS + ("loads",)

    def _snapshot(self) -> dict[str, Any]:
        data = super()._snapshot()
        data["loads"] = list(self.context.modes.loads)
        return data

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        loads = rec.reals("loads", self.context.modes.count)
        modes = self.context.modes.with_loads(loads)
        saved, self.context.modes = self.context.modes, modes
        try:  # the segment is read against the modes under the saved loads
            apply_rest = super()._read(rec, t)
        finally:
            self.context.modes = saved

        def apply() -> None:
            self.context.modes = modes
            apply_rest()
        return apply
