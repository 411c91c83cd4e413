"""Throughput of ``iceimpact.sweep``: the same grid with 1 worker and with N workers, side by side.

The grid is the article's Figure 2 scene with the flow speed varied (linearised drag), short runs.
CPU time (all processes) is measured too: "cores used" = CPU time / wall time shows how much of
the machine the sweep actually got when other jobs compete for the cores. The configurations
are timed alternately (1, N, 1, N, ...) so that background load affects them
alike, and the best of the repeats is kept. Prints a table and writes JSON.

    python benchmarks/sweep_speed.py                       # 20 runs x 20 s, workers 1 and 2
    python benchmarks/sweep_speed.py --runs 24 --t-end 30 --workers 1 2 --repeat 5
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import time
from pathlib import Path

import numpy as np

from iceimpact import Scene
from iceimpact.sweep import DEFAULT_DT, sweep

ROOT = Path(__file__).resolve().parents[1]


def cpu_seconds() -> float:
    """CPU time (user + system, s) of this process and its finished (joined) children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def measure(workers: int, grid: dict, t_end: float,
            dt: float) -> tuple[float, float, list[dict]]:
    """Wall time (s) and CPU time (s, all processes) of one sweep (no output file, no progress
    bar), and its rows. The pool's workers are joined when the sweep returns, so their CPU
    time is counted."""
    c0, t0 = cpu_seconds(), time.perf_counter()
    rows = sweep(Scene(), grid, t_end=t_end, dt=dt, workers=workers, progress=False)
    return time.perf_counter() - t0, cpu_seconds() - c0, rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20, help="grid size (flow.u values)")
    parser.add_argument("--t-end", type=float, default=20.0, help="simulated time per run, s")
    parser.add_argument("--dt", type=float, default=DEFAULT_DT, help="sample step, s")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/sweep_speed.json")
    args = parser.parse_args()

    grid = {"flow.u": np.linspace(0.05, 2.0, args.runs).tolist()}
    load_start = os.getloadavg()[0]
    best = {w: float("inf") for w in args.workers}
    cpu = {w: 0.0 for w in args.workers}
    walls = {w: 0.0 for w in args.workers}
    reference = None
    for _ in range(args.repeat):
        for w in args.workers:
            wall, cpu_s, rows = measure(w, grid, args.t_end, args.dt)
            if wall < best[w]:
                best[w], cpu[w], walls[w] = wall, cpu_s, sum(r["wall_s"] for r in rows)
            strip = [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]
            reference = reference or strip
            assert json.dumps(strip) == json.dumps(reference), "results differ between runs"

    base = best[args.workers[0]]
    results = []
    print(f"{args.runs} runs of the Figure 2 scene, flow.u 0.05..2 m/s, t_end {args.t_end:g} s, "
          f"dt {args.dt:g} s; best of {args.repeat}; {os.cpu_count()} cores, "
          f"load average {load_start:.2f} at the start, {os.getloadavg()[0]:.2f} at the end")
    print(f"{'workers':>7} {'wall s':>8} {'runs/s':>8} {'speedup':>8} {'cpu s':>7} "
          f"{'cores used':>10} {'sum of run walls s':>19}")
    for w in args.workers:
        entry = {"workers": w, "wall_s": best[w], "runs_per_s": args.runs / best[w],
                 "speedup": base / best[w], "cpu_s": cpu[w], "cores_used": cpu[w] / best[w],
                 "sum_run_wall_s": walls[w]}
        results.append(entry)
        print(f"{w:>7} {best[w]:>8.3f} {entry['runs_per_s']:>8.2f} {entry['speedup']:>8.2f} "
              f"{cpu[w]:>7.3f} {entry['cores_used']:>10.2f} {walls[w]:>19.3f}")

    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "sweep_speed", "runs": args.runs, "t_end_s": args.t_end, "dt_s": args.dt,
        "grid": "flow.u = linspace(0.05, 2, runs), Figure 2 scene", "repeat": args.repeat,
        "cpu_count": os.cpu_count(), "load_average_1min_start": load_start,
        "load_average_1min_end": os.getloadavg()[0],
        "python": platform.python_version(), "machine": platform.machine(),
        "results": results}, indent=1) + "\n")
    print(f"-> {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}")


if __name__ == "__main__":
    main()
