"""Design over an ice season: load-case tables and lifetime damage-equivalent loads.

A structural designer checks fatigue over a service life, summed over the ice conditions a site
sees, not one run's DEL. A **load-case table** lists the cases: FMI parameter values, the hours per
year each case lasts, and a number of repetitions (the motion is sensitive to its initial state,
so one run is one sample; repetition ``k`` starts the ice ``k`` steps of :func:`perturbation`
further upstream). The runs go through the sweep engine (:func:`iceimpact.sweep.run_points`:
process pool or dask, resumable, the same limits and refusals), one row per run; the rows are then
combined per case and over the life into damage-equivalent loads, damage shares and extremes
(:mod:`~iceimpact.seasons.lifetime` gives the formulas; docs/explanation/design-loads.md, "Design
over an ice season").

Case files are outside data: TOML (``tomllib``) or CSV (``csv``), nothing evaluated; every field
is checked, and an error (:class:`SeasonError`) names the file, the case, the field, the value and
what is allowed, before anything runs.

The package: :mod:`~iceimpact.seasons.cases` (reading and checking a table, the runs it asks
for), :mod:`~iceimpact.seasons.lifetime` (a run's row, the rows combined over the life) and
:func:`run_season` and :func:`write_case_series` here, which run the cases (the first on the
sweep engine, the second one by one into OpenFAST files). Every public name of the two modules is
importable from :mod:`iceimpact.seasons`. Imports go one way: this package uses
:mod:`iceimpact.sweep` and :mod:`iceimpact.studies`, and neither uses it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..runspec import apply
from ..simulator import run
from ..studies.outfiles import case_file_name, write_openfast
from ..sweep import run_points
from ..sweep.table import write_atomic
from .cases import (
    CASE_COLUMN,
    MAX_FILE_BYTES,
    MAX_HOURS_PER_YEAR,
    MAX_NAME,
    MAX_REPETITIONS,
    PERTURBATION_M,
    PERTURBATION_ULPS,
    PERTURBED,
    REPETITION_COLUMN,
    Case,
    CaseTable,
    SeasonError,
    load_cases,
    perturbation,
    perturbed_z0,
    season_runs,
)
from .lifetime import (
    FORMAT_NAME,
    FORMAT_VERSION,
    MAX_LIFE_YEARS,
    SEASON_FIELDS,
    SUMMARY_UNITS,
    check_life,
    lifetime_del,
    pooled_del,
    run_columns,
    season_measure,
    series_row,
    summarize_season,
)

__all__ = [
    "CASE_COLUMN", "Case", "CaseTable", "FORMAT_NAME", "FORMAT_VERSION", "MAX_FILE_BYTES",
    "MAX_HOURS_PER_YEAR", "MAX_LIFE_YEARS", "MAX_NAME", "MAX_REPETITIONS", "PERTURBATION_M",
    "PERTURBATION_ULPS", "PERTURBED", "REPETITION_COLUMN", "SEASON_FIELDS", "SUMMARY_UNITS",
    "SeasonError", "check_life", "lifetime_del", "load_cases", "perturbation", "perturbed_z0",
    "pooled_del", "run_columns", "run_season", "season_measure", "season_runs", "series_row",
    "summarize_season", "write_case_series", "write_summary",
]


def _jsonable(value: Any) -> Any:
    """nan and inf -> null (JSON has no such numbers)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


def write_summary(path: str | Path, summary: Mapping[str, Any]) -> None:
    """PREFIX.json, atomically (nan as null)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, json.dumps(_jsonable(dict(summary)), indent=1, allow_nan=False) + "\n")


def run_season(table: CaseTable, life_years: float, out: str | Path | None = None,
               workers: int | None = None, progress: bool = True, dask_address: Any = None,
               overwrite: bool = False, chunksize: int | None = None,
               on_rows: Callable[[list[dict[str, Any]]], None] | None = None
               ) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Run every case of ``table`` with its repetitions and combine them over ``life_years``.

    ``out`` is the PREFIX: the runs go to ``PREFIX.csv`` (one row per run, the sweep table
    with ``case`` and ``repetition`` columns, resumable: a rerun runs only what is missing;
    hours and the life do not enter it, so changing them reruns nothing) and the summary to
    ``PREFIX.json``. The other arguments are :func:`iceimpact.sweep.sweep`'s. Returns the rows
    and the summary (:func:`summarize_season`)."""
    check_life(life_years)
    names, points, labels = season_runs(table)
    kinds = {n: int if all(isinstance(p[j], int) for p in points) else float
             for j, n in enumerate(names)}
    identity = {"season": FORMAT_NAME, "names": list(names), "points": [list(p) for p in points],
                "labels": labels}
    csv_path = None if out is None else Path(f"{out}.csv")
    rows = run_points(table.base, names, points, table.t_end, table.transient, table.dt,
                      identity=identity, kinds=kinds, labels=labels, out=csv_path,
                      workers=workers, progress=progress, dask_address=dask_address, fmt="csv",
                      overwrite=overwrite, chunksize=chunksize, measure=season_measure,
                      on_rows=on_rows, desc="loads")
    summary = summarize_season(table, rows, life_years)
    if out is not None:
        summary["settings"]["runs_table"] = Path(f"{out}.csv").name
        write_summary(Path(f"{out}.json"), summary)
    return rows, summary


def write_case_series(table: CaseTable, directory: str | Path, generated: float | None = None
                      ) -> list[Path]:
    """Run every case of a load-case table (:func:`load_cases`), each repetition as ``iceimpact
    loads`` runs it (same scene, same perturbed ``ice.z0``, same ``t_end`` and ``dt``), and write
    each run as an OpenFAST text output in ``directory``
    (:func:`iceimpact.studies.outfiles.case_file_name`), so that pCrunch or pyDatView can take
    the cases' time series (weights: a case's hours over its repetitions). Runs serially;
    returns the paths, in the table's order."""
    directory = Path(directory)
    names, points, labels = season_runs(table)
    paths = []
    for point, i, k in zip(points, labels[CASE_COLUMN], labels[REPETITION_COLUMN], strict=True):
        case = table.cases[i]
        scene = apply(table.base, dict(zip(names, point, strict=True)))
        result = run(scene, table.t_end, dt=table.dt)
        description = (f"load case {case.name!r} ({case.hours:g} h per year), repetition {k} "
                       f"of {case.repetitions}, t_end {table.t_end:g} s, dt {table.dt:g} s, "
                       f"from {table.source}")
        paths.append(write_openfast(directory / case_file_name(i, case.name, k), result,
                                    description=description, generated=generated))
    return paths
