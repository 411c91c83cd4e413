"""Lifetime statistics of an ice season: one row per run, and the runs combined over a life.

Each run of a load-case table (:mod:`iceimpact.seasons.cases`) becomes one row
(:func:`run_columns`: its design loads and the Miner sums that pool). The rows are then combined
(SI units throughout; docs/explanation/design-loads.md, "Design over an ice season"):

- per case ``i``, over the cycles of its repetitions pooled (rainflow cycles of ``k x``, with
  the modal structure ``k_c x`` (:func:`iceimpact.studies.loads.spring_stiffness`), counted per
  run by :mod:`iceimpact.studies.loads`; pooling adds their Miner sums ``D = sum n S^m``, N^m,
  and their windows ``T``, s): ``DEL_i = (sum_r D_r / (f_eq sum_r T_r))^(1/m)`` at
  ``f_eq = 1 Hz`` and ``(sum_r D_r / 1e7)^(1/m)`` for 1e7 cycles; extremes with their times;
  impulse statistics; the spread of the runs' DELs over the repetitions;
- over the life: ``DEL_life = (sum_i p_i DEL_i^m)^(1/m)`` at 1 Hz, ``p_i = h_i / sum_j h_j`` the
  case's share of the ice hours, and ``DEL_life (f_eq T_ice / 1e7)^(1/m)`` for 1e7 cycles over the
  life's ice time ``T_ice = life * sum_j h_j * 3600 s``; the case's share of the lifetime damage
  ``p_i DEL_i^m / sum_j p_j DEL_j^m``; the largest extreme and the case it comes from.

Nothing here runs or writes: the functions take rows and return numbers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..studies.loads import (
    F_EQ,
    N_EQ,
    WOHLER_EXPONENTS,
    Loads,
    design_loads,
    load_columns,
    run_loads,
)
from .cases import (
    CASE_COLUMN,
    PERTURBATION_M,
    PERTURBATION_ULPS,
    REPETITION_COLUMN,
    CaseTable,
    check_number,
)

#: Longest service life accepted, years (a guard against a typo, e.g. 2e5 for 25).
MAX_LIFE_YEARS = 1000.0

FORMAT_NAME, FORMAT_VERSION = "iceimpact-season", 1


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

def check_life(life_years: Any) -> float:
    """The service life in years, a finite number in (0, :data:`MAX_LIFE_YEARS`]; a
    :class:`~iceimpact.seasons.cases.SeasonError` naming the value otherwise."""
    return check_number("", "life", life_years, 0.0, MAX_LIFE_YEARS, "service life, years",
                        low_open=True)


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
    life = check_life(life_years)
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
            "signal": "k x, the base shear of the SDOF structure (N); with the modal "
                      "structure k_c x, the quasi-static equivalent load at the contact point",
        },
        "units": SUMMARY_UNITS,
        "lifetime": lifetime,
        "cases": cases,
    }

