"""The layout of a sweep row: the fixed columns, the type of each column, and rows brought to
those types (ints as ints, everything else a float, the status a string)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

#: The run index, before the varied parameters.
RUN_COLUMN = "run"
#: ``"ok"`` or the error of the run, after the varied parameters.
STATUS_COLUMN = "status"
#: Wall time of the run, s.
WALL_COLUMN = "wall_s"
STATUS_OK = "ok"

#: Keys of :func:`iceimpact.studies.analysis.summarize` that are whole numbers (it returns them as
#: floats): the number of impacts, the nearest lock-in integer N and the 0/1 lock-in flag.
INTEGER_MEASURES = frozenset({"n_impacts", "nearest_n", "locked"})

#: Column types as stored in the metadata file.
KIND_NAMES = {int: "int", float: "float", str: "str"}


def is_int_kind(value: Any) -> bool:
    """A value that makes an integer column: an int (or numpy integer, or bool), not a float."""
    import numpy as np

    return isinstance(value, int | np.integer)


def to_kind(value: Any, kind: type) -> Any:
    """``value`` as stored in a column of type ``kind``: an integral number of an int column as
    int (nan stays a float nan: an error row has no measures), any number of a float column as
    float; a status is left as it is."""
    import numpy as np

    if kind is str:
        return value
    if isinstance(value, bool | np.integer):
        value = int(value)
    if isinstance(value, int):
        return value if kind is int else float(value)
    value = float(value)
    if kind is int and math.isfinite(value) and abs(value) < 2**53 and value == int(value):
        return int(value)
    return value


def typed_row(row: Mapping[str, Any], columns: Sequence[str],
              kinds: Mapping[str, type]) -> dict[str, Any]:
    """The row with exactly ``columns`` in that order, each value of its column's type."""
    return {c: to_kind(row[c], kinds.get(c, float)) for c in columns}
