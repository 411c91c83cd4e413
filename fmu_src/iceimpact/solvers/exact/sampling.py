"""The exact method's vectorised sampler: the states and impulses at many sample times of one
march, evaluated in closed forms per group of segments (:meth:`EventSolver.sample`)."""

from __future__ import annotations

import math
from array import array
from operator import attrgetter
from typing import Any

import numpy as np

from ..base import Samples
from ..contact_rules import Phase
from .segment import GROUPED, _SearchedSegment


def first_sample_after(times: Any, i: int, t0: float, tau_event: float) -> int:
    """The first index j >= i with ``times[j] - t0 >= tau_event``: the first sample a march
    reaches after the event (the test advance_to makes; it holds from its first j on, since
    times increase and rounding is monotone). Most events are a few samples apart: the first
    ones are tested in turn, then a bisection on the absolute times and a check of the exact
    test around it."""
    n = len(times)
    j = i
    stop = i + 8
    if stop > n:
        stop = n
    while j < stop:
        if times[j] - t0 >= tau_event:
            return j
        j += 1
    if j == n:
        return n
    # bisect.bisect_left(times, t0 + tau_event, j, n), written out: the compiled march of
    # bounces (bounces.py) calls this function on an array
    target = t0 + tau_event
    hi = n
    while j < hi:
        mid = (j + hi) // 2
        if times[mid] < target:
            j = mid + 1
        else:
            hi = mid
    while j > i and times[j - 1] - t0 >= tau_event:
        j -= 1
    while j < n and times[j] - t0 < tau_event:
        j += 1
    return j


#: Samples whose closed forms are evaluated at once, in runs of more than twice as many: their
#: temporaries (some tens of arrays) then stay in the processor's cache (3 % of Figure 2 over
#: 400 s, 40,000 samples); a shorter run is one pass (each pass costs some 40 numpy calls)
CHUNK = 8192


def _chunks(n: int) -> list[slice]:
    """Slices covering 0..n-1: one, or CHUNK each beyond 2 CHUNK (the closed forms are
    elementwise: the same values as one pass)."""
    if n <= 2 * CHUNK:
        return [slice(0, n)]
    return [slice(start, start + CHUNK) for start in range(0, n, CHUNK)]


def _sampling_kind(seg: Any) -> Any:
    """The segment's ``SAMPLING`` (segment.GROUPED, STEPPED or MARCHED), with a new _SampleGroup
    for GROUPED."""
    kind = seg.SAMPLING
    return _SampleGroup(seg) if kind == GROUPED else kind


class _SampleGroup:
    """The samples falling in segments of one kind (Flight or LinearStick), gathered during a
    sampled march and evaluated at once by the representative segment's array closed forms."""

    def __init__(self, representative: _SearchedSegment):
        self.rep = representative
        # per segment its anchor's values, flat, and its samples first..stop-1: machine numbers
        # copied as the march goes (the float objects, scattered in memory by then, would cost
        # a cache miss each to read back at the end)
        self.anchors = array("d")
        self.t0 = array("d")
        self.first = array("q")
        self.stop = array("q")
        # force-carrying pieces, one run per segment: anchor index, tau_from, samples i..j-1,
        # tau_event (nan: none), position of the first piece in the impulse values
        self.pieces: list[tuple[int, float, int, int, float, int]] = []
        # the anchor's values of a segment of this kind (the ANCHOR fields, read at once), and
        # the lists' appends, bound once (add runs for most segments of a sampled run)
        self._anchor_of = attrgetter(*representative.ANCHOR)
        self._add_anchor, self._add_t0 = self.anchors.extend, self.t0.append
        self._add_first, self._add_stop = self.first.append, self.stop.append
        self._pushes = representative.PUSHES

    def add(self, seg: _SearchedSegment, tau_from: float, i: int, j: int,
            tau_event: float | None, targets: array, values: array) -> None:
        """Samples i..j-1 in ``seg`` (from ``tau_from``); its event, if any, before sample j.

        A segment with a contact force adds one impulse piece per sample (from the previous
        sample, or ``tau_from``, to it) and one to its event, in the order the scalar march adds
        them; their values are filled in by :meth:`evaluate`."""
        self._add_anchor(self._anchor_of(seg))
        self._add_t0(seg.t0)
        self._add_first(i)
        self._add_stop(j)
        if not self._pushes:
            return
        k = len(self.t0) - 1
        self.pieces.append((k, tau_from, i, j, math.nan if tau_event is None else tau_event,
                            len(values)))
        if j - i > 16:  # (a long run of samples, such as a sticking phase's: at once)
            targets.frombytes(np.arange(i, j, dtype=np.int64).tobytes())
            values.frombytes(bytes(8 * (j - i)))  # 0.0 each
        else:
            targets.extend(range(i, j))
            values.extend([0.0] * (j - i))
        if tau_event is not None:
            targets.append(j)
            values.append(0.0)

    def evaluate(self, times: np.ndarray, out: Samples, values: np.ndarray) -> None:
        first = np.array(self.first, dtype=np.int64)
        counts = np.array(self.stop, dtype=np.int64) - first
        rows = np.repeat(np.arange(len(counts)), counts)
        # sample indices: each segment's run first..stop-1, concatenated
        index = np.arange(len(rows)) + np.repeat(first - (np.cumsum(counts) - counts), counts)
        width = len(self.rep.ANCHOR)
        anchors = np.array(self.anchors, dtype=float).reshape(len(self.t0), width)
        t0 = np.array(self.t0)
        tau = times[index] - t0[rows]
        for part in _chunks(len(index)):
            x, v, z, w = self.rep.state_array(tuple(anchors[rows[part]].T), tau[part])
            at = index[part]
            out.x[at], out.v[at], out.z[at], out.w[at] = x, v, z, w
        out.sticking[index] = self.rep.phase is Phase.STICK
        if self.pieces:
            k, tau_from, i, j, tau_event, position = (np.array(c) for c in
                                                       zip(*self.pieces, strict=True))
            n_samples = j - i
            n_pieces = n_samples + ~np.isnan(tau_event)
            run = np.repeat(np.arange(len(k)), n_pieces)  # the run of each piece
            o = np.arange(len(run)) - np.repeat(np.cumsum(n_pieces) - n_pieces, n_pieces)
            m = i[run] + o  # its sample (its end), or j for the piece to the event
            seg_t0 = t0[k[run]]
            # as the march: each piece from the previous sample (or tau_from) to its sample
            # (or the event), the times from the anchor as times[m] - t0
            tau_b = np.where(o < n_samples[run], times[np.minimum(m, len(times) - 1)] - seg_t0,
                             tau_event[run])
            tau_a = np.where(o == 0, tau_from[run], times[np.maximum(m - 1, 0)] - seg_t0)
            rows, at = k[run], position[run] + o
            for part in _chunks(len(at)):
                values[at[part]] = self.rep.impulse_array(tuple(anchors[rows[part]].T),
                                                          tau_a[part], tau_b[part])
