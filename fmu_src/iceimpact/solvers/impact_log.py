""":class:`ImpactLog`: the impacts a solver lists, in order, as a sequence of
:class:`~iceimpact.physics.contact.Impact` records kept as rows of floats.

A run of the exact method makes some ten thousand impacts a simulated minute; most come from its
compiled march of bounces (:mod:`iceimpact.solvers.exact.bounces`) in blocks of rows, the others
from the Python march one by one. Kept as rows, a block goes in with one copy and the whole list
comes out as an array with one more (:func:`iceimpact.simulator.impacts_array`), where a list of
named tuples costs a Python object an impact each way.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from itertools import chain
from typing import Any, overload

import numpy as np

from ..physics.contact import Impact

_WIDTH = len(Impact._fields)
_new = tuple.__new__


class ImpactLog(Sequence):
    """The impacts listed by a solver: ``append`` one, ``extend_rows`` a block of rows (fields in
    :class:`Impact`'s order), ``del log[n:]`` to go back to the first n (a rollback), ``clear``,
    and read as a sequence of :class:`Impact` (indices, slices, iteration) or as rows at once
    (:meth:`rows`). Equal to any sequence of the same impacts."""

    __slots__ = ("_rows", "_n", "_tail", "append")

    def __init__(self, impacts: Sequence[Impact] = ()):
        self._rows = np.zeros((0, _WIDTH))  # rows 0.._n-1 hold the first impacts
        self._n = 0
        self._tail: list[Impact] = []  # the impacts appended one by one since
        self._tail.extend(impacts)
        #: ``append(impact)``: the tail's own (the Python march appends at every impact)
        self.append = self._tail.append

    def extend_rows(self, rows: np.ndarray) -> None:
        """Add impacts given as rows of floats (an (n, 8) array, :class:`Impact`'s fields)."""
        self._flush(len(rows))
        self._rows[self._n:self._n + len(rows)] = rows
        self._n += len(rows)

    def rows(self) -> np.ndarray:
        """All the impacts as an (n, 8) array of their fields (a copy)."""
        self._flush(0)
        return self._rows[:self._n].copy()

    def clear(self) -> None:
        self._n = 0
        self._tail.clear()

    def _flush(self, room: int) -> None:
        """Move the tail into the rows, with room for ``room`` more rows."""
        need = self._n + len(self._tail) + room
        if need > len(self._rows):
            grown = np.zeros((max(need, 2 * len(self._rows), 1024), _WIDTH))
            grown[:self._n] = self._rows[:self._n]
            self._rows = grown
        if self._tail:  # (every field a float: the flat sequence read at once)
            n = len(self._tail)
            self._rows[self._n:self._n + n] = np.fromiter(
                chain.from_iterable(self._tail), float, count=n * _WIDTH).reshape(n, _WIDTH)
            self._n += n
            self._tail.clear()

    def __len__(self) -> int:
        return self._n + len(self._tail)

    @overload
    def __getitem__(self, index: int) -> Impact: ...

    @overload
    def __getitem__(self, index: slice) -> list[Impact]: ...

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        n = len(self)
        if index < 0:
            index += n
        if not 0 <= index < n:
            raise IndexError("impact index out of range")
        if index >= self._n:
            return self._tail[index - self._n]
        return _new(Impact, self._rows[index].tolist())

    def __delitem__(self, index: slice) -> None:
        """``del log[n:]`` only: the impacts from the n-th on (a rollback)."""
        if not isinstance(index, slice) or index.stop is not None or index.step is not None:
            raise TypeError("an ImpactLog drops its last impacts only: del log[n:]")
        start = index.indices(len(self))[0]
        if start >= self._n:
            del self._tail[start - self._n:]
        else:
            self._n = start
            self._tail.clear()

    def __iter__(self) -> Iterator[Impact]:
        for row in self._rows[:self._n].tolist():
            yield _new(Impact, row)
        yield from list(self._tail)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sequence) or isinstance(other, str | bytes):
            return NotImplemented
        return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"ImpactLog({list(self)!r})"
