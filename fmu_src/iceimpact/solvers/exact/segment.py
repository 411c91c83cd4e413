"""What every segment of the exact method shares: the time resolution at an absolute time, the
searched segment (an event found by a root search on its signal), and the snapshot helpers."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import StateError
from ...limits import TIME_RESOLUTION
from ...record import Record
from ..search.rootfind import RootSearch

if TYPE_CHECKING:
    from .context import SegmentContext


#: How the vectorised sampler (sampling.py) evaluates a kind of segment, as each segment class
#: declares in its ``SAMPLING``: all its samples at once in array closed forms, per segment from
#: dense output (``states_at``, Taylor steps), or stepped to each sample.
GROUPED, STEPPED, MARCHED = "grouped", "stepped", "marched"





def _time_eps(t: float) -> float:
    scale = abs(t)
    return TIME_RESOLUTION * (scale if scale > 1.0 else 1.0)  # max(1.0, |t|)


class _SearchedSegment:
    """Snapshot of a segment given in closed form from its anchor, with a root search: the
    anchor values named by ``ANCHOR``, the search start and its frontier (Flight, LinearStick).

    Its ``anchor``, ``state_array``, ``impulse_array`` and ``PUSHES`` let
    :meth:`EventSolver.sample` evaluate all the samples in segments of one kind at once; any
    segment kind that gives them joins that vectorised pass (a segment of Taylor steps gives
    ``states_at``, and in contact ``impulses_between``, instead, evaluated per segment), the
    others are sampled step by step."""

    __slots__ = ()
    ANCHOR: tuple[str, ...] = ()
    #: a contact force acts during the segment (its impulse is not zero)
    PUSHES = False
    #: marching changes nothing in the segment but its search frontier, so a checkpoint of the
    #: frontier undoes a step (:meth:`EventSolver.checkpoint`)
    FRONTIER_ONLY = True
    #: how the vectorised sampler evaluates this kind (by state_array, all at once)
    SAMPLING = GROUPED

    def anchor(self) -> tuple[float, ...]:
        return tuple(getattr(self, name) for name in self.ANCHOR)

    def next_event(self, tau_end: float) -> float | None:
        """The segment's event if at or before tau_end: the first root of its ``value`` (a
        flight's gap, its impact; a sticking phase's contact force, its separation). The
        segment is its root search's signal (:class:`~iceimpact.solvers.search.rootfind.Signal`);
        :meth:`EventSolver.sample` calls the search directly, as here."""
        return self.search.next_root_of(tau_end, self)

    def state_array(self, anchor: tuple[np.ndarray, ...],
                    tau: np.ndarray) -> tuple[np.ndarray, ...]:
        """Vectorised :meth:`state` for segments of this kind with the same parameters and flow
        speed as this one: one anchor (arrays, ``ANCHOR`` order) and tau per sample."""
        raise NotImplementedError

    def impulse_array(self, anchor: tuple[np.ndarray, ...], tau_a: np.ndarray,
                      tau_b: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`impulse`, as :meth:`state_array`."""
        return np.zeros(np.shape(tau_a))
    _SEARCHED_KEYS = ("phase", "t0", "anchor", "start", "search")

    def snapshot(self, tau: float) -> dict[str, Any]:
        return {"phase": self.phase.value, "t0": self.t0,
                "anchor": list(self.anchor()), "start": self.start,
                "search": self.search.frontier()}

    @classmethod
    def read(cls, context: SegmentContext, rec: Record, u: float) -> Callable[[], Any]:
        """Validate a :meth:`snapshot` record; return the function that builds the segment."""
        rec.expect_keys(cls._SEARCHED_KEYS)
        t0 = rec.real("t0", low=0.0)
        anchor = rec.reals("anchor", len(cls.ANCHOR))
        start = rec.real("start", low=0.0)
        frontier = RootSearch.read_frontier(rec.record("search"), start)

        def make() -> Any:
            seg = cls(context, t0, *anchor, u, start)
            seg.search.set_frontier(frontier)
            return seg
        return make


def _floats(y) -> list[float]:
    return [float(c) for c in y]


def _entry(item: Any, field: str, names: tuple[str, ...]) -> Record:
    """A list entry [a, b, ...] of a snapshot as a record with the given field names."""
    if not isinstance(item, list | tuple) or len(item) != len(names):
        raise StateError(field, item, "[" + ", ".join(names) + "]")
    return Record(dict(zip(names, item, strict=True)), field)
