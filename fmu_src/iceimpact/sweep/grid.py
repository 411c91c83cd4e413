"""The grid of a sweep: axes from text (``--vary``), checked values, the size limit, the points.

The grid is the Cartesian product of its axes; a run's index is its position in the product,
the first axis changing slowest. Sizes are checked before anything is allocated: an axis
``START:STOP:COUNT`` is refused on its COUNT alone, a grid on the product of its axis lengths.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence, Sized
from typing import Any

import numpy as np

from ..runspec import (
    SpecError,
    Value,
    check_name,
    coerce,
    parameter_names,
    parse_number,
    shown,
)
from ..runspec import parse_set as _parse_set
from .errors import SweepError

#: Default largest number of runs of one sweep (the product of the axis lengths); more is
#: refused before anything is allocated or run. Raise it with ``max_runs=`` (``--max-runs``).
DEFAULT_MAX_RUNS = 100_000

__all__ = ["DEFAULT_MAX_RUNS", "check_grid_size", "grid_points", "grid_size", "normalize_grid",
           "parameter_names", "parse_set", "parse_values", "parse_vary"]


def _sweep_error(exc: SpecError) -> SweepError:
    return SweepError(str(exc))


def _number(text: str, what: str) -> float:
    try:
        return parse_number(text, what)
    except SpecError as exc:
        raise _sweep_error(exc) from None


def _count(text: str, what: str, max_count: int) -> int:
    text = text.strip()
    try:
        n = int(text)
    except ValueError:  # also an integer of more than 4300 digits
        raise SweepError(f"{what}: COUNT {shown(text, 40)} is not an integer") from None
    if n < 1:
        raise SweepError(f"{what}: COUNT must be >= 1, got {n}")
    if n > max_count:
        raise SweepError(f"{what}: COUNT {n:,} is more than the {max_count:,} runs a sweep may "
                         "have; use fewer values, or raise the limit with --max-runs "
                         "(max_runs=)")
    return n


def _check_max_runs(max_runs: Any) -> int:
    if isinstance(max_runs, bool) or not isinstance(max_runs, int | np.integer) or max_runs < 1:
        raise SweepError(f"max_runs = {max_runs!r}: expected an integer >= 1")
    return int(max_runs)


def parse_values(text: str, what: str = "values", max_count: int = DEFAULT_MAX_RUNS
                 ) -> list[float]:
    """Values of one axis from ``START:STOP:COUNT`` (linspace, both ends included),
    ``log:START:STOP:COUNT`` (geomspace, START and STOP nonzero with the same sign) or a comma
    list ``a,b,c``. ``what`` names the argument in error messages (:class:`SweepError`); more
    than ``max_count`` values are refused before any is computed."""
    max_count = _check_max_runs(max_count)
    text = text.strip()
    if not text:
        raise SweepError(f"{what}: no values")
    if text.lower().startswith("log:"):
        parts = text[4:].split(":")
        if len(parts) != 3:
            raise SweepError(f"{what}: expected log:START:STOP:COUNT, got {shown(text)}")
        start, stop = _number(parts[0], what), _number(parts[1], what)
        n = _count(parts[2], what, max_count)
        if start == 0.0 or stop == 0.0 or (start > 0.0) != (stop > 0.0):
            raise SweepError(f"{what}: log spacing needs START and STOP nonzero with the same "
                             f"sign, got {start!r} and {stop!r}")
        with np.errstate(all="ignore"):
            values = np.geomspace(start, stop, n).tolist()
        values[0], values[-1] = start, stop  # exact end points
        values = values[:n] if n > 1 else [start]
    elif ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise SweepError(f"{what}: expected START:STOP:COUNT, got {shown(text)}")
        start, stop = _number(parts[0], what), _number(parts[1], what)
        n = _count(parts[2], what, max_count)
        with np.errstate(all="ignore"):
            values = np.linspace(start, stop, n).tolist()
    else:
        items = text.split(",")
        if len(items) > max_count:
            raise SweepError(f"{what}: {len(items):,} values, more than the {max_count:,} runs "
                             "a sweep may have; raise the limit with --max-runs (max_runs=)")
        if any(not item.strip() for item in items):
            raise SweepError(f"{what}: empty item in the list {shown(text)}")
        return [_number(item, what) for item in items]
    if not all(math.isfinite(v) for v in values):
        raise SweepError(f"{what}: the spacing between START and STOP overflows (values are "
                         "not finite); use a narrower range")
    return values


def _coerce(name: str, value: Any) -> Value:
    try:
        return coerce(name, value)
    except SpecError as exc:
        raise SweepError(str(exc).replace(f"{name}: value", f"{name}: grid value", 1)) from None


def parse_vary(spec: str, max_count: int = DEFAULT_MAX_RUNS) -> tuple[str, list[Value]]:
    """``NAME=START:STOP:COUNT``, ``NAME=log:START:STOP:COUNT`` or ``NAME=a,b,c`` -> (name,
    values). NAME is an FMI name (:func:`parameter_names`); errors raise :class:`SweepError`
    naming the argument (an unknown name with the closest known ones)."""
    what = f"--vary {shown(spec)}"
    name, sep, rhs = spec.partition("=")
    name = name.strip()
    if not sep or not name:
        raise SweepError(f"{what}: expected NAME=START:STOP:COUNT, NAME=log:START:STOP:COUNT "
                         "or NAME=a,b,c")
    try:
        check_name(name, what)
    except SpecError as exc:
        raise _sweep_error(exc) from None
    return name, [_coerce(name, v) for v in parse_values(rhs, what, max_count)]


def parse_set(spec: str) -> tuple[str, Value]:
    """``NAME=VALUE`` -> (FMI name, number), for fixed changes to the base scene
    (:func:`iceimpact.runspec.parse_set`, raising :class:`SweepError`)."""
    try:
        return _parse_set(spec)
    except SpecError as exc:
        raise _sweep_error(exc) from None


def grid_size(grid: Mapping[str, Sized]) -> int:
    """Number of runs of ``grid``: the product of its axis lengths (nothing is allocated)."""
    return math.prod(len(values) for values in grid.values())


def check_grid_size(grid: Mapping[str, Sized], max_runs: int = DEFAULT_MAX_RUNS) -> int:
    """The number of runs of ``grid``; :class:`SweepError` with the count if above
    ``max_runs``."""
    max_runs = _check_max_runs(max_runs)
    n = grid_size(grid)
    if n > max_runs:
        axes = " x ".join(f"{len(v):,}" for v in grid.values())
        raise SweepError(f"the grid has {n:,} runs ({axes}), more than the limit of "
                         f"{max_runs:,}; use fewer values, or raise the limit with --max-runs "
                         "(max_runs=)")
    return n


def normalize_grid(grid: Mapping[str, Iterable[Any]], max_runs: int = DEFAULT_MAX_RUNS
                   ) -> dict[str, list[Value]]:
    """Check a grid (FMI name -> values) and return it with plain Python numbers. An axis (or
    the grid) of more than ``max_runs`` values is refused, reading at most ``max_runs + 1``
    values of each axis (an endless iterator is refused, not read to the end)."""
    max_runs = _check_max_runs(max_runs)
    if not isinstance(grid, Mapping):
        raise SweepError(f"the grid must map FMI names to values, got {type(grid).__name__}")
    if not grid:
        raise SweepError("the grid is empty: vary at least one parameter")
    out: dict[str, list[Value]] = {}
    for name, values in grid.items():
        if not isinstance(name, str):
            raise SweepError(f"grid: parameter names are strings, got {name!r}")
        try:
            check_name(name, "grid")
        except SpecError as exc:
            raise _sweep_error(exc) from None
        if isinstance(values, str | bytes) or not isinstance(values, Iterable):
            raise SweepError(f"{name}: expected a sequence of values, got {values!r}")
        size = values.size if isinstance(values, np.ndarray) else \
            len(values) if isinstance(values, Sized) else None
        if size is not None and size > max_runs:
            raise SweepError(f"{name}: {size:,} values, more than the limit of {max_runs:,} "
                             "runs; use fewer values, or raise the limit with max_runs=")
        if isinstance(values, np.ndarray):
            items = values.ravel().tolist()
        else:
            items = list(itertools.islice(values, max_runs + 1))
            if len(items) > max_runs:
                raise SweepError(f"{name}: more than {max_runs:,} values, the limit of runs; "
                                 "raise it with max_runs=")
            try:
                items = np.asarray(items).ravel().tolist()
            except ValueError:  # ragged nesting
                raise SweepError(f"{name}: expected a flat sequence of numbers") from None
        vals = [_coerce(name, v) for v in items]
        if not vals:
            raise SweepError(f"{name}: no values")
        out[name] = vals
    check_grid_size(out, max_runs)
    return out


def grid_points(grid: Mapping[str, Sequence[Value]]) -> list[tuple[Value, ...]]:
    """All points of the Cartesian grid; the position in the list is the run index (the first
    parameter changes slowest, like nested loops in the grid's order)."""
    return list(itertools.product(*grid.values()))
