"""A linear structure given by its modes, seen at one contact point (no FMI here).

The structure of an external structural model (a finite-element model, a test) reduced to the
modes that matter at the contact point. Mode ``i`` has the natural frequency ``f_i`` (Hz, so
``omega_i = 2 pi f_i`` rad/s), the damping ratio ``zeta_i >= 0`` (every regime: undamped,
under-damped, critically damped ``zeta_i = 1``, over-damped ``zeta_i > 1``), the modal mass
``m_i > 0`` and the value ``phi_i`` of its mode shape at the contact point (dimensionless: the
modal coordinate ``q_i`` is then in metres). A force ``F`` at the contact point (positive in the
direction of ``x``) drives mode ``i`` with ``phi_i F``::

    m_i q_i'' + 2 zeta_i omega_i m_i q_i' + m_i omega_i^2 q_i = phi_i F(t)

and the contact point moves as ``x = sum phi_i q_i`` (velocity ``v`` and acceleration ``a``
likewise). A single mode with ``phi = 1`` is the damped oscillator ``m x'' + c x' + k x = F`` with
``omega = sqrt(k/m)`` and ``zeta = c / (2 sqrt(k m))`` (:meth:`Mode.from_mck`).

:meth:`ModalStructure.advance` is exact for a force held constant over the step (zero-order
hold, as a co-simulation master holds an input): per mode, the closed-form 2x2 transition of the
free oscillator plus the exact response to a constant force, written as increments
(``q1 = q + s v + g (q_s - q)``, ``q_s = phi F / (m omega^2)`` the static deflection) so that a
short step loses no digits to ``1 - cos``. The two coefficients ``s`` and ``g`` of a mode depend
on the step size only and are cached per step size.

The impact law of IceImpact's external-structure mode (``structure.model = 2``) needs the mass
the structure opposes to a short impulse at the contact point: :attr:`ModalStructure.impulse_mass`
``= 1 / sum(phi_i^2 / m_i)``, which for one mode is its effective mass ``m_i / phi_i^2``
(:attr:`Mode.effective_mass`). See docs/explanation/coupling.md, "The structure FMU".
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

from ..errors import ParameterError, checked_real

__all__ = ["ContactState", "Mode", "ModalStructure", "ParameterError"]

# Below this value of (1 + 2 zeta) omega h the coefficients of a step are summed as Taylor series
# (20 terms; term k is below 0.5^(k-1) / k! of the first): the closed forms would lose up to
# 1/(omega h)^2 of their digits to cancellation in 1 - cos(omega_d h).
_SERIES_LIMIT = 0.5
_SERIES_TERMS = 20
# Over-damped modes: above this mu h (mu = omega sqrt(zeta^2 - 1)) the response is written with
# the two real exponentials, below it with cosh and sinh (which cannot overflow there).
_EXPONENTIAL_LIMIT = 1.0
# Step sizes whose coefficients are kept (a master uses one or two step sizes).
_CACHE_SIZE = 8


def _finite(name: str, value: Any) -> float:
    """A finite Python or numpy number as a Python float (the package's one rule,
    :func:`~iceimpact.errors.checked_real`), else ParameterError."""
    return checked_real(name, value, "a finite number")


def _positive(value: float) -> bool:
    return value > 0.0


@dataclass(frozen=True)
class Mode:
    """One mode: natural frequency ``f`` (Hz), damping ratio ``zeta`` (1), modal mass ``m``
    (kg) and mode-shape value ``phi`` (1) at the contact point. Validated on construction
    (:class:`~iceimpact.scene.ParameterError` naming the field, its value and the range;
    ``name`` prefixes the field in messages, e.g. ``"mode2"``)."""

    f: float
    zeta: float = 0.0
    m: float = 1.0
    phi: float = 1.0
    name: str = "mode"

    def __post_init__(self) -> None:
        for field, value, allowed, ok in (
                ("f", self.f, "> 0 Hz", lambda v: v > 0.0),
                ("zeta", self.zeta, ">= 0", lambda v: v >= 0.0),
                ("m", self.m, "> 0 kg", lambda v: v > 0.0),
                ("phi", self.phi, "finite", lambda v: True)):
            label = f"{self.name}.{field}"
            number = _finite(label, value)
            if not ok(number):
                raise ParameterError(label, value, allowed)
            object.__setattr__(self, field, number)
        if not math.isfinite(self.omega ** 2 * self.m):
            raise ParameterError(f"{self.name}.f", self.f, f"> 0 Hz with a finite stiffness "
                                 f"m (2 pi f)^2 (m = {self.m!r} kg)")

    @classmethod
    def from_mck(cls, m: float, c: float, k: float, phi: float = 1.0,
                 name: str = "mode") -> Mode:
        """The mode of the oscillator ``m x'' + c x' + k x = F`` (kg, N.s/m, N/m) seen with
        the mode-shape value ``phi``: ``f = sqrt(k/m) / (2 pi)``, ``zeta = c / (2 sqrt(k m))``."""
        for field, value in (("m", m), ("c", c), ("k", k)):
            _finite(f"{name}.{field}", value)
        if not m > 0.0:
            raise ParameterError(f"{name}.m", m, "> 0 kg")
        if not k > 0.0:
            raise ParameterError(f"{name}.k", k, "> 0 N/m")
        if not c >= 0.0:
            raise ParameterError(f"{name}.c", c, ">= 0 N.s/m")
        return cls(f=math.sqrt(k / m) / (2.0 * math.pi), zeta=c / (2.0 * math.sqrt(k * m)),
                   m=m, phi=phi, name=name)

    @property
    def omega(self) -> float:
        """Natural circular frequency, rad/s."""
        return 2.0 * math.pi * self.f

    @property
    def k(self) -> float:
        """Modal stiffness ``m omega^2``, N/m."""
        return self.m * self.omega ** 2

    @property
    def c(self) -> float:
        """Modal damping ``2 zeta omega m``, N.s/m."""
        return 2.0 * self.zeta * self.omega * self.m

    @property
    def effective_mass(self) -> float:
        """Mass of this mode seen at the contact point, ``m / phi^2`` (kg; infinite where the
        mode does not move the contact point, ``phi = 0``)."""
        return self.m / self.phi ** 2 if self.phi != 0.0 else math.inf

    def step_coefficients(self, h: float) -> tuple[float, float]:
        """``(s, g)`` of an exact step of ``h`` seconds.

        ``s = e^(-zeta omega h) S(h)`` (s) and ``g = 1 - e^(-zeta omega h) (C(h) + zeta omega
        S(h))`` (1), where ``C = cos(omega_d h)``, ``S = sin(omega_d h) / omega_d`` when
        under-damped (``omega_d = omega sqrt(1 - zeta^2)``), ``C = 1``, ``S = h`` when critically
        damped and ``C = cosh(mu h)``, ``S = sinh(mu h) / mu`` when over-damped (``mu = omega
        sqrt(zeta^2 - 1)``). With ``q_s = phi F / (m omega^2)`` a step is::

            q(h) = q + s v + g (q_s - q)
            v(h) = v + omega^2 s (q_s - q) - (g + 2 zeta omega s) v
        """
        w, z = self.omega, self.zeta
        if (1.0 + 2.0 * z) * w * h < _SERIES_LIMIT:
            return _series(w, z, h)
        a = z * w * h
        # g is written as -expm1(...) plus small terms rather than 1 - C - ...: no digit is lost
        # to rounding in 1 - C when g is small.
        if z < 1.0:
            b = w * math.sqrt((1.0 - z) * (1.0 + z)) * h       # omega_d h
            decay = math.exp(-a)
            s = decay * h * _sinc(b)
            return s, -math.expm1(-a) + 2.0 * decay * math.sin(0.5 * b) ** 2 - z * w * s
        if z == 1.0:
            decay = math.exp(-a)
            return decay * h, -math.expm1(-a) - a * decay
        # Over-damped: the two real roots r1 (slow, written without cancellation) and r2 (fast).
        root = math.sqrt((z - 1.0) * (z + 1.0))
        mu = w * root
        r1, r2 = -w / (z + root), -w * (z + root)
        if mu * h < _EXPONENTIAL_LIMIT:
            s = math.exp(-a) * h * math.sinh(mu * h) / (mu * h)
        else:
            s = (math.exp(r1 * h) - math.exp(r2 * h)) / (2.0 * mu)
        return s, -math.expm1(r1 * h) + r1 * s


def _sinc(x: float) -> float:
    return math.sin(x) / x if x != 0.0 else 1.0


def _series(w: float, z: float, h: float) -> tuple[float, float]:
    """``(s, g)`` as Taylor series in h: ``s`` solves ``s'' + 2 zeta w s' + w^2 s = 0`` with
    ``s(0) = 0``, ``s'(0) = 1``, and ``g = w^2`` times its integral."""
    d_prev, d = 0.0, 1.0            # s^(k-1)(0) and s^(k)(0), from k = 1
    power = h                        # h^k / k!
    s = g = 0.0
    # |s^(k)(0)| <= ((1 + 2 zeta) w)^(k-1): with (1 + 2 zeta) w h < 0.5 the terms beyond the
    # 20th are below 1e-24 of the first; a fixed count (some terms vanish, e.g. zeta = 0).
    for k in range(1, _SERIES_TERMS + 1):
        term = d * power
        s += term
        g += w * w * term * h / (k + 1)
        d_prev, d = d, -2.0 * z * w * d - w * w * d_prev
        power *= h / (k + 1)
    return s, g


class ContactState(NamedTuple):
    """The contact point after a step: displacement ``x`` (m), velocity ``v`` (m/s) and
    acceleration ``a`` (m/s2, under the force of the step)."""

    x: float
    v: float
    a: float


class ModalStructure:
    """A structure of ``n`` modes seen at one contact point, advanced exactly for a force held
    over each step.

    ``modes``: the :class:`Mode` s; ``q0``, ``v0``: initial modal displacements (m) and
    velocities (m/s), zero when left out.

        >>> s = ModalStructure([Mode.from_mck(1600.0, 200.0, 1e6)])   # IceImpact's structure
        >>> s.advance(1e-3, 1000.0)                                    # 1 kN held for 1 ms
    """

    def __init__(self, modes: Iterable[Mode], q0: Sequence[float] | None = None,
                 v0: Sequence[float] | None = None):
        self.modes: tuple[Mode, ...] = tuple(modes)
        if not self.modes:
            raise ParameterError("modes", 0, "at least one mode")
        for mode in self.modes:
            if not isinstance(mode, Mode):
                raise TypeError(f"modes must be Mode objects, not {type(mode).__name__}")
        n = len(self.modes)
        self._omega = tuple(m.omega for m in self.modes)
        self._zeta = tuple(m.zeta for m in self.modes)
        # static deflection of each mode per newton at the contact point, m/N
        self._static = tuple(m.phi / (m.m * m.omega ** 2) for m in self.modes)
        self._phi = tuple(m.phi for m in self.modes)
        self._cache: dict[float, tuple[tuple[float, float], ...]] = {}
        self.q: list[float] = [0.0] * n
        self.qdot: list[float] = [0.0] * n
        self.set_state([0.0] * n if q0 is None else q0, [0.0] * n if v0 is None else v0)

    @property
    def n(self) -> int:
        """Number of modes."""
        return len(self.modes)

    # state ---------------------------------------------------------------------------------------
    def set_state(self, q: Sequence[float], qdot: Sequence[float]) -> None:
        """Set the modal displacements ``q`` (m) and velocities ``qdot`` (m/s)."""
        values = []
        for label, seq in (("q", q), ("v", qdot)):
            seq = list(seq)
            if len(seq) != self.n:
                raise ParameterError(f"modal {label}", seq, f"{self.n} values, one per mode")
            values.append([_finite(f"{mode.name}.{label}0", value)
                           for mode, value in zip(self.modes, seq, strict=True)])
        self.q, self.qdot = values

    def snapshot(self) -> dict[str, list[float]]:
        """The modal state as plain data (``{"q": [...], "qdot": [...]}``)."""
        return {"q": list(self.q), "qdot": list(self.qdot)}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Return to a :meth:`snapshot` (validated; ParameterError and no change if unsound)."""
        if not isinstance(snapshot, dict) or set(snapshot) != {"q", "qdot"}:
            raise ParameterError("structure state", snapshot, "an object with q and qdot")
        self.set_state(snapshot["q"], snapshot["qdot"])

    # the contact point ---------------------------------------------------------------------------
    @property
    def x(self) -> float:
        """Displacement of the contact point, m."""
        return math.fsum(p * q for p, q in zip(self._phi, self.q, strict=True))

    @property
    def v(self) -> float:
        """Velocity of the contact point, m/s."""
        return math.fsum(p * v for p, v in zip(self._phi, self.qdot, strict=True))

    def acceleration(self, force: float) -> float:
        """Acceleration of the contact point (m/s2) under the contact force ``force`` (N)."""
        force = _finite("force", force)
        return math.fsum(
            p * (w * w * (st * force - q) - 2.0 * z * w * v)
            for p, w, z, st, q, v in zip(self._phi, self._omega, self._zeta, self._static,
                                         self.q, self.qdot, strict=True))

    @property
    def impulse_mass(self) -> float:
        """Mass the structure opposes to a short impulse at the contact point,
        ``1 / sum(phi_i^2 / m_i)`` (kg): an impulse ``J`` changes ``v`` by ``J / impulse_mass``.
        The mass IceImpact's impact law needs (``structure.m`` in external-structure mode)."""
        mobility = math.fsum(m.phi ** 2 / m.m for m in self.modes)
        return 1.0 / mobility if mobility > 0.0 else math.inf

    @property
    def stiffness(self) -> float:
        """Static stiffness at the contact point, ``1 / sum(phi_i^2 / (m_i omega_i^2))`` (N/m):
        a force ``F`` held for ever deflects the contact point by ``F / stiffness``."""
        compliance = math.fsum(p * st for p, st in zip(self._phi, self._static, strict=True))
        return 1.0 / compliance if compliance > 0.0 else math.inf

    def energy(self) -> float:
        """Kinetic plus strain energy of the modes, ``sum m_i (qdot_i^2 + omega_i^2 q_i^2) / 2``
        (J)."""
        return math.fsum(0.5 * m.m * (v * v + (w * q) ** 2) for m, w, q, v in
                         zip(self.modes, self._omega, self.q, self.qdot, strict=True))

    # stepping ------------------------------------------------------------------------------------
    def coefficients(self, h: float) -> tuple[tuple[float, float], ...]:
        """``(s, g)`` of every mode for a step of ``h`` s (:meth:`Mode.step_coefficients`),
        cached per step size."""
        cached = self._cache.get(h)
        if cached is None:
            if len(self._cache) >= _CACHE_SIZE:
                self._cache.pop(next(iter(self._cache)))
            cached = self._cache[h] = tuple(m.step_coefficients(h) for m in self.modes)
        return cached

    def advance(self, h: float, force: float) -> ContactState:
        """Advance ``h`` seconds with the contact force ``force`` (N) held constant: exact.

        Returns the contact point's displacement, velocity and acceleration at the end of the
        step (the acceleration under ``force``, the left limit). Raises ParameterError (and
        changes nothing) for a step that is not finite and > 0 or a force that is not finite.
        """
        h = checked_real("h", h, "finite and > 0 s", _positive)
        force = _finite("force", force)
        q_new, v_new = [], []
        for (s, g), w, z, st, q, v in zip(self.coefficients(float(h)), self._omega, self._zeta,
                                           self._static, self.q, self.qdot, strict=True):
            offset = st * force - q          # q_s - q
            q_new.append(q + s * v + g * offset)
            v_new.append(v + w * w * s * offset - (g + 2.0 * z * w * s) * v)
        self.q, self.qdot = q_new, v_new
        return ContactState(self.x, self.v, self.acceleration(force))
