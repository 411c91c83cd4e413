"""Cost of the Morison terms on the structure when they are off: this tree against the model before
them (commit 060a0a0), side by side.

The old tree is extracted with ``git archive`` into a temporary folder; each configuration runs in
its own subprocess (``PYTHONPATH`` = that tree's ``fmu_src``), the two alternating (old, new, old,
new, ...) so that background load affects them alike; the best of the repeats is kept per case.
Each case steps a :class:`~iceimpact.Simulator` at 1 ms communication steps through a scene with
all four Morison parameters at their default 0. The subprocesses also report a digest of every
output, so the table says whether the two trees computed the same bits. The times are the
subprocess's CPU time (``time.process_time``), which other jobs on a shared machine disturb less
than wall time (both are written to the JSON). The committed results were measured when the terms
were added on top of 060a0a0, where "same bits" is a like-for-like check; against that commit a
later tree also differs by the numerics changed since (the speed work), so pass ``--base`` the
commit just before the change being measured. Prints a table and writes JSON::

    python benchmarks/morison_cost.py                  # 5 repeats
    python benchmarks/morison_cost.py --repeat 9 --base 060a0a0
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tree import ROOT, extract_commit

#: (name, scene changes, simulated time s): stepped at 1 ms, Morison terms off.
CASES = (
    ("figure 2, exact", {}, 100.0),
    ("e = 0.5 quadratic (sticking), exact", {"impact_e": 0.5, "drag_model": 2}, 50.0),
    ("figure 13 quadratic, exact", {"drag_model": 2, "ice_A": 2.0}, 100.0),
    ("figure 2, fixed-step", {"solver_method": 2, "solver_detection": 1}, 25.0),
    ("figure 2 e = 0.5, ODE", {"solver_method": 3, "impact_e": 0.5}, 20.0),
)
STEP = 1e-3  # s


def worker() -> None:
    """Time every case once in this process (the tree on PYTHONPATH); print JSON."""
    from iceimpact import Scene, Simulator

    out = {}
    for name, changes, t_end in CASES:
        scene = Scene(**changes)
        digest = hashlib.sha256()
        start, cpu_start = time.perf_counter(), time.process_time()
        sim = Simulator(scene)
        for _ in range(round(t_end / STEP)):
            r = sim.advance(STEP)
            digest.update(repr((r.x, r.v, r.z, r.w, r.impulse)).encode())
        out[name] = {"cpu_s": time.process_time() - cpu_start,
                     "wall_s": time.perf_counter() - start, "digest": digest.hexdigest(),
                     "impacts": r.impact_count}
    print(json.dumps(out))


def run_tree(src: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(src)}
    proc = subprocess.run([sys.executable, __file__, "--worker"], env=env, check=True,
                          capture_output=True, text=True)
    return json.loads(proc.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--base", default="060a0a0", help="commit before the Morison terms")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/morison_cost.json")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        trees = {"before": extract_commit(args.base, Path(tmp)) / "fmu_src",
                 "branch": ROOT / "fmu_src"}
        best: dict[str, dict[str, float]] = {t: {} for t in trees}
        best_wall: dict[str, dict[str, float]] = {t: {} for t in trees}
        seen: dict[str, dict[str, dict]] = {}
        load_start = os.getloadavg()[0]
        for _ in range(args.repeat):
            for tree, src in trees.items():
                result = run_tree(src)
                seen[tree] = result
                for name, row in result.items():
                    best[tree][name] = min(best[tree].get(name, float("inf")), row["cpu_s"])
                    best_wall[tree][name] = min(best_wall[tree].get(name, float("inf")),
                                                row["wall_s"])
        load_end = os.getloadavg()[0]

    rows = []
    print("| case | before, CPU s | branch, CPU s | branch / before | same bits | impacts |")
    print("|---|---|---|---|---|---|")
    for name, _, t_end in CASES:
        before, branch = best["before"][name], best["branch"][name]
        same = seen["before"][name]["digest"] == seen["branch"][name]["digest"]
        rows.append({"case": name, "simulated_s": t_end, "step_s": STEP, "before_cpu_s": before,
                     "branch_cpu_s": branch, "ratio": branch / before,
                     "before_wall_s": best_wall["before"][name],
                     "branch_wall_s": best_wall["branch"][name],
                     "wall_ratio": best_wall["branch"][name] / best_wall["before"][name],
                     "same_bits": same, "impacts": seen["branch"][name]["impacts"]})
        print(f"| {name} | {before:.3f} | {branch:.3f} | {branch / before:.3f} | {same} | "
              f"{rows[-1]['impacts']} |")
    total_before = sum(r["before_cpu_s"] for r in rows)
    total_branch = sum(r["branch_cpu_s"] for r in rows)
    print(f"| all | {total_before:.3f} | {total_branch:.3f} | "
          f"{total_branch / total_before:.3f} | | |")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "machine": platform.platform(), "python": platform.python_version(),
        "base": args.base, "repeat": args.repeat, "load_start": load_start,
        "load_end": load_end, "rows": rows,
        "total": {"before_cpu_s": total_before, "branch_cpu_s": total_branch,
                  "ratio": total_branch / total_before}}, indent=2) + "\n")
    print(f"wrote {args.out.relative_to(ROOT)}")


if __name__ == "__main__":
    if "--worker" in sys.argv:
        worker()
    else:
        main()
