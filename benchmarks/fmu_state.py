"""Cost and size of a saved state (FMI get/set/serialize FMU state) against the run length.

    python benchmarks/fmu_state.py [--quick] [--repeat N]

The exact method runs an elastic scene that keeps impacting (the Figure 2 scene with a stiffer
structure, k = 1e8 N/m: its chatter reaches 1e5 impacts in ~370 s) and, at 10, 1e3, 1e4 and 1e5
impacts (``--quick``: up to 1e4), times in this one process

- the state as it is now: ``Simulator.save()`` (a small dict of plain data) and ``json.dumps``
  of it, its size, and ``Simulator.from_snapshot(json.loads(...))``;
- the state as it was before: ``copy.deepcopy`` of scene, solver (with its impact list), last
  report and counter, then ``pickle.dumps`` of that, and its size.

The Figure 2 scene itself after 400 s (15,369 impacts) is one more row. The simulators record
their impact lists (as ``run()`` does), so that the old approach copies what it used to copy.
Prints a table and writes ``benchmarks/results/fmu_state.json``. Times are medians over
``--repeat`` calls, wall-clock.
"""

from __future__ import annotations

import argparse
import copy
import json
import pickle
import platform
import statistics
import time
from datetime import UTC, datetime
from pathlib import Path

from iceimpact import Scene, Simulator

ROOT = Path(__file__).resolve().parents[1]

HERE = Path(__file__).resolve().parent
STIFF = Scene(structure_k=1e8)  # elastic chatter: impacts accumulate fast


def _median_time(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def measure(sim: Simulator, repeat: int) -> dict[str, float | int]:
    save_s, state = _median_time(sim.save, repeat)
    json_s, text = _median_time(lambda: json.dumps(state), repeat)
    restore_s, _ = _median_time(lambda: Simulator.from_snapshot(json.loads(text)), repeat)
    old_repeat = max(3, repeat // 10)
    old_copy_s, old = _median_time(lambda: copy.deepcopy(
        (sim.scene, sim.solver, sim.report, sim.report.impact_count)), old_repeat)
    old_pickle_s, blob = _median_time(lambda: pickle.dumps(old, pickle.HIGHEST_PROTOCOL),
                                      old_repeat)
    return {"t": sim.t, "impacts": sim.report.impact_count,
            "save_ms": 1e3 * save_s, "json_ms": 1e3 * json_s, "json_bytes": len(text),
            "restore_ms": 1e3 * restore_s,
            "old_deepcopy_ms": 1e3 * old_copy_s, "old_pickle_ms": 1e3 * old_pickle_s,
            "old_bytes": len(blob)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="up to 1e4 impacts")
    parser.add_argument("--repeat", type=int, default=50, help="calls per timing (median)")
    args = parser.parse_args()
    targets = [10, 1_000, 10_000] + ([] if args.quick else [100_000])

    rows = []
    sim = Simulator(STIFF)
    for target in targets:
        while sim.report.impact_count < target:
            sim.advance(0.01 if target <= 10 else 0.1)
        rows.append({"scene": "k = 1e8 N/m, e = 1", **measure(sim, args.repeat)})
    fig2 = Simulator(Scene())
    while fig2.t < 400.0 - 1e-9:
        fig2.advance(0.05)
    rows.append({"scene": "Figure 2, 400 s", **measure(fig2, args.repeat)})

    header = (f"{'scene':<20} {'impacts':>8} | {'save ms':>8} {'json ms':>8} {'bytes':>7} "
              f"{'restore ms':>10} | {'old copy ms':>11} {'pickle ms':>9} {'old bytes':>10}")
    print(header)
    print("-" * len(header))
    for r in rows:
        print(f"{r['scene']:<20} {r['impacts']:>8} | {r['save_ms']:>8.3f} {r['json_ms']:>8.3f} "
              f"{r['json_bytes']:>7} {r['restore_ms']:>10.3f} | {r['old_deepcopy_ms']:>11.2f} "
              f"{r['old_pickle_ms']:>9.2f} {r['old_bytes']:>10}")
    out = {"date": datetime.now(UTC).isoformat(timespec="seconds"),
           "python": platform.python_version(), "machine": platform.machine(),
           "repeat": args.repeat, "rows": rows}
    path = HERE / "results" / "fmu_state.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
