"""Method 1, exact and event-driven: closed-form flights, exact impact times, a sticking phase.

Between events each body follows its closed form (structure: eq. 9-10 and the other damping
regimes, :mod:`iceimpact.physics.structure`; ice: eq. 6-7 or the exact quadratic-drag solution,
:mod:`iceimpact.physics.ice`), anchored at the event that started the segment, so communication
steps never re-base them. Impact times are the first roots of the gap g = x - z, located by
:class:`~iceimpact.solvers.rootfind.RootSearch`, which proves the intervals it skips root-free and
so never misses a grazing touch. Each impact applies eq. 16-17.

A Zeno sequence (e < 1, bodies pressed together) is closed by one plastic impact once the rest of
the sequence would take less than :data:`ZENO_TIME`; the bodies then stick: linear drag in closed
form (a damped oscillator of mass m + M, damping c + b, equilibrium b u / k, cf. eq. 27-29),
quadratic drag with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12). They separate when the
contact force would turn tensile.
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
from .rootfind import RootSearch

#: A Zeno sequence whose remaining impacts would all happen within this time (s) is closed by
#: one plastic impact: the motion it skips is below ~ closing speed * ZENO_TIME (sub-nanometre).
ZENO_TIME = 1e-9

#: Chatter closure: a bounce that would last less than this fraction of the structure's natural
#: period 2 pi / omega_n ends the bouncing with one plastic impact. With e = 1 the exact model never
#: stops bouncing: pressed on the structure by the flow, the ice makes ever smaller and faster
#: bounces (the impact rate doubles every ~25 s in the Figure 2 scene) whose mean force is the
#: sticking contact force. Closing them bounds the work per simulated second; the motion it skips
#: is a bounce of height (g'' T^2 / 8) below ~1e-9 m in the Figure 2 scene. The README gives
#: its measured effect.
CHATTER_FRACTION = 1e-2

#: Tolerances of the ODE integration of the quadratic-drag sticking phase.
STICK_RTOL = 1e-12
STICK_ATOL = (1e-15, 1e-15, 1e-12)  # x (m), v (m/s), drag impulse (N.s)

#: A closing speed below ROUNDING_SPEED * (|v| + |w| + |u| + wn |x|) is rounding, not an impact.
ROUNDING_SPEED = 1e-12
#: More than this many contacts with zero closing speed, each within CHATTER_FRACTION of a period
#: of the previous one, mean a degenerate contact (gap and contact force both zero to rounding,
#: as right after a separation): the bodies are then held together for DEGENERATE_HOLD (s),
#: doubling at each further such contact up to the chatter time, so the work stays bounded.
MAX_DEGENERATE_CONTACTS = 8
DEGENERATE_HOLD = 1e-9


class DegenerateContacts:
    """The rule for contacts that keep re-forming with no closing speed (methods 1 and 3).

    The gap and the contact force can both be zero to rounding (right after a separation, or
    with everything at rest and no force): contact then re-forms at every event. After
    MAX_DEGENERATE_CONTACTS such contacts, each within the chatter time of the previous one, the
    bodies are held together for DEGENERATE_HOLD, doubling at each further one up to the chatter
    time, so that the work per simulated second stays bounded.
    """

    def __init__(self, chatter_time: float):
        self.chatter_time = chatter_time
        self.run = 0
        self.last = -math.inf

    def hold(self, t: float) -> float:
        """Count a contact with no closing speed at time t (s); how long to hold the bodies
        together from t (s), 0 while the run of such contacts is short."""
        if t - self.last > self.chatter_time:
            self.run = 0
        self.run += 1
        self.last = t
        if self.run <= MAX_DEGENERATE_CONTACTS:
            return 0.0
        extra = self.run - MAX_DEGENERATE_CONTACTS
        return min(DEGENERATE_HOLD * 2.0 ** min(extra, 60), self.chatter_time)


def _time_eps(t: float) -> float:
    return 8.9e-16 * max(1.0, abs(t))


class Flight:
    """Both bodies free: structure on its oscillator, ice on its drag law, from one anchor."""

    kind = "flight"

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, z0: float,
                 w0: float, u: float, start: float = 0.0):
        self.osc = solver.osc
        self.drag = solver.drag
        self.t0, self.x0, self.v0, self.z0, self.w0, self.u = t0, x0, v0, z0, w0, u
        self.gap0 = x0 - z0
        self.search = RootSearch(self.probe, self.gap, start, _time_eps(t0))

    # Displacements are evaluated as increments from the anchor, so that the gap near contact
    # (x ~ z, both large) keeps its accuracy instead of the rounding of x and z.
    def state(self, tau: float) -> tuple[float, float, float, float]:
        dx, v = self.osc.displacement_change(self.x0, self.v0, tau)
        dz, w = self.drag.displacement_change(self.w0, self.u, tau)
        return self.x0 + dx, v, self.z0 + dz, w

    def gap(self, tau: float) -> float:
        dx, _ = self.osc.displacement_change(self.x0, self.v0, tau)
        dz, _ = self.drag.displacement_change(self.w0, self.u, tau)
        return self.gap0 + (dx - dz)

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        """Gap, its rate and curvature, bounds on |gap''| and |gap'''| for all later times."""
        dx, v = self.osc.displacement_change(self.x0, self.v0, tau)
        dz, w = self.drag.displacement_change(self.w0, self.u, tau)
        a_x, j_x, s_x = self.osc.derivatives(self.x0 + dx, v)
        a_z, a_z_max, j_z_max = self.drag.accel_bounds(w, self.u)
        return (self.gap0 + (dx - dz), v - w, a_x - a_z,
                self.osc.amplitude_bound(a_x, j_x) + a_z_max,
                self.osc.amplitude_bound(j_x, s_x) + j_z_max)

    def next_event(self, tau_end: float) -> float | None:
        return self.search.next_root_before(tau_end)

    def impulse(self, tau_a: float, tau_b: float) -> float:
        return 0.0  # no contact force in flight


class LinearStick:
    """Bodies together under linear drag: closed form (mass m+M, damping c+b, offset b u / k)."""

    kind = "stick"

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.M = solver.M
        self.b = solver.drag.b
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.osc = Oscillator(solver.m + solver.M, solver.c + self.b, solver.k,
                              offset=self.b * u / solver.k)
        self.search = RootSearch(self.probe, self.force, start, _time_eps(t0))

    def state(self, tau: float) -> tuple[float, float, float, float]:
        x, v = self.osc.response(self.x0, self.v0, tau)
        return x, v, x, v

    def force(self, tau: float) -> float:
        """Contact force on the structure, N: drag on the ice minus its inertia."""
        x, v = self.osc.response(self.x0, self.v0, tau)
        return -self.b * (v - self.u) - self.M * self.osc.acceleration(x, v)

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        """Contact force, its two derivatives, bounds on |lam''| and |lam'''| from here on."""
        x, v = self.osc.response(self.x0, self.v0, tau)
        _, _, a, j, s, s1, s2 = self.osc.derivative_chain(x, v, 6)
        lam = -self.b * (v - self.u) - self.M * a
        rate = -self.b * a - self.M * j
        curvature = -self.b * j - self.M * s
        bound = (self.b * self.osc.amplitude_bound(j, s)
                 + self.M * self.osc.amplitude_bound(s, s1))
        jerk = (self.b * self.osc.amplitude_bound(s, s1)
                + self.M * self.osc.amplitude_bound(s1, s2))
        return lam, rate, curvature, bound, jerk

    def next_event(self, tau_end: float) -> float | None:
        return self.search.next_root_before(tau_end)

    def impulse(self, tau_a: float, tau_b: float) -> float:
        """Integral of the contact force: drag impulse on the ice minus its momentum change."""
        if tau_b <= tau_a:
            return 0.0
        xa, va = self.osc.response(self.x0, self.v0, tau_a)
        xb, vb = self.osc.response(self.x0, self.v0, tau_b)
        return -self.b * ((xb - xa) - self.u * (tau_b - tau_a)) - self.M * (vb - va)


class QuadraticStick:
    """Bodies together under quadratic drag: DOP853 in fixed chunks from the anchor, separation as
    a terminal event. Chunk limits depend only on the anchor, so results do not depend on the
    communication step."""

    kind = "stick"

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.m, self.c, self.k, self.M = solver.m, solver.c, solver.k, solver.M
        self.drag = solver.drag
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        period = 2.0 * math.pi / math.sqrt(self.k / (self.m + self.M))
        self.chunk = min(max(0.05, 2.0 * period), 5.0)  # s, fixed from the anchor
        self.start = start
        self.hi = 0.0                   # integrated up to here
        self.y_hi = np.array([x0, v0, 0.0])
        self.chunks: list[tuple[float, float, object]] = []  # (lo, hi, dense solution)
        self.separation: float | None = None
        self.y_sep: np.ndarray | None = None
        self._recent: dict[float, np.ndarray] = {}  # the last two states asked for, by tau

    def _rhs(self, tau: float, y: np.ndarray) -> list[float]:
        x, v = y[0], y[1]
        f = self.drag.force(v, self.u)
        return [v, (f - self.c * v - self.k * x) / (self.m + self.M), f]

    def _force_event(self, tau: float, y: np.ndarray) -> float:
        x, v = y[0], y[1]
        f = self.drag.force(v, self.u)
        a = (f - self.c * v - self.k * x) / (self.m + self.M)
        return f - self.M * a

    _force_event.terminal = True
    _force_event.direction = -1

    def _extend(self) -> None:
        lo = self.hi
        if lo < self.start:  # held together: no separation looked for before `start`
            hi, events = self.start, None
        else:
            hi, events = lo + self.chunk, self._force_event
            if self._force_event(lo, self.y_hi) < 0.0:  # already tensile (after a hold)
                self.separation, self.y_sep, self.hi = lo, self.y_hi, lo
                return
        res = solve_ivp(self._rhs, (lo, hi), self.y_hi, method="DOP853", rtol=STICK_RTOL,
                        atol=STICK_ATOL, dense_output=True, events=events)
        if not res.success:
            raise SolverError(f"sticking-phase integration failed at t = {self.t0 + lo}: "
                               f"{res.message}")
        if res.status == 1:  # terminal event: the contact force turns tensile
            self.separation, self.y_sep = float(res.t_events[0][0]), res.y_events[0][0]
            hi = self.separation
        self.chunks.append((lo, hi, res.sol))
        self.hi = hi
        self.y_hi = self.y_sep if self.separation is not None else res.y[:, -1]

    def _y(self, tau: float) -> np.ndarray:
        # A communication step asks for the state at its end twice (state, impulse) and at its
        # start once more (impulse): the last two evaluations are kept, since the dense output
        # costs ~20 us per call.
        cached = self._recent.get(tau)
        if cached is not None:
            return cached
        while tau > self.hi and self.separation is None:
            self._extend()
        if tau >= self.hi:
            y = self.y_hi
        else:
            y = None
            for lo, hi, sol in reversed(self.chunks):
                if lo <= tau <= hi:
                    y = sol(tau)
                    break
            if y is None:
                y = self.y_hi if not self.chunks else self.chunks[0][2](tau)
        if len(self._recent) >= 2:
            del self._recent[next(iter(self._recent))]
        self._recent[tau] = y
        return y

    def state(self, tau: float) -> tuple[float, float, float, float]:
        y = self._y(tau)
        # the solver never looks back before its current time: drop chunks that end before it
        while len(self.chunks) > 1 and self.chunks[0][1] < tau:
            self.chunks.pop(0)
        x, v = float(y[0]), float(y[1])
        return x, v, x, v

    def next_event(self, tau_end: float) -> float | None:
        while self.separation is None and self.hi < tau_end:
            self._extend()
        if self.separation is not None and self.separation <= tau_end:
            return self.separation
        return None

    def impulse(self, tau_a: float, tau_b: float) -> float:
        if tau_b <= tau_a:
            return 0.0
        ya, yb = self._y(tau_a), self._y(tau_b)
        return float((yb[2] - ya[2]) - self.M * (yb[1] - ya[1]))


class EventSolver(Solver):
    """Exact event-driven solver (method 1)."""

    name = "exact"

    def __init__(self, scene: Scene):
        super().__init__(scene)
        self.osc = Oscillator(self.m, self.c, self.k)
        self.drag = make_drag(scene)
        self.mu = self.m * self.M / (self.m + self.M)
        self.omega_n = scene.omega_n
        self.chatter_time = CHATTER_FRACTION * 2.0 * math.pi / scene.omega_n
        self.u = scene.flow_u
        self.tau = 0.0  # position within the current segment
        self.degenerate = DegenerateContacts(self.chatter_time)
        self.pending_impulse = 0.0
        s = self.state
        self.seg = None
        self._begin(0.0, s.x, s.v, s.z, s.w, self.u)  # an impact at t = 0 goes to the 1st step

    # segment construction -----------------------------------------------------------------------
    def _free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        return self.osc.acceleration(x, v), self.drag.accel_bounds(w, u)[0]

    def _begin(self, t: float, x: float, v: float, z: float, w: float, u: float) -> None:
        """Start the segment that follows time t from state (x, v, z, w)."""
        self.u = u
        self.tau = 0.0
        gap = x - z
        if gap > 0.0:
            self._fly(t, x, v, z, w, u)
            return
        closing = w - v
        speed_scale = abs(v) + abs(w) + abs(u) + self.omega_n * abs(x)
        if closing != 0.0 and abs(closing) <= ROUNDING_SPEED * speed_scale + 1e-300:
            # a closing speed at rounding level is no impact: merge the velocities
            # (momentum kept) and let the contact logic below decide
            v = w = (self.m * v + self.M * w) / (self.m + self.M)
            closing = 0.0
        if closing > 0.0:  # approaching at contact: impact now
            self._impact(t, x, v, w, u)
            return
        if closing == 0.0:
            hold = self.degenerate.hold(t)
            if hold > 0.0:  # contact keeps re-forming with no speed: hold the bodies together
                self._stick(t, x, v, u, hold=hold)
                return
        a_x, a_z = self._free_accels(x, v, w, u)
        lam = contact_force(a_x, a_z, self.m, self.M)
        if closing == 0.0 and lam >= 0.0:
            self._stick(t, x, v, u)
        else:
            self._fly_from_contact(t, x, v, w, u, lam)

    def _fly(self, t, x, v, z, w, u, start: float = 0.0) -> None:
        self.seg = Flight(self, t, x, v, z, w, u, start)
        self._set_contact(False, t)

    def _fly_from_contact(self, t: float, x: float, v: float, w: float, u: float,
                          lam: float) -> None:
        """Flight starting at zero gap with separating (or zero) relative velocity.

        The search starts beyond the trivial root at 0, at the end of an interval proven root-free:
        ``g >= s h - K h^2/2`` (opening speed s > 0), or ``g >= g2 h^2/2 - J h^3/6`` (s = 0, gap
        curvature g2 = -lam / mu > 0, J a bound on |g'''|).
        """
        opening = v - w
        a_x, j_x, s_x = self.osc.derivatives(x, v)
        a_z, a_z_max, j_z_max = self.drag.accel_bounds(w, u)
        curvature = a_x - a_z
        acc_bound = self.osc.amplitude_bound(a_x, j_x) + a_z_max
        jerk_bound = self.osc.amplitude_bound(j_x, s_x) + j_z_max
        start = 0.0
        if opening > 0.0 and acc_bound > 0.0:
            start = opening / acc_bound
        if curvature > 0.0 and jerk_bound > 0.0:
            start = max(start, 2.0 * curvature / jerk_bound)
        self._fly(t, x, v, x, w, u, start)

    def _stick(self, t: float, x: float, v: float, u: float, hold: float = 0.0) -> None:
        """Bodies together from time t; separation is not looked for before ``t + hold``."""
        cls = QuadraticStick if self.drag.quadratic else LinearStick
        self.seg = cls(self, t, x, v, u, start=hold)
        self._set_contact(True, t)

    def _set_contact(self, sticking: bool, t: float) -> None:
        if sticking and not self.sticking:
            self.sticking_since = t
        if not sticking:
            self.sticking_since = None
        self.sticking = sticking

    def _impact(self, t: float, x: float, v_minus: float, w_minus: float, u: float) -> None:
        """Apply eq. 16-17 at time t; close a Zeno sequence with a plastic impact."""
        m, M, e = self.m, self.M, self.e
        v_plus, w_plus = impact(v_minus, w_minus, m, M, e)
        if e > 0.0:
            a_x, a_z = self._free_accels(x, v_plus, w_plus, u)
            lam = contact_force(a_x, a_z, m, M)
            if lam > 0.0:
                # next bounce lasts ~ 2 s / |g''| (opening speed s, |g''| = lam / mu); a Zeno
                # sequence (e < 1) ends after ~ that / (1 - e)
                bounce = 2.0 * (v_plus - w_plus) * self.mu / lam
                if bounce < self.chatter_time or bounce < ZENO_TIME * (1.0 - e):
                    e = 0.0
                    v_plus, w_plus = impact(v_minus, w_minus, m, M, 0.0)
        if e == 0.0:
            w_plus = v_plus  # exactly together
        impulse = impact_impulse(v_minus, v_plus, m)
        self.impacts.append(Impact(t, x, v_minus, w_minus, v_plus, w_plus, impulse, e))
        self.pending_impulse += impulse
        self._begin(t, x, v_plus, x, w_plus, u)

    # marching -----------------------------------------------------------------------------------
    def advance_to(self, t_end: float, u: float) -> float:
        if u != self.u:  # zero-order hold: a new flow speed re-anchors the closed forms here
            x, v, z, w = self.seg.state(self.tau)
            if self.seg.kind == "stick":
                z, w = x, v
            elif x - z < 0.0:  # rounding below contact at the old anchor: treat as contact
                z = x
            self._begin(self.state.t, x, v, z, w, u)
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
            x, v, z, w = seg.state(tau_event)
            t_event = seg.t0 + tau_event
            if seg.kind == "flight":
                self._begin(t_event, x, v, x, w, u)  # impact, or a touch without speed
            else:  # contact force turns tensile: separate with equal velocities
                a_x, a_z = self._free_accels(x, v, v, u)
                self._fly_from_contact(t_event, x, v, v, u, contact_force(a_x, a_z, self.m, self.M))
            impulse += self.pending_impulse
            self.pending_impulse = 0.0
        x, v, z, w = self.seg.state(self.tau)
        self.state = State(t_end, x, v, z, w)
        return impulse
