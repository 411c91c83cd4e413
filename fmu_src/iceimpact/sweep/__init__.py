"""Parameter sweeps: many runs of the core over a Cartesian grid, in parallel, resumable.

One run per grid point: the base scene with the varied parameters replaced, simulated by
:func:`iceimpact.run` (the core, not the FMU) from 0 to ``t_end`` and summarised by
:func:`iceimpact.studies.analysis.summarize` over ``t >= transient``. The result is one tidy table,
one row per run::

    run, <varied FMI names...>, status, wall_s, <summary measures...>

``run`` is the run index (position in the grid, the first varied parameter changing slowest),
``status`` is ``"ok"`` or the error of that run (e.g. ``impact.e = 1.5 is not allowed: 0 <= e
<= 1``: an invalid combination gives an error row, it does not stop the sweep), ``wall_s`` the
wall time of the run (s) and the measures are those of
:data:`iceimpact.studies.analysis.SUMMARY_FIELDS` (nan for error rows).

With an output file the rows are appended (and flushed) as runs finish, and a metadata file
``<out>.meta.json`` records the grid and settings. Running the same sweep again skips the runs
already in the file, so an interrupted sweep resumes where it stopped; a different grid or
different settings are refused unless ``overwrite=True``. When the sweep completes the table is
rewritten sorted by run index.

The package: :mod:`~iceimpact.sweep.grid` (axes from text, the grid and its size limit),
:mod:`~iceimpact.sweep.runner` (one run -> one row), :mod:`~iceimpact.sweep.columns` (the row
layout and column types), :mod:`~iceimpact.sweep.table` (the CSV/Parquet table, its metadata
and journal, resume, safe file writing), :mod:`~iceimpact.sweep.backends` (serial, process
pool, dask) and :func:`sweep` here, which ties them together (:func:`run_points` does the same
for any list of runs, e.g. the load-case tables of :mod:`iceimpact.seasons`).
Parameter changes by FMI name and the default sample step come from :mod:`iceimpact.runspec`,
below this package.

A test hook (no effect unless set): with ``ICEIMPACT_SWEEP_PAUSE_AFTER=N`` in the environment
(:data:`PAUSE_ENV`) a sweep stops after it has finished N runs in this call (written, if it has
an output file), says so on stderr and waits there until it is interrupted or killed, so that a
test kills or interrupts it at a known point instead of racing it.

    >>> from iceimpact import Scene
    >>> from iceimpact.sweep import sweep
    >>> rows = sweep(Scene(drag_model=2), {"flow.u": [0.1, 0.5], "impact.e": [0.5, 1.0]},
    ...              t_end=60.0, transient=20.0, out="sweep.csv")     # doctest: +SKIP
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import real_number, value_text
from ..runspec import DEFAULT_DT, MAX_SAMPLES, SpecError, Value, apply, check_samples
from ..scene import Scene
from . import backends
from .backends import MAX_CHUNK
from .columns import RUN_COLUMN, STATUS_COLUMN, STATUS_OK, WALL_COLUMN, typed_row
from .errors import SweepError
from .grid import (
    DEFAULT_MAX_RUNS,
    check_grid_size,
    grid_points,
    grid_size,
    normalize_grid,
    parameter_names,
    parse_set,
    parse_values,
    parse_vary,
)
from .runner import Measure, measure_columns, run_point
from .table import FORMAT_VERSION, FORMATS, Output, meta_path, output_format, read_table

__all__ = [
    "DEFAULT_DT", "DEFAULT_MAX_RUNS", "FORMATS", "FORMAT_VERSION", "MAX_CHUNK", "MAX_SAMPLES",
    "PAUSE_ENV", "RUN_COLUMN", "STATUS_COLUMN", "STATUS_OK", "WALL_COLUMN", "Measure",
    "SweepError", "Value", "apply", "check_grid_size", "grid_points", "grid_size", "meta_path",
    "normalize_grid", "output_format", "parameter_names", "parse_set", "parse_values",
    "parse_vary", "read_table", "run_point", "run_points", "sweep",
]


#: The test hook's environment variable (the module docstring): pause after this many runs.
PAUSE_ENV = "ICEIMPACT_SWEEP_PAUSE_AFTER"


def pause_after() -> int | None:
    """The test hook's run count from :data:`PAUSE_ENV` (None if unset or empty); a
    :class:`SweepError` if it is set to anything but an integer >= 1."""
    text = os.environ.get(PAUSE_ENV, "").strip()
    if not text:
        return None
    if not text.isdigit() or int(text) < 1:
        raise SweepError(f"{PAUSE_ENV} = {text!r}: expected an integer >= 1 (runs after which "
                         "a sweep waits to be killed; a test hook), or unset")
    return int(text)


def _wait_to_be_stopped(finished: int) -> None:
    """The test hook's pause: say so on stderr, then sleep until a signal ends the process or
    raises (Ctrl-C: KeyboardInterrupt, as at any other point of the sweep)."""
    print(f"iceimpact sweep: paused after {finished} runs ({PAUSE_ENV})", file=sys.stderr,
          flush=True)
    while True:
        time.sleep(3600.0)


def _progress(total: int, initial: int, enabled: bool, desc: str = "sweep") -> Any:
    """A tqdm bar on stderr (tqdm is optional: no bar without it)."""
    if enabled:
        try:
            from tqdm import tqdm

            return tqdm(total=total, initial=initial, unit="run", file=sys.stderr,
                        desc=desc, dynamic_ncols=True, smoothing=0.1)
        except ImportError:
            pass

    class _NoBar:
        def update(self, n: int = 1) -> None:
            pass

        def set_postfix(self, **kwargs: Any) -> None:
            pass

        def close(self) -> None:
            pass

    return _NoBar()


def sweep(base: Scene | None, grid: Mapping[str, Iterable[Any]], t_end: float,
          transient: float = 0.0, dt: float = DEFAULT_DT, out: str | Path | None = None,
          workers: int | None = None, progress: bool = True, dask_address: Any = None,
          fmt: str | None = None, overwrite: bool = False, chunksize: int | None = None,
          measure: Measure | None = None,
          on_rows: Callable[[list[dict[str, Any]]], None] | None = None,
          max_runs: int = DEFAULT_MAX_RUNS) -> list[dict[str, Any]]:
    """Run ``base`` (default: the Figure 2 scene) at every point of ``grid`` and summarise.

    ``grid`` maps FMI names (``"flow.u"``, ``"impact.e"``, ...; :func:`parameter_names`) to
    values; every combination is run (Cartesian product, first name changing slowest). Each run
    is :func:`iceimpact.run` from 0 to ``t_end`` (s) sampled every ``dt`` (s), summarised by
    ``measure(result, transient)`` (default :func:`iceimpact.studies.analysis.summarize`) over
    ``t >= transient`` (s).

    Returns the rows sorted by run index: ``{"run": i, <name>: value, ..., "status": "ok" or the
    error, "wall_s": s, <measure>: value, ...}``; a run whose parameters are invalid (e.g.
    ``impact.e = 1.5``) or whose simulation fails has the error as status and nan measures.
    Whole-number columns (the run index, integer parameters, ``n_impacts``, ``nearest_n``,
    ``locked``, int values of a custom measure) hold ints, the others floats.

    ``workers``: processes (default ``os.cpu_count()``; 1 runs in this process);
    ``dask_address``: a ``dask.distributed`` scheduler address (or a ``Client``) to run on
    instead. ``out``: CSV or Parquet (``fmt``, default from the suffix) written as runs finish,
    resumable (see the module docstring); ``overwrite`` replaces a table from a different sweep.
    ``chunksize``: runs per task (default: automatic). ``on_rows`` is called in this process
    with each batch of finished rows, after they are written. ``max_runs``: the largest grid
    accepted (default :data:`DEFAULT_MAX_RUNS`). Raises :class:`SweepError` for a bad grid or
    settings, a grid of more than ``max_runs`` runs, or an output table that cannot be resumed
    (another sweep's, damaged), before running or writing anything.
    """
    base = Scene() if base is None else base
    if not isinstance(base, Scene):
        raise SweepError(f"base must be a Scene, got {type(base).__name__}")
    grid = normalize_grid(grid, max_runs)
    kinds = {name: int if all(isinstance(v, int) for v in values) else float
             for name, values in grid.items()}
    return run_points(base, tuple(grid), grid_points(grid), t_end, transient, dt,
                      identity={"grid": [[n, v] for n, v in grid.items()]}, kinds=kinds,
                      out=out, workers=workers, progress=progress, dask_address=dask_address,
                      fmt=fmt, overwrite=overwrite, chunksize=chunksize, measure=measure,
                      on_rows=on_rows)


def run_points(base: Scene, names: Sequence[str], points: Sequence[tuple[Value, ...]],
               t_end: float, transient: float = 0.0, dt: float = DEFAULT_DT, *,
               identity: Mapping[str, Any], kinds: Mapping[str, type] | None = None,
               labels: Mapping[str, Sequence[int]] | None = None,
               out: str | Path | None = None, workers: int | None = None,
               progress: bool = True, dask_address: Any = None, fmt: str | None = None,
               overwrite: bool = False, chunksize: int | None = None,
               measure: Measure | None = None,
               on_rows: Callable[[list[dict[str, Any]]], None] | None = None,
               desc: str = "sweep") -> list[dict[str, Any]]:
    """The engine of :func:`sweep` for any list of runs (why: load-case tables are not grids).

    Run ``i`` is ``base`` with ``names`` set to ``points[i]`` (checked values, e.g. from
    :func:`normalize_grid`); ``kinds`` gives int or float per name (default float).
    ``identity`` (JSON-able) names what the runs are in the metadata file, besides the base
    scene and the settings: a rerun with other runs is refused, as for a sweep. ``labels`` are
    int columns placed after ``run`` whose value for run ``i`` is ``labels[c][i]`` (filled in
    this process, not passed to the scene). The other arguments are :func:`sweep`'s; rows,
    output, resume and errors are the same.
    """
    given = {"t_end": t_end, "transient": transient, "dt": dt}
    numbers = {name: real_number(value) for name, value in given.items()}  # Python or numpy
    for name, number in numbers.items():
        if number is None:
            raise SweepError(f"{name} = {value_text(given[name])}: expected a number (s)")
    t_end, transient, dt = numbers["t_end"], numbers["transient"], numbers["dt"]
    for name, ok, allowed in (
            ("t_end", math.isfinite(t_end) and t_end > 0.0, "a finite number > 0 (s)"),
            ("dt", math.isfinite(dt) and 0.0 < dt <= t_end, "a number in (0, t_end] (s)"),
            ("transient", math.isfinite(transient) and 0.0 <= transient < t_end,
             "a number in [0, t_end) (s)")):
        if not ok:
            raise SweepError(f"{name} = {value_text(given[name])}: expected {allowed}")
    try:
        check_samples(t_end, dt)
    except SpecError as exc:
        raise SweepError(str(exc)) from None
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SweepError(f"workers = {workers!r}: expected an integer >= 1")
    if chunksize is not None and (isinstance(chunksize, bool) or not isinstance(chunksize, int)
                                  or chunksize < 1):
        raise SweepError(f"chunksize = {chunksize!r}: expected an integer >= 1")
    pause = pause_after()

    names = tuple(names)
    labels = {c: list(v) for c, v in (labels or {}).items()}
    for column, values in labels.items():
        if len(values) != len(points):
            raise SweepError(f"label {column!r}: {len(values)} values for {len(points)} runs")
    measures = measure_columns(measure, base, dt)
    columns = [RUN_COLUMN, *labels, *names, STATUS_COLUMN, WALL_COLUMN, *measures]
    if len(set(columns)) != len(columns):
        raise SweepError(f"column names collide: {columns}")
    kinds = {RUN_COLUMN: int, STATUS_COLUMN: str, WALL_COLUMN: float, **measures,
             **dict.fromkeys(labels, int),
             **{name: (kinds or {}).get(name, float) for name in names}}
    nan_measures = dict.fromkeys(measures, math.nan)
    settings = {**identity, "base": base.to_fmi(),
                "t_end": float(t_end), "transient": float(transient), "dt": float(dt),
                "measure": "summarize" if measure is None else
                f"{measure.__module__}.{getattr(measure, '__qualname__', repr(measure))}",
                "columns": columns}
    # compare as stored: JSON round trip (tuples -> lists)
    settings = json.loads(json.dumps(settings))

    output = None
    existing: dict[int, dict[str, Any]] = {}
    if out is not None:
        out = Path(out)
        output = Output(out, output_format(out, fmt), settings, columns, kinds, names, points,
                        overwrite)
        existing = output.load_existing()
    todo = [i for i in range(len(points)) if i not in existing]
    rows = dict(existing)

    tasks = [(base, names, chunk, float(t_end), float(transient), float(dt), measure)
             for chunk in backends.chunks(todo, points,
                                          workers if dask_address is None else 8, chunksize)]
    if dask_address is not None:
        batches = backends.dask(tasks, dask_address)
    elif workers == 1 or len(tasks) <= 1:
        batches = backends.serial(tasks)
    else:
        batches = backends.process_pool(tasks, min(workers, len(tasks)))

    bar = _progress(len(points), len(existing), progress, desc)
    n_errors = sum(r[STATUS_COLUMN] != STATUS_OK for r in existing.values())
    finished = 0
    try:
        if output is not None:
            output.start(existing)
        for batch in batches:
            for row in batch:
                row.update({c: values[row[RUN_COLUMN]] for c, values in labels.items()})
            batch = [typed_row({**nan_measures, **row}, columns, kinds) for row in batch]
            if output is not None:
                output.append(batch)
            for row in batch:
                rows[row[RUN_COLUMN]] = row
            n_errors += sum(r[STATUS_COLUMN] != STATUS_OK for r in batch)
            bar.update(len(batch))
            if n_errors:
                bar.set_postfix(errors=n_errors)
            if on_rows is not None:
                on_rows(batch)
            finished += len(batch)
            if pause is not None and finished >= pause:
                _wait_to_be_stopped(finished)
    finally:
        bar.close()
        if hasattr(batches, "close"):
            batches.close()  # stop the workers' pending tasks if we leave early
        if output is not None:
            output.close()
    ordered = [rows[i] for i in range(len(points))]
    if output is not None:
        output.finish(ordered)
    return ordered
