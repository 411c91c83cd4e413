"""Method 3, ODE: the general path, ``scipy.integrate.solve_ivp`` with the gap as an event.

This is the integration a user would write by hand. In flight the state ``[x, v, z, w]`` obeys
``m x'' + c x' + k x = 0`` (eq. 8) and ``M w' = F_drag(w)`` (linearised, eq. 4-5, or quadratic,
eq. 2-3 and 31-32); the gap ``g = x - z`` is a terminal event with direction -1 (eq. 25: the
bodies meet). At the event the impact law of eq. 12-17 (:func:`iceimpact.physics.contact.impact`)
gives the new velocities; positions do not jump (eq. 18) and the flight restarts from there.

The integrator is ``solver.ode_method`` (1 = RK45, 2 = DOP853, 3 = LSODA, 4 = Radau) with
``rtol = solver.rtol`` and ``atol = rtol * 1e-3`` (m, m/s: displacements of the article's scenes
are of the order of a millimetre).

Sticking follows the same ideas as the exact solver (:mod:`iceimpact.solvers.event`), in place of
the article's steady-state thresholds (eq. 27-29):

- after an impact that leaves the ice pressed on the structure (contact force lam > 0), a next
  bounce shorter than :data:`~iceimpact.solvers.event.CHATTER_FRACTION` of the structure's period
  (or a Zeno sequence that would end within :data:`~iceimpact.solvers.event.ZENO_TIME`) is closed
  by one plastic impact; so is a contact that parts too slowly for such a bounce (the rounding
  left of a separation);
- the bodies then move together, ``(m + M) x'' + c x' + k x = F_drag(x')``, integrated with the
  same method, the contact force ``lam = F_drag(x') - M x''`` being a terminal event (direction -1):
  they separate when it turns tensile. The drag impulse is integrated alongside, so the impulse of
  the contact force over a step is exact to the tolerance.

Each ``solve_ivp`` call covers at most a chunk of :data:`CHUNK_PERIODS` structure periods (and
:data:`CHUNK_MAX` seconds) from the
start of the segment, and its dense output answers the communication steps inside it, so the
result does not depend on the communication step (unless the flow speed changes, which restarts
the integration at the change). Work is bounded: every impact either lasts a resolvable bounce or
ends the bouncing, and repeated events at one instant (a degenerate contact, or integration noise
at a loose tolerance) make the bodies stick.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from ..physics.contact import contact_force, impact, impact_impulse
from ..physics.ice import make_drag
from ..physics.structure import Oscillator
from ..scene import Scene
from .base import Impact, Solver, SolverError, State
from .event import CHATTER_FRACTION, ROUNDING_SPEED, ZENO_TIME, DegenerateContacts

#: Events at one instant before the bodies are held together briefly (a degenerate contact).
MAX_EVENTS_AT_ONE_INSTANT = 8

#: solve_ivp methods by ``solver.ode_method``.
ODE_METHODS = {1: "RK45", 2: "DOP853", 3: "LSODA", 4: "Radau"}

#: atol = rtol * ATOL_SCALE for every component (m, m/s, and N.s for the integrated drag impulse).
ATOL_SCALE = 1e-3

#: Length of one solve_ivp call, in natural periods of the structure (at least 1 s).
CHUNK_PERIODS = 20.0
#: ... and at most this long (s): a chunk is integrated whole even when the run ends early in it,
#: and a slow structure with a stiff drag (b/M >> omega_n) makes each second of it costly for the
#: explicit integrators (94 s chunks took 40 s for a 1 s run).
CHUNK_MAX = 5.0

#: Positive stand-in for a zero event value at the start of a segment.
_TINY = 1e-300


class _Flight:
    """Both bodies free: ``[x, v, z, w]' = [v, -(c v + k x) / m, w, F_drag(w) / M]`` (eq. 2-8)."""

    def __init__(self, solver: OdeSolver):
        self.m, self.c, self.k, self.M = solver.m, solver.c, solver.k, solver.M
        self.u, self.drag = solver.u, solver.drag

    def __call__(self, t: float, y: np.ndarray) -> list[float]:
        return [y[1], -(self.c * y[1] + self.k * y[0]) / self.m, y[3],
                self.drag.force(y[3], self.u) / self.M]


class _Gap:
    """Terminal event: the gap x - z closes (eq. 25)."""

    terminal = True
    direction = -1

    def __init__(self, start: float):
        self.start = start

    def __call__(self, t: float, y: np.ndarray) -> float:
        # at the start the bodies may touch (g = 0): count that as open, so that only a crossing
        # after the start is an event (and the root bracket stays valid)
        gap = y[0] - y[2]
        return gap if t > self.start else max(gap, _TINY)


class _Stuck:
    """Bodies together: ``[x, v, P]' = [v, (F_drag(v) - c v - k x) / (m + M), F_drag(v)]``."""

    def __init__(self, solver: OdeSolver):
        self.total, self.c, self.k, self.M = solver.m + solver.M, solver.c, solver.k, solver.M
        self.u, self.drag = solver.u, solver.drag

    def __call__(self, t: float, y: np.ndarray) -> list[float]:
        f = self.drag.force(y[1], self.u)
        return [y[1], (f - self.c * y[1] - self.k * y[0]) / self.total, f]

    def contact_force(self, y: np.ndarray) -> float:
        """Force on the structure from the ice: drag minus the ice's inertia, N."""
        f = self.drag.force(y[1], self.u)
        return f - self.M * (f - self.c * y[1] - self.k * y[0]) / self.total


class _ContactForce:
    """Terminal event: the contact force turns tensile (the bodies separate)."""

    terminal = True
    direction = -1

    def __init__(self, stuck: _Stuck, start: float):
        self.stuck, self.start = stuck, start

    def __call__(self, t: float, y: np.ndarray) -> float:
        lam = self.stuck.contact_force(y)
        # a contact force of exactly zero is not tensile (nothing pulls the bodies apart, e.g.
        # both at rest with no flow): only a negative one separates them
        return lam if t > self.start and lam != 0.0 else max(lam, _TINY)


def _same_instant(t: float, t_ref: float) -> bool:
    """Events this close (s) are one instant: what separates them is rounding."""
    return abs(t - t_ref) <= 1e-12 * max(1.0, abs(t))


class OdeSolver(Solver):
    """scipy ``solve_ivp`` with gap and contact-force events (method 3)."""

    name = "ode"

    def __init__(self, scene: Scene):
        super().__init__(scene)
        self.method = ODE_METHODS[scene.solver_ode_method]
        self.rtol = scene.solver_rtol
        self.atol = self.rtol * ATOL_SCALE
        self.osc = Oscillator(self.m, self.c, self.k)
        self.drag = make_drag(scene)
        self.mu = self.m * self.M / (self.m + self.M)
        self.omega_n = scene.omega_n
        period = 2.0 * math.pi / scene.omega_n
        self.chatter_time = CHATTER_FRACTION * period
        self.chunk = min(max(1.0, CHUNK_PERIODS * period), CHUNK_MAX)
        self.u = scene.flow_u
        self.pending_impulse = 0.0
        self.nfev = 0                   # right-hand-side evaluations, for the benchmarks
        self._events_here = 0
        self._last_event_t = -math.inf
        self.degenerate = DegenerateContacts(self.chatter_time)  # the rule of method 1
        s = self.state
        self._begin(0.0, s.x, s.v, s.z, s.w)

    # equations of motion -------------------------------------------------------------------------
    def _flight_rhs(self):
        return _Flight(self), _Gap(self.t_hi)

    def _stick_rhs(self):
        rhs = _Stuck(self)
        return rhs, _ContactForce(rhs, self.t_hi)

    # segments ------------------------------------------------------------------------------------
    def _segment(self, kind: str, t: float, y: list[float], hold: float = 0.0) -> None:
        """Start a flight ``[x, v, z, w]`` or a sticking phase ``[x, v, drag impulse]`` at t;
        a sticking phase ignores separation for ``hold`` seconds."""
        self.kind = kind
        self.t_lo = self.t_hi = t
        self.rhs, self.event_fn = self._flight_rhs() if kind == "flight" else self._stick_rhs()
        self.y_hi = np.array(y, dtype=float)
        self.y_now = self.y_hi.copy()
        self.sol = None
        self.event: tuple[float, np.ndarray] | None = None
        # a forced hold ignores the separation event for a while
        self.hold_until = t + hold if hold > 0.0 else -math.inf
        sticking = kind == "stick"
        if sticking and not self.sticking:
            self.sticking_since = t
        if not sticking:
            self.sticking_since = None
        self.sticking = sticking

    def _extend(self) -> None:
        """Integrate one more chunk of the current segment (stops at its event)."""
        lo = self.t_hi
        hi = lo + self.chunk
        events = self.event_fn
        if lo < self.hold_until:
            hi, events = self.hold_until, None
        res = solve_ivp(self.rhs, (lo, hi), self.y_hi, method=self.method, rtol=self.rtol,
                        atol=self.atol, dense_output=True, events=events)
        self.nfev += res.nfev
        if res.status == -1:
            raise SolverError(f"ODE integration ({self.method}) failed at t = {lo}: "
                               f"{res.message}")
        self.sol, self.t_lo = res.sol, lo
        if events is None:  # end of a forced hold: the contact logic decides again
            self.event = (hi, res.y[:, -1])
            self.t_hi, self.y_hi = hi, res.y[:, -1]
        elif res.status == 1:
            t_ev = float(res.t_events[0][0])
            self.event = (t_ev, res.y_events[0][0])
            self.t_hi, self.y_hi = t_ev, res.y_events[0][0]
        else:
            self.t_hi, self.y_hi = hi, res.y[:, -1]

    def _y(self, t: float) -> np.ndarray:
        if t >= self.t_hi or self.sol is None:
            return self.y_hi
        return self.sol(t)

    def _begin(self, t: float, x: float, v: float, z: float, w: float) -> None:
        """Start the segment that follows time t from state (x, v, z, w) (as the exact solver)."""
        if _same_instant(t, self._last_event_t):
            self._events_here += 1
        else:
            self._events_here, self._last_event_t = 0, t
        if x - z > 0.0:
            self._segment("flight", t, [x, v, z, w])
            return
        closing = w - v
        if self._events_here > MAX_EVENTS_AT_ONE_INSTANT:
            # degenerate contact or integration noise: plastic contact, held for a moment
            v_plus, _ = impact(v, w, self.m, self.M, 0.0)
            self.pending_impulse += impact_impulse(v, v_plus, self.m)
            self._segment("stick", t, [x, v_plus, 0.0], hold=self.chatter_time)
            return
        if closing > 0.0:  # approaching at contact: impact now
            self._impact(t, x, v, w)
            return
        speed_scale = abs(v) + abs(w) + abs(self.u) + self.omega_n * abs(x)
        if -closing <= ROUNDING_SPEED * speed_scale + 1e-300:
            # no closing speed: as in method 1, contact that keeps re-forming (contact force
            # zero to rounding, e.g. everything at rest with no flow) is held together for
            # doubling times up to the chatter time, so that the work stays bounded
            hold = self.degenerate.hold(t)
            if hold > 0.0:
                v_common, _ = impact(v, w, self.m, self.M, 0.0)
                self.pending_impulse += impact_impulse(v, v_common, self.m)
                self._segment("stick", t, [x, v_common, 0.0], hold=hold)
                return
        lam = contact_force(self.osc.acceleration(x, v), self.drag.force(w, self.u) / self.M,
                            self.m, self.M)
        if lam >= 0.0 and -2.0 * closing * self.mu <= lam * self.chatter_time:
            # pressed together and parting too slowly for a resolvable bounce (rounding of a
            # separation, the tail of a chatter): stick, with the common momentum velocity
            v_common, _ = impact(v, w, self.m, self.M, 0.0)
            self.pending_impulse += impact_impulse(v, v_common, self.m)
            self._segment("stick", t, [x, v_common, 0.0])
        else:
            self._segment("flight", t, [x, v, x, w])

    def _impact(self, t: float, x: float, v_minus: float, w_minus: float) -> None:
        """Eq. 16-17 at time t; close a chatter or Zeno sequence with a plastic impact."""
        m, M, e = self.m, self.M, self.e
        v_plus, w_plus = impact(v_minus, w_minus, m, M, e)
        if e > 0.0:
            lam = contact_force(self.osc.acceleration(x, v_plus),
                                self.drag.force(w_plus, self.u) / M, m, M)
            if lam > 0.0:
                bounce = 2.0 * (v_plus - w_plus) * self.mu / lam  # next bounce ~ 2 s mu / lam
                if bounce < self.chatter_time or bounce < ZENO_TIME * (1.0 - e):
                    e = 0.0
                    v_plus, w_plus = impact(v_minus, w_minus, m, M, 0.0)
        if e == 0.0:
            w_plus = v_plus
        impulse = impact_impulse(v_minus, v_plus, m)
        self.impacts.append(Impact(t, x, v_minus, w_minus, v_plus, w_plus, impulse, e))
        self.pending_impulse += impulse
        self._begin(t, x, v_plus, x, w_plus)

    def _stick_impulse(self, ya: np.ndarray, yb: np.ndarray) -> float:
        """Contact-force impulse on the structure: drag impulse minus the ice's momentum change."""
        return float((yb[2] - ya[2]) - self.M * (yb[1] - ya[1]))

    # marching ------------------------------------------------------------------------------------
    def advance_to(self, t_end: float, u: float) -> float:
        if u != self.u:  # zero-order hold: restart the integration at the change
            s = self.state
            self.u = u
            if self.kind == "stick":
                self._begin(s.t, s.x, s.v, s.x, s.v)
            else:
                self._begin(s.t, s.x, s.v, min(s.z, s.x), s.w)
        impulse = self.pending_impulse
        self.pending_impulse = 0.0
        while True:
            while self.event is None and self.t_hi < t_end:
                self._extend()
            if self.event is not None and self.event[0] <= t_end:
                t_ev, y_ev = self.event
                if self.kind == "stick":
                    impulse += self._stick_impulse(self.y_now, y_ev)
                    x, v = float(y_ev[0]), float(y_ev[1])
                    if self.hold_until == t_ev:
                        self._begin(t_ev, x, v, x, v)
                    else:  # contact force turns tensile: separate with equal velocities
                        self._segment("flight", t_ev, [x, v, x, v])
                else:
                    x, v, w = float(y_ev[0]), float(y_ev[1]), float(y_ev[3])
                    if w > v:
                        self._impact(t_ev, x, v, w)
                    else:  # touch without closing speed: the contact logic decides
                        self._begin(t_ev, x, v, x, w)
                impulse += self.pending_impulse
                self.pending_impulse = 0.0
                continue
            y = self._y(t_end)
            if self.kind == "stick":
                impulse += self._stick_impulse(self.y_now, y)
                self.state = State(t_end, float(y[0]), float(y[1]), float(y[0]), float(y[1]))
            else:
                self.state = State(t_end, *(float(c) for c in y))
            self.y_now = np.array(y, dtype=float)
            return impulse
