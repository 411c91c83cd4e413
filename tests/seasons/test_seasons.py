"""Load-case tables and lifetime DELs: parsing and refusals, closed forms, pCrunch, the runs."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from iceimpact import Scene, run
from iceimpact.seasons import (
    PERTURBATION_M,
    Case,
    CaseTable,
    SeasonError,
    lifetime_del,
    load_cases,
    perturbation,
    perturbed_z0,
    pooled_del,
    run_season,
    season_runs,
    series_row,
    summarize_season,
)
from iceimpact.studies.loads import WOHLER_EXPONENTS
from iceimpact.sweep import read_table

TOML = """\
t_end = 6.0            # s
transient = 1.0
dt = 0.01
repetitions = 2
[defaults]
"drag.model" = 2
[[case]]
name = "slow drift"
hours = 300.0
repetitions = 3
"flow.u" = 0.1
"ice.M" = 1600.0
[[case]]
name = "fast floe"
hours = 100.0
flow.u = 0.5           # dotted keys are FMI names too
impact.e = 0.8
"""

CSV = """\
# the TOML table above, as a spreadsheet would write it
name,hours,repetitions,drag.model,flow.u,ice.M,impact.e
slow drift,300,3,2,0.1,1600,
fast floe,100,,2,0.5,,0.8
"""


def write(tmp_path: Path, text: str, name: str = "cases.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def cosine(amplitude: float, f: float, periods: int, fs: float = 64.0):
    """A cosine of ``periods`` whole periods from peak to peak: its rainflow ranges are all
    ``2 amplitude`` (N), ``periods`` cycles, so its 1 Hz DEL is ``2 A f^(1/m)``."""
    t = np.arange(int(periods * fs) + 1) / (fs * f)
    return t, amplitude * np.cos(2 * np.pi * f * t)


def rows_of(series: list[list[tuple[np.ndarray, np.ndarray]]], **options) -> list[dict]:
    """Rows as the runs give them, from time series of k x (k = 1 N/m): series[case][rep]."""
    return [{"run": None, "case": i, "repetition": r, "status": "ok",
             **series_row(t, y, 1.0, **options)}
            for i, reps in enumerate(series) for r, (t, y) in enumerate(reps)]


def table_of(hours: list[float], reps: list[int] | None = None) -> CaseTable:
    reps = reps or [1] * len(hours)
    return CaseTable(cases=tuple(Case(f"c{i}", h, n) for i, (h, n)
                                 in enumerate(zip(hours, reps, strict=True))), t_end=1.0)


# Parsing ----------------------------------------------------------------------------------------
def test_toml_and_csv_tables_are_the_same(tmp_path):
    toml = load_cases(write(tmp_path, TOML))
    table = load_cases(write(tmp_path, CSV, "cases.csv"), t_end=6.0, transient=1.0, dt=0.01)
    assert [c.name for c in toml.cases] == ["slow drift", "fast floe"]
    assert toml.cases[0].params == {"flow.u": 0.1, "ice.M": 1600.0}
    assert toml.cases[1].params == {"flow.u": 0.5, "impact.e": 0.8}
    assert [c.repetitions for c in toml.cases] == [3, 2]   # the top-level default for "fast"
    assert toml.base.drag_model == 2 and toml.hours == 400.0 and toml.n_runs == 5
    assert (toml.t_end, toml.transient, toml.dt) == (6.0, 1.0, 0.01)
    # CSV: no top-level default repetitions (1), drag.model given per case
    assert [c.repetitions for c in table.cases] == [3, 1]
    assert table.cases[0].params == {"drag.model": 2, "flow.u": 0.1, "ice.M": 1600.0}
    names, points, labels = season_runs(toml)
    assert names == ("drag.model", "flow.u", "ice.M", "impact.e", "ice.z0")
    assert labels == {"case": [0, 0, 0, 1, 1], "repetition": [0, 1, 2, 0, 1]}
    assert points[3][:4] == (2, 0.5, 1600.0, 0.8)  # ice.M from the base scene


def test_repetitions_move_the_ice_start_deterministically():
    z0 = Scene().ice_z0
    assert perturbed_z0(z0, 0) == z0
    moves = [z0 - perturbed_z0(z0, k) for k in range(4)]
    assert moves[1] == pytest.approx(PERTURBATION_M, rel=1e-2) and moves == sorted(moves)
    assert len({perturbed_z0(z0, k) for k in range(100)}) == 100
    # far from the structure the move is 64 units in the last place, so that it is not lost
    assert perturbation(-1000.0) == 64 * math.ulp(1000.0)
    assert perturbed_z0(-1000.0, 1) < -1000.0


@pytest.mark.parametrize("text, message", [
    ("t_end = 6.0\n[[case]]\nhours = 1.0\n", "case 1: name is missing"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\n", r"case 1 \('a'\): hours is missing"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = -1.0\n",
     r"case 1 \('a'\): hours = -1.0: expected a finite number in \[0, 8784\] \(hours per year"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 9000\n", r"hours = 9000: expected"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = '5'\n", r"hours = '5': expected a finite"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = nan\n", r"hours = nan: expected"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = 0\n",
     r"repetitions = 0: expected an integer in \[1, 1000\]"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = 2.5\n",
     r"repetitions = 2.5: expected an integer"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = true\n",
     r"repetitions = True: expected an integer"),
    ("t_end = 6.0\n[[case]]\nname = ''\nhours = 1.0\n", "name = '': expected a non-empty"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n[[case]]\nname = 'a'\nhours = 2.0\n",
     r"case 2 \('a'\): name = 'a': another case has that name"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'ice.mass' = 2.0\n",
     r"case 1 \('a'\): ice.mass: unknown parameter 'ice.mass' \(did you mean 'ice.M'"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'flow.u' = 'fast'\n",
     r"case 1 \('a'\): flow.u = 'fast': expected a finite number"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'impact.e' = 1.5\n",
     r"case 1 \('a'\): impact.e = 1.5 is not allowed: 0 <= e <= 1"),
    ("t_end = 6.0\n[defaults]\n'ice.M' = -3.0\n[[case]]\nname = 'a'\nhours = 1.0\n",
     r"\[defaults\]: ice.M = -3.0 is not allowed"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'flow.u' = 0.1\nflow.u = 0.2\n",
     "flow.u is given twice|not valid TOML"),
    ("t_end = 6.0\nlife = 25\n[[case]]\nname = 'a'\nhours = 1.0\n",
     "unknown key 'life'; the top level holds t_end"),
    ("[[case]]\nname = 'a'\nhours = 1.0\n", "t_end is missing"),
    ("t_end = -1.0\n[[case]]\nname = 'a'\nhours = 1.0\n",
     r"t_end = -1.0: expected a finite number in \(0, inf\)"),
    ("t_end = 6.0\ntransient = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n",
     r"transient = 6.0: expected a number in \[0, t_end\)"),
    ("t_end = 6.0\ndt = 7.0\n[[case]]\nname = 'a'\nhours = 1.0\n", r"dt = 7.0: expected"),
    ("t_end = 1e9\ndt = 1e-3\n[[case]]\nname = 'a'\nhours = 1.0\n", "samples per run"),
    ("t_end = 6.0\n", "no case"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 0.0\n", "hours add up to 0"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 8000.0\n"
     "[[case]]\nname = 'b'\nhours = 800.0\n", "add up to 8800 h per year, more than the 8784 h"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = 1000\n"
     "[[case]]\nname = 'b'\nhours = 1.0\nrepetitions = 1000\n",
     "2,000 runs .* more than the limit"),
    ("t_end = 6.0\n[[case]\n", "not valid TOML"),
    ("t_end = 6.0\nscene = 'missing.toml'\n[[case]]\nname = 'a'\nhours = 1.0\n",
     "scene = 'missing.toml': .* not found"),
])
def test_bad_toml_tables_are_refused_naming_file_case_field_and_value(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(SeasonError, match=message) as info:
        load_cases(path, max_runs=1500)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("text, message", [
    ("name,hours\na,1\nb\n", "line 3: 1 fields, the header has 2"),
    ("name,flow.u\na,1\n", "the header has no 'hours' column"),
    ("name,hours,hours\na,1,2\n", "column 'hours' appears twice"),
    ("name,hours\na,many\n", r"line 2, case 1 \('a'\): hours = 'many': expected"),
    ("name,hours,flow.u\na,1,0.1\nb,1,fast\n", r"line 3, case 2 \('b'\): flow.u = 'fast'"),
    ("name,hours,repetitions\na,1,-2\n", "repetitions = '-2': expected an integer"),
    ("name,hours\n,1\n", "line 2, case 1: name = '': expected a non-empty"),
    ("# nothing\n", "empty"),
])
def test_bad_csv_tables_are_refused_naming_the_line(tmp_path, text, message):
    path = write(tmp_path, text, "cases.csv")
    with pytest.raises(SeasonError, match=message):
        load_cases(path, t_end=6.0)


def test_unreadable_files_are_refused(tmp_path):
    with pytest.raises(SeasonError, match="no such file"):
        load_cases(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b"t_end = 6.0\n# \xff\n")
    with pytest.raises(SeasonError, match="not UTF-8"):
        load_cases(bad)
    with pytest.raises(SeasonError, match="t_end is missing"):
        load_cases(write(tmp_path, "name,hours\na,1\n", "c.csv"))  # CSV: t_end from the caller


# Closed forms -----------------------------------------------------------------------------------
@pytest.mark.parametrize("m", WOHLER_EXPONENTS)
def test_two_sine_cases_combine_to_the_hand_formula(m):
    (a1, f1, h1), (a2, f2, h2) = (100.0, 0.5, 300.0), (40.0, 2.0, 100.0)
    rows = rows_of([[cosine(a1, f1, 20)], [cosine(a2, f2, 30)]])
    life = 25.0
    s = summarize_season(table_of([h1, h2]), rows, life)
    d1, d2 = 2 * a1 * f1 ** (1 / m), 2 * a2 * f2 ** (1 / m)  # each case's 1 Hz DEL, N
    assert s["cases"][0]["del_1Hz_N"][f"{m}"] == pytest.approx(d1, rel=1e-12)
    assert s["cases"][1]["del_1Hz_N"][f"{m}"] == pytest.approx(d2, rel=1e-12)
    p1, p2 = h1 / (h1 + h2), h2 / (h1 + h2)
    by_hand = (p1 * d1 ** m + p2 * d2 ** m) ** (1 / m)
    assert s["lifetime"]["del_1Hz_N"][f"{m}"] == pytest.approx(by_hand, rel=1e-12)
    # 1e7 cycles over the life's ice time: the damage of every hour of ice, by hand
    ice_s = life * (h1 + h2) * 3600.0
    damage = ice_s * (p1 * f1 * (2 * a1) ** m + p2 * f2 * (2 * a2) ** m)
    assert s["lifetime"]["del_1e7_N"][f"{m}"] == pytest.approx((damage / 1e7) ** (1 / m),
                                                               rel=1e-12)
    shares = [c["damage_share"][f"{m}"] for c in s["cases"]]
    assert shares == pytest.approx([p1 * d1 ** m / by_hand ** m, p2 * d2 ** m / by_hand ** m])
    assert sum(shares) == pytest.approx(1.0, rel=1e-12)
    # per case, 1e7 cycles over its pooled simulated cycles: 20 cycles of 2 a1
    assert s["cases"][0]["del_1e7_N"][f"{m}"] == pytest.approx((20 * (2 * a1) ** m / 1e7)
                                                               ** (1 / m), rel=1e-12)
    assert s["lifetime"]["kx_max_N"] == a1 and s["lifetime"]["kx_max_case"] == "c0"


def test_splitting_a_case_into_two_halves_of_its_hours_changes_nothing():
    series = [[cosine(100.0, 0.5, 20)], [cosine(40.0, 2.0, 30), cosine(35.0, 2.0, 30)]]
    whole = summarize_season(table_of([300.0, 100.0], [1, 2]), rows_of(series), 25.0)
    split = summarize_season(table_of([150.0, 150.0, 100.0], [1, 1, 2]),
                             rows_of([series[0], series[0], series[1]]), 25.0)
    for key in ("del_1Hz_N", "del_1e7_N"):
        assert split["lifetime"][key] == pytest.approx(whole["lifetime"][key], rel=1e-13)
    shares = [c["damage_share"]["4"] for c in split["cases"]]
    assert shares[0] + shares[1] == pytest.approx(whole["cases"][0]["damage_share"]["4"])


def test_a_case_of_zero_hours_contributes_nothing():
    series = [[cosine(100.0, 0.5, 20)], [cosine(40.0, 2.0, 30)]]
    base = summarize_season(table_of([300.0, 100.0]), rows_of(series), 25.0)
    huge = [*series, [cosine(1e4, 5.0, 50)]]
    rows = rows_of(huge)
    with_zero = summarize_season(table_of([300.0, 100.0, 0.0]), rows, 25.0)
    assert with_zero["lifetime"]["del_1Hz_N"] == base["lifetime"]["del_1Hz_N"]
    assert with_zero["lifetime"]["del_1e7_N"] == base["lifetime"]["del_1e7_N"]
    assert with_zero["lifetime"]["kx_max_case"] == "c0"   # not the huge case: it never occurs
    assert with_zero["cases"][2]["damage_share"] == dict.fromkeys(["3", "4", "5", "10"], 0.0)
    # even a failed case of zero hours changes nothing
    rows[-1] = {**rows[-1], "status": "SolverError: boom"}
    failed = summarize_season(table_of([300.0, 100.0, 0.0]), rows, 25.0)
    assert failed["lifetime"]["del_1Hz_N"] == base["lifetime"]["del_1Hz_N"]
    assert failed["lifetime"]["complete"] and failed["cases"][2]["runs_ok"] == 0


def test_repetitions_pool_their_cycles():
    (t1, y1), (t2, y2) = cosine(100.0, 0.5, 20), cosine(60.0, 0.5, 40)
    s = summarize_season(table_of([10.0], [2]), rows_of([[(t1, y1), (t2, y2)]]), 1.0)
    for m in WOHLER_EXPONENTS:
        pooled = ((20 * 200.0 ** m + 40 * 120.0 ** m) / (t1[-1] + t2[-1])) ** (1 / m)
        assert s["cases"][0]["del_1Hz_N"][f"{m}"] == pytest.approx(pooled, rel=1e-12)
        spread = s["cases"][0]["del_1Hz_spread_N"][f"{m}"]
        assert spread["min"] < s["cases"][0]["del_1Hz_N"][f"{m}"] < spread["max"]
    assert s["cases"][0]["kx_max_N"] == 100.0 and s["cases"][0]["kx_max_repetition"] == 0
    assert s["cases"][0]["window_s"] == t1[-1] + t2[-1] and s["cases"][0]["cycles"] == 60.0


def test_a_failed_run_of_a_lasting_case_makes_the_lifetime_incomplete():
    series = [[cosine(100.0, 0.5, 20)], [cosine(40.0, 2.0, 30)]]
    rows = rows_of(series)
    rows[1] = {**rows[1], "status": "SolverError: boom"}
    s = summarize_season(table_of([300.0, 100.0]), rows, 25.0)
    assert not s["lifetime"]["complete"] and math.isnan(s["lifetime"]["del_1Hz_N"]["4"])
    assert s["cases"][1]["failed"][0]["status"] == "SolverError: boom"


def test_combination_helpers():
    assert pooled_del([8.0, 19.0], 3, 1.0) == pytest.approx(3.0)
    assert math.isnan(pooled_del([1.0], 3, 0.0)) and math.isnan(pooled_del([math.nan], 3, 1.0))
    assert lifetime_del([2.0, 1e300], [1.0, 0.0], 10) == 2.0
    assert lifetime_del([1e30, 1e30], [1.0, 3.0], 10) == pytest.approx(1e30)  # no overflow
    with pytest.raises(SeasonError, match="life = 0: expected"):
        summarize_season(table_of([1.0]), rows_of([[cosine(1.0, 1.0, 2)]]), 0)


# pCrunch ----------------------------------------------------------------------------------------
def pcrunch_totals(series: list[tuple[np.ndarray, np.ndarray]], prob: list[float], m: float,
                   life: float, bins: int = 100):
    """pCrunch's per-run 1 Hz DELs and Miner sums, and its lifetime (DEL, damage) totals."""
    pcrunch = pytest.importorskip("pCrunch")
    outputs = [pcrunch.AeroelasticOutput({"Time": t, "kx": y}) for t, y in series]
    crunch = pcrunch.Crunch(outputs, probability=np.array(prob),
                            fatigue_channels={"kx": pcrunch.FatigueParams(slope=m)})
    crunch.process_outputs(rainflow_bins=bins)
    dels, damage = crunch.compute_total_fatigue(lifetime=life)
    return (np.asarray(crunch.dels["kx"], dtype=float),
            np.asarray(crunch.damage["kx"], dtype=float),
            float(dels["kx"]["Weighted"]), float(damage["kx"]["Weighted"]))


@pytest.mark.parametrize("m", WOHLER_EXPONENTS)
def test_lifetime_damage_agrees_with_pcrunch_where_the_conventions_agree(m):
    # cosines over whole periods (no leftover half cycles to count differently), equal run
    # lengths (pCrunch divides the weighted damage by the weighted duration) and hours adding
    # up to pCrunch's year of 365 days
    series = [cosine(100.0, 0.5, 20), cosine(40.0, 2.0, 80)]
    hours, life = [6570.0, 2190.0], 25.0
    p = [h / sum(hours) for h in hours]
    run_dels, run_damage, _, damage = pcrunch_totals(series, p, m, life, bins=1000)
    s = summarize_season(table_of(hours), rows_of([[x] for x in series]), life)
    ours = [c["del_1Hz_N"][f"{m}"] for c in s["cases"]]
    assert run_dels == pytest.approx(ours, rel=1e-4)                # binning only
    ours_damage = s["lifetime"]["del_1e7_N"][f"{m}"] ** m * 1e7       # N^m over the life
    assert damage == pytest.approx(ours_damage, rel=1e-4)
    # the combination alone is the same to rounding: ours on pCrunch's own per-run sums
    windows = [t[-1] - t[0] for t, _ in series]
    rates = [lifetime_del([(d / w) ** (1 / m)], [1.0], m) ** m for d, w in
             zip(run_damage, windows, strict=True)]
    life_rate = lifetime_del([r ** (1 / m) for r in rates], hours, m) ** m
    assert life_rate * life * sum(hours) * 3600.0 == pytest.approx(damage, rel=1e-12)


def test_pcrunch_differs_on_simulated_runs_by_its_counting_conventions():
    # where they differ: pCrunch (fatpack) discretises the signal, closes the residue into full
    # cycles and bins the ranges into 100 bins; its "Weighted" DEL is sum p_i DEL_i, an
    # arithmetic mean that is not damage-equivalent (it lies below (sum p_i DEL_i^m)^(1/m))
    series = []
    for scene in (Scene(drag_model=2, flow_u=0.1), Scene(drag_model=2, flow_u=0.5,
                                                        impact_e=0.8)):
        result = run(scene, 40.0, dt=2e-3)
        keep = result.t >= 10.0
        series.append((result.t[keep], scene.structure_k * result.x[keep]))
    hours, life = [6570.0, 2190.0], 25.0
    s = summarize_season(table_of(hours), rows_of([[x] for x in series]), life)
    for m in WOHLER_EXPONENTS:
        run_dels, _, weighted, damage = pcrunch_totals(series, [0.75, 0.25], m, life)
        ours = np.array([c["del_1Hz_N"][f"{m}"] for c in s["cases"]])
        assert np.all(np.abs(run_dels / ours - 1.0) < 0.06), (m, run_dels / ours - 1.0)
        ours_damage = s["lifetime"]["del_1e7_N"][f"{m}"] ** m * 1e7
        assert abs((damage / ours_damage) ** (1 / m) - 1.0) < 0.06
        assert weighted < s["lifetime"]["del_1Hz_N"][f"{m}"]


# The runs ---------------------------------------------------------------------------------------
def test_season_runs_resume_and_match_serial(tmp_path):
    table = load_cases(write(tmp_path, TOML))
    serial, summary = run_season(table, 25.0, workers=1, progress=False)
    out = tmp_path / "season"
    rows, summary2 = run_season(table, 25.0, out=out, workers=2, progress=False)
    strip = [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]
    assert json.dumps(strip) == json.dumps([{k: v for k, v in r.items() if k != "wall_s"}
                                            for r in serial])  # nan-aware
    assert summary2["lifetime"] == summary["lifetime"]
    assert [r["case"] for r in rows] == [0, 0, 0, 1, 1]
    assert [r["ice.z0"] for r in rows[:3]] == [perturbed_z0(-0.01, k) for k in range(3)]
    # the saved table: one row per run; the summary is plain JSON with units
    assert len(read_table(f"{out}.csv")) == 5
    saved = json.loads(Path(f"{out}.json").read_text())
    assert saved["lifetime"]["del_1Hz_N"]["4"] == pytest.approx(
        summary["lifetime"]["del_1Hz_N"]["4"])
    assert saved["units"]["*_N"] == "N" and saved["settings"]["runs_table"] == "season.csv"
    # cut the table after two runs: the rerun runs the three missing ones only
    lines = Path(f"{out}.csv").read_text().splitlines(keepends=True)
    Path(f"{out}.csv").write_text("".join(lines[:3]))
    done: list[int] = []
    again, _ = run_season(table, 25.0, out=out, workers=1, progress=False,
                          on_rows=lambda b: done.extend(r["run"] for r in b))
    assert sorted(done) == [2, 3, 4] and [r["run"] for r in again] == list(range(5))
    # other hours and life: nothing runs, the summary follows
    table2 = load_cases(write(tmp_path, TOML.replace("hours = 100.0", "hours = 0.0")))
    done.clear()
    _, summary3 = run_season(table2, 10.0, out=out, workers=1, progress=False,
                             on_rows=lambda b: done.extend(r["run"] for r in b))
    assert done == [] and summary3["lifetime"]["ice_hours"] == 3000.0
    # other runs: refused like a different sweep
    table3 = load_cases(write(tmp_path, TOML.replace("repetitions = 3", "repetitions = 4")))
    with pytest.raises(SeasonError.__mro__[1], match="different sweep"):
        run_season(table3, 25.0, out=out, workers=1, progress=False)


def test_a_table_begun_under_the_measures_earlier_name_resumes(tmp_path):
    table = load_cases(write(tmp_path, TOML))
    out = tmp_path / "season"
    run_season(table, 25.0, out=out, workers=1, progress=False)
    meta = Path(f"{out}.csv.meta.json")
    text = meta.read_text()
    assert "iceimpact.seasons.lifetime.season_measure" in text
    meta.write_text(text.replace("iceimpact.seasons.lifetime.season_measure",
                                 "iceimpact.studies.seasons.season_measure"))
    lines = Path(f"{out}.csv").read_text().splitlines(keepends=True)
    Path(f"{out}.csv").write_text("".join(lines[:3]))
    done: list[int] = []
    rows, _ = run_season(table, 25.0, out=out, workers=1, progress=False,
                         on_rows=lambda b: done.extend(r["run"] for r in b))
    assert sorted(done) == [2, 3, 4] and [r["run"] for r in rows] == list(range(5))


def test_cli_loads(tmp_path):
    cases = write(tmp_path, TOML)
    cmd = [sys.executable, "-m", "iceimpact.cli", "loads", str(cases), "--life", "25",
           "--out", str(tmp_path / "s"), "--workers", "1", "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "lifetime (25 years, 10000 ice hours): 1 Hz DEL m=3" in done.stdout
    assert json.loads((tmp_path / "s.json").read_text())["cases"][1]["name"] == "fast floe"
    bad = write(tmp_path, TOML.replace("hours = 100.0", "hours = -5"), "bad.toml")
    done = subprocess.run([*cmd[:4], str(bad), *cmd[5:]], capture_output=True, text=True,
                          check=False)
    assert done.returncode == 2 and "hours = -5: expected" in done.stderr
    assert "Traceback" not in done.stderr


def test_failed_runs_are_rows_and_the_command_exits_1(tmp_path):
    # a case whose runs stop (more impacts in a sample interval than solver.max_impacts allows)
    cases = write(tmp_path, TOML.replace("flow.u = 0.5", "flow.u = 1.0").replace(
        "impact.e = 0.8\n", 'impact.e = 0.8\n"ice.M" = 400.0\n"solver.max_impacts" = 1\n'))
    cmd = [sys.executable, "-m", "iceimpact.cli", "loads", str(cases), "--life", "25",
           "--out", str(tmp_path / "s"), "--workers", "1", "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 1, done.stderr
    assert "2 of 5 runs failed" in done.stderr and "SolverError" in done.stdout
    summary = json.loads((tmp_path / "s.json").read_text())
    assert not summary["lifetime"]["complete"]
    assert summary["lifetime"]["del_1Hz_N"]["4"] is None          # nan -> null
    assert len(summary["cases"][1]["failed"]) == 2
    assert summary["cases"][0]["del_1Hz_N"]["4"] > 0.0              # the other case is there
    again = subprocess.run([*cmd, "--allow-failures"], capture_output=True, text=True,
                           check=False)
    assert again.returncode == 0, again.stderr


def test_the_example_season_table_is_the_benchmarks_and_is_valid(tmp_path):
    import importlib.util

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("season_benchmark",
                                                  root / "benchmarks" / "season.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    bench.write_cases(tmp_path / "cases.csv")
    shipped = root / "examples" / "season_cases.csv"
    assert (tmp_path / "cases.csv").read_text() == shipped.read_text()   # regenerate if not
    table = load_cases(shipped, t_end=600.0, transient=60.0)
    assert len(table.cases) == 50 and table.n_runs == 150
    assert table.hours == pytest.approx(1200.0) and table.base.drag_model == 1
    assert {c.params["drag.model"] for c in table.cases} == {2}


def test_the_analysis_never_loads_the_sweep_or_the_seasons():
    """Imports go seasons -> sweep -> studies: importing every module of iceimpact.studies
    loads neither the sweep engine nor the seasons package, and each seasons module imports
    first in a fresh interpreter."""
    code = ("import sys\nfor m in ('analysis', 'impacts', 'loads', 'outfiles'):\n"
            "    __import__('iceimpact.studies.' + m)\n"
            "print(sorted(m for m in sys.modules if m.startswith(('iceimpact.sweep', "
            "'iceimpact.seasons'))))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"
    for module in ("iceimpact.seasons.lifetime", "iceimpact.seasons.cases", "iceimpact.seasons"):
        proc = subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 0, (module, proc.stderr)
