"""Parameter sweeps: many runs of the core over a Cartesian grid, in parallel, resumable.

One run per grid point: the base scene with the varied parameters replaced, simulated by
:func:`iceimpact.run` (the core, not the FMU) from 0 to ``t_end`` and summarised by
:func:`iceimpact.analysis.summarize` over ``t >= transient``. The result is one tidy table, one
row per run::

    run, <varied FMI names...>, status, wall_s, <summary measures...>

``run`` is the run index (position in the grid, the first varied parameter changing slowest),
``status`` is ``"ok"`` or the error of that run (e.g. ``impact.e = 1.5 is not allowed: 0 <= e
<= 1``: an invalid combination gives an error row, it does not stop the sweep), ``wall_s`` the
wall time of the run (s) and the measures are those of
:data:`iceimpact.analysis.SUMMARY_FIELDS` (nan for error rows).

With an output file the rows are appended (and flushed) as runs finish, and a metadata file
``<out>.meta.json`` records the grid and settings. Running the same sweep again skips the runs
already in the file, so an interrupted sweep resumes where it stopped; a different grid or
different settings are refused unless ``overwrite=True``. When the sweep completes the table is
rewritten sorted by run index.

    >>> from iceimpact import Scene
    >>> from iceimpact.sweep import sweep
    >>> rows = sweep(Scene(drag_model=2), {"flow.u": [0.1, 0.5], "impact.e": [0.5, 1.0]},
    ...              t_end=60.0, transient=20.0, out="sweep.csv")     # doctest: +SKIP
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

import numpy as np

from .scene import FLOW_INPUT, PARAMETERS, SPECS_BY_NAME, Scene
from .simulator import Result, run

#: Default sample step of the runs, s: 125 samples per natural period of the Figure 2 structure
#: (4 Hz) and a Nyquist frequency of 250 Hz for the spectrum; sampling dominates the cost of a
#: run, which is proportional to t_end / dt (see docs/sweeps.md).
DEFAULT_DT = 2e-3

#: Largest number of runs sent to a worker as one task (progress and resume granularity).
MAX_CHUNK = 8

#: Version of the output layout written to the metadata file.
FORMAT_VERSION = 1

FORMATS = ("csv", "parquet")

#: Columns before the varied parameters and between them and the measures.
RUN_COLUMN = "run"
STATUS_COLUMN = "status"
WALL_COLUMN = "wall_s"
STATUS_OK = "ok"

Measure = Callable[[Result, float], Mapping[str, float]]
Value = float | int



class SweepError(ValueError):
    """A sweep cannot start or continue: a bad grid or setting, an output file written by a
    different sweep, a missing optional dependency. The message says what to change."""


def parameter_names() -> list[str]:
    """FMI names that can be varied: every parameter of :data:`PARAMETERS` and ``flow.u``."""
    return [p.name for p in PARAMETERS] + [FLOW_INPUT.name]


# Grid specification ----------------------------------------------------------------------------
def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise SweepError(f"{what}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise SweepError(f"{what}: {text.strip()!r} is not finite")
    return value


def _count(text: str, what: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise SweepError(f"{what}: COUNT {text.strip()!r} is not an integer") from None
    if n < 1:
        raise SweepError(f"{what}: COUNT must be >= 1, got {n}")
    return n


def parse_values(text: str, what: str = "values") -> list[float]:
    """Values of one axis from ``START:STOP:COUNT`` (linspace, both ends included),
    ``log:START:STOP:COUNT`` (geomspace, START and STOP nonzero with the same sign) or a comma
    list ``a,b,c``. ``what`` names the argument in error messages (:class:`SweepError`)."""
    text = text.strip()
    if not text:
        raise SweepError(f"{what}: no values")
    if text.lower().startswith("log:"):
        parts = text[4:].split(":")
        if len(parts) != 3:
            raise SweepError(f"{what}: expected log:START:STOP:COUNT, got {text!r}")
        start, stop = _number(parts[0], what), _number(parts[1], what)
        n = _count(parts[2], what)
        if start == 0.0 or stop == 0.0 or (start > 0.0) != (stop > 0.0):
            raise SweepError(f"{what}: log spacing needs START and STOP nonzero with the same "
                             f"sign, got {start!r} and {stop!r}")
        values = np.geomspace(start, stop, n).tolist()
        values[0], values[-1] = start, stop  # exact end points
        return values[:n] if n > 1 else [start]
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise SweepError(f"{what}: expected START:STOP:COUNT, got {text!r}")
        start, stop = _number(parts[0], what), _number(parts[1], what)
        n = _count(parts[2], what)
        return np.linspace(start, stop, n).tolist()
    items = text.split(",")
    if any(not item.strip() for item in items):
        raise SweepError(f"{what}: empty item in the list {text!r}")
    return [_number(item, what) for item in items]


def _coerce(name: str, value: Any) -> Value:
    """A grid value as a Python number: int for integer parameters when integral, else float.
    Non-numbers and non-finite numbers raise :class:`SweepError`; other out-of-range numbers
    give error rows instead (the scene's validation decides, run by run)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise SweepError(f"{name}: grid value {value!r} is not a number")
    if not math.isfinite(value):  # no parameter accepts it; nan would also defeat resuming
        raise SweepError(f"{name}: grid value {value!r} is not finite")
    if SPECS_BY_NAME[name].kind is int and value == int(value):
        return int(value)
    return float(value)


def parse_vary(spec: str) -> tuple[str, list[Value]]:
    """``NAME=START:STOP:COUNT``, ``NAME=log:START:STOP:COUNT`` or ``NAME=a,b,c`` -> (name,
    values). NAME is an FMI name (:func:`parameter_names`); errors raise :class:`SweepError`
    naming the argument."""
    what = f"--vary {spec!r}"
    name, sep, rhs = spec.partition("=")
    name = name.strip()
    if not sep or not name:
        raise SweepError(f"{what}: expected NAME=START:STOP:COUNT, NAME=log:START:STOP:COUNT "
                         "or NAME=a,b,c")
    _check_name(name, what)
    return name, [_coerce(name, v) for v in parse_values(rhs, what)]


def parse_set(spec: str) -> tuple[str, Value]:
    """``NAME=VALUE`` -> (FMI name, number), for fixed changes to the base scene."""
    what = f"--set {spec!r}"
    name, sep, rhs = spec.partition("=")
    name = name.strip()
    if not sep or not name:
        raise SweepError(f"{what}: expected NAME=VALUE")
    _check_name(name, what)
    return name, _coerce(name, _number(rhs, what))


def _check_name(name: str, what: str) -> None:
    if name not in SPECS_BY_NAME:
        raise SweepError(f"{what}: unknown parameter {name!r}; known: "
                         + ", ".join(parameter_names()))


def normalize_grid(grid: Mapping[str, Iterable[Any]]) -> dict[str, list[Value]]:
    """Check a grid (FMI name -> values) and return it with plain Python numbers."""
    if not grid:
        raise SweepError("the grid is empty: vary at least one parameter")
    out: dict[str, list[Value]] = {}
    for name, values in grid.items():
        _check_name(name, "grid")
        if isinstance(values, str | bytes) or not isinstance(values, Iterable):
            raise SweepError(f"{name}: expected a sequence of values, got {values!r}")
        vals = [_coerce(name, v) for v in np.asarray(list(values)).ravel().tolist()]
        if not vals:
            raise SweepError(f"{name}: no values")
        out[name] = vals
    return out


def grid_points(grid: Mapping[str, Sequence[Value]]) -> list[tuple[Value, ...]]:
    """All points of the Cartesian grid; the position in the list is the run index (the first
    parameter changes slowest, like nested loops in the grid's order)."""
    return list(itertools.product(*grid.values()))


def apply(base: Scene, params: Mapping[str, Value]) -> Scene:
    """``base`` with FMI-named parameters replaced (validated: may raise ParameterError)."""
    return base.replace_fmi(dict(params))


# One run ---------------------------------------------------------------------------------------
def _status(exc: BaseException) -> str:
    from .scene import ParameterError

    text = str(exc) if isinstance(exc, ParameterError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split()) or type(exc).__name__


def run_point(base: Scene, params: Mapping[str, Value], t_end: float, transient: float,
              dt: float, measure: Measure | None = None) -> dict[str, Any]:
    """One row of the table (without the run index): the varied values, ``status``, ``wall_s``
    (s) and the measures. Any error of the run (an invalid parameter combination, a failing
    solver) becomes the status; the measures are then absent (the caller fills nan)."""
    t0 = time.perf_counter()
    row: dict[str, Any] = dict(params)
    try:
        scene = apply(base, params)
        result = run(scene, t_end, dt=dt)
        summary = (measure or _default_measure())(result, transient)
        row[STATUS_COLUMN] = STATUS_OK
    except Exception as exc:  # a failing run is a row, not the end of the sweep
        row[STATUS_COLUMN] = _status(exc)
        summary = {}
    row[WALL_COLUMN] = time.perf_counter() - t0
    row.update({key: float(value) for key, value in summary.items()})
    return row


def _default_measure() -> Measure:
    from .analysis import summarize

    return summarize


def _measure_columns(measure: Measure | None, base: Scene, dt: float) -> list[str]:
    """Column names of the measures: the analysis table, or probed on a short run of ``base``."""
    if measure is None:
        from .analysis import SUMMARY_FIELDS

        return list(SUMMARY_FIELDS)
    t_probe = max(1.0, 16 * dt)
    try:
        return [str(k) for k in measure(run(base, t_probe, dt=dt), 0.0)]
    except Exception as exc:
        raise SweepError(f"measure {measure!r} failed on a {t_probe} s run of the base scene "
                         f"({_status(exc)}); it must return the same keys for every run") from exc


def _run_chunk(task: tuple[Scene, tuple[str, ...], list[tuple[int, tuple[Value, ...]]],
                           float, float, float, Measure | None]) -> list[dict[str, Any]]:
    """Worker entry point: a list of (run index, values) -> rows (module level: picklable)."""
    base, names, points, t_end, transient, dt, measure = task
    rows = []
    for index, values in points:
        row = run_point(base, dict(zip(names, values, strict=True)), t_end, transient, dt,
                        measure)
        row[RUN_COLUMN] = index
        rows.append(row)
    return rows


# Output table ----------------------------------------------------------------------------------
def meta_path(out: str | Path) -> Path:
    """Path of the metadata file written next to the table ``out``."""
    out = Path(out)
    return out.with_name(out.name + ".meta.json")


def _journal_path(out: Path, fmt: str) -> Path:
    """Where rows are appended while the sweep runs: the CSV itself, or a CSV next to a
    Parquet file (Parquet cannot be appended to; it is written when the sweep completes)."""
    return out if fmt == "csv" else out.with_name(out.name + ".partial.csv")


def output_format(out: str | Path, fmt: str | None = None) -> str:
    """The table format, ``fmt`` or from the suffix of ``out`` (``.parquet``/``.pq``, else
    csv); :class:`SweepError` if unknown, or Parquet without pyarrow installed."""
    out = Path(out)
    if fmt is None:
        fmt = "parquet" if out.suffix.lower() in (".parquet", ".pq") else "csv"
    if fmt not in FORMATS:
        raise SweepError(f"format {fmt!r}: expected one of {', '.join(FORMATS)}")
    if fmt == "parquet":
        _require_pyarrow()
    return fmt


def _require_pyarrow() -> Any:
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise SweepError("Parquet output needs pyarrow, which is not installed: "
                         "pip install pyarrow (or write CSV: --format csv)") from None
    return pyarrow


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _csv_text(columns: Sequence[str], rows: Iterable[Mapping[str, Any]],
              header: bool = True) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    if header:
        writer.writerow(columns)
    for row in rows:
        # str(float) is repr: values read back are bit-identical (nan and inf included)
        writer.writerow([row[c] for c in columns])
    return buf.getvalue()


def _parse_cell(column: str, text: str, kind: type | None) -> Any:
    if column == STATUS_COLUMN:
        return text
    if column == RUN_COLUMN or kind is int:
        return int(text)
    return float(text)


def _read_csv_rows(path: Path, columns: Sequence[str] | None = None,
                   kinds: Mapping[str, type] | None = None) -> list[dict[str, Any]]:
    """Rows of a table CSV; an incomplete last line (a write cut by a kill) is dropped."""
    text = path.read_text(encoding="utf-8")
    if not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    lines = list(csv.reader(io.StringIO(text)))
    if not lines:
        return []
    header = lines[0]
    if columns is not None and header != list(columns):
        raise SweepError(f"{path}: its columns differ from this sweep's; use --overwrite to "
                         "replace it or choose another output file")
    kinds = kinds or {}
    rows = []
    for fields in lines[1:]:
        if len(fields) != len(header):
            continue  # cut short
        try:
            rows.append({c: _parse_cell(c, v, kinds.get(c)) for c, v in zip(header, fields,
                                                                             strict=True)})
        except ValueError:
            continue  # a damaged line: the run is simply done again
    return rows


def _write_parquet(path: Path, columns: Sequence[str], rows: Sequence[Mapping[str, Any]],
                   kinds: Mapping[str, type]) -> None:
    pa = _require_pyarrow()
    import pyarrow.parquet as pq

    arrays = {}
    for c in columns:
        if c == STATUS_COLUMN:
            arrays[c] = pa.array([r[c] for r in rows], type=pa.string())
        elif c == RUN_COLUMN or kinds.get(c) is int:
            arrays[c] = pa.array([r[c] for r in rows], type=pa.int64())
        else:
            arrays[c] = pa.array([float(r[c]) for r in rows], type=pa.float64())
    tmp = path.with_name(path.name + ".tmp")
    pq.write_table(pa.table(arrays), tmp)
    os.replace(tmp, path)


def read_table(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a sweep's output table (CSV or Parquet), as written by :func:`sweep`."""
    path = Path(path)
    if path.suffix.lower() in (".parquet", ".pq"):
        _require_pyarrow()
        import pyarrow.parquet as pq

        return pq.read_table(path).to_pylist()
    kinds: dict[str, type] = {}
    mpath = meta_path(path)
    if mpath.exists():
        meta = json.loads(mpath.read_text(encoding="utf-8"))
        for name, values in meta["settings"]["grid"]:
            kinds[name] = int if all(isinstance(v, int) for v in values) else float
    return _read_csv_rows(path, kinds=kinds)


class _Output:
    """The table being written: metadata, existing rows (resume), appending, final rewrite."""

    def __init__(self, out: Path, fmt: str, settings: dict[str, Any], columns: list[str],
                 grid: Mapping[str, Sequence[Value]], points: Sequence[tuple[Value, ...]],
                 overwrite: bool):
        self.out, self.fmt, self.columns = out, fmt, columns
        self.meta = meta_path(out)
        self.journal = _journal_path(out, fmt)
        self.settings = settings
        self.names = list(grid)
        self.kinds = {n: int if all(isinstance(v, int) for v in vals) else float
                      for n, vals in grid.items()}
        self.points = points
        self.fh: io.TextIOBase | None = None
        if overwrite:
            for p in (self.out, self.meta, self.journal):
                p.unlink(missing_ok=True)

    def load_existing(self) -> dict[int, dict[str, Any]]:
        """Rows already computed by an earlier run of the same sweep, keyed by run index."""
        files = [p for p in (self.out, self.journal) if p.exists()]
        if not self.meta.exists():
            if files:
                raise SweepError(f"{files[0]} exists but has no metadata file {self.meta.name}, "
                                 "so it cannot be resumed; use --overwrite (overwrite=True) to "
                                 "replace it or choose another output file")
            return {}
        try:
            meta = json.loads(self.meta.read_text(encoding="utf-8"))
            old = meta["settings"]
        except (ValueError, KeyError, TypeError):
            raise SweepError(f"{self.meta} is not a sweep metadata file; use --overwrite to "
                             "replace the output") from None
        if old != self.settings:
            diff = [k for k in sorted(set(old) | set(self.settings))
                    if old.get(k) != self.settings.get(k)]
            raise SweepError(f"{self.out} was written by a different sweep (differs in: "
                             f"{', '.join(diff)}); rerun with the same grid and settings to "
                             "resume, use --overwrite (overwrite=True) to replace it, or choose "
                             "another output file")
        rows: list[dict[str, Any]] = []
        if self.fmt == "parquet" and self.out.exists():
            rows += read_table(self.out)
        if self.journal.exists():
            rows += _read_csv_rows(self.journal, self.columns, self.kinds)
        existing: dict[int, dict[str, Any]] = {}
        for row in rows:
            index = row[RUN_COLUMN]
            if not 0 <= index < len(self.points):
                raise SweepError(f"{self.out}: run index {index} is outside this grid; use "
                                 "--overwrite to replace it")
            if tuple(row[n] for n in self.names) != self.points[index]:
                raise SweepError(f"{self.out}: the row of run {index} has parameter values "
                                 f"{tuple(row[n] for n in self.names)}, not the grid's "
                                 f"{self.points[index]}; use --overwrite to replace it")
            existing[index] = row  # a duplicate (identical run) is kept once
        return existing

    def start(self, existing: Mapping[int, Mapping[str, Any]]) -> None:
        """Write the metadata, rewrite the journal with the valid existing rows, open it."""
        self.out.parent.mkdir(parents=True, exist_ok=True)
        meta = {"format": "iceimpact-sweep", "format_version": FORMAT_VERSION,
                "table": self.out.name, "columns": self.columns,
                "n_runs": len(self.points), "settings": self.settings}
        _atomic_write_text(self.meta, json.dumps(meta, indent=1) + "\n")
        if self.fmt == "parquet" and self.out.exists():
            self.out.unlink()  # its rows move to the journal until the sweep completes
        rows = [existing[i] for i in sorted(existing)]
        _atomic_write_text(self.journal, _csv_text(self.columns, rows))
        self.fh = open(self.journal, "a", encoding="utf-8", newline="")

    def append(self, rows: Sequence[Mapping[str, Any]]) -> None:
        assert self.fh is not None
        self.fh.write(_csv_text(self.columns, rows, header=False))
        self.fh.flush()

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    def finish(self, rows: Sequence[Mapping[str, Any]]) -> None:
        """The complete table, sorted by run index, in its final format."""
        self.close()
        if self.fmt == "csv":
            _atomic_write_text(self.out, _csv_text(self.columns, rows))
        else:
            _write_parquet(self.out, self.columns, rows, self.kinds)
            self.journal.unlink(missing_ok=True)


# Execution -------------------------------------------------------------------------------------
def _chunks(todo: Sequence[int], points: Sequence[tuple[Value, ...]], workers: int,
            chunksize: int | None) -> list[list[tuple[int, tuple[Value, ...]]]]:
    """Tasks of a few runs each: about 8 tasks per worker (load balance across runs of very
    different cost) and at most :data:`MAX_CHUNK` runs per task (progress and resume
    granularity); the per-task cost of a process pool (~1 ms) is small against a run."""
    if chunksize is None:
        chunksize = max(1, min(MAX_CHUNK, len(todo) // (8 * workers)))
    return [[(i, points[i]) for i in todo[k:k + chunksize]]
            for k in range(0, len(todo), chunksize)]


def _serial(tasks: Sequence[tuple]) -> Iterator[list[dict[str, Any]]]:
    for task in tasks:
        yield _run_chunk(task)


def _init_worker() -> None:
    """Worker initializer: Ctrl-C interrupts the parent, which stops the workers itself (with
    SIGTERM, whose default action is restored in case the parent handles it)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _process_pool(tasks: Sequence[tuple], workers: int) -> Iterator[list[dict[str, Any]]]:
    executor = ProcessPoolExecutor(max_workers=workers, initializer=_init_worker)
    finished = False
    try:
        pending: set[Future] = {executor.submit(_run_chunk, task) for task in tasks}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                yield future.result()
        finished = True
    finally:
        if finished:
            executor.shutdown(wait=True)
        else:  # interrupted: stop the runs in progress instead of waiting for them
            _terminate_workers(executor)


def _terminate_workers(executor: ProcessPoolExecutor) -> None:
    terminate = getattr(executor, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    # before 3.14: the processes must be taken before shutdown() forgets them
    processes = list((getattr(executor, "_processes", None) or {}).values())
    executor.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()


def _dask(tasks: Sequence[tuple], address: Any) -> Iterator[list[dict[str, Any]]]:
    """Rows from a dask.distributed cluster; connects now (errors before anything runs)."""
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SweepError("--dask needs dask.distributed, which is not installed: "
                         "pip install 'iceimpact[dask]'") from None
    own = isinstance(address, str)
    try:
        client = Client(address) if own else address
    except OSError as exc:
        raise SweepError(f"cannot connect to the dask scheduler {address!r}: {exc}") from None

    def batches() -> Iterator[list[dict[str, Any]]]:
        try:
            futures = client.map(_run_chunk, list(tasks), pure=False)
            try:
                for future in as_completed(futures):
                    yield future.result()
            finally:
                client.cancel(futures)
        finally:
            if own:
                client.close()

    return batches()


def _progress(total: int, initial: int, enabled: bool) -> Any:
    """A tqdm bar on stderr (tqdm is optional: no bar without it)."""
    if enabled:
        try:
            from tqdm import tqdm

            return tqdm(total=total, initial=initial, unit="run", file=sys.stderr,
                        desc="sweep", dynamic_ncols=True, smoothing=0.1)
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
          on_rows: Callable[[list[dict[str, Any]]], None] | None = None
          ) -> list[dict[str, Any]]:
    """Run ``base`` (default: the Figure 2 scene) at every point of ``grid`` and summarise.

    ``grid`` maps FMI names (``"flow.u"``, ``"impact.e"``, ...; :func:`parameter_names`) to
    values; every combination is run (Cartesian product, first name changing slowest). Each run
    is :func:`iceimpact.run` from 0 to ``t_end`` (s) sampled every ``dt`` (s), summarised by
    ``measure(result, transient)`` (default :func:`iceimpact.analysis.summarize`) over ``t >=
    transient`` (s).

    Returns the rows sorted by run index: ``{"run": i, <name>: value, ..., "status": "ok" or the
    error, "wall_s": s, <measure>: float, ...}``; a run whose parameters are invalid (e.g.
    ``impact.e = 1.5``) or whose simulation fails has the error as status and nan measures.

    ``workers``: processes (default ``os.cpu_count()``; 1 runs in this process);
    ``dask_address``: a ``dask.distributed`` scheduler address (or a ``Client``) to run on
    instead. ``out``: CSV or Parquet (``fmt``, default from the suffix) written as runs finish,
    resumable (see the module docstring); ``overwrite`` replaces a table from a different sweep.
    ``chunksize``: runs per task (default: automatic). ``on_rows`` is called in this process
    with each batch of finished rows, after they are written. Raises :class:`SweepError` for a
    bad grid or settings before running anything.
    """
    base = Scene() if base is None else base
    if not isinstance(base, Scene):
        raise SweepError(f"base must be a Scene, got {type(base).__name__}")
    grid = normalize_grid(grid)
    for name, value, ok, allowed in (
            ("t_end", t_end, math.isfinite(t_end) and t_end > 0.0, "a finite number > 0 (s)"),
            ("dt", dt, math.isfinite(dt) and 0.0 < dt <= t_end, "a number in (0, t_end] (s)"),
            ("transient", transient, math.isfinite(transient) and 0.0 <= transient < t_end,
             "a number in [0, t_end) (s)")):
        if not ok:
            raise SweepError(f"{name} = {value!r}: expected {allowed}")
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SweepError(f"workers = {workers!r}: expected an integer >= 1")
    if chunksize is not None and (isinstance(chunksize, bool) or not isinstance(chunksize, int)
                                  or chunksize < 1):
        raise SweepError(f"chunksize = {chunksize!r}: expected an integer >= 1")

    names = tuple(grid)
    points = grid_points(grid)
    columns = [RUN_COLUMN, *names, STATUS_COLUMN, WALL_COLUMN,
               *_measure_columns(measure, base, dt)]
    if len(set(columns)) != len(columns):
        raise SweepError(f"column names collide: {columns}")
    nan_measures = dict.fromkeys(columns[len(names) + 3:], math.nan)
    settings = {"grid": [[n, v] for n, v in grid.items()], "base": base.to_fmi(),
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
        output = _Output(out, output_format(out, fmt), settings, columns, grid, points, overwrite)
        existing = output.load_existing()
    todo = [i for i in range(len(points)) if i not in existing]
    rows = dict(existing)

    tasks = [(base, names, chunk, float(t_end), float(transient), float(dt), measure)
             for chunk in _chunks(todo, points, workers if dask_address is None else 8, chunksize)]
    if dask_address is not None:
        batches = _dask(tasks, dask_address)
    elif workers == 1 or len(tasks) <= 1:
        batches = _serial(tasks)
    else:
        batches = _process_pool(tasks, min(workers, len(tasks)))

    bar = _progress(len(points), len(existing), progress)
    n_errors = sum(r[STATUS_COLUMN] != STATUS_OK for r in existing.values())
    try:
        if output is not None:
            output.start(existing)
        for batch in batches:
            batch = [{**nan_measures, **row} for row in batch]
            if output is not None:
                output.append(batch)
            for row in batch:
                rows[row[RUN_COLUMN]] = {c: row[c] for c in columns}
            n_errors += sum(r[STATUS_COLUMN] != STATUS_OK for r in batch)
            bar.update(len(batch))
            if n_errors:
                bar.set_postfix(errors=n_errors)
            if on_rows is not None:
                on_rows(batch)
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
