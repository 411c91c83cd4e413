"""The modal structure's cost per impact against the SDOF's, on the article's Figure 2 scene.

    python benchmarks/modal_speed.py [--t-end 400] [--rounds 3] [--out benchmarks/results]

Runs ``run(scene, t_end, dt=1e-2)`` in this process (after one untimed run of each, so that no
kernel is compiled or loaded while timed) for the SDOF structure of Figure 2, the same structure
as one mode (``structure.model = 3``), and with a second mode added (11 Hz, 2 % damping, modal
mass 1600 kg, phi = 0.6), in interleaved rounds (the best CPU time of each kept), and prints the
CPU time per impact and per simulated second and the ratio to the SDOF's. Writes
``modal_speed.json`` and ``modal_speed.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from tree import ROOT

from iceimpact import Scene, run

SCENES = {
    "SDOF (structure.model = 1)": {},
    "one mode (structure.model = 3)": {"structure_model": 3},
    "two modes (second: 11 Hz, 2 %, phi 0.6)": {
        "structure_model": 3, "structure_modes": 2, "structure_mode2_f": 11.0,
        "structure_mode2_zeta": 0.02, "structure_mode2_phi": 0.6},
}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=400.0, help="simulated seconds")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds, best kept")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)
    scenes = {name: Scene(**kw) for name, kw in SCENES.items()}
    best = {name: float("inf") for name in scenes}
    impacts = {}
    for scene in scenes.values():
        run(scene, 1.0)  # (kernels compiled or loaded, not timed)
    for _ in range(args.rounds):
        for name, scene in scenes.items():
            start = time.process_time()
            result = run(scene, args.t_end)
            best[name] = min(best[name], time.process_time() - start)
            impacts[name] = len(result.impacts)
    sdof = best[next(iter(scenes))] / impacts[next(iter(scenes))]
    rows = []
    lines = ["| structure | impacts | CPU (s) | per impact (us) | per simulated s (ms) | "
             "per impact / SDOF's |", "|---|---:|---:|---:|---:|---:|"]
    for name in scenes:
        per_impact = best[name] / impacts[name]
        rows.append({"structure": name, "impacts": impacts[name], "cpu": best[name],
                     "per_impact": per_impact, "per_second": best[name] / args.t_end,
                     "ratio": per_impact / sdof})
        line = (f"| {name} | {impacts[name]} | {best[name]:.3f} | {per_impact * 1e6:.1f} | "
                f"{best[name] / args.t_end * 1e3:.2f} | {per_impact / sdof:.0f}x |")
        lines.append(line)
        print(line, flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "modal_speed.json").write_text(json.dumps(
        {"benchmark": "modal_speed", "command": "python benchmarks/modal_speed.py "
         f"--t-end {args.t_end:g} --rounds {args.rounds}", "t_end": args.t_end, "rows": rows},
        indent=1) + "\n")
    (args.out / "modal_speed.md").write_text(
        f"Figure 2's scene, `run(scene, {args.t_end:g}, dt=1e-2)`, CPU time, best of "
        f"{args.rounds} interleaved rounds in one process (kernels loaded before).\n\n"
        + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
