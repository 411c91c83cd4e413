"""Method 3, ODE: the general path, ``scipy.integrate.solve_ivp`` with the gap as an event.

This is the integration a user would write by hand. In flight the state ``[x, v, z, w]`` obeys
``m x'' + c x' + k x = 0`` (eq. 8; with the Morison terms on the structure, m is m + m_a and the
drag F_s(x') is on the right, docs/explanation/morison.md) and ``M w' = F_drag(w)`` (linearised,
eq. 4-5, or
quadratic, eq. 2-3 and 31-32); the gap ``g = x - z`` is a terminal event with direction -1
(eq. 25: the bodies meet). At the event the impact law of eq. 12-17
(:func:`iceimpact.physics.contact.impact`) gives the new velocities; positions do not jump
(eq. 18) and the flight restarts from there.

The integrator is ``solver.ode_method`` (1 = RK45, 2 = DOP853, 3 = LSODA, 4 = Radau) with
``rtol = solver.rtol`` and ``atol = rtol * 1e-3`` (m, m/s: displacements of the article's scenes
are of the order of a millimetre). The implicit ones (LSODA, Radau) are given the exact Jacobian
of each right-hand side (its ``jacobian``, from the drag laws' ``force_rate``) instead of
estimating it by finite differences; Radau's own limits on omega_n and rtol are in
:func:`iceimpact.limits.omega_limit` and ``RADAU_RTOL_MIN``.

Sticking follows the contact rules shared with the exact solver
(:mod:`iceimpact.solvers.contact_rules`, with its :data:`INTEGRATED_POLICY`), in place of the
article's steady-state thresholds (eq. 27-29):

- after an impact that leaves the ice pressed on the structure (contact force lam > 0): with
  e = 1 a next bounce shorter than the chatter time (``solver.chatter_fraction`` of the
  structure's period) is closed by one plastic impact; with e < 1 the Zeno sequence is followed
  to its end, or closed at its estimated end where it would exceed ``ZENO_BUDGET`` bounces or
  its bounces are no higher than the positions' noise (10 atol + 10 rtol |x|); a contact that
  parts too slowly for a resolvable bounce (the rounding left of a separation) sticks;
- the bodies then move together, ``(m + M) x'' + c x' + k x = F_drag(x')``, integrated with the
  same method, the contact force ``lam = F_drag(x') - M x''`` being a terminal event (direction -1):
  they separate when it turns tensile. The drag impulse is integrated alongside, so the impulse of
  the contact force over a step is exact to the tolerance.

Each ``solve_ivp`` call covers at most a chunk of :data:`CHUNK_PERIODS` structure periods (and
:data:`CHUNK_MAX` seconds, and :data:`CHUNK_RATE` / rate for the stiffest rate integrated, so
that a chunk costs a bounded number of steps) from the start of the segment, and its dense
output answers the communication steps inside it, so the result does not depend on the
communication step (unless the flow speed changes, which restarts the integration at the
change). A segment's first call spans one period of the structure (after a flow change: the
step being taken, if shorter), and each next one twice the previous, up to the chunk: a segment
that an impact ends early, or a flow changing at every step, costs work in proportion to its own
length, not a whole chunk. The explicit integrators' steps are bounded
by :data:`STABLE_STEP` / rate, inside their stability intervals, so that states far below the
absolute tolerance do not ring through the ice. Work is bounded: every impact either
lasts a resolvable bounce or ends the bouncing, and repeated events at one instant (a degenerate
contact, or integration noise at a loose tolerance) make the bodies stick.

With the modal structure (structure.model = 3) the integrated state is the modes' instead of
``[x, v]`` (:mod:`~iceimpact.solvers.ode_modal`), and the contact logic here sees the contact
point through :meth:`OdeSolver._contact_view`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import DOP853, solve_ivp
from scipy.optimize import brentq

from ..errors import SolverError, StateError
from ..limits import TIME_RESOLUTION, integrated_rate
from ..physics.ice import make_drag
from ..physics.structure import Oscillator
from ..record import Record
from ..scene import Scene
from .base import State
from .contact_rules import (
    INTEGRATED_POLICY,
    ZENO_RESOLUTION,
    ContactRules,
    Outcome,
    Phase,
    Together,
    make_together,
    reanchor_on_flow_change,
)
from .march import EventMarch

#: Events at one instant before the bodies are held together briefly (a degenerate contact).
MAX_EVENTS_AT_ONE_INSTANT = 8

#: solve_ivp methods by ``solver.ode_method``.
ODE_METHODS = {1: "RK45", 2: "DOP853", 3: "LSODA", 4: "Radau"}

#: A parting speed below PARTING_NOISE times the velocities' tolerance (rtol |v| + atol) is
#: integration noise (contact_rules.ContactPolicy.stick_slow_parting).
PARTING_NOISE = 10.0

#: atol = rtol * ATOL_SCALE for every component (m, m/s, and N.s for the integrated drag impulse).
ATOL_SCALE = 1e-3

#: Length of one solve_ivp call, in natural periods of the structure (at least 1 s).
CHUNK_PERIODS = 20.0
#: ... and at most this long (s): a chunk is integrated whole even when the run ends early in it,
#: and a slow structure with a stiff drag (b/M >> omega_n) makes each second of it costly for the
#: explicit integrators (94 s chunks took 40 s for a 1 s run).
CHUNK_MAX = 5.0

#: ... and at most CHUNK_RATE / rate (s), rate being the fastest relaxation rate the segment
#: integrates (:func:`iceimpact.limits.integrated_rate`: c / m, the drag rates): near their
#: stability bound the explicit integrators take ~3.3 / rate to ~6 / rate per step, so a chunk
#: is at most ~600 steps, ~0.06 s of CPU (3e-5 s x rate per simulated second), however slow the
#: structure. A slow structure with a stiff drag integrated whole chunks of 5 s ahead of a run
#: that needed 0.01 s of them (a 4 g floe, b/M = 1.4e5 1/s, stuck for 10 s of CPU). Scenes with
#: rates below CHUNK_RATE / CHUNK_MAX = 400 1/s (the article's: 0.13 1/s) keep their chunks.
CHUNK_RATE = 2000.0

#: The explicit integrators' steps are at most STABLE_STEP[method] / rate, rate being
#: the fastest relaxation rate integrated (:func:`~iceimpact.limits.integrated_rate`, the
#: quadratic drags' at the speeds of the call's start, see ``OdeSolver._max_step``): inside
#: each method's stability interval on the negative real axis (about 3.3 for RK45, 6 for
#: DOP853). Where the states are far below the absolute tolerance (a structure at rest to
#: 1e-24 m), the error control alone let DOP853's steps grow 100-fold past that bound; the
#: unstable steps' dense output rang up to 25 times the tolerance, the structure 2.5e-10 m past
#: the ice (a critically damped structure, c / m = 7.9e3 1/s, steps of 1e-2 s). Only the
#: explicit methods (these keys) are bounded.
STABLE_STEP = {"RK45": 3.0, "DOP853": 5.0}

#: Positive stand-in for a zero event value at the start of a segment.
_TINY = 1e-300

#: Length of the integrated state by phase: [x, v, z, w] in flight, [x, v, drag impulse] stuck.
_SIZE = {Phase.FLIGHT: 4, Phase.STICK: 3}


class _Flight:
    """Both bodies free: ``[x, v, z, w]' = [v, -(c v + k x) / m, w, F_drag(w) / M]`` (eq. 2-8)."""

    def __init__(self, solver: OdeSolver):
        self.m, self.c, self.k, self.M = solver.m, solver.c, solver.k, solver.M
        self.u, self.drag = solver.u, solver.drag

    def __call__(self, t: float, y: np.ndarray) -> list[float]:
        return [y[1], -(self.c * y[1] + self.k * y[0]) / self.m, y[3],
                self.drag.force(y[3], self.u) / self.M]

    def structure_damping(self, v: float) -> float:
        """d(m x'')/dx' of the structure, kg/s: -c."""
        return -self.c

    def jacobian(self, t: float, y: np.ndarray) -> list[list[float]]:
        """d(:meth:`__call__`)/dy, for the implicit integrators: exact, the drags' dF/dw from
        their ``force_rate`` (-b for eq. 4-5, -2 B |w - u| for eq. 2-3)."""
        return [[0.0, 1.0, 0.0, 0.0],
                [-self.k / self.m, self.structure_damping(y[1]) / self.m, 0.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
                [0.0, 0.0, 0.0, self.drag.force_rate(y[3], self.u) / self.M]]


class _DraggedFlight(_Flight):
    """Flight with the Morison drag on the structure (docs/explanation/morison.md):
    ``m x'' = F_s(x') - c x' - k x``, m being m + m_a."""

    def __init__(self, solver: OdeSolver):
        super().__init__(solver)
        self.structure_drag = solver.structure_drag

    def __call__(self, t: float, y: np.ndarray) -> list[float]:
        f_s = self.structure_drag.force(y[1], self.u)
        return [y[1], (f_s - self.c * y[1] - self.k * y[0]) / self.m, y[3],
                self.drag.force(y[3], self.u) / self.M]

    def structure_damping(self, v: float) -> float:
        return self.structure_drag.force_rate(v, self.u) - self.c


class _Gap:
    """Terminal event: the gap x - z closes (eq. 25), or, with a ``slack`` (m), falls below
    -slack (a flight that starts from contact under integration noise, see ``OdeSolver._begin``)."""

    terminal = True
    direction = -1

    def __init__(self, start: float, slack: float = 0.0):
        self.start, self.slack = start, slack

    def __call__(self, t: float, y: np.ndarray) -> float:
        # at the start the bodies may touch (g = 0): count that as open, so that only a crossing
        # after the start is an event (and the root bracket stays valid)
        gap = y[0] - y[2] + self.slack
        # after the start, only a negative gap is a crossing: bodies touching at exactly zero
        # gap (positions underflowed to 0 while the speeds, 1e-319 m/s, part them) are not
        # meeting; each such touch was an event, ~1e5 a second
        return gap if t > self.start and gap != 0.0 else max(gap, _TINY)


class _ContactForce:
    """Terminal event: the contact force turns tensile (the bodies separate)."""

    terminal = True
    direction = -1

    def __init__(self, together: Together, start: float):
        self.together, self.start = together, start

    def __call__(self, t: float, y: np.ndarray) -> float:
        lam = self.together.contact_force(y)
        # a contact force of exactly zero is not tensile (nothing pulls the bodies apart, e.g.
        # both at rest with no flow): only a negative one separates them
        return lam if t > self.start and lam != 0.0 else max(lam, _TINY)


class _DOP853(DOP853):
    """scipy's DOP853, its error norm's 0 / 0 taken for what it is. The norm is err5^2 /
    sqrt(err5^2 + 0.01 err3^2): with the states some 1e-160 of the tolerance (a damped
    structure decayed to 5e-167 m), err5^2 underflows to 0 and 0.01 err3^2 too, and the NaN
    rejected a step whose error is below any double (a RuntimeWarning, the step retried at a
    fifth). That error is 0; a NaN from non-finite stages still rejects the step."""

    def _estimate_error_norm(self, K, h, scale):
        with np.errstate(invalid="ignore"):  # the one 0 / 0, handled below
            norm = super()._estimate_error_norm(K, h, scale)
        if norm == norm or not np.isfinite(K).all():
            return norm
        return 0.0


#: the integrator classes solve_ivp is given, by solver.ode_method's name (others: the name)
_INTEGRATORS = {"DOP853": _DOP853}


def _same_instant(t: float, t_ref: float) -> bool:
    """Events this close (s) are one instant: what separates them is rounding."""
    return abs(t - t_ref) <= 1e-12 * max(1.0, abs(t))


def _floats(y) -> list[float]:
    return [float(c) for c in y]


class OdeSolver(EventMarch):
    """scipy ``solve_ivp`` with gap and contact-force events (method 3)."""

    name = "ode"

    @property
    def penetration_cause(self) -> str:
        return (f"the ODE method's positions carry its integration error (absolute tolerance "
                f"{ATOL_SCALE:g} solver.rtol = {self.atol:.3g} m, exceeded a few times at most)")

    def __init__(self, scene: Scene, record_impacts: bool = True):
        super().__init__(scene, record_impacts)
        self.method = ODE_METHODS[scene.solver_ode_method]
        self.rtol = scene.solver_rtol
        self.atol = self.rtol * ATOL_SCALE
        self.osc = Oscillator(self.m, self.c, self.k)
        self.drag = make_drag(scene)
        # a parting within 10 times the velocities' tolerance is integration noise, and so is
        # a bounce no higher than 10 times the positions' (a Zeno sequence is closed there)
        self.rules = ContactRules(self.m, self.M, scene.omega_n, self._free_accels,
                                  INTEGRATED_POLICY, scene.solver_chatter_fraction,
                                  (PARTING_NOISE * self.rtol, PARTING_NOISE * self.atol),
                                  time_resolution=ZENO_RESOLUTION * TIME_RESOLUTION,
                                  gap_noise=(PARTING_NOISE * self.rtol, PARTING_NOISE * self.atol))
        #: the estimated end of the bounces of a Zeno sequence closed before it (s): the bodies
        #: move together until then, not yet sticking; None otherwise (as the exact method's)
        self.zeno_end: float | None = None
        self.period = 2.0 * math.pi / scene.omega_n
        self.u = scene.flow_u
        self._set_chunks(self.u)
        self.pending_impulse = 0.0
        self.nfev = 0                   # right-hand-side evaluations since the start
        # the step's evaluations (those of its chunks that end before the step does) and the
        # most it may make (solver.max_evaluations; none outside a step)
        self.step_evaluations = 0
        self.evaluation_budget = math.inf
        self._events_here = 0
        self._last_event_t = -math.inf
        s = self.state
        self.first_span = self.first_chunk  # length of a segment's first solve_ivp call, s
        self._begin(0.0, s.x, s.v, s.z, s.w)

    def _chunks(self, u: float) -> tuple[float, float]:
        """Length of a solve_ivp chunk and of a segment's first call (s) at flow speed u: 20
        periods of the structure (at least 1 s, at most CHUNK_MAX), and at most CHUNK_RATE / rate
        for the stiffest rate integrated; a segment's first call spans one period, then each next
        one twice the previous, up to the chunk: a segment that an impact ends early costs about
        its own length, not a chunk."""
        chunk = min(max(1.0, CHUNK_PERIODS * self.period), CHUNK_MAX)
        rate = integrated_rate(self.scene, u)
        if rate > 0.0:
            chunk = min(chunk, CHUNK_RATE / rate)
        return chunk, min(self.period, chunk)

    def _set_chunks(self, u: float) -> None:
        self.chunk, self.first_chunk = self._chunks(u)

    def _max_step(self, y: np.ndarray) -> float:
        """Largest step of an explicit integrator for a call starting from y (s): STABLE_STEP
        over the fastest relaxation rate about the states the integration can fall below its
        tolerance at, so that such states decay instead of ringing through the ice.

        - Quadratic drags: their rates at the speeds relative to the flow at the call's start
          (sticking: 2 B |v - u| / (m + m_a + M); the structure's Morison drag in flight:
          2 B_s |v - u| / (m + m_a)): bodies pushed at a steady speed have that rate however
          small their motion about it.
        - Sticking: the dampings act on the whole moving mass m + m_a + M
          (``integrated_rate(..., together=True)``), not on the flight's masses, which are
          thousands of times stiffer for a light floe
          (docs/explanation/robustness/ode.md#holds-in-spans).
        - In flight the ice's quadratic drag is left out: its rate 2 B |w - u| / M vanishes where
          the ice meets the flow, the only place its motion falls below the tolerance, and
          above it the error control sees the unstable step itself
          (docs/explanation/robustness/ode.md#explicit-step-bounds).

        A function of the call's start, so that a restored snapshot integrates its chunk again
        identically."""
        if self.method not in STABLE_STEP:
            return math.inf
        speed = abs(float(y[1]) - self.u)
        if self.phase is Phase.FLIGHT:
            rate = integrated_rate(self.scene, self.u, 0.0, speed)
        else:
            rate = integrated_rate(self.scene, self.u, speed, together=True)
        return STABLE_STEP[self.method] / rate if rate > 0.0 else math.inf

    def _free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        a_x = self.osc.acceleration(x, v)
        if self.structure_drag is not None:
            a_x += self.structure_drag.force(v, u) / self.m
        return a_x, self.drag.force(w, u) / self.M

    # the integrated state ------------------------------------------------------------------------
    def _size(self, phase: Phase) -> int:
        """Length of the integrated state of a segment of ``phase``."""
        return _SIZE[phase]

    def _contact_view(self, y):
        """The contact's view of an integrated state: ``[x, v, z, w]`` in flight, ``[x, v, P]``
        sticking (here the state itself; the modal structure's sums its modes)."""
        return y

    @staticmethod
    def _gap_rate(state):
        """The gap's rate v - w in flight (rows of arrays: element by element)."""
        return state[1] - state[3]

    # segments ------------------------------------------------------------------------------------
    def _equations(self, phase: Phase, start: float, gap_slack: float = 0.0) -> None:
        """Right-hand side and terminal event of a segment of ``phase`` starting at ``start``
        (a flight's gap event at -``gap_slack``)."""
        self.phase, self.segment_start, self.gap_slack = phase, start, gap_slack
        if phase is Phase.FLIGHT:
            flight = _Flight if self.structure_drag is None else _DraggedFlight
            self.rhs, self.event_fn = flight(self), _Gap(start, gap_slack)
        else:
            self.rhs = make_together(self.m, self.c, self.k, self.M, self.drag, self.u,
                                     inertia_from_net=True, structure_drag=self.structure_drag)
            self.event_fn = _ContactForce(self.rhs, start)

    def _segment(self, phase: Phase, t: float, y: list[float], hold: float = 0.0,
                 gap_slack: float = 0.0) -> None:
        """Start a flight ``[x, v, z, w]`` or a sticking phase ``[x, v, drag impulse]`` at t;
        a sticking phase ignores separation for ``hold`` seconds; a flight's gap event is at
        -``gap_slack``."""
        self._equations(phase, t, gap_slack)
        self.t_lo = self.t_hi = t
        self.y_hi = np.array(y, dtype=float)
        self.y_now = self.y_hi.copy()
        self.y_lo: np.ndarray | None = None   # start of the integrated chunk (none yet)
        self.chunk_hi = t                     # where its solve_ivp call was asked to end
        self.first_span = self.first_chunk    # (advance_to shortens it after a flow change)
        self.sol = None                       # its dense output
        self.event: tuple[float, np.ndarray] | None = None
        # a forced hold ignores the separation event for a while
        self.hold_until = t + hold if hold > 0.0 else -math.inf
        self._set_sticking(phase is Phase.STICK, t)

    def _next_span(self) -> float:
        """Length of the next solve_ivp call of the segment (s): the first span, then twice
        the previous call's, up to the chunk."""
        if self.y_lo is None:
            return self.first_span
        return min(2.0 * (self.chunk_hi - self.t_lo), self.chunk)

    def _integrate(self, lo: float, y_lo: np.ndarray, hi: float):
        """One solve_ivp call from (lo, y_lo) to hi; within a forced hold, without the event
        and at most to the hold's end. A hold is integrated in the segment's spans like any
        other time, not whole: a flow change may discard what lies ahead
        (docs/explanation/robustness/ode.md#holds-in-spans)."""
        events = self.event_fn
        if lo < self.hold_until:
            hi, events = min(hi, self.hold_until), None
        implicit = {} if self.method in STABLE_STEP else {"jac": self.rhs.jacobian}
        integrator = _INTEGRATORS.get(self.method, self.method)
        res = solve_ivp(self.rhs, (lo, hi), y_lo, method=integrator, rtol=self.rtol,
                        atol=self.atol, dense_output=True, events=events,
                        max_step=self._max_step(y_lo), **implicit)
        if res.status == -1:
            raise SolverError(f"ODE integration ({self.method}) failed at t = {lo}: "
                              f"{res.message}")
        return res, hi, events

    def begin_step(self, start: float | None = None) -> None:
        """The step's budgets: the impacts' (:meth:`Solver.begin_step`) and the integrator's,
        ``solver.max_evaluations`` right-hand-side evaluations (:meth:`_extend`)."""
        super().begin_step(start)
        self.step_evaluations = 0
        self.evaluation_budget = self.scene.solver_max_evaluations

    def end_step(self) -> None:
        super().end_step()
        self.evaluation_budget = math.inf

    def _extend(self, t_end: float) -> None:
        """Integrate one more chunk of the current segment (stops at its event), for a step to
        ``t_end``. A chunk that ends before t_end counts against the step's budget, and the one
        beyond the budget refuses the step (the simulator restores the state before it). The
        chunk that reaches past t_end is not counted: it integrates ahead for the steps after
        (a chunk is at most 20 periods or CHUNK_RATE / rate long), so a step short enough to end
        inside its chunk always goes on."""
        lo = self.t_hi
        res, hi, events = self._integrate(lo, self.y_hi, lo + self._next_span())
        self.nfev += res.nfev
        self.sol, self.t_lo, self.y_lo, self.chunk_hi = res.sol, lo, self.y_hi, hi
        if events is None and hi == self.hold_until:
            # end of a forced hold: the contact logic decides again
            self.event = (hi, res.y[:, -1])
            self.t_hi, self.y_hi = hi, res.y[:, -1]
        else:
            hidden = self._hidden_event(res) if events is not None else None
            if hidden is not None:
                y_ev = res.sol(hidden)
                self.event = (hidden, y_ev)
                self.t_hi, self.y_hi = hidden, y_ev
            elif res.status == 1:
                t_ev = float(res.t_events[0][0])
                self.event = (t_ev, res.y_events[0][0])
                self.t_hi, self.y_hi = t_ev, res.y_events[0][0]
            else:
                self.t_hi, self.y_hi = hi, res.y[:, -1]
        if self.t_hi < t_end:
            self.step_evaluations += res.nfev
            if self.step_evaluations > self.evaluation_budget:
                raise SolverError(self._over_budget(self.t_hi, "solver.max_evaluations",
                                                    "evaluations", "the budget spent by"))

    def _hidden_event(self, res) -> float | None:
        """The first event of the segment inside one integrator step that scipy's event test
        cannot see (s), or None (docs/explanation/robustness/ode.md#hidden-meeting). solve_ivp
        tests the
        event's sign at the ends of its steps only, so a dip below zero that starts and ends
        within one step goes unseen: in flight, the gap (the ice would pass through the
        structure); sticking, the contact force (a pull held through). Such a dip has
        its lowest point inside the step, where the event's rate turns from negative to
        positive (in flight v - w, sticking :meth:`Together.contact_force_rate`); so wherever
        it changes sign that way between two step ends (before scipy's own event, if any), the
        lowest point is found on the dense output (brentq on the rate), and if the event is
        negative there, the event is its first root before it (brentq, scipy's tolerance for
        events). A function of the call's steps, so that a restored snapshot finds the same."""
        t, y = res.t, res.y
        end = len(t) - 1
        if res.status == 1:  # scipy's event ends the call: only dips before it
            end = int(np.searchsorted(t, float(res.t_events[0][0]), side="left")) - 1
        if end < 1:
            return None
        rate = self._gap_rate if self.phase is Phase.FLIGHT else self.rhs.contact_force_rate
        rates = rate(y[:, :end + 1])
        candidates = np.flatnonzero((rates[:end] < 0.0) & (rates[1:] > 0.0))
        if not len(candidates):
            return None
        sol, event, start = res.sol, self.event_fn, self.segment_start
        tol = 4.0 * np.finfo(float).eps
        for i in candidates.tolist():
            lo, hi = float(t[i]), float(t[i + 1])
            lowest = brentq(lambda s: float(rate(sol(s))), lo, hi, xtol=tol, rtol=tol)
            if lowest <= start or not event(lowest, sol(lowest)) < 0.0:
                continue
            if not event(lo, sol(lo)) > 0.0:  # (scipy saw no crossing at the step's ends)
                return lo
            return brentq(lambda s: event(s, sol(s)), lo, lowest, xtol=tol, rtol=tol)
        return None

    def _y(self, t: float) -> np.ndarray:
        if t >= self.t_hi or self.y_lo is None:
            return self.y_hi
        if self.sol is None:  # restored from a snapshot: the same call gives the same output
            self.sol = self._integrate(self.t_lo, self.y_lo, self.chunk_hi)[0].sol
        return self.sol(t)

    def _begin(self, t: float, x: float, v: float, z: float, w: float,
               reanchor: bool = False, after_impact: bool = False) -> None:
        """Start the segment that follows time t from state (x, v, z, w) (contact rules of
        :mod:`~iceimpact.solvers.contact_rules` with :data:`INTEGRATED_POLICY`; ``reanchor``:
        after a change of the flow speed, which is no event; ``after_impact``: the velocities
        after an impact, an event, but no contact re-forming:
        docs/explanation/robustness/contact.md#contact-after-impact)."""
        if not reanchor:
            if _same_instant(t, self._last_event_t):
                self._events_here += 1
            else:
                self._events_here, self._last_event_t = 0, t
        if x - z > 0.0:
            self._segment(Phase.FLIGHT, t, [x, v, z, w])
            return
        if self._events_here > MAX_EVENTS_AT_ONE_INSTANT and not reanchor:
            # degenerate contact or integration noise (events repeating at one instant): plastic
            # contact, so that the work stays bounded (the next segment would meet the same
            # noise event again). While the contact force pushes, the bodies are held together
            # for a moment; while it pulls they fly apart (a contact only pushes), the gap event
            # set below the noise of the positions (10 times their tolerance): a real contact
            # is met there, within the method's penetration tolerance
            v_common, impulse = self.rules.plastic_merge(v, w)
            self.pending_impulse += impulse
            lam = self.rules.free_contact_force(x, v_common, v_common, self.u)
            if self.rules.tensile(lam, x, v_common, v_common, self.u):
                slack = PARTING_NOISE * (self.atol + self.rtol * abs(x))
                self._segment(Phase.FLIGHT, t, [x, v_common, x, v_common], gap_slack=slack)
            else:
                self._segment(Phase.STICK, t, [x, v_common, 0.0], hold=self.rules.chatter_time)
            return
        decision = self.rules.at_contact(t, x, v, w, self.u, reanchor or after_impact)
        if decision.outcome is Outcome.IMPACT:
            self._impact(t, x, v, w)
        elif decision.outcome is Outcome.STICK:
            self.pending_impulse += decision.impulse
            self._segment(Phase.STICK, t, [x, decision.v, 0.0], hold=decision.hold)
        else:
            self._segment(Phase.FLIGHT, t, [x, v, x, w])

    def _impact(self, t: float, x: float, v_minus: float, w_minus: float) -> None:
        """The impact step (eq. 16-18, chatter and Zeno closure) at time t; what follows: a
        Zeno sequence closed before its end moves the bodies together to its estimated end,
        where sticking starts (the exact method's rule, EventSolver._zeno_tail)."""
        impact = self.rules.impact(t, x, v_minus, w_minus, self.e, self.u)
        self._record(impact)
        self.pending_impulse += impact.impulse
        self._begin(t, x, impact.v_plus, x, impact.w_plus, after_impact=True)
        end = self.rules.take_accumulation()
        if end is not None and self.phase is Phase.STICK and end > t:
            self._set_sticking(False, t)
            self.zeno_end = end

    # marching (the loop is solvers/march.py's) --------------------------------------------------
    def reanchor(self, u: float, t_end: float) -> None:
        """Zero-order hold: restart the integration at the change, from the current segment's
        state (y_now, which follows any event at this time: self.state is the last reported
        one, before an impact at t = 0)."""
        t = self.state.t
        y = [float(c) for c in self._contact_view(self.y_now)]
        sticking = self.phase is Phase.STICK
        self.u = u
        self._set_chunks(u)
        x, v, z, w = reanchor_on_flow_change(*(y[:2] * 2 if sticking else y), sticking)
        end, self.zeno_end = self.zeno_end, None
        self._begin(t, x, v, z, w, reanchor=True)
        if end is not None and self.phase is Phase.STICK:  # a Zeno tail goes on to its end
            self._set_sticking(False, t)
            self.zeno_end = end
        # the flow may change again at the next step: integrate ahead by this step only
        # (doubling from there), not a whole chunk
        self.first_span = min(self.first_chunk, t_end - t)

    def next_event(self, t_end: float) -> tuple[float, np.ndarray] | None:
        end = self.zeno_end
        if end is not None and end <= t_end:  # the end of a Zeno tail, unless parted before
            while self.event is None and self.t_hi < end:
                self._extend(end)
            if self.event is None or self.event[0] > end:
                return end, self._y(end)
        while self.event is None and self.t_hi < t_end:
            self._extend(t_end)
        if self.event is not None and self.event[0] <= t_end:
            return self.event
        return None

    def event_time(self, event: tuple[float, np.ndarray]) -> float:
        return event[0]

    def impulse_to(self, event: tuple[float, np.ndarray]) -> float:
        if self.phase is Phase.STICK:
            return self.rhs.impulse(self.y_now, event[1])
        return 0.0

    def at_event(self, event: tuple[float, np.ndarray]) -> None:
        t_ev, y_ev = event
        view = self._contact_view(y_ev)
        if self.phase is Phase.STICK:
            x, v = float(view[0]), float(view[1])
            if self.zeno_end == t_ev and event is not self.event:
                # the end of a Zeno tail: the bodies, together already, start sticking
                self.y_now = np.array(y_ev, dtype=float)
                self.zeno_end = None
                self._set_sticking(True, t_ev)
                return
            self.zeno_end = None
            if self.hold_until == t_ev:
                self._begin(t_ev, x, v, x, v)
            else:  # contact force turns tensile: separate with equal velocities
                self._segment(Phase.FLIGHT, t_ev, [x, v, x, v])
        else:
            x, v, w = float(view[0]), float(view[1]), float(view[3])
            if w > v:
                self._impact(t_ev, x, v, w)
            else:  # touch without closing speed: the contact logic decides
                self._begin(t_ev, x, v, x, w)

    def finish(self, t_end: float) -> float:
        y = self._y(t_end)
        view = self._contact_view(y)
        impulse = 0.0
        if self.phase is Phase.STICK:
            impulse = self.rhs.impulse(self.y_now, y)
            self.state = State(t_end, float(view[0]), float(view[1]), float(view[0]),
                               float(view[1]))
        else:
            self.state = State(t_end, *(float(c) for c in view))
        self.y_now = np.array(y, dtype=float)
        return impulse

    # snapshots ----------------------------------------------------------------------------------
    _KEYS = ("u", "pending_impulse", "nfev", "events_here", "last_event_t", "degenerate",
             "zeno_end", "phase", "segment_start", "hold_until", "t_lo", "t_hi", "y_lo",
             "y_hi", "y_now", "event", "first_span", "chunk_hi", "gap_slack")

    def _snapshot(self) -> dict[str, Any]:
        return {"u": self.u, "pending_impulse": self.pending_impulse, "nfev": self.nfev,
                "events_here": self._events_here, "last_event_t": self._last_event_t,
                "degenerate": self.rules.degenerate.snapshot(), "zeno_end": self.zeno_end,
                "phase": self.phase.value,
                "segment_start": self.segment_start, "hold_until": self.hold_until,
                "t_lo": self.t_lo, "t_hi": self.t_hi,
                "y_lo": None if self.y_lo is None else _floats(self.y_lo),
                "y_hi": _floats(self.y_hi), "y_now": _floats(self.y_now),
                "event": None if self.event is None else [self.event[0],
                                                          _floats(self.event[1])],
                "first_span": self.first_span, "chunk_hi": self.chunk_hi,
                "gap_slack": self.gap_slack}

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        u = rec.real("u")
        pending = rec.real("pending_impulse")
        nfev = rec.integer("nfev", low=0)
        events_here = rec.integer("events_here", low=0)
        last_event_t = rec.real("last_event_t", finite=False, high=t)
        degenerate = self.rules.degenerate.read(rec.record("degenerate"))
        zeno_end = rec.real("zeno_end", low=t, allow_none=True)
        if zeno_end is not None and rec.data["sticking"]:
            raise StateError(rec.field("zeno_end"), zeno_end, "null while sticking is true")
        phase = Phase(rec.text("phase", [p.value for p in Phase]))
        if (phase is Phase.STICK) != (rec.data["sticking"] or zeno_end is not None):
            raise StateError(rec.field("phase"), phase.value,
                             "stick exactly when sticking is true or zeno_end is a time")
        size = self._size(phase)
        start = rec.real("segment_start", low=0.0, high=t)
        hold_until = rec.real("hold_until", finite=False, high=math.inf)
        t_lo = rec.real("t_lo", low=start)
        t_hi = rec.real("t_hi", low=t_lo)
        chunk = self._chunks(u)[0]
        first_span = rec.real("first_span", low=0.0, high=chunk)
        if first_span == 0.0:
            raise StateError(rec.field("first_span"), first_span, f"in (0, {chunk!r}] s")
        chunk_hi = rec.real("chunk_hi", low=t_lo)
        gap_slack = rec.real("gap_slack", low=0.0)
        y_lo = rec.reals("y_lo", size, allow_none=True)
        y_hi = rec.reals("y_hi", size)
        y_now = rec.reals("y_now", size)
        event = rec.raw("event")
        if event is not None:
            ev = Record({"t": event[0], "y": event[1]} if isinstance(event, list | tuple)
                        and len(event) == 2 else event, rec.field("event"))
            event = (ev.real("t", low=t_hi, high=t_hi), np.array(ev.reals("y", size)))

        def apply() -> None:
            self.u = u
            self._set_chunks(u)
            self._equations(phase, start, gap_slack)
            self.pending_impulse, self.nfev = pending, nfev
            self._events_here, self._last_event_t = events_here, last_event_t
            self.rules.degenerate.set(degenerate)
            self.zeno_end = zeno_end
            self.hold_until, self.t_lo, self.t_hi = hold_until, t_lo, t_hi
            self.first_span, self.chunk_hi = first_span, chunk_hi
            self.y_lo = None if y_lo is None else np.array(y_lo)
            self.sol = None
            self.y_hi, self.y_now = np.array(y_hi), np.array(y_now)
            self.event = event
        return apply
