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
quadratic drag with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12). They separate when the
contact force would turn tensile.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..physics.ice import downstream_speed_bound, make_drag
from ..physics.structure import Oscillator
from ..scene import Scene
from .base import Solver, SolverError, State
from .contact_rules import (
    EXACT_POLICY,
    ContactRules,
    Outcome,
    Phase,
    Together,
    reanchor_on_flow_change,
    separates,
    sticking_contact_force,
)
from .rootfind import RootSearch
from .state import Record, StateError

#: Tolerances of the ODE integration of the quadratic-drag sticking phase.
STICK_RTOL = 1e-12
STICK_ATOL = (1e-15, 1e-15, 1e-12)  # x (m), v (m/s), drag impulse (N.s)

#: Rounding of a gap evaluated from positions of magnitude X is below GAP_ULPS * X (m).
GAP_ULPS = 16.0 * 2.0 ** -52

#: At most this many integration chunks of a quadratic-drag sticking phase are saved in a
#: snapshot (those the future can ask for: one, or two at a chunk boundary).
_MAX_CHUNKS = 8


def _time_eps(t: float) -> float:
    return 8.9e-16 * max(1.0, abs(t))


class _SearchedSegment:
    """Snapshot of a segment given in closed form from its anchor, with a root search: the
    anchor values named by ``ANCHOR``, the search start and its frontier (Flight, LinearStick)."""

    ANCHOR: tuple[str, ...] = ()

    def snapshot(self, tau: float) -> dict[str, Any]:
        return {"phase": self.phase.value, "t0": self.t0,
                "anchor": [getattr(self, name) for name in self.ANCHOR], "start": self.start,
                "search": self.search.frontier()}

    @classmethod
    def read(cls, solver: EventSolver, rec: Record, u: float) -> Callable[[], Any]:
        """Validate a :meth:`snapshot` record; return the function that builds the segment."""
        rec.expect_keys(("phase", "t0", "anchor", "start", "search"))
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

    phase = Phase.FLIGHT
    ANCHOR = ("x0", "v0", "z0", "w0")

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, z0: float,
                 w0: float, u: float, start: float = 0.0):
        self.osc = solver.osc
        self.drag = solver.drag
        self.t0, self.x0, self.v0, self.z0, self.w0, self.u = t0, x0, v0, z0, w0, u
        self.start = start
        self.gap0 = x0 - z0
        self.search = RootSearch(self.probe, self.gap, start, _time_eps(t0), self.clearance)

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

    def clearance(self, tau: float) -> float:
        """Time from tau (s) during which the gap provably stays open, from the structure's
        envelope: the free structure never goes below ``offset - R``, R its amplitude bound
        (its energy never grows, eq. 8-10), and the ice moves downstream no faster than
        :func:`~iceimpact.physics.ice.downstream_speed_bound`. So the gap stays above
        ``offset - R - z(tau) - speed s`` (beyond the rounding of the positions).

        A stiff structure ringing with a large amplitude while the ice is still outside its
        reach costs the Taylor steps of the root search a few evaluations per period (its bound
        on the gap's curvature is omega_n^2 R); this spans those periods at once."""
        dx, v = self.osc.displacement_change(self.x0, self.v0, tau)
        dz, w = self.drag.displacement_change(self.w0, self.u, tau)
        x, z = self.x0 + dx, self.z0 + dz
        offset = self.osc.offset
        reach = self.osc.amplitude_bound(x - offset, v)
        margin = (offset - reach - z) - GAP_ULPS * (abs(x) + abs(z) + reach + abs(offset))
        if margin <= 0.0:
            return 0.0
        speed = downstream_speed_bound(w, self.u)
        return math.inf if speed == 0.0 else margin / speed

    def next_event(self, tau_end: float) -> float | None:
        return self.search.next_root_before(tau_end)

    def impulse(self, tau_a: float, tau_b: float) -> float:
        return 0.0  # no contact force in flight


class LinearStick(_SearchedSegment):
    """Bodies together under linear drag: closed form (mass m+M, damping c+b, offset b u / k)."""

    phase = Phase.STICK
    ANCHOR = ("x0", "v0")

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.M = solver.M
        self.drag = solver.drag
        self.b = solver.drag.b
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.start = start
        self.osc = Oscillator(solver.m + solver.M, solver.c + self.b, solver.k,
                              offset=self.b * u / solver.k)
        self.search = RootSearch(self.probe, self.force, start, _time_eps(t0))

    def state(self, tau: float) -> tuple[float, float, float, float]:
        x, v = self.osc.response(self.x0, self.v0, tau)
        return x, v, x, v

    def force(self, tau: float) -> float:
        """Contact force on the structure, N: drag on the ice minus its inertia."""
        x, v = self.osc.response(self.x0, self.v0, tau)
        return sticking_contact_force(self.drag.force(v, self.u),
                                      self.M * self.osc.acceleration(x, v))

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        """Contact force, its two derivatives, bounds on |lam''| and |lam'''| from here on."""
        x, v = self.osc.response(self.x0, self.v0, tau)
        _, _, a, j, s, s1, s2 = self.osc.derivative_chain(x, v, 6)
        lam = sticking_contact_force(self.drag.force(v, self.u), self.M * a)
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
        # displacement increments from the anchor: positions about an equilibrium b u / k far
        # away carry its rounding, which b (xb - xa) would multiply
        dxa, va = self.osc.displacement_change(self.x0, self.v0, tau_a)
        dxb, vb = self.osc.displacement_change(self.x0, self.v0, tau_b)
        return -self.b * ((dxb - dxa) - self.u * (tau_b - tau_a)) - self.M * (vb - va)


class _Separation:
    """Terminal event of the sticking integration: the contact force turns tensile."""

    terminal = True
    direction = -1

    def __init__(self, together: Together):
        self.together = together

    def __call__(self, tau: float, y: np.ndarray) -> float:
        return self.together.contact_force(y)


class _Chunk:
    """One solve_ivp call of a sticking phase: from ``lo`` (state ``y_lo``) to ``hi``. Its dense
    output ``sol`` is integrated again from (lo, y_lo) when a restored state needs it: the same
    call gives the same output, to the last bit."""

    __slots__ = ("lo", "hi", "y_lo", "sol")

    def __init__(self, lo: float, hi: float, y_lo: np.ndarray, sol: object | None):
        self.lo, self.hi, self.y_lo, self.sol = lo, hi, y_lo, sol


class QuadraticStick:
    """Bodies together under quadratic drag: DOP853 in fixed chunks from the anchor, separation as
    a terminal event. Chunk limits depend only on the anchor, so results do not depend on the
    communication step."""

    phase = Phase.STICK

    def __init__(self, solver: EventSolver, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        self.m, self.c, self.k, self.M = solver.m, solver.c, solver.k, solver.M
        self.drag = solver.drag
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.together = Together(self.m, self.c, self.k, self.M, self.drag, u,
                                 inertia_from_net=False)
        self._separation_event = _Separation(self.together)
        period = 2.0 * math.pi / math.sqrt(self.k / (self.m + self.M))
        self.chunk = min(max(0.05, 2.0 * period), 5.0)  # s, fixed from the anchor
        self.start = start
        self.hi = 0.0                   # integrated up to here
        self.y_hi = np.array([x0, v0, 0.0])
        self.chunks: list[_Chunk] = []
        self.separation: float | None = None
        self.y_sep: np.ndarray | None = None
        self._recent: dict[float, np.ndarray] = {}  # the last two states asked for, by tau

    def _integrate(self, lo: float, y_lo: np.ndarray):
        """One chunk from lo: up to the end of a hold (no separation looked for), else a chunk
        length on, stopping where the contact force turns tensile."""
        if lo < self.start:  # held together: no separation looked for before `start`
            hi, events = self.start, None
        else:
            hi, events = lo + self.chunk, self._separation_event
        res = solve_ivp(self.together, (lo, hi), y_lo, method="DOP853", rtol=STICK_RTOL,
                        atol=STICK_ATOL, dense_output=True, events=events)
        if not res.success:
            raise SolverError(f"sticking-phase integration failed at t = {self.t0 + lo}: "
                              f"{res.message}")
        return res, hi

    def _extend(self) -> None:
        lo = self.hi
        if lo >= self.start and separates(self.together.contact_force(self.y_hi)):
            # already tensile (after a hold)
            self.separation, self.y_sep, self.hi = lo, self.y_hi, lo
            return
        res, hi = self._integrate(lo, self.y_hi)
        if res.status == 1:  # terminal event: the contact force turns tensile
            self.separation, self.y_sep = float(res.t_events[0][0]), res.y_events[0][0]
            hi = self.separation
        self.chunks.append(_Chunk(lo, hi, self.y_hi, res.sol))
        self.hi = hi
        self.y_hi = self.y_sep if self.separation is not None else res.y[:, -1]

    def _sol(self, chunk: _Chunk):
        if chunk.sol is None:
            chunk.sol = self._integrate(chunk.lo, chunk.y_lo)[0].sol
        return chunk.sol

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
            for chunk in reversed(self.chunks):
                if chunk.lo <= tau <= chunk.hi:
                    y = self._sol(chunk)(tau)
                    break
            if y is None:
                y = self.y_hi if not self.chunks else self._sol(self.chunks[0])(tau)
        if len(self._recent) >= 2:
            del self._recent[next(iter(self._recent))]
        self._recent[tau] = y
        return y

    def state(self, tau: float) -> tuple[float, float, float, float]:
        y = self._y(tau)
        # the solver never looks back before its current time: drop chunks that end before it
        while len(self.chunks) > 1 and self.chunks[0].hi < tau:
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
        return self.together.impulse(self._y(tau_a), self._y(tau_b))

    def snapshot(self, tau: float) -> dict[str, Any]:
        # chunks ending before tau are never asked for again
        chunks = [c for c in self.chunks if c.hi >= tau] or self.chunks[-1:]
        return {"phase": self.phase.value, "t0": self.t0, "anchor": [self.x0, self.v0],
                "start": self.start, "hi": self.hi, "y_hi": _floats(self.y_hi),
                "chunks": [[c.lo, c.hi, _floats(c.y_lo)] for c in chunks],
                "separation": self.separation,
                "y_sep": None if self.y_sep is None else _floats(self.y_sep),
                "recent": [[key, _floats(y)] for key, y in self._recent.items()]}

    @classmethod
    def read(cls, solver: EventSolver, rec: Record, u: float) -> Callable[[], QuadraticStick]:
        """Validate a :meth:`snapshot` record; return the function that builds the segment."""
        rec.expect_keys(("phase", "t0", "anchor", "start", "hi", "y_hi", "chunks", "separation",
                         "y_sep", "recent"))
        t0 = rec.real("t0", low=0.0)
        anchor = rec.reals("anchor", 2)
        start = rec.real("start", low=0.0)
        hi = rec.real("hi", low=0.0)
        y_hi = rec.reals("y_hi", 3)
        chunks = []
        for i, item in enumerate(rec.items("chunks", _MAX_CHUNKS)):
            entry = _entry(item, f"{rec.field('chunks')}[{i}]", ("lo", "hi", "y_lo"))
            lo, chunk_hi = entry.real("lo", low=0.0), entry.real("hi", low=0.0, high=hi)
            if chunk_hi < lo:
                raise StateError(entry.field("hi"), chunk_hi, f">= lo = {lo!r}")
            chunks.append((lo, chunk_hi, entry.reals("y_lo", 3)))
        separation = rec.real("separation", low=0.0, high=hi, allow_none=True)
        y_sep = rec.reals("y_sep", 3, allow_none=True)
        if (y_sep is None) != (separation is None):
            raise StateError(rec.field("y_sep"), y_sep, "null exactly when separation is null")
        recent = []
        for i, item in enumerate(rec.items("recent", 2)):
            entry = _entry(item, f"{rec.field('recent')}[{i}]", ("tau", "y"))
            recent.append((entry.real("tau", low=0.0), entry.reals("y", 3)))

        def make() -> QuadraticStick:
            seg = cls(solver, t0, *anchor, u, start)
            seg.hi, seg.y_hi = hi, np.array(y_hi)
            seg.chunks = [_Chunk(lo, c_hi, np.array(y_lo), None) for lo, c_hi, y_lo in chunks]
            seg.separation = separation
            seg.y_sep = None if y_sep is None else np.array(y_sep)
            seg._recent = {key: np.array(y) for key, y in recent}
            return seg
        return make


def _entry(item: Any, field: str, names: tuple[str, ...]) -> Record:
    """A list entry [a, b, ...] of a snapshot as a record with the given field names."""
    if not isinstance(item, list | tuple) or len(item) != len(names):
        raise StateError(field, item, "[" + ", ".join(names) + "]")
    return Record(dict(zip(names, item, strict=True)), field)


def _floats(y) -> list[float]:
    return [float(c) for c in y]


class EventSolver(Solver):
    """Exact event-driven solver (method 1)."""

    name = "exact"

    def __init__(self, scene: Scene, record_impacts: bool = True):
        super().__init__(scene, record_impacts)
        self.osc = Oscillator(self.m, self.c, self.k)
        self.drag = make_drag(scene)
        self.rules = ContactRules(self.m, self.M, scene.omega_n, self._free_accels, EXACT_POLICY)
        self.u = scene.flow_u
        self.tau = 0.0  # position within the current segment
        self.pending_impulse = 0.0
        s = self.state
        self.seg = None
        self._begin(0.0, s.x, s.v, s.z, s.w, self.u)  # an impact at t = 0 goes to the 1st step

    # segment construction -----------------------------------------------------------------------
    def _free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        return self.osc.acceleration(x, v), self.drag.accel_bounds(w, u)[0]

    def _begin(self, t: float, x: float, v: float, z: float, w: float, u: float,
               reanchor: bool = False) -> None:
        """Start the segment that follows time t from state (x, v, z, w) (``reanchor``: after a
        change of the flow speed, see :meth:`ContactRules.at_contact`)."""
        self.u = u
        self.tau = 0.0
        if x - z > 0.0:
            self._fly(t, x, v, z, w, u)
            return
        decision = self.rules.at_contact(t, x, v, w, u, reanchor)
        if decision.outcome is Outcome.IMPACT:
            self._impact(t, x, decision.v, decision.w, u)
        elif decision.outcome is Outcome.STICK:
            self._stick(t, x, decision.v, u, hold=decision.hold)
        else:
            self._fly_from_contact(t, x, decision.v, decision.w, u, decision.lam)

    def _fly(self, t, x, v, z, w, u, start: float = 0.0) -> None:
        self.seg = Flight(self, t, x, v, z, w, u, start)
        self._set_sticking(False, t)

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
        self._set_sticking(True, t)

    def _impact(self, t: float, x: float, v_minus: float, w_minus: float, u: float) -> None:
        """The impact step (eq. 16-18, chatter and Zeno closure) at time t; what follows."""
        impact = self.rules.impact(t, x, v_minus, w_minus, self.e, u)
        self._record(impact)
        self.pending_impulse += impact.impulse
        self._begin(t, x, impact.v_plus, x, impact.w_plus, u)

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
            x, v, z, w = seg.state(tau_event)
            t_event = seg.t0 + tau_event
            if seg.phase is Phase.FLIGHT:
                self._begin(t_event, x, v, x, w, u)  # impact, or a touch without speed
            else:  # contact force turns tensile: separate with equal velocities
                self._fly_from_contact(t_event, x, v, v, u,
                                       self.rules.free_contact_force(x, v, v, u))
            impulse += self.pending_impulse
            self.pending_impulse = 0.0
        x, v, z, w = self.seg.state(self.tau)
        self.state = State(t_end, x, v, z, w)
        return impulse

    # snapshots ----------------------------------------------------------------------------------
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
            cls = Flight
        else:
            cls = QuadraticStick if self.drag.quadratic else LinearStick
        make_segment = cls.read(self, seg_rec, u)

        def apply() -> None:
            self.seg = make_segment()
            self.u, self.tau, self.pending_impulse = u, tau, pending
            self.rules.degenerate.set(degenerate)
        return apply
