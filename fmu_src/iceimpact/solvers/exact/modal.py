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
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ...errors import SolverError
from ...physics.ice import downstream_speed_bound
from ...physics.modes import Modes
from ...physics.structure import FORM_UNDER, Oscillator
from ...record import Record
from ..base import GAP_ULPS, Samples, State
from ..contact_rules import Phase, reanchor_on_flow_change
from ..search import modal_search, modal_taylor
from ..search.flight_search import FlightSearch
from ..search.modal_search import ANCHOR, STATE
from ..search.modal_taylor import KERNELS
from ..search.rootfind import RootSearch
from . import bounces
from .bounces import FLOATS, BounceMarch
from .context import SegmentContext
from .segment import STEPPED, _time_eps
from .solver import EventSolver


class ModalContext(SegmentContext):
    """:class:`SegmentContext` with the modes (``modes``, under the held loads) and the modal
    state at the current instant (``now(v)``: the modes' (q, q') with the contact point moving
    at v, set by the solver), from which the contact rules' free accelerations and the bounds of
    a flight leaving the contact are taken."""

    __slots__ = ("modes", "now")

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.modes: Modes | None = None
        self.now: Callable[[float], tuple[list[float], list[float], float]] | None = None
        self.free_accels = self._modal_free_accels

    def _modal_free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        q, p, t = self.now(v)
        return self.modes.contact_acceleration(t, q, p), self.drag.accel_bounds(w, u)[0]

    def structure_bounds(self, x: float, v: float, u: float) -> tuple[float, float, float]:
        q, p, t = self.now(v)
        return self.modes.bounds(t, q, p)


def _read_anchor(cls: Any, context: ModalContext,
                 rec: Record) -> tuple[float, list[float], list[float], float]:
    """A modal segment's record checked (its keys, ``cls._KEYS``): its start time, the modes' q
    and q' there (one each per mode) and the time its search starts from."""
    rec.expect_keys(cls._KEYS)
    n = context.modes.count
    return (rec.real("t0", low=0.0), rec.reals("q", n), rec.reals("p", n),
            rec.real("start", low=0.0))


class ModalFlightSearch(FlightSearch):
    """The root search of a modal flight's gap: :func:`~.flight_search.flight_root` on the
    modes' functions (:mod:`~iceimpact.solvers.search.modal_search`), compiled where numba is;
    RootSearch on the flight's own probe and clearance where a step leaves its common path."""

    kernel = staticmethod(modal_search.KERNEL)

    def next_root_of(self, horizon: float, signal: Any) -> float | None:
        if not self.handed_back:
            signal.search_from_anchor(signal.integrated[1])
        return super().next_root_of(horizon, signal)


class ModalFlight:
    """Both bodies free: each mode on its closed form from the anchor (q0, q0'), the ice on its
    drag law from (z0, w0); the signal of the root search is the gap x - z. Mode k moves as its
    free response y_k about its particular solution (a held load's static deflection, or one
    moving at rho_k under a load that changes linearly: :mod:`~iceimpact.physics.modes`):
    ``q_k - q_k0 = (y_k - y_k0) + rho_k tau``."""

    __slots__ = ("modes", "drag", "t0", "q0", "p0", "z0", "w0", "u", "start", "x0", "v0",
                 "gap0", "search", "y0", "yd0", "offsets", "_motions", "_z_motion", "_last",
                 "integrated", "kernel_constants")
    phase = Phase.FLIGHT
    PUSHES = False
    FRONTIER_ONLY = True
    #: its samples are :meth:`states_at`'s and its impacts' impulses each the sampler's own
    #: value, as the compiled march of bounces writes them (a march to each sample would sum
    #: a sample interval's impacts in one value: other roundings)
    SAMPLING = STEPPED

    def __init__(self, context: ModalContext, t0: float, q0: Sequence[float],
                 p0: Sequence[float], z0: float, w0: float, u: float, start: float = 0.0,
                 touching: bool = False):
        self.modes = modes = context.modes
        self.drag = drag = context.drag
        self.q0, self.p0 = tuple(q0), tuple(p0)
        self.x0, self.v0 = modes.contact(self.q0, self.p0)
        if touching:  # the ice at the contact point as the modes' sum places it: the gap starts
            z0 = self.x0  # at 0, not at rounding's distance from it (a root at once)
        self.t0, self.z0, self.w0, self.u, self.start = t0, z0, w0, u, start
        self.gap0 = self.x0 - z0
        #: each mode's particular solution and free response (y, y') at the anchor
        self.offsets = modes.offsets(t0)
        self.y0, self.yd0 = modes.deviations(t0, self.q0, self.p0)
        self._motions = None  # (built when Python evaluates the motion)
        self._z_motion = drag.response(*drag.flight_constants(w0, u))
        self._last: tuple = (0.0, 0.0, self.v0, 0.0, w0, (0.0,) * modes.count, self.p0,
                             (0.0,) * modes.count, tuple(self.yd0))
        self.integrated = modal_search.new_modes(modes, t0, self.q0, self.p0)
        # flight_root's constants (Flight.kernel_constants' order): the oscillator's and its
        # free response's are the modes' (in integrated); an infinite offset asks the envelope
        # clearance at every step; the anchor's speed is c5 of the under-damped form
        self.kernel_constants = (self.gap0, self.x0, z0, math.inf, 1.0, 0.0, 1.0, 1.0, 0.0,
                                 0.0, 0.0, FORM_UNDER, 0.0, 0.0, 0.0, 0.0, 0.0, self.v0, 0.0,
                                 0.0, *drag.flight_constants(w0, u), u, *drag.law_constants,
                                 math.inf, self.integrated)
        self.search = ModalFlightSearch(start, _time_eps(t0))

    def search_from_anchor(self, state: np.ndarray) -> None:
        """The modal state rows ``state`` (:data:`~iceimpact.solvers.search.modal_search.
        STATE`: this flight's, or the march's copy) back to the anchor where the search starts
        there: it probes the anchor first. A root found from the anchor leaves the frontier at
        0 with the state at the root in the rows, which stay."""
        if self.search.a == 0.0 and self.search.root is None:
            state[STATE.DY] = 0.0
            state[STATE.YD] = state[STATE.YD0]
            state[STATE.T, 0] = 0.0

    def remember(self, state: tuple[float, float, float, float, float]) -> None:
        """Keep ``(tau, x - x0, v, z - z0, w)`` of a root the search found, with the modal
        state there (the last point it evaluated; where that is another point, nothing is kept
        and :meth:`_motion` evaluates the root)."""
        tau, dx, v, dz, w = state
        modal = self.integrated[1]
        if modal[STATE.T, 0] != tau:  # (the state rows hold another point: _motion evaluates
            return  # the root when asked)
        dy, yd = modal[STATE.DY].tolist(), modal[STATE.YD].tolist()
        drift = self.modes.drift
        self._last = (tau, dx, v, dz, w,
                      [d + rho * tau for d, rho in zip(dy, drift, strict=True)],
                      [y + rho for y, rho in zip(yd, drift, strict=True)], dy, yd)

    def _motion(self, tau: float) -> tuple:
        """(tau, x - x0, v, z - z0, w, (q_k - q_k0), (q_k'), (y_k - y_k0), (y_k')) at tau, as
        :func:`~iceimpact.solvers.search.modal_search._modal_gap_point` evaluates it; the last
        one is kept (the search asks again for the point it just tested)."""
        last = self._last
        if last[0] == tau:
            return last
        if self._motions is None:
            self._motions = tuple(osc.deviation_increment(y, yd) for osc, y, yd in
                                  zip(self.modes.oscillators, self.y0, self.yd0, strict=True))
        dq, p, dy, yd = [], [], [], []
        dx = v = 0.0
        for phi, rho, motion in zip(self.modes.phi, self.modes.drift, self._motions,
                                    strict=True):
            dyk, ydk = motion(tau)
            dy.append(dyk)
            yd.append(ydk)
            dqk, pk = dyk + rho * tau, ydk + rho
            dq.append(dqk)
            p.append(pk)
            dx += phi * dqk
            v += phi * pk
        dz, w = self._z_motion(tau)
        self._last = last = (tau, dx, v, dz, w, dq, p, dy, yd)
        return last

    def modal_state(self, tau: float) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at tau."""
        dq, p = self._motion(tau)[5:7]
        return [q0 + d for q0, d in zip(self.q0, dq, strict=True)], list(p)

    def state(self, tau: float) -> tuple[float, float, float, float]:
        _, dx, v, dz, w = self._motion(tau)[:5]
        return self.x0 + dx, v, self.z0 + dz, w

    def states_at(self, tau: np.ndarray) -> tuple[np.ndarray, ...]:
        """:meth:`state` at each of the times tau (s from the anchor): x, v, z, w, the same
        floats."""
        states = [self.state(t) for t in tau.tolist()]
        return tuple(np.array([state[k] for state in states], dtype=float) for k in range(4))

    def modal_states_at(self, tau: np.ndarray) -> np.ndarray:
        """:meth:`modal_state` at each of the times tau: rows (q_1..q_N, q_1'..q_N')."""
        return np.array([q + p for q, p in map(self.modal_state, tau.tolist())], dtype=float)

    def gap(self, tau: float) -> float:
        _, dx, _, dz, _ = self._motion(tau)[:5]
        return self.gap0 + (dx - dz)

    def gap_and_rate(self, tau: float) -> tuple[float, float]:
        _, dx, v, dz, w = self._motion(tau)[:5]
        return self.gap0 + (dx - dz), v - w

    value, value_and_rate = gap, gap_and_rate

    def _free_responses(self, tau: float) -> tuple[tuple, list[float], list[float]]:
        """The motion at tau and each mode's free response (y, y') there."""
        last = self._motion(tau)
        return last, [y0 + d for y0, d in zip(self.y0, last[7], strict=True)], list(last[8])

    def probe(self, tau: float) -> tuple[float, float, float, float, float]:
        """Gap, its rate and curvature, bounds on the magnitudes of its second and third
        derivatives for all later times: the modes' bounds summed
        (:meth:`Modes.deviation_bounds`) and the ice's."""
        last, y, yd = self._free_responses(tau)
        _, dx, v, dz, w = last[:5]
        a_x, a_x_max, j_x_max = self.modes.deviation_bounds(y, yd)
        a_z, a_z_max, j_z_max = self.drag.accel_bounds(w, self.u)
        return (self.gap0 + (dx - dz), v - w, a_x - a_z, a_x_max + a_z_max, j_x_max + j_z_max)

    def clearance(self, tau: float) -> float:
        """Time from tau (s) during which the gap provably stays open: the contact point stays
        within ``sum |phi_k| R_k`` (:meth:`Modes.reach`) of ``sum phi_k q_p``, which moves at
        ``sum phi_k rho_k``, and the ice moves downstream no faster than its speed bound (as
        :meth:`Flight.clearance`)."""
        last, y, yd = self._free_responses(tau)
        _, dx, v, dz, w = last[:5]
        z = self.z0 + dz
        centre = drift = 0.0
        for phi, off0, rho in zip(self.modes.phi, self.offsets, self.modes.drift, strict=True):
            if phi == 0.0:
                continue
            centre += phi * (off0 + rho * tau)
            drift += phi * rho
        reach = self.modes.reach(y, yd)
        x = self.x0 + dx
        margin = (centre - reach - z) - GAP_ULPS * (abs(x) + abs(z) + reach + abs(centre))
        if not margin > 0.0:
            return 0.0
        speed = downstream_speed_bound(w, self.u, self.drag.drags)
        speed += max(0.0, -drift)  # the envelope's centre moving upstream
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
        t0, q, p, start = _read_anchor(cls, context, rec)
        z, w = rec.real("z"), rec.real("w")
        frontier = RootSearch.read_frontier(rec.record("search"), start)

        def make() -> ModalFlight:
            seg = cls(context, t0, q, p, z, w, u, start)
            seg.search.set_frontier(frontier)
            return seg
        return make


class ModalRide:
    """The ice riding on the contact point of the modes (z = x), from the anchor (q0, q0') at t0,
    under the flow u; the riding ends at the first root of the contact force (not looked for
    before ``start``, a degenerate contact's hold). Its Taylor steps are
    :mod:`~iceimpact.solvers.search.modal_taylor`'s, each from the state the previous one ended
    in (so a phase rebuilt from its anchor has the same steps, to the bit)."""

    phase = Phase.STICK
    PUSHES = True
    FRONTIER_ONLY = False
    #: its samples and impulse pieces are :meth:`states_at`'s and :meth:`impulses_between`'s,
    #: taken at once from the steps (a march to each sample costs some µs of Python)
    SAMPLING = STEPPED
    #: it drops its steps before the earliest time last asked (:meth:`_grow`), so a long run
    #: samples it a chunk at a time (``solver.SAMPLE_CHUNK``)
    CHUNKED = True

    def __init__(self, context: ModalContext, t0: float, q0: Sequence[float],
                 p0: Sequence[float], u: float, start: float = 0.0):
        self.modes = modes = context.modes
        drag = context.drag
        M = context.M
        self.t0, self.u, self.start = t0, u, start
        self.q0, self.p0 = tuple(q0), tuple(p0)
        m_eff = modes.effective_mass
        self._alpha = m_eff / (M + m_eff)
        self._beta = M * self._alpha
        self._quadratic = 1 if drag.quadratic else 0
        self._coef = drag.B if drag.quadratic else drag.b
        v0 = modes.contact(self.q0, self.p0)[1]
        drag_rate = (2.0 * self._coef * (abs(u) + abs(v0)) if drag.quadratic
                     else self._coef) / (M + m_eff)
        self._rate = modes.rates_bound() + drag_rate
        self._table = modes.ride_table()
        n = modes.count
        #: the loads given, their rates, the modes' shares of a velocity change, the loads at a
        #: step's start (ride_extend's)
        self._loads = (np.array(modes.loads, dtype=float), np.array(modes.rates, dtype=float),
                       np.array(modes.share, dtype=float), np.empty(n))
        self._rows = 2 * n + 2
        self._rs = np.empty(modal_taylor.ORDER + 1)
        self._out = np.empty(self._rows)
        self._q0, self._p0 = np.array(self.q0, dtype=float), np.array(self.p0, dtype=float)
        self._scratch = (np.empty(n), np.empty(n))
        #: the Taylor steps (modal_taylor.ride_steps'): their (lo, h, hi), tables and ends, the
        #: counts of those made and of those proven free of a separation; grown as needed
        self._steps = np.empty((0, 3))
        self._tables = np.empty((0, self._rows, modal_taylor.ORDER + 1))
        self._ends = np.empty((0, self._rows))
        self._counts = np.zeros(2, dtype=np.int64)
        #: the steps dropped before the arrays' first (wholly before the times asked), and the
        #: earliest time the last call asked (s from the anchor)
        self._dropped = 0
        self._floor = 0.0
        self._end: float | None = None  # the separation, once found
        #: the time and rows _at evaluated last (a sample's state, modal state and impulse read
        #: the same rows, and the next sample's impulse starts there)
        self._last: tuple[float, np.ndarray] = (math.nan, self._out)

    # the Taylor steps --------------------------------------------------------------------------
    def _run_steps(self, target: float, check: int) -> tuple[int, int, float]:
        """:func:`~iceimpact.solvers.search.modal_taylor.ride_steps` to ``target`` (``check``
        1: searching the steps for the separation), the arrays grown while they are full.
        Each step starts from the end of the last (the first from the anchor); under the
        quadratic drag a step ends where u - v changes sign, and its end is set to u - v = 0
        exactly (the modes' velocities moved by the rounding, as an impulse would move them); a
        step from there whose drag sign is rounding's, so that it would end at once, is taken
        with the other sign (``ride_extend``)."""
        modes = self.modes
        while True:
            outcome, step, theta = KERNELS["ride_steps"](
                self._q0, self._p0, self.t0, self._loads[0], self._loads[1], modes.since,
                self._table, self._loads[2], self.u, self._alpha, self._beta, self._coef,
                self._quadratic, self._rate, self._rs, self._loads[3], *self._scratch,
                self._steps, self._tables, self._ends, self._counts, target, self.start, check)
            if outcome == modal_taylor.STALLED:
                q, p = self._scratch
                lo = self._steps[step - 1, modal_taylor.HI] if step else 0.0
                raise SolverError(
                    f"the riding phase's Taylor steps stalled at t = {self.t0 + lo!r} s (modal "
                    f"state q = {q.tolist()} m, q' = {p.tolist()} m/s)")
            if outcome != modal_taylor.FULL:
                return outcome, step, theta
            self._grow()

    def _grow(self) -> None:
        """Room for more steps: the steps that end before the earliest time the last call asked
        and that were searched for the separation are dropped (a phase riding for hours keeps
        a few hundred steps, not all); the arrays are doubled (at least 16) where that frees
        less than half of them. An earlier time asked later makes them again
        (:meth:`_rows_at`)."""
        count = int(self._counts[modal_taylor.COUNT])
        checked = int(self._counts[modal_taylor.CHECKED])
        drop = min(int(np.searchsorted(self._steps[:checked, modal_taylor.HI], self._floor)),
                   count - 1) if count else 0
        keep = count - drop
        if 0 < keep <= len(self._steps) // 2:  # (in place: the kept steps to the front)
            for a in (self._steps, self._tables, self._ends):
                a[:keep] = a[drop:count]
        else:
            capacity = max(16, 2 * len(self._steps))
            self._steps, self._tables, self._ends = (
                np.concatenate((a[drop:count], np.empty((capacity - keep, *a.shape[1:]))))
                for a in (self._steps, self._tables, self._ends))
        self._counts[modal_taylor.COUNT] = keep
        self._counts[modal_taylor.CHECKED] = checked - drop
        self._dropped += drop

    def _at(self, tau: float) -> np.ndarray:
        """The rows (q, q', P, lam) at tau (:meth:`_rows_at`; not to be changed: the last one
        is kept)."""
        last = self._last
        if last[0] == tau:
            return last[1]
        out = np.empty((1, self._rows))
        self._rows_at(np.array([tau], dtype=float), out)
        self._last = (tau, out[0])
        return out[0]

    def _rows_at(self, tau: np.ndarray, out: np.ndarray) -> None:
        """The rows at the times tau into those of ``out``, each in the last step starting at
        or before it (``ride_rows_at``), the steps made to the last time (none beyond the
        separation, once found)."""
        if not len(tau):
            return
        self._floor = float(tau.min())
        if self._dropped and self._floor < self._steps[0, modal_taylor.LO]:
            # an earlier time than the steps kept: the steps made again from the anchor (the
            # same floats), to the separation where it was found
            self._counts[:] = 0
            self._dropped = 0
            if self._end is not None:
                self._run_steps(self._end, 1)
        if self._end is None:
            self._run_steps(float(tau.max()), 0)
        KERNELS["ride_rows_at"](self._steps, self._tables, self._ends,
                                int(self._counts[modal_taylor.COUNT]), tau, out)

    # the segment's interface -----------------------------------------------------------------
    def next_event(self, tau_end: float) -> float | None:
        """The separation: the first tau >= start where the contact force turns tensile, if at
        or before tau_end."""
        if self._end is not None:
            return self._end if self._end <= tau_end else None
        outcome, step, theta = self._run_steps(tau_end, 1)
        if outcome != modal_taylor.SEPARATES:
            return None
        lo, h = self._steps[step, modal_taylor.LO], self._steps[step, modal_taylor.H]
        self._end = tau = float(lo + theta * h)
        self._last = (math.nan, self._out)  # (it may lie in a step dropped)
        return tau if tau <= tau_end else None

    def modal_state(self, tau: float) -> tuple[list[float], list[float]]:
        n = self.modes.count
        row = self._at(tau)
        return row[:n].tolist(), row[n:2 * n].tolist()

    def states_at(self, tau: np.ndarray) -> np.ndarray:
        """Rows (x, v, q_1..q_N, q_1'..q_N', P) at the times tau (s from the anchor, within the
        steps :meth:`next_event` reached): each step's rows as :meth:`_at` evaluates them, the
        contact point's as :meth:`state` sums them (``Modes.contact``, in mode order)."""
        n = self.modes.count
        tau = np.ascontiguousarray(tau, dtype=float)
        out = np.empty((len(tau), self._rows))
        self._rows_at(tau, out)
        rows = out[:, :2 * n + 1]
        x = np.zeros(len(rows))
        v = np.zeros(len(rows))
        for k, phi in enumerate(self.modes.phi):
            x += phi * rows[:, k]
            v += phi * rows[:, n + k]
        return np.column_stack((x, v, rows))

    def impulses_between(self, tau: np.ndarray, y: np.ndarray) -> np.ndarray:
        """:meth:`impulse` over the pieces tau[k]..tau[k+1], from the rows ``y`` at tau
        (:meth:`states_at`'s)."""
        impulse = y[:, -1]
        return np.where(tau[1:] > tau[:-1], impulse[1:] - impulse[:-1], 0.0)

    def state(self, tau: float) -> tuple[float, float, float, float]:
        q, p = self.modal_state(tau)
        x, v = self.modes.contact(q, p)
        return x, v, x, v

    def impulse(self, tau_a: float, tau_b: float) -> float:
        if tau_b <= tau_a:
            return 0.0
        n = self.modes.count
        start = float(self._at(tau_a)[2 * n])  # (first: the rows _at kept, the last sample's)
        return float(self._at(tau_b)[2 * n]) - start

    _KEYS = ("phase", "t0", "q", "p", "start")

    def snapshot(self, tau: float) -> dict[str, Any]:
        """The anchor: its Taylor steps are rebuilt from it, the same floats."""
        return {"phase": self.phase.value, "t0": self.t0, "q": list(self.q0),
                "p": list(self.p0), "start": self.start}

    @classmethod
    def read(cls, context: ModalContext, rec: Record, u: float) -> Callable[[], Any]:
        t0, q, p, start = _read_anchor(cls, context, rec)
        return lambda: cls(context, t0, q, p, u, start)


class ModalBounceMarch(BounceMarch):
    """The compiled march of bounces on the modes (:data:`~.bounces.MODAL_CALLEES`): the same
    march as the SDOF's, its structure the modes' arrays (:func:`~iceimpact.solvers.search.
    modal_search.new_modes`), copied from a :class:`ModalFlight` as the march takes it, and to
    the flight it ends on. ``kernel``: :func:`~.bounces.modal_kernel`'s (tests: :data:`~.bounces.
    MODAL_MARCH`, the same march as Python)."""

    def __init__(self, solver: ModalSolver, kernel: Any = None):
        super().__init__(solver, kernel if kernel is not None else bounces.modal_kernel())
        self.flight_type = ModalFlight
        self.dragged = False
        #: where the kernel writes the samples' modal states: the Samples' in a sampled march
        n = solver.context.modes.count
        self._no_samples = self._samples = np.empty((0, 2 * n))

    def takes(self, seg: Any) -> bool:
        """A modal flight, its search not handed to RootSearch, and no Zeno tail running."""
        return (type(seg) is ModalFlight and not seg.search.handed_back
                and self.solver.zeno_end is None)

    def _structure(self, seg: ModalFlight) -> tuple[Any, dict[str, float]]:
        # (the oscillator's fields of ModalFlight.kernel_constants: the modes' are integrated)
        return self.context.modes, bounces.oscillator_fields(seg.kernel_constants[3:12], 0.0)

    def _root_state(self, seg: ModalFlight, root: float) -> tuple:
        return seg._motion(root)[:5]

    def _integrated_of(self, seg: ModalFlight) -> None:
        """The flight's arrays copied into the march's own (a flight kept in a checkpoint keeps
        its own); its search's last point the anchor if the search starts there
        (ModalFlightSearch)."""
        own = self.integrated
        if isinstance(own, int) or own[0].shape != seg.integrated[0].shape:
            own = tuple(np.empty_like(array) for array in seg.integrated[:3])
        for mine, theirs in zip(own[:3], seg.integrated[:3], strict=True):
            mine[...] = theirs
        self.integrated = (*own[:3], self._samples)
        seg.search_from_anchor(own[1])

    def _new_segment(self, F: list[float], u: float) -> ModalFlight:
        anchor = self.integrated[2]
        return ModalFlight(self.context, F[FLOATS.T0], anchor[ANCHOR.Q0].tolist(),
                           anchor[ANCHOR.P0].tolist(), F[FLOATS.Z0], F[FLOATS.W0], u,
                           F[FLOATS.START])

    def _integrated_to(self, seg: ModalFlight, N: list[int]) -> None:
        """The march's state of the modes (its search's last point) to the flight's arrays."""
        seg.integrated[1][...] = self.integrated[1]

    def sample(self, times: np.ndarray, i: int, interval: int, out: Samples, targets: Any,
               values: Any) -> tuple[int, int]:
        """:meth:`BounceMarch.sample`, the modal state at each sample to ``out.modal``."""
        self._samples = out.modal
        try:
            return super().sample(times, i, interval, out, targets, values)
        finally:
            self._samples = self._no_samples


class ModalSolver(EventSolver):
    """The exact event-driven method with the modal structure (see the module docstring). The
    modes' loads of the next step are set by :meth:`set_loads` (the simulator does it)."""

    name = "exact"
    _context_class = ModalContext

    def __init__(self, scene: Any, record_impacts: bool = True):
        self._modes = Modes(scene.mode_table, scene.mode_loads)
        x0, v0 = scene.modal_start
        #: the modal state (q, q') at the current instant, its contact point's speed, the time
        self._now: tuple[list[float], list[float], float, float] = (
            [row[4] for row in scene.mode_table], [row[5] for row in scene.mode_table], v0, 0.0)
        super().__init__(scene, record_impacts)

    def _structure(self) -> Oscillator:
        """Unused by the modal segments (the context's ``osc`` of the SDOF fields)."""
        return Oscillator(self.m, self.c, self.k)

    def _bounce_march(self) -> ModalBounceMarch | None:
        """The compiled march of bounces on the modes, or None (Python's march)."""
        return ModalBounceMarch(self) if bounces.modal_kernel() is not None else None

    def _start(self) -> None:
        context = self.context
        context.modes = self._modes
        context.now = self._context_now
        x0, v0 = self.scene.modal_start
        s = self.state
        self.state = State(0.0, x0, v0, s.z, s.w)
        self._begin(0.0, x0, v0, s.z, s.w, self.u)

    # the modal state at the current instant ----------------------------------------------------
    def modal_now(self, v: float) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at the current event with the contact point moving at v: the
        velocities of the state found there, changed by the impulse that moved v."""
        q, p, v_ref, _ = self._now
        if v == v_ref:
            return list(q), list(p)
        return list(q), self.context.modes.velocity_change(p, v - v_ref)

    def _context_now(self, v: float) -> tuple[list[float], list[float], float]:
        """:meth:`modal_now` and the time (the context's ``now``)."""
        q, p = self.modal_now(v)
        return q, p, self._now[3]

    def _take_now(self, tau: float) -> None:
        seg = self.seg
        q, p = seg.modal_state(tau)
        self._now = (q, p, self.context.modes.contact(q, p)[1], seg.t0 + tau)

    def modal_state(self) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at the solver's time."""
        return self.seg.modal_state(self.tau)

    def _new_samples(self, n: int) -> Samples:
        return Samples(n, self.context.modes.count)

    def _sampled(self, out: Samples, i: int) -> None:
        q, p = self.modal_state()
        out.modal[i] = q + p

    # segments -----------------------------------------------------------------------------------
    def _new_flight(self, t: float, x: float, v: float, z: float, w: float, u: float,
                    start: float) -> ModalFlight:
        q, p = self.modal_now(v)
        return ModalFlight(self.context, t, q, p, z, w, u, start, touching=z == x)

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

    def set_loads(self, loads: Sequence[float], rates: Sequence[float] | None = None) -> None:
        """The modes' generalized loads (N) from now on, changing at ``rates`` (N/s; default:
        held): the segment is re-anchored at the current time on the modes under them (as a new
        flow speed is), unless held loads do not change."""
        modes = self.context.modes
        loads = tuple(loads)
        rates = (0.0,) * len(loads) if rates is None else tuple(rates)
        if loads == modes.loads and rates == modes.rates and modes.held:
            return
        t = self.state.t
        self._take_now(self.tau)
        self.context.modes = modes.with_loads(loads, rates, since=t)
        x, v, z, w = reanchor_on_flow_change(*self.seg.state(self.tau),
                                             self.seg.phase is Phase.STICK)
        end, self.zeno_end = self.zeno_end, None
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

    _KEYS = EventSolver._KEYS + ("loads", "load_rates", "loads_since")

    def _snapshot(self) -> dict[str, Any]:
        data = super()._snapshot()
        modes = self.context.modes
        data["loads"], data["load_rates"] = list(modes.loads), list(modes.rates)
        data["loads_since"] = modes.since
        return data

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        n = self.context.modes.count
        loads, rates = rec.reals("loads", n), rec.reals("load_rates", n)
        since = rec.real("loads_since", low=0.0, high=t)
        modes = self.context.modes.with_loads(loads, rates, since)
        saved, self.context.modes = self.context.modes, modes
        try:  # the segment is read against the modes under the saved loads
            apply_rest = super()._read(rec, t)
        finally:
            self.context.modes = saved

        def apply() -> None:
            self.context.modes = modes
            apply_rest()
        return apply
