"""Method 1 against an external structure (structure.model = 2): the ice as a co-simulation
component.

The structure lives in another FMU. At the start of each communication step the master gives the
contact point's displacement ``x_in``, velocity ``v_in`` and, optionally, acceleration ``a_in``
(under the contact force the structure held over the previous step); IceImpact returns the
impulse the ice delivered during the step, which the master applies to the structure as the force
``impulse / h`` held over a step: the same step with a Gauss-Seidel master that steps the ice
first (``coupling.scheme = 1``), the next one with a Jacobi master (``coupling.scheme = 2``, the
fixed-step algorithms of ECOS and libcosim).

Within a step (docs/explanation/coupling.md, "External-structure mode"):

- **The structure's own forces.** ``F_o`` (spring, damping, anything but the contact) is measured
  from the structure's acceleration and the contact force it felt: ``F_o = m a_in - F_felt`` at
  the step start when the master gives ``a_in`` (non-zero), else the mean over the last step,
  ``m (v_in - v_in_prev) / h_prev - F_felt`` (exact for a structure stepped with the force held),
  which refers to that step's midpoint. ``F_felt`` is the force IceImpact returned for the last
  step (Gauss-Seidel) or for the one before (Jacobi). Two successive measurements give the rate
  ``F_o'``; ``F_o(t)`` is extrapolated linearly from the latest over the step. ``m`` is
  ``structure.m``, the effective (impulse) mass at the contact point.
- **Flight.** From each anchor (step start, impact, separation) the structure moves as a mass
  ``m`` under ``F_o`` at the anchor (:class:`~iceimpact.physics.external.ExtrapolatedStructure`):
  a polynomial, so the event solver's :class:`~iceimpact.solvers.exact.Flight` finds every impact
  as the exact first root of the gap, with its no-miss guarantee. An impact applies eq. 16-17 with
  ``m`` and the flight that follows is anchored on the structure's velocity jump. The chatter and
  Zeno closures are those of :mod:`~iceimpact.solvers.contact_rules` (their time scale is the
  period ``2 pi sqrt(m / k)``: ``structure.k`` only sets it in this mode).
- **Sticking** (:class:`ExternalStick`). The ice rides on the structure. The contact force is
  that of the combined body of mass ``m + M`` under ``F_o`` and the drag ``D``: ``(m + M) a =
  F_o + D``, so ``lam = (m D - M F_o) / (m + M)`` (the contact force of eq. 12-17's free
  accelerations, :func:`~iceimpact.physics.contact.contact_force`). Measuring ``F_o`` from the
  structure's acceleration and the force it felt means the previous contact force enters ``lam``
  scaled by ``M / (m + M) < 1``: the classic remedy of the added-mass instability, stable for any
  mass ratio (``lam = D - M a_s`` would feed the ice's inertia back with a factor ``M / m`` and
  diverge for ``M > m``). Within the step ``lam`` is linear in time (``F_o'``, and ``D``
  linearised along the combined body's velocity); the bodies separate at its root, the first
  instant it would pull, wherever it falls in the step.
- **The structure's lag.** A Gauss-Seidel master applies the impulse of a step spread over that
  step, so the structure it reports next is behind IceImpact's extrapolation (which jumped in
  velocity at the impact): the ice can be a little past the reported structure at a step start.
  Contact cannot be tensile nor penetrate, so the ice is put back at the structure (``z =
  x_in``, its velocity kept) and the contact rules decide at zero gap: an impact only if the ice
  still approaches the structure. While the bodies stick the ice takes the structure's state.
- **A Jacobi master** gives IceImpact a structure that has not felt the last step's impulse at
  all (it holds it over this step). IceImpact gives that impulse to its extrapolated structure at
  the step start, ``v_s = v_in + F_prev h / m``, so that the ice, which bounced off a structure
  that took the impulse, does not strike the reported one again; the rest is as above. The
  one-step delay of the force remains the scheme's own first-order error (it damps a riding
  floe's motion: an apparent damping of about ``M k h / (m + M)`` on a spring ``k``).

Every step starts afresh from the inputs: the state that carries over is the ice's, the sticking
flag, and the last step's ``v_in``, length, felt and returned forces and ``F_o`` measurement (the
snapshot's ``previous`` and ``other_force``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

from ...errors import StateError
from ...physics.contact import contact_force
from ...physics.external import ExtrapolatedStructure
from ...record import Record
from ...scene import Scene
from ..base import Solver, State
from ..contact_rules import Phase, separates
from .context import SegmentContext
from .solver import EventSolver


class ExternalStick:
    """Ice riding on the external structure for the rest of a step: the combined body of mass
    ``m + M`` under the structure's own force ``F_o(t)`` (linear in time within the step) and
    the drag ``D`` (linearised about the velocity at the anchor). The contact force
    ``lam = (m D - M F_o) / (m + M)`` is then linear in time, ``lam0 + lam1 tau``, and the
    bodies separate at its root if it falls within the step (the first instant it would pull).
    ``other`` and ``other_rate`` are F_o at t0 (N) and its rate (N/s), the solver's estimate.

    With ``a0 = (F_o + D) / (m + M)`` and ``j = (F_o' + D' a0) / (m + M)`` (``D'`` = dD/dv) the
    motion is ``x0 + v0 tau + a0 tau^2 / 2 + j tau^3 / 6``; the contact impulse over an interval
    is the integral of lam, which equals the drag impulse on the ice minus its momentum change
    to the same order. Separation is not looked for before ``start`` (a degenerate contact's
    hold, :class:`~iceimpact.solvers.contact_rules.DegenerateContacts`)."""

    phase = Phase.STICK
    PUSHES = True

    def __init__(self, context: SegmentContext, t0: float, x0: float, v0: float, u: float,
                 other: float, other_rate: float, start: float = 0.0):
        m, M = context.m, context.M
        total = m + M
        drag, drag_rate = context.drag.force(v0, u), context.drag.force_rate(v0, u)
        self.t0, self.x0, self.v0, self.u, self.start = t0, x0, v0, u, start
        self.a = (other + drag) / total
        self.jerk = (other_rate + drag_rate * self.a) / total
        # lam = mu (a_z - a_x) of the free accelerations (eq. 12-17), and its rate
        self.lam0 = contact_force(other / m, drag / M, m, M)
        self.lam1 = contact_force(other_rate / m, drag_rate * self.a / M, m, M)

    def state(self, tau: float) -> tuple[float, float, float, float]:
        x = self.x0 + (self.v0 + (0.5 * self.a + self.jerk * tau / 6.0) * tau) * tau
        v = self.v0 + (self.a + 0.5 * self.jerk * tau) * tau
        return x, v, x, v

    def contact_force(self, tau: float) -> float:
        """lam at tau, N."""
        return self.lam0 + self.lam1 * tau

    def next_event(self, tau_end: float) -> float | None:
        """The separation: the first tau >= start where lam < 0 (None if not before tau_end)."""
        lam_start = self.contact_force(self.start)
        if separates(lam_start):
            tau = self.start
        elif self.lam1 < 0.0:
            tau = max(-self.lam0 / self.lam1, self.start)
        else:
            return None
        return tau if tau <= tau_end else None

    def impulse(self, tau_a: float, tau_b: float) -> float:
        if tau_b <= tau_a:
            return 0.0
        return (self.lam0 + 0.5 * self.lam1 * (tau_a + tau_b)) * (tau_b - tau_a)

    def mean_force_ahead(self, tau: float, h: float) -> float:
        """Mean over [tau, tau + h] of lam continued as it is (0 once it would pull), N: what
        the riding ice will press on the structure over the next step if nothing changes."""
        lam, rate = self.contact_force(tau), self.lam1
        if lam <= 0.0:
            return 0.0
        if rate >= 0.0 or lam + rate * h >= 0.0:
            return lam + 0.5 * rate * h
        parting = lam / -rate  # < h
        return 0.5 * lam * parting / h


class LastStep(NamedTuple):
    """What the external solver keeps of the last step (its snapshot's ``previous`` is the first
    four fields, ``other_force`` the last two)."""

    v_in: float            # the structure's velocity input at the step start, m/s
    h: float               # the step's length, s
    felt: float            # the contact force the structure felt over it, N
    returned: float        # the contact force IceImpact returned for it, N
    raw: float | None      # the raw estimate of F_o made at its start, N (None: none)
    raw_time: float        # the time that estimate refers to, s


class ExternalSolver(EventSolver):
    """The exact event-driven method against an external structure (see the module docstring).

    The structure's inputs of the next step are set in :attr:`inputs` (``(x_in, v_in, a_in)``)
    before :meth:`advance_to`; the simulator does it."""

    name = "external"
    SAMPLES_AT_ONCE = False  # each step has its own structure inputs
    #: a Zeno sequence is closed at the chatter time: the structure's motion over its bounces is
    #: the other FMU's, which each step (or early return, its impulse a 0.1 us kick) restarts
    #: from, and which bounces down to 1 ns would outrun
    FOLLOW_ZENO = False
    #: its flights end where the other FMU's structure is (_flight_end): no compiled bounces
    COMPILED_BOUNCES = False

    def __init__(self, scene: Scene, record_impacts: bool = True):
        super().__init__(scene, record_impacts)
        self.inputs = (scene.structure_x_in, scene.structure_v_in, scene.structure_a_in)
        self.state = State(0.0, scene.structure_x_in, scene.structure_v_in, scene.ice_z0,
                           scene.ice_v0)
        self.jacobi = scene.jacobi
        #: the structure's own force F_o at the step start (N), its rate over the step (N/s)
        self.other_force = 0.0
        self.other_force_rate = 0.0
        self.step_start = 0.0
        #: the force for the master to hold over its next step (N), and, with a Jacobi master,
        #: the impulse returned so far beyond the contact impulses (N.s, see jacobi_force)
        self.coupling_force = 0.0
        self.lead = 0.0
        self.stick_impulse = 0.0  # contact impulse of the riding ice in the current step, N.s
        #: the last step (None before the first)
        self.previous: LastStep | None = None

    def _structure(self) -> ExtrapolatedStructure:
        """The structure from outside, extrapolated from its inputs at each step start."""
        return ExtrapolatedStructure(0.0)

    def _structure_drag(self) -> None:
        """No Morison drag here: the structure's loads live in the other FMU."""
        return None

    def _start(self) -> None:
        """Nothing yet: the first segment starts at the first step, from its inputs."""

    # the structure's inputs and force are state too: a full snapshot undoes a step
    checkpoint = Solver.checkpoint
    rollback = Solver.rollback

    # the structure's own force ------------------------------------------------------------------
    def unfelt_impulse(self, h: float) -> float:
        """Impulse IceImpact delivered that the structure given at this step start has not felt
        yet, N.s: 0 with a Gauss-Seidel master; with a Jacobi master the last step's contact
        force, which the master holds on the structure over this step of length h."""
        if not self.jacobi or self.previous is None:
            return 0.0
        return self.previous.returned * h

    def measure_other_force(self, t: float, v_in: float,
                            a_in: float) -> tuple[float | None, float]:
        """A raw estimate of F_o, N, and the time it refers to, s: ``m a_in - F_felt`` at the
        step start with ``a_in`` given, else the mean over the last step, ``m (v_in - v_prev) /
        h_prev - F_felt``, which refers to its midpoint (None before the first step)."""
        previous = self.previous
        if previous is None:
            return (self.m * a_in if a_in != 0.0 else None), t
        v_prev, h_prev, felt = previous.v_in, previous.h, previous.felt
        if a_in != 0.0:
            return self.m * a_in - felt, t
        return self.m * (v_in - v_prev) / h_prev - felt, t - 0.5 * h_prev

    def estimate_other_force(self, raw: float | None, ref: float,
                             t: float) -> tuple[float, float]:
        """F_o at the step start t, N, and its rate over the step, N/s: the raw estimate of this
        step (:meth:`measure_other_force`) and the last one's, extrapolated linearly to t."""
        if raw is None:
            return 0.0, 0.0
        previous = self.previous
        rate = 0.0
        if previous is not None and previous.raw is not None and ref > previous.raw_time:
            rate = (raw - previous.raw) / (ref - previous.raw_time)
        return raw + rate * (t - ref), rate

    def other_force_at(self, t: float) -> float:
        """F_o at time t within the current step, N."""
        return self.other_force + self.other_force_rate * (t - self.step_start)

    def _structure_at(self, t: float) -> None:
        """Anchor the extrapolated structure's acceleration F_o(t) / m for a segment from t."""
        self.context.osc = ExtrapolatedStructure(self.other_force_at(t) / self.m)

    # segments -----------------------------------------------------------------------------------
    def _begin(self, t: float, x: float, v: float, z: float, w: float, u: float,
               reanchor: bool = False, after_impact: bool = False) -> None:
        self._structure_at(t)
        super()._begin(t, x, v, z, w, u, reanchor, after_impact)

    def _fly_from_contact(self, t: float, x: float, v: float, w: float, u: float,
                          lam: float) -> None:
        self._structure_at(t)
        super()._fly_from_contact(t, x, v, w, u, lam)

    def _flight_end(self, t: float, x: float, v: float, w: float, u: float) -> None:
        self._structure_at(t)
        super()._flight_end(t, x, v, w, u)

    def _stick(self, t: float, x: float, v: float, u: float, hold: float = 0.0) -> None:
        self.seg = ExternalStick(self.context, t, x, v, u, self.other_force_at(t),
                                 self.other_force_rate, start=hold)
        self._set_sticking(True, t)

    def impulse_to(self, tau_event: float) -> float:
        """:meth:`EventSolver.impulse_to`, also summed in :attr:`stick_impulse` (the riding
        ice's contact impulse of the step, for :meth:`jacobi_force`; a flight adds 0.0)."""
        impulse = super().impulse_to(tau_event)
        self.stick_impulse += impulse
        return impulse

    def finish(self, t_end: float) -> float:
        """:meth:`EventSolver.finish`, its impulse also summed in :attr:`stick_impulse`."""
        impulse = super().finish(t_end)
        self.stick_impulse += impulse
        return impulse

    def advance_to(self, t_end: float, u: float, stop_at_event: bool = False) -> float:
        x_in, v_in, a_in = self.inputs
        t = self.state.t
        h = t_end - t
        # a Jacobi master holds the last step's force on the structure over the whole step it
        # planned (unfelt_impulse): such a step is not cut at an impact
        stop_at_event = stop_at_event and not self.jacobi
        raw, ref = self.measure_other_force(t, v_in, a_in)
        self.other_force, self.other_force_rate = self.estimate_other_force(raw, ref, t)
        self.step_start = t
        self._structure_at(t)
        # a Jacobi master's structure feels the last step's impulse over this step: the
        # extrapolated structure takes it at the step start
        unfelt = self.unfelt_impulse(h)
        v_s = v_in + unfelt / self.m
        self.u = u
        self.tau = 0.0
        z, w = self.state.z, self.state.w
        self.stick_impulse = 0.0
        started_riding = self.sticking
        if self.sticking:
            # the ice rides on the structure: it takes the structure's state, then stays if the
            # combined body's contact force is compressive
            lam = self.rules.free_contact_force(x_in, v_s, v_s, u)
            if separates(lam):
                self._fly_from_contact(t, x_in, v_s, v_s, u, lam)
            else:
                self._stick(t, x_in, v_s, u)
        else:
            # the structure lags its extrapolation: no penetration, the ice goes back to it
            self._begin(t, x_in, v_s, min(z, x_in), w, u, reanchor=True)
        impulse = self.march(t_end, stop_at_event)
        h = self.state.t - t  # (shorter if the step returned at an impact)
        returned = (self.jacobi_force(impulse, h, started_riding) if self.jacobi
                    else impulse / h)
        felt = (unfelt / h) if self.jacobi else returned
        self.previous = LastStep(v_in, h, felt, returned, raw, ref)
        self.coupling_force = returned
        return impulse

    def jacobi_force(self, impulse: float, h: float, started_riding: bool) -> float:
        """The force a Jacobi master holds on the structure over its next step, N.

        The structure feels it one step late. For impacts that is the scheme's delay (the
        velocity jump at the next step start stands for it); for the contact force of a riding
        floe it would act as an apparent damping ``~ M k h / (m + M)`` of the riding motion. So
        while the ice rides on the structure at the step end the force returned carries, instead
        of this step's riding contact impulse, the mean contact force the riding ice will press
        with over the next step (:meth:`ExternalStick.mean_force_ahead`), the one the structure
        should feel then; the riding impulse of a step that started riding was returned, as such
        a prediction, by the step before. The impacts' impulses are returned as they are. What
        the predictions returned beyond the contact impulses (:attr:`lead`, N.s: their errors,
        and a riding phase entered and left within one step) is taken back at the end of the
        first step that ends in flight, so that the impulses returned add up to the contact
        impulses."""
        riding = self.stick_impulse if started_riding else 0.0
        returned = (impulse - riding) / h
        seg = self.seg
        if isinstance(seg, ExternalStick):
            returned += seg.mean_force_ahead(self.tau, h)
        self.lead += returned * h - impulse
        if not isinstance(seg, ExternalStick):
            returned -= self.lead / h
            self.lead = 0.0
        return returned

    # snapshots ----------------------------------------------------------------------------------
    _KEYS = ("u", "previous", "other_force", "coupling_force", "lead", "degenerate")

    def _snapshot(self) -> dict[str, Any]:
        previous = None if self.previous is None else list(self.previous[:4])
        other = None if self.previous is None else list(self.previous[4:])
        return {"u": self.u, "previous": previous, "other_force": other,
                "coupling_force": self.coupling_force, "lead": self.lead,
                "degenerate": self.rules.degenerate.snapshot()}

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        u = rec.real("u")
        previous = rec.reals("previous", 4, allow_none=True)
        if previous is not None and not (previous[1] > 0.0 and math.isfinite(previous[1])):
            raise StateError(rec.field("previous") + "[1]", previous[1], "a step length > 0 (s)")
        other = rec.raw("other_force")
        if previous is None:
            if other is not None:
                raise StateError(rec.field("other_force"), other, "null when previous is null")
        else:
            if (not isinstance(other, list) or len(other) != 2
                    or not all(_finite_or_none(value, i == 0) for i, value in enumerate(other))):
                raise StateError(rec.field("other_force"), other,
                                 "[the raw estimate of F_o (N) or null, its time (s)]")
        coupling_force, lead = rec.real("coupling_force"), rec.real("lead")
        degenerate = self.rules.degenerate.read(rec.record("degenerate"))

        def apply() -> None:
            self.u = u
            self.previous = None if previous is None else LastStep(*previous, *other)
            self.coupling_force, self.lead = coupling_force, lead
            self.rules.degenerate.set(degenerate)
            self.seg = None
            self.tau = 0.0
            self.pending_impulse = 0.0
        return apply


def _finite_or_none(value: Any, none_allowed: bool) -> bool:
    if value is None:
        return none_allowed
    return (isinstance(value, int | float) and not isinstance(value, bool)
            and math.isfinite(value))
