"""The one interface every solver method implements, and the records they produce.

A solver owns the state of both bodies and marches it: ``advance_to(t_end, u)`` moves from its
current time to ``t_end`` with the flow speed u held constant, appends every impact to
``impacts`` and returns the impulse delivered to the structure on the way. The simulator above it
knows nothing of how a method marches; a method knows nothing of FMI or scene files.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from ..scene import Scene


class SolverError(RuntimeError):
    """A method cannot continue the run (an unstable explicit step, a failed integration); the
    message says why and what to change. The run stops: its state is no longer trustworthy."""


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


class Solver:
    """Base class: parameters, impact list, state. Subclasses implement :meth:`advance_to`."""

    #: short name used in reports and benchmarks
    name = "base"

    def __init__(self, scene: Scene):
        self.scene = scene
        self.m = scene.structure_m
        self.c = scene.structure_c
        self.k = scene.structure_k
        self.M = scene.ice_M
        self.e = scene.impact_e
        self.impacts: list[Impact] = []
        self.state = State(0.0, scene.structure_x0, scene.structure_v0, scene.ice_z0, scene.ice_v0)
        self.sticking = False
        self.sticking_since: float | None = None  # start of the current sticking phase, s

    @property
    def t(self) -> float:
        return self.state.t

    def set_restitution(self, e: float) -> None:
        """Change e for impacts from now on (``impact.e`` is tunable)."""
        self.e = e

    def advance_to(self, t_end: float, u: float) -> float:
        """March to ``t_end`` with flow speed u; return the impulse on the structure (N.s)."""
        raise NotImplementedError
