"""Lifetime statistics (seasons/lifetime.py): the closed forms of the combination, and pCrunch
where its conventions agree."""

from __future__ import annotations

import math

import numpy as np
import pytest

from iceimpact import Scene, run
from iceimpact.seasons import (
    SeasonError,
    lifetime_del,
    pooled_del,
    summarize_season,
)
from iceimpact.studies.loads import WOHLER_EXPONENTS
from season_tables import cosine, rows_of, table_of


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
