"""Wall time of a season: the example load-case table (50 cases x 3 repetitions x 600 s) run
by ``iceimpact.seasons.run_season`` with 1 and with N workers, with this tree's core and,
with ``--base``, with a reference commit's, side by side.

The table is examples/season_cases.csv (ice speeds 0.05-1 m/s, floe masses 400-6400 kg,
restitution 0.5 and 1, quadratic drag; made-up but plausible hours, 1200 h of ice per year;
``--write-cases`` regenerates it). Each configuration runs in a fresh process whose
``iceimpact`` is this tree's or the reference's (``git archive`` of ``fmu_src`` into a temporary
folder), the two alternating for each worker count so that both see the same load; CPU time of
all processes is measured too ("cores used" = CPU / wall: how much of the machine the runs
actually got). Each configuration runs once (a season is minutes); the results must be equal
between worker counts and between the two cores. From the simulated hours a 1,000-hour season's
time on the same workers is estimated. Prints a table and writes JSON.

Each process runs the season as ``iceimpact loads`` does: where the core has
``iceimpact.sweep.backends.keep_freed_memory`` (the pool's workers and the command line call
it), it is called first (``keeps_freed_memory`` in the JSON); a core without it runs with the C
library's defaults. To compare the cores with malloc tuned for both, set
``MALLOC_TRIM_THRESHOLD_`` and ``MALLOC_MMAP_THRESHOLD_`` in the environment.

    python benchmarks/season.py                       # 150 runs of 600 s, workers 1 and 2
    python benchmarks/season.py --base f7f01da        # and the same with that commit's core
    python benchmarks/season.py --workers 2 --t-end 60 --out /tmp/season.json   # quick look
    python benchmarks/season.py --write-cases examples/season_cases.csv
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

from tree import ROOT, extract_commit

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


#: One configuration in a fresh process (argv: cases file, t_end, transient, life, workers);
#: JSON on stdout: wall and CPU time (the process and its workers), the runs' digest, the summary.
_WORKER = """
import hashlib, json, resource, sys, time
try:
    from iceimpact.seasons import load_cases, run_season
except ImportError:  # a core from before the seasons package
    from iceimpact.studies.seasons import load_cases, run_season

def cpu():
    own, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime

cases, t_end, transient, life, workers = sys.argv[1], *map(float, sys.argv[2:5]), int(sys.argv[5])
# as the command line (iceimpact loads) runs a season, where the core has it
from iceimpact.sweep import backends
keep = getattr(backends, "keep_freed_memory", None)
kept = bool(keep()) if keep is not None else False
table = load_cases(cases, t_end=t_end, transient=transient)
c0, t0 = cpu(), time.perf_counter()
rows, summary = run_season(table, life, workers=workers, progress=False)
wall, used = time.perf_counter() - t0, cpu() - c0
strip = json.dumps([{k: v for k, v in r.items() if k != "wall_s"} for r in rows])
run_walls = sorted(r["wall_s"] for r in rows)
digest = hashlib.sha256(strip.encode()).hexdigest()
print(json.dumps({"wall_s": wall, "cpu_s": used, "digest": digest, "keeps_freed_memory": kept,
                  "runs": table.n_runs, "cases": len(table.cases), "t_end_s": table.t_end,
                  "dt_s": table.dt, "repetitions": table.cases[0].repetitions,
                  "sum_run_wall_s": sum(run_walls), "longest_run_s": run_walls[-1],
                  "median_run_s": run_walls[len(run_walls) // 2],
                  "failed_runs": sum(r["status"] != "ok" for r in rows),
                  "lifetime": summary["lifetime"],
                  "damage_share_m4": {c["name"]: c["damage_share"]["4"] for c in summary["cases"]}},
                 allow_nan=True))
"""


def season(core: Path, args: argparse.Namespace, workers: int) -> dict:
    """One season in a fresh interpreter whose ``iceimpact`` is the one under ``core``."""
    env = {**os.environ, "PYTHONPATH": str(core)}
    done = subprocess.run([sys.executable, "-c", _WORKER, str(args.cases), repr(args.t_end),
                           repr(args.transient), repr(args.life), str(workers)],
                          capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{core}: {done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=Path, default=CASES)
    parser.add_argument("--t-end", type=float, default=600.0, help="s per run")
    parser.add_argument("--transient", type=float, default=60.0, help="s")
    parser.add_argument("--life", type=float, default=25.0, help="years")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/season.json")
    parser.add_argument("--base", default=None,
                        help="a reference commit, run side by side (e.g. f7f01da)")
    parser.add_argument("--write-cases", type=Path, default=None,
                        help="write the example table to this CSV and stop")
    args = parser.parse_args()
    if args.write_cases is not None:
        write_cases(args.write_cases)
        print(f"-> {args.write_cases}")
        return

    load_start = os.getloadavg()[0]
    cores = {"after": ROOT / "fmu_src"}
    with tempfile.TemporaryDirectory() as tmp:
        if args.base:
            cores = {"before": extract_commit(args.base, Path(tmp)) / "fmu_src", **cores}
        results = []
        for w in args.workers:
            row: dict = {"workers": w}
            for name, core in cores.items():  # (alternating: both see the same load)
                row[name] = season(core, args, w)
                row[name]["cores_used"] = row[name]["cpu_s"] / row[name]["wall_s"]
            results.append(row)
    digests = {r[name]["digest"] for r in results for name in cores}
    assert len(digests) == 1, "results differ between worker counts or cores"
    first = results[0]["after"]
    hours = first["runs"] * first["t_end_s"] / 3600.0  # simulated
    for r in results:
        r["speedup_vs_1_worker"] = results[0]["after"]["wall_s"] / r["after"]["wall_s"]
        r["simulated_h"] = hours
        r["estimate_1000h_wall_s"] = r["after"]["wall_s"] * 1000.0 / hours
        if "before" in r:
            r["ratio_wall"] = r["before"]["wall_s"] / r["after"]["wall_s"]
            r["ratio_cpu"] = r["before"]["cpu_s"] / r["after"]["cpu_s"]
            r["estimate_1000h_wall_s_before"] = r["before"]["wall_s"] * 1000.0 / hours

    print(f"{first['cases']} cases x {first['repetitions']} repetitions = {first['runs']} runs "
          f"of {first['t_end_s']:g} s (dt {first['dt_s']:g} s, {hours:.1f} simulated hours); "
          f"{os.cpu_count()} cores, load average {load_start:.2f} at the start, "
          f"{os.getloadavg()[0]:.2f} at the end; results equal in every configuration")
    print(f"{'core':>7} {'workers':>7} {'wall s':>8} {'cpu s':>8} {'cores used':>10} "
          f"{'longest run s':>14} {'1,000 h, min':>13} {'x before':>9}")
    for r in results:
        for name in cores:
            c = r[name]
            gain = f"{r['ratio_wall']:>8.2f}x" if name == "after" and "before" in r else ""
            print(f"{name:>7} {r['workers']:>7} {c['wall_s']:>8.1f} {c['cpu_s']:>8.1f} "
                  f"{c['cores_used']:>10.2f} {c['longest_run_s']:>14.2f} "
                  f"{c['wall_s'] * 1000.0 / hours / 60.0:>13.1f} {gain:>9}")
    life = first["lifetime"]
    print(f"lifetime ({life['life_years']:g} years, {life['ice_hours']:g} ice hours): 1 Hz DEL "
          + ", ".join(f"m={m} {v:.4g} N" for m, v in life["del_1Hz_N"].items())
          + f"; max k x {life['kx_max_N']:.4g} N ({life['kx_max_case']})")
    top = sorted(first["damage_share_m4"].items(), key=lambda c: -c[1])[:5]
    print("largest shares of the lifetime damage (m = 4): "
          + ", ".join(f"{name} {share:.1%}" for name, share in top))

    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "season", "cases_file": str(args.cases.relative_to(ROOT)
                                                 if args.cases.is_relative_to(ROOT)
                                                 else args.cases),
        "base": args.base, "cases": first["cases"], "runs": first["runs"],
        "t_end_s": first["t_end_s"], "transient_s": args.transient, "dt_s": first["dt_s"],
        "life_years": args.life, "simulated_h": hours,
        "cpu_count": os.cpu_count(), "load_average_1min_start": load_start,
        "load_average_1min_end": os.getloadavg()[0], "python": platform.python_version(),
        "machine": platform.machine(), "results": results,
        "lifetime": first["lifetime"], "damage_share_m4": first["damage_share_m4"],
    }, indent=1, allow_nan=True) + "\n")
    print(f"-> {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}")


if __name__ == "__main__":
    main()
