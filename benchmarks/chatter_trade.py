"""The trade of the chatter threshold ``solver.chatter_fraction``: cost against design numbers.

With e = 1 the exact model bounces for ever once the flow presses the ice on the structure, its
bounces ever shorter; a bounce shorter than the chatter time (``solver.chatter_fraction`` of
the structure's natural period) ends them with one plastic impact (solvers/contact_rules.py).
A smaller fraction resolves more of the chatter at more impacts. For each scene and fraction
this runs ``iceimpact.run(scene, t_end, dt)`` (method 1) and reports the cost (impacts, CPU time
of the run, best of ``--rounds``) and the design numbers of the spring force k x over the whole
run (iceimpact.studies.loads: RMS, peak |k x|, damage-equivalent loads at 1 Hz for the Woehler
exponents 3, 4, 5 and 10), each also as its change from the smallest fraction's, the most
resolved run. Writes ``benchmarks/results/chatter_trade.json`` and ``.md``.

    python benchmarks/chatter_trade.py                       # 400 s, 4 fractions (~1 min)
    python benchmarks/chatter_trade.py --t-end 100 --fractions 1e-1 1e-2
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from iceimpact import Scene, run
from iceimpact.studies.loads import WOHLER_EXPONENTS, run_loads

RESULTS = Path(__file__).resolve().parent / "results"

#: name: (Scene fields, what it is); both e = 1, the elastic impacts that chatter
SCENES: dict[str, tuple[dict, str]] = {
    "figure2": ({}, "Figure 2: linear drag, e = 1 (Scene() defaults)"),
    "figure13": ({"drag_model": 2, "ice_A": 2.0},
                 "Figure 13: quadratic drag, ice.A = 2 m2, e = 1"),
}


def measure(fields: dict, fraction: float, t_end: float, dt: float, rounds: int) -> dict:
    """One scene at one chatter fraction: cost and design numbers."""
    scene = Scene(**fields, solver_chatter_fraction=fraction)
    cpu = math.inf
    for _ in range(rounds):
        begun = time.process_time()
        result = run(scene, t_end, dt=dt)
        cpu = min(cpu, time.process_time() - begun)
    loads = run_loads(result)
    kx = scene.structure_k * result.x
    return {"fraction": fraction, "impacts": int(len(result.impacts)), "cpu_s": cpu,
            "sticking_since_s": result.sticking_since,
            "kx_rms_N": float(np.sqrt(np.mean(kx * kx))),
            "kx_peak_N": float(np.max(np.abs(kx))),
            "del_1hz_N": {str(m): loads.del_1hz[m] for m in WOHLER_EXPONENTS}}


def _change(value: float, reference: float) -> str:
    return f"{(value - reference) / reference:+.1e}"


def markdown(rows: dict[str, list[dict]], t_end: float, dt: float) -> str:
    lines = [f"`run(scene, {t_end:g} s, dt={dt:g})`, method 1, e = 1; CPU time of the run. "
             "In brackets: the relative change from the smallest fraction's run (the most resolved "
             "chatter).", ""]
    dels = " | ".join(f"DEL m={m} (1 Hz)" for m in WOHLER_EXPONENTS)
    lines += [f"| scene | chatter_fraction | impacts | CPU | sticks from | RMS k x | "
              f"peak abs(k x) | {dels} |",
              "|---|---:|---:|---:|---:|---:|---:|" + "---:|" * len(WOHLER_EXPONENTS)]
    def cell(value: float, reference: float) -> str:
        return f"{value:.4g} N ({_change(value, reference)})"

    for name, runs in rows.items():
        ref = runs[-1]
        for r in runs:
            since = "-" if r["sticking_since_s"] is None else f"{r['sticking_since_s']:.1f} s"
            cells = [cell(r["del_1hz_N"][str(m)], ref["del_1hz_N"][str(m)])
                     for m in WOHLER_EXPONENTS]
            lines.append(f"| {name} | {r['fraction']:g} | {r['impacts']} | {r['cpu_s']:.3f} s | "
                         f"{since} | {cell(r['kx_rms_N'], ref['kx_rms_N'])} | "
                         f"{cell(r['kx_peak_N'], ref['kx_peak_N'])} | " + " | ".join(cells)
                         + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=400.0, help="run length, s")
    parser.add_argument("--dt", type=float, default=1e-3, help="sampling step, s")
    parser.add_argument("--fractions", type=float, nargs="+", default=[1e-1, 1e-2, 1e-3, 1e-4],
                        help="chatter fractions, decreasing (the last is the reference)")
    parser.add_argument("--scenes", nargs="+", choices=list(SCENES), default=list(SCENES))
    parser.add_argument("--rounds", type=int, default=1, help="timed runs each, best kept")
    parser.add_argument("--out", type=Path, default=RESULTS / "chatter_trade.json")
    args = parser.parse_args(argv)
    rows: dict[str, list[dict]] = {}
    for name in args.scenes:
        rows[name] = []
        for fraction in args.fractions:
            row = measure(SCENES[name][0], fraction, args.t_end, args.dt, args.rounds)
            rows[name].append(row)
            print(f"{name:10} {fraction:8g} {row['impacts']:8d} impacts {row['cpu_s']:8.3f} s",
                  flush=True)
    text = markdown(rows, args.t_end, args.dt)
    print(text)
    report = {"benchmark": "chatter_trade",
              "date": datetime.now(UTC).isoformat(timespec="seconds"),
              "command": "python benchmarks/chatter_trade.py " + " ".join(argv or sys.argv[1:]),
              "machine": platform.platform(), "python": platform.python_version(),
              "t_end_s": args.t_end, "dt_s": args.dt,
              "scenes": {name: SCENES[name][1] for name in args.scenes}, "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    args.out.with_suffix(".md").write_text(text)
    print(f"wrote {args.out} and {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
