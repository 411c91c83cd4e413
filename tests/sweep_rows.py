"""What the sweep tests share: a small grid and its settings, and rows compared value for value."""

from __future__ import annotations

import csv
import math

T_END, TRANSIENT, DT = 4.0, 1.0, 1e-2   # s: a run costs ~10 ms
GRID = {"flow.u": [0.1, 0.3], "impact.e": [0.5, 0.8, 1.0]}


def same(a: dict, b: dict, skip=("wall_s",)) -> bool:
    """Rows equal value for value (nan == nan), ignoring the wall time."""
    if a.keys() != b.keys():
        return False
    for key in a:
        if key in skip:
            continue
        x, y = a[key], b[key]
        if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
            continue
        if x != y:
            return False
    return True


def assert_same_rows(rows_a: list[dict], rows_b: list[dict]) -> None:
    """The two lists of rows are equal row for row (:func:`same`)."""
    assert len(rows_a) == len(rows_b)
    for a, b in zip(rows_a, rows_b, strict=True):
        assert same(a, b), (a, b)


def read_csv(path):
    """The cells of a CSV file, as text."""
    with open(path, newline="") as fh:
        return list(csv.reader(fh))
