"""Shared code of the reproduction scripts (``reproduce_linear.py``, ``reproduce_quadratic.py``).

Each figure of Section 4 of the article ("Vibrations due to Flow-Driven Repeated Impacts") is
re-run *through IceImpact.fmu* with FMPy, once with the exact event-driven solver
(``solver.method = 1``) and once with the article's fixed-step scheme (``solver.method = 2``:
eq. 24 or the Euler steps of eq. 34-36 on a grid of ``solver.dt``, impacts tested at the grid
points, the steady-state thresholds (i)-(iii) and pin of eq. 27-29). The fixed-step runs use the
sign change of the gap as impact test (``solver.detection = 2``); some cases also run the literal
tolerance window of eq. 26 (``solver.detection = 1``).

This module holds what both scripts need: the :class:`Case`/:class:`Group` description of a
figure, :class:`FmuRunner` (one FMPy ``simulate_fmu`` call per run, progress bar, one line per
case), impacts recovered from the FMU outputs, the measures the article's text quotes (times at
which the motion dies out, amplitudes, impact rates, frequencies), the side-by-side plots and the
printed tables. SI units throughout; only the printed text uses mm and micrometres
(:func:`mm`, :func:`um`).

The physics of a run comes from the package, not from here: each run carries its
:class:`iceimpact.Scene` (``omega_n`` and the fields), the static force is the drag law's force on
ice at rest (:func:`iceimpact.physics.ice.make_drag`, as the fixed-step pin of eq. 29 computes it),
and the dominant frequency is :func:`iceimpact.studies.analysis.dominant_frequency` (the peak of the
Welch spectrum, refined between bins).
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import json
import math
import re
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from iceimpact import Scene
from iceimpact.physics.ice import make_drag
from iceimpact.scene import SPECS_BY_NAME
from iceimpact.studies import analysis

if TYPE_CHECKING:
    from matplotlib.figure import Figure

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FMU = ROOT / "dist" / "IceImpact.fmu"
DEFAULT_OUT = ROOT / "out" / "reproduction"

#: Communication step of the runs, s. 50 samples per period of the structure (2 pi / omega_n =
#: 0.25 s); a sampled peak of that sine is at most 0.2 % low. Impacts are counted exactly
#: whatever the step (``contact.count``).
STEP = 5e-3
#: Internal step of the fixed-step scheme, s. The article does not state its time step; this is
#: the FMU's default ``solver.dt``.
FIXED_DT = 1e-4
#: Horizon of every case in ``--quick`` mode, s.
QUICK_STOP = 8.0
#: Resolution of the plots written to ``--out``, dots per inch.
PLOT_DPI = 90
#: Resolution and palette size of the copies written to ``--img-dir`` (the figures embedded in
#: docs/explanation/reproduction.md): 80 dpi, 64 colours (lines on white lose nothing visible),
#: 40-150 kB.
IMG_DPI = 80
IMG_COLORS = 64

#: FMU outputs recorded at every communication step.
OUTPUTS = ("structure.x", "structure.v", "ice.z", "ice.v", "contact.impulse", "contact.count",
           "contact.active", "contact.t_last")

#: The solver settings compared: key -> (label, FMU start values). ``solver.dt`` is added by
#: :func:`solver_values`.
SOLVERS: dict[str, tuple[str, dict[str, int]]] = {
    "exact": ("exact (method 1)", {"solver.method": 1}),
    "fixed": ("fixed-step, gap sign (method 2)", {"solver.method": 2, "solver.detection": 2}),
    "window": ("fixed-step, eq. 26 window (method 2)",
               {"solver.method": 2, "solver.detection": 1}),
}


def solver_values(key: str, dt: float = FIXED_DT) -> dict[str, float | int]:
    """FMU start values selecting solver ``key`` (``exact``, ``fixed``, ``window``); dt in s."""
    values: dict[str, float | int] = dict(SOLVERS[key][1])
    if values["solver.method"] == 2:
        values["solver.dt"] = dt
    return values


# Cases and runs -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """One curve of the article: a scene (FMU start values) simulated by several solvers.

    ``params`` are FMU names (``ice.M``, ``impact.e``, ``drag.model``, ``flow.u``...) that differ
    from the Figure 2 scene (the FMU's defaults). ``stop_time`` in s.
    """

    key: str
    figure: str
    label: str
    params: Mapping[str, float | int]
    stop_time: float = 400.0
    solvers: tuple[str, ...] = ("exact", "fixed")
    step: float | None = None    # communication step, s (None: the runner's)


@dataclass
class Run:
    """The FMU outputs of one case and one solver, sampled every communication step."""

    case: Case
    solver: str
    scene: Scene                 # every parameter (FMU defaults + case + solver), SI
    t: np.ndarray                # s
    x: np.ndarray                # structure displacement, m
    v: np.ndarray                # structure velocity, m/s
    z: np.ndarray                # ice displacement, m
    w: np.ndarray                # ice velocity, m/s
    impulse: np.ndarray          # impulse on the structure during each step, N.s
    count: np.ndarray            # impacts since the start
    active: np.ndarray           # bodies stick together (or are pinned by eq. 29)
    t_last: np.ndarray           # time of the latest impact, s (-1 before the first)
    wall: float                  # wall-clock time of the run, s
    cpu: float                   # CPU time of the run (this process), s

    @property
    def impacts(self) -> int:
        """Number of impacts in the whole run (``contact.count`` at the end)."""
        return int(self.count[-1])

    def impact_steps(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Steps holding impacts: (time of the step's last impact (s), impacts in the step,
        impulse on the structure in the step (N.s, impacts plus any sticking contact))."""
        idx = np.flatnonzero(np.diff(self.count) > 0) + 1
        return self.t_last[idx], np.diff(self.count)[idx - 1], self.impulse[idx]


class FmuRunner:
    """Runs cases through IceImpact.fmu with FMPy's ``simulate_fmu``.

    The FMU is extracted once into a temporary folder (removed by :meth:`close`); each run is a
    fresh instance, so runs are independent and deterministic.
    """

    def __init__(self, fmu: Path, step: float = STEP, dt: float = FIXED_DT,
                 quick: bool = False):
        from fmpy import extract, read_model_description

        self.fmu = fmu
        self.step = step
        self.dt = dt
        self.quick = quick
        self.model_description = read_model_description(str(fmu))
        self._tmp = tempfile.mkdtemp(prefix="iceimpact-reproduction-")
        self.unzipdir = extract(str(fmu), unzipdir=self._tmp)
        self.defaults: dict[str, float | int] = {
            v.name: SPECS_BY_NAME[v.name].kind(float(v.start))
            for v in self.model_description.modelVariables
            if v.start is not None and v.causality in ("parameter", "input")}
        self._cache: dict[tuple, Run] = {}

    def close(self) -> None:
        shutil.rmtree(self._tmp, ignore_errors=True)

    def __enter__(self) -> FmuRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def stop_time(self, case: Case) -> float:
        """Horizon of ``case`` in s (shortened to :data:`QUICK_STOP` in quick mode)."""
        return min(case.stop_time, QUICK_STOP) if self.quick else case.stop_time

    def run(self, case: Case, solver: str) -> Run:
        """Simulate ``case`` with ``solver`` from 0 to its stop time; prints one line.

        A scene already run with the same solver, horizon and step (the Figure 2 scene appears
        in several groups) is not run again.
        """
        stop = self.stop_time(case)
        step = case.step or self.step
        start_values = {**case.params, **solver_values(solver, self.dt)}
        key = (tuple(sorted(start_values.items())), stop, step)
        if key in self._cache:
            return dataclasses.replace(self._cache[key], case=case)
        run = self._simulate(case, solver, start_values, stop, step)
        self._cache[key] = run
        return run

    def _simulate(self, case: Case, solver: str, start_values: dict[str, float | int],
                  stop: float, step: float) -> Run:
        from fmpy import simulate_fmu
        from tqdm import tqdm

        n_steps = round(stop / step)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        with tqdm(total=n_steps, unit="step", unit_scale=True, leave=False, mininterval=0.5,
                  desc=f"{case.figure} {case.label} [{solver}]", disable=None) as bar:
            done = 0

            def step_finished(_time: float, _recorder: Any) -> bool:
                nonlocal done
                done += 1
                if done % 2000 == 0:
                    bar.update(done - bar.n)
                return True

            res = simulate_fmu(self.unzipdir, model_description=self.model_description,
                               start_time=0.0, stop_time=stop, output_interval=step,
                               start_values=start_values, output=list(OUTPUTS),
                               step_finished=step_finished)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        scene = Scene.from_fmi({**self.defaults, **start_values})
        run = Run(case=case, solver=solver, scene=scene, t=res["time"],
                  x=res["structure.x"], v=res["structure.v"], z=res["ice.z"], w=res["ice.v"],
                  impulse=res["contact.impulse"], count=res["contact.count"].astype(int),
                  active=res["contact.active"].astype(bool), t_last=res["contact.t_last"],
                  wall=wall, cpu=cpu)
        if abs(run.t[-1] - stop) > 1e-6 * stop:
            raise RuntimeError(f"{case.figure} {case.label} [{solver}]: the FMU stopped at "
                               f"t = {run.t[-1]:g} s instead of {stop:g} s (a discarded step)")
        stick = sticking_since(run)
        print(f"  {case.figure:12s} {case.label:24s} {SOLVERS[solver][0]:38s} {stop:5.0f} s "
              f"{run.impacts:9d} impacts  sticking {fmt(stick, '.2f', 'never'):>7s}  "
              f"{cpu:6.1f} s CPU {wall:6.1f} s wall", flush=True)
        return run


class CoreRunner(FmuRunner):
    """Runs cases in this process, without the FMU: a :class:`iceimpact.simulator.Simulator`
    stepped as IceImpact.fmu steps it under FMPy (one ``Simulator.advance`` per communication
    step, of the length FMPy passes to ``doStep``), so the outputs, and every number measured
    from them, are those of :class:`FmuRunner` without the FMI overhead (a 400 s exact run:
    0.3 s instead of 1.5 s). ``--core`` selects it; ``tests/docs/test_doc_numbers.py`` uses it.
    """

    def __init__(self, step: float = STEP, dt: float = FIXED_DT, quick: bool = False,
                 echo: bool = True):
        self.fmu = None
        self.step = step
        self.dt = dt
        self.quick = quick
        self.echo = echo
        self.defaults = Scene().to_fmi()
        self._cache = {}

    def close(self) -> None:
        pass

    def _simulate(self, case: Case, solver: str, start_values: dict[str, float | int],
                  stop: float, step: float) -> Run:
        from iceimpact.simulator import Simulator

        wall0, cpu0 = time.perf_counter(), time.process_time()
        scene = Scene.from_fmi({**self.defaults, **start_values})
        sim = Simulator(scene, record_impacts=False)
        n_steps = round(stop / step)
        rows = [sim.report]
        t_master = 0.0
        for i in range(1, n_steps + 1):
            t_next = i * step   # FMPy's communication points: start + n * output_interval
            rows.append(sim.advance(t_next - t_master))
            t_master = t_next

        def column(name: str, dtype: type = float) -> np.ndarray:
            return np.array([getattr(r, name) for r in rows], dtype=dtype)

        t = step * np.arange(n_steps + 1)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        run = Run(case=case, solver=solver, scene=scene, t=t, x=column("x"), v=column("v"),
                  z=column("z"), w=column("w"), impulse=column("impulse"),
                  count=column("impact_count", int), active=column("sticking", bool),
                  t_last=column("t_last"), wall=wall, cpu=cpu)
        if self.echo:
            stick = sticking_since(run)
            print(f"  {case.figure:12s} {case.label:24s} {SOLVERS[solver][0]:38s} {stop:5.0f} s "
                  f"{run.impacts:9d} impacts  sticking {fmt(stick, '.2f', 'never'):>7s}  "
                  f"{cpu:6.1f} s CPU {wall:6.1f} s wall (in process)", flush=True)
        return run


# Measures ----------------------------------------------------------------------------------------
def static_force(scene: Scene) -> float:
    """Drag on ice at rest, N: b u (linear drag, eq. 5 and 28) or B u |u| (quadratic, eq. 33),
    from the scene's drag law."""
    return make_drag(scene).force(0.0, scene.flow_u)


def static_deflection(scene: Scene) -> float:
    """x = z = F / k, m: the steady state of eq. 29 (bodies at rest in contact)."""
    return static_force(scene) / scene.structure_k


def amplitude_envelope(run: Run) -> np.ndarray:
    """Vibration amplitude of the structure about its static deflection, m.

    ``sqrt((x - x_s)^2 + (v / omega_n)^2)``: the amplitude of the free oscillation (eq. 9) the
    structure would have from this state; smooth, so not sensitive to the sampling.
    """
    return np.hypot(run.x - static_deflection(run.scene), run.v / run.scene.omega_n)


def decay_time(run: Run, fraction: float) -> float | None:
    """Last time (s) the amplitude envelope is >= ``fraction`` of its maximum over the run.

    After it the structure's vibration stays below that fraction of its peak: the measure used
    for "loses the majority of its momentum after about 54 s" (Figure 8) and the like. None if
    the envelope still reaches the fraction within the last second of the run (a chatter that
    lasts to the end).
    """
    env = amplitude_envelope(run)
    above = np.flatnonzero(env >= fraction * env.max())
    if run.t[-1] - run.t[above[-1]] < 1.0:
        return None
    return float(run.t[above[-1]])


def decay_text(run: Run, fraction: float) -> str:
    """:func:`decay_time` as text: "no motion" if the structure never moved (to 1e-12 m)."""
    if amplitude_envelope(run).max() <= 1e-12:
        return "no motion"
    return secs(decay_time(run, fraction), "not by the end")


def sticking_since(run: Run) -> float | None:
    """Start (s) of the sticking phase (``contact.active``) that lasts to the end, or None.

    Method 1: the bodies move together (the Zeno or chatter sequence was closed). Method 2: the
    steady state of eq. 27-29 was pinned.
    """
    if not run.active[-1]:
        return None
    free = np.flatnonzero(~run.active)
    return float(run.t[free[-1] + 1]) if free.size else 0.0


def window(run: Run, t0: float, t1: float) -> np.ndarray:
    """Boolean mask of the samples with t0 <= t <= t1 (s)."""
    return (run.t >= t0 - 1e-9) & (run.t <= t1 + 1e-9)


def late_window(run: Run, length: float = 20.0) -> tuple[float, float]:
    """The last ``length`` seconds of the run (380-400 s for a 400 s run, as Figure 2(c))."""
    return max(0.0, run.t[-1] - length), float(run.t[-1])


def max_deviation(run: Run, t0: float, t1: float) -> float:
    """Largest |x - x_s| in [t0, t1] (s), m: the vibration of the structure about its static
    deflection x_s (eq. 29)."""
    xs = run.x[window(run, t0, t1)]
    return float(np.max(np.abs(xs - static_deflection(run.scene))))


def impacts_between(run: Run, t0: float, t1: float) -> int:
    """Impacts in (t0, t1], from ``contact.count`` (exact whatever the communication step)."""
    c = np.interp([t0, t1], run.t, run.count)
    return int(round(c[1] - c[0]))


def impact_rate(run: Run, t0: float, t1: float) -> float:
    """Impacts per second in (t0, t1]."""
    return impacts_between(run, t0, t1) / (t1 - t0)


def dominant_frequency(run: Run, t0: float, t1: float) -> float | None:
    """Dominant frequency (Hz) of x in [t0, t1] (s), by
    :func:`iceimpact.studies.analysis.dominant_frequency`: the peak of the Welch spectrum (Hann
    segments of a quarter of the window, 50 % overlap), refined between bins.

    None when the structure is at rest there (RMS of x about its mean at most
    :data:`iceimpact.studies.analysis.REST_AMPLITUDE`) or the window holds too few samples.
    """
    mask = window(run, t0, t1)
    if np.count_nonzero(mask) < analysis.MIN_SAMPLES:
        return None
    f = analysis.dominant_frequency(run.t[mask], run.x[mask])
    return None if math.isnan(f) else f


def mean_impact_interval(run: Run, t0: float, t1: float) -> float | None:
    """(t1 - t0) / number of impacts in (t0, t1], s; None without impacts."""
    n = impacts_between(run, t0, t1)
    return (t1 - t0) / n if n else None


def median_impact_interval(run: Run, t0: float, t1: float) -> float | None:
    """Median time (s) between consecutive steps holding impacts in [t0, t1], or None.

    Impacts closer than one communication step (chatter) count as one.
    """
    times, _, _ = run.impact_steps()
    times = times[(times >= t0) & (times <= t1)]
    return float(np.median(np.diff(times))) if times.size > 2 else None


def peak(run: Run) -> tuple[float, float]:
    """Largest |x| (m) and its time (s)."""
    i = int(np.argmax(np.abs(run.x)))
    return float(abs(run.x[i])), float(run.t[i])


def first_impact(run: Run) -> float | None:
    """Time of the first impact, s (None without impacts)."""
    hit = np.flatnonzero(run.count > 0)
    return float(run.t_last[hit[0]]) if hit.size else None


def pass_through(run: Run, depth: float = 1e-3) -> float | None:
    """First time (s) the ice is more than ``depth`` (m) past the structure (z - x > depth).

    That only happens when the impact test misses an impact: the eq. 26 window.
    """
    past = np.flatnonzero(run.z - run.x > depth)
    return float(run.t[past[0]]) if past.size else None


def mean_impulse_value(run: Run, t0: float, t1: float) -> float | None:
    """Mean impulse per impact on the structure in (t0, t1], N.s (None without impacts); see
    :func:`mean_impulse`."""
    times, n, imp = run.impact_steps()
    sel = (times > t0) & (times <= t1)
    count = int(n[sel].sum())
    return float(imp[sel].sum() / count) if count else None


def drift(run: Run, t: float) -> float | None:
    """Distance (m) the ice has drifted from its start at time t (s); None past the run."""
    if t > run.t[-1] + 1e-9:
        return None
    return float(np.interp(t, run.t, run.z) - run.z[0])


def standard_measures(run: Run) -> dict[str, Any]:
    """The measures every case reports (SI units; None where undefined).

    These are also the numbers docs/explanation/reproduction.md quotes: a number there followed by
    ``<!-- run:SCRIPT.CASE.SOLVER.MEASURE -->`` is this dict's MEASURE for that run
    (:func:`check_doc`).
    """
    x_peak, t_peak = peak(run)
    a, b = late_window(run)
    end = float(run.t[-1])
    e0, e1 = 0.0, min(50.0, end)
    mid = (50.0, 100.0) if end >= 100.0 else None
    stick = sticking_since(run)
    return {
        "impacts": run.impacts,
        "impacts_early": impacts_between(run, e0, e1),
        "impacts_10s": impacts_between(run, 0.0, min(10.0, end)),
        "impacts_before_sticking": (impacts_between(run, 0.0, stick) if stick is not None
                                    else None),
        "mean_impulse_early_Ns": mean_impulse_value(run, e0, e1),
        "mean_interval_early_s": mean_impact_interval(run, e0, e1),
        "median_interval_early_s": median_impact_interval(run, e0, e1),
        "mean_interval_mid_s": mean_impact_interval(run, *mid) if mid else None,
        "dominant_frequency_mid_hz": dominant_frequency(run, *mid) if mid else None,
        "max_deviation_5_50_m": max_deviation(run, min(5.0, end), e1),
        "max_deviation_mid_m": max_deviation(run, *mid) if mid else None,
        "mean_x_late_m": float(run.x[window(run, a, b)].mean()),
        "drift_10_m": drift(run, 10.0),
        "drift_50_m": drift(run, 50.0),
        "drift_200_m": drift(run, 200.0),
        "first_impact_s": first_impact(run),
        "peak_x_m": x_peak,
        "peak_time_s": t_peak,
        "static_deflection_m": static_deflection(run.scene),
        "max_deviation_early_m": max_deviation(run, e0, e1),
        "max_deviation_late_m": max_deviation(run, a, b),
        "impact_rate_early_per_s": impact_rate(run, e0, e1),
        "impact_rate_late_per_s": impact_rate(run, a, b),
        "dominant_frequency_early_hz": dominant_frequency(run, e0, e1),
        "dominant_frequency_late_hz": dominant_frequency(run, a, b),
        "decay_50_s": decay_time(run, 0.5),
        "decay_10_s": decay_time(run, 0.1),
        "sticking_since_s": sticking_since(run),
        "pass_through_s": pass_through(run),
        "early_window_s": [e0, e1],
        "late_window_s": [a, b],
        "wall_s": run.wall,
        "cpu_s": run.cpu,
    }


# Numbers quoted by the docs ----------------------------------------------------------------------
#: A number quoted from a run in a doc: the number, then an HTML comment naming the run and the
#: measure (:func:`standard_measures`), optionally a unit it is printed in:
#: ``15144<!-- run:linear.fig2.exact.impacts -->``,
#: ``0.496<!-- run:linear.fig2.exact.peak_x_m mm -->``.
#: Thousands separators are allowed. The number is checked within half a unit of its last digit.
DOC_ANCHOR = re.compile(r"(-?\d[\d,]*(?:\.\d+)?)\s*<!-- run:([\w.\-]+)(?: (mm|ms|um|%))? -->")
#: Scale of a unit in a doc anchor (the measures are SI).
DOC_UNITS = {None: 1.0, "mm": 1e3, "ms": 1e3, "um": 1e6, "%": 100.0}


def doc_anchors(text: str) -> list[tuple[str, str, str | None]]:
    """(number as printed, key, unit) of every run anchor in ``text``."""
    return [(m.group(1), m.group(2), m.group(3)) for m in DOC_ANCHOR.finditer(text)]


def lookup(values: Mapping[str, Any], key: str) -> Any:
    """``values[SCRIPT][CASE][SOLVER][MEASURE]`` for the key ``SCRIPT.CASE.SOLVER.MEASURE``
    (case keys may hold dots: ``e0.5``); KeyError if there is no such run or measure."""
    script, rest = key.split(".", 1)
    cases = values[script]
    for case in sorted(cases, key=len, reverse=True):
        if rest.startswith(case + "."):
            solver, measure = rest[len(case) + 1:].split(".", 1)
            return cases[case][solver][measure]
    raise KeyError(key)


def check_doc(text: str, values: Mapping[str, Any], scripts: Sequence[str] | None = None
              ) -> tuple[int, list[str]]:
    """Compare every number of ``text`` anchored to a run (:data:`DOC_ANCHOR`) with ``values``
    (script -> case -> solver -> :func:`standard_measures`), within half a unit of the last
    digit printed. Only the anchors of ``scripts`` (all when None) are compared.

    Returns the number of anchors compared and one line per number that differs (or whose run
    or measure does not exist, or is undefined in the run).
    """
    checked, stale = 0, []
    for printed, key, unit in doc_anchors(text):
        if scripts is not None and key.split(".", 1)[0] not in scripts:
            continue
        checked += 1
        try:
            value = lookup(values, key)
        except (KeyError, ValueError):
            stale.append(f"{key}: no such run or measure (doc: {printed})")
            continue
        if value is None:
            stale.append(f"{key}: undefined in the run (doc: {printed})")
            continue
        number = printed.replace(",", "")
        decimals = len(number.split(".")[1]) if "." in number else 0
        got = float(value) * DOC_UNITS[unit]
        if abs(got - float(number)) > 0.5 * 10.0 ** -decimals * (1 + 1e-9) + 1e-12 * abs(got):
            stale.append(f"{key}: doc {printed}{' ' + unit if unit else ''}, "
                         f"run {got:.{decimals}f}")
    return checked, stale


def measure_groups(groups: Sequence[Group], runner: FmuRunner) -> dict[str, dict[str, Any]]:
    """Run every case of ``groups``: case -> solver -> :func:`standard_measures`."""
    out: dict[str, dict[str, Any]] = {}
    for group in groups:
        for case in group.cases:
            out[case.key] = {s: standard_measures(runner.run(case, s)) for s in case.solvers}
    return out


# Formatting and tables ---------------------------------------------------------------------------
def fmt(value: float | int | None, spec: str = ".3g", none: str = "-") -> str:
    """``format(value, spec)``, or ``none`` for None."""
    return none if value is None else format(value, spec)


def mm(value: float) -> str:
    """A length in m, printed in mm."""
    return f"{1e3 * value:.3f}"


def um(value: float) -> str:
    """A length in m, printed in micrometres."""
    return f"{1e6 * value:.2f}"


def secs(value: float | None, none: str = "never") -> str:
    """A time in s to 0.1 s, or ``none``."""
    return fmt(value, ".1f", none)


def early_window(run: Run, length: float = 50.0) -> tuple[float, float]:
    """The first ``length`` seconds of the run (s)."""
    return 0.0, min(length, float(run.t[-1]))


def mean_impulse(run: Run, t0: float, t1: float) -> str:
    """Mean impulse per impact on the structure in (t0, t1], N.s (as text; "-" without impacts).

    The step impulses also hold any sticking-contact impulse of those steps.
    """
    times, n, imp = run.impact_steps()
    sel = (times > t0) & (times <= t1)
    count = int(n[sel].sum())
    return f"{imp[sel].sum() / count:.3g}" if count else "-"


Row = tuple[str, str, dict[str, str]]   # quantity, the article's statement, solver -> value


def print_table(title: str, solvers: Sequence[str], rows: Sequence[Row]) -> None:
    """Print quantity | article | one column per solver, aligned."""
    header = ["quantity", "article"] + [SOLVERS[s][0].split(" (")[0] for s in solvers]
    table = [header] + [[q, a] + [vals.get(s, "") for s in solvers] for q, a, vals in rows]
    widths = [max(len(r[i]) for r in table) for i in range(len(header))]
    print(f"\n{title}")
    for i, r in enumerate(table):
        cells = [r[0].ljust(widths[0]), r[1].ljust(widths[1])]
        cells += [c.rjust(w) for c, w in zip(r[2:], widths[2:], strict=True)]
        print("  " + " | ".join(cells))
        if i == 0:
            print("  " + "-+-".join("-" * w for w in widths))


def per_solver(runs: Mapping[str, Run], func: Callable[[Run], str]) -> dict[str, str]:
    """``{solver: func(run)}`` over the runs of one case."""
    return {s: func(r) for s, r in runs.items()}


# Plots -------------------------------------------------------------------------------------------
def plot_group(title: str, cases: Sequence[Case], runs: Mapping[str, Mapping[str, Run]],
               zoom: float = 20.0) -> Figure:
    """Side-by-side plot of a figure group: one column per solver, three rows per case.

    Rows: x(t) and z(t) over the whole run (mm); the first ``zoom`` seconds of the same; the
    impulse delivered to the structure in each communication step holding an impact (N.s, log
    scale). The sticking (or pinned) phase is shaded green.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    solvers = [s for s in SOLVERS if any(s in runs[c.key] for c in cases)]
    n_rows = 3 * len(cases)
    height = 2.3 * n_rows + 0.9
    fig, axes = plt.subplots(n_rows, len(solvers), figsize=(6.5 * len(solvers), height),
                             squeeze=False)
    # fixed margins (constrained_layout costs seconds with this many axes)
    fig.subplots_adjust(left=0.06, right=0.98, bottom=0.5 / height, top=1.0 - 0.9 / height,
                        hspace=0.55, wspace=0.15)
    for i, case in enumerate(cases):
        for j, solver in enumerate(solvers):
            ax_full, ax_zoom, ax_imp = axes[3 * i:3 * i + 3, j]
            run = runs[case.key].get(solver)
            if run is None:
                for ax in (ax_full, ax_zoom, ax_imp):
                    ax.set_axis_off()
                ax_full.text(0.5, 0.5, "not run", ha="center", transform=ax_full.transAxes)
                continue
            head = f"{case.figure}: {case.label} | {SOLVERS[solver][0]}"
            end = min(zoom, float(run.t[-1]))
            for ax, mask, what in ((ax_full, slice(None), "whole run"),
                                   (ax_zoom, window(run, 0.0, end), f"first {end:g} s")):
                ax.plot(run.t[mask], 1e3 * run.z[mask], lw=0.6, color="tab:blue", label="ice z")
                ax.plot(run.t[mask], 1e3 * run.x[mask], lw=0.5, color="tab:red",
                        label="structure x")
                if run.active.any():
                    ax.fill_between(run.t[mask], 0, 1, where=run.active[mask],
                                    color="tab:green", alpha=0.15, label="sticking / pinned",
                                    transform=ax.get_xaxis_transform())
                ax.set(ylabel="mm", title=f"{head} ({what})")
                ax.title.set_fontsize(8)
            # x sets the scale (the ice's approach from z0 shows in the zoom; an ice that
            # passed through the structure leaves the axes)
            lo, hi = 1e3 * float(run.x.min()), 1e3 * float(run.x.max())
            pad = max(0.3 * (hi - lo), 0.05)
            ax_full.set_ylim(lo - pad, hi + pad)
            ax_zoom.set_ylim(min(lo, 1e3 * float(run.z[0])) - pad, hi + pad)
            ax_zoom.legend(loc="lower right", fontsize=7)
            times, n, imp = run.impact_steps()
            pos = imp > 0
            ax_imp.semilogy(times[pos], imp[pos], ".", ms=2, color="tab:purple")
            if pos.any():  # whole decades, labelled by decade only
                lo_imp, hi_imp = float(imp[pos].min()), float(imp[pos].max())
                ax_imp.set_ylim(10.0 ** math.floor(math.log10(lo_imp)),
                                10.0 ** math.ceil(math.log10(hi_imp * (1 + 1e-9))))
            ax_imp.yaxis.set_minor_formatter(NullFormatter())
            ax_imp.set(ylabel="N.s", xlabel="time (s)", xlim=(0, float(run.t[-1])),
                       title=f"impulse per {1e3 * (run.t[1] - run.t[0]):g} ms step with "
                             f"impacts ({run.impacts} impacts)")
            ax_imp.title.set_fontsize(8)
    fig.suptitle(title)
    return fig


def save_figure(fig: Figure, path: Path, img_dir: Path | None = None) -> list[Path]:
    """Write ``fig`` to ``path`` (:data:`PLOT_DPI`) and, with ``img_dir``, a small copy of the
    same name there (:data:`IMG_DPI`, a :data:`IMG_COLORS`-colour palette); close it.

    Returns the files written.
    """
    import matplotlib.pyplot as plt
    from PIL import Image

    written = [path]
    fig.savefig(path, dpi=PLOT_DPI)
    if img_dir is not None:
        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=IMG_DPI, format="png")
        buffer.seek(0)
        small = Image.open(buffer).convert("RGB").quantize(colors=IMG_COLORS,
                                                          dither=Image.Dither.NONE)
        small.save(img_dir / path.name, optimize=True)
        written.append(img_dir / path.name)
    plt.close(fig)
    return written


# Script driver -----------------------------------------------------------------------------------
@dataclass
class Group:
    """A figure group of the article: its cases, its table of claims, its plot file."""

    key: str                      # "2", "4-6", ...
    figures: tuple[int, ...]      # the article's figure numbers it covers
    title: str
    png: str                      # file name of its plot
    cases: list[Case]
    report: Callable[[Mapping[str, Mapping[str, Run]]], list[Row]]
    plot: Callable[[Group, Mapping[str, Mapping[str, Run]]], Figure] | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def solvers(self) -> list[str]:
        return [s for s in SOLVERS if any(s in c.solvers for c in self.cases)]


def select_groups(groups: Sequence[Group], only: Sequence[str] | None) -> list[Group]:
    """The groups named by ``--only`` (a figure number such as 8, a group key such as 4-6, or
    ``fig8``/``Figure 8``); all groups when ``only`` is empty."""
    if not only:
        return list(groups)
    chosen: list[Group] = []
    for item in only:
        key = re.sub(r"^(fig(ure)?\.?\s*)", "", item.strip().lower())
        match = [g for g in groups if g.key == key
                 or (key.isdigit() and int(key) in g.figures)]
        if not match:
            known = ", ".join(g.key for g in groups)
            raise SystemExit(f"--only {item}: no such figure here (figure groups: {known})")
        chosen += [g for g in match if g not in chosen]
    return [g for g in groups if g in chosen]


def to_jsonable(value: Any) -> Any:
    """Numbers, lists and dicts only (numpy scalars become Python numbers)."""
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def main(name: str, description: str, groups: Sequence[Group],
         argv: list[str] | None = None) -> int:
    """Command line of a reproduction script: run the chosen groups, print, plot, write JSON."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--fmu", type=Path, default=DEFAULT_FMU, help="the FMU to run")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder")
    parser.add_argument("--quick", action="store_true",
                        help=f"every case to {QUICK_STOP:g} s only (a smoke test)")
    parser.add_argument("--only", action="append", metavar="FIG",
                        help="run one figure group only (e.g. 2, 8 or 4-6); repeatable")
    parser.add_argument("--step", type=float, default=STEP,
                        help=f"communication step, s (default {STEP:g})")
    parser.add_argument("--dt", type=float, default=FIXED_DT,
                        help=f"internal step of the fixed-step scheme, s (default {FIXED_DT:g})")
    parser.add_argument("--img-dir", type=Path, default=None, metavar="DIR",
                        help=f"also write a small copy of each figure into DIR ({IMG_DPI} dpi, "
                             f"{IMG_COLORS} colours; docs/img for the figures of "
                             "docs/explanation/reproduction.md)")
    parser.add_argument("--core", action="store_true",
                        help="run in this process (iceimpact.simulator.Simulator stepped as the "
                             "FMU steps it) instead of through the FMU: the same numbers, faster")
    parser.add_argument("--check-doc", type=Path, action="append", metavar="MD",
                        help="compare the numbers MD quotes from these runs (marked "
                             "<!-- run:... -->) with the runs; exit status 3 if any differs "
                             "(e.g. docs/explanation/reproduction.md; repeatable)")
    args = parser.parse_args(argv)
    if not args.core and not args.fmu.exists():
        print(f"{args.fmu} not found: run `python build_fmu.py` first", file=sys.stderr)
        return 1
    chosen = select_groups(groups, args.only)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.img_dir is not None:
        args.img_dir.mkdir(parents=True, exist_ok=True)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    summary: dict[str, Any] = {"script": name, "quick": args.quick, "step_s": args.step,
                               "fixed_dt_s": args.dt, "groups": {}}
    runner_type = (CoreRunner if args.core
                   else lambda **kw: FmuRunner(args.fmu, **kw))  # type: ignore[misc]
    with runner_type(step=args.step, dt=args.dt, quick=args.quick) as runner:
        for group in chosen:
            print(f"\n== Figure(s) {group.key}: {group.title}", flush=True)
            runs: dict[str, dict[str, Run]] = {}
            for case in group.cases:
                runs[case.key] = {s: runner.run(case, s) for s in case.solvers}
            rows = group.report(runs)
            print_table(f"Figure(s) {group.key}: the article against the FMU "
                        f"({'quick mode, ' if args.quick else ''}communication step "
                        f"{args.step * 1e3:g} ms, fixed-step dt = {args.dt:g} s)",
                        group.solvers, rows)
            for note in group.notes:
                print(f"  note: {note}")
            if group.plot is not None:
                fig = group.plot(group, runs)
            else:
                fig = plot_group(f"Figure(s) {group.key}: {group.title}", group.cases, runs)
            written = save_figure(fig, args.out / group.png, args.img_dir)
            print(f"  wrote {' and '.join(str(p) for p in written)}")
            summary["groups"][group.key] = {
                "title": group.title,
                "table": [{"quantity": q, "article": a, **vals} for q, a, vals in rows],
                "cases": {c.key: {"figure": c.figure, "label": c.label, "params": dict(c.params),
                                  "stop_time_s": runner.stop_time(c),
                                  "runs": {s: standard_measures(r)
                                           for s, r in runs[c.key].items()}}
                          for c in group.cases},
            }
    summary["wall_s"] = time.perf_counter() - wall0
    summary["cpu_s"] = time.process_time() - cpu0
    suffix = "_only_" + "_".join(g.key for g in chosen) if args.only else ""
    if args.dt != FIXED_DT:
        suffix += f"_dt{args.dt:g}"
    if args.step != STEP:
        suffix += f"_step{args.step:g}"
    json_path = args.out / f"{name}{'_quick' if args.quick else ''}{suffix}.json"
    json_path.write_text(json.dumps(to_jsonable(summary), indent=1))
    print(f"\nwrote {json_path}; total {summary['cpu_s']:.0f} s CPU, "
          f"{summary['wall_s']:.0f} s wall")
    status = 0
    if args.check_doc:
        if args.quick or args.only or args.dt != FIXED_DT or args.step != STEP:
            print("--check-doc compares the full default runs (no --quick, --only, --dt, "
                  "--step): not checked", file=sys.stderr)
            return 2
        values = {name: {key: case["runs"] for group in summary["groups"].values()
                         for key, case in group["cases"].items()}}
        for doc in args.check_doc:
            checked, stale = check_doc(doc.read_text(), values, scripts=[name])
            print(f"{doc}: {checked} numbers from the {name} runs compared, {len(stale)} differ")
            for line in stale:
                print(f"  {line}")
            status = status or (3 if stale else 0)
    return status
