"""Work-precision study: the three solver methods, their settings, CPU time against error.

    python benchmarks/work_precision.py [--quick] [--out DIR] [--fmu PATH]

For the article's Figure 2, 8, 13 and 18 scenes, every method over a range of settings
(method 2, the article's fixed-step scheme, dt = 1e-2 .. 1e-6 s with both impact tests; method 3,
scipy ``solve_ivp``, RK45 / DOP853 / LSODA / Radau at rtol = 1e-3 .. 1e-12) is run and compared
with method 1, the exact solver:

- **first 10 s**: CPU time of one ``advance_to(10 s)``; error of the first N impact times
  (N = the exact solver's impacts in 10 s, at most 20; a missing impact counts as a 10 s error);
  missed and spurious impacts (one-to-one matching within :data:`MATCH_TIME`); largest penetration
  (negative gap); peak |x| and RMS x (1 ms samples);
- **long horizon** (100 s; ``--quick`` 30 s), where the motion may be chaotic: impact rate,
  dominant frequency of x (``iceimpact.studies.analysis.dominant_frequency``, one Hann periodogram
  of 5 ms samples), RMS x, for a subset of the settings;
- **communication step** h = 1e-4 .. 1e-1 s, per method: through :class:`iceimpact.Simulator`
  and, if the FMU exists (``dist/IceImpact.fmu``, built by ``python build_fmu.py``), through FMPy:
  results (impacts, first impact time, x at the end) and microseconds per step.

An impact counts when its closing speed exceeds :data:`MIN_APPROACH` times the fastest closing
speed of the exact solver in the same scene and horizon: slower touches are the tail of a Zeno
sequence (or rounding), which the exact solver closes with one plastic impact and the other methods
resolve into many micro-impacts, a difference of modelling rather than of accuracy.
Writes ``work_precision.json``, ``work_precision.md`` (tables) and ``work_precision.png``
(log-log error against CPU time) to ``--out``; by default the tables to ``benchmarks/results/``
and the plot to ``docs/img/``, which the documentation shows (``--quick``: all three to
``build/work_precision_quick/``). Costs are CPU times of the process (:data:`CLOCK`), best of
a few repeats for runs under 0.2 s; they depend on the machine, the ratios much less.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from iceimpact import Scene, Simulator
from iceimpact.scene import (
    DETECTION_SIGN,
    DETECTION_WINDOW,
    METHOD_EXACT,
    METHOD_FIXED_STEP,
    METHOD_ODE,
)
from iceimpact.simulator import make_solver
from iceimpact.solvers.ode import ODE_METHODS
from iceimpact.studies.analysis import dominant_frequency

ROOT = Path(__file__).resolve().parents[1]

SCENES = {
    "fig2": ("Figure 2: e = 1, linear drag (defaults)", Scene()),
    "fig8": ("Figure 8: e = 0.5, linear drag", Scene(impact_e=0.5)),
    "fig13": ("Figure 13: A = 2 m2, u = 0.1 m/s, quadratic drag", Scene(ice_A=2.0, drag_model=2)),
    "fig18": ("Figure 18: e = 0.5, quadratic drag", Scene(impact_e=0.5, drag_model=2)),
}

ACCURACY_HORIZON = 10.0     # s
MAX_IMPACTS_COMPARED = 20
SAMPLE_STEP = 1e-3          # s, samples for peak / RMS / penetration
LONG_SAMPLE_STEP = 5e-3     # s, samples for the spectrum
MIN_APPROACH = 1e-3         # impacts count when closing faster than this x the exact's fastest
MATCH_TIME = 0.025          # s, a tenth of the structure's period: same impact if this close
TIMING_TARGET = 0.2         # s: repeat shorter runs and keep the best
#: the clock of every cost: CPU time of this process (single-threaded: the wall time of an idle
#: machine, and much less sensitive than it to other load on a shared one)
CLOCK = time.process_time
FMU_PATH = ROOT / "dist" / "IceImpact.fmu"


# settings --------------------------------------------------------------------------------------

def setting(family: str, label: str, **params) -> dict:
    return {"family": family, "label": label, "params": params}


def accuracy_settings(quick: bool) -> list[dict]:
    dts = [1e-2, 1e-3, 1e-4] if quick else [1e-2, 1e-3, 1e-4, 1e-5, 1e-6]
    rtols = [1e-3, 1e-6, 1e-9] if quick else [1e-3, 1e-6, 1e-9, 1e-12]
    out = [setting("exact", "exact", solver_method=METHOD_EXACT)]
    for detection, name in ((DETECTION_SIGN, "fixed-step, sign"),
                            (DETECTION_WINDOW, "fixed-step, window")):
        for dt in dts:
            out.append(setting(name, f"dt={dt:g}", solver_method=METHOD_FIXED_STEP,
                               solver_dt=dt, solver_detection=detection))
    for code, method in ODE_METHODS.items():
        for rtol in rtols:
            if method in ("Radau", "LSODA") and rtol < 1e-10:
                continue  # minutes per run: implicit methods are not meant for this
            if quick and method in ("Radau", "LSODA") and rtol < 1e-7:
                continue
            out.append(setting(f"ODE {method}", f"rtol={rtol:g}", solver_method=METHOD_ODE,
                               solver_ode_method=code, solver_rtol=rtol))
    return out


def long_settings(quick: bool) -> list[dict]:
    out = [setting("exact", "exact", solver_method=METHOD_EXACT)]
    for dt in ([1e-2, 1e-3] if quick else [1e-2, 1e-3, 1e-4]):
        out.append(setting("fixed-step, sign", f"dt={dt:g}", solver_method=METHOD_FIXED_STEP,
                           solver_dt=dt, solver_detection=DETECTION_SIGN))
    out.append(setting("fixed-step, window", "dt=0.001", solver_method=METHOD_FIXED_STEP,
                       solver_dt=1e-3, solver_detection=DETECTION_WINDOW))
    for method, rtols in (("DOP853", [1e-3, 1e-6, 1e-9]), ("RK45", [1e-6]), ("LSODA", [1e-6]),
                          ("Radau", [1e-6])):
        code = {v: k for k, v in ODE_METHODS.items()}[method]
        for rtol in rtols:
            if quick and rtol < 1e-7:
                continue
            out.append(setting(f"ODE {method}", f"rtol={rtol:g}", solver_method=METHOD_ODE,
                               solver_ode_method=code, solver_rtol=rtol))
    return out


def step_settings() -> list[dict]:
    return [
        setting("exact", "exact", solver_method=METHOD_EXACT),
        setting("fixed-step, sign", "dt=1e-4", solver_method=METHOD_FIXED_STEP, solver_dt=1e-4,
                solver_detection=DETECTION_SIGN),
        setting("ODE DOP853", "rtol=1e-8", solver_method=METHOD_ODE, solver_ode_method=2,
                solver_rtol=1e-8),
    ]


# running ---------------------------------------------------------------------------------------

def cpu_time(scene: Scene, t_end: float) -> float:
    """Best CPU time (s) of one advance_to(t_end), repeated while cheap."""
    best, total = math.inf, 0.0
    while total < TIMING_TARGET and (best == math.inf or best < TIMING_TARGET / 4):
        solver = make_solver(scene)
        start = CLOCK()
        solver.advance_to(t_end, scene.flow_u)
        elapsed = CLOCK() - start
        best, total = min(best, elapsed), total + elapsed
        if total > 5 * TIMING_TARGET:
            break
    return best


def sampled_run(scene: Scene, t_end: float, step: float, min_approach: float = 0.0) -> dict:
    """States every ``step`` up to t_end, the impacts closing faster than ``min_approach`` (m/s),
    the largest closing speed and the largest penetration seen."""
    solver = make_solver(scene)
    n = int(round(t_end / step))
    t = step * np.arange(1, n + 1)
    x, gap = np.empty(n), np.empty(n)
    for i, ti in enumerate(t):
        solver.advance_to(float(ti), scene.flow_u)
        x[i], gap[i] = solver.state.x, solver.state.gap
    impacts = [imp for imp in solver.impacts if imp.approach_speed > min_approach]
    penetration = max(0.0, -float(gap.min()), getattr(solver, "max_penetration", 0.0))
    fastest = max((imp.approach_speed for imp in solver.impacts), default=0.0)
    return {"t": t, "x": x, "impacts": np.array([imp.t for imp in impacts]),
            "penetration": penetration, "fastest": fastest}


def match(reference: np.ndarray, other: np.ndarray, tol: float) -> tuple[int, int]:
    """Missed and spurious impacts: one-to-one matching in time order within ``tol``."""
    i = j = matched = 0
    while i < reference.size and j < other.size:
        d = other[j] - reference[i]
        if abs(d) <= tol:
            matched, i, j = matched + 1, i + 1, j + 1
        elif d < 0.0:
            j += 1
        else:
            i += 1
    return reference.size - matched, other.size - matched


def frequency_of(t: np.ndarray, x: np.ndarray) -> float | None:
    """Dominant frequency (Hz) of x: :func:`iceimpact.studies.analysis.dominant_frequency` with one
    Hann-windowed periodogram of the whole record (``nperseg = x.size``: the finest bins, the
    long runs are stationary); None (JSON null) if x does not move or is not finite."""
    try:
        f = dominant_frequency(t, x, nperseg=x.size)
    except ValueError:  # a diverging run: non-finite displacements
        return None
    return None if math.isnan(f) else f


def exact_self_check(scene: Scene, impacts: list, count: int) -> float:
    """Largest difference between the exact solver's next impact and a DOP853 (rtol 1e-12)
    integration restarted from its post-impact state, over the first ``count`` flights: an upper
    bound on the exact solver's own impact-time error."""
    worst = 0.0
    for a, b in zip(impacts[:count], impacts[1:count + 1], strict=False):
        if a.restitution == 0.0:
            continue  # the bodies stick after a plastic impact: no flight to compare
        start = scene.replace(structure_x0=a.x, structure_v0=a.v_plus, ice_z0=a.x,
                              ice_v0=a.w_plus, solver_method=METHOD_ODE, solver_ode_method=2,
                              solver_rtol=1e-12)
        solver = make_solver(start)
        solver.advance_to(1.5 * (b.t - a.t) + 1e-6, scene.flow_u)
        if solver.impacts:
            worst = max(worst, abs(solver.impacts[0].t - (b.t - a.t)))
    return worst


def rel(a: float | None, b: float | None) -> float | None:
    """Relative error of a against b (None when either is undefined)."""
    if a is None or b is None:
        return None
    return abs(a - b) / abs(b) if b != 0 else (0.0 if a == 0 else None)


def fmt(value: float | None, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def accuracy_study(quick: bool, log) -> dict:
    out = {}
    for key, (title, base) in SCENES.items():
        ref = sampled_run(base, ACCURACY_HORIZON, SAMPLE_STEP)
        min_approach = MIN_APPROACH * ref["fastest"]
        ref = sampled_run(base, ACCURACY_HORIZON, SAMPLE_STEP, min_approach)
        exact_solver = make_solver(base)
        exact_solver.advance_to(ACCURACY_HORIZON, base.flow_u)
        n_cmp = min(MAX_IMPACTS_COMPARED, ref["impacts"].size)
        ref_peak = float(np.max(np.abs(ref["x"])))
        ref_rms = float(np.sqrt(np.mean(ref["x"] ** 2)))
        rows = []
        for s in accuracy_settings(quick):
            scene = base.replace(**s["params"])
            cpu = cpu_time(scene, ACCURACY_HORIZON)
            run = sampled_run(scene, ACCURACY_HORIZON, SAMPLE_STEP, min_approach)
            times = run["impacts"]
            errors = [abs(times[i] - ref["impacts"][i]) if i < times.size else ACCURACY_HORIZON
                      for i in range(n_cmp)]
            missed, spurious = match(ref["impacts"], times, MATCH_TIME)
            peak = float(np.max(np.abs(run["x"])))
            rms = float(np.sqrt(np.mean(run["x"] ** 2)))
            row = {**{k: s[k] for k in ("family", "label")}, "cpu_s": cpu,
                   "impacts": int(times.size), "impact_time_error_s": max(errors, default=0.0),
                   "missed": missed, "spurious": spurious, "penetration_m": run["penetration"],
                   "peak_x_rel_error": rel(peak, ref_peak), "rms_x_rel_error": rel(rms, ref_rms)}
            if s["family"] == "exact":
                row["impact_time_error_s"] = exact_self_check(base, exact_solver.impacts, n_cmp)
                row["note"] = "error: bound from a DOP853 rtol 1e-12 re-integration of each flight"
            rows.append(row)
            log(f"  {key:6s} {s['family']:20s} {s['label']:11s} {cpu * 1e3:9.1f} ms  "
                f"err {row['impact_time_error_s']:.2e} s  impacts {times.size:6d} "
                f"missed {missed:3d} spurious {spurious:6d} pen {run['penetration']:.1e} m")
        out[key] = {"title": title, "horizon_s": ACCURACY_HORIZON, "impacts_compared": n_cmp,
                    "min_approach_m_per_s": min_approach,
                    "exact_impacts": int(ref["impacts"].size), "exact_peak_x_m": ref_peak,
                    "exact_rms_x_m": ref_rms, "rows": rows}
    return out


def long_study(quick: bool, log) -> dict:
    horizon = 30.0 if quick else 200.0
    out = {}
    for key, (title, base) in SCENES.items():
        rows, ref, min_approach = [], None, 0.0
        for s in long_settings(quick):
            scene = base.replace(**s["params"])
            start = CLOCK()
            run = sampled_run(scene, horizon, LONG_SAMPLE_STEP, min_approach)
            if s["family"] == "exact":  # recount with the threshold from its fastest impact
                min_approach = MIN_APPROACH * run["fastest"]
                run = sampled_run(scene, horizon, LONG_SAMPLE_STEP, min_approach)
            cpu = CLOCK() - start
            stats = {"impact_rate_per_s": run["impacts"].size / horizon,
                     "dominant_frequency_hz": frequency_of(run["t"], run["x"]),
                     "rms_x_m": float(np.sqrt(np.mean(run["x"] ** 2)))}
            if ref is None:
                ref = stats
            row = {"family": s["family"], "label": s["label"], "cpu_s": cpu, **stats,
                   "rate_rel_error": rel(stats["impact_rate_per_s"], ref["impact_rate_per_s"]),
                   "frequency_rel_error": rel(stats["dominant_frequency_hz"],
                                              ref["dominant_frequency_hz"]),
                   "rms_rel_error": rel(stats["rms_x_m"], ref["rms_x_m"])}
            rows.append(row)
            log(f"  {key:6s} {s['family']:20s} {s['label']:11s} {cpu:7.2f} s  rate "
                f"{stats['impact_rate_per_s']:9.3f}/s  f "
                f"{fmt(stats['dominant_frequency_hz'], '7.3f')} Hz  rms {stats['rms_x_m']:.3e} m")
        out[key] = {"title": title, "horizon_s": horizon, "rows": rows}
    return out


def step_study(quick: bool, fmu: Path, log) -> dict:
    horizon = 2.0 if quick else 10.0
    steps = [1e-4, 1e-3, 1e-2, 1e-1]
    base = SCENES["fig2"][1]
    rows = []
    for s in step_settings():
        scene = base.replace(**s["params"])
        for h in steps:
            n = int(round(horizon / h))
            sim = Simulator(scene)
            start = CLOCK()
            for k in range(n):
                sim.advance((k + 1) * h - k * h)
            cpu = CLOCK() - start
            imp = [i.t for i in sim.impacts]
            rows.append({"level": "Simulator", "family": s["family"], "label": s["label"],
                         "h_s": h, "steps": n, "us_per_step": cpu / n * 1e6,
                         "impacts": len(imp), "first_impact_s": imp[0] if imp else None,
                         "x_end_m": sim.report.x})
            log(f"  Simulator {s['family']:18s} h={h:g}  {cpu / n * 1e6:8.1f} us/step  "
                f"impacts {len(imp)}  x_end {sim.report.x:.6e}")
    fmu_rows, fmu_note = [], None
    if not fmu.exists():
        fmu_note = f"skipped: {fmu.name} not found (build it with `python build_fmu.py`)"
        log("  FMU level " + fmu_note)
    else:
        from fmpy import read_model_description, simulate_fmu

        names = {v.name for v in read_model_description(str(fmu)).modelVariables}
        for s in step_settings():
            start_values = {name: value for name, value in Scene(**s["params"]).to_fmi().items()
                            if name.startswith("solver.")}
            missing = sorted(set(start_values) - names)
            if missing:
                log(f"  FMU level {s['family']}: skipped, the FMU lacks {', '.join(missing)} "
                    "(rebuild it)")
                continue
            for h in steps:
                stamps: list[float] = []

                def step_finished(t, recorder, stamps=stamps):
                    stamps.append(CLOCK())
                    return True

                res = simulate_fmu(str(fmu), start_time=0.0, stop_time=horizon,
                                   output_interval=h, start_values=start_values,
                                   output=["structure.x", "contact.count", "contact.t_last"],
                                   step_finished=step_finished)
                n = len(res) - 1
                # steps only: from the end of the first doStep to the end of the last one
                cpu = (stamps[-1] - stamps[0]) * n / max(len(stamps) - 1, 1)
                count = int(res["contact.count"][-1])
                t_last = res["contact.t_last"]
                first = float(t_last[np.argmax(t_last >= 0)]) if np.any(t_last >= 0) else None
                fmu_rows.append({"level": "FMU", "family": s["family"], "label": s["label"],
                                 "h_s": h, "steps": n, "us_per_step": cpu / n * 1e6,
                                 "impacts": count, "first_impact_s": first,
                                 "x_end_m": float(res["structure.x"][-1])})
                log(f"  FMU       {s['family']:18s} h={h:g}  {cpu / n * 1e6:8.1f} us/step  "
                    f"impacts {count}  x_end {float(res['structure.x'][-1]):.6e}")
    return {"scene": "fig2", "horizon_s": horizon, "rows": rows + fmu_rows, "fmu_note": fmu_note}


# outputs ---------------------------------------------------------------------------------------

def markdown(data: dict) -> str:
    command = "python benchmarks/work_precision.py" + (" --quick" if data["quick"] else "")
    lines = ["# Work-precision study (generated)", "",
             f"Generated by `{command}`"
             f" on {data['machine']}, {data['date']}. "
             "Conclusions: `docs/explanation/accuracy.md`.", "",
             "## First 10 s: error against the exact solver", "",
             "Impact-time error: largest |t_i - t_i(exact)| over the first N impacts (a missing "
             "impact counts 10 s; for the exact solver, a bound from a DOP853 rtol 1e-12 "
             f"re-integration of each flight). Missed/spurious: matched within {MATCH_TIME} s. "
             "Peak and RMS of x: relative errors.", ""]
    for sc in data["accuracy"].values():
        lines += [f"### {sc['title']}", "",
                  f"Exact solver: {sc['exact_impacts']} impacts in {sc['horizon_s']:g} s "
                  f"(N = {sc['impacts_compared']} compared), peak |x| = "
                  f"{sc['exact_peak_x_m']:.3e} m, RMS x = {sc['exact_rms_x_m']:.3e} m.", "",
                  "| method | setting | CPU (ms) | impact-time error (s) | impacts | missed "
                  "| spurious | penetration (m) | peak x err | RMS x err |",
                  "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in sc["rows"]:
            lines.append(f"| {r['family']} | {r['label']} | {r['cpu_s'] * 1e3:.2f} | "
                         f"{r['impact_time_error_s']:.1e} | {r['impacts']} | {r['missed']} | "
                         f"{r['spurious']} | {r['penetration_m']:.1e} | "
                         f"{r['peak_x_rel_error']:.1e} | {r['rms_x_rel_error']:.1e} |")
        lines.append("")
    lines += ["## Long horizon: statistics", "",
              "Impact rate, dominant frequency of x (Hann periodogram of 5 ms samples) and RMS x, "
              "with their relative errors against the exact solver (CPU time includes the "
              "sampling).", ""]
    for sc in data["long"].values():
        lines += [f"### {sc['title']} ({sc['horizon_s']:g} s)", "",
                  "| method | setting | CPU (s) | impacts/s | err | f (Hz) | err | RMS x (m) "
                  "| err |", "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
        for r in sc["rows"]:
            lines.append(f"| {r['family']} | {r['label']} | {r['cpu_s']:.2f} | "
                         f"{r['impact_rate_per_s']:.3f} | {fmt(r['rate_rel_error'], '.1e')} | "
                         f"{fmt(r['dominant_frequency_hz'], '.3f')} | "
                         f"{fmt(r['frequency_rel_error'], '.1e')} | "
                         f"{r['rms_x_m']:.3e} | {fmt(r['rms_rel_error'], '.1e')} |")
        lines.append("")
    st = data["steps"]
    lines += ["## Communication step", "",
              f"Figure 2 scene, {st['horizon_s']:g} s, per communication step h."
              + (f" FMU level {st['fmu_note']}." if st["fmu_note"] else ""), "",
              "| level | method | setting | h (s) | us/step | impacts | first impact (s) "
              "| x at end (m) |", "|---|---|---|---:|---:|---:|---:|---:|"]
    for r in st["rows"]:
        first = f"{r['first_impact_s']:.9f}" if r["first_impact_s"] is not None else "-"
        lines.append(f"| {r['level']} | {r['family']} | {r['label']} | {r['h_s']:g} | "
                     f"{r['us_per_step']:.1f} | {r['impacts']} | {first} | {r['x_end_m']:.6e} |")
    lines.append("")
    return "\n".join(lines)


def plot(data: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = {"exact": ("k", "*"), "fixed-step, sign": ("tab:red", "o"),
              "fixed-step, window": ("tab:gray", "x"), "ODE RK45": ("tab:blue", "s"),
              "ODE DOP853": ("tab:green", "D"), "ODE LSODA": ("tab:purple", "^"),
              "ODE Radau": ("tab:orange", "v")}
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5), constrained_layout=True)
    for ax, sc in zip(axes.flat, data["accuracy"].values(), strict=False):
        for family, (color, marker) in styles.items():
            rows = [r for r in sc["rows"] if r["family"] == family]
            if not rows:
                continue
            cpu = [r["cpu_s"] for r in rows]
            err = [max(r["impact_time_error_s"], 1e-14) for r in rows]
            ax.loglog(cpu, err, color=color, marker=marker, ms=9 if family == "exact" else 5,
                      ls="-" if family != "exact" else "none", label=family)
            if family == "fixed-step, sign":
                for r, w, e in zip(rows, cpu, err, strict=True):
                    ax.annotate(r["label"], (w, e), fontsize=7, xytext=(4, 2),
                                textcoords="offset points")
        ax.set_title(sc["title"], fontsize=10)
        ax.set_xlabel("CPU time for 10 s of motion (s)")
        ax.set_ylabel(f"error of the first {sc['impacts_compared']} impact times (s)")
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle("Work-precision: error against CPU time (the window runs miss every impact:"
                 " error = 10 s)", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer settings, shorter horizons")
    parser.add_argument("--out", type=Path, default=None,
                        help="output directory (default: benchmarks/results, the plot docs/img)")
    parser.add_argument("--fmu", type=Path, default=FMU_PATH, help="the FMU for the h study")
    args = parser.parse_args(argv)
    out = args.out or (ROOT / ("build/work_precision_quick" if args.quick
                               else "benchmarks/results"))
    img = args.out or (out if args.quick else ROOT / "docs" / "img")
    out.mkdir(parents=True, exist_ok=True)

    def log(msg: str) -> None:
        print(msg, flush=True)

    study_start = time.perf_counter()
    log("first 10 s, every setting:")
    accuracy = accuracy_study(args.quick, log)
    log("long horizon statistics:")
    long = long_study(args.quick, log)
    log("communication step:")
    steps = step_study(args.quick, args.fmu, log)
    data = {"quick": args.quick, "date": datetime.now(UTC).strftime("%Y-%m-%d"),
            "machine": f"{platform.machine()}, Python {platform.python_version()}, "
                       f"numpy {np.__version__}",
            "min_approach_fraction": MIN_APPROACH, "match_time_s": MATCH_TIME,
            "accuracy": accuracy, "long": long, "steps": steps,
            "study_wall_s": None}
    data["study_wall_s"] = time.perf_counter() - study_start
    (out / "work_precision.json").write_text(json.dumps(data, indent=1) + "\n")
    (out / "work_precision.md").write_text(markdown(data))
    plot(data, img / "work_precision.png")
    log(f"wrote {out / 'work_precision.json'}, .md and {img / 'work_precision.png'} in "
        f"{data['study_wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
