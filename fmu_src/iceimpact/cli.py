"""The ``iceimpact`` command.

    iceimpact simulate [scene.toml] [--set NAME=VALUE ...] --t-end 60 --out samples.csv
        [--format csv|openfast] [--plot run.png]
    iceimpact sweep [scene.toml] --vary flow.u=0.01:2:50 --vary impact.e=0:1:11 \\
        --t-end 200 --transient 50 --out sweep.csv [--workers N] [--dask ADDRESS]
    iceimpact plot sweep.csv [--column del_m4_1Hz_N ...] [--out map.png]
    iceimpact loads cases.toml --life 25 --out season [--workers N] [--dask ADDRESS]

Scenes are TOML files with the FMU's parameter names (:func:`iceimpact.load_scene`); without one
the article's Figure 2 scene is used. ``--set`` changes single parameters of it. Runs use the core
(:func:`iceimpact.run`), not the FMU. See docs/how-to/sweep-parameters.md.

Exit status: 0 success; 1 a sweep with failed runs (unless ``--allow-failures``) or a worker
process that died; 2 an argument error (bad option, grid, scene file, output table that cannot
be resumed), with a message and no traceback; 130 interrupted (Ctrl-C, SIGTERM).

``simulate`` does not import the sweep package: what both need is in :mod:`iceimpact.runspec`.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .contract import BY_NAME, VERSION
from .errors import ParameterError, SolverError
from .runspec import DEFAULT_DT, SpecError, apply, check_samples, parse_set
from .scene import Scene, load_scene
from .simulator import Result, run

#: Columns of ``simulate --out``: the FMU's output names for the sampled states (SI units),
#: with the Result field each comes from. ``contact.active`` is 1 while the bodies stick.
SAMPLE_COLUMNS: tuple[tuple[str, str], ...] = (("time", "t"), *(
    (name, BY_NAME[name].field) for name in (
        "structure.x", "structure.v", "ice.z", "ice.v", "contact.gap", "contact.penetration",
        "contact.impulse", "contact.active")))

#: Formats of ``simulate --out``: CSV (:data:`SAMPLE_COLUMNS`) or OpenFAST's text output
#: (:mod:`iceimpact.studies.outfiles`).
SAMPLE_FORMATS = ("csv", "openfast")

#: Exit status of a sweep with failed runs (without --allow-failures).
EXIT_RUNS_FAILED = 1


def _finite(text: str, allow_zero: bool) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and (value > 0.0 or (allow_zero and value == 0.0))):
        bound = ">= 0" if allow_zero else "> 0"
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number {bound}")
    return value


def _positive(text: str) -> float:
    return _finite(text, allow_zero=False)


def _non_negative(text: str) -> float:
    return _finite(text, allow_zero=True)


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:  # also more than 4300 digits
        shown = text if len(text) <= 40 else text[:20] + "..."
        raise argparse.ArgumentTypeError(f"{shown!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 1")
    return value


def _add_scene_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", nargs="?", type=Path,
                   help="scene file (TOML, FMI parameter names); default: the article's "
                        "Figure 2 scene")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="change one parameter of the scene, e.g. --set ice.A=2 (repeatable)")
    p.add_argument("--t-end", type=_positive, default=60.0, metavar="S",
                   help="simulated time per run, s (default 60)")
    p.add_argument("--transient", type=_non_negative, default=0.0, metavar="S",
                   help="summary measures use t >= this, s (default 0)")
    p.add_argument("--dt", type=_positive, default=DEFAULT_DT, metavar="S",
                   help=f"sample step, s (default {DEFAULT_DT:g}); the cost of a run is "
                        "roughly proportional to t_end / dt")


def _add_engine_options(parser: argparse.ArgumentParser, overwrite_help: str,
                        what: str) -> None:
    """The options of the sweep engine that ``sweep`` and ``loads`` share (``what``: the
    things --max-runs counts runs of)."""
    parser.add_argument("--workers", type=_count, default=None, metavar="N",
                        help=f"worker processes (default: all cores, here {os.cpu_count()})")
    parser.add_argument("--chunksize", type=_count, default=None, metavar="N",
                        help="runs per task (default: automatic)")
    parser.add_argument("--dask", default=None, metavar="ADDRESS",
                        help="run on a dask.distributed scheduler, e.g. tcp://host:8786 "
                             "(pip install 'iceimpact[dask]')")
    parser.add_argument("--overwrite", action="store_true", help=overwrite_help)
    parser.add_argument("--max-runs", type=_count, default=None, metavar="N",
                        help=f"refuse {what} of more than N runs (default 100000)")
    parser.add_argument("--allow-failures", action="store_true",
                        help="exit 0 even when some runs failed (default: exit status 1)")

def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``iceimpact`` (subcommands ``simulate``, ``sweep``, ``plot``,
    ``loads``); the documentation's command-line reference is generated from it."""
    parser = argparse.ArgumentParser(
        prog="iceimpact",
        description="Flow-driven repeated ice impacts on a flexible structure (exact "
                    "event-driven solver).")
    # the version of the contract, which is the package's and the FMUs' (pyproject reads it too)
    parser.add_argument("--version", action="version", version=f"%(prog)s {VERSION}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    sim = sub.add_parser("simulate", help="run one scene, write its samples, print a summary",
                         description="Run one scene with the core solver, write the sampled "
                                     "states as CSV and print the summary measures.")
    _add_scene_options(sim)
    sim.add_argument("--out", type=Path, default=None, metavar="FILE",
                     help="samples, one column per FMU output: "
                          + ", ".join(name for name, _ in SAMPLE_COLUMNS) + ", and with the "
                          "modal structure structure.mode<k>.q and .v of each mode (SI units); "
                          "with --format openfast (or a .out file) an OpenFAST text output "
                          "with Time and the outputs of iceimpact.studies.outfiles")
    sim.add_argument("--impacts", type=Path, default=None, metavar="CSV",
                     help="impact list: one row per impact, fields of iceimpact.Impact")
    sim.add_argument("--format", choices=SAMPLE_FORMATS, default=None,
                     help="format of --out: csv, or openfast (OpenFAST's text output: header "
                          "lines, channel names, units, tab-separated values; read by pCrunch, "
                          "openfast-io, pyDatView); default: openfast for a .out file, else csv")
    sim.add_argument("--plot", type=Path, default=None, metavar="PNG",
                     help="also draw the run: displacements with the impacts, the first "
                          "impacts, the impulse per sample interval (.png, .pdf or .svg)")
    sim.set_defaults(handler=_simulate, subparser=sim)

    sw = sub.add_parser(
        "sweep", help="run a grid of scenes in parallel, one summary row per run",
        description="Run every combination of the --vary values (Cartesian grid) with the "
                    "core solver, in parallel, and write one row per run: the varied "
                    "parameters, status, wall_s and the summary measures. Rerunning the same "
                    "command resumes an interrupted sweep.")
    _add_scene_options(sw)
    sw.add_argument("--vary", action="append", default=[], metavar="NAME=SPEC", required=True,
                    help="NAME=START:STOP:COUNT (linspace), NAME=log:START:STOP:COUNT "
                         "(geomspace) or NAME=a,b,c; NAME is an FMI name such as flow.u, "
                         "impact.e, ice.A (repeatable: one axis each)")
    sw.add_argument("--out", type=Path, required=True, metavar="FILE",
                    help="output table (.csv, or .parquet with pyarrow); resumed if it exists")
    sw.add_argument("--format", choices=("csv", "parquet"), default=None,
                    help="table format (default: from the --out suffix, else csv)")
    _add_engine_options(sw, "replace an output table written by a different sweep", "grids")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.set_defaults(handler=_sweep, subparser=sw)
    _add_plot_parser(sub)
    _add_loads_parser(sub)
    return parser


def _add_plot_parser(sub: argparse._SubParsersAction) -> None:
    pl = sub.add_parser(
        "plot", help="draw a sweep table or a load-case result as a PNG",
        description="Draw a table: a sweep table (iceimpact sweep --out) as maps of result "
                    "columns over its two varied parameters; a load-case result (a table with "
                    "a case column, del_m<m>_1Hz_N and damage-share columns, or PREFIX.json "
                    "of iceimpact loads) as the share of the damage and the DEL per case; a "
                    ".out time series of simulate as the panels of simulate --plot.")
    pl.add_argument("table", type=Path, metavar="TABLE",
                    help="sweep table (.csv, .parquet), load-case result (.csv, .json) or "
                         "time series (.out of simulate --format openfast)")
    pl.add_argument("--out", type=Path, default=None, metavar="PNG",
                    help="image to write (.png, .pdf or .svg; default: TABLE with .png)")
    pl.add_argument("--column", dest="columns", action="append", default=[], metavar="NAME",
                    help="sweep: result column to map, one panel each (repeatable; default "
                         "del_m4_1Hz_N and x_peak_m)")
    pl.add_argument("--x", default=None, metavar="NAME",
                    help="sweep: varied parameter along x (default: the last varied)")
    pl.add_argument("--y", default=None, metavar="NAME",
                    help="sweep: varied parameter along y (default: the first varied)")
    pl.add_argument("--at", action="append", default=[], metavar="NAME=VALUE",
                    help="sweep of more than two parameters: the value of another varied "
                         "parameter (nearest grid value; repeatable)")
    pl.set_defaults(handler=_plot, subparser=pl)


def _base_scene(parser: argparse.ArgumentParser, args: argparse.Namespace) -> Scene:
    try:
        base = load_scene(args.scene) if args.scene is not None else Scene()
    except FileNotFoundError:
        parser.error(f"scene file {str(args.scene)!r} not found")
    except (ParameterError, ValueError, OSError) as exc:  # TOML syntax, bad values, unreadable
        parser.error(f"scene file {str(args.scene)!r}: {exc}")
    changes = {}
    try:
        for spec in args.sets:
            name, value = parse_set(spec)
            changes[name] = value
        return apply(base, changes)
    except (SpecError, ParameterError) as exc:
        parser.error(str(exc))


def _check_times(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    if args.transient >= args.t_end:
        parser.error(f"--transient {args.transient:g} must be less than --t-end {args.t_end:g}")
    if args.dt > args.t_end:
        parser.error(f"--dt {args.dt:g} must not exceed --t-end {args.t_end:g}")
    try:
        check_samples(args.t_end, args.dt)
    except SpecError as exc:
        parser.error(str(exc))


def _title(args: argparse.Namespace) -> str:
    """What was simulated: the Figure 2 scene only if nothing was changed, else the scene file
    and/or the --set changes."""
    changes = ", ".join(" = ".join(p.strip() for p in spec.partition("=")[::2])
                        for spec in args.sets)
    if args.scene is None:
        return f"Figure 2 defaults with {changes}" if changes else "Figure 2 scene"
    return f"{args.scene} with {changes}" if changes else str(args.scene)


def _format_value(value: float) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _sample_columns(result: Result) -> list[tuple[str, Any]]:
    """The columns of ``simulate --out``: :data:`SAMPLE_COLUMNS`, then with the modal structure
    each mode's ``structure.mode<k>.q`` and ``.v`` (the FMU's names)."""
    columns = [(name, getattr(result, field)) for name, field in SAMPLE_COLUMNS]
    if result.modes_q is not None:
        for k in range(result.modes_q.shape[1]):
            columns += [(f"structure.mode{k + 1}.q", result.modes_q[:, k]),
                        (f"structure.mode{k + 1}.v", result.modes_v[:, k])]
    return columns


def _write_samples(path: Path, result: Result) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        named = _sample_columns(result)
        writer.writerow([name for name, _ in named])
        columns = [c.astype(int) if c.dtype == bool else c for _, c in named]
        for row in zip(*(c.tolist() for c in columns), strict=True):
            writer.writerow(row)


def _write_impacts(path: Path, result: Result) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    names = result.impacts.dtype.names or ()
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(names)
        for row in result.impacts.tolist():
            writer.writerow(row)


def _sample_format(parser: argparse.ArgumentParser, args: argparse.Namespace) -> str:
    """The format of ``simulate --out``: --format, else openfast for a .out file, else csv."""
    if args.out is None:
        if args.format is not None:
            parser.error(f"--format {args.format} is the format of --out FILE: give --out")
        return "csv"
    if args.format is not None:
        return args.format
    return "openfast" if args.out.suffix.lower() == ".out" else "csv"


def _simulate(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    from .studies.analysis import SUMMARY_FIELDS, summarize

    scene = _base_scene(parser, args)
    _check_times(parser, args)
    fmt = _sample_format(parser, args)
    if args.plot is not None:
        from .plots import PlotError, check_plot_path, require_matplotlib

        try:
            check_plot_path(args.plot, "--plot")
            require_matplotlib()
        except PlotError as exc:
            parser.error(str(exc))
    t0 = time.perf_counter()
    try:
        result = run(scene, args.t_end, dt=args.dt)
    except MemoryError:
        print(f"iceimpact simulate: not enough memory for {args.t_end / args.dt:.3g} samples; "
              "raise --dt or lower --t-end", file=sys.stderr)
        return 1
    except SolverError as exc:  # the method cannot go on (a step over solver.max_impacts, ...)
        parser.error(str(exc))
    wall = time.perf_counter() - t0
    summary = summarize(result, args.transient)
    if args.out is not None and fmt == "openfast":
        from .studies.outfiles import write_openfast

        write_openfast(args.out, result, description=f"{_title(args)}, t_end {args.t_end:g} s, "
                                                     f"dt {args.dt:g} s")
    elif args.out is not None:
        _write_samples(args.out, result)
    if args.impacts is not None:
        _write_impacts(args.impacts, result)
    if args.plot is not None:
        from .plots import plot_run

        plot_run(result, args.plot, title=f"{_title(args)}, {args.t_end:g} s")
    print(f"{_title(args)}: {args.t_end:g} s simulated in {wall:.3f} s wall, "
          f"{len(result.impacts)} impacts")
    print(f"summary over t >= {args.transient:g} s:")
    width = max(map(len, summary))
    for key, value in summary.items():
        unit = SUMMARY_FIELDS.get(key, ("", ""))[0]
        unit = "" if unit in ("", "1") else f" {unit}"
        print(f"  {key:<{width}}  {_format_value(value)}{unit}")
    for label, path in (("samples", args.out), ("impacts", args.impacts), ("plot", args.plot)):
        if path is not None:
            print(f"{label}: {path}")
    return 0


def _plot(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    from .plots import PlotError, plot_table

    at: dict[str, float] = {}
    for spec in args.at:
        name, _, value = spec.partition("=")
        try:
            at[name.strip()] = float(value)
        except ValueError:
            parser.error(f"--at {spec!r}: expected NAME=VALUE with a number, e.g. flow.u=0.5")
    try:
        _, path, kind = plot_table(args.table, args.out, args.columns, args.x, args.y, at)
    except PlotError as exc:
        parser.error(str(exc))
    what = {"cases": "load cases", "run": "time series"}.get(kind, "sweep map")
    print(f"{what}: {args.table} -> {path}")
    return 0


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _resumable(parser: argparse.ArgumentParser, table: Any,
               run: Callable[[], Any]) -> tuple[Any, int | None]:
    """``run()`` of a resumable table (a sweep, a load-case table written to ``table``) as the
    command line runs it: SIGTERM stops it like Ctrl-C (workers too), and an interruption or a
    dead worker says that the finished runs are kept and how to resume. (result, None), or
    (None, the exit status); a SweepError is an argument error (exit status 2)."""
    from concurrent.futures.process import BrokenProcessPool

    from .sweep import SweepError, backends

    backends.keep_freed_memory()  # (this process runs many scenes, the serial ones)
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        return run(), None
    except SweepError as exc:
        parser.error(str(exc))
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished runs are in {table}; rerun the same command to "
              "resume", file=sys.stderr)
        return None, 130
    except BrokenProcessPool as exc:
        print(f"a worker process died ({exc}); finished runs are in {table}; rerun the "
              "same command to resume", file=sys.stderr)
        return None, 1
    finally:
        signal.signal(signal.SIGTERM, previous)


def _sweep(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:

    from .sweep import DEFAULT_MAX_RUNS, SweepError, check_grid_size, output_format, parse_vary
    from .sweep import sweep as run_sweep

    base = _base_scene(parser, args)
    _check_times(parser, args)
    max_runs = DEFAULT_MAX_RUNS if args.max_runs is None else args.max_runs
    grid: dict[str, list] = {}
    try:
        for spec in args.vary:
            name, values = parse_vary(spec, max_count=max_runs)
            if name in grid:
                raise SweepError(f"--vary {spec!r}: {name} is already varied")
            grid[name] = values
        n_runs = check_grid_size(grid, max_runs)  # before the grid's points are made
        output_format(args.out, args.format)  # a missing pyarrow is reported before anything runs
    except SweepError as exc:
        parser.error(str(exc))
    if not args.quiet:
        axes = " x ".join(f"{n} ({len(v)})" for n, v in grid.items())
        print(f"sweep: {n_runs} runs over {axes}, t_end {args.t_end:g} s, dt {args.dt:g} s "
              f"-> {args.out}", file=sys.stderr)
    t0 = time.perf_counter()
    rows, status = _resumable(parser, args.out, lambda: run_sweep(
        base, grid, t_end=args.t_end, transient=args.transient, dt=args.dt, out=args.out,
        workers=args.workers, progress=not args.quiet, dask_address=args.dask, fmt=args.format,
        overwrite=args.overwrite, chunksize=args.chunksize, max_runs=max_runs))
    if status is not None:
        return status
    errors = [r for r in rows if r["status"] != "ok"]
    print(f"{len(rows)} runs ({len(rows) - len(errors)} ok, {len(errors)} errors) in "
          f"{time.perf_counter() - t0:.1f} s -> {args.out}")
    for row in errors[:5]:
        print(f"  run {row['run']}: {row['status']}")
    if len(errors) > 5:
        print(f"  ... and {len(errors) - 5} more (status column)")
    if errors and not args.allow_failures:
        print(f"iceimpact sweep: {len(errors)} of {len(rows)} runs failed (see the status "
              f"column of {args.out}); exit status {EXIT_RUNS_FAILED} (--allow-failures: 0)",
              file=sys.stderr)
        return EXIT_RUNS_FAILED
    return 0


def _add_loads_parser(sub: argparse._SubParsersAction) -> None:
    """``iceimpact loads``: a load-case table over a service life
    (docs/how-to/design-over-a-season.md)."""
    lo = sub.add_parser(
        "loads", help="run a load-case table (cases, hours per year, repetitions) and combine "
                      "the lifetime damage-equivalent loads",
        description="Run every case of a load-case table (TOML or CSV: FMI values, hours per "
                    "year, repetitions with perturbed starts) on the sweep engine and write "
                    "PREFIX.csv (one row per run, resumable) and PREFIX.json (per case and "
                    "lifetime DELs, extremes, impulses; units in the keys). Rerunning the same "
                    "command resumes; changing only hours or --life reruns nothing.")
    lo.add_argument("cases", type=Path, help="load-case table, .toml or .csv")
    lo.add_argument("--life", type=_positive, required=True, metavar="YEARS",
                    help="service life, years (the ice hours of the table recur every year)")
    lo.add_argument("--out", type=Path, required=True, metavar="PREFIX",
                    help="writes PREFIX.csv, PREFIX.csv.meta.json and PREFIX.json")
    lo.add_argument("--t-end", type=_positive, default=None, metavar="S",
                    help="simulated time per run, s (overrides the file's t_end; needed for CSV)")
    lo.add_argument("--transient", type=_non_negative, default=None, metavar="S",
                    help="loads use t >= this, s (overrides the file's; default 0)")
    lo.add_argument("--dt", type=_positive, default=None, metavar="S",
                    help=f"sample step, s (overrides the file's; default {DEFAULT_DT:g})")
    _add_engine_options(lo, "replace a PREFIX.csv written for other runs", "tables")
    lo.add_argument("--series", type=Path, default=None, metavar="DIR",
                    help="also write each run's time series as an OpenFAST .out file in DIR "
                         "(for pCrunch, pyDatView; runs the cases again, serially)")
    lo.add_argument("--quiet", action="store_true", help="no progress bar")
    lo.set_defaults(handler=_loads, subparser=lo)


def _loads(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:

    from .seasons import load_cases, run_season
    from .sweep import DEFAULT_MAX_RUNS, SweepError

    max_runs = DEFAULT_MAX_RUNS if args.max_runs is None else args.max_runs
    try:
        table = load_cases(args.cases, t_end=args.t_end, transient=args.transient, dt=args.dt,
                           max_runs=max_runs)
    except SweepError as exc:
        parser.error(str(exc))
    csv_path = f"{args.out}.csv"
    if not args.quiet:
        print(f"loads: {len(table.cases)} cases, {table.n_runs} runs of {table.t_end:g} s "
              f"(dt {table.dt:g} s, loads over t >= {table.transient:g} s), "
              f"{table.hours:g} ice hours per year, life {args.life:g} years -> {csv_path}",
              file=sys.stderr)
    t0 = time.perf_counter()
    result, status = _resumable(parser, csv_path, lambda: run_season(
        table, args.life, out=args.out, workers=args.workers, progress=not args.quiet,
        dask_address=args.dask, overwrite=args.overwrite, chunksize=args.chunksize))
    if status is not None:
        return status
    rows, summary = result
    errors = [r for r in rows if r["status"] != "ok"]
    life = summary["lifetime"]
    print(f"{len(rows)} runs ({len(rows) - len(errors)} ok, {len(errors)} errors) in "
          f"{time.perf_counter() - t0:.1f} s -> {csv_path}, {args.out}.json")
    width = max(len(c["name"]) for c in summary["cases"])
    print(f"{'case':<{width}} {'h/yr':>7} {'DEL m=4 1Hz N':>14} {'damage share m=4':>17} "
          f"{'max k x N':>10}")
    for case in summary["cases"]:
        share = case["damage_share"]["4"]
        print(f"{case['name']:<{width}} {case['hours_per_year']:>7g} "
              f"{case['del_1Hz_N']['4']:>14.4g} {share:>17.3f} {case['kx_max_N']:>10.4g}")
    print(f"lifetime ({life['life_years']:g} years, {life['ice_hours']:g} ice hours): 1 Hz DEL "
          + ", ".join(f"m={m} {v:.4g} N" for m, v in life["del_1Hz_N"].items())
          + "; 1e7-cycle DEL "
          + ", ".join(f"m={m} {v:.4g} N" for m, v in life["del_1e7_N"].items())
          + f"; max k x {life['kx_max_N']:.4g} N ({life['kx_max_case']})")
    for row in errors[:5]:
        print(f"  run {row['run']} (case {row['case']}, repetition {row['repetition']}): "
              f"{row['status']}")
    if args.series is not None and errors:
        print(f"iceimpact loads: no time series written to {args.series}: {len(errors)} runs "
              f"failed", file=sys.stderr)
    elif args.series is not None:
        from .seasons import write_case_series

        args.series.mkdir(parents=True, exist_ok=True)
        written = write_case_series(table, args.series)
        print(f"{len(written)} time series (OpenFAST .out) -> {args.series}")
    if errors and not args.allow_failures:
        print(f"iceimpact loads: {len(errors)} of {len(rows)} runs failed (see the status "
              f"column of {csv_path}; the lifetime values leave them out); exit status "
              f"{EXIT_RUNS_FAILED} (--allow-failures: 0)", file=sys.stderr)
        return EXIT_RUNS_FAILED
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``iceimpact``; returns the exit status (argument errors exit with 2)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.handler(args.subparser, args)


if __name__ == "__main__":
    sys.exit(main())
