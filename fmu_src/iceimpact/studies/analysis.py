"""Post-processing of a run: impact statistics, displacement spectra and lock-in measures.

Physics-free: every function works on plain numpy arrays (from :func:`iceimpact.run`, from the
FMU's outputs via :func:`impacts_from_counter`, or from anywhere else), SI units throughout.

- :func:`impact_statistics` -- how many impacts, how often, how regular, how strong?
  (the impulses ``f_j`` at times ``t_j`` of the article's eq. 39).
- :func:`displacement_spectrum` -- at which frequency does the structure vibrate?
  (Welch power spectral density of ``x(t)``, the discrete counterpart of ``|X(omega)|^2`` of
  eq. 43).
- :func:`lock_in` -- is the impact period ``T`` such that ``omega_n = 2 pi N / T`` for an
  integer ``N`` (the resonance/lock-in condition of the article's Section 5, after eq. 44)?
- :func:`summarize` / :func:`summarize_arrays` -- all of the above and the design loads of
  :mod:`iceimpact.studies.loads` (extremes, damage-equivalent loads) as one flat, CSV-ready
  ``dict[str, float]`` whose keys and units are listed in :data:`SUMMARY_FIELDS`.
- :func:`impacts_from_counter` -- impact times and impulses recovered from sampled outputs
  (the FMU's ``contact.count``, ``contact.t_last`` and ``contact.impulse``).

Undefined quantities are ``nan`` (never an exception, so that sweeps can write them to CSV):
intervals need at least two impacts, impulse means at least one, the dominant frequency a
structure that moves (see :data:`REST_AMPLITUDE`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import welch

from .impacts import (
    COUNTER_IMPACT_DTYPE,
    ImpactStatistics,
    impact_statistics,
    impacts_from_counter,
)
from .loads import (
    LOAD_FIELDS,
    design_loads,
    load_columns,
    sample_window,
    spring_stiffness,
    window_start,
)

#: The impact statistics live in :mod:`iceimpact.studies.impacts` (loads uses them too) and are
#: part of this module's interface.
__all__ = ["COUNTER_IMPACT_DTYPE", "SUMMARY_FIELDS", "ImpactStatistics", "LockIn", "Spectrum",
           "displacement_spectrum", "dominant_frequency", "impact_statistics",
           "impacts_from_counter", "lock_in", "sample_spacing", "spectrum_peak", "summarize",
           "summarize_arrays"]

#: Default relative tolerance of :func:`lock_in`: ``|ratio - N| / N <= 0.05`` counts as locked.
LOCK_IN_TOLERANCE = 0.05

#: Root-mean-square (about its mean) of the displacement, m, at or below which the structure is
#: considered at rest and its dominant frequency is undefined (nan). Sticking contact or a run
#: without impacts damps out to a constant x; the "peak" of a spectrum of rounding noise or of a
#: vanishing exponential tail is not a vibration frequency.
REST_AMPLITUDE = 1e-9

#: Relative deviation of the sample spacing from its median tolerated as uniform sampling
#: (sample times computed as sums or products of a step carry rounding errors of ~1e-12).
UNIFORM_RTOL = 1e-6

#: Fewest samples :func:`displacement_spectrum` accepts.
MIN_SAMPLES = 8

#: Keys of :func:`summarize` with their units and meaning (all values are floats).
SUMMARY_FIELDS: dict[str, tuple[str, str]] = {
    "t_start_s": ("s", "start of the analysed window: the transient, or the first sample if "
                       "the series starts later"),
    "t_end_s": ("s", "end of the analysed window (last sample)"),
    "omega_n_rad_s": ("rad/s", "natural circular frequency sqrt(k/m) of the structure"),
    "n_impacts": ("1", "impacts in the window"),
    "impact_rate_hz": ("Hz", "impacts per second over the window: n_impacts / (t_end - t_start)"),
    "impact_frequency_hz": ("Hz", "1 / mean_interval_s, the 1/T of the article's Section 5"),
    "mean_interval_s": ("s", "mean time between consecutive impacts, T (nan if < 2 impacts)"),
    "std_interval_s": ("s", "standard deviation (ddof = 0) of the intervals"),
    "cv_interval": ("1", "std_interval_s / mean_interval_s: 0 for a perfectly periodic train"),
    "mean_impulse_ns": ("N.s", "mean impulse per impact on the structure (nan if none)"),
    "max_impulse_ns": ("N.s", "largest impulse of one impact (nan if none)"),
    "total_impulse_ns": ("N.s", "sum of the impact impulses (sticking contact excluded)"),
    "x_peak_m": ("m", "max |x| in the window"),
    "x_mean_m": ("m", "mean of x in the window"),
    "x_rms_m": ("m", "root mean square of x (about x = 0, the unloaded equilibrium)"),
    "x_std_m": ("m", "standard deviation of x (about its mean): the vibration amplitude scale"),
    "dominant_frequency_hz": ("Hz", "peak of the Welch PSD of x (nan when at rest or the "
                                    "sampling is unusable)"),
    "dominant_over_natural": ("1", "2 pi dominant_frequency_hz / omega_n"),
    "omega_ratio": ("1", "omega_n / (2 pi impact_frequency_hz) = omega_n T / (2 pi)"),
    "nearest_n": ("1", "integer N >= 1 nearest to omega_ratio (0 if undefined)"),
    "lockin_mismatch": ("1", "|omega_ratio - N| / N"),
    "locked": ("1", "1.0 if lockin_mismatch <= the tolerance, else 0.0"),
    "sticking_fraction": ("1", "fraction of the window's samples in sticking contact "
                               "(nan if not known)"),
    "sticking_since_s": ("s", "start of the sticking phase that lasts to the end (nan if none)"),
    # design loads (iceimpact.studies.loads): extremes, damage-equivalent loads, contact force
    **LOAD_FIELDS,
}


@dataclass(frozen=True)
class Spectrum:
    """One-sided Welch power spectral density of the structure displacement."""

    f: np.ndarray                # frequencies, Hz
    psd: np.ndarray              # power spectral density, m^2/Hz
    dominant_frequency: float    # Hz, nan when the structure is at rest

    @property
    def resolution(self) -> float:
        """Bin width of the spectrum, Hz."""
        return float(self.f[1] - self.f[0]) if self.f.size > 1 else math.nan


def sample_spacing(t: np.ndarray, name: str = "t") -> float:
    """The uniform spacing of the sample times ``t`` (s); ValueError naming ``name`` otherwise."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"{name}: need a 1-D array of at least 2 sample times, got {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{name}: sample times must be finite")
    dt = np.diff(t)
    h = float(np.median(dt))
    if not h > 0.0 or np.any(dt <= 0.0):
        raise ValueError(f"{name}: sample times must be strictly increasing")
    worst = float(np.max(np.abs(dt - h)))
    if worst > UNIFORM_RTOL * h:
        raise ValueError(f"{name}: sampling is not uniform (spacings differ from the median "
                         f"{h:.6g} s by up to {worst:.3g} s); resample onto a uniform grid")
    return h


def spectrum_peak(f: np.ndarray, psd: np.ndarray) -> float:
    """Frequency (Hz) of the largest PSD value, f = 0 excluded, refined between bins.

    The refinement fits a parabola through the logarithm of the PSD at the peak bin and its two
    neighbours and takes its vertex (exact for a Gaussian-shaped peak, within a fraction of a bin
    for the Hann window used here); the shift is limited to half a bin. nan when the PSD above
    f = 0 is identically zero.
    """
    f = np.asarray(f, dtype=float)
    psd = np.asarray(psd, dtype=float)
    positive = np.flatnonzero(f > 0.0)
    if positive.size == 0:
        return math.nan
    k = int(positive[np.argmax(psd[positive])])
    if not psd[k] > 0.0:
        return math.nan
    if 0 < k < f.size - 1 and f[k - 1] > 0.0 and psd[k - 1] > 0.0 and psd[k + 1] > 0.0:
        a, b, c = np.log(psd[k - 1]), np.log(psd[k]), np.log(psd[k + 1])
        denom = a - 2.0 * b + c
        if denom < 0.0:
            shift = float(np.clip(0.5 * (a - c) / denom, -0.5, 0.5))
            return float(f[k] + shift * (f[k + 1] - f[k]))
    return float(f[k])


def displacement_spectrum(t: np.ndarray, x: np.ndarray, t_start: float = 0.0,
                          nperseg: int | None = None) -> Spectrum:
    """Welch PSD (m^2/Hz) of the displacement ``x`` (m) sampled uniformly at times ``t`` (s).

    Only samples with ``t >= t_start`` are used (skip the transient). The mean is removed
    (``detrend='constant'``), Hann window, 50 % overlap. ``nperseg`` defaults to a quarter of the
    samples (at least 256, or all of them if fewer): about 7 averaged segments and a resolution
    of 4 / (record length) Hz. The dominant frequency is the peak above f = 0 refined by
    :func:`spectrum_peak`; it is nan when the structure is at rest, i.e. the RMS of
    ``x - mean(x)`` is at most :data:`REST_AMPLITUDE` m.

    Raises ValueError (naming the argument) for non-uniform sampling, mismatched shapes, fewer
    than :data:`MIN_SAMPLES` samples after ``t_start`` or non-finite values.
    """
    t = np.asarray(t, dtype=float).ravel()
    x = np.asarray(x, dtype=float).ravel()
    if x.shape != t.shape:
        raise ValueError(f"x: shape {x.shape} differs from t's {t.shape}")
    keep = t >= t_start
    t, x = t[keep], x[keep]
    if t.size < MIN_SAMPLES:
        raise ValueError(f"t: need at least {MIN_SAMPLES} samples at t >= t_start = {t_start!r}, "
                         f"got {t.size}")
    if not np.all(np.isfinite(x)):
        raise ValueError("x: displacements must be finite")
    h = sample_spacing(t, "t")
    n = t.size
    if nperseg is None:
        nperseg = max(min(n, 256), n // 4)
    elif isinstance(nperseg, bool) or not isinstance(nperseg, int | np.integer) or nperseg < 2:
        raise ValueError(f"nperseg = {nperseg!r} must be an integer >= 2")
    nperseg = min(int(nperseg), n)
    f, psd = welch(x, fs=1.0 / h, window="hann", nperseg=nperseg, detrend="constant",
                   scaling="density")
    at_rest = float(np.std(x)) <= REST_AMPLITUDE
    dom = math.nan if at_rest else spectrum_peak(f, psd)
    return Spectrum(f=f, psd=psd, dominant_frequency=dom)


def dominant_frequency(t: np.ndarray, x: np.ndarray, t_start: float = 0.0,
                       nperseg: int | None = None) -> float:
    """The frequency (Hz) at which a signal ``x`` sampled uniformly at times ``t`` (s) vibrates
    most: the peak of its Welch PSD above f = 0 (:func:`displacement_spectrum`, mean removed,
    Hann window), refined between bins (:func:`spectrum_peak`). nan when ``x`` does not move
    (its RMS about the mean is at most :data:`REST_AMPLITUDE`). The project's one dominant
    frequency: the sweep's ``dominant_frequency_hz`` and the benchmarks use it.

    ``t_start`` (s) skips a transient. ``nperseg`` (samples per Welch segment) sets the
    resolution: the default, a quarter of the record, averages about 7 segments (bins of
    4 / record length Hz); ``nperseg=len(x)`` is one Hann-windowed periodogram of the whole
    record (bins of 1 / record length Hz, no averaging). Raises ValueError like
    :func:`displacement_spectrum` (non-uniform sampling, too few samples, non-finite values).
    """
    return displacement_spectrum(t, x, t_start=t_start, nperseg=nperseg).dominant_frequency


# Lock-in ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LockIn:
    """How close the impact train is to the lock-in condition ``omega_n = 2 pi N / T``."""

    ratio: float       # omega_n / (2 pi f_impact) = omega_n T / (2 pi), nan if undefined
    n: int             # nearest integer N >= 1 (0 if the ratio is undefined)
    mismatch: float    # |ratio - N| / N (nan if undefined)
    locked: bool       # mismatch <= tolerance
    tolerance: float   # relative tolerance used


def lock_in(omega_n: float, impact_frequency: float,
            tolerance: float = LOCK_IN_TOLERANCE) -> LockIn:
    """Distance of an impact train from the lock-in (resonance) condition of Section 5.

    The article models the impacts as a comb of impulses of period ``T`` (eq. 40) whose Fourier
    transform has lines at ``2 pi N / T`` (eq. 41); the structure's response (eq. 44) resonates
    when ``omega_n = 2 pi N / T`` for an integer ``N >= 1``. With ``omega_n`` in rad/s and
    ``impact_frequency = 1/T`` in Hz this returns ``ratio = omega_n / (2 pi impact_frequency)``,
    the nearest ``N >= 1``, the relative mismatch ``|ratio - N| / N`` and ``locked =
    mismatch <= tolerance`` (default 5 %). The article's Figure 13 case: ``omega_n = 25 rad/s``,
    ``T = 0.5 s`` gives ratio 1.99, N = 2, locked.

    A non-finite or zero impact frequency (no impact train) gives ratio nan, N = 0, not locked.

    Caveat: the mismatch is at most 0.5 / N, so for N >= 0.5 / tolerance (N >= 10 at 5 %) every
    ratio counts as locked; the test only discriminates for small N. Physically, the comb line
    2 pi N / T falls inside the structure's half-power band when the mismatch is below about the
    damping ratio zeta (0.0025 in the article's scenes); pass ``tolerance=zeta`` for that reading.
    Whether the impacts form a regular train at all is a separate question: check the
    coefficient of variation of the intervals (:class:`ImpactStatistics`).
    """
    if not (math.isfinite(omega_n) and omega_n > 0.0):
        raise ValueError(f"omega_n = {omega_n!r} must be a finite number > 0 (rad/s)")
    if not (math.isfinite(tolerance) and tolerance >= 0.0):
        raise ValueError(f"tolerance = {tolerance!r} must be a finite number >= 0")
    if math.isnan(impact_frequency) or impact_frequency == 0.0:
        return LockIn(ratio=math.nan, n=0, mismatch=math.nan, locked=False, tolerance=tolerance)
    if not (math.isfinite(impact_frequency) and impact_frequency > 0.0):
        raise ValueError(f"impact_frequency = {impact_frequency!r} must be a finite number "
                         ">= 0 (Hz) or nan")
    ratio = omega_n / (2.0 * math.pi * impact_frequency)
    n = max(1, round(ratio))
    mismatch = abs(ratio - n) / n
    return LockIn(ratio=ratio, n=n, mismatch=mismatch, locked=mismatch <= tolerance,
                  tolerance=tolerance)


# Summary ---------------------------------------------------------------------------------------
def _uniform_prefix(t: np.ndarray) -> int:
    """Number of leading samples of ``t`` that are uniformly spaced (a short last interval, as
    :func:`iceimpact.run` appends when t_end is not a multiple of dt, is dropped)."""
    if t.size < 3:
        return t.size
    dt = np.diff(t)
    h = float(np.median(dt))
    if np.all(np.abs(dt[:-1] - h) <= UNIFORM_RTOL * h) and abs(dt[-1] - h) > UNIFORM_RTOL * h:
        return t.size - 1
    return t.size


def summarize_arrays(t: np.ndarray, x: np.ndarray, impacts: np.ndarray, omega_n: float,
                     transient: float = 0.0, sticking: np.ndarray | None = None,
                     sticking_since: float | None = None,
                     tolerance: float = LOCK_IN_TOLERANCE, structure_k: float | None = None,
                     impulse: np.ndarray | None = None) -> dict[str, float]:
    """:func:`summarize` on plain arrays: samples ``t`` (s), ``x`` (m), an impact array as
    accepted by :func:`impact_statistics`, ``omega_n`` (rad/s), optional per-sample sticking
    flags and the start of a final sticking phase (s). Keys and units: :data:`SUMMARY_FIELDS`.
    The design loads (:mod:`iceimpact.studies.loads`) need the stiffness ``structure_k`` (N/m) for
    the k x columns and the per-sample ``impulse`` (N.s) for the contact force; without them those
    columns are nan.
    """
    t, x, window = sample_window(t, x, transient)
    t_start = window_start(t, transient)  # a series may start after t = 0
    t_end = float(t[-1])
    t_w, x_w = t[window], x[window]

    stats = impact_statistics(impacts, t_start=t_start, t_end=t_end)
    # The article's T is the time between impacts, so lock-in uses 1 / mean interval, not the
    # window rate (which a quiet tail after the impacts stopped would lower).
    lock = lock_in(omega_n, stats.frequency, tolerance)

    dom = math.nan
    n_uniform = _uniform_prefix(t_w)
    try:
        spectrum = displacement_spectrum(t_w[:n_uniform], x_w[:n_uniform])
        dom = spectrum.dominant_frequency
    except ValueError:
        pass  # too few or non-uniform samples: no spectrum, dominant frequency undefined

    if sticking is not None:
        stick_w = np.asarray(sticking, dtype=bool).ravel()[window]
        sticking_fraction = float(np.mean(stick_w)) if stick_w.size else math.nan
    else:
        sticking_fraction = math.nan

    out = {
        "t_start_s": t_start,
        "t_end_s": t_end,
        "omega_n_rad_s": float(omega_n),
        "n_impacts": float(stats.count),
        "impact_rate_hz": stats.rate,
        "impact_frequency_hz": stats.frequency,
        "mean_interval_s": stats.mean_interval,
        "std_interval_s": stats.std_interval,
        "cv_interval": stats.cv_interval,
        "mean_impulse_ns": stats.mean_impulse,
        "max_impulse_ns": stats.max_impulse,
        "total_impulse_ns": stats.total_impulse,
        "x_peak_m": float(np.max(np.abs(x_w))),
        "x_mean_m": float(np.mean(x_w)),
        "x_rms_m": float(np.sqrt(np.mean(x_w * x_w))),
        "x_std_m": float(np.std(x_w)),
        "dominant_frequency_hz": float(dom),
        "dominant_over_natural": float(2.0 * math.pi * dom / omega_n),
        "omega_ratio": lock.ratio,
        "nearest_n": float(lock.n),
        "lockin_mismatch": lock.mismatch,
        "locked": 1.0 if lock.locked else 0.0,
        "sticking_fraction": sticking_fraction,
        "sticking_since_s": math.nan if sticking_since is None else float(sticking_since),
    }
    out.update(load_columns(design_loads(t, x, structure_k, impacts=impacts, impulse=impulse,
                                         transient=transient)))
    assert out.keys() == SUMMARY_FIELDS.keys()
    return out


def summarize(result: Any, transient: float = 0.0,
              tolerance: float = LOCK_IN_TOLERANCE) -> dict[str, float]:
    """One flat dict of floats (keys and units in :data:`SUMMARY_FIELDS`) for a run's ``Result``.

    Everything is computed on ``t >= transient`` (s) only: impact statistics (with the window
    ending at the last sample), displacement peak/mean/RMS, the dominant frequency of the Welch
    spectrum of x, and the lock-in measures of :func:`lock_in` for the impact period T = mean
    interval (Section 5 of the article). Undefined entries are nan (fewer than two impacts, a
    structure at rest, too few samples for a spectrum, no sticking phase), and the design
    loads of :mod:`iceimpact.studies.loads` (extremes and damage-equivalent loads of k x, contact
    force, impulse percentile). ``result`` needs ``t``, ``x``, ``impacts`` and
    ``scene.omega_n``; ``sticking``, ``sticking_since``, ``impulse`` and the scene's stiffness
    of k x (:func:`~iceimpact.studies.loads.spring_stiffness`: ``structure.k``, the static
    stiffness at the contact point with the modal structure) are used when present.
    """
    return summarize_arrays(result.t, result.x, result.impacts, result.scene.omega_n,
                            transient=transient, sticking=getattr(result, "sticking", None),
                            sticking_since=getattr(result, "sticking_since", None),
                            tolerance=tolerance,
                            structure_k=spring_stiffness(result.scene),
                            impulse=getattr(result, "impulse", None))
