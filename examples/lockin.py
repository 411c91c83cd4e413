"""The article's lock-in case (Figure 13, Section 5) through IceImpact.fmu, analysed for lock-in.

    python build_fmu.py && python examples/lockin.py [--fmu dist/IceImpact.fmu]
        [--stop-time 200] [--out out] [--core] [--window 10]
        [--write-doc docs/explanation/lockin.md]

Scene: quadratic drag (``drag.model = 2``), ice drag area ``ice.A = 2`` m^2, flow ``flow.u = 0.1``
m/s, every other parameter at the Figure 2 default (omega_n = sqrt(k/m) = 25 rad/s, e = 1). The
article reads an impact period T = 0.5 s off Figure 13(b), so 2 pi / T = 12.57 rad/s = omega_n / 2,
and calls it lock-in: omega_n = 2 pi N / T with N = 2.

The FMU runs at a 1 ms communication step; impact times are recovered from the outputs
(``contact.count`` increases, ``contact.t_last`` is the exact time of the latest impact,
``contact.impulse`` the impulse of the step). ``--core`` runs the same scene with
``iceimpact.run`` instead (same solver, no FMI layer). The run is cut into windows; in each the
impact intervals, the lock-in ratio omega_n T / (2 pi) and the dominant frequency of the
structure's displacement are computed with :mod:`iceimpact.studies.analysis`. Writes ``lockin.png``
into ``--out``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from doc_blocks import begin, read_block, write_block

from iceimpact import Scene, run
from iceimpact.studies.analysis import (
    displacement_spectrum,
    impact_statistics,
    impacts_from_counter,
    lock_in,
    summarize_arrays,
)

ROOT = Path(__file__).resolve().parents[1]
STEP = 1e-3  # communication step / sampling interval, s
#: The article's Figure 13 scene, as FMU start values.
START_VALUES = {"drag.model": 2, "ice.A": 2.0, "flow.u": 0.1}
ARTICLE_T = 0.5  # s, impact period read off Figure 13(b) in Section 5
ARTICLE_N = 2


@dataclass
class Record:
    """A run reduced to what the analysis needs (SI units)."""

    source: str
    t: np.ndarray            # sample times, s
    x: np.ndarray            # structure displacement, m
    z: np.ndarray            # ice displacement, m
    impacts: np.ndarray      # structured array with fields t (s), impulse (N.s)
    sticking: np.ndarray     # bool per sample
    sticking_since: float | None
    wall_time: float         # s


def simulate_fmu_case(fmu: Path, stop_time: float) -> Record:
    from fmpy import simulate_fmu

    start = time.perf_counter()
    res = simulate_fmu(str(fmu), start_time=0.0, stop_time=stop_time, output_interval=STEP,
                       start_values=START_VALUES)
    wall = time.perf_counter() - start
    t = res["time"]
    impacts = impacts_from_counter(t, res["contact.count"], res["contact.t_last"],
                                   res["contact.impulse"])
    active = res["contact.active"].astype(bool)
    since = None
    if active[-1]:  # the sticking phase that lasts to the end starts after the last free sample
        free = np.flatnonzero(~active)
        since = float(t[free[-1] + 1]) if free.size else float(t[0])
    return Record("IceImpact.fmu (FMPy)", t, res["structure.x"], res["ice.z"], impacts, active,
                  since, wall)


def simulate_core(stop_time: float) -> Record:
    scene = Scene.from_fmi(START_VALUES)
    start = time.perf_counter()
    res = run(scene, t_end=stop_time, dt=STEP)
    wall = time.perf_counter() - start
    return Record("iceimpact.run", res.t, res.x, res.z, res.impacts, res.sticking,
                  res.sticking_since, wall)


def cluster_starts(times: np.ndarray, gap: float) -> np.ndarray:
    """First impact of each cluster: impacts closer than ``gap`` (s) to the previous one are
    rebounds of the same encounter (at the resolution of the article's plots they are one)."""
    if times.size == 0:
        return times
    new = np.r_[True, np.diff(times) >= gap]
    return times[new]


def window_rows(rec: Record, omega_n: float, width: float) -> list[dict]:
    """Impact and vibration measures in consecutive windows of ``width`` seconds."""
    rows = []
    period = 2 * math.pi / omega_n
    clusters = cluster_starts(rec.impacts["t"], period)
    end = rec.t[-1]
    for a in np.arange(0.0, end - 1e-9, width):
        b = min(a + width, end)
        stats = impact_statistics(rec.impacts, t_start=a, t_end=b)
        cl = impact_statistics(clusters, t_start=a, t_end=b)
        lock = lock_in(omega_n, stats.frequency)
        lock_cl = lock_in(omega_n, cl.frequency)
        m = (rec.t >= a) & (rec.t <= b)
        try:
            dom = displacement_spectrum(rec.t[m], rec.x[m]).dominant_frequency
            dom_z = displacement_spectrum(rec.t[m], rec.z[m]).dominant_frequency
        except ValueError:
            dom = dom_z = math.nan
        rows.append(dict(a=a, b=b, n=stats.count, T=stats.mean_interval, cv=stats.cv_interval,
                         ratio=lock.ratio, N=lock.n, locked=lock.locked, Tc=cl.mean_interval,
                         ratio_c=lock_cl.ratio, N_c=lock_cl.n, locked_c=lock_cl.locked,
                         dom=dom, dom_z=dom_z, xstd=float(np.std(rec.x[m])),
                         stick=float(np.mean(rec.sticking[m]))))
    return rows


def fmt(value: float | None, spec: str = ".3f") -> str:
    """``value`` formatted, or "-" when undefined (nan)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return format(value, spec)


def closest_to_article(rows: list[dict]) -> dict | None:
    """The window whose impact-cluster period is closest to the article's T = 0.5 s."""
    candidates = [r for r in rows if math.isfinite(r["Tc"])]
    return min(candidates, key=lambda r: abs(r["Tc"] - ARTICLE_T)) if candidates else None


def report(rec: Record, scene: Scene, rows: list[dict], stop_time: float) -> None:
    omega_n = scene.omega_n
    omega_c = math.sqrt(scene.structure_k / (scene.structure_m + scene.ice_M))
    two_pi = 2 * math.pi
    whole = summarize_arrays(rec.t, rec.x, rec.impacts, omega_n, sticking=rec.sticking,
                             sticking_since=rec.sticking_since)
    print(f"{rec.source}: quadratic drag, A = 2 m^2, u = 0.1 m/s, {stop_time:g} s at "
          f"{STEP * 1e3:g} ms steps, wall time {rec.wall_time:.1f} s")
    print(f"  omega_n = sqrt(k/m) = {omega_n:.3f} rad/s; lock-in periods T = 2 pi N / omega_n: "
          + ", ".join(f"{2 * math.pi * n / omega_n:.3f} s (N={n})" for n in (1, 2, 3))
          + f"; both bodies moving as one: sqrt(k/(m+M)) = {omega_c:.3f} rad/s")
    print(f"  impacts: {int(whole['n_impacts'])}; sticking contact "
          + (f"from t = {rec.sticking_since:.2f} s to the end" if rec.sticking_since is not None
             else "never"))
    print(f"  whole run: mean interval {whole['mean_interval_s']:.4f} s, cv "
          f"{whole['cv_interval']:.2f} (a periodic train has cv 0); dominant frequency of x "
          f"{fmt(two_pi * whole['dominant_frequency_hz'], '.2f')} rad/s")
    print()
    print(f"  windows of {rows[0]['b'] - rows[0]['a']:g} s; a cluster is a run of impacts less "
          f"than one natural period ({2 * math.pi / omega_n:.3f} s) apart")
    print("   window (s)   all impacts: n   T (s)    cv  wnT/2pi |  clusters: T (s)  wnT/2pi  N "
          "lock | dominant (rad/s): x      z | std x (um) stick")
    for r in rows:
        print(f"  {r['a']:5.0f}-{r['b']:<5.0f} {r['n']:15d} {fmt(r['T'], '7.4f'):>7s} "
              f"{fmt(r['cv'], '5.2f'):>5s} {fmt(r['ratio'], '8.3f'):>8s} | "
              f"{fmt(r['Tc'], '15.3f'):>15s} {fmt(r['ratio_c'], '8.3f'):>8s} {r['N_c']:2d} "
              f"{'yes' if r['locked_c'] else 'no':>4s} | "
              f"{fmt(two_pi * r['dom'], '18.2f'):>18s} {fmt(two_pi * r['dom_z'], '6.2f'):>6s} | "
              f"{r['xstd'] * 1e6:10.3f} {r['stick']:5.2f}")
    print("  (lock: |wnT/2pi - N| / N <= 5 %; for N >= 10 every ratio passes, so the test only "
          "means something for small N)")
    print()
    print(f"  article (Figure 13(b)): T = {ARTICLE_T} s, 2 pi/T = {two_pi / ARTICLE_T:.2f} rad/s,"
          f" omega_n = 25 rad/s, ratio {omega_n * ARTICLE_T / two_pi:.3f}, N = {ARTICLE_N}; "
          "both bodies vibrating at 2 pi/T = omega_n/2, and staying there")
    best = closest_to_article(rows)
    if best is not None:
        Tc = best["Tc"]
        print(f"  this run, closest window {best['a']:.0f}-{best['b']:.0f} s: impact clusters "
              f"every T = {Tc:.3f} s (2 pi/T = {two_pi / Tc:.2f} rad/s), ratio "
              f"{best['ratio_c']:.3f}, N = {best['N_c']}, within 5 %: "
              f"{'yes' if best['locked_c'] else 'no'}; single impacts every "
              f"{fmt(best['T'], '.3f')} s on average (cv {fmt(best['cv'], '.2f')}); dominant "
              f"frequency of x {fmt(two_pi * best['dom'], '.2f')} rad/s, of z "
              f"{fmt(two_pi * best['dom_z'], '.2f')} rad/s")
    small_n = [f"{r['a']:.0f}-{r['b']:.0f} s (N={r['N_c']})" for r in rows
               if r["locked_c"] and r["N_c"] < 10]
    print("  windows meeting omega_n = 2 pi N / T (clusters, N < 10): "
          + (", ".join(small_n) or "none"))
    free_end = rec.sticking_since if rec.sticking_since is not None else rec.t[-1]
    drift = [fmt(r["Tc"], ".2f") for r in rows if r["b"] <= free_end + 1e-9]
    print(f"  cluster period window by window until sticking (s): {' '.join(drift)}")


BEGIN = begin("lockin.py")


def write_doc(path: Path, text: str) -> bool:
    """Replace this script's block of ``path``; True if the file changed."""
    return write_block(path, BEGIN, text)


def generated_block(path: Path) -> str:
    """This script's block currently in ``path``."""
    return read_block(path, BEGIN)


def markdown_table(rec: Record, rows: list[dict]) -> str:
    """The window table of docs/explanation/lockin.md (one row per window) and the run's totals."""
    two_pi = 2 * math.pi
    lines = ["| window (s) | impacts | mean interval (s) | cluster period T (s) | "
             "ωnT/2π (clusters) | N, within 5 % | dominant ω of x (rad/s) | "
             "dominant ω of z (rad/s) | std x (µm) | sticking |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lock = f"{r['N_c']}, {'yes' if r['locked_c'] else 'no'}" if math.isfinite(
            r["ratio_c"]) else "-"
        lines.append(f"| {r['a']:.0f}–{r['b']:.0f} | {r['n']} | {fmt(r['T'], '.4f')} | "
                     f"{fmt(r['Tc'], '.3f')} | {fmt(r['ratio_c'], '.2f')} | {lock} | "
                     f"{fmt(two_pi * r['dom'], '.2f')} | {fmt(two_pi * r['dom_z'], '.2f')} | "
                     f"{r['xstd'] * 1e6:.3f} | {100 * r['stick']:.0f} % |")
    since = ("never" if rec.sticking_since is None
             else f"from t = {rec.sticking_since:.2f} s to the end")
    lines += ["", f"{rec.impacts.size} impacts in all; sticking contact {since}."]
    return "\n".join(lines)






def plot(rec: Record, scene: Scene, rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    omega_n = scene.omega_n
    omega_c = math.sqrt(scene.structure_k / (scene.structure_m + scene.ice_M))
    t, x, z = rec.t, rec.x, rec.z
    times = rec.impacts["t"]
    best = closest_to_article(rows)
    fig, (ax_x, ax_zoom, ax_int, ax_psd) = plt.subplots(4, 1, figsize=(11, 14),
                                                          constrained_layout=True)

    ax_x.plot(t, 1e6 * x, lw=0.4, color="tab:red", label="structure x")
    if rec.sticking.any():
        ax_x.fill_between(t, 0, 1, where=rec.sticking, color="tab:green", alpha=0.15,
                          transform=ax_x.get_xaxis_transform(), label="sticking contact")
    if best is not None:
        ax_x.axvspan(best["a"], best["b"], color="tab:blue", alpha=0.08,
                     label="window closest to T = 0.5 s")
    ax_x.set(xlabel="time (s)", ylabel="x (µm)",
             title=f"{rec.source}: A = 2 m², u = 0.1 m/s, quadratic drag (the article's "
                   "Figure 13 scene)")
    ax_x.legend(loc="upper right")

    if best is not None:
        a, b = best["a"], best["b"]
        m = (t >= a) & (t <= b)
        ax_zoom.plot(t[m], 1e6 * x[m], lw=0.8, color="tab:red", label="structure x")
        ax_zoom.plot(t[m], 1e6 * z[m], lw=0.8, color="tab:blue", label="ice z")
        hits = times[(times >= a) & (times <= b)]
        ax_zoom.plot(hits, 1e6 * np.interp(hits, t, x), "k|", ms=8, label="impacts")
        ax_zoom.set(xlabel="time (s)", ylabel="displacement (µm)",
                    title=f"{a:.0f}-{b:.0f} s: impact clusters every {best['Tc']:.2f} s on "
                          "average")
        ax_zoom.legend(loc="lower right", fontsize=8)

    period = 2 * math.pi / omega_n
    ax_int.semilogy(times[1:], np.diff(times), ".", ms=2, color="0.4",
                    label="interval to the previous impact")
    cl = cluster_starts(times, period)
    ax_int.semilogy(cl[1:], np.diff(cl), "o", ms=3, color="tab:blue", mfc="none",
                    label="interval between impact clusters")
    for n, style in ((1, ":"), (2, "--"), (3, "-.")):
        ax_int.axhline(n * period, color="tab:orange", ls=style, lw=1,
                       label=f"T = 2π·{n}/ωn = {n * period:.3f} s (N = {n})")
    ax_int.axhline(ARTICLE_T, color="k", lw=0.8, alpha=0.6, label="article: T ≈ 0.5 s")
    ax_int.set(xlabel="time (s)", ylabel="interval (s)", xlim=ax_x.get_xlim(),
               title="impact intervals over time")
    ax_int.legend(loc="lower left", fontsize=8, ncol=2)

    free_end = rec.sticking_since if rec.sticking_since is not None else t[-1]
    spans = [(0.0, free_end, "tab:red", f"0-{free_end:.0f} s (all impacts)")]
    if best is not None:
        spans.append((best["a"], best["b"], "tab:blue",
                      f"{best['a']:.0f}-{best['b']:.0f} s (clusters every {best['Tc']:.2f} s)"))
    late = [r for r in rows if r["n"] > 0 and r["b"] <= free_end and r["cv"] < 0.5]
    if late:
        spans.append((late[0]["a"], late[-1]["b"], "tab:green",
                      f"{late[0]['a']:.0f}-{late[-1]['b']:.0f} s (chattering contact)"))
    visible = []
    for a, b, color, label in spans:
        m = (t >= a) & (t <= b)
        spec = displacement_spectrum(t[m], x[m])
        w = 2 * math.pi * spec.f
        ax_psd.semilogy(w, spec.psd, color=color, lw=0.8, label=label)
        visible.append(spec.psd[(w > 0) & (w <= 2.5 * omega_n)])
    for n in (1, 2, 3, 4):
        ax_psd.axvline(omega_n / n, color="tab:orange", ls="--" if n > 1 else "-", lw=0.9)
        ax_psd.annotate("ωn" if n == 1 else f"ωn/{n}", (omega_n / n, 1.0),
                        xycoords=("data", "axes fraction"), xytext=(2, -12),
                        textcoords="offset points", fontsize=8, color="tab:orange")
    ax_psd.axvline(omega_c, color="tab:green", lw=0.9, ls=":")
    ax_psd.annotate("√(k/(m+M))", (omega_c, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(2, -24), textcoords="offset points", fontsize=8, color="tab:green")
    values = np.concatenate(visible)
    values = values[values > 0]
    ax_psd.set(xlim=(0, 2.5 * omega_n), ylim=(values.min() / 3, values.max() * 10),
               xlabel="angular frequency ω (rad/s)", ylabel="PSD of x (m²/Hz)",
               title="Welch spectrum of the structure displacement (ωn and ωn/N marked; the "
                     "article's 2π/T = 12.57 rad/s is ωn/2)")
    ax_psd.legend(loc="lower left", fontsize=8)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", type=Path, default=ROOT / "dist" / "IceImpact.fmu")
    parser.add_argument("--stop-time", type=float, default=200.0,
                        help="s (default 200: the impacts end in sticking contact at ~159 s)")
    parser.add_argument("--out", type=Path, default=ROOT / "out", help="output folder")
    parser.add_argument("--core", action="store_true",
                        help="run iceimpact.run instead of the FMU (for comparison)")
    parser.add_argument("--window", type=float, default=10.0, help="analysis window, s")
    parser.add_argument("--write-doc", type=Path, metavar="MD",
                        help="rewrite the window table of MD (docs/explanation/lockin.md; default "
                             "--stop-time and --window only)")
    args = parser.parse_args(argv)
    if not args.core and not args.fmu.exists():
        print(f"{args.fmu} not found: run `python build_fmu.py` first", file=sys.stderr)
        return 1
    args.out.mkdir(parents=True, exist_ok=True)

    rec = simulate_core(args.stop_time) if args.core else simulate_fmu_case(args.fmu,
                                                                            args.stop_time)
    scene = Scene.from_fmi(START_VALUES)
    rows = window_rows(rec, scene.omega_n, args.window)
    report(rec, scene, rows, args.stop_time)
    png = args.out / "lockin.png"
    plot(rec, scene, rows, png)
    print(f"wrote {png.relative_to(ROOT) if png.is_relative_to(ROOT) else png}")
    if args.write_doc is not None:
        if args.stop_time != 200.0 or args.window != 10.0:
            print("--write-doc writes the default table only: not written", file=sys.stderr)
            return 2
        changed = write_doc(args.write_doc, markdown_table(rec, rows))
        print(f"{args.write_doc}: {'rewritten' if changed else 'unchanged'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
