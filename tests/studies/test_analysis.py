"""Post-processing (iceimpact.studies.analysis): spectra, impact statistics, lock-in measures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from iceimpact import Scene, run
from iceimpact.simulator import IMPACT_DTYPE
from iceimpact.studies.analysis import (
    COUNTER_IMPACT_DTYPE,
    REST_AMPLITUDE,
    SUMMARY_FIELDS,
    displacement_spectrum,
    impact_statistics,
    impacts_from_counter,
    lock_in,
    summarize,
    summarize_arrays,
)


def _impacts(times, impulses) -> np.ndarray:
    arr = np.zeros(len(times), dtype=IMPACT_DTYPE)
    arr["t"] = times
    arr["impulse"] = impulses
    return arr


# Spectrum -------------------------------------------------------------------------------------
@pytest.mark.parametrize("f0", [0.37, 2.0, 3.9788735772973833, 11.3])
def test_sine_gives_its_frequency_within_a_bin(f0):
    h = 1e-2
    t = np.arange(0.0, 200.0, h)
    x = 1e-3 * np.sin(2 * np.pi * f0 * t + 0.3) + 5e-4  # the offset must not matter
    spec = displacement_spectrum(t, x)
    assert spec.f[0] == 0.0
    assert spec.resolution == pytest.approx(1.0 / (h * (t.size // 4)), rel=1e-9)
    assert abs(spec.dominant_frequency - f0) <= spec.resolution
    # the refinement between bins does better than the half-bin of the raw peak
    assert abs(spec.dominant_frequency - f0) <= 0.25 * spec.resolution
    # Parseval: the PSD integrates to the variance of the sine
    var = np.trapezoid(spec.psd, spec.f) if hasattr(np, "trapezoid") else np.trapz(spec.psd,
                                                                                      spec.f)
    assert var == pytest.approx(0.5e-6, rel=0.05)


def test_spectrum_skips_the_transient_and_honours_nperseg():
    h = 1e-2
    t = np.arange(0.0, 100.0, h)
    x = np.where(t < 50.0, np.sin(2 * np.pi * 1.0 * t), 0.1 * np.sin(2 * np.pi * 3.0 * t))
    assert displacement_spectrum(t, x).dominant_frequency == pytest.approx(1.0, abs=0.05)
    late = displacement_spectrum(t, x, t_start=50.0, nperseg=1000)
    assert late.resolution == pytest.approx(1.0 / (1000 * h))
    assert late.dominant_frequency == pytest.approx(3.0, abs=late.resolution)


def test_structure_at_rest_has_no_dominant_frequency():
    t = np.linspace(0.0, 10.0, 1001)
    assert math.isnan(displacement_spectrum(t, np.full_like(t, 2.5e-4)).dominant_frequency)
    tiny = 0.1 * REST_AMPLITUDE * np.sin(2 * np.pi * t)
    assert math.isnan(displacement_spectrum(t, tiny).dominant_frequency)


def test_spectrum_rejects_bad_sampling():
    t = np.linspace(0.0, 10.0, 1001)
    x = np.sin(t)
    t_bad = t.copy()
    t_bad[500] += 3e-3
    with pytest.raises(ValueError, match=r"^t: .*not uniform"):
        displacement_spectrum(t_bad, x)
    with pytest.raises(ValueError, match=r"^t: .*increasing"):
        displacement_spectrum(t[::-1], x)
    with pytest.raises(ValueError, match=r"^t: .*at least"):
        displacement_spectrum(t[:5], x[:5])
    with pytest.raises(ValueError, match=r"^t: .*at least"):
        displacement_spectrum(t, x, t_start=9.97)
    with pytest.raises(ValueError, match=r"^x: "):
        displacement_spectrum(t, x[:-1])
    with pytest.raises(ValueError, match="nperseg"):
        displacement_spectrum(t, x, nperseg=1)


# Impacts --------------------------------------------------------------------------------------
def test_regular_impacts_give_exact_statistics():
    times = 0.5 * np.arange(1, 41)             # 0.5, 1.0, ..., 20.0 s
    impulses = np.linspace(1.0, 4.0, 40)
    stats = impact_statistics(_impacts(times, impulses))
    assert stats.count == 40
    assert stats.rate == pytest.approx(2.0, rel=1e-12)
    assert stats.mean_interval == pytest.approx(0.5, rel=1e-12)
    assert stats.std_interval == pytest.approx(0.0, abs=1e-12)
    assert stats.cv_interval == pytest.approx(0.0, abs=1e-12)
    assert stats.frequency == pytest.approx(2.0, rel=1e-12)
    assert stats.mean_impulse == pytest.approx(2.5)
    assert stats.max_impulse == 4.0
    assert stats.total_impulse == pytest.approx(100.0)

    window = impact_statistics(_impacts(times, impulses), t_start=10.0, t_end=30.0)
    assert window.count == 21                   # 10.0 ... 20.0 inclusive
    assert window.rate == pytest.approx(21 / 20.0)  # a quiet tail lowers the rate ...
    assert window.mean_interval == pytest.approx(0.5)  # ... not the period


def test_irregular_intervals():
    stats = impact_statistics(np.array([1.0, 2.0, 4.0]))  # plain times: impulses unknown
    assert stats.mean_interval == pytest.approx(1.5)
    assert stats.std_interval == pytest.approx(0.5)
    assert stats.cv_interval == pytest.approx(1.0 / 3.0)
    assert math.isnan(stats.mean_impulse) and math.isnan(stats.total_impulse)


def test_empty_and_single_impact_windows():
    empty = impact_statistics(_impacts([], []), t_start=0.0, t_end=10.0)
    assert empty.count == 0 and empty.rate == 0.0 and empty.total_impulse == 0.0
    assert math.isnan(empty.mean_interval) and math.isnan(empty.mean_impulse)
    one = impact_statistics(_impacts([3.0], [7.0]), t_end=10.0)
    assert one.count == 1 and one.rate == pytest.approx(0.1)
    assert one.mean_impulse == one.max_impulse == one.total_impulse == 7.0
    assert math.isnan(one.mean_interval) and math.isnan(one.cv_interval)
    with pytest.raises(ValueError, match="t_end"):
        impact_statistics(_impacts([1.0], [1.0]), t_start=5.0, t_end=1.0)
    with pytest.raises(ValueError, match="impacts"):
        impact_statistics(np.array([2.0, 1.0]))


def test_impacts_from_counter():
    t = np.arange(0, 11) * 0.1
    count = np.array([0, 0, 1, 1, 1, 3, 3, 3, 3, 4, 4])
    t_last = np.array([-1, -1, 0.15, 0.15, 0.15, 0.48, 0.48, 0.48, 0.48, 0.81, 0.81])
    impulse = np.array([0, 0, 2.0, 0, 0, 6.0, 0, 0, 0, 1.0, 0])
    imp = impacts_from_counter(t, count, t_last, impulse)
    assert imp.dtype == COUNTER_IMPACT_DTYPE
    assert imp["t"] == pytest.approx([0.15, 0.44, 0.48, 0.81])
    assert imp["impulse"] == pytest.approx([2.0, 3.0, 3.0, 1.0])
    assert list(imp["multiplicity"]) == [1, 2, 2, 1]
    assert impacts_from_counter(t, count)["t"] == pytest.approx([0.2, 0.45, 0.5, 0.9])
    with pytest.raises(ValueError, match="count"):
        impacts_from_counter(t, count[::-1])


# Lock-in --------------------------------------------------------------------------------------
def test_lock_in_of_the_article_example():
    li = lock_in(25.0, 25.0 / (2 * np.pi * 2))
    assert li.n == 2 and li.locked
    assert li.ratio == pytest.approx(2.0) and li.mismatch == pytest.approx(0.0, abs=1e-12)
    article = lock_in(25.0, 1.0 / 0.5)          # T = 0.5 s as read from Figure 13(b)
    assert article.n == 2 and article.locked
    assert article.ratio == pytest.approx(25.0 * 0.5 / (2 * np.pi))


def test_lock_in_mismatch_and_undefined():
    off = lock_in(25.0, 25.0 / (2 * np.pi * 2.5))
    assert off.n in (2, 3) and off.mismatch > 0.15 and not off.locked
    slow = lock_in(1.0, 10.0)                    # ratio << 1 still compares with N = 1
    assert slow.n == 1 and slow.mismatch == pytest.approx(1 - 1 / (20 * np.pi))
    assert lock_in(25.0, 25.0 / (2 * np.pi * 3.1), tolerance=0.05).locked
    assert not lock_in(25.0, 25.0 / (2 * np.pi * 3.1), tolerance=0.01).locked
    none = lock_in(25.0, math.nan)
    assert none.n == 0 and not none.locked and math.isnan(none.ratio)
    with pytest.raises(ValueError, match="omega_n"):
        lock_in(0.0, 1.0)
    with pytest.raises(ValueError, match="impact_frequency"):
        lock_in(25.0, -1.0)


# Summary of a real run ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def figure2_run():
    return run(Scene(), t_end=20.0, dt=1e-3)


def test_summarize_real_run(figure2_run):
    res = figure2_run
    s = summarize(res, transient=2.0)
    assert list(s) == list(SUMMARY_FIELDS)
    assert all(isinstance(v, float) for v in s.values())
    # consistent with the impact array
    times = res.impacts["t"]
    inside = times >= 2.0
    assert s["n_impacts"] == inside.sum() >= 2
    assert s["total_impulse_ns"] == pytest.approx(res.impacts["impulse"][inside].sum())
    assert s["max_impulse_ns"] == pytest.approx(res.impacts["impulse"][inside].max())
    assert s["mean_interval_s"] == pytest.approx(np.diff(times[inside]).mean())
    assert s["impact_rate_hz"] == pytest.approx(inside.sum() / 18.0)
    late = res.t >= 2.0
    assert s["x_peak_m"] == pytest.approx(np.abs(res.x[late]).max())
    assert 0.0 < s["x_rms_m"] <= s["x_peak_m"]
    # defined quantities are finite; the run never sticks (e = 1)
    for key, value in s.items():
        if key != "sticking_since_s":
            assert math.isfinite(value), key
    assert math.isnan(s["sticking_since_s"]) and s["sticking_fraction"] == 0.0
    # free vibrations between impacts: the structure rings at omega_n (zeta = 0.0025)
    assert s["dominant_over_natural"] == pytest.approx(1.0, abs=0.05)
    assert s["omega_ratio"] == pytest.approx(s["omega_n_rad_s"] * s["mean_interval_s"]
                                             / (2 * np.pi))
    assert s["nearest_n"] == max(1, round(s["omega_ratio"]))


def test_summarize_window_without_impacts_and_at_rest():
    t = np.arange(0.0, 10.0001, 1e-2)
    s = summarize_arrays(t, np.zeros_like(t), _impacts([], []), omega_n=25.0, transient=1.0,
                         sticking=np.ones_like(t, dtype=bool), sticking_since=0.4)
    assert s["n_impacts"] == 0.0 and s["impact_rate_hz"] == 0.0
    assert math.isnan(s["dominant_frequency_hz"]) and math.isnan(s["dominant_over_natural"])
    assert math.isnan(s["omega_ratio"]) and s["nearest_n"] == 0.0 and s["locked"] == 0.0
    assert s["sticking_fraction"] == 1.0 and s["sticking_since_s"] == 0.4
    assert s["x_peak_m"] == 0.0


def test_summarize_never_raises_on_short_or_ragged_runs():
    # 3 samples: no spectrum possible; t_end not a multiple of dt: a short last interval
    short = summarize(run(Scene(), t_end=0.02, dt=1e-2))
    assert math.isnan(short["dominant_frequency_hz"]) and short["n_impacts"] == 0.0
    ragged = summarize(run(Scene(), t_end=3.0005, dt=1e-3))
    assert math.isfinite(ragged["dominant_frequency_hz"])
    with pytest.raises(ValueError, match="transient"):
        summarize(run(Scene(), t_end=1.0, dt=1e-2), transient=2.0)


def test_dominant_frequency_of_samples():
    """The one public dominant frequency: Hz from (t, x), nan at rest, the spectrum's peak."""
    from iceimpact.studies.analysis import dominant_frequency

    t = np.arange(0.0, 20.0, 1e-3)
    x = 1e-3 * np.sin(2 * np.pi * 3.3 * t) + 0.5   # the mean is removed
    assert dominant_frequency(t, x) == pytest.approx(3.3, abs=0.05)
    assert dominant_frequency(t, x, nperseg=t.size) == pytest.approx(3.3, abs=0.01)
    assert dominant_frequency(t, x) == displacement_spectrum(t, x).dominant_frequency
    assert math.isnan(dominant_frequency(t, np.full_like(t, 0.2)))
    assert dominant_frequency(t, x, t_start=10.0) == pytest.approx(3.3, abs=0.1)
