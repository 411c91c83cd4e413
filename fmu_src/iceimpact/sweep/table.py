"""The sweep's output: the table (CSV or Parquet), its metadata file, the journal that makes a
sweep resumable, and writing files safely.

While a sweep runs, rows are appended (and flushed) to a journal as runs finish: the CSV table
itself, or ``<out>.partial.csv`` next to a Parquet table (Parquet cannot be appended to).
``<out>.meta.json`` records the grid and settings. Rerunning the same sweep reads both and runs
only the missing runs. Both files are outside data when read back: they are parsed as CSV and
JSON only (nothing is unpickled or evaluated), every row is checked against the grid, and a
damaged, truncated or foreign file is refused with a :class:`SweepError` naming the file, the
line and what is wrong, before anything is written. Only an incomplete last line (a write cut
by a kill) is dropped, and its run done again.

Every file is written to a fresh temporary file created exclusively in the target directory
(``tempfile.mkstemp``: ``O_CREAT | O_EXCL``, never through an existing file or link) and then
renamed over the target (``os.replace``, atomic), so a link planted at any name next to the
table is never followed and a reader never sees half a file.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

from .columns import KIND_NAMES, RUN_COLUMN, STATUS_COLUMN, WALL_COLUMN, to_kind
from .errors import SweepError

#: Measures whose recorded name (module and function) changed between versions, old -> new: a
#: table begun under the old name resumes (the function computes the same row)
MOVED_MEASURES = {
    "iceimpact.studies.seasons.season_measure": "iceimpact.seasons.lifetime.season_measure",
}

#: Version of the output layout written to the metadata file (2: column types recorded; a
#: version-1 file is read as well).
FORMAT_VERSION = 2
FORMAT_NAME = "iceimpact-sweep"

FORMATS = ("csv", "parquet")

#: A metadata file larger than this is not one of ours (a grid of 100,000 values is ~3 MB).
MAX_META_BYTES = 64 * 2**20

#: Advice appended to every refusal of an existing output.
_REFUSED = ("nothing was changed; fix or remove that file, rerun with --overwrite "
            "(overwrite=True) to replace the table (its rows are lost), or choose another "
            "output file")

_KINDS_BY_NAME = {name: kind for kind, name in KIND_NAMES.items()}


# Paths and formats -----------------------------------------------------------------------------
def meta_path(out: str | Path) -> Path:
    """Path of the metadata file written next to the table ``out``."""
    out = Path(out)
    return out.with_name(out.name + ".meta.json")


def journal_path(out: Path, fmt: str) -> Path:
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
        require_pyarrow()
    return fmt


def require_pyarrow() -> Any:
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise SweepError("Parquet output needs pyarrow, which is not installed: "
                         "pip install pyarrow (or write CSV: --format csv)") from None
    return pyarrow


# Safe writing ----------------------------------------------------------------------------------
def _new_file_mode() -> int:
    """Permissions of a new file under the process umask (mkstemp creates files 0600)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return 0o644


def _temporary(path: Path) -> tuple[int, Path]:
    """A new, empty file in ``path``'s directory, created exclusively (a name nobody else holds,
    never an existing file or symlink), with the permissions of the file it will replace."""
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        st = os.stat(path, follow_symlinks=False)
        mode = stat.S_IMODE(st.st_mode) if stat.S_ISREG(st.st_mode) else _new_file_mode()
    except OSError:
        mode = _new_file_mode()
    try:
        os.fchmod(fd, mode)
    except OSError:  # pragma: no cover - e.g. a file system without permissions
        pass
    return fd, Path(name)


def write_atomic(path: Path, text: str, keep_open: bool = False) -> IO[str] | None:
    """Write ``text`` to ``path`` atomically: a fresh temporary file (see :func:`_temporary`)
    renamed over ``path``. With ``keep_open``, return that file open for appending (it is now
    ``path``, so later appends cannot be redirected by a link planted meanwhile)."""
    fd, tmp = _temporary(path)
    fh = os.fdopen(fd, "w", encoding="utf-8", newline="")
    try:
        fh.write(text)
        fh.flush()
        os.replace(tmp, path)
    except BaseException:
        fh.close()
        tmp.unlink(missing_ok=True)
        raise
    if keep_open:
        return fh
    fh.close()
    return None


def csv_text(columns: Sequence[str], rows: Iterable[Mapping[str, Any]],
             header: bool = True) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    if header:
        writer.writerow(columns)
    for row in rows:
        # str(float) is repr: values read back are bit-identical (nan and inf included)
        writer.writerow([row[c] for c in columns])
    return buf.getvalue()


def write_parquet(path: Path, columns: Sequence[str], rows: Sequence[Mapping[str, Any]],
                  kinds: Mapping[str, type]) -> None:
    """The table as Parquet: int64 for the integer columns (null where a run has no value,
    i.e. nan), float64 for the others, string for the status; written atomically."""
    pa = require_pyarrow()
    import pyarrow.parquet as pq

    arrays = {}
    for c in columns:
        values = [r[c] for r in rows]
        if c == STATUS_COLUMN:
            arrays[c] = pa.array(values, type=pa.string())
        elif kinds.get(c) is int and all(isinstance(v, int) or math.isnan(v) for v in values):
            arrays[c] = pa.array([v if isinstance(v, int) else None for v in values],
                                 type=pa.int64())
        else:
            arrays[c] = pa.array([float(v) for v in values], type=pa.float64())
    fd, tmp = _temporary(path)
    try:
        with os.fdopen(fd, "wb") as fh:
            pq.write_table(pa.table(arrays), fh)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


# Reading outside data --------------------------------------------------------------------------
def _refuse(path: Path, problem: str) -> SweepError:
    return SweepError(f"{path}: {problem}; {_REFUSED}")


def read_text_file(path: Path, limit: int | None,
                   refuse: Callable[[Path, str], Exception]) -> str:
    """The text of a regular file from outside (a link to one is fine): the exception
    ``refuse(path, problem)`` if it is missing, something else, over ``limit`` bytes, unreadable
    or not UTF-8. Used for sweep tables, their journals and load-case tables."""
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise refuse(path, "is not a regular file")
        if limit is not None and st.st_size > limit:
            raise refuse(path, f"is {st.st_size:,} bytes, more than the {limit:,} allowed")
        data = path.read_bytes()
    except FileNotFoundError:
        raise refuse(path, "no such file") from None
    except OSError as exc:
        raise refuse(path, f"cannot be read ({exc.strerror or exc})") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise refuse(path, f"byte {exc.start} is not UTF-8 text") from None


def _read_text(path: Path, limit: int | None = None) -> str:
    return read_text_file(path, limit, _refuse)


def read_meta(path: Path) -> dict[str, Any]:
    """The metadata of a sweep, checked for its layout (not for the settings)."""
    text = _read_text(path, MAX_META_BYTES)
    try:
        meta = json.loads(text)
    except RecursionError:
        raise _refuse(path, "is not a sweep metadata file (nested too deeply)") from None
    except ValueError as exc:
        raise _refuse(path, f"is not valid JSON ({exc}); damaged or truncated?") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT_NAME:
        raise _refuse(path, f"is not a sweep metadata file (no \"format\": \"{FORMAT_NAME}\")")
    version = meta.get("format_version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise _refuse(path, f"has no valid format_version (got {version!r})")
    if version > FORMAT_VERSION:
        raise _refuse(path, f"has format_version {version}, newer than this iceimpact's "
                            f"{FORMAT_VERSION}; update iceimpact")
    settings = meta.get("settings")
    if not isinstance(settings, dict):
        raise _refuse(path, "has no \"settings\" object; damaged?")
    return meta


def meta_kinds(meta: Mapping[str, Any]) -> dict[str, type]:
    """Column types recorded in a metadata file (version 2), else inferred from its grid
    (version 1: the varied columns; measures are then read as floats and made ints where the
    current sweep says so)."""
    kinds: dict[str, type] = {}
    recorded = meta.get("column_types")
    if isinstance(recorded, dict):
        for column, name in recorded.items():
            if isinstance(column, str) and name in _KINDS_BY_NAME:
                kinds[column] = _KINDS_BY_NAME[name]
        return kinds
    grid = meta.get("settings", {}).get("grid")
    if isinstance(grid, list):
        for axis in grid:
            if isinstance(axis, list) and len(axis) == 2 and isinstance(axis[1], list):
                name, values = axis
                kinds[str(name)] = int if all(isinstance(v, int) and not isinstance(v, bool)
                                              for v in values) else float
    return kinds


def _parse_cell(column: str, text: str, kind: type | None) -> Any:
    """A CSV cell as a Python value; ValueError if it is not what the column holds."""
    if column == STATUS_COLUMN:
        return text
    text = text.strip()
    if column == RUN_COLUMN:
        if not text.isdigit() or len(text) > 18:
            raise ValueError(f"run index {text!r} is not a whole number")
        return int(text)
    if kind is int:
        try:
            return int(text) if len(text) <= 18 else to_kind(float(text), int)
        except ValueError:
            return to_kind(float(text), int)  # "3.0" of an older table, or nan
    return float(text)


def read_csv_rows(path: Path, columns: Sequence[str] | None = None,
                  kinds: Mapping[str, type] | None = None) -> list[tuple[int, dict[str, Any]]]:
    """(line number, row) of every complete line of a table CSV. An incomplete last line (a
    write cut by a kill) is dropped; any other damage (a line with the wrong number of
    fields, a cell that is not a number, a header other than ``columns``) is a SweepError
    naming the file and the line."""
    text = _read_text(path)
    if not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    reader = csv.reader(io.StringIO(text))
    kinds = kinds or {}
    rows: list[tuple[int, dict[str, Any]]] = []
    try:
        header = next(reader, None)
        if header is None:
            return []
        if columns is not None and header != list(columns):
            raise _refuse(path, "its header (columns) differs from this sweep's, so it was "
                                "written by a different sweep or is damaged")
        if len(set(header)) != len(header) or RUN_COLUMN not in header:
            raise _refuse(path, "line 1 is not the header of a sweep table")
        for fields in reader:
            line = reader.line_num
            if len(fields) != len(header):
                raise _refuse(path, f"line {line} has {len(fields)} fields, the header "
                                    f"{len(header)} (damaged)")
            row = {}
            for column, cell in zip(header, fields, strict=True):
                try:
                    row[column] = _parse_cell(column, cell, kinds.get(column))
                except ValueError as exc:
                    detail = str(exc) if column == RUN_COLUMN else f"{cell[:40]!r} is not a number"
                    raise _refuse(path, f"line {line}, column {column}: {detail} "
                                        "(damaged)") from None
            rows.append((line, row))
    except csv.Error as exc:
        raise _refuse(path, f"line {reader.line_num} is not valid CSV ({exc}; damaged)") from None
    return rows


def _read_parquet_rows(path: Path, columns: Sequence[str] | None = None
                       ) -> list[tuple[int, dict[str, Any]]]:
    require_pyarrow()
    import pyarrow.parquet as pq

    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise _refuse(path, "is not a regular file")
        table = pq.read_table(path)
    except SweepError:
        raise
    except Exception as exc:  # pyarrow's errors for a damaged or foreign file vary
        raise _refuse(path, f"is not a readable Parquet table ({type(exc).__name__}: "
                            f"{' '.join(str(exc).split())[:200]})") from None
    if columns is not None and table.column_names != list(columns):
        raise _refuse(path, "its columns differ from this sweep's, so it was written by a "
                            "different sweep or is damaged")
    rows = []
    for i, row in enumerate(table.to_pylist()):
        for column, value in row.items():
            if column == STATUS_COLUMN:
                if not isinstance(value, str):
                    raise _refuse(path, f"row {i + 1}: status {value!r} is not a string")
            elif value is None:
                row[column] = math.nan
            elif isinstance(value, bool) or not isinstance(value, int | float):
                raise _refuse(path, f"row {i + 1}, column {column}: {value!r} is not a number")
        if not isinstance(row.get(RUN_COLUMN), int):
            raise _refuse(path, f"row {i + 1}: no whole run index")
        rows.append((i + 1, row))
    return rows


def read_table(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a sweep's output table (CSV or Parquet), as written by :func:`sweep`:
    integer columns as ints (nan where a failed run has no value), the others as floats.
    A damaged table is a :class:`SweepError`; an incomplete last CSV line is dropped."""
    path = Path(path)
    if path.suffix.lower() in (".parquet", ".pq"):
        return [row for _, row in _read_parquet_rows(path)]
    kinds: dict[str, type] = {}
    mpath = meta_path(path)
    if mpath.exists():
        try:
            kinds = meta_kinds(read_meta(mpath))
        except SweepError:
            pass  # the table is read without its types: numbers as floats
    return [row for _, row in read_csv_rows(path, kinds=kinds)]


# The output of one sweep -----------------------------------------------------------------------
class Output:
    """The table being written: metadata, existing rows (resume), appending, final rewrite."""

    def __init__(self, out: Path, fmt: str, settings: dict[str, Any], columns: list[str],
                 kinds: Mapping[str, type], names: Sequence[str],
                 points: Sequence[tuple[Any, ...]], overwrite: bool):
        self.out, self.fmt, self.columns = out, fmt, columns
        self.meta = meta_path(out)
        self.journal = journal_path(out, fmt)
        self.settings = settings
        self.names = list(names)
        self.kinds = dict(kinds)
        self.points = points
        self.fh: IO[str] | None = None
        if overwrite:
            for p in (self.out, self.meta, self.journal):
                p.unlink(missing_ok=True)

    def load_existing(self) -> dict[int, dict[str, Any]]:
        """Rows already computed by an earlier run of the same sweep, keyed by run index.
        Refuses (SweepError, nothing written) a table without metadata, metadata of another
        sweep, and damaged or foreign rows."""
        files = [p for p in (self.out, self.journal) if p.exists() or p.is_symlink()]
        if not (self.meta.exists() or self.meta.is_symlink()):
            if files:
                raise SweepError(f"{files[0]} exists but has no metadata file "
                                 f"{self.meta.name}, so it is not a sweep table that can be "
                                 f"resumed; {_REFUSED}")
            return {}
        old = read_meta(self.meta)["settings"]
        measure = old.get("measure")
        if isinstance(measure, str) and measure in MOVED_MEASURES:
            old = {**old, "measure": MOVED_MEASURES[measure]}
        if old != self.settings:
            diff = [k for k in sorted(set(old) | set(self.settings), key=str)
                    if old.get(k) != self.settings.get(k)]
            raise SweepError(f"{self.out} was written by a different sweep (differs in: "
                             f"{', '.join(map(str, diff))}); rerun with the same grid and "
                             "settings to resume, use --overwrite (overwrite=True) to replace "
                             "it, or choose another output file")
        sources: list[tuple[Path, str, list[tuple[int, dict[str, Any]]]]] = []
        if self.fmt == "parquet" and self.out.exists():
            sources.append((self.out, "row", _read_parquet_rows(self.out, self.columns)))
        if self.journal.exists() or self.journal.is_symlink():
            sources.append((self.journal, "line",
                            read_csv_rows(self.journal, self.columns, self.kinds)))
        existing: dict[int, dict[str, Any]] = {}
        for path, unit, rows in sources:
            for line, raw in rows:
                where = f"{unit} {line}"
                index = raw[RUN_COLUMN]
                if not 0 <= index < len(self.points):
                    raise _refuse(path, f"{where}: run index {index} is outside this grid "
                                        f"(0 to {len(self.points) - 1})")
                try:
                    row = {c: to_kind(raw[c], self.kinds.get(c, float)) for c in self.columns}
                except (TypeError, ValueError, OverflowError):
                    raise _refuse(path, f"{where}: a value is not a number") from None
                values = tuple(row[n] for n in self.names)
                if values != self.points[index]:
                    raise _refuse(path, f"{where}: the row of run {index} has parameter values "
                                        f"{values}, not the grid's {self.points[index]}")
                if index in existing and not _same_run(existing[index], row):
                    raise _refuse(path, f"{where}: run {index} appears twice with different "
                                        "results")
                existing.setdefault(index, row)
        return existing

    def start(self, existing: Mapping[int, Mapping[str, Any]]) -> None:
        """Write the metadata, rewrite the journal with the existing rows and keep it open."""
        self.out.parent.mkdir(parents=True, exist_ok=True)
        meta = {"format": FORMAT_NAME, "format_version": FORMAT_VERSION,
                "table": self.out.name, "columns": self.columns,
                "column_types": {c: KIND_NAMES[self.kinds.get(c, float)] for c in self.columns},
                "n_runs": len(self.points), "settings": self.settings}
        write_atomic(self.meta, json.dumps(meta, indent=1) + "\n")
        rows = [existing[i] for i in sorted(existing)]
        self.fh = write_atomic(self.journal, csv_text(self.columns, rows), keep_open=True)
        if self.fmt == "parquet" and self.out.exists():
            self.out.unlink()  # its rows are in the journal now, until the sweep completes

    def append(self, rows: Sequence[Mapping[str, Any]]) -> None:
        assert self.fh is not None
        self.fh.write(csv_text(self.columns, rows, header=False))
        self.fh.flush()

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    def finish(self, rows: Sequence[Mapping[str, Any]]) -> None:
        """The complete table, sorted by run index, in its final format."""
        self.close()
        if self.fmt == "csv":
            write_atomic(self.out, csv_text(self.columns, rows))
        else:
            write_parquet(self.out, self.columns, rows, self.kinds)
            self.journal.unlink(missing_ok=True)


def _same_run(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    """Two rows of one run with the same results (the wall time may differ)."""
    for key, x in a.items():
        if key == WALL_COLUMN:
            continue
        y = b[key]
        if not (x == y or (isinstance(x, float) and isinstance(y, float)
                           and math.isnan(x) and math.isnan(y))):
            return False
    return True
