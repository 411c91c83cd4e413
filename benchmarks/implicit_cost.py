"""Work of method 3's implicit integrators (LSODA, Radau) per simulated second.

    python benchmarks/implicit_cost.py [--quick] [--base COMMIT]

Scenes: the four stiff scene kinds of ``tools/ode_rate_cost.py`` (an over-damped structure in
flight, c / m = rate; the same structure pushed by a 1 g floe in contact; a 1 g floe under a
linear drag, b / M = rate; a 0.1 mg floe under a quadratic drag, 2 B |u| / M = rate), the flow
reversed at every 1 ms step or held, at rates from 1e3 to 9.9e5 1/s; a lightly damped structure
ringing at omega_n (``ringing``, the "rate" column is omega_n in rad/s, zeta = 0.01, the ice out
of reach); and the Figure 2 scene. Each run covers ``--sim`` s of simulated time (default 0.05 s
in 1 ms steps) or stops at ``--budget`` s of CPU. Printed per run: CPU s per simulated s, and per
1 ms step the ``solve_ivp`` steps, right-hand-side and Jacobian evaluations (machine-independent).
A second table gives the accuracy: each of the first 20 flights of Figures 2 and 13, restarted
from the exact solver's post-impact state, against the exact next impact (the largest and mean
relative error of the flight's duration, as ``tests/solvers/test_methods.py`` checks it). A third
gives the steps against ``solver.rtol`` (1e-4 to 1e-12; 10 ms per run) in three of the scenes.

``--base COMMIT`` runs every case on that commit's ``fmu_src`` too (extracted with ``git
archive``), in a second worker process fed the cases in turn with this tree's, so that both see
the same machine load. Writes ``benchmarks/results/implicit_cost.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tree import ROOT, extract_commit, load

STEP = 1e-3  # s
RATES = (1e3, 1e4, 1e5, 9.9e5)
KINDS = ("over-damped flight", "over-damped stuck", "linear drag", "quadratic drag")


def _scene(kind: str, rate: float, ode: int):
    from iceimpact import Scene

    scene = load("tools/ode_rate_cost.py").scene

    if kind == "ringing":  # rate = omega_n, zeta = 0.01, the ice 1 m away without drag
        return Scene(structure_m=1.0, structure_k=rate**2, structure_c=0.02 * rate,
                     structure_x0=0.01, ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0,
                     solver_method=3, solver_ode_method=ode)
    if kind == "figure 2":
        return Scene(solver_method=3, solver_ode_method=ode)
    return scene(kind, rate, ode)


def _with_rtol(sc, rtol: float | None):
    return sc if rtol is None else sc.replace(solver_rtol=rtol)


def run_case(case: dict) -> dict:
    """One run of ``case`` (kind, rate, ode, flow, sim, budget) in this process's iceimpact."""
    import iceimpact.solvers.ode as ode_module
    from iceimpact import ParameterError, Simulator

    counts = {"steps": 0, "nfev": 0, "njev": 0, "calls": 0}
    original = ode_module.solve_ivp

    def counted(*args, **kwargs):
        res = original(*args, **kwargs)
        counts["steps"] += len(res.t) - 1
        counts["nfev"] += int(res.nfev)
        counts["njev"] += int(res.njev)
        counts["calls"] += 1
        return res

    ode_module.solve_ivp = counted
    try:
        try:
            sc = _with_rtol(_scene(case["kind"], case["rate"], case["ode"]), case.get("rtol"))
            sim = Simulator(sc)
        except ParameterError as exc:
            return {"refused": str(exc)}
        u = sc.flow_u
        start = time.process_time()
        n = 0
        while (sim.t < case["sim"] - 1e-12
               and time.process_time() - start < case["budget"]):
            sim.advance(STEP, u if case["flow"] == "held" or n % 2 == 0 else -u)
            n += 1
        cpu = time.process_time() - start
    finally:
        ode_module.solve_ivp = original
    return {"cpu_per_s": cpu / sim.t, "reached_s": sim.t, "steps": n,
            **{f"{key}_per_step": value / n for key, value in counts.items()}}


def flight_errors(case: dict) -> dict:
    """Relative errors of the first 20 flights' durations of ``case["figure"]`` with
    solver.ode_method ``case["ode"]`` at ``case["rtol"]``, each restarted from the exact
    solver's post-impact state (test_methods.test_ode_flights_agree_with_exact_within_tolerance)."""
    test_methods = load("tests/solvers/test_methods.py")
    FIG2, FIG13, impact_times, ode = (test_methods.FIG2, test_methods.FIG13,
                                      test_methods.impact_times, test_methods.ode)
    from iceimpact.simulator import make_solver

    scene = {"Figure 2": FIG2, "Figure 13": FIG13}[case["figure"]]
    exact = make_solver(scene)
    exact.advance_to(60.0, scene.flow_u)
    impacts = exact.impacts[:21]
    errors = []
    for a, b in zip(impacts[:-1], impacts[1:], strict=True):
        start = scene.replace(structure_x0=a.x, structure_v0=a.v_plus, ice_z0=a.x,
                              ice_v0=a.w_plus)
        duration = b.t - a.t
        got = impact_times(ode(start, case["rtol"], case["ode"]), 1.5 * duration)
        errors.append(abs(got[0] - duration) / duration if got.size else math.inf)
    return {"max_rel_error": max(errors), "mean_rel_error": sum(errors) / len(errors)}


def _worker() -> None:
    for line in sys.stdin:
        case = json.loads(line)
        result = flight_errors(case) if "figure" in case else run_case(case)
        print(json.dumps(result), flush=True)


def _start_worker(fmu_src: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(fmu_src))
    return subprocess.Popen([sys.executable, __file__, "--worker"], env=env, text=True,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE)


def _ask(worker: subprocess.Popen, case: dict) -> dict:
    worker.stdin.write(json.dumps(case) + "\n")
    worker.stdin.flush()
    return json.loads(worker.stdout.readline())


def _cell(r: dict) -> str:
    if "refused" in r:
        return "refused |  |  | "
    reached = "" if r["reached_s"] >= 0.999 * r["sim"] else f" (over {r['reached_s']:.3g} s)"
    return (f"{r['cpu_per_s']:.2f}{reached} | {r['steps_per_step']:.0f} | "
            f"{r['nfev_per_step']:.0f} | {r['njev_per_step']:.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", help="also run every case on this commit's fmu_src")
    parser.add_argument("--quick", action="store_true", help="rates 1e3 and 9.9e5 only")
    parser.add_argument("--ode", default="3,4", help="solver.ode_method values")
    parser.add_argument("--sim", type=float, default=0.05, help="simulated s per run")
    parser.add_argument("--budget", type=float, default=3.0, help="CPU s per run")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        _worker()
        return
    rates = (1e3, 9.9e5) if args.quick else RATES
    cases = [dict(kind=kind, rate=rate, ode=ode, flow=flow, sim=args.sim, budget=args.budget)
             for ode in (int(x) for x in args.ode.split(","))
             for kind in (*KINDS, "ringing", "figure 2")
             for rate in ((0.0,) if kind == "figure 2" else
                          (1e2, 1e3, 1e4) if kind == "ringing" else rates)
             for flow in ("reversed", "held")]
    trees = {"branch": ROOT / "fmu_src"}
    with tempfile.TemporaryDirectory() as tmp:
        if args.base:
            trees["base"] = extract_commit(args.base, Path(tmp) / "base") / "fmu_src"
        workers = {name: _start_worker(src) for name, src in trees.items()}
        head = " | ".join(f"{name}: CPU s per simulated s | solve_ivp steps | f evals | "
                          "jacobians" for name in trees)
        print(f"| solver.ode_method | scene | rate (1/s) | flow | {head} |")
        print("|---|---|---|---|" + "---|---|---|---|" * len(trees))
        rows = []
        for case in cases:
            row = dict(case)
            for name, worker in workers.items():
                row[name] = {**_ask(worker, case), "sim": case["sim"]}
            rows.append(row)
            cells = " | ".join(_cell(row[name]) for name in trees)
            print(f"| {case['ode']} | {case['kind']} | {case['rate']:.3g} | {case['flow']} | "
                  f"{cells} |", flush=True)
        print()
        print("| solver.ode_method | scene | rtol | " + " | ".join(
            f"{name}: largest, mean relative error of a flight's duration" for name in trees)
            + " |")
        print("|---|---|---|" + "---|" * len(trees))
        accuracy = []
        for figure in ("Figure 2", "Figure 13"):
            for ode in (int(x) for x in args.ode.split(",")):
                for rtol in (1e-6, 1e-8):
                    case = dict(figure=figure, ode=ode, rtol=rtol)
                    row = dict(case)
                    for name, worker in workers.items():
                        row[name] = _ask(worker, case)
                    accuracy.append(row)
                    cells = " | ".join(f"{row[name]['max_rel_error']:.4g}, "
                                       f"{row[name]['mean_rel_error']:.4g}" for name in trees)
                    print(f"| {ode} | {figure} | {rtol:g} | {cells} |", flush=True)
        print()
        print("| solver.ode_method | scene | rate (1/s) | flow | solver.rtol | " + " | ".join(
            f"{name}: CPU s per simulated s | solve_ivp steps per 1 ms step" for name in trees)
            + " |")
        print("|---|---|---|---|---|" + "---|---|" * len(trees))
        tolerance = []
        for ode in (int(x) for x in args.ode.split(",")):
            for kind, rate, flow in (("linear drag", 1e5, "reversed"),
                                     ("quadratic drag", 1e5, "reversed"),
                                     ("ringing", 1e3, "held")):
                for rtol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12):
                    case = dict(kind=kind, rate=rate, ode=ode, flow=flow, sim=0.01,
                                budget=args.budget, rtol=rtol)
                    row = dict(case)
                    for name, worker in workers.items():
                        row[name] = {**_ask(worker, case), "sim": case["sim"]}
                    tolerance.append(row)
                    cells = " | ".join(" | ".join(_cell(row[name]).split(" | ")[:2])
                                       for name in trees)
                    print(f"| {ode} | {kind} | {rate:.3g} | {flow} | {rtol:g} | {cells} |",
                          flush=True)
        for worker in workers.values():
            worker.stdin.close()
            worker.wait()
    out = ROOT / "benchmarks" / "results" / "implicit_cost.json"
    out.write_text(json.dumps({
        "command": "python benchmarks/implicit_cost.py" + " ".join(
            [""] + [a for a in sys.argv[1:]]),
        "machine": platform.platform(), "python": platform.python_version(),
        "base": args.base, "step_s": STEP, "rows": rows, "accuracy": accuracy,
        "tolerance": tolerance}, indent=2) + "\n")
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
