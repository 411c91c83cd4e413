"""The modal structure: N damped oscillators seen at the contact point (structure.model = 3).

A designer's structure is a table of modes from a finite-element model: for mode k a natural
frequency f_k (omega_k = 2 pi f_k), a damping ratio zeta_k, a modal mass m_k and the value phi_k
of its mode shape at the ice action point (docs/explanation/modes.md)::

    m_k q_k'' + c_k q_k' + k_k q_k = phi_k F + L_k,   c_k = 2 zeta_k omega_k m_k,
    k_k = m_k omega_k^2
    x = sum phi_k q_k,   v = sum phi_k q_k'

F is the contact force on the structure and L_k a generalized load from the rest of the system,
held over a communication step. Free of contact each mode is a damped oscillator in closed form
(:class:`~.structure.Oscillator`, every damping regime, with the offset L_k / k_k of its held
load), so the contact point's motion is a sum of closed forms, and bounds on its derivatives for
all later times are sums of the modes' bounds (each mode's energy never grows).

An impulse J at the contact point changes mode k's velocity by ``phi_k J / m_k`` and the contact
point's by ``J / m_eff``, with the effective mass ``1 / m_eff = sum phi_k^2 / m_k``: the impact
law of the SDOF (eq. 12-17) holds with m_eff in place of m. One mode with phi = 1 is the SDOF
``(m, c, k)`` of the article.

Sums over the modes are written out in mode order (no numpy reduction, no BLAS): the same bits on
every CPU.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .structure import Oscillator


class Modes:
    """The modes of the structure under held generalized loads ``loads`` (N, one per mode).

    ``table`` rows are ``(f, zeta, m, phi)`` (Hz, 1, kg, 1); further columns are ignored, so a
    scene's :attr:`~iceimpact.Scene.mode_table` serves as it is."""

    __slots__ = ("table", "loads", "phi", "mass", "oscillators", "count", "flexibility",
                 "effective_mass", "share")

    def __init__(self, table: Sequence[Sequence[float]], loads: Sequence[float] | None = None):
        self.table = tuple(tuple(float(value) for value in row[:4]) for row in table)
        self.count = len(self.table)
        self.loads = tuple(float(load) for load in loads) if loads is not None else (
            (0.0,) * self.count)
        oscillators = []
        flexibility = 0.0
        for (f, zeta, m, phi), load in zip(self.table, self.loads, strict=True):
            omega = 2.0 * math.pi * f
            stiffness = m * omega * omega
            oscillators.append(Oscillator(m, 2.0 * zeta * omega * m, stiffness,
                                          offset=load / stiffness))
            flexibility += phi * phi / m
        #: (phi_k), (m_k), the oscillators of the modes (each q_k's closed form)
        self.phi = tuple(row[3] for row in self.table)
        self.mass = tuple(row[2] for row in self.table)
        self.oscillators = tuple(oscillators)
        #: sum phi_k^2 / m_k (1/kg) and its inverse, the contact point's effective mass (kg)
        self.flexibility = flexibility
        self.effective_mass = 1.0 / flexibility
        #: phi_k m_eff / m_k: mode k's share of a velocity change of the contact point
        self.share = tuple(phi * self.effective_mass / m for phi, m in zip(self.phi, self.mass,
                                                                            strict=True))

    def with_loads(self, loads: Sequence[float]) -> Modes:
        """The same modes under other held loads (N)."""
        return Modes(self.table, loads)

    def contact(self, q: Sequence[float], p: Sequence[float]) -> tuple[float, float]:
        """The contact point's displacement and velocity ``(sum phi q, sum phi q')``."""
        x = v = 0.0
        for phi, qk, pk in zip(self.phi, q, p, strict=True):
            x += phi * qk
            v += phi * pk
        return x, v

    def velocity_change(self, p: Sequence[float], dv: float) -> list[float]:
        """The modal velocities after the contact point's velocity changed by ``dv`` (m/s) in an
        instant, i.e. under the impulse ``m_eff dv`` at the contact point: each ``q_k'`` changes
        by ``phi_k J / m_k`` (:attr:`share` times dv)."""
        return [pk + share * dv for pk, share in zip(p, self.share, strict=True)]

    def free_accelerations(self, q: Sequence[float], p: Sequence[float]) -> list[float]:
        """Each mode's q_k'' without a contact force (under its held load), m/s^2."""
        return [osc.acceleration(qk, pk) for osc, qk, pk in zip(self.oscillators, q, p,
                                                                strict=True)]

    def contact_acceleration(self, q: Sequence[float], p: Sequence[float]) -> float:
        """The contact point's acceleration without a contact force, ``sum phi_k q_k''``."""
        a = 0.0
        for phi, ak in zip(self.phi, self.free_accelerations(q, p), strict=True):
            a += phi * ak
        return a

    def bounds(self, q: Sequence[float], p: Sequence[float]) -> tuple[float, float, float]:
        """(x'', a bound on |x''|, a bound on |x'''|) of the contact point for all later times
        of a flight from the modal state (q, q'): the sums over the modes of phi_k times each
        oscillator's (:meth:`~.structure.Oscillator.bounds`, its energy never grows)."""
        a = a_max = j_max = 0.0
        for phi, osc, qk, pk in zip(self.phi, self.oscillators, q, p, strict=True):
            if phi == 0.0:
                continue
            ak, ak_max, jk_max = osc.bounds(qk, pk)
            size = phi if phi > 0.0 else -phi
            a += phi * ak
            a_max += size * ak_max
            j_max += size * jk_max
        return a, a_max, j_max

    def envelope(self, q: Sequence[float], p: Sequence[float]) -> tuple[float, float]:
        """``(sum phi_k offset_k, sum |phi_k| R_k)``: the contact point stays within the second
        of the first for all later times of a flight, R_k mode k's amplitude bound about its
        offset (:meth:`~.structure.Oscillator.amplitude_bound`)."""
        centre = reach = 0.0
        for phi, osc, qk, pk in zip(self.phi, self.oscillators, q, p, strict=True):
            if phi == 0.0:
                continue
            centre += phi * osc.offset
            reach += (phi if phi > 0.0 else -phi) * osc.amplitude_bound(qk - osc.offset, pk)
        return centre, reach

    def ride_table(self) -> np.ndarray:
        """The modes as the riding phase's Taylor steps take them
        (:mod:`iceimpact.solvers.search.modal_taylor`): rows phi_k, m_k, c_k, k_k, L_k, omega_k
        and the load's offset L_k / k_k, a column per mode."""
        return np.array([self.phi, self.mass,
                         [osc.damping for osc in self.oscillators],
                         [osc.stiffness for osc in self.oscillators], self.loads,
                         [math.sqrt(osc.omega2) for osc in self.oscillators],
                         [osc.offset for osc in self.oscillators]], dtype=float)

    def rates(self) -> float:
        """The fastest rate of the free modes, 1/s: the largest ``omega_k (zeta_k +
        sqrt(zeta_k^2 + 1))`` (the magnitude of its fastest exponent, bounding an under-damped
        mode's omega_k too)."""
        rate = 0.0
        for f, zeta, _, _ in self.table:
            omega = 2.0 * math.pi * f
            rate = max(rate, omega * (zeta + math.sqrt(zeta * zeta + 1.0)))
        return rate
