"""Method 3 with the modal structure (structure.model = 3): the ODEs of N modes at the contact point
integrated by ``solve_ivp`` (docs/explanation/modes.md).

The events and the contact rules are those of :class:`~iceimpact.solvers.ode.OdeSolver`, on the
contact point ``x = sum phi_k q_k``: the impact law with the effective mass
``1 / m_eff = sum phi_k^2 / m_k`` (the solver's m), the free acceleration of the contact point
``sum phi_k q_k''`` in the rules' hook. What the modes change is the integrated state:

- **Flight** ``[q_1..q_N, q_1'..q_N', z, w]`` (2N + 2): ``m_k q_k'' + c_k q_k' + k_k q_k = L_k``
  (L_k the held generalized load), the ice on its drag law; the gap ``sum phi_k q_k - z`` is the
  terminal event.
- **Riding** ``[q_1..q_N, q_1'..q_N', P]`` (2N + 1), the ice on the contact point (z = x): the
  modes coupled through the contact force ``lam = m_eff (D + M S) / (M + m_eff)``, D the drag on
  the ice at v, ``S = sum phi_k (c_k q_k' + k_k q_k - L_k) / m_k``; ``m_k q_k'' = ... + phi_k lam``.
  P is the drag impulse on the ice, so that the contact impulse is ``dP - M dv`` exactly as for
  the SDOF; lam turning tensile is the terminal event.

Any instant change of the contact point's velocity (an impact, a plastic merge) is an impulse
there: mode k's velocity changes by ``phi_k J / m_k`` (:meth:`Modes.velocity_change`). The solver
keeps the modal state found at the current event (``_now``) and the contact point's velocity
there; a segment started with another velocity starts its modes with that change.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..limits import drag_rate
from ..physics.modes import Modes, refuse_load_rates
from ..record import Record
from ..scene import QUADRATIC_DRAG, Scene
from .contact_rules import Phase
from .ode import _TINY, STABLE_STEP, OdeSolver, _ContactForce


class _ModalRates:
    """The modes' constants as arrays: masses, dampings, stiffnesses, load offsets, phi."""

    def __init__(self, modes: Modes):
        self.n = modes.count
        self.phi = np.array(modes.phi)
        self.mass = np.array(modes.mass)
        self.damping = np.array([osc.damping for osc in modes.oscillators])
        self.stiffness = np.array([osc.stiffness for osc in modes.oscillators])
        self.offset = np.array([osc.offset for osc in modes.oscillators])

    def free(self, q, p):
        """Each mode's q_k'' without a contact force (1-D states)."""
        return -(self.damping * p + self.stiffness * (q - self.offset)) / self.mass

    def velocity(self, y):
        """sum phi_k q_k' of a state (rows of arrays: element by element), summed in mode order."""
        n = self.n
        v = self.phi[0] * y[n]
        for k in range(1, n):
            v = v + self.phi[k] * y[n + k]
        return v


class _ModalFlight(_ModalRates):
    """Modes and ice free: ``[q, q', z, w]' = [q', (L - c q' - k q) / m, w, F_drag(w) / M]``."""

    def __init__(self, solver: ModalOdeSolver):
        super().__init__(solver.modes)
        self.M, self.u, self.drag = solver.M, solver.u, solver.drag

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        n = self.n
        q, p, w = y[:n], y[n:2 * n], y[2 * n + 1]
        return np.concatenate((p, self.free(q, p), (w, self.drag.force(w, self.u) / self.M)))

    def jacobian(self, t: float, y: np.ndarray) -> np.ndarray:
        """d(:meth:`__call__`)/dy, exact (the drag's dF/dw from its ``force_rate``)."""
        n = self.n
        jac = np.zeros((2 * n + 2, 2 * n + 2))
        for k in range(n):
            jac[k, n + k] = 1.0
            jac[n + k, k] = -self.stiffness[k] / self.mass[k]
            jac[n + k, n + k] = -self.damping[k] / self.mass[k]
        jac[2 * n, 2 * n + 1] = 1.0
        jac[2 * n + 1, 2 * n + 1] = self.drag.force_rate(y[2 * n + 1], self.u) / self.M
        return jac


class _ModalTogether(_ModalRates):
    """The ice riding on the contact point: the modes coupled through the contact force (see the
    module docstring); the state ``[q, q', P]``."""

    def __init__(self, solver: ModalOdeSolver):
        super().__init__(solver.modes)
        self.M, self.u, self.drag = solver.M, solver.u, solver.drag
        m_eff = solver.modes.effective_mass
        self.alpha = m_eff / (self.M + m_eff)
        self.beta = self.M * self.alpha

    def _parts(self, y):
        """(v, drag D, the modes' free accelerations, lam) at a state (rows of arrays too)."""
        n = self.n
        v = self.velocity(y)
        drag = self.drag.force(v, self.u)
        free = [-(self.damping[k] * y[n + k] + self.stiffness[k] * (y[k] - self.offset[k]))
                / self.mass[k] for k in range(n)]
        free_sum = self.phi[0] * free[0]
        for k in range(1, n):
            free_sum = free_sum + self.phi[k] * free[k]
        return v, drag, free, self.alpha * drag - self.beta * free_sum

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        n = self.n
        _, drag, free, lam = self._parts(y)
        accel = np.array(free) + self.phi * lam / self.mass
        return np.concatenate((y[n:2 * n], accel, (drag,)))

    def jacobian(self, t: float, y: np.ndarray) -> np.ndarray:
        """d(:meth:`__call__`)/dy, exact (the drag's dD/dv from its ``force_rate``)."""
        n = self.n
        v = self.velocity(y)
        d_drag = self.drag.force_rate(v, self.u)
        # d lam / dq_j and d lam / dq_j'
        lam_q = self.beta * self.phi * self.stiffness / self.mass
        lam_p = self.phi * (self.alpha * d_drag + self.beta * self.damping / self.mass)
        jac = np.zeros((2 * n + 1, 2 * n + 1))
        for k in range(n):
            jac[k, n + k] = 1.0
            share = self.phi[k] / self.mass[k]
            jac[n + k, :n] = share * lam_q
            jac[n + k, n:2 * n] = share * lam_p
            jac[n + k, k] -= self.stiffness[k] / self.mass[k]
            jac[n + k, n + k] -= self.damping[k] / self.mass[k]
        jac[2 * n, n:2 * n] = d_drag * self.phi
        return jac

    def contact_force(self, y) -> float:
        """Force on the contact point from the ice, N (the riding phase's lam)."""
        return self._parts(y)[3]

    def contact_force_rate(self, y):
        """d lam / dt (rows of arrays: element by element): ``alpha D'(v) v' - beta sum phi_k
        f_k'``, f_k' = -(c_k q_k'' + k_k q_k') / m_k."""
        n = self.n
        v, _, free, lam = self._parts(y)
        d_drag = self.drag.force_rate(v, self.u)
        accel = [free[k] + self.phi[k] * lam / self.mass[k] for k in range(n)]
        a = self.phi[0] * accel[0]
        rate = self.phi[0] * -(self.damping[0] * accel[0] + self.stiffness[0] * y[n]) / self.mass[0]
        for k in range(1, n):
            a = a + self.phi[k] * accel[k]
            rate = rate + self.phi[k] * -(self.damping[k] * accel[k]
                                          + self.stiffness[k] * y[n + k]) / self.mass[k]
        return self.alpha * d_drag * a - self.beta * rate

    def impulse(self, ya, yb) -> float:
        """Contact impulse on the structure between states ya and yb, N.s: the ice's drag
        impulse minus its momentum change."""
        n = self.n
        return float((yb[2 * n] - ya[2 * n]) - self.M * (self.velocity(yb) - self.velocity(ya)))


class _ModalGap:
    """Terminal event: the gap ``sum phi_k q_k - z`` closes (as the SDOF's ``_Gap``)."""

    terminal = True
    direction = -1

    def __init__(self, n: int, phi: Sequence[float], start: float, slack: float = 0.0):
        self.n, self.phi, self.start, self.slack = n, tuple(phi), start, slack

    def __call__(self, t: float, y: np.ndarray) -> float:
        x = 0.0
        for k, phi in enumerate(self.phi):
            x += phi * y[k]
        gap = x - y[2 * self.n] + self.slack
        return gap if t > self.start and gap != 0.0 else max(gap, _TINY)


class ModalOdeSolver(OdeSolver):
    """Method 3 with the modal structure (see the module docstring). The modes' loads of the next
    step are set by :meth:`set_loads` (the simulator does it)."""

    def __init__(self, scene: Scene, record_impacts: bool = True):
        self.modes = Modes(scene.mode_table, scene.mode_loads)
        _, v0 = scene.modal_start
        #: the modes' (q, q') at the current event and the contact point's velocity there
        self._now: tuple[list[float], list[float], float] = (
            [row[4] for row in scene.mode_table], [row[5] for row in scene.mode_table], v0)
        super().__init__(scene, record_impacts)

    # the modal state ----------------------------------------------------------------------------
    def modal_now(self, v: float) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at the current event with the contact point moving at v: the
        velocities found there, changed by the impulse that moved v."""
        q, p, v_ref = self._now
        if v == v_ref:
            return list(q), list(p)
        return list(q), self.modes.velocity_change(p, v - v_ref)

    def _contact_view(self, y):
        """The contact point's ``[x, v, z, w]`` (flight) or ``[x, v, P]`` (riding) of a modal
        state; the modal state becomes the current event's (``_now``)."""
        n = self.modes.count
        q, p = [float(c) for c in y[:n]], [float(c) for c in y[n:2 * n]]
        x, v = self.modes.contact(q, p)
        self._now = (q, p, v)
        return [x, v, *(float(c) for c in y[2 * n:])]

    def modal_state(self) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at the solver's time."""
        n = self.modes.count
        return [float(c) for c in self.y_now[:n]], [float(c) for c in self.y_now[n:2 * n]]

    def _size(self, phase: Phase) -> int:
        return 2 * self.modes.count + (2 if phase is Phase.FLIGHT else 1)

    def _gap_rate(self, state):
        return self.rhs.velocity(state) - state[2 * self.modes.count + 1]

    def _free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        q, p = self.modal_now(v)
        modes = self.modes  # (held loads: the same at any time)
        return modes.contact_acceleration(modes.since, q, p), self.drag.force(w, u) / self.M

    # rates ----------------------------------------------------------------------------------------
    def _damping_rate(self) -> float:
        """The fastest damping rate c_k / m_k of the modes, 1/s."""
        return max(osc.damping / osc.mass for osc in self.modes.oscillators)

    def _chunks(self, u: float) -> tuple[float, float]:
        """As :meth:`OdeSolver._chunks`, the rate being the modes' dampings and the ice's drag
        (the quadratic one at |u| + |ice.v0| + 2 |v0|)."""
        chunk = min(max(1.0, 20.0 * self.period), 5.0)
        s = self.scene
        if s.drag_model == QUADRATIC_DRAG:
            ice = drag_rate(s, abs(u) + abs(s.ice_v0) + 2.0 * abs(s.modal_start[1]))
        else:
            ice = s.drag_b / s.ice_M
        rate = max(self._damping_rate(), ice)
        if rate > 0.0:
            chunk = min(chunk, 2000.0 / rate)
        return chunk, min(self.period, chunk)

    def _max_step(self, y: np.ndarray) -> float:
        """As :meth:`OdeSolver._max_step`: in flight the modes' dampings and the linear drag's
        b / M (the quadratic one left out, as for the SDOF); riding, the modes' dampings and
        the drag's on the ice and the structure's effective mass together."""
        if self.method not in STABLE_STEP:
            return math.inf
        s = self.scene
        n = self.modes.count
        v = self.modes.contact(y[:n], y[n:2 * n])[1]
        quadratic = s.drag_model == QUADRATIC_DRAG
        if self.phase is Phase.FLIGHT:
            ice = 0.0 if quadratic else s.drag_b / s.ice_M
        else:
            damping = 2.0 * s.drag_B * abs(v - self.u) if quadratic else s.drag_b
            ice = damping / (self.modes.effective_mass + s.ice_M)
        rate = max(self._damping_rate(), ice)
        return STABLE_STEP[self.method] / rate if rate > 0.0 else math.inf

    # segments -------------------------------------------------------------------------------------
    def _equations(self, phase: Phase, start: float, gap_slack: float = 0.0) -> None:
        self.phase, self.segment_start, self.gap_slack = phase, start, gap_slack
        if phase is Phase.FLIGHT:
            self.rhs = _ModalFlight(self)
            self.event_fn = _ModalGap(self.modes.count, self.modes.phi, start, gap_slack)
        else:
            self.rhs = _ModalTogether(self)
            self.event_fn = _ContactForce(self.rhs, start)

    def _segment(self, phase: Phase, t: float, y: list[float], hold: float = 0.0,
                 gap_slack: float = 0.0) -> None:
        """The SDOF segment's start ``[x, v, z, w]`` or ``[x, v, P]`` in modal form: the modes
        of the current event, their velocities changed by the impulse that moved v to y[1]."""
        q, p = self.modal_now(float(y[1]))
        super()._segment(phase, t, [*q, *p, *y[2:]], hold, gap_slack)

    def set_loads(self, loads: Sequence[float], rates: Sequence[float] | None = None) -> None:
        """Hold the modes' generalized loads (N) from now on: the segment restarts at the
        current time on the modes under them (as at a new flow speed)."""
        refuse_load_rates(rates, 3)
        loads = tuple(float(load) for load in loads)
        if loads == self.modes.loads:
            return
        self.modes = self.modes.with_loads(loads)
        self.reanchor(self.u, self.state.t + self.first_chunk)

    # snapshots ------------------------------------------------------------------------------------
    _KEYS = OdeSolver._KEYS + ("loads",)

    def _snapshot(self) -> dict[str, Any]:
        data = super()._snapshot()
        data["loads"] = list(self.modes.loads)
        return data

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        modes = self.modes.with_loads(rec.reals("loads", self.modes.count))
        apply_rest = super()._read(rec, t)

        def apply() -> None:
            self.modes = modes  # (before the segment's equations are built on them)
            apply_rest()
        return apply
