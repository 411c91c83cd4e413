"""Plots of a run, a sweep table and a load-case result (``iceimpact simulate --plot``,
``iceimpact plot``, ``examples/demo.py``).

matplotlib is imported only when a plot is drawn (``pip install 'iceimpact[plot]'``), so that
importing :mod:`iceimpact` stays light; figures are drawn on the Agg canvas (no display, no
pyplot state). Every function saves the figure and returns it, so that a caller (a test) can look
at its axes. What is drawn is read and chosen by :mod:`iceimpact.plot_data` (table files,
load-case results, the columns and axes of a map); this module only draws. Axis labels carry
their units: SI, from the contract (parameters, outputs) and from
:data:`iceimpact.studies.analysis.SUMMARY_FIELDS` (measures), ``-`` for none.

- :func:`plot_series`: the demo's four panels (structure displacement with the impacts and the
  sticking, ice displacement, the first impacts, the impulse per interval) of any series keyed by
  FMU output names: FMPy's result array, or a run's (:func:`plot_run`);
- :func:`plot_sweep_map`: result columns of a sweep table as maps over two varied parameters;
- :func:`plot_load_cases`: share of the damage and DEL per load case.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .plot_data import (
    PlotError,
    default_columns,
    lifetime_dels,
    load_case_columns,
    measure_columns,
    out_series,
    read_rows,
    run_series,
    season_rows,
    season_summary,
    select_rows,
    sweep_axes,
    sweep_grid,
)

#: File types the plots are written as (matplotlib picks the format from the suffix).
PLOT_SUFFIXES = (".png", ".pdf", ".svg")

#: Resolution of the PNG files, dots per inch (the figure sizes are in inches).
DPI = 100

#: sticking_fraction above which a cell of a sweep map is marked as sticking.
STICKING = 0.5

#: Cells of a sweep map are annotated with their values up to this many per axis.
ANNOTATE_MAX = 12


def check_plot_path(path: str | Path, option: str = "plot") -> Path:
    """``path`` if its suffix is one of :data:`PLOT_SUFFIXES`, else PlotError naming them."""
    path = Path(path)
    if path.suffix.lower() not in PLOT_SUFFIXES:
        raise PlotError(f"{option} {str(path)!r}: the file name must end in "
                         + ", ".join(PLOT_SUFFIXES[:-1]) + f" or {PLOT_SUFFIXES[-1]}")
    return path


def require_matplotlib() -> None:
    """PlotError if matplotlib is not installed (checked before a run whose plot is asked)."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise PlotError("plots need matplotlib, which is not installed: "
                        "pip install 'iceimpact[plot]'") from None


def _figure(width: float, height: float) -> Any:
    """A new figure (inches) on an Agg canvas, with constrained layout."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Any, path: str | Path) -> Any:
    path = check_plot_path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return fig


def unit_text(unit: str) -> str:
    """A unit as an axis label writes it, in parentheses (``-`` for none)."""
    return f"({unit if unit not in ('', '1') else '-'})"


def length_scale(values: np.ndarray) -> tuple[float, str]:
    """(factor, unit) to show lengths ``values`` (m) in m, mm or µm by their largest size."""
    finite = np.abs(values[np.isfinite(values)])
    peak = float(finite.max()) if finite.size else 0.0
    if peak >= 1.0:
        return 1.0, "m"
    if peak >= 1e-3:
        return 1e3, "mm"
    return 1e6, "µm"


# A run ------------------------------------------------------------------------------------------
def plot_series(series: Mapping[str, Any], path: str | Path, title: str = "IceImpact",
                interval: str | None = None) -> Any:
    """The demo's four panels of a run, saved to ``path``; returns the figure.

    ``series`` maps FMU output names to arrays over the samples: ``time``, ``structure.x``,
    ``ice.z``, ``contact.impulse`` (per interval), ``contact.count`` (cumulative) and
    ``contact.active`` (FMPy's structured result array is such a mapping). ``interval`` names
    the sampling interval in the impulse panel (default: from the sample times, e.g. "10 ms
    interval").
    """
    t = np.asarray(series["time"], dtype=float)
    x, z = np.asarray(series["structure.x"], float), np.asarray(series["ice.z"], float)
    impulse = np.asarray(series["contact.impulse"], dtype=float)
    hit = np.flatnonzero(np.diff(np.asarray(series["contact.count"])) > 0) + 1  # impact steps
    active = np.asarray(series["contact.active"]).astype(bool)
    if interval is None:
        step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        interval = (f"{step * 1e3:.3g} ms" if step < 1.0 else f"{step:.3g} s") + " interval"
    fx, ux = length_scale(x)
    fz, uz = length_scale(z)

    fig = _figure(11, 12)
    ax_x, ax_z, ax_zoom, ax_imp = fig.subplots(4, 1)
    ax_x.plot(t, fx * x, lw=0.5, color="tab:red", label="structure x")
    ax_x.plot(t[hit], fx * x[hit], "k|", ms=6, label="impacts")
    if active.any():
        ax_x.fill_between(t, 0, 1, where=active, color="tab:green", alpha=0.15,
                          transform=ax_x.get_xaxis_transform(), label="sticking")
    ax_x.set(xlabel="time (s)", ylabel=f"x ({ux})", title=f"{title}: structure displacement")
    ax_x.legend(loc="upper right")

    ax_z.plot(t, fz * z, lw=0.6, color="tab:blue", label="ice z")
    ax_z.plot(t[hit], fz * z[hit], "k|", ms=6, label="impacts")
    ax_z.set(xlabel="time (s)", ylabel=f"z ({uz})", title="ice displacement")
    ax_z.legend(loc="lower right")

    # The first impacts: the ice's approach and the structure's ringing after each impact.
    end = t[hit[min(len(hit) - 1, 5)]] + 1.0 if len(hit) else min(t[-1], 10.0)
    window = t <= end
    ax_zoom.plot(t[window], fz * z[window], color="tab:blue", label=f"ice z ({uz})")
    ax_zoom.set(xlabel="time (s)", ylabel=f"z ({uz})")
    ax_zoom.set_title(f"the first {end:.1f} s", loc="left")
    twin = ax_zoom.twinx()
    twin.plot(t[window], fx * x[window], color="tab:red", lw=0.8,
              label=f"structure x ({ux})")
    zoom_hits = hit[t[hit] <= end]
    twin.plot(t[zoom_hits], fx * x[zoom_hits], "ko", ms=4, label="impacts")
    twin.set_ylabel(f"x ({ux})")
    lines = ax_zoom.get_lines() + twin.get_lines()
    # above the axes, beside the title: the ice's approach and the ringing fill the panel
    ax_zoom.legend(lines, [line.get_label() for line in lines], loc="lower right",
                   bbox_to_anchor=(1.0, 1.0), ncol=3, frameon=False, borderaxespad=0.2)

    ax_imp.plot(t, impulse, lw=0.5, color="tab:purple", label="impulse per interval")
    ax_imp.plot(t[hit], impulse[hit], "k.", ms=3, label="intervals with an impact")
    ax_imp.set(xlabel="time (s)", ylabel="impulse (N.s)",
               title=f"impulse on the structure per {interval} (impacts and sticking "
                     "contact)")
    ax_imp.legend(loc="upper right")
    return _save(fig, path)


def plot_run(result: Any, path: str | Path, title: str = "IceImpact") -> Any:
    """:func:`plot_series` of a run (``iceimpact simulate --plot``); returns the figure."""
    return plot_series(run_series(result), path, title=title)


def plot_out(table: str | Path, path: str | Path) -> Any:
    """:func:`plot_series` of an OpenFAST text output written by ``iceimpact simulate --format
    openfast`` (``iceimpact plot run.out``, read by :func:`iceimpact.plot_data.out_series`);
    returns the figure."""
    series, title = out_series(table)
    return plot_series(series, path, title=title)


# Units of table columns --------------------------------------------------------------------------
def column_unit(name: str) -> str:
    """The unit of a table column: a parameter's from the contract, a measure's from
    SUMMARY_FIELDS, else from a suffix (``_N``, ``_s``, ``_m``, ``_hz``...); "" if unknown."""
    from .contract import BY_NAME
    from .studies.analysis import SUMMARY_FIELDS

    if name in BY_NAME:
        return BY_NAME[name].unit
    if name in SUMMARY_FIELDS:
        return SUMMARY_FIELDS[name][0]
    suffixes = {"_N": "N", "_ns": "N.s", "_s": "s", "_m": "m", "_hz": "Hz", "_Hz": "Hz",
                "_rad_s": "rad/s", "_h": "h", "hours": "h"}
    for suffix, unit in suffixes.items():
        if name.endswith(suffix):
            return unit
    return ""


def column_label(name: str) -> str:
    return f"{name} {unit_text(column_unit(name))}"


# A sweep table ----------------------------------------------------------------------------------
def _log_axis(values: np.ndarray) -> bool:
    """A log axis for positive values: evenly spaced in log, or uneven over two decades, or two
    values a decade apart or more."""
    if values.size < 2 or np.any(values <= 0.0):
        return False
    ratio = values.max() / values.min()
    if values.size == 2:
        return bool(ratio >= 10.0)
    steps, log_steps = np.diff(values), np.diff(np.log(values))
    if np.allclose(steps, steps[0], rtol=1e-6):
        return False  # evenly spaced
    return bool(np.allclose(log_steps, log_steps[0], rtol=1e-6) or ratio >= 100.0)


def _edges(values: np.ndarray, log: bool) -> np.ndarray:
    """Cell edges around sorted grid values (midpoints, in log space on a log axis)."""
    v = np.log(values) if log else values.astype(float)
    if v.size == 1:
        half = 0.5 if log else (0.5 * abs(v[0]) or 0.5)
        e = np.array([v[0] - half, v[0] + half])
    else:
        mid = 0.5 * (v[1:] + v[:-1])
        e = np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])
    return np.exp(e) if log else e


def _centre(edges: np.ndarray, i: int, log: bool) -> float:
    return math.sqrt(edges[i] * edges[i + 1]) if log else 0.5 * (edges[i] + edges[i + 1])


def plot_sweep_map(rows: Sequence[Mapping[str, Any]], path: str | Path,
                   columns: Sequence[str], x: str, y: str, title: str = "") -> Any:
    """Each of ``columns`` as a map over the parameters ``x`` and ``y`` of the sweep ``rows`` (one
    panel each, as examples/design_map.py draws them), saved to ``path``; returns the figure.

    Cells show their values when the grid is small; failed runs are blank cells marked with a
    cross; cells in sticking contact for most of the window (``sticking_fraction``) with a dot.
    Log axes for log-spaced values, a log colour scale for positive values over two decades.
    """
    from matplotlib.colors import LogNorm, Normalize

    if not rows:
        raise PlotError("the table has no rows")
    n = len(columns)
    fig = _figure(min(5.6 * n, 17.0), 4.6)
    axes = fig.subplots(1, n, sharey=True, squeeze=False)[0]
    failed = [r for r in rows if r.get("status", "ok") != "ok"]
    for ax, column in zip(axes, columns, strict=True):
        xs, ys, data = sweep_grid(rows, column, x, y)
        logx, logy = _log_axis(xs), _log_axis(ys)
        xe, ye = _edges(xs, logx), _edges(ys, logy)
        finite = data[np.isfinite(data)]
        positive = finite[finite > 0.0]
        if positive.size and positive.size == finite.size and positive.max() > 100 * positive.min():
            norm = LogNorm(vmin=positive.min(), vmax=positive.max())
        elif finite.size:
            norm = Normalize(vmin=finite.min(), vmax=finite.max())
        else:
            norm = None
        mesh = ax.pcolormesh(xe, ye, data, shading="flat", cmap="magma", norm=norm)
        fig.colorbar(mesh, ax=ax, label=column_label(column))
        annotate = xs.size <= ANNOTATE_MAX and ys.size <= ANNOTATE_MAX
        if annotate:
            for i in range(ys.size):
                for j in range(xs.size):
                    if math.isfinite(data[i, j]):
                        dark = norm is None or norm(data[i, j]) < 0.6
                        ax.text(_centre(xe, j, logx), _centre(ye, i, logy), f"{data[i, j]:.3g}",
                                ha="center", va="center", fontsize=7,
                                color="white" if dark else "black")
        if failed:
            fx = [float(r[x]) for r in failed]
            fy = [float(r[y]) for r in failed]
            ax.scatter(fx, fy, marker="x", s=30, color="tab:gray", label="run failed")
        if "sticking_fraction" in rows[0]:
            _, _, stick = sweep_grid(rows, "sticking_fraction", x, y)
            si, sj = np.nonzero(stick > STICKING)
            if si.size:
                up = 0.8 if annotate else 0.5  # above the value, if it is written
                dots = [ye[i] ** (1 - up) * ye[i + 1] ** up if logy
                        else ye[i] + up * (ye[i + 1] - ye[i]) for i in si]
                ax.scatter([_centre(xe, j, logx) for j in sj], dots, s=6, color="cyan",
                           label=f"sticking > {STICKING:.0%} of the window")
        if logx:
            ax.set_xscale("log")
        if logy:
            ax.set_yscale("log")
        ax.set_xlabel(column_label(x))
        ax.set_title(column, fontsize=10)
    axes[0].set_ylabel(column_label(y))
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower left", fontsize=8, frameon=False)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)


# A load-case result -----------------------------------------------------------------------------
def plot_load_cases(rows: Sequence[Mapping[str, Any]], path: str | Path, title: str = "",
                    share_scale: float | None = None,
                    lifetime: Mapping[float, float] | None = None) -> Any:
    """A load-case result: the share of the lifetime damage per case (left, %) and its 1 Hz DEL
    per case (right, N), one bar per Wöhler exponent; saved to ``path``, returns the figure.

    ``rows`` are the table's rows (:func:`iceimpact.plot_data.load_case_columns` finds the
    columns). Shares are
    fractions (summing to 1 over the cases) unless ``share_scale`` says otherwise (100 for
    percent); by default a column summing to about 100 is taken as percent. ``lifetime``
    ({Wöhler exponent: DEL, N}) draws the lifetime 1 Hz DELs as dashed lines.
    """
    if not rows:
        raise PlotError("the table has no rows")
    cols = load_case_columns(list(rows[0]))
    names = [str(r[cols["case"]]) for r in rows]
    if cols["hours"]:
        unit = "h/yr" if "year" in cols["hours"] else "h"
        names = [f"{n} ({float(r[cols['hours']]):.4g} {unit})"
                 for n, r in zip(names, rows, strict=True)]
    pos = np.arange(len(rows))
    fig = _figure(11, 2.0 + 0.6 * len(rows))
    ax_share, ax_del = fig.subplots(1, 2, sharey=True)
    shares = sorted(cols["shares"].items(), key=lambda kv: (kv[0] is None, kv[0] or 0))
    dels = sorted(cols["dels"].items())
    exponents = sorted({m for m, _ in dels} | {m for m, _ in shares if m is not None})
    color = {m: f"C{i % 10}" for i, m in enumerate(exponents)}

    height = 0.8 / max(len(shares), 1)
    for k, (m, column) in enumerate(shares):
        values = np.array([float(r[column]) for r in rows])
        scale = share_scale
        if scale is None:
            scale = 100.0 if abs(np.nansum(values) - 100.0) < 1.0 else 1.0
        ax_share.barh(pos - 0.4 + height * (k + 0.5), 100.0 * values / scale, height=height,
                      color=color.get(m, "tab:gray"),
                      label="all exponents" if m is None else f"m = {m:g}")
    ax_share.set(xlabel="share of the lifetime damage (%)", title="damage per case")
    ax_share.set_yticks(pos, names)
    ax_share.invert_yaxis()

    height = 0.8 / len(dels)
    for k, (m, column) in enumerate(dels):
        values = np.array([float(r[column]) for r in rows])
        ax_del.barh(pos - 0.4 + height * (k + 0.5), values, height=height, color=color[m],
                    label=f"m = {m:g}")
    for m, value in (lifetime or {}).items():
        if m in color and value is not None and math.isfinite(value):
            ax_del.axvline(value, color=color[m], ls="--", lw=1.0,
                           label="lifetime DEL" if m == dels[0][0] else None)
    positive = [float(r[c]) for r in rows for _, c in dels if float(r[c]) > 0.0]
    if positive and max(positive) > 100 * min(positive):
        ax_del.set_xscale("log")
    ax_del.set(xlabel="1 Hz damage-equivalent load of k x (N)", title="DEL per case")
    handles, labels = ax_del.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(handles), fontsize=8,
               frameon=False, title="Wöhler exponent", title_fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)


# A table file (``iceimpact plot``) --------------------------------------------------------------
def plot_table(table: str | Path, path: str | Path | None = None,
               columns: Sequence[str] = (), x: str | None = None, y: str | None = None,
               at: Mapping[str, float] | None = None) -> tuple[Any, Path, str]:
    """Plot a table file (``iceimpact plot``): a sweep table as maps of ``columns`` over two
    varied parameters (:func:`plot_sweep_map`), a load-case result (a table with a ``case``
    column, ``del_m<m>_1Hz_N`` and damage-share columns) as :func:`plot_load_cases`. ``path``
    defaults to the table's name with ``.png``; an OpenFAST ``.out`` file of ``iceimpact
    simulate`` is drawn as :func:`plot_series`. Returns (figure, path, "sweep", "cases" or
    "run"); PlotError naming what is wrong."""
    table = Path(table)
    path = check_plot_path(table.with_suffix(".png") if path is None else path, "--out")
    require_matplotlib()
    if table.suffix.lower() == ".out":
        if columns or x or y or at:
            raise PlotError(f"--column, --x, --y and --at apply to sweep tables; {table.name} "
                            "is a time series")
        return plot_out(table, path), path, "run"
    summary = season_summary(table)
    if summary is not None:  # PREFIX.json of iceimpact loads, or the PREFIX.csv beside it
        if columns or x or y or at:
            raise PlotError("--column, --x, --y and --at apply to sweep tables; "
                            f"{table.name} is a load-case result")
        rows = season_rows(summary)
        if not rows:
            raise PlotError(f"{table}: the load-case result has no cases")
        dels = lifetime_dels(summary)
        years = (summary.get("lifetime") or {}).get("life_years")
        title = f"{table.stem}: {len(rows)} load cases" + (
            f"; dashed: the lifetime DELs ({years:g} years)" if dels and years else "")
        return plot_load_cases(rows, path, title=title, lifetime=dels), path, "cases"
    rows = read_rows(table)
    if not rows:
        raise PlotError(f"{table}: the table has no rows")
    header = list(rows[0])
    if "run" not in header or "status" not in header:
        try:
            load_case_columns(header)
        except PlotError as exc:
            raise PlotError(f"{table}: neither a sweep table (no 'run' and 'status' columns) "
                            f"nor a load-case result ({str(exc).split(': ', 1)[-1]})") from None
        if columns or x or y or at:
            raise PlotError("--column, --x, --y and --at apply to sweep tables; "
                            f"{table.name} is a load-case result")
        return plot_load_cases(rows, path, title=f"{table.name}: {len(rows)} load cases"), \
            path, "cases"
    at = dict(at or {})
    x, y = sweep_axes(rows, x, y, at)
    measures = measure_columns(header)
    columns = list(columns) or default_columns(rows)
    for c in columns:
        if c not in measures:
            raise PlotError(f"--column {c!r} is not a result column of {table.name}; its result "
                            "columns: " + ", ".join(measures))
    selected = select_rows(rows, at)
    fixed = ", ".join(f"{n} = {float(selected[0][n]):.4g}" for n in at) if selected else ""
    ok = sum(r.get("status") == "ok" for r in selected)
    title = f"{table.name}: {len(selected)} runs ({ok} ok)" + (f", {fixed}" if fixed else "")
    return plot_sweep_map(selected, path, columns, x, y, title=title), path, "sweep"
