"""An independent structure and plain Gauss-Seidel and Jacobi masters, for the ice-structure
coupling tests.

This module is the independent check of a coupled run: it imports nothing from ``iceimpact``
(nor from the FMUs' sources) and shares no code with them. It has two parts.

``ExactSdof(m, c, k, x0=0, v0=0)``
    The damped oscillator ``m x'' + c x' + k x = F`` advanced exactly for a force held constant
    over each step: the state ``(x, v, 1)`` is multiplied by ``expm(h A)`` of the augmented
    matrix ``A = [[0, 1, 0], [-k/m, -c/m, F/m], [0, 0, 0]]`` (``scipy.linalg.expm``; the
    exponential of ``h [[0, 1, 0], [-k/m, -c/m, 1/m], [0, 0, 0]]`` is cached per step size and
    the force enters through its last column). ``step(h, force)`` returns ``(x, v, a)`` at the
    end of the step, ``a`` under the held force; ``acceleration(force)`` is ``(force - c v -
    k x) / m``.

``gauss_seidel(ice, structure, t_end, h, t0=0.0, second_order=False)``
    The coupling loop. ``ice`` is any object with::

        ice.step(t, h, x_in, v_in, a_in) -> impulse

    that advances the ice from ``t`` to ``t + h`` against a structure extrapolated from the
    contact point's displacement ``x_in`` (m), velocity ``v_in`` (m/s) and acceleration ``a_in``
    (m/s2) at ``t``, and returns the impulse (N.s) the ice delivered to the structure during the
    step (IceImpact.fmu in external-structure mode: set ``structure.x_in``, ``structure.v_in``,
    ``structure.a_in``, ``fmi2DoStep``, read ``contact.impulse``). ``structure`` is any object with
    ``x``, ``v``, ``acceleration(force)`` and ``step(h, force)`` (an :class:`ExactSdof`, or a
    wrapper around ModalStructure.fmu that sets ``force``, steps and reads ``x``, ``v``, ``a``).

    Each communication step, in this order (Gauss-Seidel, ice first):

    1. read the structure at ``t``: ``x``, ``v`` and ``a = acceleration(F_prev)``, ``F_prev`` the
       force of the previous step (0 at the start); with ``second_order=False`` the ice gets
       ``a_in = 0`` (first-order extrapolation ``x_in + v_in tau``);
    2. ``impulse = ice.step(t, h, x, v, a)``;
    3. ``F = impulse / h`` is held over ``[t, t + h]`` on the structure: ``structure.step(h, F)``.

``jacobi(ice, structure, t_end, h, t0=0.0, second_order=False)``
    The same loop as a Jacobi (parallel) master, the fixed-step scheme of ECOS and libcosim:
    both components step from the values exchanged at ``t``, so the structure holds over
    ``[t, t + h]`` the force the ice returned for the *previous* step (0 over the first), and
    ``a = acceleration(F_held)`` is under the force it held over the previous step.

    Both return a :class:`CoupledRun` of arrays: ``t`` (the ``n + 1`` communication points), ``x``,
    ``v`` (the structure at those points) and ``impulse``, ``force`` (per step, ``n`` values).
    The step sizes are ``t[k+1] - t[k]`` with ``t[k] = t0 + k h`` (the last one may be shorter so
    that the run ends at ``t_end``).

Example, with a stand-in ice that delivers one impulse of 1 N.s in its first step::

    class Kick:
        def step(self, t, h, x_in, v_in, a_in):
            return 1.0 if t == 0.0 else 0.0

    run = gauss_seidel(Kick(), ExactSdof(1600.0, 200.0, 1e6), t_end=1.0, h=1e-3)
    run.x[-1]   # the oscillator's response to 1 N.s spread over the first millisecond

To measure the coupling error, compare a coupled run with the ice model's own built-in structure
(IceImpact with ``structure.model = 1``) at decreasing ``h``: the error of this scheme is first
order in ``h``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.linalg import expm


class ExactSdof:
    """``m x'' + c x' + k x = F``, advanced exactly for ``F`` held over each step (see the module
    docstring)."""

    def __init__(self, m: float, c: float, k: float, x0: float = 0.0, v0: float = 0.0):
        if not (m > 0.0 and c >= 0.0 and k >= 0.0):
            raise ValueError(f"ExactSdof needs m > 0, c >= 0, k >= 0 (got {m}, {c}, {k})")
        self.m, self.c, self.k = float(m), float(c), float(k)
        self.x, self.v = float(x0), float(v0)
        self._generator = np.array([[0.0, 1.0, 0.0],
                                    [-self.k / self.m, -self.c / self.m, 1.0 / self.m],
                                    [0.0, 0.0, 0.0]])
        self._propagators: dict[float, np.ndarray] = {}

    def propagator(self, h: float) -> np.ndarray:
        """``expm(h A)`` of the augmented matrix per newton of force (3 x 3), cached per h."""
        p = self._propagators.get(h)
        if p is None:
            p = self._propagators[h] = expm(h * self._generator)
        return p

    def acceleration(self, force: float) -> float:
        return (force - self.c * self.v - self.k * self.x) / self.m

    def step(self, h: float, force: float) -> tuple[float, float, float]:
        p = self.propagator(h)
        self.x, self.v = (float(p[0, 0] * self.x + p[0, 1] * self.v + p[0, 2] * force),
                          float(p[1, 0] * self.x + p[1, 1] * self.v + p[1, 2] * force))
        return self.x, self.v, self.acceleration(force)

    def energy(self) -> float:
        return 0.5 * self.m * self.v ** 2 + 0.5 * self.k * self.x ** 2


class Ice(Protocol):
    def step(self, t: float, h: float, x_in: float, v_in: float, a_in: float) -> float: ...


class Structure(Protocol):
    x: float
    v: float

    def acceleration(self, force: float) -> float: ...

    def step(self, h: float, force: float) -> object: ...


@dataclass
class CoupledRun:
    """A coupled run: ``t``, ``x``, ``v`` at the communication points; ``impulse``, ``force``
    per step."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    impulse: np.ndarray
    force: np.ndarray


def gauss_seidel(ice: Ice, structure: Structure, t_end: float, h: float, t0: float = 0.0,
                 second_order: bool = False) -> CoupledRun:
    """Couple ``ice`` and ``structure`` from ``t0`` to ``t_end`` with steps ``h`` (see the
    module docstring)."""
    return _loop(ice, structure, t_end, h, t0, second_order, parallel=False)


def jacobi(ice: Ice, structure: Structure, t_end: float, h: float, t0: float = 0.0,
           second_order: bool = False) -> CoupledRun:
    """Couple ``ice`` and ``structure`` with a Jacobi master: the structure holds the ice's
    force of the previous step (see the module docstring)."""
    return _loop(ice, structure, t_end, h, t0, second_order, parallel=True)


def _loop(ice: Ice, structure: Structure, t_end: float, h: float, t0: float,
          second_order: bool, parallel: bool) -> CoupledRun:
    if not (h > 0.0 and t_end > t0):
        raise ValueError(f"the coupling loop needs h > 0 and t_end > t0 (got h = {h}, "
                         f"t0 = {t0}, t_end = {t_end})")
    n = max(1, math.ceil((t_end - t0) / h - 1e-9))
    times = [min(t0 + k * h, t_end) for k in range(n)] + [t_end]
    xs, vs, impulses, forces = [structure.x], [structure.v], [], []
    held = 0.0      # the force the structure held over the previous step, N
    returned = 0.0  # the ice's force of the previous step, N
    for k in range(n):
        t, step = times[k], times[k + 1] - times[k]
        a = structure.acceleration(held) if second_order else 0.0
        impulse = float(ice.step(t, step, structure.x, structure.v, a))
        if parallel:   # Jacobi: this step's force reaches the structure next step
            held, returned = returned, impulse / step
        else:          # Gauss-Seidel, ice first: this step's force, over this step
            held = returned = impulse / step
        structure.step(step, held)
        xs.append(structure.x)
        vs.append(structure.v)
        impulses.append(impulse)
        forces.append(returned)
    return CoupledRun(np.array(times), np.array(xs), np.array(vs), np.array(impulses),
                      np.array(forces))
