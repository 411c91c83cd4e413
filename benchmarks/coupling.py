"""Work-precision of the ice as a co-simulation component: which communication step for which
accuracy, with which master.

    python build_fmu.py
    python benchmarks/coupling.py [--quick] [--fmus dist] [--no-fmu] [--out benchmarks/results]

Two scenes (quadratic drag, u = 0.3 m/s, 6 s): an impacting floe (M = 1200 kg, e = 0.7) and a
heavy floe that sticks and separates (M = 4800 kg, e = 0.3), on a structure equal to IceImpact's
built-in one (m = 1600 kg, c = 200 N.s/m, k = 1e6 N/m). Reference: IceImpact's own monolithic run
(``structure.model = 1``) sampled at the same communication points.

Masters:

- **core GS**, **core Jacobi**: :class:`iceimpact.Simulator` in external-structure mode coupled
  by the independent masters of ``tests/coupling_master.py`` (``gauss_seidel``, ``jacobi``) to
  their exact SDOF (matrix exponential): the coupling error alone, no FMI;
- **FMPy GS**: both FMUs (IceImpact.fmu, ModalStructure.fmu with its default mode, equal to the
  built-in structure) in the scripted FMPy Gauss-Seidel loop of ``examples/system/system.py``
  (``coupling.scheme = 1``);
- **ecospy**: the SSP of ``examples/system/`` run by ECOS (Jacobi, ``coupling.scheme = 2``);
- **libcosimpy**: the same system in libcosim (Jacobi, ``coupling.scheme = 2``).

Orders: 1 = the structure's acceleration is not passed (``structure.a_in = 0``: IceImpact
estimates the structure's own force from the change of ``v_in``), 2 = it is (``a ->
structure.a_in``).

Per row:

- **peak x error**: ``|max |x_c| - max |x_m|| / max |x_m|``;
- **x error**: ``max |x_c - x_m| / max |x_m|`` over the run (phase errors included);
- **impulse/s error**: relative error of the mean impulse per second delivered to the structure;
- **impacts**: coupled / monolithic counts (the latter with the monolithic run's Zeno sequences
  closed at the chatter time, as against an external structure: :func:`impacts_as_external`);
- **wall**: seconds for the coupled run in this process (the FMU masters include the FMUs'
  instantiation; compare rows of one run, not across machines).

Writes ``coupling.json`` and ``coupling.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from tree import ROOT, load

from iceimpact import Scene
from iceimpact.simulator import Simulator, run

system = load("examples/system/system.py")
coupling_master = load("tests/coupling_master.py")
ExactSdof, gauss_seidel, jacobi = (coupling_master.ExactSdof, coupling_master.gauss_seidel,
                                   coupling_master.jacobi)

SCENES = {
    "impacting (M = 1200 kg, e = 0.7)": {"drag_model": 2, "flow_u": 0.3, "ice_M": 1200.0,
                                         "impact_e": 0.7},
    "heavy, sticks (M = 4800 kg, e = 0.3)": {"drag_model": 2, "flow_u": 0.3, "ice_M": 4800.0,
                                             "impact_e": 0.3},
}
T_END = 6.0
GAUSS_SEIDEL, JACOBI = 1, 2


class Ice:
    def __init__(self, scene: Scene, scheme: int):
        self.sim = Simulator(scene.replace(structure_model=2, coupling_scheme=scheme),
                             record_impacts=False)
        self.impulse = 0.0  # the contact impulses, N.s

    def step(self, t, h, x_in, v_in, a_in):
        self.impulse += (report := self.sim.advance(h, structure=(x_in, v_in, a_in))).impulse
        return report.coupling_force * h


def core_run(scene: Scene, h: float, order: int, scheme: int) -> dict:
    ice = Ice(scene, scheme)
    loop = gauss_seidel if scheme == GAUSS_SEIDEL else jacobi
    coupled = loop(ice, ExactSdof(scene.structure_m, scene.structure_c, scene.structure_k),
                   T_END, h, second_order=order == 2)
    return {"x": coupled.x, "impulse": ice.impulse, "count": ice.sim.impact_count}


def ice_values(scene: Scene) -> dict:
    """The FMU parameters of a scene in external-structure mode (examples/system's ICE)."""
    return {"structure.model": 2, "drag.model": scene.drag_model, "ice.M": scene.ice_M,
            "impact.e": scene.impact_e, "structure.m": scene.structure_m}


def fmu_run(master: str, fmus: Path, scene: Scene, h: float, order: int, tmp: Path) -> dict:
    ice, second = ice_values(scene), order == 2
    if master == "FMPy GS":
        result = system.fmpy_master(fmus, T_END, h, "gauss-seidel", ice=ice,
                                    flow_u=scene.flow_u, second_order=second)
    elif master == "ecospy":
        ssp = system.write_ssp(fmus, tmp / "IceOnStructure.ssp", ice=ice, flow_u=scene.flow_u,
                               second_order=second)
        result = system.ecospy_run(ssp, T_END, h)
    else:
        result = system.libcosimpy_run(fmus, T_END, h, ice=ice, flow_u=scene.flow_u,
                                       second_order=second)
    # the force a step returned times the step: the impulse IceImpact delivered
    return {"x": result["x"], "impulse": float(np.sum(result["force"][1:]) * h),
            "count": result["count"]}


def impacts_as_external(scene: Scene, h: float) -> np.ndarray:
    """The impact times of the monolithic run with its Zeno sequences closed at the chatter time,
    as IceImpact closes them against an external structure (``ExternalSolver.FOLLOW_ZENO``):
    the impacts a coupled run can meet. The monolithic run itself follows each sequence to its
    end, bounces of nanoseconds that no coupled structure resolves."""
    sim = Simulator(scene)
    sim.solver.rules.follow_zeno = False
    for k in range(round(T_END / h)):
        sim.advance_to((k + 1) * h)
    return np.array([impact.t for impact in sim.impacts])


def measure(coupled: dict, mono, wall: float) -> dict:
    n = min(len(coupled["x"]), len(mono.x))
    x_c, x_m = coupled["x"][:n], mono.x[:n]
    peak_m = np.max(np.abs(x_m))
    impulse_m = float(np.sum(mono.impulse))
    return {"peak_error": float(abs(np.max(np.abs(x_c)) - peak_m) / peak_m),
            "x_error": float(np.max(np.abs(x_c - x_m)) / peak_m),
            "impulse_error": abs(coupled["impulse"] - impulse_m) / abs(impulse_m),
            "impacts": int(coupled["count"]), "impacts_mono": len(mono.impacts), "wall": wall}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="h = 1 ms and 0.1 ms only")
    parser.add_argument("--fmus", type=Path, default=ROOT / "dist",
                        help="folder with IceImpact.fmu and ModalStructure.fmu")
    parser.add_argument("--no-fmu", action="store_true", help="the core masters only")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)
    core_steps = (1e-3, 1e-4) if args.quick else (1e-3, 3e-4, 1e-4, 3e-5)
    fmu_steps = (1e-3, 1e-4)
    masters = [("core GS", core_steps), ("core Jacobi", core_steps)]
    if not args.no_fmu:
        masters += [("FMPy GS", fmu_steps), ("ecospy", fmu_steps), ("libcosimpy", fmu_steps)]
    rows = []
    lines = ["| scene | master | order | h (s) | peak x error | x error | impulse/s error | "
             "impacts (coupled / mono) | wall (s) |", "|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for name, values in SCENES.items():
            scene = Scene(**values)
            monos = {}
            resolved = {}  # h -> the monolithic impacts a coupled run can meet
            for master, steps in masters:
                for order in (1, 2):
                    for h in steps:
                        mono = monos.get(h) or monos.setdefault(h, run(scene, T_END, dt=h))
                        if h not in resolved:
                            resolved[h] = len(impacts_as_external(scene, h))
                        start = time.perf_counter()
                        if master.startswith("core"):
                            scheme = GAUSS_SEIDEL if master == "core GS" else JACOBI
                            coupled = core_run(scene, h, order, scheme)
                        else:
                            coupled = fmu_run(master, args.fmus, scene, h, order, Path(tmp))
                        row = {"scene": name, "master": master, "order": order, "h": h,
                               **measure(coupled, mono, time.perf_counter() - start),
                               "impacts_mono": resolved[h]}
                        rows.append(row)
                        line = (f"| {name} | {master} | {order} | {h:g} | "
                                f"{row['peak_error']:.2%} | {row['x_error']:.2%} | "
                                f"{row['impulse_error']:.2%} | {row['impacts']} / "
                                f"{row['impacts_mono']} | {row['wall']:.2f} |")
                        lines.append(line)
                        print(line, flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "coupling.json").write_text(json.dumps({"t_end": T_END, "rows": rows},
                                                       indent=1) + "\n")
    (args.out / "coupling.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
