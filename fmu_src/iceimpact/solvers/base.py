"""The one interface every solver method implements, and the records they produce.

A solver owns the state of both bodies and marches it: ``advance_to(t_end, u)`` moves from its
current time to ``t_end`` with the flow speed u held constant, counts every impact (and lists it
in ``impacts`` if asked to) and returns the impulse delivered to the structure on the way.
``snapshot()`` gives the state that determines the future as plain data, ``restore()`` takes it
back after checking every field. The simulator above it knows nothing of how a method marches; a
method knows nothing of FMI or scene files.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..contract import INT32_MAX
from ..errors import SolverError, StateError
from ..physics.contact import Impact
from ..physics.ice import make_structure_drag
from ..record import STATE_VERSION, Record, check_version
from ..scene import Scene
from .contact_rules import sticking_start
from .impact_log import ImpactLog

__all__ = ["GAP_ROUNDING", "Impact", "Samples", "Solver", "SolverError", "State", "StateError"]

#: Gaps between -GAP_ROUNDING and 0 (m) are rounding of x - z at contact: the simulator reports
#: them as 0, and the exact method never accepts a graze deeper than this as a touch.
GAP_ROUNDING = 1e-12

#: Rounding of a gap evaluated from positions of magnitude X is below GAP_ULPS * X (m).
GAP_ULPS = 16.0 * 2.0 ** -52

#: A flight's clearance from the ice's acceleration bound (Flight.clearance) counts only when it
#: spans at least this much of the structure's phase omega_n t (rad), 256 periods: shorter
#: stretches the root search crosses in a few steps by itself.
ACCEL_CLEARANCE_PHASE = 512.0 * math.pi


@dataclass
class State:
    """Positions (m) and velocities (m/s) of structure (x, v) and ice (z, w) at time t (s)."""

    t: float
    x: float
    v: float
    z: float
    w: float

    @property
    def gap(self) -> float:
        """x - z, m."""
        return self.x - self.z


class Samples:
    """States (m, m/s), contact impulses (N.s, each over the interval that ends at its sample) and
    sticking flags at a run's sample times: what :meth:`Simulator.sample` returns, from a
    solver's vectorised sampler or from one step per sample. With ``modes`` (the modal
    structure's N), ``modal`` holds each sample's modal state, a row (q_1..q_N, q_1'..q_N')
    (m, m/s); else None."""

    __slots__ = ("x", "v", "z", "w", "impulse", "sticking", "modal")

    def __init__(self, n: int, modes: int = 0):
        self.x, self.v, self.z, self.w = (np.empty(n) for _ in range(4))
        self.impulse = np.zeros(n)
        self.sticking = np.zeros(n, dtype=bool)
        self.modal = np.empty((n, 2 * modes)) if modes else None

    def set(self, i: int, state: State, sticking: bool) -> None:
        self.x[i], self.v[i], self.z[i], self.w[i] = state.x, state.v, state.z, state.w
        self.sticking[i] = sticking


class Solver:
    """Base class: parameters, state, impact count and list, snapshots.

    The contract of a method (as scipy's ``OdeSolver`` states its own), which the simulator
    relies on and the tests check for every method (``tests/test_state.py``,
    ``tests/test_step_budget.py``, ``tests/test_simulator.py``):

    1. ``advance_to(t_end, u)`` marches from ``state.t`` to ``t_end`` (> t) with the flow speed
       u held, leaves ``state`` at ``t_end`` and returns the contact impulse on the structure
       over the interval (N.s), impacts included. The event-driven methods do it through the
       one loop of :class:`~iceimpact.solvers.march.EventMarch`. With ``stop_at_event`` an
       event-driven method (1 or 3) ends the march at the first contact event (an impact, a
       separation) before ``t_end`` instead (``state`` just after it); method 2 marches to
       ``t_end`` regardless.
    2. Every impact goes through :meth:`_record` (the count, the list, the step's impact
       budget: one beyond it raises :class:`SolverError`); sticking is entered and left through
       :meth:`_set_sticking`.
    3. A method that cannot go on raises :class:`SolverError` saying why and what to change; it
       never returns NaN or inf knowingly (the simulator checks anyway).
    4. :meth:`checkpoint` / :meth:`rollback` undo the next :meth:`advance_to` exactly (the
       simulator rolls a refused step back); :meth:`snapshot` / :meth:`restore` carry the whole
       future as plain data, every field checked on the way in.
    5. With ``SAMPLES_AT_ONCE``, ``sample(times, u)`` returns the :class:`Samples` that
       ``advance_to`` at each time would give, to rounding.

    Subclasses implement :meth:`advance_to` and the method-specific part of :meth:`snapshot` /
    :meth:`restore` (``_KEYS``, ``_snapshot``, ``_read``).

    ``impact_count`` and ``t_last`` count every impact; the list ``impacts`` keeps the impacts
    from ``impacts_base`` on, and only when ``record_impacts`` is true (a long FMU run keeps its
    memory flat with ``record_impacts=False``). The list is a record beside the state: it is not
    part of a snapshot.
    """

    #: short name used in reports, benchmarks and snapshots
    name = "base"
    #: The solver has ``sample(times, u)``: many sample times in one march, evaluated at once
    #: (run() takes it; otherwise it steps to each sample time).
    SAMPLES_AT_ONCE = False

    @property
    def penetration_cause(self) -> str:
        """Why this method can leave the ice past the structure (z > x), for diagnostics; the
        exact method never does."""
        return "rounding"

    def __init__(self, scene: Scene, record_impacts: bool = True):
        self.scene = scene
        # the mass moving with the structure: m + m_a with the Morison added mass (eq. 8 and the
        # impact law, docs/explanation/morison.md), exactly m without it
        self.m = scene.structure_mass
        #: Morison drag of the flow on the structure (same law as the ice's), None when off
        self.structure_drag = make_structure_drag(scene)
        self.c = scene.structure_c
        self.k = scene.structure_k
        self.M = scene.ice_M
        self.e = scene.impact_e
        self.record_impacts = record_impacts
        self.impacts = ImpactLog()
        self.impacts_base = 0           # impacts before the first one listed
        self.impact_count = 0           # impacts since the start
        self.t_last: float | None = None  # time of the latest impact, s
        # the modal structure (structure.model = 3) starts at its contact point's sum phi q0
        x0, v0 = (scene.modal_start if scene.modal
                  else (scene.structure_x0, scene.structure_v0))
        self.state = State(0.0, x0, v0, scene.ice_z0, scene.ice_v0)
        self.sticking = False
        self.sticking_since: float | None = None  # start of the current sticking phase, s
        # the impact count beyond which the current step is refused (solver.max_impacts over
        # the step's start, set by begin_step; none until a step sets it)
        self.impact_limit = math.inf
        self.step_start = 0.0  # the time the current step started from, s

    @property
    def t(self) -> float:
        return self.state.t

    def set_restitution(self, e: float) -> None:
        """Change e for impacts from now on (``impact.e`` is tunable)."""
        self.e = e

    def advance_to(self, t_end: float, u: float, stop_at_event: bool = False) -> float:
        """March to ``t_end`` (or, with ``stop_at_event``, to the first contact event before
        it) with flow speed u; return the impulse on the structure (N.s)."""
        raise NotImplementedError

    def begin_step(self, start: float | None = None) -> None:
        """Start the impact budget of a communication step from time ``start`` (s; default: now)
        or of one sample interval of a sampled run: at most ``solver.max_impacts`` impacts
        from now on, else :meth:`_record` refuses the step. :meth:`end_step` lifts it."""
        self.impact_limit = self.impact_count + self.scene.solver_max_impacts
        self.step_start = self.state.t if start is None else start

    def end_step(self) -> None:
        """No budget outside a step (a solver marched directly has none)."""
        self.impact_limit = math.inf

    def _record(self, impact: Impact) -> None:
        """Count an impact (and list it, if impacts are recorded). One impact beyond the step's
        budget (:meth:`begin_step`) raises :class:`SolverError`: the simulator rolls the step
        back, so a scene whose impacts would take a step minutes or hours (a stick-part cycle
        at a stiff structure, docs/explanation/robustness/budgets.md) is refused with the way out,
        never a hang."""
        if self.impact_count >= self.impact_limit:
            raise SolverError(self._over_budget(impact.t))
        self.impact_count += 1
        self.t_last = impact.t
        if self.record_impacts:
            self.impacts.append(impact)

    def _over_budget(self, t: float, name: str = "solver.max_impacts", what: str = "impacts",
                     at: str = "the next one at") -> str:
        """The refusal of a step that needs more than its budget ``name`` of ``what`` (the
        impacts, or method 3's evaluations), ``at`` time t: the budget, where the step stood
        and the rate so far, and the two ways on."""
        budget = getattr(self.scene, name.replace(".", "_"))
        span = t - self.step_start
        if span > 0.0:
            rate = budget / span
            where = (f"{at} t = {t!r} s, {span:.3g} s into the step: {rate:.3g} "
                     f"{what} a simulated second; at that rate steps of {0.5 * span:.3g} s "
                     f"take half the budget")
        else:
            where = f"all at t = {t!r} s"
        short = name.split(".")[1]
        return (f"the step needs more than {name} = {budget} {what} ({where}). "
                f"Take shorter communication steps (run(): a shorter dt), or raise "
                f"{name} (allowed: an integer, 1 <= {short} <= {INT32_MAX}) if "
                f"a step may take that long")

    def _set_sticking(self, sticking: bool, t: float) -> None:
        """Enter (at time t, s) or leave the sticking phase."""
        self.sticking_since = sticking_start(self.sticking, self.sticking_since, sticking, t)
        self.sticking = sticking

    # snapshots ----------------------------------------------------------------------------------
    _BASE_KEYS = ("version", "method", "t", "x", "v", "z", "w", "e", "impact_count", "t_last",
                  "sticking", "sticking_since")
    #: the method's own snapshot fields (subclasses)
    _KEYS: tuple[str, ...] = ()

    def snapshot(self) -> dict[str, Any]:
        """The state that determines the future exactly, as plain JSON-compatible data (no
        impact history): :meth:`restore` on a solver of the same scene continues identically."""
        s = self.state
        data = {"version": STATE_VERSION, "method": self.name, "t": s.t, "x": s.x, "v": s.v,
                "z": s.z, "w": s.w, "e": self.e, "impact_count": self.impact_count,
                "t_last": self.t_last, "sticking": self.sticking,
                "sticking_since": self.sticking_since}
        data.update(self._snapshot())
        return data

    def checkpoint(self) -> Any:
        """What :meth:`rollback` needs to undo the next :meth:`advance_to` of this same solver
        (a method may give something cheaper than a :meth:`snapshot`; the simulator takes one
        before every step)."""
        return self.snapshot()

    def rollback(self, checkpoint: Any) -> None:
        """Return to the state of :meth:`checkpoint`: exactly, as :meth:`restore` would."""
        self.restore(checkpoint)

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Return to a state from :meth:`snapshot`. Every field is checked first: a malformed
        snapshot raises :class:`StateError` naming the field, and the solver is unchanged.

        The impact list keeps its entries before the snapshot's impact count if they are the
        same history (rolling back in the same run); otherwise it starts empty from there."""
        self.read_snapshot(snapshot)()

    def read_snapshot(self, snapshot: dict[str, Any]) -> Callable[[], None]:
        """Check every field of a :meth:`snapshot` (:class:`StateError` if one is malformed)
        without changing anything; return the function that restores it."""
        rec = Record(snapshot, "solver")
        rec.expect_keys(self._BASE_KEYS + self._KEYS)
        check_version(rec)
        rec.text("method", [self.name])
        t = rec.real("t", low=0.0)
        x, v, z, w = (rec.real(key) for key in ("x", "v", "z", "w"))
        e = rec.real("e", low=0.0, high=1.0)
        count = rec.integer("impact_count", low=0)
        t_last = rec.real("t_last", low=0.0, high=t, allow_none=True)
        if (t_last is None) != (count == 0):
            raise StateError("solver.t_last", t_last, "null exactly when impact_count is 0")
        sticking = rec.flag("sticking")
        since = rec.real("sticking_since", low=0.0, high=t, allow_none=True)
        if (since is None) == sticking:
            raise StateError("solver.sticking_since", since,
                             "a time <= t while sticking, null otherwise")
        apply_method = self._read(rec, t)  # validates the method's fields, changes nothing yet

        def apply() -> None:
            self.state = State(t, x, v, z, w)
            self.e = e
            kept = count - self.impacts_base
            if not (0 <= kept <= len(self.impacts)
                    and (kept == 0 or self.impacts[kept - 1].t == t_last)):
                self.impacts.clear()
                self.impacts_base, kept = count, 0
            del self.impacts[kept:]
            self.impact_count, self.t_last = count, t_last
            self.sticking, self.sticking_since = sticking, since
            apply_method()
        return apply

    def _snapshot(self) -> dict[str, Any]:
        return {}

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        """Validate the method's fields of ``rec``; return the function that applies them."""
        return lambda: None
