"""Design loads (iceimpact.studies.loads): extremes, rainflow DELs, contact force, against closed
forms."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rainflow

from iceimpact import Scene, run
from iceimpact.studies.analysis import SUMMARY_FIELDS, summarize, summarize_arrays
from iceimpact.studies.loads import (
    LOAD_FIELDS,
    N_EQ,
    WOHLER_EXPONENTS,
    Cycles,
    contact_force,
    damage_equivalent_load,
    design_loads,
    extremes,
    load_columns,
    rainflow_cycles,
    run_loads,
    turning_points,
)

ROOT = Path(__file__).resolve().parents[2]


# Damage-equivalent loads: closed forms ---------------------------------------------------------
@pytest.mark.parametrize("m", [*WOHLER_EXPONENTS, 1.5, 7])
def test_sine_del_is_its_range_at_its_own_frequency(m):
    amplitude, f, periods, per_period = 3.0e3, 0.37, 25, 64
    t = np.arange(periods * per_period + 1) / (f * per_period)
    y = amplitude * np.cos(2.0 * np.pi * f * t)
    cycles = rainflow_cycles(y)
    # a cosine from peak to peak: 2 x periods half cycles of range 2A (MLife counts them 0.5)
    assert cycles.total == pytest.approx(periods)
    assert np.allclose(cycles.ranges, 2.0 * amplitude, rtol=1e-12)
    duration = t[-1]
    assert damage_equivalent_load(cycles, m, f * duration) == pytest.approx(2 * amplitude,
                                                                           rel=1e-12)
    assert damage_equivalent_load(cycles, m, periods) == pytest.approx(2 * amplitude, rel=1e-12)
    # through design_loads: y = k x with k = 2e5 N/m, f_eq = f; the extremes are +-A
    loads = design_loads(t, y / 2e5, 2e5, f_eq=f, n_eq=periods, exponents=(m,))
    assert loads.del_1hz[m] == pytest.approx(2 * amplitude, rel=1e-12)
    assert loads.del_neq[m] == pytest.approx(2 * amplitude, rel=1e-12)
    assert loads.kx.max == pytest.approx(amplitude) and loads.kx.t_max == 0.0
    assert loads.kx.min == pytest.approx(-amplitude)
    assert loads.kx.t_min == pytest.approx(0.5 / f)


def test_sine_del_at_1hz_scales_with_the_frequency():
    # the 1 Hz DEL of a sine of range S at frequency f is S f^(1/m)
    amplitude, f, periods = 1.0, 4.0, 40
    t = np.linspace(0.0, periods / f, periods * 50 + 1)
    loads = design_loads(t, amplitude * np.cos(2 * np.pi * f * t), 1.0)
    for m in WOHLER_EXPONENTS:
        assert loads.del_1hz[m] == pytest.approx(2 * amplitude * f ** (1.0 / m), rel=1e-9)
        assert loads.del_neq[m] == pytest.approx(2 * amplitude * (periods / N_EQ) ** (1.0 / m),
                                                 rel=1e-9)


def test_a_series_that_starts_late_is_taken_over_its_own_span():
    """FMU output from a later start time or a saved slice of a run: T is the span of the
    samples, not their last time (that gave 1.68 for m = 4 here, (100 / 200)^(1/4) x 2)."""
    t = 100.0 + np.arange(6401) / 64.0  # 100 periods of a 1 Hz cosine, from t = 100 s
    y = np.cos(2 * np.pi * t)
    loads = design_loads(t, y, 1.0)
    assert loads.t_start == 100.0 and loads.duration == 100.0
    for m in WOHLER_EXPONENTS:
        assert loads.del_1hz[m] == pytest.approx(2.0, rel=1e-12)
    # the same series from t = 0, and the same window cut by a transient, agree
    assert design_loads(t - 100.0, y, 1.0).del_1hz == loads.del_1hz
    assert design_loads(t, y, 1.0, transient=100.0).del_1hz == loads.del_1hz
    # a transient inside the series starts the window there (the first half of the series)
    half = design_loads(t, y, 1.0, transient=150.0)
    assert half.t_start == 150.0 and half.del_1hz[4] == pytest.approx(2.0, rel=1e-12)
    # the summary's window and rates too: impacts before the series are not in it
    impacts = np.array([(50.0, 1.0), *((100.5 + k, 2.0) for k in range(100))],
                       dtype=[("t", float), ("impulse", float)])
    s = summarize_arrays(t, y, impacts, omega_n=2 * np.pi, structure_k=1.0)
    assert s["t_start_s"] == 100.0 and s["n_impacts"] == 100.0
    assert s["impact_rate_hz"] == pytest.approx(1.0, rel=1e-12)
    assert s["del_m4_1Hz_N"] == pytest.approx(2.0, rel=1e-12)


@pytest.mark.parametrize("m", WOHLER_EXPONENTS)
def test_two_level_block_signal_gives_the_hand_computed_del(m):
    # reversals: -B, B, then n1 small cycles (-a, a) nested in the first big half, then the
    # big cycle goes on for n2 cycles in all: n1 full cycles of 2a and n2 cycles of 2B
    a, big, n1, n2 = 1.0e3, 4.0e3, 7, 5
    y = [-big, big, *([-a, a] * n1), -big, *([big, -big] * (n2 - 1))]
    h = 0.5  # s between reversals
    t = h * np.arange(len(y))
    loads = design_loads(t, np.array(y), 1.0, exponents=(m,))
    damage = n1 * (2 * a) ** m + n2 * (2 * big) ** m
    assert loads.cycles.total == pytest.approx(n1 + n2)
    assert loads.del_neq[m] == pytest.approx((damage / N_EQ) ** (1 / m), rel=1e-12)
    assert loads.del_1hz[m] == pytest.approx((damage / t[-1]) ** (1 / m), rel=1e-12)
    if m == 3:  # by hand: 7 (2 kN)^3 + 5 (8 kN)^3 = 2.616e12 N^3 over 12 s (25 reversals)
        assert t[-1] == 12.0
        assert loads.del_neq[3] == pytest.approx(63.96, abs=0.01)
        assert loads.del_1hz[3] == pytest.approx(6018.46, abs=0.01)


def test_half_cycles_count_half_as_mlife_does():
    cycles = rainflow_cycles(np.array([0.0, 1.0, -1.0, 0.0]))
    assert sorted(cycles.ranges.tolist()) == [1.0, 1.0, 2.0]
    assert cycles.counts.tolist() == [0.5, 0.5, 0.5]
    assert rainflow_cycles(np.array([0.0, 1.0, -1.0, 0.0]), half=1.0).total == 3.0
    assert rainflow_cycles(np.array([0.0, 1.0, -1.0, 0.0]), half=0.0).total == 0.0


def test_turning_points_reproduce_the_rainflow_package():
    rng = np.random.default_rng(17)
    y = np.cumsum(rng.normal(size=4000))
    y[100:110] = y[100]  # a plateau
    expected = [v for _, v in rainflow.reversals(y.tolist())]
    assert turning_points(y).tolist() == expected
    ours = rainflow_cycles(y)
    theirs = rainflow.count_cycles(y.tolist())
    for m in (3, 10):
        d_ours = float(np.sum(ours.counts * ours.ranges ** m))
        d_theirs = sum(n * s ** m for s, n in theirs)
        assert d_ours == pytest.approx(d_theirs, rel=1e-12)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "as-python"])
def test_the_rainflow_count_is_the_rainflow_packages(compiled):
    """rainflow_count (the package's algorithm over arrays, compiled where numba is) gives the
    package's cycles in its order, to the bit: random walks, integer signals full of ties and
    plateaus, and the shortest series."""
    from iceimpact.studies import loads
    count = loads._COUNT if compiled else loads.rainflow_count
    if count is None:
        pytest.skip("numba is not installed (or ICEIMPACT_PURE is set): nothing compiled")
    rng = np.random.default_rng(23)
    signals = [np.cumsum(rng.normal(size=n)) for n in (0, 1, 2, 3, 4, 5, 50, 3000)]
    signals += [rng.integers(-3, 4, size=n).astype(float) for n in (2, 3, 7, 40, 500)]
    signals += [np.array([1.0, 1.0]), np.array([0.0, 1.0, 1.0]), np.array([2.0, 2.0, 2.0]),
                np.array([0.0, 1.0, -1.0, 0.0])]
    for y in signals:
        want = [row[:3] for row in rainflow.extract_cycles(y.tolist())]
        ranges, means, counts = np.empty(y.size), np.empty(y.size), np.empty(y.size)
        n = count(y, ranges, means, counts)
        got = list(zip(ranges[:n].tolist(), means[:n].tolist(), counts[:n].tolist(),
                       strict=True))
        assert got == [tuple(row) for row in want], y


def test_degenerate_signals():
    none = rainflow_cycles(np.array([2.0, 2.0, 2.0]))
    assert none.total == 0.0
    assert damage_equivalent_load(none, 3, 10.0) == 0.0
    assert math.isnan(damage_equivalent_load(Cycles(np.ones(1), np.ones(1), np.ones(1)), 3, 0.0))
    with pytest.raises(ValueError, match="finite"):
        rainflow_cycles(np.array([0.0, math.nan, 1.0]))
    with pytest.raises(ValueError, match="exponent"):
        damage_equivalent_load(none, 0.0, 1.0)
    # a diverged run: nan loads rather than an exception
    bad = design_loads(np.arange(4.0), np.array([0.0, 1.0, math.inf, 0.0]), 1.0)
    assert math.isnan(bad.del_1hz[3]) and math.isnan(load_columns(bad)["del_m10_1e7_N"])
    ext = extremes(np.array([]), np.array([]))
    assert math.isnan(ext.max) and math.isnan(ext.t_min)
    # large ranges and m = 10: no overflow
    huge = Cycles(np.array([1e40, 2e40]), np.zeros(2), np.ones(2))
    assert damage_equivalent_load(huge, 10, 2.0) == pytest.approx(
        2e40 * ((1 + 2 ** -10) / 2) ** 0.1)


# Extremes of a free decay ------------------------------------------------------------------------
def test_extreme_equals_the_closed_form_peak_of_a_free_decay():
    # the structure starts at x = 0 with velocity v0; the ice is far away and at rest (no flow):
    # x(t) = v0/wd exp(-zeta wn t) sin(wd t), first peak at tan(wd t) = wd / (zeta wn)
    scene = Scene(structure_c=2000.0, structure_v0=0.01, ice_z0=-10.0, ice_v0=0.0, flow_u=0.0)
    k, wn, zeta = scene.structure_k, scene.omega_n, scene.zeta
    wd = wn * math.sqrt(1 - zeta ** 2)
    t_peak = math.atan2(math.sqrt(1 - zeta ** 2), zeta) / wd
    t_trough = t_peak + math.pi / wd
    x_peak = (scene.structure_v0 / wn) * math.exp(-zeta * wn * t_peak)
    x_trough = -x_peak * math.exp(-zeta * wn * math.pi / wd)
    samples = np.sort(np.concatenate([np.arange(1, 2001) * 1e-3, [t_peak, t_trough]]))
    res = run(scene, 2.0, sample_times=samples)
    assert res.impacts.size == 0
    loads = run_loads(res)
    assert loads.kx.max == pytest.approx(k * x_peak, rel=1e-9)
    assert loads.kx.t_max == t_peak
    assert loads.kx.min == pytest.approx(k * x_trough, rel=1e-9)
    assert loads.kx.t_min == t_trough
    assert loads.n_impacts == 0 and math.isnan(loads.impulse_p99)
    assert loads.contact.max == 0.0 and loads.contact_mean == 0.0
    # the largest rainflow range is the first swing, peak to trough
    assert loads.cycles.ranges.max() == pytest.approx(k * (x_peak - x_trough), rel=1e-9)


# Contact force and impacts -----------------------------------------------------------------------
def test_contact_force_is_the_impulse_over_the_sample_interval():
    t = np.array([0.0, 0.1, 0.2, 0.4, 0.5])
    impulse = np.array([0.0, 1.0, 0.0, 3.0, 0.5])
    assert contact_force(t, impulse).tolist() == pytest.approx([0.0, 10.0, 0.0, 15.0, 5.0])
    loads = design_loads(t, np.zeros(5), 1.0, impulse=impulse, transient=0.15)
    # intervals starting at or after 0.15 s: (0.2, 0.4] and (0.4, 0.5]
    assert loads.contact.max == pytest.approx(15.0) and loads.contact.t_max == 0.4
    assert loads.contact_mean == pytest.approx(3.5 / 0.3)
    with pytest.raises(ValueError, match="increasing"):
        contact_force(np.array([0.0, 0.0]), np.zeros(2))


@pytest.fixture(scope="module")
def figure2_run():
    return run(Scene(), t_end=30.0, dt=1e-3)


def test_loads_of_a_real_run(figure2_run):
    res, transient = figure2_run, 5.0
    loads = run_loads(res, transient)
    late = res.t >= transient
    kx = res.scene.structure_k * res.x[late]
    assert loads.kx.max == kx.max() and loads.kx.min == kx.min()
    assert loads.kx.t_max == res.t[late][np.argmax(kx)]
    inside = res.impacts["t"] >= transient
    j = res.impacts["impulse"][inside]
    assert loads.n_impacts == inside.sum() >= 5
    assert loads.impulse_mean == pytest.approx(j.mean())
    assert loads.impulse_max == j.max()
    assert j.mean() <= loads.impulse_p99 <= j.max()
    # e = 1: no sticking, so the contact force integrates to the impacts' impulse
    assert loads.contact_mean * (res.t[-1] - transient) == pytest.approx(j.sum(), rel=1e-9)
    assert loads.contact.max == pytest.approx(j.max() / 1e-3, rel=1e-6)
    # a DEL never exceeds the largest range; the 1e7-cycle DEL is far below for a 25 s window
    top = loads.cycles.ranges.max()
    for m in WOHLER_EXPONENTS:
        assert 0.0 < loads.del_neq[m] < loads.del_1hz[m] <= top * 4.0 ** (1 / m)
    assert loads.cycles.ranges.max() <= loads.kx.max - loads.kx.min + 1e-9


def test_summary_has_the_load_columns_with_units(figure2_run):
    s = summarize(figure2_run, transient=5.0)
    assert list(s)[-len(LOAD_FIELDS):] == list(LOAD_FIELDS)
    assert set(LOAD_FIELDS) <= set(SUMMARY_FIELDS)
    for key in ("del_m3_1Hz_N", "del_m10_1Hz_N", "del_m4_1e7_N", "kx_max_N", "kx_max_t_s",
                "contact_force_max_N", "p99_impulse_ns"):
        assert key in s and math.isfinite(s[key])
    for key, (unit, _) in LOAD_FIELDS.items():
        assert key.endswith({"N": "_N", "s": "_s", "N.s": "_ns", "1": "_cycles"}[unit]), key
    assert s["kx_max_N"] == pytest.approx(figure2_run.scene.structure_k * s["x_peak_m"])
    assert s == {**s, **load_columns(run_loads(figure2_run, 5.0))}


def test_the_modal_structures_design_loads_are_those_of_k_c_x():
    """With the modal structure the k x columns are k_c x, k_c = 1 / sum(phi_k^2 / (m_k
    omega_k^2)) worked out from the modes (not structure.k, which it ignores): extremes and the
    1 Hz DELs of the rainflow package's cycles."""
    scene = Scene(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                  structure_mode2_zeta=0.02, structure_mode2_phi=0.6, structure_k=5.0e5)
    k_c = 1.0 / sum(phi * phi / (m * (2.0 * math.pi * f) ** 2)
                    for f, _, m, phi, _, _ in scene.mode_table)
    result = run(scene, 12.0, dt=1e-2)
    transient = 2.0
    s = summarize(result, transient=transient)
    late = result.t >= transient
    load = k_c * result.x[late]
    assert s["kx_max_N"] == pytest.approx(load.max(), rel=1e-14)
    assert s["kx_min_N"] == pytest.approx(load.min(), rel=1e-14)
    assert s["kx_mean_N"] == pytest.approx(load.mean(), rel=1e-12)
    cycles = rainflow.count_cycles(load.tolist())
    for m in WOHLER_EXPONENTS:
        del_1hz = (math.fsum(n * r ** m for r, n in cycles) / (result.t[-1] - transient)) ** (1 / m)
        assert s[f"del_m{m}_1Hz_N"] == pytest.approx(del_1hz, rel=1e-10), m
    assert s == {**s, **load_columns(run_loads(result, transient))}


def test_summarize_arrays_without_stiffness_keeps_working():
    t = np.arange(0.0, 5.0001, 1e-2)
    s = summarize_arrays(t, 1e-3 * np.sin(25 * t), np.zeros(0, dtype=[("t", float),
                                                                       ("impulse", float)]),
                         omega_n=25.0)
    assert list(s) == list(SUMMARY_FIELDS)
    assert math.isnan(s["kx_max_N"]) and math.isnan(s["del_m3_1Hz_N"])
    assert math.isnan(s["contact_force_max_N"])
    s = summarize_arrays(t, 1e-3 * np.sin(25 * t), np.zeros(0), omega_n=25.0, structure_k=1e6)
    assert s["kx_max_N"] == pytest.approx(1e3, rel=1e-3)


# The design map example -----------------------------------------------------------------------
def test_design_map_quick(tmp_path):
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "design_map.py"), "--quick", "--out-dir",
         str(tmp_path), "--workers", "1"],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    png = tmp_path / "design_map.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    lines = (tmp_path / "design_map.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert "del_m4_1Hz_N" in header and "kx_max_N" in header and "flow.u" in header
    assert len(lines) == 1 + 4


def test_the_transient_takes_python_and_numpy_numbers_and_refuses_huge_ones():
    t = np.arange(641) / 64.0
    y = np.cos(2 * np.pi * t)
    want = design_loads(t, y, 1.0, transient=2.0).del_1hz
    for transient in (2, np.int64(2), np.float32(2.0)):
        assert design_loads(t, y, 1.0, transient=transient).del_1hz == want
    for transient in (10**400, True, np.bool_(False), math.nan, -1.0):  # 10**400: OverflowError
        with pytest.raises(ValueError, match="transient = .* must be a finite number >= 0"):
            design_loads(t, y, 1.0, transient=transient)
