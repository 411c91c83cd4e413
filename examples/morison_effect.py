"""How much the Morison loads on the structure change the article's Figure 2 and Figure 13 scenes.

The structure is taken as a vertical leg of diameter d = 1 m with 1 m of draft in the current
(the SDOF structure of the article, m = 1600 kg, k = 1 MN/m, stands for such a leg):

- added mass: Ca = 1 (a circular cylinder), V = pi d^2 / 4 x draft = 0.785 m^3, so
  m_a = rho Ca V = 785 kg (the natural frequency falls from 25.0 to 20.5 rad/s);
- drag: Cd = 1, A = d x draft = 1 m^2 (the ice's own drag area in Figure 2).

Each scene runs four ways (terms off, added mass only, drag only, both) with the exact method for
the article's 400 s, and the script prints a Markdown table and plots the envelope of each
variant's displacement (max |x| per second). The table gives the peak displacement, the impact
count, the "strong" impacts (impulse >= 1 N.s: the impacts of the floe's returns, not the chatter
of a floe pressed on the structure, whose many tiny impacts would swamp a mean), their mean
impulse and rate, the lock-in ratio omega_n T / (2 pi) of that rate (Section 5: an integer N
means lock-in) and when the bodies start sticking. See docs/morison.md.

    python examples/morison_effect.py                 # 400 s, about a minute
    python examples/morison_effect.py --t-end 40      # shorter
    python examples/morison_effect.py --out docs/img  # where the PNG goes
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from iceimpact import Scene, run  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

DIAMETER, DRAFT = 1.0, 1.0  # m
ADDED_MASS = {"structure.Ca": 1.0, "structure.V": math.pi / 4 * DIAMETER ** 2 * DRAFT}
DRAG = {"structure.Cd": 1.0, "structure.A": DIAMETER * DRAFT}
VARIANTS = (("off", {}), ("added mass", ADDED_MASS), ("drag", DRAG),
            ("both", {**ADDED_MASS, **DRAG}))
SCENES = (("Figure 2 (linearised drag, A = 1 m^2)", {}),
          ("Figure 13 (quadratic drag, A = 2 m^2)", {"drag.model": 2, "ice.A": 2.0}))


STRONG = 1.0  # N.s: an impact at least this strong is a floe's return, not chatter


def measure(scene: Scene, t_end: float, dt: float) -> dict:
    """Peak displacement, impacts, strong impacts (count, mean impulse, rate, lock-in ratio) and
    the start of sticking of one run."""
    res = run(scene, t_end, dt=dt)
    imp = res.impacts
    strong = imp[imp["impulse"] >= STRONG]
    times = strong["t"]
    rate = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 2 else math.nan
    return {"t": res.t, "x": res.x, "peak_x": float(np.max(np.abs(res.x))),
            "impacts": len(imp), "strong": len(strong),
            "mean_impulse": float(np.mean(strong["impulse"])) if len(strong) else math.nan,
            "rate": rate, "omega_n": scene.omega_n,
            "ratio": scene.omega_n / (2.0 * math.pi * rate) if rate == rate else math.nan,
            "sticking_since": res.sticking_since}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=400.0, help="simulated time, s")
    parser.add_argument("--dt", type=float, default=1e-2, help="sample step, s")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "img")
    args = parser.parse_args()

    print("| scene | Morison terms | omega_n (rad/s) | peak x (mm) | impacts | strong impacts | "
          "their mean impulse (N.s) | their rate (1/s) | omega_n T / 2 pi | sticking from (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    fig, axes = plt.subplots(len(SCENES), 1, figsize=(10, 7), sharex=True)
    for ax, (title, changes) in zip(axes, SCENES, strict=True):
        for label, terms in VARIANTS:
            scene = Scene().replace_fmi({**changes, **terms})
            m = measure(scene, args.t_end, args.dt)
            since = m["sticking_since"]
            print(f"| {title} | {label} | {m['omega_n']:.2f} | {1e3 * m['peak_x']:.3f} | "
                  f"{m['impacts']} | {m['strong']} | {m['mean_impulse']:.2f} | {m['rate']:.3g} | "
                  f"{m['ratio']:.3g} | {'-' if since is None else f'{since:.1f}'} |", flush=True)
            per_second = max(1, round(1.0 / args.dt))
            n = len(m["x"]) // per_second * per_second
            envelope = np.abs(m["x"][1:n + 1]).reshape(-1, per_second).max(axis=1)
            ax.plot(m["t"][per_second:n + 1:per_second], 1e3 * envelope, lw=1.0, label=label)
        ax.set_title(title)
        ax.set_ylabel("max |x| per second (mm)")
        ax.set_yscale("log")
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.suptitle("Morison loads on the structure: d = 1 m leg, 1 m draft "
                 "(Ca = 1, V = 0.785 m^3; Cd = 1, A = 1 m^2)")
    fig.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "morison_effect.png"
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
