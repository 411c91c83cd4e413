"""Speed of the exact method's quadratic-drag sticking phase: this tree against a base commit,
side by side in one run.

The base commit's ``fmu_src`` is extracted with ``git archive`` into a temporary directory; each
measurement runs in a subprocess (this script with ``--worker``, ``PYTHONPATH`` that tree's
``fmu_src``) importing ``iceimpact`` from either tree, alternating base and current, best of
``--repeat``. Times are the CPU time of the measuring process (``time.process_time``): on a
shared machine wall times move with the other load, CPU times much less; the method-3 row, whose
code the sticking work does not touch, shows what is left of that (its ratio should be near 1).
Measured:

- ``fig18 sticking, sampled``: the sticking phase of the Figure 18 scene (quadratic drag,
  e = 0.5; sticking from 9.77 s) from 10 s to 200 s through the method (``advance_to`` every
  10 ms, without the Simulator's checkpoint and report);
- ``fig18 sticking, integration``: the same phase in one ``advance_to(200 s)`` call: the
  integration of the sticking phase alone;
- ``fig18 run``: ``run(scene, 200, dt=1e-2)``, the whole run;
- ``fig18 run, method 3 rtol 1e-9``: the same run with method 3, which the sticking work does not
  change (a control: its ratio shows how evenly the load fell on both trees);
- ``flow change every 1 ms step``: 300 steps of a slow, heavy scene sticking throughout, the flow
  changing at every step (each change re-anchors the sticking phase), through the Simulator;
- ``regime cell ...``: runs of ``examples/regime_map.py``'s grid (60 s at the sweep's ``dt``),
  its costliest cells at the base commit, all sticking most of the time.

Accuracy: the sampled Figure 18 sticking phase of each tree against an independent ``solve_ivp``
integration (DOP853, rtol 1e-12, written out here) from that tree's own sticking anchor.

    python benchmarks/sticking_speed.py                 # base 060a0a0, best of 3
    python benchmarks/sticking_speed.py --repeat 1 --base HEAD~3

Prints a table and writes ``benchmarks/results/sticking_speed.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from tree import ROOT, extract_commit

BASE = "060a0a0"

#: Figure 18 sticking phase: from T_STICK to T_END sampled every DT (s)
T_STICK, T_END, DT = 10.0, 200.0, 1e-2
#: regime-map cells (ice.M index, flow.u index) on its default grid: the costliest at 060a0a0
CELLS = [(4, 19), (5, 18), (5, 17), (1, 19), (5, 16), (2, 12)]
REGIME_T_END = 60.0
FLOW_STEPS = 300


def _worker() -> dict:
    """The measurements, with ``iceimpact`` from the tree on ``PYTHONPATH`` (a subprocess)."""
    from iceimpact import Scene, Simulator, run
    from iceimpact.sweep import DEFAULT_DT

    fig18 = Scene(drag_model=2, impact_e=0.5)
    out: dict = {}

    def stuck_solver():
        sim = Simulator(fig18)
        for i in range(1, round(T_STICK / DT) + 1):
            sim.advance_to(i * DT)
        assert sim.sticking, "the Figure 18 scene sticks from 9.77 s"
        seg = sim.solver.seg
        return sim.solver, (seg.t0, seg.x0, seg.v0)

    solver, anchor = stuck_solver()
    u = fig18.flow_u
    times = [i * DT for i in range(round(T_STICK / DT) + 1, round(T_END / DT) + 1)]
    xs = []
    t0 = time.process_time()
    for t in times:
        solver.advance_to(t, u)
        xs.append(solver.state.x)
    out["fig18 sticking, sampled"] = {"cpu_s": time.process_time() - t0, "samples": len(times),
                                      "final_x": solver.state.x}
    out["accuracy"] = {"anchor": list(anchor), "t": times[99::100], "x": xs[99::100],
                       "scene": [fig18.structure_m, fig18.structure_c, fig18.structure_k,
                                 fig18.ice_M, fig18.drag_B, u]}

    solver, _ = stuck_solver()
    t0 = time.process_time()
    solver.advance_to(T_END, u)
    out["fig18 sticking, integration"] = {"cpu_s": time.process_time() - t0, "samples": 1,
                                          "final_x": solver.state.x}

    t0 = time.process_time()
    res = run(fig18, T_END, dt=DT)
    out["fig18 run"] = {"cpu_s": time.process_time() - t0, "impacts": len(res.impacts),
                        "final_x": float(res.x[-1])}

    # method 3 (unchanged by the sticking work: a control of the load) on the same run
    method3 = fig18.replace(solver_method=3, solver_rtol=1e-9)
    t0 = time.process_time()
    res = run(method3, T_END, dt=DT)
    out["fig18 run, method 3 rtol 1e-9"] = {"cpu_s": time.process_time() - t0,
                                            "impacts": len(res.impacts),
                                            "final_x": float(res.x[-1])}

    # a new flow at every 1 ms step re-anchors the sticking phase: a slow, heavy scene
    # (m = M = 4.4e4 kg, omega_n = 1 rad/s) starting in contact, sticking throughout
    heavy = Scene(drag_model=2, structure_m=4.4e4, structure_k=4.4e4, ice_M=4.4e4,
                  impact_e=0.0, ice_z0=0.0, ice_v0=0.0)
    sim = Simulator(heavy)
    sim.advance(1e-3)
    t0 = time.process_time()
    for i in range(FLOW_STEPS):
        rep = sim.advance(1e-3, heavy.flow_u * (1.0 + 0.01 * (-1) ** i))
    assert rep.sticking
    out["flow change every 1 ms step"] = {"cpu_s": time.process_time() - t0,
                                          "samples": FLOW_STEPS, "final_x": rep.x}

    masses, flows = np.geomspace(200.0, 6400.0, 10), np.geomspace(0.01, 2.0, 20)
    for i, j in CELLS:
        scene = Scene(drag_model=2, ice_M=float(masses[i]), flow_u=float(flows[j]))
        t0 = time.process_time()
        res = run(scene, REGIME_T_END, dt=DEFAULT_DT)
        out[f"regime cell M={masses[i]:.0f} u={flows[j]:.3g}"] = {
            "cpu_s": time.process_time() - t0, "impacts": len(res.impacts),
            "final_x": float(res.x[-1])}
    return out


def reference_positions(scene: list[float], anchor: list[float],
                        times: list[float]) -> np.ndarray:
    """x(t) of the bodies together (Figure 18 scene, no separation in this phase) from the
    anchor (t0, x0, v0): (m + M) x'' + c x' + k x = B |u - x'| (u - x'), DOP853 at rtol 1e-12,
    restarted where u - x' changes sign (the right-hand side is not smooth there)."""
    from scipy.integrate import solve_ivp

    m, c, k, M, B, u = scene

    def rhs(t, y):
        r = u - y[1]
        return [y[1], (B * abs(r) * r - c * y[1] - k * y[0]) / (m + M)]

    def flip(t, y):
        return u - y[1]
    flip.terminal = True

    t0, x0, v0 = anchor
    out, t, y = [], t0, [x0, v0]
    targets = list(times)
    while targets:
        sol = solve_ivp(rhs, (t, targets[-1]), y, method="DOP853", rtol=1e-12, atol=1e-20,
                        dense_output=True, events=flip)
        end = sol.t[-1]
        while targets and targets[0] <= end:
            out.append(sol.sol(targets.pop(0))[0])
        t, y = end, [sol.y[0, -1], u]
    return np.array(out)


def _run_worker(src: Path) -> dict:
    proc = subprocess.run([sys.executable, __file__, "--worker"], check=True,
                          env={**os.environ, "PYTHONPATH": str(src)},
                          capture_output=True, text=True, cwd=ROOT)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default=BASE, help=f"commit to compare with (default {BASE})")
    parser.add_argument("--repeat", type=int, default=3, help="best of N (alternating)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path,
                        default=ROOT / "benchmarks" / "results" / "sticking_speed.json")
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(_worker()))
        return 0

    with tempfile.TemporaryDirectory() as tmp:
        trees = {"base": extract_commit(args.base, Path(tmp)) / "fmu_src",
                 "current": ROOT / "fmu_src"}
        runs: dict[str, list[dict]] = {"base": [], "current": []}
        for _ in range(args.repeat):
            for name, src in trees.items():
                runs[name].append(_run_worker(src))

    best = {name: {key: min(r[key]["cpu_s"] for r in rs) for key in rs[0] if key != "accuracy"}
            for name, rs in runs.items()}
    accuracy = {}
    for name, rs in runs.items():
        acc = rs[0]["accuracy"]
        ref = reference_positions(acc["scene"], acc["anchor"], acc["t"])
        accuracy[name] = float(np.max(np.abs(np.array(acc["x"]) - ref)) / np.max(np.abs(ref)))

    rows = []
    for key in best["base"]:
        base, cur = runs["base"][0][key], runs["current"][0][key]
        rows.append({"measure": key, "base_s": best["base"][key], "current_s": best["current"][key],
                     "ratio": best["base"][key] / best["current"][key],
                     "impacts_base": base.get("impacts"), "impacts_current": cur.get("impacts"),
                     "final_x_rel_diff": abs(cur["final_x"] - base["final_x"])
                     / max(abs(base["final_x"]), 1e-300)})
    head = (f"{'measure (CPU s)':34} {'base s':>8} {'current s':>9} {'ratio':>6} {'impacts':>13} "
            f"{'final x rel diff':>16}")
    print(head)
    print("-" * len(head))
    for r in rows:
        imp = ("" if r["impacts_base"] is None
               else f"{r['impacts_base']}/{r['impacts_current']}")
        print(f"{r['measure']:34} {r['base_s']:8.3f} {r['current_s']:9.4f} {r['ratio']:6.1f} "
              f"{imp:>13} {r['final_x_rel_diff']:16.1e}")
    print("Figure 18 sticking phase, max |x - x_ref| / max |x_ref| against DOP853 rtol 1e-12: "
          + ", ".join(f"{name} {err:.1e}" for name, err in accuracy.items()))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "machine": platform.platform(), "python": platform.python_version(),
        "cpus": __import__("os").cpu_count(), "base": args.base, "repeat": args.repeat,
        "rows": rows, "accuracy_fig18_sticking_rel": accuracy,
        "note": "CPU seconds of the measuring process, best of the repeats; base and current "
                "alternate; the method-3 row is a control (unchanged code)",
    }, indent=2) + "\n")
    print(f"-> {args.out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
