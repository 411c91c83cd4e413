"""Wall time of a season: the example load-case table (50 cases x 3 repetitions x 600 s) run
by ``iceimpact.studies.seasons.run_season`` with 1 and with N workers.

The table is examples/season_cases.csv (ice speeds 0.05-1 m/s, floe masses 400-6400 kg,
restitution 0.5 and 1, quadratic drag; made-up but plausible hours, 1200 h of ice per year;
``--write-cases`` regenerates it). CPU time of all processes is measured too ("cores used" =
CPU / wall: how much of the machine the runs actually got). Each configuration runs once (a
season is minutes), the results must be equal between them. Prints a table and writes JSON.

    python benchmarks/season.py                       # 150 runs of 600 s, workers 1 and 2
    python benchmarks/season.py --workers 2 --t-end 60 --out /tmp/season.json   # quick look
    python benchmarks/season.py --write-cases examples/season_cases.csv
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import resource
import time
from pathlib import Path

from iceimpact.studies.seasons import load_cases, run_season

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "examples/season_cases.csv"

#: Illustrative site: flow (ice drift) speeds, m/s, floe masses, kg, and restitution, each with
#: its share of the ice time; a case's hours are ICE_HOURS times the product of its shares.
SPEEDS = {0.05: 0.30, 0.1: 0.30, 0.2: 0.22, 0.5: 0.13, 1.0: 0.05}
MASSES = {400.0: 0.30, 800.0: 0.28, 1600.0: 0.22, 3200.0: 0.14, 6400.0: 0.06}
RESTITUTION = {0.5: 0.5, 1.0: 0.5}
ICE_HOURS = 1200.0   # h of ice per year
REPETITIONS = 3


def write_cases(path: Path) -> None:
    """The example table as CSV: 5 speeds x 5 masses x 2 restitutions, quadratic drag."""
    with open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write("# Illustrative ice season (made-up but plausible hours): 50 cases of the "
                 "article's scenes, quadratic drag. Hours per year = 1200 h x shares of speed, "
                 "mass and restitution (benchmarks/season.py). Run: iceimpact loads "
                 "examples/season_cases.csv --t-end 600 --transient 60 --life 25 --out season\n")
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["name", "hours", "repetitions", "drag.model", "flow.u", "ice.M",
                         "impact.e"])
        for u, pu in SPEEDS.items():
            for m, pm in MASSES.items():
                for e, pe in RESTITUTION.items():
                    writer.writerow([f"u={u:g} M={m:g} e={e:g}", round(ICE_HOURS * pu * pm * pe, 3),
                                     REPETITIONS, 2, u, m, e])


def cpu_seconds() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=Path, default=CASES)
    parser.add_argument("--t-end", type=float, default=600.0, help="s per run")
    parser.add_argument("--transient", type=float, default=60.0, help="s")
    parser.add_argument("--life", type=float, default=25.0, help="years")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/season.json")
    parser.add_argument("--write-cases", type=Path, default=None,
                        help="write the example table to this CSV and stop")
    args = parser.parse_args()
    if args.write_cases is not None:
        write_cases(args.write_cases)
        print(f"-> {args.write_cases}")
        return

    table = load_cases(args.cases, t_end=args.t_end, transient=args.transient)
    load_start = os.getloadavg()[0]
    results, reference, summary = [], None, None
    for w in args.workers:
        c0, t0 = cpu_seconds(), time.perf_counter()
        rows, summary = run_season(table, args.life, workers=w, progress=False)
        wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
        strip = json.dumps([{k: v for k, v in r.items() if k != "wall_s"} for r in rows])
        reference = reference or strip
        assert strip == reference, "results differ between worker counts"
        run_walls = sorted(r["wall_s"] for r in rows)
        results.append({"workers": w, "wall_s": wall, "cpu_s": cpu, "cores_used": cpu / wall,
                        "sum_run_wall_s": sum(run_walls), "longest_run_s": run_walls[-1],
                        "median_run_s": run_walls[len(run_walls) // 2],
                        "failed_runs": sum(r["status"] != "ok" for r in rows)})
    base = results[0]["wall_s"]
    for r in results:
        r["speedup"] = base / r["wall_s"]

    print(f"{len(table.cases)} cases x {table.cases[0].repetitions} repetitions = "
          f"{table.n_runs} runs of {table.t_end:g} s (dt {table.dt:g} s); {os.cpu_count()} "
          f"cores, load average {load_start:.2f} at the start, {os.getloadavg()[0]:.2f} at "
          "the end")
    print(f"{'workers':>7} {'wall s':>8} {'speedup':>8} {'cpu s':>8} {'cores used':>10} "
          f"{'sum of runs s':>14} {'longest run s':>14}")
    for r in results:
        print(f"{r['workers']:>7} {r['wall_s']:>8.1f} {r['speedup']:>8.2f} {r['cpu_s']:>8.1f} "
              f"{r['cores_used']:>10.2f} {r['sum_run_wall_s']:>14.1f} {r['longest_run_s']:>14.2f}")
    life = summary["lifetime"]
    print(f"lifetime ({life['life_years']:g} years, {life['ice_hours']:g} ice hours): 1 Hz DEL "
          + ", ".join(f"m={m} {v:.4g} N" for m, v in life["del_1Hz_N"].items())
          + f"; max k x {life['kx_max_N']:.4g} N ({life['kx_max_case']})")
    top = sorted(summary["cases"], key=lambda c: -c["damage_share"]["4"])[:5]
    print("largest shares of the lifetime damage (m = 4): " + ", ".join(
        f"{c['name']} {c['damage_share']['4']:.1%}" for c in top))

    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "season", "cases_file": str(args.cases.relative_to(ROOT)
                                                 if args.cases.is_relative_to(ROOT)
                                                 else args.cases),
        "cases": len(table.cases), "runs": table.n_runs, "t_end_s": table.t_end,
        "transient_s": table.transient, "dt_s": table.dt, "life_years": args.life,
        "cpu_count": os.cpu_count(), "load_average_1min_start": load_start,
        "load_average_1min_end": os.getloadavg()[0], "python": platform.python_version(),
        "machine": platform.machine(), "results": results,
        "lifetime": summary["lifetime"],
        "damage_share_m4": {c["name"]: c["damage_share"]["4"] for c in summary["cases"]},
    }, indent=1, allow_nan=True) + "\n")
    print(f"-> {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}")


if __name__ == "__main__":
    main()
