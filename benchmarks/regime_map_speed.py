"""End-to-end time of ``examples/regime_map.py`` (200 runs of 60 s, 2 workers): this tree
against base commits, side by side in one run.

Each base commit's ``fmu_src`` and ``examples`` are extracted with ``git archive`` into a
temporary directory; each measurement runs the example of one tree in a subprocess (``python
examples/regime_map.py --workers 2`` into a fresh output directory, ``iceimpact`` imported from
that tree), the trees alternating round by round. Measured per run:

- ``wall_s``: the wall time of the whole example (imports, sweep, figure), which moves with the
  other load of a shared machine;
- ``cpu_s``: the CPU time of the example and its sweep workers (user + system, from the
  children's resource usage), which moves much less.

The tables the trees write are compared with the current tree's: the same status and impact
count in every cell, and the largest relative difference of the other measures (the wall time
of each run and ``kx_cycles`` excepted: a rainflow count of an almost constant spring force in a
steady sticking phase counts cycles of rounding size, so it moves with the last bits).

    python benchmarks/regime_map_speed.py                      # bases 060a0a0 and 17eb7ff
    python benchmarks/regime_map_speed.py --base HEAD~1 --rounds 3

Prints a table and writes ``benchmarks/results/regime_map_speed.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tree import ROOT, extract_commit

#: the commit issue 16 measured (4 min 51 s), and main before the vectorised sticking phase
BASES = ("060a0a0", "17eb7ff")
WORKERS = 2
#: columns not compared between trees (see the module docstring)
UNCOMPARED = ("wall_s", "kx_cycles")


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_example(tree: Path, out_dir: Path) -> dict[str, float]:
    """One run of the tree's regime map: wall and CPU time (s)."""
    env = {**os.environ, "PYTHONPATH": str(tree / "fmu_src"), "MPLBACKEND": "Agg"}
    cpu0, wall0 = _children_cpu(), time.perf_counter()
    subprocess.run([sys.executable, str(tree / "examples" / "regime_map.py"), "--workers",
                    str(WORKERS), "--out-dir", str(out_dir)], cwd=tree, env=env, check=True,
                   capture_output=True)
    return {"wall_s": time.perf_counter() - wall0, "cpu_s": _children_cpu() - cpu0}


def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def compare(rows: list[dict[str, str]], reference: list[dict[str, str]]) -> dict[str, float]:
    """Cells with a different status or impact count, and the largest relative difference of
    the other measures, against the reference table."""
    assert len(rows) == len(reference), "the trees ran different grids"
    different, worst, identical = 0, 0.0, 0
    for row, ref in zip(rows, reference, strict=True):
        if row["status"] != ref["status"] or row["n_impacts"] != ref["n_impacts"]:
            different += 1
            continue
        same = True
        for key, text in ref.items():
            if key in UNCOMPARED or key == "status" or row[key] == text:
                continue
            same = False
            a, b = float(row[key]), float(text)
            if math.isnan(a) and math.isnan(b):
                continue
            worst = max(worst, abs(a - b) / max(abs(a), abs(b)))
        identical += same
    return {"cells_with_other_impacts": different, "identical_cells": identical,
            "max_rel_diff": worst}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", action="append", default=None,
                        help=f"commit to compare with (repeatable; default {' and '.join(BASES)})")
    parser.add_argument("--rounds", type=int, default=1, help="runs of each tree, alternating")
    parser.add_argument("--out", type=Path,
                        default=ROOT / "benchmarks" / "results" / "regime_map_speed.json")
    args = parser.parse_args(argv)
    bases = args.base or list(BASES)

    with tempfile.TemporaryDirectory() as tmp:
        trees = {}
        for base in bases:
            trees[base] = extract_commit(base, Path(tmp) / f"base-{base}",
                                         ("fmu_src", "examples"))
        trees["current"] = ROOT
        runs: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
        tables: dict[str, list[dict[str, str]]] = {}
        for k in range(args.rounds):
            for name, tree in trees.items():
                out_dir = Path(tmp) / f"out-{name}-{k}"
                runs[name].append(run_example(tree, out_dir))
                tables[name] = read_rows(out_dir / "regime_map.csv")
                print(f"round {k + 1}: {name}: {runs[name][-1]['wall_s']:.1f} s wall, "
                      f"{runs[name][-1]['cpu_s']:.1f} s CPU", file=sys.stderr)

    current = {key: min(r[key] for r in runs["current"]) for key in ("wall_s", "cpu_s")}
    rows = []
    for name in trees:
        best = {key: min(r[key] for r in runs[name]) for key in ("wall_s", "cpu_s")}
        rows.append({"tree": name, **best,
                     "wall_ratio": best["wall_s"] / current["wall_s"],
                     "cpu_ratio": best["cpu_s"] / current["cpu_s"],
                     "runs": runs[name], **compare(tables[name], tables["current"])})

    print(f"{'tree':<10} {'wall s':>8} {'CPU s':>8} {'wall x':>7} {'CPU x':>7} "
          f"{'other impacts':>13} {'identical':>9} {'max rel diff':>12}")
    for r in rows:
        print(f"{r['tree']:<10} {r['wall_s']:8.1f} {r['cpu_s']:8.1f} {r['wall_ratio']:7.2f} "
              f"{r['cpu_ratio']:7.2f} {r['cells_with_other_impacts']:13d} "
              f"{r['identical_cells']:9d} {r['max_rel_diff']:12.2e}")
    result = {"machine": platform.platform(), "python": platform.python_version(),
              "cpus": os.cpu_count(), "workers": WORKERS, "rounds": args.rounds,
              "load_average_at_end": os.getloadavg(), "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"-> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
