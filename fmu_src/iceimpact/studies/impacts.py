"""Statistics of an impact train: how many impacts, how often, how regular, how strong (the
impulses ``f_j`` at times ``t_j`` of the article's eq. 39), from a run's impact array or from the
FMU's sampled outputs (:func:`impacts_from_counter`).

Physics-free, plain numpy arrays, SI units; undefined quantities are ``nan``. Used by
:mod:`iceimpact.studies.analysis` (summaries, lock-in) and :mod:`iceimpact.studies.loads` (impact
loads), which is why it is a module of its own: neither imports the other's internals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ImpactStatistics:
    """Statistics of the impacts in a time window; nan marks an undefined quantity.

    Intervals are the differences of consecutive impact times inside the window (so they need
    ``count >= 2``); impulses are those delivered to the structure, ``m (v+ - v-)`` (eq. 12-17).
    """

    count: int              # impacts in the window
    duration: float         # window length, s
    rate: float             # count / duration, 1/s (nan if duration <= 0)
    mean_interval: float    # s (nan if count < 2)
    std_interval: float     # s, population standard deviation, ddof = 0 (nan if count < 2)
    cv_interval: float      # std_interval / mean_interval (nan if count < 2)
    mean_impulse: float     # N.s (nan if count == 0 or impulses unknown)
    max_impulse: float      # N.s (nan if count == 0 or impulses unknown)
    total_impulse: float    # N.s (0 if count == 0, nan if impulses unknown)

    @property
    def frequency(self) -> float:
        """1 / mean_interval, Hz: the impact frequency 1/T (nan if undefined)."""
        if math.isfinite(self.mean_interval) and self.mean_interval > 0.0:
            return 1.0 / self.mean_interval
        return math.nan


def _impact_columns(impacts: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Times and impulses of an impact array: structured (fields t, impulse) or plain times."""
    arr = np.asarray(impacts)
    if arr.dtype.names is not None:
        if "t" not in arr.dtype.names:
            raise ValueError("impacts: a structured array needs a field 't' (impact times, s)")
        times = np.asarray(arr["t"], dtype=float).ravel()
        impulses = (np.asarray(arr["impulse"], dtype=float).ravel()
                    if "impulse" in arr.dtype.names else None)
    else:
        if arr.ndim > 1:
            raise ValueError(f"impacts: expected a 1-D array of times, got shape {arr.shape}")
        times = arr.astype(float).ravel()
        impulses = None
    if times.size and not np.all(np.isfinite(times)):
        raise ValueError("impacts: impact times must be finite")
    if times.size > 1 and np.any(np.diff(times) < 0.0):
        raise ValueError("impacts: impact times must be non-decreasing")
    return times, impulses


def impact_statistics(impacts: np.ndarray, t_start: float = 0.0,
                      t_end: float | None = None) -> ImpactStatistics:
    """Count, rate, interval and impulse statistics of the impacts with ``t_start <= t <= t_end``.

    ``impacts`` is the structured array of :attr:`Result.impacts` (fields ``t`` in s and
    ``impulse`` in N.s; the other fields are ignored), any structured array with those fields
    (e.g. from :func:`impacts_from_counter`), or a plain 1-D array of impact times (then the
    impulse statistics are nan). ``t_end`` defaults to the time of the last impact, so that the
    rate of a regular train starting one period after ``t_start`` is exactly 1/T; pass the end of
    the simulation to count a quiet tail (impacts that stopped) in the rate.

    Undefined quantities are nan: the interval statistics for fewer than two impacts, the
    impulse mean and maximum for none, the rate for an empty window.
    """
    times, impulses = _impact_columns(impacts)
    if not math.isfinite(t_start):
        raise ValueError(f"t_start = {t_start!r} must be finite (s)")
    if t_end is None:
        t_end = float(times[-1]) if times.size and times[-1] >= t_start else t_start
    elif not math.isfinite(t_end) or t_end < t_start:
        raise ValueError(f"t_end = {t_end!r} must be finite and >= t_start = {t_start!r} (s)")
    inside = (times >= t_start) & (times <= t_end)
    t_in = times[inside]
    count = int(t_in.size)
    duration = float(t_end - t_start)
    rate = count / duration if duration > 0.0 else math.nan
    if count >= 2:
        intervals = np.diff(t_in)
        mean_interval = float(np.mean(intervals))
        std_interval = float(np.std(intervals))
        cv_interval = std_interval / mean_interval if mean_interval > 0.0 else math.nan
    else:
        mean_interval = std_interval = cv_interval = math.nan
    if impulses is None:
        mean_impulse = max_impulse = total_impulse = math.nan
    else:
        j_in = impulses[inside]
        total_impulse = float(np.sum(j_in))
        mean_impulse = float(np.mean(j_in)) if count else math.nan
        max_impulse = float(np.max(j_in)) if count else math.nan
    return ImpactStatistics(count=count, duration=duration, rate=rate,
                            mean_interval=mean_interval, std_interval=std_interval,
                            cv_interval=cv_interval, mean_impulse=mean_impulse,
                            max_impulse=max_impulse, total_impulse=total_impulse)


#: dtype of :func:`impacts_from_counter`: time (s), impulse (N.s), impacts sharing the sample.
COUNTER_IMPACT_DTYPE = np.dtype([("t", float), ("impulse", float), ("multiplicity", float)])


def impacts_from_counter(t: np.ndarray, count: np.ndarray, t_last: np.ndarray | None = None,
                         impulse: np.ndarray | None = None) -> np.ndarray:
    """Impacts recovered from sampled outputs: one row per impact, fields ``t``, ``impulse``.

    ``count`` is the cumulative impact counter at the sample times ``t`` (the FMU's
    ``contact.count``); an impact happened in each sample interval where it increases.
    ``t_last`` (``contact.t_last``, s) gives the exact time of the latest of them; without it
    the time is the end of the sample interval. ``impulse`` (``contact.impulse``, N.s) is the
    impulse delivered during each interval (an increase at sample 0 belongs to that sample).

    When k > 1 impacts share one interval (a fast sequence, e.g. a Zeno accumulation), only the
    last time is known: the k - 1 earlier ones are spread evenly between the interval start and
    that time and the interval's impulse is shared equally; ``multiplicity`` records k. The
    interval's impulse also includes any sticking-contact impulse of that interval.
    """
    t = np.asarray(t, dtype=float).ravel()
    count = np.asarray(count, dtype=float).ravel()
    if count.shape != t.shape:
        raise ValueError(f"count: shape {count.shape} differs from t's {t.shape}")
    for name, arr in (("t_last", t_last), ("impulse", impulse)):
        if arr is not None and np.asarray(arr).ravel().shape != t.shape:
            raise ValueError(f"{name}: shape {np.asarray(arr).shape} differs from t's {t.shape}")
    if t.size == 0:
        return np.zeros(0, dtype=COUNTER_IMPACT_DTYPE)
    increments = np.diff(count, prepend=0.0)
    if np.any(increments < 0):
        raise ValueError("count: the impact counter must be non-decreasing")
    rows: list[tuple[float, float, float]] = []
    for i in np.flatnonzero(increments > 0):
        k = int(round(increments[i]))
        t_end_i = float(np.asarray(t_last).ravel()[i]) if t_last is not None else float(t[i])
        t_begin_i = float(t[i - 1]) if i > 0 else min(0.0, t_end_i)
        j = float(np.asarray(impulse).ravel()[i]) / k if impulse is not None else math.nan
        for q in range(k):
            tq = t_begin_i + (t_end_i - t_begin_i) * (q + 1) / k
            rows.append((tq, j, float(k)))
    return np.array(rows, dtype=COUNTER_IMPACT_DTYPE)


# Spectrum --------------------------------------------------------------------------------------
