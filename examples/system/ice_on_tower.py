"""Ice striking a three-mode tower: IceImpact.fmu (external structure) coupled to
ModalStructure.fmu through FMPy, compared with IceImpact's built-in SDOF structure.

    python build_fmu.py
    python examples/system/ice_on_tower.py [--fmus dist] [--t-end 20] [--step 2e-4] [--out out]
        [--quick]

The tower is seen at the ice's contact point (the waterline) through three modes: a slender first
bending mode and two higher modes with larger mode-shape values there (see ``TOWER``). IceImpact
needs the mass the tower opposes to an impulse at the contact point, the impulse mass ``1 /
sum(phi_i^2 / m_i)`` (docs/explanation/coupling.md, "The mass IceImpact needs"), and is given the
static stiffness there for its chatter time scale. The masters' loop is the scripted FMPy
Gauss-Seidel master of ``examples/system/system.py`` (ice first, ``coupling.scheme = 1``), passing
``x``, ``v`` and ``a``.

Two SDOF idealisations of the same tower run with the built-in structure (structure.model = 1)
for comparison:

- *first mode*: the first mode alone seen at the contact point (``m_1 / phi_1^2``, its
  frequency and damping), what a design that keeps only the fundamental mode would use;
- *impulse mass*: the impulse mass and the static stiffness at the contact point (the local
  view of the impact, missing the dynamics of the modes).

Writes ``out/ice_on_tower.png`` (displacement of the contact point, contact force, impact times
for the three runs) and ``out/ice_on_tower.json`` (the comparison table it prints).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

import system
from iceimpact.modal import ModalStructure, Mode

ROOT = Path(__file__).resolve().parents[2]

#: The tower at the contact point: (frequency Hz, damping ratio, modal mass kg, mode shape there)
TOWER = [(1.2, 0.01, 2.0e4, 0.35), (6.5, 0.015, 1.5e4, -0.8), (17.0, 0.02, 1.2e4, 0.6)]
#: The floe and the flow (quadratic drag)
ICE = {"drag.model": 2, "ice.M": 8000.0, "ice.A": 2.0, "impact.e": 0.5, "ice.z0": -0.01,
       "ice.v0": 0.3}
FLOW_U = 0.5


def tower() -> ModalStructure:
    return ModalStructure([Mode(f=f, zeta=z, m=m, phi=phi) for f, z, m, phi in TOWER])


def structure_values() -> dict:
    """ModalStructure.fmu's parameters for TOWER."""
    values: dict[str, float] = {"modes": len(TOWER)}
    for i, (f, zeta, m, phi) in enumerate(TOWER, start=1):
        values.update({f"mode{i}.f": f, f"mode{i}.zeta": zeta, f"mode{i}.m": m,
                       f"mode{i}.phi": phi})
    return values


def sdof_values() -> dict[str, dict]:
    """The built-in structure's parameters of the two SDOF idealisations."""
    f, zeta, m, phi = TOWER[0]
    first = Mode(f=f, zeta=zeta, m=m, phi=phi)
    m1 = first.effective_mass
    k1 = m1 * (2.0 * math.pi * f) ** 2
    local = tower()
    m_imp, k_static = local.impulse_mass, local.stiffness
    return {"first mode": {"structure.m": m1, "structure.k": k1,
                           "structure.c": 2.0 * zeta * math.sqrt(k1 * m1)},
            "impulse mass": {"structure.m": m_imp, "structure.k": k_static,
                             "structure.c": 2.0 * zeta * math.sqrt(k_static * m_imp)}}


def summary(result: dict, t_end: float, h: float) -> dict:
    counts = np.asarray(result["counts"])
    struck = np.flatnonzero(np.diff(counts) > 0)  # step k ends at time[k + 1]
    impacts = result["time"][1:][struck]
    first_impulse = float(result["force"][struck[0] + 1] * h) if len(struck) else None
    return {"impacts": int(counts[-1]), "peak x (mm)": float(np.max(np.abs(result["x"])) * 1e3),
            "peak force (kN)": float(np.max(result["force"]) / 1e3),
            "mean force (kN)": float(np.sum(result["force"][1:]) * h / t_end / 1e3),
            "first impact (s)": float(impacts[0]) if len(impacts) else None,
            "1st step impulse (N.s)": first_impulse}


def plot(runs: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for (name, result), color in zip(runs.items(), ("C0", "C1", "C2"), strict=False):
        t = result["time"]
        axes[0].plot(t, result["x"] * 1e3, color=color, lw=0.8, label=name)
        axes[1].plot(t, result["force"] / 1e3, color=color, lw=0.8, label=name)
        counts = np.asarray(result["counts"])
        hits = t[1:][np.diff(counts) > 0]
        axes[2].plot(hits, np.full(len(hits), list(runs).index(name)), "|", color=color,
                     markersize=12)
    axes[0].set_ylabel("contact point x (mm)")
    axes[1].set_ylabel("contact force (kN)\n(mean over each step)")
    axes[2].set_yticks(range(len(runs)), list(runs))
    axes[2].set_ylabel("impacts")
    axes[2].set_xlabel("time (s)")
    axes[0].legend(loc="upper right", fontsize=8)
    fig.suptitle("Ice floe on a three-mode tower (ModalStructure.fmu + IceImpact.fmu, FMPy) "
                 "and two SDOF idealisations")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmus", type=Path, default=ROOT / "dist")
    parser.add_argument("--t-end", type=float, default=20.0)
    parser.add_argument("--step", type=float, default=2e-4, help="communication step (s)")
    parser.add_argument("--out", type=Path, default=Path("out"))
    parser.add_argument("--quick", action="store_true", help="4 s at 1 ms (a test's run)")
    args = parser.parse_args(argv)
    t_end, h = (4.0, 1e-3) if args.quick else (args.t_end, args.step)
    local = tower()
    ice = {**ICE, "structure.model": 2, "structure.m": local.impulse_mass,
           "structure.k": local.stiffness}
    runs = {"3-mode tower": system.fmpy_master(args.fmus, t_end, h, "gauss-seidel", ice=ice,
                                                structure=structure_values(), flow_u=FLOW_U)}
    for name, values in sdof_values().items():
        runs[f"SDOF, {name}"] = system.monolithic(args.fmus, t_end, h, ice={**ICE, **values},
                                                  flow_u=FLOW_U)
    table = {name: summary(result, t_end, h) for name, result in runs.items()}
    print(f"impulse mass at the contact point {local.impulse_mass:.0f} kg, static stiffness "
          f"{local.stiffness:.3g} N/m; {t_end:g} s at h = {h:g} s")
    columns = list(next(iter(table.values())))
    print(f"{'run':26s}" + "".join(f"{c:>23s}" for c in columns))
    for name, row in table.items():
        cells = "".join(f"{'-' if v is None else format(v, '.4g'):>23s}" for v in row.values())
        print(f"{name:26s}{cells}")
    args.out.mkdir(parents=True, exist_ok=True)
    plot(runs, args.out / "ice_on_tower.png")
    (args.out / "ice_on_tower.json").write_text(json.dumps(
        {"t_end": t_end, "step": h, "quick": args.quick, "tower": TOWER,
         "impulse_mass": local.impulse_mass, "stiffness": local.stiffness, "runs": table},
        indent=1) + "\n")
    return table


if __name__ == "__main__":
    main()
