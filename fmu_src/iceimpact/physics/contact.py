"""Contact between ice and structure: the impact law and the sticking phase.

Impact (eq. 12-17): momentum is conserved and Newton's restitution law holds; positions do not jump
(eq. 18). Sticking (our replacement for the article's steady-state thresholds, eq. 27-29):
both bodies move together, ``(m + M) x'' + c x' + k x = F_drag(x')``, and the contact force on the
structure, ``lam = F_drag(x') - M x''``, must stay compressive (>= 0).
"""

from __future__ import annotations

from typing import NamedTuple


class Impact(NamedTuple):
    """One impact (eq. 11-18). Velocities in m/s, impulse on the structure in N.s."""

    t: float              # time, s
    x: float              # position of contact, m (x = z)
    v_minus: float        # structure velocity before
    w_minus: float        # ice velocity before
    v_plus: float         # structure velocity after
    w_plus: float         # ice velocity after
    impulse: float        # m (v+ - v-)
    restitution: float    # e applied (0 for the plastic impact that closes a Zeno sequence)

    @property
    def approach_speed(self) -> float:
        """w- - v-, the closing speed (>= 0)."""
        return self.w_minus - self.v_minus


def impact(v_minus: float, w_minus: float, m: float, M: float, e: float) -> tuple[float, float]:
    """Post-impact velocities (structure v+, ice w+) from pre-impact ones (eq. 16-17).

    ``m v+ + M w+ = m v- + M w-`` (eq. 12) and ``v+ - w+ = e (w- - v-)`` (eq. 13).
    """
    total = m + M
    momentum = m * v_minus + M * w_minus
    approach = w_minus - v_minus
    v_plus = (momentum + e * M * approach) / total
    w_plus = (momentum - e * m * approach) / total
    return v_plus, w_plus


def impact_impulse(v_minus: float, v_plus: float, m: float) -> float:
    """Impulse delivered to the structure by one impact, N.s: m (v+ - v-)."""
    return m * (v_plus - v_minus)


def impact_energy_loss(v_minus: float, w_minus: float, m: float, M: float, e: float) -> float:
    """Kinetic energy lost in an impact, J: (1 - e^2) mu (w- - v-)^2 / 2, mu = m M / (m + M)."""
    mu = m * M / (m + M)
    return 0.5 * (1.0 - e * e) * mu * (w_minus - v_minus) ** 2


def contact_force(structure_accel: float, ice_accel: float, m: float, M: float) -> float:
    """Contact force lam on the structure needed to keep the bodies together, N.

    With free accelerations a_x (structure alone) and a_z (ice alone, drag only) at the same state,
    ``lam = mu (a_z - a_x)``; lam >= 0 keeps them together, lam < 0 means they separate.
    Equivalently lam = -mu g'' where g = x - z is the gap of a free flight.
    """
    return m * M / (m + M) * (ice_accel - structure_accel)
