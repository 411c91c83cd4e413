"""Load-case tables: reading and checking a table of ice conditions, and the runs it asks for.

A **load-case table** lists the cases of a site's ice season: FMI parameter values, the hours per
year each case lasts, and a number of repetitions (the motion is sensitive to its initial state,
so one run is one sample; repetition ``k`` starts the ice ``k`` steps of :func:`perturbation`
further upstream). :func:`load_cases` reads one and :func:`season_runs` lists its runs (FMI
names and values, with the case and repetition of each); :mod:`iceimpact.seasons.lifetime`
combines their loads and :func:`iceimpact.seasons.run_season` runs them.

Case files are outside data: TOML (``tomllib``) or CSV (``csv``), nothing evaluated; every field
is checked, and an error (:class:`SeasonError`) names the file, the case, the field, the value and
what is allowed, before anything runs.
"""

from __future__ import annotations

import csv
import io
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ParameterError, real_number, value_text
from ..runspec import DEFAULT_DT, MAX_SAMPLES, SpecError, Value, apply, check_name, coerce
from ..scene import Scene, flatten_table, load_scene
from ..sweep.errors import SweepError
from ..sweep.table import read_text_file

#: Hours in a (leap) year: the largest ice time per year a table may give, h.
MAX_HOURS_PER_YEAR = 8784.0

#: Most repetitions of one case (each is a full run).
MAX_REPETITIONS = 1000


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

_TOP_KEYS = ("t_end", "transient", "dt", "repetitions", "scene", "defaults", "case")
_CASE_KEYS = ("name", "hours", "repetitions")


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


def check_number(where: str, key: str, value: Any, low: float, high: float | None,
                 what: str, low_open: bool = False) -> float:
    """``value`` as a float if it is a finite real number in ``[low, high]`` (``(low, high]``
    with ``low_open``; no upper bound for ``high=None``); else a :class:`SeasonError` starting
    with ``where`` and naming ``key``, the value, the interval and ``what`` it is."""
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
    t_end = check_number(f"{path}: ", "t_end", given["t_end"], 0.0, None,
                         "simulated time per run, s", low_open=True)
    transient = check_number(f"{path}: ", "transient", given.get("transient", 0.0), 0.0, None,
                             "s, the loads use t >= transient")
    if transient >= t_end:
        raise SeasonError(f"{path}: transient = {transient!r}: expected a number in [0, t_end) "
                          f"with t_end = {t_end!r} (s)")
    dt = check_number(f"{path}: ", "dt", given.get("dt", DEFAULT_DT), 0.0, t_end,
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
        hours = check_number(where, "hours", raw["hours"], 0.0, MAX_HOURS_PER_YEAR,
                             "hours per year in this case, h")
        reps = raw.get("repetitions")
        reps = reps_default if reps is None else _check_count(where, "repetitions", reps)
        params = {key: _parameter(where, key, value) for key, value in raw.items()
                  if key not in _CASE_KEYS}
        try:
            apply(scene_base, params)  # the case's scene, checked before anything runs
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

