"""What a plastic stick-part cycle at a stiff structure costs before it ends (method 1).

The random search's seed-49 scene (docs/robustness.md, "Many real impacts at a stiff
structure"): a plastic ice pressed by its linear drag on a stiff undamped structure. Stuck, the
pair rings just beyond what its drag holds, parts once a period and meets again plastically,
until the drag's damping and the impacts bring the ringing within what the drag holds (or fix
28's rounding holds the pair). Each variant runs at u = 0.1 m/s in windows of 2,000 periods of
the structure until three windows in a row have no impact and end stuck, or until its CPU
limit. The budget of a step is lifted (solver.max_impacts = 2^31 - 1): this measures the cycle,
not the refusal.

Prints a table, writes JSON (benchmarks/results/stick_part_cycle.json).

    python benchmarks/stick_part_cycle.py            # every variant (about 7 min)
    python benchmarks/stick_part_cycle.py --quick    # the three cheapest (about 10 s)
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

from iceimpact import Scene, Simulator
from iceimpact.contract import INT32_MAX

ROOT = Path(__file__).resolve().parents[1]

SEED_49 = dict(structure_m=1851.183822340676, structure_c=0.0, structure_k=5.307267671675244e17,
               structure_x0=-1.0553886196597527e-48, structure_v0=0.0001,
               ice_M=600.1787218082427, ice_A=5.856127714135108, ice_Cd=0.5255924056645146,
               ice_z0=-1.0553886196597527e-48, ice_v0=0.0001, impact_e=0.0, drag_model=1,
               drag_v_lin=0.3242134652243039, solver_method=1)
K, CD = SEED_49["structure_k"], SEED_49["ice_Cd"]

#: (label, changes to the seed-49 scene), cheapest first
VARIANTS = (
    ("k / 1e4", {"structure_k": K / 1e4}),
    ("k / 100", {"structure_k": K / 100}),
    ("k / 1e4, ice.Cd / 10", {"structure_k": K / 1e4, "ice_Cd": CD / 10}),
    ("k / 1e4, ice.Cd / 1000", {"structure_k": K / 1e4, "ice_Cd": CD / 1000}),
    ("as found", {}),
    ("ice.M 6000 kg", {"ice_M": 6000.0}),
    ("ice.M 60 kg", {"ice_M": 60.0}),
    ("ice.M 6 kg", {"ice_M": 6.0}),
    ("ice.M 0.6 kg", {"ice_M": 0.6}),
    ("k x 10, ice.M 6 kg", {"structure_k": K * 10, "ice_M": 6.0}),
)
U = 0.1  # m/s


def measure(changes: dict, cpu_limit: float) -> dict:
    """Run one variant until its cycle has ended (or the CPU limit): impacts, time, CPU."""
    scene = Scene(**{**SEED_49, **changes, "solver_max_impacts": INT32_MAX})
    sim = Simulator(scene, record_impacts=False)
    window = 2000 * 2.0 * math.pi / scene.omega_n
    start = time.process_time()
    quiet, end = 0, 0.0
    while quiet < 3 and time.process_time() - start < cpu_limit:
        before = sim.impact_count
        report = sim.advance(window, U)
        if report.impact_count == before and before > 0 and report.sticking:
            quiet += 1
        else:
            quiet, end = 0, sim.t
    return {"omega_n": scene.omega_n, "impacts": sim.impact_count, "ended": quiet >= 3,
            "ends_by_t": end, "cpu_s": time.process_time() - start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the three cheapest variants")
    parser.add_argument("--cpu-limit", type=float, default=600.0,
                        help="CPU seconds per variant (default 600)")
    parser.add_argument("--out", type=Path,
                        default=ROOT / "benchmarks" / "results" / "stick_part_cycle.json")
    args = parser.parse_args()
    rows = []
    print(f"{'variant':<24} {'omega_n':>9} {'impacts':>9} {'ended by t, s':>14} {'CPU, s':>8}")
    for label, changes in VARIANTS[:3] if args.quick else VARIANTS:
        row = {"variant": label, **measure(changes, args.cpu_limit)}
        rows.append(row)
        ended = f"{row['ends_by_t']:.3g}" if row["ended"] else "not ended"
        print(f"{label:<24} {row['omega_n']:>9.2g} {row['impacts']:>9,} {ended:>14} "
              f"{row['cpu_s']:>8.1f}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"machine": platform.platform(), "u": U, "rows": rows},
                                   indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
