"""Method 1, exact and event-driven: closed-form flights, exact impact times, a sticking phase.

Between events each body follows its closed form (structure: eq. 9-10 and the other damping
regimes, :mod:`iceimpact.physics.structure`; ice: eq. 6-7 or the exact quadratic-drag solution,
:mod:`iceimpact.physics.ice`), anchored at the event that started the segment, so communication
steps never re-base them. Impact times are the first roots of the gap g = x - z, located by
:class:`~iceimpact.solvers.search.rootfind.RootSearch`, which proves the intervals it skips
root-free and so never misses a grazing touch. Each impact applies eq. 16-17.

The contact rules (impact step, chatter and Zeno closure, degenerate contacts, sticking entry,
contact force, separation, re-anchoring on a flow change) are those of
:mod:`iceimpact.solvers.contact_rules`, with its :data:`EXACT_POLICY`. A Zeno sequence (e < 1,
bodies pressed together) is followed bounce by bounce and closed by one plastic impact once the
rest of the sequence would take less than ``ZENO_TIME`` (or, beyond ``ZENO_BUDGET`` bounces, at
its estimated end, the bodies moving together to it); the bodies then stick: linear drag in closed
form (a damped oscillator of mass m + M, damping c + b, equilibrium b u / k, cf. eq. 27-29),
quadratic drag by high-order Taylor steps (:mod:`iceimpact.solvers.search.taylor`: while the sign of
u - x' holds the right-hand side is a polynomial, so the series follow by recurrence; each step
from the state the previous one ended in, none ahead of the time asked for). They separate when
the contact force would turn tensile.

The modules, one concern each:

- :mod:`.context`: what a segment and the march of bounces read of their solver (the laws of
  the bodies, built once by the solver) and, for the march, the few fields it writes;
- :mod:`.segment`: what every segment shares (the searched segment, the time resolution at t);
- :mod:`.flight`: the bodies free (:class:`Flight`, :class:`DraggedFlight`) and the clearances
  that prove a stretch of a flight free of contact;
- :mod:`.sticking`: the bodies together (:class:`LinearStick`, :class:`QuadraticStick`) and the
  clearances that prove the contact force stays a push;
- :mod:`.sampling`: the vectorised sampler of many sample times in one march;
- :mod:`.bounces`: the march of bounces (flight, impact, flight...) compiled by numba where it
  is installed, on the same functions as the Python march, handing back to it at anything
  else;
- :mod:`.solver`: :class:`EventSolver`, the method itself;
- :mod:`.external`: :class:`ExternalSolver`, the same method against a structure from another
  FMU;
- :mod:`.modal`: :class:`ModalSolver`, the same method with the modal structure (N modes at the
  contact point: flights as sums of closed forms, riding by Taylor steps).
"""

from ..base import Samples
from .external import ExternalSolver
from .flight import DraggedFlight, Flight
from .modal import ModalFlight, ModalRide, ModalSolver
from .solver import EventSolver
from .sticking import LinearStick, QuadraticStick

__all__ = ["DraggedFlight", "EventSolver", "ExternalSolver", "Flight", "LinearStick",
           "ModalFlight", "ModalRide", "ModalSolver", "QuadraticStick", "Samples"]
