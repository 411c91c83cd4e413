"""Work-precision of the ice as a co-simulation component: which communication step for which
accuracy.

    python benchmarks/coupling.py [--quick] [--out benchmarks/results]

IceImpact in external-structure mode (``structure.model = 2``, :class:`iceimpact.Simulator`)
coupled by the independent Gauss-Seidel master of ``tests/coupling_master.py`` (ice first) to its
exact SDOF structure equal to IceImpact's built-in one, against IceImpact's own monolithic run
(``structure.model = 1``) sampled at the same communication points. Orders: 1 = the master
passes ``x``, ``v`` only (``a_in = 0``: IceImpact estimates the structure's acceleration from
the change of ``v_in``), 2 = it also passes ``a`` (``structure.a_in``).

Per scene, order and communication step h:

- **peak x error**: ``|max |x_c| - max |x_m|| / max |x_m|``;
- **x error**: ``max |x_c - x_m| / max |x_m|`` over the run (phase errors included);
- **impulse/s error**: relative error of the mean impulse per second delivered to the structure;
- **impacts**: coupled / monolithic counts;
- **wall**: seconds for the coupled run (one process; the machine matters, ratios less).

Writes ``coupling.json`` and ``coupling.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "fmu_src"))

from coupling_master import ExactSdof, gauss_seidel  # noqa: E402
from iceimpact import Scene  # noqa: E402
from iceimpact.simulator import Simulator, run  # noqa: E402

SCENES = {
    "impacting (M = 1200 kg, e = 0.7)": {"drag_model": 2, "flow_u": 0.3, "ice_M": 1200.0,
                                         "impact_e": 0.7},
    "heavy, sticks (M = 4800 kg, e = 0.3)": {"drag_model": 2, "flow_u": 0.3, "ice_M": 4800.0,
                                             "impact_e": 0.3},
}
T_END = 6.0


class Ice:
    def __init__(self, scene: Scene):
        self.sim = Simulator(scene.replace(structure_model=2), record_impacts=False)

    def step(self, t, h, x_in, v_in, a_in):
        return self.sim.advance(h, structure=(x_in, v_in, a_in)).impulse


def measure(scene: Scene, h: float, order: int, t_end: float) -> dict:
    mono = run(scene, t_end, dt=h)
    ice = Ice(scene)
    start = time.perf_counter()
    coupled = gauss_seidel(ice, ExactSdof(scene.structure_m, scene.structure_c,
                                          scene.structure_k), t_end, h,
                           second_order=order == 2)
    wall = time.perf_counter() - start
    n = min(len(coupled.x), len(mono.x))
    peak_m = np.max(np.abs(mono.x[:n]))
    impulse_m = float(np.sum(mono.impulse)) / t_end
    impulse_c = float(np.sum(coupled.impulse)) / t_end
    return {"h": h, "order": order,
            "peak_error": float(abs(np.max(np.abs(coupled.x[:n])) - peak_m) / peak_m),
            "x_error": float(np.max(np.abs(coupled.x[:n] - mono.x[:n])) / peak_m),
            "impulse_error": abs(impulse_c - impulse_m) / abs(impulse_m),
            "impacts": ice.sim.impact_count, "impacts_mono": len(mono.impacts), "wall": wall}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="h = 1 ms and 0.1 ms only")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)
    steps = (1e-3, 1e-4) if args.quick else (1e-3, 3e-4, 1e-4, 3e-5)
    rows = []
    lines = ["| scene | order | h (s) | peak x error | x error | impulse/s error | impacts "
             "(coupled / mono) | wall (s) |", "|---|---|---|---|---|---|---|---|"]
    for name, values in SCENES.items():
        scene = Scene(**values)
        for order in (1, 2):
            for h in steps:
                row = {"scene": name, **measure(scene, h, order, T_END)}
                rows.append(row)
                line = (f"| {name} | {order} | {h:g} | {row['peak_error']:.2%} | "
                        f"{row['x_error']:.2%} | {row['impulse_error']:.2%} | "
                        f"{row['impacts']} / {row['impacts_mono']} | {row['wall']:.2f} |")
                lines.append(line)
                print(line, flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "coupling.json").write_text(json.dumps({"t_end": T_END, "rows": rows},
                                                       indent=1) + "\n")
    (args.out / "coupling.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
