"""Method 2 with the modal structure (structure.model = 3): the article's fixed-step scheme
(:mod:`~iceimpact.solvers.fixed_step`) on N modes at the contact point
(docs/explanation/modes.md).

What the scheme does is unchanged; the structure's closed form becomes the modes':

- **Flight.** Each mode follows its own closed form from the anchor (the physics
  :class:`~iceimpact.physics.structure.Oscillator` of :attr:`Modes.oscillators`, every damping
  regime, its held generalized load an offset L_k / k_k), evaluated at the grid's local times;
  the contact point is ``x = sum phi_k q_k``, ``v = sum phi_k q_k'``. The ice is marched as for
  the SDOF (closed form, or explicit Euler with the quadratic drag).
- **Impact** at a grid point, detected as for the SDOF (the eq. 26 window or the gap's sign
  change), by eq. 16-17 with the effective mass ``1 / m_eff = sum phi_k^2 / m_k`` in place of m;
  each mode's velocity jumps by ``phi_k J / m_k`` (J the impulse on the contact point), the
  positions are kept, and all closed forms restart there.
- **Steady state** (eq. 27-29): the same thresholds (i)-(iii) on the contact point and the ice;
  the bodies are then pinned where the coupled modes balance the drag at rest,
  ``F = F_drag(0)`` on the contact point: ``q_k = (phi_k F + L_k) / k_k``, ``q_k' = 0``,
  ``x = z = sum phi_k q_k``, the structure receiving the constant contact force F. This is the
  SDOF's pin with the modes' static compliance ``sum phi_k^2 / k_k`` in place of 1 / k; like
  the SDOF's, it ignores how the modes would ring into that equilibrium.

A change of the held loads (:meth:`ModalFixedStepSolver.set_loads`) starts a new grid at the
time of the change, as a new flow speed does (a pinned state is released from its pin).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..physics.modes import Modes, refuse_load_rates
from ..record import Record
from ..scene import Scene
from .fixed_step import FixedStepSolver


class ModalFixedStepSolver(FixedStepSolver):
    """The fixed-step scheme with the modal structure (see the module docstring)."""

    def __init__(self, scene: Scene, record_impacts: bool = True):
        self.modes = Modes(scene.mode_table, scene.mode_loads)
        # the modal state the next anchor starts from (None: the closed forms at its time)
        self._pending: tuple[list[float], list[float]] | None = (
            [row[4] for row in scene.mode_table], [row[5] for row in scene.mode_table])
        super().__init__(scene, record_impacts)

    # the modes ------------------------------------------------------------------------------------
    def _pin_modes(self) -> tuple[list[float], list[float]]:
        """The modes pinned at the steady state: ``q_k = (phi_k F + L_k) / k_k``, at rest."""
        force = self.drag.force(0.0, self.u)
        q = [(phi * force + load) / osc.stiffness for phi, load, osc in
             zip(self.modes.phi, self.modes.loads, self.modes.oscillators, strict=True)]
        return q, [0.0] * self.modes.count

    def _modal_at(self, t: float) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at time t >= the anchor."""
        if self.pinned:
            return self._pin_modes()
        return self._responses(t - self.t_a)

    def _responses(self, tau: float) -> tuple[list[float], list[float]]:
        """Each mode's (q, q') tau after the anchor, on its closed form."""
        q, p = [], []
        for osc, qk, pk in zip(self.modes.oscillators, self.q_a, self.p_a, strict=True):
            qt, pt = osc.response(qk, pk, tau)
            q.append(qt)
            p.append(pt)
        return q, p

    def modal_state(self) -> tuple[list[float], list[float]]:
        """The modes' (q, q') at the solver's time."""
        return self._modal_at(self.state.t)

    def _structure_at(self, tau: float) -> tuple[float, float]:
        return self.modes.contact(*self._responses(tau))

    def _structure_array(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.zeros_like(tau)
        v = np.zeros_like(tau)
        for phi, osc, qk, pk in zip(self.modes.phi, self.modes.oscillators, self.q_a, self.p_a,
                                    strict=True):
            qt, pt = osc.response_array(qk, pk, tau)
            x += phi * qt
            v += phi * pt
        return x, v

    def _pin_position(self) -> float:
        """Where the pinned contact point rests: ``sum phi_k (phi_k F + L_k) / k_k``."""
        return self.modes.contact(*self._pin_modes())[0]

    def _pin_force(self) -> float:
        """The constant contact force of the steady state: the drag on the ice at rest, N."""
        return self.drag.force(0.0, self.u)

    # anchors --------------------------------------------------------------------------------------
    def _anchor(self, t: float, x: float, v: float, z: float, w: float) -> None:
        """Restart the closed forms at time t from the modes there (or the pending ones), their
        velocities changed by the impulse that moved the contact point's velocity to v."""
        q, p = self._pending if self._pending is not None else self._modal_at(t)
        self._pending = None
        v_modes = self.modes.contact(q, p)[1]
        if v != v_modes:
            p = self.modes.velocity_change(p, v - v_modes)
        self.q_a, self.p_a = list(q), list(p)
        super()._anchor(t, x, v, z, w)

    def _release(self, t: float) -> None:
        self._pending = self._pin_modes()
        super()._release(t)

    def set_loads(self, loads: Sequence[float], rates: Sequence[float] | None = None) -> None:
        """Hold the modes' generalized loads (N) from now on: a new grid starts at the current
        time, from the modes there (a pinned state is released from its pin)."""
        refuse_load_rates(rates, 2)
        loads = tuple(float(load) for load in loads)
        if loads == self.modes.loads:
            return
        t = self.state.t
        if self.pinned:
            self._release(t)  # (from the pin under the loads held so far)
            self.modes = self.modes.with_loads(loads)
            return
        self._pending = self._modal_at(t)
        self.modes = self.modes.with_loads(loads)
        s = self.state
        self._anchor(t, s.x, s.v, s.z, s.w)

    # snapshots ------------------------------------------------------------------------------------
    _KEYS = FixedStepSolver._KEYS + ("loads", "q_a", "p_a")

    def _snapshot(self) -> dict[str, Any]:
        data = super()._snapshot()
        data.update({"loads": list(self.modes.loads), "q_a": list(self.q_a),
                     "p_a": list(self.p_a)})
        return data

    def _read(self, rec: Record, t: float) -> Callable[[], None]:
        n = self.modes.count
        modes = self.modes.with_loads(rec.reals("loads", n))
        q_a, p_a = rec.reals("q_a", n), rec.reals("p_a", n)
        apply_rest = super()._read(rec, t)

        def apply() -> None:
            apply_rest()
            self.modes, self.q_a, self.p_a = modes, list(q_a), list(p_a)
            self._pending = None
        return apply
