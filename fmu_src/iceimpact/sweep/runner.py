"""One run of a sweep -> one row: the base scene with the grid point's values, simulated by the
core (:func:`iceimpact.run`) and summarised by a measure (default
:func:`iceimpact.studies.analysis.summarize`). Any error of the run is the row's status."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

from ..runspec import Value, apply
from ..scene import Scene
from ..simulator import Result, run
from .columns import (
    INTEGER_MEASURES,
    RUN_COLUMN,
    STATUS_COLUMN,
    STATUS_OK,
    WALL_COLUMN,
    is_int_kind,
)
from .errors import SweepError

Measure = Callable[[Result, float], Mapping[str, float]]

#: A task of a worker: base scene, varied names, (run index, values) pairs, t_end, transient,
#: dt, measure.
Task = tuple[Scene, tuple[str, ...], list[tuple[int, tuple[Value, ...]]], float, float, float,
             "Measure | None"]


def status_text(exc: BaseException) -> str:
    """The status of a failed run: a ParameterError's own message, else ``Type: message``."""
    from ..errors import ParameterError

    text = str(exc) if isinstance(exc, ParameterError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split()) or type(exc).__name__


def default_measure() -> Measure:
    """:func:`iceimpact.studies.analysis.summarize`, the measure of a sweep that names none."""
    # imported here: a worker of a load-case table never loads the spectra (scipy.signal)
    from ..studies.analysis import summarize

    return summarize


def run_point(base: Scene, params: Mapping[str, Value], t_end: float, transient: float,
              dt: float, measure: Measure | None = None) -> dict[str, Any]:
    """One row of the table (without the run index): the varied values, ``status``, ``wall_s``
    (s) and the measures. Any error of the run (an invalid parameter combination, a failing
    solver) becomes the status; the measures are then absent (the caller fills nan). Integer
    measures (ints from the measure) stay ints, the others are floats."""
    t0 = time.perf_counter()
    row: dict[str, Any] = dict(params)
    try:
        scene = apply(base, params)
        result = run(scene, t_end, dt=dt)
        summary = (measure or default_measure())(result, transient)
        row[STATUS_COLUMN] = STATUS_OK
    except Exception as exc:  # a failing run is a row, not the end of the sweep
        row[STATUS_COLUMN] = status_text(exc)
        summary = {}
    row[WALL_COLUMN] = time.perf_counter() - t0
    row.update({key: int(value) if is_int_kind(value) else float(value)
                for key, value in summary.items()})
    return row


def measure_columns(measure: Measure | None, base: Scene, dt: float) -> dict[str, type]:
    """Column names and types (int or float) of the measures: the analysis table (its whole
    numbers :data:`~iceimpact.sweep.columns.INTEGER_MEASURES` as ints), or probed on a short
    run of ``base`` (an int value makes an int column)."""
    if measure is None:
        from ..studies.analysis import SUMMARY_FIELDS  # (as in default_measure)

        return {k: int if k in INTEGER_MEASURES else float for k in SUMMARY_FIELDS}
    t_probe = max(1.0, 16 * dt)
    try:
        probe = measure(run(base, t_probe, dt=dt), 0.0)
        return {str(k): int if is_int_kind(v) else float for k, v in probe.items()}
    except Exception as exc:
        raise SweepError(f"measure {measure!r} failed on a {t_probe} s run of the base scene "
                         f"({status_text(exc)}); it must return the same keys for every run"
                         ) from exc


def run_chunk(task: Task) -> list[dict[str, Any]]:
    """Worker entry point: a list of (run index, values) -> rows (module level: picklable)."""
    base, names, points, t_end, transient, dt, measure = task
    rows = []
    for index, values in points:
        row = run_point(base, dict(zip(names, values, strict=True)), t_end, transient, dt,
                        measure)
        row[RUN_COLUMN] = index
        rows.append(row)
    return rows
