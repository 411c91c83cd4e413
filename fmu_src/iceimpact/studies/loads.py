"""Design loads of a run: extremes, rainflow fatigue (damage-equivalent loads) and impact loads.

What a structural designer takes from one load case (ISO 19906 and IEC 61400-3 ask for an
extreme load and the fatigue damage for ice), computed from the samples of a run after an
optional transient, SI units throughout (docs/explanation/design-loads.md explains every number):

- the **spring force** ``k x`` (N), the base shear of the single-degree-of-freedom idealisation
  (with the modal structure ``k_c x``, k_c the static stiffness at the contact point: the
  quasi-static equivalent load there, :func:`spring_stiffness`): its maximum and minimum with
  their times (:func:`extremes`), and its rainflow cycles (:func:`rainflow_cycles`, ASTM
  E1049-85 by the ``rainflow`` package) turned into **damage-equivalent loads**
  (:func:`damage_equivalent_load`) for the Wöhler exponents :data:`WOHLER_EXPONENTS`, with the
  two references of NREL's MLife:

  * short-term, at ``f_eq = 1 Hz``: ``DEL = (sum_i n_i S_i^m / (f_eq T))^(1/m)``, T the length of
    the analysed window (s), from the transient or the first sample, whichever is later, to the
    last sample (:func:`window_start`): the range of the 1 Hz sinusoid that does the same damage
    in T;
  * ``N_eq = 1e7`` cycles: ``DEL = (sum_i n_i S_i^m / N_eq)^(1/m)``: the range that, applied 1e7
    times, does the damage of the window (of this one run, not extrapolated to a lifetime);

  ``S_i`` are rainflow ranges (peak to trough, N) and ``n_i`` their counts; half cycles (the
  residue) count 0.5, as MLife's default ``UCMult = 0.5``; no mean-load (Goodman) correction.
- the **contact force** (N), the mean force of the ice on the structure over each sample
  interval, ``impulse / dt`` (:func:`contact_force`): its maximum (it depends on the sampling
  interval: an impact is an impulse, so a shorter interval gives a larger peak) and its mean;
- the **impacts**: count and impulse per impact (mean, maximum, 99th percentile, N.s).

:func:`design_loads` computes all of them from plain arrays into a :class:`Loads`;
:func:`run_loads` does it for a :class:`iceimpact.Result`; :func:`load_columns` flattens it into
the CSV-ready columns of :data:`LOAD_FIELDS` (merged into
:func:`iceimpact.studies.analysis.summarize`).

The ``rainflow`` package is imported only when cycles are counted, so that importing this module
(e.g. from the FMU) does not need it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..compiled import compile_or_none, entry_point, jit
from ..errors import real_number, value_text
from .impacts import impact_statistics

#: Wöhler (S-N curve) exponents of the damage-equivalent loads in the summary: 3, 4, 5 for
#: welded steel details, 10 for composites (blades).
WOHLER_EXPONENTS: tuple[int, ...] = (3, 4, 5, 10)

#: Reference frequency of the short-term damage-equivalent load, Hz (MLife's 1 Hz DEL).
F_EQ = 1.0

#: Reference number of cycles of the second damage-equivalent load (over the analysed window).
N_EQ = 1.0e7

#: Weight of a half cycle (an unclosed cycle of the rainflow residue): MLife's UCMult default.
HALF_CYCLE = 0.5

#: Percentile of the impulse per impact reported besides its mean and maximum.
IMPULSE_PERCENTILE = 99.0


def _del_key(m: float, ref: str) -> str:
    return f"del_m{m:g}_{ref}_N"


#: Columns of :func:`load_columns` (merged into :data:`iceimpact.studies.analysis.SUMMARY_FIELDS`):
#: name -> (unit, meaning). The impact count and the mean and maximum impulse per impact are
#: the summary's ``n_impacts``, ``mean_impulse_ns`` and ``max_impulse_ns`` (same window).
LOAD_FIELDS: dict[str, tuple[str, str]] = {
    "kx_max_N": ("N", "maximum of the spring force k x (base shear) in the window"),
    "kx_max_t_s": ("s", "time of kx_max_N (first sample attaining it)"),
    "kx_min_N": ("N", "minimum of the spring force k x in the window"),
    "kx_min_t_s": ("s", "time of kx_min_N (first sample attaining it)"),
    "kx_mean_N": ("N", "mean of k x over the window's samples"),
    "kx_cycles": ("1", "rainflow cycles of k x in the window (half cycles count 0.5)"),
    **{_del_key(m, "1Hz"): ("N", f"damage-equivalent range of k x, Woehler exponent {m}, "
                                 f"at {F_EQ:g} Hz over the window: "
                                 f"(sum n S^{m} / (f_eq T))^(1/{m})")
       for m in WOHLER_EXPONENTS},
    **{_del_key(m, "1e7"): ("N", f"damage-equivalent range of k x, Woehler exponent {m}, for "
                                 f"{N_EQ:.0e} cycles: (sum n S^{m} / N_eq)^(1/{m})")
       for m in WOHLER_EXPONENTS},
    "contact_force_max_N": ("N", "maximum of the contact force impulse / (sample interval), "
                                 "intervals inside the window (depends on the sampling)"),
    "contact_force_max_t_s": ("s", "end of the sample interval of contact_force_max_N"),
    "contact_force_mean_N": ("N", "impulse on the structure over the window / its duration "
                                  "(impacts and sticking)"),
    "p99_impulse_ns": ("N.s", "99th percentile of the impulse per impact (linear interpolation; "
                              "nan if no impact)"),
}


# Building blocks --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Extremes:
    """Maximum and minimum of a sampled signal and the (first) times they occur."""

    max: float     # signal unit
    t_max: float   # s
    min: float     # signal unit
    t_min: float   # s


def extremes(t: np.ndarray, y: np.ndarray) -> Extremes:
    """Maximum and minimum of the samples ``y`` at times ``t`` (s); the first sample attaining
    each gives its time. The extremes of the samples: a peak between two samples is missed by
    up to ``y'' dt^2 / 8``. All nan for no samples."""
    t = np.asarray(t, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if y.shape != t.shape:
        raise ValueError(f"y: shape {y.shape} differs from t's {t.shape}")
    if y.size == 0:
        return Extremes(math.nan, math.nan, math.nan, math.nan)
    i, j = int(np.argmax(y)), int(np.argmin(y))
    return Extremes(max=float(y[i]), t_max=float(t[i]), min=float(y[j]), t_min=float(t[j]))


@dataclass(frozen=True)
class Cycles:
    """Rainflow cycles: one entry per counted (half) cycle, in the order of counting."""

    ranges: np.ndarray   # peak-to-trough range S_i, signal unit
    means: np.ndarray    # mean of the cycle, signal unit
    counts: np.ndarray   # n_i: 1.0 for a full cycle, the half-cycle weight for a half cycle

    @property
    def total(self) -> float:
        """Number of cycles, half cycles weighted."""
        return float(np.sum(self.counts))


def turning_points(y: np.ndarray) -> np.ndarray:
    """The reversals of ``y`` (first and last samples included, repeated values merged): the
    points rainflow counting uses, as ``rainflow.reversals`` yields them, found with numpy."""
    y = np.asarray(y, dtype=float).ravel()
    if y.size == 0:
        return y
    y = y[np.concatenate(([True], np.diff(y) != 0.0))]
    if y.size <= 2:
        return y
    d = np.diff(y)
    turn = np.flatnonzero(d[:-1] * d[1:] < 0.0) + 1
    return np.concatenate((y[:1], y[turn], y[-1:]))


def rainflow_count(series, ranges, means, counts):
    """``rainflow.extract_cycles`` (the ``rainflow`` package's ASTM E1049-85, section 5.4.4) as
    loops over arrays, for numba: its reversal points of ``series``, then its cycles, in its
    order, into ``ranges`` (|x1 - x2|), ``means`` (0.5 (x1 + x2)) and ``counts`` (1.0 a full
    cycle, 0.5 a half cycle), each at least ``series.size`` long; returns the number of cycles.
    The same operations as the package's, so the same floats."""
    size = series.size
    if size < 2:
        return 0
    points = np.empty(size)  # the reversals, then the stack points[start:end]
    end = 1
    points[0] = series[0]
    x = series[1]
    d_last = x - series[0]
    for index in range(2, size):
        x_next = series[index]
        if x_next == x:
            continue
        d_next = x_next - x
        if d_last * d_next < 0.0:
            points[end] = x
            end += 1
        x = x_next
        d_last = d_next
    if size > 2:  # (the package yields the last point only after a third one)
        points[end] = series[size - 1]
        end += 1
    reversals = end
    cycles = 0
    start = end = 0
    for p in range(reversals):
        points[end] = points[p]  # (end <= p: each reversal read before it is overwritten)
        end += 1
        while end - start >= 3:
            x1, x2, x3 = points[end - 3], points[end - 2], points[end - 1]
            if abs(x3 - x2) < abs(x2 - x1):
                break
            if end - start == 3:  # Y holds the starting point: a half cycle
                ranges[cycles], means[cycles] = abs(x1 - x2), 0.5 * (x1 + x2)
                counts[cycles] = 0.5
                start += 1
            else:  # a full cycle: its peak and valley leave the stack
                ranges[cycles], means[cycles] = abs(x1 - x2), 0.5 * (x1 + x2)
                counts[cycles] = 1.0
                points[end - 3] = x3
                end -= 2
            cycles += 1
    while end - start > 1:  # the residue: half cycles
        x1, x2 = points[start], points[start + 1]
        ranges[cycles], means[cycles], counts[cycles] = abs(x1 - x2), 0.5 * (x1 + x2), 0.5
        cycles += 1
        start += 1
    return cycles


def _compile_count(numba: Any) -> Any:
    f8 = numba.float64[::1]
    return entry_point(jit(numba, numba.int64(f8, f8, f8, f8), rainflow_count))


#: :func:`rainflow_count` compiled where numba is, else None (the ``rainflow`` package counts)
_COUNT = compile_or_none("the rainflow count", _compile_count)


def rainflow_cycles(y: np.ndarray, half: float = HALF_CYCLE) -> Cycles:
    """Rainflow cycles of the signal ``y`` (ASTM E1049-85, section 5.4.4, by the ``rainflow``
    package, or where numba is by :func:`rainflow_count`, its algorithm compiled: the same
    cycles). Each unclosed cycle of the residue and of the start counts ``half`` (default 0.5,
    MLife's ``UCMult``; 1 counts them as full cycles, 0 drops them). Non-finite values raise
    ValueError."""
    y = np.asarray(y, dtype=float).ravel()
    if not np.all(np.isfinite(y)):
        raise ValueError("rainflow_cycles: the signal must be finite")
    if not 0.0 <= half <= 1.0:
        raise ValueError(f"half = {half!r}: expected a weight in [0, 1]")
    points = turning_points(y)
    if _COUNT is not None:
        ranges, means, full = np.empty(points.size), np.empty(points.size), np.empty(points.size)
        count = _COUNT(np.ascontiguousarray(points), ranges, means, full)
        arr = np.stack((ranges[:count], means[:count], full[:count]), axis=1)
    else:
        import rainflow  # only here: the FMU's runtime does not need it

        rows = list(rainflow.extract_cycles(points.tolist()))
        arr = np.array([row[:3] for row in rows], dtype=float).reshape(-1, 3)
    if not arr.size:
        empty = np.zeros(0)
        return Cycles(empty, empty.copy(), empty.copy())
    counts = np.where(arr[:, 2] < 1.0, half, 1.0)
    return Cycles(ranges=arr[:, 0], means=arr[:, 1], counts=counts)


def damage_equivalent_load(cycles: Cycles, m: float, n_eq: float) -> float:
    """``(sum_i n_i S_i^m / n_eq)^(1/m)``: the range (signal unit) that, applied ``n_eq`` times,
    does the Palmgren-Miner damage of ``cycles`` on an S-N curve ``N S^m = const``.

    ``n_eq = f_eq T`` gives the short-term DEL at frequency ``f_eq`` (Hz) over T (s) (MLife's
    1 Hz DEL for f_eq = 1); ``n_eq = 1e7`` the DEL for 1e7 cycles. 0 without cycles; nan when
    ``n_eq`` is not a positive finite number (e.g. a window of zero length).
    """
    if not m > 0.0:
        raise ValueError(f"m = {m!r}: the Woehler exponent must be > 0")
    if not (math.isfinite(n_eq) and n_eq > 0.0):
        return math.nan
    s_max = float(np.max(cycles.ranges)) if cycles.ranges.size else 0.0
    if s_max == 0.0:
        return 0.0
    # scaled by the largest range: no overflow of S^m for large m
    damage = float(np.sum(cycles.counts * (cycles.ranges / s_max) ** m))
    return s_max * (damage / n_eq) ** (1.0 / m)


def contact_force(t: np.ndarray, impulse: np.ndarray) -> np.ndarray:
    """Mean contact force on the structure over each sample interval, N: ``impulse[i] / (t[i] -
    t[i-1])``, with ``impulse[i]`` (N.s) the impulse delivered during ``(t[i-1], t[i]]``
    (:attr:`iceimpact.Result.impulse`, the FMU's ``contact.impulse``); 0 at the first sample.
    An impact is an impulse: its force is spread over the interval, so the peak grows as the
    sampling interval shrinks."""
    t = np.asarray(t, dtype=float).ravel()
    impulse = np.asarray(impulse, dtype=float).ravel()
    if impulse.shape != t.shape:
        raise ValueError(f"impulse: shape {impulse.shape} differs from t's {t.shape}")
    force = np.zeros_like(t)
    if t.size > 1:
        dt = np.diff(t)
        if np.any(dt <= 0.0):
            raise ValueError("t: sample times must be strictly increasing")
        force[1:] = impulse[1:] / dt
    return force


# All loads of a run -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Loads:
    """The design loads of one run over the window ``t_start <= t <= t_end`` (SI units)."""

    t_start: float                 # s
    t_end: float                   # s
    kx: Extremes                   # spring force k x, N (nan if k unknown)
    kx_mean: float                 # N
    cycles: Cycles                 # rainflow cycles of k x, ranges in N
    del_1hz: dict[float, float]    # Woehler exponent -> DEL at F_EQ over the window, N
    del_neq: dict[float, float]    # Woehler exponent -> DEL for N_EQ cycles, N
    contact: Extremes              # contact force impulse / dt, N (nan if impulses unknown)
    contact_mean: float            # N
    n_impacts: int | None         # impacts in the window (None if the impacts are unknown)
    impulse_mean: float            # N.s per impact (nan if none)
    impulse_max: float             # N.s
    impulse_p99: float             # N.s

    @property
    def duration(self) -> float:
        """Length of the window, s."""
        return self.t_end - self.t_start


def window_start(t: np.ndarray, transient: float) -> float:
    """Start of the analysed window of samples ``t`` (s): the transient, or the first sample if
    the series starts later (FMU output from a later start time, a saved slice of a run). The
    window ends at the last sample; its length is the T of the 1 Hz DEL and of the rates, so
    that a series that does not start at t = 0 is not taken as longer than it is."""
    return max(float(transient), float(t[0]))


def sample_window(t: Any, x: Any, transient: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Samples ``t`` (s) and ``x`` as flat float arrays, and the mask of ``t >= transient``.

    Raises ValueError if the shapes differ, there is no sample, or ``transient`` (s) is not a
    finite number >= 0 at or before the last sample.
    """
    t = np.asarray(t, dtype=float).ravel()
    x = np.asarray(x, dtype=float).ravel()
    if x.shape != t.shape:
        raise ValueError(f"x: shape {x.shape} differs from t's {t.shape}")
    if t.size == 0:
        raise ValueError("t: no samples")
    number = real_number(transient)  # Python or numpy; 10**400 is not finite
    if number is None or not (math.isfinite(number) and number >= 0.0):
        raise ValueError(f"transient = {value_text(transient)} must be a finite number >= 0 (s)")
    transient = number
    t_end = float(t[-1])
    if transient > t_end:
        raise ValueError(f"transient = {transient!r} s is beyond the last sample t = {t_end!r} s")
    return t, x, t >= transient


def design_loads(t: np.ndarray, x: np.ndarray, k: float | None, impacts: np.ndarray | None = None,
                 impulse: np.ndarray | None = None, transient: float = 0.0,
                 exponents: tuple[float, ...] = WOHLER_EXPONENTS, f_eq: float = F_EQ,
                 n_eq: float = N_EQ, half: float = HALF_CYCLE) -> Loads:
    """The design loads of samples ``t`` (s), ``x`` (m) of a structure of stiffness ``k`` (N/m)
    over ``t >= transient`` (s).

    ``impacts`` is an impact array as :func:`iceimpact.studies.analysis.impact_statistics` takes it
    (a structured array with fields ``t`` and ``impulse``); ``impulse`` the per-sample impulse
    (N.s, :attr:`iceimpact.Result.impulse`). Missing inputs give nan for what needs them (k:
    the k x loads; impacts: the impact loads; impulse: the contact force). The window of the
    contact force is made of the sample intervals that start at or after ``transient``. The
    window starts at the transient, or at the first sample if the series starts later
    (:func:`window_start`), and ends at the last sample: its length is the T of the 1 Hz DEL. A
    displacement that is not finite gives nan DELs (no exception).
    """
    t, x, window = sample_window(t, x, transient)
    t_start = window_start(t, transient)
    t_end = float(t[-1])
    t_w = t[window]
    duration = t_end - t_start

    nan_extremes = Extremes(math.nan, math.nan, math.nan, math.nan)
    if k is not None and math.isfinite(k):
        kx = k * x[window]
        kx_ext = extremes(t_w, kx)
        kx_mean = float(np.mean(kx))
        if np.all(np.isfinite(kx)):
            cycles = rainflow_cycles(kx, half=half)
            del_1hz = {m: damage_equivalent_load(cycles, m, f_eq * duration) for m in exponents}
            del_neq = {m: damage_equivalent_load(cycles, m, n_eq) for m in exponents}
        else:  # a diverged run: nan loads, not an exception (sweeps write them to CSV)
            cycles = Cycles(np.zeros(0), np.zeros(0), np.zeros(0))
            del_1hz = dict.fromkeys(exponents, math.nan)
            del_neq = dict.fromkeys(exponents, math.nan)
    else:
        kx_ext, kx_mean = nan_extremes, math.nan
        cycles = Cycles(np.zeros(0), np.zeros(0), np.zeros(0))
        del_1hz = dict.fromkeys(exponents, math.nan)
        del_neq = dict.fromkeys(exponents, math.nan)

    contact, contact_mean = nan_extremes, math.nan
    if impulse is not None:
        impulse = np.asarray(impulse, dtype=float).ravel()
        force = contact_force(t, impulse)
        inside = np.flatnonzero(t[:-1] >= transient) + 1  # intervals (t[i-1], t[i]] in window
        if inside.size:
            contact = extremes(t[inside], force[inside])
            contact_mean = float(np.sum(impulse[inside]) / (t_end - t[inside[0] - 1]))

    n_impacts: int | None = None
    j_mean = j_max = j_p99 = math.nan
    if impacts is not None:
        stats = impact_statistics(impacts, t_start=t_start, t_end=t_end)
        n_impacts = stats.count
        arr = np.asarray(impacts)
        if arr.dtype.names is not None and "impulse" in arr.dtype.names and stats.count:
            times = np.asarray(arr["t"], dtype=float)
            j_in = np.asarray(arr["impulse"], dtype=float)[(times >= t_start)
                                                           & (times <= t_end)]
            j_mean, j_max = stats.mean_impulse, stats.max_impulse
            j_p99 = float(np.percentile(j_in, IMPULSE_PERCENTILE))

    return Loads(t_start=t_start, t_end=t_end, kx=kx_ext, kx_mean=kx_mean,
                 cycles=cycles, del_1hz=del_1hz, del_neq=del_neq, contact=contact,
                 contact_mean=contact_mean, n_impacts=n_impacts, impulse_mean=j_mean,
                 impulse_max=j_max, impulse_p99=j_p99)


def spring_stiffness(scene: Any) -> float | None:
    """The stiffness k of a scene's structural load k x (N/m): its static stiffness at the
    contact point, :attr:`iceimpact.Scene.contact_stiffness` (``structure.k`` for the SDOF; for
    the modal structure ``1 / sum(phi_k^2 / k_k)``, a quasi-static equivalent load that carries
    none of the modes' own amplification of member forces). None for an object without one
    (the k x columns are then nan)."""
    return getattr(scene, "contact_stiffness", None)


def spring_force(scene: Any, x: Any) -> np.ndarray:
    """``structure.force`` of samples ``x`` (m) as the FMU reports it: k x with the stiffness
    :func:`spring_stiffness` (N)."""
    k = spring_stiffness(scene)
    x = np.asarray(x, dtype=float)
    return np.zeros_like(x) if k is None else k * x


def run_loads(result: Any, transient: float = 0.0, **options: Any) -> Loads:
    """:func:`design_loads` of a run's :class:`iceimpact.Result` (``t``, ``x``, ``impulse``,
    ``impacts`` and the stiffness :func:`spring_stiffness`); ``options`` go to
    :func:`design_loads`."""
    return design_loads(result.t, result.x, spring_stiffness(result.scene),
                        impacts=result.impacts,
                        impulse=getattr(result, "impulse", None), transient=transient,
                        **options)


def load_columns(loads: Loads) -> dict[str, float]:
    """The columns of :data:`LOAD_FIELDS` (floats) for ``loads`` computed with the default
    exponents and references (a missing exponent gives nan)."""
    out = {
        "kx_max_N": loads.kx.max,
        "kx_max_t_s": loads.kx.t_max,
        "kx_min_N": loads.kx.min,
        "kx_min_t_s": loads.kx.t_min,
        "kx_mean_N": loads.kx_mean,
        "kx_cycles": loads.cycles.total if math.isfinite(loads.kx_mean) else math.nan,
    }
    for m in WOHLER_EXPONENTS:
        out[_del_key(m, "1Hz")] = loads.del_1hz.get(m, math.nan)
    for m in WOHLER_EXPONENTS:
        out[_del_key(m, "1e7")] = loads.del_neq.get(m, math.nan)
    out.update({
        "contact_force_max_N": loads.contact.max,
        "contact_force_max_t_s": loads.contact.t_max,
        "contact_force_mean_N": loads.contact_mean,
        "p99_impulse_ns": loads.impulse_p99,
    })
    out = {key: float(value) for key, value in out.items()}
    assert out.keys() == LOAD_FIELDS.keys()
    return out
