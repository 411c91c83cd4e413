"""What the segments of the exact method and its march of bounces read of their solver, and
nothing else: :class:`SegmentContext`, the bodies' laws (masses, the structure's closed form,
the drag laws, the contact rules), built once by the solver; :class:`BounceHost`, the few
fields of the solver's state the compiled march reads and writes.

A segment (:class:`~.flight.Flight`, :class:`~.sticking.LinearStick`, ...) is built from a
context and its anchor, so it depends on no solver, and the solver's modules import the segment
modules, never the other way (docs/explanation/architecture.md).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from ...physics.structure import Oscillator, morison_oscillator


class SegmentContext:
    """The laws a segment of the exact method follows, from one scene (SI units):

    - ``m``, ``c``, ``k``: the structure's mass (with the Morison added mass), damping and
      stiffness; ``M``: the ice's mass;
    - ``drag``: the ice's drag law; ``structure_drag``: the Morison drag on the structure (a
      drag law, None when off), ``structure_b`` its linearised damping (0 unless linearised),
      ``dragged_structure`` the structure under its quadratic form (None unless quadratic);
    - ``osc``: the structure's closed form without a flow, for the segments that start now (a
      structure from another FMU is re-anchored here by its solver at each segment start);
    - ``flight_cls``: the kind of flight (``Flight``, or ``DraggedFlight`` under the quadratic
      Morison drag); ``rules``: the contact rules (built on ``free_accels``, then set here by
      the solver); ``max_impacts``: the impacts a step may take (the march of bounces reads
      these three);
    - ``structure_osc(u)``, ``structure_bounds(x, v, u)``, ``free_accels(x, v, w, u)``: the
      structure's closed form in a flow, its acceleration bounds, the bodies' free
      accelerations (the contact rules ask these at every impact).

    Segments only read it. Its fields are plain slots, read at the cost of a solver's
    attributes (no properties: a flight is built at every impact)."""

    __slots__ = ("m", "c", "k", "M", "drag", "structure_drag", "structure_b",
                 "dragged_structure", "osc", "flight_cls", "rules", "max_impacts",
                 "free_accels", "_osc_by_flow")

    def __init__(self, m: float, c: float, k: float, M: float, drag: Any,
                 structure_drag: Any, dragged_structure: Any, osc: Any, flight_cls: type,
                 max_impacts: int):
        self.m, self.c, self.k, self.M = m, c, k, M
        self.drag = drag
        self.structure_drag = structure_drag
        self.structure_b = (structure_drag.b if structure_drag is not None
                            and not structure_drag.quadratic else 0.0)
        self.dragged_structure = dragged_structure
        self.osc = osc
        self.flight_cls = flight_cls
        self.max_impacts = max_impacts
        self.rules: Any = None  # (the rules are built on free_accels: the solver sets them)
        self._osc_by_flow: tuple[float, Oscillator] | None = None
        #: the free accelerations (x, v, w, u) -> (a_x, a_z) the contact rules ask at every
        #: impact: without a Morison drag on the structure, the shorter form
        self.free_accels = (self._free_accels if self.structure_b or dragged_structure
                            else self._free_accels_without_morison)

    def structure_osc(self, u: float) -> Oscillator:
        """The structure's closed form in a flow of speed u: ``osc``, or with the linearised
        Morison drag the oscillator of m, c, k with its damping and offset (the last one is
        kept)."""
        if not self.structure_b:
            return self.osc
        if self._osc_by_flow is None or self._osc_by_flow[0] != u:
            self._osc_by_flow = (u, morison_oscillator(self.m, self.c, self.k,
                                                       self.structure_b, u))
        return self._osc_by_flow[1]

    def structure_bounds(self, x: float, v: float, u: float) -> tuple[float, float, float]:
        """The structure's acceleration and bounds on |x''| and |x'''| for all later times."""
        if self.dragged_structure is not None:
            return self.dragged_structure.bounds(x, v, u)
        return self.structure_osc(u).bounds(x, v)

    def _free_accels(self, x: float, v: float, w: float, u: float) -> tuple[float, float]:
        """The free accelerations (structure, ice) at (x, v, w) under the flow u."""
        if self.dragged_structure is not None:
            a_x = self.dragged_structure.acceleration(x, v, u)
        else:
            # (structure_osc called only with a Morison drag: this runs at every impact)
            osc = self.structure_osc(u) if self.structure_b else self.osc
            a_x = osc.acceleration(x, v)
        return a_x, self.drag.accel_bounds(w, u)[0]

    def _free_accels_without_morison(self, x: float, v: float, w: float,
                                     u: float) -> tuple[float, float]:
        """:meth:`_free_accels` without the structure's Morison drag (asked at every impact)."""
        return self.osc.acceleration(x, v), self.drag.accel_bounds(w, u)[0]


class BounceHost(Protocol):
    """What the compiled march of bounces (:class:`~.bounces.BounceMarch`) reads and writes of
    its solver: the laws (``context``); the current segment and the position in it (a flight the
    march ends on replaces it, at its start); the end of a Zeno tail (the march takes none); the
    restitution; the impact count, the step's budget and the time the step started from (the
    sampler moves the last two from sample interval to sample interval); the impacts it makes go
    to ``record_rows`` (rows of :class:`~iceimpact.solvers.impact_log.ImpactLog`)."""

    context: SegmentContext
    seg: Any
    tau: float
    zeno_end: float | None
    e: float
    impact_count: int
    impact_limit: float
    step_start: float

    def record_rows(self, rows: np.ndarray) -> None:
        """Count and list the impacts of ``rows`` (t, x, v-, w-, v+, w+, impulse, e)."""
