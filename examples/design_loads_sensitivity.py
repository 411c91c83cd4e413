"""How wrong is the design number when the impacts are not exact? DELs by solver and step.

The same load case run with the exact event-driven solver (method 1) and with the article's
fixed-step scheme (method 2) at the steps a user would pick, 1e-2 to 1e-5 s, with the article's
impact test (the tolerance window of eq. 26, detection 1) and with the sign change of the gap
(detection 2). For each run: the impacts, the extreme base shear ``max k x`` and the 1 Hz
damage-equivalent loads of ``k x`` (:mod:`iceimpact.studies.loads`), and their relative errors
against the exact run. Two load cases:

- ``figure2``: the article's Figure 2 scene (linearised drag, e = 1);
- ``quadratic_A2``: quadratic drag, A = 2 m^2, u = 0.1 m/s (the article's lock-in case).

All runs are sampled at the same interval (the trajectories do not depend on it), so the
differences are the solvers'. Both responses are chaotic (a 1e-9 relative change of the initial
ice velocity changes the impact sequence after a few dozen impacts), so the DEL of one finite run
has a spread of its own: the exact solver is also run with the initial ice velocity changed by
+-1e-9, 1e-8, 1e-7 and 1e-6 (relative), and the table gives the range of those runs' deviations, the
noise floor below which a solver's error cannot be told from chance.

    python examples/design_loads_sensitivity.py              # 100 s runs, ~1 min on one core
    python examples/design_loads_sensitivity.py --t-end 20   # shorter

Writes ``out/design_loads_sensitivity.json`` and ``.md`` (the table of docs/design_loads.md).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from iceimpact import Scene, SolverError, run
from iceimpact.scene import (
    DETECTION_SIGN,
    DETECTION_WINDOW,
    METHOD_EXACT,
    METHOD_FIXED_STEP,
    QUADRATIC_DRAG,
)
from iceimpact.studies.analysis import summarize

ROOT = Path(__file__).resolve().parents[1]
CASES = {
    "figure2": ("Figure 2 (linear drag, e = 1)", Scene()),
    "quadratic_A2": ("quadratic drag, A = 2 m2, u = 0.1 m/s",
                     Scene(drag_model=QUADRATIC_DRAG, ice_A=2.0)),
}
STEPS = (1e-2, 1e-3, 1e-4, 1e-5)
DETECTIONS = {DETECTION_WINDOW: "window (eq. 26)", DETECTION_SIGN: "sign of the gap"}
EXPONENTS = (3, 4, 5, 10)
PERTURBATIONS = (1e-9, -1e-9, 1e-8, -1e-8, 1e-7, -1e-7, 1e-6, -1e-6)  # of ice.v0, relative
SAMPLE_DT = 1e-3  # s


def measure(scene: Scene, t_end: float, transient: float) -> dict:
    t0 = time.perf_counter()
    try:
        result = run(scene, t_end, dt=SAMPLE_DT)
    except SolverError as exc:
        return {"status": str(exc), "wall_s": time.perf_counter() - t0}
    wall = time.perf_counter() - t0
    s = summarize(result, transient)
    keep = ["n_impacts", "kx_max_N", "kx_min_N", "contact_force_max_N", "p99_impulse_ns",
            *(f"del_m{m}_1Hz_N" for m in EXPONENTS)]
    return {"status": "ok", "wall_s": wall, **{k: s[k] for k in keep}}


def relative(value: float, exact: float) -> float:
    return (value - exact) / exact if exact != 0.0 and math.isfinite(value) else math.nan


KEYS = ("kx_max_N", *(f"del_m{m}_1Hz_N" for m in EXPONENTS))


def spread_row(case: str, exact: dict, perturbed: list[dict]) -> str:
    """The table row of the perturbed exact runs: the range of their relative deviations."""
    cells = []
    for key in KEYS:
        dev = [100 * relative(r[key], exact[key]) for r in perturbed]
        cells.append(f"{min(dev):+.1f} to {max(dev):+.1f} %")
    impacts = [int(r["n_impacts"]) for r in perturbed]
    wall = max(r["wall_s"] for r in perturbed)
    return (f"| {case} | exact, ice.v0 x (1 +- 1e-9..1e-6) | - | {wall:.2f} | {min(impacts)}"
            f"-{max(impacts)} | " + " | ".join(cells) + " |")


def markdown(results: dict, t_end: float, transient: float) -> str:
    lines = [f"Runs of {t_end:g} s, loads over t >= {transient:g} s, sampled every "
             f"{SAMPLE_DT:g} s. Relative errors against the exact solver in %; wall: run time "
             f"of the simulation (one core); 1 Hz DELs of k x.", ""]
    head = ("| load case | solver | dt (s) | wall (s) | impacts | max k x (N) | "
            + " | ".join(f"DEL m={m} (N)" for m in EXPONENTS) + " |")
    lines += [head, "|" + "---|" * (6 + len(EXPONENTS))]
    for case, entry in results.items():
        exact = entry["runs"]["exact"]
        lines.append(f"| {case} | exact | - | {exact['wall_s']:.2f} | {exact['n_impacts']:.0f} | "
                     + " | ".join(f"{exact[k]:.4g}" for k in KEYS) + " |")
        lines.append(spread_row(case, exact, entry["perturbed"]))
        for label, r in entry["runs"].items():
            if label == "exact":
                continue
            if r["status"] != "ok":
                lines.append(f"| {case} | {label} | | {r['wall_s']:.2f} | failed: "
                             f"{r['status'][:60]} |" + " |" * (1 + len(EXPONENTS)))
                continue

            def cell(key: str, r: dict = r, exact: dict = exact) -> str:
                return f"{r[key]:.4g} ({100 * relative(r[key], exact[key]):+.1f} %)"

            solver, _, dt = label.partition(" dt=")
            lines.append(f"| {case} | {solver} | {dt or '-'} | {r['wall_s']:.2f} | "
                         f"{r['n_impacts']:.0f} | {cell('kx_max_N')} | "
                         + " | ".join(cell(f"del_m{m}_1Hz_N") for m in EXPONENTS) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=100.0, help="s (default 100)")
    parser.add_argument("--transient", type=float, default=10.0, help="s (default 10)")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "out")
    args = parser.parse_args()

    results = {}
    for case, (title, scene) in CASES.items():
        exact = scene.replace(solver_method=METHOD_EXACT)
        runs = {"exact": measure(exact, args.t_end, args.transient)}
        perturbed = [measure(exact.replace(ice_v0=exact.ice_v0 * (1.0 + eps)), args.t_end,
                             args.transient) for eps in PERTURBATIONS]
        for detection, dname in DETECTIONS.items():
            for dt in STEPS:
                label = f"fixed-step, {dname} dt={dt:g}"
                runs[label] = measure(scene.replace(solver_method=METHOD_FIXED_STEP,
                                                    solver_dt=dt, solver_detection=detection),
                                      args.t_end, args.transient)
                print(f"{case:>13} {label:<40} {runs[label]['wall_s']:7.2f} s wall", flush=True)
        results[case] = {"title": title, "scene": scene.to_fmi(), "runs": runs,
                         "perturbed": perturbed, "perturbations": list(PERTURBATIONS)}
    args.out_dir.mkdir(parents=True, exist_ok=True)
    settings = {"t_end_s": args.t_end, "transient_s": args.transient, "sample_dt_s": SAMPLE_DT}
    (args.out_dir / "design_loads_sensitivity.json").write_text(
        json.dumps({"settings": settings, "cases": results}, indent=1, allow_nan=True) + "\n")
    table = markdown(results, args.t_end, args.transient)
    (args.out_dir / "design_loads_sensitivity.md").write_text(table)
    print(table)


if __name__ == "__main__":
    main()
