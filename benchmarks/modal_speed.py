"""The modal structure's cost per impact against the SDOF's, on the article's Figure 2 scene.

    python benchmarks/modal_speed.py [--t-end 400] [--rounds 3] [--out benchmarks/results]

Runs ``run(scene, t_end, dt=1e-2)`` in this process (after one untimed run of each, so that no
kernel is compiled or loaded while timed) for the SDOF structure of Figure 2, the same structure
as one mode (``structure.model = 3``), and with a second mode added (11 Hz, 2 % damping, modal
mass 1600 kg, phi = 0.6), in interleaved rounds (the best CPU time of each kept), and prints the
CPU time per impact and per simulated second and the ratio to the SDOF's. The two-mode scene
bounces faster and faster up to about 54 s, then the ice rides on the structure to the end: it
is timed a second time up to ``--bounces`` (54 s), its bouncing phase alone, which the compiled
march of bounces makes; the riding phase's samples are counted (``riding``). Writes
``modal_speed.json`` and ``modal_speed.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from tree import ROOT

from iceimpact import Scene, run

TWO_MODES = {"structure_model": 3, "structure_modes": 2, "structure_mode2_f": 11.0,
             "structure_mode2_zeta": 0.02, "structure_mode2_phi": 0.6}
#: name: (scene fields, whether its run ends at --bounces rather than --t-end)
SCENES = {
    "SDOF (structure.model = 1)": ({}, False),
    "one mode (structure.model = 3)": ({"structure_model": 3}, False),
    "two modes (second: 11 Hz, 2 %, phi 0.6)": (TWO_MODES, False),
    "two modes, its bouncing phase": (TWO_MODES, True),
}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=400.0, help="simulated seconds")
    parser.add_argument("--bounces", type=float, default=54.0,
                        help="the end of the two-mode scene's bouncing phase, s")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds, best kept")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)
    scenes = {name: (Scene(**fields), args.bounces if short else args.t_end)
              for name, (fields, short) in SCENES.items()}
    best = {name: float("inf") for name in scenes}
    impacts, riding = {}, {}
    for scene, _ in scenes.values():
        run(scene, 1.0)  # (kernels compiled or loaded, not timed)
    for _ in range(args.rounds):
        for name, (scene, t_end) in scenes.items():
            start = time.process_time()
            result = run(scene, t_end)
            best[name] = min(best[name], time.process_time() - start)
            impacts[name] = len(result.impacts)
            riding[name] = int(result.sticking.sum())
    first = next(iter(scenes))
    sdof = best[first] / impacts[first]
    rows = []
    lines = ["| structure | simulated (s) | impacts | samples riding | CPU (s) | per impact (us) | "
             "per simulated s (ms) | per impact / SDOF's |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, (_, t_end) in scenes.items():
        per_impact = best[name] / impacts[name]
        rows.append({"structure": name, "t_end": t_end, "impacts": impacts[name],
                     "riding_samples": riding[name], "cpu": best[name],
                     "per_impact": per_impact, "per_second": best[name] / t_end,
                     "ratio": per_impact / sdof})
        line = (f"| {name} | {t_end:g} | {impacts[name]} | {riding[name]} | {best[name]:.3f} | "
                f"{per_impact * 1e6:.2f} | {best[name] / t_end * 1e3:.2f} | "
                f"{per_impact / sdof:.1f}x |")
        lines.append(line)
        print(line, flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "modal_speed.json").write_text(json.dumps(
        {"benchmark": "modal_speed", "command": "python benchmarks/modal_speed.py "
         f"--t-end {args.t_end:g} --bounces {args.bounces:g} --rounds {args.rounds}",
         "t_end": args.t_end, "bounces": args.bounces, "rows": rows}, indent=1) + "\n")
    (args.out / "modal_speed.md").write_text(
        f"Figure 2's scene, `run(scene, t_end, dt=1e-2)`, CPU time, best of {args.rounds} "
        "interleaved rounds in one process (kernels loaded before); samples riding: the "
        "samples (every 10 ms) at which the ice rides on the structure.\n\n"
        + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
