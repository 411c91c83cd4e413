"""Method 1 against an external structure (structure.model = 2): the ice as a co-simulation
component.

The structure lives in another FMU. At the start of each communication step the master gives the
contact point's displacement ``x_in``, velocity ``v_in`` and, optionally, acceleration ``a_in``
(under the contact force of the previous step); IceImpact returns the impulse the ice delivered
during the step, which the master applies to the structure as the force ``impulse / h`` held over
the same step (Gauss-Seidel, ice first).

Within a step (docs/coupling.md, "External-structure mode"):

- **The structure's own forces.** ``F_o`` (spring, damping, anything but the contact) is estimated
  at the step start from the structure's acceleration and the force IceImpact applied:
  ``F_o = m a_s - F_prev``, with ``a_s = a_in`` when the master gives it (non-zero), else the mean
  acceleration over the last step, ``(v_in - v_in_prev) / h_prev`` (exact for a structure stepped
  with the force held). ``m`` is ``structure.m``, the effective mass at the contact point.
- **Flight.** The structure moves as a mass ``m`` under ``F_o``
  (:class:`~iceimpact.physics.external.ExtrapolatedStructure`): a polynomial, so the event
  solver's :class:`~iceimpact.solvers.event.Flight` finds every impact as the exact first root of
  the gap, with its no-miss guarantee. An impact applies eq. 16-17 with ``m`` and the flight that
  follows is anchored on the structure's velocity jump. The chatter and Zeno closures are those of
  :mod:`~iceimpact.solvers.contact_rules` (their time scale is the period ``2 pi sqrt(m / k)``:
  ``structure.k`` only sets it in this mode).
- **Sticking.** The ice rides on the structure. The contact force is that of the combined body of
  mass ``m + M`` under ``F_o`` and the drag ``D``: ``(m + M) a = F_o + D``, so
  ``lam = (m D - M F_o) / (m + M)``, held over the step (the master holds it too). Estimating
  ``F_o`` from the structure's acceleration means the previous contact force enters ``lam`` scaled
  by ``M / (m + M) < 1``: the classic remedy of the added-mass instability, stable for any mass
  ratio (``lam = D - M a_s`` would feed the ice's inertia back with a factor ``M / m`` and
  diverge for ``M > m``). The bodies separate at the first step start where ``lam < 0``.
- **The structure's lag.** The master applies the impulse of a step spread over that step, so the
  structure it reports next is behind IceImpact's extrapolation (which jumped in velocity at the
  impact): the ice can be a little past the reported structure at a step start. Contact cannot be
  tensile nor penetrate, so the ice is put back at the structure (``z = x_in``, its velocity
  kept) and the contact rules decide at zero gap: an impact only if the ice still approaches the
  reported structure. While the bodies stick the ice takes the structure's reported state.

Every step starts afresh from the inputs: the state that carries over is the ice's, the sticking
flag, and the previous step's ``v_in``, length and force (the snapshot's ``previous``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ..physics.external import ExtrapolatedStructure
from ..physics.ice import make_drag
from ..scene import Scene
from .base import Solver, State
from .contact_rules import EXACT_POLICY, ContactRules, Phase, separates
from .event import EventSolver
from .state import Record, StateError


class ExternalStick:
    """Ice riding on the external structure for the rest of a step: the combined body of mass
    m + M under the structure's own force F_o and the drag at the start, the contact force
    ``lam = (m D - M F_o) / (m + M)`` held (the separation is looked for at step starts)."""

    phase = Phase.STICK

    def __init__(self, solver: ExternalSolver, t0: float, x0: float, v0: float, u: float,
                 start: float = 0.0):
        m, M = solver.m, solver.M
        drag = solver.drag.force(v0, u)
        other = solver.other_force
        self.t0, self.x0, self.v0, self.u = t0, x0, v0, u
        self.a = (other + drag) / (m + M)
        self.lam = max(0.0, (m * drag - M * other) / (m + M))

    def state(self, tau: float) -> tuple[float, float, float, float]:
        x = self.x0 + (self.v0 + 0.5 * self.a * tau) * tau
        v = self.v0 + self.a * tau
        return x, v, x, v

    def next_event(self, tau_end: float) -> float | None:
        return None

    def impulse(self, tau_a: float, tau_b: float) -> float:
        return self.lam * (tau_b - tau_a) if tau_b > tau_a else 0.0


class ExternalSolver(EventSolver):
    """The exact event-driven method against an external structure (see the module docstring).

    The structure's inputs of the next step are set in :attr:`inputs` (``(x_in, v_in, a_in)``)
    before :meth:`advance_to`; the simulator does it."""

    name = "external"

    def __init__(self, scene: Scene, record_impacts: bool = True):
        Solver.__init__(self, scene, record_impacts)
        self.inputs = (scene.structure_x_in, scene.structure_v_in, scene.structure_a_in)
        self.state = State(0.0, scene.structure_x_in, scene.structure_v_in, scene.ice_z0,
                           scene.ice_v0)
        self.osc = ExtrapolatedStructure(0.0)
        self.drag = make_drag(scene)
        self.rules = ContactRules(self.m, self.M, scene.omega_n, self._free_accels, EXACT_POLICY)
        self.u = scene.flow_u
        self.tau = 0.0
        self.pending_impulse = 0.0
        self.other_force = 0.0
        #: (v_in, step length, contact force) of the last step, None before the first
        self.previous: tuple[float, float, float] | None = None
        self.seg = None

    # the structure's inputs and force are state too: a full snapshot undoes a step
    checkpoint = Solver.checkpoint
    rollback = Solver.rollback

    def _stick(self, t: float, x: float, v: float, u: float, hold: float = 0.0) -> None:
        self.seg = ExternalStick(self, t, x, v, u)
        self._set_sticking(True, t)

    def estimate_other_force(self, v_in: float, a_in: float) -> float:
        """F_o = m a_s - F_prev, N: the structure's forces other than the contact (see the
        module docstring)."""
        previous = self.previous
        force = previous[2] if previous is not None else 0.0
        if a_in != 0.0:
            accel = a_in
        elif previous is not None:
            accel = (v_in - previous[0]) / previous[1]
        else:
            accel = 0.0
        return self.m * accel - force

    def advance_to(self, t_end: float, u: float) -> float:
        x_in, v_in, a_in = self.inputs
        t = self.state.t
        h = t_end - t
        self.other_force = self.estimate_other_force(v_in, a_in)
        self.osc = ExtrapolatedStructure(self.other_force / self.m)
        self.u = u
        self.tau = 0.0
        z, w = self.state.z, self.state.w
        if self.sticking:
            # the ice rides on the structure: it takes the structure's state, then stays if the
            # combined body's contact force is compressive
            lam = self.rules.free_contact_force(x_in, v_in, v_in, u)
            if separates(lam):
                self._fly_from_contact(t, x_in, v_in, v_in, u, lam)
            else:
                self._stick(t, x_in, v_in, u)
        else:
            # the structure lags its extrapolation: no penetration, the ice goes back to it
            self._begin(t, x_in, v_in, min(z, x_in), w, u, reanchor=True)
        impulse = self._march(t_end, u)
        self.previous = (v_in, h, impulse / h)
        return impulse

    # snapshots ----------------------------------------------------------------------------------
    _KEYS = ("u", "previous", "degenerate")

    def _snapshot(self) -> dict[str, Any]:
        return {"u": self.u, "previous": None if self.previous is None else list(self.previous),
                "degenerate": self.rules.degenerate.snapshot()}

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        u = rec.real("u")
        previous = rec.reals("previous", 3, allow_none=True)
        if previous is not None and not (previous[1] > 0.0 and math.isfinite(previous[1])):
            raise StateError(rec.field("previous") + "[1]", previous[1], "a step length > 0 (s)")
        degenerate = self.rules.degenerate.read(rec.record("degenerate"))

        def apply() -> None:
            self.u = u
            self.previous = None if previous is None else tuple(previous)
            self.rules.degenerate.set(degenerate)
            self.seg = None
            self.tau = 0.0
            self.pending_impulse = 0.0
        return apply
