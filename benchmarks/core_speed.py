"""Speed of the exact solver against a solve_ivp-with-events baseline, measured side by side.

For each scene: wall time and impacts per second of ``iceimpact.run`` (exact, event-driven) and of
a direct DOP853 integration with the gap as a terminal event (rtol 1e-10, the way one would write
it by hand; tests/ode_reference.py), both over the same impacts, plus the accuracy of each against
a tight (rtol 1e-13) integration on the first impacts. Prints a table, writes JSON.

    python benchmarks/core_speed.py            # Figure 2 scene over 400 s, quadratic scene
    python benchmarks/core_speed.py --quick    # 60 s horizons
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from iceimpact import Scene, run  # noqa: E402
from ode_reference import simulate as ode_simulate  # noqa: E402

SCENES = {
    "figure2_linear": Scene(),
    "quadratic_drag": Scene(drag_model=2),
}


def _best_of(fn, repeat):
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def measure(name: str, scene: Scene, t_end: float, repeat: int) -> dict:
    # The baseline cannot model sticking: both solvers are timed over the impacts it reaches.
    t_base, base = _best_of(lambda: ode_simulate(scene, t_end, rtol=1e-10, atol=1e-13), repeat)
    n_base = len(base["t"])
    horizon = float(base["t"][-1]) if n_base else t_end
    t_exact, res = _best_of(lambda: run(scene, horizon + 1e-9, dt=horizon), repeat)
    exact_t = res.impacts["t"]
    n = min(n_base, len(exact_t))
    # accuracy on the first impacts, against a tight integration
    n_acc = min(10, n)
    tight = ode_simulate(scene, t_end, max_impacts=n_acc, rtol=1e-13, atol=1e-16)["t"]
    err_exact = float(np.max(np.abs(exact_t[:n_acc] - tight))) if n_acc else float("nan")
    err_base = float(np.max(np.abs(base["t"][:n_acc] - tight))) if n_acc else float("nan")
    return {
        "scene": name, "horizon_s": horizon, "impacts_exact": int(len(exact_t)),
        "impacts_baseline": n_base, "impacts_compared": n,
        "wall_exact_s": t_exact, "wall_baseline_s": t_base,
        "impacts_per_s_exact": len(exact_t) / t_exact, "impacts_per_s_baseline": n_base / t_base,
        "speedup": t_base / t_exact,
        "first10_err_exact_s": err_exact, "first10_err_baseline_s": err_base,
        "baseline_rhs_evaluations": int(base["nfev"]),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="60 s horizons, one repeat")
    parser.add_argument("--t-end", type=float, default=400.0, help="horizon, s")
    parser.add_argument("--repeat", type=int, default=3, help="best of N timings")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "core_speed.json"))
    args = parser.parse_args(argv)
    t_end = 60.0 if args.quick else args.t_end
    repeat = 1 if args.quick else args.repeat
    rows = [measure(name, scene, t_end, repeat) for name, scene in SCENES.items()]

    head = (f"{'scene':16} {'horizon s':>9} {'impacts':>8} {'exact s':>9} {'baseline s':>10} "
            f"{'speedup':>8} {'exact imp/s':>11} {'base imp/s':>10} {'err exact':>9} "
            f"{'err base':>9}")
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['scene']:16} {r['horizon_s']:9.1f} {r['impacts_compared']:8d} "
              f"{r['wall_exact_s']:9.4f} {r['wall_baseline_s']:10.3f} {r['speedup']:7.1f}x "
              f"{r['impacts_per_s_exact']:11.0f} {r['impacts_per_s_baseline']:10.0f} "
              f"{r['first10_err_exact_s']:9.1e} {r['first10_err_baseline_s']:9.1e}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": platform.platform(), "python": platform.python_version(),
                               "t_end": t_end, "repeat": repeat, "rows": rows}, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
