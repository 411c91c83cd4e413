"""The data the plots draw, without drawing: table files and load-case results read into rows,
a run or an OpenFAST ``.out`` file into series, and the columns and axes a plot takes from them.

:mod:`iceimpact.plots` draws what this module returns; neither matplotlib nor a figure appears
here. Every outside file is read as the sweep reads one (a regular file, a size limit, UTF-8) and
a file that cannot be read, or a table that cannot be plotted, is a :class:`PlotError` naming
the file and what is wrong.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np


class PlotError(ValueError):
    """A table or a choice of columns that cannot be plotted (the message says why)."""


# A run ------------------------------------------------------------------------------------------
def run_series(result: Any) -> dict[str, np.ndarray]:
    """A run (:class:`iceimpact.Result`) as :func:`iceimpact.plots.plot_series` takes it: the
    FMU's outputs at the samples (``contact.count`` counts the impacts up to each sample)."""
    from .studies.outfiles import TIME_CHANNEL, run_channels

    channels = run_channels(result)
    channels["time"] = channels.pop(TIME_CHANNEL)
    return channels


def out_series(table: str | Path) -> tuple[dict[str, np.ndarray], str]:
    """The series of an OpenFAST text output written by ``iceimpact simulate --format openfast``
    as :func:`iceimpact.plots.plot_series` takes them, and a title (the file's description, up
    to its first comma, else the file name). PlotError if the file cannot be read or lacks a
    channel the plot needs."""
    from .studies.outfiles import TIME_CHANNEL, read_out

    try:
        channels, _, description = read_out(table)
    except (OSError, ValueError) as exc:
        raise PlotError(str(exc)) from None
    series = {("time" if n == TIME_CHANNEL else n): v for n, v in channels.items()}
    missing = [n for n in ("structure.x", "ice.z", "contact.impulse", "contact.count",
                           "contact.active") if n not in series]
    if missing or series["time"].size < 2:
        raise PlotError(f"{table}: " + (f"has no channel {', '.join(missing)}" if missing
                                         else "has fewer than two samples")
                        + "; it was not written by iceimpact simulate --format openfast")
    return series, description.split(",")[0] or Path(table).name


# A sweep table ----------------------------------------------------------------------------------
def varied_columns(columns: Sequence[str]) -> list[str]:
    """The varied parameters of a sweep table: its columns between ``run`` and ``status``."""
    from .sweep.columns import RUN_COLUMN, STATUS_COLUMN

    columns = list(columns)
    if RUN_COLUMN not in columns or STATUS_COLUMN not in columns:
        raise PlotError("not a sweep table: it has no 'run' and 'status' columns")
    return columns[columns.index(RUN_COLUMN) + 1:columns.index(STATUS_COLUMN)]


def measure_columns(columns: Sequence[str]) -> list[str]:
    """The result columns of a sweep table (after ``status``)."""
    from .sweep.columns import STATUS_COLUMN

    columns = list(columns)
    return columns[columns.index(STATUS_COLUMN) + 1:] if STATUS_COLUMN in columns else []


def select_rows(rows: Sequence[Mapping[str, Any]], at: Mapping[str, float]
                ) -> list[Mapping[str, Any]]:
    """The rows whose parameter ``name`` is the grid value nearest ``at[name]``, for each."""
    out = list(rows)
    for name, wanted in at.items():
        values = np.unique([float(r[name]) for r in out])
        if not values.size:
            break
        nearest = values[int(np.argmin(np.abs(values - wanted)))]
        out = [r for r in out if float(r[name]) == nearest]
    return out


def sweep_grid(rows: Sequence[Mapping[str, Any]], column: str, x: str, y: str
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x values, y values, column as an array [y, x]) of the table's rows; nan for a failed run
    or a missing cell."""
    xs = np.unique([float(r[x]) for r in rows])
    ys = np.unique([float(r[y]) for r in rows])
    data = np.full((ys.size, xs.size), np.nan)
    for r in rows:
        if r.get("status", "ok") != "ok":
            continue
        i = int(np.searchsorted(ys, float(r[y])))
        j = int(np.searchsorted(xs, float(r[x])))
        data[i, j] = float(r[column])
    return xs, ys, data


def sweep_axes(rows: Sequence[Mapping[str, Any]], x: str | None = None, y: str | None = None,
               at: Mapping[str, float] | None = None) -> tuple[str, str]:
    """The map's (x, y) parameters of a sweep table: by default its two varied parameters
    (columns between ``run`` and ``status`` with more than one value; x the last, y the first);
    with more, ``x`` and ``y`` chosen and every other one fixed by ``at``. PlotError naming
    what is needed."""
    between = varied_columns(list(rows[0]))
    varied = [c for c in between if len({float(r[c]) for r in rows}) > 1]
    at = dict(at or {})
    for name in (x, y, *at):
        if name is not None and name not in between:
            raise PlotError(f"{name!r} is not a parameter of this sweep; its parameters: "
                            + (", ".join(between) or "none"))
    if len(varied) < 2:
        raise PlotError("a map needs a sweep table with two varied parameters (a sweep with "
                        "two --vary options); this one varies "
                        + (", ".join(varied) if varied else "none") + ": plot it from the table "
                        "itself, or sweep a second parameter")
    if x is None and y is None and len(varied) == 2:
        return varied[1], varied[0]
    if x is None or y is None or x == y:
        raise PlotError(f"this sweep varies {len(varied)} parameters ({', '.join(varied)}): "
                        "choose two different ones as the map's axes with --x NAME and --y NAME")
    loose = [c for c in varied if c not in (x, y) and c not in at]
    if loose:
        raise PlotError("fix the other varied parameters with --at NAME=VALUE (the nearest grid "
                        "value is taken): " + ", ".join(loose))
    return x, y


def default_columns(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The columns plotted without --column: the 1 Hz DEL (m = 4) and the peak displacement,
    those of them in the table, else the first result column."""
    measures = measure_columns(list(rows[0]))
    chosen = [c for c in ("del_m4_1Hz_N", "x_peak_m") if c in measures]
    return chosen or measures[:1]


# A load-case result -----------------------------------------------------------------------------
_DEL_1HZ = re.compile(r"^del_m(\d+(?:\.\d+)?)_1Hz_N$")


def load_case_columns(columns: Sequence[str]) -> dict[str, Any]:
    """The columns of a load-case table that :func:`iceimpact.plots.plot_load_cases` draws:
    ``case`` (the name column), ``hours``, ``dels`` ({Wöhler exponent: column}) and ``shares``
    ({exponent or None: column}). PlotError naming what is missing."""
    columns = [c for c in columns if isinstance(c, str)]
    case = next((c for c in columns if c.lower() in ("case", "name", "case_name", "load_case")),
                None)
    hours = next((c for c in columns if "hour" in c.lower() or c in ("h", "duration_h")), None)
    dels = {float(m.group(1)): c for c in columns if (m := _DEL_1HZ.match(c))}
    shares: dict[float | None, str] = {}
    for c in columns:
        low = c.lower()
        if "damage" in low and ("share" in low or "fraction" in low):
            m = re.search(r"m(\d+(?:\.\d+)?)", low)
            shares[float(m.group(1)) if m else None] = c
    missing = [what for what, found in (("a case name column ('case')", case),
                                        ("DEL columns (del_m<m>_1Hz_N)", dels),
                                        ("damage share columns (damage_share*)", shares))
               if not found]
    if missing:
        raise PlotError("not a load-case table: no " + ", no ".join(missing))
    return {"case": case, "hours": hours, "dels": dels, "shares": shares}


#: The ``format`` of a load-case result's PREFIX.json (``iceimpact loads``).
SEASON_FORMAT = "iceimpact-season"


def _float(value: Any) -> float:
    return math.nan if value is None else float(value)


def season_rows(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The cases of a load-case result (PREFIX.json of ``iceimpact loads``: ``cases``, each with
    ``name``, ``hours_per_year`` and ``del_1Hz_N`` and ``damage_share`` keyed by the Wöhler
    exponent) as flat rows: ``case``, ``hours_per_year``, ``del_m<m>_1Hz_N``,
    ``damage_share_m<m>``."""
    rows = []
    for case in summary.get("cases") or []:
        if not isinstance(case, Mapping):
            raise PlotError("a load-case result's \"cases\" must be objects")
        row: dict[str, Any] = {"case": case.get("name", "?"),
                               "hours_per_year": _float(case.get("hours_per_year"))}
        for key, template in (("del_1Hz_N", "del_m{}_1Hz_N"),
                              ("damage_share", "damage_share_m{}")):
            for m, value in (case.get(key) or {}).items():
                row[template.format(m)] = _float(value)
        rows.append(row)
    return rows


def lifetime_dels(summary: Mapping[str, Any]) -> dict[float, float]:
    """The lifetime 1 Hz DELs of a load-case result (N), keyed by the Wöhler exponent; nan where
    the summary has null."""
    life = summary.get("lifetime") or {}
    return {float(m): _float(v) for m, v in (life.get("del_1Hz_N") or {}).items()}


# A table file (``iceimpact plot``) --------------------------------------------------------------
def _number(text: Any) -> Any:
    """A CSV cell as a float where it is a number, else the text."""
    if not isinstance(text, str):
        return text
    try:
        return float(text)
    except ValueError:
        return text


#: The largest JSON file a plot reads (a load-case summary is a few kB).
MAX_JSON_BYTES = 64 * 2**20


def _read_json_text(path: Path) -> str:
    """The text of a JSON file from outside, read as every outside text file is (a regular
    file, within MAX_JSON_BYTES, UTF-8); PlotError otherwise."""
    from .sweep.table import read_text_file

    return read_text_file(path, MAX_JSON_BYTES,
                          lambda p, problem: PlotError(f"{p}: not readable JSON ({problem})"))


def season_summary(path: str | Path) -> dict[str, Any] | None:
    """The load-case summary of ``path``: PREFIX.json itself, or the one beside PREFIX.csv;
    None if there is none (or it is not one)."""
    import json

    path = Path(path)
    doc = path if path.suffix.lower() == ".json" else path.with_suffix(".json")
    if not doc.is_file():
        return None
    try:
        data = json.loads(_read_json_text(doc))
    except (PlotError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("format") == SEASON_FORMAT else None


def read_rows(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a table file: a sweep table (CSV or Parquet, :func:`iceimpact.sweep.read_table`)
    or another CSV (numbers as floats), or the case rows of a JSON file (a list of objects, or an
    object holding one under ``cases`` or ``rows``; else its sibling ``.csv``). PlotError if
    it cannot be read."""
    import csv
    import json

    path = Path(path)
    if not path.is_file():
        raise PlotError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix in (".parquet", ".pq"):
        from .sweep import SweepError, read_table

        try:
            return read_table(path)
        except SweepError as exc:
            raise PlotError(str(exc)) from None
    if suffix == ".json":
        try:
            data = json.loads(_read_json_text(path))
        except ValueError as exc:
            raise PlotError(f"{path}: not readable JSON ({exc})") from None
        if isinstance(data, dict):
            data = next((data[k] for k in ("cases", "rows", "table") if isinstance(data.get(k),
                                                                                   list)), None)
        if isinstance(data, list) and data and all(isinstance(r, dict) for r in data):
            return [dict(r) for r in data]
        sibling = path.with_suffix(".csv")
        if sibling.is_file():
            return read_rows(sibling)
        raise PlotError(f"{path}: holds no list of cases (\"cases\": [...]) and there is no "
                        f"{sibling.name} beside it")
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            header = reader.fieldnames or []
            if "run" in header and "status" in header:
                from .sweep import SweepError, read_table

                try:
                    return read_table(path)
                except SweepError as exc:
                    raise PlotError(str(exc)) from None
            return [{k: _number(v) for k, v in row.items()} for row in reader]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise PlotError(f"{path}: not a readable CSV table ({exc})") from None
