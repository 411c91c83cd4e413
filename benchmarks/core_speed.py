"""Speed of the exact solver, before and after: a reference commit and this tree, side by side.

For each scene and run length (10 s, 100 s, 1,000 s by default) ``iceimpact.run(scene, t_end,
dt=1e-2)`` is timed in a fresh subprocess, once with the core of a reference commit (``--base``,
extracted with ``git archive`` into a temporary directory) and once with this tree's, alternating
the two over ``--rounds`` rounds so that both see the same machine load; the best round counts.
Costs are CPU time of the run in its process (less sensitive than wall-clock time to other load
on the machine; the wall-clock times are in the JSON too). The table gives per-impact and
per-simulated-second costs, the before/after ratio, the impact
counts and how far the first 10 impact times moved. Writes ``benchmarks/results/core_speed.json``
and ``core_speed.md``.

    python benchmarks/core_speed.py                 # 10, 100, 1000 s, 2 rounds (~10 min)
    python benchmarks/core_speed.py --quick         # 10 and 100 s, 1 round
    python benchmarks/core_speed.py --spread        # + the reference's own impact-count spread
    python benchmarks/core_speed.py --vs-ode        # + the exact solver vs solve_ivp with events
    python benchmarks/core_speed.py --steps         # only the stepping costs (below), ~1 min
    python benchmarks/core_speed.py --warm 5        # each process: an untimed run, best of 5

``--warm N`` times what a sweep or a co-simulation that runs many scenes in one process sees:
the first run of a process pays for lazy imports and numba's loading of its cached machine code
(a few milliseconds, most of a 30 s run); without it the first run is timed.

``--steps`` times, before and after, what docs/accuracy.md quotes for method 1: one
``Simulator.advance_to(10 s)`` for the Figure 2, 8, 13 and 18 scenes, and the cost of one
``Simulator.advance`` step at h = 1e-4 and 1e-1 s over 10 s of Figure 2; it writes
``core_speed_steps.json`` and ``.md``.

``--spread`` runs both the reference and this tree again, for every scene and run length, with
the ice's start position moved by 0 to 5e-15 m (``--move``; ``--members`` runs, evenly spaced;
6 by default, 1e-15 m apart): the motion of these scenes is sensitive, and the spread of the
impact counts it gives is what rounding alone does to them (a changed root finder moves the
impact times by rounding, and these moves grow by a factor of 2-5 per impact). The table then
gives, next to the counts, each ensemble's mean, standard deviation and range, and whether
"after" lies within the reference's own spread: its count within the reference ensemble's
range, and the two ensembles' means within 2 standard errors of each other. Where the
reference's own range exceeds 2 % of its mean, no code can keep the counts within 2 % of the
reference's single run, and the ensembles are the comparison that can fail
(docs/accuracy.md, Impact counts and rounding).

    python benchmarks/core_speed.py --spread --members 24 --rounds 1 \
        --out benchmarks/results/core_speed_spread.json     # ~10 min of CPU
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

from tree import ROOT, extract_commit, load

RESULTS = ROOT / "benchmarks" / "results"
DT = 1e-2  # s, run()'s sampling step

#: name: (Scene fields, what it is)
SCENES: dict[str, tuple[dict, str]] = {
    "figure2": ({}, "Figure 2: linear drag, e = 1 (Scene() defaults)"),
    "quadratic_A2": ({"drag_model": 2, "ice_A": 2.0}, "quadratic drag, ice.A = 2 m2"),
    "heavy_floe": ({"ice_M": 6400.0, "flow_u": 2.0},
                   "heavy floe, M = 6400 kg, u = 2 m/s, linear drag"),
    "heavy_floe_quadratic": ({"ice_M": 6400.0, "flow_u": 2.0, "drag_model": 2},
                             "heavy floe, M = 6400 kg, u = 2 m/s, quadratic drag"),
    "figure18": ({"drag_model": 2, "impact_e": 0.5},
                 "Figure 18: quadratic drag, e = 0.5 (mostly quadratic sticking)"),
    "morison_quadratic": ({"structure_Cd": 1.0, "structure_A": 2.0, "drag_model": 2,
                           "ice_A": 2.0},
                          "quadratic Morison drag on the pile (Cd = 1, A = 2 m2), quadratic "
                          "drag, ice.A = 2 m2"),
}

#: What one subprocess runs: the scene over t_end, timed; JSON on stdout.
_WORKER = """
import json, sys, time
import_cpu = time.process_time()
from iceimpact import Scene, run
import_cpu = time.process_time() - import_cpu
import importlib
compiled = False
for where in ("iceimpact.solvers.search.flight_search", "iceimpact.solvers.flight_search"):
    try:  # the compiled flight search (numba, the fast extra) is on (its module moved once)
        compiled = importlib.import_module(where).COMPILED is not None
        break
    except ImportError:  # (a tree without it)
        continue
fields, t_end, dt = json.loads(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
warm = int(sys.argv[4])
scene = Scene(**fields)
if warm:  # a process that has run before: the first run untimed, the best of `warm` timed
    run(scene, t_end, dt=dt)
cpu = wall = float("inf")
for _ in range(max(warm, 1)):
    start, begun = time.perf_counter(), time.process_time()
    result = run(scene, t_end, dt=dt)
    cpu, wall = min(cpu, time.process_time() - begun), min(wall, time.perf_counter() - start)
print(json.dumps({"cpu_s": cpu, "wall_s": wall, "impacts": int(len(result.impacts)),
                  "first10": result.impacts["t"][:10].tolist(),
                  "sticking_fraction": float(result.sticking.mean()),
                  "compiled": compiled, "import_cpu_s": import_cpu}))
"""


#: The work-precision study's scenes (benchmarks/work_precision.py), for --steps.
STEP_SCENES: dict[str, dict] = {
    "fig2": {}, "fig8": {"impact_e": 0.5}, "fig13": {"ice_A": 2.0, "drag_model": 2},
    "fig18": {"impact_e": 0.5, "drag_model": 2},
}

#: --steps: the first 10 s in one advance_to, and Simulator.advance at two step sizes (CPU time,
#: best of 5).
_STEP_WORKER = """
import json, sys, time
from iceimpact import Scene, Simulator
scenes, steps = json.loads(sys.argv[1]), json.loads(sys.argv[2])

def best(fn, repeat=5):
    out = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        fn()
        out = min(out, time.process_time() - start)
    return out

result = {"first_10s_ms": {name: 1e3 * best(lambda: Simulator(Scene(**f)).advance_to(10.0))
                           for name, f in scenes.items()}, "step_us": {}}
for h in steps:
    n = round(10.0 / h)

    def stepped():
        sim = Simulator(Scene())
        for _ in range(n):
            sim.advance(h)
    result["step_us"][repr(h)] = 1e6 * best(stepped, 3) / n
print(json.dumps(result))
"""


def step_costs(cores: dict[str, Path], rounds: int) -> dict:
    """--steps: the stepping costs before and after, best of the interleaved rounds."""
    runs: dict[str, list[dict]] = {name: [] for name in cores}
    for _ in range(rounds):
        for name, core in cores.items():
            done = subprocess.run([sys.executable, "-c", _STEP_WORKER, json.dumps(STEP_SCENES),
                                   json.dumps([1e-4, 1e-1])], capture_output=True, text=True,
                                  env={"PYTHONPATH": str(core), "PATH": "/usr/bin:/bin"},
                                  check=True)
            runs[name].append(json.loads(done.stdout.strip().splitlines()[-1]))
    out = {}
    for name, rs in runs.items():
        out[name] = {kind: {key: min(r[kind][key] for r in rs) for key in rs[0][kind]}
                     for kind in ("first_10s_ms", "step_us")}
    return out


#: --pure: the environment of every run (the compiled flight search off, in a reference commit
#: that has one too)
PURE_ENV: dict[str, str] = {}
#: --warm N: each process runs the scene once untimed, then N times, the best kept (0: one cold
#: run, the first of its process)
WARM = {"runs": 0}


def measure(core: Path, fields: dict, t_end: float) -> dict:
    """One timed run in a fresh interpreter whose ``iceimpact`` is the one under ``core``."""
    env = {"PYTHONPATH": str(core), "PATH": "/usr/bin:/bin", **PURE_ENV}
    done = subprocess.run([sys.executable, "-c", _WORKER, json.dumps(fields), repr(t_end),
                           repr(DT), str(WARM["runs"])], capture_output=True, text=True,
                          env=env, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{core}: {done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def compare(cores: dict[str, Path], fields: dict, t_end: float, rounds: int) -> dict:
    """Interleaved rounds (reference, then this tree); the best wall time of each."""
    runs: dict[str, list[dict]] = {name: [] for name in cores}
    for _ in range(rounds):
        for name, core in cores.items():
            runs[name].append(measure(core, fields, t_end))
    best = {name: min(rs, key=lambda r: r["cpu_s"]) for name, rs in runs.items()}
    before, after = best["before"], best["after"]
    n = min(len(before["first10"]), len(after["first10"]))
    drift = max((abs(a - b) for a, b in zip(before["first10"][:n], after["first10"][:n],
                                            strict=True)), default=0.0)
    row = {"t_end_s": t_end, "ratio": before["cpu_s"] / after["cpu_s"],
           "first10_max_shift_s": drift,
           "impact_count_change": (after["impacts"] - before["impacts"]) / before["impacts"]
           if before["impacts"] else 0.0}
    for name, r in best.items():
        row[name] = {"cpu_s": r["cpu_s"], "wall_s": r["wall_s"], "impacts": r["impacts"],
                     "us_per_impact": 1e6 * r["cpu_s"] / r["impacts"] if r["impacts"] else None,
                     "ms_per_simulated_s": 1e3 * r["cpu_s"] / t_end,
                     "sticking_fraction": r["sticking_fraction"],
                     "compiled": r["compiled"], "import_cpu_s": r["import_cpu_s"]}
    row["ratio_per_impact"] = (row["before"]["us_per_impact"] / row["after"]["us_per_impact"]
                               if row["after"]["us_per_impact"] else None)
    return row


#: --spread: the impact counts of one scene over t_end with the ice's start moved away from the
#: structure by each offset (m), in one process; JSON on stdout.
_SPREAD_WORKER = """
import json, sys
from iceimpact import Scene, run
fields, t_end, dt = json.loads(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
z0 = Scene(**fields).ice_z0
print(json.dumps([len(run(Scene(**{**fields, "ice_z0": z0 - d}), t_end, dt=dt).impacts)
                  for d in json.loads(sys.argv[4])]))
"""

#: --spread: the largest move of the ice's start by default, m (about 3000 units in the last
#: place of 0.01 m)
SPREAD_MOVE = 5e-15


def offsets(members: int, move: float = SPREAD_MOVE) -> list[float]:
    """The moves of the ice's start of a --spread ensemble: 0 to ``move`` (m), evenly spaced."""
    return [move * k / (members - 1) for k in range(members)]


def spread(core: Path, fields: dict, t_end: float, members: int,
           move: float = SPREAD_MOVE) -> dict:
    """Impact counts of ``core`` with the ice's start moved by each of :func:`offsets` (m)."""
    done = subprocess.run([sys.executable, "-c", _SPREAD_WORKER, json.dumps(fields), repr(t_end),
                           repr(DT), json.dumps(offsets(members, move))], capture_output=True,
                          text=True, env={"PYTHONPATH": str(core), "PATH": "/usr/bin:/bin"},
                          check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{core}: {done.stderr}")
    counts = json.loads(done.stdout.strip().splitlines()[-1])
    mean = sum(counts) / len(counts)
    std = (sum((c - mean) ** 2 for c in counts) / (len(counts) - 1)) ** 0.5
    return {"counts": counts, "mean": mean, "std": std, "min": min(counts), "max": max(counts),
            "relative_range": (max(counts) - min(counts)) / mean if mean else 0.0}


def within(before: dict, after: dict) -> dict:
    """Whether the after ensemble lies within the reference's own spread: after's unmoved count
    in the reference's range, and the means within 2 standard errors of their difference."""
    n_b, n_a = len(before["counts"]), len(after["counts"])
    se = (before["std"] ** 2 / n_b + after["std"] ** 2 / n_a) ** 0.5
    diff = after["mean"] - before["mean"]
    z = diff / se if se else (0.0 if diff == 0 else float("inf"))
    in_range = before["min"] <= after["counts"][0] <= before["max"]
    return {"after_count_in_before_range": in_range, "means_z": z,
            "within": in_range and abs(z) <= 2.0,
            "two_percent_possible": before["relative_range"] <= 0.02}


def _cost(value: float | None, unit: str) -> str:
    return "-" if value is None else f"{value:.1f} {unit}"


def _per_impact(row: dict) -> str:
    ratio = row.get("ratio_per_impact")
    return "-" if ratio is None else f"{ratio:.2f}x"


def _ensemble(e: dict) -> str:
    return f"{e['mean']:.0f} ± {e['std']:.0f} [{e['min']}, {e['max']}]"


def markdown(rows: list[dict], base: str, members: int = 0, move: float = SPREAD_MOVE,
             warm: int = 0) -> str:
    spreads = any("spread" in r for r in rows)
    compiled = {r["after"].get("compiled") for r in rows}
    after = ("its kernels compiled by numba" if compiled == {True} else
             "pure Python" if compiled == {False} else "compiled in some runs")
    how = (f"in each process the best of {warm} runs after an untimed first one" if warm
           else "each the first run of a fresh process (its import not counted)")
    lines = [f"Before: commit {base}; after: this tree ({after}). `run(scene, t_end, dt=1e-2)`, "
             f"CPU time, best of the interleaved rounds, {how}.", ""]
    head = ("| scene | t_end | impacts before / after | per impact before / after | "
            "per simulated s before / after | speed-up | per impact | first 10 impacts moved |")
    if spreads:
        lines += [f"Ensembles: the same run with the ice's start moved by 0 to "
                  f"{move:g} m ({members} runs each), impact counts as mean ± standard "
                  "deviation [range]; \"within\": after's count in the reference's range and "
                  "the means within 2 standard errors (z).", ""]
        head += (" before's ensemble | after's ensemble | before's own range | "
                 "after within (z) |")
    lines += [head, "|---|---:|---:|---:|---:|---:|---:|---:|" + (
        "---:|---:|---:|---|" if spreads else "")]
    for r in rows:
        b, a = r["before"], r["after"]
        line = (f"| {r['scene']} | {r['t_end_s']:g} s | {b['impacts']} / {a['impacts']} "
                f"({100 * r['impact_count_change']:+.1f} %) | {_cost(b['us_per_impact'], 'us')} / "
                f"{_cost(a['us_per_impact'], 'us')} | {b['ms_per_simulated_s']:.2f} / "
                f"{a['ms_per_simulated_s']:.2f} ms | {r['ratio']:.2f}x | "
                f"{_per_impact(r)} | {r['first10_max_shift_s']:.1e} s |")
        if "spread" in r:
            sb, sa, w = r["spread"]["before"], r["spread"]["after"], r["spread"]["verdict"]
            line += (f" {_ensemble(sb)} | {_ensemble(sa)} | {100 * sb['relative_range']:.1f} % | "
                     f"{'yes' if w['within'] else 'no'} ({w['means_z']:+.1f}) |")
        lines.append(line)
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="7c9c6ad",
                        help="reference commit (before; default 7c9c6ad, release 0.2.0)")
    parser.add_argument("--quick", action="store_true", help="10 and 100 s, one round")
    parser.add_argument("--lengths", type=float, nargs="+", help="run lengths, s")
    parser.add_argument("--scenes", nargs="+", choices=list(SCENES), default=list(SCENES))
    parser.add_argument("--rounds", type=int, default=2, help="interleaved rounds, best kept")
    parser.add_argument("--spread", action="store_true",
                        help="the impact counts' spread, before and after, under moves of the "
                             "ice's start by 0 to 5e-15 m")
    parser.add_argument("--members", type=int, default=6,
                        help="--spread: runs per ensemble (>= 2)")
    parser.add_argument("--move", type=float, default=SPREAD_MOVE,
                        help="--spread: the largest move of the ice's start, m (> 0)")
    parser.add_argument("--vs-ode", action="store_true",
                        help="also the exact solver against solve_ivp with events")
    parser.add_argument("--steps", action="store_true",
                        help="only the stepping costs docs/accuracy.md quotes")
    parser.add_argument("--pure", action="store_true",
                        help="every run with ICEIMPACT_PURE=1: the compiled flight search (numba) "
                             "off, in the reference commit too where it has one")
    parser.add_argument("--warm", type=int, default=0, metavar="N",
                        help="time N runs after an untimed one in each process (a process that "
                             "has run before, as in a sweep), the best kept; 0: the first run")
    parser.add_argument("--out", type=Path, default=RESULTS / "core_speed.json")
    args = parser.parse_args(argv)
    if not args.out.suffix:  # (a name without .json: the JSON beside its .md, as the others)
        args.out = args.out.with_suffix(".json")
    if args.warm < 0:
        parser.error(f"--warm = {args.warm}: a number of runs >= 0")
    WARM["runs"] = args.warm
    if args.pure:
        PURE_ENV["ICEIMPACT_PURE"] = "1"
    if args.steps:
        with tempfile.TemporaryDirectory(prefix="core_speed_") as tmp:
            cores = {"before": extract_commit(args.base, Path(tmp)) / "fmu_src",
                     "after": ROOT / "fmu_src"}
            costs = step_costs(cores, args.rounds)
        lines = [f"Before: commit {args.base}; after: this tree. CPU time, best of the rounds.",
                 "", "| what | before | after | speed-up |", "|---|---:|---:|---:|"]
        for kind, unit in (("first_10s_ms", "ms"), ("step_us", "us")):
            for key, before in costs["before"][kind].items():
                after = costs["after"][kind][key]
                label = (f"advance_to(10 s), {key}" if kind == "first_10s_ms"
                         else f"Simulator.advance, Figure 2, h = {key} s")
                lines.append(f"| {label} | {before:.3g} {unit} | {after:.3g} {unit} | "
                             f"{before / after:.1f}x |")
        text = "\n".join(lines) + "\n"
        print(text)
        out = args.out.with_name("core_speed_steps.json")
        out.write_text(json.dumps({"benchmark": "core_speed --steps", "base": args.base,
                                   "date": datetime.now(UTC).isoformat(timespec="seconds"),
                                   "machine": platform.platform(), **costs}, indent=2) + "\n")
        out.with_suffix(".md").write_text(text)
        print(f"wrote {out} and {out.with_suffix('.md')}")
        return 0
    lengths = args.lengths or ([10.0, 100.0] if args.quick else [10.0, 100.0, 1000.0])
    rounds = 1 if args.quick else args.rounds

    if args.spread and args.members < 2:
        parser.error(f"--members = {args.members}: an ensemble needs at least 2 runs")
    if args.spread and not args.move > 0.0:
        parser.error(f"--move = {args.move}: the largest move must be > 0 m")
    rows = []
    with tempfile.TemporaryDirectory(prefix="core_speed_") as tmp:
        cores = {"before": extract_commit(args.base, Path(tmp)) / "fmu_src",
                     "after": ROOT / "fmu_src"}
        head = (f"{'scene':22} {'t_end':>6} {'impacts':>13} {'us/impact':>15} "
                f"{'ms/sim s':>13} {'speed-up':>8} {'/impact':>8} {'first10 moved':>13}")
        print(f"before = {args.base}, after = this tree; run(dt={DT:g}), best of {rounds}")
        print(head)
        print("-" * len(head))
        for name in args.scenes:
            fields = SCENES[name][0]
            for t_end in lengths:
                row = {"scene": name, **compare(cores, fields, t_end, rounds)}
                rows.append(row)
                b, a = row["before"], row["after"]
                print(f"{name:22} {t_end:6g} {b['impacts']:6d}/{a['impacts']:<6d} "
                      f"{b['us_per_impact'] or 0:7.1f}/{a['us_per_impact'] or 0:<7.1f} "
                      f"{b['ms_per_simulated_s']:6.2f}/{a['ms_per_simulated_s']:<6.2f} "
                      f"{row['ratio']:7.2f}x {_per_impact(row):>8} "
                      f"{row['first10_max_shift_s']:13.1e}", flush=True)
                if args.spread:
                    ens = {side: spread(cores[side], fields, t_end, args.members, args.move)
                           for side in ("before", "after")}
                    ens["verdict"] = within(ens["before"], ens["after"])
                    row["spread"] = ens
                    print(f"{'':22} ensembles: before {_ensemble(ens['before'])}, after "
                          f"{_ensemble(ens['after'])}, within: {ens['verdict']['within']} "
                          f"(z {ens['verdict']['means_z']:+.1f})", flush=True)

    report = {"benchmark": "core_speed", "date": datetime.now(UTC).isoformat(timespec="seconds"),
              "command": "python benchmarks/core_speed.py " + " ".join(argv or sys.argv[1:]),
              "machine": platform.platform(), "python": platform.python_version(),
              "base": args.base, "dt_s": DT, "rounds": rounds, "pure": args.pure,
              "warm_runs": args.warm,
              "scenes": {name: SCENES[name][1] for name in args.scenes},
              "rows": rows}
    if args.spread:
        report["spread"] = {"members": args.members,
                            "ice_z0_moves_m": offsets(args.members, args.move)}
    if args.vs_ode:
        report["vs_ode"] = vs_ode(min(max(lengths), 150.0))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    args.out.with_suffix(".md").write_text(markdown(rows, args.base, args.members, args.move,
                                                    args.warm))
    print(f"wrote {args.out} and {args.out.with_suffix('.md')}")
    return 0


def vs_ode(t_end: float) -> list[dict]:
    """The exact solver against a DOP853 integration with the gap as a terminal event
    (rtol 1e-10, tests/ode_reference.py) over the impacts the latter reaches (it has no
    sticking phase), and both against a tight (rtol 1e-13) one on the first 10 impacts."""
    import numpy as np

    from iceimpact import Scene, run

    simulate = load("tests/ode_reference.py").simulate

    rows = []
    for name in ("figure2", "quadratic_A2"):
        scene = Scene(**SCENES[name][0])
        start = time.perf_counter()
        base = simulate(scene, t_end, rtol=1e-10, atol=1e-13)
        wall_base = time.perf_counter() - start
        horizon = float(base["t"][-1]) if len(base["t"]) else t_end
        start = time.perf_counter()
        res = run(scene, horizon + 1e-9, dt=horizon)
        wall_exact = time.perf_counter() - start
        n_acc = min(10, len(base["t"]), len(res.impacts))
        tight = simulate(scene, t_end, max_impacts=n_acc, rtol=1e-13, atol=1e-16)["t"]
        rows.append({"scene": name, "horizon_s": horizon, "impacts_exact": len(res.impacts),
                     "impacts_baseline": len(base["t"]), "wall_exact_s": wall_exact,
                     "wall_baseline_s": wall_base, "speedup": wall_base / wall_exact,
                     "first10_err_exact_s": float(np.max(np.abs(res.impacts["t"][:n_acc]
                                                                - tight))),
                     "first10_err_baseline_s": float(np.max(np.abs(base["t"][:n_acc]
                                                                   - tight)))})
        r = rows[-1]
        print(f"vs solve_ivp with events, {name}: {r['speedup']:.0f}x faster over "
              f"{horizon:.0f} s; first-10 errors {r['first10_err_exact_s']:.1e} s (exact) vs "
              f"{r['first10_err_baseline_s']:.1e} s")
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
