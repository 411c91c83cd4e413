"""Design over an ice season: load-case tables and lifetime damage-equivalent loads.

A structural designer checks fatigue over a service life, summed over the ice conditions a site
sees, not one run's DEL. A **load-case table** lists the cases: FMI parameter values, the hours per
year each case lasts, and a number of repetitions (the motion is sensitive to its initial state,
so one run is one sample; repetition ``k`` starts the ice ``k`` steps of :func:`perturbation`
further upstream). The runs go through the sweep engine (:func:`iceimpact.sweep.run_points`:
process pool or dask, resumable, the same limits and refusals), one row per run; the rows are then
combined (SI units throughout; docs/explanation/design-loads.md, "Design over an ice season"):

- per case ``i``, over the cycles of its repetitions pooled (rainflow cycles of ``k x`` counted
  per run by :mod:`iceimpact.studies.loads`; pooling adds their Miner sums ``D = sum n S^m``,
  N^m, and their windows ``T``, s): ``DEL_i = (sum_r D_r / (f_eq sum_r T_r))^(1/m)`` at
  ``f_eq = 1 Hz`` and ``(sum_r D_r / 1e7)^(1/m)`` for 1e7 cycles; extremes with their times;
  impulse statistics; the spread of the runs' DELs over the repetitions;
- over the life: ``DEL_life = (sum_i p_i DEL_i^m)^(1/m)`` at 1 Hz, ``p_i = h_i / sum_j h_j`` the
  case's share of the ice hours, and ``DEL_life (f_eq T_ice / 1e7)^(1/m)`` for 1e7 cycles over the
  life's ice time ``T_ice = life * sum_j h_j * 3600 s``; the case's share of the lifetime damage
  ``p_i DEL_i^m / sum_j p_j DEL_j^m``; the largest extreme and the case it comes from.

Case files are outside data: TOML (``tomllib``) or CSV (``csv``), nothing evaluated; every field
is checked, and an error (:class:`SeasonError`) names the file, the case, the field, the value and
what is allowed, before anything runs.
"""

from __future__ import annotations

import csv
import io
import json
import math
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError, real_number, value_text
from ..runspec import DEFAULT_DT, MAX_SAMPLES, SpecError, Value, apply, check_name, coerce
from ..scene import Scene, flatten_table, load_scene
from ..sweep.errors import SweepError
from ..sweep.table import read_text_file
from .loads import F_EQ, N_EQ, WOHLER_EXPONENTS, Loads, design_loads, load_columns, run_loads

__all__ = [
    "Case", "CaseTable", "SEASON_FIELDS", "SeasonError", "load_cases", "lifetime_del",
    "perturbation", "pooled_del", "run_columns", "run_season", "season_measure", "season_runs",
    "series_row", "summarize_season", "write_summary",
]

#: Hours in a (leap) year: the largest ice time per year a table may give, h.
MAX_HOURS_PER_YEAR = 8784.0

#: Most repetitions of one case (each is a full run).
MAX_REPETITIONS = 1000

#: Longest service life accepted, years (a guard against a typo, e.g. 2e5 for 25).
MAX_LIFE_YEARS = 1000.0

#: Longest case name, characters.
MAX_NAME = 200

#: A case file larger than this is not a load-case table, bytes.
MAX_FILE_BYTES = 16 * 2**20

#: Move of the ice's start per repetition, m: far below any physical scale, but enough to take a
#: sensitive motion onto another trajectory (benchmarks/core_speed.py --spread uses the same).
PERTURBATION_M = 1e-15

#: ...or this many units in the last place of ``ice.z0`` when larger, so that every move changes
#: the float (|ice.z0| above about 0.07 m).
PERTURBATION_ULPS = 64

#: The FMI name moved between repetitions.
PERTURBED = "ice.z0"

#: Columns labelling each run of the table: the case (0-based position in the file) and the
#: repetition (0 = unperturbed).
CASE_COLUMN, REPETITION_COLUMN = "case", "repetition"

FORMAT_NAME, FORMAT_VERSION = "iceimpact-season", 1

_TOP_KEYS = ("t_end", "transient", "dt", "repetitions", "scene", "defaults", "case")
_CASE_KEYS = ("name", "hours", "repetitions")


def _miner_key(m: float) -> str:
    return f"miner_m{m:g}"


#: Columns of :func:`run_columns` besides :data:`iceimpact.studies.loads.LOAD_FIELDS`:
#: name -> (unit, meaning).
SEASON_FIELDS: dict[str, tuple[str, str]] = {
    "t_start_s": ("s", "start of the analysed window (transient, or first sample if later)"),
    "t_end_s": ("s", "end of the analysed window (last sample)"),
    "window_s": ("s", "T = t_end_s - t_start_s, the time the cycles are counted over"),
    "n_impacts": ("1", "impacts in the window"),
    "mean_impulse_ns": ("N.s", "mean impulse per impact (nan if none)"),
    "max_impulse_ns": ("N.s", "largest impulse of an impact (nan if none)"),
    **{_miner_key(m): (f"N^{m:g}", f"Miner sum of k x: sum n S^{m:g} over the rainflow cycles "
                                   "(half cycles weighted as in the DELs)")
       for m in WOHLER_EXPONENTS},
}


class SeasonError(SweepError):
    """A load-case table that cannot be run: the message names the file, the case, the field,
    the value and what is allowed. Raised before anything runs or is written."""


# Perturbed repetitions -------------------------------------------------------------------------
def perturbation(z0: float) -> float:
    """The move of the ice's start between two repetitions, m: :data:`PERTURBATION_M`, or
    :data:`PERTURBATION_ULPS` units in the last place of ``z0`` if larger (every move changes
    the float)."""
    return max(PERTURBATION_M, PERTURBATION_ULPS * math.ulp(z0))


def perturbed_z0(z0: float, repetition: int) -> float:
    """``ice.z0`` of repetition ``k``: moved ``k`` perturbations upstream (away from the
    structure, so ``ice.z0 <= structure.x0`` still holds); repetition 0 is the case as given."""
    return float(z0 - repetition * perturbation(z0)) if repetition else float(z0)


# The case table ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """One load case: its own FMI values (over the table's defaults), hours per year (h) and
    repetitions (runs)."""

    name: str
    hours: float
    repetitions: int = 1
    params: dict[str, Value] = field(default_factory=dict)


@dataclass(frozen=True)
class CaseTable:
    """A checked load-case table: the base scene (with the defaults), the cases and the run
    settings (s)."""

    cases: tuple[Case, ...]
    t_end: float
    transient: float = 0.0
    dt: float = DEFAULT_DT
    base: Scene = field(default_factory=Scene)
    defaults: dict[str, Value] = field(default_factory=dict)
    source: str = "<table>"

    @property
    def hours(self) -> float:
        """Ice hours per year of all cases, h."""
        return float(sum(c.hours for c in self.cases))

    @property
    def n_runs(self) -> int:
        return sum(c.repetitions for c in self.cases)


def _where(path: str, case: int | None, name: str | None = None, line: int | None = None) -> str:
    if case is None:
        return f"{path}: " if line is None else f"{path}: line {line}: "
    label = f"case {case + 1}" + (f" ({name!r})" if name else "")
    return f"{path}: " + (f"line {line}, " if line is not None else "") + f"{label}: "


def _check_number(where: str, key: str, value: Any, low: float, high: float | None,
                  what: str, low_open: bool = False) -> float:
    number = real_number(value)
    if number is not None and math.isfinite(number) and (
            number > low if low_open else number >= low) and (high is None or number <= high):
        return number
    bracket = "(" if low_open else "["
    span = f"{bracket}{low:g}, {high:g}]" if high is not None else f"{bracket}{low:g}, inf)"
    raise SeasonError(f"{where}{key} = {value_text(value)}: expected a finite number in {span} "
                      f"({what})")


def _check_count(where: str, key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_REPETITIONS:
        raise SeasonError(f"{where}{key} = {value_text(value)}: expected an integer in "
                          f"[1, {MAX_REPETITIONS}] (runs of the case)")
    return value


def _check_name(where: str, value: Any, seen: set[str]) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > MAX_NAME or any(
            ord(ch) < 32 for ch in value):
        raise SeasonError(f"{where}name = {value_text(value)}: expected a non-empty text of at "
                          f"most {MAX_NAME} characters, without control characters")
    name = value.strip()
    if name in seen:
        raise SeasonError(f"{where}name = {name!r}: another case has that name; names must be "
                          "unique")
    seen.add(name)
    return name


def _parameter(where: str, name: str, value: Any) -> Value:
    """An FMI-named value: a known name ("did you mean" otherwise) and a finite number."""
    try:
        check_name(name, f"{where}{name}".rstrip())
    except SpecError as exc:
        raise SeasonError(str(exc)) from None
    try:
        return coerce(name, value)
    except SpecError:
        raise SeasonError(f"{where}{name} = {value_text(value)}: expected a finite number "
                          "(the parameter's SI unit)") from None


def _flatten(where: str, table: Mapping[str, Any]) -> dict[str, Any]:
    """``{"drag": {"model": 2}}`` (TOML's ``drag.model = 2``) -> ``{"drag.model": 2}``."""
    return flatten_table(dict(table), lambda name, *_: SeasonError(
        f"{where}{name} is given twice (dotted and as a table)"))


def _read_text(path: Path) -> str:
    return read_text_file(path, MAX_FILE_BYTES, lambda p, problem: SeasonError(f"{p}: {problem}"))


def _settings(path: str, given: Mapping[str, Any]) -> tuple[float, float, float]:
    if given.get("t_end") is None:
        raise SeasonError(f"{path}: t_end is missing: give the simulated time per run, s "
                          "(t_end = 600.0 in the TOML file, or --t-end)")
    t_end = _check_number(f"{path}: ", "t_end", given["t_end"], 0.0, None,
                          "simulated time per run, s", low_open=True)
    transient = _check_number(f"{path}: ", "transient", given.get("transient", 0.0), 0.0, None,
                              "s, the loads use t >= transient")
    if transient >= t_end:
        raise SeasonError(f"{path}: transient = {transient!r}: expected a number in [0, t_end) "
                          f"with t_end = {t_end!r} (s)")
    dt = _check_number(f"{path}: ", "dt", given.get("dt", DEFAULT_DT), 0.0, t_end,
                       "sample step, s", low_open=True)
    if t_end / dt > MAX_SAMPLES:
        raise SeasonError(f"{path}: t_end / dt = {t_end / dt:.3g} samples per run, more than "
                          f"{MAX_SAMPLES:,}; raise dt or lower t_end")
    return t_end, transient, dt


def _build(path: str, raw_cases: Sequence[tuple[int | None, Mapping[str, Any]]],
           defaults: Mapping[str, Any], settings: Mapping[str, Any], base: Scene,
           default_repetitions: Any, max_runs: int) -> CaseTable:
    """Check every field and every case's scene; raw cases are (line or None, fields)."""
    t_end, transient, dt = _settings(path, settings)
    reps_default = _check_count(f"{path}: ", "repetitions", default_repetitions)
    checked_defaults = {name: _parameter(f"{path}: [defaults] ", name, value)
                        for name, value in defaults.items()}
    try:
        scene_base = apply(base, checked_defaults)
    except ParameterError as exc:
        raise SeasonError(f"{path}: [defaults]: {exc}") from None
    if not raw_cases:
        raise SeasonError(f"{path}: no case: a load-case table needs at least one case")
    cases: list[Case] = []
    seen: set[str] = set()
    for i, (line, raw) in enumerate(raw_cases):
        label = raw.get("name") if isinstance(raw.get("name"), str) else None
        where = _where(path, i, label, line)
        if "name" not in raw:
            raise SeasonError(f"{where}name is missing")
        name = _check_name(where, raw["name"], seen)
        where = _where(path, i, name, line)
        if "hours" not in raw:
            raise SeasonError(f"{where}hours is missing (hours per year in this case, h)")
        hours = _check_number(where, "hours", raw["hours"], 0.0, MAX_HOURS_PER_YEAR,
                              "hours per year in this case, h")
        reps = raw.get("repetitions")
        reps = reps_default if reps is None else _check_count(where, "repetitions", reps)
        params = {key: _parameter(where, key, value) for key, value in raw.items()
                  if key not in _CASE_KEYS}
        try:
            apply(scene_base, params)
        except ParameterError as exc:
            raise SeasonError(f"{where}{exc}") from None
        cases.append(Case(name=name, hours=hours, repetitions=reps, params=params))
    total = sum(c.hours for c in cases)
    if not total > 0.0:
        raise SeasonError(f"{path}: the cases' hours add up to 0: at least one case must last "
                          "(hours > 0)")
    if total > MAX_HOURS_PER_YEAR:
        raise SeasonError(f"{path}: the cases' hours add up to {total:g} h per year, more than "
                          f"the {MAX_HOURS_PER_YEAR:g} h of a year")
    n_runs = sum(c.repetitions for c in cases)
    if n_runs > max_runs:
        raise SeasonError(f"{path}: {n_runs:,} runs ({len(cases)} cases with their repetitions), "
                          f"more than the limit of {max_runs:,}; use fewer cases or "
                          "repetitions, or raise the limit with --max-runs (max_runs=)")
    return CaseTable(cases=tuple(cases), t_end=t_end, transient=transient, dt=dt,
                     base=scene_base, defaults=checked_defaults, source=path)


def _toml_cases(path: Path, overrides: Mapping[str, Any], base: Scene | None,
                max_runs: int) -> CaseTable:
    where = f"{path}: "
    text = _read_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SeasonError(f"{path}: not valid TOML ({exc})") from None
    except ValueError as exc:  # an integer of more than 4300 digits
        raise SeasonError(f"{path}: a number Python cannot read ({value_text(str(exc))})") from None
    unknown = [k for k in data if k not in _TOP_KEYS]
    if unknown:
        raise SeasonError(f"{where}unknown key {unknown[0]!r}; the top level holds "
                          f"{', '.join(_TOP_KEYS)} (FMI parameters go under [defaults] or "
                          "into a [[case]])")
    defaults = data.get("defaults", {})
    if not isinstance(defaults, dict):
        raise SeasonError(f"{where}defaults must be a table ([defaults]), got "
                          f"{value_text(defaults)}")
    raw = data.get("case", [])
    if not isinstance(raw, list) or not all(isinstance(c, dict) for c in raw):
        raise SeasonError(f"{where}case must be an array of tables ([[case]] sections)")
    if base is None:
        base = Scene()
        if "scene" in data:
            scene = data["scene"]
            if not isinstance(scene, str):
                raise SeasonError(f"{where}scene = {value_text(scene)}: expected the path of a "
                                  "scene file (TOML), relative to this file")
            scene_path = path.parent / scene
            try:
                base = load_scene(scene_path)
            except FileNotFoundError:
                raise SeasonError(f"{where}scene = {scene!r}: {scene_path} not found") from None
            except (ParameterError, ValueError, OSError) as exc:
                raise SeasonError(f"{where}scene = {scene!r}: {exc}") from None
    settings = {k: data.get(k) for k in ("t_end", "transient", "dt")}
    settings = {k: v for k, v in settings.items() if v is not None}
    settings.update({k: v for k, v in overrides.items() if v is not None})
    cases = []
    for i, case in enumerate(raw):
        label = case.get("name") if isinstance(case.get("name"), str) else None
        cases.append((None, _flatten(_where(str(path), i, label), case)))
    return _build(str(path), cases, _flatten(f"{where}[defaults] ", defaults), settings, base,
                  data.get("repetitions", 1), max_runs)


def _csv_cases(path: Path, overrides: Mapping[str, Any], base: Scene | None,
               max_runs: int) -> CaseTable:
    reader = csv.reader(io.StringIO(_read_text(path)))
    try:
        lines = [(reader.line_num, row) for row in reader]
    except csv.Error as exc:
        raise SeasonError(f"{path}: line {reader.line_num} is not valid CSV ({exc})") from None
    lines = [(n, r) for n, r in lines if r and any(c.strip() for c in r)
             and not r[0].lstrip().startswith("#")]
    if not lines:
        raise SeasonError(f"{path}: empty: expected a header name,hours,repetitions,<FMI names>")
    header_line, header = lines[0]
    header = [h.strip() for h in header]
    for key in ("name", "hours"):
        if key not in header:
            raise SeasonError(f"{path}: line {header_line}: the header has no {key!r} column "
                              "(expected name,hours[,repetitions],<FMI names...>)")
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise SeasonError(f"{path}: line {header_line}: column {dup!r} appears twice")
    cases = []
    for n, row in lines[1:]:
        if len(row) != len(header):
            raise SeasonError(f"{path}: line {n}: {len(row)} fields, the header has "
                              f"{len(header)}")
        fields: dict[str, Any] = {}
        for h, cell in zip(header, row, strict=True):
            text = cell.strip()
            if h == "name":
                fields[h] = cell
            elif h == "repetitions" and text:
                fields[h] = int(text) if text.isdigit() and len(text) < 10 else text
            elif text:  # a number, or the text itself, refused with its case and line
                fields[h] = _cell_number(text)
        cases.append((n, fields))
    settings = {k: v for k, v in overrides.items() if v is not None}
    return _build(str(path), cases, {}, settings, Scene() if base is None else base, 1, max_runs)


def _cell_number(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


def load_cases(path: str | Path, t_end: float | None = None, transient: float | None = None,
               dt: float | None = None, base: Scene | None = None,
               max_runs: int = 100_000) -> CaseTable:
    """Read and check a load-case table, TOML (``.toml``) or CSV (any other suffix).

    TOML: top-level ``t_end``, ``transient``, ``dt`` (s), ``repetitions`` (default per case),
    ``scene`` (a scene file, relative to this one), a ``[defaults]`` table of FMI values and
    ``[[case]]`` tables with ``name``, ``hours`` (per year, h), optional ``repetitions`` and FMI
    values (``"flow.u" = 0.1`` or ``flow.u = 0.1``). CSV: a header ``name,hours[,repetitions],
    <FMI names>``, one case per line, an empty cell for the default; lines starting with ``#``
    are comments; the run settings come from the arguments. ``t_end``, ``transient``, ``dt``
    given here override the file's; ``base`` (default: the file's scene, else the Figure 2
    scene) is the scene the defaults and cases change. Raises :class:`SeasonError`.
    """
    path = Path(path)
    overrides = {"t_end": t_end, "transient": transient, "dt": dt}
    if path.suffix.lower() == ".toml":
        return _toml_cases(path, overrides, base, max_runs)
    return _csv_cases(path, overrides, base, max_runs)


# The runs --------------------------------------------------------------------------------------
def season_runs(table: CaseTable) -> tuple[tuple[str, ...], list[tuple[Value, ...]],
                                           dict[str, list[int]]]:
    """The runs of a table: FMI names (every name any case or default sets, then ``ice.z0``),
    one point per run (cases in order, repetitions within), and the case and repetition labels.
    A name a case does not set has its default (or the base scene's) value."""
    names: list[str] = list(table.defaults)
    for case in table.cases:
        names += [n for n in case.params if n not in names]
    if PERTURBED not in names:
        names.append(PERTURBED)
    base_values = table.base.to_fmi()
    points, case_labels, rep_labels = [], [], []
    for i, case in enumerate(table.cases):
        values = {n: coerce(n, base_values[n]) for n in names}
        values.update(case.params)
        for k in range(case.repetitions):
            z0 = perturbed_z0(float(values[PERTURBED]), k)
            points.append(tuple(z0 if n == PERTURBED else values[n] for n in names))
            case_labels.append(i)
            rep_labels.append(k)
    return tuple(names), points, {CASE_COLUMN: case_labels, REPETITION_COLUMN: rep_labels}


def run_columns(loads: Loads) -> dict[str, float | int]:
    """One row of the season table from a run's loads: the columns of
    :func:`iceimpact.studies.loads.load_columns` and :data:`SEASON_FIELDS` (the Miner sums
    ``sum n S^m`` that pooling adds up, N^m)."""
    out: dict[str, float | int] = {
        "t_start_s": loads.t_start, "t_end_s": loads.t_end, "window_s": loads.duration,
        "n_impacts": -1 if loads.n_impacts is None else int(loads.n_impacts),  # -1: unknown
        "mean_impulse_ns": loads.impulse_mean, "max_impulse_ns": loads.impulse_max,
    }
    out.update(load_columns(loads))
    cycles = loads.cycles
    finite = math.isfinite(loads.kx_mean)  # no k, or a diverged run: no cycles to count
    s_max = float(np.max(cycles.ranges)) if cycles.ranges.size else 0.0
    for m in WOHLER_EXPONENTS:
        if not finite:
            out[_miner_key(m)] = math.nan
        elif s_max == 0.0:
            out[_miner_key(m)] = 0.0
        else:  # scaled by the largest range: no overflow inside the sum
            out[_miner_key(m)] = s_max ** m * float(np.sum(cycles.counts
                                                           * (cycles.ranges / s_max) ** m))
    return out


def season_measure(result: Any, transient: float) -> dict[str, float | int]:
    """The sweep measure of a season run (module level: picklable for the workers)."""
    return run_columns(run_loads(result, transient))


def series_row(t: Any, x: Any, k: float, transient: float = 0.0, **options: Any
               ) -> dict[str, float | int]:
    """:func:`run_columns` of sampled ``t`` (s), ``x`` (m) of a structure of stiffness ``k``
    (N/m): a row for :func:`summarize_season` from a time series instead of a run (tests,
    other simulators); ``options`` go to :func:`iceimpact.studies.loads.design_loads`
    (``impacts``, ``impulse``, ``half``)."""
    return run_columns(design_loads(t, x, k, transient=transient, **options))


# The combination ---------------------------------------------------------------------------------
def pooled_del(miner_sums: Sequence[float], m: float, n_eq: float) -> float:
    """``(sum_r D_r / n_eq)^(1/m)``: the DEL (N) of the pooled cycles of runs whose Miner sums
    ``D_r = sum n S^m`` (N^m) are given; ``n_eq = f_eq sum_r T_r`` for the 1 Hz DEL. nan if a
    sum is nan or ``n_eq`` is not a positive finite number."""
    total = float(np.sum(miner_sums)) if len(miner_sums) else 0.0
    if not (math.isfinite(n_eq) and n_eq > 0.0) or math.isnan(total):
        return math.nan
    return (total / n_eq) ** (1.0 / m)


def lifetime_del(dels: Sequence[float], weights: Sequence[float], m: float) -> float:
    """``(sum_i p_i DEL_i^m)^(1/m)`` with ``p_i = w_i / sum w`` (N): the 1 Hz DEL of the life
    from the cases' 1 Hz DELs and hours. A case of zero weight contributes nothing (even a nan
    DEL); nan if a weighted case's DEL is nan."""
    d = np.asarray(dels, dtype=float)
    w = np.asarray(weights, dtype=float)
    keep = w > 0.0
    if not np.any(keep):
        return math.nan
    d, p = d[keep], w[keep] / np.sum(w[keep])
    if np.any(np.isnan(d)):
        return math.nan
    top = float(np.max(d))
    if top == 0.0:
        return 0.0
    return top * float(np.sum(p * (d / top) ** m)) ** (1.0 / m)  # scaled: no overflow


def _spread(values: Sequence[float]) -> dict[str, float]:
    v = np.asarray([x for x in values if not math.isnan(x)], dtype=float)
    if v.size == 0:
        return dict.fromkeys(("min", "max", "mean", "std"), math.nan)
    return {"min": float(v.min()), "max": float(v.max()), "mean": float(v.mean()),
            "std": float(v.std(ddof=1)) if v.size > 1 else 0.0}


def _extreme(rows: Sequence[Mapping[str, Any]], key: str, biggest: bool
             ) -> tuple[float, Mapping[str, Any] | None]:
    best, where = math.nan, None
    for r in rows:
        v = r[key]
        if not math.isnan(v) and (where is None or (v > best if biggest else v < best)):
            best, where = v, r
    return best, where


#: Units of the summary's entries, by key or key suffix (PREFIX.json's "units").
SUMMARY_UNITS = {
    "*_N": "N", "*_s": "s", "*_ns": "N.s", "*_hz": "Hz", "hours_per_year": "h per year",
    "ice_hours": "h", "ice_hours_per_year": "h per year", "life_years": "years",
    "share_of_hours": "1", "damage_share": "1 (of the lifetime damage, per Woehler exponent)",
    "cycles": "1 (rainflow cycles, half cycles weighted 0.5)",
    "del_1Hz_N, del_1e7_N, del_1Hz_spread_N": "N, per Woehler exponent m (the keys)",
}


def summarize_season(table: CaseTable, rows: Sequence[Mapping[str, Any]],
                     life_years: float) -> dict[str, Any]:
    """The season summary (JSON-able; units in the key suffixes and ``units``) from the rows of
    its runs (``case``, ``repetition``, ``status`` and the :func:`run_columns`), as written to
    PREFIX.json. Failed runs are left out of their case and listed; a case with hours > 0 and
    no successful run makes the lifetime values nan (``complete`` false)."""
    life = _check_number("", "life", life_years, 0.0, MAX_LIFE_YEARS, "service life, years",
                         low_open=True)
    ms = WOHLER_EXPONENTS
    total_hours = table.hours
    by_case: list[list[Mapping[str, Any]]] = [[] for _ in table.cases]
    failed: list[list[Mapping[str, Any]]] = [[] for _ in table.cases]
    for r in rows:
        (by_case if r["status"] == "ok" else failed)[int(r[CASE_COLUMN])].append(r)
    cases, del_1hz = [], {m: [] for m in ms}
    for i, case in enumerate(table.cases):
        ok = sorted(by_case[i], key=lambda r: r[REPETITION_COLUMN])
        window = float(sum(r["window_s"] for r in ok))
        entry: dict[str, Any] = {
            "name": case.name, "hours_per_year": case.hours,
            "share_of_hours": case.hours / total_hours, "repetitions": case.repetitions,
            "runs_ok": len(ok),
            "failed": [{"run": r.get("run"), "repetition": r[REPETITION_COLUMN],
                        "status": r["status"]} for r in failed[i]],
            "parameters": {**table.defaults, **case.params},
            "window_s": window, "cycles": float(sum(r["kx_cycles"] for r in ok)),
            "del_1Hz_N": {}, "del_1e7_N": {}, "del_1Hz_spread_N": {},
        }
        for m in ms:
            sums = [r[_miner_key(m)] for r in ok]
            d1 = pooled_del(sums, m, F_EQ * window) if ok else math.nan
            entry["del_1Hz_N"][f"{m:g}"] = d1
            entry["del_1e7_N"][f"{m:g}"] = pooled_del(sums, m, N_EQ) if ok else math.nan
            entry["del_1Hz_spread_N"][f"{m:g}"] = _spread([r[f"del_m{m:g}_1Hz_N"] for r in ok])
            del_1hz[m].append(d1)
        for key, biggest in (("kx_max", True), ("kx_min", False)):
            value, r = _extreme(ok, f"{key}_N", biggest)
            entry[f"{key}_N"] = value
            entry[f"{key}_t_s"] = math.nan if r is None else r[f"{key}_t_s"]
            entry[f"{key}_repetition"] = None if r is None else r[REPETITION_COLUMN]
        entry["kx_max_spread_N"] = _spread([r["kx_max_N"] for r in ok])
        counts = [r["n_impacts"] for r in ok if r["n_impacts"] >= 0]
        n = int(sum(counts))
        weighted = [r["n_impacts"] * r["mean_impulse_ns"] for r in ok if r["n_impacts"] > 0]
        entry["impacts"] = {
            "count": n, "rate_hz": n / window if window > 0 else math.nan,
            "mean_impulse_ns": float(sum(weighted)) / n if n else math.nan,
            "max_impulse_ns": _extreme(ok, "max_impulse_ns", True)[0],
            "p99_impulse_ns": _extreme(ok, "p99_impulse_ns", True)[0],
        }
        cases.append(entry)

    hours = [c.hours for c in table.cases]
    lasting = [i for i, c in enumerate(table.cases) if c.hours > 0.0]
    complete = all(not failed[i] for i in lasting)
    ice_s = life * total_hours * 3600.0
    lifetime: dict[str, Any] = {
        "life_years": life, "ice_hours_per_year": total_hours, "ice_hours": life * total_hours,
        "complete": complete, "del_1Hz_N": {}, "del_1e7_N": {},
    }
    for m in ms:
        d_life = lifetime_del(del_1hz[m], hours, m)
        lifetime["del_1Hz_N"][f"{m:g}"] = d_life
        lifetime["del_1e7_N"][f"{m:g}"] = d_life * (F_EQ * ice_s / N_EQ) ** (1.0 / m)
        weighted = [case.hours / total_hours * (d / d_life) ** m if case.hours > 0.0 else 0.0
                    for case, d in zip(table.cases, del_1hz[m], strict=True)] \
            if d_life > 0.0 else [math.nan if c.hours > 0.0 else 0.0 for c in table.cases]
        for entry, share in zip(cases, weighted, strict=True):
            entry.setdefault("damage_share", {})[f"{m:g}"] = share
    for key, biggest in (("kx_max", True), ("kx_min", False)):
        best, where = math.nan, None
        for i in lasting:
            v = cases[i][f"{key}_N"]
            if not math.isnan(v) and (where is None or (v > best if biggest else v < best)):
                best, where = v, i
        lifetime[f"{key}_N"] = best
        lifetime[f"{key}_case"] = None if where is None else table.cases[where].name
        lifetime[f"{key}_t_s"] = math.nan if where is None else cases[where][f"{key}_t_s"]
        lifetime[f"{key}_repetition"] = None if where is None else \
            cases[where][f"{key}_repetition"]
    return {
        "format": FORMAT_NAME, "format_version": FORMAT_VERSION,
        "settings": {
            "cases_file": table.source, "t_end_s": table.t_end, "transient_s": table.transient,
            "dt_s": table.dt, "f_eq_hz": F_EQ, "n_eq": N_EQ, "exponents": list(ms),
            "perturbation": f"repetition k starts the ice at ice.z0 - k * max({PERTURBATION_M:g}"
                            f" m, {PERTURBATION_ULPS} ulp(ice.z0))",
            "signal": "k x, the base shear of the SDOF structure (N)",
        },
        "units": SUMMARY_UNITS,
        "lifetime": lifetime,
        "cases": cases,
    }


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
    from ..sweep.table import write_atomic

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
    from ..sweep import run_points

    _check_number("", "life", life_years, 0.0, MAX_LIFE_YEARS, "service life, years",
                  low_open=True)
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
