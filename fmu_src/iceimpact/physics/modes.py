"""The modal structure: N damped oscillators seen at the contact point (structure.model = 3).

A designer's structure is a table of modes from a finite-element model: for mode k a natural
frequency f_k (omega_k = 2 pi f_k), a damping ratio zeta_k, a modal mass m_k and the value phi_k
of its mode shape at the ice action point (docs/explanation/modes.md)::

    m_k q_k'' + c_k q_k' + k_k q_k = phi_k F + L_k(t),   c_k = 2 zeta_k omega_k m_k,
    k_k = m_k omega_k^2,   x = sum phi_k q_k,   v = sum phi_k q_k'

F is the contact force on the structure and L_k a generalized load from the rest of the system,
given at the start of a communication step (``since``) with its rate: ``L_k(t) = L_k + R_k (t -
since)`` over the step (R_k = 0: held). Free of contact each mode is then its free response
about the particular solution ``q_p(t) = (L_k(t) - c_k rho_k) / k_k``, rho_k = R_k / k_k, which
moves at the speed rho_k: with ``y = q - q_p`` the damped oscillator ``m_k y'' + c_k y' + k_k y =
0`` in closed form (:class:`~.structure.Oscillator`, every damping regime), so the contact
point's motion is a sum of closed forms, and bounds on its derivatives for all later times are
sums of the modes' bounds (each free response's energy never grows; q_k'' = y'').

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

from ..errors import ParameterError
from .structure import Oscillator


def refuse_load_rates(rates: Sequence[float] | None, method: int) -> None:
    """Methods 2 and 3 hold each load over a step: a load rate other than 0 is refused, naming
    the method that takes them."""
    if rates is not None and any(rate != 0.0 for rate in rates):
        raise ParameterError("load rates", list(rates), f"0 with solver.method = {method}: this "
                             "method holds each load over a step; method 1 takes loads that "
                             "change linearly over it")


class Modes:
    """The modes of the structure under the generalized loads ``loads`` (N, one per mode) given
    at the time ``since`` (s) and changing at ``rates`` (N/s; default 0: held).

    ``table`` rows are ``(f, zeta, m, phi)`` (Hz, 1, kg, 1); further columns are ignored, so a
    scene's :attr:`~iceimpact.Scene.mode_table` serves as it is."""

    __slots__ = ("table", "loads", "rates", "since", "phi", "mass", "oscillators", "count",
                 "flexibility", "effective_mass", "share", "drift", "held")

    def __init__(self, table: Sequence[Sequence[float]], loads: Sequence[float] | None = None,
                 rates: Sequence[float] | None = None, since: float = 0.0):
        self.table = tuple(tuple(float(value) for value in row[:4]) for row in table)
        self.count = n = len(self.table)
        self.loads = tuple(float(load) for load in loads) if loads is not None else (0.0,) * n
        self.rates = tuple(float(rate) for rate in rates) if rates is not None else (0.0,) * n
        self.since = float(since)
        #: no load changes within the step: the particular solutions stand still
        self.held = all(rate == 0.0 for rate in self.rates)
        oscillators = []
        flexibility = 0.0
        for (f, zeta, m, phi), load in zip(self.table, self.loads, strict=True):
            omega = 2.0 * math.pi * f
            stiffness = m * omega * omega
            oscillators.append(Oscillator(m, 2.0 * zeta * omega * m, stiffness,
                                          offset=load / stiffness))
            flexibility += phi * phi / m
        #: (phi_k), (m_k), the oscillators of the modes (each free response's closed form; their
        #: offsets the held loads' static deflections)
        self.phi = tuple(row[3] for row in self.table)
        self.mass = tuple(row[2] for row in self.table)
        self.oscillators = tuple(oscillators)
        #: rho_k = R_k / k_k (m/s): the speed of mode k's particular solution
        self.drift = tuple(rate / osc.stiffness for rate, osc in zip(self.rates, oscillators,
                                                                      strict=True))
        #: sum phi_k^2 / m_k (1/kg) and its inverse, the contact point's effective mass (kg)
        self.flexibility = flexibility
        self.effective_mass = 1.0 / flexibility
        #: phi_k m_eff / m_k: mode k's share of a velocity change of the contact point
        self.share = tuple(phi * self.effective_mass / m for phi, m in zip(self.phi, self.mass,
                                                                            strict=True))

    def with_loads(self, loads: Sequence[float], rates: Sequence[float] | None = None,
                   since: float = 0.0) -> Modes:
        """The same modes under other loads (N) given at ``since`` (s), changing at ``rates``
        (N/s)."""
        return Modes(self.table, loads, rates, since)

    def loads_at(self, t: float) -> list[float]:
        """The generalized loads at time t (s), N."""
        return [load + rate * (t - self.since) for load, rate in zip(self.loads, self.rates,
                                                                       strict=True)]

    def offsets(self, t: float) -> list[float]:
        """Each mode's particular solution at time t (m): ``(L_k(t) - c_k rho_k) / k_k``, the
        held load's static deflection when the loads are held."""
        if self.held:
            return [osc.offset for osc in self.oscillators]
        return [(load - osc.damping * rho) / osc.stiffness for load, rho, osc in
                zip(self.loads_at(t), self.drift, self.oscillators, strict=True)]

    def deviations(self, t: float, q: Sequence[float],
                   p: Sequence[float]) -> tuple[list[float], list[float]]:
        """Each mode's free response at time t from the modal state (q, q'): ``(q_k - q_p,
        q_k' - rho_k)``."""
        return ([qk - off for qk, off in zip(q, self.offsets(t), strict=True)],
                [pk - rho for pk, rho in zip(p, self.drift, strict=True)])

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

    def contact_acceleration(self, t: float, q: Sequence[float], p: Sequence[float]) -> float:
        """The contact point's acceleration without a contact force at time t,
        ``sum phi_k (L_k(t) - c_k q_k' - k_k q_k) / m_k``."""
        a = 0.0
        for phi, osc, load, qk, pk in zip(self.phi, self.oscillators, self.loads_at(t), q, p,
                                          strict=True):
            a += phi * ((load - osc.damping * pk - osc.stiffness * qk) / osc.mass)
        return a

    def bounds(self, t: float, q: Sequence[float],
               p: Sequence[float]) -> tuple[float, float, float]:
        """(x'', a bound on |x''|, a bound on |x'''|) of the contact point for all later times
        of a flight from the modal state (q, q') at time t: the sums over the modes of phi_k
        times each free response's (:meth:`~.structure.Oscillator.deviation_bounds`)."""
        y, ydot = self.deviations(t, q, p)
        return self.deviation_bounds(y, ydot)

    def deviation_bounds(self, y: Sequence[float],
                         ydot: Sequence[float]) -> tuple[float, float, float]:
        """:meth:`bounds` from each mode's free response (y, y')."""
        a = a_max = j_max = 0.0
        for phi, osc, yk, ydk in zip(self.phi, self.oscillators, y, ydot, strict=True):
            if phi == 0.0:
                continue
            ak, ak_max, jk_max = osc.deviation_bounds(yk, ydk)
            size = phi if phi > 0.0 else -phi
            a += phi * ak
            a_max += size * ak_max
            j_max += size * jk_max
        return a, a_max, j_max

    def reach(self, y: Sequence[float], ydot: Sequence[float]) -> float:
        """``sum |phi_k| R_k``: the contact point stays within it of ``sum phi_k q_p`` for all
        later times of a flight, R_k mode k's amplitude bound
        (:meth:`~.structure.Oscillator.amplitude_bound`) from its free response (y, y')."""
        reach = 0.0
        for phi, osc, yk, ydk in zip(self.phi, self.oscillators, y, ydot, strict=True):
            if phi == 0.0:
                continue
            reach += (phi if phi > 0.0 else -phi) * osc.amplitude_bound(yk, ydk)
        return reach

    def ride_table(self) -> np.ndarray:
        """The modes as the riding phase's Taylor steps take them
        (:mod:`iceimpact.solvers.search.modal_taylor`): rows phi_k, m_k, c_k, k_k, R_k,
        omega_k, a column per mode (the loads at each step's start are given per step)."""
        return np.array([self.phi, self.mass,
                         [osc.damping for osc in self.oscillators],
                         [osc.stiffness for osc in self.oscillators], self.rates,
                         [math.sqrt(osc.omega2) for osc in self.oscillators]], dtype=float)

    def rates_bound(self) -> float:
        """The fastest rate of the free modes, 1/s: the largest ``omega_k (zeta_k +
        sqrt(zeta_k^2 + 1))`` (the magnitude of its fastest exponent, bounding an under-damped
        mode's omega_k too)."""
        rate = 0.0
        for f, zeta, _, _ in self.table:
            omega = 2.0 * math.pi * f
            rate = max(rate, omega * (zeta + math.sqrt(zeta * zeta + 1.0)))
        return rate
